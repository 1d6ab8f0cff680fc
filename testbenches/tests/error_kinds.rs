//! Conformance scenarios on the kinds of errors (groups ST, CR, FE, BE and FT-05/06) on both IUTs
//! (the RTL core, and the controller through its registers): stuff errors around the CRC and in the
//! IUT's own stuff bits, CRC errors, form errors of the fixed-form fields, the error and overload
//! delimiters, bit errors of a transmitter in every field and in flags, and overload frames after
//! the IUT's own frame.
//!
//! Bit numbers are lower-tester script bits. On the receive side the LT plays [`INTEGRATION_BITS`] idle
//! bits first, so the frame's wire bit i is script bit `SOF + i`; on the transmit side the LT script
//! starts at the IUT's SOF, so wire bit i is script bit i. An error detected at bit e gives a flag
//! e+1..e+6, delimiter e+7..e+14, intermission e+15..e+17 and (error-active transmitter) the
//! retransmission SOF at e+18. Every position is computed from the golden encoding (`golden::frame`).

use golden::frame::{
    decode, encode, DecodeErrorKind, EncodedFrame, Field, Frame, Id, DOMINANT, RECESSIVE,
};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use sim::nodes::lower_tester::LowerTester;
use testbenches::ecc::*;
use testbenches::protocol_bench::{
    bits_of, field, flag_after, Iut, LtScript, ProtocolBench, INTEGRATION_BITS,
};

const SOF: usize = INTEGRATION_BITS;

fn frame() -> Frame {
    Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap()
}

/// The golden decoder's verdict on a wire bit list (followed by an idle bus).
fn golden(bits: &[bool]) -> Result<golden::frame::DecodedFrame, golden::frame::DecodeError> {
    // bitvec is no dependency of the testbenches: reuse (and empty) an encoded frame's bit vector.
    let mut wire = encode(&frame()).bits;
    wire.clear();
    wire.extend(bits.iter().copied());
    wire.extend(std::iter::repeat_n(RECESSIVE, 40));
    decode(&wire)
}

/// ECC segment of the field bit at wire position `i` of `encoded` (for an error on a stuff bit: pass
/// the position of the field bit after it, the engine's convention).
fn segment_of(encoded: &EncodedFrame, i: usize) -> u8 {
    let tag = encoded.tags[i];
    let extended = encoded.position(Field::Srr, 0).is_some();
    match tag.field {
        Field::Sof => SEG_SOF,
        Field::BaseId if tag.index < 8 => SEG_ID_28_21,
        Field::BaseId => SEG_ID_20_18,
        Field::Srr => SEG_SRTR,
        Field::Rtr if !extended => SEG_SRTR,
        Field::Ide => SEG_IDE,
        Field::ExtId if tag.index < 5 => SEG_ID_17_13,
        Field::ExtId if tag.index < 13 => SEG_ID_12_5,
        Field::ExtId => SEG_ID_4_0,
        Field::Rtr => SEG_RTR,
        Field::R1 => SEG_R1,
        Field::R0 => SEG_R0,
        Field::Dlc => SEG_DLC,
        Field::Data => SEG_DATA,
        Field::Crc => SEG_CRC,
        Field::CrcDelim => SEG_CRC_DELIM,
        Field::AckSlot => SEG_ACK_SLOT,
        Field::AckDelim => SEG_ACK_DELIM,
        Field::Eof => SEG_EOF,
    }
}

/// The IUT transmits `f` with TEC preset to `tec`; the LT script (from the IUT's SOF) is `len`
/// released bits edited by `edit`.
fn transmit_with(
    iut: Iut,
    f: &Frame,
    tec: u8,
    len: usize,
    edit: impl FnOnce(&mut LowerTester),
) -> ProtocolBench {
    let mut bench = ProtocolBench::iut_transmits_with(iut, f, tec, false);
    bench.lt().release(len);
    edit(bench.lt());
    bench.run(1);
    bench
}

/// The IUT transmits `f` (TEC preset `tec`); `inject` makes it detect an error at bit `e` of the first
/// attempt; the retransmission (SOF at e + 18) is acknowledged.
fn transmitter_error_then_acked_retry(
    iut: Iut,
    f: &Frame,
    tec: u8,
    e: usize,
    inject: impl FnOnce(&mut LowerTester),
) -> ProtocolBench {
    let encoded = encode(f);
    let ack = field(&encoded, Field::AckSlot, 0);
    let retry = e + 18;
    transmit_with(iut, f, tec, retry + encoded.len() + 4, |lt| {
        lt.set_bit(retry + ack, Drive::Dominant);
        inject(lt);
    })
}

