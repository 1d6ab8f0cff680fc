//! The controller on an AXI4-Lite bus (`can_controller_axil`): a 32-bit slave for Zynq, MicroBlaze
//! and other AXI SoCs.
//!
//! Ports: `clock`, `reset` (synchronous, active high: the controller's too); the slave channels
//! `s_axil_aw*` (`valid`, `ready`, `addr`), `s_axil_w*` (`valid`, `ready`, `data`, `strb`),
//! `s_axil_b*` (`valid`, `ready`, `resp`), `s_axil_ar*` (`valid`, `ready`, `addr`) and `s_axil_r*`
//! (`valid`, `ready`, `data`, `resp`), 10-bit byte addresses; the CAN side `rx` in, `tx`, `clkout`
//! out; `irq` (active high). The write address and write data channels are taken independently
//! (each ready while it holds nothing); once both are there, or a read address is, the register
//! port does the access, then the response waits for its ready. One transaction at a time, reads and
//! writes taking turns when both wait; every ready comes from a flip-flop (no path from a valid to a
//! ready). Responses are OKAY. With `word_stride` 0 (default; a Verilog parameter) registers are
//! bytes at byte addresses: a write writes the lanes `strb` enables, a read reads the one register
//! `araddr` names (its lane; the others read 0); with 1 each register is the low byte of its own
//! word (`reg-io-width = 4`). Acts on the rising edge of `clock`.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bus::register_port::RegisterPort;

/// What the AXI4-Lite slave is doing.
#[derive(Copy, Clone, Debug, PartialEq, Eq, LogicState)]
pub enum AxiState {
    /// Collecting requests.
    Idle,
    /// The register port writes.
    Write,
    /// The register port reads.
    Read,
    /// `bvalid` until `bready`.
    WriteResponse,
    /// `rvalid` until `rready`.
    ReadResponse,
}

/// The controller behind an AXI4-Lite slave port.
#[derive(ActivityBlock, BlockDefault)]
pub struct CanControllerAxiLite {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Bus and controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Write address valid.
    pub s_axil_awvalid: Signal<In, Bit>,
    /// Write address ready.
    pub s_axil_awready: Signal<Out, Bit>,
    /// Write address (bytes).
    pub s_axil_awaddr: Signal<In, Bits<10>>,
    /// Write data valid.
    pub s_axil_wvalid: Signal<In, Bit>,
    /// Write data ready.
    pub s_axil_wready: Signal<Out, Bit>,
    /// Write data.
    pub s_axil_wdata: Signal<In, Bits<32>>,
    /// Write strobes, one per byte lane.
    pub s_axil_wstrb: Signal<In, Bits<4>>,
    /// Write response valid.
    pub s_axil_bvalid: Signal<Out, Bit>,
    /// Write response ready.
    pub s_axil_bready: Signal<In, Bit>,
    /// Write response (OKAY).
    pub s_axil_bresp: Signal<Out, Bits<2>>,
    /// Read address valid.
    pub s_axil_arvalid: Signal<In, Bit>,
    /// Read address ready.
    pub s_axil_arready: Signal<Out, Bit>,
    /// Read address (bytes).
    pub s_axil_araddr: Signal<In, Bits<10>>,
    /// Read data valid.
    pub s_axil_rvalid: Signal<Out, Bit>,
    /// Read data ready.
    pub s_axil_rready: Signal<In, Bit>,
    /// Read data.
    pub s_axil_rdata: Signal<Out, Bits<32>>,
    /// Read response (OKAY).
    pub s_axil_rresp: Signal<Out, Bits<2>>,
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
    state: DFF<AxiState>,
    /// The write address, the write data and strobes, the read address, each with its flag.
    aw_full: DFF<Bit>,
    aw_addr: DFF<Bits<10>>,
    w_full: DFF<Bit>,
    w_data: DFF<Bits<32>>,
    w_strb: DFF<Bits<4>>,
    ar_full: DFF<Bit>,
    ar_addr: DFF<Bits<10>>,
    /// The last access wrote: a waiting read goes first next.
    last_write: DFF<Bit>,
    /// The access the port begins now, and its address.
    begin_write: Signal<Local, Bit>,
    begin_read: Signal<Local, Bit>,
    addr: Signal<Local, Bits<10>>,
    /// The lane a byte-stride read names.
    read_lane: Signal<Local, Bits<4>>,
    /// Register layout (see [`RegisterPort`]); a Verilog parameter of the emitted top module.
    #[constant(false)]
    pub word_stride: Constant<Bit>,
}

impl CanControllerAxiLite {
    /// The wrapper with one register per 32-bit word (`word_stride` 1) or byte registers (0).
    pub fn with_word_stride(word_stride: bool) -> CanControllerAxiLite {
        CanControllerAxiLite {
            word_stride: Constant::new(word_stride),
            ..CanControllerAxiLite::default()
        }
    }
}

