//! Equivalence harness: the same per-cycle stimulus applied to N rust-hdl [`CanController`] models
//! and to N instances of the generated Verilog (`can_controller`, run by Icarus), with the outputs
//! of every node recorded after every rising edge and compared.
//!
//! Model of the bench (identical on both sides, deterministic):
//! - all nodes run on the same clock; cycle `k` ends with rising edge `k`;
//! - the inputs of cycle `k` (`reset`, `addr`, `wdata`, `we`, `re`, and `rx`) are applied while the
//!   clock is low, before edge `k`;
//! - the bus of cycle `k` is the wired-AND of every node's registered `tx` after edge `k − 1`
//!   (recessive in cycle 0); node `n` sees `rx = bus & !force_dominant`, so an injected dominant
//!   level reaches only the nodes whose `force_dominant` is set in that cycle;
//! - the outputs `tx`, `rdata`, `irq_n` and `clkout` are sampled after edge `k` with the clock low
//!   again and before the inputs of cycle `k + 1` change (rust-hdl: after
//!   [`clock_cycle_with`]; Verilog: clock high for 1 time unit, low, then sampled), so `clkout` with
//!   CDR divider code 7 (the clock itself) reads 0 on both sides.
//!
//! [`StimulusBuilder`] writes stimuli as host programs: register accesses at a cursor, idle gaps,
//! configuration, transmission, RX buffer reads and forced-dominant bursts. [`run_rust`],
//! [`run_verilated`] (the simulator's Verilator engine) and [`run_icarus`] (or a [`VerilogBench`]
//! compiled once and run many times, in Icarus or Verilator) produce [`Trace`]s, and
//! [`first_mismatch`] names the first differing cycle, node and signals.

use std::fmt::{self, Write as _};
use std::path::{Path, PathBuf};
use std::process::Command;

use golden::frame::Frame;
use rtl::can_controller::CanController;
use rtl::registers::{mode, pelican};
use rust_hdl::prelude::*;
use sim::compiled::CompiledController;
use sim::host::sja1000::{self, PelicanSetup, BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ};
use sim::host::RegisterPort;
use sim::nodes::controller_node::rust_hdl_cycle;
pub use sim::verilated::verilog::{controller_verilog, TOP_MODULE};
use sim::verilated::{EngineError, PortInputs, PortOutputs, VerilatedController};

/// OCR normal output mode (SJA1000 data sheet, OCR.1..0 = 10), as the Linux driver writes it.
const OCR_NORMAL_MODE: u8 = 0x02;

/// A node's host port inside a [`StimulusBuilder`] ([`StimulusBuilder::port`]). Only sequences that
/// do not act on what they read fit here: a read is one cycle of the stimulus and returns 0, its
/// value is known only when the stimulus runs (the harness compares it between the models).
pub struct ScriptPort<'b> {
    builder: &'b mut StimulusBuilder,
    node: usize,
}

impl RegisterPort for ScriptPort<'_> {
    fn write(&mut self, addr: u8, value: u8) {
        self.builder.write(self.node, addr, value);
    }

    fn read(&mut self, addr: u8) -> u8 {
        self.builder.read(self.node, addr);
        0
    }
}

/// Clock cycles per bit with [`BTR0_500K_AT_16MHZ`] and [`BTR1_500K_AT_16MHZ`].
pub const CLOCKS_PER_BIT: usize = 32;

// ---- stimulus ---------------------------------------------------------------------------------

/// The inputs of one node in one cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeInputs {
    /// Synchronous reset.
    pub reset: bool,
    /// Register address.
    pub addr: u8,
    /// Write data.
    pub wdata: u8,
    /// Write strobe.
    pub we: bool,
    /// Read strobe.
    pub re: bool,
    /// This node's `rx` is forced dominant in this cycle (whatever the bus is).
    pub force_dominant: bool,
}

impl NodeInputs {
    /// The controller's port inputs with the bus at `bus` (`rx` dominant when forced).
    fn ports(&self, bus: bool) -> PortInputs {
        PortInputs {
            reset: self.reset,
            addr: self.addr,
            wdata: self.wdata,
            we: self.we,
            re: self.re,
            rx: bus && !self.force_dominant,
        }
    }

    /// The 20-bit word of the Verilog stimulus file: `{reset, we, re, force, addr, wdata}`.
    fn word(&self) -> u32 {
        u32::from(self.reset) << 19
            | u32::from(self.we) << 18
            | u32::from(self.re) << 17
            | u32::from(self.force_dominant) << 16
            | u32::from(self.addr) << 8
            | u32::from(self.wdata)
    }
}

/// The inputs of every node in one cycle.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CycleInputs {
    /// One entry per node.
    pub nodes: Vec<NodeInputs>,
}

/// A complete stimulus: `nodes` controllers on one bus, one [`CycleInputs`] per clock cycle.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stimulus {
    /// Number of controllers.
    pub nodes: usize,
    /// The inputs, cycle by cycle.
    pub cycles: Vec<CycleInputs>,
}

impl Stimulus {
    /// Number of cycles.
    pub fn len(&self) -> usize {
        self.cycles.len()
    }

    /// No cycles at all.
    pub fn is_empty(&self) -> bool {
        self.cycles.is_empty()
    }

    /// Checks the shape (every cycle has `nodes` entries) and the port contract (`we` and `re`
    /// never together).
    pub fn validate(&self) -> Result<(), String> {
        if self.nodes == 0 {
            return Err("a stimulus needs at least one node".into());
        }
        for (k, cycle) in self.cycles.iter().enumerate() {
            if cycle.nodes.len() != self.nodes {
                return Err(format!(
                    "cycle {k}: {} node entries, expected {}",
                    cycle.nodes.len(),
                    self.nodes
                ));
            }
            if let Some(n) = cycle.nodes.iter().position(|i| i.we && i.re) {
                return Err(format!("cycle {k} node {n}: we and re together"));
            }
        }
        Ok(())
    }

