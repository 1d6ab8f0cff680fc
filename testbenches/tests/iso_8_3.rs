//! ISO 16845-1:2016 clauses 8.3 and 8.4: the IUT as transmitter, active error frame and overload
//! frame. Each test is named after its clause and runs every elementary test case of it on both
//! IUTs. Bit numbers are lower-tester script bits; script bit 0 is the IUT's SOF.

use golden::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::iso::{
    ack_offset, active_retransmission, bits_from, dominant_bits_of, lt_acknowledges_at,
    transmitter_data_bit_error, transmitter_overload_after_frame, DELIMITER, FLAG, PASSIVE_LIMIT,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// The IUT's frame (a dominant data bit for the LT to corrupt).
fn frame() -> Frame {
    Frame::data(Id::standard(0x2A5).unwrap(), &[0x96, 0x3C]).unwrap()
}

/// The frames of the "SOF in the third intermission bit" cases: #1 an identifier starting with 4
/// dominant bits (with the SOF before them, a stuff bit follows), #2 one starting with 5 recessive
/// bits.
fn identifier_cases() -> [(u32, Frame); 2] {
    [
        (
            1,
            Frame::data(Id::standard(0x07F).unwrap(), &[0x96]).unwrap(),
        ),
        (
            2,
            Frame::data(Id::standard(0x7C3).unwrap(), &[0x96]).unwrap(),
        ),
    ]
}

/// The IUT transmits `frame` (TEC `tec`); the LT corrupts its first dominant data bit.
fn data_bit_error(iut: Iut, frame: &Frame, tec: u8) -> (ProtocolBench, usize) {
    transmitter_data_bit_error(iut, frame, tec)
}

/// The IUT transmits [`frame`] (TEC `tec`), acknowledged; the first intermission bit is dominant.
fn overload_after_frame(iut: Iut, tec: u8) -> (ProtocolBench, usize) {
    transmitter_overload_after_frame(iut, &frame(), tec)
}

/// The IUT's bits of `frame` sent from the identifier on after a SOF at `sof` that another node
/// sent: the frame's dominant bits but the SOF.
fn frame_without_sof(frame: &Frame, sof: usize) -> Vec<usize> {
    dominant_bits_of(frame, sof)
        .into_iter()
        .filter(|&b| b != sof)
        .collect()
}

/// 8.3.1: a transmitter tolerates up to 7 dominant bits after its error flag.
///
/// ISO 16845-1 8.3.1: after the IUT's active error flag (data bit corrupted) the LT prolongs it by 1
/// (#1), 4 (#2) or 7 (#3) dominant bits. One error frame only: the delimiter starts with the first
/// recessive bit, and the IUT restarts its frame after the intermission.
fn iso_8_3_1_transmitter_tolerates_7_dominant_bits_after_its_flag(iut: Iut) {
    for (case, extra) in [(1, 1usize), (2, 4), (3, 7)] {
        let (mut bench, error) = data_bit_error(iut, &frame(), 0);
        bench
            .lt()
            .release(FLAG)
            .send_bits(std::iter::repeat_n(DOMINANT, extra));
        let again = active_retransmission(error) + extra;
        lt_acknowledges_at(&mut bench, again, &frame(), 4);
        bench.run(0);
        let mut expected = bits_from(error + 1, FLAG);
        expected.extend(dominant_bits_of(&frame(), again));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, again + ack_offset(&frame())),
            expected,
            "#{case}: one flag, the frame again after delimiter and intermission"
        );
        assert_eq!(bench.bus_errors().len(), 1, "#{case}: one error frame");
    }
}

/// 8.3.2: after its error frame, the IUT takes a SOF in the third intermission bit as its own.
///
/// ISO 16845-1 8.3.2: after the IUT's active error flag (data bit corrupted) the LT waits 8 + 2 bits
/// and sends a SOF: the third intermission bit. The IUT shall send its frame from the identifier,
/// without a SOF of its own (ISO 11898-1); #1 and #2 as in 8.1.8.
fn iso_8_3_2_sof_in_intermission_bit_3_after_an_error_frame(iut: Iut) {
    for (case, frame) in identifier_cases() {
        let (mut bench, error) = data_bit_error(iut, &frame, 0);
        let sof = error + 1 + FLAG + DELIMITER + 2;
        bench.lt().release(sof - error - 1).send_bits([DOMINANT]);
        lt_acknowledges_at(&mut bench, sof, &frame, 4);
        bench.run(0);
        let mut expected = bits_from(error + 1, FLAG);
        expected.extend(frame_without_sof(&frame, sof));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, sof + ack_offset(&frame)),
            expected,
            "#{case}: the identifier from the bit after the LT's SOF"
        );
        assert_eq!(
            bench.iut_events().last(),
            Some(&NodeEvent::TransmitDone(true))
        );
    }
}

