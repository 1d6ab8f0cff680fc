//! A model of the Linux SocketCAN SJA1000 driver (`drivers/net/can/sja1000/sja1000.c`) at register
//! level: the same register accesses in the same order as the driver makes them, so a testbench can
//! replay what Linux does to the controller and see whether the controller answers as an SJA1000
//! would. Written from the description in `docs/SJA1000.md` ("What the Linux driver needs") and the
//! driver's documented behaviour, not from its code.
//!
//! Every method talks to one [`ControllerNode`](crate::nodes::controller_node::ControllerNode) through a
//! [`Host`]: each access is one controller clock cycle while the whole engine keeps running. The
//! kernel side (socket buffers, the echo skb, netif queue, error frames) is reduced to what a test
//! observes: typed [`DriverEvent`]s, the device [`CanState`] and [`DriverStats`].
//!
//! What the model does, per driver entry point:
//! * probe ([`Sja1000Driver::probe`]): MOD must not read 0xFF; reset mode; CDR (PeliCAN and the
//!   board's comparator-bypass / CLKOUT settings), an open acceptance filter (or the board's
//!   [`DriverConfig::filter`]), OCR in normal mode;
//! * open: [`Sja1000Driver::set_bittiming`] (or [`Sja1000Driver::set_bitrate`]), then
//!   [`Sja1000Driver::start`] with the control modes;
//! * `ndo_start_xmit` ([`Sja1000Driver::transmit`]): one frame in flight at a time (the queue is
//!   stopped until TI);
//! * the interrupt handler ([`Sja1000Driver::interrupt`]);
//! * the bus-off restart ([`Sja1000Driver::restart`]) and close ([`Sja1000Driver::stop`]).

use std::fmt;

use rtl::registers::{clock_divider, command, interrupt, mode, pelican, status};

use crate::engine::{DeviceId, Engine};
use crate::host::acceptance::FilterConfig;
use crate::host::sja1000::{load_tx_buffer, read_rx_message};
use crate::host::Host;
use golden::btr::{calc_bittiming, BitTimingError, Btr};
use golden::frame::Frame;

/// Most iterations of the interrupt handler's loop per call (the driver's `SJA1000_MAX_IRQ`).
pub const MAX_IRQ_LOOPS: usize = 20;
/// Most writes of MOD while waiting for the reset bit to change (the driver polls 100 times).
pub const MODE_POLL_ATTEMPTS: usize = 100;
/// IER value that disables every interrupt (the driver's `IRQ_OFF`).
pub const IRQ_OFF: u8 = 0x00;
/// IER value with every interrupt enabled (the driver's `IRQ_ALL`).
pub const IRQ_ALL: u8 = 0xFF;
/// OCR normal output mode (OCR bits 1..0 = 10), or-ed into the board's OCR at probe.
pub const OCR_MODE_NORMAL: u8 = 0x02;
/// Interrupts handled by the driver's error path.
const ERROR_INTERRUPTS: u8 =
    interrupt::DOI | interrupt::EI | interrupt::BEI | interrupt::EPI | interrupt::ALI;

/// Board settings the driver gets from the platform (device tree or PCI glue).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriverConfig {
    /// The controller clock (SJA1000 fosc) in Hz; the bit-timing calculator works on it.
    pub clock_hz: u32,
    /// CDR.6: bypass the input comparator.
    pub comparator_bypass: bool,
    /// CLKOUT divider code (CDR bits 2..0) or `None` for CLKOUT off (CDR.3).
    pub clock_out: Option<u8>,
    /// The board's output control (OCR) value; the driver adds [`OCR_MODE_NORMAL`].
    pub ocr: u8,
    /// Delay between a MOD write and its read-back while polling the reset bit (the driver's
    /// `udelay(10)`), in microseconds of controller clock.
    pub mode_poll_delay_us: u32,
    /// The acceptance filter written at chip initialisation (ACR0..3, AMR0..3) and MOD.AFM set
    /// with every mode change. The mainline driver always opens the filter ([`open_filter`]); a
    /// board that filters in hardware sets its own.
    pub filter: FilterConfig,
}

