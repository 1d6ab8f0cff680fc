//! The two engines of the complete controller, rust-hdl and Verilator (`CAN_ENGINE`), give identical
//! results:
//! - every scenario of `examples/` writes the same VCD (the bus and, per node, `tx`, `rx`, sample
//!   point, segment, protocol state, TEC, REC, `irq_n`, `clkout` at every change), the same bus log
//!   and the same report (driver events, frames, states, counters) with either;
//! - a register-level session on three controllers (arbitration, reception, an error, counter
//!   writes, every register read between the phases) reads the same values and puts the same bit
//!   sequence on the bus.
//!
//! The cycle-by-cycle comparison of the outputs is in `verilog_equivalence.rs`.

use std::path::{Path, PathBuf};

use rtl::registers::{command, interrupt, mode, pelican};
use sim::controller_node::ModelEngine;
use sim::frame::{Frame, Id};
use sim::scenario::{load, run, RunOptions, RunReport};
use testbenches::controller_bench::{
    configure_pelican, drain_rx, transmit, ControllerBench, INTEGRATION_BITS,
};

/// A fresh scratch directory.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cansim-engines-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Panics at the first line where `a` and `b` differ, showing both.
fn assert_same_text(what: &str, a: &str, b: &str) {
    if let Some((k, (x, y))) = a
        .lines()
        .zip(b.lines())
        .enumerate()
        .find(|(_, (x, y))| x != y)
    {
        panic!(
            "{what}: line {} differs:\n  rust-hdl:  {x}\n  verilator: {y}",
            k + 1
        );
    }
    assert_eq!(
        a.lines().count(),
        b.lines().count(),
        "{what}: one is longer"
    );
}

/// Panics at the first element where `a` and `b` differ.
fn assert_same_items<T: PartialEq + std::fmt::Debug>(what: &str, a: &[T], b: &[T]) {
    if let Some(k) = (0..a.len().min(b.len())).find(|&k| a[k] != b[k]) {
        panic!(
            "{what}: item {k} differs: rust-hdl {:?}, verilator {:?}",
            a[k], b[k]
        );
    }
    assert_eq!(a.len(), b.len(), "{what}: one is longer");
}

/// What one engine's run of a scenario produced.
struct Outcome {
    report: RunReport,
    vcd: String,
    log: String,
}

fn run_example(name: &str, engine: ModelEngine) -> Outcome {
    let file = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name);
    let scenario = load(&file).unwrap_or_else(|e| panic!("{e}"));
    let dir = scratch(&format!("{name}-{engine}"));
    let options = RunOptions {
        vcd: Some(dir.join("run.vcd")),
        log: Some(dir.join("run.log")),
        engine: Some(engine),
        ..RunOptions::default()
    };
    let report = run(&scenario, options).unwrap_or_else(|e| panic!("{name} on {engine}: {e}"));
    let read = |file: &str| std::fs::read_to_string(dir.join(file)).unwrap();
    let outcome = Outcome {
        vcd: read("run.vcd"),
        log: read("run.log"),
        report,
    };
    let _ = std::fs::remove_dir_all(&dir);
    outcome
}

/// Runs example `name` on both engines and compares everything it wrote and reported.
fn example_is_the_same_on_both_engines(name: &str) {
    let a = run_example(name, ModelEngine::RustHdl);
    let b = run_example(name, ModelEngine::Verilator);
    assert!(!a.report.log.is_empty(), "{name}: nothing on the bus");
    assert_same_text(&format!("{name}: VCD"), &a.vcd, &b.vcd);
    assert_same_text(&format!("{name}: bus log"), &a.log, &b.log);
    assert_same_items(
        &format!("{name}: node reports"),
        &a.report.nodes,
        &b.report.nodes,
    );
    assert_same_items(
        &format!("{name}: events"),
        &a.report.events,
        &b.report.events,
    );
    assert_same_items(
        &format!("{name}: faults"),
        &a.report.faults,
        &b.report.faults,
    );
    assert_eq!(a.report.missed_faults, b.report.missed_faults, "{name}");
    assert_eq!(a.report.frame_starts, b.report.frame_starts, "{name}");
    assert_eq!(a.report.simulated_fs, b.report.simulated_fs, "{name}");
}

#[test]
fn example_arbitration_is_the_same_on_both_engines() {
    example_is_the_same_on_both_engines("arbitration.toml");
}

#[test]
fn example_bus_off_is_the_same_on_both_engines() {
    example_is_the_same_on_both_engines("bus_off.toml");
}

#[test]
fn example_canopen_is_the_same_on_both_engines() {
    example_is_the_same_on_both_engines("canopen.toml");
}

