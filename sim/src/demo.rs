//! The demo run of `cansim demo` (and of a bare `cargo run --release`): three RTL CAN controllers on
//! one bus, at 500 kbit/s on clocks a few thousand ppm apart and at different propagation delays.
//!
//! 1. Arbitration: all three request a frame at the same moment; the lowest identifier wins, the
//!    others lose at the bit where their identifiers differ and retry in turn.
//! 2. An injected error: node `b` sees the CRC delimiter of node `a`'s frame dominant (a local
//!    disturbance): a form error; its error flag makes `a` and `c` detect a form error in the ACK
//!    delimiter, and `a` retransmits.
//! 3. Error passive and back: `b` and `c` go to reset mode, so nobody acknowledges `a`'s frame; every
//!    attempt is an ACK error (TEC + 8) until `a` is error passive; `b` and `c` come back, the attempt
//!    is acknowledged, and `a` sends frames until its TEC is below 128: error active again.
//!
//! The run writes a VCD (bus; per node tx, rx, sample point, segment, protocol state, TEC, REC) and
//! returns the timeline of what every controller reported.

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

use rtl::bsp::ecc_segment as seg;
use rtl::bsp::protocol::ProtocolState;

use crate::btr::Btr;
use crate::can_node::{CanNode, NodeEvent};
use crate::engine::{DeviceId, Engine};
use crate::frame::{encode, Field, Frame, Id, DOMINANT};
use crate::time::{ClockSpec, FS_PER_NS};

/// Controller clock of the demo nodes.
pub const DEMO_CLOCK_HZ: f64 = 16e6;
/// 500 kbit/s at 16 MHz: BRP 0, SJW 2, TSEG1 13, TSEG2 2 (16 tq, sample point 87.5 %).
pub const DEMO_BTR: (u8, u8) = (0x40, 0x1C);
/// Sample point of the demo bit timing, in percent (for decoders).
pub const DEMO_SAMPLE_POINT_PCT: f64 = 87.5;
/// Idle bits between the phases.
const GAP_BITS: u64 = 20;
/// Longest phase, in bits (the error-passive phase needs about 17 attempts).
const PHASE_LIMIT_BITS: u64 = 3000;

/// A node of the demos: name, clock offset and propagation delay.
pub(crate) struct NodeSpec {
    pub(crate) name: &'static str,
    pub(crate) ppm: f64,
    pub(crate) delay_ns: u64,
}

/// The three nodes of both demos (the bit timing demo too).
pub(crate) const NODES: [NodeSpec; 3] = [
    NodeSpec {
        name: "a",
        ppm: 0.0,
        delay_ns: 0,
    },
    NodeSpec {
        name: "b",
        ppm: 1500.0,
        delay_ns: 60,
    },
    NodeSpec {
        name: "c",
        ppm: -2500.0,
        delay_ns: 140,
    },
];

/// Index of node `a`, `b`, `c` in the report.
const A: usize = 0;
const B: usize = 1;
const C: usize = 2;

/// One thing a controller reported.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DemoEvent {
    /// Simulated time.
    pub at_fs: u64,
    /// Node name.
    pub node: &'static str,
    /// What it reported.
    pub event: NodeEvent,
}

/// A node's state at the end of the run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeSummary {
    /// Node name (its VCD scope).
    pub name: &'static str,
    /// Frames it sent successfully.
    pub sent: usize,
    /// Frames it received.
    pub received: Vec<Frame>,
    /// Bus errors it detected.
    pub errors: usize,
    /// Final TEC.
    pub tec: u8,
    /// Final REC.
    pub rec: u8,
    /// Final protocol state.
    pub state: ProtocolState,
    /// Final fault confinement state.
    pub error_passive: bool,
}

/// One change of node `a`'s TEC.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TecStep {
    /// Simulated time (resolution: one bit).
    pub at_fs: u64,
    /// The new TEC.
    pub tec: u8,
    /// Error passive from then on.
    pub error_passive: bool,
}

