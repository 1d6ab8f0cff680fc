//! The golden model of classic CAN (Bosch CAN 2.0A/2.0B, ISO 11898-1), written from the
//! standards and independent of the RTL (this crate does not depend on `rtl`): the judge of the
//! testbenches, the fault campaign and the bus decoder.
//!
//! * [`frame`]: frames and their exact wire bits (stuffing, CRC, field tags), encode and decode;
//! * [`crc15`]: the CRC-15/CAN sequence;
//! * [`mod@reference`]: the bit-level protocol model of several nodes on one bus, with faults;
//! * [`worst_case`]: the longest stuffed frames (bounds and exact search);
//! * [`btr`]: the SJA1000 bit-timing registers and the bit-timing calculator.
#![warn(missing_docs)]

pub mod btr;
pub mod crc15;
pub mod frame;
pub mod reference;
pub mod worst_case;
