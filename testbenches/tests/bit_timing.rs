//! Conformance group BT (bit timing and synchronisation) at the level of the bit timing logic's sample
//! and transmit points, in every catalog configuration (BT-A, BT-B, BT-C, each with BRP 0 and BRP > 0),
//! sweeping every phase error. Positions are lower-tester script quanta: a sample "at quantum q of a bit"
//! took the bus level of the last clock of quantum q − 1 of that bit.

use sim::bus::Drive;
use sim::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE};
use testbenches::{bt_configs, BtBench, LEAD_IN_BITS};

const D: bool = DOMINANT;
const R: bool = RECESSIVE;
/// Script bit of the start of frame in the receive scenarios.
const SOF: usize = LEAD_IN_BITS;

/// Idle lead-in, SOF, then `bits`, then idle.
fn frame_script(bench: &mut BtBench, bits: &[bool]) {
    bench
        .lt()
        .release(LEAD_IN_BITS)
        .send_bits([D])
        .send_bits(bits.iter().copied())
        .release(3);
}

/// Receive scenario with an edge moved by `phase_error` quanta: SOF, R, D(edge), R, D; the recessive
/// bit before the edge is lengthened (late edge, e > 0) or shortened (early edge, e < 0).
fn phase_error_bench(btr: sim::btr::Btr, phase_error: i32) -> BtBench {
    let mut bench = BtBench::new(btr);
    frame_script(&mut bench, &[R, D, R, D]);
    bench.lt().lengthen_bit(SOF + 1, phase_error);
    bench.run();
    bench
}

/// Where the IUT samples the bit after a moved edge, in quanta from that bit's (moved) start.
fn expected_offset_after_edge(sp: usize, sjw: usize, phase_error: i32) -> usize {
    let e = phase_error.unsigned_abs() as usize;
    let absorbed = e.min(sjw);
    if phase_error > 0 {
        sp + absorbed - e
    } else {
        sp + e - absorbed
    }
}

#[test]
fn bt_01_dominant_bit_ending_at_the_sample_point_is_read_dominant() {
    for cfg in bt_configs() {
        let frame = encode(&Frame::data(Id::standard(0x7FF).unwrap(), &[]).unwrap());
        let stuff = (0..frame.len())
            .find(|&i| frame.tags[i].stuff && frame.bits[i] == D)
            .expect("ID 0x7FF has a dominant stuff bit");
        assert_eq!(
            frame.bits[stuff + 1],
            R,
            "the stuff bit is followed by a recessive bit"
        );
        for (length_tq, expected) in [(0, D), (-1, R)] {
            let mut bench = BtBench::new(cfg.btr);
            let sp = bench.sp() as i32;
            let nbt = bench.nbt() as i32;
            bench
                .lt()
                .release(LEAD_IN_BITS)
                .send_bits(frame.bits.iter().by_vals())
                .release(3)
                .lengthen_bit(LEAD_IN_BITS + stuff, sp + length_tq - nbt);
            bench.run();
            let sample_point = bench.lt_ref().bit_start_quantum(LEAD_IN_BITS + stuff) + sp as usize;
            assert_eq!(
                bench.sample_at_quantum(sample_point),
                Some(expected),
                "{}: stuff bit lasting {} tq",
                cfg.name,
                sp + length_tq
            );
        }
    }
}

#[test]
fn bt_02_transmitter_samples_its_own_bit_at_the_sample_point() {
    for cfg in bt_configs() {
        let frame = encode(&Frame::data(Id::standard(0x000).unwrap(), &[]).unwrap());
        let bit = frame.position(Field::BaseId, 2).unwrap();
        assert_eq!(frame.bits[bit], D);
        for (force_from, expected) in [(1, D), (0, D), (-1, R)] {
            let mut bench = BtBench::new(cfg.btr);
            let (sp, nbt) = (bench.sp() as i32, bench.nbt() as i32);
            bench.iut_mut().transmit(frame.bits.iter().by_vals());
            let from = (sp + force_from) as u32;
            bench
                .lt()
                .start_on_dominant()
                .release(frame.len() + 3)
                .force(bit, from, (nbt as u32) - from, Drive::ForceRecessive);
            bench.run();
            let q = bit * bench.nbt() + bench.sp();
            assert_eq!(
                bench.sample_at_quantum(q),
                Some(expected),
                "{}: own dominant bit forced recessive from SP{:+} tq",
                cfg.name,
                force_from
            );
        }
    }
}