/// Inverts the IUT's bit `i` (script bit `at`): a dominant bit is forced recessive over the whole bit,
/// a recessive one is driven dominant.
fn invert(lt: &mut LowerTester, at: usize, level: bool) {
    if level == DOMINANT {
        let quanta = lt.quanta_per_bit();
        lt.force(at, 0, quanta, Drive::ForceRecessive);
    } else {
        lt.set_bit(at, Drive::Dominant);
    }
}

/// Error flag after bit `e`, recessive delimiter and intermission, retransmission SOF at e + 18 and
/// then exactly the golden bits of `f` (ACK slot recessive: the LT acknowledges).
fn assert_flag_and_retry(bench: &ProtocolBench, f: &Frame, e: usize, what: &str) {
    let encoded = encode(f);
    let retry = e + 18;
    let mut expected = flag_after(e);
    expected.extend(
        (0..encoded.len())
            .filter(|&i| encoded.bits[i] == DOMINANT)
            .map(|i| retry + i),
    );
    assert_eq!(
        bench.iut_dominant_bits(e + 1, retry + encoded.len()),
        expected,
        "{what}: flag from e + 1, retransmission SOF at e + 18 and the golden frame"
    );
}

// ---------------------------------------------------------------------------------------------------
// ST: bit stuffing

fn st_04_missing_stuff_bit_after_the_crc(iut: Iut) {
    // A standard DLC-0 frame whose CRC ends with 5 recessive wire bits: a dominant stuff bit follows
    // the last CRC bit (the first such identifier in ascending order).
    let (f, encoded, s) = (0..=0x7FFu16)
        .map(|id| Frame::data(Id::standard(id).unwrap(), &[]).unwrap())
        .find_map(|f| {
            let encoded = encode(&f);
            let s = field(&encoded, Field::Crc, 14) + 1;
            (encoded.tags[s].stuff && encoded.bits[s] == DOMINANT).then_some((f, encoded, s))
        })
        .expect("a CRC followed by a dominant stuff bit");
    assert_eq!(
        field(&encoded, Field::CrcDelim, 0),
        s + 1,
        "{f}: the stuff bit sits between the CRC and its delimiter"
    );
    // The LT sends a recessive bit instead of the stuff bit (the CRC delimiter comes one bit early),
    // then leaves the bus to the IUT: the sixth recessive bit is a stuff error.
    let mut bits = bits_of(&encoded)[..=s].to_vec();
    bits[s] = RECESSIVE;
    let verdict = golden(&bits).unwrap_err();
    assert_eq!(
        (verdict.kind, verdict.position),
        (DecodeErrorKind::Stuff, s),
        "golden: stuff error at the missing stuff bit"
    );
    let mut bench = ProtocolBench::receive_bits(iut, bits.iter().copied(), None, 30);
    assert_eq!(
        bench.iut_dominant_bits(0, SOF + s + 30),
        flag_after(SOF + s),
        "{f}: no ACK, flag from the bit after the missing stuff bit"
    );
    assert_eq!(bench.rec(), 1);
    // The stuff bit's segment is that of the field bit after it: the CRC delimiter.
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(ecc(STUFF, true, SEG_CRC_DELIM))],
        "{f}: stuff/RX/CRC delimiter, not stored"
    );
}

/// Stuff bits of `encoded` after the arbitration field (control field, data, CRC).
fn stuff_bits_after_arbitration(encoded: &EncodedFrame) -> Vec<usize> {
    let extended = encoded.position(Field::Srr, 0).is_some();
    (0..encoded.len())
        .filter(|&i| encoded.tags[i].stuff)
        .filter(|&i| match encoded.tags[i].field {
            // In a standard frame IDE belongs to the control field; in an extended one to arbitration.
            Field::Ide => !extended,
            Field::R1 | Field::R0 | Field::Dlc | Field::Data | Field::Crc => true,
            _ => false,
        })
        .collect()
}

fn stuff_category(field: Field) -> &'static str {
    match field {
        Field::Data => "data",
        Field::Crc => "CRC",
        _ => "control",
    }
}

