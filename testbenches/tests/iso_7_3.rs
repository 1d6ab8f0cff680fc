//! ISO 16845-1:2016 clauses 7.3 and 7.4: the IUT as receiver, active error frame and overload
//! frame. Each test is named after its clause and runs every elementary test case of it on both
//! IUTs. Bit numbers are lower-tester script bits.

use golden::frame::{encode, Field, Frame, Id, DOMINANT};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::iso::{
    bits_from, lt_sends_to_iut, receiver_stuff_error_in_data, DELIMITER, FLAG, RX_SOF,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// The LT's frame (the bit before its data field is recessive, for the stuff error in the data
/// field that the clauses use to start an error frame).
fn frame() -> Frame {
    Frame::data(Id::standard(0x2A5).unwrap(), &[0x96]).unwrap()
}

/// A second frame of the LT.
fn other_frame() -> Frame {
    Frame::data(Id::standard(0x111).unwrap(), &[0x07]).unwrap()
}

/// A receiving IUT gets [`frame`], acknowledges it, and the LT makes the first intermission bit
/// dominant (an overload condition); the LT idles after. Returns the bench (not run) and the first
/// bit of the IUT's overload flag.
fn overload_after_frame(iut: Iut) -> (ProtocolBench, usize) {
    let bits: Vec<bool> = encode(&frame()).bits.iter().by_vals().collect();
    let mut bench = lt_sends_to_iut(iut, &bits, 40);
    let intermission = RX_SOF + bits.len();
    bench.lt().set_bit(intermission, Drive::Dominant);
    (bench, intermission + 1)
}

/// The script bit of the IUT's ACK of [`frame`].
fn ack() -> usize {
    RX_SOF + encode(&frame()).position(Field::AckSlot, 0).unwrap()
}

/// 7.3.1: a receiver tolerates up to 7 dominant bits after its active error flag.
///
/// ISO 16845-1 7.3.1: after the IUT's active flag (a stuff error in the data field) the LT
/// lengthens it by 1 (#1), 4 (#2) or 7 (#3) dominant bits: after its flag the IUT sends recessive
/// bits, and detects no new error (ISO 11898-1: the delimiter starts with the first recessive bit;
/// rule 2 costs +8 for a dominant first bit after the flag, no error flag).
fn iso_7_3_1_receiver_tolerates_7_dominant_bits_after_its_flag(iut: Iut) {
    for (case, extra) in [(1, 1usize), (2, 4), (3, 7)] {
        let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
        bench
            .lt()
            .release(FLAG)
            .send_bits(std::iter::repeat_n(DOMINANT, extra))
            .release(20);
        bench.run(1);
        assert_eq!(
            bench.iut_dominant_bits(error + 1, error + 40),
            bits_from(error + 1, FLAG),
            "#{case}: the flag, then recessive bits"
        );
        assert_eq!(bench.bus_errors().len(), 1, "#{case}: one error frame");
    }
}

/// 7.3.2: a receiver accepts a frame starting in the third intermission bit after its error frame.
///
/// ISO 16845-1 7.3.2: after the IUT's error frame (stuff error in the data field) the LT starts a
/// frame 2 bits after the end of the error delimiter: the IUT shall acknowledge and receive it.
fn iso_7_3_2_frame_in_intermission_bit_3_after_an_error_frame(iut: Iut) {
    let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
    let sof = error + 1 + FLAG + DELIMITER + 2;
    let played = bench.lt_ref().script_len();
    bench
        .lt()
        .release(sof - played)
        .send_bits(encode(&other_frame()).bits.iter().by_vals())
        .release(4);
    bench.run(1);
    let ack = sof + encode(&other_frame()).position(Field::AckSlot, 0).unwrap();
    let mut expected = bits_from(error + 1, FLAG);
    expected.push(ack);
    assert_eq!(bench.iut_dominant_bits(error + 1, ack + 10), expected);
    assert_eq!(
        bench.iut_events()[1..],
        [NodeEvent::Received(other_frame())],
        "the frame after the error"
    );
}

/// 7.3.3: a bit error in the receiver's active error flag restarts it.
///
/// ISO 16845-1 7.3.3: the LT forces bit 1 (#1), 3 (#2) or 6 (#3) of the IUT's active error flag
/// recessive: a new active error flag from the next bit.
fn iso_7_3_3_bit_error_in_the_active_flag_restarts_it(iut: Iut) {
    for (case, flag_bit) in [(1, 0usize), (2, 2), (3, 5)] {
        let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
        let corrupted = error + 1 + flag_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::ForceRecessive);
        bench.run(1);
        let mut expected = bits_from(error + 1, flag_bit + 1);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, corrupted + 20),
            expected,
            "#{case}"
        );
    }
}