impl Logic for CanControllerAxiLite {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self, clock, state, aw_full, aw_addr, w_full, w_data, w_strb, ar_full, ar_addr,
            last_write
        );
        clock!(self, clock, port);
        // Channels: each takes a request while it holds none.
        self.s_axil_awready.next = self.aw_full.q.val() == false;
        self.s_axil_wready.next = self.w_full.q.val() == false;
        self.s_axil_arready.next = self.ar_full.q.val() == false;
        if self.s_axil_awvalid.val() & (self.aw_full.q.val() == false) {
            self.aw_full.d.next = true;
            self.aw_addr.d.next = self.s_axil_awaddr.val();
        }
        if self.s_axil_wvalid.val() & (self.w_full.q.val() == false) {
            self.w_full.d.next = true;
            self.w_data.d.next = self.s_axil_wdata.val();
            self.w_strb.d.next = self.s_axil_wstrb.val();
        }
        if self.s_axil_arvalid.val() & (self.ar_full.q.val() == false) {
            self.ar_full.d.next = true;
            self.ar_addr.d.next = self.s_axil_araddr.val();
        }
        // Which access begins: a write needs both its channels; reads and writes take turns.
        self.begin_write.next = false;
        self.begin_read.next = false;
        if self.state.q.val() == AxiState::Idle {
            if self.aw_full.q.val() & self.w_full.q.val() {
                self.begin_write.next = true;
            }
            if self.ar_full.q.val() & (self.last_write.q.val() | (self.begin_write.val() == false))
            {
                self.begin_read.next = true;
                self.begin_write.next = false;
            }
        }
        self.addr.next = self.aw_addr.q.val();
        if self.begin_read.val() {
            self.addr.next = self.ar_addr.q.val();
        }
        self.read_lane.next = 1.into();
        if self.ar_addr.q.val().get_bits::<2>(0) == 1 {
            self.read_lane.next = 2.into();
        }
        if self.ar_addr.q.val().get_bits::<2>(0) == 2 {
            self.read_lane.next = 4.into();
        }
        if self.ar_addr.q.val().get_bits::<2>(0) == 3 {
            self.read_lane.next = 8.into();
        }
        self.port.reset.next = self.reset.val();
        self.port.word_stride.next = self.word_stride.val();
        self.port.start.next = self.begin_write.val() | self.begin_read.val();
        self.port.write.next = self.begin_write.val();
        self.port.word.next = bit_cast::<8, 10>(self.addr.val() >> 2);
        self.port.wdata.next = self.w_data.q.val();
        self.port.byte_enable.next = self.w_strb.q.val();
        if self.begin_read.val() {
            self.port.byte_enable.next = self.read_lane.val();
        }
        if self.word_stride.val() {
            self.port.byte_enable.next = self.w_strb.q.val() & 1;
            if self.begin_read.val() {
                self.port.byte_enable.next = 1.into();
            }
        }
        // Responses.
        self.s_axil_bvalid.next = self.state.q.val() == AxiState::WriteResponse;
        self.s_axil_bresp.next = 0.into();
        self.s_axil_rvalid.next = self.state.q.val() == AxiState::ReadResponse;
        self.s_axil_rdata.next = self.port.rdata.val();
        self.s_axil_rresp.next = 0.into();
        match self.state.q.val() {
            AxiState::Idle => {
                if self.begin_write.val() {
                    self.state.d.next = AxiState::Write;
                    self.last_write.d.next = true;
                }
                if self.begin_read.val() {
                    self.state.d.next = AxiState::Read;
                    self.last_write.d.next = false;
                }
            }
            AxiState::Write => {
                if self.port.done.val() {
                    self.state.d.next = AxiState::WriteResponse;
                    self.aw_full.d.next = false;
                    self.w_full.d.next = false;
                }
            }
            AxiState::Read => {
                if self.port.done.val() {
                    self.state.d.next = AxiState::ReadResponse;
                    self.ar_full.d.next = false;
                }
            }
            AxiState::WriteResponse => {
                if self.s_axil_bready.val() {
                    self.state.d.next = AxiState::Idle;
                }
            }
            AxiState::ReadResponse => {
                if self.s_axil_rready.val() {
                    self.state.d.next = AxiState::Idle;
                }
            }
        }
        self.port.rx.next = self.rx.val();
        self.tx.next = self.port.tx.val();
        self.irq.next = self.port.irq.val();
        self.clkout.next = self.port.clkout.val();
        if self.reset.val() {
            self.state.d.next = AxiState::Idle;
            self.aw_full.d.next = false;
            self.w_full.d.next = false;
            self.ar_full.d.next = false;
            self.last_write.d.next = false;
        }
    }
}
