//! Fault injection: one frame sent by node 0 to the other RTL cores, one injected fault, and the
//! checks of what CAN guarantees afterwards.
//!
//! A [`Case`] is a frame, the nodes' starting error counters and at most one [`Injection`]: a whole
//! bit seen flipped or forced (by one node, a local disturbance, or by all nodes), or a glitch of a few
//! time quanta. [`run_rtl`] plays it on the cycle-accurate cores, [`check`] classifies the result
//! into an [`Outcome`] and, for whole-bit faults, compares it with the bit-level golden model of
//! [`golden::reference`] (bus levels bit by bit, deliveries, error kinds, TEC/REC). [`run_campaign`]
//! draws random cases and spreads them over threads.
//!
//! Faults are placed by bus bit: bit 0 is the SOF of the first attempt. A bus monitor reads the bus
//! like a receiver that synchronises on every falling edge; a whole-bit fault covers one bit time
//! from 2 clocks after the start of its bit as the monitor saw it, so every node's sample point of
//! that bit lies inside and those of its neighbours outside, whatever the small phase differences
//! between the nodes.

mod lanes;

use crate::engine::rng::Rng;
use crate::host::sja1000::{BTR0_1M_AT_16MHZ, BTR1_1M_AT_16MHZ};
use crate::verilated::EngineError;
use crate::workloads::campaign_slice::Shard;
use lanes::LaneRunner;
use std::any::Any;
use std::collections::BTreeMap;
use std::io;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use rtl::bsp::protocol::ProtocolState;

use crate::engine::bus::Drive;
use crate::engine::bus_timing::BusTiming;
use crate::engine::time::ClockSpec;
use crate::engine::{Device, DeviceId, EdgeSkipping, Engine};
use crate::nodes::can_node::{CanNode, NodeEvent};
use crate::nodes::controller_node::ModelEngine;
use crate::nodes::core_engine::CoreModel;
use golden::btr::Btr;
use golden::frame::{decode, encode, Field, Frame, Id, DOMINANT};
use golden::reference::{self, Detected, Fault, FaultKind, Scenario};

/// Nodes on the bus: node 0 transmits, the others receive.
pub const NODES: usize = 3;
/// Controller clock of every node.
pub const CLOCK_HZ: f64 = 16e6;
/// Clocks by which a whole-bit fault window follows the start of the bit on the bus (the receivers'
/// bits start 2 to 3 clocks after the edge they synchronised on).
const WINDOW_SHIFT_CLOCKS: u64 = 2;
/// Recessive bits every node sees before the frame (bus integration).
const INTEGRATION_BITS: u64 = 14;
/// Bits of bus idle after which a run is over.
const SETTLED_IDLE_BITS: usize = 4;
/// Longest run in bits (a transmitter at TEC 250 may need a few error frames to reach bus-off).
const MAX_BITS: usize = 4000;
/// Longest cut of a node from the bus, in bits.
const MAX_CUT_BITS: u64 = 48;

/// One injected fault.
#[derive(Clone, Debug)]
pub enum Injection {
    /// A whole bus bit seen changed.
    Bit(Fault),
    /// `quanta` time quanta from quantum `from_tq` of bus bit `bit` seen as `level`.
    Glitch {
        /// Bus bit (0 = SOF of the first attempt).
        bit: usize,
        /// First quantum within the bit.
        from_tq: u32,
        /// Length in quanta.
        quanta: u32,
        /// The node that sees it, or all.
        node: Option<usize>,
        /// The level seen (true = recessive).
        level: bool,
    },
}

impl Injection {
    /// The bus bit the fault is in.
    pub fn bit(&self) -> usize {
        match self {
            Injection::Bit(fault) => fault.bit,
            Injection::Glitch { bit, .. } => *bit,
        }
    }
}

/// One fault-injection case.
#[derive(Clone, Debug)]
pub struct Case {
    /// The frame node 0 sends.
    pub frame: Frame,
    /// Starting TEC per node.
    pub tec: [u8; NODES],
    /// Starting REC per node.
    pub rec: [u8; NODES],
    /// The fault, if any.
    pub injection: Option<Injection>,
}

/// What one RTL node did in a run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeReport {
    /// Frames delivered, in order.
    pub received: Vec<Frame>,
    /// SJA1000 ECC values of the errors detected, in order.
    pub errors: Vec<u8>,
    /// TEC at the end.
    pub tec: u8,
    /// REC at the end.
    pub rec: u8,
    /// Error passive at the end.
    pub error_passive: bool,
    /// Bus-off at the end.
    pub bus_off: bool,
}

