//! Conformance groups AK, BE, EC, EP, OV, BO and RT (error flags, counter rules, error passive,
//! overload, bus-off and recovery, retransmission) on both IUTs (the RTL core, and the controller
//! through its registers). Bit numbers are lower-tester script bits; an error detected at bit e
//! gives a flag e+1..e+6.

use golden::frame::{encode, Field, Frame, Id, DOMINANT};
use rtl::registers::{interrupt, mode, pelican, status};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::protocol_bench::{
    first_dominant, ErrorInterrupt, Iut, LtScript, ProtocolBench, INTEGRATION_BITS,
};

const SOF: usize = INTEGRATION_BITS;
/// A receiver's stuff error on the sixth dominant bit: SOF and five dominant ID bits, then a sixth.
const STUFF_ERROR_AT: usize = SOF + 5;

fn frame() -> Frame {
    Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap()
}

fn flag_after(e: usize) -> Vec<usize> {
    (e + 1..=e + 6).collect()
}

fn bus_errors(bench: &mut ProtocolBench) -> usize {
    bench.bus_errors().len()
}

/// The IUT receives six dominant bits (stuff error at [`STUFF_ERROR_AT`]); after its error flag the
/// LT drives `after_flag` dominant bits, then releases the bus.
fn receiver_error_then_dominant(iut: Iut, after_flag: usize) -> ProtocolBench {
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .after_integration()
        .send_bits([DOMINANT; 6])
        .release(6)
        .send_bits(std::iter::repeat_n(DOMINANT, after_flag))
        .release(20);
    bench.run(1);
    bench
}

/// The IUT transmits `frame()`; the LT forces its first dominant identifier bit recessive (bit error),
/// drives `after_flag` dominant bits after the error flag, then releases the bus for `tail` bits.
fn transmitter_error_then_dominant(
    iut: Iut,
    tec: u8,
    after_flag: usize,
    tail: usize,
) -> (ProtocolBench, usize) {
    let (mut bench, bit) = transmitter_error_script(iut, tec, after_flag, tail);
    bench.run(0);
    (bench, bit)
}

/// The bench of [`transmitter_error_then_dominant`] before it runs; returns it and the error's bit.
fn transmitter_error_script(
    iut: Iut,
    tec: u8,
    after_flag: usize,
    tail: usize,
) -> (ProtocolBench, usize) {
    let f = frame();
    let encoded = encode(&f);
    let bit = first_dominant(&encoded, Field::BaseId, 1..12);
    let mut bench = ProtocolBench::iut_transmits_with(iut, &f, tec, false);
    bench
        .lt()
        .release(bit + 7)
        .force(bit, 0, 16, Drive::ForceRecessive)
        .send_bits(std::iter::repeat_n(DOMINANT, after_flag))
        .release(tail);
    (bench, bit)
}

fn ak_02_dominant_ack_slot_while_sending_recessive_is_success(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench
        .lt()
        .release(encoded.len() + 4)
        .set_bit(ack, Drive::Dominant);
    bench.run(1);
    assert!(
        !bench.iut_dominant_in(ack),
        "the IUT itself sends a recessive ACK slot"
    );
    assert_eq!(bench.iut_events(), vec![NodeEvent::TransmitDone(true)]);
}

fn ak_03_receiver_ack_overridden_is_a_bit_error(iut: Iut) {
    let encoded = encode(&frame());
    let ack = SOF + encoded.position(Field::AckSlot, 0).unwrap();
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .after_integration()
        .send_frame(&encoded)
        .release(10)
        .force(ack, 0, 16, Drive::ForceRecessive);
    bench.run(1);
    assert_eq!(bench.iut_dominant_bits(ack + 1, ack + 20), flag_after(ack));
    assert_eq!(bench.rec(), 1);
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(0x39)],
        "bit/RX/ACK slot, not stored"
    );
}

fn ak_04_ec_06_passive_transmitter_without_ack(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    for dominant_in_flag in [false, true] {
        let mut bench = ProtocolBench::iut_transmits_with(iut, &f, 128, false);
        bench.lt().release(ack + 28);
        if dominant_in_flag {
            bench.lt().set_bit(ack + 3, Drive::Dominant);
        }
        bench.run(0);
        if dominant_in_flag {
            assert_eq!(
                bench.tec(),
                136,
                "(b) a dominant bit inside the passive flag: +8"
            );
        } else {
            assert_eq!(bench.tec(), 128, "(a) rule 3 exception a: unchanged");
            assert_eq!(
                bench.iut_dominant_bits(ack, ack + 27),
                vec![ack + 26],
                "passive flag, delimiter, intermission, 8 suspend bits, SOF at ACK slot + 26"
            );
        }
    }
}

