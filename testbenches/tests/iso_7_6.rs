//! ISO 16845-1:2016 clause 7.6: the IUT as receiver, its receive error counter. Each test is named
//! after its clause and runs every elementary test case of it on both IUTs. Where a clause's set-up
//! raises REC "by an error scenario" (to 9: a stuff error and a bit error in the flag), the bench
//! writes RXERR in reset mode instead. Bit numbers are lower-tester script bits.

use golden::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::iso::{
    encode_with_reserved_bits, flippable_bit, lt_acknowledges_at, lt_sends_to_iut,
    receiver_stuff_error_in_data, DELIMITER, FLAG, INTERMISSION, PASSIVE_LIMIT, PENALTY, RX_SOF,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// REC after the clauses' set-up error scenario: a stuff error (+1) and a bit error in the flag (+8).
const RAISED_REC: u8 = 9;

/// The LT's frame (recessive before its data field, for the stuff error in the data field).
fn frame() -> Frame {
    Frame::data(Id::standard(0x2A5).unwrap(), &[0x96]).unwrap()
}

fn frame_bits() -> Vec<bool> {
    encode(&frame()).bits.iter().by_vals().collect()
}

/// REC read at the start of script bit `bit`.
fn rec_before(bench: &mut ProtocolBench, bit: usize) -> u8 {
    bench.run_to_bit(bit);
    bench.rec()
}

/// A receiving IUT with REC `rec` gets [`frame`]; the LT idles 40 bits after it. Returns the bench
/// (not run) and the script bit of the frame's last EOF bit.
fn frame_with_rec(iut: Iut, rec: u8) -> (ProtocolBench, usize) {
    let bits = frame_bits();
    let mut bench = lt_sends_to_iut(iut, &bits, 40);
    bench.load_counter(false, rec);
    (bench, RX_SOF + bits.len() - 1)
}

/// As [`frame_with_rec`] with REC 0, and the first intermission bit dominant. Returns the first bit
/// of the IUT's overload flag.
fn overload_after_frame(iut: Iut) -> (ProtocolBench, usize) {
    let (mut bench, last_eof) = frame_with_rec(iut, 0);
    bench.lt().set_bit(last_eof + 1, Drive::Dominant);
    (bench, last_eof + 2)
}

/// A script bit of [`frame`].
fn at(field: Field, index: u16) -> usize {
    RX_SOF + encode(&frame()).position(field, index).unwrap()
}

/// 7.6.1: a bit error in the receiver's active error flag: REC +8.
///
/// ISO 16845-1 7.6.1: after a stuff error (REC 1) the LT forces flag bit 1 (#1), 3 (#2) or 6 (#3)
/// recessive: REC +8 at that bit (ISO 11898-1 rule 5).
fn iso_7_6_1_bit_error_in_the_active_flag_is_plus_8(iut: Iut) {
    for (case, flag_bit) in [(1, 0usize), (2, 2), (3, 5)] {
        let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
        let corrupted = error + 1 + flag_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::ForceRecessive);
        assert_eq!(rec_before(&mut bench, corrupted), 1, "#{case}");
        assert_eq!(
            rec_before(&mut bench, corrupted + 1),
            1 + PENALTY,
            "#{case}"
        );
    }
}

/// 7.6.2: a bit error in the receiver's overload flag: REC +8.
///
/// ISO 16845-1 7.6.2: the LT forces overload flag bit 1 (#1), 3 (#2) or 6 (#3) recessive: REC +8
/// (ISO 11898-1 rule 5).
fn iso_7_6_2_bit_error_in_the_overload_flag_is_plus_8(iut: Iut) {
    for (case, flag_bit) in [(1, 0usize), (2, 2), (3, 5)] {
        let (mut bench, overload) = overload_after_frame(iut);
        let corrupted = overload + flag_bit;
        bench.lt().set_bit(corrupted, Drive::ForceRecessive);
        assert_eq!(rec_before(&mut bench, corrupted), 0, "#{case}");
        assert_eq!(rec_before(&mut bench, corrupted + 1), PENALTY, "#{case}");
    }
}

