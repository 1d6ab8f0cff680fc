//! ISO 16845-1:2016 clause 8.6: the IUT as transmitter, its transmit error counter. Each test is
//! named after its clause and runs every elementary test case of it on both IUTs. Bit numbers are
//! lower-tester script bits; script bit 0 is the IUT's SOF. Where a clause's set-up raises TEC "by
//! an error scenario" first, the bench writes TXERR in reset mode instead (the SJA1000's way to set
//! it; on the core its counter load).

use golden::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::{ecc, BIT, FORM, SEG_ACK_DELIM, SEG_CRC_DELIM, SEG_EOF, STUFF};
use testbenches::iso::{
    ack_offset, bits_from, first_bit_at, lt_acknowledges_at, lt_sends_at,
    transmitter_data_bit_error, transmitter_overload_after_frame, DELIMITER, EOF, FLAG,
    INTERMISSION, PASSIVE_LIMIT, PENALTY,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// The TEC the clauses' set-ups reach "by an error scenario" (08h).
const RAISED_TEC: u8 = 8;

/// The IUT's frame: recessive and dominant bits in DLC, data and CRC.
fn frame() -> Frame {
    Frame::data(Id::standard(0x2A5).unwrap(), &[0x96, 0x3C]).unwrap()
}

/// A frame of higher priority than [`frame`].
fn winner() -> Frame {
    Frame::data(Id::standard(0x0A5).unwrap(), &[0x42]).unwrap()
}

/// TEC read at the start of script bit `bit` (after the IUT has processed bit `bit` − 1).
fn tec_before(bench: &mut ProtocolBench, bit: usize) -> u8 {
    bench.run_to_bit(bit);
    bench.tec()
}

/// The IUT transmits [`frame`] with TEC `tec`; the LT corrupts its first dominant data bit.
fn data_bit_error(iut: Iut, tec: u8) -> (ProtocolBench, usize) {
    transmitter_data_bit_error(iut, &frame(), tec)
}

/// The IUT transmits [`frame`] with TEC `tec`, acknowledged; the first intermission bit is dominant.
fn overload_after_frame(iut: Iut, tec: u8) -> (ProtocolBench, usize) {
    transmitter_overload_after_frame(iut, &frame(), tec)
}

/// 8.6.1: a bit error in the transmitter's active error flag: TEC +8.
///
/// ISO 16845-1 8.6.1: after a data bit error (TEC 8) the LT corrupts the first (#1), third (#2) or
/// sixth (#3) bit of the IUT's active error flag: TEC +8 at that bit (ISO 11898-1 rule 4), and the
/// flag starts again after it.
fn iso_8_6_1_bit_error_in_the_active_error_flag_is_plus_8(iut: Iut) {
    for (case, flag_bit) in [(1, 0usize), (2, 2), (3, 5)] {
        let (mut bench, error) = data_bit_error(iut, 0);
        let corrupted = error + 1 + flag_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::ForceRecessive);
        assert_eq!(tec_before(&mut bench, corrupted), PENALTY, "#{case}");
        assert_eq!(
            tec_before(&mut bench, corrupted + 1),
            2 * PENALTY,
            "#{case}"
        );
        bench.run(0);
        let mut expected = bits_from(error + 1, flag_bit + 1);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, corrupted + 1 + FLAG + 2),
            expected,
            "#{case}: the flag restarts after the corrupted bit"
        );
    }
}

/// 8.6.2: a bit error in the transmitter's overload flag: TEC +8.
///
/// ISO 16845-1 8.6.2: after its frame the IUT sends an overload flag (dominant first intermission
/// bit); the LT corrupts its first (#1), fourth (#2) or sixth (#3) bit: TEC +8 at that bit (ISO
/// 11898-1 rule 4), and an error flag follows.
fn iso_8_6_2_bit_error_in_the_overload_flag_is_plus_8(iut: Iut) {
    for (case, flag_bit) in [(1, 0usize), (2, 3), (3, 5)] {
        let (mut bench, overload) = overload_after_frame(iut, 0);
        let corrupted = overload + flag_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::ForceRecessive);
        assert_eq!(
            tec_before(&mut bench, corrupted),
            0,
            "#{case}: success at TEC 0"
        );
        assert_eq!(tec_before(&mut bench, corrupted + 1), PENALTY, "#{case}");
        bench.run(0);
        let mut expected = bits_from(overload, flag_bit + 1);
        expected.extend(bits_from(corrupted + 1, FLAG));
        assert_eq!(
            bench.iut_dominant_bits(overload, corrupted + 20),
            expected,
            "#{case}: an active error flag after the corrupted bit"
        );
    }
}

