//! The engines of the complete controller (`CAN_ENGINE`) give identical results: rust-hdl with
//! its activity-driven settle (the reference here), the same model with every kernel run on every
//! pass (`rust-hdl-exhaustive`, rust-hdl's own evaluation), Verilator, and the compiled engine
//! (the Yosys netlist as straight-line Rust) with its skipping of unchanged groups of cells and
//! without (`compiled-exhaustive`):
//! - every scenario of `examples/` writes the same VCD (the bus and, per node, `tx`, `rx`, sample
//!   point, segment, protocol state, TEC, REC, `irq_n`, `clkout` at every change), the same bus log
//!   and the same report (driver events, frames, states, counters) with either, and with the
//!   compiled and the Verilator engine skipping their quiet clock edges (`CAN_SKIP_EDGES`);
//! - a register-level session on three controllers (arbitration, reception, an error, counter
//!   writes, every register read between the phases) reads the same values and puts the same bit
//!   sequence on the bus;
//! - the bare CAN cores of the fault campaign (rust-hdl, or the core's own compiled model with and
//!   without skipping) give the same result for a random slice of campaign cases: bus bits,
//!   deliveries, error codes, counters and states, and the same VCD for the first cases.
//!
//! The cycle-by-cycle comparison of the outputs is in `verilog_equivalence.rs`.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use golden::frame::{Frame, Id};
use rtl::registers::{command, interrupt, mode, pelican};
use sim::engine::rng::Rng;
use sim::engine::EdgeSkipping;
use sim::host::sja1000::{drain_rx, transmit};
use sim::nodes::controller_node::ModelEngine;
use sim::scenario::{load, run, RunOptions, RunReport};
use sim::workloads::campaign::{
    check, random_case, run_rtl_lanes, run_rtl_on, run_rtl_with, Outcome as CaseOutcome,
};
use testbenches::controller_bench::{configure_pelican, ControllerBench, INTEGRATION_BITS};

/// A fresh scratch directory, unique within the process (tests run in parallel).
fn scratch(name: &str) -> PathBuf {
    static RUNS: AtomicUsize = AtomicUsize::new(0);
    let run = RUNS.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!(
        "cansim-engines-{name}-{}-{run}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The runs compared: the reference's name (usually rust-hdl) and the other's.
type Sides<'a> = (&'a str, &'a str);

/// The usual sides: rust-hdl against `other`.
fn against(other: ModelEngine) -> Sides<'static> {
    ("rust-hdl", other.name())
}

/// Panics at the first line where `a` (from the reference) and `b` (from the other run) differ,
/// showing both.
fn assert_same_text(what: &str, (reference, other): Sides, a: &str, b: &str) {
    if let Some((k, (x, y))) = a
        .lines()
        .zip(b.lines())
        .enumerate()
        .find(|(_, (x, y))| x != y)
    {
        panic!(
            "{what}: line {} differs:\n  {reference}:  {x}\n  {other}: {y}",
            k + 1
        );
    }
    assert_eq!(
        a.lines().count(),
        b.lines().count(),
        "{what}: one is longer"
    );
}

/// Panics at the first element where `a` (from the reference) and `b` (from the other run)
/// differ.
fn assert_same_items<T: PartialEq + std::fmt::Debug>(
    what: &str,
    (reference, other): Sides,
    a: &[T],
    b: &[T],
) {
    if let Some(k) = (0..a.len().min(b.len())).find(|&k| a[k] != b[k]) {
        panic!(
            "{what}: item {k} differs: {reference} {:?}, {other} {:?}",
            a[k], b[k]
        );
    }
    assert_eq!(a.len(), b.len(), "{what}: one is longer");
}

/// What one engine's run of a scenario produced.
struct Outcome {
    report: RunReport,
    /// Empty when the run was not traced.
    vcd: String,
    log: String,
}

/// Runs example `name` on `engine`, writing a VCD if `traced`.
fn run_example(name: &str, engine: ModelEngine, skipping: EdgeSkipping, traced: bool) -> Outcome {
    let file = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name);
    let scenario = load(&file).unwrap_or_else(|e| panic!("{e}"));
    let dir = scratch(&format!("{name}-{engine}"));
    let options = RunOptions {
        vcd: traced.then(|| dir.join("run.vcd")),
        log: Some(dir.join("run.log")),
        engine: Some(engine),
        edge_skipping: Some(skipping),
        ..RunOptions::default()
    };
    let report = run(&scenario, options).unwrap_or_else(|e| panic!("{name} on {engine}: {e}"));
    let read = |file: &str| std::fs::read_to_string(dir.join(file)).unwrap();
    let outcome = Outcome {
        vcd: if traced {
            read("run.vcd")
        } else {
            String::new()
        },
        log: read("run.log"),
        report,
    };
    let _ = std::fs::remove_dir_all(&dir);
    outcome
}

