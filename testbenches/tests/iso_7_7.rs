//! ISO 16845-1:2016 clause 7.7: the IUT as receiver, bit timing (sample point, hard
//! synchronisation, resynchronisation with positive and negative phase errors within and beyond
//! SJW, one synchronisation between two sample points, glitches on an idle bus, no
//! synchronisation after a dominant sample, the ACK after a negative phase error). Each test runs
//! every elementary test case of its clause in the bit timings of [`iso_bit_timings`] (BRP 0 and 2)
//! on both IUTs. Times are in clocks from the start of the LT's script; the IUT's own edges follow
//! the bus edge it synchronised on by [`IUT_DELAY_CLOCKS`].

use golden::btr::Btr;
use golden::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::STUFF;
use testbenches::iso::{
    first_dominant_edge, iso_bit_timings, DELIMITER, FLAG, IUT_DELAY_CLOCKS, RX_SOF,
};
use testbenches::protocol_bench::{Iut, LtScript, ProtocolBench};

/// Frame 7FFh: its identifier has two dominant stuff bits, each after 5 recessive bits.
fn all_ones() -> EncodedFrame {
    encode(&Frame::data(Id::standard(0x7FF).unwrap(), &[]).unwrap())
}

/// The dominant stuff bits of [`all_ones`].
fn dominant_stuff_bits(encoded: &EncodedFrame) -> Vec<usize> {
    (0..encoded.len())
        .filter(|&i| encoded.tags[i].stuff && encoded.bits[i] == DOMINANT)
        .collect()
}

/// Quanta per bit, sample point, Phase_Seg2, SJW (in quanta) and clocks per quantum and bit.
struct Timing {
    ntq: u32,
    sp: u32,
    ps2: u32,
    sjw: u32,
    tq: u64,
    bit: u64,
}

fn timing(btr: &Btr) -> Timing {
    let ntq = btr.quanta_per_bit();
    let sp = btr.sample_point_tq();
    let tq = u64::from(btr.clocks_per_tq());
    Timing {
        ntq,
        sp,
        ps2: ntq - sp,
        sjw: btr.sjw_tq(),
        tq,
        bit: u64::from(ntq) * tq,
    }
}

/// A receiving IUT in `btr`; the LT sends [`all_ones`] up to and including its bit `last` (from
/// [`RX_SOF`]), then `after`, then idles; `edit` changes the script. Run to its end.
fn receive(
    iut: Iut,
    btr: Btr,
    last: usize,
    after: &[bool],
    edit: impl FnOnce(&mut sim::nodes::lower_tester::LowerTester),
) -> ProtocolBench {
    let encoded = all_ones();
    let mut bench = ProtocolBench::with_btr(iut, btr);
    bench
        .lt()
        .release(RX_SOF)
        .send_bits(encoded.bits.iter().by_vals().take(last + 1))
        .send_bits(after.iter().copied())
        .release(30);
    edit(bench.lt());
    bench.run(1);
    bench
}

/// The IUT detected one stuff error and its flag's first edge is at `expected` (clock).
fn assert_stuff_error_flag_at(
    bench: &mut ProtocolBench,
    from_bit: usize,
    expected: u64,
    what: &str,
) {
    let errors = bench.bus_errors();
    assert_eq!(errors.len(), 1, "{what}: one error {errors:02X?}");
    assert_eq!(errors[0] >> 6, STUFF, "{what}: a stuff error");
    assert_eq!(
        first_dominant_edge(bench, from_bit),
        Some(expected),
        "{what}: the error flag's first edge"
    );
}

