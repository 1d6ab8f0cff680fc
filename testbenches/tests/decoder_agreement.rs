//! Our bus decoder (`cansim decode`) and sigrok's CAN decoder agree frame by frame on a representative
//! set of VCDs written here: the bit timing demo (the demo: `tests/demo.rs`), every frame kind at several bit rates and
//! sample points, error frames and overload frames (rule and exclusions: `testbenches::agreement`).
//! Our decoder is also checked against what was sent and what the RTL receivers got.
//! `make waves-check` runs the same comparison on the VCD of every testbench.

use std::path::{Path, PathBuf};

use golden::btr::Btr;
use golden::frame::{encode, Frame, Id, MAX_DLC};
use sim::decode::bus_decoder::{BusEventKind, ErrorCause};
use sim::decode::vcd_reader::{decode_vcd, DecodeOptions, VcdDecode};
use sim::engine::bus::Drive;
use sim::engine::bus_timing::BusTiming;
use sim::engine::time::{ClockSpec, FS_PER_S};
use sim::engine::Engine;
use sim::nodes::can_node::CanNode;
use testbenches::agreement::{check_vcd, Agreement, Exclusion};
use testbenches::protocol_bench::{bt_a, Iut, LtScript, ProtocolBench, INTEGRATION_BITS};
use testbenches::{bt_configs, sigrok, CLOCK_HZ};

/// Idle bits before the first frame (the nodes integrate on 11) and after each frame.
const IDLE_BITS: u64 = 14;
/// Idle bits after each frame when sigrok must be back in step for the next one after a remote frame
/// with DLC 3, whose 24 data bits that are not there it reads.
const LONG_IDLE_BITS: u64 = 40;

/// A directory of this test run for `scenario`'s VCDs.
fn vcd_path(scenario: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cansim-agreement-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(format!("{scenario}.vcd"))
}

/// Both decoders on `path`; panics on a disagreement. `None` when sigrok checks are skipped.
fn agreement(path: &Path) -> Option<Agreement> {
    if sigrok::skipped() {
        return None;
    }
    let agreement = check_vcd(path).unwrap();
    assert!(agreement.agrees(), "{agreement}\n{}", agreement.details());
    Some(agreement)
}

fn ours(path: &Path) -> VcdDecode {
    decode_vcd(path, &DecodeOptions::default()).unwrap()
}

/// Our decoder's valid frames.
fn frames(decoded: &VcdDecode) -> Vec<Frame> {
    decoded
        .events
        .iter()
        .filter_map(|e| match e.kind {
            BusEventKind::Frame { frame, .. } => Some(frame),
            _ => None,
        })
        .collect()
}

/// Node `a` sends `frames` one at a time to node `b`, which acknowledges them, with `idle_bits` of idle
/// bus before the first and after each; the engine writes its VCD to `path`. `disturb` makes `b` see
/// the bus inverted for one bit at that many bits after the given frame was queued. Returns the
/// frames `b` received.
fn exchange(
    btr: Btr,
    frames: &[Frame],
    idle_bits: u64,
    path: &Path,
    disturb: Option<(usize, u64)>,
) -> Vec<Frame> {
    let clock = ClockSpec::from_hz(CLOCK_HZ);
    let bit_fs = u64::from(btr.clocks_per_bit()) * clock.period_fs();
    let mut engine = Engine::new();
    let a = engine.add(CanNode::new("a", clock, btr), 0);
    let b = engine.add(CanNode::new("b", clock, btr), 0);
    engine
        .trace_vcd_timed(path, BusTiming::from_btr(&btr, clock))
        .unwrap();
    let idle = |engine: &mut Engine| engine.run_until(engine.now() + idle_bits * bit_fs).unwrap();
    idle(&mut engine);
    for (k, frame) in frames.iter().enumerate() {
        engine.device_mut::<CanNode>(a).send(frame, false);
        if let Some((_, after)) = disturb.filter(|&(at, _)| at == k) {
            let from = engine.now() + after * bit_fs;
            engine.invert_rx(b, from, from + bit_fs);
        }
        let sent = engine
            .run_while(engine.now() + FS_PER_S, |e| {
                !e.device::<CanNode>(a).transmit_pending()
            })
            .unwrap();
        assert!(sent, "{frame} not sent");
        idle(&mut engine);
    }
    engine.finish_trace().unwrap();
    engine.device::<CanNode>(b).received()
}

