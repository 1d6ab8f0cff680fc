//! The bit transmitter: chooses the bit the node sends next and drives `tx`.
//!
//! At each process point the sequencer has decided the next field, its position and the node's
//! role; this block turns that into the next bit: the transmit stream (identifier and data bits,
//! read byte by byte from the transmit buffer in the SJA1000 frame-buffer layout, most significant
//! bit first), the frame information (SRR/RTR, IDE, r1/r0, DLC), the CRC register's MSB, the ACK, an
//! error or overload flag of the right kind, or a stuff bit where five equal bits demand one;
//! recessive everywhere else. Ports in: the timing strobes `process_point` (load `tx_next`) and
//! `transmit_point` (copy it to `tx`), the decisions of this bit, `tx_data` (the buffer byte at
//! `tx_addr`, from a registered RAM read) and `silent` (bus-off or reset mode: recessive at once).
//! Out, from registers only: `tx` and `tx_addr`. Acts on the rising edge of `clock`; the extra
//! transmit point of a hard synchronisation sends the same bit again. The stream lives here, not in
//! a block of its own, so that its head bits never cross the sequencer (a combinational path
//! through the parent that Verilator reports as a loop).

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::protocol::ProtocolState;
use crate::bsp::{EXT_RTR_POSITION, IDE_POSITION, SRR_RTR_POSITION};
use crate::registers::frame_buffer;

/// Transmit-bit selection of the bit stream processor.
#[derive(ActivityBlock, BlockDefault)]
pub struct BitTransmitter {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Process point: load the next bit.
    pub process_point: Signal<In, Bit>,
    /// Transmit point: send it.
    pub transmit_point: Signal<In, Bit>,
    /// The sampled bit.
    pub rx_bit: Signal<In, Bit>,
    /// The field of the bit being processed.
    pub field: Signal<In, ProtocolState>,
    /// Its position in the field.
    pub count: Signal<In, Bits<7>>,
    /// The bit being processed is a stuff bit (the field position holds).
    pub stuff_bit: Signal<In, Bit>,
    /// The bit being processed is a SOF.
    pub start_frame: Signal<In, Bit>,
    /// The field of the next bit.
    pub next_field: Signal<In, ProtocolState>,
    /// The node transmits the next bit's frame.
    pub next_transmitter: Signal<In, Bit>,
    /// A frame of our own may start (idle bus: send a SOF).
    pub may_start: Signal<In, Bit>,
    /// Frame information byte: FF (7), RTR (6), DLC (3..0).
    pub tx_info: Signal<In, Bits<8>>,
    /// The transmit-buffer byte at `tx_addr`.
    pub tx_data: Signal<In, Bits<8>>,
    /// This bit consumes a stream bit (shift, and fetch the next byte after the last bit of one).
    pub consume: Signal<In, Bit>,
    /// The arbitration field ends: the stream continues with the data bytes.
    pub to_data: Signal<In, Bit>,
    /// With `to_data`: the frame is extended (4 identifier bytes).
    pub extended: Signal<In, Bit>,
    /// No frame under way: the stream waits at the first identifier byte.
    pub rewind: Signal<In, Bit>,
    /// The CRC register's most significant bit (14).
    pub crc_msb: Signal<In, Bit>,
    /// The CRC register's bit 13 (the MSB after a shift).
    pub crc_next_msb: Signal<In, Bit>,
    /// This bit goes into the CRC register.
    pub feed_crc: Signal<In, Bit>,
    /// Acknowledge the frame in the next bit.
    pub send_ack: Signal<In, Bit>,
    /// A new error flag would be passive (error passive or listen-only).
    pub flag_is_passive: Signal<In, Bit>,
    /// The error flag being sent is passive.
    pub flag_passive: Signal<In, Bit>,
    /// Our active error flag restarts with this bit (a bit error in it).
    pub flag_restarts: Signal<In, Bit>,
    /// Listen-only mode: never a dominant bit.
    pub listen_only: Signal<In, Bit>,
    /// Four equal bits in the stuffed region before this one.
    pub four_equal: Signal<In, Bit>,
    /// Level of that run.
    pub run_level: Signal<In, Bit>,
    /// Stuffing ends with this bit (an error, or the end of the stuffed fields).
    pub stop_stuffing: Signal<In, Bit>,
    /// A bus error is detected in this bit (a flag follows, no stuff bit).
    pub error: Signal<In, Bit>,
    /// Bus-off or reset mode: recessive at once.
    pub silent: Signal<In, Bit>,
    /// Bus output, registered.
    pub tx: Signal<Out, Bit>,
    /// Transmit-buffer byte wanted.
    pub tx_addr: Signal<Out, Bits<4>>,
    tx_reg: DFF<Bit>,
    tx_next: DFF<Bit>,
    tx_ptr: DFF<Bits<4>>,
    tx_shift: DFF<Bits<8>>,
    /// Bits of the current byte still in `tx_shift` (0: the head is bit 7 of `tx_data`).
    tx_left: DFF<Bits<4>>,
    /// The bit at the head of the stream, and the head after `consume`.
    stream_bit: Signal<Local, Bit>,
    stream_next_bit: Signal<Local, Bit>,
    next_bit: Signal<Local, Bit>,
    /// The next bit is at arbitration position 11, 12 or 31 (SRR/RTR, IDE, extended RTR).
    next_is_srr_rtr: Signal<Local, Bit>,
    next_is_ide: Signal<Local, Bit>,
    next_is_ext_rtr: Signal<Local, Bit>,
    /// Low bits of the next bit's position, and its DLC bit number (1..4) in the control field.
    next_count_low: Signal<Local, Bits<3>>,
    count_plus_1: Signal<Local, Bits<7>>,
    dlc_position: Signal<Local, Bits<3>>,
    #[constant(SRR_RTR_POSITION - 1)]
    before_srr_rtr: Constant<Bits<7>>,
    #[constant(SRR_RTR_POSITION)]
    srr_rtr_position: Constant<Bits<7>>,
    #[constant(IDE_POSITION)]
    ide_position: Constant<Bits<7>>,
    #[constant(EXT_RTR_POSITION - 1)]
    before_ext_rtr: Constant<Bits<7>>,
    #[constant(EXT_RTR_POSITION)]
    ext_rtr_position: Constant<Bits<7>>,
    #[constant(frame_buffer::FIRST_ID_BYTE)]
    first_id_byte: Constant<Bits<4>>,
    #[constant(frame_buffer::STANDARD_DATA_BYTE)]
    standard_data_byte: Constant<Bits<4>>,
    #[constant(frame_buffer::EXTENDED_DATA_BYTE)]
    extended_data_byte: Constant<Bits<4>>,
}

