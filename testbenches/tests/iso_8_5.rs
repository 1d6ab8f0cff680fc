//! ISO 16845-1:2016 clause 8.5: the IUT as transmitter, error-passive state and bus-off. Each test
//! is named after its clause and runs every elementary test case of it on both IUTs. Bit numbers are
//! lower-tester script bits; script bit 0 is the IUT's SOF.

use golden::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::{ecc, BIT, FORM, SEG_DATA, SEG_ERROR_DELIM};
use testbenches::iso::{
    ack_offset, dominant_bits_of, dominant_data_bit, lt_acknowledges_at, lt_sends_at,
    transmitter_bit_corrupted, DELIMITER, FLAG, INTERMISSION, PENALTY, SUSPEND,
};
use testbenches::protocol_bench::{Iut, ProtocolBench};

/// "The TEC passive state" of the clauses' set-up: error passive, and still error passive after one
/// successful transmission (−1), so that suspend transmission follows the IUT's own frames too.
const PASSIVE_TEC: u8 = 136;

/// The IUT's frame: the highest priority, and a dominant data bit for the LT to corrupt.
fn frame() -> Frame {
    Frame::data(Id::standard(0x001).unwrap(), &[0x80]).unwrap()
}

/// The LT's frame: of lower priority than [`frame`].
fn lt_frame() -> Frame {
    Frame::data(Id::standard(0x6B3).unwrap(), &[0x5A, 0x0F]).unwrap()
}

/// A second frame for the IUT to send.
fn second_frame() -> Frame {
    Frame::data(Id::standard(0x002).unwrap(), &[0x11]).unwrap()
}

/// The IUT, error passive with TEC `tec`, transmits [`frame`]; the LT corrupts its first dominant
/// data bit (a bit error, +8, a passive error flag from the next bit). The LT's script holds the bits
/// up to the error; returns the bench and the error's bit.
fn passive_data_error(iut: Iut, tec: u8) -> (ProtocolBench, usize) {
    let error = dominant_data_bit(&frame());
    (transmitter_bit_corrupted(iut, &frame(), tec, error), error)
}

/// 8.5.15: an error-active transmitter becomes error passive within 17 bit times of errors.
///
/// ISO 16845-1 8.5.15: the LT corrupts a data bit of the IUT's frame, then forces the IUT's active
/// error flag recessive for 16 bit times; the IUT shall send a passive error flag and repeat the
/// frame 6 + 8 + 3 + 8 bits after its last dominant bit. By ISO 11898-1 the kind of an error flag is
/// the state of the node detecting the error (an error-active node signals with an active flag, the
/// counter change is the flag's consequence): the data bit error takes TEC to 8, each corrupted flag
/// bit +8 and restarts the flag; the 15th takes TEC from 120 to 128 and is still signalled active, so
/// 16 corrupted flag bits are needed, exactly as the clause drives, and the 16th (TEC 136) is
/// signalled passive. (The same count is what 7.5.7 drives for a receiver: 17 recessive bits.)
fn iso_8_5_15_active_transmitter_becomes_passive_within_17_bit_times(iut: Iut) {
    const CORRUPTED_FLAG_BITS: usize = 16;
    let f = frame();
    let corrupted = dominant_data_bit(&f);
    let flag = corrupted + 1;
    let last_dominant = flag + CORRUPTED_FLAG_BITS - 1;
    let retransmission = last_dominant + 1 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    let encoded = encode(&f);
    let mut bench = ProtocolBench::iut_transmits(iut, &f);
    bench
        .lt()
        .release(retransmission + encoded.len() + 4)
        .set_bit(corrupted, Drive::ForceRecessive)
        .set_bit(
            retransmission + encoded.position(Field::AckSlot, 0).unwrap(),
            Drive::Dominant,
        );
    for bit in flag..flag + CORRUPTED_FLAG_BITS {
        bench.lt().set_bit(bit, Drive::ForceRecessive);
    }
    bench.run_to_bit(retransmission);
    assert_eq!(
        bench.tec(),
        PENALTY * (1 + CORRUPTED_FLAG_BITS as u8),
        "+8 for the data bit error and for each of the 16 flag bit errors"
    );
    assert!(bench.error_passive());
    bench.run(1);
    assert_eq!(
        bench.iut_dominant_bits(flag, retransmission),
        (flag..=last_dominant).collect::<Vec<_>>(),
        "16 active flag bits (each restarted), then a passive flag: recessive"
    );
    let expected: Vec<usize> = (0..encoded.len() - 3)
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .map(|i| retransmission + i)
        .collect();
    assert_eq!(
        bench.iut_dominant_bits(retransmission, retransmission + encoded.len() - 3),
        expected,
        "the frame again, SOF 6 + 8 + 3 + 8 bits after the last dominant flag bit"
    );
    assert_eq!(bench.tec(), 135, "the retransmission succeeds: −1");
}