/// 7.6.3: 8 dominant bits after the receiver's active flag, and each further 8: REC +8.
///
/// ISO 16845-1 7.6.3: after the active flag (stuff error, REC 1) the LT sends 16 dominant bits: +8
/// for the first (rule 2), +8 on the 8th and the 16th (rule 6): 9, 17, 25.
fn iso_7_6_3_dominant_bits_after_the_active_flag_count_8_each(iut: Iut) {
    let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
    let after_flag = error + 1 + FLAG;
    bench
        .lt()
        .release(FLAG)
        .send_bits([DOMINANT; 16])
        .release(20);
    assert_eq!(
        rec_before(&mut bench, after_flag + 1),
        1 + PENALTY,
        "rule 2"
    );
    assert_eq!(rec_before(&mut bench, after_flag + 7), 1 + PENALTY);
    assert_eq!(
        rec_before(&mut bench, after_flag + 8),
        1 + 2 * PENALTY,
        "the 8th"
    );
    assert_eq!(
        rec_before(&mut bench, after_flag + 16),
        1 + 3 * PENALTY,
        "the 16th"
    );
}

/// 7.6.4: 8 dominant bits after the receiver's overload flag, and each further 8: REC +8.
///
/// ISO 16845-1 7.6.4: after the overload flag the LT sends 16 dominant bits: +8 on the 8th and the
/// 16th (rule 6; rule 2 is for error flags).
fn iso_7_6_4_dominant_bits_after_the_overload_flag_count_8_each(iut: Iut) {
    let (mut bench, overload) = overload_after_frame(iut);
    let after_flag = overload + FLAG;
    for bit in after_flag..after_flag + 16 {
        bench.lt().set_bit(bit, Drive::Dominant);
    }
    assert_eq!(rec_before(&mut bench, after_flag + 7), 0);
    assert_eq!(rec_before(&mut bench, after_flag + 8), PENALTY, "the 8th");
    assert_eq!(
        rec_before(&mut bench, after_flag + 16),
        2 * PENALTY,
        "the 16th"
    );
}

/// 7.6.5: the receiver's ACK read recessive: REC +1.
///
/// ISO 16845-1 7.6.5: a bit error (ISO 11898-1 rule 1).
fn iso_7_6_5_ack_read_recessive_is_plus_1(iut: Iut) {
    let (mut bench, _) = frame_with_rec(iut, 0);
    let ack = at(Field::AckSlot, 0);
    bench.lt().set_bit(ack, Drive::ForceRecessive);
    assert_eq!(rec_before(&mut bench, ack + 1), 1);
}

/// 7.6.6: a dominant CRC delimiter: REC +1.
///
/// ISO 16845-1 7.6.6: a form error (rule 1), counted at the delimiter.
fn iso_7_6_6_dominant_crc_delimiter_is_plus_1(iut: Iut) {
    let (mut bench, _) = frame_with_rec(iut, 0);
    let delimiter = at(Field::CrcDelim, 0);
    bench.lt().set_bit(delimiter, Drive::Dominant);
    assert_eq!(rec_before(&mut bench, delimiter), 0);
    assert_eq!(rec_before(&mut bench, delimiter + 1), 1);
}

/// 7.6.7: a dominant ACK delimiter: −1 for the frame free of errors up to the ACK, +1 for the form
/// error.
///
/// ISO 16845-1 7.6.7: from REC 9 the IUT acknowledges (−1: this project decrements REC when its
/// ACK went out), then the dominant ACK delimiter (+1): REC 9 again.
fn iso_7_6_7_dominant_ack_delimiter_leaves_rec_unchanged(iut: Iut) {
    let (mut bench, _) = frame_with_rec(iut, RAISED_REC);
    let delimiter = at(Field::AckDelim, 0);
    bench.lt().set_bit(delimiter, Drive::Dominant);
    bench.run(1);
    assert_eq!(bench.rec(), RAISED_REC);
    assert_eq!(bench.bus_errors().len(), 1, "the form error");
}

/// 7.6.8: a dominant EOF bit: −1 for the frame up to the ACK, +1 for the form error.
///
/// ISO 16845-1 7.6.8: from REC 9, EOF bit 2 (#1), 3 (#2) or 5 (#3) dominant: REC 9 again.
fn iso_7_6_8_dominant_eof_bit_leaves_rec_unchanged(iut: Iut) {
    for (case, eof_bit) in [(1, 1u16), (2, 2), (3, 4)] {
        let (mut bench, _) = frame_with_rec(iut, RAISED_REC);
        bench.lt().set_bit(at(Field::Eof, eof_bit), Drive::Dominant);
        bench.run(1);
        assert_eq!(bench.rec(), RAISED_REC, "#{case}");
        assert_eq!(bench.bus_errors().len(), 1, "#{case}: the form error");
    }
}