/// The filter the mainline driver writes: ACR = 0x00, AMR = 0xFF (every frame passes), dual
/// filter mode (MOD.AFM = 0).
pub fn open_filter() -> FilterConfig {
    FilterConfig::dual([0x00; 4], [0xFF; 4])
}

impl Default for DriverConfig {
    /// A typical board: 16 MHz, comparator bypassed, CLKOUT off, TX0 push-pull (OCR 0x18), 10 µs
    /// polling delay.
    fn default() -> Self {
        DriverConfig {
            clock_hz: 16_000_000,
            comparator_bypass: true,
            clock_out: None,
            ocr: 0x18,
            mode_poll_delay_us: 10,
            filter: open_filter(),
        }
    }
}

impl DriverConfig {
    /// The CDR value written at probe: PeliCAN plus the board's comparator and CLKOUT settings.
    pub fn cdr(&self) -> u8 {
        let mut cdr = clock_divider::PELICAN;
        if self.comparator_bypass {
            cdr |= clock_divider::CBP;
        }
        match self.clock_out {
            Some(divider) => cdr |= divider & clock_divider::DIVIDER,
            None => cdr |= clock_divider::CLOCK_OFF,
        }
        cdr
    }

    /// MOD.AFM as the filter needs it.
    fn filter_mode(&self) -> u8 {
        if self.filter.single_filter {
            mode::AFM
        } else {
            0
        }
    }

    /// The MOD polling delay in controller clock cycles.
    pub fn mode_poll_delay_cycles(&self) -> u64 {
        u64::from(self.clock_hz) * u64::from(self.mode_poll_delay_us) / 1_000_000
    }
}

/// The SocketCAN control modes the driver supports (`ip link set ... type can ...`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CtrlMode {
    /// `listen-only on`: MOD.LOM.
    pub listen_only: bool,
    /// `presume-ack on`: MOD.STM (a transmission succeeds without an ACK).
    pub presume_ack: bool,
    /// `one-shot on`: every transmission request carries CMR.AT (single shot).
    pub one_shot: bool,
    /// `berr-reporting on`: the bus error interrupt (BEI) is enabled.
    pub berr_reporting: bool,
}

impl CtrlMode {
    /// The MOD value that leaves reset mode with these modes.
    pub fn mod_value(&self) -> u8 {
        let mut value = 0;
        if self.listen_only {
            value |= mode::LOM;
        }
        if self.presume_ack {
            value |= mode::STM;
        }
        value
    }

    /// The IER value written once the controller runs.
    pub fn ier_value(&self) -> u8 {
        if self.berr_reporting {
            IRQ_ALL
        } else {
            IRQ_ALL & !interrupt::BEI
        }
    }
}

/// The SocketCAN device state (`enum can_state`) as the driver tracks it, ordered by severity as
/// in the kernel (a change to a higher state counts in [`DriverStats`]); `Stopped` comes last.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum CanState {
    /// Both error counters below the warning limit.
    ErrorActive,
    /// A counter at or above the warning limit (SR.ES).
    ErrorWarning,
    /// A counter above 127 (as tracked through EPI).
    ErrorPassive,
    /// Bus-off (SR.BS); the controller is in reset mode.
    BusOff,
    /// The device is down: the controller is held in reset mode.
    Stopped,
}

impl fmt::Display for CanState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CanState::ErrorActive => "error-active",
            CanState::ErrorWarning => "error-warning",
            CanState::ErrorPassive => "error-passive",
            CanState::BusOff => "bus-off",
            CanState::Stopped => "stopped",
        })
    }
}

/// The error counters as the driver reads them on every error interrupt (TXERR, then RXERR).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ErrorCounters {
    /// TXERR.
    pub txerr: u8,
    /// RXERR.
    pub rxerr: u8,
}

