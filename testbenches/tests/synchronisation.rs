//! Conformance BT scenarios that need the protocol engine (BT-12 …): synchronisation of a
//! transmitter around the ACK, at the start of a frame and on its own edges. Bit numbers are
//! lower-tester script bits; edge times are clocks from the start of the LT's script (its quantum q
//! starts at q · clocks per tq). BT-14..16 run in every catalog configuration. Every scenario runs
//! on both IUTs (the RTL core, and the controller through its registers).
//!
//! BT-01, 02, 03, 10 and 17 are also checked here by what the bit timing decides for the protocol,
//! in every configuration: a bit read one way or the other is a frame received or a stuff, bit or
//! CRC error with its flag on the wire (`bit_timing.rs` checks the sampled levels themselves).

use golden::btr::Btr;
use golden::frame::{
    decode, encode, DecodeErrorKind, EncodedFrame, Field, Frame, Id, DOMINANT, RECESSIVE,
};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use sim::nodes::lower_tester::LowerTester;
use testbenches::bt_configs;
use testbenches::ecc::{ecc, BIT, OTHER, SEG_ACK_DELIM, SEG_ID_28_21, STUFF};
use testbenches::protocol_bench::{Iut, LtScript, ProtocolBench, INTEGRATION_BITS};

fn bt_12_negative_resync_at_the_crc_delimiter_before_the_ack(iut: Iut) {
    let frame = Frame::data(Id::standard(0x456).unwrap(), &[0xC3, 0x3C]).unwrap();
    let encoded = encode(&frame);
    let delimiter = encoded.position(Field::CrcDelim, 0).unwrap();
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    // The acknowledging node's ACK edge comes early: the CRC delimiter is shortened by 1 .. TSEG2 tq.
    for early_tq in 1..=4 {
        let mut bench = ProtocolBench::iut_transmits(iut, &frame);
        bench
            .lt()
            .release(encoded.len() + 4)
            .set_bit(ack, Drive::Dominant)
            .lengthen_bit(delimiter, -early_tq);
        bench.run(1);
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::TransmitDone(true)],
            "ACK {early_tq} tq early is read correctly"
        );
        assert_eq!(bench.tec(), 0);
    }
}

/// A transmitter's bit reaches the bus this many clocks after the start of that bit on the grid of
/// the edge it synchronised on (transmit point at the first clock of Sync, tx one clock later, and
/// the two-clock synchroniser between the edge and its Sync).
const TX_DELAY_CLOCKS: u64 = 3;

fn frame() -> Frame {
    Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap()
}

/// The first bit k ≥ 1 of `encoded` that is recessive and followed by a dominant bit: the IUT's own
/// recessive → dominant edge at the start of bit k + 1.
fn recessive_before_dominant(encoded: &EncodedFrame) -> usize {
    (1..encoded.len() - 1)
        .find(|&k| encoded.bits[k] == RECESSIVE && encoded.bits[k + 1] == DOMINANT)
        .expect("the frame has a recessive → dominant edge")
}

/// The IUT transmits `frame()` in `btr`; the LT acknowledges it after `edit` changed its script.
/// Returns the bench played to the end, with the frame's bit `k` of [`recessive_before_dominant`].
fn transmit_edited(
    iut: Iut,
    btr: golden::btr::Btr,
    edit: impl FnOnce(&mut sim::nodes::lower_tester::LowerTester, usize),
) -> ProtocolBench {
    let encoded = encode(&frame());
    let k = recessive_before_dominant(&encoded);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let mut bench = ProtocolBench::iut_transmits_in(iut, btr, &frame());
    bench
        .lt()
        .release(encoded.len() + 4)
        .set_bit(ack, Drive::Dominant);
    edit(bench.lt(), k);
    bench.run(1);
    bench
}

/// The IUT's transmit edges in the unperturbed frame: each at the start of its LT script bit plus
/// the transmitter delay (the LT's script starts at the IUT's SOF edge).
fn reference_edges(iut: Iut, btr: golden::btr::Btr) -> Vec<(u64, bool)> {
    let encoded = encode(&frame());
    let mut bench = transmit_edited(iut, btr, |_, _| {});
    let edges = bench.iut_edges(0, encoded.len() + 4);
    let golden: Vec<(u64, bool)> = (1..encoded.len())
        .filter(|&i| encoded.bits[i] != encoded.bits[i - 1])
        .map(|i| (bench.bit_start_clock(i) + TX_DELAY_CLOCKS, encoded.bits[i]))
        .collect();
    assert_eq!(edges[0], (0, DOMINANT), "SOF edge at the script start");
    assert_eq!(
        edges[1..],
        golden[..],
        "reference: every edge of the IUT at its bit start + {TX_DELAY_CLOCKS} clocks"
    );
    assert_eq!(bench.iut_events(), vec![NodeEvent::TransmitDone(true)]);
    edges
}