/// Frames with stuff bits in every field and of both levels: those of 7.1.10 and 7.1.11.
fn stuffing_candidates() -> Vec<(Frame, Vec<bool>, Vec<usize>)> {
    let mut first = vec![0xE1; 8];
    first[0] = 0x01;
    let base = |id, data: &[u8]| Frame::data(Id::standard(id).unwrap(), data).unwrap();
    let ext = |id, data: &[u8]| Frame::data(Id::extended(id).unwrap(), data).unwrap();
    [
        (base(0x78, &first), false),
        (base(0x41F, &[0x00]), false),
        (base(0x47F, &[0x1F]), false),
        (base(0x758, &[]), false),
        (base(0x777, &[0x1F]), false),
        (ext(0x07C3_0F0F, &[0x3C; 8]), false),
        (ext(0x07C0_F0F0, &[0x00]), false),
        (ext(0x1FB8_0000, &[0xA0]), false),
        (base(0x7F0, &[0x0F, 0x83, 0xE0]), false),
        (base(0x00F, &[0xF8]), false),
        // 7.1.10 #3: r0 recessive and DLC 15, five recessive control bits.
        (
            Frame::data_with_dlc(Id::standard(0x707).unwrap(), 15, &[0x0F; 8]).unwrap(),
            true,
        ),
    ]
    .into_iter()
    .map(|(f, r0)| {
        let (bits, stuff) = encode_with_reserved_bits(&f, true, false, r0);
        (f, bits, stuff)
    })
    .collect()
}

/// The field class of the bit at index `field_bit` of `frame` without its stuff bits (ISO 11898-1
/// layout: SOF, identifier, RTR (SRR, IDE, identifier extension, RTR) in the arbitration field; IDE
/// or r1, r0 and the DLC in the control field; then data and CRC).
fn field_class(frame: &Frame, field_bit: usize) -> &'static str {
    let control = if frame.id().is_extended() { 33 } else { 13 };
    let data = control + 6;
    let data_bits = 8 * frame.data_bytes().len();
    match field_bit {
        b if b < control => "arbitration",
        b if b < data => "control",
        b if b < data + data_bits => "data",
        _ => "CRC",
    }
}

/// 7.6.9: a stuff error: REC +1.
///
/// ISO 16845-1 7.6.9: the LT sends 6 equal bits (a stuff bit inverted) in the arbitration, control,
/// data and CRC fields, after recessive (#1..#4) and dominant (#5..#8) runs: REC +1 on the sixth
/// bit (rule 1).
fn iso_7_6_9_stuff_error_is_plus_1(iut: Iut) {
    let candidates = stuffing_candidates();
    let mut case = 0;
    for level in [RECESSIVE, DOMINANT] {
        for class in ["arbitration", "control", "data", "CRC"] {
            case += 1;
            let (frame, bits, bit) = candidates
                .iter()
                .find_map(|(f, bits, stuff)| {
                    stuff
                        .iter()
                        .enumerate()
                        .find(|&(k, &s)| bits[s] == level && field_class(f, s - k - 1) == class)
                        .map(|(_, &s)| (f, bits, s))
                })
                .unwrap_or_else(|| panic!("#{case}: a stuff bit at {level} after the {class}"));
            let mut sent = bits[..=bit].to_vec();
            sent[bit] = !sent[bit];
            let mut bench = lt_sends_to_iut(iut, &sent, 30);
            assert_eq!(rec_before(&mut bench, RX_SOF + bit), 0, "#{case} {frame}");
            assert_eq!(
                rec_before(&mut bench, RX_SOF + bit + 1),
                1,
                "#{case} {frame}: {class}"
            );
        }
    }
}

/// 7.6.10: a CRC error: REC +1 when the error flag starts after the ACK delimiter.
///
/// ISO 16845-1 7.6.10: the IUT sends no ACK, an active error flag from the bit after the ACK
/// delimiter, and REC +1 (rule 1).
fn iso_7_6_10_crc_error_is_plus_1(iut: Iut) {
    let mut bits = frame_bits();
    let encoded = encode(&frame());
    let crc =
        encoded.position(Field::Crc, 0).unwrap()..encoded.position(Field::CrcDelim, 0).unwrap();
    let flipped = flippable_bit(&bits, crc, DOMINANT);
    bits[flipped] = !bits[flipped];
    let mut bench = lt_sends_to_iut(iut, &bits, 30);
    let delimiter = at(Field::AckDelim, 0);
    assert_eq!(rec_before(&mut bench, delimiter + 1), 1);
    bench.run(1);
    assert_eq!(
        bench.iut_dominant_bits(RX_SOF, delimiter + 1 + 2 * FLAG),
        (delimiter + 1..=delimiter + FLAG).collect::<Vec<_>>(),
        "no ACK, a flag after the ACK delimiter"
    );
}

