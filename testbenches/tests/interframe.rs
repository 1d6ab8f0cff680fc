//! Conformance groups IF (interframe space and bus integration), EP (error passive) and the
//! overload scenarios OV-03/OV-04 on both IUTs (the RTL core, and the controller through its
//! registers). Bit numbers are lower-tester script bits.

use golden::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT};
use sim::engine::bus::Drive;
use sim::engine::time::ClockSpec;
use sim::nodes::can_node::NodeEvent;
use testbenches::protocol_bench::{Iut, LtScript, ProtocolBench, INTEGRATION_BITS};

const SOF: usize = INTEGRATION_BITS;

fn frame() -> Frame {
    Frame::data(Id::standard(0x2C5).unwrap(), &[0x81, 0x3C]).unwrap()
}

fn other_frame() -> Frame {
    Frame::data(Id::standard(0x0A1).unwrap(), &[0x42]).unwrap()
}

fn flag_after(e: usize) -> Vec<usize> {
    (e + 1..=e + 6).collect()
}

/// An error-passive receiver (REC preset 130) gets six dominant bits (stuff error at SOF + 5), then
/// `after` from the LT.
fn passive_receiver_error(iut: Iut, after: &[bool]) -> ProtocolBench {
    let bits = [DOMINANT; 6].into_iter().chain(after.iter().copied());
    ProtocolBench::receive_bits(iut, bits, Some(130), 30)
}

fn if_01_reset_mode_left_mid_frame_ignores_that_frame(iut: Iut) {
    let first = encode(&frame());
    let second = encode(&other_frame());
    let mut bench = ProtocolBench::new(iut);
    bench.set_enable(false);
    bench
        .lt()
        .after_integration()
        .send_frame(&first)
        .release(12)
        .send_frame(&second)
        .release(4);
    // Leave reset mode in the middle of the first frame.
    bench.run_bits(SOF as u64 + 20);
    bench.set_enable(true);
    bench.run(1);
    let second_sof = SOF + first.len() + 12;
    let ack = second_sof + second.position(Field::AckSlot, 0).unwrap();
    assert_eq!(
        bench.iut_dominant_bits(0, second_sof + second.len()),
        vec![ack],
        "no ACK or flag during the first frame; the second is acknowledged"
    );
    assert_eq!(bench.iut_events(), vec![NodeEvent::Received(other_frame())]);
}

fn if_03_bt_13_pending_transmitter_takes_a_sof_in_intermission_bit_3_as_its_own(iut: Iut) {
    let theirs = encode(&other_frame());
    let mine = frame();
    let mine_bits = encode(&mine);
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .after_integration()
        .send_frame(&theirs)
        .release(2)
        .send_bits([DOMINANT])
        .release(mine_bits.len() + 4);
    // The IUT's request comes while the LT's frame is on the bus.
    bench.run_bits(SOF as u64 + 10);
    bench.send(&mine, false);
    let sof = SOF + theirs.len() + 2;
    let ack = sof + mine_bits.position(Field::AckSlot, 0).unwrap();
    bench.lt().set_bit(ack, Drive::Dominant);
    bench.run(1);
    assert!(
        !bench.iut_dominant_in(sof),
        "the IUT sends no SOF of its own"
    );
    let golden: Vec<usize> = (1..mine_bits.len())
        .filter(|&i| mine_bits.bits[i] == DOMINANT)
        .map(|i| sof + i)
        .collect();
    assert_eq!(
        bench.iut_dominant_bits(sof + 1, sof + mine_bits.len()),
        golden,
        "its first identifier bit follows the LT's SOF; the frame is sent as usual"
    );
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::Received(other_frame()),
            NodeEvent::TransmitDone(true)
        ]
    );
}

fn if_04_request_on_an_idle_bus_starts_within_one_bit_time(iut: Iut) {
    let mut bench = ProtocolBench::new(iut);
    bench.integrate();
    bench.send(&frame(), false);
    // The request is made: through the registers the CMR write has happened; the core takes it at
    // its next clock edge.
    let requested = bench.engine.now();
    assert!(bench.run_until_iut_dominant(2), "SOF within two bit times");
    // The SOF starts at the next bit boundary; the tx output register adds one clock.
    let delay = bench.engine.now() - requested;
    let period = ClockSpec::from_hz(testbenches::CLOCK_HZ).period_fs();
    assert!(
        delay <= bench.bit_fs() + period,
        "the SOF is on tx at most one bit time after the request ({delay} fs)"
    );
}

