//! Conformance group AR (arbitration) and RT-02 on both IUTs (the RTL core, and the controller
//! through its registers): where the IUT stops driving, the ALC position it reports, what it
//! receives, its counters and when it retransmits.
//!
//! The IUT transmits with [`ProtocolBench::iut_transmits`]; the LT's script starts at the IUT's SOF
//! (script bit 0 = SOF), so script bit positions are wire positions of both frames (stuff bits
//! counted). Every expected position comes from the golden encoding (`golden::frame::encode`). Two frames
//! that are equal up to some bit are stuffed identically up to there (stuffing only depends on the
//! earlier bits), so the first wire bit where they differ is a real (non-stuff) bit of both frames.
//! An error detected at bit e gives the IUT's flag at e+1..e+6 (catalog conventions).

use golden::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT, RECESSIVE};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::ecc::{ecc, SEG_DATA, STUFF};
use testbenches::protocol_bench::{acknowledged_bits, Iut, LtScript, ProtocolBench};

/// Bits after a frame's last EOF bit until the next SOF: the 3 intermission bits.
const INTERMISSION: usize = 3;

fn std_id(id: u16) -> Id {
    Id::standard(id).unwrap()
}

fn ext_id(id: u32) -> Id {
    Id::extended(id).unwrap()
}

fn field(encoded: &EncodedFrame, f: Field, index: u16) -> usize {
    encoded
        .position(f, index)
        .unwrap_or_else(|| panic!("{f:?} {index} not in the frame"))
}

/// The dominant wire positions of `encoded` in `from..to`, shifted by `offset` (where its SOF is in
/// the script).
fn golden_dominant(encoded: &EncodedFrame, from: usize, to: usize, offset: usize) -> Vec<usize> {
    (from..to.min(encoded.len()))
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .map(|i| i + offset)
        .collect()
}

/// The six bits of an error flag after an error at `e`.
fn flag_after(e: usize) -> Vec<usize> {
    (e + 1..=e + 6).collect()
}

/// The first wire position where the two frames differ (panics if one is a prefix of the other).
fn first_difference(a: &EncodedFrame, b: &EncodedFrame) -> usize {
    (0..a.len().min(b.len()))
        .find(|&i| a.bits[i] != b.bits[i])
        .expect("the frames differ")
}

/// Checks that the IUT's `mine` loses to the LT's `theirs` exactly at `loss` (the construction of the
/// scenario, from the golden bits): equal before, IUT recessive and LT dominant there, not a stuff bit.
fn check_loss_position(mine: &EncodedFrame, theirs: &EncodedFrame, loss: usize, what: &str) {
    assert_eq!(
        first_difference(mine, theirs),
        loss,
        "{what}: first difference"
    );
    assert_eq!(
        mine.bits[loss], RECESSIVE,
        "{what}: IUT recessive at the loss"
    );
    assert_eq!(
        theirs.bits[loss], DOMINANT,
        "{what}: LT dominant at the loss"
    );
    assert!(!mine.tags[loss].stuff && !theirs.tags[loss].stuff, "{what}");
}