fn ak_05_alone_on_the_bus_tec_stops_at_128(iut: Iut) {
    let f = frame();
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench.lt().release(40 * 90);
    bench.run(0);
    assert!(
        bus_errors(&mut bench) >= 40,
        "{} attempts",
        bus_errors(&mut bench)
    );
    assert_eq!(bench.tec(), 128);
    assert!(bench.error_passive() && !bench.bus_off());
    bench.assert_error_interrupts(
        &[
            ErrorInterrupt::new(interrupt::EI, true, (96, 0)),
            ErrorInterrupt::new(interrupt::EPI, true, (128, 0)),
        ],
        "ES and EI at 96, EPI at 128",
    );
}

fn be_03_ec_02_bit_error_in_the_own_active_flag_restarts_it(iut: Iut) {
    for k in [0usize, 2, 5] {
        let mut bench = ProtocolBench::new(iut);
        bench
            .lt()
            .after_integration()
            .send_bits([DOMINANT; 6])
            .release(30)
            .force(STUFF_ERROR_AT + 1 + k, 0, 16, Drive::ForceRecessive);
        bench.run(1);
        let restart = STUFF_ERROR_AT + 1 + k;
        let mut expected: Vec<usize> = (STUFF_ERROR_AT + 1..=restart).collect();
        expected.extend(flag_after(restart));
        assert_eq!(
            bench.iut_dominant_bits(STUFF_ERROR_AT + 1, STUFF_ERROR_AT + 30),
            expected,
            "flag bit {} forced recessive: the flag restarts after it",
            k + 1
        );
        assert_eq!(bench.rec(), 9, "flag bit {}: +1, then +8", k + 1);
    }
}

fn ec_01_03_04_09_receiver_counts_dominant_bits_after_its_flag(iut: Iut) {
    for (after_flag, rec) in [(0, 1), (1, 9), (7, 9), (8, 17), (16, 25)] {
        let mut bench = receiver_error_then_dominant(iut, after_flag);
        assert_eq!(
            bench.rec(),
            rec,
            "{after_flag} dominant bits after the flag"
        );
        assert_eq!(bus_errors(&mut bench), 1, "{after_flag}: no new error");
    }
}

fn ec_05_10_transmitter_counts_dominant_bits_after_its_flag(iut: Iut) {
    let cases = [(0, 8), (7, 8), (8, 16), (16, 24)];
    assert_tec_after_dominant_bits(iut, 0, 10, &cases, "the flag");
}

/// For each `(after_flag, tec)` case: a transmitter with TEC `preset` makes a bit error, sends its
/// flag, then reads `after_flag` dominant bits (and `extra_bits` more after them): TEC is `tec`.
fn assert_tec_after_dominant_bits(
    iut: Iut,
    preset: u8,
    extra_bits: usize,
    cases: &[(usize, u8)],
    flag: &str,
) {
    for &(after_flag, tec) in cases {
        let (mut bench, _) = transmitter_error_then_dominant(iut, preset, after_flag, extra_bits);
        assert_eq!(bench.tec(), tec, "{after_flag} dominant bits after {flag}");
    }
}

fn ec_14_the_error_reaching_128_is_still_signalled_active(iut: Iut) {
    let (mut bench, bit) = transmitter_error_then_dominant(iut, 120, 0, 30);
    assert_eq!(bench.tec(), 128);
    assert!(bench.error_passive());
    assert_eq!(
        bench.iut_dominant_bits(bit + 1, bit + 7),
        flag_after(bit),
        "active flag although the counter reaches 128"
    );
    bench.assert_error_interrupts(
        &[
            ErrorInterrupt::new(interrupt::EI, true, (120, 0)),
            ErrorInterrupt::new(interrupt::EPI, true, (128, 0)),
        ],
        "EI when the preset 120 takes effect, EPI at 128",
    );
}