#[test]
fn example_demo_is_the_same_on_both_engines() {
    example_is_the_same_on_both_engines("demo.toml");
}

#[test]
fn example_oscillator_is_the_same_on_both_engines() {
    example_is_the_same_on_both_engines("oscillator.toml");
}

#[test]
fn example_replay_is_the_same_on_both_engines() {
    example_is_the_same_on_both_engines("replay.toml");
}

#[test]
fn every_example_is_compared() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "arbitration.toml",
            "bus_off.toml",
            "canopen.toml",
            "demo.toml",
            "oscillator.toml",
            "replay.toml"
        ],
        "a new example needs its comparison test here"
    );
}

// ---- a register-level session -------------------------------------------------------------------

/// Nodes of the session.
const NODES: usize = 3;
/// Register addresses read in every snapshot (the PeliCAN map without the RX/TX RAM).
const SNAPSHOT: std::ops::Range<u8> = 0..32;

fn std_frame(id: u16, data: &[u8]) -> Frame {
    Frame::data(Id::standard(id).unwrap(), data).unwrap()
}

fn ext_frame(id: u32, data: &[u8]) -> Frame {
    Frame::data(Id::extended(id).unwrap(), data).unwrap()
}

/// What a session saw: every register read in order, the frames each node drained, the bus
/// level changes.
#[derive(Debug)]
struct Session {
    reads: Vec<u8>,
    drained: Vec<Vec<Frame>>,
    bus: Vec<(u64, bool)>,
}

fn snapshot(bench: &mut ControllerBench, reads: &mut Vec<u8>) {
    for n in 0..NODES {
        let mut host = bench.host(n);
        reads.extend(SNAPSHOT.map(|addr| host.read(addr)));
    }
}

/// Three controllers: nodes 0 and 1 start a standard and an extended frame together (node 1
/// loses, then sends), node 2 receives both; node 1 sends again while node 2 sees one bit
/// inverted (an error frame follows, the frame is repeated); every node's RX FIFO is drained; the
/// error counters are written in reset mode; every register of every node is read between the
/// phases.
fn register_session(engine: ModelEngine) -> Session {
    let mut bench = ControllerBench::with_engine(NODES, engine);
    bench.engine.watch_bus();
    let mut reads = Vec::new();
    for n in 0..NODES {
        configure_pelican(&mut bench.host(n));
        bench.host(n).write(pelican::MOD, 0);
    }
    bench.run_bits(INTEGRATION_BITS);
    snapshot(&mut bench, &mut reads);

    transmit(
        &mut bench.host(0),
        &std_frame(0x123, &[1, 2, 3]),
        command::TR,
    );
    transmit(
        &mut bench.host(1),
        &ext_frame(0x0246_8ACE, &[0xA5; 8]),
        command::TR,
    );
    bench.run_bits(300);
    snapshot(&mut bench, &mut reads);

    transmit(&mut bench.host(1), &std_frame(0x7FF, &[0x55]), command::TR);
    let sof = bench.run_until_sof(1, 50);
    bench.force_seen_bit(2, sof, 3, false);
    bench.run_bits(200);
    snapshot(&mut bench, &mut reads);
    let drained = (0..NODES).map(|n| drain_rx(&mut bench.host(n))).collect();

    for n in 0..NODES {
        let mut host = bench.host(n);
        host.write(pelican::MOD, mode::RM);
        host.write(pelican::TXERR, 7 * n as u8);
        host.write(pelican::RXERR, 11 * n as u8);
        host.write(pelican::MOD, 0);
    }
    bench.run_bits(INTEGRATION_BITS);
    snapshot(&mut bench, &mut reads);
    Session {
        reads,
        drained,
        bus: bench.engine.take_bus_changes().unwrap(),
    }
}

#[test]
fn a_register_session_reads_and_sends_the_same_on_both_engines() {
    let a = register_session(ModelEngine::RustHdl);
    let b = register_session(ModelEngine::Verilator);
    // The session does what it says (on the reference engine).
    assert_eq!(
        a.drained[2],
        [
            std_frame(0x123, &[1, 2, 3]),
            ext_frame(0x0246_8ACE, &[0xA5; 8]),
            std_frame(0x7FF, &[0x55])
        ]
    );
    let ir_after_error = a.reads[(2 * NODES + 2) * SNAPSHOT.len() + usize::from(pelican::IR)];
    assert_ne!(ir_after_error & interrupt::BEI, 0, "node 2 saw a bus error");
    assert_same_items("register reads", &a.reads, &b.reads);
    assert_same_items("drained frames", &a.drained, &b.drained);
    assert_same_items("bus level changes", &a.bus, &b.bus);
}
