//! Every scenario in `examples/` runs, and shows what its comments promise: frames in the bus log,
//! what the drivers reported, the nodes' counters and states at the end.

use std::path::PathBuf;

use golden::frame::Frame;
use sim::engine::time::{FS_PER_MS, FS_PER_US};
use sim::host::driver::CanState;
use sim::scenario::candump::{parse_frame, parse_log};
use sim::scenario::{load, run, RunOptions, RunReport, Scenario};
use testbenches::scenario_report::{
    driver_events, error_frames, log_frames, losses, node, restarts, sent_frames, states,
};

fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name)
}

fn run_example(name: &str) -> (Scenario, RunReport) {
    let scenario = load(&example(name)).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&scenario, RunOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    (scenario, report)
}

fn frames(texts: &[&str]) -> Vec<Frame> {
    texts.iter().map(|t| parse_frame(t).unwrap()).collect()
}

#[test]
fn eight_nodes_send_in_priority_order_each_losing_once_per_frame_before_its_own() {
    let (_, report) = run_example("arbitration.toml");
    let order = [
        ("n4", "0FF#04"),
        ("n5", "100#05"),
        ("n7", "04000000#07"),
        ("n6", "101#06"),
        ("n3", "280#03"),
        ("n2", "300#02"),
        ("n1", "301#01"),
        ("n8", "7FF#08"),
    ];
    let mut expected = vec!["080#"];
    expected.extend(order.iter().map(|(_, f)| *f));
    assert_eq!(log_frames(&report), frames(&expected));
    assert_eq!(error_frames(&report), 0);
    for (k, (name, _)) in order.iter().enumerate() {
        assert_eq!(losses(&report, name).len(), k, "{name}");
        let n = node(&report, name);
        assert_eq!(n.received.len(), expected.len() - n.sent, "{name}");
    }
    // The extended frame with base identifier 100 loses to the standard 100 at the SRR bit (ALC
    // 11) and beats 101, which loses at its last identifier bit (ALC 10).
    assert_eq!(losses(&report, "n7"), [2, 11]);
    assert_eq!(losses(&report, "n6"), [2, 10, 10]);
}

#[test]
fn a_stuck_transmitter_takes_the_sender_to_bus_off_and_its_driver_restarts_it() {
    let (scenario, report) = run_example("bus_off.toml");
    assert_eq!(
        states(&report, "ecu"),
        [
            CanState::ErrorWarning,
            CanState::ErrorPassive,
            CanState::BusOff
        ]
    );
    let ecu = driver_events(&report, "ecu");
    let bus_off_at = ecu
        .iter()
        .find(|(_, e)| {
            matches!(
                e,
                sim::host::driver::DriverEvent::StateChanged {
                    state: CanState::BusOff,
                    ..
                }
            )
        })
        .map(|(t, _)| *t)
        .unwrap();
    let restart = scenario.nodes[0].restart_fs.unwrap();
    assert_eq!(restart, FS_PER_MS);
    let restarted = restarts(&report, "ecu");
    assert_eq!(restarted.len(), 1);
    assert!(restarted[0].abs_diff(bus_off_at + restart) < FS_PER_US);
    // Frames get through again after the restart; the receivers are error active again.
    let sent_after = sent_frames(&report)
        .iter()
        .filter(|(n, _)| n == "ecu")
        .count()
        - 2;
    assert!(sent_after >= 5, "{sent_after}");
    let e = node(&report, "ecu");
    assert_eq!(
        (e.tec, e.dropped, e.restarts, e.state),
        (0, 1, 1, CanState::ErrorActive)
    );
    for name in ["gateway", "display"] {
        assert_eq!(
            states(&report, name),
            [
                CanState::ErrorWarning,
                CanState::ErrorPassive,
                CanState::ErrorWarning
            ],
            "{name}"
        );
        let n = node(&report, name);
        assert!(n.rec < 128, "{name}: {n:?}");
        assert_eq!(n.received, log_frames(&report), "{name}");
    }
    assert_eq!(error_frames(&report), 1);
}