/// 8.3.3: a bit error in the transmitter's active error flag restarts the flag.
///
/// ISO 16845-1 8.3.3: the LT corrupts the first (#1), fourth (#2) or sixth (#3) bit of the IUT's
/// active error flag: the IUT shall restart its flag at the next bit.
fn iso_8_3_3_bit_error_in_the_active_flag_restarts_it(iut: Iut) {
    for (case, flag_bit) in [(1, 0usize), (2, 3), (3, 5)] {
        let (mut bench, error) = data_bit_error(iut, &frame(), 0);
        let corrupted = error + 1 + flag_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::ForceRecessive);
        bench.run(0);
        let mut expected = bits_from(error + 1, flag_bit + 1);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, corrupted + 1 + FLAG + 2),
            expected,
            "#{case}"
        );
    }
}

/// 8.3.4: a form error in the transmitter's error delimiter starts a new error frame.
///
/// ISO 16845-1 8.3.4: the LT makes bit 2 (#1), 4 (#2) or 7 (#3) of the IUT's error delimiter
/// dominant: the IUT shall start an error flag at the next bit.
fn iso_8_3_4_form_error_in_the_error_delimiter_restarts_the_error_frame(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 4), (3, 7)] {
        let (mut bench, error) = data_bit_error(iut, &frame(), 0);
        let corrupted = error + FLAG + delimiter_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::Dominant);
        bench.run(0);
        let mut expected = bits_from(error + 1, FLAG);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, corrupted + 1 + FLAG + 2),
            expected,
            "#{case}"
        );
    }
}

/// 8.4.1: a dominant first or second intermission bit after the transmitter's frame is an overload
/// condition.
///
/// ISO 16845-1 8.4.1: the passive IUT's frame is acknowledged; the LT makes intermission bit 1 (#1)
/// or 2 (#2) dominant: an overload flag from the next bit (dominant: overload flags are the same for
/// error-passive nodes, ISO 11898-1).
fn iso_8_4_1_dominant_intermission_bit_gives_an_overload_frame(iut: Iut) {
    let len = encode(&frame()).len();
    for (case, bit) in [(1, len), (2, len + 1)] {
        let mut bench = ProtocolBench::iut_transmits_with(iut, &frame(), PASSIVE_LIMIT, false);
        lt_acknowledges_at(&mut bench, 0, &frame(), 20);
        bench.lt().set_bit(bit, Drive::Dominant);
        bench.run(0);
        assert_eq!(
            bench.iut_dominant_bits(len, len + 20),
            bits_from(bit + 1, FLAG),
            "#{case}"
        );
        assert_eq!(
            bench.iut_events(),
            [NodeEvent::TransmitDone(true)],
            "#{case}"
        );
    }
}

/// 8.4.2: a dominant eighth delimiter bit is an overload condition.
///
/// ISO 16845-1 8.4.2: the passive IUT's error delimiter after a data bit error (#1), or its overload
/// delimiter after its frame (#2), gets a dominant eighth bit: an overload flag from the next bit.
fn iso_8_4_2_dominant_last_delimiter_bit_gives_an_overload_frame(iut: Iut) {
    let (mut bench, error) = data_bit_error(iut, &frame(), PASSIVE_LIMIT);
    let last = error + FLAG + DELIMITER;
    bench.lt().release(30);
    bench.lt().set_bit(last, Drive::Dominant);
    bench.run(0);
    assert_eq!(
        bench.iut_dominant_bits(error + 1, last + 12),
        bits_from(last + 1, FLAG),
        "#1: the passive flag, then an overload flag"
    );
    let (mut bench, overload) = overload_after_frame(iut, PASSIVE_LIMIT);
    let last = overload + FLAG + DELIMITER - 1;
    bench.lt().release(30);
    bench.lt().set_bit(last, Drive::Dominant);
    bench.run(0);
    let mut expected = bits_from(overload, FLAG);
    expected.extend(bits_from(last + 1, FLAG));
    assert_eq!(
        bench.iut_dominant_bits(overload, last + 12),
        expected,
        "#2: a second overload flag"
    );
}

