//! ISO 16845-1:2016 clause 7.2: the IUT as receiver, error detection (bit error in its ACK, stuff,
//! CRC and form errors, the last point at which a frame is still invalid). Each test is named after
//! its clause and runs every elementary test case of it on both IUTs; "a" variants repeat a clause
//! with the IUT error passive. Bit numbers are lower-tester script bits.

use golden::frame::{encode, Field, Frame, Id};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::{
    ecc, BIT, FORM, OTHER, SEG_ACK_DELIM, SEG_ACK_SLOT, SEG_CRC_DELIM, SEG_EOF, STUFF,
};
use testbenches::iso::{
    bits_from, critical_stuffing_base_frames, critical_stuffing_extended_frames,
    data_field_stuffing_payloads, encode_with_reserved_bits, flippable_bit, lt_sends_to_iut, FLAG,
    PASSIVE_LIMIT, RX_SOF,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// The receiver's error state for a clause: active (counters 0) or passive (REC 128, "the IUT is
/// set to error passive state" of the "a" variants).
#[derive(Clone, Copy, PartialEq, Eq)]
enum State {
    Active,
    Passive,
}

/// The LT sends `bits` to a receiving IUT in `state` with `change` applied to the script (bit
/// numbers from [`RX_SOF`]); returns the bench, run to its end.
fn received_with(
    iut: Iut,
    state: State,
    bits: &[bool],
    change: impl FnOnce(&mut ProtocolBench),
) -> ProtocolBench {
    let mut bench = lt_sends_to_iut(iut, bits, 30);
    if state == State::Passive {
        bench.load_counter(false, PASSIVE_LIMIT);
    }
    change(&mut bench);
    bench.run(1);
    bench
}

/// An error detected at script bit `error`: an active flag from the next bit (error-active IUT) or
/// no dominant bit at all (error-passive IUT: a passive flag), the error reported with `code`, REC
/// +1, and the frame not received.
fn assert_error_flag_after(
    bench: &mut ProtocolBench,
    state: State,
    error: usize,
    code: u8,
    what: &str,
) {
    let flag = match state {
        State::Active => bits_from(error + 1, FLAG),
        State::Passive => vec![],
    };
    assert_eq!(
        bench.iut_dominant_bits(error + 1, error + 1 + 2 * FLAG),
        flag,
        "{what}: the error flag after bit {error}"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(code)],
        "{what}: one error, no frame"
    );
    let rec = if state == State::Passive {
        PASSIVE_LIMIT
    } else {
        0
    };
    assert_eq!(bench.rec(), rec + 1, "{what}: REC +1");
}

/// 7.2.1: the IUT's ACK read recessive is a bit error.
///
/// ISO 16845-1 7.2.1: the LT forces the IUT's dominant ACK bit recessive: an active error flag from
/// the next bit (ISO 11898-1: a node sending a dominant ACK monitors it).
fn iso_7_2_1_ack_read_recessive_is_a_bit_error(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap();
    let bits: Vec<bool> = encode(&frame).bits.iter().by_vals().collect();
    let ack = RX_SOF + encode(&frame).position(Field::AckSlot, 0).unwrap();
    let mut bench = received_with(iut, State::Active, &bits, |b| {
        b.lt().set_bit(ack, Drive::ForceRecessive);
    });
    assert_error_flag_after(
        &mut bench,
        State::Active,
        ack,
        ecc(BIT, true, SEG_ACK_SLOT),
        "#1",
    );
}

/// Every stuff bit of every frame inverted in turn: the receiver reads a sixth equal bit, a stuff
/// error there (ISO 11898-1), and flags it from the next bit.
fn every_stuff_bit_inverted(iut: Iut, state: State, frames: Vec<(Frame, Vec<bool>, Vec<usize>)>) {
    for (case, (frame, bits, stuff)) in (1..).zip(frames) {
        assert!(!stuff.is_empty(), "#{case}: stuff bits");
        for bit in stuff {
            // The LT plays the frame up to the inverted stuff bit, then leaves the bus (as the
            // transmitter does once it sees the IUT's error flag).
            let mut sent = bits[..=bit].to_vec();
            sent[bit] = !sent[bit];
            let at = RX_SOF + bit;
            let mut bench = received_with(iut, state, &sent, |_| {});
            let code = bench.bus_errors().first().copied().unwrap_or(0);
            assert_eq!(
                code >> 5,
                STUFF << 1 | 1,
                "#{case} {frame} bit {bit}: stuff error, receiving"
            );
            assert_error_flag_after(
                &mut bench,
                state,
                at,
                code,
                &format!("#{case} {frame} bit {bit}"),
            );
        }
    }
}

