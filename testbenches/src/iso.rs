//! Shared pieces of the ISO 16845-1 clause tests (`tests/iso_*.rs`): the field lengths of ISO
//! 11898-1, where a frame has its bits, and the lower tester's usual moves in script bits (the LT's
//! frame at a given bit, the IUT's frame acknowledged, a transmitted bit corrupted).

use golden::btr::Btr;
use golden::frame::{encode, Field, Frame, Id, DOMINANT, RECESSIVE, STUFF_RUN};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;

use crate::protocol_bench::{Iut, ProtocolBench, INTEGRATION_BITS};

/// Bits of an error or overload flag (ISO 11898-1).
pub const FLAG: usize = 6;
/// Bits of an error or overload delimiter.
pub const DELIMITER: usize = 8;
/// Bits of the intermission.
pub const INTERMISSION: usize = 3;
/// Bits of an error-passive transmitter's suspend transmission.
pub const SUSPEND: usize = 8;
/// Bits of the end of frame.
pub const EOF: usize = 7;
/// Counter change of fault-confinement rules 2 to 6.
pub const PENALTY: u8 = 8;
/// The counter value from which a node is error passive.
pub const PASSIVE_LIMIT: u8 = 128;

/// Offset of the ACK slot in `frame`'s bits (SOF = 0).
pub fn ack_offset(frame: &Frame) -> usize {
    encode(frame).position(Field::AckSlot, 0).expect("ACK slot")
}

/// Offset of the first bit (not a stuff bit) of `field` in `frame` at `level`.
pub fn first_bit_at(frame: &Frame, field: Field, level: bool) -> usize {
    let encoded = encode(frame);
    (0..128)
        .map_while(|i| encoded.position(field, i))
        .find(|&p| encoded.bits[p] == level)
        .unwrap_or_else(|| panic!("{frame}: no {field:?} bit at level {level}"))
}

/// Offset of the first dominant data bit of `frame` (the bit a clause's LT corrupts "in the data
/// field").
pub fn dominant_data_bit(frame: &Frame) -> usize {
    first_bit_at(frame, Field::Data, DOMINANT)
}

/// The script bits where `frame` starting at `sof` is dominant, SOF to CRC delimiter (what its
/// transmitter drives before the ACK slot).
pub fn dominant_bits_of(frame: &Frame, sof: usize) -> Vec<usize> {
    let encoded = encode(frame);
    (0..ack_offset(frame))
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .map(|i| sof + i)
        .collect()
}

/// `count` consecutive script bits from `from`.
pub fn bits_from(from: usize, count: usize) -> Vec<usize> {
    (from..from + count).collect()
}

/// The LT releases the bus up to `sof`, then sends `frame` with its ACK slot left to the IUT;
/// returns the script bit of that ACK slot.
pub fn lt_sends_at(bench: &mut ProtocolBench, sof: usize, frame: &Frame) -> usize {
    let played = bench.lt_ref().script_len();
    assert!(
        sof >= played,
        "the LT's frame at {sof} starts before {played}"
    );
    bench
        .lt()
        .release(sof - played)
        .send_bits(encode(frame).bits.iter().by_vals());
    sof + ack_offset(frame)
}

/// The LT releases the bus for the IUT's `frame` starting at `sof` and acknowledges it; its script
/// then ends `tail` bits after the frame's last EOF bit.
pub fn lt_acknowledges_at(bench: &mut ProtocolBench, sof: usize, frame: &Frame, tail: usize) {
    let played = bench.lt_ref().script_len();
    let end = sof + encode(frame).len() + tail;
    assert!(end >= played, "the script is already past {end}");
    bench
        .lt()
        .release(end - played)
        .set_bit(sof + ack_offset(frame), Drive::Dominant);
}