/// A transmitter cut from the bus (its `rx` reads recessive whatever it sends) until bus-off, bit by
/// bit from ISO 11898-1 (bit error, error flags, fault confinement rules c and d, suspend
/// transmission): SOF bit error (TEC 8); 15 bit errors in its restarted active flags take TEC to 128,
/// the flag after the 15th is still active (decided at an error-active detection, as in 8.5.15) and
/// its bit error gives TEC 136; from then on each attempt is a SOF bit error (+8), a passive flag (6),
/// the delimiter (8), the intermission (3) and suspend transmission (8): 26 bits. The attempt that
/// takes TEC from 248 past 255 is the 16th after TEC 128, so bus-off comes with the SOF bit error of
/// the attempt starting at bit 17 + 25 + 14 × 26 = 406 after the first SOF.
fn iso_8_5_15_cut_transmitter_reaches_bus_off_at_the_standard_bit(iut: Iut) {
    const ATTEMPT: usize = 1 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    const FIRST_PASSIVE_ATTEMPT: usize = 17 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    const BUS_OFF_SOF: usize = FIRST_PASSIVE_ATTEMPT + 14 * ATTEMPT;
    let mut bench = ProtocolBench::iut_transmits(iut, &frame());
    let iut_id = bench.iut_id();
    let now = bench.engine.now();
    bench.engine.disturb_rx(iut_id, now, u64::MAX, RECESSIVE);
    bench.lt().release(BUS_OFF_SOF + 40);
    bench.run_to_bit(17);
    assert_eq!(bench.tec(), 136, "SOF and 16 active flag bits in error");
    assert!(bench.error_passive());
    let mut tec = 136u8;
    for attempt in 0..15 {
        let sof = FIRST_PASSIVE_ATTEMPT + attempt * ATTEMPT;
        bench.run_to_bit(sof + 1);
        if attempt < 14 {
            tec += PENALTY;
            assert_eq!(bench.tec(), tec, "attempt at bit {sof}: SOF bit error +8");
            assert!(!bench.bus_off(), "attempt at bit {sof}");
        }
    }
    assert!(
        bench.bus_off(),
        "bus-off with the SOF bit error at bit {BUS_OFF_SOF}"
    );
    assert_eq!(bench.tec(), 127, "SJA1000: TXERR 127 at bus-off");
    bench.run(0);
    let mut expected: Vec<usize> = (0..17).collect();
    expected.extend((0..15).map(|k| FIRST_PASSIVE_ATTEMPT + k * ATTEMPT));
    assert_eq!(
        bench.iut_dominant_bits(0, BUS_OFF_SOF + 40),
        expected,
        "active flags until the 16th error, then one SOF per 26-bit attempt, then nothing"
    );
}

/// 8.5.1: a passive transmitter detects no error when an active error flag overlaps its passive flag.
///
/// ISO 16845-1 8.5.1: the LT corrupts a data bit of the passive IUT's frame; during the IUT's passive
/// error flag the LT sends an active error flag starting at its first (#1), third (#2) or sixth (#3)
/// bit; 8 + 3 bits after the end of that flag the LT sends a frame, which the IUT shall acknowledge.
/// By ISO 11898-1 the passive flag is complete after 6 equal bits (the LT's 6 dominant bits), the
/// error delimiter follows at the first recessive bit; the LT's frame starts in the first bit of the
/// IUT's suspend transmission, so the IUT receives it (a node that did not start transmitting is a
/// receiver). Only the data bit error counts: TEC 136 + 8.
fn iso_8_5_1_passive_transmitter_ignores_an_active_flag_in_its_passive_flag(iut: Iut) {
    for (case, start) in [(1, 0usize), (2, 2), (3, 5)] {
        let (mut bench, error) = passive_data_error(iut, PASSIVE_TEC);
        let flag = error + 1 + start;
        bench.lt().release(flag + FLAG - error - 1);
        for bit in flag..flag + FLAG {
            bench.lt().set_bit(bit, Drive::Dominant);
        }
        let sof = flag + FLAG + DELIMITER + INTERMISSION;
        let ack = lt_sends_at(&mut bench, sof, &lt_frame());
        bench.lt().release(30);
        bench.run(0);
        assert_eq!(
            bench.iut_dominant_bits(error + 1, ack + 1),
            vec![ack],
            "#{case}: no flag of its own, the LT's frame acknowledged"
        );
        let events = bench.iut_events();
        assert_eq!(
            events[..2],
            [
                NodeEvent::BusError(ecc(BIT, false, SEG_DATA)),
                NodeEvent::Received(lt_frame())
            ],
            "#{case}: one bit error, then the LT's frame"
        );
        assert_eq!(bench.tec(), PASSIVE_TEC + PENALTY, "#{case}");
    }
}