fn bt_14_dominant_after_the_sample_point_of_intermission_bit_3_starts_the_own_sof(iut: Iut) {
    let theirs_frame = Frame::data(Id::standard(0x0A1).unwrap(), &[0x42]).unwrap();
    let theirs = encode(&theirs_frame);
    let mine = encode(&frame());
    let first_sof = INTEGRATION_BITS;
    let intermission_3 = first_sof + theirs.len() + 2;
    let sof = intermission_3 + 1;
    for cfg in bt_configs() {
        let (sp, nbt) = (cfg.btr.sample_point_tq(), cfg.btr.quanta_per_bit());
        let cpt = cfg.btr.clocks_per_tq() as u64;
        // The dominant edge `at` quanta into intermission bit 3; the LT drives it for a whole bit
        // (another node's SOF) and then leaves the bus to the IUT. `sp - 1` is BT-13's case.
        for at in sp - 1..=nbt {
            let what = format!("{}: dominant from tq {at} of intermission bit 3", cfg.name);
            let mut bench = ProtocolBench::with_btr(iut, cfg.btr);
            bench
                .lt()
                .after_integration()
                .send_frame(&theirs)
                .release(3)
                .lengthen_bit(intermission_3, at as i32 - nbt as i32)
                .push_bit(Drive::Dominant)
                .release(mine.len() + 3)
                .set_bit(
                    sof + mine.position(Field::AckSlot, 0).unwrap(),
                    Drive::Dominant,
                );
            bench.run_to_bit(first_sof + 10);
            bench.send(&frame(), false);
            bench.run(1);
            let after_sample_point = at >= sp;
            assert_eq!(
                bench.iut_dominant_in(sof),
                after_sample_point,
                "{what}: the IUT sends its own SOF exactly when the edge follows its sample point"
            );
            let edge = bench.bit_start_clock(sof);
            let edges = bench.iut_edges(intermission_3, sof + mine.len());
            let mut golden: Vec<(u64, bool)> = (1..mine.len())
                .filter(|&i| mine.bits[i] != mine.bits[i - 1])
                .map(|i| {
                    let start = bench.bit_start_clock(sof + i);
                    (start + TX_DELAY_CLOCKS, mine.bits[i])
                })
                .collect();
            if after_sample_point {
                // Hard synchronisation on the edge: the SOF goes out with the transmitter delay,
                // one clock later when the edge is seen at the process point (at == SP, the transmit
                // point waits for the protocol's decision).
                let delay = TX_DELAY_CLOCKS + u64::from(at == sp);
                golden.insert(0, (edge + delay, DOMINANT));
            } else {
                // BT-13: no SOF of its own; the first identifier bit (dominant) one bit after the edge.
                assert_eq!(mine.bits[1], DOMINANT, "ID.28 of the frame is dominant");
                golden.insert(0, (edge + nbt as u64 * cpt + TX_DELAY_CLOCKS, DOMINANT));
            }
            assert_eq!(
                edges, golden,
                "{what}: the IUT's edges follow the grid of the LT's edge"
            );
            assert_eq!(
                bench.iut_events(),
                vec![
                    NodeEvent::Received(theirs_frame),
                    NodeEvent::TransmitDone(true)
                ],
                "{what}"
            );
        }
    }
}

fn bt_15_transmitter_negative_phase_error_moves_its_next_edges_by_the_absorbed_amount(iut: Iut) {
    for cfg in bt_configs() {
        let reference = reference_edges(iut, cfg.btr);
        let (sjw, tseg2) = (cfg.btr.sjw_tq(), cfg.btr.tseg2_tq());
        let cpt = cfg.btr.clocks_per_tq() as u64;
        let encoded = encode(&frame());
        // The LT shortens the IUT's recessive bit k by e quanta and drives the next (dominant) bit
        // from there: the IUT sees the edge e quanta before the end of its TSEG2.
        for e in 1..=tseg2 {
            let what = format!("{}: edge {e} tq early (SJW {sjw})", cfg.name);
            let mut k = 0;
            let mut bench = transmit_edited(iut, cfg.btr, |lt, bit| {
                k = bit;
                lt.lengthen_bit(bit, -(e as i32))
                    .set_bit(bit + 1, Drive::Dominant);
            });
            let moved_from = bench.bit_start_clock(k + 1) + e as u64 * cpt;
            let absorbed = e.min(sjw) as u64 * cpt;
            let expected: Vec<(u64, bool)> = reference
                .iter()
                .map(|&(t, level)| {
                    if t < moved_from {
                        (t, level)
                    } else {
                        (t - absorbed, level)
                    }
                })
                .collect();
            assert_eq!(
                bench.iut_edges(0, encoded.len() + 4),
                expected,
                "{what}: the edges from bit k + 1 on move {} tq earlier",
                e.min(sjw)
            );
            assert_eq!(
                bench.iut_events(),
                vec![NodeEvent::TransmitDone(true)],
                "{what}"
            );
        }
    }
}

