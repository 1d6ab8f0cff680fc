//! ISO 16845-1:2016 clause 8.2: the IUT as transmitter, error detection (bit, stuff, form and ACK
//! errors). Each test is named after its clause and runs every elementary test case of it on both
//! IUTs. Bit numbers are lower-tester script bits; script bit 0 is the IUT's SOF.

use golden::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::{
    ecc, BIT, FORM, OTHER, SEG_ACK_DELIM, SEG_ACK_SLOT, SEG_CRC_DELIM, SEG_EOF, STUFF,
};
use testbenches::iso::{
    ack_offset, active_retransmission, bits_from, data_field_stuffing_payloads, dominant_bits_of,
    lt_acknowledges_at, EOF, FLAG,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// The IUT sends `frame`; the LT inverts its bit `bit` (a dominant bit read recessive, or a recessive
/// one read dominant) and acknowledges the retransmission. The IUT shall send an active error flag
/// from the next bit and its frame again as soon as the bus is idle (after the error delimiter and
/// the intermission); the error is reported as an error while transmitting, of type `error_type`
/// (or a bit or stuff error when `None`).
fn corrupted_bit_gives_a_flag_and_a_retransmission(
    iut: Iut,
    frame: &Frame,
    bit: usize,
    error_type: Option<u8>,
    what: &str,
) {
    let encoded = encode(frame);
    let mut bench = ProtocolBench::iut_transmits(iut, frame);
    let again = active_retransmission(bit);
    lt_acknowledges_at(&mut bench, again, frame, 4);
    let inverted = if encoded.bits[bit] == DOMINANT {
        Drive::ForceRecessive
    } else {
        Drive::Dominant
    };
    bench.lt().set_bit(bit, inverted);
    bench.run(0);
    let mut expected: Vec<usize> = dominant_bits_of(frame, 0)
        .into_iter()
        .filter(|&b| b <= bit)
        .collect();
    expected.extend(bits_from(bit + 1, FLAG));
    expected.extend(dominant_bits_of(frame, again));
    assert_eq!(
        bench.iut_dominant_bits(0, again + ack_offset(frame)),
        expected,
        "{what} (bit {bit}): an active error flag from the next bit, the frame again when idle"
    );
    let events = bench.iut_events();
    assert_eq!(events.len(), 2, "{what}: {events:?}");
    let NodeEvent::BusError(code) = events[0] else {
        panic!("{what}: {events:?}");
    };
    assert_eq!(code & 0x20, 0, "{what}: an error while transmitting");
    if let Some(error_type) = error_type {
        assert_eq!(code >> 6, error_type, "{what}: error type");
    } else {
        assert!(
            [BIT, STUFF].contains(&(code >> 6)),
            "{what}: a bit or stuff error"
        );
    }
    assert_eq!(events[1], NodeEvent::TransmitDone(true), "{what}");
}

/// Every field bit of `frame` to corrupt by clauses 8.2.1 and 8.2.2: in the arbitration field only
/// its first dominant bit (a recessive one read dominant is lost arbitration), elsewhere the first
/// dominant and the first recessive bit of each field that has them, up to the CRC sequence.
fn field_bits_to_corrupt(frame: &Frame) -> Vec<(String, usize)> {
    let encoded = encode(frame);
    let mut bits = vec![("SOF".to_string(), 0)];
    let arbitration = [
        Field::BaseId,
        Field::Srr,
        Field::Ide,
        Field::ExtId,
        Field::Rtr,
    ];
    let control = [
        Field::Ide,
        Field::R1,
        Field::R0,
        Field::Dlc,
        Field::Data,
        Field::Crc,
    ];
    for field in arbitration {
        if let Some(p) = first_field_bit(&encoded, field, DOMINANT) {
            if in_arbitration(frame, field) {
                bits.push((format!("dominant {field:?}"), p));
            }
        }
    }
    for field in control {
        if in_arbitration(frame, field) {
            continue;
        }
        for level in [DOMINANT, RECESSIVE] {
            if let Some(p) = first_field_bit(&encoded, field, level) {
                let name = if level == DOMINANT {
                    "dominant"
                } else {
                    "recessive"
                };
                bits.push((format!("{name} {field:?}"), p));
            }
        }
    }
    bits
}

/// Whether `field` belongs to the arbitration field of `frame` (IDE is part of it in an extended
/// frame, of the control field in a base one).
fn in_arbitration(frame: &Frame, field: Field) -> bool {
    match field {
        Field::BaseId | Field::Srr | Field::ExtId => true,
        Field::Ide => frame.id().is_extended(),
        Field::Rtr => true,
        _ => false,
    }
}

/// The first non-stuff bit of `field` at `level`, if any.
fn first_field_bit(encoded: &EncodedFrame, field: Field, level: bool) -> Option<usize> {
    (0..encoded.len()).find(|&i| {
        encoded.tags[i].field == field && !encoded.tags[i].stuff && encoded.bits[i] == level
    })
}

/// 8.2.1: bit errors in every field of a base format frame.
///
/// ISO 16845-1 8.2.1: the LT corrupts, in each field, at least one dominant and one recessive bit
/// (in the arbitration field only dominant bits; not the ACK slot): SOF, identifier, RTR, IDE, r0,
/// DLC, data and CRC. The IUT shall send an active error flag from the next bit and restart its
/// frame as soon as the bus is idle.
fn iso_8_2_1_bit_errors_in_every_field_of_a_base_frame(iut: Iut) {
    let frame = Frame::data(Id::standard(0x4A5).unwrap(), &[0x96, 0x3C]).unwrap();
    for (what, bit) in field_bits_to_corrupt(&frame) {
        corrupted_bit_gives_a_flag_and_a_retransmission(iut, &frame, bit, Some(BIT), &what);
    }
}

/// 8.2.2: bit errors in every field of an extended format frame.
///
/// ISO 16845-1 8.2.2: as 8.2.1 with an extended frame, including a dominant extended identifier bit
/// and r1, r0.
fn iso_8_2_2_bit_errors_in_every_field_of_an_extended_frame(iut: Iut) {
    let frame = Frame::data(Id::extended(0x0A5C_3C5A).unwrap(), &[0x96, 0x3C]).unwrap();
    for (what, bit) in field_bits_to_corrupt(&frame) {
        corrupted_bit_gives_a_flag_and_a_retransmission(iut, &frame, bit, Some(BIT), &what);
    }
}

/// Every stuff bit of `frames`: the LT inverts it, so the IUT reads a sixth bit equal to the five
/// before it. ISO 11898-1: the transmitter monitors every bit it sends, so a stuff bit read wrong is
/// an error, and an error flag follows at the next bit (the clauses' response). Its kind is a bit
/// error, or a stuff error for a recessive stuff bit of the arbitration field read dominant (rule 3
/// exception b); where that field ends for a stuff bit after the extended RTR the standard does not
/// say, so for stuff bits the test accepts either kind and checks the flag and the retransmission.
fn every_stuff_bit_corrupted(iut: Iut, frames: &[Frame]) {
    for (case, frame) in (1..).zip(frames) {
        let encoded = encode(frame);
        let stuff: Vec<usize> = (0..encoded.len())
            .filter(|&i| encoded.tags[i].stuff)
            .collect();
        assert!(!stuff.is_empty(), "#{case} has stuff bits");
        for bit in stuff {
            corrupted_bit_gives_a_flag_and_a_retransmission(
                iut,
                frame,
                bit,
                None,
                &format!("#{case} {frame} stuff bit"),
            );
        }
    }
}

/// 8.2.3: the IUT detects a stuffing violation of its own base format frame at every stuff bit.
///
/// ISO 16845-1 8.2.3: the six base format frames of the clause (those of 8.1.6); every stuff bit in
/// them is corrupted in turn; the IUT shall send an error flag from the next bit and its frame again.
fn iso_8_2_3_every_stuff_bit_of_base_frames(iut: Iut) {
    let mut first = vec![0xE1; 8];
    first[0] = 0x01;
    let data = |id, bytes: &[u8]| Frame::data(Id::standard(id).unwrap(), bytes).unwrap();
    let frames = [
        data(0x78, &first),
        data(0x41F, &[0x00]),
        data(0x47F, &[0x1F]),
        data(0x758, &[]),
        data(0x777, &[0x1F]),
        Frame::remote(Id::standard(0x7EF).unwrap(), 2).unwrap(),
    ];
    every_stuff_bit_corrupted(iut, &frames);
}

/// 8.2.4: the same with the four extended frames of the clause.
///
/// ISO 16845-1 8.2.4: 07C30F0Fh with 8 bytes 3Ch, 07C0F0F0h with 00h, 1FB80000h with A0h,
/// 00000000h with 00h.
fn iso_8_2_4_every_stuff_bit_of_extended_frames(iut: Iut) {
    let data = |id, bytes: &[u8]| Frame::data(Id::extended(id).unwrap(), bytes).unwrap();
    let frames = [
        data(0x07C3_0F0F, &[0x3C; 8]),
        data(0x07C0_F0F0, &[0x00]),
        data(0x1FB8_0000, &[0xA0]),
        data(0, &[0x00]),
    ];
    every_stuff_bit_corrupted(iut, &frames);
}

/// 8.2.5: form errors in the fixed-form fields of the IUT's frame.
///
/// ISO 16845-1 8.2.5: the LT makes the CRC delimiter (#1), the ACK delimiter (#2), EOF bit 1 (#3),
/// 4 (#4) or 7 (#5) dominant: a form error (ISO 11898-1; for the transmitter the last EOF bit too);
/// an error flag from the next bit, the frame again as soon as the bus is idle.
fn iso_8_2_5_form_errors_in_the_fixed_fields(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2A5).unwrap(), &[0x96]).unwrap();
    let encoded = encode(&frame);
    let at = |field, index| encoded.position(field, index).unwrap();
    let cases = [
        (1, at(Field::CrcDelim, 0), SEG_CRC_DELIM),
        (2, at(Field::AckDelim, 0), SEG_ACK_DELIM),
        (3, at(Field::Eof, 0), SEG_EOF),
        (4, at(Field::Eof, 3), SEG_EOF),
        (5, at(Field::Eof, EOF as u16 - 1), SEG_EOF),
    ];
    for (case, bit, segment) in cases {
        let mut bench = ProtocolBench::iut_transmits(iut, &frame);
        lt_acknowledges_at(&mut bench, 0, &frame, 0);
        bench.lt().set_bit(bit, Drive::Dominant);
        let again = active_retransmission(bit);
        lt_acknowledges_at(&mut bench, again, &frame, 4);
        bench.run(0);
        let mut expected = dominant_bits_of(&frame, 0);
        expected.extend(bits_from(bit + 1, FLAG));
        expected.extend(dominant_bits_of(&frame, again));
        assert_eq!(
            bench.iut_dominant_bits(0, again + ack_offset(&frame)),
            expected,
            "#{case}: an error flag after the form error, then the frame again"
        );
        assert_eq!(
            bench.iut_events(),
            [
                NodeEvent::BusError(ecc(FORM, false, segment)),
                NodeEvent::TransmitDone(true)
            ],
            "#{case}"
        );
    }
}

