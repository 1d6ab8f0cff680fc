//! ISO 16845-1:2016 clause 8.7: the IUT as transmitter, bit timing (its sample point, hard
//! synchronisation on a SOF in the third intermission bit before and after the sample point,
//! negative phase errors within and beyond SJW, one synchronisation per bit, no resynchronisation on
//! late edges while sending dominant, an edge just after the sample point). Each test runs every
//! elementary test case of its clause in the bit timings of [`iso_bit_timings`] (BRP 0 and 2) on
//! both IUTs. Times are clocks from the start of the LT's script (the IUT's SOF edge); the IUT's
//! edges follow the bit starts of the grid it synchronised on by [`IUT_DELAY_CLOCKS`].

use golden::btr::Btr;
use golden::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::BIT;
use testbenches::iso::{
    ack_offset, bits_from, dominant_data_bit, iso_bit_timings, lt_acknowledges_at, DELIMITER, FLAG,
    IUT_DELAY_CLOCKS,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

fn frame() -> Frame {
    Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap()
}

/// Clocks per quantum and per bit.
fn clocks(btr: &Btr) -> (u64, u64) {
    let tq = u64::from(btr.clocks_per_tq());
    (tq, tq * u64::from(btr.quanta_per_bit()))
}

/// The IUT's processing time in whole quanta (its delay rounded up), which bounds the negative
/// phase errors the clauses apply: Phase_Seg2 − IPT.
fn ipt_tq(btr: &Btr) -> u32 {
    IUT_DELAY_CLOCKS.div_ceil(u64::from(btr.clocks_per_tq())) as u32
}

/// The script bits k + 1 of `frame` where bit k is recessive and bit k + 1 dominant, in the
/// arbitration field.
fn dominant_after_recessive_in_arbitration(frame: &Frame) -> Vec<usize> {
    let encoded = encode(frame);
    (1..encoded.len() - 1)
        .filter(|&k| encoded.bits[k] == RECESSIVE && encoded.bits[k + 1] == DOMINANT)
        .filter(|&k| matches!(encoded.tags[k + 1].field, Field::BaseId | Field::Rtr))
        .map(|k| k + 1)
        .collect()
}

/// The IUT transmits `frame` in `btr`; the LT acknowledges it after `edit` changed its script.
/// Played to the end.
fn transmit(
    iut: Iut,
    btr: Btr,
    frame: &Frame,
    edit: impl FnOnce(&mut sim::nodes::lower_tester::LowerTester),
) -> ProtocolBench {
    let mut bench = ProtocolBench::iut_transmits_in(iut, btr, frame);
    lt_acknowledges_at(&mut bench, 0, frame, 4);
    edit(bench.lt());
    bench.run(1);
    bench
}

/// The IUT's edges (clock, level) while sending `frame` undisturbed: each at its bit's start on the
/// LT's script plus [`IUT_DELAY_CLOCKS`] (checked).
fn reference_edges(iut: Iut, btr: Btr, frame: &Frame) -> Vec<(u64, bool)> {
    let encoded = encode(frame);
    let bench = transmit(iut, btr, frame, |_| {});
    let edges = bench.iut_edges(0, encoded.len());
    let expected: Vec<(u64, bool)> = std::iter::once((0, DOMINANT))
        .chain(
            (1..ack_offset(frame))
                .filter(|&i| encoded.bits[i] != encoded.bits[i - 1])
                .map(|i| (bench.bit_start_clock(i) + IUT_DELAY_CLOCKS, encoded.bits[i])),
        )
        .collect();
    assert_eq!(
        edges, expected,
        "reference: every edge at its bit start + delay"
    );
    edges
}

/// The IUT's edges of the disturbed run before the ACK slot.
fn edges_before_ack(bench: &ProtocolBench, frame: &Frame) -> Vec<(u64, bool)> {
    let ack_clock = bench.bit_start_clock(ack_offset(frame));
    bench
        .iut_edges(0, encode(frame).len())
        .into_iter()
        .filter(|&(t, _)| t < ack_clock)
        .collect()
}

/// 8.7.1: the transmitter's sample point.
///
/// ISO 16845-1 8.7.1: the LT forces a dominant bit preceded by a recessive one recessive from just
/// after the sample point to the end of the bit (read dominant: no error), and later another from
/// 1 tq before the sample point (read recessive: a bit error): an error flag from the next bit. (The
/// clause adds one minimum time quantum to each boundary; the LT here works in whole quanta.)
fn iso_8_7_1_transmitter_sample_point(iut: Iut) {
    let f = frame();
    let bits = dominant_after_recessive_in_arbitration(&f);
    let (first, second) = (bits[0], bits[1]);
    for (name, btr) in iso_bit_timings() {
        let (sp, ntq) = (btr.sample_point_tq(), btr.quanta_per_bit());
        let mut bench = ProtocolBench::iut_transmits_in(iut, btr, &f);
        bench
            .lt()
            .release(second + 30)
            .force(first, sp, ntq - sp, Drive::ForceRecessive)
            .force(second, sp - 1, ntq - sp + 1, Drive::ForceRecessive);
        bench.run(1);
        assert_eq!(
            bench.iut_dominant_bits(second + 1, second + 1 + FLAG + 2),
            bits_from(second + 1, FLAG),
            "{name}: an error flag after the second bit"
        );
        let errors = bench.bus_errors();
        assert_eq!(errors.len(), 1, "{name}: one error {errors:02X?}");
        assert_eq!(errors[0] >> 6, BIT, "{name}: a bit error");
    }
}

/// The frame of 8.7.2/8.7.3 with the most significant identifier bit `msb`.
fn msb_frame(msb: bool) -> Frame {
    let id = if msb == RECESSIVE { 0x5A5 } else { 0x1A5 };
    Frame::data(Id::standard(id).unwrap(), &[0x12]).unwrap()
}

/// The IUT's `frame` is disturbed (a data bit error); while its retransmission is pending, the LT
/// sends a dominant bit in the third intermission bit starting `start_tq` quanta into it, then
/// leaves the bus to the IUT and acknowledges its frame. Returns the bench and the clock of the
/// LT's edge.
fn sof_in_intermission_bit_3(
    iut: Iut,
    btr: Btr,
    frame: &Frame,
    start_tq: u32,
) -> (ProtocolBench, u64) {
    let error = dominant_data_bit(frame);
    let int3 = error + 1 + FLAG + DELIMITER + 2;
    let mut bench = ProtocolBench::iut_transmits_in(iut, btr, frame);
    let ntq = btr.quanta_per_bit();
    bench
        .lt()
        .release(error + 1)
        .set_bit(error, Drive::ForceRecessive)
        .release(int3 - error - 1)
        .release(1)
        .lengthen_bit(int3, start_tq as i32 - ntq as i32)
        .send_bits([DOMINANT]);
    // The IUT's frame from its identifier on, acknowledged.
    let sof = int3 + 1;
    lt_acknowledges_at(&mut bench, sof, frame, 4);
    bench.run(1);
    let edge = bench.bit_start_clock(sof);
    (bench, edge)
}

/// The script bit that starts at clock `edge`.
fn sof_bit(bench: &ProtocolBench, edge: u64) -> usize {
    (0..bench.lt_ref().script_len())
        .find(|&b| bench.bit_start_clock(b) == edge)
        .expect("the SOF is a script bit")
}

/// The IUT's edges in its arbitration field after a SOF at `edge`: each an integer number of bit
/// times after it (plus the IUT's delay).
fn assert_arbitration_edges_on_the_grid_of(
    bench: &ProtocolBench,
    frame: &Frame,
    edge: u64,
    bit: u64,
    drives_sof: bool,
    what: &str,
) {
    let encoded = encode(frame);
    let dlc = encoded.position(Field::Dlc, 0).unwrap();
    let sof_bit = sof_bit(bench, edge);
    let edges: Vec<(u64, bool)> = bench
        .iut_edges(sof_bit + 1, sof_bit + dlc)
        .into_iter()
        .collect();
    assert!(!edges.is_empty(), "{what}: edges in the arbitration field");
    for (t, _) in &edges {
        assert_eq!(
            (t - edge - IUT_DELAY_CLOCKS) % bit,
            0,
            "{what}: edge at clock {t}, not a whole number of bits after the SOF edge {edge}"
        );
    }
    // Before its identifier the IUT drove its own SOF (8.7.3) or nothing (8.7.2: the LT's SOF).
    let before = if drives_sof { DOMINANT } else { RECESSIVE };
    let first = edges[0];
    let expected_first = (1..encoded.len())
        .scan(before, |level, i| {
            let changed = encoded.bits[i] != *level;
            *level = encoded.bits[i];
            Some((i, changed))
        })
        .find(|&(_, changed)| changed)
        .map(|(i, _)| i as u64)
        .unwrap();
    assert_eq!(
        first.0,
        edge + expected_first * bit + IUT_DELAY_CLOCKS,
        "{what}: the first edge of the identifier"
    );
}

/// 8.7.2: a pending transmitter hard-synchronises on a dominant bit before the sample point of the
/// third intermission bit.
///
/// ISO 16845-1 8.7.2: the dominant bit starts 1 tq and a minimum time quantum before the sample
/// point (here: 2 tq before it): a SOF; the IUT (identifier MSB recessive) sends its identifier from
/// the next bit, its first edge 1 bit time after the SOF edge and every edge in the arbitration field
/// a whole number of bit times after it (the clause's window: −1 tq .. 0, plus the IUT's delay).
fn iso_8_7_2_hard_sync_before_the_sample_point_of_intermission_bit_3(iut: Iut) {
    let f = msb_frame(RECESSIVE);
    for (name, btr) in iso_bit_timings() {
        let (_, bit) = clocks(&btr);
        let (mut bench, edge) = sof_in_intermission_bit_3(iut, btr, &f, btr.sample_point_tq() - 2);
        assert!(
            !bench.iut_dominant_in(sof_bit(&bench, edge)),
            "{name}: the IUT sends no SOF of its own"
        );
        assert_arbitration_edges_on_the_grid_of(&bench, &f, edge, bit, false, &name);
        assert_eq!(
            bench.iut_events().last(),
            Some(&NodeEvent::TransmitDone(true)),
            "{name}"
        );
    }
}

/// 8.7.3: a pending transmitter hard-synchronises on a dominant edge after the sample point of the
/// third intermission bit.
///
/// ISO 16845-1 8.7.3: the dominant bit starts the IUT's processing time after the sample point
/// (here: 1 tq after it, 2 at BRP 0): the IUT starts its SOF on that edge and sends its frame (MSB
/// dominant) on the grid of that edge.
fn iso_8_7_3_hard_sync_after_the_sample_point_of_intermission_bit_3(iut: Iut) {
    let f = msb_frame(DOMINANT);
    for (name, btr) in iso_bit_timings() {
        let (_, bit) = clocks(&btr);
        let start = btr.sample_point_tq() + ipt_tq(&btr);
        let (mut bench, edge) = sof_in_intermission_bit_3(iut, btr, &f, start);
        assert_eq!(
            bench
                .iut_edges(sof_bit(&bench, edge), sof_bit(&bench, edge) + 1)
                .first(),
            Some(&(edge + IUT_DELAY_CLOCKS, DOMINANT)),
            "{name}: the IUT's SOF starts on the LT's edge"
        );
        assert_arbitration_edges_on_the_grid_of(&bench, &f, edge, bit, true, &name);
        assert_eq!(
            bench.iut_events().last(),
            Some(&NodeEvent::TransmitDone(true)),
            "{name}"
        );
    }
}

/// The IUT's recessive bit `k` − 1 before the dominant bit `k` is shortened by `e` quanta (the LT
/// drives bit `k` from there): the IUT's edges from bit `k` on shall move by `moved` quanta earlier.
fn early_edge_moves_the_next_edges(iut: Iut, btr: Btr, e: u32, moved: u32, what: &str) {
    let f = frame();
    let reference = reference_edges(iut, btr, &f);
    let k = dominant_after_recessive_in_arbitration(&f)[0];
    let (tq, _) = clocks(&btr);
    let bench = transmit(iut, btr, &f, |lt| {
        lt.lengthen_bit(k - 1, -(e as i32))
            .set_bit(k, Drive::Dominant);
    });
    let from = bench.bit_start_clock(k) + u64::from(e) * tq;
    let expected: Vec<(u64, bool)> = reference
        .iter()
        .filter(|&&(t, _)| t < bench.bit_start_clock(ack_offset(&f)) + u64::from(e) * tq)
        .map(|&(t, level)| {
            if t < from {
                (t, level)
            } else {
                (t - u64::from(moved) * tq, level)
            }
        })
        .collect();
    assert_eq!(edges_before_ack(&bench, &f), expected, "{what}");
}

/// 8.7.4: a negative phase error up to SJW: the transmitter's next edges follow the early edge.
///
/// ISO 16845-1 8.7.4: the LT shortens a recessive bit before a dominant one in the arbitration field
/// by |e| ∈ [1, min(SJW, Phase_Seg2 − IPT)]: the IUT's next edges come a whole number of bit times
/// after the LT's edge (it moved by |e|).
fn iso_8_7_4_negative_phase_error_up_to_sjw(iut: Iut) {
    for (name, btr) in iso_bit_timings() {
        let top = btr.sjw_tq().min(btr.tseg2_tq() - ipt_tq(&btr));
        for e in 1..=top {
            early_edge_moves_the_next_edges(iut, btr, e, e, &format!("{name}: |e| = {e}"));
        }
    }
}

/// 8.7.5: a negative phase error above SJW: the transmitter moves by SJW only.
///
/// ISO 16845-1 8.7.5: |e| ∈ [SJW + 1, Phase_Seg2 − IPT]: the IUT's next edges come a whole number of
/// bit times plus (|e| − SJW) after the LT's edge (they moved by SJW).
fn iso_8_7_5_negative_phase_error_above_sjw(iut: Iut) {
    let mut cases = 0;
    for (name, btr) in iso_bit_timings() {
        let sjw = btr.sjw_tq();
        for e in sjw + 1..=btr.tseg2_tq() - ipt_tq(&btr) {
            cases += 1;
            early_edge_moves_the_next_edges(iut, btr, e, sjw, &format!("{name}: |e| = {e}"));
        }
    }
    assert!(cases > 0, "a bit timing with SJW < Phase_Seg2 − IPT");
}

/// 8.7.6: one synchronisation per bit for a transmitter.
///
/// ISO 16845-1 8.7.6: the recessive bit before a dominant one is shortened by 1 tq, and the second
/// quantum of the early dominant bit is recessive (a second falling edge): the IUT synchronises on
/// the first edge only; its next edges come a whole number of bit times after it.
fn iso_8_7_6_one_synchronisation_per_bit(iut: Iut) {
    let f = frame();
    let k = dominant_after_recessive_in_arbitration(&f)[0];
    for (name, btr) in iso_bit_timings() {
        let reference = reference_edges(iut, btr, &f);
        let (tq, _) = clocks(&btr);
        let bench = transmit(iut, btr, &f, |lt| {
            lt.lengthen_bit(k - 1, -1)
                .set_bit(k, Drive::Dominant)
                .force(k, 1, 1, Drive::ForceRecessive);
        });
        let from = bench.bit_start_clock(k) + tq;
        let expected: Vec<(u64, bool)> = reference
            .iter()
            .filter(|&&(t, _)| t < bench.bit_start_clock(ack_offset(&f)) + tq)
            .map(|&(t, level)| {
                if t < from {
                    (t, level)
                } else {
                    (t - tq, level)
                }
            })
            .collect();
        assert_eq!(edges_before_ack(&bench, &f), expected, "{name}");
    }
}

/// 8.7.7: a transmitter sending dominant does not resynchronise on late edges.
///
/// ISO 16845-1 8.7.7: the LT delays every recessive-to-dominant edge of the IUT's frame by 2 tq (a
/// positive phase error on a bit the IUT itself sends dominant): the IUT's edges do not move, and the
/// frame goes through.
fn iso_8_7_7_no_resynchronisation_on_late_edges_while_sending_dominant(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let late: Vec<usize> = (1..ack_offset(&f))
        .filter(|&k| encoded.bits[k - 1] == RECESSIVE && encoded.bits[k] == DOMINANT)
        .collect();
    for (name, btr) in iso_bit_timings() {
        let reference = reference_edges(iut, btr, &f);
        let mut bench = transmit(iut, btr, &f, |lt| {
            for &k in &late {
                lt.force(k, 0, 2, Drive::ForceRecessive);
            }
        });
        assert_eq!(
            bench.iut_edges(0, encoded.len()),
            reference,
            "{name}: no edge moves"
        );
        assert_eq!(
            bench.iut_events(),
            [NodeEvent::TransmitDone(true)],
            "{name}"
        );
    }
}

/// 8.7.8: resynchronisation on an edge immediately after the sample point.
///
/// ISO 16845-1 8.7.8: in the alternating identifier of 555h the LT shortens the first recessive bit
/// of an R-D-R-D sequence by Phase_Seg2 and sends the dominant bit: the edge comes Phase_Seg2 early
/// (just after the IUT's sample point); the IUT moves by min(SJW, Phase_Seg2), so its next
/// recessive-to-dominant edge comes 2 bit times + (Phase_Seg2 − SJW) (or + 0) after the LT's edge.
fn iso_8_7_8_resynchronisation_just_after_the_sample_point(iut: Iut) {
    let f = Frame::data(Id::standard(0x555).unwrap(), &[0x55]).unwrap();
    let encoded = encode(&f);
    let k = (1..ack_offset(&f) - 4)
        .find(|&k| {
            (0..4).all(|j| encoded.bits[k + j] == (j % 2 == 0))
                && encoded.tags[k].field == Field::BaseId
        })
        .expect("R D R D in the identifier");
    for (name, btr) in iso_bit_timings() {
        let (tq, bit) = clocks(&btr);
        let ps2 = btr.tseg2_tq();
        let mut bench = transmit(iut, btr, &f, |lt| {
            lt.lengthen_bit(k, -(ps2 as i32))
                .set_bit(k + 1, Drive::Dominant);
        });
        let edge = bench.bit_start_clock(k + 1);
        let lag = u64::from(ps2.saturating_sub(btr.sjw_tq()));
        let next_dominant = bench
            .iut_edges(k + 2, k + 5)
            .into_iter()
            .find(|&(_, level)| level == DOMINANT)
            .map(|(t, _)| t);
        assert_eq!(
            next_dominant,
            Some(edge + 2 * bit + lag * tq + IUT_DELAY_CLOCKS),
            "{name}"
        );
        assert_eq!(
            bench.iut_events(),
            [NodeEvent::TransmitDone(true)],
            "{name}"
        );
    }
}

/// 8.7.9: a transmitter synchronises on an edge after the sample point of a disturbed dominant bit.
///
/// ISO 16845-1 8.7.9: while the IUT sends a dominant bit the LT makes the bus recessive for 2 tq
/// from 1 tq before the sample point: a bit error, and the recessive-to-dominant edge 1 tq after
/// the sample point. By ISO 11898-1 that edge's phase error is −(Phase_Seg2 − 1) tq, so the IUT's
/// next bit (its error flag's first) starts max(0, Phase_Seg2 − 1 − SJW) tq after it, and the flag
/// ends 6 bit times later: that is the IUT's next edge. (The clause states 6 bit times +
/// (Phase_Seg2 − SJW): it counts the phase error as the whole Phase_Seg2, as if the edge were at the
/// sample point; the edge it places is 1 tq later.)
fn iso_8_7_9_synchronisation_after_the_sample_point_of_a_disturbed_dominant_bit(iut: Iut) {
    let f = frame();
    let k = dominant_after_recessive_in_arbitration(&f)[0];
    for (name, btr) in iso_bit_timings() {
        let (tq, bit) = clocks(&btr);
        let (sp, ps2, sjw) = (btr.sample_point_tq(), btr.tseg2_tq(), btr.sjw_tq());
        let mut bench = ProtocolBench::iut_transmits_in(iut, btr, &f);
        bench
            .lt()
            .release(k + 30)
            .force(k, sp - 1, 2, Drive::ForceRecessive);
        bench.run(1);
        let edge = bench.bit_start_clock(k) + u64::from(sp + 1) * tq;
        let lag = u64::from((ps2 - 1).saturating_sub(sjw));
        let flag_end = bench
            .iut_edges(k + 1, k + 10)
            .into_iter()
            .find(|&(_, level)| level == RECESSIVE)
            .map(|(t, _)| t);
        assert_eq!(
            flag_end,
            Some(edge + lag * tq + 6 * bit + IUT_DELAY_CLOCKS),
            "{name}: the end of the error flag"
        );
        assert_eq!(bench.bus_errors().len(), 1, "{name}: one bit error");
    }
}

testbenches::on_both_iuts! {
    iso_8_7_1_transmitter_sample_point,
    iso_8_7_2_hard_sync_before_the_sample_point_of_intermission_bit_3,
    iso_8_7_3_hard_sync_after_the_sample_point_of_intermission_bit_3,
    iso_8_7_4_negative_phase_error_up_to_sjw,
    iso_8_7_5_negative_phase_error_above_sjw,
    iso_8_7_6_one_synchronisation_per_bit,
    iso_8_7_7_no_resynchronisation_on_late_edges_while_sending_dominant,
    iso_8_7_8_resynchronisation_just_after_the_sample_point,
    iso_8_7_9_synchronisation_after_the_sample_point_of_a_disturbed_dominant_bit,
}