fn ov_01_dominant_intermission_bit_1_or_2_gives_an_overload_frame(iut: Iut) {
    let encoded = encode(&frame());
    for k in 0..2 {
        let mut bench = ProtocolBench::new(iut);
        bench
            .lt()
            .after_integration()
            .send_frame(&encoded)
            .release(30);
        let intermission = SOF + encoded.len() + k;
        bench.lt().set_bit(intermission, Drive::Dominant);
        bench.run(1);
        let ack = SOF + encoded.position(Field::AckSlot, 0).unwrap();
        let mut expected = vec![ack];
        expected.extend(flag_after(intermission));
        assert_eq!(
            bench.iut_dominant_bits(0, intermission + 25),
            expected,
            "intermission bit {}",
            k + 1
        );
        assert_eq!(bench.iut_events(), vec![NodeEvent::Received(frame())]);
        assert_eq!(bench.rec(), 0);
    }
}

fn ov_06_if_02_sof_in_intermission_bit_3_starts_a_frame(iut: Iut) {
    let first = encode(&frame());
    let second_frame = Frame::data(Id::standard(0x111).unwrap(), &[7]).unwrap();
    let second = encode(&second_frame);
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .after_integration()
        .send_frame(&first)
        .release(2)
        .send_frame(&second)
        .release(4);
    bench.run(1);
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::Received(frame()),
            NodeEvent::Received(second_frame)
        ]
    );
}

fn bo_01_bo_03_bus_off_and_recovery_after_128_times_11_recessive_bits(iut: Iut) {
    // The error at bit e takes TEC from 250 above 255.
    let (mut bench, bit) = enter_bus_off(iut, 1);
    assert!(bench.bus_off(), "TEC above 255");
    assert_eq!(
        (bench.tec(), bench.rec()),
        (127, 0),
        "SJA1000: TXERR 127, RXERR 0"
    );
    if let Some(mut registers) = bench.registers() {
        assert_eq!(registers.read(pelican::MOD) & mode::RM, mode::RM, "RM = 1");
    }
    if let Some(passes) = bench.interrupt_passes() {
        assert!(
            passes.iter().any(|p| p.ir & interrupt::EI != 0
                && p.sr & status::BS != 0
                && p.counters == Some((127, 0))),
            "EI with BS = 1: {passes:?}"
        );
    }
    let cleared = clear_reset_mode(&mut bench, bit);
    assert!(
        bench.iut_dominant_bits(bit + 1, bit + 8).is_empty(),
        "no flag: tx recessive at once"
    );
    // 1407 recessive bits from the host's write: 127 runs of 11, TEC counted down to 0, still bus-off.
    let played = bench.lt_ref().script_len();
    bench.lt().release(cleared + 1407 - played);
    bench.run(0);
    assert!(bench.bus_off());
    assert_eq!(bench.tec(), 0, "TXERR counts down during recovery");
    assert!(
        bench.iut_dominant_bits(bit + 1, cleared + 1407).is_empty(),
        "bus-off: never dominant"
    );
    // The 128th run of 11 recessive bits ends bus-off.
    bench.lt().release(2);
    bench.run(0);
    assert!(!bench.bus_off(), "recovered after 128 × 11 recessive bits");
    assert_eq!((bench.tec(), bench.rec()), (0, 0));
    if let Some(passes) = bench.interrupt_passes() {
        let last = passes.last().expect("interrupts");
        assert!(
            last.ir & interrupt::EI != 0
                && last.sr & status::BS == 0
                && last.counters == Some((0, 0)),
            "EI with BS = 0 at the end of recovery: {last:?}"
        );
    }
}

fn bo_06_no_recovery_in_reset_mode(iut: Iut) {
    let (mut bench, _) = transmitter_error_then_dominant(iut, 250, 0, 5);
    assert!(bench.bus_off());
    bench.set_enable(false);
    bench.lt().release(1600);
    bench.run(0);
    assert!(
        bench.bus_off(),
        "reset mode: no recovery however long the bus is idle"
    );
}

fn rt_04_single_shot_makes_one_attempt(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let mut bench = ProtocolBench::iut_transmits_with(iut, &f, 0, true);
    bench.lt().release(ack + 40);
    bench.run(0);
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(0xD9), NodeEvent::TransmitDone(false)]
    );
    assert_eq!(
        bench.iut_dominant_bits(ack + 7, ack + 40),
        Vec::<usize>::new(),
        "no retry"
    );
    assert_eq!(bench.tec(), 8);
    if let Some(passes) = bench.interrupt_passes() {
        let ti = passes
            .iter()
            .find(|p| p.ir & interrupt::TI != 0)
            .expect("TI");
        assert_eq!(
            ti.sr & (status::TCS | status::TBS),
            status::TBS,
            "TCS = 0, TBS = 1"
        );
    }
}