/// 8.6.3: 8 dominant bits after the transmitter's active error flag, and each further 8: TEC +8.
///
/// ISO 16845-1 8.6.3: after its active error flag (data bit error, TEC 8) the LT sends 16 dominant
/// bits: TEC +8 on the eighth and on the sixteenth (ISO 11898-1 rule 6: the 14th dominant bit
/// counting the flag, then every 8 more).
fn iso_8_6_3_dominant_bits_after_the_active_flag_count_8_each(iut: Iut) {
    let (mut bench, error) = data_bit_error(iut, 0);
    let after_flag = error + 1 + FLAG;
    bench
        .lt()
        .release(FLAG)
        .send_bits([DOMINANT; 16])
        .release(20);
    assert_eq!(tec_before(&mut bench, after_flag + 7), PENALTY);
    assert_eq!(
        tec_before(&mut bench, after_flag + 8),
        2 * PENALTY,
        "the 8th"
    );
    assert_eq!(tec_before(&mut bench, after_flag + 15), 2 * PENALTY);
    assert_eq!(
        tec_before(&mut bench, after_flag + 16),
        3 * PENALTY,
        "the 16th"
    );
    bench.run(0);
    assert_eq!(
        bench.bus_errors().len(),
        1,
        "no new error, only the counting"
    );
}

/// 8.6.4: 8 dominant bits after the transmitter's passive error flag, and each further 8: TEC +8.
///
/// ISO 16845-1 8.6.4: the passive IUT (TEC 128) sends a passive flag after a data bit error (136);
/// the LT then sends 1, 6, 8, 9 or 16 dominant bits (#1..#5): TEC +8 on each eighth (ISO 11898-1
/// rule 6: the 8th dominant bit after a passive flag, then every 8 more).
fn iso_8_6_4_dominant_bits_after_the_passive_flag_count_8_each(iut: Iut) {
    for (case, dominant) in [(1, 1usize), (2, 6), (3, 8), (4, 9), (5, 16)] {
        let (mut bench, _) = data_bit_error(iut, PASSIVE_LIMIT);
        bench
            .lt()
            .release(FLAG)
            .send_bits(std::iter::repeat_n(DOMINANT, dominant))
            .release(12);
        bench.run(0);
        let eighths = (dominant / 8) as u8;
        assert_eq!(
            bench.tec(),
            PASSIVE_LIMIT + PENALTY + eighths * PENALTY,
            "#{case}: {dominant} dominant bits"
        );
    }
}

/// 8.6.5: 8 dominant bits after the transmitter's overload flag, and each further 8: TEC +8.
///
/// ISO 16845-1 8.6.5: after the IUT's overload flag (dominant first intermission bit after its
/// frame) the LT sends 23 dominant bits: TEC +8 on the 8th and the 16th (ISO 11898-1 rule 6), none
/// for the 7 after them.
fn iso_8_6_5_dominant_bits_after_the_overload_flag_count_8_each(iut: Iut) {
    let (mut bench, overload) = overload_after_frame(iut, 0);
    let after_flag = overload + FLAG;
    bench
        .lt()
        .release(FLAG)
        .send_bits([DOMINANT; 23])
        .release(20);
    assert_eq!(tec_before(&mut bench, after_flag + 8), PENALTY, "the 8th");
    assert_eq!(
        tec_before(&mut bench, after_flag + 16),
        2 * PENALTY,
        "the 16th"
    );
    bench.run(0);
    assert_eq!(bench.tec(), 2 * PENALTY, "23 bits: two eighths");
}

