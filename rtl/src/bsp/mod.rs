//! The bit stream processor (BSP): the CAN 2.0A/2.0B protocol engine.
//!
//! `protocol.rs` holds the frame sequencer, the top block of the BSP (the field, its bit count and
//! the node's role); it contains the decisions of a bit (`frame_fields.rs` for the fields of a data
//! or remote frame, `interframe.rs` for the rest, the error and overload flags and the outcome), the
//! stuff-run tracker (`stuffing.rs`), the CRC register (`crc15.rs`), fault confinement
//! (`fault_confinement.rs`), the receive assembler (`rx_assembler.rs`, with its port group
//! `received_frame.rs`), the bit transmitter with the transmit stream (`bit_transmitter.rs`) and the
//! ECC/ALC capture (`error_capture.rs`).
//! Every block acts at the process point of the bit timing logic (the clock after the sample point);
//! the transmit point only loads the bit prepared there.

pub mod bit_transmitter;
pub mod core_ports;
pub mod crc15;
pub mod error_capture;
pub mod fault_confinement;
pub mod frame_fields;
pub mod interframe;
pub mod protocol;
pub mod received_frame;
pub mod rx_assembler;
pub mod stuffing;

// The constants below are the one definition of the field lengths and SJA1000 codes. They are plain
// Rust constants, so kernels read them through `Constant` fields (`#[constant(...)]`), never
// directly (a Rust constant inside a kernel becomes an undeclared Verilog identifier).

/// Bits of the base identifier.
pub const BASE_ID_BITS: u64 = 11;
/// Arbitration bit position of SRR (extended) / RTR (standard).
pub const SRR_RTR_POSITION: u64 = 11;
/// Arbitration bit position of IDE.
pub const IDE_POSITION: u64 = 12;
/// Arbitration bit position of the RTR bit of an extended frame.
pub const EXT_RTR_POSITION: u64 = 31;
/// Bits of the DLC.
pub const DLC_BITS: u64 = 4;
/// The CRC-15/CAN generator polynomial x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1, without its
/// x^15 term.
pub const CRC15_POLYNOMIAL: u64 = 0x4599;
/// Bits of the CRC sequence.
pub const CRC_BITS: u64 = 15;
/// Bits of the end of frame.
pub const EOF_BITS: u64 = 7;
/// Bits of the intermission.
pub const INTERMISSION_BITS: u64 = 3;
/// Bits of suspend transmission.
pub const SUSPEND_BITS: u64 = 8;
/// Bits of an error or overload flag.
pub const FLAG_BITS: u64 = 6;
/// Bits of an error or overload delimiter.
pub const DELIMITER_BITS: u64 = 8;
/// Recessive bits of bus integration and of each bus-off recovery step.
pub const IDLE_RUN_BITS: u64 = 11;
/// Consecutive dominant bits after an error or overload flag that cost a node 8 again (fault
/// confinement rule 6).
pub const PENALTY_DOMINANT_BITS: u64 = 8;

/// SJA1000 ECC error types (bits 7..6).
pub mod ecc_type {
    /// Bit error.
    pub const BIT: u64 = 0;
    /// Form error.
    pub const FORM: u64 = 1;
    /// Stuff error.
    pub const STUFF: u64 = 2;
    /// Other: ACK or CRC error.
    pub const OTHER: u64 = 3;
}

/// SJA1000 ECC segment codes (bits 4..0).
pub mod ecc_segment {
    /// Start of frame.
    pub const SOF: u64 = 0x03;
    /// ID.28 to ID.21.
    pub const ID_28_21: u64 = 0x02;
    /// ID.20 to ID.18.
    pub const ID_20_18: u64 = 0x06;
    /// SRR (extended) or RTR (standard).
    pub const SRTR: u64 = 0x04;
    /// IDE.
    pub const IDE: u64 = 0x05;
    /// ID.17 to ID.13.
    pub const ID_17_13: u64 = 0x07;
    /// ID.12 to ID.5.
    pub const ID_12_5: u64 = 0x0F;
    /// ID.4 to ID.0.
    pub const ID_4_0: u64 = 0x0E;
    /// RTR of an extended frame.
    pub const RTR: u64 = 0x0C;
    /// Reserved bit 1.
    pub const R1: u64 = 0x0D;
    /// Reserved bit 0.
    pub const R0: u64 = 0x09;
    /// Data length code.
    pub const DLC: u64 = 0x0B;
    /// Data field.
    pub const DATA: u64 = 0x0A;
    /// CRC sequence.
    pub const CRC: u64 = 0x08;
    /// CRC delimiter.
    pub const CRC_DELIMITER: u64 = 0x18;
    /// ACK slot.
    pub const ACK_SLOT: u64 = 0x19;
    /// ACK delimiter.
    pub const ACK_DELIMITER: u64 = 0x1B;
    /// End of frame.
    pub const EOF: u64 = 0x1A;
    /// Intermission.
    pub const INTERMISSION: u64 = 0x12;
    /// Active error flag.
    pub const ACTIVE_ERROR_FLAG: u64 = 0x11;
    /// Passive error flag.
    pub const PASSIVE_ERROR_FLAG: u64 = 0x16;
    /// Tolerated dominant bits after a flag.
    pub const TOLERATE_DOMINANT: u64 = 0x13;
    /// Error (or overload) delimiter.
    pub const ERROR_DELIMITER: u64 = 0x17;
    /// Overload flag.
    pub const OVERLOAD_FLAG: u64 = 0x1C;
}