#[test]
fn oscillators_at_the_limit_agree_and_one_far_beyond_it_breaks_the_bus() {
    let (_, report) = run_example("oscillator.toml");
    let joins = 970 * FS_PER_US;
    let before = report.log.iter().filter(|e| e.end_fs < joins);
    let (valid_before, errors_before): (Vec<_>, Vec<_>) = before.partition(|e| {
        matches!(
            e.kind,
            sim::decode::bus_decoder::BusEventKind::Frame { acked: true, .. }
        )
    });
    assert_eq!(valid_before.len(), 3);
    assert!(errors_before.is_empty(), "{errors_before:?}");
    for name in ["ref", "fast", "slow"] {
        assert!(
            driver_events(&report, name)
                .iter()
                .filter(|(_, e)| matches!(e, sim::host::driver::DriverEvent::BusError { .. }))
                .all(|(t, _)| *t > joins),
            "{name} saw a bus error before far joined"
        );
    }
    let after: Vec<_> = report.log.iter().filter(|e| e.start_fs > joins).collect();
    assert!(after.len() >= 4);
    assert!(after
        .iter()
        .all(|e| !matches!(e.kind, sim::decode::bus_decoder::BusEventKind::Frame { .. })));
    assert_eq!(node(&report, "far").sent, 0);
}

#[test]
fn a_candump_log_is_replayed_at_its_times() {
    let (scenario, report) = run_example("replay.toml");
    let text = std::fs::read_to_string(example("replay.log")).unwrap();
    let lines = parse_log(&text, &example("replay.log")).unwrap();
    let can0: Vec<_> = lines.iter().filter(|l| l.interface == "can0").collect();
    let expected: Vec<Frame> = can0.iter().map(|l| l.frame).collect();
    assert_eq!(log_frames(&report), expected);
    // Each frame starts when it is released (first line at 0.1 ms), or as soon as the bus is
    // free, within a few bits.
    let start = 100 * FS_PER_US;
    for (line, event) in can0.iter().zip(&report.log) {
        let release = start + (line.time_fs - can0[0].time_fs) as u64;
        let late = event.start_fs - release;
        assert!(late < 10 * scenario.bus.bit_fs(), "{event}: {late} fs late");
    }
    assert_eq!(node(&report, "logger").received, expected);
    assert_eq!(node(&report, "logger").sent, 0);
    assert_eq!(node(&report, "player").sent, expected.len());
}

#[test]
fn the_canopen_network_boots_synchronises_and_answers_its_sdos() {
    let (scenario, report) = run_example("canopen.toml");
    assert_eq!(error_frames(&report), 0);
    let log: Vec<String> = log_frames(&report).iter().map(|f| f.to_string()).collect();
    // Boot-up of the master and both devices (CiA 301 7.3.2.2.1: 700h + node-ID, one byte 00h).
    assert_eq!(log[..3], ["701#00", "702#00", "703#00"]);
    // Every step of the master's script ended as it expected.
    let steps = scenario.nodes[0]
        .canopen_master
        .as_ref()
        .unwrap()
        .steps
        .len();
    let ended = report
        .master
        .iter()
        .filter(|l| l.text.starts_with("line "))
        .count();
    assert_eq!(ended, steps);
    assert_eq!(report.failed_steps(), 0, "{:?}", report.master);
    // Between two SYNCs, TPDO1 of each device once: the io module's inputs (5Ah) and debounce
    // time (10), the drive's statusword (0250h) and position (0).
    let syncs: Vec<usize> = (0..log.len()).filter(|&i| log[i] == "080#").collect();
    assert!(syncs.len() >= 3, "{log:?}");
    for pair in syncs.windows(2) {
        let between = &log[pair[0] + 1..pair[1]];
        for tpdo in ["182#5A0A00", "183#500200000000"] {
            let count = between.iter().filter(|f| *f == tpdo).count();
            assert_eq!(count, 1, "{tpdo} after SYNC {}: {between:?}", pair[0]);
        }
    }
    for name in ["master", "io", "drive"] {
        let n = node(&report, name);
        assert_eq!((n.tec, n.rec, n.unsent), (0, 0, 0), "{name}");
    }
}

#[test]
fn the_served_bus_sends_engine_status_every_10_ms_and_the_gateway_frame_every_50_ms() {
    let (_, report) = run_example("serve.toml");
    let engine = |k: u8| format!("0C0#{k:02X}401F5A00000000");
    let expected: Vec<String> = [
        engine(0),
        "18FEF100#FF00".into(),
        engine(1),
        engine(2),
        engine(3),
        engine(4),
        engine(5),
        "18FEF100#FF00".into(),
    ]
    .into();
    let texts: Vec<&str> = expected.iter().map(String::as_str).collect();
    assert_eq!(log_frames(&report), frames(&texts));
    assert_eq!(error_frames(&report), 0);
    for (event, at_ms) in report.log.iter().zip([1, 5, 11, 21, 31, 41, 51, 55]) {
        let late = event.start_fs - at_ms * FS_PER_MS;
        assert!(late < 5 * FS_PER_US, "{event}: {late} fs after its time");
    }
}
