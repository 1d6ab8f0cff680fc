//! The demo run of `cansim demo` (and of a bare `cargo run --release`): three complete RTL CAN
//! controllers ([`ControllerNode`]: the SJA1000 register map, TX buffer, RX FIFO, interrupts) on one
//! bus, at 500 kbit/s on clocks a few thousand ppm apart and at different propagation delays. Each
//! controller is driven only through its registers, by the model of the Linux SJA1000 driver
//! ([`Sja1000Driver`]): probe, bit timing, start with bus-error reporting, `transmit`, the interrupt
//! handler whenever the controller's `irq_n` is low, `stop` and `start`. What the demo reports is
//! what the drivers report ([`DriverEvent`]), plus TXERR and RXERR read through the host (a's
//! TXERR once per bit time, for its trace). Besides running the engine, the demo touches the
//! simulation only to inject phase 2's disturbance and to write the VCD.
//!
//! 1. Arbitration: all three drivers request a frame at once; the lowest identifier wins, the others
//!    lose at the bit where their identifiers differ (ALI, the ALC value the driver read) and the
//!    controllers retry by themselves.
//! 2. An injected error: node `b` sees the CRC delimiter of node `a`'s frame dominant (a local
//!    disturbance): a form error; its error flag makes `a` and `c` detect a form error in the ACK
//!    delimiter (BEI, the ECC value each driver read), and `a` retransmits.
//! 3. Error passive and back: the drivers of `b` and `c` stop them (reset mode), so nobody
//!    acknowledges `a`'s frame; every attempt is an ACK error (TXERR + 8) until `a`'s driver sees EPI
//!    (error passive); `b` and `c` are started again, the attempt is acknowledged, and `a` sends
//!    frames until TXERR is back at 127: error active again (EPI once more).
//!
//! The run writes a VCD (bus; per node tx, rx and the controller's probes: sample point, segment,
//! protocol state, TEC, REC, `irq_n`, CLKOUT) and returns the timeline of what every driver reported.

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

use rtl::bsp::ecc_segment as seg;
use rtl::registers::{interrupt, pelican};

use crate::btr::Btr;
use crate::bus_decoder::BusTiming;
use crate::controller_node::ControllerNode;
use crate::driver::{CanState, CtrlMode, DriverConfig, DriverEvent, Sja1000Driver};
use crate::engine::{DeviceId, Engine};
use crate::frame::{encode, Field, Frame, Id, DOMINANT};
use crate::host::Host;
use crate::time::{ClockSpec, FS_PER_NS};

/// Controller clock of the demo nodes.
pub const DEMO_CLOCK_HZ: f64 = 16e6;
/// 500 kbit/s at 16 MHz: BRP 0, SJW 2, TSEG1 13, TSEG2 2 (16 tq, sample point 87.5 %).
pub const DEMO_BTR: (u8, u8) = (0x40, 0x1C);
/// Sample point of the demo bit timing, in percent (for decoders).
pub const DEMO_SAMPLE_POINT_PCT: f64 = 87.5;
/// Idle bits between the phases (more than the 11 recessive bits a started controller needs to
/// integrate).
const GAP_BITS: u64 = 20;
/// Longest phase, in bits (the error-passive phase needs about 17 attempts).
const PHASE_LIMIT_BITS: u64 = 3000;
/// Interrupt services in a row that find nothing before the demo gives up (a stuck `irq_n`).
const QUIET_SERVICE_LIMIT: usize = 1000;

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

/// The control modes every driver starts its controller with: bus-error reporting on (BEI), so the
/// driver reads ECC on every bus error.
const DEMO_CTRL_MODE: CtrlMode = CtrlMode {
    listen_only: false,
    presume_ack: false,
    one_shot: false,
    berr_reporting: true,
};

/// One thing a node's driver reported.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DemoEvent {
    /// Simulated time (when the interrupt handler that reported it returned).
    pub at_fs: u64,
    /// Node name.
    pub node: &'static str,
    /// What the driver reported.
    pub event: DriverEvent,
}

/// A node at the end of the run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeSummary {
    /// Node name (its VCD scope).
    pub name: &'static str,
    /// Frames it sent successfully (TI for the frame in flight).
    pub sent: usize,
    /// Frames its driver read from the RX FIFO, in order.
    pub received: Vec<Frame>,
    /// Bus errors its driver reported (BEI).
    pub errors: usize,
    /// Arbitration losses its driver reported (ALI).
    pub arbitration_lost: usize,
    /// Final TXERR, read through the host.
    pub tec: u8,
    /// Final RXERR, read through the host.
    pub rec: u8,
    /// Final device state as the driver tracks it.
    pub state: CanState,
}