impl Logic for BitTransmitter {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, tx_reg, tx_next, tx_ptr, tx_shift, tx_left);
        self.tx.next = self.tx_reg.q.val();
        self.tx_addr.next = self.tx_ptr.q.val();

        // ---- The transmit stream.
        self.stream_bit.next = self.tx_shift.q.val().get_bit(7);
        self.stream_next_bit.next = self.tx_shift.q.val().get_bit(6);
        if self.tx_left.q.val() == 0 {
            self.stream_bit.next = self.tx_data.val().get_bit(7);
            self.stream_next_bit.next = self.tx_data.val().get_bit(6);
        }
        if self.tx_left.q.val() == 1 {
            self.stream_next_bit.next = self.tx_data.val().get_bit(7);
        }
        if self.consume.val() {
            if self.tx_left.q.val() == 0 {
                self.tx_shift.d.next = self.tx_data.val() << 1;
                self.tx_left.d.next = 7.into();
                self.tx_ptr.d.next = self.tx_ptr.q.val() + 1;
            } else {
                self.tx_shift.d.next = self.tx_shift.q.val() << 1;
                self.tx_left.d.next = self.tx_left.q.val() - 1;
            }
        }
        if self.to_data.val() {
            self.tx_left.d.next = 0.into();
            self.tx_ptr.d.next = self.standard_data_byte.val();
            if self.extended.val() {
                self.tx_ptr.d.next = self.extended_data_byte.val();
            }
        }
        if self.rewind.val() {
            self.tx_ptr.d.next = self.first_id_byte.val();
            self.tx_left.d.next = 0.into();
        }

        // ---- The next bit.

        // The next bit's arbitration and control positions come from registers rather than from
        // the sequencer's next count, the end of its longest path: a stuff bit holds the count, a
        // field bit advances it, a SOF starts the arbitration field at 0 (no special position) and
        // the control field starts at 0 from arbitration count 12 or 31 (positions 5 or 0: neither
        // a DLC bit).
        self.next_is_srr_rtr.next = self.count.val() == self.before_srr_rtr.val();
        self.next_is_ide.next = self.count.val() == self.srr_rtr_position.val();
        self.next_is_ext_rtr.next = self.count.val() == self.before_ext_rtr.val();
        self.count_plus_1.next = self.count.val() + 1;
        self.next_count_low.next = bit_cast::<3, 7>(self.count_plus_1.val());
        if self.stuff_bit.val() {
            self.next_is_srr_rtr.next = self.count.val() == self.srr_rtr_position.val();
            self.next_is_ide.next = self.count.val() == self.ide_position.val();
            self.next_is_ext_rtr.next = self.count.val() == self.ext_rtr_position.val();
            self.next_count_low.next = bit_cast::<3, 7>(self.count.val());
        }
        if self.start_frame.val() {
            self.next_is_srr_rtr.next = false;
            self.next_is_ide.next = false;
            self.next_is_ext_rtr.next = false;
        }
        self.dlc_position.next = 0.into();

        self.next_bit.next = true;
        match self.next_field.val() {
            ProtocolState::Idle => {
                self.next_bit.next = self.may_start.val() == false;
            }
            ProtocolState::Arbitration => {
                if self.next_transmitter.val() {
                    self.next_bit.next = self.stream_bit.val();
                    if self.consume.val() {
                        self.next_bit.next = self.stream_next_bit.val();
                    }
                    // SRR is recessive; RTR, IDE from the frame information.
                    if self.next_is_srr_rtr.val() {
                        self.next_bit.next = self.tx_info.val().get_bit(6);
                        if self.tx_info.val().get_bit(7) {
                            self.next_bit.next = true;
                        }
                    }
                    if self.next_is_ide.val() {
                        self.next_bit.next = self.tx_info.val().get_bit(7);
                    }
                    if self.next_is_ext_rtr.val() {
                        self.next_bit.next = self.tx_info.val().get_bit(6);
                    }
                }
            }
            ProtocolState::Control => {
                if self.next_transmitter.val() {
                    // r1 (extended), r0: dominant; then DLC bits 3..0.
                    self.next_bit.next = false;
                    self.dlc_position.next = self.next_count_low.val();
                    if self.tx_info.val().get_bit(7) {
                        self.dlc_position.next = self.next_count_low.val() - 1;
                    }
                    if self.dlc_position.val() == 1 {
                        self.next_bit.next = self.tx_info.val().get_bit(3);
                    }
                    if self.dlc_position.val() == 2 {
                        self.next_bit.next = self.tx_info.val().get_bit(2);
                    }
                    if self.dlc_position.val() == 3 {
                        self.next_bit.next = self.tx_info.val().get_bit(1);
                    }
                    if self.dlc_position.val() == 4 {
                        self.next_bit.next = self.tx_info.val().get_bit(0);
                    }
                }
            }
            ProtocolState::Data => {
                if self.next_transmitter.val() {
                    self.next_bit.next = self.stream_bit.val();
                    if self.consume.val() {
                        self.next_bit.next = self.stream_next_bit.val();
                    }
                }
            }
            ProtocolState::Crc => {
                if self.next_transmitter.val() {
                    // The MSB of the register after this bit (fed unless it was a stuff bit).
                    self.next_bit.next = self.crc_msb.val();
                    if self.feed_crc.val() {
                        self.next_bit.next =
                            self.crc_next_msb.val() ^ self.crc_msb.val() ^ self.rx_bit.val();
                    }
                }
            }
            ProtocolState::AckSlot => {
                self.next_bit.next = self.send_ack.val() == false;
            }
            ProtocolState::ErrorFlag => {
                // A flag (a new one, or ours restarted by a bit error) starts with the state at this
                // detection; its later bits keep its kind.
                self.next_bit.next = self.flag_is_passive.val();
                if (self.field.val() == ProtocolState::ErrorFlag) & !self.flag_restarts.val() {
                    self.next_bit.next = self.flag_passive.val();
                }
            }
            ProtocolState::OverloadFlag => {
                self.next_bit.next = self.listen_only.val();
            }
            _ => {}
        }
        // Five equal bits with this one: the next bit is a stuff bit (complement of this level).
        if self.four_equal.val()
            & !self.stuff_bit.val()
            & (self.rx_bit.val() == self.run_level.val())
            & self.next_transmitter.val()
            & !self.error.val()
            & !self.stop_stuffing.val()
        {
            self.next_bit.next = self.rx_bit.val() == false;
        }

        if self.process_point.val() {
            self.tx_next.d.next = self.next_bit.val();
        }
        if self.transmit_point.val() {
            self.tx_reg.d.next = self.tx_next.q.val();
        }
        if self.listen_only.val() {
            self.tx_reg.d.next = true;
        }
        if self.silent.val() | self.reset.val() {
            self.tx_reg.d.next = true;
            self.tx_next.d.next = true;
        }
        if self.reset.val() {
            self.tx_ptr.d.next = self.first_id_byte.val();
            self.tx_shift.d.next = 0.into();
            self.tx_left.d.next = 0.into();
        }
    }
}