fn bt_16_transmitter_sending_dominant_does_not_resynchronise_on_a_late_edge(iut: Iut) {
    for cfg in bt_configs() {
        let reference = reference_edges(iut, cfg.btr);
        let (sjw, tseg1) = (cfg.btr.sjw_tq(), cfg.btr.tseg1_tq());
        let encoded = encode(&frame());
        // The LT holds the bus recessive for the first e quanta of the IUT's dominant bit k + 1 (up
        // to the quantum before the sample point): a positive phase error of e quanta.
        for e in 1..=tseg1 {
            let what = format!("{}: edge {e} tq late (SJW {sjw})", cfg.name);
            let mut bench = transmit_edited(iut, cfg.btr, |lt, k| {
                lt.force(k + 1, 0, e, Drive::ForceRecessive);
            });
            assert_eq!(
                bench.iut_edges(0, encoded.len() + 4),
                reference,
                "{what}: no edge of the IUT moves"
            );
            assert_eq!(
                bench.iut_events(),
                vec![NodeEvent::TransmitDone(true)],
                "{what}"
            );
        }
    }
}

/// Script bit of the SOF in the receive scenarios.
const SOF: usize = INTEGRATION_BITS;

/// The six bits of an error flag after an error detected at script bit `e`.
fn flag_after(e: usize) -> Vec<usize> {
    (e + 1..=e + 6).collect()
}

/// The LT sends `bits` from script bit [`SOF`] in `btr`, its script edited by `edit`, then leaves
/// the bus idle for 30 bits; the bench has played it all.
fn receive_edited(
    iut: Iut,
    btr: Btr,
    bits: impl IntoIterator<Item = bool>,
    edit: impl FnOnce(&mut LowerTester),
) -> ProtocolBench {
    let mut bench = ProtocolBench::with_btr(iut, btr);
    bench.lt().release(SOF).send_bits(bits).release(30);
    edit(bench.lt());
    bench.run(1);
    bench
}

/// The IUT received `frame` sent from script bit [`SOF`]: it drove only the ACK slot, reported the
/// frame and no error, REC 0.
fn assert_frame_received(bench: &mut ProtocolBench, frame: &Frame, what: &str) {
    let encoded = encode(frame);
    let ack = SOF + encoded.position(Field::AckSlot, 0).unwrap();
    assert_eq!(
        bench.iut_dominant_bits(0, SOF + encoded.len() + 30),
        vec![ack],
        "{what}: only the ACK"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::Received(*frame)],
        "{what}"
    );
    assert_eq!(bench.rec(), 0, "{what}");
}

/// The IUT, receiving, detected an error at script bit `e` reported as `code`: its active flag from
/// e + 1 is all it drove, REC 1.
fn assert_receiver_error(bench: &mut ProtocolBench, e: usize, code: u8, what: &str) {
    assert_eq!(
        bench.iut_dominant_bits(0, e + 30),
        flag_after(e),
        "{what}: the flag from the next bit"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(code)],
        "{what}: ECC {code:#04x}"
    );
    assert_eq!(bench.rec(), 1, "{what}");
}