/// 8.4.3: after an overload frame, the IUT takes a SOF in the third intermission bit as its own.
///
/// ISO 16845-1 8.4.3: the IUT's frame is disturbed (data bit error, active flag); the LT makes the
/// first intermission bit after the error frame dominant (an overload frame) and then the third
/// intermission bit after the overload delimiter: the IUT shall send its frame from the
/// identifier, without a SOF of its own; #1 and #2 as in 8.1.8.
fn iso_8_4_3_sof_in_intermission_bit_3_after_an_overload_frame(iut: Iut) {
    for (case, frame) in identifier_cases() {
        let (mut bench, error) = data_bit_error(iut, &frame, 0);
        let overload_condition = error + 1 + FLAG + DELIMITER;
        let sof = overload_condition + 1 + FLAG + DELIMITER + 2;
        bench
            .lt()
            .release(overload_condition - error - 1)
            .send_bits([DOMINANT])
            .release(sof - overload_condition - 1)
            .send_bits([DOMINANT]);
        lt_acknowledges_at(&mut bench, sof, &frame, 4);
        bench.run(0);
        let mut expected = bits_from(error + 1, FLAG);
        expected.extend(bits_from(overload_condition + 1, FLAG));
        expected.extend(frame_without_sof(&frame, sof));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, sof + ack_offset(&frame)),
            expected,
            "#{case}: error flag, overload flag, the identifier after the LT's SOF"
        );
        assert_eq!(
            bench.iut_events().last(),
            Some(&NodeEvent::TransmitDone(true))
        );
        assert_eq!(encode(&frame).tags[1].field, Field::BaseId);
        assert_eq!(
            encode(&frame).bits[1],
            if case == 1 { DOMINANT } else { RECESSIVE }
        );
    }
}

/// 8.4.4: a bit error in the transmitter's overload flag starts an error frame.
///
/// ISO 16845-1 8.4.4: the LT corrupts the first (#1), second (#2) or sixth (#3) bit of the IUT's
/// overload flag: an error flag from the next bit.
fn iso_8_4_4_bit_error_in_the_overload_flag_gives_an_error_frame(iut: Iut) {
    for (case, flag_bit) in [(1, 0usize), (2, 1), (3, 5)] {
        let (mut bench, overload) = overload_after_frame(iut, 0);
        let corrupted = overload + flag_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::ForceRecessive);
        bench.run(0);
        let mut expected = bits_from(overload, flag_bit + 1);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(overload, corrupted + 1 + FLAG + 2),
            expected,
            "#{case}"
        );
        assert_eq!(bench.bus_errors().len(), 1, "#{case}: a bit error");
    }
}

/// 8.4.5: a form error in the transmitter's overload delimiter starts an error frame.
///
/// ISO 16845-1 8.4.5: the LT makes bit 2 (#1), 4 (#2) or 7 (#3) of the IUT's overload delimiter
/// dominant: an error flag from the next bit.
fn iso_8_4_5_form_error_in_the_overload_delimiter_gives_an_error_frame(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 4), (3, 7)] {
        let (mut bench, overload) = overload_after_frame(iut, 0);
        let corrupted = overload + FLAG + delimiter_bit - 1;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::Dominant);
        bench.run(0);
        let mut expected = bits_from(overload, FLAG);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(overload, corrupted + 1 + FLAG + 2),
            expected,
            "#{case}"
        );
        assert_eq!(bench.bus_errors().len(), 1, "#{case}: a form error");
    }
}

testbenches::on_both_iuts! {
    iso_8_3_1_transmitter_tolerates_7_dominant_bits_after_its_flag,
    iso_8_3_2_sof_in_intermission_bit_3_after_an_error_frame,
    iso_8_3_3_bit_error_in_the_active_flag_restarts_it,
    iso_8_3_4_form_error_in_the_error_delimiter_restarts_the_error_frame,
    iso_8_4_1_dominant_intermission_bit_gives_an_overload_frame,
    iso_8_4_2_dominant_last_delimiter_bit_gives_an_overload_frame,
    iso_8_4_3_sof_in_intermission_bit_3_after_an_overload_frame,
    iso_8_4_4_bit_error_in_the_overload_flag_gives_an_error_frame,
    iso_8_4_5_form_error_in_the_overload_delimiter_gives_an_error_frame,
}