    /// The host accesses, resets and forced bits of `cycles` (clamped to the stimulus), one line
    /// per cycle that has any, for failure messages.
    pub fn describe(&self, cycles: std::ops::Range<usize>) -> String {
        let mut out = String::new();
        let end = cycles.end.min(self.len());
        for k in cycles.start.min(end)..end {
            let mut line = String::new();
            for (n, i) in self.cycles[k].nodes.iter().enumerate() {
                if i.reset {
                    write!(line, " n{n}:reset").unwrap();
                }
                if i.we {
                    write!(line, " n{n}:W[{}]={:#04x}", i.addr, i.wdata).unwrap();
                }
                if i.re {
                    write!(line, " n{n}:R[{}]", i.addr).unwrap();
                }
                if i.force_dominant {
                    write!(line, " n{n}:rx=0").unwrap();
                }
            }
            if !line.is_empty() {
                writeln!(out, "  cycle {k}:{line}").unwrap();
            }
        }
        out
    }
}

/// One host access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Write `value` to `addr`.
    Write {
        /// Register address.
        addr: u8,
        /// Value.
        value: u8,
    },
    /// Read `addr`.
    Read {
        /// Register address.
        addr: u8,
    },
}

#[derive(Clone, Copy, Debug, Default)]
struct Slot {
    access: Option<Access>,
    reset: bool,
    force_dominant: bool,
}

/// Builds a [`Stimulus`] from host programs.
///
/// The builder has a cursor (a cycle number). Every helper places its cycles from the cursor on
/// and moves the cursor past them; [`StimulusBuilder::seek`] moves it back to overlay another
/// node's program in the same cycles (a node can have one access per cycle: placing a second one
/// panics). Cycles without an access keep the node's previous `addr` and `wdata` with `we` and
/// `re` low. [`StimulusBuilder::build`] ends the stimulus at the furthest cycle used or the cursor.
#[derive(Clone, Debug)]
pub struct StimulusBuilder {
    nodes: usize,
    slots: Vec<Vec<Slot>>,
    cursor: usize,
}

impl StimulusBuilder {
    /// An empty stimulus for `nodes` controllers.
    pub fn new(nodes: usize) -> StimulusBuilder {
        assert!(nodes > 0, "at least one node");
        StimulusBuilder {
            nodes,
            slots: Vec::new(),
            cursor: 0,
        }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.nodes
    }

    /// The cursor.
    pub fn now(&self) -> usize {
        self.cursor
    }

    /// Cycles used so far (the furthest cycle written, plus one).
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Nothing placed yet.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Moves the cursor to `cycle`.
    pub fn seek(&mut self, cycle: usize) -> &mut Self {
        self.cursor = cycle;
        self
    }

    /// Runs each branch from the current cursor (e.g. one host program per node, side by side) and
    /// leaves the cursor after the longest one.
    pub fn concurrently(
        &mut self,
        branches: &mut [&mut dyn FnMut(&mut StimulusBuilder)],
    ) -> &mut Self {
        let start = self.cursor;
        let mut end = start;
        for branch in branches.iter_mut() {
            self.cursor = start;
            branch(self);
            end = end.max(self.cursor);
        }
        self.cursor = end;
        self
    }

    fn slot(&mut self, cycle: usize, node: usize) -> &mut Slot {
        assert!(node < self.nodes, "node {node} of {}", self.nodes);
        if self.slots.len() <= cycle {
            self.slots
                .resize(cycle + 1, vec![Slot::default(); self.nodes]);
        }
        &mut self.slots[cycle][node]
    }

    /// Places `access` of `node` at `cycle` (the cursor does not move); panics if that node already
    /// has an access there.
    pub fn access_at(&mut self, cycle: usize, node: usize, access: Access) -> &mut Self {
        let slot = self.slot(cycle, node);
        if let Some(old) = slot.access {
            panic!("cycle {cycle} node {node}: {access:?} placed over {old:?}");
        }
        slot.access = Some(access);
        self
    }

    /// One access of `node` at the cursor; the cursor moves on by one cycle.
    pub fn access(&mut self, node: usize, access: Access) -> &mut Self {
        self.access_at(self.cursor, node, access);
        self.cursor += 1;
        self
    }

    /// Writes `value` to `addr` of `node` (one cycle).
    pub fn write(&mut self, node: usize, addr: u8, value: u8) -> &mut Self {
        self.access(node, Access::Write { addr, value })
    }

    /// Reads `addr` of `node` (one cycle).
    pub fn read(&mut self, node: usize, addr: u8) -> &mut Self {
        self.access(node, Access::Read { addr })
    }

    /// Reads each address of `addrs` from `node`, one per cycle.
    pub fn reads(&mut self, node: usize, addrs: impl IntoIterator<Item = u8>) -> &mut Self {
        for addr in addrs {
            self.read(node, addr);
        }
        self
    }

    /// Writes `value` to `addr` of every node in the same cycle.
    pub fn write_all(&mut self, addr: u8, value: u8) -> &mut Self {
        for node in 0..self.nodes {
            self.access_at(self.cursor, node, Access::Write { addr, value });
        }
        self.cursor += 1;
        self
    }

    /// `cycles` cycles without new accesses.
    pub fn idle(&mut self, cycles: usize) -> &mut Self {
        if cycles > 0 {
            self.slot(self.cursor + cycles - 1, 0);
        }
        self.cursor += cycles;
        self
    }

    /// `bits` bit times of [`CLOCKS_PER_BIT`] cycles without new accesses.
    pub fn idle_bits(&mut self, bits: usize) -> &mut Self {
        self.idle(bits * CLOCKS_PER_BIT)
    }

    /// Idles for the wire length of `frame` (stuff bits counted, SOF to EOF) plus the
    /// intermission and two bits of margin, at [`CLOCKS_PER_BIT`]: long enough for one
    /// transmission of `frame` requested just before on an idle bus.
    pub fn idle_frame(&mut self, frame: &Frame) -> &mut Self {
        self.idle_bits(golden::frame::encode(frame).len() + 3 + 2)
    }