/// One change of node `a`'s TXERR.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TecStep {
    /// Simulated time (resolution: one bit).
    pub at_fs: u64,
    /// The new TXERR value, read through the host.
    pub tec: u8,
    /// The device state a's driver tracked at that time.
    pub state: CanState,
}

/// Everything the demo run saw.
#[derive(Clone, Debug)]
pub struct DemoReport {
    /// Every driver report, in time order.
    pub events: Vec<DemoEvent>,
    /// Per node, at the end.
    pub nodes: Vec<NodeSummary>,
    /// Node `a`'s TXERR after each change (read once per bit time), with the time and its driver's
    /// state.
    pub tec_trace: Vec<TecStep>,
    /// The VCD written, if any.
    pub vcd: Option<PathBuf>,
    /// Simulated time.
    pub simulated_fs: u64,
}

/// A controller and the driver bound to it.
struct Node {
    id: DeviceId,
    driver: Sja1000Driver,
    events: Vec<(u64, DriverEvent)>,
}

struct Demo {
    engine: Engine,
    nodes: Vec<Node>,
    bit_fs: u64,
    tec_trace: Vec<TecStep>,
}

fn demo_error(what: String) -> io::Error {
    io::Error::other(format!("demo: {what}"))
}

impl Demo {
    /// The three controllers after a hardware reset, each with its driver (nothing accessed yet).
    fn new() -> Demo {
        let mut engine = Engine::new();
        let nodes = NODES
            .iter()
            .map(|n| {
                let clock = ClockSpec::with_ppm(DEMO_CLOCK_HZ, n.ppm);
                let id = engine.add(ControllerNode::new(n.name, clock), n.delay_ns * FS_PER_NS);
                let config = DriverConfig {
                    clock_hz: DEMO_CLOCK_HZ as u32,
                    ..DriverConfig::default()
                };
                Node {
                    id,
                    driver: Sja1000Driver::new(id, config),
                    events: Vec::new(),
                }
            })
            .collect();
        let btr = Btr::from_registers(DEMO_BTR.0, DEMO_BTR.1);
        let bit_fs = btr.clocks_per_bit() as u64 * ClockSpec::from_hz(DEMO_CLOCK_HZ).period_fs();
        Demo {
            engine,
            nodes,
            bit_fs,
            tec_trace: Vec::new(),
        }
    }

    fn driver(&self, n: usize) -> &Sja1000Driver {
        &self.nodes[n].driver
    }

