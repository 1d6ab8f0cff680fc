//! ISO 16845-1:2016 clause 7.1: the IUT as receiver, frame formats (identifiers and data lengths,
//! the arbitration winner's frame, non-nominal reserved bits, DLC above 8, back-to-back frames,
//! stuffing profiles, the validity point). Each test is named after its clause and runs every
//! elementary test case of it on both IUTs. Bit numbers are lower-tester script bits.

use golden::frame::{encode, Field, Frame, Id};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::iso::{
    bits_from, critical_stuffing_base_frames, critical_stuffing_extended_frames,
    encode_with_reserved_bits, loses_arbitration_then_retransmits, lt_sends_to_iut, receives,
    receives_bits, FLAG, INTERMISSION, RX_SOF,
};
use testbenches::protocol_bench::Iut;

/// Data bytes for a frame of `dlc` bytes (the clauses leave the payload open).
fn payload(dlc: usize) -> Vec<u8> {
    [0x5A, 0xC3, 0xFF, 0x00, 0x69, 0xF0, 0x18, 0xE7][..dlc].to_vec()
}

/// 7.1.1: the IUT receives base format data frames with any identifier and 0..8 data bytes.
///
/// ISO 16845-1 7.1.1: identifiers 555h (#1), 2AAh (#2), 000h (#3), 7FFh (#4) and one more (#5: 1D3h
/// here), each with 0 to 8 data bytes: no error flag, the frame acknowledged, the data received as
/// sent.
fn iso_7_1_1_base_format_data_frames(iut: Iut) {
    for (case, id) in [
        (1, 0x555u16),
        (2, 0x2AA),
        (3, 0x000),
        (4, 0x7FF),
        (5, 0x1D3),
    ] {
        for dlc in 0..=8 {
            let frame = Frame::data(Id::standard(id).unwrap(), &payload(dlc)).unwrap();
            receives(iut, &frame, &format!("#{case}, DLC {dlc}"));
        }
    }
}

/// 7.1.2: the IUT receives extended format data frames with any identifier and 0..8 data bytes.
///
/// ISO 16845-1 7.1.2: identifiers 15555555h, 0AAAAAAAh, 0, 1FFFFFFFh and one more (12F0E4D1h
/// here), each with 0 to 8 data bytes.
fn iso_7_1_2_extended_format_data_frames(iut: Iut) {
    let ids = [0x1555_5555u32, 0x0AAA_AAAA, 0, 0x1FFF_FFFF, 0x12F0_E4D1];
    for (case, id) in (1..).zip(ids) {
        for dlc in 0..=8 {
            let frame = Frame::data(Id::extended(id).unwrap(), &payload(dlc)).unwrap();
            receives(iut, &frame, &format!("#{case}, DLC {dlc}"));
        }
    }
}

/// 7.1.3: the IUT receives the frame that wins arbitration against its own.
///
/// ISO 16845-1 7.1.3: the IUT sends a remote frame with all identifier bits 1 and DLC 0; the LT wins
/// at the RTR bit (#1: base against base), at SRR (#2: the LT's base data frame against the IUT's
/// extended frame), at IDE (#3: the LT's base remote frame), at the last base identifier bit (#4:
/// the LT's extended frame against the IUT's base frame), at the last extended identifier bit (#5)
/// and at RTR (#6: extended against extended). The IUT shall become receiver there, receive the
/// LT's frame as sent, send its own again when the bus is idle, and send no error flag.
fn iso_7_1_3_receives_the_frame_that_wins_arbitration(iut: Iut) {
    let base = Id::standard(0x7FF).unwrap();
    let extended = Id::extended(0x1FFF_FFFF).unwrap();
    let base_remote = Frame::remote(base, 0).unwrap();
    let extended_remote = Frame::remote(extended, 0).unwrap();
    let cases = [
        (1, base_remote, Frame::data(base, &[]).unwrap()),
        (2, extended_remote, Frame::data(base, &[]).unwrap()),
        (3, extended_remote, Frame::remote(base, 0).unwrap()),
        (
            4,
            base_remote,
            Frame::remote(Id::extended(0x1FFB_FFFF).unwrap(), 0).unwrap(),
        ),
        (
            5,
            extended_remote,
            Frame::remote(Id::extended(0x1FFF_FFFE).unwrap(), 0).unwrap(),
        ),
        (6, extended_remote, Frame::data(extended, &[]).unwrap()),
    ];
    for (case, mine, theirs) in cases {
        loses_arbitration_then_retransmits(iut, &mine, &theirs, &format!("#{case}"));
    }
}