/// What the driver reports upwards from an interrupt.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DriverEvent {
    /// WUI: the controller woke up.
    WakeUp,
    /// TI: the frame in flight was sent (its echo is delivered).
    TxDone(Frame),
    /// TI in one-shot mode with SR.TCS = 0: the single attempt failed; the frame is dropped.
    TxFailed(Frame),
    /// The frame in flight was dropped because the controller went bus-off (or was put into
    /// reset mode) before it completed.
    TxDropped(Frame),
    /// A frame read from the RX buffer (including own frames sent with self-reception).
    Received(Frame),
    /// DOI: a message was lost for lack of FIFO space; the driver wrote CMR.CDO.
    Overrun(ErrorCounters),
    /// BEI: a bus error; `ecc` is the ECC value the driver read.
    BusError {
        /// The error code capture register.
        ecc: u8,
        /// TXERR and RXERR.
        counters: ErrorCounters,
    },
    /// ALI: arbitration lost; `alc` is the ALC value the driver read (bits 4..0 are the position).
    ArbitrationLost {
        /// The arbitration lost capture register.
        alc: u8,
        /// TXERR and RXERR.
        counters: ErrorCounters,
    },
    /// The device state changed (from EI, EPI or both in one IR value).
    StateChanged {
        /// The new state.
        state: CanState,
        /// The IR value that caused the change.
        ir: u8,
        /// The SR value read with it.
        sr: u8,
        /// TXERR and RXERR.
        counters: ErrorCounters,
    },
    /// TI without a frame in flight (the driver would deliver an empty echo).
    SpuriousTxInterrupt {
        /// The SR value read with it.
        sr: u8,
    },
}

/// The driver's statistics (net device stats and CAN device stats, as far as modelled).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DriverStats {
    /// Frames sent successfully (TI with TCS, or TI outside one-shot mode).
    pub tx_frames: u64,
    /// One-shot transmissions that failed (TI with TCS = 0).
    pub tx_failed: u64,
    /// Frames in flight dropped by bus-off, stop or a start from a running state.
    pub tx_dropped: u64,
    /// Frames read from the RX FIFO.
    pub rx_frames: u64,
    /// Data overruns (DOI).
    pub rx_overruns: u64,
    /// Bus errors (BEI).
    pub bus_errors: u64,
    /// Bus errors while transmitting (ECC.DIR = 0).
    pub bus_errors_tx: u64,
    /// Bus errors while receiving (ECC.DIR = 1).
    pub bus_errors_rx: u64,
    /// Arbitration losses (ALI).
    pub arbitration_lost: u64,
    /// Changes up to error-warning.
    pub error_warning: u64,
    /// Changes up to error-passive.
    pub error_passive: u64,
    /// Changes to bus-off.
    pub bus_off: u64,
    /// Bus-off restarts.
    pub restarts: u64,
    /// Wake-ups (WUI).
    pub wakeups: u64,
    /// TI without a frame in flight.
    pub spurious_tx: u64,
    /// Interrupts handled, per IR bit (index = bit number: RI, TI, EI, DOI, WUI, EPI, ALI, BEI).
    pub interrupts: [u64; 8],
}

/// Why a driver operation failed.
#[derive(Clone, Debug, PartialEq)]
pub enum DriverError {
    /// MOD reads 0xFF: no controller answers (the driver's `sja1000_is_absent`).
    NoChip {
        /// The MOD value read.
        mod_value: u8,
    },
    /// MOD.RM did not read 1 after [`MODE_POLL_ATTEMPTS`] writes of MOD = RM.
    ResetModeFailed {
        /// The last MOD value read.
        mod_value: u8,
    },
    /// MOD.RM did not read 0 after [`MODE_POLL_ATTEMPTS`] writes of the operating mode.
    NormalModeFailed {
        /// The MOD value written.
        written: u8,
        /// The last MOD value read.
        mod_value: u8,
    },
    /// The bit timing can only be set while the device is stopped.
    NotStopped(CanState),
    /// The device is not running (stopped or bus-off): no transmission.
    NotRunning(CanState),
    /// A restart is only possible from bus-off.
    NotBusOff(CanState),
    /// The queue is stopped: the previous frame is still in flight (SR.TBS = 0 until TI).
    TxBusy {
        /// The frame in flight.
        in_flight: Frame,
    },
    /// The bit-timing calculator found no setting.
    BitTiming(BitTimingError),
}

