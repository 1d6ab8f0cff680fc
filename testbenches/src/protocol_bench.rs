//! Bench for the protocol scenarios: a lower tester (LT) and one node under test (IUT, the RTL CAN core)
//! on a 16 MHz clock in configuration BT-A (TSEG1 11, TSEG2 4, SJW 2, BRP 0: 500 kbit/s), the catalog's
//! default setup (error active, counters 0, integrated). Queries are in LT script bits: "what did the
//! IUT drive in bit i" reads the IUT's drive at the LT's sample point of script bit i.

use sim::btr::Btr;
use sim::bus::Drive;
use sim::can_node::{CanNode, NodeEvent};
use sim::engine::{DeviceId, Engine};
use sim::frame::{encode, EncodedFrame, Field, Frame, DOMINANT};
use sim::lower_tester::LowerTester;
use sim::time::ClockSpec;

use crate::{bench_engine, CLOCK_HZ};

/// Idle bits before the first frame: the IUT needs 11 recessive bits to integrate.
pub const INTEGRATION_BITS: usize = 14;

/// The catalog's default configuration BT-A with BRP 0.
pub fn bt_a() -> Btr {
    Btr::from_quanta(0, 11, 4, 2, false).expect("BT-A")
}

/// LT + IUT.
pub struct ProtocolBench {
    /// The engine (public for scenario-specific queries).
    pub engine: Engine,
    lt: DeviceId,
    iut: DeviceId,
    btr: Btr,
    clock: ClockSpec,
}

impl ProtocolBench {
    /// A bench whose LT starts playing at once (the IUT receives).
    pub fn new() -> ProtocolBench {
        ProtocolBench::with_btr(bt_a())
    }

    /// As [`ProtocolBench::new`], with the bit timing `btr` for both the LT and the IUT.
    pub fn with_btr(btr: Btr) -> ProtocolBench {
        ProtocolBench::with_clock(btr, ClockSpec::from_hz(CLOCK_HZ))
    }

    /// As [`ProtocolBench::with_btr`], with the LT and the IUT both on `clock` (e.g. a clock some
    /// ppm off the nominal 16 MHz), so the LT's script bits stay the IUT's bits.
    pub fn with_clock(btr: Btr, clock: ClockSpec) -> ProtocolBench {
        let mut engine = bench_engine(&btr, clock);
        engine.keep_history();
        let lt = engine.add(LowerTester::new("lt", clock, btr), 0);
        let iut = engine.add(CanNode::new("iut", clock, btr), 0);
        ProtocolBench {
            engine,
            lt,
            iut,
            btr,
            clock,
        }
    }

    /// A bench where the IUT transmits `frame` once integrated; the LT's script starts at the IUT's
    /// SOF edge (script bit 0 is the SOF).
    pub fn iut_transmits(frame: &Frame) -> ProtocolBench {
        ProtocolBench::iut_transmits_with(frame, 0, false)
    }

    /// As [`ProtocolBench::iut_transmits`], with the IUT's TEC preset to `tec` before integration and
    /// a single-shot request if `single_shot`.
    pub fn iut_transmits_with(frame: &Frame, tec: u8, single_shot: bool) -> ProtocolBench {
        ProtocolBench::transmitting(ProtocolBench::new(), frame, tec, single_shot)
    }

    /// As [`ProtocolBench::iut_transmits`], with the bit timing `btr` for both the LT and the IUT.
    pub fn iut_transmits_in(btr: Btr, frame: &Frame) -> ProtocolBench {
        ProtocolBench::transmitting(ProtocolBench::with_btr(btr), frame, 0, false)
    }

    /// As [`ProtocolBench::iut_transmits_in`], with the LT and the IUT on `clock`
    /// (see [`ProtocolBench::with_clock`]).
    pub fn iut_transmits_on(btr: Btr, clock: ClockSpec, frame: &Frame) -> ProtocolBench {
        ProtocolBench::transmitting(ProtocolBench::with_clock(btr, clock), frame, 0, false)
    }

    fn transmitting(
        mut bench: ProtocolBench,
        frame: &Frame,
        tec: u8,
        single_shot: bool,
    ) -> ProtocolBench {
        bench.lt().start_on_dominant();
        bench.iut_mut().load_counter(true, tec);
        bench.integrate();
        bench.iut_mut().send(frame, single_shot);
        bench
    }

    /// A bench where the IUT, with its TEC preset to `tec`, transmits `frame` once integrated and the
    /// LT acknowledges it; the script is played to its end plus one bit.
    pub fn iut_transmits_acknowledged(frame: &Frame, tec: u8) -> ProtocolBench {
        let encoded = encode(frame);
        let ack = encoded.position(Field::AckSlot, 0).expect("ack slot");
        let mut bench = ProtocolBench::iut_transmits_with(frame, tec, false);
        bench
            .lt()
            .release(encoded.len() + 4)
            .set_bit(ack, Drive::Dominant);
        bench.run(1);
        bench
    }

    /// Lets the IUT integrate (runs the bus idle for [`INTEGRATION_BITS`]) before the LT's script.
    pub fn integrate(&mut self) {
        let bits = INTEGRATION_BITS as u64 * self.btr.clocks_per_bit() as u64;
        let end = self.engine.now() + bits * self.clock.period_fs();
        self.engine.run_until(end).expect("simulation");
    }

    /// The bit timing of the LT and the IUT.
    pub fn btr(&self) -> Btr {
        self.btr
    }

