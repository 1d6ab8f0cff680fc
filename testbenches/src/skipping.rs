//! The check that the compiled engine's skipping (a group of cells runs only when something it reads
//! changed) changes nothing a scenario can see: the scenario runs once on `compiled` and once on
//! `compiled-exhaustive` (every group at every evaluation), and every bench it built must have seen
//! the same IUT: its drive changes on the bus, its events with their times and, through the
//! registers, every register access with its clock edge and the value read.
//!
//! The complete controller's scenarios run a third time, on `compiled` with the engine skipping
//! the quiet clock edges (`CAN_SKIP_EDGES`, each skip checked against stepping a copy): the same
//! drive changes, events and register accesses at the same times again.
//!
//! [`crate::on_both_iuts!`] runs every protocol scenario this way (`skipping::core::…`,
//! `skipping::registers::…`); the benches find the engine to use here while a check runs.

use std::cell::RefCell;

use sim::engine::bus::Drive;
use sim::engine::EdgeSkipping;
use sim::nodes::can_node::NodeEvent;
use sim::nodes::controller_node::{HostAccess, ModelEngine};

use crate::protocol_bench::Iut;

/// What one bench's IUT did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IutTrace {
    /// Every change of the IUT's drive, (time, new drive).
    pub drive: Vec<(u64, Drive)>,
    /// The IUT's events with their times.
    pub events: Vec<(u64, NodeEvent)>,
    /// The register accesses (clock edge, access, value read); empty for the bare core.
    pub accesses: Vec<(u64, HostAccess, Option<u8>)>,
    /// Clock edges the bench's engine skipped (not compared: only the edge skipping check has
    /// any).
    pub skipped_edges: u64,
}

struct Check {
    engine: ModelEngine,
    edges: EdgeSkipping,
    traces: Vec<IutTrace>,
}

thread_local! {
    static CHECK: RefCell<Option<Check>> = const { RefCell::new(None) };
}

/// The engine the benches of a running check use (`None` outside a check).
pub(crate) fn engine() -> Option<ModelEngine> {
    CHECK.with(|c| c.borrow().as_ref().map(|c| c.engine))
}

/// The edge skipping the benches of a running check use (`None` outside a check).
pub(crate) fn edge_skipping() -> Option<EdgeSkipping> {
    CHECK.with(|c| c.borrow().as_ref().map(|c| c.edges))
}

/// Keeps the trace of a bench of the running check (nothing outside a check).
pub(crate) fn record(trace: impl FnOnce() -> IutTrace) {
    CHECK.with(|c| {
        if let Some(check) = c.borrow_mut().as_mut() {
            check.traces.push(trace());
        }
    });
}

fn traces_on(
    engine: ModelEngine,
    edges: EdgeSkipping,
    iut: Iut,
    scenario: fn(Iut),
) -> Vec<IutTrace> {
    CHECK.with(|c| {
        *c.borrow_mut() = Some(Check {
            engine,
            edges,
            traces: Vec::new(),
        })
    });
    scenario(iut);
    CHECK
        .with(|c| c.borrow_mut().take())
        .expect("the check is still set")
        .traces
}

/// Runs `scenario` on `iut` with the compiled engine's skipping and without; panics at the first
/// difference in what its benches' IUT did.
pub fn assert_skipping_changes_nothing(iut: Iut, scenario: fn(Iut)) {
    let skipping = traces_on(ModelEngine::Compiled, EdgeSkipping::Off, iut, scenario);
    let every_group = traces_on(
        ModelEngine::CompiledExhaustive,
        EdgeSkipping::Off,
        iut,
        scenario,
    );
    assert!(!skipping.is_empty(), "the scenario built no bench");
    assert!(
        skipping
            .iter()
            .any(|t| !t.drive.is_empty() || !t.events.is_empty()),
        "the IUT neither drove the bus nor reported anything"
    );
    if iut == Iut::Registers {
        assert!(
            skipping.iter().any(|t| !t.accesses.is_empty()),
            "no register access was recorded"
        );
    }
    assert_same_traces("skipping", &skipping, &every_group);
    if iut == Iut::Registers {
        let edges = traces_on(ModelEngine::Compiled, EdgeSkipping::Checked, iut, scenario);
        assert!(
            edges.iter().any(|t| t.skipped_edges > 0),
            "no clock edge was skipped"
        );
        assert_same_traces("edges skipped", &edges, &every_group);
    }
}

/// Panics at the first difference between the traces of `how` (`a`) and of every group's run
/// (`b`).
fn assert_same_traces(how: &str, a: &[IutTrace], b: &[IutTrace]) {
    assert_eq!(a.len(), b.len(), "benches built");
    for (k, (a, b)) in a.iter().zip(b).enumerate() {
        first_difference(how, k, "drive change", &a.drive, &b.drive);
        first_difference(how, k, "event", &a.events, &b.events);
        first_difference(how, k, "register access", &a.accesses, &b.accesses);
    }
}

fn first_difference<T: PartialEq + std::fmt::Debug>(
    how: &str,
    bench: usize,
    what: &str,
    a: &[T],
    b: &[T],
) {
    if let Some(i) = (0..a.len().min(b.len())).find(|&i| a[i] != b[i]) {
        panic!(
            "bench {bench}, {what} {i}: {how} {:?}, every group {:?}",
            a[i], b[i]
        );
    }
    assert_eq!(a.len(), b.len(), "bench {bench} ({how}): {what}s");
}