fn bt_01_stuff_bit_cut_at_the_sample_point_keeps_the_frame_one_tq_earlier_is_a_stuff_error(
    iut: Iut,
) {
    let frame = Frame::data(Id::standard(0x7FF).unwrap(), &[]).unwrap();
    let encoded = encode(&frame);
    let stuff = (0..encoded.len())
        .find(|&i| encoded.tags[i].stuff && encoded.bits[i] == DOMINANT)
        .expect("ID 0x7FF has a dominant stuff bit after five recessive bits");
    assert_eq!(encoded.bits[stuff + 1], RECESSIVE);
    assert_eq!(encoded.tags[stuff + 1].field, Field::BaseId);
    for cfg in bt_configs() {
        let (sp, nbt) = (cfg.btr.sample_point_tq(), cfg.btr.quanta_per_bit());
        // The dominant stuff bit lasts `sp` quanta (up to the sample point), or one less; the bus is
        // recessive for the rest of the bit, so the following bits keep their grid.
        for dominant_tq in [sp, sp - 1] {
            let what = format!("{}: stuff bit dominant for {dominant_tq} tq", cfg.name);
            // Read recessive, the stuff bit ends the frame: the LT stops there and leaves the bus
            // to the IUT's error frame.
            let sent = if dominant_tq == sp {
                encoded.len()
            } else {
                stuff + 1
            };
            let bits = encoded.bits[..sent].iter().by_vals();
            let mut bench = receive_edited(iut, cfg.btr, bits, |lt| {
                lt.force(
                    SOF + stuff,
                    dominant_tq,
                    nbt - dominant_tq,
                    Drive::ForceRecessive,
                );
            });
            if dominant_tq == sp {
                assert_frame_received(&mut bench, &frame, &what);
            } else {
                let code = ecc(STUFF, true, SEG_ID_28_21);
                assert_receiver_error(&mut bench, SOF + stuff, code, &what);
            }
        }
    }
}

fn bt_02_own_bit_forced_recessive_after_the_sample_point_is_no_error_before_it_a_bit_error(
    iut: Iut,
) {
    let f = Frame::data(Id::standard(0x000).unwrap(), &[]).unwrap();
    let encoded = encode(&f);
    let bit = encoded.position(Field::BaseId, 2).unwrap();
    assert!(encoded.bits[bit] == DOMINANT && !encoded.tags[bit].stuff);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let golden: Vec<usize> = (0..encoded.len())
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .collect();
    for cfg in bt_configs() {
        let (sp, nbt) = (cfg.btr.sample_point_tq(), cfg.btr.quanta_per_bit());
        for from_tq in [sp + 1, sp, sp - 1] {
            let what = format!("{}: own dominant bit recessive from tq {from_tq}", cfg.name);
            let error = from_tq < sp;
            // After a bit error the retransmission starts at e + 18; the LT acknowledges the
            // attempt that completes.
            let sent_from = if error { bit + 18 } else { 0 };
            let mut bench = ProtocolBench::iut_transmits_in(iut, cfg.btr, &f);
            bench
                .lt()
                .release(sent_from + encoded.len() + 4)
                .force(bit, from_tq, nbt - from_tq, Drive::ForceRecessive)
                .set_bit(sent_from + ack, Drive::Dominant);
            bench.run(1);
            let mut expected: Vec<usize> = golden.iter().map(|&i| sent_from + i).collect();
            let mut events = vec![NodeEvent::TransmitDone(true)];
            if error {
                let first_attempt = golden.iter().copied().filter(|&i| i <= bit);
                expected = first_attempt
                    .chain(flag_after(bit))
                    .chain(expected)
                    .collect();
                events.insert(0, NodeEvent::BusError(ecc(BIT, false, SEG_ID_28_21)));
            }
            assert_eq!(
                bench.iut_dominant_bits(0, sent_from + encoded.len() + 4),
                expected,
                "{what}"
            );
            assert_eq!(bench.iut_events(), events, "{what}");
            assert_eq!(bench.tec(), if error { 7 } else { 0 }, "{what}");
        }
    }
}

fn bt_03_stuff_error_flag_six_bits_after_the_sof_edge_at_every_offset(iut: Iut) {
    for cfg in bt_configs() {
        let nbt = cfg.btr.quanta_per_bit();
        let clocks_per_bit = u64::from(nbt * cfg.btr.clocks_per_tq());
        for last_idle_tq in 1..=nbt {
            let what = format!("{}: last idle bit {last_idle_tq} tq", cfg.name);
            // SOF and five dominant identifier bits: a stuff error at the sixth dominant bit.
            let mut bench = receive_edited(iut, cfg.btr, [DOMINANT; 6], |lt| {
                lt.lengthen_bit(SOF - 1, last_idle_tq as i32 - nbt as i32);
            });
            let e = SOF + 5;
            assert_receiver_error(&mut bench, e, ecc(STUFF, true, SEG_ID_28_21), &what);
            // Hard synchronisation on the SOF edge: the flag goes out 6 bits after it, with the
            // transmitter delay.
            let sof_edge = bench.bit_start_clock(SOF);
            assert_eq!(
                bench.iut_edges(SOF, e + 2).first(),
                Some(&(sof_edge + 6 * clocks_per_bit + TX_DELAY_CLOCKS, DOMINANT)),
                "{what}: the flag's first edge"
            );
        }
    }
}

