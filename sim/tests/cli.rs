//! The `cansim` command line: outputs and exit codes a user sees.

use std::process::{Command, Output};

fn cansim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cansim"))
        .args(args)
        .output()
        .expect("cansim runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
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
    assert!(log_text.starts_with("(0.000101) can0 080#\n"), "{log_text}");
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