fn rt_03_no_retry_limit(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let bit = first_dominant(&encoded, Field::BaseId, 0..12);
    let mut bench = ProtocolBench::iut_transmits_with(iut, &f, 0, false);
    // 20 attempts each with a bit error at `bit`. The next SOF comes at e + 18, or e + 26 once the
    // IUT is error passive (TEC ≥ 128 after the 16th error: 8 suspend bits).
    let mut sof = 0;
    let mut forced = Vec::new();
    for attempt in 1..=20 {
        forced.push(sof + bit);
        sof += bit + if attempt >= 16 { 26 } else { 18 };
    }
    bench
        .lt()
        .release(sof + encoded.len() + 4)
        .set_bit(sof + ack, Drive::Dominant);
    for &b in &forced {
        bench.lt().force(b, 0, 16, Drive::ForceRecessive);
    }
    bench.run(1);
    let events = bench.iut_events();
    let errors = events
        .iter()
        .filter(|e| matches!(e, NodeEvent::BusError(_)))
        .count();
    assert_eq!(errors, 20);
    assert_eq!(
        events.last(),
        Some(&NodeEvent::TransmitDone(true)),
        "one TI, after the 21st attempt"
    );
    assert_eq!(bench.tec(), 159, "20 × 8, then −1");
    assert!(
        bench.iut_dominant_in(sof),
        "21st attempt at the expected bit"
    );
}

fn ec_08_transmitter_bit_error_in_its_own_active_flag(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let bit = first_dominant(&encoded, Field::BaseId, 1..12);
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench
        .lt()
        .release(bit + 30)
        .force(bit, 0, 16, Drive::ForceRecessive)
        .force(bit + 3, 0, 16, Drive::ForceRecessive);
    bench.run(0);
    assert_eq!(
        bench.tec(),
        16,
        "+8 for the error, +8 for the bit error in its flag"
    );
}

fn ec_11_dominant_bits_after_a_passive_flag(iut: Iut) {
    // Passive transmitter (TEC 128): bit error, passive flag, then n dominant bits.
    let cases = [(1, 136), (6, 136), (8, 144), (9, 144), (16, 152)];
    assert_tec_after_dominant_bits(iut, 128, 20, &cases, "the passive flag");
}

fn ec_15_rec_saturates_at_255_and_never_causes_bus_off(iut: Iut) {
    // REC 127 + 1: passive at 128 (a receiver counter alone makes the node passive).
    let mut bench = ProtocolBench::new(iut);
    bench.load_counter(false, 127);
    bench
        .lt()
        .after_integration()
        .send_bits([DOMINANT; 6])
        .release(20);
    bench.run(1);
    assert_eq!(bench.rec(), 128);
    assert!(bench.error_passive());
    // REC 250 + 1 + 8 (first bit after the flag) + 8 (8th) + 8 (16th): saturated at 255, never bus-off.
    let mut bench = ProtocolBench::new(iut);
    bench.load_counter(false, 250);
    bench
        .lt()
        .after_integration()
        .send_bits([DOMINANT; 6])
        .release(6)
        .send_bits([DOMINANT; 24])
        .release(20);
    bench.run(1);
    assert_eq!(bench.rec(), 255);
    assert!(bench.error_passive() && !bench.bus_off());
}

/// Takes the IUT to bus-off (TEC 250 + a bit error at bit e, which sets MOD.RM on the controller) and
/// runs to bit e + 1, with the LT's script ending `tail` bits after the flag time (e + 7); returns the
/// bench and e.
fn enter_bus_off(iut: Iut, tail: usize) -> (ProtocolBench, usize) {
    let (mut bench, bit) = transmitter_error_script(iut, 250, 0, tail);
    bench.run_to_bit(bit + 1);
    (bench, bit)
}

/// Bits from the error that caused bus-off to the host's write that clears MOD.RM.
const RM_CLEARED_AFTER: usize = 3;