fn base_frames() -> Vec<(Frame, Vec<bool>, Vec<usize>)> {
    critical_stuffing_base_frames()
        .into_iter()
        .map(|(frame, r0)| {
            let (bits, stuff) = encode_with_reserved_bits(&frame, true, false, r0);
            (frame, bits, stuff)
        })
        .collect()
}

fn extended_frames() -> Vec<(Frame, Vec<bool>, Vec<usize>)> {
    let mut frames = critical_stuffing_extended_frames();
    frames.push((
        Frame::data(Id::extended(0).unwrap(), &[0x00]).unwrap(),
        false,
        false,
    ));
    frames
        .into_iter()
        .map(|(frame, r1, r0)| {
            let (bits, stuff) = encode_with_reserved_bits(&frame, true, r1, r0);
            (frame, bits, stuff)
        })
        .collect()
}

/// 7.2.2: a stuff error at every stuff bit of base format frames.
///
/// ISO 16845-1 7.2.2: the ten frames of the classical-CAN table; each stuff bit inverted in turn:
/// an active error frame from the next bit.
fn iso_7_2_2_stuff_error_at_every_stuff_bit_of_base_frames(iut: Iut) {
    every_stuff_bit_inverted(iut, State::Active, base_frames());
}

/// 7.2.2 a: the same with the IUT error passive: a passive error flag.
fn iso_7_2_2_a_stuff_errors_of_base_frames_when_passive(iut: Iut) {
    every_stuff_bit_inverted(iut, State::Passive, base_frames());
}

/// 7.2.3: a stuff error at every stuff bit of extended format frames.
///
/// ISO 16845-1 7.2.3: the eight frames of the classical-CAN table; each stuff bit inverted in turn.
/// (The clause's response text repeats 7.1's; its purpose, a stuff error flagged from the next
/// bit, is what is checked.)
fn iso_7_2_3_stuff_error_at_every_stuff_bit_of_extended_frames(iut: Iut) {
    every_stuff_bit_inverted(iut, State::Active, extended_frames());
}

/// 7.2.3 a: the same with the IUT error passive.
fn iso_7_2_3_a_stuff_errors_of_extended_frames_when_passive(iut: Iut) {
    every_stuff_bit_inverted(iut, State::Passive, extended_frames());
}

/// The data-field frames of 7.2.4: the clause defines 64-byte payloads (byte 0, bytes 1..63); a
/// classical frame (ID 555h, DLC 15) carries 8 bytes: byte 0, then 7 bytes of the second value.
/// Only the stuff bits of the data field are inverted.
fn data_field_frames() -> Vec<(Frame, Vec<bool>, Vec<usize>)> {
    data_field_stuffing_payloads()
        .into_iter()
        .map(|bytes| {
            let frame = Frame::data_with_dlc(Id::standard(0x555).unwrap(), 15, &bytes).unwrap();
            let encoded = encode(&frame);
            let stuff = (0..encoded.len())
                .filter(|&i| encoded.tags[i].stuff && encoded.tags[i].field == Field::Data)
                .collect();
            (frame, encoded.bits.iter().by_vals().collect(), stuff)
        })
        .collect()
}

/// 7.2.4: a stuff error at every stuff bit of the data field.
///
/// ISO 16845-1 7.2.4: eight payload patterns (see [`data_field_frames`]): an active error frame
/// from the bit after each inverted stuff bit.
fn iso_7_2_4_stuff_error_at_every_stuff_bit_of_the_data_field(iut: Iut) {
    every_stuff_bit_inverted(iut, State::Active, data_field_frames());
}

/// 7.2.4 a: the same with the IUT error passive: a passive error frame.
fn iso_7_2_4_a_stuff_errors_of_the_data_field_when_passive(iut: Iut) {
    every_stuff_bit_inverted(iut, State::Passive, data_field_frames());
}

