//! Bench for the protocol scenarios: a lower tester (LT) and one node under test (IUT) on a 16 MHz
//! clock in configuration BT-A (TSEG1 11, TSEG2 4, SJW 2, BRP 0: 500 kbit/s), the catalog's default
//! setup (error active, counters 0, integrated). Queries are in LT script bits: "what did the IUT
//! drive in bit i" reads the IUT's drive at the LT's sample point of script bit i.
//!
//! A scenario is written once and runs on either IUT ([`Iut`]): the bare RTL core, driven through its
//! internal interface and observed through its strobes, or the complete controller, driven and
//! observed only through its SJA1000 registers by an interrupt-driven host
//! ([`crate::register_iut`]). Stimuli and queries are methods of the bench that do the same thing
//! on both; [`ProtocolBench::registers`], [`ProtocolBench::interrupt_passes`] and
//! [`ProtocolBench::error_interrupts`] give what only the controller has.
//! A stimulus returns once it has taken effect (the core has seen it at a clock edge; the register
//! write is done), and a query first lets the controller's interrupt handler finish.

use golden::btr::Btr;
use golden::frame::{encode, EncodedFrame, Field, Frame, DOMINANT};
use rtl::registers::{command, interrupt, mode, pelican, status};
use sim::engine::bus::Drive;
use sim::engine::time::ClockSpec;
use sim::engine::{DeviceId, Engine};
use sim::nodes::can_node::{CanNode, NodeEvent};
use sim::nodes::controller_node::ModelEngine;
use sim::nodes::lower_tester::LowerTester;

use crate::controller_bench::{configure_pelican_for, rx_buffer_bytes};
use crate::register_iut::{InterruptPass, IutHost, RegisterIut};
use crate::skipping::{self, IutTrace};
use crate::{bench_engine, CLOCK_HZ};
use sim::host::sja1000::transmit;

/// Idle bits before the first frame: the IUT needs 11 recessive bits to integrate.
pub const INTEGRATION_BITS: usize = 14;

/// The six bits of an error (or overload) flag after an error detected at bit `e`.
pub fn flag_after(e: usize) -> Vec<usize> {
    (e + 1..=e + 6).collect()
}

/// The bits of `encoded` (stuff bits included).
pub fn bits_of(encoded: &EncodedFrame) -> Vec<bool> {
    encoded.bits.iter().by_vals().collect()
}

/// The position of bit `index` of field `f` in `encoded` (the frame has that field).
pub fn field(encoded: &EncodedFrame, f: Field, index: u16) -> usize {
    encoded.position(f, index).unwrap()
}

/// The position of the first dominant bit among bits `indices` of field `f` of `encoded` (a bit
/// the transmitter sends dominant, for a bit error the LT can force).
pub fn first_dominant(encoded: &EncodedFrame, f: Field, indices: std::ops::Range<u16>) -> usize {
    indices
        .map(|i| field(encoded, f, i))
        .find(|&p| encoded.bits[p] == DOMINANT)
        .unwrap()
}

/// Script steps of the lower tester that the protocol tests share.
pub trait LtScript {
    /// Lets the IUT integrate: [`INTEGRATION_BITS`] recessive bits.
    fn after_integration(&mut self) -> &mut Self;
    /// Sends `frame` as encoded (stuff bits included), every bit nominal.
    fn send_frame(&mut self, frame: &EncodedFrame) -> &mut Self;
}

impl LtScript for LowerTester {
    fn after_integration(&mut self) -> &mut Self {
        self.release(INTEGRATION_BITS)
    }

    fn send_frame(&mut self, frame: &EncodedFrame) -> &mut Self {
        self.send_bits(frame.bits.iter().by_vals())
    }
}

/// The counter value from which a node is error passive.
pub const ERROR_PASSIVE_LIMIT: u8 = 128;

/// The catalog's default configuration BT-A with BRP 0.
pub fn bt_a() -> Btr {
    Btr::from_quanta(0, 11, 4, 2, false).expect("BT-A")
}