/// 7.7.1: the sample point.
///
/// ISO 16845-1 7.7.1: the LT shortens a dominant stuff bit of the identifier by Phase_Seg2 (it ends
/// at the sample point: read dominant), and later another by Phase_Seg2 + 1 tq (read recessive: a
/// stuff error). The error flag shall start at the bit after the second. Its edge: the second stuff
/// bit's edge comes Phase_Seg2 early (the first was cut short), the IUT resynchronises by at most
/// SJW, so its bits start Phase_Seg2 − SJW (or 0) after that edge; the flag one bit later.
fn iso_7_7_1_sample_point(iut: Iut) {
    let encoded = all_ones();
    let [s1, s2] = dominant_stuff_bits(&encoded)[..] else {
        panic!("two dominant stuff bits");
    };
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        let mut bench = receive(iut, btr, s2, &[], |lt| {
            lt.lengthen_bit(RX_SOF + s1, -(t.ps2 as i32))
                .lengthen_bit(RX_SOF + s2, -(t.ps2 as i32 + 1));
        });
        let edge = bench.bit_start_clock(RX_SOF + s2);
        let lag = u64::from(t.ps2.saturating_sub(t.sjw));
        let expected = edge + lag * t.tq + t.bit + IUT_DELAY_CLOCKS;
        assert_stuff_error_flag_at(&mut bench, RX_SOF + s1, expected, &name);
    }
}

/// 7.7.2: hard synchronisation on a SOF in the third intermission bit.
///
/// ISO 16845-1 7.7.2: after an error frame, the third intermission bit lasts e ∈ [1, NTQ] tq and a
/// SOF follows with 5 dominant bits (a stuff error at the sixth dominant bit). The IUT hard
/// synchronises on the SOF edge: its error flag starts 6 bit times after that edge (plus the IUT's
/// delay, inside the clause's window of 6 bit times − 1 tq .. 6 bit times measured at the IUT).
fn iso_7_7_2_hard_sync_on_a_sof_in_intermission_bit_3(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2A5).unwrap(), &[0x96]).unwrap();
    let encoded = encode(&frame);
    let data = encoded.position(Field::Data, 0).unwrap();
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        for e in 1..=t.ntq {
            let mut bench = ProtocolBench::with_btr(iut, btr);
            let first_error = RX_SOF + data + 5;
            let int3 = first_error + 1 + FLAG + DELIMITER + 2;
            bench
                .lt()
                .release(RX_SOF)
                .send_bits(encoded.bits.iter().by_vals().take(data))
                .send_bits([DOMINANT; 6])
                .release(int3 - first_error - 1)
                .release(1)
                .lengthen_bit(int3, e as i32 - t.ntq as i32)
                .send_bits([DOMINANT; 6])
                .release(30);
            bench.run(1);
            let sof = bench.bit_start_clock(int3 + 1);
            let what = format!("{name}: intermission bit 3 of {e} tq");
            assert_eq!(bench.bus_errors().len(), 2, "{what}: two stuff errors");
            assert_eq!(
                first_dominant_edge(&bench, int3),
                Some(sof + 6 * t.bit + IUT_DELAY_CLOCKS),
                "{what}: the flag 6 bit times after the SOF edge"
            );
        }
    }
}

/// 7.7.3: a positive phase error up to SJW is corrected completely.
///
/// ISO 16845-1 7.7.3: the LT delays a dominant stuff bit by e ∈ [1, SJW] tq and shortens it by
/// Phase_Seg2 + 1 tq: read at the resynchronised sample point it is recessive (a stuff error); the
/// error flag starts 1 bit time after the delayed edge.
fn iso_7_7_3_positive_phase_error_up_to_sjw(iut: Iut) {
    let s1 = dominant_stuff_bits(&all_ones())[0];
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        for e in 1..=t.sjw {
            let mut bench = receive(iut, btr, s1, &[], |lt| {
                lt.lengthen_bit(RX_SOF + s1 - 1, e as i32)
                    .lengthen_bit(RX_SOF + s1, -(t.ps2 as i32 + 1));
            });
            let edge = bench.bit_start_clock(RX_SOF + s1);
            let what = format!("{name}: e = {e}");
            assert_stuff_error_flag_at(&mut bench, RX_SOF, edge + t.bit + IUT_DELAY_CLOCKS, &what);
        }
    }
}