fn st_05_inverted_stuff_bit_of_the_iut_is_a_bit_error(iut: Iut) {
    let frames = [
        frame(),
        Frame::data(Id::standard(0x000).unwrap(), &[0xFF, 0x00]).unwrap(),
        // Recessive control-field stuff bits: in 0x7E0# and 0x7C1#0F the dominant run through RTR, IDE,
        // r0 and DLC 0000/0001 gets a recessive stuff bit after DLC bit 1.
        Frame::data(Id::standard(0x7E0).unwrap(), &[]).unwrap(),
        Frame::data(Id::standard(0x7C1).unwrap(), &[0x0F]).unwrap(),
        // A dominant control-field stuff bit needs five recessive bits there; IDE/r1 and r0 are
        // dominant, so only a recessive stuff bit after r0 followed by DLC 1111 makes one: ID 0x0A4
        // ends "100", so ID bits 9..10, RTR, IDE and r0 are five dominant bits, the recessive stuff bit
        // after r0 and DLC 15 = 1111 are five recessive bits, a dominant stuff bit follows DLC bit 3.
        Frame::data_with_dlc(Id::standard(0x0A4).unwrap(), 15, &[0x5A; 8]).unwrap(),
        golden::worst_case::longest_frame(false, 8),
        golden::worst_case::longest_frame(true, 3),
    ];
    let mut seen = std::collections::BTreeSet::new();
    for f in &frames {
        let encoded = encode(f);
        for s in stuff_bits_after_arbitration(&encoded) {
            let level = encoded.bits[s];
            let mut bench =
                transmitter_error_then_acked_retry(iut, f, 0, s, |lt| invert(lt, s, level));
            let what = format!(
                "{f}: stuff bit {s} after {:?} {} ({})",
                encoded.tags[s].field,
                encoded.tags[s].index,
                if level == DOMINANT {
                    "dominant"
                } else {
                    "recessive"
                }
            );
            assert_flag_and_retry(&bench, f, s, &what);
            // Choice: a bit error (not a stuff error); the segment is that of the field bit after it.
            assert_eq!(
                bench.iut_events(),
                vec![
                    NodeEvent::BusError(ecc(BIT, false, segment_of(&encoded, s + 1))),
                    NodeEvent::TransmitDone(true)
                ],
                "{what}"
            );
            assert_eq!(bench.tec(), 7, "{what}: +8, then -1 for the retry");
            seen.insert((stuff_category(encoded.tags[s].field), level));
        }
    }
    for category in ["control", "data", "CRC"] {
        for level in [DOMINANT, RECESSIVE] {
            assert!(
                seen.contains(&(category, level)),
                "no {category} stuff bit of level {level} covered: {seen:?}"
            );
        }
    }
}

fn st_06_ec_07_recessive_stuff_bit_in_the_identifier_forced_dominant(iut: Iut) {
    // Identifiers starting with dominant runs: SOF + four dominant ID bits -> a recessive stuff bit in
    // the base identifier; the extended identifier 0x3 has 16 dominant bits in ID.17..0 (recessive
    // stuff bits in the extended identifier too).
    let frames = [
        Frame::data(Id::standard(0x003).unwrap(), &[0x5A]).unwrap(),
        Frame::data(Id::extended(0x0000_0003).unwrap(), &[0x5A]).unwrap(),
    ];
    let mut covered = 0;
    for f in &frames {
        let encoded = encode(f);
        let stuff: Vec<usize> = (0..encoded.len())
            .filter(|&i| encoded.tags[i].stuff && encoded.bits[i] == RECESSIVE)
            .filter(|&i| matches!(encoded.tags[i].field, Field::BaseId | Field::ExtId))
            .collect();
        assert!(!stuff.is_empty(), "{f}: recessive identifier stuff bits");
        for &s in &stuff {
            for (tec, after) in [(0, 0), (9, 8)] {
                let mut bench = transmitter_error_then_acked_retry(iut, f, tec, s, |lt| {
                    lt.set_bit(s, Drive::Dominant);
                });
                let what = format!(
                    "{f}: recessive stuff bit {s} after {:?} {}, TEC {tec}",
                    encoded.tags[s].field, encoded.tags[s].index
                );
                assert_flag_and_retry(&bench, f, s, &what);
                let events = bench.iut_events();
                assert_eq!(
                    events.len(),
                    2,
                    "{what}: one error, then success: {events:?}"
                );
                // Not an arbitration loss: a stuff error (ISO 11898-1 names it so in rule 3 exception
                // b), unlike an inverted own stuff bit outside arbitration, which is a bit error.
                let NodeEvent::BusError(code) = events[0] else {
                    panic!("{what}: {events:?}");
                };
                assert_eq!(code >> 6, STUFF, "{what}: ECC {code:#04x}");
                assert_eq!(
                    code & 0x3F,
                    ecc(0, false, segment_of(&encoded, s + 1)),
                    "{what}: ECC {code:#04x} TX, segment of the identifier bit after the stuff bit"
                );
                assert_eq!(events[1], NodeEvent::TransmitDone(true), "{what}");
                assert_eq!(
                    bench.tec(),
                    after,
                    "{what}: rule 3 exception b (no +8), -1 for the retry"
                );
                covered += 1;
            }
        }
    }
    assert!(covered >= 4);
}

// ---------------------------------------------------------------------------------------------------
// CR: CRC

/// A non-stuff bit of `f`'s field `which` with level `level` whose flip keeps the stuffing: the golden
/// decoder still reads the whole frame and reports a CRC error (after the ACK delimiter).
fn flip_giving_crc_error(encoded: &EncodedFrame, which: Field, level: Option<bool>) -> usize {
    let ack_delim = field(encoded, Field::AckDelim, 0);
    (0..encoded.len())
        .filter(|&i| encoded.tags[i].field == which && !encoded.tags[i].stuff)
        .filter(|&i| level.is_none_or(|l| encoded.bits[i] == l))
        .find(|&i| {
            let mut bits = bits_of(encoded);
            bits[i] = !bits[i];
            matches!(golden(&bits), Err(e) if e.kind == DecodeErrorKind::Crc && e.position == ack_delim + 1)
        })
        .expect("a flip that keeps the stuffing")
}