/// The IUT, with TEC `tec`, transmits `frame`; the LT releases the bus up to bit `bit` of it and
/// forces that bit recessive (a corrupted dominant bit: a bit error). Returns the bench.
pub fn transmitter_bit_corrupted(iut: Iut, frame: &Frame, tec: u8, bit: usize) -> ProtocolBench {
    let mut bench = ProtocolBench::iut_transmits_with(iut, frame, tec, false);
    bench
        .lt()
        .release(bit + 1)
        .set_bit(bit, Drive::ForceRecessive);
    bench
}

/// Where an error-active transmitter starts its frame again after an error detected at `error`: its
/// flag, the error delimiter and the intermission (ISO 11898-1).
pub fn active_retransmission(error: usize) -> usize {
    error + 1 + FLAG + DELIMITER + INTERMISSION
}

/// The SJA1000 ALC value of a transmitter of `mine` losing to `theirs`: the arbitration position of
/// the first bit where they differ (identifier bits from 0, SRR/RTR 11, IDE 12, extended bits 13..,
/// extended RTR 31), which is the bit's index among the frame's bits without stuff bits, less the SOF.
pub fn arbitration_position(mine: &Frame, theirs: &Frame) -> u8 {
    let (a, b) = (encode(mine), encode(theirs));
    let differ = (0..a.len().min(b.len()))
        .find(|&i| a.bits[i] != b.bits[i])
        .expect("the frames differ");
    let field_bits = (0..differ).filter(|&i| !a.tags[i].stuff).count();
    (field_bits - 1) as u8
}

/// The script bit where `mine`, sent from SOF 0 against `theirs`, loses arbitration.
pub fn arbitration_loss_bit(mine: &Frame, theirs: &Frame) -> usize {
    let (a, b) = (encode(mine), encode(theirs));
    (0..a.len().min(b.len()))
        .find(|&i| a.bits[i] != b.bits[i])
        .expect("the frames differ")
}

/// Script bit of a receiving IUT's first frame: the LT idles for [`INTEGRATION_BITS`] first.
pub const RX_SOF: usize = INTEGRATION_BITS;

/// The bus bits of `frame` (SOF to EOF, ACK slot recessive) with SRR, r1 and r0 at the given levels
/// (the golden encoder sends only the nominal ones), rebuilt with its CRC and stuffing, and the
/// positions of its stuff bits.
pub fn encode_with_reserved_bits(
    frame: &Frame,
    srr: bool,
    r1: bool,
    r0: bool,
) -> (Vec<bool>, Vec<usize>) {
    fn push(bits: &mut Vec<bool>, value: u32, width: u32) {
        bits.extend((0..width).rev().map(|i| value >> i & 1 == 1));
    }
    let mut bits = vec![DOMINANT];
    match frame.id() {
        Id::Standard(id) => {
            push(&mut bits, id as u32, 11);
            bits.extend([frame.is_remote(), DOMINANT, r0]);
        }
        Id::Extended(id) => {
            push(&mut bits, id >> 18, 11);
            bits.extend([srr, RECESSIVE]);
            push(&mut bits, id & 0x3_FFFF, 18);
            bits.extend([frame.is_remote(), r1, r0]);
        }
    }
    push(&mut bits, frame.dlc() as u32, 4);
    for byte in frame.data_bytes() {
        push(&mut bits, *byte as u32, 8);
    }
    let crc = golden::crc15::crc15(bits.iter().copied());
    push(&mut bits, crc as u32, 15);
    let (mut stuffed, mut stuff) = (Vec::new(), Vec::new());
    let mut run = (0, RECESSIVE);
    for bit in bits {
        stuffed.push(bit);
        run = if bit == run.1 {
            (run.0 + 1, bit)
        } else {
            (1, bit)
        };
        if run.0 == STUFF_RUN {
            stuff.push(stuffed.len());
            stuffed.push(!bit);
            run = (1, !bit);
        }
    }
    // CRC delimiter, ACK slot (left to the receivers), ACK delimiter, EOF.
    stuffed.extend([RECESSIVE; 3 + EOF]);
    (stuffed, stuff)
}