fn ep_01_03_passive_flag_ends_after_6_equal_bits(iut: Iut) {
    // Passive flag from SOF + 6; the LT adds an active flag on top (6 dominant), then 1, 4 or 7 more
    // dominant bits (EP-03): no new error, no dominant bit from the IUT.
    for extra in [0usize, 1, 4, 7] {
        let after = vec![DOMINANT; 6 + extra];
        let mut bench = passive_receiver_error(iut, &after);
        assert!(
            bench.iut_dominant_bits(SOF, SOF + 60).is_empty(),
            "{extra}: a passive node never sends a dominant flag"
        );
        assert_eq!(bench.bus_errors().len(), 1, "{extra}: one error");
        assert_eq!(bench.rec(), 131 + if extra > 0 { 8 } else { 0 }, "{extra}");
    }
}

fn ep_04_passive_node_still_acknowledges(iut: Iut) {
    let encoded = encode(&frame());
    let mut bench = ProtocolBench::receive_bits(iut, encoded.bits.iter().by_vals(), Some(130), 4);
    let ack = SOF + encoded.position(Field::AckSlot, 0).unwrap();
    assert_eq!(
        bench.iut_dominant_bits(0, SOF + encoded.len() + 4),
        vec![ack]
    );
    assert_eq!(bench.rec(), 127, "a successful reception takes REC to 127");
}

fn ep_05_passive_transmitter_suspends_between_its_frames(iut: Iut) {
    let first = frame();
    let encoded = encode(&first);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let mut bench = ProtocolBench::iut_transmits_with(iut, &first, 200, false);
    let second_sof = encoded.len() + 3 + 8;
    let second = encode(&other_frame());
    bench
        .lt()
        .release(second_sof + second.len() + 4)
        .set_bit(ack, Drive::Dominant)
        .set_bit(
            second_sof + second.position(Field::AckSlot, 0).unwrap(),
            Drive::Dominant,
        );
    let done = bench.run_until_event(200, &NodeEvent::TransmitDone(true));
    assert!(done);
    bench.send(&other_frame(), false);
    bench.run(1);
    assert_eq!(
        bench.iut_dominant_bits(encoded.len(), second_sof + 1),
        vec![second_sof],
        "second SOF after 3 intermission and 8 suspend bits"
    );
    assert_eq!(bench.tec(), 198);
}

/// The error-passive IUT (TEC 200) sends `frame()`, which the LT acknowledges; the LT starts
/// `other_frame()` `after_own_frame` bits after the end of the IUT's frame and then releases the
/// bus for `extra_bits`. The IUT's own frame is done and queued again. Returns the bench, the LT's
/// SOF position and the other frame.
fn passive_transmitter_then_theirs(
    iut: Iut,
    after_own_frame: usize,
    extra_bits: usize,
) -> (ProtocolBench, usize, EncodedFrame) {
    let mine = frame();
    let encoded = encode(&mine);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    let theirs = encode(&other_frame());
    let their_sof = encoded.len() + after_own_frame;
    let mut bench = ProtocolBench::iut_transmits_with(iut, &mine, 200, false);
    bench
        .lt()
        .release(their_sof)
        .set_bit(ack, Drive::Dominant)
        .send_frame(&theirs)
        .release(extra_bits);
    assert!(bench.run_until_event(200, &NodeEvent::TransmitDone(true)));
    bench.send(&mine, false);
    (bench, their_sof, theirs)
}

fn ep_07_a_frame_started_during_suspend_is_received_and_then_no_suspend(iut: Iut) {
    // Own frame acknowledged (TEC 200 → 199, passive): suspend; the LT's SOF in suspend bit 2.
    let (mut bench, their_sof, theirs) = passive_transmitter_then_theirs(iut, 3 + 1, 60);
    bench.run(1);
    let their_ack = their_sof + theirs.position(Field::AckSlot, 0).unwrap();
    let next = their_sof + theirs.len() + 3;
    assert!(
        bench.iut_dominant_in(their_ack),
        "the IUT acknowledges the other frame"
    );
    assert!(
        bench.iut_dominant_in(next),
        "as a receiver it transmits right after the intermission"
    );
    assert!(bench
        .iut_events()
        .contains(&NodeEvent::Received(other_frame())));
}

