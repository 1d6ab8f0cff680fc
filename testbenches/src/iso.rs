//! Shared pieces of the ISO 16845-1 clause tests (`tests/iso_*.rs`): the field lengths of ISO
//! 11898-1, where a frame has its bits, and the lower tester's usual moves in script bits (the LT's
//! frame at a given bit, the IUT's frame acknowledged, a transmitted bit corrupted).

use sim::bus::Drive;
use sim::frame::{encode, Field, Frame, DOMINANT};

use crate::protocol_bench::{Iut, ProtocolBench};

/// Bits of an error or overload flag (ISO 11898-1).
pub const FLAG: usize = 6;
/// Bits of an error or overload delimiter.
pub const DELIMITER: usize = 8;
/// Bits of the intermission.
pub const INTERMISSION: usize = 3;
/// Bits of an error-passive transmitter's suspend transmission.
pub const SUSPEND: usize = 8;
/// Bits of the end of frame.
pub const EOF: usize = 7;
/// Counter change of fault-confinement rules 2 to 6.
pub const PENALTY: u8 = 8;
/// The counter value from which a node is error passive.
pub const PASSIVE_LIMIT: u8 = 128;

/// Offset of the ACK slot in `frame`'s bits (SOF = 0).
pub fn ack_offset(frame: &Frame) -> usize {
    encode(frame).position(Field::AckSlot, 0).expect("ACK slot")
}

/// Offset of the first bit (not a stuff bit) of `field` in `frame` at `level`.
pub fn first_bit_at(frame: &Frame, field: Field, level: bool) -> usize {
    let encoded = encode(frame);
    (0..128)
        .map_while(|i| encoded.position(field, i))
        .find(|&p| encoded.bits[p] == level)
        .unwrap_or_else(|| panic!("{frame}: no {field:?} bit at level {level}"))
}

/// Offset of the first dominant data bit of `frame` (the bit a clause's LT corrupts "in the data
/// field").
pub fn dominant_data_bit(frame: &Frame) -> usize {
    first_bit_at(frame, Field::Data, DOMINANT)
}

/// The script bits where `frame` starting at `sof` is dominant, SOF to CRC delimiter (what its
/// transmitter drives before the ACK slot).
pub fn dominant_bits_of(frame: &Frame, sof: usize) -> Vec<usize> {
    let encoded = encode(frame);
    (0..ack_offset(frame))
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .map(|i| sof + i)
        .collect()
}

/// `count` consecutive script bits from `from`.
pub fn bits_from(from: usize, count: usize) -> Vec<usize> {
    (from..from + count).collect()
}

/// The LT releases the bus up to `sof`, then sends `frame` with its ACK slot left to the IUT;
/// returns the script bit of that ACK slot.
pub fn lt_sends_at(bench: &mut ProtocolBench, sof: usize, frame: &Frame) -> usize {
    let played = bench.lt_ref().script_len();
    assert!(
        sof >= played,
        "the LT's frame at {sof} starts before {played}"
    );
    bench
        .lt()
        .release(sof - played)
        .send_bits(encode(frame).bits.iter().by_vals());
    sof + ack_offset(frame)
}

/// The LT releases the bus for the IUT's `frame` starting at `sof` and acknowledges it; its script
/// then ends `tail` bits after the frame's last EOF bit.
pub fn lt_acknowledges_at(bench: &mut ProtocolBench, sof: usize, frame: &Frame, tail: usize) {
    let played = bench.lt_ref().script_len();
    let end = sof + encode(frame).len() + tail;
    assert!(end >= played, "the script is already past {end}");
    bench
        .lt()
        .release(end - played)
        .set_bit(sof + ack_offset(frame), Drive::Dominant);
}

/// The IUT, with TEC `tec`, transmits `frame`; the LT releases the bus up to bit `bit` of it and
/// forces that bit recessive (a corrupted dominant bit: a bit error). Returns the bench.
pub fn transmitter_bit_corrupted(iut: Iut, frame: &Frame, tec: u8, bit: usize) -> ProtocolBench {
    let mut bench = ProtocolBench::iut_transmits_with(iut, frame, tec, false);
    bench
        .lt()
        .release(bit + 1)
        .set_bit(bit, Drive::ForceRecessive);
    bench
}

/// Where an error-active transmitter starts its frame again after an error detected at `error`: its
/// flag, the error delimiter and the intermission (ISO 11898-1).
pub fn active_retransmission(error: usize) -> usize {
    error + 1 + FLAG + DELIMITER + INTERMISSION
}

/// The SJA1000 ALC value of a transmitter of `mine` losing to `theirs`: the arbitration position of
/// the first bit where they differ (identifier bits from 0, SRR/RTR 11, IDE 12, extended bits 13..,
/// extended RTR 31), which is the bit's index among the frame's bits without stuff bits, less the SOF.
pub fn arbitration_position(mine: &Frame, theirs: &Frame) -> u8 {
    let (a, b) = (encode(mine), encode(theirs));
    let differ = (0..a.len().min(b.len()))
        .find(|&i| a.bits[i] != b.bits[i])
        .expect("the frames differ");
    let field_bits = (0..differ).filter(|&i| !a.tags[i].stuff).count();
    (field_bits - 1) as u8
}

/// The script bit where `mine`, sent from SOF 0 against `theirs`, loses arbitration.
pub fn arbitration_loss_bit(mine: &Frame, theirs: &Frame) -> usize {
    let (a, b) = (encode(mine), encode(theirs));
    (0..a.len().min(b.len()))
        .find(|&i| a.bits[i] != b.bits[i])
        .expect("the frames differ")
}