/// The AR-01 pattern: the IUT transmits `mine`, the LT plays `theirs` from the IUT's SOF; `theirs`
/// wins at its bit (`loss_field`, `loss_index`). Expected: the IUT sends its own frame up to the loss,
/// is recessive from there except its ACK of the LT frame, reports `ArbitrationLost(alc)`, receives
/// the LT frame, keeps its counters and starts its retransmission right after the LT frame's
/// intermission.
fn lose_arbitration(
    iut: Iut,
    mine: &Frame,
    theirs: &Frame,
    loss_field: Field,
    loss_index: u16,
    alc: u8,
) {
    let what = format!("{mine} vs {theirs} (ALC {alc})");
    let (enc_mine, enc_theirs) = (encode(mine), encode(theirs));
    let loss = field(&enc_theirs, loss_field, loss_index);
    check_loss_position(&enc_mine, &enc_theirs, loss, &what);
    let mut bench = ProtocolBench::iut_transmits(iut, mine);
    // 6 released bits after the LT frame: intermission (3) and the IUT's retransmission SOF.
    bench.lt().send_frame(&enc_theirs).release(6);
    bench.run(1);
    let ack = field(&enc_theirs, Field::AckSlot, 0);
    // The LT frame ends at len - 1 (EOF bit 7); intermission len..len+2; SOF at len + 3.
    let next_sof = enc_theirs.len() + INTERMISSION;
    assert_eq!(
        bench.iut_dominant_bits(0, loss),
        golden_dominant(&enc_mine, 0, loss, 0),
        "{what}: the IUT sends its own frame up to the loss"
    );
    assert_eq!(
        bench.iut_dominant_bits(loss, next_sof + 1),
        vec![ack, next_sof],
        "{what}: recessive from the loss bit, ACK of the LT frame, retry after the intermission"
    );
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::ArbitrationLost(alc),
            NodeEvent::Received(*theirs)
        ],
        "{what}: no error, LT frame received"
    );
    assert_eq!(
        (bench.tec(), bench.rec()),
        (0, 0),
        "{what}: counters unchanged"
    );
}

fn ar_02_extended_loss_at_every_extended_identifier_bit(iut: Iut) {
    // Two IUT identifiers (all recessive; alternating bits, i.e. other stuffing), with extended bit j
    // forced recessive in the IUT's frame and dominant in the LT's.
    for base in [0x1FFF_FFFFu32, 0x0AAA_AAAA] {
        for j in 0..18u16 {
            let bit = 1u32 << (17 - j); // ExtId index 0 is ID.17
            let mine = Frame::data(ext_id(base | bit), &[]).unwrap();
            let theirs = Frame::data(ext_id(base & !bit), &[0xA5]).unwrap();
            // ALC: 0..10 base ID, 11 SRR, 12 IDE, 13.. ID.17..ID.0.
            lose_arbitration(iut, &mine, &theirs, Field::ExtId, j, 13 + j as u8);
        }
    }
}

fn ar_03_extended_loses_to_standard_at_srr(iut: Iut) {
    // The IUT's recessive SRR meets the LT's dominant RTR (standard data frame), same base ID.
    let mine = Frame::data(ext_id(0x2C5 << 18 | 0x1_2345), &[0x11]).unwrap();
    let theirs = Frame::data(std_id(0x2C5), &[0x81, 0x3C]).unwrap();
    assert_eq!(
        field(&encode(&mine), Field::Srr, 0),
        field(&encode(&theirs), Field::Rtr, 0)
    );
    lose_arbitration(iut, &mine, &theirs, Field::Rtr, 0, 11);
}

fn ar_04_standard_remote_loses_to_data_at_rtr(iut: Iut) {
    let mine = Frame::remote(std_id(0x2C5), 2).unwrap();
    let theirs = Frame::data(std_id(0x2C5), &[0x81, 0x3C]).unwrap();
    lose_arbitration(iut, &mine, &theirs, Field::Rtr, 0, 11);
}

fn ar_05_extended_loses_to_standard_remote_at_ide(iut: Iut) {
    // SRR (IUT) and RTR (LT remote frame) are both recessive; the IUT's recessive IDE meets the
    // LT's dominant one.
    let mine = Frame::data(ext_id(0x2C5 << 18 | 0x1_2345), &[0x11]).unwrap();
    let theirs = Frame::remote(std_id(0x2C5), 3).unwrap();
    lose_arbitration(iut, &mine, &theirs, Field::Ide, 0, 12);
}

fn ar_06_extended_remote_loses_to_extended_data_at_rtr(iut: Iut) {
    let id = ext_id(0x0ABC_DEF1);
    let mine = Frame::remote(id, 4).unwrap();
    let theirs = Frame::data(id, &[0x01, 0x02, 0x03, 0x04]).unwrap();
    lose_arbitration(iut, &mine, &theirs, Field::Rtr, 0, 31);
}