    fn host(&mut self, n: usize) -> Host<'_> {
        Host::new(&mut self.engine, self.nodes[n].id)
    }

    /// Brings the three interfaces up as Linux would at boot and on `ip link set ... up`: every
    /// driver probes its controller, then each gets the bit timing [`DEMO_BTR`], then each is
    /// started (with [`DEMO_CTRL_MODE`]). The bit timing logics run from the hardware reset, which
    /// the three controllers share; with the BTR writes back to back, their new bits begin within a
    /// few clock cycles of each other and stay so (the bus has had no edge yet that would
    /// synchronise them). Phase 1 relies on that: see [`Demo::arbitration`].
    fn bring_up(&mut self) -> io::Result<()> {
        let fail = |spec: &NodeSpec, e: crate::driver::DriverError| {
            demo_error(format!("{}: {e}", spec.name))
        };
        for (node, spec) in self.nodes.iter_mut().zip(&NODES) {
            node.driver
                .probe(&mut self.engine)
                .map_err(|e| fail(spec, e))?;
        }
        for (node, spec) in self.nodes.iter_mut().zip(&NODES) {
            node.driver
                .set_bittiming(&mut self.engine, DEMO_BTR.0, DEMO_BTR.1)
                .map_err(|e| fail(spec, e))?;
        }
        for n in 0..self.nodes.len() {
            self.start(n)?;
        }
        Ok(())
    }

    fn start(&mut self, n: usize) -> io::Result<()> {
        self.nodes[n]
            .driver
            .start(&mut self.engine, DEMO_CTRL_MODE)
            .map_err(|e| demo_error(format!("{}: start: {e}", NODES[n].name)))?;
        Ok(())
    }

    fn stop(&mut self, n: usize) -> io::Result<()> {
        self.nodes[n]
            .driver
            .stop(&mut self.engine)
            .map_err(|e| demo_error(format!("{}: stop: {e}", NODES[n].name)))?;
        Ok(())
    }

    fn transmit(&mut self, n: usize, frame: &Frame) -> io::Result<()> {
        self.nodes[n]
            .driver
            .transmit(&mut self.engine, frame, false)
            .map_err(|e| demo_error(format!("{}: transmit {frame}: {e}", NODES[n].name)))
    }

    /// Runs node `n`'s interrupt handler and books what its driver reports; whether it reported
    /// anything.
    fn service(&mut self, n: usize) -> bool {
        let events = self.nodes[n].driver.interrupt(&mut self.engine);
        let at = self.engine.now();
        let node = &mut self.nodes[n];
        node.events.extend(events.iter().map(|e| (at, *e)));
        !events.is_empty()
    }

    /// Runs the bus for one bit time, running a node's interrupt handler whenever its `irq_n` is
    /// asserted (as the kernel would).
    fn run_bit(&mut self) -> io::Result<()> {
        let end = self.engine.now() + self.bit_fs;
        let ids: Vec<DeviceId> = self.nodes.iter().map(|n| n.id).collect();
        let mut quiet = 0;
        loop {
            let irq = self.engine.run_while(end, |e| {
                ids.iter().any(|&id| e.device::<ControllerNode>(id).irq())
            })?;
            if !irq {
                return Ok(());
            }
            for (n, &id) in ids.iter().enumerate() {
                if self.engine.device::<ControllerNode>(id).irq() && !self.service(n) {
                    quiet += 1;
                    if quiet >= QUIET_SERVICE_LIMIT {
                        return Err(demo_error(format!(
                            "{}: irq_n stays low but the handler finds nothing",
                            NODES[n].name
                        )));
                    }
                }
            }
        }
    }

    /// Reads a's TXERR through the host and records it if it changed.
    fn watch_tec(&mut self) {
        let tec = self.host(A).read(pelican::TXERR);
        if self.tec_trace.last().map(|s| s.tec) != Some(tec) {
            self.tec_trace.push(TecStep {
                at_fs: self.engine.now(),
                tec,
                state: self.driver(A).state(),
            });
        }
    }

    /// Runs bit by bit (servicing interrupts, watching a's TXERR) for `bits` bit times.
    fn run_bits(&mut self, bits: u64) -> io::Result<()> {
        for _ in 0..bits {
            self.run_bit()?;
            self.watch_tec();
        }
        Ok(())
    }

    /// Runs bit by bit until `done` holds, at most [`PHASE_LIMIT_BITS`].
    fn run_until<F: Fn(&Demo) -> bool>(&mut self, what: &str, done: F) -> io::Result<()> {
        for _ in 0..PHASE_LIMIT_BITS {
            if done(self) {
                return Ok(());
            }
            self.run_bits(1)?;
        }
        Err(demo_error(format!("{what} did not happen")))
    }

    /// No driver has a frame in flight (every TI seen).
    fn all_sent(&self) -> bool {
        self.nodes.iter().all(|n| n.driver.in_flight().is_none())
    }

    /// Phase 1: three requests at once: the three `transmit` calls, one after the other, take 28
    /// clock cycles, and from the first transmission request to the last 15 (under half a bit).
    ///
    /// On an idle bus a controller starts its SOF in the bit after the one in which it saw its
    /// request, and a controller that sees another's SOF first becomes a receiver: the three meet
    /// in one arbitration only if every request comes before its controller's decision point for
    /// the same bit. That holds because the bits of the three are aligned within a few clock
    /// cycles ([`Demo::bring_up`]) and the requests come at a suitable point of the bit (in this
    /// deterministic run 19 of the 32 clock cycles of a bit would do). The run checks it: the two
    /// losers must report three losses between them.
    fn arbitration(&mut self, frames: &[Frame; 3]) -> io::Result<()> {
        let before = self.losses();
        for (n, frame) in frames.iter().enumerate() {
            self.transmit(n, frame)?;
        }
        self.run_until("the arbitration phase", Demo::all_sent)?;
        let losses = self.losses() - before;
        if losses != 2 + 1 {
            return Err(demo_error(format!(
                "the three requests did not start in the same bit ({losses} arbitration losses \
                 instead of 3)"
            )));
        }
        Ok(())
    }

    /// Arbitration losses reported so far, all nodes.
    fn losses(&self) -> usize {
        self.nodes
            .iter()
            .flat_map(|n| &n.events)
            .filter(|(_, e)| matches!(e, DriverEvent::ArbitrationLost { .. }))
            .count()
    }

    /// Phase 2: `a` sends `frame`; `b` sees its CRC delimiter dominant.
    fn injected_error(&mut self, frame: &Frame) -> io::Result<()> {
        self.transmit(A, frame)?;
        let limit = self.engine.now() + 4 * self.bit_fs;
        let started = self
            .engine
            .run_while(limit, |e| !e.bus_level_before(e.now() + 1))?;
        if !started {
            return Err(demo_error("a's frame did not start".into()));
        }
        let sof = self.engine.now();
        let bit = encode(frame)
            .position(Field::CrcDelim, 0)
            .expect("every frame has a CRC delimiter") as u64;
        // The whole bit as it reaches b, from just after its start to just after its end.
        let shift = NODES[B].delay_ns * FS_PER_NS + self.bit_fs / 8;
        let from = sof + bit * self.bit_fs + shift;
        self.engine
            .disturb_rx(self.nodes[B].id, from, from + self.bit_fs, DOMINANT);
        self.run_until("the retransmission", Demo::all_sent)
    }

    /// Phase 3: `b` and `c` stopped, nobody acknowledges `a` until its driver sees it error passive;
    /// then `b` and `c` are started again and `a` sends until TXERR is below 128.
    fn error_passive_and_back(&mut self, frame: &Frame) -> io::Result<()> {
        self.stop(B)?;
        self.stop(C)?;
        self.transmit(A, frame)?;
        self.run_until("error passive", |d| {
            d.driver(A).state() == CanState::ErrorPassive
        })?;
        self.start(B)?;
        self.start(C)?;
        self.run_until("the acknowledged attempt", Demo::all_sent)?;
        let mut follow_ups = follow_up_frames();
        while self.host(A).read(pelican::TXERR) >= 128 {
            let follow_up = follow_ups
                .next()
                .ok_or_else(|| demo_error("a stays error passive".into()))?;
            self.transmit(A, &follow_up)?;
            self.run_until("a follow-up frame", Demo::all_sent)?;
        }
        self.run_until("EPI back to error active", |d| {
            d.driver(A).state() != CanState::ErrorPassive
        })
    }

    fn report(mut self, vcd: Option<PathBuf>) -> DemoReport {
        let mut events: Vec<DemoEvent> = Vec::new();
        for (node, spec) in self.nodes.iter().zip(&NODES) {
            events.extend(node.events.iter().map(|(at, e)| DemoEvent {
                at_fs: *at,
                node: spec.name,
                event: *e,
            }));
        }
        events.sort_by_key(|e| e.at_fs);
        let nodes = (0..self.nodes.len())
            .map(|n| self.summary(n))
            .collect::<Vec<_>>();
        DemoReport {
            events,
            nodes,
            tec_trace: self.tec_trace,
            vcd,
            simulated_fs: self.engine.now(),
        }
    }

    fn summary(&mut self, n: usize) -> NodeSummary {
        let mut host = self.host(n);
        let (tec, rec) = (host.read(pelican::TXERR), host.read(pelican::RXERR));
        let node = &self.nodes[n];
        let count =
            |kind: fn(&DriverEvent) -> bool| node.events.iter().filter(|(_, e)| kind(e)).count();
        NodeSummary {
            name: NODES[n].name,
            sent: count(|e| matches!(e, DriverEvent::TxDone(_))),
            received: node
                .events
                .iter()
                .filter_map(|(_, e)| match e {
                    DriverEvent::Received(frame) => Some(*frame),
                    _ => None,
                })
                .collect(),
            errors: count(|e| matches!(e, DriverEvent::BusError { .. })),
            arbitration_lost: count(|e| matches!(e, DriverEvent::ArbitrationLost { .. })),
            tec,
            rec,
            state: node.driver.state(),
        }
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

/// What `a` sends after phase 3 until it is error active again (8 successes are needed after the
/// first ACK error that makes it error passive; one more missed acknowledgement would need 16).
fn follow_up_frames() -> impl Iterator<Item = Frame> {
    (1..=16u8).map(|k| {
        let id = Id::standard(0x300 + k as u16).expect("demo id");
        Frame::data(id, &[k]).expect("demo frame")
    })
}

/// Runs the demo; writes the VCD to `vcd` if given.
pub fn run_demo(vcd: Option<&Path>) -> io::Result<DemoReport> {
    let mut demo = Demo::new();
    if let Some(path) = vcd {
        let btr = Btr::from_registers(DEMO_BTR.0, DEMO_BTR.1);
        let timing = BusTiming::from_btr(&btr, ClockSpec::from_hz(DEMO_CLOCK_HZ));
        demo.engine.trace_vcd_timed(path, timing)?;
    }
    let (arbitrating, disturbed, unacknowledged) = demo_frames();
    demo.bring_up()?;
    demo.run_bits(GAP_BITS)?;
    demo.arbitration(&arbitrating)?;
    demo.run_bits(GAP_BITS)?;
    demo.injected_error(&disturbed)?;
    demo.run_bits(GAP_BITS)?;
    demo.error_passive_and_back(&unacknowledged)?;
    demo.run_bits(GAP_BITS)?;
    let written = demo.engine.finish_trace()?;
    Ok(demo.report(written))
}

/// The interrupt bits of a state change, as names.
fn state_irq_text(ir: u8) -> String {
    let names: Vec<&str> = [(interrupt::EI, "EI"), (interrupt::EPI, "EPI")]
        .iter()
        .filter(|(bit, _)| ir & bit != 0)
        .map(|(_, name)| *name)
        .collect();
    names.join("+")
}

impl fmt::Display for DemoEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = self.at_fs as f64 / 1e12;
        write!(f, "{ms:9.3} ms  {}  ", self.node)?;
        match &self.event {
            DriverEvent::Received(frame) => write!(f, "received {frame}"),
            DriverEvent::TxDone(frame) => write!(f, "sent {frame}"),
            DriverEvent::TxFailed(frame) => write!(f, "gave up {frame} (one-shot)"),
            DriverEvent::TxDropped(frame) => write!(f, "dropped {frame}"),
            DriverEvent::BusError { ecc, counters } => write!(
                f,
                "bus error, ECC 0x{ecc:02X} ({}); TXERR {}, RXERR {}",
                ecc_text(*ecc),
                counters.txerr,
                counters.rxerr
            ),
            DriverEvent::ArbitrationLost { alc, .. } => {
                write!(f, "lost arbitration at bit {} (ALC)", alc & 0x1F)
            }
            DriverEvent::StateChanged {
                state,
                ir,
                counters,
                ..
            } => write!(
                f,
                "{state} ({}); TXERR {}, RXERR {}",
                state_irq_text(*ir),
                counters.txerr,
                counters.rxerr
            ),
            DriverEvent::Overrun(_) => write!(f, "data overrun"),
            DriverEvent::WakeUp => write!(f, "woke up"),
            DriverEvent::SpuriousTxInterrupt { sr } => {
                write!(f, "TI without a frame in flight (SR 0x{sr:02X})")
            }
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

/// `head` then `words`, separated by spaces, in lines of at most 100 characters (continuation
/// lines indented).
fn wrap(head: &str, words: &[String]) -> String {
    let mut out = head.to_string();
    let mut line = head.trim_start_matches('\n').len();
    for word in words {
        if line + 1 + word.len() > 100 {
            out += "\n   ";
            line = 3;
        }
        out += " ";
        out += word;
        line += 1 + word.len();
    }
    out + "\n"
}

/// The report as text for the terminal.
pub fn format_report(report: &DemoReport) -> String {
    let btr = Btr::from_registers(DEMO_BTR.0, DEMO_BTR.1);
    let mut out = format!(
        "cansim demo: {} CAN controllers (RTL) at {:.0} kbit/s ({btr})\n\
         each driven only through its registers by the Linux SJA1000 driver model, bus-error \
         reporting on\n",
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
        "3. b and c stopped (reset mode), a sends {unacknowledged}: ACK errors until a is error \
         passive;\n   b and c started again, a sends until it is error active again\n\n"
    );
    for event in &report.events {
        out += &format!("{event}\n");
    }
    // Fault confinement as a's driver learns it from EPI: passive between the two EPIs.
    let mut words = Vec::new();
    let mut passive = false;
    for step in &report.tec_trace {
        words.push(step.tec.to_string());
        if (step.state == CanState::ErrorPassive) != passive {
            passive = !passive;
            words.push(
                if passive {
                    "(error passive)"
                } else {
                    "(error active)"
                }
                .to_string(),
            );
        }
    }
    out += &wrap("\na's TXERR, read once per bit:", &words);
    out += "\nnode  sent  received  errors  lost  TXERR  RXERR  driver state\n";
    for n in &report.nodes {
        out += &format!(
            "{:<4}  {:>4}  {:>8}  {:>6}  {:>4}  {:>5}  {:>5}  {}\n",
            n.name,
            n.sent,
            n.received.len(),
            n.errors,
            n.arbitration_lost,
            n.tec,
            n.rec,
            n.state
        );
    }
    out +=
        "(on EPI the driver goes from error-passive to error-warning; it reports error-active on \
            an EI\n with both counters below the warning limit 96)\n";
    out += &format!("\nsimulated {:.3} ms\n", report.simulated_fs as f64 / 1e12);
    out
}