/// 8.6.6: a bit error in SOF, identifier, DLC, data or CRC: TEC +8.
///
/// ISO 16845-1 8.6.6: the LT corrupts SOF (#1), a dominant identifier bit (#2; only dominant ones:
/// a recessive one read dominant is lost arbitration), a dominant (#3) or recessive (#4) DLC bit, a
/// dominant (#5) or recessive (#6) data bit, a dominant (#7) or recessive (#8) CRC bit: TEC +8 at
/// the detection (ISO 11898-1 rule 3), an error flag from the next bit.
fn iso_8_6_6_bit_error_in_every_field_is_plus_8(iut: Iut) {
    let f = frame();
    let cases = [
        (1, 0),
        (2, first_bit_at(&f, Field::BaseId, DOMINANT)),
        (3, first_bit_at(&f, Field::Dlc, DOMINANT)),
        (4, first_bit_at(&f, Field::Dlc, RECESSIVE)),
        (5, first_bit_at(&f, Field::Data, DOMINANT)),
        (6, first_bit_at(&f, Field::Data, RECESSIVE)),
        (7, first_bit_at(&f, Field::Crc, DOMINANT)),
        (8, first_bit_at(&f, Field::Crc, RECESSIVE)),
    ];
    let encoded = encode(&f);
    for (case, bit) in cases {
        let mut bench = ProtocolBench::iut_transmits(iut, &f);
        let flipped = if encoded.bits[bit] == DOMINANT {
            Drive::ForceRecessive
        } else {
            Drive::Dominant
        };
        bench.lt().release(bit + 20).set_bit(bit, flipped);
        if bit > 0 {
            assert_eq!(tec_before(&mut bench, bit), 0, "#{case}");
        }
        assert_eq!(
            tec_before(&mut bench, bit + 1),
            PENALTY,
            "#{case}: bit {bit}"
        );
        bench.run(0);
        assert_eq!(
            bench.iut_dominant_bits(bit + 1, bit + 1 + FLAG + 4),
            bits_from(bit + 1, FLAG),
            "#{case}: an active error flag"
        );
        assert_eq!(bench.bus_errors()[0] >> 6, BIT, "#{case}: a bit error");
    }
}

/// 8.6.7: a form error in CRC delimiter, ACK delimiter or EOF: TEC +8.
///
/// ISO 16845-1 8.6.7: the LT makes the CRC delimiter (#1), the ACK delimiter (#2), or the first
/// (#3), fourth (#4) or last (#5) EOF bit dominant: a form error, TEC +8 at the detection (ISO
/// 11898-1 rule 3; for the transmitter the frame is valid only after the last EOF bit).
fn iso_8_6_7_form_error_in_every_fixed_field_is_plus_8(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let at = |field, index| encoded.position(field, index).unwrap();
    let cases = [
        (1, at(Field::CrcDelim, 0), SEG_CRC_DELIM),
        (2, at(Field::AckDelim, 0), SEG_ACK_DELIM),
        (3, at(Field::Eof, 0), SEG_EOF),
        (4, at(Field::Eof, 3), SEG_EOF),
        (5, at(Field::Eof, EOF as u16 - 1), SEG_EOF),
    ];
    for (case, bit, segment) in cases {
        let mut bench = ProtocolBench::iut_transmits(iut, &f);
        lt_acknowledges_at(&mut bench, 0, &f, 20);
        bench.lt().set_bit(bit, Drive::Dominant);
        assert_eq!(
            tec_before(&mut bench, bit + 1),
            PENALTY,
            "#{case}: bit {bit}"
        );
        bench.run(0);
        assert_eq!(
            bench.iut_dominant_bits(bit + 1, bit + 1 + FLAG + 4),
            bits_from(bit + 1, FLAG),
            "#{case}: an active error flag"
        );
        assert_eq!(
            bench.bus_errors()[0],
            ecc(FORM, false, segment),
            "#{case}: a form error"
        );
    }
}