/// Runs example `name` on rust-hdl and on `other` and compares everything they wrote and reported.
fn example_is_the_same_on(name: &str, other: ModelEngine) {
    let a = run_example(name, ModelEngine::RustHdl, EdgeSkipping::Off, true);
    let b = run_example(name, other, EdgeSkipping::Off, true);
    example_matches(name, against(other), &a, &b);
}

/// Example `name` on `engine` with its quiet edges skipped writes and reports what the same engine
/// stepping every edge does (which the tests above compare with rust-hdl), with each skip checked
/// (`checked`: the compiled engine steps a copy of the controller beside the skip and compares the
/// whole state, the Verilator engine steps the edges instead of skipping and compares the state
/// with the skip's) and, on Verilator, with the skips made as such (the wrapper loading the
/// counters). Untraced, the skips run on through the ends of Sync and TSEG2 (only the trace shows
/// the segment): the bus log and the report must still be the same.
fn example_is_the_same_with_quiet_edges_skipped(name: &str, engine: ModelEngine) {
    let a = run_example(name, engine, EdgeSkipping::Off, true);
    let mut modes = vec![EdgeSkipping::Checked];
    if engine == ModelEngine::Verilator {
        modes.push(EdgeSkipping::On);
    }
    for skipping in modes {
        for traced in [true, false] {
            let mut b = run_example(name, engine, skipping, traced);
            assert!(
                b.report.skipped_edges > 0,
                "{name}: no edge was skipped ({} stepped)",
                b.report.edges
            );
            let trace = if traced { "traced" } else { "untraced" };
            let skipping_side = format!("{engine} skipping edges ({}, {trace})", skipping.name());
            if !traced {
                b.vcd.clone_from(&a.vcd);
            }
            example_matches(name, (engine.name(), &skipping_side), &a, &b);
        }
    }
}

/// Compares everything example `name`'s runs `a` and `b` wrote and reported.
fn example_matches(name: &str, sides: Sides, a: &Outcome, b: &Outcome) {
    assert!(!a.report.log.is_empty(), "{name}: nothing on the bus");
    assert_same_text(&format!("{name}: VCD"), sides, &a.vcd, &b.vcd);
    assert_same_text(&format!("{name}: bus log"), sides, &a.log, &b.log);
    let r = (&a.report, &b.report);
    assert_same_items(
        &format!("{name}: node reports"),
        sides,
        &r.0.nodes,
        &r.1.nodes,
    );
    assert_same_items(&format!("{name}: events"), sides, &r.0.events, &r.1.events);
    assert_same_items(&format!("{name}: faults"), sides, &r.0.faults, &r.1.faults);
    assert_eq!(r.0.missed_faults, r.1.missed_faults, "{name}");
    assert_eq!(r.0.master, r.1.master, "{name}: CANopen master");
    assert_eq!(r.0.frame_starts, r.1.frame_starts, "{name}");
    assert_eq!(r.0.simulated_fs, r.1.simulated_fs, "{name}");
}

