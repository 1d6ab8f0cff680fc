//! The `cansim` command line: outputs and exit codes a user sees.

mod common;

use std::path::PathBuf;
use std::process::Output;

use common::{cansim, text};

use golden::frame::{encode, Field, Frame, Id};
use sim::engine::bus_timing::BusTiming;
use sim::engine::trace::VcdTracer;

fn stdout(o: &Output) -> String {
    text(&o.stdout)
}

fn stderr(o: &Output) -> String {
    text(&o.stderr)
}

#[test]
fn bittiming_500k_at_16mhz_is_btr0_00_btr1_1c() {
    let o = cansim(&["bittiming", "--clock", "16000000", "--bitrate", "500000"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    for expected in [
        "BTR0         0x00",
        "BTR1         0x1C",
        "87.5 %",
        "16 (sync 1 + tseg1 13 + tseg2 2)",
    ] {
        assert!(out.contains(expected), "missing {expected:?} in\n{out}");
    }
}

#[test]
fn bittiming_sample_point_in_percent_or_fraction() {
    let percent = stdout(&cansim(&[
        "bittiming",
        "--bitrate",
        "250000",
        "--sample-point",
        "75",
    ]));
    let fraction = stdout(&cansim(&[
        "bittiming",
        "--bitrate",
        "250000",
        "--sample-point",
        "0.75",
    ]));
    assert_eq!(percent, fraction);
    assert!(percent.contains("sample point 75.0 %"), "{percent}");
}

#[test]
fn bittiming_table_lists_the_usual_bit_rates() {
    let o = cansim(&["bittiming", "--all"]);
    assert!(o.status.success());
    let out = stdout(&o);
    assert!(out.contains("500000 bit/s: BTR0=0x00 BTR1=0x1C"), "{out}");
    assert_eq!(
        out.lines().filter(|l| l.contains("bit/s:")).count(),
        9,
        "{out}"
    );
}

#[test]
fn impossible_or_bad_requests_fail_with_a_message() {
    for (args, message) in [
        (&["bittiming", "--bitrate", "3000000"][..], "impossible"),
        (&["bittiming", "--bitrate", "1000"][..], "impossible"),
        (
            &["bittiming", "--bitrate", "500000", "--sample-point", "120"][..],
            "--sample-point 120",
        ),
        (
            &["bittiming", "--clock", "0", "--bitrate", "500000"][..],
            "0 Hz",
        ),
        (
            &["bittiming", "--bitrate", "500000", "--sjw", "5"][..],
            "SJW",
        ),
        (&["bittiming"][..], "--bitrate"),
    ] {
        let o = cansim(args);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(stderr(&o).contains(message), "{args:?}: {}", stderr(&o));
        assert!(stdout(&o).is_empty(), "{args:?} printed a result");
    }
}

#[test]
fn demo_reports_every_node_and_writes_the_vcd_and_log_where_asked() {
    let dir = std::env::temp_dir().join(format!("cansim-cli-{}", std::process::id()));
    let (vcd, log) = (
        dir.join("sub").join("demo.vcd"),
        dir.join("logs").join("demo.log"),
    );
    let o = cansim(&[
        "demo",
        "--vcd",
        vcd.to_str().unwrap(),
        "--log",
        log.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    for expected in [
        "a: 16 MHz +0 ppm, 0 ns from the bus",
        "b: 16 MHz +1500 ppm, 60 ns from the bus",
        "d: 16 MHz +800 ppm, 100 ns from the bus, single filter ACR 20000000 AMR 1FFFFFFF",
        "a  lost arbitration at bit 9 (ALC)",
        "b  bus error, ECC 0x78 (form error, receiving, CRC delimiter)",
        "a  error-passive (EPI)",
        "d  bus-off (EI)",
        "d  restarted by its driver after bus-off",
        "node  sent  received  dropped  unsent  TXERR  RXERR  state",
        "gtkwave",
    ] {
        assert!(out.contains(expected), "missing {expected:?} in\n{out}");
    }
    assert!(
        !out.contains("received 080#"),
        "the demo leaves out receptions"
    );
    assert!(std::fs::metadata(&vcd).unwrap().len() > 10_000);
    let log_text = std::fs::read_to_string(&log).unwrap();
    let first = log_text.lines().next().unwrap_or_default();
    assert!(first.ends_with(") can0 080#"), "{log_text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn sync_demo_reports_every_node_sampling_right() {
    let o = cansim(&["sync-demo", "--no-vcd"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    for node in [
        "a (16 MHz +0 ppm",
        "b (16 MHz +1500 ppm",
        "c (16 MHz -2500 ppm",
    ] {
        assert!(out.contains(node), "missing {node:?}");
    }
    assert!(out.contains("every bit sampled right: yes"), "{out}");
}

#[test]
fn demo_into_an_unwritable_place_fails_cleanly() {
    let o = cansim(&["demo", "--vcd", "/proc/cansim/demo.vcd"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("/proc/cansim"), "{}", stderr(&o));
}

// ---- cansim rta: the tables, the CSV, the refusals and the exit codes.

fn example(name: &str) -> String {
    common::example(&format!("rta/{name}.toml"))
}

/// Writes `text` to a file of its own for one test and returns its path.
fn message_file(test: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cansim-rta-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(format!("{test}.toml"));
    std::fs::write(&path, text).expect("write message set");
    path
}

/// The part of `cansim rta --simulate` output from the simulation table on.
fn simulation_table(out: &str) -> &str {
    &out[out.find("\nsimulation:").expect("a simulation table")..]
}

/// The whitespace-separated cells of the table row starting with `name`.
fn row(out: &str, name: &str) -> Vec<String> {
    out.lines()
        .find(|l| l.split_whitespace().next() == Some(name))
        .unwrap_or_else(|| panic!("no row {name} in\n{out}"))
        .split_whitespace()
        .map(String::from)
        .collect()
}

const VALID: &str = r#"bitrate = 500000
[[message]]
name = "a"
id = 0x100
dlc = 8
period_ms = 10
node = "ecu"
"#;

#[test]
fn worked_example_table_shows_both_analyses() {
    let o = cansim(&["rta", &example("classic_example_1")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    // message id C T J D | classic B w R ok | corrected B w R q/Q ok
    assert_eq!(
        row(&out, "m1"),
        ["m1", "001", "1", "3", "0", "3", "2", "2", "3", "yes", "3", "3", "4", "0/2", "no"]
    );
    assert_eq!(row(&out, "m2")[6..10], ["2", "4", "5", "yes"]);
    assert_eq!(row(&out, "m3")[6..10], ["0", "2", "5", "yes"]);
    assert!(
        out.contains("classic: every message meets its deadline"),
        "{out}"
    );
    assert!(out.contains("bus utilisation 80.0 %"), "{out}");
}

#[test]
fn csv_has_a_header_and_one_line_per_message() {
    let o = cansim(&["rta", "--csv", &example("classic_example_2")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let mut lines = out.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3);
    let cells = |name: &str| rows.iter().map(|r| r[column(name)]).collect::<Vec<_>>();
    assert_eq!(cells("message"), ["m1", "m2", "m3"]);
    assert_eq!(cells("classic_queuing"), ["3", "5", "2"]);
    assert_eq!(cells("classic_response"), ["4", "6", "6"]);
    assert_eq!(cells("classic_schedulable"), ["no", "yes", "yes"]);
    assert_eq!(cells("corrected_response"), ["5", "8", "6"]);
    assert!(rows.iter().all(|r| r.len() == header.len()));
}

#[test]
fn bit_rate_sets_print_times_in_milliseconds() {
    let o = cansim(&["rta", "--csv", &example("davis2007")]);
    let out = stdout(&o);
    assert!(
        out.starts_with("message,id,extended,node,dlc,frame_bits,transmission_ms,"),
        "{out}"
    );
    assert!(
        out.contains("\nC,0x030,false,n3,7,125,1,3.5,0,3.25,0,2,3,yes,0,2.5,3.5,7,2,1,no\n"),
        "{out}"
    );
}

#[test]
fn simulation_prints_the_counterexample_beside_both_bounds() {
    let o = cansim(&[
        "rta",
        "--simulate",
        "--threads",
        "1",
        &example("davis2007_on_bus"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let sim = simulation_table(&out);
    let c = row(sim, "C");
    // message frame bits sent classic corrected observed instance scenario verdict
    assert_eq!(c[4..6], ["3", "3.5"]);
    let observed: f64 = c[6].parse().unwrap();
    assert!(observed > 3.25 && observed <= 3.5, "{out}");
    assert_eq!(c[9..], ["exceeds", "classic", "bound"]);
    assert_eq!(row(sim, "A")[9..], ["within", "both"]);
}

#[test]
fn invalid_sets_are_refused_naming_file_and_line() {
    let duplicate = format!(
        "{VALID}[[message]]\nname = \"b\"\nid = 256\ndlc = 1\nperiod_ms = 5\nnode = \"x\"\n"
    );
    let cases = [
        (
            "duplicate",
            duplicate,
            ":8: duplicate identifier 0x100: messages 'a' (line 2) and 'b'",
        ),
        (
            "dlc",
            VALID.replace("dlc = 8", "dlc = 9"),
            ":2: message 'a': DLC 9 is out of range 0..=8",
        ),
        (
            "zero_period",
            VALID.replace("period_ms = 10", "period_ms = 0"),
            ":2: message 'a': zero period",
        ),
        (
            "unknown_key",
            VALID.replace("dlc = 8", "dlc = 8\npriority = 1"),
            ":6: unknown field `priority`",
        ),
        (
            "malformed",
            VALID.replace("period_ms = 10", "period_ms = = 10"),
            ":6:",
        ),
        (
            "no_rate",
            VALID.replace("bitrate = 500000", ""),
            ": missing `bitrate = ...`",
        ),
    ];
    for (test, text, expected) in cases {
        let path = message_file(test, &text);
        let o = cansim(&["rta", path.to_str().unwrap()]);
        std::fs::remove_file(&path).ok();
        assert_eq!(o.status.code(), Some(1), "{test}");
        let err = stderr(&o);
        let expected = format!("cansim: {}{expected}", path.display());
        assert!(
            err.starts_with(&expected),
            "{test}: {err:?} does not start with {expected:?}"
        );
        assert!(stdout(&o).is_empty(), "{test}: no report for a bad file");
    }
}

#[test]
fn a_missing_file_is_an_error() {
    let o = cansim(&["rta", "no/such/set.toml"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).starts_with("cansim: no/such/set.toml: cannot read:"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn utilisation_above_one_is_reported_not_looped_on() {
    let text = r#"bitrate = 125000
[[message]]
name = "fast"
id = 0x100
dlc = 8
period_ms = 1.5
node = "a"
[[message]]
name = "slow"
id = 0x200
dlc = 8
period_ms = 2
node = "b"
"#;
    let path = message_file("overload", text);
    let o = cansim(&["rta", path.to_str().unwrap()]);
    let simulated = cansim(&["rta", "--simulate", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("bus utilisation 126.0 %"), "{out}");
    // message id node dlc bits C T J D | classic B w R ok | corrected B w R q/Q ok
    assert_eq!(row(&out, "fast")[15], "2.16");
    assert_eq!(
        row(&out, "slow")[13..],
        ["-", "-", "unbounded", "-", "unbounded"]
    );
    // The classic recurrence sums only the higher priorities (72 %) and still converges.
    assert_eq!(row(&out, "slow")[9..13], ["0", "1.08", "2.16", "no"]);
    assert!(
        out.contains(
            "slow: no bound: the messages of its priority and above load the bus to 126.0 %"
        ),
        "{out}"
    );
    // Simulated, slow's own scenario is skipped; it is seen only as fast's blocking frame.
    assert!(simulated.status.success(), "{}", stderr(&simulated));
    let sim_out = stdout(&simulated);
    let sim = simulation_table(&sim_out);
    assert_eq!(row(sim, "slow")[8..], ["fast", "no", "corrected", "bound"]);
    assert!(
        sim.contains("\ncritical instants simulated: 1 of 2;"),
        "{sim}"
    );
}

#[test]
fn abstract_sets_cannot_be_simulated() {
    let o = cansim(&["rta", "--simulate", &example("classic_example_1")]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("abstract message sets cannot be simulated"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn help_explains_the_analyses_and_the_file() {
    let out = stdout(&cansim(&["rta", "--help"]));
    for expected in [
        "Davis, Burns, Bril, Lukkien (2007)",
        "abstract = true",
        "period_ms",
        "--simulate",
        "Exit status",
    ] {
        assert!(out.contains(expected), "{expected:?} missing in\n{out}");
    }
}

/// A VCD written by the project's tracer: `frames` (acknowledged) at 250 kbit/s, sample point 75 %
/// recorded in the header, each followed by 11 idle bits; an error flag cuts the second frame after
/// its DLC.
fn traced_bus(path: &std::path::Path, frames: &[Frame]) {
    let timing = BusTiming::from_bitrate(250_000.0, 0.75).unwrap();
    let mut tracer = VcdTracer::create(path, &[], &[], Some(&timing)).unwrap();
    let mut t = 10 * timing.bit_time_fs;
    let mut play = |tracer: &mut VcdTracer, bits: &[bool]| {
        for &bit in bits {
            tracer.bus(t, bit).unwrap();
            t += timing.bit_time_fs;
        }
    };
    for (i, frame) in frames.iter().enumerate() {
        let encoded = encode(frame);
        let mut bits: Vec<bool> = encoded.bits.iter().by_vals().collect();
        bits[encoded.position(Field::AckSlot, 0).unwrap()] = false;
        if i == 1 {
            bits.truncate(encoded.position(Field::Dlc, 3).unwrap() + 1);
            bits.extend([false; 6]);
        }
        play(&mut tracer, &bits);
        play(&mut tracer, &[true; 11]);
    }
    tracer.finish(t).unwrap();
}

#[test]
fn decode_prints_frames_errors_and_the_count_with_the_recorded_timing() {
    let dir = std::env::temp_dir().join(format!("cansim-cli-decode-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vcd = dir.join("bus.vcd");
    let frames = [
        Frame::data(Id::Standard(0x123), &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap(),
        Frame::data(Id::Standard(0x555), &[0xAA]).unwrap(),
        Frame::remote(Id::Extended(0x1ABC_DEF0), 0).unwrap(),
    ];
    traced_bus(&vcd, &frames);
    let o = cansim(&["decode", vcd.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // 250 kbit/s: 4 µs a bit; the first SOF after 10 idle bits, each frame then 11 idle bits. The
    // flag after the recessive last DLC bit of 0x555 makes data bits 0..=4 dominant, and its sixth bit
    // breaks the stuff rule.
    let second = 10 + encode(&frames[0]).len() + 11;
    let dlc3 = encode(&frames[1]).position(Field::Dlc, 3).unwrap();
    let third = second + dlc3 + 1 + 6 + 11;
    let expected = format!(
        "{} top.bus at 250000 bit/s, sample point 75 % (recorded in the file)\n\
         (0.000040) can0 123#DEADBEEF\n\
         (0.{:06}) can0 ERROR FRAME after data bit 4 of 555 (stuff error)\n\
         (0.{:06}) can0 1ABCDEF0#R\n\
         2 frames, 1 error frame, 0 overload frames\n",
        vcd.display(),
        (second + dlc3 + 6) * 4,
        third * 4
    );
    assert_eq!(stdout(&o), expected);
    let o = cansim(&["decode", vcd.to_str().unwrap(), "--bitrate", "125000"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("at 125000 bit/s, sample point 75 %\n"),
        "{}",
        stdout(&o)
    );
    assert!(!stdout(&o).contains("123#DEADBEEF"), "{}", stdout(&o));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn decode_bad_input_fails_with_the_file_and_line() {
    let dir = std::env::temp_dir().join(format!("cansim-cli-decode-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vcd = dir.join("bus.vcd");
    traced_bus(&vcd, &[Frame::data(Id::Standard(1), &[]).unwrap()]);
    let malformed = dir.join("malformed.vcd");
    let text = std::fs::read_to_string(&vcd).unwrap();
    std::fs::write(&malformed, text.replacen("#", "%", 1)).unwrap();
    let line = text.lines().position(|l| l.starts_with('#')).unwrap() + 1;
    let path = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let missing = dir.join("missing.vcd");
    for (args, message) in [
        (
            vec!["decode".into(), path(&missing)],
            format!("{}: cannot open", missing.display()),
        ),
        (
            vec!["decode".into(), path(&malformed)],
            format!("{}:{line}: malformed VCD", malformed.display()),
        ),
        (
            vec![
                "decode".into(),
                path(&vcd),
                "--signal".into(),
                "can_rx".into(),
            ],
            format!(
                "{}: no signal `can_rx`; the signals are: top.bus",
                vcd.display()
            ),
        ),
        (
            vec![
                "decode".into(),
                path(&vcd),
                "--sample-point".into(),
                "100".into(),
            ],
            "--sample-point 100 is out of range".into(),
        ),
        (
            vec!["decode".into(), path(&vcd), "--bitrate".into(), "0".into()],
            "bit rate 0 is not a rate of at least 1 bit/s".into(),
        ),
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = cansim(&args);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(stderr(&o).contains(&message), "{args:?}: {}", stderr(&o));
        assert!(stdout(&o).is_empty(), "{args:?} printed a result");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn verilog_writes_the_controller_and_the_bus_wrapper_asked_for() {
    let dir = std::env::temp_dir().join(format!("cansim-verilog-cli-{}", std::process::id()));
    let out = dir.to_str().unwrap();
    let o = cansim(&["verilog", "--bus", "axi4-lite", "--out", out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("can_controller_axil.v"),
        "{}",
        stdout(&o)
    );
    let wrapper = std::fs::read_to_string(dir.join("can_controller_axil.v")).unwrap();
    assert!(wrapper.contains("module can_controller_axil(clock,reset,s_axil_awvalid,"));
    assert!(wrapper.contains("    parameter  word_stride = 1'b0;"));
    assert!(wrapper.contains("    can_controller can("));
    assert!(
        !wrapper.contains("module can_controller("),
        "the controller is its own file"
    );
    assert!(dir.join("can_controller.v").exists());
    let o = cansim(&["verilog", "--bus", "pci", "--out", out]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("--bus: unknown bus \"pci\": native, wishbone, axi4-lite, apb"),
        "{}",
        stderr(&o)
    );
    std::fs::remove_dir_all(&dir).ok();
}
