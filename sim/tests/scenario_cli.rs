//! `cansim run`: a scenario runs from the command line and writes its outputs; bad input of every
//! kind fails with a message naming the file and line, a non-zero exit, nothing on stdout and no
//! output file left behind.

mod common;

use common::{cansim, example, scratch, text};

const HEADER: &str = "duration = \"1ms\"\n[bus]\nbitrate = 500000\n[[node]]\nname = \"a\"\n";

/// Runs `cansim run` on `scenario` (written as `bad.toml`, with `extra` files beside it) asking for
/// a VCD and a log in an output directory; checks that it fails with `message` on stderr and
/// leaves the output directory empty.
fn fails(test: &str, scenario: &str, extra: &[(&str, &str)], args: &[&str], message: &str) {
    let dir = scratch("run", test);
    let file = dir.join("bad.toml");
    std::fs::write(&file, scenario).unwrap();
    for (name, contents) in extra {
        std::fs::write(dir.join(name), contents).unwrap();
    }
    let out = dir.join("out");
    let (vcd, log) = (out.join("run.vcd"), out.join("run.log"));
    let mut all = vec![
        "run",
        file.to_str().unwrap(),
        "--vcd",
        vcd.to_str().unwrap(),
        "--log",
        log.to_str().unwrap(),
    ];
    all.extend(args);
    let o = cansim(&all);
    let stderr = text(&o.stderr);
    assert!(!o.status.success(), "{test}: should fail");
    let expected = message.replace("FILE", &dir.to_string_lossy());
    assert!(
        stderr.contains(&expected),
        "{test}: expected {expected:?} in {stderr:?}"
    );
    assert!(
        text(&o.stdout).is_empty(),
        "{test}: printed {}",
        text(&o.stdout)
    );
    let left: Vec<_> = std::fs::read_dir(&out)
        .map(|d| d.map(|e| e.unwrap().file_name()).collect())
        .unwrap_or_default();
    assert!(left.is_empty(), "{test}: left {left:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn malformed_toml() {
    fails(
        "malformed",
        "duration = \"1ms\"\n[bus\nbitrate = 500000\n",
        &[],
        &[],
        "FILE/bad.toml:2:5: invalid table header; expected `.`, `]`",
    );
}

#[test]
fn unknown_keys() {
    fails(
        "unknown-key",
        &format!("{HEADER}colour = \"red\"\n"),
        &[],
        &[],
        "FILE/bad.toml:6:1: unknown field `colour`, expected one of `name`, `clock`",
    );
    fails(
        "unknown-top-key",
        &format!("{HEADER}[[frames]]\n"),
        &[],
        &[],
        "FILE/bad.toml:6:3: unknown field `frames`",
    );
}

#[test]
fn bad_identifiers_and_lengths() {
    let frame =
        |f: &str| format!("{HEADER}[[frame]]\nnode = \"a\"\nat = \"1us\"\nframe = \"{f}\"\n");
    fails(
        "bad-id",
        &frame("800#00"),
        &[],
        &[],
        "FILE/bad.toml:9:9: bad frame \"800#00\": standard identifier 0x800 is out of range",
    );
    fails(
        "bad-extended-id",
        &frame("20000000#"),
        &[],
        &[],
        "FILE/bad.toml:9:9: bad frame \"20000000#\": extended identifier 0x20000000 is out of range",
    );
    fails(
        "bad-length",
        &frame("123#001122334455667788"),
        &[],
        &[],
        "FILE/bad.toml:9:9: bad frame \"123#001122334455667788\": data \"001122334455667788\" has 9 bytes, at most 8",
    );
    fails(
        "bad-filter",
        &format!("{HEADER}filter = {{ acr = [1, 2, 3], amr = [0, 0, 0, 0] }}\n"),
        &[],
        &[],
        "FILE/bad.toml:6:18: expected 4 register values, got 3",
    );
}

#[test]
fn impossible_bit_timings() {
    fails(
        "impossible-bitrate",
        "duration = \"1ms\"\n[bus]\nbitrate = 3000000\n[[node]]\nname = \"a\"\n",
        &[],
        &[],
        "FILE/bad.toml:3:11: impossible bit timing: bitrate 3000000 is impossible with a 16000000 Hz clock",
    );
    fails(
        "bad-sample-point",
        "duration = \"1ms\"\n[bus]\nbitrate = 500000\nsample_point = 120\n[[node]]\nname = \"a\"\n",
        &[],
        &[],
        "FILE/bad.toml:4:16: sample point 120 is out of range",
    );
    fails(
        "half-btr",
        "duration = \"1ms\"\n[bus]\nbtr0 = 0\n[[node]]\nname = \"a\"\n",
        &[],
        &[],
        "FILE/bad.toml:3:8: btr0 and btr1 go together",
    );
}

#[test]
fn unknown_or_unusable_node_names() {
    fails(
        "unknown-node",
        &format!("{HEADER}[[frame]]\nnode = \"z\"\nat = \"1us\"\nframe = \"123#00\"\n"),
        &[],
        &[],
        "FILE/bad.toml:7:8: unknown node \"z\" (the nodes are: a)",
    );
    fails(
        "twice",
        &format!("{HEADER}[[node]]\nname = \"a\"\n"),
        &[],
        &[],
        "FILE/bad.toml:7:8: two nodes are called \"a\"",
    );
    fails(
        "listen-only-sender",
        &format!(
            "{HEADER}mode = \"listen-only\"\n[[frame]]\nnode = \"a\"\nat = \"1us\"\nframe = \"123#00\"\n"
        ),
        &[],
        &[],
        "FILE/bad.toml:8:8: node \"a\" is listen-only: it cannot send",
    );
}

#[test]
fn bad_times_and_faults() {
    fails(
        "bad-unit",
        "duration = \"1 fortnight\"\n[bus]\nbitrate = 500000\n[[node]]\nname = \"a\"\n",
        &[],
        &[],
        "FILE/bad.toml:1:12: unknown unit \"fortnight\" in \"1 fortnight\"",
    );
    fails(
        "glitch-without-quanta",
        &format!("{HEADER}[[fault]]\nkind = \"glitch\"\nat = \"10us\"\n"),
        &[],
        &[],
        "FILE/bad.toml:6: a glitch needs quanta (its length)",
    );
    fails(
        "unknown-field",
        &format!("{HEADER}[[fault]]\nkind = \"flip\"\nframe = 1\nfield = \"payload\"\n"),
        &[],
        &[],
        "FILE/bad.toml:9:9: unknown variant `payload`, expected one of `sof`, `id`",
    );
    fails(
        "bad-until",
        HEADER,
        &[],
        &["--until", "5 parsecs"],
        "cansim: --until: unknown unit \"parsecs\"",
    );
}

#[test]
fn unreadable_logs_and_missing_files() {
    let replay = format!("{HEADER}[[replay]]\nnode = \"a\"\nfile = \"in.log\"\n");
    fails(
        "bad-log-line",
        &replay,
        &[("in.log", "(1.000000) can0 123#00\n(1.000100) can0 123#0G\n")],
        &[],
        "FILE/in.log:2: bad frame \"123#0G\": data \"0G\" is not hex",
    );
    fails(
        "log-line-without-timestamp",
        &replay,
        &[("in.log", "(1.000000) can0 123#00\n\ncan0 123#00\n")],
        &[],
        "FILE/in.log:3: expected \"(SECONDS.MICROS) INTERFACE FRAME\"",
    );
    fails(
        "missing-log",
        &replay,
        &[],
        &[],
        "FILE/bad.toml:8:8: cannot read the log FILE/in.log: No such file or directory",
    );
    let o = cansim(&["run", "/nonexistent/scenario.toml"]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("/nonexistent/scenario.toml: cannot read the scenario"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn an_error_while_running_leaves_no_half_written_output() {
    fails(
        "runtime",
        &format!(
            "{HEADER}[[node]]\nname = \"b\"\n[[frame]]\nnode = \"a\"\nat = \"100us\"\nframe = \"123#01\"\n\
             [[fault]]\nkind = \"flip\"\nframe = 1\nfield = \"data\"\nbit = 40\n"
        ),
        &[],
        &[],
        "FILE/bad.toml:12: frame 1 on the bus: it is 123#01 and has no data bit 40",
    );
}

#[test]
fn a_scenario_runs_and_writes_its_log_and_waves_without_a_progress_bar_when_piped() {
    let dir = scratch("run", "replay");
    let (vcd, log) = (dir.join("w").join("replay.vcd"), dir.join("replay.log"));
    let o = cansim(&[
        "run",
        &example("replay.toml"),
        "--vcd",
        vcd.to_str().unwrap(),
        "--log",
        log.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stderr).is_empty(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    for expected in [
        "bus: 6 frames, 0 error frames, 0 overload frames",
        "logger     0         6",
        &format!("wrote {}", log.display()),
        &format!("gtkwave {}", vcd.display()),
    ] {
        assert!(out.contains(expected), "missing {expected:?} in\n{out}");
    }
    assert!(
        !out.contains("can0 123#DEADBEEF"),
        "the log went to its file"
    );
    let log_text = std::fs::read_to_string(&log).unwrap();
    assert_eq!(log_text.lines().count(), 6);
    assert!(log_text.contains(") can0 18DAF110#R8\n"));
    assert!(std::fs::metadata(&vcd).unwrap().len() > 1000);
    // The GTKWave view and its filters are beside the VCD.
    let waves = dir.join("w");
    assert!(out.contains(&format!(
        "gtkwave {} {}",
        vcd.display(),
        waves.join("replay.gtkw").display()
    )));
    let view = std::fs::read_to_string(waves.join("replay.gtkw")).unwrap();
    assert!(view.contains(&format!("^2 {}\n", waves.join("state.filter").display())));
    assert!(view.contains("-logger\n"));
    let frames = std::fs::read_to_string(waves.join("replay.frames.filter")).unwrap();
    assert!(frames.contains("\n0001 1: 123#DEADBEEF\n"), "{frames}");
    assert!(std::fs::read_to_string(waves.join("state.filter"))
        .unwrap()
        .contains("04 ErrorFlag"));
    // Without --log the log goes to stdout; --until cuts the run short.
    let o = cansim(&["run", &example("replay.toml"), "--until", "0.5ms"]);
    let out = text(&o.stdout);
    assert!(out.contains(") can0 123#DEADBEEF\n"), "{out}");
    assert!(out.contains("simulated 0.500 ms"), "{out}");
    assert!(!out.contains("0C4#"), "{out}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn traffic_the_bus_cannot_carry_is_refused_up_front() {
    // 123#1122334455667788 without stuff bits is 108 bits (ISO 11898-1 10.4.2: SOF, 11 identifier
    // bits, RTR, IDE, r0, 4 DLC bits, 64 data bits, 15 CRC bits, CRC and ACK delimiters, ACK slot,
    // 7 EOF bits) plus the 3-bit intermission: 111 bits, 222 us at 500 kbit/s.
    fails(
        "period-shorter-than-the-frame",
        &format!(
            "{HEADER}[[periodic]]\nnode = \"a\"\nframe = \"123#1122334455667788\"\nperiod = \"1ns\"\n"
        ),
        &[],
        &[],
        "FILE/bad.toml:9:10: period \"1ns\" is shorter than 123#1122334455667788 takes on the bus \
         (111 bits with the intermission, 222.0 us at node a's bit rate)",
    );
    fails(
        "empty-transmit-queue",
        &format!("{HEADER}txqueuelen = 0\n"),
        &[],
        &[],
        "FILE/bad.toml:6:14: txqueuelen 0 is out of range 1..=100000",
    );
}

/// The summary row of node `name`: its columns after the name.
fn summary_row<'a>(out: &'a str, name: &str) -> Vec<&'a str> {
    let row = out
        .lines()
        .find(|l| l.split_whitespace().next() == Some(name) && l.contains("error"))
        .unwrap_or_else(|| panic!("no summary row for {name} in\n{out}"));
    row.split_whitespace().skip(1).collect()
}

#[test]
fn a_hundred_million_frame_scenario_keeps_a_bounded_queue_and_little_memory() {
    // Node a has a frame due every 111 us (two messages of 222 us each, 100 million of each), twice
    // what the bus can carry: its queue holds 4 frames (txqueuelen), the later messages wait, and
    // those still waiting at the end are counted as dropped. Nothing is made before it is due.
    let dir = scratch("run", "hundred-million");
    let file = dir.join("flood.toml");
    std::fs::write(
        &file,
        "duration = \"20ms\"\n[bus]\nbitrate = 500000\n\
         [[node]]\nname = \"a\"\ntxqueuelen = 4\n[[node]]\nname = \"b\"\n\
         [[periodic]]\nnode = \"a\"\nframe = \"123#1122334455667788\"\nperiod = \"222us\"\ncount = 100000000\n\
         [[periodic]]\nnode = \"a\"\nframe = \"124#1122334455667788\"\nperiod = \"222us\"\nstart = \"111us\"\ncount = 100000000\n",
    )
    .unwrap();
    let o = cansim(&["run", file.to_str().unwrap(), "--quiet"]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let a = summary_row(&out, "a");
    let (sent, dropped, unsent): (usize, usize, usize) = (
        a[0].parse().unwrap(),
        a[2].parse().unwrap(),
        a[3].parse().unwrap(),
    );
    // Releases at 0, 222, ..., 19 980 us (91) and at 111, ..., 19 869 us (90); about 87 frames fit
    // on the bus in 20 ms (each about 230 us with its stuff bits and intermission).
    assert!((80..=90).contains(&sent), "sent {sent}\n{out}");
    assert_eq!(sent + dropped + unsent, 181, "{out}");
    assert!(
        unsent <= 5,
        "4 queued and one in flight at most: {unsent}\n{out}"
    );
    let peak: u64 = out
        .split("peak memory ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|mb| mb.parse().ok())
        .unwrap_or_else(|| panic!("no peak memory in\n{out}"));
    assert!(peak < 100, "peak memory {peak} MB\n{out}");
    std::fs::remove_dir_all(&dir).ok();
}