    /// Quanta from a bit's start to its sample point.
    pub fn sample_point_tq(&self) -> u32 {
        self.btr.sample_point_tq()
    }

    /// The lower tester, to write its script.
    pub fn lt(&mut self) -> &mut LowerTester {
        self.engine.device_mut(self.lt)
    }

    /// The lower tester.
    pub fn lt_ref(&self) -> &LowerTester {
        self.engine.device(self.lt)
    }

    /// The node under test.
    pub fn iut(&self) -> &CanNode {
        self.engine.device(self.iut)
    }

    /// The node under test, mutably.
    pub fn iut_mut(&mut self) -> &mut CanNode {
        self.engine.device_mut(self.iut)
    }

    /// Runs until the LT has played its script, then `extra_bits` more bits.
    pub fn run(&mut self, extra_bits: usize) {
        let lt = self.lt;
        let limit = self.engine.now() + sim::time::FS_PER_S;
        let done = self
            .engine
            .run_while(limit, |e| e.device::<LowerTester>(lt).finished())
            .expect("simulation");
        assert!(
            done,
            "the lower tester never started or never finished its script"
        );
        let bits = extra_bits as u64 * self.btr.clocks_per_bit() as u64;
        let end = self.engine.now() + bits * self.clock.period_fs();
        self.engine.run_until(end).expect("simulation");
    }

    /// Runs until `done(iut)` holds or `max_bits` bit times pass; returns whether it held.
    pub fn run_until<F: Fn(&CanNode) -> bool>(&mut self, max_bits: u64, done: F) -> bool {
        let iut = self.iut;
        let bits = max_bits * self.btr.clocks_per_bit() as u64;
        let limit = self.engine.now() + bits * self.clock.period_fs();
        self.engine
            .run_while(limit, |e| done(e.device::<CanNode>(iut)))
            .expect("simulation")
    }

    /// Runs until script bit `bit` of the LT starts (first until the LT starts, if it has not).
    pub fn run_to_bit(&mut self, bit: usize) {
        if self.lt_ref().started_at().is_none() {
            let lt = self.lt;
            let limit = self.engine.now() + sim::time::FS_PER_S;
            let started = self
                .engine
                .run_while(limit, |e| {
                    e.device::<LowerTester>(lt).started_at().is_some()
                })
                .expect("simulation");
            assert!(started, "the LT never started");
        }
        let at = self.lt_ref().bit_time(bit).expect("LT started");
        assert!(
            at >= self.engine.now(),
            "script bit {bit} has already started"
        );
        self.engine.run_until(at).expect("simulation");
    }

    /// Clocks from the start of the LT's script to the start of script bit `bit`.
    pub fn bit_start_clock(&self, bit: usize) -> u64 {
        let lt = self.lt_ref();
        lt.bit_start_quantum(bit) as u64 * self.btr.clocks_per_tq() as u64
    }

    /// Every change of the IUT's drive while the LT played script bits `from_bit..to_bit`, as
    /// (clocks from the start of the LT's script, new level). The IUT's drive changes at its clock
    /// edges, which are the LT's (same clock).
    pub fn iut_edges(&self, from_bit: usize, to_bit: usize) -> Vec<(u64, bool)> {
        let lt = self.lt_ref();
        let period = self.clock.period_fs();
        let start = lt.started_at().expect("LT started");
        let from = lt.bit_time(from_bit).expect("LT started");
        let to = lt.bit_time(to_bit).expect("LT started");
        let mut level = self.engine.drive_before(self.iut, from).level();
        let mut edges = Vec::new();
        let mut t = self
            .clock
            .edge(from.saturating_sub(self.clock.edge(0)).div_ceil(period));
        while t < to {
            let after = self.engine.drive_before(self.iut, t + 1).level();
            if after != level {
                edges.push(((t - start) / period, after));
                level = after;
            }
            t += period;
        }
        edges
    }

    /// Whether the IUT drove dominant at the LT's sample point of script bit `bit`.
    pub fn iut_dominant_in(&self, bit: usize) -> bool {
        let lt = self.lt_ref();
        let at = lt.bit_time(bit).expect("LT started") + self.sample_point_tq() as u64 * lt.tq_fs();
        self.engine.drive_before(self.iut, at) == Drive::Dominant
    }

    /// The script bits in `from..to` where the IUT drove dominant.
    pub fn iut_dominant_bits(&self, from: usize, to: usize) -> Vec<usize> {
        (from..to).filter(|&b| self.iut_dominant_in(b)).collect()
    }

    /// The IUT's events, without times.
    pub fn iut_events(&self) -> Vec<NodeEvent> {
        self.iut().events().iter().map(|(_, e)| e.clone()).collect()
    }
}

impl Default for ProtocolBench {
    fn default() -> Self {
        ProtocolBench::new()
    }
}

/// `frame` as a receiver expects it on the bus: SOF to EOF with the ACK slot left recessive for the IUT.
pub fn lt_frame(frame: &Frame) -> EncodedFrame {
    encode(frame)
}

/// The encoded bits of `frame` with the ACK slot dominant (a receiver acknowledged it).
pub fn acknowledged_bits(frame: &EncodedFrame) -> Vec<bool> {
    let ack = frame.position(Field::AckSlot, 0).expect("ack slot");
    let mut bits: Vec<bool> = frame.bits.iter().by_vals().collect();
    bits[ack] = DOMINANT;
    bits
}
