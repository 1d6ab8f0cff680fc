//! Worst-case response-time analysis of CAN message sets (`cansim rta`), checked against the
//! cycle-accurate bus.
//!
//! * [`message_set`]: the TOML message-set format, validation, priority order.
//! * [`analysis`]: the classic recurrence and the corrected analysis of Davis, Burns, Bril and
//!   Lukkien (2007), side by side.
//! * [`simulate`]: each message's critical instant recreated on the cycle-accurate bus, one RTL
//!   CAN core per message; the observed worst-case responses beside both bounds.
//! * [`report`]: the text table and the CSV.
//!
//! See `docs/RTA.md` for the conventions (blocking, τbit, what C and a response time include).

pub mod analysis;
pub mod message_set;
pub mod report;
pub mod simulate;

use golden::frame::INTERMISSION_BITS;
use golden::worst_case::length_bound;

/// A time in the message set's ticks: nanoseconds for a set with a bit rate, abstract units
/// (one tick per bit time) otherwise.
pub type Ticks = u64;

/// Worst-case bus time of a data frame in bits: the stuffing bound `44 + 8n + ⌊(34+8n)/4⌋`
/// (standard) or `64 + 8n + ⌊(54+8n)/4⌋` (extended) plus the 3-bit intermission.
pub fn frame_bits(extended: bool, dlc: u8) -> u64 {
    length_bound(extended, usize::from(dlc)) as u64 + u64::from(INTERMISSION_BITS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_bits_are_the_stuffing_bound_plus_intermission() {
        assert_eq!(frame_bits(false, 0), 55);
        assert_eq!(frame_bits(false, 7), 125);
        assert_eq!(frame_bits(false, 8), 135);
        assert_eq!(frame_bits(true, 0), 80);
        assert_eq!(frame_bits(true, 8), 160);
    }
}