/// A receiving IUT: the LT idles until [`RX_SOF`], then sends `bits` (ACK slot recessive) and
/// idles `tail` bits; nothing is run yet.
pub fn lt_sends_to_iut(iut: Iut, bits: &[bool], tail: usize) -> ProtocolBench {
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .release(RX_SOF)
        .send_bits(bits.iter().copied())
        .release(tail);
    bench
}

/// The IUT received `frame` sent as `bits` at [`RX_SOF`]: it drove only the ACK slot, reported the
/// frame and nothing else, and on the controller its interrupt handler read it from the RX buffer
/// (RI, RMC 1, the SJA1000 buffer bytes).
pub fn assert_received(bench: &mut ProtocolBench, bits: &[bool], frame: &Frame, what: &str) {
    let ack = RX_SOF + bits.len() - 2 - EOF;
    assert_eq!(
        bench.iut_dominant_bits(0, RX_SOF + bits.len()),
        vec![ack],
        "{what}: the IUT acknowledges, nothing else"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::Received(*frame)],
        "{what}: received, no error"
    );
    bench.assert_stored_through_registers(frame, what);
}

/// The LT sends `frame` (nominal bits) to a receiving IUT, which shall acknowledge and receive it.
pub fn receives(iut: Iut, frame: &Frame, what: &str) {
    let bits: Vec<bool> = encode(frame).bits.iter().by_vals().collect();
    receives_bits(iut, &bits, frame, what);
}

/// As [`receives`], for `frame` sent as `bits`.
pub fn receives_bits(iut: Iut, bits: &[bool], frame: &Frame, what: &str) {
    let mut bench = lt_sends_to_iut(iut, bits, 4);
    bench.run(1);
    assert_received(&mut bench, bits, frame, what);
}

/// The LT sends `theirs` against the IUT's `mine` from the same SOF: the IUT shall stop driving at
/// the bit where it loses, receive and acknowledge `theirs`, and send `mine` again as soon as the bus
/// is idle (after the intermission), with no error flag (ISO 16845-1 7.1.3, 8.1.3, 8.1.4).
pub fn loses_arbitration_then_retransmits(iut: Iut, mine: &Frame, theirs: &Frame, what: &str) {
    let mut bench = ProtocolBench::iut_transmits(iut, mine);
    let ack = lt_sends_at(&mut bench, 0, theirs);
    let again = encode(theirs).len() + INTERMISSION;
    lt_acknowledges_at(&mut bench, again, mine, 4);
    bench.run(0);
    let lost = arbitration_loss_bit(mine, theirs);
    let mut expected: Vec<usize> = dominant_bits_of(mine, 0)
        .into_iter()
        .filter(|&b| b < lost)
        .collect();
    expected.push(ack);
    expected.extend(dominant_bits_of(mine, again));
    assert_eq!(
        bench.iut_dominant_bits(0, again + ack_offset(mine)),
        expected,
        "{what}: receiver from the lost bit on, ACK, then its frame again"
    );
    assert_eq!(
        bench.iut_events(),
        [
            NodeEvent::ArbitrationLost(arbitration_position(mine, theirs)),
            NodeEvent::Received(*theirs),
            NodeEvent::TransmitDone(true)
        ],
        "{what}"
    );
}

/// A receiving IUT gets `frame` up to its data field, then 6 dominant bits (the bit before the data
/// field is recessive): a stuff error at the sixth, an error flag from the next bit. The LT idles
/// after; returns the bench (not run) and the script bit of the error.
pub fn receiver_stuff_error_in_data(iut: Iut, frame: &Frame) -> (ProtocolBench, usize) {
    let encoded = encode(frame);
    let data = encoded.position(Field::Data, 0).expect("a data field");
    assert_eq!(
        encoded.bits[data - 1],
        RECESSIVE,
        "{frame}: recessive before the data"
    );
    let bits: Vec<bool> = encoded.bits.iter().by_vals().take(data).collect();
    let mut bench = ProtocolBench::new(iut);
    bench
        .lt()
        .release(RX_SOF)
        .send_bits(bits)
        .send_bits([DOMINANT; STUFF_RUN as usize + 1]);
    (bench, RX_SOF + data + STUFF_RUN as usize)
}