/// The result of a case on the RTL cores.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Run {
    /// Bus level in every bit from the SOF (sampled at the nominal sample point).
    pub bus: Vec<bool>,
    /// Per node.
    pub nodes: Vec<NodeReport>,
    /// Node 0's request ended with success.
    pub transmitted: bool,
}

/// The classes of case results.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub enum Outcome {
    /// No node detected an error and every receiver has the frame once.
    NoEffect,
    /// Errors were detected; after retransmission every receiver has the frame exactly once.
    Recovered,
    /// A receiver has the frame twice: the known CAN inconsistency (fault in the last EOF bits).
    Duplicate,
    /// An error-passive transmitter detected an error nobody else saw: its passive error flag
    /// leaves the frame valid for the receivers, and its retransmission gives them a second copy.
    PassiveTransmitterRepeated,
    /// A receiver never got the frame: the last-EOF-bit case.
    Omission,
    /// An error-passive receiver detected an error nobody else saw: its passive error flag cannot
    /// destroy the frame, so it misses it (CAN's rule for error-passive nodes).
    PassiveReceiverMissed,
    /// A receiver cut from the bus (reading recessive) from before the SOF never saw the frame
    /// start, so it neither received it nor flagged an error.
    CutReceiverMissed,
    /// A node delivered a frame that was not sent: allowed only for the known weakness of CAN (a
    /// fault that moves the stuffing can escape the CRC).
    Corrupted,
    /// The transmitter went bus-off (from a high starting TEC).
    TransmitterBusOff,
}

/// The verdict on one case: its outcome, and what broke a rule (empty if nothing did).
#[derive(Clone, Debug)]
pub struct Verdict {
    /// Outcome class.
    pub outcome: Outcome,
    /// Violations: disagreement with the golden model, or a disagreement between nodes outside the
    /// last EOF bits.
    pub violations: Vec<String>,
}

/// How a campaign plays its cases.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Runner {
    /// 64 cases at a time in the lanes of the lane model (the CAN core mapped to gates by Yosys,
    /// [`crate::compiled::lane_core`]): the default, about ten times faster.
    Lanes,
    /// Each case alone on the simulation engine with its cores on this model, as
    /// [`run_rtl_on`] plays it (and `cansim campaign --case`).
    Engine(ModelEngine),
}

impl Runner {
    /// `lanes`, or `engine` with the cores on `model`.
    pub fn parse(text: &str, model: ModelEngine) -> Result<Runner, String> {
        match text {
            "lanes" => Ok(Runner::Lanes),
            "engine" => Ok(Runner::Engine(model)),
            other => Err(format!(
                "`{other}` is not a campaign runner: use `lanes` (the default) or `engine`"
            )),
        }
    }
}

impl std::fmt::Display for Runner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Runner::Lanes => write!(f, "lanes (64 cases per evaluation of the gate-level core)"),
            Runner::Engine(model) => write!(f, "engine, cores on {model}"),
        }
    }
}

/// The campaign bit timing.
pub fn campaign_btr() -> Btr {
    Btr::from_registers(BTR0_1M_AT_16MHZ, BTR1_1M_AT_16MHZ)
}

/// Plays `case` on [`NODES`] RTL cores (same clock, no propagation delay) on the engine
/// `CAN_ENGINE` names; panics if that engine cannot run.
pub fn run_rtl(case: &Case) -> Run {
    let engine = ModelEngine::from_env().unwrap_or_else(|e| panic!("{e}"));
    run_rtl_on(case, engine, None).unwrap_or_else(|e| panic!("{e}"))
}

/// [`run_rtl`] with the cores on `model`, writing a VCD of the bus and the nodes to `vcd` if
/// given.
pub fn run_rtl_on(case: &Case, model: ModelEngine, vcd: Option<&Path>) -> io::Result<Run> {
    run_rtl_with(case, model, vcd, None).map(|(run, _)| run)
}