fn cr_02_flipped_data_bit_and_flipped_recessive_crc_bit(iut: Iut) {
    let encoded = encode(&frame());
    let data = flip_giving_crc_error(&encoded, Field::Data, None);
    let crc = flip_giving_crc_error(&encoded, Field::Crc, Some(RECESSIVE));
    let ack_delim = field(&encoded, Field::AckDelim, 0);
    for flips in [vec![data], vec![crc], vec![data, crc]] {
        let mut bits = bits_of(&encoded);
        for &i in &flips {
            bits[i] = !bits[i];
        }
        let verdict = golden(&bits).unwrap_err();
        assert_eq!(
            (verdict.kind, verdict.position),
            (DecodeErrorKind::Crc, ack_delim + 1),
            "golden, flips {flips:?}"
        );
        let mut bench = ProtocolBench::receive_bits(iut, bits.iter().copied(), None, 20);
        assert_eq!(
            bench.iut_dominant_bits(0, SOF + bits.len() + 20),
            flag_after(SOF + ack_delim),
            "flips {flips:?}: no ACK, active flag from the bit after the ACK delimiter"
        );
        assert_eq!(bench.rec(), 1, "flips {flips:?}");
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::BusError(ecc(OTHER, true, SEG_ACK_DELIM))],
            "flips {flips:?}: ECC 0xFB, not stored"
        );
    }
}

fn cr_03_crc_error_and_dominant_crc_delimiter_give_one_flag(iut: Iut) {
    let encoded = encode(&frame());
    let crc = flip_giving_crc_error(&encoded, Field::Crc, None);
    let delimiter = field(&encoded, Field::CrcDelim, 0);
    let mut bits = bits_of(&encoded);
    bits[crc] = !bits[crc];
    bits[delimiter] = DOMINANT;
    let verdict = golden(&bits).unwrap_err();
    assert_eq!(
        (verdict.kind, verdict.position),
        (DecodeErrorKind::Form, delimiter),
        "golden: the form error comes first"
    );
    // The LT stops after the delimiter.
    let mut bench = ProtocolBench::receive_bits(iut, bits[..=delimiter].iter().copied(), None, 30);
    assert_eq!(
        bench.iut_dominant_bits(0, SOF + delimiter + 30),
        flag_after(SOF + delimiter),
        "exactly one flag, from the bit after the CRC delimiter; no ACK"
    );
    assert_eq!(bench.rec(), 1, "REC +1, not +2");
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(ecc(FORM, true, SEG_CRC_DELIM))]
    );
}

/// The bits the IUT takes for a frame when the LT sends `f` with a recessive SOF: from the first
/// dominant bit (shift k) on.
fn recessive_sof(f: &Frame) -> (Vec<bool>, usize, golden::frame::DecodeError) {
    let mut bits = bits_of(&encode(f));
    bits[0] = RECESSIVE;
    let k = bits.iter().position(|&b| b == DOMINANT).unwrap();
    let verdict = golden(&bits[k..]).expect_err("the shifted bits are no valid frame");
    (bits, k, verdict)
}