/// A bit of `bits` that can be inverted without changing the stuffing: its neighbours differ from
/// it, and the bits on either side of it do not form a run of 5 with it inverted.
pub fn flippable_bit(bits: &[bool], range: std::ops::Range<usize>, level: bool) -> usize {
    range
        .filter(|&i| bits[i] == level)
        .find(|&i| {
            let mut changed = bits.to_vec();
            changed[i] = !changed[i];
            let from = i.saturating_sub(5);
            let to = (i + 6).min(bits.len());
            (from..to - 5).all(|s| !changed[s..s + 6].iter().all(|&b| b == changed[s]))
                && (from..to.saturating_sub(4))
                    .all(|s| !changed[s..s + 5].iter().all(|&b| b == changed[s]))
        })
        .expect("a bit whose inversion keeps the stuffing")
}

/// Clocks from an edge on the bus to the IUT's own edge at the start of a bit it synchronised on
/// that edge: the two-clock input synchroniser before its Sync, the transmit point at the first
/// clock of Sync and the output register (what ISO 16845-1 counts in the IUT's processing time).
pub const IUT_DELAY_CLOCKS: u64 = 3;

/// The bit timings of the bit-timing clauses (7.7, 8.7): BT-A (TSEG1 11, TSEG2 4, SJW 2: 16 tq),
/// BT-C (16/8/4: 25 tq, the SJA1000's longest bit and largest SJW) and BT-D (6/2/2: the shortest
/// Phase_Seg2 ISO 11898-1 allows with an SJW as large as it), each with BRP 0 (tq = 2 clocks) and
/// BRP 2 (6 clocks); then, for the clauses' "each programmable sample point", every sample point
/// of a 16-tq bit at BRP 2 (Phase_Seg2 2..8, SJW min(4, Phase_Seg2)).
pub fn iso_bit_timings() -> Vec<(String, Btr)> {
    let mut timings = Vec::new();
    for (name, tseg1, tseg2, sjw) in [("BT-A", 11, 4, 2), ("BT-C", 16, 8, 4), ("BT-D", 6, 2, 2)] {
        for brp in [0, crate::BRP_ABOVE_ZERO] {
            let btr = Btr::from_quanta(brp, tseg1, tseg2, sjw, false).expect("a valid bit timing");
            timings.push((format!("{name}/BRP{brp}"), btr));
        }
    }
    for tseg2 in 2..=8 {
        let (tseg1, sjw) = (15 - tseg2, tseg2.min(4));
        let btr = Btr::from_quanta(crate::BRP_ABOVE_ZERO, tseg1, tseg2, sjw, false)
            .expect("a valid bit timing");
        timings.push((
            format!("16 tq, TSEG2 {tseg2}/BRP{}", crate::BRP_ABOVE_ZERO),
            btr,
        ));
    }
    timings
}

/// The clock (from the start of the LT's script) of the IUT's first dominant edge in script bits
/// `from..from + 40`.
pub fn first_dominant_edge(bench: &ProtocolBench, from: usize) -> Option<u64> {
    bench
        .iut_edges(from, from + 40)
        .into_iter()
        .find(|&(_, level)| level == DOMINANT)
        .map(|(clock, _)| clock)
}