/// Everything the demo run saw.
#[derive(Clone, Debug)]
pub struct DemoReport {
    /// Every controller report, in time order.
    pub events: Vec<DemoEvent>,
    /// Per node, at the end.
    pub nodes: Vec<NodeSummary>,
    /// Node `a`'s TEC after each change, with the time and whether it was error passive.
    pub tec_trace: Vec<TecStep>,
    /// The VCD written, if any.
    pub vcd: Option<PathBuf>,
    /// Simulated time.
    pub simulated_fs: u64,
}

struct Demo {
    engine: Engine,
    nodes: Vec<DeviceId>,
    bit_fs: u64,
    tec_trace: Vec<TecStep>,
}

impl Demo {
    fn new() -> Demo {
        let btr = Btr::from_registers(DEMO_BTR.0, DEMO_BTR.1);
        let mut engine = Engine::new();
        let nodes = NODES
            .iter()
            .map(|n| {
                let clock = ClockSpec::with_ppm(DEMO_CLOCK_HZ, n.ppm);
                engine.add(CanNode::new(n.name, clock, btr), n.delay_ns * FS_PER_NS)
            })
            .collect();
        let bit_fs = btr.clocks_per_bit() as u64 * ClockSpec::from_hz(DEMO_CLOCK_HZ).period_fs();
        Demo {
            engine,
            nodes,
            bit_fs,
            tec_trace: Vec::new(),
        }
    }

    fn node(&self, n: usize) -> &CanNode {
        self.engine.device::<CanNode>(self.nodes[n])
    }

    fn node_mut(&mut self, n: usize) -> &mut CanNode {
        self.engine.device_mut::<CanNode>(self.nodes[n])
    }

    fn idle_bits(&mut self, bits: u64) -> io::Result<()> {
        self.engine
            .run_until(self.engine.now() + bits * self.bit_fs)
    }

    /// Runs until `done` holds, at most [`PHASE_LIMIT_BITS`].
    fn run_until<F: Fn(&Demo) -> bool>(&mut self, what: &str, done: F) -> io::Result<()> {
        let limit = self.engine.now() + PHASE_LIMIT_BITS * self.bit_fs;
        while !done(self) {
            if self.engine.now() >= limit {
                return Err(io::Error::other(format!("demo: {what} did not happen")));
            }
            self.engine.run_until(self.engine.now() + self.bit_fs)?;
            self.watch_tec();
        }
        Ok(())
    }

    fn watch_tec(&mut self) {
        let (tec, error_passive) = (self.node(A).tec(), self.node(A).error_passive());
        if self.tec_trace.last().map(|s| s.tec) != Some(tec) {
            let at_fs = self.engine.now();
            self.tec_trace.push(TecStep {
                at_fs,
                tec,
                error_passive,
            });
        }
    }

    fn all_sent(&self) -> bool {
        (0..NODES.len()).all(|n| !self.node(n).transmit_pending())
    }

    /// Phase 1: three simultaneous requests.
    fn arbitration(&mut self, frames: &[Frame; 3]) -> io::Result<()> {
        for (n, frame) in frames.iter().enumerate() {
            self.node_mut(n).send(frame, false);
        }
        self.run_until("the arbitration phase", Demo::all_sent)
    }

    /// Phase 2: `a` sends `frame`; `b` sees its CRC delimiter dominant.
    fn injected_error(&mut self, frame: &Frame) -> io::Result<()> {
        self.node_mut(A).send(frame, false);
        let limit = self.engine.now() + 4 * self.bit_fs;
        self.engine
            .run_while(limit, |e| !e.bus_level_before(e.now() + 1))?;
        let sof = self.engine.now();
        let bit = encode(frame)
            .position(Field::CrcDelim, 0)
            .expect("every frame has a CRC delimiter") as u64;
        // The whole bit as it reaches b, from just after its start to just after its end.
        let shift = NODES[B].delay_ns * FS_PER_NS + self.bit_fs / 8;
        let from = sof + bit * self.bit_fs + shift;
        self.engine
            .disturb_rx(self.nodes[B], from, from + self.bit_fs, DOMINANT);
        self.run_until("the retransmission", Demo::all_sent)
    }

