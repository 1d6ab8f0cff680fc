//! Conformance scenarios on errors, arbitration and counters on both IUTs (the RTL core, and the
//! controller through its registers): where the error flag goes on the wire, the counter deltas,
//! the SJA1000 ECC/ALC capture values, what is stored and when a frame is retransmitted. Bit
//! numbers are lower-tester script bits; an error detected at bit e gives a flag e+1..e+6.

use golden::frame::{decode, encode, DecodeErrorKind, Field, Frame, Id, DOMINANT};
use rtl::registers::interrupt;
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::*;
use testbenches::protocol_bench::{
    bits_of, field, first_dominant, flag_after, ErrorInterrupt, Iut, LtScript, ProtocolBench,
    INTEGRATION_BITS,
};

const SOF: usize = INTEGRATION_BITS;

fn frame() -> Frame {
    Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap()
}

fn cr_01_crc_error_is_signalled_after_the_ack_delimiter(iut: Iut) {
    let encoded = encode(&frame());
    let crc0 = field(&encoded, Field::Crc, 0);
    // A CRC bit whose flip keeps the stuffing: the golden decoder then reports a CRC error.
    let flipped = (crc0..crc0 + 15)
        .filter(|&i| !encoded.tags[i].stuff)
        .find(|&i| {
            let mut bits = encoded.bits.clone();
            let v = !bits[i];
            bits.set(i, v);
            matches!(decode(&bits), Err(e) if e.kind == DecodeErrorKind::Crc)
        })
        .expect("a CRC bit that keeps the stuffing");
    let mut bits = bits_of(&encoded);
    bits[flipped] = !bits[flipped];
    let mut bench = ProtocolBench::receive_bits(iut, bits.iter().copied(), None, 20);
    let ack_delimiter = SOF + field(&encoded, Field::AckDelim, 0);
    assert_eq!(
        bench.iut_dominant_bits(0, SOF + bits.len() + 20),
        flag_after(ack_delimiter),
        "no ACK, active flag from the bit after the ACK delimiter"
    );
    assert_eq!(bench.rec(), 1);
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(ecc(OTHER, true, SEG_ACK_DELIM))]
    );
}

fn fe_01_dominant_crc_delimiter_is_a_form_error(iut: Iut) {
    let encoded = encode(&frame());
    let mut bits = bits_of(&encoded);
    let delimiter = field(&encoded, Field::CrcDelim, 0);
    bits[delimiter] = DOMINANT;
    let mut bench = ProtocolBench::receive_bits(iut, bits.iter().copied(), None, 20);
    assert_eq!(
        bench.iut_dominant_bits(0, SOF + bits.len() + 20),
        flag_after(SOF + delimiter),
        "no ACK, flag from the next bit"
    );
    assert_eq!(bench.rec(), 1);
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(ecc(FORM, true, SEG_CRC_DELIM))]
    );
}

fn st_03_received_stuff_errors_in_every_field_and_polarity(iut: Iut) {
    let frames = [
        Frame::data(Id::standard(0x000).unwrap(), &[0xFF, 0x00]).unwrap(),
        golden::worst_case::longest_frame(false, 8),
        golden::worst_case::longest_frame(true, 3),
    ];
    let mut seen = std::collections::BTreeSet::new();
    for frame in &frames {
        let (encoded, extended) = (encode(frame), frame.id().is_extended());
        for s in (0..encoded.len()).filter(|&i| encoded.tags[i].stuff) {
            // The LT stops after the faulty bit (the bus is left to the IUT's error frame).
            let mut bits = bits_of(&encoded)[..=s].to_vec();
            bits[s] = !bits[s];
            let mut bench = ProtocolBench::receive_bits(iut, bits.iter().copied(), None, 20);
            // A stuff bit belongs to the segment of the field bit after it (the engine has moved on).
            let next = encoded.tags[s + 1];
            let segment = match next.field {
                Field::BaseId if next.index < 8 => 0x02,
                Field::BaseId => 0x06,
                Field::Srr => 0x04,
                Field::Rtr if !extended => 0x04,
                Field::Ide => 0x05,
                Field::ExtId if next.index < 5 => 0x07,
                Field::ExtId if next.index < 13 => 0x0F,
                Field::ExtId => 0x0E,
                Field::Rtr => 0x0C,
                Field::R1 => 0x0D,
                Field::R0 => 0x09,
                Field::Dlc => 0x0B,
                Field::Data => 0x0A,
                Field::Crc => 0x08,
                Field::CrcDelim => 0x18,
                other => panic!("stuff bit before {other:?}"),
            };
            seen.insert((format!("{:?}", encoded.tags[s].field), encoded.bits[s]));
            let what = format!("stuff bit {s} ({:?}) inverted", encoded.tags[s].field);
            assert_eq!(
                bench.iut_dominant_bits(SOF + s, SOF + s + 20),
                flag_after(SOF + s),
                "{what}: flag"
            );
            assert_eq!(bench.rec(), 1, "{what}");
            assert_eq!(
                bench.iut_events(),
                vec![NodeEvent::BusError(ecc(STUFF, true, segment))],
                "{what}: not stored, one error"
            );
        }
    }
    for field in ["BaseId", "Data", "Crc"] {
        for level in [false, true] {
            assert!(
                seen.contains(&(field.to_string(), level)),
                "{field} stuff bit {level}: {seen:?}"
            );
        }
    }
    assert!(
        seen.iter().any(|(f, _)| f == "Dlc" || f == "R0"),
        "control field: {seen:?}"
    );
}