/// The implementation under test of a scenario.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Iut {
    /// The RTL CAN core ([`CanNode`]): requests, counter loads and aborts through the core's
    /// interface; observed through its strobes (events at their clock edge) and counter outputs.
    Core,
    /// The complete controller ([`RegisterIut`]) in the catalog's default setup (PeliCAN, filter
    /// open, every interrupt enabled, EWLR 96), reached only through its registers: TX buffer and
    /// CMR, TXERR/RXERR written in reset mode, MOD; observed by its interrupt handler (IR, SR, ECC,
    /// ALC, RMC, the RX buffer) and by reads of SR, TXERR and RXERR.
    Registers,
}

/// The LT's start: at its first clock edge, or at the first dominant edge on the bus.
#[derive(Clone, Copy, PartialEq, Eq)]
enum LtStart {
    AtOnce,
    OnDominant,
}

/// LT + IUT.
pub struct ProtocolBench {
    /// The engine (public for scenario-specific queries).
    pub engine: Engine,
    lt: DeviceId,
    iut: DeviceId,
    kind: Iut,
    btr: Btr,
    clock: ClockSpec,
}

impl ProtocolBench {
    /// A bench whose LT starts playing at once (the IUT receives).
    pub fn new(iut: Iut) -> ProtocolBench {
        ProtocolBench::with_btr(iut, bt_a())
    }

    /// The IUT receives: its REC preset to `rec` (if any), the LT sends `bits` after the
    /// integration time and releases the bus for `extra_bits`; the bench has run one bit.
    pub fn receive_bits(
        iut: Iut,
        bits: impl IntoIterator<Item = bool>,
        rec: Option<u8>,
        extra_bits: usize,
    ) -> ProtocolBench {
        ProtocolBench::receive_with(iut, bits, rec, extra_bits, |_| {})
    }

    /// As [`ProtocolBench::receive_bits`], with the LT script edited by `edit` before it plays
    /// (positions in script bits).
    pub fn receive_with(
        iut: Iut,
        bits: impl IntoIterator<Item = bool>,
        rec: Option<u8>,
        extra_bits: usize,
        edit: impl FnOnce(&mut LowerTester),
    ) -> ProtocolBench {
        let mut bench = ProtocolBench::new(iut);
        if let Some(rec) = rec {
            bench.load_counter(false, rec);
        }
        bench
            .lt()
            .after_integration()
            .send_bits(bits)
            .release(extra_bits);
        edit(bench.lt());
        bench.run(1);
        bench
    }

    /// As [`ProtocolBench::new`], with the bit timing `btr` for both the LT and the IUT.
    pub fn with_btr(iut: Iut, btr: Btr) -> ProtocolBench {
        ProtocolBench::with_clock(iut, btr, ClockSpec::from_hz(CLOCK_HZ))
    }

    /// As [`ProtocolBench::with_btr`], with the LT and the IUT both on `clock` (e.g. a clock some
    /// ppm off the nominal 16 MHz), so the LT's script bits stay the IUT's bits.
    pub fn with_clock(iut: Iut, btr: Btr, clock: ClockSpec) -> ProtocolBench {
        ProtocolBench::build(iut, btr, clock, LtStart::AtOnce)
    }

    /// The bench, with the controller configured (the LT plays meanwhile) and operating.
    fn build(kind: Iut, btr: Btr, clock: ClockSpec, start: LtStart) -> ProtocolBench {
        let mut engine = bench_engine(&btr, clock);
        engine.keep_history();
        let mut lt = LowerTester::new("lt", clock, btr);
        if start == LtStart::OnDominant {
            lt.start_on_dominant();
        }
        let lt = engine.add(lt, 0);
        // A skipping check names the engine; otherwise `CAN_ENGINE` does.
        let checking = skipping::engine();
        let on =
            checking.unwrap_or_else(|| ModelEngine::from_env().unwrap_or_else(|e| panic!("{e}")));
        let iut = match kind {
            Iut::Core => {
                let node = CanNode::with_engine("iut", clock, btr, on)
                    .unwrap_or_else(|e| panic!("the core on {on}: {e}"));
                engine.add(node, 0)
            }
            Iut::Registers => {
                let mut node = RegisterIut::with_engine("iut", clock, on);
                if checking.is_some() {
                    node.record_accesses();
                }
                engine.add(node, 0)
            }
        };
        let mut bench = ProtocolBench {
            engine,
            lt,
            iut,
            kind,
            btr,
            clock,
        };
        if let Some(mut host) = bench.host() {
            configure_pelican_for(&mut host, btr);
            host.write(pelican::MOD, 0);
        }
        bench
    }