    /// Hardware reset of every node for `cycles` cycles.
    pub fn reset(&mut self, cycles: usize) -> &mut Self {
        for k in self.cursor..self.cursor + cycles {
            for node in 0..self.nodes {
                self.slot(k, node).reset = true;
            }
        }
        self.cursor += cycles;
        self
    }

    /// Hardware reset of `node` alone for `cycles` cycles.
    pub fn reset_node(&mut self, node: usize, cycles: usize) -> &mut Self {
        for k in self.cursor..self.cursor + cycles {
            self.slot(k, node).reset = true;
        }
        self.cursor += cycles;
        self
    }

    /// Forces `node`'s `rx` dominant for `cycles` cycles (an error burst seen by that node only).
    pub fn force_dominant(&mut self, node: usize, cycles: usize) -> &mut Self {
        for k in self.cursor..self.cursor + cycles {
            self.slot(k, node).force_dominant = true;
        }
        self.cursor += cycles;
        self
    }

    /// Puts `node` in reset mode and configures PeliCAN, 500 kbit/s at 16 MHz ([`BTR0_500K_AT_16MHZ`],
    /// [`BTR1_500K_AT_16MHZ`]), an open dual filter, OCR normal mode and every interrupt enabled; the node
    /// stays in reset mode ([`StimulusBuilder::leave_reset_mode`]).
    pub fn configure_pelican(&mut self, node: usize) -> &mut Self {
        self.configure_pelican_with(node, BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ)
    }

    /// [`StimulusBuilder::configure_pelican`] with other bit timing registers.
    pub fn configure_pelican_with(&mut self, node: usize, btr0: u8, btr1: u8) -> &mut Self {
        sja1000::set_up_pelican(&mut self.port(node), &PelicanSetup::open(btr0, btr1));
        self.write(node, pelican::OCR, OCR_NORMAL_MODE)
    }

    /// `node`'s host port as a [`RegisterPort`] that writes the accesses of the SJA1000 host
    /// sequences (`sim::host::sja1000`) into this stimulus, one cycle each from the current one.
    pub fn port(&mut self, node: usize) -> ScriptPort<'_> {
        ScriptPort {
            builder: self,
            node,
        }
    }

    /// Writes MOD = `mode_bits` without RM (operating mode; LOM/STM/AFM take effect when written
    /// from reset mode).
    pub fn leave_reset_mode(&mut self, node: usize, mode_bits: u8) -> &mut Self {
        self.write(node, pelican::MOD, mode_bits & !mode::RM)
    }

    /// Writes the TX buffer bytes `bytes` (frame information first) at 16, 17, …
    /// Writes `frame` into `node`'s TX buffer and `cmd` (e.g. TR) into CMR.
    pub fn transmit(&mut self, node: usize, frame: &Frame, cmd: u8) -> &mut Self {
        sja1000::transmit(&mut self.port(node), frame, cmd);
        self
    }

    /// Reads the whole RX window (16..28) of `node`.
    pub fn read_rx_buffer(&mut self, node: usize) -> &mut Self {
        self.reads(node, pelican::FRAME..=pelican::FRAME_LAST)
    }

    /// Releases `node`'s head message (CMR = RRB).
    pub fn release_rx_buffer(&mut self, node: usize) -> &mut Self {
        sja1000::release_rx(&mut self.port(node));
        self
    }

    /// Reads the RX window of `node` and releases the message.
    pub fn read_and_release(&mut self, node: usize) -> &mut Self {
        self.read_rx_buffer(node).release_rx_buffer(node)
    }

    /// Reads the whole RX FIFO RAM window (32..95) of `node`.
    pub fn read_rx_ram(&mut self, node: usize) -> &mut Self {
        self.reads(node, pelican::RX_RAM..=pelican::RX_RAM_LAST)
    }

    /// Reads the status and capture registers of `node`: SR, IR, ALC, ECC, RXERR, TXERR, RMC, RBSA.
    pub fn read_status(&mut self, node: usize) -> &mut Self {
        self.reads(
            node,
            [
                pelican::SR,
                pelican::IR,
                pelican::ALC,
                pelican::ECC,
                pelican::RXERR,
                pelican::TXERR,
                pelican::RMC,
                pelican::RBSA,
            ],
        )
    }

    /// The stimulus: every placed cycle, and idle cycles up to the cursor.
    pub fn build(&self) -> Stimulus {
        let len = self.slots.len().max(self.cursor);
        let mut held = vec![NodeInputs::default(); self.nodes];
        let mut cycles = Vec::with_capacity(len);
        let idle = vec![Slot::default(); self.nodes];
        for k in 0..len {
            let slots = self.slots.get(k).unwrap_or(&idle);
            let nodes = slots
                .iter()
                .zip(held.iter_mut())
                .map(|(slot, held)| {
                    let mut i = NodeInputs {
                        reset: slot.reset,
                        addr: held.addr,
                        wdata: held.wdata,
                        we: false,
                        re: false,
                        force_dominant: slot.force_dominant,
                    };
                    match slot.access {
                        Some(Access::Write { addr, value }) => {
                            i.we = true;
                            i.addr = addr;
                            i.wdata = value;
                        }
                        Some(Access::Read { addr }) => {
                            i.re = true;
                            i.addr = addr;
                        }
                        None => {}
                    }
                    *held = i;
                    i
                })
                .collect();
            cycles.push(CycleInputs { nodes });
        }
        Stimulus {
            nodes: self.nodes,
            cycles,
        }
    }
}

// ---- traces -----------------------------------------------------------------------------------