impl fmt::Display for DriverError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DriverError::NoChip { mod_value } => {
                write!(f, "MOD reads {mod_value:#04x}: no SJA1000 present")
            }
            DriverError::ResetModeFailed { mod_value } => write!(
                f,
                "MOD reads {mod_value:#04x} after {MODE_POLL_ATTEMPTS} writes of MOD = {:#04x}: \
                 reset mode not entered",
                mode::RM
            ),
            DriverError::NormalModeFailed { written, mod_value } => write!(
                f,
                "MOD reads {mod_value:#04x} after {MODE_POLL_ATTEMPTS} writes of MOD = \
                 {written:#04x}: operating mode not entered"
            ),
            DriverError::NotStopped(state) => {
                write!(
                    f,
                    "device is {state}: BTR0/BTR1 can only be set while stopped"
                )
            }
            DriverError::NotRunning(state) => {
                write!(f, "device is {state}: no transmission (CMR not written)")
            }
            DriverError::NotBusOff(state) => {
                write!(f, "device is {state}: restart only from bus-off")
            }
            DriverError::TxBusy { in_flight } => write!(
                f,
                "queue stopped: frame {in_flight} still in flight (TBS = 0 until TI)"
            ),
            DriverError::BitTiming(e) => write!(f, "bit timing: {e}"),
        }
    }
}

impl std::error::Error for DriverError {}

/// The frame the driver handed to the controller and has not seen TI for yet (the echo skb).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct InFlight {
    frame: Frame,
    loopback: bool,
}

/// The Linux SJA1000 driver bound to one controller.
#[derive(Clone, Debug)]
pub struct Sja1000Driver {
    node: DeviceId,
    config: DriverConfig,
    ctrl_mode: CtrlMode,
    state: CanState,
    in_flight: Option<InFlight>,
    stats: DriverStats,
}

impl Sja1000Driver {
    /// A driver for the controller `node` of an engine, on a board described by `config`. Nothing
    /// is accessed until [`Sja1000Driver::probe`].
    pub fn new(node: DeviceId, config: DriverConfig) -> Sja1000Driver {
        Sja1000Driver {
            node,
            config,
            ctrl_mode: CtrlMode::default(),
            state: CanState::Stopped,
            in_flight: None,
            stats: DriverStats::default(),
        }
    }

    /// The controller this driver is bound to.
    pub fn node(&self) -> DeviceId {
        self.node
    }

    /// The board settings.
    pub fn config(&self) -> &DriverConfig {
        &self.config
    }

    /// The control modes of the last [`Sja1000Driver::start`].
    pub fn ctrl_mode(&self) -> CtrlMode {
        self.ctrl_mode
    }

    /// The device state as the driver tracks it.
    pub fn state(&self) -> CanState {
        self.state
    }

    /// The statistics.
    pub fn stats(&self) -> &DriverStats {
        &self.stats
    }

    /// The frame in flight (handed to the controller, no TI yet), if any.
    pub fn in_flight(&self) -> Option<Frame> {
        self.in_flight.map(|f| f.frame)
    }

    /// The device runs (not stopped, not bus-off) and no frame is in flight: a
    /// [`Sja1000Driver::transmit`] would be accepted.
    pub fn can_transmit(&self) -> bool {
        self.in_flight.is_none() && self.running()
    }

    fn running(&self) -> bool {
        !matches!(self.state, CanState::Stopped | CanState::BusOff)
    }

    /// Probe: checks that a chip answers (MOD ≠ 0xFF), puts it into reset mode and initialises it:
    /// CDR (PeliCAN | comparator bypass | CLKOUT), ACR0..3 and AMR0..3 from the board's filter
    /// (mainline: ACR = 0x00, AMR = 0xFF, accept all),
    /// OCR = board OCR | [`OCR_MODE_NORMAL`]. The device is stopped afterwards.
    pub fn probe(&mut self, eng: &mut Engine) -> Result<(), DriverError> {
        let mut host = Host::new(eng, self.node);
        let mod_value = host.read(pelican::MOD);
        if mod_value == 0xFF {
            return Err(DriverError::NoChip { mod_value });
        }
        self.set_reset_mode(&mut host)?;
        self.chipset_init(&mut host);
        Ok(())
    }

