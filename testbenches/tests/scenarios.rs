//! Scenario runs (`sim::scenario`): each kind of traffic and fault, node modes and filters, the bus
//! log, the summary and the errors that only show while running. Small buses and short runs; the
//! bad input of the command line is in `sim/tests/scenario_cli.rs`.

use std::path::Path;

use golden::frame::Frame;
use sim::engine::time::FS_PER_US;
use sim::host::driver::{CanState, DriverEvent};
use sim::scenario::candump::parse_frame;
use sim::scenario::summary::{format_report, ReportParts};
use sim::scenario::{parse, run, RunOptions, RunReport, Scenario};
use testbenches::ecc::{ecc, BIT, FORM, OTHER, SEG_ACK_SLOT, SEG_CRC_DELIM, SEG_DATA};
use testbenches::scenario_report::{
    bus_errors, driver_events, error_frames, log_frames, log_lines_with, node, states,
};

/// Two nodes at 500 kbit/s (a bit is 2 us); a test adds its duration, traffic and faults.
const TWO_NODES: &str = r#"
[bus]
bitrate = 500000
[[node]]
name = "a"
[[node]]
name = "b"
ppm = 1000
delay = "50ns"
"#;

fn scenario(text: &str) -> Scenario {
    parse(text, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn run_text(text: &str) -> RunReport {
    run(&scenario(text), RunOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn frames(texts: &[&str]) -> Vec<Frame> {
    texts.iter().map(|t| parse_frame(t).unwrap()).collect()
}

#[test]
fn frames_go_out_at_their_times() {
    let report = run_text(&format!(
        "duration = \"0.6ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#11\"\n\
         [[frame]]\nnode = \"b\"\nat = \"400us\"\nframe = \"1ABCDEF0#R2\"\n"
    ));
    assert_eq!(log_frames(&report), frames(&["123#11", "1ABCDEF0#R2"]));
    for (event, at) in report.log.iter().zip([100, 400]) {
        let late = event.start_fs - at * FS_PER_US;
        assert!(late < 3 * FS_PER_US, "{event}: {late} fs after its time");
    }
    assert_eq!(node(&report, "a").received, frames(&["1ABCDEF0#R2"]));
    assert_eq!(node(&report, "b").received, frames(&["123#11"]));
}

#[test]
fn a_periodic_counter_message_stops_at_its_count() {
    let report = run_text(&format!(
        "duration = \"0.8ms\"\n{TWO_NODES}\
         [[periodic]]\nnode = \"a\"\nframe = \"123#00AA\"\nstart = \"100us\"\nperiod = \"150us\"\n\
         count = 3\npattern = \"counter\"\n"
    ));
    assert_eq!(
        log_frames(&report),
        frames(&["123#00AA", "123#01AA", "123#02AA"])
    );
    for (event, at) in report.log.iter().zip([100, 250, 400]) {
        let late = event.start_fs - at * FS_PER_US;
        assert!(late < 3 * FS_PER_US, "{event}: {late} fs after its time");
    }
}

#[test]
fn random_payloads_follow_the_seed() {
    let text = |seed: u64| {
        format!(
            "duration = \"1ms\"\nseed = {seed}\n{TWO_NODES}\
             [[periodic]]\nnode = \"b\"\nframe = \"7FF#0000000000000000\"\nstart = \"100us\"\n\
             period = \"250us\"\ncount = 3\npattern = \"random\"\n"
        )
    };
    let first = log_frames(&run_text(&text(1)));
    assert_eq!(first.len(), 3);
    assert!(first.iter().all(|f| f.dlc() == 8 && f.id().raw() == 0x7FF));
    assert!(first[0] != first[1] && first[1] != first[2]);
    assert_eq!(log_frames(&run_text(&text(1))), first);
    assert_ne!(log_frames(&run_text(&text(2))), first);
}

#[test]
fn a_self_test_node_sends_alone_and_receives_its_own_frame() {
    let report = run_text(
        "duration = \"0.4ms\"\n[bus]\nbitrate = 500000\n\
         [[node]]\nname = \"alone\"\nmode = \"self-test\"\n\
         [[frame]]\nnode = \"alone\"\nat = \"100us\"\nframe = \"321#CAFE\"\n",
    );
    let alone = node(&report, "alone");
    assert_eq!((alone.sent, alone.tec), (1, 0));
    assert_eq!(alone.received, frames(&["321#CAFE"]));
    let log = report.log_text();
    assert_eq!(log.lines().count(), 1, "{log}");
    assert!(log.ends_with(") can0 321#CAFE (no ACK)\n"), "{log}");
}

#[test]
fn a_listen_only_node_never_acknowledges() {
    let report = run_text(
        "duration = \"0.4ms\"\n[bus]\nbitrate = 500000\n\
         [[node]]\nname = \"a\"\n[[node]]\nname = \"spy\"\nmode = \"listen-only\"\n\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#01\"\n",
    );
    let ack_error = ecc(OTHER, false, SEG_ACK_SLOT);
    let errors = bus_errors(&report, "a");
    assert!(
        errors.len() >= 2 && errors.iter().all(|&e| e == ack_error),
        "{errors:x?}"
    );
    assert!(log_frames(&report).is_empty());
    assert_eq!(error_frames(&report), errors.len());
    // It sees the error frames, but sends no error flag and counts nothing.
    let spy = node(&report, "spy");
    assert!(spy.received.is_empty());
    assert_eq!((spy.sent, spy.tec, spy.rec), (0, 0, 0));
}

#[test]
fn a_one_shot_node_gives_up_after_one_attempt() {
    let report = run_text(
        "duration = \"0.4ms\"\n[bus]\nbitrate = 500000\n\
         [[node]]\nname = \"a\"\none_shot = true\n\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#01\"\n",
    );
    let a = node(&report, "a");
    assert_eq!((a.sent, a.dropped, a.unsent, a.tec), (0, 1, 0, 8));
    assert!(driver_events(&report, "a")
        .iter()
        .any(|(_, e)| *e == DriverEvent::TxFailed(parse_frame("123#01").unwrap())));
    assert_eq!(error_frames(&report), 1);
}

#[test]
fn a_register_filter_decides_what_the_driver_reads() {
    // Dual filter, standard frames: filter 1 passes identifier 123 (ACR0 0x24, ACR1 0x6x: ID
    // bits 2..0 = 011, RTR 0), filter 2 passes 7xx (ACR2 0xE0, AMR2 0x1F, AMR3 0xFF).
    let report = run_text(&format!(
        "duration = \"0.9ms\"\n{TWO_NODES}filter = {{ single = false, acr = [0x24, 0x60, 0xE0, 0x00], \
         amr = [0x00, 0x0F, 0x1F, 0xFF] }}\n\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#01\"\n\
         [[frame]]\nnode = \"a\"\nat = \"300us\"\nframe = \"124#02\"\n\
         [[frame]]\nnode = \"a\"\nat = \"500us\"\nframe = \"7A5#03\"\n\
         [[frame]]\nnode = \"a\"\nat = \"700us\"\nframe = \"6A5#04\"\n"
    ));
    assert_eq!(log_frames(&report).len(), 4);
    assert_eq!(node(&report, "b").received, frames(&["123#01", "7A5#03"]));
}

#[test]
fn a_flipped_ack_slot_is_an_ack_error_and_the_frame_goes_again() {
    let report = run_text(&format!(
        "duration = \"0.7ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"100#01\"\n\
         [[frame]]\nnode = \"a\"\nat = \"300us\"\nframe = \"200#02\"\n\
         [[fault]]\nkind = \"flip\"\nframe = 2\nfield = \"ack_slot\"\n"
    ));
    assert_eq!(bus_errors(&report, "a"), [ecc(OTHER, false, SEG_ACK_SLOT)]);
    assert_eq!(log_frames(&report), frames(&["100#01", "200#02"]));
    assert_eq!(log_lines_with(&report, "ERROR FRAME").len(), 1);
    assert_eq!(
        report.faults[0].text,
        "flip on the bus: ACK slot bit 0 of frame 2 (200#02 from a)"
    );
    assert_eq!(node(&report, "a").tec, 8 - 1);
}

#[test]
fn a_flipped_data_bit_is_a_bit_error_of_the_transmitter() {
    let report = run_text(&format!(
        "duration = \"0.5ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"b\"\nat = \"100us\"\nframe = \"555#F0F0\"\n\
         [[fault]]\nkind = \"flip\"\nframe = 1\nfield = \"data\"\nbit = 3\n"
    ));
    assert_eq!(bus_errors(&report, "b")[0], ecc(BIT, false, SEG_DATA));
    assert_eq!(bus_errors(&report, "a").len(), 1);
    assert_eq!(log_frames(&report), frames(&["555#F0F0"]));
}

#[test]
fn a_forced_level_by_time_hits_the_frame_on_the_bus_then() {
    // a's frame starts at 100 us; the bus is forced dominant for 3 bits from 140 us.
    let report = run_text(&format!(
        "duration = \"0.5ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"3FF#FFFFFFFF\"\n\
         [[fault]]\nkind = \"force\"\nlevel = \"dominant\"\nat = \"140us\"\nduration = \"3bits\"\n"
    ));
    assert!(error_frames(&report) >= 1);
    assert_eq!(bus_errors(&report, "a")[0] >> 6, BIT);
    assert_eq!(log_frames(&report), frames(&["3FF#FFFFFFFF"]));
    let fault = &report.faults[0];
    assert_eq!(
        (fault.start_fs, fault.end_fs),
        (140 * FS_PER_US, 146 * FS_PER_US)
    );
}

#[test]
fn a_local_fault_is_seen_by_its_node_only() {
    let report = run_text(&format!(
        "duration = \"0.5ms\"\n{TWO_NODES}[[node]]\nname = \"c\"\nppm = -800\ndelay = \"90ns\"\n\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"200#DEADBEEF\"\n\
         [[fault]]\nkind = \"force\"\nlevel = \"dominant\"\nframe = 1\nfield = \"crc_delim\"\n\
         nodes = [\"b\"]\n"
    ));
    assert_eq!(bus_errors(&report, "b")[0], ecc(FORM, true, SEG_CRC_DELIM));
    // c sees the bus as it is: b's error flag in the ACK delimiter.
    assert_eq!(bus_errors(&report, "c")[0] & 0x1F, 0x1B);
    assert_eq!(
        report.faults[0].text,
        "force dominant seen by b: CRC delimiter bit 0 of frame 1 (200#DEADBEEF from a)"
    );
}

#[test]
fn a_glitch_over_the_sample_point_is_an_error_and_lasts_its_quanta() {
    // 16 quanta per bit, sample point after quantum 14: a 2-quantum glitch from quantum 13 covers
    // it.
    let report = run_text(&format!(
        "duration = \"0.5ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"0F0#00\"\n\
         [[fault]]\nkind = \"glitch\"\nquanta = 2\nframe = 1\nfield = \"data\"\nbit = 4\n\
         offset = \"13tq\"\n"
    ));
    let fault = &report.faults[0];
    assert_eq!(fault.end_fs - fault.start_fs, 250_000_000);
    assert!(error_frames(&report) >= 1);
    assert_eq!(bus_errors(&report, "a")[0], ecc(BIT, false, SEG_DATA));
    assert_eq!(log_frames(&report), frames(&["0F0#00"]));
}

#[test]
fn a_disconnected_node_neither_acknowledges_nor_sends_until_it_is_back() {
    let report = run_text(&format!(
        "duration = \"0.9ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#01\"\n\
         [[fault]]\nkind = \"disconnect\"\nnode = \"b\"\nat = \"0us\"\nduration = \"400us\"\n"
    ));
    let ack_errors = bus_errors(&report, "a");
    assert!(ack_errors.len() >= 2);
    let cut_off = 400 * FS_PER_US;
    assert!(
        driver_events(&report, "b")
            .iter()
            .all(|(t, _)| *t > cut_off),
        "b reported something while cut off"
    );
    assert_eq!(node(&report, "b").received, frames(&["123#01"]));
    assert_eq!(node(&report, "a").sent, 1);
}

#[test]
fn without_a_restart_delay_a_node_stays_bus_off() {
    // Cut off, `a` reaches bus-off 407 bits (814 us) after its first SOF (ISO 16845-1 8.5.15: 17
    // bit errors to error passive, then one per 26-bit attempt), well inside the 1 ms cut.
    let report = run_text(&format!(
        "duration = \"1.3ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#01\"\n\
         [[frame]]\nnode = \"a\"\nat = \"1100us\"\nframe = \"123#02\"\n\
         [[fault]]\nkind = \"disconnect\"\nnode = \"a\"\nat = \"0us\"\nduration = \"1000us\"\n"
    ));
    assert_eq!(states(&report, "a").last(), Some(&CanState::BusOff));
    let a = node(&report, "a");
    assert_eq!((a.sent, a.dropped, a.unsent, a.restarts), (0, 1, 1, 0));
    assert!(report.log.is_empty(), "{}", report.log_text());
}

#[test]
fn a_fault_for_a_frame_that_never_comes_is_reported_missed() {
    let report = run_text(&format!(
        "duration = \"0.3ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#01\"\n\
         [[fault]]\nkind = \"flip\"\nframe = 9\nfield = \"crc\"\n"
    ));
    assert_eq!(
        report.missed_faults,
        ["line 15: not applied: the bus saw only 1 frames"]
    );
}

#[test]
fn a_fault_on_a_bit_the_frame_lacks_stops_the_run_naming_its_line() {
    let text = format!(
        "duration = \"0.3ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#01\"\n\
         [[fault]]\nkind = \"flip\"\nframe = 1\nfield = \"data\"\nbit = 40\n"
    );
    let error = run(&scenario(&text), RunOptions::default()).unwrap_err();
    assert_eq!(
        error.to_string(),
        "test.toml:15: frame 1 on the bus: it is 123#01 and has no data bit 40"
    );
}

#[test]
fn until_cuts_the_run_short() {
    let s = scenario(&format!("duration = \"1ms\"\n{TWO_NODES}"));
    let options = RunOptions {
        until_fs: Some(200 * FS_PER_US),
        ..RunOptions::default()
    };
    let report = run(&s, options).unwrap();
    assert!(report.simulated_fs.abs_diff(200 * FS_PER_US) < FS_PER_US);
}

#[test]
fn the_report_shows_nodes_log_events_faults_counts_and_the_table() {
    let text = format!(
        "duration = \"0.7ms\"\n{TWO_NODES}\
         [[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"100#01\"\n\
         [[frame]]\nnode = \"a\"\nat = \"300us\"\nframe = \"200#02\"\n\
         [[fault]]\nkind = \"flip\"\nframe = 2\nfield = \"ack_slot\"\n"
    );
    let s = scenario(&text);
    let report = run(&s, RunOptions::default()).unwrap();
    let parts = ReportParts {
        log: true,
        events: true,
        receptions: false,
    };
    let out = format_report(&s, &report, parts);
    for expected in [
        "test.toml: 2 nodes, 500 kbit/s at 16 MHz",
        "  b: 16 MHz +1000 ppm, 50 ns from the bus\n",
        ") can0 100#01\n",
        "can0 ERROR FRAME in ACK delimiter of 200#02 (ACK error)\n",
        "  a  bus error, ECC 0xD9 (other error, transmitting, ACK slot); TXERR 8, RXERR 0\n",
        "  a  sent 200#02\n",
        "line 19: flip on the bus: ACK slot bit 0 of frame 2 (200#02 from a)\n",
        "bus: 2 frames, 1 error frames, 0 overload frames\n",
        "a        2         0        0       0      7      0  error-active          0  TI 2, BEI 1\n",
        "b        0         2        0       0      0      0  error-active          0  RI 2, BEI 1\n",
    ] {
        assert!(out.contains(expected), "missing {expected:?} in\n{out}");
    }
    assert!(
        !out.contains("  b  received"),
        "receptions left out:\n{out}"
    );
}

#[test]
fn the_example_of_the_scenario_documentation_runs_as_it_says() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/SCENARIOS.md"))
        .unwrap();
    let example = doc
        .split("## Example")
        .nth(1)
        .and_then(|rest| rest.split("```toml\n").nth(1))
        .and_then(|block| block.split("```").next())
        .expect("docs/SCENARIOS.md ends with an example");
    let report = run_text(example);
    assert_eq!(
        log_frames(&report),
        frames(&["123#0011", "123#0111", "123#0211"])
    );
    assert_eq!(bus_errors(&report, "b"), [ecc(FORM, true, SEG_CRC_DELIM)]);
    assert_eq!(error_frames(&report), 1);
}