/// 8.6.8: an ACK error: TEC +8.
///
/// ISO 16845-1 8.6.8: the error-active IUT's frame is not acknowledged (ACK slot recessive): TEC +8
/// at the ACK error (ISO 11898-1 rule 3).
fn iso_8_6_8_ack_error_is_plus_8(iut: Iut) {
    let ack = ack_offset(&frame());
    let mut bench = ProtocolBench::iut_transmits(iut, &frame());
    bench.lt().release(ack + 20);
    assert_eq!(tec_before(&mut bench, ack), 0);
    assert_eq!(tec_before(&mut bench, ack + 1), PENALTY);
    bench.run(0);
    assert_eq!(
        bench.iut_dominant_bits(ack + 1, ack + 1 + FLAG + 4),
        bits_from(ack + 1, FLAG),
        "an active error flag after the ACK slot"
    );
}

/// 8.6.9: a form error in the transmitter's error delimiter: TEC +8.
///
/// ISO 16845-1 8.6.9: after the active flag of a data bit error (TEC 8) the LT makes the second
/// (#1), fourth (#2) or seventh (#3) error delimiter bit dominant: a form error, TEC +8 at it (ISO
/// 11898-1 rule 3), a new error flag from the next bit.
fn iso_8_6_9_form_error_in_the_error_delimiter_is_plus_8(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 4), (3, 7)] {
        let (mut bench, error) = data_bit_error(iut, 0);
        let corrupted = error + FLAG + delimiter_bit;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::Dominant);
        assert_eq!(tec_before(&mut bench, corrupted), PENALTY, "#{case}");
        assert_eq!(
            tec_before(&mut bench, corrupted + 1),
            2 * PENALTY,
            "#{case}"
        );
        bench.run(0);
        assert_eq!(
            bench.iut_dominant_bits(corrupted + 1, corrupted + 1 + FLAG + 4),
            bits_from(corrupted + 1, FLAG),
            "#{case}: a new error flag"
        );
    }
}

/// 8.6.10: a form error in the transmitter's overload delimiter: TEC +8.
///
/// ISO 16845-1 8.6.10: after the IUT's overload flag (dominant first intermission bit after its
/// frame) the LT makes the second (#1) or seventh (#2) overload delimiter bit dominant: a form
/// error, TEC +8 at it (ISO 11898-1 rule 3).
fn iso_8_6_10_form_error_in_the_overload_delimiter_is_plus_8(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 7)] {
        let (mut bench, overload) = overload_after_frame(iut, 0);
        let corrupted = overload + FLAG + delimiter_bit - 1;
        bench.lt().release(30);
        bench.lt().set_bit(corrupted, Drive::Dominant);
        assert_eq!(tec_before(&mut bench, corrupted), 0, "#{case}");
        assert_eq!(tec_before(&mut bench, corrupted + 1), PENALTY, "#{case}");
        bench.run(0);
        assert_eq!(
            bench.iut_dominant_bits(corrupted + 1, corrupted + 1 + FLAG + 4),
            bits_from(corrupted + 1, FLAG),
            "#{case}: an active error flag"
        );
    }
}

/// The IUT with TEC `tec` transmits [`frame`], acknowledged; returns the TEC at its end.
fn tec_after_acknowledged_frame(iut: Iut, tec: u8) -> u8 {
    let mut bench = ProtocolBench::iut_transmits_acknowledged(iut, &frame(), tec);
    assert_eq!(bench.iut_events(), [NodeEvent::TransmitDone(true)]);
    bench.tec()
}

/// 8.6.11: a valid frame sent by an error-active transmitter: TEC −1.
///
/// ISO 16845-1 8.6.11: with TEC raised (8), the IUT's acknowledged frame takes it to 7 (ISO 11898-1
/// rule 7).
fn iso_8_6_11_a_successful_transmission_is_minus_1(iut: Iut) {
    assert_eq!(
        tec_after_acknowledged_frame(iut, RAISED_TEC),
        RAISED_TEC - 1
    );
}

/// 8.6.12: a valid frame sent by an error-passive transmitter: TEC −1.
///
/// ISO 16845-1 8.6.12: from the TEC passive state (128) the acknowledged frame takes TEC to 127
/// (ISO 11898-1 rule 7): error active again.
fn iso_8_6_12_a_successful_transmission_when_passive_is_minus_1(iut: Iut) {
    assert_eq!(
        tec_after_acknowledged_frame(iut, PASSIVE_LIMIT),
        PASSIVE_LIMIT - 1
    );
}