/// 7.6.11: a dominant first bit after the receiver's active error flag: REC +8.
///
/// ISO 16845-1 7.6.11: rule 2: from 1 (stuff error) to 9.
fn iso_7_6_11_dominant_bit_after_the_flag_is_plus_8(iut: Iut) {
    let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
    bench.lt().release(FLAG).send_bits([DOMINANT]).release(20);
    bench.run(1);
    assert_eq!(bench.rec(), 1 + PENALTY);
    assert_eq!(bench.bus_errors().len(), 1);
    assert!(bench
        .iut_dominant_bits(error + 1 + FLAG, error + 30)
        .is_empty());
}

/// 7.6.12: a form error in the receiver's error delimiter: REC +1.
///
/// ISO 16845-1 7.6.12: delimiter bit 2 (#1) or 7 (#2) dominant: REC from 1 to 2 (rule 1).
fn iso_7_6_12_form_error_in_the_error_delimiter_is_plus_1(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 7)] {
        let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
        let corrupted = error + FLAG + delimiter_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::Dominant);
        assert_eq!(rec_before(&mut bench, corrupted + 1), 2, "#{case}");
    }
}

/// 7.6.13: a form error in the receiver's overload delimiter: REC +1.
///
/// ISO 16845-1 7.6.13: delimiter bit 2 (#1) or 7 (#2) dominant: REC 1 (rule 1).
fn iso_7_6_13_form_error_in_the_overload_delimiter_is_plus_1(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 7)] {
        let (mut bench, overload) = overload_after_frame(iut);
        let corrupted = overload + FLAG + delimiter_bit - 1;
        bench.lt().set_bit(corrupted, Drive::Dominant);
        assert_eq!(rec_before(&mut bench, corrupted + 1), 1, "#{case}");
    }
}

/// 7.6.14: a valid frame: REC −1.
///
/// ISO 16845-1 7.6.14: from 9, −1 after the ACK slot (rule 8).
fn iso_7_6_14_valid_frame_is_minus_1(iut: Iut) {
    let (mut bench, _) = frame_with_rec(iut, RAISED_REC);
    let ack = at(Field::AckSlot, 0);
    assert_eq!(rec_before(&mut bench, ack), RAISED_REC);
    assert_eq!(rec_before(&mut bench, ack + 1), RAISED_REC - 1);
    bench.run(1);
    assert_eq!(bench.iut_events(), [NodeEvent::Received(frame())]);
}

/// 7.6.15: a valid frame while error passive: REC to a value from 119 to 127.
///
/// ISO 16845-1 7.6.15: ISO 11898-1 rule 8: an error-passive receiver's REC is set between 119 and
/// 127 (the SJA1000 and this controller: 127).
fn iso_7_6_15_valid_frame_when_passive_sets_rec_below_128(iut: Iut) {
    let (mut bench, _) = frame_with_rec(iut, PASSIVE_LIMIT + 7);
    bench.run(1);
    let rec = bench.rec();
    assert!((119..=127).contains(&rec), "REC {rec}");
    assert!(!bench.error_passive());
}

/// 7.6.16: a dominant last EOF bit leaves REC as the frame left it.
///
/// ISO 16845-1 7.6.16: from 9, the valid frame (−1) and an overload condition (no change): 8.
fn iso_7_6_16_dominant_last_eof_bit_changes_nothing(iut: Iut) {
    let (mut bench, last_eof) = frame_with_rec(iut, RAISED_REC);
    bench.lt().set_bit(last_eof, Drive::Dominant);
    bench.run(1);
    assert_eq!(bench.rec(), RAISED_REC - 1);
}

/// 7.6.17: a 13-bit overload flag leaves REC unchanged.
///
/// ISO 16845-1 7.6.17: from 9, the valid frame (8), an overload frame, and 7 dominant bits after its
/// flag (fewer than 8: rule 6 does not apply): 8.
fn iso_7_6_17_a_13_bit_overload_flag_changes_nothing(iut: Iut) {
    let (mut bench, last_eof) = frame_with_rec(iut, RAISED_REC);
    for bit in last_eof + 1..=last_eof + 1 + FLAG + 7 {
        bench.lt().set_bit(bit, Drive::Dominant);
    }
    bench.run(1);
    assert_eq!(bench.rec(), RAISED_REC - 1);
}

