//! SJA1000 error code capture (ECC) values for test expectations, built from the one definition of
//! the codes in `rtl::bsp` (`ecc_type`, `ecc_segment`).

use rtl::bsp::{ecc_segment as seg, ecc_type};

/// Error type: bit error.
pub const BIT: u8 = ecc_type::BIT as u8;
/// Error type: form error.
pub const FORM: u8 = ecc_type::FORM as u8;
/// Error type: stuff error.
pub const STUFF: u8 = ecc_type::STUFF as u8;
/// Error type: other (ACK or CRC) error.
pub const OTHER: u8 = ecc_type::OTHER as u8;

/// Segment: start of frame.
pub const SEG_SOF: u8 = seg::SOF as u8;
/// Segment: ID.28 to ID.21.
pub const SEG_ID_28_21: u8 = seg::ID_28_21 as u8;
/// Segment: ID.20 to ID.18.
pub const SEG_ID_20_18: u8 = seg::ID_20_18 as u8;
/// Segment: SRR (extended) or RTR (standard).
pub const SEG_SRTR: u8 = seg::SRTR as u8;
/// Segment: IDE.
pub const SEG_IDE: u8 = seg::IDE as u8;
/// Segment: ID.17 to ID.13.
pub const SEG_ID_17_13: u8 = seg::ID_17_13 as u8;
/// Segment: ID.12 to ID.5.
pub const SEG_ID_12_5: u8 = seg::ID_12_5 as u8;
/// Segment: ID.4 to ID.0.
pub const SEG_ID_4_0: u8 = seg::ID_4_0 as u8;
/// Segment: RTR of an extended frame.
pub const SEG_RTR: u8 = seg::RTR as u8;
/// Segment: reserved bit 1.
pub const SEG_R1: u8 = seg::R1 as u8;
/// Segment: reserved bit 0.
pub const SEG_R0: u8 = seg::R0 as u8;
/// Segment: data length code.
pub const SEG_DLC: u8 = seg::DLC as u8;
/// Segment: data field.
pub const SEG_DATA: u8 = seg::DATA as u8;
/// Segment: CRC sequence.
pub const SEG_CRC: u8 = seg::CRC as u8;
/// Segment: CRC delimiter.
pub const SEG_CRC_DELIM: u8 = seg::CRC_DELIMITER as u8;
/// Segment: ACK slot.
pub const SEG_ACK_SLOT: u8 = seg::ACK_SLOT as u8;
/// Segment: ACK delimiter.
pub const SEG_ACK_DELIM: u8 = seg::ACK_DELIMITER as u8;
/// Segment: end of frame.
pub const SEG_EOF: u8 = seg::EOF as u8;
/// Segment: error (or overload) delimiter.
pub const SEG_ERROR_DELIM: u8 = seg::ERROR_DELIMITER as u8;
/// Segment: overload flag.
pub const SEG_OVERLOAD_FLAG: u8 = seg::OVERLOAD_FLAG as u8;

/// The ECC value: type (bits 7..6), direction (bit 5, 1 = receiving), segment (bits 4..0).
pub fn ecc(kind: u8, receiving: bool, segment: u8) -> u8 {
    kind << 6 | (receiving as u8) << 5 | segment
}