    /// Sets BTR0 and BTR1 (the device must be stopped: the controller is in reset mode).
    pub fn set_bittiming(
        &mut self,
        eng: &mut Engine,
        btr0: u8,
        btr1: u8,
    ) -> Result<(), DriverError> {
        if self.state != CanState::Stopped {
            return Err(DriverError::NotStopped(self.state));
        }
        let mut host = Host::new(eng, self.node);
        host.write(pelican::BTR0, btr0);
        host.write(pelican::BTR1, btr1);
        Ok(())
    }

    /// Computes the bit timing for `bitrate` bit/s with the Linux calculator (default sample point
    /// and SJW) and sets it; returns the registers written.
    pub fn set_bitrate(&mut self, eng: &mut Engine, bitrate: u32) -> Result<Btr, DriverError> {
        let btr = calc_bittiming(self.config.clock_hz, bitrate, None, None)
            .map_err(DriverError::BitTiming)?
            .btr;
        self.set_bittiming(eng, btr.btr0(), btr.btr1())?;
        Ok(btr)
    }

    /// Starts the controller with `mode` (the driver's `sja1000_start`): reset mode unless stopped
    /// (IER = 0 first), chip initialisation again if CDR.7 reads 0, TXERR = 0, RXERR = 0, read ECC
    /// (re-arm), read IR (clear), then MOD = LOM/STM as requested until RM reads 0, and IER = all
    /// (without BEI unless `berr_reporting`). The state is error-active afterwards.
    ///
    /// Returns the frame that was in flight if entering reset mode dropped it.
    pub fn start(
        &mut self,
        eng: &mut Engine,
        mode: CtrlMode,
    ) -> Result<Option<Frame>, DriverError> {
        let dropped = self.flush_in_flight();
        self.ctrl_mode = mode;
        let mut host = Host::new(eng, self.node);
        if self.state != CanState::Stopped {
            self.set_reset_mode(&mut host)?;
        }
        if host.read(pelican::CDR) & clock_divider::PELICAN == 0 {
            self.chipset_init(&mut host);
        }
        host.write(pelican::TXERR, 0);
        host.write(pelican::RXERR, 0);
        host.read(pelican::ECC);
        host.read(pelican::IR);
        self.set_normal_mode(&mut host)?;
        Ok(dropped)
    }

    /// Stops the device (close): IER = 0 and reset mode. Returns the frame that was in flight, if
    /// any (dropped).
    pub fn stop(&mut self, eng: &mut Engine) -> Result<Option<Frame>, DriverError> {
        let dropped = self.flush_in_flight();
        let mut host = Host::new(eng, self.node);
        self.set_reset_mode(&mut host)?;
        Ok(dropped)
    }

    /// The bus-off restart (`can_restart`): it does not wait for 128 × 11 recessive bits; it runs
    /// [`Sja1000Driver::start`] with the current modes, whose TXERR = 0 in reset mode ends bus-off
    /// at once. Only from bus-off.
    pub fn restart(&mut self, eng: &mut Engine) -> Result<(), DriverError> {
        if self.state != CanState::BusOff {
            return Err(DriverError::NotBusOff(self.state));
        }
        self.stats.restarts += 1;
        // The echo frame was dropped when bus-off was reported.
        self.start(eng, self.ctrl_mode)?;
        Ok(())
    }

    /// Transmits `frame` (`ndo_start_xmit`): writes FI, the identifier bytes and the data bytes to
    /// the TX buffer, then CMR = TR (SRR when `loopback`), | AT in one-shot mode, then reads SR.
    /// The queue stays stopped until TI: a second call before it fails with
    /// [`DriverError::TxBusy`].
    pub fn transmit(
        &mut self,
        eng: &mut Engine,
        frame: &Frame,
        loopback: bool,
    ) -> Result<(), DriverError> {
        if !self.running() {
            return Err(DriverError::NotRunning(self.state));
        }
        if let Some(f) = self.in_flight {
            return Err(DriverError::TxBusy { in_flight: f.frame });
        }
        let mut host = Host::new(eng, self.node);
        load_tx_buffer(&mut host, frame);
        self.in_flight = Some(InFlight {
            frame: *frame,
            loopback,
        });
        let mut cmd = if loopback { command::SRR } else { command::TR };
        if self.ctrl_mode.one_shot {
            cmd |= command::AT;
        }
        write_command(&mut host, cmd);
        Ok(())
    }