fn cr_04_recessive_sof_moves_the_frame(iut: Iut) {
    // The catalog expects a CRC error. Whether the shifted bit stream gives a CRC error depends on the
    // frame: over standard IDs × {DLC 0, 813C, 55} the golden model finds ~16 % CRC errors, the rest are
    // stuff errors (~82 %) and form errors. The CRC case (the catalog's) is the first identifier from
    // 0x2C5 up with the 813C payload whose shifted stream decodes to a CRC error; the stuff case is
    // `frame()` itself and the form case the first identifier giving a form error. They are:
    // 783#813C (ID bits 0..3 recessive, IUT SOF at wire bit 5; golden: CRC error, flag from shifted bit
    // 40), 2C5#813C (SOF at wire bit 1; stuff error at shifted bit 52, in the data) and 780#813C (SOF at
    // wire bit 5; form error at the shifted ACK delimiter, bit 39).
    let search = |kind: DecodeErrorKind| {
        (0x2C5..=0x7FFu16)
            .chain(0..0x2C5)
            .map(|id| Frame::data(Id::standard(id).unwrap(), &[0x81, 0x3C]).unwrap())
            .find(|f| recessive_sof(f).2.kind == kind)
            .unwrap()
    };
    let cases = [
        (search(DecodeErrorKind::Crc), OTHER),
        (frame(), STUFF),
        (search(DecodeErrorKind::Form), FORM),
    ];
    for (f, kind) in cases {
        let (bits, k, verdict) = recessive_sof(&f);
        let expected_kind = match kind {
            OTHER => DecodeErrorKind::Crc,
            STUFF => DecodeErrorKind::Stuff,
            _ => DecodeErrorKind::Form,
        };
        assert_eq!(verdict.kind, expected_kind, "{f}: {verdict}");
        // The golden position is where the error is detected (CRC: the bit after the ACK delimiter,
        // where the flag starts; stuff and form: the faulty bit). Error bit e in script bits:
        let e = SOF + k + verdict.position - usize::from(verdict.kind == DecodeErrorKind::Crc);
        // The LT stops after the bit at which the IUT detects the error (it sends wire bits ..=e).
        let sent = (e - SOF + 1).min(bits.len());
        let mut bench = ProtocolBench::receive_bits(iut, bits[..sent].iter().copied(), None, 30);
        let what = format!(
            "{f} with a recessive SOF: the IUT's frame starts at wire bit {k}; golden: {verdict}"
        );
        assert_eq!(
            bench.iut_dominant_bits(0, SOF + sent + 30),
            flag_after(e),
            "{what}: no ACK, flag from the bit after the error"
        );
        assert_eq!(bench.rec(), 1, "{what}");
        let events = bench.iut_events();
        assert!(
            matches!(events[..], [NodeEvent::BusError(code)] if code >> 5 == kind << 1 | 1),
            "{what}: one error of type {kind} (RX): {events:?}"
        );
        if kind == OTHER {
            assert_eq!(
                events,
                vec![NodeEvent::BusError(ecc(OTHER, true, SEG_ACK_DELIM))],
                "{what}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// FE: form errors

fn fe_04_case(k: usize) -> (Frame, usize, u8, &'static str) {
    let f = frame();
    let encoded = encode(&f);
    match k {
        0 => (
            f,
            field(&encoded, Field::CrcDelim, 0),
            SEG_CRC_DELIM,
            "CRC delimiter",
        ),
        1 => (
            f,
            field(&encoded, Field::AckDelim, 0),
            SEG_ACK_DELIM,
            "ACK delimiter",
        ),
        2 => (f, field(&encoded, Field::Eof, 0), SEG_EOF, "EOF bit 1"),
        3 => (f, field(&encoded, Field::Eof, 3), SEG_EOF, "EOF bit 4"),
        _ => (f, field(&encoded, Field::Eof, 6), SEG_EOF, "EOF bit 7"),
    }
}

/// The IUT transmits; the LT acknowledges (when the ACK slot comes before the fault) and drives the
/// recessive fixed-form bit `e` dominant; the retry is acknowledged.
fn transmitter_form_error(iut: Iut, f: &Frame, e: usize, segment: u8, what: &str) {
    let encoded = encode(f);
    let ack = field(&encoded, Field::AckSlot, 0);
    let mut bench = transmitter_error_then_acked_retry(iut, f, 0, e, |lt| {
        if ack < e {
            lt.set_bit(ack, Drive::Dominant);
        }
        lt.set_bit(e, Drive::Dominant);
    });
    assert_flag_and_retry(&bench, f, e, what);
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::BusError(ecc(FORM, false, segment)),
            NodeEvent::TransmitDone(true)
        ],
        "{what}: form/TX, no TI before the successful retry"
    );
    assert_eq!(bench.tec(), 7, "{what}: +8, then -1 (net +7)");
}

fn fe_04_transmitter_form_errors(iut: Iut) {
    for k in 0..5 {
        let (f, e, segment, what) = fe_04_case(k);
        transmitter_form_error(iut, &f, e, segment, what);
    }
}

fn ft_05_dominant_last_eof_bit_of_own_frame_is_a_form_error(iut: Iut) {
    let (f, e, segment, what) = fe_04_case(4);
    transmitter_form_error(iut, &f, e, segment, what);
}

/// Receiver stuff error at script bit [`STUFF_ERROR_AT`] = 19 (SOF and ID bits 0..3 are five dominant
/// bits at 14..18; ID bit 4, dominant too, sits where the stuff bit belongs): flag 20..25, error
/// delimiter bits 1..8 at 26..33, intermission 34..36.
const STUFF_ERROR_AT: usize = SOF + 5;
/// ECC of that error: stuff/RX/ID.28–21 (the field bit at the error, ID bit 4).
const STUFF_ERROR_ECC: u8 = 0xA2;

/// Script bit of error-delimiter bit `k` (1..8) after the stuff error.
fn error_delimiter_bit(k: usize) -> usize {
    STUFF_ERROR_AT + 6 + k
}

/// The IUT detects the stuff error; the LT then drives `dominant` bits dominant.
fn receiver_error_with_dominant(iut: Iut, rec: Option<u8>, dominant: &[usize]) -> ProtocolBench {
    ProtocolBench::receive_with(iut, [DOMINANT; 6], rec, 60, |lt| {
        for &b in dominant {
            lt.set_bit(b, Drive::Dominant);
        }
    })
}

/// The IUT sends two flags: after the stuff error, and after bit `d`.
fn assert_flags_after_stuff_error_and(bench: &mut ProtocolBench, d: usize, why: &str) {
    let mut expected = flag_after(STUFF_ERROR_AT);
    expected.extend(flag_after(d));
    assert_eq!(
        bench.iut_dominant_bits(STUFF_ERROR_AT, d + 30),
        expected,
        "{why}"
    );
}

fn fe_05_dominant_error_delimiter_bits(iut: Iut) {
    assert_eq!(STUFF_ERROR_ECC, ecc(STUFF, true, SEG_ID_28_21));
    for k in [2, 4, 7] {
        let d = error_delimiter_bit(k);
        let mut bench = receiver_error_with_dominant(iut, None, &[d]);
        assert_flags_after_stuff_error_and(
            &mut bench,
            d,
            &format!("error delimiter bit {k} dominant: a new active flag from the next bit"),
        );
        assert_eq!(
            bench.iut_events(),
            vec![
                NodeEvent::BusError(STUFF_ERROR_ECC),
                NodeEvent::BusError(ecc(FORM, true, SEG_ERROR_DELIM))
            ],
            "delimiter bit {k}: form/RX/error delimiter"
        );
        assert_eq!(bench.rec(), 2, "delimiter bit {k}: +1 +1");
    }
}

fn fe_06_dominant_last_error_delimiter_bit_is_an_overload(iut: Iut) {
    let d = error_delimiter_bit(8);
    let mut bench = receiver_error_with_dominant(iut, None, &[d]);
    assert_flags_after_stuff_error_and(
        &mut bench,
        d,
        "error delimiter bit 8 dominant: overload flag from the next bit",
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(STUFF_ERROR_ECC)],
        "no new error"
    );
    assert_eq!(bench.rec(), 1, "no extra counter change");
}

/// The IUT receives `frame()`; the LT drives intermission bit 1 dominant (overload flag at i+1..i+6,
/// overload delimiter bits 1..8 at i+7..i+14) and then edits the script with `edit`. Returns the bench
/// and i.
fn overload_after_reception(
    iut: Iut,
    edit: impl FnOnce(&mut LowerTester, usize),
) -> (ProtocolBench, usize) {
    let encoded = encode(&frame());
    let i = SOF + encoded.len();
    let bench = ProtocolBench::receive_with(iut, bits_of(&encoded), None, 60, |lt| {
        lt.set_bit(i, Drive::Dominant);
        edit(lt, i);
    });
    (bench, i)
}

/// Script bit of overload-delimiter bit `k` (1..8) after an overload flag started at i+1.
fn overload_delimiter_bit(i: usize, k: usize) -> usize {
    i + 6 + k
}

fn fe_07_dominant_overload_delimiter_bits(iut: Iut) {
    let ack = SOF + field(&encode(&frame()), Field::AckSlot, 0);
    for k in [2, 4, 7] {
        let (mut bench, i) = overload_after_reception(iut, |lt, i| {
            lt.set_bit(overload_delimiter_bit(i, k), Drive::Dominant);
        });
        let d = overload_delimiter_bit(i, k);
        assert_eq!(
            bench.iut_dominant_bits(0, d + 30),
            ack_and_flags(ack, i, d),
            "overload delimiter bit {k} dominant: active error flag from the next bit"
        );
        let events = bench.iut_events();
        assert_eq!(events.len(), 2, "delimiter bit {k}: {events:?}");
        assert_eq!(events[0], NodeEvent::Received(frame()));
        // The SJA1000 has no segment code for the overload delimiter: the catalog fixes only form/RX.
        assert!(
            matches!(events[1], NodeEvent::BusError(code) if code >> 5 == FORM << 1 | 1),
            "delimiter bit {k}: form/RX: {events:?}"
        );
        assert_eq!(bench.rec(), 1, "delimiter bit {k}: REC +1");
    }
}

/// The IUT's dominant bits: its ACK, a flag after bit `i` and a flag after bit `d`.
fn ack_and_flags(ack: usize, i: usize, d: usize) -> Vec<usize> {
    let mut bits = vec![ack];
    bits.extend(flag_after(i));
    bits.extend(flag_after(d));
    bits
}

fn fe_08_dominant_last_overload_delimiter_bit_is_a_new_overload(iut: Iut) {
    let ack = SOF + field(&encode(&frame()), Field::AckSlot, 0);
    let (mut bench, i) = overload_after_reception(iut, |lt, i| {
        lt.set_bit(overload_delimiter_bit(i, 8), Drive::Dominant);
    });
    let d = overload_delimiter_bit(i, 8);
    assert_eq!(
        bench.iut_dominant_bits(0, d + 30),
        ack_and_flags(ack, i, d),
        "overload delimiter bit 8 dominant: a new overload flag from the next bit"
    );
    assert_eq!(bench.iut_events(), vec![NodeEvent::Received(frame())]);
    assert_eq!(bench.rec(), 0, "no counter change");
}

// ---------------------------------------------------------------------------------------------------
// BE: bit errors

fn be_02_transmitter_bit_errors_in_every_field(iut: Iut) {
    let standard = frame();
    let extended = Frame::data(Id::extended(0x0ABC_DEF1).unwrap(), &[0xC3]).unwrap();
    let mut cases: Vec<(Frame, usize)> = vec![(standard, 0)]; // SOF
    let encoded = encode(&standard);
    for i in 0..encoded.len() {
        let tag = encoded.tags[i];
        if !tag.stuff
            && matches!(
                tag.field,
                Field::Ide | Field::R0 | Field::Dlc | Field::Data | Field::Crc
            )
        {
            cases.push((standard, i));
        }
    }
    // r1 and r0 of an extended frame (its IDE is recessive and part of the arbitration field).
    let encoded_ext = encode(&extended);
    cases.push((extended, field(&encoded_ext, Field::R1, 0)));
    cases.push((extended, field(&encoded_ext, Field::R0, 0)));
    let mut seen = std::collections::BTreeSet::new();
    let mut failures = Vec::new();
    for (f, e) in cases {
        let encoded = encode(&f);
        let level = encoded.bits[e];
        let tag = encoded.tags[e];
        let mut bench =
            transmitter_error_then_acked_retry(iut, &f, 0, e, |lt| invert(lt, e, level));
        let what = format!(
            "{f}: {} bit {} at {e} ({})",
            tag.field,
            tag.index,
            if level == DOMINANT {
                "dominant forced recessive"
            } else {
                "recessive driven dominant"
            }
        );
        // Every case runs; the mismatches are listed together at the end.
        let retry = e + 18;
        let wire = (flag_after(e), retry, retry + encoded.len());
        let mut expected_bits = wire.0;
        expected_bits.extend(
            (0..encoded.len())
                .filter(|&i| encoded.bits[i] == DOMINANT)
                .map(|i| retry + i),
        );
        let got_bits = bench.iut_dominant_bits(e + 1, wire.2);
        if got_bits != expected_bits {
            failures.push(format!(
                "{what}: dominant bits {got_bits:?}, expected flag e+1..e+6 and the retry from e+18 \
                 {expected_bits:?}"
            ));
        }
        let expected_events = vec![
            NodeEvent::BusError(ecc(BIT, false, segment_of(&encoded, e))),
            NodeEvent::TransmitDone(true),
        ];
        if bench.iut_events() != expected_events {
            failures.push(format!(
                "{what}: events {:?}, expected {expected_events:?} (bit/TX/segment)",
                bench.iut_events()
            ));
        }
        let counters = (bench.tec(), bench.rec());
        if counters != (7, 0) {
            failures.push(format!(
                "{what}: (TEC, REC) = {counters:?}, expected (7, 0): +8, then -1 for the retry"
            ));
        }
        seen.insert((format!("{:?}", tag.field), level));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    for field in ["Dlc", "Data", "Crc"] {
        for level in [DOMINANT, RECESSIVE] {
            assert!(
                seen.contains(&(field.to_string(), level)),
                "{field} {level}"
            );
        }
    }
}

fn be_04_bit_error_in_own_overload_flag(iut: Iut) {
    let ack = SOF + field(&encode(&frame()), Field::AckSlot, 0);
    for j in [1, 3, 6] {
        let (mut bench, i) = overload_after_reception(iut, |lt, i| {
            let quanta = lt.quanta_per_bit();
            lt.force(i + j, 0, quanta, Drive::ForceRecessive);
        });
        let e = i + j;
        // The IUT drove overload flag bits 1..j (bit j forced recessive on the bus), then its active
        // error flag from the next bit.
        let mut expected = vec![ack];
        expected.extend(i + 1..=e);
        expected.extend(flag_after(e));
        assert_eq!(
            bench.iut_dominant_bits(0, e + 30),
            expected,
            "overload flag bit {j} forced recessive"
        );
        assert_eq!(
            bench.iut_events(),
            vec![
                NodeEvent::Received(frame()),
                NodeEvent::BusError(ecc(BIT, true, SEG_OVERLOAD_FLAG))
            ],
            "overload flag bit {j}: bit/RX/overload flag"
        );
        assert_eq!(bench.rec(), 8, "overload flag bit {j}: REC +8");
    }
}

fn be_05_dominant_bits_during_a_passive_flag_are_no_bit_error(iut: Iut) {
    // REC 130: error passive; the stuff error gives REC 131 and a passive flag from bit 20. The LT
    // drives `n` dominant bits from flag bit 2 (script bit 21): the six equal bits needed to end the
    // flag are the recessive bits 21 + n .. 21 + n + 5, so the flag ends at F = 26 + n; delimiter
    // F+1..F+8, intermission F+9..F+11.
    // Probes: (a) a dominant bit at F+10 (intermission bit 2) is an overload condition: overload flag
    // F+11..F+16; (b) a SOF at F+11 (intermission bit 3) starts a frame, received and acknowledged.
    // A flag ending one bit late fails (b); one bit early fails (a).
    let f = frame();
    let encoded = encode(&f);
    for n in [2, 5] {
        let flag_end = STUFF_ERROR_AT + 1 + 1 + n + 5;
        let inside: Vec<usize> = (STUFF_ERROR_AT + 2..STUFF_ERROR_AT + 2 + n).collect();
        // (a)
        let mut dominant = inside.clone();
        dominant.push(flag_end + 10);
        let mut bench = receiver_error_with_dominant(iut, Some(130), &dominant);
        assert_eq!(
            bench.iut_dominant_bits(STUFF_ERROR_AT, flag_end + 30),
            flag_after(flag_end + 10),
            "{n} dominant bits in the passive flag: recessive flag, overload flag after intermission bit 2"
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::BusError(STUFF_ERROR_ECC)],
            "{n} dominant bits in the passive flag: no new error"
        );
        assert_eq!(bench.rec(), 131, "{n}: +1 only");
        // (b)
        let sof = flag_end + 11;
        let mut bench = ProtocolBench::new(iut);
        bench.load_counter(false, 130);
        bench
            .lt()
            .after_integration()
            .send_bits([DOMINANT; 6])
            .release(sof - STUFF_ERROR_AT - 1)
            .send_frame(&encoded)
            .release(4);
        for &b in &inside {
            bench.lt().set_bit(b, Drive::Dominant);
        }
        bench.run(1);
        let ack = sof + field(&encoded, Field::AckSlot, 0);
        assert_eq!(
            bench.iut_dominant_bits(STUFF_ERROR_AT, sof + encoded.len()),
            vec![ack],
            "{n}: SOF in intermission bit 3 received and acknowledged"
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::BusError(STUFF_ERROR_ECC), NodeEvent::Received(f)],
            "{n}"
        );
        assert_eq!(bench.rec(), 127, "{n}: success above 127 sets 127 (choice)");
    }
}