/// The base format frames of the classical-CAN tables of 7.1.10 and 7.2.2 (identifier; control
/// field with RTR in bit 6, r0 in bit 4 and the DLC; data), chosen for their stuffing, as (frame,
/// r0).
pub fn critical_stuffing_base_frames() -> Vec<(Frame, bool)> {
    let id = |v| Id::standard(v).expect("base identifier");
    let mut first = vec![0xE1; 8];
    first[0] = 0x01;
    vec![
        (Frame::data(id(0x78), &first).unwrap(), false),
        (Frame::data(id(0x41F), &[0x00]).unwrap(), false),
        (
            Frame::data_with_dlc(id(0x707), 0xF, &[0x0F; 8]).unwrap(),
            true,
        ),
        (Frame::data(id(0x360), &[]).unwrap(), true),
        (Frame::data(id(0x730), &[]).unwrap(), true),
        (Frame::data(id(0x47F), &[0x1F]).unwrap(), false),
        (Frame::data(id(0x758), &[]).unwrap(), false),
        (Frame::data(id(0x777), &[0x1F]).unwrap(), false),
        (Frame::remote(id(0x7EF), 2).unwrap(), false),
        (Frame::remote(id(0x3EA), 0xF).unwrap(), true),
    ]
}

/// The extended format frames of the classical-CAN tables of 7.1.11 and 7.2.3 (identifier; control
/// field with SRR in bit 8, IDE in bit 7, RTR in bit 6, r1 in bit 5, r0 in bit 4 and the DLC; data)
/// as (frame, r1, r0).
pub fn critical_stuffing_extended_frames() -> Vec<(Frame, bool, bool)> {
    let id = |v| Id::extended(v).expect("extended identifier");
    vec![
        (
            Frame::data(id(0x07C3_0F0F), &[0x3C; 8]).unwrap(),
            false,
            false,
        ),
        (Frame::data(id(0x07C0_F0F0), &[0x00]).unwrap(), false, false),
        (
            Frame::data_with_dlc(id(0x01E3_1717), 0xF, &[0x0F; 8]).unwrap(),
            false,
            true,
        ),
        (
            Frame::data_with_dlc(
                id(0x01E0_0FF0),
                0xC,
                &[0x1F, 0x0F, 0xE0, 0xF0, 0x7F, 0xE0, 0xFF, 0x20],
            )
            .unwrap(),
            true,
            true,
        ),
        (Frame::data(id(0x1FB8_0000), &[0xA0]).unwrap(), false, false),
        (Frame::remote(id(0x00BC_540F), 0).unwrap(), true, false),
        (Frame::remote(id(0x155D_5557), 0xF).unwrap(), true, true),
    ]
}

/// The payload patterns (data byte 0, the other bytes) of the data-field stuffing clauses 7.2.4 and
/// 8.2.8; they define 64-byte payloads, a classical frame carries 8 bytes: byte 0, then 7 of the
/// other value.
pub fn data_field_stuffing_payloads() -> Vec<[u8; 8]> {
    [
        (0x10u8, 0x78u8),
        (0x78, 0x3C),
        (0x34, 0x1E),
        (0x12, 0x0F),
        (0x0F, 0x87),
        (0x17, 0xC3),
        (0x43, 0xE1),
        (0x21, 0xF0),
    ]
    .into_iter()
    .map(|(first, rest)| {
        let mut bytes = [rest; 8];
        bytes[0] = first;
        bytes
    })
    .collect()
}

/// The IUT, with TEC `tec`, transmits `frame`; the LT corrupts its first dominant data bit (a bit
/// error, an error flag from the next bit). Returns the bench (not run) and the error's bit.
pub fn transmitter_data_bit_error(iut: Iut, frame: &Frame, tec: u8) -> (ProtocolBench, usize) {
    let error = dominant_data_bit(frame);
    (transmitter_bit_corrupted(iut, frame, tec, error), error)
}

/// The IUT, with TEC `tec`, transmits `frame`, acknowledged, and the LT makes the first intermission
/// bit dominant (an overload condition). Returns the bench (not run) and the first bit of the IUT's
/// overload flag.
pub fn transmitter_overload_after_frame(
    iut: Iut,
    frame: &Frame,
    tec: u8,
) -> (ProtocolBench, usize) {
    let len = encode(frame).len();
    let mut bench = ProtocolBench::iut_transmits_with(iut, frame, tec, false);
    lt_acknowledges_at(&mut bench, 0, frame, 1);
    bench.lt().set_bit(len, Drive::Dominant);
    (bench, len + 1)
}