    /// A bench where the IUT transmits `frame` once integrated; the LT's script starts at the IUT's
    /// SOF edge (script bit 0 is the SOF).
    pub fn iut_transmits(iut: Iut, frame: &Frame) -> ProtocolBench {
        ProtocolBench::iut_transmits_with(iut, frame, 0, false)
    }

    /// As [`ProtocolBench::iut_transmits`], with the IUT's TEC preset to `tec` before integration and
    /// a single-shot request if `single_shot`.
    pub fn iut_transmits_with(
        iut: Iut,
        frame: &Frame,
        tec: u8,
        single_shot: bool,
    ) -> ProtocolBench {
        let clock = ClockSpec::from_hz(CLOCK_HZ);
        let bench = ProtocolBench::build(iut, bt_a(), clock, LtStart::OnDominant);
        bench.transmitting(frame, tec, single_shot)
    }

    /// As [`ProtocolBench::iut_transmits`], with the bit timing `btr` for both the LT and the IUT.
    pub fn iut_transmits_in(iut: Iut, btr: Btr, frame: &Frame) -> ProtocolBench {
        ProtocolBench::iut_transmits_on(iut, btr, ClockSpec::from_hz(CLOCK_HZ), frame)
    }

    /// As [`ProtocolBench::iut_transmits_in`], with the LT and the IUT on `clock`
    /// (see [`ProtocolBench::with_clock`]).
    pub fn iut_transmits_on(iut: Iut, btr: Btr, clock: ClockSpec, frame: &Frame) -> ProtocolBench {
        let bench = ProtocolBench::build(iut, btr, clock, LtStart::OnDominant);
        bench.transmitting(frame, 0, false)
    }

    fn transmitting(mut self, frame: &Frame, tec: u8, single_shot: bool) -> ProtocolBench {
        self.load_counter(true, tec);
        self.integrate();
        self.send(frame, single_shot);
        self
    }

    /// A bench where the IUT, with its TEC preset to `tec`, transmits `frame` once integrated and the
    /// LT acknowledges it; the script is played to its end plus one bit.
    pub fn iut_transmits_acknowledged(iut: Iut, frame: &Frame, tec: u8) -> ProtocolBench {
        let encoded = encode(frame);
        let ack = encoded.position(Field::AckSlot, 0).expect("ack slot");
        let mut bench = ProtocolBench::iut_transmits_with(iut, frame, tec, false);
        bench
            .lt()
            .release(encoded.len() + 4)
            .set_bit(ack, Drive::Dominant);
        bench.run(1);
        bench
    }

