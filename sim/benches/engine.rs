//! Speed of the simulation engine with bit-timing nodes: a lower tester sends 8-byte frames at
//! 500 kbit/s (16 MHz clocks) to 1 or 4 nodes, with and without VCD tracing. Prints node clock cycles
//! per second (every node's cycles counted; the lower tester's are not) as the median of 5 runs.

use std::time::Instant;

use sim::btl_node::BitTimingNode;
use sim::btr::Btr;
use sim::engine::Engine;
use sim::frame::{encode, Frame, Id};
use sim::lower_tester::LowerTester;
use sim::time::ClockSpec;

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
}