/// 8.5.2: a passive transmitter receives a frame starting after the second intermission bit that
/// follows its error frame.
///
/// ISO 16845-1 8.5.2: the LT corrupts a data bit; during the IUT's passive flag the LT sends an
/// active error flag; 8 + 2 bits after the end of that flag it sends a frame, which the IUT shall
/// acknowledge. The frame's SOF is the third intermission bit; a passive former transmitter does
/// not take it as the start of its own transmission (it owes suspend transmission), it receives.
fn iso_8_5_2_passive_transmitter_receives_a_frame_from_intermission_bit_3(iut: Iut) {
    let (mut bench, error) = passive_data_error(iut, PASSIVE_TEC);
    let flag = error + 1;
    bench.lt().send_bits([DOMINANT; FLAG]);
    let sof = flag + FLAG + DELIMITER + 2;
    let ack = lt_sends_at(&mut bench, sof, &lt_frame());
    bench.lt().release(30);
    bench.run(0);
    assert_eq!(bench.iut_dominant_bits(error + 1, ack + 1), vec![ack]);
    assert_eq!(
        bench.iut_events()[..2],
        [
            NodeEvent::BusError(ecc(BIT, false, SEG_DATA)),
            NodeEvent::Received(lt_frame())
        ]
    );
}

/// 8.5.3: a passive transmitter detects no error for up to 7 dominant bits after its error flag.
///
/// ISO 16845-1 8.5.3: the LT corrupts a data bit and sends an active error flag over the IUT's
/// passive flag, then continues with 1 (#1), 4 (#2) or 7 (#3) dominant bits; 8 + 3 bits after them
/// it sends a frame. The IUT shall acknowledge it and restart its own frame 1 + 7 + 3 bits after its
/// ACK bit. ISO 11898-1: after a passive flag the node waits for a recessive bit; fewer than 8
/// dominant bits there cost nothing (rule 6 counts 8); the IUT, which received the last frame, owes
/// no suspend transmission.
fn iso_8_5_3_passive_transmitter_tolerates_7_dominant_bits_after_its_flag(iut: Iut) {
    for (case, extra) in [(1, 1usize), (2, 4), (3, 7)] {
        let (mut bench, error) = passive_data_error(iut, PASSIVE_TEC);
        let dominant_end = error + 1 + FLAG + extra;
        bench
            .lt()
            .send_bits(std::iter::repeat_n(DOMINANT, FLAG + extra));
        let sof = dominant_end + DELIMITER + INTERMISSION;
        let ack = lt_sends_at(&mut bench, sof, &lt_frame());
        let retransmission = ack + 1 + 7 + INTERMISSION + 1;
        lt_acknowledges_at(&mut bench, retransmission, &frame(), 4);
        bench.run(0);
        let mut expected = vec![ack];
        expected.extend(dominant_bits_of(&frame(), retransmission));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, retransmission + ack_offset(&frame())),
            expected,
            "#{case}: ACK, then the frame again 1 + 7 + 3 bits after it"
        );
        assert_eq!(
            bench.iut_events(),
            [
                NodeEvent::BusError(ecc(BIT, false, SEG_DATA)),
                NodeEvent::Received(lt_frame()),
                NodeEvent::TransmitDone(true)
            ],
            "#{case}"
        );
        assert_eq!(bench.tec(), PASSIVE_TEC + PENALTY - 1, "#{case}: +8, −1");
    }
}

