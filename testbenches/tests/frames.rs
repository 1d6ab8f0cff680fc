//! Conformance groups FR (receiving frame formats), FT (transmitting frame formats) and ST-01/ST-02
//! (stuffing profiles) on both IUTs (the RTL core, and the controller through its registers),
//! bit-exact on the wire.

use golden::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT};
use golden::worst_case::longest_frame;
use rtl::registers::{interrupt, status};
use sim::engine::bus::Drive;
use sim::nodes::can_node::NodeEvent;
use testbenches::iso::encode_with_reserved_bits;
use testbenches::protocol_bench::{Iut, LtScript, ProtocolBench, INTEGRATION_BITS};

const SOF: usize = INTEGRATION_BITS;

fn data(seed: usize, len: usize) -> Vec<u8> {
    (0..len).map(|i| (seed * 37 + i * 101 + 5) as u8).collect()
}

fn standard(id: u16) -> Id {
    Id::standard(id).unwrap()
}

fn extended(id: u32) -> Id {
    Id::extended(id).unwrap()
}

/// The LT sends `frame` (ACK slot left to the IUT) after the integration time.
fn receive(iut: Iut, frame: &Frame) -> (ProtocolBench, EncodedFrame) {
    let encoded = encode(frame);
    let bench = ProtocolBench::receive_bits(iut, encoded.bits.iter().by_vals(), None, 4);
    (bench, encoded)
}

/// FR-01 expectations: exactly the ACK slot driven dominant, the frame stored, no error; through the
/// registers one RI, RMC 1 and the frame's bytes in the RX buffer.
fn assert_received(iut: Iut, frame: &Frame) {
    let (mut bench, encoded) = receive(iut, frame);
    let ack = SOF + encoded.position(Field::AckSlot, 0).unwrap();
    let end = SOF + encoded.len() + 4;
    assert_eq!(
        bench.iut_dominant_bits(0, end),
        vec![ack],
        "{frame}: IUT drives only the ACK slot"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::Received(*frame)],
        "{frame}"
    );
    assert_eq!((bench.rec(), bench.tec()), (0, 0), "{frame}");
    bench.assert_stored_through_registers(frame, &frame.to_string());
}

/// The IUT sends `frame`; the LT acknowledges it.
fn transmit(iut: Iut, frame: &Frame) -> (ProtocolBench, EncodedFrame) {
    let encoded = encode(frame);
    let mut bench = ProtocolBench::iut_transmits(iut, frame);
    let ack = encoded.position(Field::AckSlot, 0).unwrap();
    bench
        .lt()
        .release(encoded.len() + 4)
        .set_bit(ack, Drive::Dominant);
    bench.run(1);
    (bench, encoded)
}

/// FT-01 expectations: every bit on the wire is the golden bit (ACK slot, delimiters, EOF recessive
/// from the IUT), success, TEC unchanged; through the registers one TI with TCS = 1 and TBS = 1.
fn assert_transmitted(iut: Iut, frame: &Frame) {
    let (mut bench, encoded) = transmit(iut, frame);
    let golden: Vec<usize> = (0..encoded.len())
        .filter(|&i| encoded.bits[i] == DOMINANT)
        .collect();
    assert_eq!(
        bench.iut_dominant_bits(0, encoded.len() + 4),
        golden,
        "{frame}: dominant bits on the wire"
    );
    assert_eq!(
        bench.iut_events(),
        vec![NodeEvent::TransmitDone(true)],
        "{frame}"
    );
    assert_eq!((bench.tec(), bench.rec()), (0, 0), "{frame}");
    if let Some(passes) = bench.interrupt_passes() {
        let [pass] = &passes[..] else {
            panic!("{frame}: one interrupt: {passes:?}");
        };
        assert_eq!(pass.ir, interrupt::TI, "{frame}: TI");
        assert_eq!(
            pass.sr & (status::TCS | status::TBS),
            status::TCS | status::TBS,
            "{frame}: TCS and TBS"
        );
    }
}

fn fr_01_standard_data_frames(iut: Iut) {
    for (i, id) in [0x000, 0x7FF, 0x555, 0x2AA, 0x3C5].into_iter().enumerate() {
        for dlc in 0..=8 {
            assert_received(
                iut,
                &Frame::data(standard(id), &data(i + dlc, dlc)).unwrap(),
            );
        }
    }
}

fn fr_02_extended_data_frames(iut: Iut) {
    for (i, id) in [0, 0x1FFF_FFFF, 0x1555_5555, 0x0AAA_AAAA, 0x12C4_F00D]
        .into_iter()
        .enumerate()
    {
        for dlc in 0..=8 {
            assert_received(
                iut,
                &Frame::data(extended(id), &data(i + dlc, dlc)).unwrap(),
            );
        }
    }
}

fn fr_03_remote_frames(iut: Iut) {
    for dlc in 0..=15 {
        assert_received(iut, &Frame::remote(standard(0x6A5), dlc).unwrap());
        assert_received(iut, &Frame::remote(extended(0x0ABC_1234), dlc).unwrap());
    }
}

fn fr_04_dlc_above_8_carries_8_bytes(iut: Iut) {
    for dlc in 9..=15 {
        let bytes = data(dlc as usize, 8);
        assert_received(
            iut,
            &Frame::data_with_dlc(standard(0x123), dlc, &bytes).unwrap(),
        );
        assert_received(
            iut,
            &Frame::data_with_dlc(extended(0x1234_5678), dlc, &bytes).unwrap(),
        );
    }
}

