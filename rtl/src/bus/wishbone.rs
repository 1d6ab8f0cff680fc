//! The controller on a Wishbone B4 bus (`can_controller_wb`): a 32-bit slave with byte selects, for
//! LiteX and other Wishbone SoCs.
//!
//! Ports: `clock`, `reset` (synchronous, active high: the controller's too); the slave interface
//! `wb_cyc`, `wb_stb`, `wb_we`, `wb_adr` (word address), `wb_sel`, `wb_dat_w` in and `wb_dat_r`,
//! `wb_ack`, `wb_stall` out; the CAN side `rx` in, `tx`, `clkout` out; `irq` (active high: IR &
//! IER != 0). A classic cycle (`wb_cyc` and `wb_stb` held until `wb_ack`) is acknowledged after
//! the register port's 8 cycles, with the read data; `wb_stall` is high while an access is taken
//! and not yet acknowledged, so a pipelined master works too (it may drop `wb_stb` once the
//! request is accepted). With `word_stride` 0 (the default; a Verilog parameter of the top module)
//! the SJA1000 registers are bytes at byte addresses (`wb_sel` picks them, one strobe each); with 1
//! each register is the low byte of its own word (`reg-io-width = 4`; `wb_sel` bit 0 writes).
//! Acts on the rising edge of `clock`.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bus::register_port::RegisterPort;

/// Where a Wishbone access is.
#[derive(Copy, Clone, Debug, PartialEq, Eq, LogicState)]
pub enum WishboneState {
    /// Waiting for a request.
    Idle,
    /// The register port works on the request.
    Busy,
    /// `wb_ack` this cycle.
    Ack,
}

/// The controller behind a Wishbone B4 slave port.
#[derive(ActivityBlock, BlockDefault)]
pub struct CanControllerWishbone {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Bus and controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Bus cycle.
    pub wb_cyc: Signal<In, Bit>,
    /// Strobe: a request.
    pub wb_stb: Signal<In, Bit>,
    /// The request writes.
    pub wb_we: Signal<In, Bit>,
    /// Word address.
    pub wb_adr: Signal<In, Bits<8>>,
    /// Byte selects.
    pub wb_sel: Signal<In, Bits<4>>,
    /// Write data.
    pub wb_dat_w: Signal<In, Bits<32>>,
    /// Read data, with `wb_ack`.
    pub wb_dat_r: Signal<Out, Bits<32>>,
    /// The request is done.
    pub wb_ack: Signal<Out, Bit>,
    /// No request is taken this cycle.
    pub wb_stall: Signal<Out, Bit>,
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
    state: DFF<WishboneState>,
    /// Register layout (see [`RegisterPort`]); a Verilog parameter of the emitted top module.
    #[constant(false)]
    pub word_stride: Constant<Bit>,
}

impl CanControllerWishbone {
    /// The wrapper with one register per 32-bit word (`word_stride` 1) or byte registers (0).
    pub fn with_word_stride(word_stride: bool) -> CanControllerWishbone {
        CanControllerWishbone {
            word_stride: Constant::new(word_stride),
            ..CanControllerWishbone::default()
        }
    }
}

impl Logic for CanControllerWishbone {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, state);
        clock!(self, clock, port);
        self.port.reset.next = self.reset.val();
        self.port.word_stride.next = self.word_stride.val();
        self.port.start.next =
            (self.state.q.val() == WishboneState::Idle) & self.wb_cyc.val() & self.wb_stb.val();
        self.port.write.next = self.wb_we.val();
        self.port.word.next = self.wb_adr.val();
        self.port.wdata.next = self.wb_dat_w.val();
        // Word stride: the register is the word's lane 0, read whatever the selects say.
        self.port.byte_enable.next = self.wb_sel.val();
        if self.word_stride.val() {
            self.port.byte_enable.next = self.wb_sel.val() & 1;
            if self.wb_we.val() == false {
                self.port.byte_enable.next = 1.into();
            }
        }
        self.port.rx.next = self.rx.val();
        self.tx.next = self.port.tx.val();
        self.irq.next = self.port.irq.val();
        self.clkout.next = self.port.clkout.val();
        self.wb_dat_r.next = self.port.rdata.val();
        self.wb_ack.next = self.state.q.val() == WishboneState::Ack;
        self.wb_stall.next = self.state.q.val() != WishboneState::Idle;
        match self.state.q.val() {
            WishboneState::Idle => {
                if self.wb_cyc.val() & self.wb_stb.val() {
                    self.state.d.next = WishboneState::Busy;
                }
            }
            WishboneState::Busy => {
                if self.port.done.val() {
                    self.state.d.next = WishboneState::Ack;
                }
            }
            WishboneState::Ack => {
                self.state.d.next = WishboneState::Idle;
            }
        }
        if self.reset.val() {
            self.state.d.next = WishboneState::Idle;
        }
    }
}