/// The LT sends the frame, a dominant first intermission bit (an overload condition: the IUT sends
/// its overload flag) and holds the bus dominant for the 6 flag bits and `dominant_after` more.
fn overload_flag_then_dominant(iut: Iut, dominant_after: usize) -> ProtocolBench {
    let encoded = encode(&frame());
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .after_integration()
        .send_frame(&encoded)
        .send_bits([DOMINANT])
        .send_bits(std::iter::repeat_n(DOMINANT, 6 + dominant_after))
        .release(30);
    bench.run(1);
    bench
}

fn ov_03_extended_overload_flag_is_tolerated(iut: Iut) {
    let intermission = SOF + encode(&frame()).len();
    for extra in 1..=7 {
        let mut bench = overload_flag_then_dominant(iut, extra);
        assert_eq!(bench.rec(), 0, "{extra} extra dominant bits");
        assert_eq!(bench.bus_errors().len(), 0, "{extra}");
        assert_eq!(
            bench.iut_dominant_bits(intermission + 1, intermission + 30),
            flag_after(intermission),
            "{extra}"
        );
    }
}

fn ov_04_dominant_bits_after_an_overload_flag_count_8_each(iut: Iut) {
    for (dominant_after, rec) in [(7, 0), (8, 8), (16, 16)] {
        let mut bench = overload_flag_then_dominant(iut, dominant_after);
        assert_eq!(
            bench.rec(),
            rec,
            "{dominant_after} dominant bits after the overload flag"
        );
    }
}

fn ep_02_passive_flag_restarts_on_level_changes(iut: Iut) {
    // Passive receiver error at e = SOF + 5. A dominant bit at e + 3 restarts the count of 6 equal bits,
    // so the flag ends at e + 9 and a dominant e + 10 is the first bit after the flag (rule 2: +8).
    // Without the restart, e + 10 would be inside the delimiter: a form error.
    let e = SOF + 5;
    let mut after = vec![true; 12];
    after[2] = DOMINANT;
    after[9] = DOMINANT;
    let mut bench = passive_receiver_error(iut, &after);
    assert_eq!(
        bench.rec(),
        139,
        "+1, then +8 for the dominant bit after the restarted flag"
    );
    assert_eq!(bench.bus_errors().len(), 1, "no form error");
    assert!(bench.iut_dominant_bits(e, e + 30).is_empty());
}

fn ep_08_passive_former_transmitter_receives_a_frame_started_in_intermission_bit_3(iut: Iut) {
    // The LT's SOF in intermission bit 3.
    let (mut bench, their_sof, theirs) = passive_transmitter_then_theirs(iut, 2, 4);
    bench.run(0);
    let their_ack = their_sof + theirs.position(Field::AckSlot, 0).unwrap();
    assert_eq!(
        bench.iut_dominant_bits(their_sof, their_sof + theirs.len()),
        vec![their_ack],
        "it does not take the other SOF as its own: it receives and acknowledges"
    );
    assert!(bench
        .iut_events()
        .contains(&NodeEvent::Received(other_frame())));
}

fn ep_09_passive_node_that_lost_arbitration_does_not_suspend(iut: Iut) {
    let mine = Frame::data(Id::standard(0x7F0).unwrap(), &[1]).unwrap();
    let theirs_frame = Frame::data(Id::standard(0x100).unwrap(), &[2]).unwrap();
    let theirs = encode(&theirs_frame);
    let mut bench = ProtocolBench::iut_transmits_with(iut, &mine, 200, false);
    bench.lt().send_frame(&theirs).release(6);
    bench.run(0);
    let retry = theirs.len() + 3;
    assert!(
        bench.iut_dominant_in(retry),
        "retry right after the intermission"
    );
    assert!(
        bench.iut_events().contains(&NodeEvent::ArbitrationLost(0)),
        "0x7F0 vs 0x100: ID.28"
    );
}