/// Standard and extended, data and remote, DLC 0..=8, identifiers and data that stuff a lot or
/// never; then a remote frame with DLC 3 and a data frame with DLC 12, which sigrok cannot read.
fn frame_kinds() -> (Vec<Frame>, Vec<Frame>) {
    let mut frames = Vec::new();
    for (i, id) in [
        Id::Standard(0),
        Id::Standard(0x7FF),
        Id::Standard(0x555),
        Id::Extended(0),
        Id::Extended(0x1FFF_FFFF),
        Id::Extended(0x1555_5555),
    ]
    .into_iter()
    .enumerate()
    {
        for len in (i % 3..=8).step_by(3) {
            let data: Vec<u8> = (0..len as u8)
                .map(|b| b.wrapping_mul(0x3B) ^ 0xF0)
                .collect();
            frames.push(Frame::data(id, &data).unwrap());
        }
        frames.push(Frame::remote(id, 0).unwrap());
    }
    let unreadable = vec![
        Frame::remote(Id::Standard(0x321), 3).unwrap(),
        Frame::data_with_dlc(Id::Extended(0x0ABC_DEF0), 12, &[0x5A; 8]).unwrap(),
    ];
    assert!(unreadable.iter().all(|f| f.dlc() > 0 && f.dlc() <= MAX_DLC));
    (frames, unreadable)
}

#[test]
fn every_frame_kind_at_several_bit_rates_and_sample_points() {
    let (readable, unreadable) = frame_kinds();
    let sent: Vec<Frame> = readable.iter().chain(&unreadable).copied().collect();
    let configs = bt_configs();
    // BT-A 500 kbit/s 75 %, BT-B 1 Mbit/s 62.5 %, BT-C 320 kbit/s 68 %.
    for config in configs.iter().filter(|c| c.name.ends_with("BRP0")) {
        let path = vcd_path(&format!("kinds-{}", config.name.replace('/', "-")));
        let got = exchange(config.btr, &sent, LONG_IDLE_BITS, &path, None);
        assert_eq!(got, sent, "{}: the RTL receiver", config.name);
        let decoded = ours(&path);
        assert_eq!(frames(&decoded), sent, "{}: our decoder", config.name);
        let Some(agreement) = agreement(&path) else {
            continue;
        };
        assert_eq!(agreement.agreed, readable.len(), "{agreement}");
        assert_eq!(agreement.excluded(Exclusion::RemoteWithDlc), 1);
        assert_eq!(agreement.excluded(Exclusion::DlcAbove8), 1);
        assert_eq!(agreement.exclusions.len(), 2, "{agreement}");
    }
}

/// The error causes our decoder saw, with the content of the frames they interrupted after the CRC.
fn errors(decoded: &VcdDecode) -> Vec<(ErrorCause, Option<Frame>)> {
    decoded
        .events
        .iter()
        .filter_map(|e| match e.kind {
            BusEventKind::ErrorFrame { cause, frame, .. } => Some((cause, frame)),
            _ => None,
        })
        .collect()
}

#[test]
fn error_frame_after_a_receiver_error() {
    let (kinds, _) = frame_kinds();
    let sent = &kinds[..4];
    // BT-B, 1 Mbit/s: node b sees the bus inverted for one bit in frame 1's data field, so it does
    // not acknowledge, and a's ACK error flag cuts the frame, which the bus carried complete.
    let config = bt_configs()
        .into_iter()
        .find(|c| c.name == "BT-B/BRP0")
        .unwrap();
    let path = vcd_path("receiver-error");
    let got = exchange(config.btr, sent, IDLE_BITS, &path, Some((1, 30)));
    assert_eq!(got, sent, "the RTL receiver, after the retransmission");
    let decoded = ours(&path);
    assert_eq!(frames(&decoded), sent, "our decoder");
    assert_eq!(errors(&decoded), [(ErrorCause::Ack, Some(sent[1]))]);
    if let Some(agreement) = agreement(&path) {
        assert_eq!(agreement.agreed, sent.len() + 1, "{agreement}");
        assert!(agreement.exclusions.is_empty(), "{agreement}");
    }
}