/// The host clears MOD.RM at the start of script bit `bit` + [`RM_CLEARED_AFTER`] (after bus-off at
/// `bit`), and the LT plays its script to the end. Bus-off recovery counts recessive bits from the
/// write (BO-03). The core has no RM (the register block sets it at bus-off): the bench keeps the
/// core in reset mode until the write, which holds its count of recessive bits at 0 as RM does on
/// the controller. Returns the script bit of the write.
fn clear_reset_mode(bench: &mut ProtocolBench, bit: usize) -> usize {
    let cleared = bit + RM_CLEARED_AFTER;
    bench.clear_reset_mode_at(cleared);
    bench.run(0);
    cleared
}

/// Bus-off as in [`enter_bus_off`], then recovery started by the host as in [`clear_reset_mode`].
fn bus_off_bench(iut: Iut, tail: usize) -> (ProtocolBench, usize) {
    let (mut bench, bit) = enter_bus_off(iut, tail);
    clear_reset_mode(&mut bench, bit);
    (bench, bit)
}

fn bo_02_bus_off_node_neither_acknowledges_nor_stores(iut: Iut) {
    let (mut bench, bit) = bus_off_bench(iut, 1);
    let encoded = encode(&frame());
    let start = bit + 8;
    bench.lt().send_frame(&encoded).release(10);
    bench.run(0);
    assert!(bench.bus_off());
    assert!(bench
        .iut_dominant_bits(start, start + encoded.len() + 10)
        .is_empty());
    assert!(bench.received().is_empty());
}

fn bo_04_only_complete_runs_of_11_recessive_bits_count(iut: Iut) {
    // After bus-off: runs of 10 recessive bits broken by a dominant bit never count.
    let (mut bench, _) = bus_off_bench(iut, 1);
    for _ in 0..150 {
        bench.lt().send_bits([DOMINANT]).release(10);
    }
    bench.run(0);
    assert!(bench.bus_off());
    assert_eq!(bench.tec(), 127, "no run of 11 completed");
}

fn bo_05_recovery_counts_the_idle_runs_between_frames(iut: Iut) {
    // Frames with ACK delimiter + EOF + intermission = 11 recessive bits (the LT acknowledges its own
    // frame), then 3 idle bits: each frame and gap counts one run (no run is 22 bits long).
    let (mut bench, _) = bus_off_bench(iut, 1);
    let encoded = encode(&Frame::data(Id::standard(0x000).unwrap(), &[0, 0]).unwrap());
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    for _ in 0..20 {
        let start = bench.lt_ref().script_len();
        bench
            .lt()
            .send_frame(&encoded)
            .set_bit(start + ack, Drive::Dominant)
            .release(3);
    }
    bench.run(0);
    assert!(bench.bus_off());
    let tec = bench.tec();
    assert!(
        (127 - 21..=127 - 19).contains(&tec),
        "about one run per frame: TEC {tec}"
    );
}

fn ep_10_error_passive_and_warning_follow_the_counters(iut: Iut) {
    let (ei, epi) = (interrupt::EI, interrupt::EPI);
    let (mut bench, _) = transmitter_error_then_dominant(iut, 120, 0, 5);
    assert!(bench.error_passive(), "TEC 128");
    bench.assert_error_interrupts(
        &[
            ErrorInterrupt::new(ei, true, (120, 0)),
            ErrorInterrupt::new(epi, true, (128, 0)),
        ],
        "TEC 120 (ES), then 128: EPI",
    );
    let (mut bench, _) = transmitter_error_then_dominant(iut, 88, 0, 5);
    assert!(!bench.error_passive(), "TEC 96");
    bench.assert_error_interrupts(
        &[ErrorInterrupt::new(ei, true, (96, 0))],
        "TEC 88, then 96 = EWLR: ES and EI, no EPI",
    );
    let mut bench = ProtocolBench::iut_transmits_acknowledged(iut, &frame(), 128);
    assert!(!bench.error_passive(), "TEC 128 → 127: active again");
    bench.assert_error_interrupts(
        &[
            ErrorInterrupt::new(ei | epi, true, (128, 0)),
            ErrorInterrupt::new(epi, true, (127, 0)),
        ],
        "TEC 128 when reset mode is left: ES and passive; 127: EPI (active again)",
    );
}