// ---------------------------------------------------------------------------------------------------
// FT: transmitting

fn ft_06_overload_after_own_frame_counts_as_success(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let ack = field(&encoded, Field::AckSlot, 0);
    for k in 0..2 {
        let i = encoded.len() + k; // intermission bit k + 1
        let mut bench = transmit_with(iut, &f, 9, encoded.len() + 40, |lt| {
            lt.set_bit(ack, Drive::Dominant);
            lt.set_bit(i, Drive::Dominant);
        });
        let golden: Vec<usize> = (0..encoded.len())
            .filter(|&b| encoded.bits[b] == DOMINANT)
            .collect();
        assert_eq!(
            bench.iut_dominant_bits(0, encoded.len()),
            golden,
            "intermission bit {}: the frame",
            k + 1
        );
        assert_eq!(
            bench.iut_dominant_bits(encoded.len(), encoded.len() + 40),
            flag_after(i),
            "intermission bit {}: overload flag from the next bit, no retransmission",
            k + 1
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::TransmitDone(true)],
            "intermission bit {}: TI, success",
            k + 1
        );
        assert_eq!(bench.tec(), 8, "intermission bit {}: 9 -> 8", k + 1);
    }
}

testbenches::on_both_iuts! {
    st_04_missing_stuff_bit_after_the_crc,
    st_05_inverted_stuff_bit_of_the_iut_is_a_bit_error,
    st_06_ec_07_recessive_stuff_bit_in_the_identifier_forced_dominant,
    cr_02_flipped_data_bit_and_flipped_recessive_crc_bit,
    cr_03_crc_error_and_dominant_crc_delimiter_give_one_flag,
    cr_04_recessive_sof_moves_the_frame,
    fe_04_transmitter_form_errors,
    ft_05_dominant_last_eof_bit_of_own_frame_is_a_form_error,
    fe_05_dominant_error_delimiter_bits,
    fe_06_dominant_last_error_delimiter_bit_is_an_overload,
    fe_07_dominant_overload_delimiter_bits,
    fe_08_dominant_last_overload_delimiter_bit_is_a_new_overload,
    be_02_transmitter_bit_errors_in_every_field,
    be_04_bit_error_in_own_overload_flag,
    be_05_dominant_bits_during_a_passive_flag_are_no_bit_error,
    ft_06_overload_after_own_frame_counts_as_success,
}