/// 8.5.4: a passive transmitter receives a frame that starts during its suspend transmission.
///
/// ISO 16845-1 8.5.4: the passive IUT sends a frame (acknowledged); after its EOF and intermission
/// the LT sends a frame starting in the first (#1), fourth (#2) or eighth (#3) bit of the IUT's
/// suspend transmission; the IUT shall acknowledge it.
fn iso_8_5_4_passive_transmitter_receives_a_frame_started_during_suspend(iut: Iut) {
    let len = encode(&frame()).len();
    for (case, suspend_bit) in [(1, 0usize), (2, 3), (3, 7)] {
        let mut bench = ProtocolBench::iut_transmits_with(iut, &frame(), PASSIVE_TEC, false);
        bench
            .lt()
            .release(len)
            .set_bit(ack_offset(&frame()), Drive::Dominant);
        let sof = len + INTERMISSION + suspend_bit;
        let ack = lt_sends_at(&mut bench, sof, &lt_frame());
        bench.lt().release(20);
        bench.run(0);
        assert_eq!(bench.iut_dominant_bits(len, ack + 20), vec![ack], "#{case}");
        assert_eq!(
            bench.iut_events(),
            [
                NodeEvent::TransmitDone(true),
                NodeEvent::Received(lt_frame())
            ],
            "#{case}"
        );
    }
}

/// 8.5.5: after an error frame a passive transmitter waits for suspend transmission.
///
/// ISO 16845-1 8.5.5: after the IUT's passive error flag (data bit corrupted) the bus stays
/// recessive for the delimiter, intermission and suspend transmission; the IUT shall wait 8 bits
/// after the intermission: its SOF is bit e + 1 + 6 + 8 + 3 + 8.
fn iso_8_5_5_passive_transmitter_suspends_after_an_error_frame(iut: Iut) {
    let (mut bench, error) = passive_data_error(iut, PASSIVE_TEC);
    let sof = error + 1 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    lt_acknowledges_at(&mut bench, sof, &frame(), 4);
    bench.run(0);
    assert_eq!(
        bench.iut_dominant_bits(error + 1, sof + ack_offset(&frame())),
        dominant_bits_of(&frame(), sof)
    );
    assert_eq!(bench.tec(), PASSIVE_TEC + PENALTY - 1);
}

/// 8.5.6: after an overload frame a passive transmitter waits for suspend transmission.
///
/// ISO 16845-1 8.5.6: the passive IUT has two frames to send; after the first (acknowledged) the LT
/// causes an overload frame (dominant first intermission bit), then leaves the bus recessive; the
/// IUT shall wait 8 bits after the intermission that follows the overload frame before its second
/// frame. (The controller has one transmit buffer: the second frame is requested once the first is
/// done, at the end of its EOF.)
fn iso_8_5_6_passive_transmitter_suspends_after_an_overload_frame(iut: Iut) {
    let len = encode(&frame()).len();
    let mut bench = ProtocolBench::iut_transmits_with(iut, &frame(), PASSIVE_TEC, false);
    lt_acknowledges_at(&mut bench, 0, &frame(), 4);
    bench.lt().set_bit(len, Drive::Dominant);
    let sof = len + 1 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    lt_acknowledges_at(&mut bench, sof, &second_frame(), 4);
    bench.run_to_bit(len);
    bench.send(&second_frame(), false);
    bench.run(0);
    let mut expected: Vec<usize> = (len + 1..len + 1 + FLAG).collect();
    expected.extend(dominant_bits_of(&second_frame(), sof));
    assert_eq!(
        bench.iut_dominant_bits(len, sof + ack_offset(&second_frame())),
        expected,
        "overload flag, delimiter, intermission, 8 suspend bits, the second frame"
    );
    assert_eq!(
        bench.iut_events(),
        [NodeEvent::TransmitDone(true), NodeEvent::TransmitDone(true)]
    );
}

/// 8.5.7: after its own frame a passive transmitter waits for suspend transmission.
///
/// ISO 16845-1 8.5.7: the passive IUT sends two frames; the first is acknowledged and followed by
/// EOF and intermission; the IUT shall wait 8 more bits before the second: SOF at EOF + 3 + 8.
fn iso_8_5_7_passive_transmitter_suspends_after_its_own_frame(iut: Iut) {
    let len = encode(&frame()).len();
    let mut bench = ProtocolBench::iut_transmits_with(iut, &frame(), PASSIVE_TEC, false);
    lt_acknowledges_at(&mut bench, 0, &frame(), 4);
    let sof = len + INTERMISSION + SUSPEND;
    lt_acknowledges_at(&mut bench, sof, &second_frame(), 4);
    bench.run_to_bit(len);
    bench.send(&second_frame(), false);
    bench.run(0);
    assert_eq!(
        bench.iut_dominant_bits(len, sof + ack_offset(&second_frame())),
        dominant_bits_of(&second_frame(), sof)
    );
    assert_eq!(bench.tec(), PASSIVE_TEC - 2, "two successes");
}