fn ep_06_passive_transmitter_retransmits_after_suspend(iut: Iut) {
    let (bench, bit) = transmitter_error_then_dominant(iut, 128, 0, 30);
    assert_eq!(
        bench.iut_dominant_bits(bit + 1, bit + 27),
        vec![bit + 26],
        "passive flag, delimiter, intermission, suspend: SOF at e + 26"
    );
}

/// A frame that loses arbitration against `frame()` at its last base identifier bit (ID.18, ALC 10).
fn winner_frame() -> Frame {
    Frame::data(Id::standard(0x2C4).unwrap(), &[0x42]).unwrap()
}

/// Time of the IUT's first `TransmitDone` event.
fn transmit_done_at(bench: &mut ProtocolBench) -> u64 {
    bench
        .iut_timed_events()
        .iter()
        .find(|(_, e)| matches!(e, NodeEvent::TransmitDone(_)))
        .expect("the request ended")
        .0
}

fn rt_05_abort_of_a_pending_frame_ends_the_request_unsent(iut: Iut) {
    // The request comes while the LT's frame is on the bus and is aborted before that frame ends.
    let theirs = encode(&winner_frame());
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .after_integration()
        .send_frame(&theirs)
        .release(40);
    bench.run_to_bit(SOF + 5);
    bench.send(&frame(), false);
    bench.run_to_bit(SOF + 20);
    assert!(bench.transmit_pending());
    let aborted_at = bench.engine.now();
    bench.abort();
    bench.run(1);
    let bit_fs = bench.lt_ref().bit_time(1).unwrap() - bench.lt_ref().bit_time(0).unwrap();
    let done = transmit_done_at(&mut bench);
    assert!(
        done > aborted_at && done - aborted_at <= bit_fs,
        "the request ends at the next process point ({} fs after the abort)",
        done - aborted_at
    );
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::TransmitDone(false),
            NodeEvent::Received(winner_frame())
        ],
        "not sent (TCS = 0); the LT's frame is received as usual"
    );
    assert_eq!(
        bench.iut_dominant_bits(0, SOF + theirs.len() + 40),
        vec![SOF + theirs.position(Field::AckSlot, 0).unwrap()],
        "only the ACK of the LT's frame: no frame of its own after the LT's"
    );
    assert!(!bench.transmit_pending());
    assert_eq!(bench.tec(), 0);
}

fn rt_05_abort_during_the_own_transmission_makes_it_the_last_attempt(iut: Iut) {
    let f = frame();
    let encoded = encode(&f);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let golden: Vec<usize> = (0..encoded.len())
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .collect();
    let aborted_in = 3;

    // The attempt succeeds: it is completed (TCS = 1).
    let mut bench = ProtocolBench::iut_transmits_with(iut, &f, 10, false);
    bench
        .lt()
        .release(encoded.len() + 30)
        .set_bit(ack, Drive::Dominant);
    bench.run_to_bit(aborted_in);
    bench.abort();
    bench.run(0);
    assert_eq!(
        bench.iut_dominant_bits(0, encoded.len() + 30),
        golden,
        "success: the whole frame is sent"
    );
    assert_eq!(bench.iut_events(), vec![NodeEvent::TransmitDone(true)]);
    assert_eq!(bench.tec(), 9);

    // A bit error in the data field: no retransmission.
    let data = first_dominant(&encoded, Field::Data, 0..8);
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench
        .lt()
        .release(data + 60)
        .force(data, 0, 16, Drive::ForceRecessive);
    bench.run_to_bit(aborted_in);
    bench.abort();
    bench.run(0);
    let mut expected: Vec<usize> = golden.iter().copied().filter(|&i| i <= data).collect();
    expected.extend(flag_after(data));
    assert_eq!(
        bench.iut_dominant_bits(0, data + 60),
        expected,
        "error: the flag, then no retransmission (it would start at e + 18)"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(0x0A), NodeEvent::TransmitDone(false)],
        "bit error TX in the data field, then the request ends unsent"
    );
    assert_eq!(bench.tec(), 8);

    // Arbitration lost at ID.18: no retry after the winner's frame.
    let theirs = encode(&winner_frame());
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench.lt().send_frame(&theirs).release(40);
    bench.run_to_bit(aborted_in);
    bench.abort();
    bench.run(0);
    let loss = encoded.position(Field::BaseId, 10).unwrap();
    let mut expected: Vec<usize> = golden.iter().copied().filter(|&i| i < loss).collect();
    expected.push(theirs.position(Field::AckSlot, 0).unwrap());
    assert_eq!(
        bench.iut_dominant_bits(0, theirs.len() + 40),
        expected,
        "identifier up to the loss, ACK of the winner, then no retry"
    );
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::ArbitrationLost(10),
            NodeEvent::TransmitDone(false),
            NodeEvent::Received(winner_frame()),
        ]
    );

    // Aborted during the error flag of a failed attempt: the retransmission is cancelled.
    let e = encoded.position(Field::BaseId, 0).unwrap();
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench
        .lt()
        .release(e + 60)
        .force(e, 0, 16, Drive::ForceRecessive);
    bench.run_to_bit(e + 3);
    bench.abort();
    bench.run(0);
    assert_eq!(
        bench.iut_dominant_bits(0, e + 60),
        [vec![0, e], flag_after(e)].concat(),
        "no retransmission at e + 18"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::BusError(0x02), NodeEvent::TransmitDone(false)]
    );
    // The flag, delimiter and intermission still belong to the failed attempt: the request ends in
    // intermission bit 3 (e + 17), where the retransmission would have been decided.
    let done = transmit_done_at(&mut bench);
    let lt = bench.lt_ref();
    assert!(
        lt.bit_time(e + 17).unwrap() < done && done < lt.bit_time(e + 18).unwrap(),
        "the request ends in intermission bit 3, before the retransmission would have started"
    );
    assert_eq!(bench.tec(), 8);
}