    /// Whether the frame in flight was sent with self-reception (SRR).
    pub fn in_flight_is_loopback(&self) -> bool {
        self.in_flight.is_some_and(|f| f.loopback)
    }

    /// The interrupt handler. Reads IER (0: not ours, nothing happens); then up to
    /// [`MAX_IRQ_LOOPS`] times: read IR (stop at 0), read SR, and handle WUI, TI (TCS decides in
    /// one-shot mode), RI (`while SR.RBS { read FI, ID, data; CMR = RRB; read SR; read SR }`) and
    /// the error interrupts (TXERR and RXERR read; DOI → CMR = CDO; EI → state from SR.BS/ES;
    /// BEI → read ECC; EPI toggles error-passive/warning; ALI → read ALC).
    ///
    /// As in the driver, the IR read that finds the loop bound exhausted still happens (and clears
    /// IR); its bits are not handled.
    pub fn interrupt(&mut self, eng: &mut Engine) -> Vec<DriverEvent> {
        let mut events = Vec::new();
        let mut host = Host::new(eng, self.node);
        if host.read(pelican::IER) == IRQ_OFF {
            return events;
        }
        let mut loops = 0;
        loop {
            let ir = host.read(pelican::IR);
            if ir == 0 || loops >= MAX_IRQ_LOOPS {
                break;
            }
            let mut sr = host.read(pelican::SR);
            self.count_interrupts(ir);
            if ir & interrupt::WUI != 0 {
                self.stats.wakeups += 1;
                events.push(DriverEvent::WakeUp);
            }
            if ir & interrupt::TI != 0 {
                self.transmit_interrupt(sr, &mut events);
            }
            if ir & interrupt::RI != 0 {
                while sr & status::RBS != 0 {
                    // `sja1000_rx` without the release: FI, identifier and data bytes.
                    let frame = read_rx_message(&mut host);
                    write_command(&mut host, command::RRB);
                    self.stats.rx_frames += 1;
                    events.push(DriverEvent::Received(frame));
                    sr = host.read(pelican::SR);
                }
            }
            if ir & ERROR_INTERRUPTS != 0 {
                self.error_interrupt(&mut host, ir, sr, &mut events);
            }
            loops += 1;
        }
        events
    }

    fn count_interrupts(&mut self, ir: u8) {
        for (bit, count) in self.stats.interrupts.iter_mut().enumerate() {
            *count += u64::from(ir >> bit & 1);
        }
    }

    fn transmit_interrupt(&mut self, sr: u8, events: &mut Vec<DriverEvent>) {
        match self.in_flight.take() {
            Some(tx) if self.ctrl_mode.one_shot && sr & status::TCS == 0 => {
                self.stats.tx_failed += 1;
                events.push(DriverEvent::TxFailed(tx.frame));
            }
            Some(tx) => {
                self.stats.tx_frames += 1;
                events.push(DriverEvent::TxDone(tx.frame));
            }
            None => {
                self.stats.spurious_tx += 1;
                events.push(DriverEvent::SpuriousTxInterrupt { sr });
            }
        }
    }