/// 7.1.4: a base format frame with r0 recessive is accepted.
///
/// ISO 16845-1 7.1.4 (classical CAN): the non-nominal reserved bit r0 = 1 (ISO 11898-1: receivers
/// accept either level of a reserved bit): no error flag, acknowledged, received as sent.
fn iso_7_1_4_base_frame_with_recessive_r0_is_accepted(iut: Iut) {
    let frame = Frame::data(Id::standard(0x3A7).unwrap(), &[0x11, 0x22]).unwrap();
    let (bits, _) = encode_with_reserved_bits(&frame, true, false, true);
    receives_bits(iut, &bits, &frame, "r0 = 1");
}

/// 7.1.5: an extended format frame with non-nominal SRR, r1 or r0 is accepted.
///
/// ISO 16845-1 7.1.5 (classical CAN): (SRR, r0, r1) = 111 (#1), 110 (#2), 101 (#3), 011 (#4),
/// 010 (#5), 001 (#6), 000 (#7) (nominal: SRR 1, r1 0, r0 0).
fn iso_7_1_5_extended_frame_with_non_nominal_srr_r1_r0_is_accepted(iut: Iut) {
    let frame = Frame::data(Id::extended(0x0765_4321).unwrap(), &[0x33]).unwrap();
    let cases = [
        (1, true, true, true),
        (2, true, true, false),
        (3, true, false, true),
        (4, false, true, true),
        (5, false, true, false),
        (6, false, false, true),
        (7, false, false, false),
    ];
    for (case, srr, r0, r1) in cases {
        let (bits, _) = encode_with_reserved_bits(&frame, srr, r1, r0);
        receives_bits(
            iut,
            &bits,
            &frame,
            &format!("#{case}: SRR {srr} r0 {r0} r1 {r1}"),
        );
    }
}

/// 7.1.8: a classical frame with DLC 9..15 carries 8 data bytes.
///
/// ISO 16845-1 7.1.8: DLC 9h..Fh (#1..#7): no error flag, acknowledged, DLC and data received as
/// sent (ISO 11898-1: a DLC above 8 means 8 data bytes).
fn iso_7_1_8_dlc_above_8_is_received_with_8_bytes(iut: Iut) {
    for (case, dlc) in (1..).zip(9..=15u8) {
        let frame = Frame::data_with_dlc(Id::standard(0x4C1).unwrap(), dlc, &payload(8)).unwrap();
        receives(iut, &frame, &format!("#{case}: DLC {dlc}"));
    }
}

/// 7.1.9: two frames without bus idle between them.
///
/// ISO 16845-1 7.1.9: the second frame starts after the second (#1, a SOF in the third
/// intermission bit) or the third (#2) intermission bit of the first; both shall be acknowledged
/// and received, with no error flag.
fn iso_7_1_9_two_frames_without_bus_idle(iut: Iut) {
    let first = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap();
    let second = Frame::data(Id::standard(0x111).unwrap(), &[0x07]).unwrap();
    for (case, gap) in [(1, INTERMISSION - 1), (2, INTERMISSION)] {
        let first_bits: Vec<bool> = encode(&first).bits.iter().by_vals().collect();
        let mut bench = lt_sends_to_iut(iut, &first_bits, gap);
        bench
            .lt()
            .send_bits(encode(&second).bits.iter().by_vals())
            .release(4);
        bench.run(1);
        let ack_1 = RX_SOF + encode(&first).position(Field::AckSlot, 0).unwrap();
        let second_sof = RX_SOF + first_bits.len() + gap;
        let ack_2 = second_sof + encode(&second).position(Field::AckSlot, 0).unwrap();
        assert_eq!(
            bench.iut_dominant_bits(0, ack_2 + 12),
            vec![ack_1, ack_2],
            "#{case}: both acknowledged"
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::Received(first), NodeEvent::Received(second)],
            "#{case}"
        );
    }
}