/// One test per engine compared with rust-hdl for the example `$file`.
macro_rules! example_tests {
    ($module:ident, $file:literal) => {
        mod $module {
            use super::*;

            #[test]
            fn is_the_same_on_verilator() {
                example_is_the_same_on($file, ModelEngine::Verilator);
            }

            #[test]
            fn is_the_same_on_compiled() {
                example_is_the_same_on($file, ModelEngine::Compiled);
            }

            #[test]
            fn is_the_same_on_compiled_with_every_group_every_cycle() {
                example_is_the_same_on($file, ModelEngine::CompiledExhaustive);
            }

            #[test]
            fn is_the_same_with_quiet_edges_skipped() {
                example_is_the_same_with_quiet_edges_skipped($file, ModelEngine::Compiled);
            }

            #[test]
            fn is_the_same_on_verilator_with_quiet_edges_skipped() {
                example_is_the_same_with_quiet_edges_skipped($file, ModelEngine::Verilator);
            }

            #[test]
            fn is_the_same_with_every_kernel_on_every_pass() {
                example_is_the_same_on($file, ModelEngine::RustHdlExhaustive);
            }
        }
    };
}

example_tests!(example_arbitration, "arbitration.toml");
example_tests!(example_bus_off, "bus_off.toml");
example_tests!(example_canopen, "canopen.toml");
example_tests!(example_canopen_device, "canopen_device.toml");
example_tests!(example_canopen_io, "canopen_io.toml");
example_tests!(example_demo, "demo.toml");
example_tests!(example_oscillator, "oscillator.toml");
example_tests!(example_replay, "replay.toml");
example_tests!(example_serve, "serve.toml");

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
            "canopen_device.toml",
            "canopen_io.toml",
            "demo.toml",
            "oscillator.toml",
            "replay.toml",
            "serve.toml",
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

/// The register session on rust-hdl and on `other`: the same reads, frames and bus changes.
fn register_session_is_the_same_on(other: ModelEngine) {
    let a = register_session(ModelEngine::RustHdl);
    let b = register_session(other);
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
    assert_same_items("register reads", against(other), &a.reads, &b.reads);
    assert_same_items("drained frames", against(other), &a.drained, &b.drained);
    assert_same_items("bus level changes", against(other), &a.bus, &b.bus);
}

#[test]
fn a_register_session_reads_and_sends_the_same_on_verilator() {
    register_session_is_the_same_on(ModelEngine::Verilator);
}

#[test]
fn a_register_session_reads_and_sends_the_same_on_compiled() {
    register_session_is_the_same_on(ModelEngine::Compiled);
}

#[test]
fn a_register_session_reads_and_sends_the_same_on_compiled_with_every_group_every_cycle() {
    register_session_is_the_same_on(ModelEngine::CompiledExhaustive);
}

#[test]
fn a_register_session_reads_and_sends_the_same_with_every_kernel_on_every_pass() {
    register_session_is_the_same_on(ModelEngine::RustHdlExhaustive);
}

/// The campaign seed and cases of the slice compared, and how many of them are traced.
const SLICE_SEED: u64 = 2026;
const SLICE_CASES: u64 = 40;
const TRACED_CASES: u64 = 4;