/// 7.2.5: CRC errors are detected and flagged after the ACK delimiter.
///
/// ISO 16845-1 7.2.5: a dominant CRC bit made recessive (#1), a recessive one made dominant (#2) (each
/// where the stuffing stays valid), and a recessive SOF followed by identifier 001h (#3: the first
/// dominant identifier bit is taken as SOF, so the receiver reads the frame shifted). The IUT shall
/// not acknowledge and shall send an active error flag from the bit after the ACK delimiter (ISO
/// 11898-1: a CRC error is signalled after the ACK delimiter).
fn iso_7_2_5_crc_errors_are_flagged_after_the_ack_delimiter(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap();
    let encoded = encode(&frame);
    let bits: Vec<bool> = encoded.bits.iter().by_vals().collect();
    let crc =
        encoded.position(Field::Crc, 0).unwrap()..encoded.position(Field::CrcDelim, 0).unwrap();
    let ack_delimiter = RX_SOF + encoded.position(Field::AckDelim, 0).unwrap();
    for (case, level) in [(1, false), (2, true)] {
        let bit = flippable_bit(&bits, crc.clone(), level);
        let mut bench = received_with(iut, State::Active, &bits, |b| {
            b.lt().flip_bit(RX_SOF + bit);
        });
        assert!(
            bench.iut_dominant_bits(RX_SOF, ack_delimiter).is_empty(),
            "#{case}: no ACK"
        );
        assert_error_flag_after(
            &mut bench,
            State::Active,
            ack_delimiter,
            ecc(OTHER, true, SEG_ACK_DELIM),
            &format!("#{case}: CRC bit {bit}"),
        );
    }
    let shifted = Frame::data(Id::standard(0x001).unwrap(), &[0x81, 0x3C]).unwrap();
    let mut shifted_bits: Vec<bool> = encode(&shifted).bits.iter().by_vals().collect();
    shifted_bits[0] = true;
    // The IUT's SOF is identifier bit 1, and the stuff bit after identifier bit 4 is a field bit
    // for it (only 4 equal bits before it): its frame ends where the LT's does.
    let ack_delimiter = RX_SOF + encode(&shifted).position(Field::AckDelim, 0).unwrap();
    let mut bench = received_with(iut, State::Active, &shifted_bits, |_| {});
    assert!(
        bench.iut_dominant_bits(RX_SOF, ack_delimiter).is_empty(),
        "#3: no ACK"
    );
    assert_error_flag_after(
        &mut bench,
        State::Active,
        ack_delimiter,
        ecc(OTHER, true, SEG_ACK_DELIM),
        "#3: recessive SOF",
    );
}

/// A frame for the form-error clauses, with its bits.
fn test_frame() -> (Frame, Vec<bool>) {
    let frame = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap();
    let bits = encode(&frame).bits.iter().by_vals().collect();
    (frame, bits)
}

/// 7.2.6: a CRC error and a dominant CRC delimiter give one flag.
///
/// ISO 16845-1 7.2.6: a frame with a CRC error whose CRC delimiter is dominant: one active error
/// flag, 6 bits, from the bit after the CRC delimiter (the form error comes first and takes the
/// frame).
fn iso_7_2_6_crc_and_form_error_give_one_flag(iut: Iut) {
    let (frame, bits) = test_frame();
    let encoded = encode(&frame);
    let crc =
        encoded.position(Field::Crc, 0).unwrap()..encoded.position(Field::CrcDelim, 0).unwrap();
    let bit = flippable_bit(&bits, crc, false);
    let delimiter = RX_SOF + encoded.position(Field::CrcDelim, 0).unwrap();
    let mut bench = received_with(iut, State::Active, &bits, |b| {
        b.lt()
            .flip_bit(RX_SOF + bit)
            .set_bit(delimiter, Drive::Dominant);
    });
    assert_error_flag_after(
        &mut bench,
        State::Active,
        delimiter,
        ecc(FORM, true, SEG_CRC_DELIM),
        "#1",
    );
}

/// 7.2.7: a dominant CRC delimiter is a form error.
///
/// ISO 16845-1 7.2.7: an active error flag from the bit after the CRC delimiter.
fn iso_7_2_7_dominant_crc_delimiter_is_a_form_error(iut: Iut) {
    let (frame, bits) = test_frame();
    let delimiter = RX_SOF + encode(&frame).position(Field::CrcDelim, 0).unwrap();
    let mut bench = received_with(iut, State::Active, &bits, |b| {
        b.lt().set_bit(delimiter, Drive::Dominant);
    });
    assert_error_flag_after(
        &mut bench,
        State::Active,
        delimiter,
        ecc(FORM, true, SEG_CRC_DELIM),
        "#1",
    );
}

