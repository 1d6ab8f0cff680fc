//! The demo run (`cansim demo`): three complete controllers, each driven only through its registers
//! by the Linux SJA1000 driver model, arbitrate, recover from an injected error, and one goes error
//! passive and back; everything is checked through what the drivers reported (and TXERR/RXERR read
//! through the host); sigrok's CAN decoder reads every frame of its VCD and flags the error frames.

use rtl::registers::interrupt;
use sim::demo::{demo_frames, run_demo, DemoReport, DEMO_SAMPLE_POINT_PCT};
use sim::driver::{CanState, DriverEvent};
use sim::frame::Frame;
use testbenches::ecc::{ecc, FORM, OTHER, SEG_ACK_DELIM, SEG_ACK_SLOT, SEG_CRC_DELIM};
use testbenches::sigrok;

/// ECC of b's form error in the CRC delimiter (receiving), and of the form errors it causes in the
/// ACK delimiter at a (transmitting) and c (receiving); a's ACK errors (transmitting, ACK slot).
const B_CRC_DELIMITER_FORM: u8 = 0x78;
const A_ACK_DELIMITER_FORM: u8 = 0x5B;
const C_ACK_DELIMITER_FORM: u8 = 0x7B;
const A_ACK_ERROR: u8 = 0xD9;

#[test]
fn demo_ecc_values_decode_as_named() {
    assert_eq!(B_CRC_DELIMITER_FORM, ecc(FORM, true, SEG_CRC_DELIM));
    assert_eq!(A_ACK_DELIMITER_FORM, ecc(FORM, false, SEG_ACK_DELIM));
    assert_eq!(C_ACK_DELIMITER_FORM, ecc(FORM, true, SEG_ACK_DELIM));
    assert_eq!(A_ACK_ERROR, ecc(OTHER, false, SEG_ACK_SLOT));
}

fn events_of(report: &DemoReport, node: &str) -> Vec<DriverEvent> {
    report
        .events
        .iter()
        .filter(|e| e.node == node)
        .map(|e| e.event)
        .collect()
}

/// The ECC values node `node`'s driver read (BEI).
fn errors_of(report: &DemoReport, node: &str) -> Vec<u8> {
    events_of(report, node)
        .into_iter()
        .filter_map(|e| match e {
            DriverEvent::BusError { ecc, .. } => Some(ecc),
            _ => None,
        })
        .collect()
}

/// The ALC values node `node`'s driver read (ALI).
fn losses_of(report: &DemoReport, node: &str) -> Vec<u8> {
    events_of(report, node)
        .into_iter()
        .filter_map(|e| match e {
            DriverEvent::ArbitrationLost { alc, .. } => Some(alc),
            _ => None,
        })
        .collect()
}

/// The frames sent successfully (TI), in bus order, with their sender.
fn sent(report: &DemoReport) -> Vec<(&str, Frame)> {
    report
        .events
        .iter()
        .filter_map(|e| match e.event {
            DriverEvent::TxDone(frame) => Some((e.node, frame)),
            _ => None,
        })
        .collect()
}

