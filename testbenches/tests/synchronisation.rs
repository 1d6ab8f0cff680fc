//! Conformance BT scenarios that need the protocol engine (BT-12 …): synchronisation of a
//! transmitter around the ACK, at the start of a frame and on its own edges. Bit numbers are
//! lower-tester script bits; edge times are clocks from the start of the LT's script (its quantum q
//! starts at q · clocks per tq). BT-14..16 run in every catalog configuration. Every scenario runs
//! on both IUTs (the RTL core, and the controller through its registers).

use sim::bus::Drive;
use sim::can_node::NodeEvent;
use sim::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT, RECESSIVE};
use testbenches::bt_configs;
use testbenches::protocol_bench::{Iut, ProtocolBench, INTEGRATION_BITS};

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
    btr: sim::btr::Btr,
    edit: impl FnOnce(&mut sim::lower_tester::LowerTester, usize),
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
fn reference_edges(iut: Iut, btr: sim::btr::Btr) -> Vec<(u64, bool)> {
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
                .release(INTEGRATION_BITS)
                .send_bits(theirs.bits.iter().by_vals())
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

testbenches::on_both_iuts! {
    bt_12_negative_resync_at_the_crc_delimiter_before_the_ack,
    bt_14_dominant_after_the_sample_point_of_intermission_bit_3_starts_the_own_sof,
    bt_15_transmitter_negative_phase_error_moves_its_next_edges_by_the_absorbed_amount,
    bt_16_transmitter_sending_dominant_does_not_resynchronise_on_a_late_edge,
}