/// 7.7.4: a positive phase error above SJW is corrected by SJW.
///
/// ISO 16845-1 7.7.4: the LT delays a dominant stuff bit by e ∈ [SJW + 1, NTQ − Phase_Seg2 − 1] tq
/// and shortens it by Phase_Seg2 + 1 + e − SJW tq: the error flag starts 1 bit time − (e − SJW) tq
/// after the delayed edge.
fn iso_7_7_4_positive_phase_error_above_sjw(iut: Iut) {
    let s1 = dominant_stuff_bits(&all_ones())[0];
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        for e in t.sjw + 1..t.ntq - t.ps2 {
            let mut bench = receive(iut, btr, s1, &[], |lt| {
                lt.lengthen_bit(RX_SOF + s1 - 1, e as i32)
                    .lengthen_bit(RX_SOF + s1, -((t.ps2 + 1 + e - t.sjw) as i32));
            });
            let edge = bench.bit_start_clock(RX_SOF + s1);
            let expected = edge + t.bit - u64::from(e - t.sjw) * t.tq + IUT_DELAY_CLOCKS;
            assert_stuff_error_flag_at(&mut bench, RX_SOF, expected, &format!("{name}: e = {e}"));
        }
    }
}

/// The stimulus of 7.7.5 and 7.7.6: the recessive bit before the first dominant stuff bit is
/// shortened by `e` tq, the stuff bit is dominant for 1 tq and recessive after it.
fn early_one_quantum_stuff_bit(iut: Iut, btr: Btr, e: u32) -> (ProtocolBench, u64) {
    let s1 = dominant_stuff_bits(&all_ones())[0];
    let ntq = btr.quanta_per_bit();
    let bench = receive(iut, btr, s1, &[], |lt| {
        lt.lengthen_bit(RX_SOF + s1 - 1, -(e as i32)).force(
            RX_SOF + s1,
            1,
            ntq - 1,
            Drive::ForceRecessive,
        );
    });
    let edge = bench.bit_start_clock(RX_SOF + s1);
    (bench, edge)
}

/// 7.7.5: a negative phase error up to SJW is corrected completely.
///
/// ISO 16845-1 7.7.5: the recessive bit before a dominant stuff bit is shortened by |e| ∈ [1, SJW]
/// tq, the stuff bit is dominant for 1 tq only: the error flag starts 1 bit time after that edge.
fn iso_7_7_5_negative_phase_error_up_to_sjw(iut: Iut) {
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        for e in 1..=t.sjw.min(t.ps2) {
            let (mut bench, edge) = early_one_quantum_stuff_bit(iut, btr, e);
            let what = format!("{name}: |e| = {e}");
            assert_stuff_error_flag_at(&mut bench, RX_SOF, edge + t.bit + IUT_DELAY_CLOCKS, &what);
        }
    }
}

/// 7.7.6: a negative phase error above SJW is corrected by SJW.
///
/// ISO 16845-1 7.7.6: as 7.7.5 with |e| ∈ [SJW + 1, Phase_Seg2]: the error flag starts 1 bit time +
/// (|e| − SJW) tq after the edge.
fn iso_7_7_6_negative_phase_error_above_sjw(iut: Iut) {
    let mut cases = 0;
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        for e in t.sjw + 1..=t.ps2 {
            cases += 1;
            let (mut bench, edge) = early_one_quantum_stuff_bit(iut, btr, e);
            let expected = edge + t.bit + u64::from(e - t.sjw) * t.tq + IUT_DELAY_CLOCKS;
            assert_stuff_error_flag_at(&mut bench, RX_SOF, expected, &format!("{name}: |e| = {e}"));
        }
    }
    assert!(cases > 0, "a bit timing with SJW < Phase_Seg2");
}

