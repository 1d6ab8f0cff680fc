//! The check that the compiled engine's skipping (a group of cells runs only when something it reads
//! changed) changes nothing a scenario can see: the scenario runs once on `compiled` and once on
//! `compiled-exhaustive` (every group at every evaluation), and every bench it built must have seen
//! the same IUT: its drive changes on the bus, its events with their times and, through the
//! registers, every register access with its clock edge and the value read.
//!
//! [`crate::on_both_iuts!`] runs every protocol scenario this way (`skipping::core::…`,
//! `skipping::registers::…`); the benches find the engine to use here while a check runs.

use std::cell::RefCell;

use sim::engine::bus::Drive;
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
}

struct Check {
    engine: ModelEngine,
    traces: Vec<IutTrace>,
}

thread_local! {
    static CHECK: RefCell<Option<Check>> = const { RefCell::new(None) };
}

/// The engine the benches of a running check use (`None` outside a check).
pub(crate) fn engine() -> Option<ModelEngine> {
    CHECK.with(|c| c.borrow().as_ref().map(|c| c.engine))
}

/// Keeps the trace of a bench of the running check (nothing outside a check).
pub(crate) fn record(trace: impl FnOnce() -> IutTrace) {
    CHECK.with(|c| {
        if let Some(check) = c.borrow_mut().as_mut() {
            check.traces.push(trace());
        }
    });
}

fn traces_on(engine: ModelEngine, iut: Iut, scenario: fn(Iut)) -> Vec<IutTrace> {
    CHECK.with(|c| {
        *c.borrow_mut() = Some(Check {
            engine,
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
    let skipping = traces_on(ModelEngine::Compiled, iut, scenario);
    let every_group = traces_on(ModelEngine::CompiledExhaustive, iut, scenario);
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
    assert_eq!(skipping.len(), every_group.len(), "benches built");
    for (k, (a, b)) in skipping.iter().zip(&every_group).enumerate() {
        first_difference(k, "drive change", &a.drive, &b.drive);
        first_difference(k, "event", &a.events, &b.events);
        first_difference(k, "register access", &a.accesses, &b.accesses);
    }
}

fn first_difference<T: PartialEq + std::fmt::Debug>(bench: usize, what: &str, a: &[T], b: &[T]) {
    if let Some(i) = (0..a.len().min(b.len())).find(|&i| a[i] != b[i]) {
        panic!(
            "bench {bench}, {what} {i}: skipping {:?}, every group {:?}",
            a[i], b[i]
        );
    }
    assert_eq!(a.len(), b.len(), "bench {bench}: {what}s");
}