fn ov_02_05_overload_frames_after_error_and_overload_frames_are_not_limited(iut: Iut) {
    // Receiver error at e = SOF + 5: flag e+1..e+6, delimiter e+7..e+14, intermission from e+15.
    let e = SOF + 5;
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .after_integration()
        .send_bits([DOMINANT; 6])
        .release(80);
    // Intermission bit 1 dominant three times: after the error frame and after each overload frame
    // (an overload frame is flag 6 + delimiter 8, so the next intermission starts 14 bits later).
    let mut expected = flag_after(e);
    for k in 0..3 {
        let intermission = e + 15 + 15 * k;
        bench.lt().set_bit(intermission, Drive::Dominant);
        expected.extend(flag_after(intermission));
    }
    bench.run(1);
    assert_eq!(
        bench.iut_dominant_bits(e, e + 80),
        expected,
        "three overload frames"
    );
    assert_eq!(bench.rec(), 1, "overload frames do not count");
    assert_eq!(bench.bus_errors().len(), 1);
}

fn ov_07_pending_retransmission_after_error_and_overload_frames_takes_a_sof_in_intermission_bit_3(
    iut: Iut,
) {
    let mine = encode(&frame());
    // The LT's frame differs from the IUT's in the last base identifier bit only (0x2C4 < 0x2C5).
    let theirs_frame = Frame::data(Id::standard(0x2C4).unwrap(), &[0x42]).unwrap();
    let theirs = encode(&theirs_frame);
    let loss = (1..mine.len())
        .find(|&i| mine.bits[i] != theirs.bits[i])
        .unwrap();
    assert_eq!(loss, mine.position(Field::BaseId, 10).unwrap());
    // Bit error on ID.28 at e; error flag e+1..e+6, delimiter e+7..e+14; intermission bit 1 (e+15)
    // dominant: overload flag, delimiter, intermission; the LT's SOF in its bit 3.
    let e = mine.position(Field::BaseId, 0).unwrap();
    assert_eq!(mine.bits[e], DOMINANT);
    let overload = e + 15;
    let sof = overload + 6 + 8 + 3;
    let retry = sof + theirs.len() + 3;
    let mut bench = ProtocolBench::iut_transmits(iut, &frame());
    bench
        .lt()
        .release(sof)
        .force(e, 0, 16, Drive::ForceRecessive)
        .set_bit(overload, Drive::Dominant)
        .send_frame(&theirs)
        .release(3 + mine.len() + 4)
        .set_bit(
            retry + mine.position(Field::AckSlot, 0).unwrap(),
            Drive::Dominant,
        );
    bench.run(1);
    // SOF and ID.28 (driven dominant, read recessive), the flags.
    let mut expected = vec![0, e];
    expected.extend(flag_after(e));
    expected.extend(flag_after(overload));
    // No SOF of its own: its identifier from sof + 1, up to the lost bit.
    expected.extend(
        (1..loss)
            .filter(|&i| mine.bits[i] == DOMINANT)
            .map(|i| sof + i),
    );
    expected.push(sof + theirs.position(Field::AckSlot, 0).unwrap());
    expected.extend(
        (0..mine.len())
            .filter(|&i| mine.bits[i] == DOMINANT)
            .map(|i| retry + i),
    );
    assert!(!bench.iut_dominant_in(sof), "no SOF of its own");
    assert_eq!(
        bench.iut_dominant_bits(0, retry + mine.len() + 4),
        expected,
        "error flag, overload flag, identifier from the bit after the LT's SOF until the loss, ACK of \
         the LT's frame, retransmission after its intermission"
    );
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::BusError(0x02),
            NodeEvent::ArbitrationLost(10),
            NodeEvent::Received(theirs_frame),
            NodeEvent::TransmitDone(true),
        ],
        "bit error (TX, ID.28..21), loss at ID.18, the LT's frame received, then sent"
    );
    assert_eq!(bench.tec(), 7, "+8, then −1");
}

/// A dominant disturbance of one bit time in the intermission after a correct frame, starting
/// `from_sp_tq` quanta after the sample point of intermission bit 2 (LT script positions; the IUT
/// acknowledged the frame). Returns the bench run to its end and the script bit of intermission bit 2.
fn intermission_disturbance(iut: Iut, from_sp_tq: i32) -> (ProtocolBench, usize) {
    let first = encode(&frame());
    let mut bench = ProtocolBench::new(iut);
    let bit_2 = SOF + first.len() + 1;
    let quanta = bench.lt().quanta_per_bit();
    let start = bench.sample_point_tq() as i32 + from_sp_tq;
    bench
        .lt()
        .after_integration()
        .send_frame(&first)
        .release(40)
        .force(bit_2, start as u32, quanta, Drive::Dominant);
    bench.run(1);
    (bench, bit_2)
}