/// 8.6.13: a 13-bit overload flag costs the transmitter nothing.
///
/// ISO 16845-1 8.6.13: with TEC 8, after the last EOF bit of the IUT's acknowledged frame the LT
/// sends 1 + 13 dominant bits: the first is an overload condition, the IUT's overload flag covers 6
/// of the 13 and 7 follow it (fewer than the 14 that ISO 11898-1 rule 6 counts with the flag). TEC
/// shall be the set-up value − 1.
fn iso_8_6_13_a_13_bit_overload_flag_changes_nothing(iut: Iut) {
    let len = encode(&frame()).len();
    let mut bench = ProtocolBench::iut_transmits_with(iut, &frame(), RAISED_TEC, false);
    lt_acknowledges_at(&mut bench, 0, &frame(), 0);
    bench.lt().send_bits([DOMINANT; 14]).release(20);
    bench.run(0);
    assert_eq!(bench.tec(), RAISED_TEC - 1);
    assert_eq!(
        bench.iut_dominant_bits(len, len + 20),
        bits_from(len + 1, FLAG),
        "one overload flag"
    );
    assert_eq!(bench.iut_events(), [NodeEvent::TransmitDone(true)]);
}

/// 8.6.14: a 13-bit error flag costs the transmitter nothing more.
///
/// ISO 16845-1 8.6.14: after the IUT's active error flag (data bit error, TEC 8) the LT sends 7
/// dominant bits (a 13-bit flag with the IUT's 6): fewer than ISO 11898-1 rule 6 counts; TEC stays 8.
fn iso_8_6_14_a_13_bit_error_flag_changes_nothing_more(iut: Iut) {
    let (mut bench, _) = data_bit_error(iut, 0);
    bench
        .lt()
        .release(FLAG)
        .send_bits([DOMINANT; 7])
        .release(20);
    bench.run(0);
    assert_eq!(bench.tec(), PENALTY);
    assert_eq!(bench.bus_errors().len(), 1);
}

/// 8.6.15: a dominant last overload delimiter bit costs the transmitter nothing.
///
/// ISO 16845-1 8.6.15: with TEC 8, after the IUT's acknowledged frame (7) and its overload flag, the
/// LT makes the eighth overload delimiter bit dominant: an overload condition (ISO 11898-1), not an
/// error; a new overload flag follows and TEC stays at the set-up value − 1.
fn iso_8_6_15_dominant_last_overload_delimiter_bit_changes_nothing(iut: Iut) {
    let (mut bench, overload) = overload_after_frame(iut, RAISED_TEC);
    let last = overload + FLAG + DELIMITER - 1;
    bench.lt().release(30);
    bench.lt().set_bit(last, Drive::Dominant);
    bench.run(0);
    assert_eq!(bench.tec(), RAISED_TEC - 1);
    let mut expected = bits_from(overload, FLAG);
    expected.extend(bits_from(last + 1, FLAG));
    assert_eq!(
        bench.iut_dominant_bits(overload, last + 20),
        expected,
        "a second overload flag"
    );
    assert!(bench.bus_errors().is_empty());
}

/// 8.6.16: a dominant last error delimiter bit costs the transmitter nothing.
///
/// ISO 16845-1 8.6.16 (its execution text repeats 8.6.14's; its purpose is followed): after the
/// IUT's active error flag (data bit error, TEC 8) the LT makes the eighth error delimiter bit
/// dominant: an overload condition (ISO 11898-1), not a form error; an overload flag follows, TEC
/// stays 8.
fn iso_8_6_16_dominant_last_error_delimiter_bit_changes_nothing(iut: Iut) {
    let (mut bench, error) = data_bit_error(iut, 0);
    let last = error + FLAG + DELIMITER;
    bench.lt().release(30);
    bench.lt().set_bit(last, Drive::Dominant);
    bench.run(0);
    assert_eq!(bench.tec(), PENALTY);
    assert_eq!(
        bench.iut_dominant_bits(last, last + 20),
        bits_from(last + 1, FLAG),
        "an overload flag"
    );
    assert_eq!(bench.bus_errors().len(), 1);
}