fn bt_10_idle_pulse_past_the_sample_point_starts_a_frame_a_shorter_one_is_ignored(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap();
    let encoded = encode(&frame);
    for cfg in bt_configs() {
        let sp = cfg.btr.sample_point_tq();
        // The shortest pulse and both sides of the sample point (`bit_timing.rs` sweeps them all).
        for pulse_tq in [1, sp - 1, sp, sp + 1] {
            let what = format!("{}: idle pulse of {pulse_tq} tq", cfg.name);
            let pulse = |lt: &mut LowerTester| {
                lt.force(SOF, 0, pulse_tq, Drive::Dominant);
            };
            if pulse_tq >= sp {
                // A SOF followed by a recessive bus: the sixth recessive bit is a stuff error.
                let mut bench = receive_edited(iut, cfg.btr, [RECESSIVE], pulse);
                let code = ecc(STUFF, true, SEG_ID_28_21);
                assert_receiver_error(&mut bench, SOF + 6, code, &what);
            } else {
                // No SOF: a frame starting two bits later is received as usual.
                let bits = [RECESSIVE; 2]
                    .into_iter()
                    .chain(encoded.bits.iter().by_vals());
                let mut bench = receive_edited(iut, cfg.btr, bits, pulse);
                let ack = SOF + 2 + encoded.position(Field::AckSlot, 0).unwrap();
                assert_eq!(
                    bench.iut_dominant_bits(0, ack + 30),
                    vec![ack],
                    "{what}: only the ACK of the next frame"
                );
                assert_eq!(
                    bench.iut_events(),
                    vec![NodeEvent::Received(frame)],
                    "{what}"
                );
            }
        }
    }
}

/// A dominant, non-stuff data bit of `encoded` whose flip keeps the stuffing: read recessive, the
/// frame has a CRC error.
fn dominant_bit_whose_flip_is_a_crc_error(encoded: &EncodedFrame) -> usize {
    let after_ack_delimiter = encoded.position(Field::AckDelim, 0).unwrap() + 1;
    (0..encoded.len())
        .filter(|&i| encoded.tags[i].field == Field::Data && !encoded.tags[i].stuff)
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .find(|&i| {
            let mut bits = encoded.bits.clone();
            bits.set(i, RECESSIVE);
            matches!(decode(&bits), Err(e)
                if e.kind == DecodeErrorKind::Crc && e.position == after_ack_delimiter)
        })
        .expect("a data bit whose flip keeps the stuffing")
}

fn bt_17_triple_sampling_decides_whether_a_spike_corrupts_the_frame(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap();
    let encoded = encode(&frame);
    let bit = dominant_bit_whose_flip_is_a_crc_error(&encoded);
    let ack_delimiter = SOF + encoded.position(Field::AckDelim, 0).unwrap();
    for cfg in bt_configs() {
        for sam in [false, true] {
            let btr = Btr { sam, ..cfg.btr };
            let sp = btr.sample_point_tq();
            // (first quantum of the recessive spike before the sample point, length).
            for (before_sp, length) in [(1, 1), (2, 1), (3, 1), (2, 2), (3, 2)] {
                let start = sp - before_sp;
                let read_recessive = if sam {
                    length > 1
                } else {
                    start + length == sp
                };
                let what = format!(
                    "{} SAM={}: {length}-tq spike {before_sp} tq before the sample point",
                    cfg.name, sam as u8
                );
                let mut bench = receive_edited(iut, btr, encoded.bits.iter().by_vals(), |lt| {
                    lt.force(SOF + bit, start, length, Drive::Recessive);
                });
                if read_recessive {
                    let code = ecc(OTHER, true, SEG_ACK_DELIM);
                    assert_receiver_error(&mut bench, ack_delimiter, code, &what);
                } else {
                    assert_frame_received(&mut bench, &frame, &what);
                }
            }
        }
    }
}

testbenches::on_both_iuts! {
    bt_01_stuff_bit_cut_at_the_sample_point_keeps_the_frame_one_tq_earlier_is_a_stuff_error,
    bt_02_own_bit_forced_recessive_after_the_sample_point_is_no_error_before_it_a_bit_error,
    bt_03_stuff_error_flag_six_bits_after_the_sof_edge_at_every_offset,
    bt_10_idle_pulse_past_the_sample_point_starts_a_frame_a_shorter_one_is_ignored,
    bt_12_negative_resync_at_the_crc_delimiter_before_the_ack,
    bt_14_dominant_after_the_sample_point_of_intermission_bit_3_starts_the_own_sof,
    bt_15_transmitter_negative_phase_error_moves_its_next_edges_by_the_absorbed_amount,
    bt_16_transmitter_sending_dominant_does_not_resynchronise_on_a_late_edge,
    bt_17_triple_sampling_decides_whether_a_spike_corrupts_the_frame,
}