fn bo_07_host_writes_of_txerr_force_and_end_bus_off_and_rxerr_writes_are_ignored(iut: Iut) {
    use sim::engine::time::ClockSpec;
    use sim::nodes::can_node::CanNode;
    let theirs = encode(&winner_frame());
    let mine = encode(&frame());
    for written in [0u8, 100] {
        let what = format!("TXERR {written} written in bus-off");
        let mut bench = ProtocolBench::new(iut);
        // A second node acknowledges and receives the frames (the LT only plays its script).
        let peer = bench.engine.add(
            CanNode::new(
                "peer",
                ClockSpec::from_hz(testbenches::CLOCK_HZ),
                bench.btr(),
            ),
            0,
        );
        let their_sof = SOF + 4;
        let enabled_at = their_sof + theirs.len() + 8;
        bench
            .lt()
            .release(their_sof)
            .send_frame(&theirs)
            .release(enabled_at - their_sof - theirs.len() + 11 + mine.len() + 10);
        bench.load_counter(false, 9);

        // TXERR = 255 in reset mode: bus-off with TXERR 127 and RXERR 0.
        bench.run_to_bit(SOF);
        assert_eq!((bench.tec(), bench.rec()), (0, 9));
        bench.set_enable(false);
        bench.run_to_bit(SOF + 1);
        bench.load_counter(true, 255);
        bench.run_to_bit(SOF + 2);
        assert!(bench.bus_off(), "TXERR = 255 forces bus-off");
        assert_eq!((bench.tec(), bench.rec()), (127, 0));
        // Back in operating mode with a request: bus-off sends nothing, not even an ACK.
        bench.set_enable(true);
        bench.send(&frame(), false);
        bench.run_to_bit(their_sof + theirs.len() + 2);
        assert!(
            bench
                .iut_dominant_bits(SOF, their_sof + theirs.len())
                .is_empty(),
            "bus-off: tx recessive throughout the LT's frame"
        );
        assert!(bench.received().is_empty());
        assert_eq!(
            bench.engine.device::<CanNode>(peer).received(),
            vec![winner_frame()],
            "the frame was valid (the peer acknowledged it)"
        );
        assert!(bench.bus_off());

        // RXERR writes are ignored while bus-off.
        bench.load_counter(false, 50);
        bench.run_to_bit(their_sof + theirs.len() + 3);
        assert_eq!(bench.rec(), 0, "RXERR write ignored in bus-off");
        assert!(bench.bus_off());

        // Reset mode, TXERR = written: bus-off ends at once.
        bench.set_enable(false);
        bench.run_to_bit(their_sof + theirs.len() + 4);
        bench.load_counter(true, written);
        let period = ClockSpec::from_hz(testbenches::CLOCK_HZ).period_fs();
        let now = bench.engine.now();
        bench.engine.run_until(now + 2 * period).unwrap();
        assert!(!bench.bus_off(), "{what}: bus-off ends at once");
        assert_eq!((bench.tec(), bench.rec()), (written, 0), "{what}");
        // Outside bus-off RXERR can be written again.
        bench.load_counter(false, 5);
        bench.run_to_bit(their_sof + theirs.len() + 5);
        assert_eq!(bench.rec(), 5, "{what}: RXERR writable again");

        // Operating mode: 11 recessive bits of integration, then the pending frame goes out. Reset
        // mode has cancelled the request on the controller (TBS = 1, no TI: SJA1000.md), so the host
        // requests it again; the core's request does not depend on reset mode.
        let kept = bench.transmit_pending();
        assert_eq!(kept, iut == Iut::Core, "{what}: request kept in reset mode");
        bench.run_to_bit(enabled_at);
        bench.set_enable(true);
        if !kept {
            bench.send(&frame(), false);
        }
        bench.run(0);
        let sof = enabled_at + 11;
        assert!(
            bench.iut_dominant_bits(enabled_at, sof).is_empty(),
            "{what}: integration"
        );
        assert_eq!(
            bench.iut_dominant_bits(sof, sof + mine.len()),
            (0..mine.len())
                .filter(|&i| mine.bits[i] == DOMINANT)
                .map(|i| sof + i)
                .collect::<Vec<_>>(),
            "{what}: SOF right after 11 recessive bits, then the frame"
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::TransmitDone(true)],
            "{what}"
        );
        assert_eq!(
            bench.engine.device::<CanNode>(peer).received(),
            vec![winner_frame(), frame()],
            "{what}: the peer receives the IUT's frame"
        );
        assert_eq!(
            (bench.tec(), bench.rec()),
            (written.saturating_sub(1), 5),
            "{what}: a successful transmission (TEC −1); REC unchanged by it"
        );
    }

    // Bus-off reached by errors (BO-01) ends the same way; 254 is the largest value that ends it.
    let (mut bench, _) = bus_off_bench(iut, 1);
    assert!(bench.bus_off());
    bench.set_enable(false);
    bench.lt().release(1);
    bench.run(0);
    bench.load_counter(true, 254);
    bench.lt().release(1);
    bench.run(0);
    assert!(!bench.bus_off(), "TXERR 254 ends bus-off");
    assert_eq!((bench.tec(), bench.rec()), (254, 0));
    assert!(bench.error_passive());
}