/// 8.5.8: a passive transmitter that lost arbitration repeats its frame without suspend.
///
/// ISO 16845-1 8.5.8: the LT sends a frame of higher priority at the IUT's SOF; the IUT loses
/// arbitration, receives and acknowledges it, and shall send its frame again 1 + 7 + 3 bits after
/// its ACK bit (it was a receiver of the last frame: no suspend transmission).
fn iso_8_5_8_passive_transmitter_that_lost_arbitration_does_not_suspend(iut: Iut) {
    let winner = Frame::data(Id::standard(0x000).unwrap(), &[0x3C]).unwrap();
    let mine = second_frame();
    let mut bench = ProtocolBench::iut_transmits_with(iut, &mine, PASSIVE_TEC, false);
    let ack = lt_sends_at(&mut bench, 0, &winner);
    let sof = ack + 1 + 7 + INTERMISSION + 1;
    lt_acknowledges_at(&mut bench, sof, &mine, 4);
    bench.run(0);
    let lost_at = encode(&winner)
        .bits
        .iter()
        .by_vals()
        .zip(encode(&mine).bits.iter().by_vals())
        .position(|(w, m)| w != m)
        .expect("the frames differ");
    let mut expected: Vec<usize> = dominant_bits_of(&mine, 0)
        .into_iter()
        .filter(|&b| b < lost_at)
        .collect();
    expected.push(ack);
    expected.extend(dominant_bits_of(&mine, sof));
    assert_eq!(
        bench.iut_dominant_bits(0, sof + ack_offset(&mine)),
        expected
    );
    assert_eq!(
        bench.iut_events()[1..],
        [NodeEvent::Received(winner), NodeEvent::TransmitDone(true)]
    );
}

/// 8.5.9: a passive transmitter does not start its frame at the identifier on a dominant third
/// intermission bit, nor during suspend transmission.
///
/// ISO 16845-1 8.5.9: after the passive IUT's error frame (data bit corrupted) the LT starts a frame
/// of lower priority in the third intermission bit (#1), the first (#2) or the seventh (#3) bit of
/// suspend transmission. The IUT shall not start its retransmission before the end of the LT's frame
/// and shall acknowledge it. ISO 11898-1: a pending error-active node may take a dominant third
/// intermission bit as its own SOF; an error-passive former transmitter owes suspend transmission,
/// so it receives. Its retransmission follows the LT's frame after the intermission.
fn iso_8_5_9_passive_transmitter_does_not_join_a_frame_in_intermission_or_suspend(iut: Iut) {
    let intermission = FLAG + DELIMITER;
    for (case, offset) in [
        (1, intermission + 2),
        (2, intermission + INTERMISSION),
        (3, intermission + INTERMISSION + 6),
    ] {
        let (mut bench, error) = passive_data_error(iut, PASSIVE_TEC);
        let sof = error + 1 + offset;
        let ack = lt_sends_at(&mut bench, sof, &lt_frame());
        let retransmission = sof + encode(&lt_frame()).len() + INTERMISSION;
        lt_acknowledges_at(&mut bench, retransmission, &frame(), 4);
        bench.run(0);
        let mut expected = vec![ack];
        expected.extend(dominant_bits_of(&frame(), retransmission));
        assert_eq!(
            bench.iut_dominant_bits(error + 1, retransmission + ack_offset(&frame())),
            expected,
            "#{case}: the LT's frame acknowledged, the IUT's frame after it"
        );
        assert_eq!(
            bench.iut_events(),
            [
                NodeEvent::BusError(ecc(BIT, false, SEG_DATA)),
                NodeEvent::Received(lt_frame()),
                NodeEvent::TransmitDone(true)
            ],
            "#{case}"
        );
    }
}

/// Recessive bits after which a bus-off node recovers: 128 sequences of 11 (ISO 11898-1).
const RECOVERY_BITS: usize = 128 * 11;