/// [`run_rtl_on`] with quiet clock edges skipped as `skipping` says (`None`: as
/// `CAN_SKIP_EDGES` says); also how many edges were skipped.
pub fn run_rtl_with(
    case: &Case,
    model: ModelEngine,
    vcd: Option<&Path>,
    skipping: Option<EdgeSkipping>,
) -> io::Result<(Run, u64)> {
    let btr = campaign_btr();
    let clock = ClockSpec::from_hz(CLOCK_HZ);
    let period = clock.period_fs();
    let bit_fs = btr.clocks_per_bit() as u64 * period;
    let mut engine = Engine::new();
    if let Some(skipping) = skipping {
        engine.set_edge_skipping(skipping);
    }
    let mut ids = Vec::with_capacity(NODES);
    for n in 0..NODES {
        let node = CanNode::with_engine(&format!("n{n}"), clock, btr, model)
            .map_err(|e| io::Error::other(e.to_string()))?;
        ids.push(engine.add(node, 0));
    }
    let monitor = engine.add(BusMonitor::new(clock, &btr), 0);
    if let Some(path) = vcd {
        engine.trace_vcd_timed(path, BusTiming::from_btr(&btr, clock))?;
    }
    load_counters(&mut engine, &ids, case, period)?;
    engine.run_until(engine.now() + INTEGRATION_BITS * bit_fs)?;
    engine.device_mut::<BusMonitor>(monitor).start();
    engine
        .device_mut::<CanNode>(ids[0])
        .send(&case.frame, false);
    let fault_bit = case.injection.as_ref().map(Injection::bit);
    let mut idle_bits = 0;
    let mut bits = 0;
    while bits < MAX_BITS && idle_bits < SETTLED_IDLE_BITS {
        // Bit `bits` has started (or, for bit 0, its SOF edge was seen): place a fault due in it
        // before the simulation gets there.
        let started = engine.run_while(u64::MAX, |e| {
            e.device::<BusMonitor>(monitor).bit_starts.len() > bits
        })?;
        assert!(started, "the bus monitor stopped");
        if fault_bit == Some(bits) {
            let start = engine.device::<BusMonitor>(monitor).bit_starts[bits];
            let injection = case.injection.as_ref().expect("a fault is due");
            disturb(&mut engine, &ids, injection, start, period, &btr);
        }
        engine.run_while(u64::MAX, |e| {
            e.device::<BusMonitor>(monitor).samples.len() > bits
        })?;
        bits += 1;
        enter_reset_mode_at_bus_off(&mut engine, &ids);
        let done = {
            let tx = engine.device::<CanNode>(ids[0]);
            !tx.transmit_pending() || tx.bus_off()
        };
        let idle = ids.iter().all(|&id| {
            let node = engine.device::<CanNode>(id);
            node.bus_off() || node.state() == ProtocolState::Idle
        });
        idle_bits = if done && idle { idle_bits + 1 } else { 0 };
    }
    let transmitted = engine
        .device::<CanNode>(ids[0])
        .events()
        .iter()
        .any(|(_, e)| *e == NodeEvent::TransmitDone(true));
    let nodes = ids
        .iter()
        .map(|&id| node_report(engine.device::<CanNode>(id)))
        .collect();
    engine.finish_trace()?;
    let run = Run {
        bus: engine.device::<BusMonitor>(monitor).samples.clone(),
        nodes,
        transmitted,
    };
    Ok((run, engine.skipped_edges()))
}

/// Reads the bus bit by bit: synchronises on a recessive-to-dominant edge when the last bit it read
/// was recessive (so glitches inside dominant runs do not move it), reads each bit in its middle,
/// and records when each bit starts. Bit 0 is the first dominant bit after [`BusMonitor::start`].
struct BusMonitor {
    clock: ClockSpec,
    clocks_per_bit: u32,
    sample_clock: u32,
    started: bool,
    /// Clocks since the start of the current bit, once the first edge was seen.
    phase: Option<u32>,
    last_level: bool,
    bit_starts: Vec<u64>,
    samples: Vec<bool>,
}

impl BusMonitor {
    fn new(clock: ClockSpec, btr: &Btr) -> BusMonitor {
        BusMonitor {
            clock,
            clocks_per_bit: btr.clocks_per_bit(),
            sample_clock: btr.clocks_per_bit() / 2,
            started: false,
            phase: None,
            last_level: !DOMINANT,
            bit_starts: Vec::new(),
            samples: Vec::new(),
        }
    }

    fn start(&mut self) {
        self.started = true;
    }
}

impl Device for BusMonitor {
    fn name(&self) -> &str {
        "monitor"
    }

    fn clock(&self) -> ClockSpec {
        self.clock
    }

    fn rising_edge(&mut self, t_fs: u64, rx: bool) -> Drive {
        let edge = self.last_level != DOMINANT
            && rx == DOMINANT
            && self.samples.last().is_none_or(|&b| b != DOMINANT);
        self.last_level = rx;
        if !self.started {
            return Drive::Recessive;
        }
        let phase = match self.phase {
            _ if edge => 0,
            None => return Drive::Recessive,
            Some(p) if p + 1 == self.clocks_per_bit => 0,
            Some(p) => p + 1,
        };
        // A bit restarted by an edge before its sample point replaces the unfinished one.
        if phase == 0 {
            if self.bit_starts.len() > self.samples.len() {
                self.bit_starts.pop();
            }
            self.bit_starts.push(t_fs);
        }
        if phase == self.sample_clock {
            self.samples.push(rx);
        }
        self.phase = Some(phase);
        Drive::Recessive
    }

