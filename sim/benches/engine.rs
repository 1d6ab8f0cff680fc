//! Speed of the simulation engine with bit-timing nodes: a lower tester sends 8-byte frames at
//! 500 kbit/s (16 MHz clocks) to 1 or 4 nodes, with and without VCD tracing. Prints node clock cycles
//! per second (every node's cycles counted; the lower tester's are not) as the median of 5 runs; then
//! two RTL CAN cores exchanging 8-byte frames, and two complete controllers doing the same through
//! their registers (the reference workload: A writes each frame and waits for TI, B reads each one
//! and releases it): node-pair cycles and frames per second.

use std::time::Instant;

use rtl::registers::{clock_divider, command, interrupt, mode, pelican};
use sim::btl_node::BitTimingNode;
use sim::btr::Btr;
use sim::can_node::CanNode;
use sim::controller_node::ControllerNode;
use sim::engine::Engine;
use sim::frame::{encode, Frame, Id};
use sim::frame_buffer::{buffer_len, decode_buffer, encode_buffer};
use sim::host::Host;
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

/// Puts controller `id` into PeliCAN operation at 500 kbit/s (BTR0 0x40, BTR1 0x1C), filter open,
/// TI and RI enabled.
fn configure(engine: &mut Engine, id: sim::engine::DeviceId) {
    let mut host = Host::new(engine, id);
    host.write(pelican::CDR, clock_divider::PELICAN);
    host.write(pelican::BTR0, 0x40);
    host.write(pelican::BTR1, 0x1C);
    host.write(pelican::AMR0, 0xFF);
    host.write(pelican::AMR0 + 1, 0xFF);
    host.write(pelican::AMR0 + 2, 0xFF);
    host.write(pelican::AMR0 + 3, 0xFF);
    host.write(pelican::IER, interrupt::RI | interrupt::TI);
    host.write(pelican::MOD, 0);
    assert_eq!(host.read(pelican::MOD) & mode::RM, 0);
}

/// Two complete controllers: A transmits `FRAMES` 8-byte frames through its registers, B takes each
/// from its RX buffer and releases it. Returns node-pair cycles per second and frames per second.
fn run_controllers(trace: bool) -> (f64, f64) {
    let mut engine = Engine::new();
    let a = engine.add(ControllerNode::new("a", ClockSpec::from_hz(16e6)), 0);
    let b = engine.add(
        ControllerNode::new("b", ClockSpec::with_ppm(16e6, 300.0)),
        0,
    );
    configure(&mut engine, a);
    configure(&mut engine, b);
    let vcd = std::env::temp_dir().join(format!("cansim-bench-ctl-{}.vcd", std::process::id()));
    if trace {
        engine.trace_vcd(&vcd).unwrap();
    }
    let start = Instant::now();
    let mut received = 0;
    for i in 0..FRAMES {
        let frame = Frame::data(Id::standard(i as u16).unwrap(), &[i as u8; 8]).unwrap();
        let buf = encode_buffer(&frame);
        let mut host = Host::new(&mut engine, a);
        for (k, byte) in buf.iter().take(buffer_len(buf[0])).enumerate() {
            host.write(pelican::FRAME + k as u8, *byte);
        }
        host.write(pelican::CMR, command::TR);
        let mut sent = false;
        while !sent {
            engine
                .run_while(u64::MAX, |e| {
                    e.device::<ControllerNode>(a).irq() || e.device::<ControllerNode>(b).irq()
                })
                .unwrap();
            if engine.device::<ControllerNode>(b).irq() {
                let mut host = Host::new(&mut engine, b);
                if host.read(pelican::IR) & interrupt::RI != 0 {
                    let mut bytes = [0u8; 13];
                    bytes[0] = host.read(pelican::FRAME);
                    for k in 1..buffer_len(bytes[0]) {
                        bytes[k] = host.read(pelican::FRAME + k as u8);
                    }
                    host.write(pelican::CMR, command::RRB);
                    assert_eq!(decode_buffer(&bytes), frame, "frame {i} received intact");
                    received += 1;
                }
            }
            if engine.device::<ControllerNode>(a).irq() {
                sent = Host::new(&mut engine, a).read(pelican::IR) & interrupt::TI != 0;
            }
        }
    }
    engine.finish_trace().unwrap();
    let seconds = start.elapsed().as_secs_f64();
    std::fs::remove_file(&vcd).ok();
    assert_eq!(received, FRAMES, "every frame received");
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
    for trace in [false, true] {
        let mut runs: Vec<(f64, f64)> = (0..RUNS).map(|_| run_controllers(trace)).collect();
        runs.sort_by(|x, y| x.0.total_cmp(&y.0));
        let (cycles, frames) = runs[RUNS / 2];
        println!(
            "BENCH engine=rust-hdl device=controller nodes=2 trace={} pair_cycles_per_s={cycles:.0} frames_per_s={frames:.1} (min {:.0}, max {:.0})",
            if trace { "on" } else { "off" },
            runs[0].0,
            runs[RUNS - 1].0
        );
    }
}