/// After bus-off at script bit `bus_off`, the host clears MOD.RM three bits later (the SJA1000 sets
/// RM at bus-off; recovery counts from the write) and, on the controller, requests [`frame`] again
/// (reset mode ended the request). Returns the bit at which recovery starts counting.
fn restart_after_bus_off(bench: &mut ProtocolBench, iut: Iut, bus_off: usize) -> usize {
    let cleared = bus_off + 3;
    bench.clear_reset_mode_at(cleared);
    if iut == Iut::Registers {
        bench.send(&frame(), false);
    }
    cleared
}

/// 8.5.10: a passive transmitter driven to bus-off through overload flags sends its frame once and
/// acknowledges nothing while bus-off.
///
/// ISO 16845-1 8.5.10: the passive IUT (TEC 128)'s frame is corrupted (data bit: +8, TEC 136); its passive
/// flag is followed by 112 dominant bits (ISO 11898-1 rule 6: +8 after each 8 dominant bits
/// following a passive flag: TEC 248); then it retransmits its frame (acknowledged: 247); the LT
/// makes the first intermission bit dominant and forces the first bit of the IUT's overload flag
/// recessive (a bit error in its overload flag: +8, 255, and a passive error flag since the IUT is
/// passive at that detection); 6 + 7 bits later a dominant bit (the eighth delimiter bit: a new
/// overload flag) whose first bit the LT forces recessive again: TEC above 255, bus-off. The LT
/// sends a frame 6 + 8 + 3 + 8 bits later: the bus-off IUT shall not acknowledge it; after recovery
/// (128 × 11 recessive bits, counted from the host's restart) its counters are 0.
fn iso_8_5_10_passive_transmitter_reaches_bus_off_through_overload_flags(iut: Iut) {
    const DOMINANT_AFTER_FLAG: usize = 112;
    // TEC 128 (the passive limit): the clause's sequence ends exactly above 255.
    const TEC: u8 = 128;
    let (mut bench, error) = passive_data_error(iut, TEC);
    bench
        .lt()
        .release(FLAG)
        .send_bits(std::iter::repeat_n(DOMINANT, DOMINANT_AFTER_FLAG));
    let retransmission =
        error + 1 + FLAG + DOMINANT_AFTER_FLAG + DELIMITER + INTERMISSION + SUSPEND;
    let len = encode(&frame()).len();
    lt_acknowledges_at(&mut bench, retransmission, &frame(), 4);
    let overload_bit_1 = retransmission + len + 1;
    bench.lt().set_bit(overload_bit_1 - 1, Drive::Dominant);
    bench.lt().set_bit(overload_bit_1, Drive::ForceRecessive);
    // 6 + 7 bits after the bit error: the passive flag and 7 delimiter bits; the dominant bit is the
    // eighth delimiter bit, and the new overload flag starts after it.
    let second_overload = overload_bit_1 + 1 + FLAG + 7 + 1;
    let played = bench.lt_ref().script_len();
    bench.lt().release(second_overload + 2 - played);
    bench.lt().set_bit(second_overload - 1, Drive::Dominant);
    bench.lt().set_bit(second_overload, Drive::ForceRecessive);
    let lt_sof = second_overload + 1 + FLAG + DELIMITER + INTERMISSION + SUSPEND;
    let lt_ack = lt_sends_at(&mut bench, lt_sof, &lt_frame());
    bench.run_to_bit(retransmission);
    assert_eq!(bench.tec(), TEC + PENALTY + 14 * PENALTY, "+8, then 14 × 8");
    bench.run_to_bit(second_overload + 1);
    assert!(
        bench.bus_off(),
        "bus-off at the bit error in the second overload flag"
    );
    let end = lt_sof + encode(&lt_frame()).len();
    let cleared = restart_after_bus_off(&mut bench, iut, end);
    bench.lt().release(cleared + RECOVERY_BITS + 2 - end);
    bench.run(0);
    let mut expected = dominant_bits_of(&frame(), 0);
    expected.retain(|&b| b <= error);
    expected.extend(dominant_bits_of(&frame(), retransmission));
    expected.push(overload_bit_1);
    expected.push(second_overload);
    assert_eq!(
        bench.iut_dominant_bits(0, lt_ack + 1),
        expected,
        "the frame sent once more, the first bit of each overload flag; no ACK while bus-off"
    );
    assert!(!bench.bus_off(), "recovered after 128 × 11 recessive bits");
    assert_eq!(
        (bench.tec(), bench.rec()),
        (0, 0),
        "counters reset by the recovery"
    );
}