    /// Phase 3: nobody acknowledges `a` until it is error passive; then `b` and `c` return and `a`
    /// sends until it is error active again.
    fn error_passive_and_back(&mut self, frame: &Frame) -> io::Result<()> {
        self.node_mut(B).set_enable(false);
        self.node_mut(C).set_enable(false);
        self.node_mut(A).send(frame, false);
        self.run_until("error passive", |d| d.node(A).error_passive())?;
        self.node_mut(B).set_enable(true);
        self.node_mut(C).set_enable(true);
        self.run_until("the acknowledged attempt", Demo::all_sent)?;
        for follow_up in follow_up_frames() {
            if !self.node(A).error_passive() {
                break;
            }
            self.node_mut(A).send(&follow_up, false);
            self.run_until("a follow-up frame", Demo::all_sent)?;
        }
        Ok(())
    }

    fn report(self, vcd: Option<PathBuf>) -> DemoReport {
        let mut events: Vec<DemoEvent> = Vec::new();
        for (n, spec) in NODES.iter().enumerate() {
            let node = self.node(n);
            events.extend(node.events().iter().map(|(at, e)| DemoEvent {
                at_fs: *at,
                node: spec.name,
                event: e.clone(),
            }));
        }
        events.sort_by_key(|e| e.at_fs);
        let nodes = NODES
            .iter()
            .enumerate()
            .map(|(n, spec)| summary(spec.name, self.node(n)))
            .collect();
        DemoReport {
            events,
            nodes,
            tec_trace: self.tec_trace,
            vcd,
            simulated_fs: self.engine.now(),
        }
    }
}

fn summary(name: &'static str, node: &CanNode) -> NodeSummary {
    NodeSummary {
        name,
        sent: node
            .events()
            .iter()
            .filter(|(_, e)| *e == NodeEvent::TransmitDone(true))
            .count(),
        received: node.received(),
        errors: node.bus_errors().len(),
        tec: node.tec(),
        rec: node.rec(),
        state: node.state(),
        error_passive: node.error_passive(),
    }
}

/// The frames of the demo: phase 1 (a, b, c), phase 2 (a), phase 3 (a).
pub fn demo_frames() -> ([Frame; 3], Frame, Frame) {
    let std_id = |id| Id::standard(id).expect("demo id");
    let ext_id = |id| Id::extended(id).expect("demo id");
    let frame = |id, data: &[u8]| Frame::data(id, data).expect("demo frame");
    (
        [
            frame(
                std_id(0x123),
                &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88],
            ),
            frame(ext_id(0x1234_5678), &[0xCA, 0xFE]),
            frame(std_id(0x121), &[0x01]),
        ],
        frame(std_id(0x200), &[0xDE, 0xAD, 0xBE, 0xEF]),
        frame(std_id(0x300), &[0x42]),
    )
}

/// What `a` sends after phase 3 until it is error active again (8 successes at most are needed).
fn follow_up_frames() -> impl Iterator<Item = Frame> {
    (1..=8u8).map(|k| {
        let id = Id::standard(0x300 + k as u16).expect("demo id");
        Frame::data(id, &[k]).expect("demo frame")
    })
}

/// Runs the demo; writes the VCD to `vcd` if given.
pub fn run_demo(vcd: Option<&Path>) -> io::Result<DemoReport> {
    let mut demo = Demo::new();
    if let Some(path) = vcd {
        demo.engine.trace_vcd(path)?;
    }
    let (arbitrating, disturbed, unacknowledged) = demo_frames();
    demo.idle_bits(GAP_BITS)?;
    demo.arbitration(&arbitrating)?;
    demo.idle_bits(GAP_BITS)?;
    demo.injected_error(&disturbed)?;
    demo.idle_bits(GAP_BITS)?;
    demo.error_passive_and_back(&unacknowledged)?;
    demo.idle_bits(GAP_BITS)?;
    let written = demo.engine.finish_trace()?;
    Ok(demo.report(written))
}

