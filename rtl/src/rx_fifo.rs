//! The receive FIFO: 64 bytes in one RAM block holding received messages circularly, each in the
//! SJA1000 frame-buffer layout (frame information, 2 or 4 identifier bytes, the data bytes).
//!
//! Ports in: the received-frame stream of the protocol engine (`rx_frame`: the `header` strobe with
//! `id`, `ide`, `rtr`, `dlc` held from then on, so the frame information of the message being
//! written is computed from them, not copied; `strobe` with `data`, the data bytes in order; `index`
//! is not used: the bytes go to consecutive addresses), `store`
//! (the frame is valid and accepted: keep it), the host commands `release_head` (RRB) and
//! `clear_overrun` (CDO), `clear` (reset mode: empty), `load_start` + `start_address` (RBSA write),
//! and the host port `host_read` / `host_write` at `host_address` (writes only in reset mode, when
//! no frame is written). Out: `read_data` (the RAM byte, registered: valid the cycle after
//! `host_read`), `message_count` (RMC), `start` (RBSA), `overrun` (DOS), `head_info` (frame
//! information of the head message). Acts on the rising edge of `clock`.
//!
//! A message is written while it arrives, into the free space after the stored messages (from the
//! tail); its first byte that would land on the head message finds no room, and that byte and every
//! later one of the message are dropped and mark it incomplete. At `store` a complete message is
//! counted (RMC + 1), an incomplete one is dropped entirely and sets `overrun`. `release_head` frees
//! the head message; the frame information of the next one is fetched through the RAM read port in
//! that same cycle (a host write cycle, so the port is free) and is valid from the cycle after.

use rust_hdl::prelude::*;

use crate::bsp::received_frame::ReceivedFrameIn;

use crate::activity::{Activity, ActivityBlock, BlockDefault};

/// Bytes of the receive FIFO.
pub const RX_FIFO_BYTES: usize = 64;

/// The receive FIFO.
#[derive(ActivityBlock, BlockDefault)]
pub struct RxFifo {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Empty the FIFO (reset mode).
    pub clear: Signal<In, Bit>,
    /// Set the start address (RBSA write; only with the FIFO empty).
    pub load_start: Signal<In, Bit>,
    /// Value for `load_start`.
    pub start_address: Signal<In, Bits<6>>,
    /// The received-frame stream (`crate::bsp::received_frame`).
    #[interface]
    pub rx_frame: ReceivedFrameIn,
    /// Keep the frame received (one clock at its validity point, if accepted).
    pub store: Signal<In, Bit>,
    /// Free the head message (CMR.RRB).
    pub release_head: Signal<In, Bit>,
    /// Clear the overrun status (CMR.CDO).
    pub clear_overrun: Signal<In, Bit>,
    /// The host reads the RAM this cycle.
    pub host_read: Signal<In, Bit>,
    /// RAM address the host reads or writes.
    pub host_address: Signal<In, Bits<6>>,
    /// The host writes `host_data` at `host_address` (reset mode only: the FIFO is idle then).
    pub host_write: Signal<In, Bit>,
    /// Value the host writes.
    pub host_data: Signal<In, Bits<8>>,
    /// RAM byte read (valid the cycle after `host_read`).
    pub read_data: Signal<Out, Bits<8>>,
    /// Messages stored (RMC).
    pub message_count: Signal<Out, Bits<5>>,
    /// RAM address of the head message (RBSA).
    pub start: Signal<Out, Bits<6>>,
    /// A message was lost for want of room (SR.DOS).
    pub overrun: Signal<Out, Bit>,
    /// Frame information byte of the head message (meaningful while `message_count` > 0).
    pub head_info: Signal<Out, Bits<8>>,
    // Every word initialised: unwritten RAM reads X in Verilog (RUST_HDL.md rule 6).
    #[init(cleared_ram())]
    ram: RAM<Bits<8>, 6>,
    head: DFF<Bits<6>>,
    tail: DFF<Bits<6>>,
    /// Where the next byte of the message being received goes (from the tail on).
    write_at: DFF<Bits<6>>,
    count: DFF<Bits<5>>,
    /// The pointers meet with messages stored: all 64 bytes are used.
    full: DFF<Bit>,
    overrun_state: DFF<Bit>,
    head_info_reg: DFF<Bits<8>>,
    fetching: DFF<Bit>,
    header_step: DFF<Bits<3>>,
    writing_header: DFF<Bit>,
    incomplete: DFF<Bit>,
    // Combinational helpers.
    new_info: Signal<Local, Bits<8>>,
    head_info_now: Signal<Local, Bits<8>>,
    head_length: Signal<Local, Bits<4>>,
    head_header_bytes: Signal<Local, Bits<4>>,
    write_now: Signal<Local, Bit>,
    ram_write: Signal<Local, Bit>,
    ram_write_address: Signal<Local, Bits<6>>,
    ram_write_data: Signal<Local, Bits<8>>,
    write_byte: Signal<Local, Bits<8>>,
    no_room: Signal<Local, Bit>,
    at_head: Signal<Local, Bit>,
    releasing: Signal<Local, Bit>,
    storing: Signal<Local, Bit>,
    next_head: Signal<Local, Bits<6>>,
    count_after_release: Signal<Local, Bits<5>>,
    header_last: Signal<Local, Bits<3>>,
    #[constant(0u64)]
    zero_byte: Constant<Bits<8>>,
}

