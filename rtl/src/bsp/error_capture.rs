//! Error and arbitration-loss capture: the SJA1000 error code (ECC) of a detected bus error and the
//! arbitration lost position (ALC).
//!
//! Ports in: the sequencer's `field`, `count`, the received `ide` and the kind of the error flag
//! being sent (`flag_passive`) select the ECC segment of the bit being processed (SJA1000 data
//! sheet, ECC bit interpretation); `error` with `error_type` and `receiving` (the direction bit)
//! captures ECC, `lost` captures ALC from `count` (the arbitration bit position). `discard` (reset
//! mode) drops the strobes of this clock. Out, from registers, one clock after the detection:
//! `bus_error` with `ecc`, `arbitration_lost` with `alc`. Acts on the rising edge of `clock`; the
//! sequencer raises `error` and `lost` at the process point only.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::ecc_segment;
use crate::bsp::protocol::ProtocolState;
use crate::bsp::{BASE_ID_BITS, EXT_RTR_POSITION, IDE_POSITION, SRR_RTR_POSITION};

/// The first arbitration position of each identifier part with an ECC segment of its own (SJA1000
/// ALC coding: ID.28..21 are the first 8 of the 11 base identifier bits), in order; the kernel
/// decodes them from the count's eighths, which these assertions tie to the named positions.
pub const ARBITRATION_PARTS: [(u64, u64); 8] = [
    (0, ecc_segment::ID_28_21),
    (BASE_ID_BITS - 3, ecc_segment::ID_20_18),
    (SRR_RTR_POSITION, ecc_segment::SRTR),
    (IDE_POSITION, ecc_segment::IDE),
    (IDE_POSITION + 1, ecc_segment::ID_17_13),
    (IDE_POSITION + 6, ecc_segment::ID_12_5),
    (IDE_POSITION + 14, ecc_segment::ID_4_0),
    (EXT_RTR_POSITION, ecc_segment::RTR),
];
const _: () = assert!(
    ARBITRATION_PARTS[1].0 == 8
        && ARBITRATION_PARTS[2].0 == 11
        && ARBITRATION_PARTS[3].0 == 12
        && ARBITRATION_PARTS[4].0 == 13
        && ARBITRATION_PARTS[5].0 == 18
        && ARBITRATION_PARTS[6].0 == 26
        && ARBITRATION_PARTS[7].0 == 31
);