/// 7.1.10: base format frames with critical stuffing profiles are received.
///
/// ISO 16845-1 7.1.10: the ten frames of the clause's classical-CAN table (#1..#10, some with r0
/// recessive and DLC above 8): no error flag, acknowledged, received as sent.
fn iso_7_1_10_base_frames_with_critical_stuffing(iut: Iut) {
    for (case, (frame, r0)) in (1..).zip(critical_stuffing_base_frames()) {
        let (bits, stuff) = encode_with_reserved_bits(&frame, true, false, r0);
        assert!(!stuff.is_empty(), "#{case}: stuff bits");
        receives_bits(iut, &bits, &frame, &format!("#{case} {frame}"));
    }
}

/// 7.1.11: extended format frames with critical stuffing profiles are received.
///
/// ISO 16845-1 7.1.11: the seven frames of the clause's classical-CAN table (#1..#7).
fn iso_7_1_11_extended_frames_with_critical_stuffing(iut: Iut) {
    for (case, (frame, r1, r0)) in (1..).zip(critical_stuffing_extended_frames()) {
        let (bits, stuff) = encode_with_reserved_bits(&frame, true, r1, r0);
        assert!(!stuff.is_empty(), "#{case}: stuff bits");
        receives_bits(iut, &bits, &frame, &format!("#{case} {frame}"));
    }
}

/// 7.1.12: a receiver takes the frame at the sixth EOF bit.
///
/// ISO 16845-1 7.1.12: the last EOF bit is dominant: the IUT shall take the frame as valid (ISO
/// 11898-1: for receivers a frame is valid when there is no error until the last but one EOF bit),
/// acknowledge it, send no error flag but an overload flag from the next bit.
fn iso_7_1_12_the_frame_is_valid_at_eof_bit_6(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap();
    let encoded = encode(&frame);
    let bits: Vec<bool> = encoded.bits.iter().by_vals().collect();
    let mut bench = lt_sends_to_iut(iut, &bits, 20);
    let last_eof = RX_SOF + bits.len() - 1;
    bench.lt().set_bit(last_eof, Drive::Dominant);
    bench.run(1);
    let mut expected = vec![RX_SOF + encoded.position(Field::AckSlot, 0).unwrap()];
    expected.extend(bits_from(last_eof + 1, FLAG));
    assert_eq!(
        bench.iut_dominant_bits(0, last_eof + 20),
        expected,
        "ACK, then an overload flag"
    );
    assert_eq!(bench.iut_events(), vec![NodeEvent::Received(frame)]);
}

testbenches::on_both_iuts! {
    iso_7_1_1_base_format_data_frames,
    iso_7_1_2_extended_format_data_frames,
    iso_7_1_3_receives_the_frame_that_wins_arbitration,
    iso_7_1_4_base_frame_with_recessive_r0_is_accepted,
    iso_7_1_5_extended_frame_with_non_nominal_srr_r1_r0_is_accepted,
    iso_7_1_8_dlc_above_8_is_received_with_8_bytes,
    iso_7_1_9_two_frames_without_bus_idle,
    iso_7_1_10_base_frames_with_critical_stuffing,
    iso_7_1_11_extended_frames_with_critical_stuffing,
    iso_7_1_12_the_frame_is_valid_at_eof_bit_6,
}
