//! The controller behind a 32-bit register port, what every bus wrapper shares: one access of a
//! wrapper (a word address, byte enables, 32 bits of write data) becomes one strobe of the
//! controller's byte-wide host port per enabled byte lane, in lane order, and the bytes read are
//! gathered into a 32-bit word.
//!
//! Ports: `start` (one cycle: take `write`, `word`, `byte_enable`, `wdata`; ignored during an access),
//! `word_stride` (0: byte registers at byte addresses, register = `word` × 4 + lane, as Linux's
//! `reg-io-width = 1`; 1: one register per 32-bit word in its byte lane 0, register = `word`, as
//! `reg-io-width = 4`) in; `done` (one cycle, with `rdata`: the bytes read in their lanes,
//! 0 in lanes not read) out, from registers only; the controller's pins `rx` in, `tx`, `clkout` and
//! `irq` (active high) out. The controller's read data arrives the cycle after its strobe: every
//! access takes 8 cycles (a strobe and a capture cycle per lane),
//! then `done`; a lane that is not enabled gets no strobe, so reading one register never touches
//! its neighbours (a read of IR clears it). Acts on the rising edge of `clock`.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::can_controller::CanController;

/// Where the port is in an access.
#[derive(Copy, Clone, Debug, PartialEq, Eq, LogicState)]
pub enum PortState {
    /// Waiting for `start`.
    Idle,
    /// Strobing the current lane's register.
    Strobe,
    /// Taking the byte read (if any) and moving to the next lane.
    Capture,
}

/// The controller and the byte-lane sequencer in front of its host port.
#[derive(ActivityBlock, BlockDefault)]
pub struct RegisterPort {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high: an access in progress is dropped.
    pub reset: Signal<In, Bit>,
    /// Begin an access.
    pub start: Signal<In, Bit>,
    /// The access writes.
    pub write: Signal<In, Bit>,
    /// Register layout: 0 byte registers at byte addresses, 1 one register per 32-bit word.
    pub word_stride: Signal<In, Bit>,
    /// Word address of the access.
    pub word: Signal<In, Bits<8>>,
    /// The byte lanes accessed.
    pub byte_enable: Signal<In, Bits<4>>,
    /// Write data, byte lane k in bits 8k+7..8k.
    pub wdata: Signal<In, Bits<32>>,
    /// The access ended (one cycle).
    pub done: Signal<Out, Bit>,
    /// The bytes read, in their lanes (valid with `done`, held until the next access ends).
    pub rdata: Signal<Out, Bits<32>>,
    /// From the transceiver (RXD).
    pub rx: Signal<In, Bit>,
    /// To the transceiver (TXD).
    pub tx: Signal<Out, Bit>,
    /// Interrupt, active high.
    pub irq: Signal<Out, Bit>,
    /// The controller's clock output (CDR).
    pub clkout: Signal<Out, Bit>,
    /// The controller.
    can: CanController,
    state: DFF<PortState>,
    lane: DFF<Bits<2>>,
    /// Lanes still to do, the current one in bit 0.
    lanes_left: DFF<Bits<4>>,
    /// Write data still to go, the current lane's byte in bits 7..0.
    data_out: DFF<Bits<32>>,
    /// Bytes read so far, shifted in from the top.
    data_in: DFF<Bits<32>>,
    /// The register of the current lane.
    addr_q: DFF<Bits<8>>,
    write_q: DFF<Bit>,
    stride_q: DFF<Bit>,
    done_q: DFF<Bit>,
    /// The byte the current lane adds to `data_in`.
    byte_read: Signal<Local, Bits<32>>,
}

impl Logic for RegisterPort {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self, clock, state, lane, lanes_left, data_out, data_in, addr_q, write_q, stride_q,
            done_q
        );
        clock!(self, clock, can);
        // The controller's host inputs come from flip-flops only, each written once: its read data
        // depends on the strobes in Verilator's view of the design, and a value written twice in
        // one pass would wake the controller's logic again in an event simulator.
        self.done.next = self.done_q.q.val();
        self.rdata.next = self.data_in.q.val();
        self.can.reset.next = self.reset.val();
        self.can.addr.next = self.addr_q.q.val();
        self.can.wdata.next = self.data_out.q.val().get_bits::<8>(0);
        self.can.we.next = (self.state.q.val() == PortState::Strobe)
            & self.lanes_left.q.val().get_bit(0)
            & self.write_q.q.val();
        self.can.re.next = (self.state.q.val() == PortState::Strobe)
            & self.lanes_left.q.val().get_bit(0)
            & (self.write_q.q.val() == false);
        self.can.rx.next = self.rx.val();
        self.tx.next = self.can.tx.val();
        self.irq.next = self.can.irq_n.val() == false;
        self.clkout.next = self.can.clkout.val();
        self.byte_read.next = 0.into();
        self.done_q.d.next = false;
        match self.state.q.val() {
            PortState::Idle => {
                if self.start.val() {
                    self.state.d.next = PortState::Strobe;
                    self.lane.d.next = 0.into();
                    self.lanes_left.d.next = self.byte_enable.val();
                    self.data_out.d.next = self.wdata.val();
                    self.data_in.d.next = 0.into();
                    self.write_q.d.next = self.write.val();
                    self.stride_q.d.next = self.word_stride.val();
                    self.addr_q.d.next = self.word.val() << 2;
                    if self.word_stride.val() {
                        self.addr_q.d.next = self.word.val();
                    }
                }
            }
            PortState::Strobe => {
                self.state.d.next = PortState::Capture;
            }
            PortState::Capture => {
                if self.lanes_left.q.val().get_bit(0) & (self.write_q.q.val() == false) {
                    self.byte_read.next = bit_cast::<32, 8>(self.can.rdata.val()) << 24;
                }
                self.data_in.d.next = (self.data_in.q.val() >> 8) | self.byte_read.val();
                self.data_out.d.next = self.data_out.q.val() >> 8;
                self.lanes_left.d.next = self.lanes_left.q.val() >> 1;
                self.lane.d.next = self.lane.q.val() + 1;
                if self.stride_q.q.val() == false {
                    self.addr_q.d.next = self.addr_q.q.val() + 1;
                }
                self.state.d.next = PortState::Strobe;
                if self.lane.q.val() == 3 {
                    self.state.d.next = PortState::Idle;
                    self.done_q.d.next = true;
                }
            }
        }
        if self.reset.val() {
            self.state.d.next = PortState::Idle;
            self.done_q.d.next = false;
        }
    }
}