fn ft_01_standard_data_frames_are_bit_exact(iut: Iut) {
    for (i, id) in [0x000, 0x7FF, 0x555, 0x2AA, 0x3C5].into_iter().enumerate() {
        for dlc in 0..=8 {
            assert_transmitted(
                iut,
                &Frame::data(standard(id), &data(i + dlc, dlc)).unwrap(),
            );
        }
    }
}

fn ft_02_extended_data_frames_are_bit_exact(iut: Iut) {
    for (i, id) in [0, 0x1FFF_FFFF, 0x1555_5555, 0x0AAA_AAAA, 0x12C4_F00D]
        .into_iter()
        .enumerate()
    {
        for dlc in 0..=8 {
            assert_transmitted(
                iut,
                &Frame::data(extended(id), &data(i + dlc, dlc)).unwrap(),
            );
        }
    }
}

fn ft_03_remote_frames_are_bit_exact(iut: Iut) {
    for dlc in 0..=15 {
        assert_transmitted(iut, &Frame::remote(standard(0x6A5), dlc).unwrap());
        assert_transmitted(iut, &Frame::remote(extended(0x0ABC_1234), dlc).unwrap());
    }
}

fn ft_04_dlc_above_8_sends_8_bytes(iut: Iut) {
    for dlc in 9..=15 {
        let bytes = data(dlc as usize, 8);
        assert_transmitted(
            iut,
            &Frame::data_with_dlc(standard(0x123), dlc, &bytes).unwrap(),
        );
        assert_transmitted(
            iut,
            &Frame::data_with_dlc(extended(0x1234_5678), dlc, &bytes).unwrap(),
        );
    }
}

/// Frames whose stuffing exercises every place of the catalog's ST-01 list.
fn stuffing_profiles() -> Vec<Frame> {
    let mut frames = vec![
        Frame::data(standard(0x000), &[]).unwrap(),
        Frame::remote(standard(0x7FF), 0).unwrap(),
        Frame::data(standard(0x07F), &[0x00, 0xFF, 0x0F, 0xF0, 0x1F, 0xE0]).unwrap(),
        Frame::data(extended(0x0000_001F), &[0xFF, 0x00]).unwrap(),
        Frame::data(standard(0x010), &[0x07, 0xC1]).unwrap(),
    ];
    for n in [0, 4, 8] {
        frames.push(longest_frame(false, n));
        frames.push(longest_frame(true, n));
    }
    frames
}

fn st_01_received_stuffing_profiles(iut: Iut) {
    let frames = stuffing_profiles();
    assert!(
        frames.iter().any(|f| {
            let e = encode(f);
            let crc_end = e.position(Field::CrcDelim, 0).unwrap();
            e.tags[crc_end - 1].stuff
        }),
        "one profile has a stuff bit after the last CRC bit"
    );
    for frame in &frames {
        assert_received(iut, frame);
    }
}

fn st_02_transmitted_stuffing_profiles(iut: Iut) {
    for frame in &stuffing_profiles() {
        assert_transmitted(iut, frame);
    }
}

fn fr_05_non_nominal_reserved_and_srr_bits_are_accepted(iut: Iut) {
    let std_frame = Frame::data(standard(0x3A7), &[0x11, 0x22]).unwrap();
    let ext_frame = Frame::data(extended(0x0765_4321), &[0x33]).unwrap();
    let mut cases = vec![(std_frame, true, false, true)];
    for combo in 0..8u8 {
        let (srr, r1, r0) = (combo & 4 != 0, combo & 2 != 0, combo & 1 != 0);
        if (srr, r1, r0) != (true, false, false) {
            cases.push((ext_frame, srr, r1, r0));
        }
    }
    for (frame, srr, r1, r0) in cases {
        let (bits, _) = encode_with_reserved_bits(&frame, srr, r1, r0);
        let as_bitvec: bitvec::vec::BitVec<u8, bitvec::order::Msb0> =
            bits.iter().copied().collect();
        assert_eq!(
            golden::frame::decode(&as_bitvec).unwrap().frame,
            frame,
            "golden decoder agrees"
        );
        let mut bench = ProtocolBench::new(iut);
        bench
            .lt()
            .after_integration()
            .send_bits(bits.iter().copied())
            .release(4);
        bench.run(1);
        let ack = SOF + bits.len() - 9;
        let what = format!("{frame} SRR {srr} r1 {r1} r0 {r0}");
        assert_eq!(
            bench.iut_dominant_bits(0, SOF + bits.len()),
            vec![ack],
            "{what}: ACK"
        );
        assert_eq!(
            bench.iut_events(),
            vec![NodeEvent::Received(frame)],
            "{what}"
        );
        bench.assert_stored_through_registers(&frame, &what);
    }
}

testbenches::on_both_iuts! {
    fr_01_standard_data_frames,
    fr_02_extended_data_frames,
    fr_03_remote_frames,
    fr_04_dlc_above_8_carries_8_bytes,
    ft_01_standard_data_frames_are_bit_exact,
    ft_02_extended_data_frames_are_bit_exact,
    ft_03_remote_frames_are_bit_exact,
    ft_04_dlc_above_8_sends_8_bytes,
    st_01_received_stuffing_profiles,
    st_02_transmitted_stuffing_profiles,
    fr_05_non_nominal_reserved_and_srr_bits_are_accepted,
}