/// 7.7.7: one synchronisation between two sample points (edges after Sync).
///
/// ISO 16845-1 7.7.7: a dominant stuff bit whose third quantum is recessive (a second falling edge
/// after it), then 6 recessive bits: the second edge is not used (one synchronisation per bit), the
/// stuff bit is read dominant, and the sixth recessive bit is a stuff error: the error flag starts
/// exactly 7 bit times after the stuff bit's first edge.
fn iso_7_7_7_one_synchronisation_between_sample_points(iut: Iut) {
    let s1 = dominant_stuff_bits(&all_ones())[0];
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        let mut bench = receive(iut, btr, s1, &[], |lt| {
            lt.force(RX_SOF + s1, 2, 1, Drive::ForceRecessive);
        });
        let edge = bench.bit_start_clock(RX_SOF + s1);
        assert_stuff_error_flag_at(
            &mut bench,
            RX_SOF,
            edge + 7 * t.bit + IUT_DELAY_CLOCKS,
            &name,
        );
    }
}

/// 7.7.8: one synchronisation between two sample points (the first edge before Sync).
///
/// ISO 16845-1 7.7.8: as 7.7.7 with the recessive bit before the stuff bit shortened by 1 tq (the
/// first edge is early, a negative phase error of 1 tq corrected completely): the error flag starts
/// exactly 7 bit times after that first edge.
fn iso_7_7_8_one_synchronisation_after_an_early_edge(iut: Iut) {
    let s1 = dominant_stuff_bits(&all_ones())[0];
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        let mut bench = receive(iut, btr, s1, &[], |lt| {
            lt.lengthen_bit(RX_SOF + s1 - 1, -1)
                .force(RX_SOF + s1, 2, 1, Drive::ForceRecessive);
        });
        let edge = bench.bit_start_clock(RX_SOF + s1);
        assert_stuff_error_flag_at(
            &mut bench,
            RX_SOF,
            edge + 7 * t.bit + IUT_DELAY_CLOCKS,
            &name,
        );
    }
}

/// After idle-bus glitches from bit [`RX_SOF`] (`edit`), the IUT shall stay idle: no dominant bit,
/// no event, and a frame sent 8 bits later is received as usual.
fn stays_idle_after(
    iut: Iut,
    btr: Btr,
    name: &str,
    edit: impl FnOnce(&mut sim::nodes::lower_tester::LowerTester),
) {
    let frame = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81]).unwrap();
    let encoded = encode(&frame);
    let mut bench = ProtocolBench::with_btr(iut, btr);
    let sof = RX_SOF + 1 + 8;
    bench.lt().release(sof).send_frame(&encoded).release(4);
    edit(bench.lt());
    bench.run(1);
    let ack = sof + encoded.position(Field::AckSlot, 0).unwrap();
    assert_eq!(
        bench.iut_dominant_bits(0, ack + 10),
        vec![ack],
        "{name}: idle, then only the ACK of the next frame"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::Received(frame)],
        "{name}"
    );
}

/// 7.7.9.1: a dominant pulse shorter than Prop_Seg + Phase_Seg1 on the idle bus is no SOF.
///
/// ISO 16845-1 7.7.9.1: a dominant pulse of TSEG1 − 1 tq (the IUT hard-synchronises on it and
/// samples recessive at its sample point): the IUT shall stay idle.
fn iso_7_7_9_1_short_idle_pulse_is_no_sof(iut: Iut) {
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        stays_idle_after(iut, btr, &name, |lt| {
            lt.force(RX_SOF, 0, t.sp - 2, Drive::Dominant);
        });
    }
}

/// 7.7.9.2: no resynchronisation after the hard synchronisation on an idle-bus edge.
///
/// ISO 16845-1 7.7.9.2: three dominant glitches: (TSEG1 − 2)/2 tq, 2 tq recessive, (TSEG1 − 2)/2 tq
/// (the rest of TSEG1 − 2 for an odd TSEG1), 1 tq recessive, then TSEG1 − 2 tq. Hard-synchronised
/// on the first edge, the IUT samples the recessive quantum around its sample point; had it
/// resynchronised on the second edge it would sample the third glitch. The IUT shall stay idle.
/// (The clause shortens the second glitch by one minimum time quantum and widens the recessive gap
/// by two; the LT here works in whole quanta, so the gap is the quantum that ends at the sample
/// point.)
fn iso_7_7_9_2_no_resynchronisation_after_hard_sync(iut: Iut) {
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        let tseg1 = t.sp - 1;
        let first = (tseg1 - 2) / 2;
        let second = tseg1 - 2 - first;
        stays_idle_after(iut, btr, &name, |lt| {
            lt.force(RX_SOF, 0, first, Drive::Dominant)
                .force(RX_SOF, first + 2, second, Drive::Dominant)
                .force(RX_SOF, first + 2 + second + 1, tseg1 - 2, Drive::Dominant);
        });
    }
}