/// `unknown` bits of [`NodeOutputs`]: `rdata` bits 7..0.
pub const UNKNOWN_RDATA: u16 = 0x00FF;
/// `unknown` bit of `tx`.
pub const UNKNOWN_TX: u16 = 0x0100;
/// `unknown` bit of `irq_n`.
pub const UNKNOWN_IRQ_N: u16 = 0x0200;
/// `unknown` bit of `clkout`.
pub const UNKNOWN_CLKOUT: u16 = 0x0400;

/// The outputs of one node after one rising edge.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeOutputs {
    /// Bus output.
    pub tx: bool,
    /// Read data.
    pub rdata: u8,
    /// Interrupt, active low.
    pub irq_n: bool,
    /// Clock output.
    pub clkout: bool,
    /// Bits that were X or Z in Verilog ([`UNKNOWN_RDATA`], [`UNKNOWN_TX`], …); their value bits
    /// are 0. Always 0 in the rust-hdl model.
    pub unknown: u16,
}

impl NodeOutputs {
    fn bit(value: bool, unknown: bool) -> char {
        match (unknown, value) {
            (true, _) => 'x',
            (false, true) => '1',
            (false, false) => '0',
        }
    }

    fn tx_str(&self) -> String {
        Self::bit(self.tx, self.unknown & UNKNOWN_TX != 0).into()
    }

    fn irq_n_str(&self) -> String {
        Self::bit(self.irq_n, self.unknown & UNKNOWN_IRQ_N != 0).into()
    }

    fn clkout_str(&self) -> String {
        Self::bit(self.clkout, self.unknown & UNKNOWN_CLKOUT != 0).into()
    }

    fn rdata_str(&self) -> String {
        if self.unknown & UNKNOWN_RDATA == 0 {
            format!("{:#04x}", self.rdata)
        } else {
            let bits: String = (0..8)
                .rev()
                .map(|b| Self::bit(self.rdata >> b & 1 != 0, self.unknown >> b & 1 != 0))
                .collect();
            format!("0b{bits}")
        }
    }
}

impl fmt::Display for NodeOutputs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "tx={} rdata={} irq_n={} clkout={}",
            self.tx_str(),
            self.rdata_str(),
            self.irq_n_str(),
            self.clkout_str()
        )
    }
}

/// The outputs of every node after every rising edge.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Trace {
    /// Where the trace comes from ("rust-hdl", "Icarus"), for messages.
    pub source: String,
    /// Number of nodes.
    pub nodes: usize,
    /// Cycle-major: the outputs of node `n` after edge `k` are at `k * nodes + n`.
    pub outputs: Vec<NodeOutputs>,
}

impl Trace {
    /// The trace from cycle `first` on (cycle `first` becomes cycle 0).
    pub fn from_cycle(&self, first: usize) -> Trace {
        Trace {
            source: self.source.clone(),
            nodes: self.nodes,
            outputs: self.outputs[(first * self.nodes).min(self.outputs.len())..].to_vec(),
        }
    }

    /// Number of cycles.
    pub fn cycles(&self) -> usize {
        self.outputs.len().checked_div(self.nodes).unwrap_or(0)
    }

    /// The outputs of `node` after edge `cycle`.
    pub fn at(&self, cycle: usize, node: usize) -> NodeOutputs {
        self.outputs[cycle * self.nodes + node]
    }

    /// Cycles in which the bus (wired-AND of every `tx`) was dominant.
    pub fn dominant_cycles(&self) -> usize {
        self.outputs
            .chunks(self.nodes.max(1))
            .filter(|c| c.iter().any(|o| !o.tx))
            .count()
    }

    /// Cycles in which `node`'s `irq_n` was low.
    pub fn irq_cycles(&self, node: usize) -> usize {
        (0..self.cycles())
            .filter(|&k| !self.at(k, node).irq_n)
            .count()
    }
}

/// One register read of a stimulus with the value its trace shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadResult {
    /// The cycle of the `re` strobe (the value is `rdata` after its edge).
    pub cycle: usize,
    /// The node.
    pub node: usize,
    /// The register address.
    pub addr: u8,
    /// `rdata` after the edge.
    pub value: NodeOutputs,
}

/// Every read of `stim` with its result in `trace`, in cycle order.
pub fn read_results(stim: &Stimulus, trace: &Trace) -> Vec<ReadResult> {
    let mut reads = Vec::new();
    for (cycle, inputs) in stim.cycles.iter().enumerate().take(trace.cycles()) {
        for (node, i) in inputs.nodes.iter().enumerate() {
            if i.re {
                reads.push(ReadResult {
                    cycle,
                    node,
                    addr: i.addr,
                    value: trace.at(cycle, node),
                });
            }
        }
    }
    reads
}

/// The first difference between two traces: cycle, node, and each differing signal with both
/// values; or a difference in node count or length (after the common cycles agree).
pub fn first_mismatch(a: &Trace, b: &Trace) -> Option<String> {
    if a.nodes != b.nodes {
        return Some(format!(
            "{} has {} nodes, {} has {}",
            a.source, a.nodes, b.source, b.nodes
        ));
    }
    if let Some((k, n)) = first_difference(a, b) {
        let (x, y) = (a.at(k, n), b.at(k, n));
        let mut diffs = Vec::new();
        let mut compare = |name: &str, f: fn(&NodeOutputs) -> String| {
            let (u, v) = (f(&x), f(&y));
            if u != v {
                diffs.push(format!("{name}: {} {u}, {} {v}", a.source, b.source));
            }
        };
        compare("tx", NodeOutputs::tx_str);
        compare("rdata", NodeOutputs::rdata_str);
        compare("irq_n", NodeOutputs::irq_n_str);
        compare("clkout", NodeOutputs::clkout_str);
        return Some(format!(
            "first mismatch at cycle {k} (after rising edge {k}), node {n}: {}",
            diffs.join("; ")
        ));
    }
    if a.cycles() != b.cycles() {
        return Some(format!(
            "{} has {} cycles, {} has {} (the first {} agree)",
            a.source,
            a.cycles(),
            b.source,
            b.cycles(),
            a.cycles().min(b.cycles())
        ));
    }
    None
}