testbenches::on_both_iuts! {
    ak_02_dominant_ack_slot_while_sending_recessive_is_success,
    ak_03_receiver_ack_overridden_is_a_bit_error,
    ak_04_ec_06_passive_transmitter_without_ack,
    ak_05_alone_on_the_bus_tec_stops_at_128,
    be_03_ec_02_bit_error_in_the_own_active_flag_restarts_it,
    ec_01_03_04_09_receiver_counts_dominant_bits_after_its_flag,
    ec_05_10_transmitter_counts_dominant_bits_after_its_flag,
    ec_14_the_error_reaching_128_is_still_signalled_active,
    ov_01_dominant_intermission_bit_1_or_2_gives_an_overload_frame,
    ov_06_if_02_sof_in_intermission_bit_3_starts_a_frame,
    bo_01_bo_03_bus_off_and_recovery_after_128_times_11_recessive_bits,
    bo_06_no_recovery_in_reset_mode,
    rt_04_single_shot_makes_one_attempt,
    rt_03_no_retry_limit,
    ec_08_transmitter_bit_error_in_its_own_active_flag,
    ec_11_dominant_bits_after_a_passive_flag,
    ec_15_rec_saturates_at_255_and_never_causes_bus_off,
    bo_02_bus_off_node_neither_acknowledges_nor_stores,
    bo_04_only_complete_runs_of_11_recessive_bits_count,
    bo_05_recovery_counts_the_idle_runs_between_frames,
    ep_10_error_passive_and_warning_follow_the_counters,
    ep_06_passive_transmitter_retransmits_after_suspend,
    rt_05_abort_of_a_pending_frame_ends_the_request_unsent,
    rt_05_abort_during_the_own_transmission_makes_it_the_last_attempt,
    bo_07_host_writes_of_txerr_force_and_end_bus_off_and_rxerr_writes_are_ignored,
}