/// ECC and ALC capture of the bit stream processor.
#[derive(ActivityBlock, BlockDefault)]
pub struct ErrorCapture {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// The field of the bit being processed.
    pub field: Signal<In, ProtocolState>,
    /// The bit's position in its field.
    pub count: Signal<In, Bits<7>>,
    /// IDE of the frame on the bus (the control field is one bit longer in extended frames).
    pub ide: Signal<In, Bit>,
    /// The error flag being sent is passive.
    pub flag_passive: Signal<In, Bit>,
    /// A bus error is detected in this bit.
    pub error: Signal<In, Bit>,
    /// Its SJA1000 error type (`bsp::ecc_type`).
    pub error_type: Signal<In, Bits<2>>,
    /// The node is a receiver of the frame (ECC direction bit).
    pub receiving: Signal<In, Bit>,
    /// Arbitration is lost in this bit.
    pub lost: Signal<In, Bit>,
    /// Drop this clock's strobes (the node is in reset mode).
    pub discard: Signal<In, Bit>,
    /// One clock per detected bus error, with `ecc`.
    pub bus_error: Signal<Out, Bit>,
    /// Error code: type (7..6), direction (5, 1 = receiving), segment (4..0).
    pub ecc: Signal<Out, Bits<8>>,
    /// One clock when arbitration is lost, with `alc`.
    pub arbitration_lost: Signal<Out, Bit>,
    /// Arbitration bit position of the loss (SJA1000 ALC coding).
    pub alc: Signal<Out, Bits<5>>,
    error_pulse: DFF<Bit>,
    ecc_reg: DFF<Bits<8>>,
    lost_pulse: DFF<Bit>,
    alc_reg: DFF<Bits<5>>,
    /// ECC segment of the bit being processed.
    segment: Signal<Local, Bits<5>>,
    /// In the arbitration field: the bit count's eighth (bits 4..3) and position in it (2..0).
    arbitration_eighth: Signal<Local, Bits<2>>,
    arbitration_offset: Signal<Local, Bits<3>>,
    #[constant(ecc_segment::SOF)]
    seg_sof: Constant<Bits<5>>,
    #[constant(ecc_segment::ID_28_21)]
    seg_id_28_21: Constant<Bits<5>>,
    #[constant(ecc_segment::ID_20_18)]
    seg_id_20_18: Constant<Bits<5>>,
    #[constant(ecc_segment::SRTR)]
    seg_srtr: Constant<Bits<5>>,
    #[constant(ecc_segment::IDE)]
    seg_ide: Constant<Bits<5>>,
    #[constant(ecc_segment::ID_17_13)]
    seg_id_17_13: Constant<Bits<5>>,
    #[constant(ecc_segment::ID_12_5)]
    seg_id_12_5: Constant<Bits<5>>,
    #[constant(ecc_segment::ID_4_0)]
    seg_id_4_0: Constant<Bits<5>>,
    #[constant(ecc_segment::RTR)]
    seg_rtr: Constant<Bits<5>>,
    #[constant(ecc_segment::R1)]
    seg_r1: Constant<Bits<5>>,
    #[constant(ecc_segment::R0)]
    seg_r0: Constant<Bits<5>>,
    #[constant(ecc_segment::DLC)]
    seg_dlc: Constant<Bits<5>>,
    #[constant(ecc_segment::DATA)]
    seg_data: Constant<Bits<5>>,
    #[constant(ecc_segment::CRC)]
    seg_crc: Constant<Bits<5>>,
    #[constant(ecc_segment::CRC_DELIMITER)]
    seg_crc_delimiter: Constant<Bits<5>>,
    #[constant(ecc_segment::ACK_SLOT)]
    seg_ack_slot: Constant<Bits<5>>,
    #[constant(ecc_segment::ACK_DELIMITER)]
    seg_ack_delimiter: Constant<Bits<5>>,
    #[constant(ecc_segment::EOF)]
    seg_eof: Constant<Bits<5>>,
    #[constant(ecc_segment::INTERMISSION)]
    seg_intermission: Constant<Bits<5>>,
    #[constant(ecc_segment::ACTIVE_ERROR_FLAG)]
    seg_active_error_flag: Constant<Bits<5>>,
    #[constant(ecc_segment::PASSIVE_ERROR_FLAG)]
    seg_passive_error_flag: Constant<Bits<5>>,
    #[constant(ecc_segment::TOLERATE_DOMINANT)]
    seg_tolerate_dominant: Constant<Bits<5>>,
    #[constant(ecc_segment::ERROR_DELIMITER)]
    seg_error_delimiter: Constant<Bits<5>>,
    #[constant(ecc_segment::OVERLOAD_FLAG)]
    seg_overload_flag: Constant<Bits<5>>,
}