/// The first (cycle, node) whose outputs differ, over the cycles both traces have (`None` also
/// when the node counts differ).
pub fn first_difference(a: &Trace, b: &Trace) -> Option<(usize, usize)> {
    if a.nodes != b.nodes {
        return None;
    }
    let common = a.cycles().min(b.cycles()) * a.nodes;
    (0..common)
        .find(|&i| a.outputs[i] != b.outputs[i])
        .map(|i| (i / a.nodes, i % a.nodes))
}

// ---- rust-hdl ---------------------------------------------------------------------------------

/// Runs `stim` on `stim.nodes` rust-hdl controllers stepped directly.
pub fn run_rust(stim: &Stimulus) -> Trace {
    stim.validate().expect("stimulus");
    let n = stim.nodes;
    let mut uuts: Vec<CanController> = (0..n)
        .map(|_| {
            let mut uut = CanController::default();
            uut.connect_all();
            uut
        })
        .collect();
    // The inputs and rx last applied to each node (None: nothing applied yet, settle anyway).
    let mut applied: Vec<Option<PortInputs>> = vec![None; n];
    let mut bus = true;
    let mut outputs = Vec::with_capacity(stim.len() * n);
    for cycle in &stim.cycles {
        let mut next_bus = true;
        for ((uut, inputs), applied) in uuts.iter_mut().zip(&cycle.nodes).zip(&mut applied) {
            rust_hdl_cycle(uut, applied, inputs.ports(bus));
            let out = NodeOutputs {
                tx: uut.tx.val(),
                rdata: uut.rdata.val().to_u8(),
                irq_n: uut.irq_n.val(),
                clkout: uut.clkout.val(),
                unknown: 0,
            };
            next_bus &= out.tx;
            outputs.push(out);
        }
        bus = next_bus;
    }
    Trace {
        source: "rust-hdl".into(),
        nodes: n,
        outputs,
    }
}

/// Runs `stim` on the Verilator engine of the simulator ([`VerilatedController`]: the generated
/// Verilog compiled into a library, one call per cycle), with the same bench model as [`run_rust`].
pub fn run_verilated(stim: &Stimulus) -> Result<Trace, EngineError> {
    let models = (0..stim.nodes)
        .map(|_| VerilatedController::new())
        .collect::<Result<Vec<_>, _>>()?;
    Ok(run_word_models(stim, models, "verilated", |m, i| {
        m.cycle(i)
    }))
}

/// Checks the Verilator engine's quiet-edge skips on `stim`: every node is stepped cycle by cycle
/// (the reference, on the bus the stepped nodes make), and a second model of each node, given the
/// same inputs and bus, skips wherever it reports quiet cycles (as many as its inputs stay the
/// same; `traced`: as for a traced node, whose CLKOUT, segment and sample point must hold), then
/// must show the state ([`VerilatedController::quiet_state`]) and the outputs the stepped model
/// had after the same cycle. Returns the cycles skipped; the error names the first cycle at which
/// they differ.
pub fn verilated_skips_agree(stim: &Stimulus, traced: bool) -> Result<u64, String> {
    stim.validate()?;
    let new = || VerilatedController::new().map_err(|e| e.to_string());
    let mut stepped = (0..stim.nodes)
        .map(|_| new())
        .collect::<Result<Vec<_>, _>>()?;
    let mut inputs = vec![Vec::with_capacity(stim.len()); stim.nodes];
    let mut after = vec![Vec::with_capacity(stim.len()); stim.nodes];
    let mut bus = true;
    for step in &stim.cycles {
        let mut next_bus = true;
        for (node, (model, node_inputs)) in stepped.iter_mut().zip(&step.nodes).enumerate() {
            let ports = node_inputs.ports(bus);
            let out = model.cycle(ports);
            next_bus &= out.tx();
            inputs[node].push(ports);
            after[node].push((model.quiet_state(), out));
        }
        bus = next_bus;
    }
    let mut skipped = 0;
    for (node, (inputs, after)) in inputs.iter().zip(&after).enumerate() {
        let mut model = new()?;
        let mut cycle = 0;
        while cycle < inputs.len() {
            let ports = inputs[cycle];
            let holding = inputs[cycle..].iter().take_while(|&&p| p == ports).count() as u64;
            // Every stretch of two or more cycles, whatever the engine's minimum: the test is of
            // the load, not of when to use it.
            let quiet = model.quiet_cycles(ports, traced, 2).min(holding);
            if quiet >= 2 {
                model.skip(quiet, traced, false);
                skipped += quiet;
                cycle += quiet as usize;
            } else {
                model.cycle(ports);
                cycle += 1;
            }
            let reached = (model.quiet_state(), model.outputs());
            if reached != after[cycle - 1] {
                return Err(format!(
                    "node {node}, cycle {}: the skipping model has state {:#018x} and outputs \
                     {:?}, stepping gave {:#018x} and {:?}",
                    cycle - 1,
                    reached.0,
                    reached.1,
                    after[cycle - 1].0,
                    after[cycle - 1].1
                ));
            }
        }
    }
    Ok(skipped)
}