fn ak_01_no_acknowledge_is_an_ack_error_and_the_frame_is_retransmitted(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let ack = field(&encoded, Field::AckSlot, 0);
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench.lt().release(ack + 20);
    bench.run(0);
    let mut expected = flag_after(ack);
    expected.push(ack + 18);
    assert_eq!(
        bench.iut_dominant_bits(ack, ack + 19),
        expected,
        "flag from the ACK delimiter, retransmission SOF at ACK slot + 18"
    );
    assert_eq!(bench.tec(), 8);
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(ecc(OTHER, false, SEG_ACK_SLOT))]
    );
}

fn be_01_rt_01_dominant_identifier_bit_read_recessive_is_a_bit_error(iut: Iut) {
    let f = Frame::data(Id::standard(0x0F3).unwrap(), &[0x55]).unwrap();
    let encoded = encode(&f);
    let bit = first_dominant(&encoded, Field::BaseId, 1..12);
    let ack = field(&encoded, Field::AckSlot, 0);
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    // First attempt: the bit is forced recessive. Second attempt (SOF at e + 18): acknowledged.
    let retry = bit + 18;
    bench
        .lt()
        .release(retry + encoded.len() + 4)
        .force(bit, 0, 16, Drive::ForceRecessive)
        .set_bit(retry + ack, Drive::Dominant);
    bench.run(1);
    assert_eq!(
        bench.iut_dominant_bits(bit + 1, bit + 10),
        flag_after(bit),
        "flag after the bit error"
    );
    assert!(bench.iut_dominant_in(retry), "retransmission SOF at e + 18");
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::BusError(ecc(BIT, false, SEG_ID_28_21)),
            NodeEvent::TransmitDone(true)
        ]
    );
    assert_eq!(
        bench.tec(),
        7,
        "RT-01: +8 for the error, -1 for the success"
    );
}

fn ar_01_arbitration_lost_at_every_base_identifier_bit(iut: Iut) {
    for k in 0..11u16 {
        let mine = Frame::data(Id::standard(0x7FF).unwrap(), &[]).unwrap();
        let theirs = Frame::data(Id::standard(0x7FF & !(1 << (10 - k))).unwrap(), &[0xA5]).unwrap();
        let encoded = encode(&theirs);
        let mut bench = ProtocolBench::iut_transmits(iut, &mine);
        bench.lt().send_frame(&encoded).release(6);
        bench.run(1);
        let from = field(&encoded, Field::BaseId, k);
        let ack = field(&encoded, Field::AckSlot, 0);
        let next_sof = encoded.len() + 3;
        assert_eq!(
            bench.iut_dominant_bits(from, next_sof + 1),
            vec![ack, next_sof],
            "loss at bit {k}: recessive from there, ACK of the LT frame, retry after intermission"
        );
        assert_eq!(
            bench.iut_events(),
            vec![
                NodeEvent::ArbitrationLost(k as u8),
                NodeEvent::Received(theirs)
            ],
            "loss at bit {k}"
        );
        assert_eq!((bench.tec(), bench.rec()), (0, 0));
    }
}