/// The RAM with every word 0: unwritten RAM reads X in Verilog (RUST_HDL.md rule 6).
fn cleared_ram() -> RAM<Bits<8>, 6> {
    RAM::from((0..RX_FIFO_BYTES).map(|_| Bits::<8>::from(0u64)))
}

impl Logic for RxFifo {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            head,
            tail,
            write_at,
            count,
            full,
            overrun_state,
            head_info_reg,
            fetching,
            header_step,
            writing_header,
            incomplete
        );
        self.ram.read_clock.next = self.clock.val();
        self.ram.write_clock.next = self.clock.val();
        self.read_data.next = self.ram.read_data.val();
        self.message_count.next = self.count.q.val();
        self.start.next = self.head.q.val();
        self.overrun.next = self.overrun_state.q.val();

        // The frame information of the head message: fetched from the RAM after a release.
        self.head_info_now.next = self.head_info_reg.q.val();
        if self.fetching.q.val() {
            self.head_info_now.next = self.ram.read_data.val();
        }
        // The output again from flip-flops only, not from `head_info_now`, which input-dependent
        // logic shares: that keeps the Verilog free of loops through the parent (docs/RUST_HDL.md).
        self.head_info.next = self.head_info_reg.q.val();
        if self.fetching.q.val() {
            self.head_info.next = self.ram.read_data.val();
        }
        self.head_info_reg.d.next = self.head_info_now.val();
        self.fetching.d.next = false;

        // Message lengths: frame information + 2 or 4 identifier bytes + data (none for RTR, at most 8).
        self.head_header_bytes.next = 3.into();
        if self.head_info_now.val().get_bit(7) {
            self.head_header_bytes.next = 5.into();
        }
        self.head_length.next =
            self.head_header_bytes.val() + bit_cast::<4, 8>(self.head_info_now.val());
        if self.head_info_now.val().get_bit(3) {
            self.head_length.next = self.head_header_bytes.val() + 8;
        }
        if self.head_info_now.val().get_bit(6) {
            self.head_length.next = self.head_header_bytes.val();
        }
        self.new_info.next = bit_cast::<8, 4>(self.rx_frame.dlc.val())
            .replace_bit(6, self.rx_frame.rtr.val())
            .replace_bit(7, self.rx_frame.ide.val());

        // ---- Writing the message being received.
        self.write_now.next = false;
        self.write_byte.next = self.new_info.val();
        self.header_last.next = 2.into();
        if self.rx_frame.ide.val() {
            self.header_last.next = 4.into();
        }
        if self.rx_frame.header.val() {
            self.header_step.d.next = 0.into();
            self.write_at.d.next = self.tail.q.val();
            self.writing_header.d.next = true;
            self.incomplete.d.next = false;
        }
        if self.writing_header.q.val() {
            self.write_now.next = true;
            self.header_step.d.next = self.header_step.q.val() + 1;
            if self.header_step.q.val() == self.header_last.val() {
                self.writing_header.d.next = false;
            }
            // The stream's `id` holds ID.28..18 in bits 28..18 in both formats and 0 below in a
            // standard frame: the frame information, ID.28..21, then ID.20..13 or (standard)
            // ID.20..18, the RTR copy in bit 4 and 0000, ID.12..5, ID.4..0 with the RTR copy in
            // bit 2. A mux tree on the step's bits (steps 0..4: the header ends at `header_last`),
            // not a chain of step comparisons: fewer LUTs.
            if self.header_step.q.val().get_bit(2) {
                self.write_byte.next = self
                    .zero_byte
                    .val()
                    .replace_bit(7, self.rx_frame.id.val().get_bit(4))
                    .replace_bit(6, self.rx_frame.id.val().get_bit(3))
                    .replace_bit(5, self.rx_frame.id.val().get_bit(2))
                    .replace_bit(4, self.rx_frame.id.val().get_bit(1))
                    .replace_bit(3, self.rx_frame.id.val().get_bit(0))
                    .replace_bit(2, self.rx_frame.rtr.val());
            } else if self.header_step.q.val().get_bit(1) {
                if self.header_step.q.val().get_bit(0) {
                    self.write_byte.next = self.rx_frame.id.val().get_bits::<8>(5);
                } else {
                    self.write_byte.next = self.rx_frame.id.val().get_bits::<8>(13);
                    if self.rx_frame.ide.val() == false {
                        self.write_byte.next = self
                            .rx_frame
                            .id
                            .val()
                            .get_bits::<8>(13)
                            .replace_bit(4, self.rx_frame.rtr.val());
                    }
                }
            } else if self.header_step.q.val().get_bit(0) {
                self.write_byte.next = self.rx_frame.id.val().get_bits::<8>(21);
            }
        }
        if self.rx_frame.strobe.val() {
            self.write_now.next = true;
            self.write_byte.next = self.rx_frame.data.val();
        }
        // A message's bytes go to consecutive addresses from the tail (the header, then the data
        // bytes in order), so the first that finds no room is the one that would land on the head
        // message: after a byte of the message was written (the write position left the tail), or
        // at its first byte if the FIFO is `full` (the pointers meet both when it is empty and when
        // it is full). Every later byte of the message is dropped with it.
        self.at_head.next = self.write_at.q.val() == self.head.q.val();
        self.no_room.next = (self.at_head.val()
            & ((self.write_at.q.val() != self.tail.q.val()) | self.full.q.val()))
            | self.incomplete.q.val();
        self.ram_write.next = false;
        self.ram_write_address.next = self.write_at.q.val();
        self.ram_write_data.next = self.write_byte.val();
        if self.write_now.val() {
            if self.no_room.val() {
                self.incomplete.d.next = true;
            } else {
                self.ram_write.next = true;
                self.write_at.d.next = self.write_at.q.val() + 1;
            }
        }

        // ---- Release of the head message and storing of the new one (possibly in the same cycle).
        self.releasing.next = self.release_head.val() & (self.count.q.val() != 0);
        self.storing.next = self.store.val() & (self.incomplete.q.val() == false);
        self.next_head.next = self.head.q.val() + bit_cast::<6, 4>(self.head_length.val());
        self.count_after_release.next = self.count.q.val();
        if self.releasing.val() {
            self.full.d.next = false;
            self.head.d.next = self.next_head.val();
            self.count_after_release.next = self.count.q.val() - 1;
            self.fetching.d.next = true;
        }
        self.count.d.next = self.count_after_release.val();
        if self.storing.val() {
            // A complete message: every byte was written, the last just before `write_at`.
            self.tail.d.next = self.write_at.q.val();
            // The message took the last free bytes (with a release in the same clock it cannot: it
            // fitted before the release freed at least 3 more).
            self.full.d.next = self.at_head.val() & !self.releasing.val();
            self.count.d.next = self.count_after_release.val() + 1;
            if self.count_after_release.val() == 0 {
                self.head_info_reg.d.next = self.new_info.val();
                self.fetching.d.next = false;
            }
        }
        if self.store.val() & self.incomplete.q.val() {
            self.overrun_state.d.next = true;
        }
        if self.clear_overrun.val() {
            self.overrun_state.d.next = false;
        }

        // The RAM read port: the host's reads, otherwise the next head's frame information.
        self.ram.read_address.next = self.next_head.val();
        if self.host_read.val() {
            self.ram.read_address.next = self.host_address.val();
        }

        // ---- Reset mode empties the FIFO; the start address stays (RBSA); the host may write the RAM.
        if self.clear.val() {
            if self.host_write.val() {
                self.ram_write.next = true;
                self.ram_write_address.next = self.host_address.val();
                self.ram_write_data.next = self.host_data.val();
            }
            self.tail.d.next = self.head.q.val();
            self.count.d.next = 0.into();
            self.full.d.next = false;
            self.overrun_state.d.next = false;
            self.writing_header.d.next = false;
            self.incomplete.d.next = false;
            if self.load_start.val() {
                self.head.d.next = self.start_address.val();
                self.tail.d.next = self.start_address.val();
            }
        }
        self.ram.write_enable.next = self.ram_write.val();
        self.ram.write_address.next = self.ram_write_address.val();
        self.ram.write_data.next = self.ram_write_data.val();
        if self.reset.val() {
            self.head.d.next = 0.into();
            self.tail.d.next = 0.into();
            self.write_at.d.next = 0.into();
            self.count.d.next = 0.into();
            self.full.d.next = false;
            self.overrun_state.d.next = false;
            self.writing_header.d.next = false;
            self.incomplete.d.next = false;
            self.fetching.d.next = false;
            self.head_info_reg.d.next = 0.into();
            self.header_step.d.next = 0.into();
        }
    }
}