    /// Quiet while the level holds: up to the next bit's start or sample, or for good before
    /// the first edge.
    fn quiet_edges(&self, rx: bool, _traced: bool) -> u64 {
        if rx != self.last_level {
            return 0;
        }
        match self.phase {
            Some(p) if self.started && p < self.sample_clock => {
                u64::from(self.sample_clock - p - 1)
            }
            Some(p) if self.started => u64::from(self.clocks_per_bit - p - 1),
            _ => u64::MAX,
        }
    }

    fn skip_edges(&mut self, edges: u64, _rx: bool, _traced: bool, _checked: bool) {
        if let (true, Some(p)) = (self.started, self.phase) {
            self.phase = Some(p + edges as u32);
        }
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// The SJA1000 register block sets RM at bus-off, so recovery waits for the host: do the same.
fn enter_reset_mode_at_bus_off(engine: &mut Engine, ids: &[DeviceId]) {
    for &id in ids {
        let node = engine.device_mut::<CanNode>(id);
        if node.bus_off() {
            node.set_enable(false);
        }
    }
}

fn load_counters(
    engine: &mut Engine,
    ids: &[DeviceId],
    case: &Case,
    period: u64,
) -> io::Result<()> {
    for (n, &id) in ids.iter().enumerate() {
        engine
            .device_mut::<CanNode>(id)
            .load_counter(true, case.tec[n]);
    }
    engine.run_until(engine.now() + 2 * period)?;
    for (n, &id) in ids.iter().enumerate() {
        engine
            .device_mut::<CanNode>(id)
            .load_counter(false, case.rec[n]);
    }
    engine.run_until(engine.now() + 2 * period)
}

/// What an injection does to the nodes, and when: at the clock edges in `from_fs..to_fs`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Window {
    from_fs: u64,
    to_fs: u64,
    /// The node it applies to, or every node.
    node: Option<usize>,
    effect: Effect,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Effect {
    /// The node sees this level.
    Force(bool),
    /// The node sees the inverted bus level.
    Invert,
    /// What the node drives does not reach the bus (it drives recessive).
    Cut,
}

/// The window of `injection` in the bit that started at `start` (as the bus monitor saw it).
fn window(injection: &Injection, start: u64, period: u64, btr: &Btr) -> Window {
    let bit_fs = btr.clocks_per_bit() as u64 * period;
    let tq_fs = btr.clocks_per_tq() as u64 * period;
    match *injection {
        Injection::Bit(Fault {
            node, kind, bits, ..
        }) => {
            let from_fs = start + WINDOW_SHIFT_CLOCKS * period;
            let effect = match kind {
                FaultKind::Dominant => Effect::Force(DOMINANT),
                FaultKind::Recessive => Effect::Force(!DOMINANT),
                FaultKind::Flip => Effect::Invert,
                FaultKind::Disconnected => {
                    assert!(node.is_some(), "a disconnection is of one node");
                    Effect::Cut
                }
            };
            Window {
                from_fs,
                to_fs: from_fs + bits as u64 * bit_fs,
                node,
                effect,
            }
        }
        Injection::Glitch {
            from_tq,
            quanta,
            node,
            level,
            ..
        } => {
            let from_fs = start + from_tq as u64 * tq_fs;
            Window {
                from_fs,
                to_fs: from_fs + quanta as u64 * tq_fs,
                node,
                effect: Effect::Force(level),
            }
        }
    }
}

/// Applies `injection` to the bit that started at `start` (as the bus monitor saw it).
fn disturb(
    engine: &mut Engine,
    ids: &[DeviceId],
    injection: &Injection,
    start: u64,
    period: u64,
    btr: &Btr,
) {
    let w = window(injection, start, period, btr);
    let targets: Vec<DeviceId> = match w.node {
        Some(n) => vec![ids[n]],
        None => ids.to_vec(),
    };
    for id in targets {
        match w.effect {
            Effect::Force(level) => engine.disturb_rx(id, w.from_fs, w.to_fs, level),
            Effect::Invert => engine.invert_rx(id, w.from_fs, w.to_fs),
            Effect::Cut => engine.override_drive(id, w.from_fs, w.to_fs, Drive::Recessive),
        }
    }
}

fn node_report(node: &CanNode) -> NodeReport {
    NodeReport {
        received: node.received(),
        errors: node.bus_errors(),
        tec: node.tec(),
        rec: node.rec(),
        error_passive: node.error_passive(),
        bus_off: node.bus_off(),
    }
}

/// The golden model's scenario for `case`.
pub fn reference_scenario(case: &Case) -> Scenario {
    Scenario {
        nodes: NODES,
        transmitter: 0,
        frame: case.frame,
        tec: case.tec.to_vec(),
        rec: case.rec.to_vec(),
    }
}

/// Classifies `run` (the result of `case`) and lists what broke a rule.
pub fn check(case: &Case, run: &Run) -> Verdict {
    let mut violations = Vec::new();
    let corrupted = run
        .nodes
        .iter()
        .any(|n| n.received.iter().any(|f| *f != case.frame));
    let copies: Vec<usize> = run.nodes[1..]
        .iter()
        .map(|n| n.received.iter().filter(|f| **f == case.frame).count())
        .collect();
    let any_error = run.nodes.iter().any(|n| !n.errors.is_empty());
    let outcome = if corrupted {
        Outcome::Corrupted
    } else if run.nodes[0].bus_off {
        Outcome::TransmitterBusOff
    } else if copies.iter().any(|&c| c > 1) && error_passive(case, run, 0) {
        Outcome::PassiveTransmitterRepeated
    } else if copies.iter().any(|&c| c > 1) {
        Outcome::Duplicate
    } else if copies.contains(&0) && missing_only_at_passive_receivers(case, run, &copies) {
        Outcome::PassiveReceiverMissed
    } else if copies.contains(&0) && missing_only_where_cut_through_the_sof(case, &copies) {
        Outcome::CutReceiverMissed
    } else if copies.contains(&0) {
        Outcome::Omission
    } else if any_error {
        Outcome::Recovered
    } else {
        Outcome::NoEffect
    };
    if outcome == Outcome::Corrupted && !golden_decoder_accepts_corruption(case) {
        violations.push(format!(
            "a node delivered a frame that was not sent: {:?}",
            run.nodes
                .iter()
                .map(|n| n.received.iter().map(|f| f.to_string()).collect::<Vec<_>>())
                .collect::<Vec<_>>()
        ));
    }
    if matches!(outcome, Outcome::Duplicate | Outcome::Omission)
        && !in_last_eof_bits(case)
        && !flag_starts_in_last_eof_bit(case, run)
    {
        violations.push(format!(
            "receivers disagree ({outcome:?}, copies {copies:?}) for a fault outside the last EOF bits"
        ));
    }
    if outcome != Outcome::TransmitterBusOff && !run.transmitted {
        violations.push("node 0's request did not end with success".into());
    }
    match &case.injection {
        Some(Injection::Bit(fault)) => {
            compare_with_reference(case, Some(fault), run, &mut violations)
        }
        None => compare_with_reference(case, None, run, &mut violations),
        Some(Injection::Glitch { .. }) => {}
    }
    if case.injection.is_none() && outcome != Outcome::NoEffect {
        violations.push(format!("a fault-free frame gave {outcome:?}"));
    }
    Verdict {
        outcome,
        violations,
    }
}

/// Whether node `n` was error passive at the start or at the end of the run.
fn error_passive(case: &Case, run: &Run, n: usize) -> bool {
    case.rec[n] >= 128 || case.tec[n] >= 128 || run.nodes[n].error_passive
}

/// Whether every receiver without the frame is error passive.
fn missing_only_at_passive_receivers(case: &Case, run: &Run, copies: &[usize]) -> bool {
    copies
        .iter()
        .enumerate()
        .all(|(i, &c)| c > 0 || error_passive(case, run, i + 1))
}

/// Whether every receiver without the frame is the one whose receiver was cut from the bus (reading
/// recessive) from the SOF on: it never saw the frame start.
fn missing_only_where_cut_through_the_sof(case: &Case, copies: &[usize]) -> bool {
    let Some(Injection::Bit(Fault {
        bit: 0,
        node: Some(cut),
        kind: FaultKind::Recessive,
        ..
    })) = case.injection
    else {
        return false;
    };
    copies
        .iter()
        .enumerate()
        .all(|(i, &c)| c > 0 || i + 1 == cut)
}

/// Whether CAN itself cannot detect the fault: the golden decoder accepts the frame's bits with the
/// fault applied as a different valid frame (a fault that moves the stuffing can escape the CRC).
fn golden_decoder_accepts_corruption(case: &Case) -> bool {
    let Some(Injection::Bit(fault)) = &case.injection else {
        return false;
    };
    let mut bits = encode(&case.frame).bits;
    if fault.bit >= bits.len() {
        return false;
    }
    for bit in fault.bit..(fault.bit + fault.bits).min(bits.len()) {
        let level = match fault.kind {
            FaultKind::Flip => !bits[bit],
            FaultKind::Dominant => DOMINANT,
            FaultKind::Recessive => !DOMINANT,
            // Only the transmitter's missing drive changes the frame's bits.
            FaultKind::Disconnected if fault.node == Some(0) => !DOMINANT,
            FaultKind::Disconnected => bits[bit],
        };
        bits.set(bit, level);
    }
    decode(&bits).is_ok_and(|d| d.frame != case.frame)
}

/// Whether the bus shows the first attempt's EOF recessive up to bit 6 and dominant in bit 7: an error
/// flag that starts in the last EOF bit, wherever the fault was (e.g. a receiver that lost the SOF
/// finds its CRC error one bit late). Receivers that took the frame at EOF bit 6 keep it while the
/// transmitter repeats it: the known inconsistency.
fn flag_starts_in_last_eof_bit(case: &Case, run: &Run) -> bool {
    let encoded = encode(&case.frame);
    let eof = |i| {
        encoded
            .position(Field::Eof, i)
            .expect("every frame has 7 EOF bits")
    };
    let recessive_until_6 = (eof(0)..eof(6)).all(|k| run.bus.get(k) == Some(&!DOMINANT));
    recessive_until_6 && run.bus.get(eof(6)) == Some(&DOMINANT)
}

/// Whether the fault hits EOF bit 6 or 7 of the first attempt, where CAN nodes may disagree.
fn in_last_eof_bits(case: &Case) -> bool {
    let Some(bit) = case.injection.as_ref().map(Injection::bit) else {
        return false;
    };
    let encoded = encode(&case.frame);
    let eof6 = encoded
        .position(Field::Eof, 5)
        .expect("every frame has 7 EOF bits");
    bit == eof6 || bit == eof6 + 1
}

/// Compares the bus, the deliveries, the error kinds and every node's TEC, REC and error state
/// (active / passive / bus-off) at the end of `run` with the golden model's for the same case.
fn compare_with_reference(
    case: &Case,
    fault: Option<&Fault>,
    run: &Run,
    violations: &mut Vec<String>,
) {
    let golden = reference::simulate(&reference_scenario(case), fault, MAX_BITS);
    let common = golden.bus.len().min(run.bus.len());
    if let Some(k) = (0..common).find(|&k| golden.bus[k] != run.bus[k]) {
        violations.push(format!(
            "bus bit {k}: RTL {} golden {}",
            level_name(run.bus[k]),
            level_name(golden.bus[k])
        ));
    }
    if golden.transmitted != run.transmitted {
        violations.push(format!(
            "transmitted: RTL {} golden {}",
            run.transmitted, golden.transmitted
        ));
    }
    for (n, (rtl, gold)) in run.nodes.iter().zip(&golden.nodes).enumerate() {
        let gold_frames: Vec<Frame> = gold.received.iter().map(|(_, f)| *f).collect();
        if rtl.received != gold_frames {
            violations.push(format!(
                "node {n} received {} frames, golden {}",
                rtl.received.len(),
                gold_frames.len()
            ));
        }
        let rtl_kinds: Vec<u8> = rtl.errors.iter().map(|ecc| ecc >> 6).collect();
        let gold_kinds: Vec<u8> = gold.errors.iter().map(|(_, d)| ecc_type(*d)).collect();
        if rtl_kinds != gold_kinds {
            violations.push(format!(
                "node {n} error types (ECC 7..6): RTL {rtl_kinds:?} golden {gold_kinds:?}"
            ));
        }
        if (rtl.tec, rtl.rec, rtl.error_passive, rtl.bus_off)
            != (gold.tec, gold.rec, gold.error_passive, gold.bus_off)
        {
            violations.push(format!(
                "node {n} TEC/REC/passive/bus-off: RTL {}/{}/{}/{} golden {}/{}/{}/{}",
                rtl.tec,
                rtl.rec,
                rtl.error_passive,
                rtl.bus_off,
                gold.tec,
                gold.rec,
                gold.error_passive,
                gold.bus_off
            ));
        }
    }
}

fn level_name(level: bool) -> &'static str {
    if level == DOMINANT {
        "dominant"
    } else {
        "recessive"
    }
}

/// SJA1000 ECC error type (bits 7..6) of a detected error.
fn ecc_type(detected: Detected) -> u8 {
    match detected {
        Detected::Bit => 0,
        Detected::Form => 1,
        Detected::Stuff => 2,
        Detected::Crc | Detected::Ack => 3,
    }
}

/// A random frame: standard or extended, data (DLC 0..8, sometimes 9..15) or remote.
pub fn random_frame(rng: &mut Rng) -> Frame {
    let id = if rng.chance(50) {
        Id::extended(rng.below(1 << 29) as u32)
    } else {
        Id::standard(rng.below(1 << 11) as u16)
    }
    .expect("identifier in range");
    let dlc = if rng.chance(10) {
        9 + rng.below(7) as u8
    } else {
        rng.below(9) as u8
    };
    if rng.chance(10) {
        return Frame::remote(id, dlc).expect("DLC in range");
    }
    let data: Vec<u8> = (0..dlc.min(8)).map(|_| rng.next_u64() as u8).collect();
    Frame::data_with_dlc(id, dlc, &data).expect("DLC in range")
}

/// A random case: random frame, error counters (mostly 0, sometimes error passive or close to
/// bus-off), and one fault in the frame, its ACK, EOF or intermission.
pub fn random_case(rng: &mut Rng) -> Case {
    let frame = random_frame(rng);
    let mut tec = [0u8; NODES];
    let mut rec = [0u8; NODES];
    if rng.chance(30) {
        tec[0] = rng.below(251) as u8;
        for r in rec.iter_mut() {
            *r = rng.below(200) as u8;
        }
    }
    let bits = encode(&frame).len() + 3;
    let bit = rng.below(bits as u64) as usize;
    let node = if rng.chance(50) {
        None
    } else {
        Some(rng.below(NODES as u64) as usize)
    };
    let injection = if rng.chance(10) {
        // A node cut from the bus for a while: its receiver reads recessive, or its drive does not
        // reach the bus; long enough to take an active transmitter to error passive (17 bits).
        let kind = if rng.chance(50) {
            FaultKind::Recessive
        } else {
            FaultKind::Disconnected
        };
        Injection::Bit(Fault {
            bit,
            bits: 2 + rng.below(MAX_CUT_BITS - 1) as usize,
            node: Some(rng.below(NODES as u64) as usize),
            kind,
        })
    } else if rng.chance(80) {
        let kind = match rng.below(5) {
            0 => FaultKind::Dominant,
            1 => FaultKind::Recessive,
            _ => FaultKind::Flip,
        };
        Injection::Bit(Fault::single(bit, node, kind))
    } else {
        let quanta_per_bit = campaign_btr().quanta_per_bit() as u64;
        Injection::Glitch {
            bit,
            from_tq: rng.below(quanta_per_bit) as u32,
            quanta: 1 + rng.below(4) as u32,
            node,
            level: rng.chance(50),
        }
    };
    Case {
        frame,
        tec,
        rec,
        injection: Some(injection),
    }
}

/// Counts per outcome and the cases that broke a rule.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    /// Cases run.
    pub cases: usize,
    /// Cases per outcome.
    pub outcomes: BTreeMap<Outcome, usize>,
    /// (case index, violations) of every case that broke a rule.
    pub failures: Vec<(u64, Vec<String>)>,
}