/// 7.7.10: no synchronisation on an edge when the previous sample equals the level after it.
///
/// ISO 16845-1 7.7.10: a dominant stuff bit with one recessive quantum at NTQ − Phase_Seg2 + 1 tq
/// after its edge (in Phase_Seg2), followed by 5 dominant bits: the falling edge after that glitch
/// follows a dominant sample and is not used; the sixth dominant bit is a stuff error, and the error
/// flag starts exactly 6 bit times after the stuff bit's edge.
fn iso_7_7_10_no_synchronisation_after_a_dominant_sample(iut: Iut) {
    let s1 = dominant_stuff_bits(&all_ones())[0];
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        let mut bench = receive(iut, btr, s1, &[DOMINANT; 5], |lt| {
            lt.force(RX_SOF + s1, t.sp + 1, 1, Drive::ForceRecessive);
        });
        let edge = bench.bit_start_clock(RX_SOF + s1);
        assert_stuff_error_flag_at(
            &mut bench,
            RX_SOF,
            edge + 6 * t.bit + IUT_DELAY_CLOCKS,
            &name,
        );
    }
}

/// 7.7.11: a negative phase error at the ACK.
///
/// ISO 16845-1 7.7.11 (labelled 7.7.3 in some descriptions): the LT makes the last |e| ∈ [1, SJW]
/// quanta of the CRC delimiter dominant and forces the ACK bit recessive for its last Phase_Seg2 +
/// |e| quanta: the IUT resynchronises on the early edge, so its sample point falls just before the
/// recessive part and its ACK is read dominant: the frame is valid, no error flag.
fn iso_7_7_11_negative_phase_error_at_the_ack(iut: Iut) {
    let frame = Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap();
    let encoded = encode(&frame);
    let delimiter = RX_SOF + encoded.position(Field::CrcDelim, 0).unwrap();
    let ack = RX_SOF + encoded.position(Field::AckSlot, 0).unwrap();
    for (name, btr) in iso_bit_timings() {
        let t = timing(&btr);
        for e in 1..=t.sjw.min(t.ps2) {
            let mut bench = ProtocolBench::with_btr(iut, btr);
            bench
                .lt()
                .release(RX_SOF)
                .send_frame(&encoded)
                .release(4)
                .force(delimiter, t.ntq - e, e, Drive::Dominant)
                .force(ack, t.ntq - t.ps2 - e, t.ps2 + e, Drive::ForceRecessive);
            bench.run(1);
            let what = format!("{name}: |e| = {e}");
            assert_eq!(
                bench.iut_events(),
                vec![NodeEvent::Received(frame)],
                "{what}"
            );
            assert_eq!(bench.rec(), 0, "{what}");
        }
    }
}

testbenches::on_both_iuts! {
    iso_7_7_1_sample_point,
    iso_7_7_2_hard_sync_on_a_sof_in_intermission_bit_3,
    iso_7_7_3_positive_phase_error_up_to_sjw,
    iso_7_7_4_positive_phase_error_above_sjw,
    iso_7_7_5_negative_phase_error_up_to_sjw,
    iso_7_7_6_negative_phase_error_above_sjw,
    iso_7_7_7_one_synchronisation_between_sample_points,
    iso_7_7_8_one_synchronisation_after_an_early_edge,
    iso_7_7_9_1_short_idle_pulse_is_no_sof,
    iso_7_7_9_2_no_resynchronisation_after_hard_sync,
    iso_7_7_10_no_synchronisation_after_a_dominant_sample,
    iso_7_7_11_negative_phase_error_at_the_ack,
}