#[test]
fn bt_03_hard_sync_at_every_offset() {
    for cfg in bt_configs() {
        let clocks_per_tq = cfg.btr.clocks_per_tq() as u64;
        let nbt = cfg.btr.quanta_per_bit() as i32;
        for lt_delay in 0..clocks_per_tq {
            for last_idle_tq in 1..=nbt {
                let mut bench = BtBench::with_lt_delay_clocks(cfg.btr, lt_delay);
                frame_script(&mut bench, &[D, D, D, D, D]);
                bench.lt().lengthen_bit(SOF - 1, last_idle_tq - nbt);
                bench.run();
                let hard_syncs = bench
                    .iut()
                    .events()
                    .iter()
                    .filter(|e| e.kind == sim::btl_node::BtlEventKind::HardSync)
                    .count();
                assert_eq!(hard_syncs, 1, "{}: one hard synchronisation", cfg.name);
                for bit in SOF..SOF + 6 {
                    assert_eq!(
                        bench.sample_in_bit(bit),
                        Some((bench.sp(), D)),
                        "{}: LT {} clocks late, last idle bit {} tq: bit {} after SOF",
                        cfg.name,
                        lt_delay,
                        last_idle_tq,
                        bit - SOF
                    );
                }
            }
        }
    }
}

fn check_phase_errors(errors: impl Fn(usize, usize, usize) -> Vec<i32>) {
    for cfg in bt_configs() {
        let (sjw, tseg1, tseg2) = (
            cfg.btr.sjw_tq() as usize,
            cfg.btr.tseg1_tq() as usize,
            cfg.btr.tseg2_tq() as usize,
        );
        for e in errors(sjw, tseg1, tseg2) {
            let bench = phase_error_bench(cfg.btr, e);
            let expected = expected_offset_after_edge(bench.sp(), sjw, e);
            assert_eq!(
                bench.sample_in_bit(SOF + 2),
                Some((expected, D)),
                "{}: phase error {e:+} tq (SJW {sjw})",
                cfg.name
            );
            assert_eq!(
                bench.sample_in_bit(SOF + 1),
                Some((bench.sp(), R)),
                "{}: phase error {e:+}: the bit before the edge",
                cfg.name
            );
        }
    }
}

#[test]
fn bt_04_positive_phase_error_up_to_sjw_is_absorbed() {
    check_phase_errors(|sjw, _, _| (1..=sjw as i32).collect());
}

#[test]
fn bt_05_positive_phase_error_above_sjw_is_absorbed_by_sjw_only() {
    check_phase_errors(|sjw, tseg1, _| (sjw as i32 + 1..=tseg1 as i32).collect());
}

#[test]
fn bt_06_negative_phase_error_up_to_sjw_is_absorbed() {
    check_phase_errors(|sjw, _, tseg2| (1..=sjw.min(tseg2) as i32).map(|e| -e).collect());
}

#[test]
fn bt_07_negative_phase_error_above_sjw_is_absorbed_by_sjw_only() {
    check_phase_errors(|sjw, _, tseg2| (sjw as i32 + 1..=tseg2 as i32).map(|e| -e).collect());
}

fn resyncs_between(bench: &BtBench, from_bit: usize, to_bit: usize) -> usize {
    let lt = bench.lt_ref();
    let from = lt.bit_time(from_bit).unwrap();
    let to = lt.bit_time(to_bit).unwrap();
    bench
        .iut()
        .events()
        .iter()
        .filter(|e| {
            e.kind == sim::btl_node::BtlEventKind::Resync && e.at_fs >= from && e.at_fs < to
        })
        .count()
}

#[test]
fn bt_08_only_one_synchronisation_between_two_sample_points() {
    for cfg in bt_configs() {
        let sp = cfg.btr.sample_point_tq();
        // First edge 1 tq late (absorbed), then a 1-tq recessive glitch whose falling edge would be a
        // second synchronisation before the sample point.
        for glitch_at in 1..sp - 2 {
            let mut bench = BtBench::new(cfg.btr);
            frame_script(&mut bench, &[R, D, R, D]);
            bench
                .lt()
                .lengthen_bit(SOF + 1, 1)
                .force(SOF + 2, glitch_at, 1, Drive::Recessive);
            bench.run();
            assert_eq!(
                bench.sample_in_bit(SOF + 2),
                Some((sp as usize, D)),
                "{}: glitch at tq {glitch_at}",
                cfg.name
            );
            assert_eq!(resyncs_between(&bench, SOF + 2, SOF + 3), 1, "{}", cfg.name);
        }
    }
}

#[test]
fn bt_09_no_synchronisation_after_a_dominant_sample() {
    for cfg in bt_configs() {
        let (sp, nbt) = (cfg.btr.sample_point_tq(), cfg.btr.quanta_per_bit());
        // A recessive glitch inside a dominant bit (edge late) and at the end of the bit before it
        // (edge early): the previous sample was dominant, so neither edge synchronises.
        let glitches: Vec<(usize, u32)> = (0..sp - 2)
            .map(|q| (SOF + 2, q))
            .chain((sp..nbt - 1).map(|q| (SOF + 1, q)))
            .collect();
        for (bit, glitch_at) in glitches {
            let mut bench = BtBench::new(cfg.btr);
            frame_script(&mut bench, &[D, D, D]);
            bench.lt().force(bit, glitch_at, 1, Drive::Recessive);
            bench.run();
            for b in SOF..SOF + 4 {
                assert_eq!(
                    bench.sample_in_bit(b),
                    Some((sp as usize, D)),
                    "{}: glitch in bit {} at tq {glitch_at}, sample of bit {}",
                    cfg.name,
                    bit - SOF,
                    b - SOF
                );
            }
            assert_eq!(resyncs_between(&bench, SOF, SOF + 4), 0, "{}", cfg.name);
        }
    }
}