impl fmt::Display for DemoEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = self.at_fs as f64 / 1e12;
        write!(f, "{ms:9.3} ms  {}  ", self.node)?;
        match &self.event {
            NodeEvent::Received(frame) => write!(f, "received {frame}"),
            NodeEvent::TransmitDone(true) => write!(f, "sent its frame"),
            NodeEvent::TransmitDone(false) => write!(f, "gave up its frame"),
            NodeEvent::BusError(ecc) => {
                write!(f, "bus error, ECC 0x{ecc:02X} ({})", ecc_text(*ecc))
            }
            NodeEvent::ArbitrationLost(alc) => write!(f, "lost arbitration at bit {alc} (ALC)"),
        }
    }
}

/// The SJA1000 ECC value in words: error type, direction, segment.
pub fn ecc_text(ecc: u8) -> String {
    let kind = ["bit error", "form error", "stuff error", "other error"][(ecc >> 6) as usize];
    let direction = if ecc & 0x20 != 0 {
        "receiving"
    } else {
        "transmitting"
    };
    let segment = match u64::from(ecc & 0x1F) {
        seg::SOF => "start of frame",
        seg::ID_28_21 | seg::ID_20_18 | seg::ID_17_13 | seg::ID_12_5 | seg::ID_4_0 => "identifier",
        seg::SRTR => "SRTR/RTR",
        seg::IDE => "IDE",
        seg::RTR => "RTR",
        seg::R1 | seg::R0 => "reserved bit",
        seg::DLC => "DLC",
        seg::DATA => "data field",
        seg::CRC => "CRC sequence",
        seg::CRC_DELIMITER => "CRC delimiter",
        seg::ACK_SLOT => "ACK slot",
        seg::ACK_DELIMITER => "ACK delimiter",
        seg::EOF => "end of frame",
        seg::INTERMISSION => "intermission",
        seg::ACTIVE_ERROR_FLAG => "active error flag",
        seg::PASSIVE_ERROR_FLAG => "passive error flag",
        seg::TOLERATE_DOMINANT => "tolerated dominant bits",
        seg::ERROR_DELIMITER => "error delimiter",
        seg::OVERLOAD_FLAG => "overload flag",
        _ => "unknown segment",
    };
    format!("{kind}, {direction}, {segment}")
}

/// The report as text for the terminal.
pub fn format_report(report: &DemoReport) -> String {
    let btr = Btr::from_registers(DEMO_BTR.0, DEMO_BTR.1);
    let mut out = format!(
        "cansim demo: {} CAN controllers (RTL) at {:.0} kbit/s ({btr})\n",
        NODES.len(),
        btr.bitrate(DEMO_CLOCK_HZ) / 1000.0
    );
    for spec in &NODES {
        out += &format!(
            "  {}: 16 MHz {:+} ppm, {} ns from the bus\n",
            spec.name, spec.ppm, spec.delay_ns
        );
    }
    let (arbitrating, disturbed, unacknowledged) = demo_frames();
    out += &format!(
        "\n1. a, b, c request {}, {}, {} at once: arbitration\n",
        arbitrating[A], arbitrating[B], arbitrating[C]
    );
    out += &format!(
        "2. a sends {disturbed}; b sees its CRC delimiter dominant: an error frame, a retransmits\n"
    );
    out += &format!(
        "3. b and c in reset mode, a sends {unacknowledged}: ACK errors until a is error passive;\n   b and c return, a sends until it is error active again\n\n"
    );
    for event in &report.events {
        out += &format!("{event}\n");
    }
    out += "\na's TEC:";
    let mut passive = false;
    for step in &report.tec_trace {
        out += &format!(" {}", step.tec);
        if step.error_passive != passive {
            passive = step.error_passive;
            out += if passive {
                " (error passive)"
            } else {
                " (error active)"
            };
        }
    }
    out += "\n\nnode  sent  received  errors  TEC  REC  state\n";
    for n in &report.nodes {
        out += &format!(
            "{:<4}  {:>4}  {:>8}  {:>6}  {:>3}  {:>3}  {}\n",
            n.name,
            n.sent,
            n.received.len(),
            n.errors,
            n.tec,
            n.rec,
            if n.error_passive {
                "error passive"
            } else {
                "error active"
            }
        );
    }
    out += &format!("\nsimulated {:.3} ms\n", report.simulated_fs as f64 / 1e12);
    out
}