fn fr_06_dominant_last_eof_bit_is_an_overload_for_a_receiver(iut: Iut) {
    let encoded = encode(&frame());
    let mut bits = bits_of(&encoded);
    let eof7 = field(&encoded, Field::Eof, 6);
    bits[eof7] = DOMINANT;
    let mut bench = ProtocolBench::receive_bits(iut, bits.iter().copied(), Some(9), 20);
    assert_eq!(
        bench.iut_dominant_bits(SOF + eof7, SOF + eof7 + 20),
        flag_after(SOF + eof7),
        "overload flag from the next bit"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::Received(frame())],
        "valid, no bus error"
    );
    assert_eq!(bench.rec(), 8);
}

fn fr_07_fe_03_dominant_eof_bits_1_to_6_are_form_errors(iut: Iut) {
    let encoded = encode(&frame());
    for k in 0..6 {
        let mut bits = bits_of(&encoded);
        let eof = field(&encoded, Field::Eof, k);
        bits[eof] = DOMINANT;
        let mut bench = ProtocolBench::receive_bits(iut, bits.iter().copied(), Some(9), 20);
        assert_eq!(
            bench.iut_dominant_bits(SOF + eof, SOF + eof + 20),
            flag_after(SOF + eof),
            "EOF bit {}",
            k + 1
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::BusError(ecc(FORM, true, SEG_EOF))],
            "EOF bit {}: not stored",
            k + 1
        );
        assert_eq!(bench.rec(), 9, "EOF bit {}: -1 at the ACK, +1", k + 1);
    }
}

fn fe_02_dominant_ack_delimiter(iut: Iut) {
    let encoded = encode(&frame());
    let mut bits = bits_of(&encoded);
    let delimiter = field(&encoded, Field::AckDelim, 0);
    bits[delimiter] = DOMINANT;
    for (preset, after) in [(9, 9), (0, 1)] {
        let mut bench = ProtocolBench::receive_bits(iut, bits.iter().copied(), Some(preset), 20);
        assert_eq!(
            bench.iut_dominant_bits(SOF + delimiter, SOF + delimiter + 20),
            flag_after(SOF + delimiter),
            "flag from EOF bit 1"
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::BusError(ecc(FORM, true, SEG_ACK_DELIM))]
        );
        assert_eq!(bench.rec(), after, "REC {preset}");
    }
}

fn ec_12_successful_transmission_decrements_tec(iut: Iut) {
    for (before, after) in [(9, 8), (130, 129), (0, 0)] {
        let mut bench = ProtocolBench::iut_transmits_acknowledged(iut, &frame(), before);
        assert_eq!(bench.tec(), after, "TEC {before}");
        assert_eq!(bench.iut_events(), vec![NodeEvent::TransmitDone(true)]);
    }
}

fn ec_13_successful_reception_decrements_rec_and_clamps_passive_values_to_127(iut: Iut) {
    let encoded = encode(&frame());
    for (before, after) in [(9, 8), (130, 127), (0, 0)] {
        let mut bench = ProtocolBench::receive_bits(iut, bits_of(&encoded), Some(before), 4);
        assert_eq!(bench.rec(), after, "REC {before}");
        assert_eq!(bench.iut_events(), vec![NodeEvent::Received(frame())]);
        assert!(!bench.error_passive());
        if let Some(interrupts) = bench.error_interrupts() {
            // The preset takes effect when reset mode is left: above EWLR and passive from 130.
            let expected = match before {
                130 => vec![
                    ErrorInterrupt::new(interrupt::EI | interrupt::EPI, true, (0, 130)),
                    ErrorInterrupt::new(interrupt::EPI, true, (0, 127)),
                ],
                _ => vec![],
            };
            assert_eq!(interrupts, expected, "REC {before}: EPI on leaving passive");
        }
    }
}

testbenches::on_both_iuts! {
    cr_01_crc_error_is_signalled_after_the_ack_delimiter,
    fe_01_dominant_crc_delimiter_is_a_form_error,
    st_03_received_stuff_errors_in_every_field_and_polarity,
    ak_01_no_acknowledge_is_an_ack_error_and_the_frame_is_retransmitted,
    be_01_rt_01_dominant_identifier_bit_read_recessive_is_a_bit_error,
    ar_01_arbitration_lost_at_every_base_identifier_bit,
    fr_06_dominant_last_eof_bit_is_an_overload_for_a_receiver,
    fr_07_fe_03_dominant_eof_bits_1_to_6_are_form_errors,
    fe_02_dominant_ack_delimiter,
    ec_12_successful_transmission_decrements_tec,
    ec_13_successful_reception_decrements_rec_and_clamps_passive_values_to_127,
}