#[test]
fn bt_10_idle_glitch_is_a_start_of_frame_only_past_the_sample_point() {
    for cfg in bt_configs() {
        let sp = cfg.btr.sample_point_tq();
        for pulse_tq in 1..=sp + 1 {
            let mut bench = BtBench::new(cfg.btr);
            bench
                .lt()
                .release(LEAD_IN_BITS + 4)
                .force(SOF, 0, pulse_tq, Drive::Dominant);
            bench.run();
            let expected = if pulse_tq >= sp { D } else { R };
            assert_eq!(
                bench.sample_in_bit(SOF),
                Some((sp as usize, expected)),
                "{}: idle pulse of {pulse_tq} tq",
                cfg.name
            );
        }
    }
}

#[test]
fn bt_11_glitches_after_a_hard_sync_do_not_resynchronise() {
    for cfg in bt_configs() {
        let sp = cfg.btr.sample_point_tq();
        let singles = (1..sp - 1).map(|q| vec![q]);
        let group = std::iter::once((1..sp - 1).step_by(2).collect::<Vec<_>>());
        for glitches in singles.chain(group) {
            let mut bench = BtBench::new(cfg.btr);
            frame_script(&mut bench, &[D, R, D]);
            for &q in &glitches {
                bench.lt().force(SOF, q, 1, Drive::Recessive);
            }
            bench.run();
            assert_eq!(
                bench.sample_in_bit(SOF),
                Some((sp as usize, D)),
                "{}: glitches at {glitches:?}",
                cfg.name
            );
            assert_eq!(resyncs_between(&bench, SOF, SOF + 1), 0, "{}", cfg.name);
            assert_eq!(bench.sample_in_bit(SOF + 1), Some((sp as usize, D)));
        }
    }
}

#[test]
fn bt_17_triple_sampling_outvotes_one_quantum_spikes() {
    for cfg in bt_configs() {
        for sam in [false, true] {
            let btr = sim::btr::Btr { sam, ..cfg.btr };
            let sp = btr.sample_point_tq();
            // (first quantum of the spike relative to the sample point, length) → sampled level.
            let spikes = [(1, 1), (2, 1), (3, 1), (2, 2), (3, 2)];
            for (before_sp, length) in spikes {
                let start = sp - before_sp;
                let covers_last = start + length == sp;
                let expected = match (sam, length) {
                    (true, 1) => D,
                    (true, _) => R,
                    (false, _) if covers_last => R,
                    (false, _) => D,
                };
                let mut bench = BtBench::new(btr);
                frame_script(&mut bench, &[D, D]);
                bench.lt().force(SOF + 1, start, length, Drive::Recessive);
                bench.run();
                assert_eq!(
                    bench.sample_in_bit(SOF + 1),
                    Some((sp as usize, expected)),
                    "{} SAM={}: {length}-tq spike starting {before_sp} tq before the sample point",
                    cfg.name,
                    sam as u8
                );
            }
        }
    }
}

/// Two nodes at +df and −df (so their clocks differ by 2·df), df being the ISO 11898-1 tolerance
/// `min(SJW/(20·NBT), min(Phase1, Phase2)/(2·(13·NBT − Phase2)))` of the configuration, exchange the
/// longest possible frames (most stuff bits: resynchronising edges 10 bits apart) and a 0x0F data
/// pattern. Measured: no wrong bit up to 1.1·df in every configuration; from 1.25·df (BT-A, BT-C) or
/// 1.5·df (BT-B) on, bits are sampled in the wrong bit time.
#[test]
fn bt_18_oscillator_tolerance_at_and_beyond_the_limit() {
    use sim::worst_case::longest_frame;
    let frames: Vec<_> = [
        longest_frame(false, 8),
        longest_frame(true, 8),
        longest_frame(false, 0),
        Frame::data(Id::standard(0x7FF).unwrap(), &[0x0F; 8]).unwrap(),
    ]
    .iter()
    .map(encode)
    .collect();
    for cfg in bt_configs() {
        let df_ppm = cfg.btr.oscillator_tolerance() * 1e6;
        let at_limit = testbenches::exchange_with_clock_offset(cfg.btr, df_ppm, &frames);
        assert_eq!(
            at_limit,
            vec![0; frames.len()],
            "{}: ±{df_ppm:.0} ppm",
            cfg.name
        );
        let beyond = testbenches::exchange_with_clock_offset(cfg.btr, 2.0 * df_ppm, &frames);
        assert!(
            beyond.iter().sum::<usize>() > 0,
            "{}: ±{:.0} ppm should break sampling",
            cfg.name,
            2.0 * df_ppm
        );
    }
}