/// 7.3.4: a dominant error delimiter bit is a form error.
///
/// ISO 16845-1 7.3.4: the LT makes bit 2 (#1), 4 (#2) or 7 (#3) of the IUT's error delimiter
/// dominant: a new active error flag from the next bit.
fn iso_7_3_4_form_error_in_the_error_delimiter(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 4), (3, 7)] {
        let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
        let corrupted = error + FLAG + delimiter_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::Dominant);
        bench.run(1);
        let mut expected = bits_from(error + 1, FLAG);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, corrupted + 20),
            expected,
            "#{case}"
        );
    }
}

/// 7.4.1: a dominant first or second intermission bit after a frame is an overload condition.
///
/// ISO 16845-1 7.4.1: intermission bit 1 (#1) or 2 (#2) dominant: an overload flag from the next
/// bit.
fn iso_7_4_1_dominant_intermission_bit_gives_an_overload_frame(iut: Iut) {
    let bits: Vec<bool> = encode(&frame()).bits.iter().by_vals().collect();
    for (case, offset) in [(1, 0usize), (2, 1)] {
        let mut bench = lt_sends_to_iut(iut, &bits, 30);
        let dominant = RX_SOF + bits.len() + offset;
        bench.lt().set_bit(dominant, Drive::Dominant);
        bench.run(1);
        let mut expected = vec![ack()];
        expected.extend(bits_from(dominant + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(0, dominant + 20),
            expected,
            "#{case}"
        );
        assert_eq!(
            bench.iut_events(),
            [NodeEvent::Received(frame())],
            "#{case}"
        );
    }
}

/// 7.4.2: a dominant last EOF bit is an overload condition for a receiver.
///
/// ISO 16845-1 7.4.2: an overload flag from the bit after the last EOF bit.
fn iso_7_4_2_dominant_last_eof_bit_gives_an_overload_frame(iut: Iut) {
    let bits: Vec<bool> = encode(&frame()).bits.iter().by_vals().collect();
    let mut bench = lt_sends_to_iut(iut, &bits, 30);
    let last = RX_SOF + bits.len() - 1;
    bench.lt().set_bit(last, Drive::Dominant);
    bench.run(1);
    let mut expected = vec![ack()];
    expected.extend(bits_from(last + 1, FLAG));
    assert_eq!(bench.iut_dominant_bits(0, last + 20), expected);
}

/// 7.4.3: a dominant eighth delimiter bit is an overload condition.
///
/// ISO 16845-1 7.4.3: the eighth bit of the IUT's error delimiter (after a stuff error in the data
/// field, #1) or of its overload delimiter (after a frame, #2) dominant: an overload flag from the
/// next bit.
fn iso_7_4_3_dominant_last_delimiter_bit_gives_an_overload_frame(iut: Iut) {
    let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
    let last = error + FLAG + DELIMITER;
    bench.lt().release(30);
    bench.lt().set_bit(last, Drive::Dominant);
    bench.run(1);
    let mut expected = bits_from(error + 1, FLAG);
    expected.extend(bits_from(last + 1, FLAG));
    assert_eq!(
        bench.iut_dominant_bits(error + 1, last + 20),
        expected,
        "#1"
    );
    let (mut bench, overload) = overload_after_frame(iut);
    let last = overload + FLAG + DELIMITER - 1;
    bench.lt().set_bit(last, Drive::Dominant);
    bench.run(1);
    let mut expected = bits_from(overload, FLAG);
    expected.extend(bits_from(last + 1, FLAG));
    assert_eq!(bench.iut_dominant_bits(overload, last + 20), expected, "#2");
}

/// 7.4.4: a bit error in the receiver's overload flag gives an error frame.
///
/// ISO 16845-1 7.4.4: the LT forces bit 1 (#1), 3 (#2) or 6 (#3) of the IUT's overload flag
/// recessive: an active error flag from the next bit.
fn iso_7_4_4_bit_error_in_the_overload_flag_gives_an_error_frame(iut: Iut) {
    for (case, flag_bit) in [(1, 0usize), (2, 2), (3, 5)] {
        let (mut bench, overload) = overload_after_frame(iut);
        let corrupted = overload + flag_bit;
        bench.lt().set_bit(corrupted, Drive::ForceRecessive);
        bench.run(1);
        let mut expected = bits_from(overload, flag_bit + 1);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(overload, corrupted + 20),
            expected,
            "#{case}"
        );
        assert_eq!(bench.bus_errors().len(), 1, "#{case}: a bit error");
    }
}

