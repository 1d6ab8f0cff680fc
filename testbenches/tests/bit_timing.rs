//! Conformance group BT (bit timing and synchronisation) at the level of the bit timing logic's sample
//! and transmit points, in every catalog configuration (BT-A, BT-B, BT-C, each with BRP 0 and BRP > 0),
//! sweeping every phase error. Positions are lower-tester script quanta: a sample "at quantum q of a bit"
//! took the bus level of the last clock of quantum q − 1 of that bit. The error-flag case of BT-18 needs
//! the protocol engine: a transmitter (the IUT: an RTL core, or the controller through its registers)
//! and a receiving RTL core (`CanNode`), with the LT injecting the error.

use golden::btr::Btr;
use golden::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::engine::time::ClockSpec;
use sim::engine::DeviceId;
use sim::nodes::can_node::{CanNode, NodeEvent};
use testbenches::protocol_bench::{Iut, LtScript, ProtocolBench};
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
fn phase_error_bench(btr: golden::btr::Btr, phase_error: i32) -> BtBench {
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
                .send_frame(&frame)
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
                    .filter(|e| e.kind == sim::nodes::btl_node::BtlEventKind::HardSync)
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
            e.kind == sim::nodes::btl_node::BtlEventKind::Resync && e.at_fs >= from && e.at_fs < to
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
            let btr = golden::btr::Btr { sam, ..cfg.btr };
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
    use golden::worst_case::longest_frame;
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

/// One exchange of [`error_flag_exchange`].
struct FlagExchange {
    /// The transmitter is the bench's IUT; the LT's script bits are its bits (same clock).
    bench: ProtocolBench,
    /// The receiver.
    rx: DeviceId,
    /// The transmitter's recessive stuff bit forced dominant.
    error_at: usize,
}

impl FlagExchange {
    fn receiver(&self) -> &CanNode {
        self.bench.engine.device(self.rx)
    }
}

/// A data frame whose data field has a recessive stuff bit after five dominant bits.
fn flag_case_frame() -> Frame {
    Frame::data(Id::standard(0x2C5).unwrap(), &[0x00, 0x00]).unwrap()
}

/// A transmitter on a clock `tx_ppm` off nominal sends [`flag_case_frame`] to a receiver at
/// `rx_ppm` whose line delay fills the propagation segment (see [`receiver_delay_fs`]). With
/// `inject`, the LT (on the transmitter's clock, so its script bits are the transmitter's bits)
/// forces the first recessive stuff bit of the data field dominant, from 2 tq before that bit to
/// 4 tq into the next one (no edge of its own): the transmitter sees a bit error, the receiver a
/// stuff error, both send an error flag, and the bus has been dominant for 12 bits since the last
/// recessive → dominant edge (the start of the five dominant bits) when the error delimiter starts.
fn error_flag_exchange(iut: Iut, btr: Btr, tx_ppm: f64, rx_ppm: f64, inject: bool) -> FlagExchange {
    let encoded = encode(&flag_case_frame());
    let error_at = (0..encoded.len())
        .find(|&i| {
            let tag = &encoded.tags[i];
            tag.stuff && tag.field == Field::Data && encoded.bits[i] == R
        })
        .expect("a recessive stuff bit in the data field");
    assert!(
        (error_at - 5..error_at).all(|i| encoded.bits[i] == D) && encoded.bits[error_at - 6] == R
    );
    let tx_clock = ClockSpec::with_ppm(testbenches::CLOCK_HZ, tx_ppm);
    let rx_clock = ClockSpec::with_ppm(testbenches::CLOCK_HZ, rx_ppm);
    let mut bench = ProtocolBench::iut_transmits_on(iut, btr, tx_clock, &flag_case_frame());
    let rx = bench
        .engine
        .add(CanNode::new("rx", rx_clock, btr), receiver_delay_fs(btr));
    let nbt = btr.quanta_per_bit();
    bench.lt().release(error_at + 18 + encoded.len() + 10);
    if inject {
        bench
            .lt()
            .force(error_at - 1, nbt - 2, nbt + 6, Drive::Dominant);
    }
    bench.run(0);
    FlagExchange {
        bench,
        rx,
        error_at,
    }
}

/// The receiver's line delay (each way) for which the loop transmitter → receiver → transmitter
/// (2 · delay plus 7 clocks of the two nodes' synchronisers and tx registers) fills the propagation
/// segment of [`Btr::prop_seg_tq`], as ISO 11898-1's tolerance formula assumes; 0 when those 7
/// clocks alone are longer (BT-B with BRP 0). The transmitter then has Sync + Phase_Seg1 left for the
/// drift when it reads the end of the receiver's error flag.
fn receiver_delay_fs(btr: Btr) -> u64 {
    let period = ClockSpec::from_hz(testbenches::CLOCK_HZ).period_fs();
    let prop_clocks = u64::from(btr.prop_seg_tq() * btr.clocks_per_tq());
    prop_clocks.saturating_sub(7) * period / 2
}

/// BT-A timing with SJW 4: the oscillator tolerance is set by the error-flag condition
/// (4/(2·(13·16 − 4)) ≈ 0.98 %) rather than by the SJW condition (4/320 = 1.25 %).
fn bt_a_sjw_4(brp: u8) -> Btr {
    Btr::from_quanta(brp, 11, 4, 4, false).expect("BT-A with SJW 4")
}

/// BT-18, the 13-bit case of the tolerance condition `min(Phase_Seg1, Phase_Seg2) / (2·(13·NBT −
/// Phase_Seg2))`: an error flag after five dominant bits and a stuff error leaves the bus without a
/// resynchronising edge for 12 bits, and both nodes must still read the 13th (the first delimiter
/// bit) correctly. Transmitter and receiver at +df and −df (and the other way round), df the
/// configuration's tolerance, with the propagation segment filled by the line delay: one error frame
/// (bit error for the transmitter, stuff error for the receiver), the retransmission exactly 18 bits
/// after the error, received; TEC 8 − 1, REC 1 − 1. Run in the catalog configurations and in BT-A with
/// SJW 4, where df comes from this condition. Measured there: from about 1.6·df (BRP 0) or 1.4·df
/// (BRP 2) on, the fast transmitter reads the end of the slow receiver's flag as the first bit after
/// its own, so its delimiter and retransmission come one bit late, while a frame without error is
/// still exchanged correctly at those clocks; checked at 1.75·df.
fn bt_18_error_flag_case_the_13th_bit_after_the_last_edge_is_read_correctly(iut: Iut) {
    let mut configs: Vec<(String, Btr)> = bt_configs()
        .into_iter()
        .map(|c| (c.name.to_string(), c.btr))
        .collect();
    for brp in [0, testbenches::BRP_ABOVE_ZERO] {
        configs.push((format!("BT-A SJW 4/BRP{brp}"), bt_a_sjw_4(brp)));
    }
    for (name, btr) in configs {
        let df_ppm = btr.oscillator_tolerance() * 1e6;
        for tx_sign in [1.0, -1.0] {
            let what = format!(
                "{name}: transmitter {:+.0} ppm, receiver {:+.0} ppm",
                tx_sign * df_ppm,
                -tx_sign * df_ppm
            );
            let mut x = error_flag_exchange(iut, btr, tx_sign * df_ppm, -tx_sign * df_ppm, true);
            let e = x.error_at;
            let mut expected: Vec<usize> = (e + 1..=e + 6).collect();
            expected.push(e + 18);
            assert_eq!(
                x.bench.iut_dominant_bits(e + 1, e + 19),
                expected,
                "{what}: the transmitter's flag, then its retransmission at e + 18"
            );
            assert_eq!(
                x.bench.iut_events(),
                vec![NodeEvent::BusError(0x0A), NodeEvent::TransmitDone(true)],
                "{what}: bit error (TX, data field), then sent"
            );
            assert_eq!(
                x.receiver()
                    .events()
                    .iter()
                    .map(|(_, ev)| ev.clone())
                    .collect::<Vec<_>>(),
                vec![
                    NodeEvent::BusError(0xAA),
                    NodeEvent::Received(flag_case_frame())
                ],
                "{what}: stuff error (RX, data field), then received"
            );
            assert_eq!(
                (x.bench.tec(), x.receiver().rec()),
                (7, 0),
                "{what}: TEC +8 −1, REC +1 −1"
            );
        }
    }
    for brp in [0, testbenches::BRP_ABOVE_ZERO] {
        let btr = bt_a_sjw_4(brp);
        let ppm = 1.75 * btr.oscillator_tolerance() * 1e6;
        let x = error_flag_exchange(iut, btr, ppm, -ppm, true);
        let e = x.error_at;
        let mut late: Vec<usize> = (e + 1..=e + 6).collect();
        late.push(e + 19);
        assert_eq!(
            x.bench.iut_dominant_bits(e + 1, e + 20),
            late,
            "BT-A SJW 4/BRP{brp} at ±{ppm:.0} ppm: the 13th bit is misread, the retransmission is late"
        );
        let mut clean = error_flag_exchange(iut, btr, ppm, -ppm, false);
        assert_eq!(
            clean.bench.iut_events(),
            vec![NodeEvent::TransmitDone(true)],
            "BT-A SJW 4/BRP{brp} at ±{ppm:.0} ppm: without the error the frame still gets through"
        );
        assert_eq!(clean.receiver().received(), vec![flag_case_frame()]);
    }
}

testbenches::on_both_iuts! {
    bt_18_error_flag_case_the_13th_bit_after_the_last_edge_is_read_correctly,
}