/// 7.2.9: a dominant ACK delimiter is a form error.
///
/// ISO 16845-1 7.2.9: an active error flag from the bit after the ACK delimiter.
fn iso_7_2_9_dominant_ack_delimiter_is_a_form_error(iut: Iut) {
    let (frame, bits) = test_frame();
    let delimiter = RX_SOF + encode(&frame).position(Field::AckDelim, 0).unwrap();
    let mut bench = received_with(iut, State::Active, &bits, |b| {
        b.lt().set_bit(delimiter, Drive::Dominant);
    });
    let ack = RX_SOF + encode(&frame).position(Field::AckSlot, 0).unwrap();
    assert!(bench.iut_dominant_in(ack), "the IUT acknowledged");
    assert_error_flag_after(
        &mut bench,
        State::Active,
        delimiter,
        ecc(FORM, true, SEG_ACK_DELIM),
        "#1",
    );
}

/// 7.2.10: a dominant bit among the first five EOF bits is a form error.
///
/// ISO 16845-1 7.2.10: EOF bit 1..5 dominant (#1..#5): an active error flag from the next bit, the
/// frame not received.
fn iso_7_2_10_dominant_eof_bit_is_a_form_error(iut: Iut) {
    let (frame, bits) = test_frame();
    for eof_bit in 0..5u16 {
        let bit = RX_SOF + encode(&frame).position(Field::Eof, eof_bit).unwrap();
        let mut bench = received_with(iut, State::Active, &bits, |b| {
            b.lt().set_bit(bit, Drive::Dominant);
        });
        assert_error_flag_after(
            &mut bench,
            State::Active,
            bit,
            ecc(FORM, true, SEG_EOF),
            &format!("#{}", eof_bit + 1),
        );
    }
}

/// 7.2.11: the frame is still invalid when EOF bit 6 is dominant.
///
/// ISO 16845-1 7.2.11: the sixth EOF bit dominant: a form error (ISO 11898-1: a receiver takes the
/// frame only when the last but one EOF bit is recessive), an active error flag, and the frame not
/// delivered (on the controller: no RI, the RX buffer unchanged).
fn iso_7_2_11_dominant_eof_bit_6_leaves_the_frame_invalid(iut: Iut) {
    let (frame, bits) = test_frame();
    let bit = RX_SOF + encode(&frame).position(Field::Eof, 5).unwrap();
    let mut bench = received_with(iut, State::Active, &bits, |b| {
        b.lt().set_bit(bit, Drive::Dominant);
    });
    assert_error_flag_after(
        &mut bench,
        State::Active,
        bit,
        ecc(FORM, true, SEG_EOF),
        "#1",
    );
    if let Some(passes) = bench.interrupt_passes() {
        assert!(
            passes.iter().all(|p| p.rmc.is_none_or(|n| n == 0)),
            "no frame in the receive FIFO: {passes:?}"
        );
    }
}

testbenches::on_both_iuts! {
    iso_7_2_1_ack_read_recessive_is_a_bit_error,
    iso_7_2_2_stuff_error_at_every_stuff_bit_of_base_frames,
    iso_7_2_2_a_stuff_errors_of_base_frames_when_passive,
    iso_7_2_3_stuff_error_at_every_stuff_bit_of_extended_frames,
    iso_7_2_3_a_stuff_errors_of_extended_frames_when_passive,
    iso_7_2_4_stuff_error_at_every_stuff_bit_of_the_data_field,
    iso_7_2_4_a_stuff_errors_of_the_data_field_when_passive,
    iso_7_2_5_crc_errors_are_flagged_after_the_ack_delimiter,
    iso_7_2_6_crc_and_form_error_give_one_flag,
    iso_7_2_7_dominant_crc_delimiter_is_a_form_error,
    iso_7_2_9_dominant_ack_delimiter_is_a_form_error,
    iso_7_2_10_dominant_eof_bit_is_a_form_error,
    iso_7_2_11_dominant_eof_bit_6_leaves_the_frame_invalid,
}