/// 7.4.5: a dominant overload delimiter bit is a form error.
///
/// ISO 16845-1 7.4.5: the LT makes bit 2 (#1), 4 (#2) or 7 (#3) of the IUT's overload delimiter
/// dominant: an active error flag from the next bit.
fn iso_7_4_5_form_error_in_the_overload_delimiter(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 4), (3, 7)] {
        let (mut bench, overload) = overload_after_frame(iut);
        let corrupted = overload + FLAG + delimiter_bit - 1;
        bench.lt().set_bit(corrupted, Drive::Dominant);
        bench.run(1);
        let mut expected = bits_from(overload, FLAG);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(overload, corrupted + 20),
            expected,
            "#{case}"
        );
        assert_eq!(bench.bus_errors().len(), 1, "#{case}: a form error");
    }
}

/// 7.4.6: a dominant first or second intermission bit after an error frame is an overload condition.
///
/// ISO 16845-1 7.4.6: after the IUT's error frame (stuff error in the data field), intermission
/// bit 1 (#1) or 2 (#2) dominant: an overload flag from the next bit.
fn iso_7_4_6_dominant_intermission_bit_after_an_error_frame(iut: Iut) {
    for (case, offset) in [(1, 0usize), (2, 1)] {
        let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
        let dominant = error + 1 + FLAG + DELIMITER + offset;
        bench.lt().release(40);
        bench.lt().set_bit(dominant, Drive::Dominant);
        bench.run(1);
        let mut expected = bits_from(error + 1, FLAG);
        expected.extend(bits_from(dominant + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, dominant + 20),
            expected,
            "#{case}"
        );
    }
}

/// 7.4.7: a dominant first or second intermission bit after an overload frame is an overload
/// condition.
///
/// ISO 16845-1 7.4.7: after the IUT's overload frame, intermission bit 1 (#1) or 2 (#2) dominant: a
/// new overload flag from the next bit.
fn iso_7_4_7_dominant_intermission_bit_after_an_overload_frame(iut: Iut) {
    for (case, offset) in [(1, 0usize), (2, 1)] {
        let (mut bench, overload) = overload_after_frame(iut);
        let dominant = overload + FLAG + DELIMITER + offset;
        bench.lt().set_bit(dominant, Drive::Dominant);
        bench.run(1);
        let mut expected = bits_from(overload, FLAG);
        expected.extend(bits_from(dominant + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(overload, dominant + 20),
            expected,
            "#{case}"
        );
    }
}

testbenches::on_both_iuts! {
    iso_7_3_1_receiver_tolerates_7_dominant_bits_after_its_flag,
    iso_7_3_2_frame_in_intermission_bit_3_after_an_error_frame,
    iso_7_3_3_bit_error_in_the_active_flag_restarts_it,
    iso_7_3_4_form_error_in_the_error_delimiter,
    iso_7_4_1_dominant_intermission_bit_gives_an_overload_frame,
    iso_7_4_2_dominant_last_eof_bit_gives_an_overload_frame,
    iso_7_4_3_dominant_last_delimiter_bit_gives_an_overload_frame,
    iso_7_4_4_bit_error_in_the_overload_flag_gives_an_error_frame,
    iso_7_4_5_form_error_in_the_overload_delimiter,
    iso_7_4_6_dominant_intermission_bit_after_an_error_frame,
    iso_7_4_7_dominant_intermission_bit_after_an_overload_frame,
}
