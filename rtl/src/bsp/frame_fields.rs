//! Frame fields: what a bit of a data or remote frame decides, from the arbitration field to the end
//! of frame, stuff bits included (ISO 11898-1 frame coding, bit monitoring, arbitration, ACK and
//! the error kinds they detect).
//!
//! Ports in: the sequencer's `field`, `count` and `transmitter`, the bit `rx_bit` and the level the
//! node sends `sender_tx`, the stuffing state (`stuff_bit`, `run_level`), the received header so far
//! (`ide`, `rtr`, `dlc`, `last_data_byte`), the CRC register `crc` and `crc_error`, and the modes
//! (`enable`, `listen_only`, `self_test`, `error_passive`, `tx_single_shot`, `abort_pending`).
//! Out, combinational, meaningful at a process point of a stuff bit or of a frame field: the next
//! field and count, an `error` with its `error_type` and whether it `counts` (rule 3 exceptions),
//! arbitration `lost`, the transmit stream's `consume`, `feed_crc`, `stop_stuffing`, `send_ack`,
//! `arbitration_end` (for the transmit stream), the register updates `set_crc_error` and
//! `set_ack_penalty`, the counter events `rec_success`
//! and `tec_minus_1`, the results `valid` (receiver, EOF bit 6) and `done`/`done_success`, and
//! the arbitration field's bit kinds (`srr_rtr_bit`, `ide_bit`, `ext_rtr_bit`, `id_bit`) and
//! `control_last` the receive assembler needs. No clock: every
//! input comes straight from a port, a flip-flop or another block's output, so the sequencer may
//! use these outputs anywhere (docs/VERILOG.md).

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::protocol::ProtocolState;
use crate::bsp::{
    ecc_type, CRC_BITS, DLC_BITS, EOF_BITS, EXT_RTR_POSITION, IDE_POSITION, SRR_RTR_POSITION,
};

/// The decisions of a frame-field bit.
#[derive(ActivityBlock, BlockDefault)]
pub struct FrameFields {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Process point of the bit timing logic: the decisions are made there (else all idle).
    pub process_point: Signal<In, Bit>,
    /// The field of the bit.
    pub field: Signal<In, ProtocolState>,
    /// The bit's position in its field.
    pub count: Signal<In, Bits<7>>,
    /// The node transmits the frame.
    pub transmitter: Signal<In, Bit>,
    /// The sampled bit.
    pub rx_bit: Signal<In, Bit>,
    /// The level the node sends.
    pub sender_tx: Signal<In, Bit>,
    /// The bit is a stuff bit.
    pub stuff_bit: Signal<In, Bit>,
    /// The level of the current run of equal bits.
    pub run_level: Signal<In, Bit>,
    /// Received IDE.
    pub ide: Signal<In, Bit>,
    /// Received RTR.
    pub rtr: Signal<In, Bit>,
    /// Received DLC so far.
    pub dlc: Signal<In, Bits<4>>,
    /// Index of the last data byte the DLC announces.
    pub last_data_byte: Signal<In, Bits<4>>,
    /// The CRC register (0 after a correct CRC sequence).
    pub crc: Signal<In, Bits<15>>,
    /// A CRC error was found at the CRC delimiter.
    pub crc_error: Signal<In, Bit>,
    /// Operating mode.
    pub enable: Signal<In, Bit>,
    /// Listen-only mode.
    pub listen_only: Signal<In, Bit>,
    /// Self-test mode.
    pub self_test: Signal<In, Bit>,
    /// Error passive.
    pub error_passive: Signal<In, Bit>,
    /// One attempt only.
    pub tx_single_shot: Signal<In, Bit>,
    /// The request is being aborted (it ends as a single shot).
    pub abort_pending: Signal<In, Bit>,
    /// The field after this bit.
    pub next_field: Signal<Out, ProtocolState>,
    /// The count after this bit.
    pub next_count: Signal<Out, Bits<7>>,
    /// An error is detected at this bit.
    pub error: Signal<Out, Bit>,
    /// Its ECC type.
    pub error_type: Signal<Out, Bits<2>>,
    /// It changes the error counters.
    pub counts: Signal<Out, Bit>,
    /// Arbitration is lost at this bit.
    pub lost: Signal<Out, Bit>,
    /// The transmit stream moves on.
    pub consume: Signal<Out, Bit>,
    /// The bit goes into the CRC.
    pub feed_crc: Signal<Out, Bit>,
    /// Stuffing stops after this bit.
    pub stop_stuffing: Signal<Out, Bit>,
    /// The node sends an ACK in the next bit.
    pub send_ack: Signal<Out, Bit>,
    /// The CRC sequence was wrong (reported at the ACK delimiter).
    pub set_crc_error: Signal<Out, Bit>,
    /// An error-passive transmitter's ACK error, counted only if its passive flag sees a dominant bit.
    pub set_ack_penalty: Signal<Out, Bit>,
    /// A receiver's ACK went out (REC decrement).
    pub rec_success: Signal<Out, Bit>,
    /// A transmission succeeded (TEC decrement).
    pub tec_minus_1: Signal<Out, Bit>,
    /// The frame is valid for receivers.
    pub valid: Signal<Out, Bit>,
    /// The request ends.
    pub done: Signal<Out, Bit>,
    /// With `done`: the frame was sent.
    pub done_success: Signal<Out, Bit>,
    /// The arbitration field ends with this bit (errors aside): the control field follows.
    pub arbitration_end: Signal<Out, Bit>,
    /// In the arbitration field: the SRR (extended) or RTR (standard) bit.
    pub srr_rtr_bit: Signal<Out, Bit>,
    /// In the arbitration field: the IDE bit.
    pub ide_bit: Signal<Out, Bit>,
    /// In the arbitration field: the RTR bit of an extended frame.
    pub ext_rtr_bit: Signal<Out, Bit>,
    /// In the arbitration field: an identifier bit (not SRR/RTR, IDE or the extended RTR).
    pub id_bit: Signal<Out, Bit>,
    /// In the control field: the last DLC bit.
    pub control_last: Signal<Out, Bit>,
    count_plus_1: Signal<Local, Bits<7>>,
    /// A transmitter reads back another level than it sends.
    bit_error: Signal<Local, Bit>,
    single_shot: Signal<Local, Bit>,
    /// With `control_last`: no data field follows (remote frame, or the DLC with this bit is 0).
    no_data: Signal<Local, Bit>,
    /// In the data field: the last bit of the last data byte.
    data_last: Signal<Local, Bit>,
    #[constant(ecc_type::BIT)]
    bit_error_type: Constant<Bits<2>>,
    #[constant(ecc_type::FORM)]
    form_error_type: Constant<Bits<2>>,
    #[constant(ecc_type::STUFF)]
    stuff_error_type: Constant<Bits<2>>,
    #[constant(ecc_type::OTHER)]
    other_error_type: Constant<Bits<2>>,
    #[constant(SRR_RTR_POSITION)]
    srr_rtr_position: Constant<Bits<7>>,
    #[constant(IDE_POSITION)]
    ide_position: Constant<Bits<7>>,
    #[constant(EXT_RTR_POSITION)]
    ext_rtr_position: Constant<Bits<7>>,
    /// The last DLC bit of a standard and of an extended frame.
    #[constant(DLC_BITS)]
    last_standard_dlc_bit: Constant<Bits<7>>,
    #[constant(DLC_BITS + 1)]
    last_extended_dlc_bit: Constant<Bits<7>>,
    /// The last bit of a data byte.
    #[constant(7)]
    last_byte_bit: Constant<Bits<3>>,
    #[constant(CRC_BITS - 1)]
    last_crc_bit: Constant<Bits<7>>,
    /// EOF bit 6 (the last but one): a receiver takes the frame here.
    #[constant(EOF_BITS - 2)]
    validity_eof_bit: Constant<Bits<7>>,
    #[constant(EOF_BITS - 1)]
    last_eof_bit: Constant<Bits<7>>,
}