/// The slice of the fault campaign on rust-hdl and on `other`, case by case.
fn campaign_slice_is_the_same_on(other: ModelEngine) {
    let dir = scratch(&format!("campaign-{other}"));
    let mut outcomes = std::collections::BTreeSet::new();
    for index in 0..SLICE_CASES {
        let case = random_case(&mut Rng::for_case(SLICE_SEED, index));
        let traced = index < TRACED_CASES;
        let run_on = |engine: ModelEngine| {
            let vcd = dir.join(format!("case{index}-{engine}.vcd"));
            let run = run_rtl_on(&case, engine, traced.then_some(vcd.as_path())).unwrap();
            (run, traced.then(|| std::fs::read_to_string(&vcd).unwrap()))
        };
        let (a, vcd_a) = run_on(ModelEngine::RustHdl);
        let (b, vcd_b) = run_on(other);
        assert_same_items(
            &format!("case {index}: bus bits"),
            against(other),
            &a.bus,
            &b.bus,
        );
        assert_eq!(a, b, "case {index}: rust-hdl and {other} differ");
        if let (Some(x), Some(y)) = (vcd_a, vcd_b) {
            assert_same_text(&format!("case {index}: VCD"), against(other), &x, &y);
        }
        outcomes.insert(sim::workloads::campaign::check(&case, &a).outcome);
    }
    // The slice exercises error handling, not only clean frames.
    assert!(outcomes.contains(&CaseOutcome::Recovered), "{outcomes:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The slice on the compiled core with the quiet edges skipped (each skip checked against stepping
/// a copy) gives what it gives stepping every edge, case by case, VCDs included.
#[test]
fn a_campaign_slice_runs_the_same_with_quiet_edges_skipped() {
    let dir = scratch("campaign-skipping");
    let mut skipped = 0;
    for index in 0..SLICE_CASES {
        let case = random_case(&mut Rng::for_case(SLICE_SEED, index));
        let traced = index < TRACED_CASES;
        let run_with = |skipping: EdgeSkipping| {
            let vcd = dir.join(format!("case{index}-{}.vcd", skipping.name()));
            let vcd = traced.then_some(vcd.as_path());
            let (run, skipped) =
                run_rtl_with(&case, ModelEngine::Compiled, vcd, Some(skipping)).unwrap();
            (
                run,
                vcd.map(|v| std::fs::read_to_string(v).unwrap()),
                skipped,
            )
        };
        let (a, vcd_a, _) = run_with(EdgeSkipping::Off);
        let (b, vcd_b, edges) = run_with(EdgeSkipping::Checked);
        skipped += edges;
        let sides = ("compiled", "compiled skipping edges");
        assert_same_items(&format!("case {index}: bus bits"), sides, &a.bus, &b.bus);
        assert_eq!(a, b, "case {index}: skipping edges changed the run");
        if let (Some(x), Some(y)) = (vcd_a, vcd_b) {
            assert_same_text(&format!("case {index}: VCD"), sides, &x, &y);
        }
    }
    assert!(skipped > 0, "no edge was skipped");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Cases of the lane comparison: enough for every lane to take several cases one after the other.
const LANE_CASES: u64 = 200;

/// The lane runner (64 cases at a time in the lane model, the core mapped to gates by Yosys; a lane
/// takes the next case as soon as its case ends) gives every case the run the engine gives it
/// alone on the compiled core: bus bits, deliveries, errors, counters.
#[test]
fn campaign_cases_run_the_same_in_lanes_as_alone_on_the_engine() {
    let cases: Vec<_> = (0..LANE_CASES)
        .map(|index| random_case(&mut Rng::for_case(SLICE_SEED, index)))
        .collect();
    let runs = run_rtl_lanes(&cases).unwrap();
    let mut outcomes = std::collections::BTreeSet::new();
    let sides = ("compiled engine", "lanes");
    for (index, (case, lanes)) in cases.iter().zip(&runs).enumerate() {
        let alone = run_rtl_on(case, ModelEngine::Compiled, None).unwrap();
        let what = format!("case {index}: bus bits");
        assert_same_items(&what, sides, &alone.bus, &lanes.bus);
        assert_eq!(
            &alone, lanes,
            "case {index}: the lanes differ from the engine"
        );
        outcomes.insert(check(case, &alone).outcome);
    }
    // Errors, retransmissions and error-passive nodes are among them, not only clean frames.
    assert!(outcomes.len() >= 4, "{outcomes:?}");
}

#[test]
fn a_campaign_slice_runs_the_same_on_the_compiled_core() {
    campaign_slice_is_the_same_on(ModelEngine::Compiled);
}

#[test]
fn a_campaign_slice_runs_the_same_on_the_compiled_core_with_every_group_every_cycle() {
    campaign_slice_is_the_same_on(ModelEngine::CompiledExhaustive);
}

#[test]
fn a_campaign_slice_runs_the_same_with_every_kernel_on_every_pass() {
    campaign_slice_is_the_same_on(ModelEngine::RustHdlExhaustive);
}