fn ar_07_iut_wins_against_a_larger_identifier(iut: Iut) {
    // (IUT frame, LT frame): the LT's identifier is numerically larger (or it loses at SRR/RTR/IDE),
    // so the first bit where they differ is dominant for the IUT and recessive for the LT.
    let cases = [
        // Base ID: 0x2C5 = 010_1100_0101, 0x3C5 = 011_1100_0101 differ at ID.26 (bit 2).
        (
            Frame::data(std_id(0x2C5), &[0x81, 0x3C]).unwrap(),
            Frame::data(std_id(0x3C5), &[0x00]).unwrap(),
        ),
        // Standard data vs standard remote, same ID: the LT loses at RTR.
        (
            Frame::data(std_id(0x2C5), &[0x81]).unwrap(),
            Frame::remote(std_id(0x2C5), 1).unwrap(),
        ),
        // Standard vs extended with the same base ID: the LT loses at SRR.
        (
            Frame::data(std_id(0x2C5), &[]).unwrap(),
            Frame::data(ext_id(0x2C5 << 18), &[]).unwrap(),
        ),
        // Extended vs extended, differing in ID.0 only.
        (
            Frame::data(ext_id(0x1555_5554), &[0xFF, 0x00]).unwrap(),
            Frame::data(ext_id(0x1555_5555), &[0x12]).unwrap(),
        ),
    ];
    for (mine, theirs) in cases {
        let what = format!("{mine} vs {theirs}");
        let (enc_mine, enc_theirs) = (encode(&mine), encode(&theirs));
        let lt_loses = first_difference(&enc_mine, &enc_theirs);
        assert_eq!(enc_mine.bits[lt_loses], DOMINANT, "{what}");
        assert_eq!(enc_theirs.bits[lt_loses], RECESSIVE, "{what}");
        let ack = field(&enc_mine, Field::AckSlot, 0);
        let tail = 4; // released bits after the IUT's frame: no retransmission may start there
        let mut bench = ProtocolBench::iut_transmits(iut, &mine);
        // The LT plays its frame up to (not including) the bit it loses, then stops driving (a
        // transmitter that lost), and acknowledges the IUT's frame.
        bench
            .lt()
            .send_bits(enc_theirs.bits[..lt_loses].iter().by_vals())
            .release(enc_mine.len() - lt_loses + tail)
            .set_bit(ack, Drive::Dominant);
        bench.run(1);
        assert_eq!(
            bench.iut_dominant_bits(0, enc_mine.len() + tail),
            golden_dominant(&enc_mine, 0, enc_mine.len(), 0),
            "{what}: the IUT sends its whole golden frame, and nothing after it"
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::TransmitDone(true)],
            "{what}: no arbitration loss, success"
        );
        assert_eq!((bench.tec(), bench.rec()), (0, 0), "{what}");
        // "The LT receives it": the bus at the LT's sample points is the IUT's frame, acknowledged.
        let sp = bench.sample_point_tq() - 1;
        let bus: Vec<bool> = (0..enc_mine.len())
            .map(|i| bench.lt_ref().observed(i, sp).expect("observed"))
            .collect();
        assert_eq!(bus, acknowledged_bits(&enc_mine), "{what}: bus");
    }
}

