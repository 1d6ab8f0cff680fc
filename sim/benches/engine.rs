//! Speed of the simulation engine with the smaller devices (the complete controller's reference
//! workload is `cansim bench`): a lower tester sends 8-byte frames at 500 kbit/s (16 MHz clocks) to 1
//! or 4 bit-timing nodes, with and without VCD tracing, counted in node clock cycles per second (the
//! lower tester's are not counted), as the median of 5 runs; then two RTL CAN cores (no host
//! registers) exchanging 8-byte frames: node-pair cycles and frames per second.

use std::time::Instant;

use golden::btr::Btr;
use golden::frame::{encode, Frame, Id};
use sim::engine::time::ClockSpec;
use sim::engine::Engine;
use sim::nodes::btl_node::BitTimingNode;
use sim::nodes::can_node::CanNode;
use sim::nodes::lower_tester::LowerTester;

const FRAMES: usize = 40;
const RUNS: usize = 5;

fn run(nodes: usize, trace: bool) -> f64 {
    let btr = Btr::from_registers(0x40, 0x1C);
    let clock = ClockSpec::from_hz(16e6);
    let mut engine = Engine::new();
    let mut lt = LowerTester::new("lt", clock, btr);
    lt.release(12);
    for i in 0..FRAMES {
        let frame = Frame::data(Id::standard(i as u16).unwrap(), &[i as u8; 8]).unwrap();
        lt.send_bits(encode(&frame).bits.iter().by_vals())
            .release(12);
    }
    let lt = engine.add(lt, 0);
    for n in 0..nodes {
        let node_clock = ClockSpec::with_ppm(16e6, 500.0 * n as f64);
        engine.add(BitTimingNode::new(&format!("n{n}"), node_clock, btr), 0);
    }
    let vcd = std::env::temp_dir().join(format!("cansim-bench-{}.vcd", std::process::id()));
    if trace {
        engine.trace_vcd(&vcd).unwrap();
    }
    let start = Instant::now();
    engine
        .run_while(u64::MAX, |e| e.device::<LowerTester>(lt).finished())
        .unwrap();
    engine.finish_trace().unwrap();
    let seconds = start.elapsed().as_secs_f64();
    std::fs::remove_file(&vcd).ok();
    let lt_edges = engine.now() / clock.period_fs() + 1;
    (engine.edges() - lt_edges) as f64 / seconds
}

/// Two RTL CAN cores at 16 MHz / 500 kbit/s: node A sends `FRAMES` 8-byte data frames back to back,
/// node B receives them. Returns node-pair clock cycles per second and frames per second.
fn run_cores(trace: bool) -> (f64, f64) {
    let btr = Btr::from_registers(0x40, 0x1C);
    let mut engine = Engine::new();
    let a = engine.add(CanNode::new("a", ClockSpec::from_hz(16e6), btr), 0);
    let b = engine.add(CanNode::new("b", ClockSpec::with_ppm(16e6, 300.0), btr), 0);
    let vcd = std::env::temp_dir().join(format!("cansim-bench-core-{}.vcd", std::process::id()));
    if trace {
        engine.trace_vcd(&vcd).unwrap();
    }
    let start = Instant::now();
    for i in 0..FRAMES {
        let frame = Frame::data(Id::standard(i as u16).unwrap(), &[i as u8; 8]).unwrap();
        engine.device_mut::<CanNode>(a).send(&frame, false);
        engine
            .run_while(u64::MAX, |e| !e.device::<CanNode>(a).transmit_pending())
            .unwrap();
    }
    engine.finish_trace().unwrap();
    let seconds = start.elapsed().as_secs_f64();
    std::fs::remove_file(&vcd).ok();
    assert_eq!(
        engine.device::<CanNode>(b).received().len(),
        FRAMES,
        "every frame received"
    );
    let pair_cycles = engine.edges() as f64 / 2.0;
    (pair_cycles / seconds, FRAMES as f64 / seconds)
}

fn main() {
    for nodes in [1, 4] {
        for trace in [false, true] {
            let mut rates: Vec<f64> = (0..RUNS).map(|_| run(nodes, trace)).collect();
            rates.sort_by(f64::total_cmp);
            println!(
                "BENCH engine=rust-hdl device=bit-timing nodes={nodes} trace={} node_cycles_per_s={:.0} (min {:.0}, max {:.0})",
                if trace { "on" } else { "off" },
                rates[RUNS / 2],
                rates[0],
                rates[RUNS - 1]
            );
        }
    }
    for trace in [false, true] {
        let mut runs: Vec<(f64, f64)> = (0..RUNS).map(|_| run_cores(trace)).collect();
        runs.sort_by(|x, y| x.0.total_cmp(&y.0));
        let (cycles, frames) = runs[RUNS / 2];
        println!(
            "BENCH engine=rust-hdl device=can-core nodes=2 trace={} pair_cycles_per_s={cycles:.0} frames_per_s={frames:.1} (min {:.0}, max {:.0})",
            if trace { "on" } else { "off" },
            runs[0].0,
            runs[RUNS - 1].0
        );
    }
}
