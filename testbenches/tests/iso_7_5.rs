//! ISO 16845-1:2016 clause 7.5: the IUT as receiver, error-passive state. Each test is named after
//! its clause and runs every elementary test case of it on both IUTs. "The IUT is set in passive
//! state" is REC 128 (the RXERR write). Bit numbers are lower-tester script bits.

use golden::frame::{encode, Field, Frame, Id, DOMINANT};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::STUFF;
use testbenches::iso::{
    bits_from, receiver_stuff_error_in_data, DELIMITER, FLAG, INTERMISSION, PASSIVE_LIMIT, PENALTY,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// The LT's frame with the stuff error (recessive before its data field).
fn frame() -> Frame {
    Frame::data(Id::standard(0x2A5).unwrap(), &[0x96]).unwrap()
}

/// The valid test frame the LT sends afterwards.
fn test_frame() -> Frame {
    Frame::data(Id::standard(0x111).unwrap(), &[0x07]).unwrap()
}

/// A receiving IUT with REC `rec` gets [`frame`] with a stuff error in its data field. Returns the
/// bench (not run) and the error's bit.
fn stuff_error_with_rec(iut: Iut, rec: u8) -> (ProtocolBench, usize) {
    let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
    bench.load_counter(false, rec);
    (bench, error)
}

/// The LT idles up to `sof` and sends [`test_frame`]; returns the script bit of its ACK slot.
fn lt_sends_test_frame_at(bench: &mut ProtocolBench, sof: usize) -> usize {
    let played = bench.lt_ref().script_len();
    assert!(
        sof >= played,
        "the test frame at {sof} starts before {played}"
    );
    bench
        .lt()
        .release(sof - played)
        .send_bits(encode(&test_frame()).bits.iter().by_vals())
        .release(4);
    sof + encode(&test_frame()).position(Field::AckSlot, 0).unwrap()
}

/// After the error at `error`, the passive IUT drove no dominant bit but the ACK of the test frame
/// at `ack`, and received it.
fn assert_test_frame_acknowledged(bench: &mut ProtocolBench, error: usize, ack: usize, what: &str) {
    assert_eq!(
        bench.iut_dominant_bits(error + 1, ack + 10),
        vec![ack],
        "{what}: recessive flag, then the ACK of the test frame"
    );
    assert!(
        bench
            .iut_events()
            .contains(&NodeEvent::Received(test_frame())),
        "{what}: the test frame received"
    );
}

/// 7.5.1: the passive flag is complete after 6 equal bits.
///
/// ISO 16845-1 7.5.1: during the passive IUT's error flag the LT sends an active error flag
/// starting at its first (#1), third (#2) or sixth (#3) bit; 8 + 2 bits after it the LT sends a
/// test frame: it starts in the IUT's third intermission bit only if the passive flag ended with
/// the LT's 6 dominant bits; the IUT shall acknowledge it.
fn iso_7_5_1_passive_flag_is_complete_after_6_equal_bits(iut: Iut) {
    for (case, start) in [(1, 0usize), (2, 2), (3, 5)] {
        let (mut bench, error) = stuff_error_with_rec(iut, PASSIVE_LIMIT);
        let flag = error + 1 + start;
        bench.lt().release(start).send_bits([DOMINANT; FLAG]);
        let ack = lt_sends_test_frame_at(&mut bench, flag + FLAG + DELIMITER + 2);
        bench.run(1);
        assert_test_frame_acknowledged(&mut bench, error, ack, &format!("#{case}"));
    }
}

/// 7.5.2: a passive receiver accepts a frame in the third intermission bit after its error frame.
///
/// ISO 16845-1 7.5.2: 8 + 2 bits after the passive IUT's error flag the LT sends a test frame; the
/// IUT shall acknowledge it.
fn iso_7_5_2_passive_receiver_accepts_a_frame_in_intermission_bit_3(iut: Iut) {
    let (mut bench, error) = stuff_error_with_rec(iut, PASSIVE_LIMIT);
    let ack = lt_sends_test_frame_at(&mut bench, error + 1 + FLAG + DELIMITER + 2);
    bench.run(1);
    assert_test_frame_acknowledged(&mut bench, error, ack, "#1");
}

/// 7.5.3: a passive receiver tolerates up to 7 dominant bits after its passive flag.
///
/// ISO 16845-1 7.5.3: after the passive flag the LT sends 1 (#1), 4 (#2) or 7 (#3) dominant bits,
/// then 8 + 2 bits later a test frame: no new error (the delimiter starts with the first recessive
/// bit), the test frame acknowledged.
fn iso_7_5_3_passive_receiver_tolerates_7_dominant_bits_after_its_flag(iut: Iut) {
    for (case, extra) in [(1, 1usize), (2, 4), (3, 7)] {
        let (mut bench, error) = stuff_error_with_rec(iut, PASSIVE_LIMIT);
        bench
            .lt()
            .release(FLAG)
            .send_bits(std::iter::repeat_n(DOMINANT, extra));
        let after = error + 1 + FLAG + extra;
        let ack = lt_sends_test_frame_at(&mut bench, after + DELIMITER + 2);
        bench.run(1);
        assert_test_frame_acknowledged(&mut bench, error, ack, &format!("#{case}"));
        assert_eq!(bench.bus_errors().len(), 1, "#{case}: no new error");
    }
}

/// 7.5.4: a passive receiver never sends an active error flag.
///
/// ISO 16845-1 7.5.4: the LT sends 9 frames with a stuff error in the data field: the passive IUT
/// shall never drive a dominant error flag (its REC only grows: it stays passive).
fn iso_7_5_4_passive_receiver_never_sends_an_active_flag(iut: Iut) {
    const FRAMES: usize = 9;
    let (mut bench, first_error) = stuff_error_with_rec(iut, PASSIVE_LIMIT);
    let prefix: Vec<bool> = encode(&frame())
        .bits
        .iter()
        .by_vals()
        .take(encode(&frame()).position(Field::Data, 0).unwrap())
        .collect();
    for _ in 1..FRAMES {
        bench
            .lt()
            .release(FLAG + DELIMITER + INTERMISSION + 4)
            .send_bits(prefix.iter().copied())
            .send_bits([DOMINANT; FLAG]);
    }
    bench.lt().release(30);
    bench.run(1);
    assert!(
        bench
            .iut_dominant_bits(first_error, bench.lt_ref().script_len())
            .is_empty(),
        "no dominant bit after the first error"
    );
    let errors = bench.bus_errors();
    assert_eq!(errors.len(), FRAMES, "{errors:02X?}");
    assert!(
        errors.iter().all(|e| e >> 5 == STUFF << 1 | 1),
        "stuff errors while receiving"
    );
    assert!(bench.error_passive());
}

/// 7.5.5: dominant bits in the passive flag restart its count of equal bits.
///
/// ISO 16845-1 7.5.5: during the passive flag the LT sends 5 dominant bits from its first (#1),
/// third (#2) or sixth (#3) bit; 6 + 7 bits after them it sends a dominant bit. The flag completes
/// with 6 recessive bits after the 5 dominant ones, so that bit is the eighth delimiter bit: an
/// overload flag from the next bit.
fn iso_7_5_5_dominant_bits_restart_the_passive_flag(iut: Iut) {
    for (case, start) in [(1, 0usize), (2, 2), (3, 5)] {
        let (mut bench, error) = stuff_error_with_rec(iut, PASSIVE_LIMIT);
        let last_dominant = error + start + 5;
        let overload_condition = last_dominant + FLAG + 7 + 1;
        bench
            .lt()
            .release(start)
            .send_bits([DOMINANT; 5])
            .release(30);
        bench.lt().set_bit(overload_condition, Drive::Dominant);
        bench.run(1);
        assert_eq!(
            bench.iut_dominant_bits(error + 1, overload_condition + 20),
            bits_from(overload_condition + 1, FLAG),
            "#{case}: an overload flag after the LT's dominant bit"
        );
    }
}

/// 7.5.6: a passive receiver detects a form error in its error delimiter.
///
/// ISO 16845-1 7.5.6: the LT makes bit 2 (#1), 4 (#2) or 7 (#3) of the delimiter after the passive
/// flag dominant (a form error, a new passive flag), and 6 + 7 bits later sends a dominant bit, the
/// eighth bit of the new delimiter: an overload flag from the next bit.
fn iso_7_5_6_passive_receiver_detects_a_form_error_in_its_delimiter(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 4), (3, 7)] {
        let (mut bench, error) = stuff_error_with_rec(iut, PASSIVE_LIMIT);
        let form_error = error + FLAG + delimiter_bit;
        let overload_condition = form_error + FLAG + 7 + 1;
        bench.lt().release(40);
        bench.lt().set_bit(form_error, Drive::Dominant);
        bench.lt().set_bit(overload_condition, Drive::Dominant);
        bench.run(1);
        assert_eq!(
            bench.iut_dominant_bits(error + 1, overload_condition + 20),
            bits_from(overload_condition + 1, FLAG),
            "#{case}"
        );
        assert_eq!(
            bench.bus_errors().len(),
            2,
            "#{case}: the stuff and the form error"
        );
    }
}