/// Runs cases `0..count` of the campaign with `seed` on `threads` threads, the cores on `model`;
/// `progress` is called with the number of cases done from time to time.
pub fn run_campaign(
    seed: u64,
    count: u64,
    runner: Runner,
    threads: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Summary, String> {
    run_campaign_shard(seed, count, Shard::WHOLE, runner, threads, progress)
}

/// Runs the cases of `0..count` that fall to `shard` (case i is the same case whatever the
/// sharding: it is drawn from `seed` and i alone); an error if the cores cannot run on `model`.
pub fn run_campaign_shard(
    seed: u64,
    count: u64,
    shard: Shard,
    runner: Runner,
    threads: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Summary, String> {
    // Refused once here rather than by every worker's first case.
    match runner {
        Runner::Lanes => LaneRunner::new()
            .map(drop)
            .map_err(|e| format!("{e} (the campaign's --runner engine needs no lane model)")),
        Runner::Engine(model) => CoreModel::new(model).map(drop).map_err(|e| e.to_string()),
    }?;
    let next = AtomicUsize::new(0);
    let next_case = || {
        let index = shard.case(next.fetch_add(1, Ordering::Relaxed) as u64);
        (index < count).then(|| (index, random_case(&mut Rng::for_case(seed, index))))
    };
    let summary = Mutex::new(Summary::default());
    let record = |index: u64, case: &Case, run: &Run| {
        let verdict = check(case, run);
        let mut s = summary.lock().expect("no worker panicked");
        s.cases += 1;
        *s.outcomes.entry(verdict.outcome).or_default() += 1;
        if !verdict.violations.is_empty() {
            s.failures.push((index, verdict.violations));
        }
        let done = s.cases as u64;
        drop(s);
        progress(done);
    };
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            scope.spawn(|| match runner {
                Runner::Lanes => {
                    let mut lanes = LaneRunner::new().expect("the lane model runs (checked above)");
                    lanes.run(next_case, |index, case, run| record(index, &case, &run));
                }
                Runner::Engine(model) => {
                    while let Some((index, case)) = next_case() {
                        let run = run_rtl_on(&case, model, None)
                            .expect("the engine runs (checked above)");
                        record(index, &case, &run);
                    }
                }
            });
        }
    });
    let mut summary = summary.into_inner().expect("no worker panicked");
    summary.failures.sort_by_key(|(i, _)| *i);
    Ok(summary)
}