/// Runs `stim` on the compiled engine ([`sim::compiled`]): the Yosys netlist of the Verilog as
/// straight-line Rust; with `every_group`, every group of cells runs at every evaluation instead
/// of only those whose inputs changed.
pub fn run_compiled(stim: &Stimulus, every_group: bool) -> Result<Trace, EngineError> {
    let models = (0..stim.nodes)
        .map(|_| {
            CompiledController::new().map(|mut m| {
                m.set_every_group(every_group);
                m
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let source = if every_group {
        "compiled, every group"
    } else {
        "compiled"
    };
    Ok(run_word_models(stim, models, source, |m, i| m.cycle(i)))
}

/// Runs `stim` on models stepped by `cycle`, one per node, on a wired-AND bus.
fn run_word_models<M>(
    stim: &Stimulus,
    mut models: Vec<M>,
    source: &str,
    cycle: impl Fn(&mut M, PortInputs) -> PortOutputs,
) -> Trace {
    stim.validate().expect("stimulus");
    let mut bus = true;
    let mut outputs = Vec::with_capacity(stim.len() * stim.nodes);
    for step in &stim.cycles {
        let mut next_bus = true;
        for (model, inputs) in models.iter_mut().zip(&step.nodes) {
            let out = cycle(model, inputs.ports(bus));
            next_bus &= out.tx();
            outputs.push(NodeOutputs {
                tx: out.tx(),
                rdata: out.rdata(),
                irq_n: out.irq_n(),
                clkout: out.clkout(),
                unknown: 0,
            });
        }
        bus = next_bus;
    }
    Trace {
        source: source.into(),
        nodes: stim.nodes,
        outputs,
    }
}

// ---- Icarus -----------------------------------------------------------------------------------

/// Environment variable that lets a developer without Icarus Verilog skip the Verilog checks (CI never
/// sets it; `make tools` installs Icarus).
pub const SKIP_ICARUS_ENV: &str = "CANSIM_SKIP_ICARUS";

/// Whether the Icarus checks are skipped: `false` when `iverilog` and `vvp` run; `true` when they are
/// missing and [`SKIP_ICARUS_ENV`] is set (with a note naming `test`). Panics when they are missing
/// and the developer did not opt out, so a CI machine without Icarus fails instead of passing.
pub fn icarus_skipped(test: &str) -> bool {
    if Simulator::Icarus.available() {
        return false;
    }
    if std::env::var_os(SKIP_ICARUS_ENV).is_some() {
        eprintln!("{test}: skipped, iverilog/vvp not on PATH and {SKIP_ICARUS_ENV} set");
        return true;
    }
    panic!(
        "{test}: iverilog/vvp not on PATH: run `make tools`, or set {SKIP_ICARUS_ENV}=1 to skip"
    );
}

/// The Verilog testbench: `nodes` instances of [`TOP_MODULE`] on one bus, stimulus from `stim.hex`
/// (`+cycles=N` words per node), outputs written to `trace.txt`, one line per cycle; `+vcd` dumps
/// `equivalence.vcd`.
fn testbench(nodes: usize, max_cycles: usize) -> String {
    let words = (max_cycles * nodes).max(1);
    let mut tb = String::new();
    writeln!(tb, "// Generated by testbenches::equivalence.").unwrap();
    writeln!(tb, "module equivalence_tb;").unwrap();
    writeln!(tb, "    localparam NODES = {nodes};").unwrap();
    writeln!(tb, "    localparam WORDS = {words};").unwrap();
    writeln!(tb, "    reg clock = 1'b0;").unwrap();
    writeln!(tb, "    reg [19:0] stim [0:WORDS-1];").unwrap();
    writeln!(tb, "    reg bus;").unwrap();
    writeln!(tb, "    integer cycles, k, fd;").unwrap();
    for n in 0..nodes {
        writeln!(
            tb,
            "    reg reset_{n} = 1'b0, we_{n} = 1'b0, re_{n} = 1'b0, force_{n} = 1'b0, rx_{n} = 1'b1;\n\
             \x20   reg [7:0] addr_{n} = 8'h00, wdata_{n} = 8'h00;\n\
             \x20   wire tx_{n}, irq_n_{n}, clkout_{n};\n\
             \x20   wire [7:0] rdata_{n};\n\
             \x20   {TOP_MODULE} node_{n}(.clock(clock), .reset(reset_{n}), .addr(addr_{n}), \
             .wdata(wdata_{n}), .we(we_{n}), .re(re_{n}), .rdata(rdata_{n}), .rx(rx_{n}), \
             .tx(tx_{n}), .irq_n(irq_n_{n}), .clkout(clkout_{n}));"
        )
        .unwrap();
    }
    let all_tx: Vec<String> = (0..nodes).map(|n| format!("tx_{n}")).collect();
    let format: Vec<&str> = (0..nodes).map(|_| "%b%b%b%b").collect();
    let values: Vec<String> = (0..nodes)
        .map(|n| format!("tx_{n}, irq_n_{n}, clkout_{n}, rdata_{n}"))
        .collect();
    writeln!(
        tb,
        "    initial begin\n\
         \x20       if (!$value$plusargs(\"cycles=%d\", cycles)) cycles = 0;\n\
         \x20       if (cycles * NODES > WORDS) begin\n\
         \x20           $display(\"equivalence_tb: %0d cycles do not fit\", cycles);\n\
         \x20           $finish;\n\
         \x20       end\n\
         \x20       if (cycles > 0) $readmemh(\"stim.hex\", stim, 0, cycles * NODES - 1);\n\
         \x20       if ($test$plusargs(\"vcd\")) begin\n\
         \x20           $dumpfile(\"equivalence.vcd\");\n\
         \x20           $dumpvars(0, equivalence_tb);\n\
         \x20       end\n\
         \x20       fd = $fopen(\"trace.txt\", \"w\");\n\
         \x20       bus = 1'b1;\n\
         \x20       for (k = 0; k < cycles; k = k + 1) begin"
    )
    .unwrap();
    for n in 0..nodes {
        writeln!(
            tb,
            "            {{reset_{n}, we_{n}, re_{n}, force_{n}, addr_{n}, wdata_{n}}} = \
             stim[k * NODES + {n}];\n\
             \x20           rx_{n} = bus & ~force_{n};"
        )
        .unwrap();
    }
    writeln!(
        tb,
        "            #5 clock = 1'b1;\n\
         \x20           #1 clock = 1'b0;\n\
         \x20           #1 $fdisplay(fd, \"{}\", {});\n\
         \x20           bus = {};\n\
         \x20           #3;\n\
         \x20       end\n\
         \x20       $fclose(fd);\n\
         \x20       $finish;\n\
         \x20   end\n\
         endmodule",
        format.join(" "),
        values.join(", "),
        all_tx.join(" & ")
    )
    .unwrap();
    tb
}

/// The stimulus file of the testbench: one 20-bit word per node and cycle, in hex.
fn stimulus_hex(stim: &Stimulus) -> String {
    let mut hex = String::with_capacity(stim.len() * stim.nodes * 6);
    for cycle in &stim.cycles {
        for inputs in &cycle.nodes {
            writeln!(hex, "{:05x}", inputs.word()).unwrap();
        }
    }
    hex
}

/// Parses one output line of the testbench (per node: tx, irq_n, clkout, rdata bits 7..0).
fn parse_line(line: &str, nodes: usize) -> Result<Vec<NodeOutputs>, String> {
    let fields: Vec<&str> = line.split_whitespace().collect();
    if fields.len() != nodes {
        return Err(format!("{} fields, expected {nodes}", fields.len()));
    }
    fields
        .iter()
        .map(|field| {
            let bits: Vec<char> = field.chars().collect();
            if bits.len() != 11 {
                return Err(format!("field `{field}`: expected 11 bits"));
            }
            let mut out = NodeOutputs::default();
            let mut level = |c: char, unknown: u16| -> bool {
                match c {
                    '0' => false,
                    '1' => true,
                    _ => {
                        out.unknown |= unknown;
                        false
                    }
                }
            };
            let tx = level(bits[0], UNKNOWN_TX);
            let irq_n = level(bits[1], UNKNOWN_IRQ_N);
            let clkout = level(bits[2], UNKNOWN_CLKOUT);
            let mut rdata = 0u8;
            for (i, &c) in bits[3..].iter().enumerate() {
                let b = 7 - i;
                rdata |= u8::from(level(c, 1 << b)) << b;
            }
            out.tx = tx;
            out.irq_n = irq_n;
            out.clkout = clkout;
            out.rdata = rdata;
            Ok(out)
        })
        .collect()
}

fn run_tool(cmd: &mut Command, what: &str) -> Result<String, String> {
    let out = cmd
        .output()
        .map_err(|e| format!("cannot start {what}: {e}"))?;
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    if !out.status.success() {
        return Err(format!(
            "{what} failed ({}):\n{stdout}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(stdout)
}

/// A Verilog simulator that runs the generated Verilog against the testbench.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Simulator {
    /// Icarus Verilog (`iverilog -g2005`, `vvp`): the reference, required in CI.
    Icarus,
    /// Verilator (`verilator --binary --timing`): compiled C++, much faster; used when installed.
    Verilator,
}

impl Simulator {
    /// The name in traces and messages.
    pub fn name(self) -> &'static str {
        match self {
            Simulator::Icarus => "Icarus",
            Simulator::Verilator => "Verilator",
        }
    }

    /// Compiles `equivalence_tb.v` and `can_controller.v` in `dir`.
    fn compile(self, dir: &Path) -> Result<(), String> {
        self.compile_files(
            dir,
            "equivalence_tb",
            &["equivalence_tb.v", "can_controller.v"],
        )
    }

    /// Compiles `files` in `dir` with `top` as the top module (its executable named after it).
    pub fn compile_files(self, dir: &Path, top: &str, files: &[&str]) -> Result<(), String> {
        let mut cmd = match self {
            Simulator::Icarus => {
                let mut c = Command::new("iverilog");
                c.args(["-g2005", "-o", &format!("{top}.vvp"), "-s", top]);
                c
            }
            Simulator::Verilator => {
                let mut c = Command::new("verilator");
                c.args([
                    "--binary",
                    "--timing",
                    "-O3",
                    "-Wno-fatal",
                    "-Wno-lint",
                    "-Wno-style",
                ])
                .args(["--top-module", top, "-o", top])
                .args(["-j", "2", "--Mdir", "obj_dir"]);
                c
            }
        };
        cmd.current_dir(dir).args(files);
        run_tool(&mut cmd, self.name()).map(|_| ())
    }

    /// The command that runs the compiled testbench in `dir`.
    fn run_command(self, dir: &Path) -> Command {
        self.run_command_for(dir, "equivalence_tb")
    }

    /// The command that runs the testbench compiled by [`Simulator::compile_files`] for `top`.
    pub fn run_command_for(self, dir: &Path, top: &str) -> Command {
        let mut cmd = match self {
            Simulator::Icarus => {
                let mut c = Command::new("vvp");
                c.args(["-n", &format!("{top}.vvp")]);
                c
            }
            Simulator::Verilator => Command::new(dir.join("obj_dir").join(top)),
        };
        cmd.current_dir(dir);
        cmd
    }

    /// Whether the simulator's tools can be started.
    pub fn available(self) -> bool {
        let works = |tool: &str, arg: &str| {
            Command::new(tool)
                .arg(arg)
                .output()
                .map(|o| o.status.success())
                .unwrap_or(false)
        };
        match self {
            Simulator::Icarus => works("iverilog", "-V") && works("vvp", "-V"),
            Simulator::Verilator => works("verilator", "--version"),
        }
    }
}

/// The generated Verilog and testbench compiled once by a [`Simulator`] for `nodes` controllers and
/// up to `max_cycles` cycles, to run several stimuli.
#[derive(Debug)]
pub struct VerilogBench {
    simulator: Simulator,
    dir: PathBuf,
    nodes: usize,
    max_cycles: usize,
}

impl VerilogBench {
    /// Writes `can_controller.v` and `equivalence_tb.v` into `workdir` (created if needed) and
    /// compiles them with `simulator`.
    pub fn new(
        simulator: Simulator,
        nodes: usize,
        max_cycles: usize,
        workdir: &Path,
    ) -> Result<VerilogBench, String> {
        VerilogBench::with_verilog(simulator, nodes, max_cycles, workdir, &controller_verilog())
    }

    /// Like [`VerilogBench::new`] with other Verilog for module [`TOP_MODULE`] (a hand-reduced or
    /// patched copy of [`controller_verilog`], to check a fix or a reproducer).
    pub fn with_verilog(
        simulator: Simulator,
        nodes: usize,
        max_cycles: usize,
        workdir: &Path,
        verilog: &str,
    ) -> Result<VerilogBench, String> {
        if nodes == 0 {
            return Err("at least one node".into());
        }
        std::fs::create_dir_all(workdir)
            .map_err(|e| format!("cannot create {}: {e}", workdir.display()))?;
        let write = |name: &str, text: &str| {
            std::fs::write(workdir.join(name), text)
                .map_err(|e| format!("cannot write {name}: {e}"))
        };
        write("can_controller.v", verilog)?;
        write("equivalence_tb.v", &testbench(nodes, max_cycles))?;
        simulator.compile(workdir)?;
        Ok(VerilogBench {
            simulator,
            dir: workdir.to_path_buf(),
            nodes,
            max_cycles,
        })
    }

    /// The working directory (Verilog, testbench, stimulus, trace and optional VCD).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Runs `stim` and parses the trace.
    pub fn run(&self, stim: &Stimulus) -> Result<Trace, String> {
        self.run_inner(stim, false)
    }

    /// Like [`VerilogBench::run`], also dumping every signal to `equivalence.vcd` in
    /// [`VerilogBench::dir`] (slow: for investigating a short reproducer).
    pub fn run_with_vcd(&self, stim: &Stimulus) -> Result<Trace, String> {
        self.run_inner(stim, true)
    }

    fn run_inner(&self, stim: &Stimulus, vcd: bool) -> Result<Trace, String> {
        stim.validate()?;
        if stim.nodes != self.nodes {
            return Err(format!(
                "stimulus for {} nodes, bench for {}",
                stim.nodes, self.nodes
            ));
        }
        if stim.len() > self.max_cycles {
            return Err(format!(
                "stimulus of {} cycles, bench for at most {}",
                stim.len(),
                self.max_cycles
            ));
        }
        std::fs::write(self.dir.join("stim.hex"), stimulus_hex(stim))
            .map_err(|e| format!("cannot write stim.hex: {e}"))?;
        let trace_file = self.dir.join("trace.txt");
        let _ = std::fs::remove_file(&trace_file);
        let mut cmd = self.simulator.run_command(&self.dir);
        cmd.arg(format!("+cycles={}", stim.len()));
        if vcd {
            cmd.arg("+vcd");
        }
        let name = self.simulator.name();
        run_tool(&mut cmd, name)?;
        let text = std::fs::read_to_string(&trace_file)
            .map_err(|e| format!("cannot read {}: {e}", trace_file.display()))?;
        let mut outputs = Vec::with_capacity(stim.len() * self.nodes);
        for (k, line) in text.lines().enumerate() {
            outputs
                .extend(parse_line(line, self.nodes).map_err(|e| format!("trace line {k}: {e}"))?);
        }
        let trace = Trace {
            source: name.into(),
            nodes: self.nodes,
            outputs,
        };
        if trace.cycles() != stim.len() {
            return Err(format!(
                "{name} printed {} cycles of {}",
                trace.cycles(),
                stim.len()
            ));
        }
        Ok(trace)
    }
}

/// `verilog` without its `initial` blocks (the power-up values rust-hdl gives flip-flops and RAM
/// words), so every register starts unknown in a four-state simulator.
pub fn without_initial_blocks(verilog: &str) -> String {
    let mut out = String::with_capacity(verilog.len());
    let mut in_initial = false;
    for line in verilog.split_inclusive('\n') {
        match line.trim() {
            "initial begin" => in_initial = true,
            "end" if in_initial => in_initial = false,
            _ if in_initial => {}
            _ => out.push_str(line),
        }
    }
    out
}

/// Compiles the Verilog and a testbench for `stim` in `workdir` and runs it with Icarus.
pub fn run_icarus(stim: &Stimulus, workdir: &Path) -> Result<Trace, String> {
    VerilogBench::new(Simulator::Icarus, stim.nodes, stim.len(), workdir)?.run(stim)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builder_holds_address_and_overlays_nodes() {
        let mut b = StimulusBuilder::new(2);
        b.reset(1).write(0, 4, 0xAA).idle(2);
        let t = b.now();
        b.read(0, 2);
        b.seek(t).write(1, 7, 0x1C);
        let s = b.build();
        assert_eq!(s.len(), 5);
        assert!(s.cycles[0].nodes.iter().all(|i| i.reset));
        assert_eq!(
            s.cycles[2].nodes[0],
            NodeInputs {
                addr: 4,
                wdata: 0xAA,
                ..Default::default()
            }
        );
        assert!(s.cycles[4].nodes[0].re && s.cycles[4].nodes[1].we);
        assert_eq!(s.cycles[4].nodes[0].wdata, 0xAA);
    }

    #[test]
    fn parses_unknown_bits() {
        let out = parse_line("10x0000x001 11110100101", 2).unwrap();
        assert!(out[0].tx && !out[0].irq_n);
        assert_eq!(out[0].unknown, UNKNOWN_CLKOUT | 0x08);
        assert_eq!(out[0].rdata, 0x01);
        assert_eq!(out[1].rdata, 0b1010_0101);
        assert!(out[1].clkout && out[1].unknown == 0);
    }

    #[test]
    fn mismatch_names_cycle_node_and_signal() {
        let a = Trace {
            source: "A".into(),
            nodes: 2,
            outputs: vec![NodeOutputs::default(); 6],
        };
        let mut b = a.clone();
        b.source = "B".into();
        assert_eq!(first_mismatch(&a, &b), None);
        b.outputs[5].rdata = 0x3C;
        let m = first_mismatch(&a, &b).unwrap();
        assert!(m.contains("cycle 2") && m.contains("node 1"), "{m}");
        assert!(m.contains("rdata: A 0x00, B 0x3c"), "{m}");
    }
}
