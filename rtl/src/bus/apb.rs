//! The controller on an APB bus (`can_controller_apb`): a 32-bit APB3/APB4 completer for Cortex-M
//! and other APB peripherals.
//!
//! Ports: `clock`, `reset` (synchronous, active high: the controller's too); `psel`, `penable`,
//! `pwrite`, `paddr` (10-bit byte address), `pwdata`, `pstrb` in and `prdata`, `pready`, `pslverr`
//! out; the CAN side `rx` in, `tx`, `clkout` out; `irq` (active high). The access phase (`psel`
//! and `penable`) starts the register port's 8 cycles; `pready` (from a flip-flop) ends it with
//! `prdata`; `pslverr` is always 0. With `word_stride` 0 (default; a Verilog parameter) registers
//! are bytes at byte addresses: a write writes the lanes `pstrb` enables (an APB3 requester drives
//! `pstrb` as `4'b0001 << paddr[1:0]` for a byte write), a read reads the one register `paddr`
//! names; with 1 each register is the low byte of its own word (`reg-io-width = 4`). Acts on the
//! rising edge of `clock`.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bus::register_port::RegisterPort;

/// Where an APB transfer is.
#[derive(Copy, Clone, Debug, PartialEq, Eq, LogicState)]
pub enum ApbState {
    /// Waiting for an access phase.
    Idle,
    /// The register port works on it.
    Busy,
    /// `pready` this cycle.
    Ready,
}

/// The controller behind an APB completer port.
#[derive(ActivityBlock, BlockDefault)]
pub struct CanControllerApb {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Bus and controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Select.
    pub psel: Signal<In, Bit>,
    /// Access phase.
    pub penable: Signal<In, Bit>,
    /// The transfer writes.
    pub pwrite: Signal<In, Bit>,
    /// Byte address.
    pub paddr: Signal<In, Bits<10>>,
    /// Write data.
    pub pwdata: Signal<In, Bits<32>>,
    /// Write strobes (APB4).
    pub pstrb: Signal<In, Bits<4>>,
    /// Read data, with `pready`.
    pub prdata: Signal<Out, Bits<32>>,
    /// The transfer ends.
    pub pready: Signal<Out, Bit>,
    /// Transfer error: never.
    pub pslverr: Signal<Out, Bit>,
    /// From the transceiver (RXD).
    pub rx: Signal<In, Bit>,
    /// To the transceiver (TXD).
    pub tx: Signal<Out, Bit>,
    /// Interrupt, active high.
    pub irq: Signal<Out, Bit>,
    /// The controller's clock output (CDR).
    pub clkout: Signal<Out, Bit>,
    /// The controller and its register port.
    port: RegisterPort,
    state: DFF<ApbState>,
    /// The lane a byte-stride read names.
    read_lane: Signal<Local, Bits<4>>,
    /// Register layout (see [`RegisterPort`]); a Verilog parameter of the emitted top module.
    #[constant(false)]
    pub word_stride: Constant<Bit>,
}

impl CanControllerApb {
    /// The wrapper with one register per 32-bit word (`word_stride` 1) or byte registers (0).
    pub fn with_word_stride(word_stride: bool) -> CanControllerApb {
        CanControllerApb {
            word_stride: Constant::new(word_stride),
            ..CanControllerApb::default()
        }
    }
}

impl Logic for CanControllerApb {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, state);
        clock!(self, clock, port);
        self.read_lane.next = 1.into();
        if self.paddr.val().get_bits::<2>(0) == 1 {
            self.read_lane.next = 2.into();
        }
        if self.paddr.val().get_bits::<2>(0) == 2 {
            self.read_lane.next = 4.into();
        }
        if self.paddr.val().get_bits::<2>(0) == 3 {
            self.read_lane.next = 8.into();
        }
        self.port.reset.next = self.reset.val();
        self.port.word_stride.next = self.word_stride.val();
        self.port.start.next =
            (self.state.q.val() == ApbState::Idle) & self.psel.val() & self.penable.val();
        self.port.write.next = self.pwrite.val();
        self.port.word.next = bit_cast::<8, 10>(self.paddr.val() >> 2);
        self.port.wdata.next = self.pwdata.val();
        self.port.byte_enable.next = self.pstrb.val();
        if self.pwrite.val() == false {
            self.port.byte_enable.next = self.read_lane.val();
        }
        if self.word_stride.val() {
            self.port.byte_enable.next = self.pstrb.val() & 1;
            if self.pwrite.val() == false {
                self.port.byte_enable.next = 1.into();
            }
        }
        self.prdata.next = self.port.rdata.val();
        self.pready.next = self.state.q.val() == ApbState::Ready;
        self.pslverr.next = false;
        match self.state.q.val() {
            ApbState::Idle => {
                if self.psel.val() & self.penable.val() {
                    self.state.d.next = ApbState::Busy;
                }
            }
            ApbState::Busy => {
                if self.port.done.val() {
                    self.state.d.next = ApbState::Ready;
                }
            }
            ApbState::Ready => {
                self.state.d.next = ApbState::Idle;
            }
        }
        self.port.rx.next = self.rx.val();
        self.tx.next = self.port.tx.val();
        self.irq.next = self.port.irq.val();
        self.clkout.next = self.port.clkout.val();
        if self.reset.val() {
            self.state.d.next = ApbState::Idle;
        }
    }
}
