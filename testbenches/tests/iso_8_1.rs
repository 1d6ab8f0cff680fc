//! ISO 16845-1:2016 clause 8.1: the IUT as transmitter, frame formats (identifiers and data
//! lengths, arbitration at every position, the validity point, stuffing, a SOF taken from the third
//! intermission bit). Each test is named after its clause and runs every elementary test case of it
//! on both IUTs. Bit numbers are lower-tester script bits; script bit 0 is the IUT's SOF.

use golden::frame::{encode, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::iso::{
    ack_offset, bits_from, dominant_bits_of, loses_arbitration_then_retransmits,
    lt_acknowledges_at, lt_sends_at, FLAG,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// Data bytes for a frame of `dlc` bytes (the clauses leave the payload open).
fn payload(dlc: usize) -> Vec<u8> {
    [0xA5, 0x3C, 0x00, 0xFF, 0x96, 0x0F, 0x81, 0x7E][..dlc].to_vec()
}

/// The IUT sends `frame`, the LT acknowledges it: the IUT's bits shall be the frame's, with no
/// error, and the request shall end with success.
fn transmits_exactly(iut: Iut, frame: &Frame, what: &str) {
    let mut bench = ProtocolBench::iut_transmits_acknowledged(iut, frame, 0);
    assert_eq!(
        bench.iut_dominant_bits(0, ack_offset(frame)),
        dominant_bits_of(frame, 0),
        "{what}: {frame} bit by bit, stuff bits included"
    );
    assert_eq!(
        bench.iut_events(),
        [NodeEvent::TransmitDone(true)],
        "{what}"
    );
}

/// 8.1.1: the IUT sends base format data frames with any identifier and 0..8 data bytes.
///
/// ISO 16845-1 8.1.1: identifiers 555h (#1), 2AAh (#2), 000h (#3), 7FFh (#4) and one more (#5: 3C9h
/// here), each with 0 to 8 data bytes; no error flag, and the frame on the bus is the one requested.
fn iso_8_1_1_base_format_data_frames(iut: Iut) {
    for (case, id) in [
        (1, 0x555u16),
        (2, 0x2AA),
        (3, 0x000),
        (4, 0x7FF),
        (5, 0x3C9),
    ] {
        for dlc in 0..=8 {
            let frame = Frame::data(Id::standard(id).unwrap(), &payload(dlc)).unwrap();
            transmits_exactly(iut, &frame, &format!("#{case}, DLC {dlc}"));
        }
    }
}

/// 8.1.2: the IUT sends extended format data frames with any identifier and 0..8 data bytes.
///
/// ISO 16845-1 8.1.2: identifiers 15555555h, 0AAAAAAAh, 0, 1FFFFFFFh and one more (0B3C5A96h
/// here), each with 0 to 8 data bytes.
fn iso_8_1_2_extended_format_data_frames(iut: Iut) {
    let ids = [0x1555_5555u32, 0x0AAA_AAAA, 0, 0x1FFF_FFFF, 0x0B3C_5A96];
    for (case, id) in (1..).zip(ids) {
        for dlc in 0..=8 {
            let frame = Frame::data(Id::extended(id).unwrap(), &payload(dlc)).unwrap();
            transmits_exactly(iut, &frame, &format!("#{case}, DLC {dlc}"));
        }
    }
}

/// The recessive identifier bits of a `width`-bit identifier `id`, as bit masks.
fn recessive_id_bits(id: u32, width: u32) -> impl Iterator<Item = u32> {
    (0..width).map(|k| 1 << k).filter(move |m| id & m != 0)
}

/// 8.1.3: arbitration lost at every recessive bit of a base format identifier.
///
/// ISO 16845-1 8.1.3: the IUT sends identifier 7EFh (10 elementary tests) or 010h (1); the LT forces
/// each recessive identifier bit dominant and continues with a valid frame (here: the IUT's frame
/// with that bit dominant, a smaller identifier). The IUT shall become receiver at that bit, send
/// its frame again once the bus is idle, and send no error flag.
fn iso_8_1_3_arbitration_at_every_base_identifier_bit(iut: Iut) {
    for id in [0x7EFu16, 0x010] {
        let mine = Frame::data(Id::standard(id).unwrap(), &[0x55]).unwrap();
        for mask in recessive_id_bits(id.into(), 11) {
            let theirs = Frame::data(Id::standard(id & !(mask as u16)).unwrap(), &[0x55]).unwrap();
            loses_arbitration_then_retransmits(
                iut,
                &mine,
                &theirs,
                &format!("{id:03X} bit {mask:X}"),
            );
        }
    }
}

/// 8.1.4: arbitration lost at every recessive bit of an extended identifier, at SRR and at IDE.
///
/// ISO 16845-1 8.1.4: the IUT sends identifier 1FBFFFFFh (28 elementary tests) or 00400000h (1),
/// without data, and the LT forces each recessive identifier bit dominant; with 00400000h also SRR
/// (the LT's standard data frame with the same base identifier: its dominant RTR) and IDE (the LT's
/// standard remote frame: equal up to IDE).
fn iso_8_1_4_arbitration_at_every_extended_identifier_bit_srr_and_ide(iut: Iut) {
    for id in [0x1FBF_FFFFu32, 0x0040_0000] {
        let mine = Frame::data(Id::extended(id).unwrap(), &[]).unwrap();
        for mask in recessive_id_bits(id, 29) {
            let theirs = Frame::data(Id::extended(id & !mask).unwrap(), &[]).unwrap();
            loses_arbitration_then_retransmits(
                iut,
                &mine,
                &theirs,
                &format!("{id:08X} bit {mask:X}"),
            );
        }
    }
    let mine = Frame::data(Id::extended(0x0040_0000).unwrap(), &[]).unwrap();
    let base = Id::standard(0x001).unwrap();
    let srr = Frame::data(base, &[]).unwrap();
    loses_arbitration_then_retransmits(iut, &mine, &srr, "SRR");
    let ide = Frame::remote(base, 0).unwrap();
    loses_arbitration_then_retransmits(iut, &mine, &ide, "IDE");
}

/// 8.1.5: the transmitter's frame is valid at the end of EOF.
///
/// ISO 16845-1 8.1.5: the LT makes the first intermission bit after the IUT's frame dominant: an
/// overload condition (ISO 11898-1), not an error. The IUT shall send an overload flag, no error
/// flag, and shall not send its frame again.
fn iso_8_1_5_the_frame_is_valid_before_the_intermission(iut: Iut) {
    let frame = Frame::data(Id::standard(0x123).unwrap(), &payload(2)).unwrap();
    let len = encode(&frame).len();
    let mut bench = ProtocolBench::iut_transmits(iut, &frame);
    lt_acknowledges_at(&mut bench, 0, &frame, 40);
    bench.lt().set_bit(len, Drive::Dominant);
    bench.run(0);
    assert_eq!(
        bench.iut_dominant_bits(len, len + 40),
        bits_from(len + 1, FLAG),
        "an overload flag, then nothing"
    );
    assert_eq!(bench.iut_events(), [NodeEvent::TransmitDone(true)]);
}

/// The frames of 8.1.6 (ISO 16845-1, CBFF column: identifier, control field with RTR in bit 6 and
/// DLC, data).
fn stuffing_frames_base() -> Vec<Frame> {
    let mut first = vec![0xE1; 8];
    first[0] = 0x01;
    let data = |id, bytes: &[u8]| Frame::data(Id::standard(id).unwrap(), bytes).unwrap();
    vec![
        data(0x78, &first),
        data(0x41F, &[0x00]),
        data(0x47F, &[0x1F]),
        data(0x758, &[]),
        data(0x777, &[0x1F]),
        Frame::remote(Id::standard(0x7EF).unwrap(), 2).unwrap(),
    ]
}

/// The frames of 8.1.7 (ISO 16845-1, CBFF column: identifier, control field 18xh = data frame with
/// DLC x, data).
fn stuffing_frames_extended() -> Vec<Frame> {
    let data = |id, bytes: &[u8]| Frame::data(Id::extended(id).unwrap(), bytes).unwrap();
    vec![
        data(0x07C3_0F0F, &[0x3C; 8]),
        data(0x07C0_F0F0, &[0x00]),
        data(0x1FB8_0000, &[0xA0]),
    ]
}

/// 8.1.6: the IUT stuffs a base format frame correctly.
///
/// ISO 16845-1 8.1.6: the six frames of the clause (#1..#6), chosen for their stuffing profiles: no
/// error flag, every stuff bit where ISO 11898-1 puts it (after 5 equal bits, SOF to CRC).
fn iso_8_1_6_stuff_bits_of_base_format_frames(iut: Iut) {
    for (case, frame) in (1..).zip(stuffing_frames_base()) {
        assert!(encode(&frame).stuff_count() > 0, "#{case} has stuff bits");
        transmits_exactly(iut, &frame, &format!("#{case}"));
    }
}

/// 8.1.7: the IUT stuffs an extended format frame correctly.
///
/// ISO 16845-1 8.1.7: the three frames of the clause (#1..#3).
fn iso_8_1_7_stuff_bits_of_extended_format_frames(iut: Iut) {
    for (case, frame) in (1..).zip(stuffing_frames_extended()) {
        assert!(encode(&frame).stuff_count() > 0, "#{case} has stuff bits");
        transmits_exactly(iut, &frame, &format!("#{case}"));
    }
}

/// 8.1.8: after losing arbitration, the IUT takes a SOF in the third intermission bit as its own.
///
/// ISO 16845-1 8.1.8: the LT's frame of higher priority wins against the IUT's; 2 bits into the
/// intermission after it the LT sends a SOF. ISO 11898-1: a node with a frame pending that sees a
/// dominant third intermission bit takes it as a SOF and sends its identifier from the next bit.
/// #1: an identifier starting with 4 dominant bits (with that SOF, 5: the stuff bit follows them);
/// #2: starting with 5 recessive bits.
fn iso_8_1_8_sof_in_intermission_bit_3_after_lost_arbitration(iut: Iut) {
    for (case, id, winner) in [(1, 0x07Fu16, 0x03Fu16), (2, 0x7C0, 0x780)] {
        let mine = Frame::data(Id::standard(id).unwrap(), &[0x0F]).unwrap();
        let theirs = Frame::data(Id::standard(winner).unwrap(), &[0x0F]).unwrap();
        let mut bench = ProtocolBench::iut_transmits(iut, &mine);
        let ack = lt_sends_at(&mut bench, 0, &theirs);
        let sof = encode(&theirs).len() + 2;
        bench.lt().release(2).send_bits([DOMINANT]);
        lt_acknowledges_at(&mut bench, sof, &mine, 4);
        bench.run(0);
        let mut expected = vec![ack];
        expected.extend(
            dominant_bits_of(&mine, sof)
                .into_iter()
                .filter(|&b| b != sof),
        );
        assert_eq!(
            bench.iut_dominant_bits(ack, sof + ack_offset(&mine)),
            expected,
            "#{case}: the identifier from the bit after the LT's SOF, stuffed counting that SOF"
        );
        assert_eq!(encode(&mine).bits[0], DOMINANT);
        assert_eq!(
            encode(&mine).bits[1],
            if case == 1 { DOMINANT } else { RECESSIVE }
        );
        assert_eq!(
            bench.iut_events()[1..],
            [NodeEvent::Received(theirs), NodeEvent::TransmitDone(true)],
            "#{case}"
        );
    }
}

testbenches::on_both_iuts! {
    iso_8_1_1_base_format_data_frames,
    iso_8_1_2_extended_format_data_frames,
    iso_8_1_3_arbitration_at_every_base_identifier_bit,
    iso_8_1_4_arbitration_at_every_extended_identifier_bit_srr_and_ide,
    iso_8_1_5_the_frame_is_valid_before_the_intermission,
    iso_8_1_6_stuff_bits_of_base_format_frames,
    iso_8_1_7_stuff_bits_of_extended_format_frames,
    iso_8_1_8_sof_in_intermission_bit_3_after_lost_arbitration,
}