    /// Lets the IUT integrate (runs the bus idle for [`INTEGRATION_BITS`]) before the LT's script.
    pub fn integrate(&mut self) {
        self.run_bits(INTEGRATION_BITS as u64);
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

    /// Runs until the LT has played its script, then `extra_bits` more bits.
    pub fn run(&mut self, extra_bits: usize) {
        let lt = self.lt;
        let limit = self.engine.now() + sim::engine::time::FS_PER_S;
        let done = self
            .engine
            .run_while(limit, |e| e.device::<LowerTester>(lt).finished())
            .expect("simulation");
        assert!(
            done,
            "the lower tester never started or never finished its script"
        );
        self.run_bits(extra_bits as u64);
    }

    /// Runs `bits` bit times.
    pub fn run_bits(&mut self, bits: u64) {
        let end = self.engine.now() + bits * self.bit_fs();
        self.engine.run_until(end).expect("simulation");
    }

    /// Runs until the IUT has reported `event` or `max_bits` bit times pass; returns whether it has.
    /// (Through the registers an event is known once the interrupt handler has read it.)
    pub fn run_until_event(&mut self, max_bits: u64, event: &NodeEvent) -> bool {
        let (iut, kind) = (self.iut, self.kind);
        let limit = self.engine.now() + max_bits * self.bit_fs();
        self.engine
            .run_while(limit, |e| {
                event_list(e, iut, kind)
                    .iter()
                    .any(|(_, seen)| seen == event)
            })
            .expect("simulation")
    }

    /// Runs until the IUT drives the bus dominant or `max_bits` bit times pass; returns whether it
    /// did.
    pub fn run_until_iut_dominant(&mut self, max_bits: u64) -> bool {
        let iut = self.iut;
        let limit = self.engine.now() + max_bits * self.bit_fs();
        self.engine
            .run_while(limit, |e| {
                e.drive_before(iut, e.now() + 1) == Drive::Dominant
            })
            .expect("simulation")
    }

    /// One nominal bit time in femtoseconds.
    pub fn bit_fs(&self) -> u64 {
        self.btr.clocks_per_bit() as u64 * self.clock.period_fs()
    }

    /// Runs until script bit `bit` of the LT starts (first until the LT starts, if it has not).
    pub fn run_to_bit(&mut self, bit: usize) {
        if self.lt_ref().started_at().is_none() {
            let lt = self.lt;
            let limit = self.engine.now() + sim::engine::time::FS_PER_S;
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
    pub fn iut_events(&mut self) -> Vec<NodeEvent> {
        self.iut_timed_events()
            .into_iter()
            .map(|(_, e)| e)
            .collect()
    }

    /// The IUT's events with their times: the clock edge of the core's strobe, or through the
    /// registers the edge of the IR read that found them.
    pub fn iut_timed_events(&mut self) -> Vec<(u64, NodeEvent)> {
        self.settle();
        event_list(&self.engine, self.iut, self.kind).to_vec()
    }

    /// The frames the IUT received, in order.
    pub fn received(&mut self) -> Vec<Frame> {
        self.iut_events()
            .into_iter()
            .filter_map(|e| match e {
                NodeEvent::Received(f) => Some(f),
                _ => None,
            })
            .collect()
    }

    /// The ECC values of the IUT's bus errors, in order.
    pub fn bus_errors(&mut self) -> Vec<u8> {
        self.iut_events()
            .into_iter()
            .filter_map(|e| match e {
                NodeEvent::BusError(ecc) => Some(ecc),
                _ => None,
            })
            .collect()
    }

    /// The transmit error counter (TXERR through the registers).
    pub fn tec(&mut self) -> u8 {
        match self.host() {
            Some(mut host) => host.read(pelican::TXERR),
            None => self.core_node().tec(),
        }
    }

    /// The receive error counter (RXERR through the registers).
    pub fn rec(&mut self) -> u8 {
        match self.host() {
            Some(mut host) => host.read(pelican::RXERR),
            None => self.core_node().rec(),
        }
    }

    /// Bus-off (SR.BS through the registers).
    pub fn bus_off(&mut self) -> bool {
        match self.host() {
            Some(mut host) => host.read(pelican::SR) & status::BS != 0,
            None => self.core_node().bus_off(),
        }
    }

    /// Error passive: through the registers, what a host concludes from them (not bus-off, and
    /// TXERR or RXERR at least [`ERROR_PASSIVE_LIMIT`]); EPI is checked where the scenarios expect
    /// it.
    pub fn error_passive(&mut self) -> bool {
        if self.kind == Iut::Core {
            return self.core_node().error_passive();
        }
        let (tec, rec) = (self.tec(), self.rec());
        !self.bus_off() && tec.max(rec) >= ERROR_PASSIVE_LIMIT
    }

    /// A transmission request is pending (SR.TBS = 0 through the registers).
    pub fn transmit_pending(&mut self) -> bool {
        match self.host() {
            Some(mut host) => host.read(pelican::SR) & status::TBS == 0,
            None => self.core_node().transmit_pending(),
        }
    }

    /// Requests the transmission of `frame` (automatic retransmission, or one attempt only with
    /// `single_shot`): through the registers the TX buffer and CMR = TR (TR + AT for single shot),
    /// after SR shows the buffer free.
    pub fn send(&mut self, frame: &Frame, single_shot: bool) {
        match self.host() {
            Some(mut host) => {
                assert!(
                    host.read(pelican::SR) & status::TBS != 0,
                    "a transmission is already pending"
                );
                let cmd = if single_shot {
                    command::TR | command::AT
                } else {
                    command::TR
                };
                transmit(&mut host, frame, cmd);
            }
            None => self.apply_to_core(|core| core.send(frame, single_shot)),
        }
    }

    /// Aborts the pending request (CMR = AT): a frame not under transmission is not sent; an
    /// attempt under way finishes and is not retried.
    pub fn abort(&mut self) {
        match self.host() {
            Some(mut host) => host.write(pelican::CMR, command::AT),
            None => self.apply_to_core(CanNode::abort),
        }
    }

    /// Operating mode (`true`) or reset mode (`false`): MOD.RM through the registers.
    pub fn set_enable(&mut self, enable: bool) {
        match self.host() {
            Some(mut host) => host.write(pelican::MOD, if enable { 0 } else { mode::RM }),
            None => self.apply_to_core(|core| core.set_enable(enable)),
        }
    }

    /// The host clears MOD.RM at the start of script bit `bit`, after a bus-off (the SJA1000 sets RM
    /// at bus-off, and bus-off recovery counts recessive bits from the host's write). The core has no
    /// RM: the bench holds it in reset mode until `bit`, which keeps its count of recessive bits at 0
    /// as RM does on the controller.
    pub fn clear_reset_mode_at(&mut self, bit: usize) {
        self.set_enable(false);
        self.run_to_bit(bit);
        self.set_enable(true);
    }

    /// Loads TEC (`tec` = true) or REC with `value`, like a host write of TXERR/RXERR in reset
    /// mode. Through the registers it is that write; an IUT in operating mode enters reset mode for
    /// it and leaves it again (and integrates anew).
    pub fn load_counter(&mut self, tec: bool, value: u8) {
        let Some(mut host) = self.host() else {
            self.apply_to_core(|core| core.load_counter(tec, value));
            return;
        };
        let operating = host.read(pelican::MOD) & mode::RM == 0;
        if operating {
            host.write(pelican::MOD, mode::RM);
        }
        host.write(if tec { pelican::TXERR } else { pelican::RXERR }, value);
        if operating {
            host.write(pelican::MOD, 0);
        }
    }

    /// The IUT's device id.
    pub fn iut_id(&self) -> DeviceId {
        self.iut
    }

    /// Register access to the controller (after its interrupt handler has serviced what is
    /// pending), if the IUT is the complete controller.
    pub fn registers(&mut self) -> Option<IutHost<'_>> {
        self.settle();
        self.host()
    }

    /// Every pass of the controller's interrupt handler, if the IUT is the complete controller.
    pub fn interrupt_passes(&mut self) -> Option<Vec<InterruptPass>> {
        self.registers()
            .map(|host| host.iut().interrupt_passes().to_vec())
    }

    /// Through the registers: one interrupt, RI, with RMC 1 and exactly `frame`'s bytes in the RX
    /// buffer (nothing to check on the core, whose `Received` event is all there is).
    pub fn assert_stored_through_registers(&mut self, frame: &Frame, what: &str) {
        if let Some(passes) = self.interrupt_passes() {
            let [pass] = &passes[..] else {
                panic!("{what}: one interrupt: {passes:?}");
            };
            assert_eq!(pass.ir, interrupt::RI, "{what}: RI");
            assert_eq!(pass.rmc, Some(1), "{what}: RMC");
            assert_eq!(
                pass.rx_bytes.as_deref(),
                Some(&rx_buffer_bytes(frame)[..]),
                "{what}: RX buffer"
            );
        }
    }

    /// On the IUT observed through its registers, its error interrupts (EI, EPI with ES and
    /// the counters at each) are `expected`, else panics with `why`; the bare core has no interrupt
    /// register, so there is nothing to check on it.
    pub fn assert_error_interrupts(&mut self, expected: &[ErrorInterrupt], why: &str) {
        if let Some(interrupts) = self.error_interrupts() {
            assert_eq!(interrupts, expected, "{why}");
        }
    }

    /// The error-status interrupts (EI, EPI) the controller's handler serviced, oldest first, if the
    /// IUT is the complete controller.
    pub fn error_interrupts(&mut self) -> Option<Vec<ErrorInterrupt>> {
        let passes = self.interrupt_passes()?;
        let error_bits = interrupt::EI | interrupt::EPI;
        let interrupts = passes
            .iter()
            .filter(|pass| pass.ir & error_bits != 0)
            .map(|pass| ErrorInterrupt {
                bits: pass.ir & error_bits,
                warning: pass.sr & status::ES != 0,
                bus_off: pass.sr & status::BS != 0,
                counters: pass
                    .counters
                    .expect("the handler reads the counters on EI/EPI"),
            })
            .collect();
        Some(interrupts)
    }

    /// Lets the controller's interrupt handler service what is pending (nothing to do on the core,
    /// whose events are known at their clock edge).
    fn settle(&mut self) {
        if let Some(mut host) = self.host() {
            host.settle();
        }
    }

    fn host(&mut self) -> Option<IutHost<'_>> {
        (self.kind == Iut::Registers).then(|| IutHost::new(&mut self.engine, self.iut))
    }

    fn core_node(&self) -> &CanNode {
        self.engine.device(self.iut)
    }

    /// Changes the core's inputs with `change` and runs one clock cycle, so that the core has taken
    /// them when the bench goes on (as a register write has when the host's access returns).
    fn apply_to_core(&mut self, change: impl FnOnce(&mut CanNode)) {
        change(self.engine.device_mut(self.iut));
        let end = self.engine.now() + self.clock.period_fs();
        self.engine.run_until(end).expect("simulation");
    }
}

/// An EI or EPI interrupt as the controller's interrupt handler saw it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ErrorInterrupt {
    /// The EI and EPI bits of IR.
    pub bits: u8,
    /// SR.ES (a counter at or above EWLR).
    pub warning: bool,
    /// SR.BS.
    pub bus_off: bool,
    /// (TXERR, RXERR).
    pub counters: (u8, u8),
}