#[test]
fn demo_arbitrates_recovers_goes_error_passive_and_back_and_sigrok_decodes_it() {
    let dir = std::env::temp_dir().join(format!("cansim-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vcd = dir.join("demo.vcd");
    let report = run_demo(Some(&vcd)).expect("demo runs");
    let ([frame_a, frame_b, frame_c], disturbed, unacknowledged) = demo_frames();

    // Arbitration: 0x121 (c) beats 0x123 (a) at identifier bit 9; b's extended 0x12345678 (base
    // 0x48D) loses at bit 0 to both. The drivers read these positions from ALC.
    let sent = sent(&report);
    let senders: Vec<&str> = sent.iter().map(|(node, _)| *node).collect();
    assert_eq!(senders[..4], ["c", "a", "b", "a"]);
    assert_eq!(
        sent[..4].iter().map(|(_, f)| *f).collect::<Vec<_>>(),
        [frame_c, frame_a, frame_b, disturbed]
    );
    assert_eq!(losses_of(&report, "a"), [9]);
    assert_eq!(losses_of(&report, "b"), [0, 0]);
    assert_eq!(losses_of(&report, "c"), []);

    // The injected error: reported once by each driver, with the ECC of where each node saw it.
    let a_errors = errors_of(&report, "a");
    assert_eq!(errors_of(&report, "b"), [B_CRC_DELIMITER_FORM]);
    assert_eq!(errors_of(&report, "c"), [C_ACK_DELIMITER_FORM]);
    assert_eq!(a_errors[0], A_ACK_DELIMITER_FORM);

    // Error passive and back: ACK errors only, TXERR above 127 (EPI), then active again at 127
    // (EPI once more; the driver shows error-warning, TXERR being above the warning limit).
    let ack_errors = a_errors.len() - 1;
    assert!(a_errors[1..].iter().all(|&ecc| ecc == A_ACK_ERROR));
    let trace = &report.tec_trace;
    let passive_at = trace
        .iter()
        .position(|s| s.state == CanState::ErrorPassive)
        .expect("a's driver saw it error passive");
    assert!(trace[passive_at].tec >= 128, "{trace:?}");
    assert!(trace[..passive_at].iter().all(|s| s.tec < 128), "{trace:?}");
    let last = trace.last().unwrap();
    assert_eq!(
        (last.tec, last.state),
        (127, CanState::ErrorWarning),
        "{trace:?}"
    );
    let changes: Vec<(CanState, u8)> = events_of(&report, "a")
        .into_iter()
        .filter_map(|e| match e {
            DriverEvent::StateChanged { state, ir, .. } => {
                Some((state, ir & (interrupt::EI | interrupt::EPI)))
            }
            _ => None,
        })
        .collect();
    assert_eq!(
        changes,
        [
            (CanState::ErrorWarning, interrupt::EI),
            (CanState::ErrorPassive, interrupt::EPI),
            (CanState::ErrorWarning, interrupt::EPI),
        ]
    );
    // TXERR 7 after phase 2 (+8 - 1), + 8 per ACK error, - 1 per success.
    let successes_after = report.nodes[0].sent - 2;
    assert_eq!(7 + 8 * ack_errors - successes_after, 127);
    let a = &report.nodes[0];
    assert_eq!((a.tec, a.rec, a.state), (127, 0, CanState::ErrorWarning));

    // Every receiver got every frame of the others once, in bus order.
    for node in &report.nodes {
        let expected: Vec<Frame> = sent
            .iter()
            .filter(|(sender, _)| *sender != node.name)
            .map(|(_, f)| *f)
            .collect();
        assert_eq!(node.received, expected, "{}", node.name);
        assert_eq!(node.rec, 0, "{}", node.name);
    }
    for node in &report.nodes[1..] {
        assert_eq!((node.tec, node.state), (0, CanState::ErrorActive));
    }
    assert_eq!(
        report.nodes[1].received[..4],
        [frame_c, frame_a, disturbed, unacknowledged]
    );
    assert!(vcd.exists() && !dir.join("demo.vcd.partial").exists());
    if sigrok::skipped() {
        return;
    }

    // sigrok sees every frame that reached its ACK slot: the disturbed one and its retransmission,
    // every unacknowledged attempt, and flags each error frame's dominant ACK delimiter and EOF.
    let decoded = sigrok::decode(&vcd, "bus", 500_000, DEMO_SAMPLE_POINT_PCT);
    let mut expected: Vec<String> = [frame_c, frame_a, frame_b, disturbed, disturbed]
        .iter()
        .map(|f| f.to_string())
        .collect();
    let received_by_b = &report.nodes[1].received;
    let unacknowledged = received_by_b[3].to_string();
    expected.extend(std::iter::repeat_n(unacknowledged, ack_errors));
    expected.extend(received_by_b[3..].iter().map(|f| f.to_string()));
    assert_eq!(decoded.frames, expected);
    let error_frames = 1 + ack_errors;
    let count = |text: &str| decoded.warnings.iter().filter(|w| w.contains(text)).count();
    assert_eq!(count("ACK delimiter must be a recessive bit"), error_frames);
    assert_eq!(
        count("End of frame (EOF) must be 7 recessive bits"),
        error_frames
    );
    assert_eq!(
        decoded.warnings.len(),
        2 * error_frames,
        "{:?}",
        decoded.warnings
    );
    std::fs::remove_dir_all(&dir).ok();
}