#[test]
fn error_frame_cutting_a_frame_and_the_retransmission() {
    // The lower tester overwrites a recessive data bit of the node's frame with a dominant one: the
    // node's bit error flag cuts the frame on the bus; the retransmission follows 18 bits after the
    // error (flag 6, delimiter 8, intermission 3), and the lower tester acknowledges it.
    let frame = Frame::data(Id::Standard(0x0F3), &[0x81, 0x7E]).unwrap();
    let encoded = encode(&frame);
    let error = (0..encoded.len())
        .find(|&i| encoded.tags[i].field == golden::frame::Field::Data && encoded.bits[i])
        .unwrap();
    let ack = encoded.position(golden::frame::Field::AckSlot, 0).unwrap();
    let mut bench = ProtocolBench::iut_transmits(Iut::Core, &frame);
    let path = vcd_path("cut-frame");
    let clock = ClockSpec::from_hz(CLOCK_HZ);
    bench
        .engine
        .trace_vcd_timed(&path, BusTiming::from_btr(&bt_a(), clock))
        .unwrap();
    let retry = error + 18;
    bench
        .lt()
        .release(retry + encoded.len() + 5)
        .set_bit(error, Drive::Dominant)
        .set_bit(retry + ack, Drive::Dominant);
    bench.run(2);
    bench.engine.finish_trace().unwrap();
    assert_eq!(
        bench.iut_events().last(),
        Some(&sim::nodes::can_node::NodeEvent::TransmitDone(true))
    );
    let decoded = ours(&path);
    assert_eq!(frames(&decoded), [frame]);
    let cut = errors(&decoded);
    assert_eq!(cut.len(), 1, "{:?}", decoded.events);
    assert_eq!(cut[0].1, None, "cut before its CRC");
    if let Some(agreement) = agreement(&path) {
        assert_eq!(agreement.excluded(Exclusion::Rejected), 1, "{agreement}");
        assert_eq!(
            agreement.agreed + agreement.excluded(Exclusion::MissedWhileOutOfStep),
            1,
            "{agreement}"
        );
    }
}

#[test]
fn overload_frames() {
    // The lower tester sends a frame that the node under test acknowledges, then makes intermission
    // bit 1 dominant twice: two overload frames, the node's overload flag answering each.
    let frame = Frame::data(Id::Standard(0x2A5), &[0xC3, 0x3C]).unwrap();
    let encoded = encode(&frame);
    let mut bench = ProtocolBench::new(Iut::Core);
    let path = vcd_path("overload");
    let clock = ClockSpec::from_hz(CLOCK_HZ);
    bench
        .engine
        .trace_vcd_timed(&path, BusTiming::from_btr(&bt_a(), clock))
        .unwrap();
    let sof = INTEGRATION_BITS;
    let first = sof + encoded.len() + 1;
    let second = first + 6 + 8 + 1;
    bench
        .lt()
        .after_integration()
        .send_frame(&encoded)
        .release(40)
        .set_bit(first, Drive::Dominant)
        .set_bit(second, Drive::Dominant);
    bench.run(2);
    bench.engine.finish_trace().unwrap();
    assert_eq!(bench.received(), [frame]);
    let decoded = ours(&path);
    let kinds: Vec<&BusEventKind> = decoded.events.iter().map(|e| &e.kind).collect();
    assert_eq!(kinds.len(), 3, "{kinds:?}");
    assert!(matches!(kinds[0], BusEventKind::Frame { acked: true, .. }));
    assert!(kinds[1..]
        .iter()
        .all(|k| matches!(k, BusEventKind::OverloadFrame { .. })));
    if let Some(agreement) = agreement(&path) {
        assert_eq!(agreement.agreed, 1, "{agreement}");
        assert!(
            agreement.excluded(Exclusion::FlagReadAsFrame) >= 1,
            "{agreement}"
        );
        let others = agreement
            .exclusions
            .iter()
            .filter(|e| !matches!(e.why, Exclusion::FlagReadAsFrame | Exclusion::OutOfStep));
        assert_eq!(others.count(), 0, "{agreement}");
    }
}

/// (The demo's VCD is checked against sigrok by `tests/demo.rs`.)
#[test]
fn bit_timing_demo() {
    let path = vcd_path("sync-demo");
    let report = sim::workloads::sync_demo::run_demo(Some(&path)).unwrap();
    let decoded = ours(&path);
    let sent: Vec<String> = report.frames.iter().map(|(f, _)| f.clone()).collect();
    let got: Vec<String> = frames(&decoded).iter().map(|f| f.to_string()).collect();
    assert_eq!(got, sent);
    if let Some(agreement) = agreement(&path) {
        assert_eq!(agreement.agreed, sent.len(), "{agreement}");
        assert!(agreement.exclusions.is_empty(), "{agreement}");
    }
}