impl Logic for ErrorCapture {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, error_pulse, ecc_reg, lost_pulse, alc_reg);
        self.bus_error.next = self.error_pulse.q.val();
        self.ecc.next = self.ecc_reg.q.val();
        self.arbitration_lost.next = self.lost_pulse.q.val();
        self.alc.next = self.alc_reg.q.val();
        self.error_pulse.d.next = false;
        self.lost_pulse.d.next = false;

        self.segment.next = 0.into();
        self.arbitration_eighth.next = self.count.val().get_bits::<2>(3);
        self.arbitration_offset.next = self.count.val().get_bits::<3>(0);
        match self.field.val() {
            ProtocolState::Integrating => {}
            ProtocolState::BusOff => {}
            ProtocolState::Idle => {
                self.segment.next = self.seg_sof.val();
            }
            ProtocolState::Suspend => {
                self.segment.next = self.seg_sof.val();
            }
            ProtocolState::Arbitration => {
                // The parts by position (SJA1000 ALC coding, `ARBITRATION_PARTS`), decoded from the
                // count's eighths: equalities, where comparisons would be carry chains.
                self.segment.next = self.seg_id_28_21.val();
                if self.arbitration_eighth.val() == 1 {
                    // 8..10 ID.20..18, 11 SRR/RTR, 12 IDE, 13..15 ID.17..13.
                    self.segment.next = self.seg_id_17_13.val();
                    if self.arbitration_offset.val() == 4 {
                        self.segment.next = self.seg_ide.val();
                    }
                    if self.arbitration_offset.val() == 3 {
                        self.segment.next = self.seg_srtr.val();
                    }
                    if (self.arbitration_offset.val().get_bit(2) == false)
                        & (self.arbitration_offset.val() != 3)
                    {
                        self.segment.next = self.seg_id_20_18.val();
                    }
                }
                if self.arbitration_eighth.val() == 2 {
                    // 16..17 ID.17..13, 18..23 ID.12..5.
                    self.segment.next = self.seg_id_12_5.val();
                    if self.arbitration_offset.val().get_bits::<2>(1) == 0 {
                        self.segment.next = self.seg_id_17_13.val();
                    }
                }
                if self.arbitration_eighth.val() == 3 {
                    // 24..25 ID.12..5, 26..30 ID.4..0, 31 RTR.
                    self.segment.next = self.seg_id_4_0.val();
                    if self.arbitration_offset.val().get_bits::<2>(1) == 0 {
                        self.segment.next = self.seg_id_12_5.val();
                    }
                    if self.arbitration_offset.val() == 7 {
                        self.segment.next = self.seg_rtr.val();
                    }
                }
                // Past the field's 32 positions (never reached): the last part, as before.
                if self.count.val().get_bits::<2>(5) != 0 {
                    self.segment.next = self.seg_rtr.val();
                }
            }
            ProtocolState::Control => {
                // r1 (extended only), r0, then the DLC.
                self.segment.next = self.seg_dlc.val();
                if self.ide.val() {
                    if self.count.val() == 0 {
                        self.segment.next = self.seg_r1.val();
                    }
                    if self.count.val() == 1 {
                        self.segment.next = self.seg_r0.val();
                    }
                } else if self.count.val() == 0 {
                    self.segment.next = self.seg_r0.val();
                }
            }
            ProtocolState::Data => {
                self.segment.next = self.seg_data.val();
            }
            ProtocolState::Crc => {
                self.segment.next = self.seg_crc.val();
            }
            ProtocolState::CrcDelimiter => {
                self.segment.next = self.seg_crc_delimiter.val();
            }
            ProtocolState::AckSlot => {
                self.segment.next = self.seg_ack_slot.val();
            }
            ProtocolState::AckDelimiter => {
                self.segment.next = self.seg_ack_delimiter.val();
            }
            ProtocolState::EndOfFrame => {
                self.segment.next = self.seg_eof.val();
            }
            ProtocolState::Intermission => {
                self.segment.next = self.seg_intermission.val();
            }
            ProtocolState::ErrorFlag => {
                self.segment.next = self.seg_active_error_flag.val();
                if self.flag_passive.val() {
                    self.segment.next = self.seg_passive_error_flag.val();
                }
            }
            ProtocolState::OverloadFlag => {
                self.segment.next = self.seg_overload_flag.val();
            }
            ProtocolState::Delimiter => {
                // Count 0 waits for the first recessive bit after the flag.
                self.segment.next = self.seg_error_delimiter.val();
                if self.count.val() == 0 {
                    self.segment.next = self.seg_tolerate_dominant.val();
                }
            }
        }

        if self.error.val() {
            self.error_pulse.d.next = true;
            self.ecc_reg.d.next = bit_cast::<8, 5>(self.segment.val())
                .replace_bit(5, self.receiving.val())
                .replace_bit(6, self.error_type.val().get_bit(0))
                .replace_bit(7, self.error_type.val().get_bit(1));
        }
        if self.lost.val() {
            self.lost_pulse.d.next = true;
            self.alc_reg.d.next = self.count.val().get_bits::<5>(0);
        }
        if self.discard.val() {
            self.error_pulse.d.next = false;
            self.lost_pulse.d.next = false;
        }
        if self.reset.val() {
            self.error_pulse.d.next = false;
            self.lost_pulse.d.next = false;
            self.ecc_reg.d.next = 0.into();
            self.alc_reg.d.next = 0.into();
        }
    }
}