impl Logic for FrameFields {
    #[hdl_gen]
    fn update(&mut self) {
        self.count_plus_1.next = self.count.val() + 1;
        self.bit_error.next = self.transmitter.val() & (self.sender_tx.val() != self.rx_bit.val());
        self.single_shot.next = self.tx_single_shot.val() | self.abort_pending.val();
        // Where the fields end, from the count (it stays below 32 in the arbitration field:
        // equalities, not comparisons, which are carry chains on FPGAs).
        self.srr_rtr_bit.next = self.count.val() == self.srr_rtr_position.val();
        self.ide_bit.next = self.count.val() == self.ide_position.val();
        self.ext_rtr_bit.next = self.count.val() == self.ext_rtr_position.val();
        self.id_bit.next =
            (self.srr_rtr_bit.val() | self.ide_bit.val() | self.ext_rtr_bit.val()) == false;
        self.control_last.next = (self.count.val() == self.last_extended_dlc_bit.val())
            | ((self.count.val() == self.last_standard_dlc_bit.val()) & (self.ide.val() == false));
        self.no_data.next = self.rtr.val()
            | ((bit_cast::<3, 4>(self.dlc.val()) == 0) & (self.rx_bit.val() == false));
        self.data_last.next = (self.count.val().get_bits::<3>(0) == self.last_byte_bit.val())
            & (self.count.val().get_bits::<4>(3) == self.last_data_byte.val());

        self.next_field.next = self.field.val();
        self.next_count.next = self.count_plus_1.val();
        self.error.next = false;
        self.error_type.next = self.bit_error_type.val();
        self.counts.next = true;
        self.lost.next = false;
        self.consume.next = false;
        self.feed_crc.next = false;
        self.stop_stuffing.next = false;
        self.send_ack.next = false;
        self.set_crc_error.next = false;
        self.set_ack_penalty.next = false;
        self.rec_success.next = false;
        self.tec_minus_1.next = false;
        self.valid.next = false;
        self.arbitration_end.next = false;
        self.done.next = false;
        self.done_success.next = false;

        if self.process_point.val() & self.stuff_bit.val() {
            // A stuff bit: no field advance.
            self.next_count.next = self.count.val();
            if self.bit_error.val() {
                self.error.next = true;
                // Rule 3 exception b: a recessive stuff bit of the arbitration field read dominant
                // is a stuff error (ISO 11898-1) that does not count.
                if (self.field.val() == ProtocolState::Arbitration) & self.sender_tx.val() {
                    self.error_type.next = self.stuff_error_type.val();
                    self.counts.next = false;
                }
            } else if self.rx_bit.val() == self.run_level.val() {
                self.error.next = true;
                self.error_type.next = self.stuff_error_type.val();
            }
        } else if self.process_point.val() {
            match self.field.val() {
                ProtocolState::Arbitration => {
                    self.feed_crc.next = true;
                    self.consume.next = self.transmitter.val() & self.id_bit.val();
                    // A dominant IDE ends a standard arbitration field.
                    if (self.ide_bit.val() & (self.rx_bit.val() == false)) | self.ext_rtr_bit.val()
                    {
                        self.next_field.next = ProtocolState::Control;
                        self.next_count.next = 0.into();
                        self.arbitration_end.next = true;
                    }
                    if self.bit_error.val() {
                        if self.sender_tx.val() {
                            // Sent recessive, read dominant: arbitration lost.
                            self.consume.next = false;
                            self.lost.next = true;
                            self.done.next = self.single_shot.val();
                        } else {
                            self.error.next = true;
                        }
                    }
                }
                ProtocolState::Control => {
                    self.feed_crc.next = true;
                    if self.control_last.val() {
                        self.next_count.next = 0.into();
                        self.next_field.next = ProtocolState::Data;
                        if self.no_data.val() {
                            self.next_field.next = ProtocolState::Crc;
                        }
                    }
                    self.error.next = self.bit_error.val();
                }
                ProtocolState::Data => {
                    self.feed_crc.next = true;
                    self.consume.next = self.transmitter.val();
                    if self.data_last.val() {
                        self.next_field.next = ProtocolState::Crc;
                        self.next_count.next = 0.into();
                    }
                    self.error.next = self.bit_error.val();
                }
                ProtocolState::Crc => {
                    self.feed_crc.next = true;
                    if self.count.val() == self.last_crc_bit.val() {
                        self.next_field.next = ProtocolState::CrcDelimiter;
                    }
                    self.error.next = self.bit_error.val();
                }
                ProtocolState::CrcDelimiter => {
                    self.stop_stuffing.next = true;
                    self.next_field.next = ProtocolState::AckSlot;
                    if self.rx_bit.val() == false {
                        self.error.next = true;
                        self.error_type.next = self.form_error_type.val();
                    } else if self.transmitter.val() == false {
                        if self.crc.val() == 0 {
                            self.send_ack.next =
                                self.enable.val() & (self.listen_only.val() == false);
                        } else {
                            self.set_crc_error.next = true;
                        }
                    }
                }
                ProtocolState::AckSlot => {
                    self.next_field.next = ProtocolState::AckDelimiter;
                    if self.transmitter.val() {
                        if self.rx_bit.val() & (self.self_test.val() == false) {
                            self.error.next = true;
                            self.error_type.next = self.other_error_type.val();
                            // Rule 3 exception a is decided during the passive flag.
                            if self.error_passive.val() {
                                self.counts.next = false;
                                self.set_ack_penalty.next = true;
                            }
                        }
                    } else if self.sender_tx.val() == false {
                        if self.rx_bit.val() {
                            self.error.next = true;
                        } else {
                            self.rec_success.next = true;
                        }
                    }
                }
                ProtocolState::AckDelimiter => {
                    self.next_field.next = ProtocolState::EndOfFrame;
                    self.next_count.next = 0.into();
                    if self.rx_bit.val() == false {
                        self.error.next = true;
                        self.error_type.next = self.form_error_type.val();
                    } else if self.crc_error.val() {
                        self.error.next = true;
                        self.error_type.next = self.other_error_type.val();
                    }
                }
                ProtocolState::EndOfFrame => {
                    if self.count.val() == self.last_eof_bit.val() {
                        self.next_field.next = ProtocolState::Intermission;
                        self.next_count.next = 0.into();
                    }
                    if self.rx_bit.val() == false {
                        if (self.count.val() == self.last_eof_bit.val())
                            & (self.transmitter.val() == false)
                        {
                            self.next_field.next = ProtocolState::OverloadFlag;
                        } else {
                            self.error.next = true;
                            self.error_type.next = self.form_error_type.val();
                        }
                    } else {
                        self.valid.next = (self.count.val() == self.validity_eof_bit.val())
                            & (self.transmitter.val() == false);
                        if (self.count.val() == self.last_eof_bit.val()) & self.transmitter.val() {
                            self.done.next = true;
                            self.done_success.next = true;
                            self.tec_minus_1.next = true;
                        }
                    }
                }
                _ => {}
            }
        }
    }
}