/// 8.2.6: an ACK error.
///
/// ISO 16845-1 8.2.6: nobody acknowledges the IUT's base format frame: an ACK error, an error flag
/// from the bit after the (1-bit) ACK slot, the frame again as soon as the bus is idle.
fn iso_8_2_6_ack_error(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2A5).unwrap(), &[0x96]).unwrap();
    let ack = ack_offset(&frame);
    let mut bench = ProtocolBench::iut_transmits(iut, &frame);
    let again = active_retransmission(ack);
    lt_acknowledges_at(&mut bench, again, &frame, 4);
    bench.run(0);
    let mut expected = dominant_bits_of(&frame, 0);
    expected.extend(bits_from(ack + 1, FLAG));
    expected.extend(dominant_bits_of(&frame, again));
    assert_eq!(
        bench.iut_dominant_bits(0, again + ack_offset(&frame)),
        expected
    );
    assert_eq!(
        bench.iut_events(),
        [
            NodeEvent::BusError(ecc(OTHER, false, SEG_ACK_SLOT)),
            NodeEvent::TransmitDone(true)
        ]
    );
}

/// 8.2.8: every stuff bit of the data field corrupted.
///
/// ISO 16845-1 8.2.8 defines 64-byte payloads (data byte 0 and bytes 1..63) with 126 stuff bits
/// each; a classical frame carries 8 bytes, so each of the clause's eight payload patterns is sent
/// as byte 0 followed by 7 bytes of the second value, and every stuff bit in its data field is
/// inverted in turn: an active error flag from the next bit.
fn iso_8_2_8_every_stuff_bit_of_the_data_field(iut: Iut) {
    for bytes in data_field_stuffing_payloads() {
        let frame = Frame::data(Id::standard(0x555).unwrap(), &bytes).unwrap();
        let encoded = encode(&frame);
        let data_stuff: Vec<usize> = (0..encoded.len())
            .filter(|&i| encoded.tags[i].stuff && encoded.tags[i].field == Field::Data)
            .collect();
        assert!(!data_stuff.is_empty(), "{frame}: stuff bits in the data");
        for bit in data_stuff {
            corrupted_bit_gives_a_flag_and_a_retransmission(
                iut,
                &frame,
                bit,
                Some(BIT),
                &format!("{frame} data stuff bit"),
            );
        }
    }
}

testbenches::on_both_iuts! {
    iso_8_2_1_bit_errors_in_every_field_of_a_base_frame,
    iso_8_2_2_bit_errors_in_every_field_of_an_extended_frame,
    iso_8_2_3_every_stuff_bit_of_base_frames,
    iso_8_2_4_every_stuff_bit_of_extended_frames,
    iso_8_2_5_form_errors_in_the_fixed_fields,
    iso_8_2_6_ack_error,
    iso_8_2_8_every_stuff_bit_of_the_data_field,
}