/// 7.5.7: an error-active receiver becomes error passive.
///
/// ISO 16845-1 7.5.7: after a stuff error in the data field (REC 1) the LT forces 17 bits of the
/// IUT's active error flags recessive. Each is a bit error (+8, the flag restarts); the 16th takes
/// REC from 121 to 129 and is still signalled active (the state at its detection), the 17th (REC
/// 137) passive: the passive flag starts at the bit after the LT's last recessive bit. The LT's test
/// frame 6 + 8 + 3 bits after the dominant part shall be acknowledged.
fn iso_7_5_7_active_receiver_becomes_passive(iut: Iut) {
    const CORRUPTED: usize = 17;
    let (mut bench, error) = receiver_stuff_error_in_data(iut, &frame());
    let last_corrupted = error + CORRUPTED;
    bench.lt().release(CORRUPTED);
    for bit in error + 1..=last_corrupted {
        bench.lt().set_bit(bit, Drive::ForceRecessive);
    }
    let ack = lt_sends_test_frame_at(
        &mut bench,
        last_corrupted + 1 + FLAG + DELIMITER + INTERMISSION,
    );
    bench.run_to_bit(last_corrupted + 1);
    assert_eq!(
        bench.rec(),
        1 + CORRUPTED as u8 * PENALTY,
        "+1, then 17 × 8"
    );
    assert!(bench.error_passive());
    bench.run(1);
    let mut expected = bits_from(error + 1, CORRUPTED);
    expected.push(ack);
    assert_eq!(
        bench.iut_dominant_bits(error + 1, ack + 10),
        expected,
        "17 active flag bits, a passive flag after the last, then the ACK"
    );
    assert!(bench
        .iut_events()
        .contains(&NodeEvent::Received(test_frame())));
}

testbenches::on_both_iuts! {
    iso_7_5_1_passive_flag_is_complete_after_6_equal_bits,
    iso_7_5_2_passive_receiver_accepts_a_frame_in_intermission_bit_3,
    iso_7_5_3_passive_receiver_tolerates_7_dominant_bits_after_its_flag,
    iso_7_5_4_passive_receiver_never_sends_an_active_flag,
    iso_7_5_5_dominant_bits_restart_the_passive_flag,
    iso_7_5_6_passive_receiver_detects_a_form_error_in_its_delimiter,
    iso_7_5_7_active_receiver_becomes_passive,
}