/// 8.5.11: a bus-off IUT becomes error active only after 128 sequences of 11 recessive bits.
///
/// ISO 16845-1 8.5.11: the IUT goes bus-off with a frame to send (TEC 248, a data bit error); the LT
/// then sends #1 recessive bits for 128 × 11 bit times, or #2 one group of 10 recessive bits, one of
/// 21 and 127 of 11, each group separated by one dominant bit (the 10-bit group counts nothing, the
/// 21-bit group one sequence). The IUT shall not send its frame before the end of the profile and
/// shall send it before a time-out, which the clause leaves open: here within the 11 bits of one
/// bus-idle sequence after the profile (the IUT starts 1 bit after it: it leaves bus-off at the
/// sample point of the last recessive bit and spends one bit in bus idle).
fn iso_8_5_11_bus_off_recovery_needs_128_sequences_of_11_recessive_bits(iut: Iut) {
    for case in [1, 2] {
        let f = frame();
        let error = dominant_data_bit(&f);
        let mut bench = ProtocolBench::iut_transmits_with(iut, &f, 248, false);
        bench
            .lt()
            .release(error + 1)
            .set_bit(error, Drive::ForceRecessive);
        bench.run_to_bit(error + 1);
        assert!(bench.bus_off(), "#{case}: 248 + 8 is above 255");
        let start = restart_after_bus_off(&mut bench, iut, error);
        bench.lt().release(start - error - 1);
        if case == 1 {
            bench.lt().release(RECOVERY_BITS);
        } else {
            bench.lt().release(10).send_bits([DOMINANT]).release(21);
            for _ in 0..127 {
                bench.lt().send_bits([DOMINANT]).release(11);
            }
        }
        let profile_end = bench.lt_ref().script_len();
        bench.lt().release(11);
        bench.run(0);
        assert!(
            bench.iut_dominant_bits(error + 1, profile_end).is_empty(),
            "#{case}: nothing during the profile"
        );
        let sof = bench
            .iut_dominant_bits(profile_end, profile_end + 11)
            .first()
            .copied()
            .unwrap_or_else(|| panic!("#{case}: no SOF within 11 bits after the profile"));
        lt_acknowledges_at(&mut bench, sof, &f, 4);
        bench.run(0);
        assert_eq!(
            bench.iut_dominant_bits(sof, sof + ack_offset(&f)),
            dominant_bits_of(&f, sof),
            "#{case}: the frame"
        );
        assert_eq!(
            bench.tec(),
            0,
            "#{case}: recovered, then a success at TEC 0"
        );
    }
}

/// 8.5.12: a passive transmitter completes its passive flag after 6 equal bits.
///
/// ISO 16845-1 8.5.12: during the passive IUT's error flag (data bit corrupted) the LT sends 5
/// dominant, 5 recessive, then 6 dominant bits; 8 bits after those it sends one dominant bit. The
/// flag is complete only with the 6 equal dominant bits; the delimiter (8 bits) follows, and the
/// dominant bit falls in the first intermission bit: an overload frame from the next bit.
fn iso_8_5_12_passive_flag_waits_for_6_equal_bits(iut: Iut) {
    let (mut bench, error) = passive_data_error(iut, PASSIVE_TEC);
    bench
        .lt()
        .send_bits([DOMINANT; 5])
        .release(5)
        .send_bits([DOMINANT; 6])
        .release(DELIMITER)
        .send_bits([DOMINANT])
        .release(20);
    bench.run(0);
    let last_dominant = error + 5 + 5 + 6 + DELIMITER + 1;
    assert_eq!(
        bench.iut_dominant_bits(error + 1, last_dominant + 20),
        (last_dominant + 1..=last_dominant + FLAG).collect::<Vec<_>>(),
        "an overload flag right after the LT's dominant bit"
    );
    assert_eq!(bench.tec(), PASSIVE_TEC + PENALTY);
}