/// Plays `cases` as [`run_rtl`] does, 64 at a time in the lanes of the lane model (the CAN core
/// mapped to gates, [`crate::compiled::lane_core`]); the runs in the order of `cases`. An error if
/// the lane model does not match `rtl/`.
pub fn run_rtl_lanes(cases: &[Case]) -> Result<Vec<Run>, EngineError> {
    let mut runner = LaneRunner::new()?;
    let mut runs: Vec<Option<Run>> = vec![None; cases.len()];
    let mut queue = cases.iter().cloned().enumerate();
    runner.run(
        || queue.next().map(|(i, case)| (i as u64, case)),
        |i, _, run| runs[i as usize] = Some(run),
    );
    Ok(runs
        .into_iter()
        .map(|run| run.expect("every case ran"))
        .collect())
}

/// The summary as text: cases per outcome, then every case that broke a rule.
pub fn format_summary(summary: &Summary) -> String {
    let mut out = format!("{} cases\n", summary.cases);
    for (outcome, count) in &summary.outcomes {
        out += &format!(
            "  {:<18} {count:>8}  {:6.2} %\n",
            format!("{outcome:?}"),
            100.0 * *count as f64 / summary.cases.max(1) as f64
        );
    }
    out += &format!("cases that broke a rule: {}\n", summary.failures.len());
    for (index, violations) in summary.failures.iter().take(20) {
        out += &format!("  case {index}: {}\n", violations.join("; "));
    }
    out
}