/// 8.6.17: a passive transmitter's ACK error followed by a passive error flag: TEC unchanged.
///
/// ISO 16845-1 8.6.17: the passive IUT (TEC 128) gets no ACK; during its passive flag the bus
/// stays recessive: ISO 11898-1 rule 3 exception a, TEC stays 128.
fn iso_8_6_17_passive_ack_error_with_a_recessive_flag_changes_nothing(iut: Iut) {
    let ack = ack_offset(&frame());
    let mut bench = ProtocolBench::iut_transmits_with(iut, &frame(), PASSIVE_LIMIT, false);
    bench.lt().release(ack + 1 + FLAG + DELIMITER + 1);
    bench.run(0);
    assert_eq!(bench.tec(), PASSIVE_LIMIT);
}

/// 8.6.18: a passive transmitter's ACK error followed by a dominant bit in its passive flag: +8.
///
/// ISO 16845-1 8.6.18: the passive IUT gets no ACK; the LT sends a dominant bit in the sixth bit of
/// its passive flag: rule 3 exception a no longer applies, TEC +8 (ISO 11898-1).
fn iso_8_6_18_passive_ack_error_with_a_dominant_bit_in_the_flag_is_plus_8(iut: Iut) {
    let ack = ack_offset(&frame());
    let mut bench = ProtocolBench::iut_transmits_with(iut, &frame(), PASSIVE_LIMIT, false);
    bench.lt().release(ack + 1 + 2 * FLAG + DELIMITER + 1);
    bench.lt().set_bit(ack + FLAG, Drive::Dominant);
    assert_eq!(tec_before(&mut bench, ack + FLAG), PASSIVE_LIMIT);
    bench.run(0);
    assert_eq!(bench.tec(), PASSIVE_LIMIT + PENALTY);
}

/// 8.6.19: a recessive stuff bit of the arbitration field read dominant: TEC unchanged.
///
/// ISO 16845-1 8.6.19: with TEC 8, the LT forces a recessive stuff bit in the IUT's arbitration
/// field dominant: a stuff error that ISO 11898-1 rule 3 exception b leaves uncounted; TEC is still
/// 8 after the error frame.
fn iso_8_6_19_stuff_error_in_arbitration_changes_nothing(iut: Iut) {
    let f = Frame::data(Id::standard(0x00F).unwrap(), &[0x01]).unwrap();
    let encoded = encode(&f);
    let stuff = (0..encoded.len())
        .find(|&i| encoded.tags[i].stuff && encoded.bits[i] == RECESSIVE)
        .expect("SOF and 4 dominant identifier bits: a recessive stuff bit");
    assert_eq!(
        encoded.tags[stuff + 1].field,
        Field::BaseId,
        "inside the identifier"
    );
    let mut bench = ProtocolBench::iut_transmits_with(iut, &f, RAISED_TEC, false);
    let end = stuff + 1 + FLAG + DELIMITER;
    bench.lt().release(end).set_bit(stuff, Drive::Dominant);
    bench.run(0);
    assert_eq!(bench.bus_errors().len(), 1, "one error");
    assert_eq!(bench.bus_errors()[0] >> 6, STUFF, "a stuff error");
    assert_eq!(bench.tec(), RAISED_TEC);
}

/// 8.6.20: a frame received after lost arbitration leaves TEC as it is.
///
/// ISO 16845-1 8.6.20: the IUT's first attempt is disturbed (data bit error, TEC 8); at its
/// retransmission the LT sends a frame of higher priority, which the IUT receives (TEC unchanged),
/// then the IUT's frame gets through: TEC 7 at the end, only −1 for that success.
fn iso_8_6_20_a_received_frame_leaves_tec_unchanged(iut: Iut) {
    let (mut bench, error) = data_bit_error(iut, 0);
    let retransmission = error + 1 + FLAG + DELIMITER + INTERMISSION;
    let winner_ack = lt_sends_at(&mut bench, retransmission, &winner());
    let mine = winner_ack + 1 + EOF + INTERMISSION + 1;
    lt_acknowledges_at(&mut bench, mine, &frame(), 4);
    assert_eq!(
        tec_before(&mut bench, winner_ack + 1 + EOF),
        PENALTY,
        "receiving: unchanged"
    );
    bench.run(0);
    assert_eq!(bench.tec(), PENALTY - 1);
    let events = bench.iut_events();
    assert!(events.contains(&NodeEvent::Received(winner())));
    assert_eq!(events.last(), Some(&NodeEvent::TransmitDone(true)));
}