/// 8.5.13: a passive transmitter detects a form error in its error delimiter.
///
/// ISO 16845-1 8.5.13: after the passive IUT's error flag (data bit corrupted) the LT makes bit 2
/// (#1), 4 (#2) or 7 (#3) of the error delimiter dominant; 6 + 7 bits after that form error it sends
/// a dominant bit. The form error starts a new passive flag (6 bits) and delimiter; the dominant bit
/// is its eighth delimiter bit, an overload condition: an overload flag from the next bit. TEC: +8
/// for the bit error, +8 for the form error (ISO 11898-1 rule 3; ISO 16845-1 8.6.9).
fn iso_8_5_13_passive_transmitter_detects_a_form_error_in_its_error_delimiter(iut: Iut) {
    for (case, delimiter_bit) in [(1, 2usize), (2, 4), (3, 7)] {
        let (mut bench, error) = passive_data_error(iut, PASSIVE_TEC);
        let form_error = error + FLAG + delimiter_bit;
        let dominant = form_error + FLAG + 7 + 1;
        bench.lt().release(dominant + 20 - error - 1);
        bench.lt().set_bit(form_error, Drive::Dominant);
        bench.lt().set_bit(dominant, Drive::Dominant);
        bench.run(0);
        assert_eq!(
            bench.iut_dominant_bits(error + 1, dominant + 20),
            (dominant + 1..=dominant + FLAG).collect::<Vec<_>>(),
            "#{case}: an overload flag after the LT's dominant bit"
        );
        assert_eq!(
            bench.iut_events(),
            [
                NodeEvent::BusError(ecc(BIT, false, SEG_DATA)),
                NodeEvent::BusError(ecc(FORM, false, SEG_ERROR_DELIM)),
            ],
            "#{case}"
        );
        assert_eq!(bench.tec(), PASSIVE_TEC + 2 * PENALTY, "#{case}");
    }
}

/// 8.5.14: a passive transmitter repeats its frame at most 31 bit times after an error.
///
/// ISO 16845-1 8.5.14: after the passive flag that follows the corrupted data bit, the LT sends 6
/// dominant bits. They are tolerated after a passive flag; the delimiter starts with the first
/// recessive bit, then intermission and suspend transmission: the SOF is 1 + 6 + 6 + 8 + 3 + 8 bits
/// after the corrupted bit, as the clause's 31 bit times after its detection.
fn iso_8_5_14_passive_transmitter_repeats_31_bit_times_after_the_error(iut: Iut) {
    let (mut bench, error) = passive_data_error(iut, PASSIVE_TEC);
    bench.lt().release(FLAG).send_bits([DOMINANT; 6]);
    let sof = error + 1 + FLAG + 6 + DELIMITER + INTERMISSION + SUSPEND;
    assert_eq!(
        sof - error,
        32,
        "the SOF bit starts 31 bit times after the error's bit ends"
    );
    lt_acknowledges_at(&mut bench, sof, &frame(), 4);
    bench.run(0);
    assert_eq!(
        bench.iut_dominant_bits(error + 1, sof + ack_offset(&frame())),
        dominant_bits_of(&frame(), sof)
    );
    assert_eq!(bench.tec(), PASSIVE_TEC + PENALTY - 1);
}

testbenches::on_both_iuts! {
    iso_8_5_1_passive_transmitter_ignores_an_active_flag_in_its_passive_flag,
    iso_8_5_2_passive_transmitter_receives_a_frame_from_intermission_bit_3,
    iso_8_5_3_passive_transmitter_tolerates_7_dominant_bits_after_its_flag,
    iso_8_5_4_passive_transmitter_receives_a_frame_started_during_suspend,
    iso_8_5_5_passive_transmitter_suspends_after_an_error_frame,
    iso_8_5_6_passive_transmitter_suspends_after_an_overload_frame,
    iso_8_5_7_passive_transmitter_suspends_after_its_own_frame,
    iso_8_5_8_passive_transmitter_that_lost_arbitration_does_not_suspend,
    iso_8_5_9_passive_transmitter_does_not_join_a_frame_in_intermission_or_suspend,
    iso_8_5_10_passive_transmitter_reaches_bus_off_through_overload_flags,
    iso_8_5_11_bus_off_recovery_needs_128_sequences_of_11_recessive_bits,
    iso_8_5_12_passive_flag_waits_for_6_equal_bits,
    iso_8_5_13_passive_transmitter_detects_a_form_error_in_its_error_delimiter,
    iso_8_5_14_passive_transmitter_repeats_31_bit_times_after_the_error,
    iso_8_5_15_active_transmitter_becomes_passive_within_17_bit_times,
    iso_8_5_15_cut_transmitter_reaches_bus_off_at_the_standard_bit,
}