/// A case and its run in detail, beside the golden model's (for `cansim campaign --case`): the bus
/// bit by bit (`0` dominant, `1` recessive, `^` under the first difference), then per node the
/// deliveries, errors and counters.
pub fn describe(case: &Case, run: &Run) -> String {
    let mut out = format!(
        "frame {} ({} bits), TEC {:?}, REC {:?}\nfault {:?}\n",
        case.frame,
        encode(&case.frame).len(),
        case.tec,
        case.rec,
        case.injection
    );
    let golden = match &case.injection {
        Some(Injection::Bit(fault)) => Some(reference::simulate(
            &reference_scenario(case),
            Some(fault),
            MAX_BITS,
        )),
        None => Some(reference::simulate(
            &reference_scenario(case),
            None,
            MAX_BITS,
        )),
        Some(Injection::Glitch { .. }) => None,
    };
    let bits = |bus: &[bool]| {
        bus.iter()
            .map(|&b| if b { '1' } else { '0' })
            .collect::<String>()
    };
    out += &format!("RTL bus    {}\n", bits(&run.bus));
    if let Some(g) = &golden {
        out += &format!("golden bus {}\n", bits(&g.bus));
        if let Some(k) = run.bus.iter().zip(&g.bus).position(|(a, b)| a != b) {
            out += &format!("           {}^ bit {k}\n", " ".repeat(k));
        }
    }
    for (n, node) in run.nodes.iter().enumerate() {
        out +=
            &format!(
            "node {n} RTL:    received {:?}, errors {:02X?}, TEC {} REC {} passive {} bus-off {}\n",
            node.received.iter().map(|f| f.to_string()).collect::<Vec<_>>(),
            node.errors,
            node.tec,
            node.rec,
            node.error_passive,
            node.bus_off
        );
        if let Some(g) = golden.as_ref().map(|g| &g.nodes[n]) {
            out += &format!(
                "node {n} golden: received {:?}, errors {:?}, TEC {} REC {} passive {} bus-off {}\n",
                g.received.iter().map(|(at, f)| format!("{f}@{at}")).collect::<Vec<_>>(),
                g.errors,
                g.tec,
                g.rec,
                g.error_passive,
                g.bus_off
            );
        }
    }
    out
}