impl ErrorInterrupt {
    /// An interrupt with the IR bits `bits`, SR.ES `warning`, SR.BS = 0 and the counters
    /// (TXERR, RXERR).
    pub fn new(bits: u8, warning: bool, counters: (u8, u8)) -> ErrorInterrupt {
        ErrorInterrupt {
            bits,
            warning,
            bus_off: false,
            counters,
        }
    }
}

/// The events the IUT `iut` of kind `kind` has reported so far.
/// A bench built during a skipping check leaves what its IUT did there.
impl Drop for ProtocolBench {
    fn drop(&mut self) {
        skipping::record(|| IutTrace {
            drive: self.engine.drive_changes(self.iut),
            events: event_list(&self.engine, self.iut, self.kind).to_vec(),
            accesses: match self.kind {
                Iut::Core => Vec::new(),
                Iut::Registers => self
                    .engine
                    .device::<RegisterIut>(self.iut)
                    .accesses()
                    .to_vec(),
            },
            skipped_edges: self.engine.skipped_edges(),
        });
    }
}

fn event_list(engine: &Engine, iut: DeviceId, kind: Iut) -> &[(u64, NodeEvent)] {
    match kind {
        Iut::Core => engine.device::<CanNode>(iut).events(),
        Iut::Registers => engine.device::<RegisterIut>(iut).events(),
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