/// 7.6.18: after the first dominant bit following its flag, 6 more do not raise REC.
///
/// ISO 16845-1 7.6.18: after the active flag (stuff error, 1) the LT sends 7 dominant bits: +8 for
/// the first (rule 2), nothing more (fewer than 8 for rule 6): 9.
fn iso_7_6_18_seven_dominant_bits_after_the_flag_count_once(iut: Iut) {
    let (mut bench, _) = receiver_stuff_error_in_data(iut, &frame());
    bench
        .lt()
        .release(FLAG)
        .send_bits([DOMINANT; 7])
        .release(20);
    bench.run(1);
    assert_eq!(bench.rec(), 1 + PENALTY);
}

/// 7.6.19: a dominant last error delimiter bit leaves REC unchanged.
///
/// ISO 16845-1 7.6.19: an overload condition, not an error: REC stays 1.
fn iso_7_6_19_dominant_last_error_delimiter_bit_changes_nothing(iut: Iut) {
    let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
    bench.lt().release(30);
    bench
        .lt()
        .set_bit(error + FLAG + DELIMITER, Drive::Dominant);
    bench.run(1);
    assert_eq!(bench.rec(), 1);
}

/// 7.6.20: a dominant last overload delimiter bit leaves REC unchanged.
///
/// ISO 16845-1 7.6.20: an overload condition, not an error: REC stays 0.
fn iso_7_6_20_dominant_last_overload_delimiter_bit_changes_nothing(iut: Iut) {
    let (mut bench, overload) = overload_after_frame(iut);
    bench
        .lt()
        .set_bit(overload + FLAG + DELIMITER - 1, Drive::Dominant);
    bench.run(1);
    assert_eq!(bench.rec(), 0);
}

/// 7.6.21: a successful transmission does not decrement REC.
///
/// ISO 16845-1 7.6.21: the IUT loses arbitration to the LT's frame, which carries a stuff error
/// after the arbitration field (the IUT is its receiver: REC +1); then the IUT's frame gets through:
/// REC stays 1 (rule 8 is for receptions).
fn iso_7_6_21_a_successful_transmission_leaves_rec_unchanged(iut: Iut) {
    let mine = Frame::data(Id::standard(0x2A6).unwrap(), &[0x96]).unwrap();
    let encoded = encode(&frame());
    let data = encoded.position(Field::Data, 0).unwrap();
    let mut bench = ProtocolBench::iut_transmits(iut, &mine);
    bench
        .lt()
        .send_bits(encoded.bits.iter().by_vals().take(data))
        .send_bits([DOMINANT; FLAG]);
    let error = data + FLAG - 1;
    let again = error + 1 + FLAG + DELIMITER + INTERMISSION;
    lt_acknowledges_at(&mut bench, again, &mine, 4);
    assert_eq!(
        rec_before(&mut bench, error + 1),
        1,
        "the stuff error, as receiver"
    );
    bench.run(0);
    assert_eq!(
        bench.iut_events().last(),
        Some(&NodeEvent::TransmitDone(true))
    );
    assert_eq!(bench.rec(), 1, "not decremented by the transmission");
}

testbenches::on_both_iuts! {
    iso_7_6_1_bit_error_in_the_active_flag_is_plus_8,
    iso_7_6_2_bit_error_in_the_overload_flag_is_plus_8,
    iso_7_6_3_dominant_bits_after_the_active_flag_count_8_each,
    iso_7_6_4_dominant_bits_after_the_overload_flag_count_8_each,
    iso_7_6_5_ack_read_recessive_is_plus_1,
    iso_7_6_6_dominant_crc_delimiter_is_plus_1,
    iso_7_6_7_dominant_ack_delimiter_leaves_rec_unchanged,
    iso_7_6_8_dominant_eof_bit_leaves_rec_unchanged,
    iso_7_6_9_stuff_error_is_plus_1,
    iso_7_6_10_crc_error_is_plus_1,
    iso_7_6_11_dominant_bit_after_the_flag_is_plus_8,
    iso_7_6_12_form_error_in_the_error_delimiter_is_plus_1,
    iso_7_6_13_form_error_in_the_overload_delimiter_is_plus_1,
    iso_7_6_14_valid_frame_is_minus_1,
    iso_7_6_15_valid_frame_when_passive_sets_rec_below_128,
    iso_7_6_16_dominant_last_eof_bit_changes_nothing,
    iso_7_6_17_a_13_bit_overload_flag_changes_nothing,
    iso_7_6_18_seven_dominant_bits_after_the_flag_count_once,
    iso_7_6_19_dominant_last_error_delimiter_bit_changes_nothing,
    iso_7_6_20_dominant_last_overload_delimiter_bit_changes_nothing,
    iso_7_6_21_a_successful_transmission_leaves_rec_unchanged,
}