fn ar_08_stuff_error_after_lost_arbitration_makes_the_receiver_flag(iut: Iut) {
    let mine = Frame::data(std_id(0x7FF), &[0x5A]).unwrap();
    // 0x7FF with ID bit 4 (ID.24) dominant: the IUT loses there, ALC 4. Data 0x00 0xFF gives
    // recessive and dominant stuff bits in the data field.
    let theirs = Frame::data(std_id(0x7FF & !(1 << (10 - 4))), &[0x00, 0xFF, 0x33]).unwrap();
    let (enc_mine, enc_theirs) = (encode(&mine), encode(&theirs));
    let loss = field(&enc_theirs, Field::BaseId, 4);
    check_loss_position(&enc_mine, &enc_theirs, loss, "AR-08");
    // The first stuff bit of each polarity inside the data field (followed by a data bit: ECC
    // segment "data"; a stuff bit is captured with the segment of the bit after it).
    let stuff_bits: Vec<usize> = [DOMINANT, RECESSIVE]
        .into_iter()
        .map(|level| {
            (loss..enc_theirs.len() - 1)
                .find(|&i| {
                    enc_theirs.tags[i].stuff
                        && enc_theirs.bits[i] == level
                        && enc_theirs.tags[i + 1].field == Field::Data
                })
                .expect("a data stuff bit of that level")
        })
        .collect();
    let mine_ack = field(&enc_mine, Field::AckSlot, 0);
    for s in stuff_bits {
        let what = format!("stuff bit {s} ({}) inverted", enc_theirs.bits[s] as u8);
        // Error at s: flag s+1..s+6, delimiter s+7..s+14, intermission s+15..s+17, the IUT (error
        // active, was receiver) retransmits at s + 18.
        let retry = s + 18;
        let mut bits: Vec<bool> = enc_theirs.bits[..=s].iter().by_vals().collect();
        bits[s] = !bits[s];
        let mut bench = ProtocolBench::iut_transmits(iut, &mine);
        bench
            .lt()
            .send_bits(bits)
            .release(retry + enc_mine.len() + 2 - (s + 1))
            .set_bit(retry + mine_ack, Drive::Dominant);
        bench.run(1);
        let mut expected = flag_after(s);
        expected.push(retry);
        assert_eq!(
            bench.iut_dominant_bits(loss, retry + 1),
            expected,
            "{what}: recessive after the loss, receiver flag from the next bit, retry at e + 18"
        );
        assert_eq!(
            bench.iut_dominant_bits(retry, retry + enc_mine.len()),
            golden_dominant(&enc_mine, 0, enc_mine.len(), retry),
            "{what}: the retransmission is the golden frame"
        );
        assert_eq!(
            bench.iut_events(),
            vec![
                NodeEvent::ArbitrationLost(4),
                NodeEvent::BusError(ecc(STUFF, true, SEG_DATA)),
                NodeEvent::TransmitDone(true),
            ],
            "{what}: stuff error as receiver, not stored, retransmitted"
        );
        assert_eq!(bench.rec(), 1, "{what}: REC+1");
        assert_eq!(bench.tec(), 0, "{what}: TEC unchanged");
    }
}

/// AR-09 proper (ALC keeps the first position until ALC is read; one ALI) is a rule of the SJA1000
/// register block (`registers.rs`). Here every loss is reported, each with its own position: the
/// core's strobes, and through the registers an ALI per loss because the interrupt handler reads ALC
/// after each. Two losses in a row (the second frame of the LT starts together with the IUT's retry),
/// then the IUT's third attempt succeeds.
fn ar_09_core_reports_every_loss(iut: Iut) {
    let mine = Frame::data(ext_id(0x1FFF_FFFF), &[0x11]).unwrap();
    // First loss at ID.12 (extended bit 5): ALC 13 + 5 = 18.
    let first = Frame::data(ext_id(0x1FFF_FFFF & !(1 << (17 - 5))), &[0x22]).unwrap();
    // Second loss at SRR against a standard frame with the same base ID: ALC 11.
    let second = Frame::data(std_id(0x7FF), &[0x33, 0x44]).unwrap();
    let (enc_mine, enc_1, enc_2) = (encode(&mine), encode(&first), encode(&second));
    let loss_1 = field(&enc_1, Field::ExtId, 5);
    let loss_2 = field(&enc_2, Field::Rtr, 0);
    check_loss_position(&enc_mine, &enc_1, loss_1, "first loss");
    check_loss_position(&enc_mine, &enc_2, loss_2, "second loss");
    // Script: frame 1, intermission, frame 2 from the IUT's retry SOF, intermission, the third
    // attempt (acknowledged).
    let sof_2 = enc_1.len() + INTERMISSION;
    let sof_3 = sof_2 + enc_2.len() + INTERMISSION;
    let mut bench = ProtocolBench::iut_transmits(iut, &mine);
    bench
        .lt()
        .send_frame(&enc_1)
        .release(INTERMISSION)
        .send_frame(&enc_2)
        .release(INTERMISSION + enc_mine.len() + 2)
        .set_bit(sof_3 + field(&enc_mine, Field::AckSlot, 0), Drive::Dominant);
    bench.run(1);
    assert_eq!(
        bench.iut_events(),
        vec![
            NodeEvent::ArbitrationLost(18),
            NodeEvent::Received(first),
            NodeEvent::ArbitrationLost(11),
            NodeEvent::Received(second),
            NodeEvent::TransmitDone(true),
        ],
        "both losses reported with their positions"
    );
    let ack_1 = field(&enc_1, Field::AckSlot, 0);
    let ack_2 = sof_2 + field(&enc_2, Field::AckSlot, 0);
    let mut expected = golden_dominant(&enc_mine, 0, loss_1, 0);
    expected.push(ack_1);
    expected.extend(golden_dominant(&enc_mine, 0, loss_2, sof_2));
    expected.push(ack_2);
    expected.extend(golden_dominant(&enc_mine, 0, enc_mine.len(), sof_3));
    assert_eq!(
        bench.iut_dominant_bits(0, sof_3 + enc_mine.len()),
        expected,
        "attempt 1 up to ID.12, ACK, attempt 2 up to SRR, ACK, attempt 3 complete"
    );
    assert_eq!((bench.tec(), bench.rec()), (0, 0));
}