/// 8.6.21: an error in a frame received after lost arbitration leaves TEC as it is.
///
/// ISO 16845-1 8.6.21: with TEC 8, the IUT loses arbitration to the LT's frame, which the LT then
/// disturbs (a stuff error after the arbitration field): the IUT is a receiver, so REC +1 and TEC
/// unchanged (ISO 11898-1 rules 1 and 3 apply by role).
fn iso_8_6_21_an_error_after_lost_arbitration_leaves_tec_unchanged(iut: Iut) {
    let w = winner();
    let encoded = encode(&w);
    let mut bench = ProtocolBench::iut_transmits_with(iut, &frame(), RAISED_TEC, false);
    let data = encoded.position(Field::Data, 0).unwrap();
    let mut bits: Vec<bool> = encoded.bits.iter().by_vals().take(data).collect();
    let last = *bits.last().unwrap();
    bits.extend(std::iter::repeat_n(last, 6));
    bench.lt().send_bits(bits).release(FLAG + DELIMITER + 2);
    bench.run(0);
    assert_eq!(bench.tec(), RAISED_TEC);
    assert_eq!(bench.rec(), 1, "a receiver's error: +1");
    let events = bench.iut_events();
    assert_eq!(
        events[0],
        NodeEvent::ArbitrationLost(first_difference(&frame(), &w) as u8)
    );
    let errors = bench.bus_errors();
    assert_eq!(errors.len(), 1);
    assert_eq!(
        errors[0] >> 5,
        STUFF << 1 | 1,
        "a stuff error while receiving"
    );
}

/// The arbitration position where `a` and `b` first differ (SJA1000 ALC: identifier bits from 0).
fn first_difference(a: &Frame, b: &Frame) -> usize {
    let (a, b) = (encode(a), encode(b));
    (1..)
        .find(|&i| a.bits[i] != b.bits[i])
        .expect("different frames")
        - 1
}

testbenches::on_both_iuts! {
    iso_8_6_1_bit_error_in_the_active_error_flag_is_plus_8,
    iso_8_6_2_bit_error_in_the_overload_flag_is_plus_8,
    iso_8_6_3_dominant_bits_after_the_active_flag_count_8_each,
    iso_8_6_4_dominant_bits_after_the_passive_flag_count_8_each,
    iso_8_6_5_dominant_bits_after_the_overload_flag_count_8_each,
    iso_8_6_6_bit_error_in_every_field_is_plus_8,
    iso_8_6_7_form_error_in_every_fixed_field_is_plus_8,
    iso_8_6_8_ack_error_is_plus_8,
    iso_8_6_9_form_error_in_the_error_delimiter_is_plus_8,
    iso_8_6_10_form_error_in_the_overload_delimiter_is_plus_8,
    iso_8_6_11_a_successful_transmission_is_minus_1,
    iso_8_6_12_a_successful_transmission_when_passive_is_minus_1,
    iso_8_6_13_a_13_bit_overload_flag_changes_nothing,
    iso_8_6_14_a_13_bit_error_flag_changes_nothing_more,
    iso_8_6_15_dominant_last_overload_delimiter_bit_changes_nothing,
    iso_8_6_16_dominant_last_error_delimiter_bit_changes_nothing,
    iso_8_6_17_passive_ack_error_with_a_recessive_flag_changes_nothing,
    iso_8_6_18_passive_ack_error_with_a_dominant_bit_in_the_flag_is_plus_8,
    iso_8_6_19_stuff_error_in_arbitration_changes_nothing,
    iso_8_6_20_a_received_frame_leaves_tec_unchanged,
    iso_8_6_21_an_error_after_lost_arbitration_leaves_tec_unchanged,
}