    /// The driver's error path for one IR value (`sja1000_err`).
    fn error_interrupt(&mut self, host: &mut Host, ir: u8, sr: u8, events: &mut Vec<DriverEvent>) {
        let txerr = host.read(pelican::TXERR);
        let rxerr = host.read(pelican::RXERR);
        let counters = ErrorCounters { txerr, rxerr };
        let mut state = self.state;
        if ir & interrupt::DOI != 0 {
            self.stats.rx_overruns += 1;
            write_command(host, command::CDO);
            events.push(DriverEvent::Overrun(counters));
        }
        if ir & interrupt::EI != 0 {
            state = if sr & status::BS != 0 {
                CanState::BusOff
            } else if sr & status::ES != 0 {
                CanState::ErrorWarning
            } else {
                CanState::ErrorActive
            };
        }
        if ir & interrupt::BEI != 0 {
            let ecc = host.read(pelican::ECC);
            self.stats.bus_errors += 1;
            // ECC.DIR (bit 5): 0 while transmitting, 1 while receiving.
            if ecc & 0x20 == 0 {
                self.stats.bus_errors_tx += 1;
            } else {
                self.stats.bus_errors_rx += 1;
            }
            events.push(DriverEvent::BusError { ecc, counters });
        }
        if ir & interrupt::EPI != 0 {
            // The driver treats EPI as a toggle between passive and warning.
            state = if state == CanState::ErrorPassive {
                CanState::ErrorWarning
            } else {
                CanState::ErrorPassive
            };
        }
        if ir & interrupt::ALI != 0 {
            let alc = host.read(pelican::ALC);
            self.stats.arbitration_lost += 1;
            events.push(DriverEvent::ArbitrationLost { alc, counters });
        }
        if state != self.state {
            if state > self.state {
                match state {
                    CanState::ErrorWarning => self.stats.error_warning += 1,
                    CanState::ErrorPassive => self.stats.error_passive += 1,
                    CanState::BusOff => self.stats.bus_off += 1,
                    CanState::ErrorActive | CanState::Stopped => {}
                }
            }
            self.state = state;
            events.push(DriverEvent::StateChanged {
                state,
                ir,
                sr,
                counters,
            });
            if state == CanState::BusOff {
                // can_bus_off: carrier off, the queue stays stopped; the echo frame is dropped.
                if let Some(frame) = self.flush_in_flight() {
                    events.push(DriverEvent::TxDropped(frame));
                }
            }
        }
    }

    /// `set_reset_mode`: read MOD, IER = 0, then write MOD = RM and read it back until RM is 1.
    fn set_reset_mode(&mut self, host: &mut Host) -> Result<(), DriverError> {
        let mut mod_value = host.read(pelican::MOD);
        host.write(pelican::IER, IRQ_OFF);
        for _ in 0..MODE_POLL_ATTEMPTS {
            if mod_value & mode::RM != 0 {
                self.state = CanState::Stopped;
                return Ok(());
            }
            host.write(pelican::MOD, mode::RM);
            host.idle(self.config.mode_poll_delay_cycles());
            mod_value = host.read(pelican::MOD);
        }
        Err(DriverError::ResetModeFailed { mod_value })
    }

    /// `set_normal_mode`: read MOD, then write MOD = LOM/STM (and the board's AFM) and read it back
    /// until RM is 0; then enable the interrupts.
    fn set_normal_mode(&mut self, host: &mut Host) -> Result<(), DriverError> {
        let written = self.ctrl_mode.mod_value() | self.config.filter_mode();
        let mut mod_value = host.read(pelican::MOD);
        for _ in 0..MODE_POLL_ATTEMPTS {
            if mod_value & mode::RM == 0 {
                self.state = CanState::ErrorActive;
                host.write(pelican::IER, self.ctrl_mode.ier_value());
                return Ok(());
            }
            host.write(pelican::MOD, written);
            host.idle(self.config.mode_poll_delay_cycles());
            mod_value = host.read(pelican::MOD);
        }
        Err(DriverError::NormalModeFailed { written, mod_value })
    }

    /// `chipset_init`: CDR, the acceptance filter, OCR.
    fn chipset_init(&mut self, host: &mut Host) {
        host.write(pelican::CDR, self.config.cdr());
        for (i, acr) in (0..).zip(self.config.filter.acr) {
            host.write(pelican::ACR0 + i, acr);
        }
        for (i, amr) in (0..).zip(self.config.filter.amr) {
            host.write(pelican::AMR0 + i, amr);
        }
        host.write(pelican::OCR, self.config.ocr | OCR_MODE_NORMAL);
    }

    /// Drops the frame in flight (the echo skb is freed), counting it.
    fn flush_in_flight(&mut self) -> Option<Frame> {
        let dropped = self.in_flight.take().map(|f| f.frame);
        if dropped.is_some() {
            self.stats.tx_dropped += 1;
        }
        dropped
    }
}

/// `sja1000_write_cmdreg`: CMR, then a read of SR (the driver reads SR after every command).
fn write_command(host: &mut Host, cmd: u8) {
    host.write(pelican::CMR, cmd);
    host.read(pelican::SR);
}