fn rt_02_retransmission_after_lost_arbitration_right_after_the_intermission(iut: Iut) {
    let cases = [
        // Loss in the base identifier (ID.28, ALC 0).
        (
            Frame::data(std_id(0x7F0), &[0x01]).unwrap(),
            Frame::data(std_id(0x3F0), &[0xA5, 0x5A]).unwrap(),
            0u8,
        ),
        // Loss at RTR of an extended remote frame (ALC 31).
        (
            Frame::remote(ext_id(0x0123_4567), 8).unwrap(),
            Frame::data(ext_id(0x0123_4567), &[0xFF; 8]).unwrap(),
            31,
        ),
    ];
    for (mine, theirs, alc) in cases {
        let what = format!("{mine} vs {theirs}");
        let (enc_mine, enc_theirs) = (encode(&mine), encode(&theirs));
        let loss = first_difference(&enc_mine, &enc_theirs);
        check_loss_position(&enc_mine, &enc_theirs, loss, &what);
        let ack = field(&enc_theirs, Field::AckSlot, 0);
        let eof_last = field(&enc_theirs, Field::Eof, 6);
        // Intermission eof_last+1..eof_last+3; SOF exactly 3 bits after the EOF.
        let retry = eof_last + 1 + INTERMISSION;
        let mut bench = ProtocolBench::iut_transmits(iut, &mine);
        bench
            .lt()
            .send_frame(&enc_theirs)
            .release(INTERMISSION + enc_mine.len() + 2)
            .set_bit(retry + field(&enc_mine, Field::AckSlot, 0), Drive::Dominant);
        bench.run(1);
        assert_eq!(
            bench.iut_dominant_bits(ack, retry + 1),
            vec![ack, retry],
            "{what}: ACK, idle through the intermission, SOF right after it"
        );
        assert_eq!(
            bench.iut_dominant_bits(retry, retry + enc_mine.len() + 2),
            golden_dominant(&enc_mine, 0, enc_mine.len(), retry),
            "{what}: the retransmission is the golden frame"
        );
        assert_eq!(
            bench.iut_events(),
            vec![
                NodeEvent::ArbitrationLost(alc),
                NodeEvent::Received(theirs),
                NodeEvent::TransmitDone(true),
            ],
            "{what}"
        );
        assert_eq!((bench.tec(), bench.rec()), (0, 0), "{what}");
    }
}

testbenches::on_both_iuts! {
    ar_02_extended_loss_at_every_extended_identifier_bit,
    ar_03_extended_loses_to_standard_at_srr,
    ar_04_standard_remote_loses_to_data_at_rtr,
    ar_05_extended_loses_to_standard_remote_at_ide,
    ar_06_extended_remote_loses_to_extended_data_at_rtr,
    ar_07_iut_wins_against_a_larger_identifier,
    ar_08_stuff_error_after_lost_arbitration_makes_the_receiver_flag,
    ar_09_core_reports_every_loss,
    rt_02_retransmission_after_lost_arbitration_right_after_the_intermission,
}