/// The disagreement settled by the standard (issue 16, item 6): a dominant disturbance starting
/// 1 tq after the sample point of intermission bit 2 and lasting one bit time. Intermission bit 2
/// was sampled recessive, so it is no overload condition; the edge lies in Phase_Seg2 and is used
/// for synchronisation (in intermission bit 3 a node hard-synchronises on a SOF: ISO 16845-1 7.7.2,
/// 8.7.2/8.7.3; with |e| ≤ SJW a resynchronisation ends the bit at the same edge); bit 3 is then
/// sampled dominant, and a dominant third intermission bit is a SOF (ISO 11898-1, interframe
/// space). The IUT receives: no flag in bit 3. The bus stays recessive after it, so the sixth
/// recessive bit after that SOF is a stuff error: one active flag, REC 1, ECC stuff error in
/// ID.28..21.
fn intermission_disturbance_after_the_sample_point_of_bit_2_is_a_sof(iut: Iut) {
    let (mut bench, bit_2) = intermission_disturbance(iut, 1);
    let ack = SOF + encode(&frame()).position(Field::AckSlot, 0).unwrap();
    // The IUT's bits start up to 3 tq before the LT's (it synchronised on the early edge): its SOF
    // is LT bit 3 of intermission, its stuff error is its bit 6 after the SOF, the flag its bits 7..12,
    // seen at the LT's sample points of bits 8..13 after intermission bit 2.
    let mut expected = vec![ack];
    expected.extend(bit_2 + 8..=bit_2 + 13);
    assert_eq!(bench.iut_dominant_bits(0, bit_2 + 30), expected);
    assert_eq!(
        bench.rec(),
        1,
        "the stuff error: +1; no dominant bit after the flag"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::Received(frame()), NodeEvent::BusError(0xA2)],
        "the frame, then a stuff error (receiving, ID.28..21)"
    );
}

/// The same disturbance starting 1 tq before the sample point of intermission bit 2: bit 2 is
/// sampled dominant, an overload condition (ISO 11898-1; ISO 16845-1 7.4.1): a 6-bit overload flag
/// from the next bit, REC unchanged.
fn intermission_disturbance_before_the_sample_point_of_bit_2_is_an_overload_condition(iut: Iut) {
    let (mut bench, bit_2) = intermission_disturbance(iut, -1);
    let ack = SOF + encode(&frame()).position(Field::AckSlot, 0).unwrap();
    let mut expected = vec![ack];
    expected.extend(flag_after(bit_2));
    assert_eq!(bench.iut_dominant_bits(0, bit_2 + 30), expected);
    assert_eq!(bench.rec(), 0);
    assert_eq!(bench.iut_events(), vec![NodeEvent::Received(frame())]);
}

testbenches::on_both_iuts! {
    if_01_reset_mode_left_mid_frame_ignores_that_frame,
    if_03_bt_13_pending_transmitter_takes_a_sof_in_intermission_bit_3_as_its_own,
    if_04_request_on_an_idle_bus_starts_within_one_bit_time,
    ep_01_03_passive_flag_ends_after_6_equal_bits,
    ep_04_passive_node_still_acknowledges,
    ep_05_passive_transmitter_suspends_between_its_frames,
    ep_07_a_frame_started_during_suspend_is_received_and_then_no_suspend,
    ov_03_extended_overload_flag_is_tolerated,
    ov_04_dominant_bits_after_an_overload_flag_count_8_each,
    ep_02_passive_flag_restarts_on_level_changes,
    ep_08_passive_former_transmitter_receives_a_frame_started_in_intermission_bit_3,
    ep_09_passive_node_that_lost_arbitration_does_not_suspend,
    ov_02_05_overload_frames_after_error_and_overload_frames_are_not_limited,
    ov_07_pending_retransmission_after_error_and_overload_frames_takes_a_sof_in_intermission_bit_3,
    intermission_disturbance_after_the_sample_point_of_bit_2_is_a_sof,
    intermission_disturbance_before_the_sample_point_of_bit_2_is_an_overload_condition,
}
