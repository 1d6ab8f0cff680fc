//! CANopen devices of our stack on the simulated bus, mastered by an independent implementation:
//! python canopen 2.4.1 (from build/pyenv, made by `make pyenv`) over python-can's socketcand
//! interface and `cansim serve examples/canopen_device.toml` (tests/python/canopen_master.py): NMT,
//! boot-up, heartbeat states, SDO expedited, segmented and block (with CRC) in both directions,
//! the abort codes, PDO mapping by SDO with its aborts, a TPDO on SYNC and an RPDO, the SYNC
//! producer with its counter, a heartbeat loss reported by EMCY 8130h and its error reset, the
//! resets; both read the same EDS (examples/eds/io.eds). Our master, scripted by a scenario,
//! against python canopen's LocalNode as the device. The CANopen example (examples/canopen.toml:
//! our master and two of our devices), a script whose steps do not get what they expect, node
//! guarding with our own nodes, the CANopen trace of `cansim decode`, and bad CANopen
//! configuration and scripts refused with their line.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use common::{cansim, example, python, scratch, text, ServeProcess};

#[test]
fn python_canopen_masters_our_device_through_the_registers() {
    let mut server = ServeProcess::start(&example("canopen_device.toml"), &[]);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/canopen_master.py");
    let o = Command::new(python())
        .arg(&script)
        .arg(server.port.to_string())
        .arg(example("eds/io.eds"))
        .output()
        .unwrap();
    let out = server.stop();
    assert!(
        o.status.success() && text(&o.stdout).ends_with("PASS\n"),
        "python canopen:\n{}{}\nserver:\n{out}",
        text(&o.stdout),
        text(&o.stderr)
    );
    assert!(out.contains(" 0 error frames"), "{out}");
}

#[test]
fn the_example_log_reads_like_a_canopen_trace_of_the_device_answering() {
    let o = cansim(&["run", &example("canopen_io.toml")]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        out.contains("io: 16 MHz +0 ppm, 0 ns from the bus, CANopen device 2 (io.eds)"),
        "{out}"
    );
    // The device's answers, as CiA 301 encodes them: boot-up (7.3.2.2.1); the download
    // confirmation 60h; the segmented upload of 13 bytes (41h, size 0Dh), its segments 00h and
    // 13h (toggle 1, 1 byte unused, last); the abort of 3000h with 0602 0000; the heartbeat with
    // the operational state after the NMT start; TPDO1 on every SYNC with 6000h:1 = 5Ah and
    // 2000h = 10 (little endian).
    for (line, meaning) in [
        ("702#00 ", "boot-up of node 2"),
        (
            "582#6017100000000000",
            "download 1017h:00 (Producer heartbeat time) confirmed",
        ),
        (
            "582#410810000D000000",
            "upload 1008h:00 (Manufacturer device name), segmented",
        ),
        ("582#0063616E73696D20", "upload segment"),
        ("582#13494F2038783800", "upload segment, last"),
        (
            "582#8000300000000206",
            "abort 3000h:00 (not in the EDS): 0602 0000",
        ),
        ("702#05 ", "heartbeat of node 2: operational"),
    ] {
        let found = out
            .lines()
            .any(|l| l.contains(line) && l.ends_with(meaning));
        assert!(found, "no {line} ; {meaning} in\n{out}");
    }
    let tpdos = out
        .lines()
        .filter(|l| l.contains(") can0 182#5A0A00 "))
        .count();
    assert_eq!(tpdos, 5, "one TPDO1 per SYNC\n{out}");
}

#[test]
fn cansim_decode_reads_canopen_traffic_with_the_eds() {
    let dir = scratch("canopen", "decode");
    let vcd = dir.join("io.vcd");
    let o = cansim(&[
        "run",
        &example("canopen_io.toml"),
        "--vcd",
        vcd.to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let eds = format!("2={}", example("eds/io.eds"));
    let o = cansim(&["decode", vcd.to_str().unwrap(), "--canopen", &eds]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        out.contains(") can0 702#00") && out.contains("; boot-up of node 2\n"),
        "{out}"
    );
    for (bad, expected) in [
        ("io.eds", "expected NODE=EDS"),
        ("200=io.eds", "node-ID 200 is out of range 1..=127"),
        ("2=missing.eds", "missing.eds: cannot read the EDS"),
    ] {
        let o = cansim(&["decode", vcd.to_str().unwrap(), "--canopen", bad]);
        assert!(!o.status.success(), "{bad}");
        assert!(
            text(&o.stderr).contains(expected),
            "{bad}: {}",
            text(&o.stderr)
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_canopen_nodes_are_refused_with_their_line() {
    let dir = scratch("canopen", "bad");
    let eds = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/eds/io.eds");
    std::fs::copy(&eds, dir.join("io.eds")).unwrap();
    std::fs::write(dir.join("bad.eds"), "[MandatoryObjects]\nSupportedObjects=1\n1=0x1000\n[1000]\nParameterName=x\nDataType=0x0007\nAccessType=rx\n").unwrap();
    let header = "duration = \"1ms\"\n[bus]\nbitrate = 500000\n[[node]]\nname = \"a\"\n";
    for (node, expected) in [
        ("canopen = { node_id = 0, eds = \"io.eds\" }", "bad.toml:6:23: node-ID 0 is out of range 1..=127"),
        ("canopen = { node_id = 128, eds = \"io.eds\" }", "bad.toml:6:23: node-ID 128 is out of range 1..=127"),
        ("canopen = { node_id = 2, eds = \"missing.eds\" }", "bad.toml:6:32: EDS: "),
        ("canopen = { node_id = 2, eds = \"bad.eds\" }", "bad.eds:7: AccessType 'rx' is not"),
        ("mode = \"listen-only\"\ncanopen = { node_id = 2, eds = \"io.eds\" }", "it cannot be listen-only"),
        ("canopen = { node_id = 2, eds = \"io.eds\" }\n[[node]]\nname = \"b\"\ncanopen = { node_id = 2, eds = \"io.eds\" }", "node-ID 2 is node \"a\"'s already"),
    ] {
        let file = dir.join("bad.toml");
        std::fs::write(&file, format!("{header}{node}\n")).unwrap();
        let o = cansim(&["run", file.to_str().unwrap()]);
        assert!(!o.status.success(), "{node}");
        assert!(text(&o.stderr).contains(expected), "{node}: {}", text(&o.stderr));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn node_guarding_answers_with_a_toggle_and_a_silent_master_is_a_life_guarding_event() {
    // CiA 301 7.2.8.3.1 with our own nodes (socketcand carries no remote frames from python-can):
    // the master's remote frames on 702h are answered with the state (7Fh pre-operational) and a
    // toggle bit that starts at 0; with guard time 10 ms x life time factor 3, no request for
    // 30 ms after the last one is EMCY 8130h (error register 11h), and the next request ends it
    // (EMCY 0000h).
    let dir = scratch("canopen", "guard");
    let eds = std::fs::read_to_string(example("eds/io.eds")).unwrap();
    let guarded = eds
        .replace("ParameterName=Guard time\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=0", "ParameterName=Guard time\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=10")
        .replace("ParameterName=Life time factor\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=0", "ParameterName=Life time factor\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\nDefaultValue=3");
    assert_ne!(guarded, eds);
    std::fs::write(dir.join("io.eds"), guarded).unwrap();
    let scenario = dir.join("guard.toml");
    std::fs::write(
        &scenario,
        "duration = \"60ms\"\n[bus]\nbitrate = 500000\n\
         [[node]]\nname = \"io\"\ncanopen = { node_id = 2, eds = \"io.eds\" }\n\
         [[node]]\nname = \"master\"\n\
         [[frame]]\nnode = \"master\"\nat = \"1ms\"\nframe = \"702#R1\"\n\
         [[frame]]\nnode = \"master\"\nat = \"2ms\"\nframe = \"702#R1\"\n\
         [[frame]]\nnode = \"master\"\nat = \"50ms\"\nframe = \"702#R1\"\n",
    )
    .unwrap();
    let o = cansim(&["run", scenario.to_str().unwrap()]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let frames: Vec<&str> = out
        .lines()
        .filter_map(|l| l.split_once(") can0 "))
        .map(|(_, rest)| rest.split_whitespace().next().unwrap())
        .collect();
    assert_eq!(
        frames,
        [
            "702#00",
            "702#R1",
            "702#7F",
            "702#R1",
            "702#FF",
            "082#3081110000000000",
            "702#R1",
            "702#7F",
            "082#0000000000000000"
        ],
        "{out}"
    );
    let at = |frame: &str| -> f64 {
        let line = out.lines().find(|l| l.contains(frame)).unwrap();
        line[1..line.find(')').unwrap()].parse().unwrap()
    };
    let lost = at("082#3081");
    assert!(
        (0.032..0.0325).contains(&lost),
        "30 ms after the request at 2 ms: {lost}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn our_master_works_against_python_canopens_local_node() {
    // The independent device: python canopen's LocalNode (node 5, the same EDS), reached through
    // `cansim serve`; our master runs the script of a scenario, every step judged by what it
    // expects (CiA 301 encodings of the values in the EDS): boot-up, SDO segmented upload and
    // download, expedited upload and download, an abort for an object that does not exist
    // (0602 0000, Table 22), NMT start and the heartbeat that shows it.
    let dir = scratch("canopen", "local-node");
    std::fs::copy(example("eds/io.eds"), dir.join("io.eds")).unwrap();
    let scenario = dir.join("master.toml");
    std::fs::write(
        &scenario,
        r#"duration = "1s"
[bus]
bitrate = 500000
[[node]]
name = "master"
canopen_master = { node_id = 1, sdo_timeout = "5s", remote = [{ node_id = 5, eds = "io.eds" }] }
[[master]]
await = "boot-up"
node = 5
[[master]]
read = "1008:00"
node = 5
expect = "cansim IO 8x8"
[[master]]
write = "1017:00"
node = 5
value = 300
[[master]]
read = "1017:00"
node = 5
expect = 300
[[master]]
write = "2001:00"
node = 5
value = "written by our CANopen master"
[[master]]
read = "2001:00"
node = 5
expect = "written by our CANopen master"
[[master]]
read = "3000:00"
node = 5
expect_abort = "0602 0000"
[[master]]
nmt = "start"
node = 5
[[master]]
await = "operational"
node = 5
"#,
    )
    .unwrap();
    let mut server = ServeProcess::start(scenario.to_str().unwrap(), &[]);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/canopen_local_node.py");
    let mut local = Command::new(python())
        .arg(&script)
        .arg(server.port.to_string())
        .arg(example("eds/io.eds"))
        .arg("5")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut ready = String::new();
    BufReader::new(local.stdout.take().unwrap())
        .read_line(&mut ready)
        .unwrap();
    assert_eq!(ready, "READY\n");
    let done = server.wait_for("await node 5 operational", Duration::from_secs(60));
    drop(local.stdin.take());
    local.wait().unwrap();
    let out = server.stop();
    assert!(done, "the script did not end:\n{out}");
    for line in [
        "line 7: await node 5 boot-up: seen",
        "line 10: read 1008h:00 (Manufacturer device name) of node 5 = \"cansim IO 8x8\"",
        "line 14: write 1017h:00 (Producer heartbeat time) of node 5: done",
        "line 18: read 1017h:00 (Producer heartbeat time) of node 5 = 300",
        "line 22: write 2001h:00 (Label) of node 5: done",
        "line 26: read 2001h:00 (Label) of node 5 = \"written by our CANopen master\"",
        "line 30: read 3000h:00 of node 5: abort 0602 0000 (object does not exist in the object \
         dictionary), as expected",
        "line 34: NMT Start to node 5: done",
        "node 5: heartbeat, operational",
        "line 37: await node 5 operational: seen",
    ] {
        assert!(out.contains(line), "no {line:?} in\n{out}");
    }
    assert!(!out.contains("FAILED"), "{out}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The time of the first log line containing `needle`, in seconds.
fn time_of(out: &str, needle: &str) -> f64 {
    let line = out
        .lines()
        .find(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("no {needle} in\n{out}"));
    line[1..line.find(')').unwrap()].parse().unwrap()
}

#[test]
fn the_canopen_example_runs_its_script_on_the_real_stack() {
    let o = cansim(&["run", &example("canopen.toml")]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{out}{}", text(&o.stderr));
    assert!(!out.contains("FAILED"), "{out}");
    // Frames as CiA 301 encodes them: the NMT start for all nodes (7.2.8.3.1.1: 01h, node 0);
    // the block download of the 39-byte label (7.2.4.3.9: C6h = ccs 6, cc, s; size 27h), its
    // sixth and last segment (86h) and the end with 3 unused bytes (CDh = C1h | 3 << 2) and the
    // CRC 564Dh, which is CRC-16/XMODEM of the label (python's binascii.crc_hqx(label, 0) gives
    // 0x564d); TPDO1 of the io module (6000h:01 = 5Ah, 2000h = 10) and of the drive (statusword
    // 0250h, position 0); the drive's RPDO1; EMCY 8130h with error register 11h (7.2.7.3.1,
    // Table 21/48); TIME 8 ms... after 2000-01-01 (day 16D4h).
    for frame in [
        "000#0100 ",
        "602#C601200027000000",
        "602#862E2E3820000000",
        "602#CD4D560000000000",
        "182#5A0A00 ",
        "183#500200000000",
        "203#0F00E8030000",
        "082#3081110000000000",
        "609#8000100000000405",
    ] {
        assert!(
            out.contains(&format!("can0 {frame}")),
            "no {frame} in\n{out}"
        );
    }
    for meaning in [
        "; SDO request to node 2: block download end: 3 bytes unused, CRC 564Dh",
        "; SDO response of node 2: block upload end: 3 bytes unused, CRC 564Dh",
        "; TPDO1 of node 3, Statusword = 592, Position actual value = 0",
        "; TIME 2000-01-01 00:00:00.0",
    ] {
        assert!(out.contains(meaning), "no {meaning} in\n{out}");
    }
    // The master's log: every step as it ended.
    for line in [
        "read 1008h:00 (Manufacturer device name) of node 2 = \"cansim IO 8x8\"",
        "block read 2001h:00 (Label) of node 2 = \"conveyor 3, left side: photo-eyes 1..8 \"",
        "read 607Ah:00 (Target position) of node 3 = 1000",
        "read 3000h:00 of node 2: abort 0602 0000",
        "write 2000h:00 (Input debounce time) of node 2: abort 0609 0031",
        "read 1000h:00 of node 9: abort 0504 0000 (SDO protocol timed out), as expected",
        "node 3: heartbeat lost",
        "await EMCY 8130h of node 2: seen",
    ] {
        assert!(out.contains(line), "no {line} in\n{out}");
    }
    // TPDO2 of the io module every 5 ms (event timer 1801h:05, 7.5.2.35).
    let tpdo2: Vec<f64> = out
        .lines()
        .filter(|l| l.contains(" can0 282#5A "))
        .map(|l| l[1..l.find(')').unwrap()].parse().unwrap())
        .collect();
    assert!(tpdo2.len() >= 5, "{out}");
    for pair in tpdo2.windows(2) {
        let gap = pair[1] - pair[0];
        assert!((0.0049..0.0051).contains(&gap), "TPDO2 gap {gap}");
    }
    // Heartbeat consumers (CiA 301 7.2.8.3.2.2): the master calls the drive lost 25 ms (its
    // consumer time) after the drive's last heartbeat; the io module sends EMCY 8130h 30 ms
    // (1016h:01) after the master's last heartbeat.
    let last = |id: &str, before: f64| -> f64 {
        let times = out
            .lines()
            .filter(|l| l.contains(&format!(" can0 {id} ")))
            .map(|l| l[1..l.find(')').unwrap()].parse::<f64>().unwrap());
        times.filter(|&t| t < before).fold(0.0, f64::max)
    };
    let lost_line = out
        .lines()
        .find(|l| l.contains("node 3: heartbeat lost"))
        .unwrap();
    let lost: f64 = lost_line
        .split_whitespace()
        .next()
        .unwrap()
        .parse::<f64>()
        .unwrap()
        / 1e3;
    let after = lost - last("703#05", lost);
    assert!(
        (0.025..0.0255).contains(&after),
        "lost {after} s after the last heartbeat"
    );
    let emcy = time_of(&out, "082#3081110000000000");
    let after = emcy - last("701#05", emcy);
    assert!(
        (0.030..0.0305).contains(&after),
        "EMCY {after} s after the last heartbeat"
    );
}

#[test]
fn a_step_that_does_not_get_what_it_expects_fails_the_run_with_its_line() {
    let dir = scratch("canopen", "failing");
    std::fs::copy(example("eds/io.eds"), dir.join("io.eds")).unwrap();
    let scenario = dir.join("failing.toml");
    std::fs::write(
        &scenario,
        r#"duration = "8ms"
[bus]
bitrate = 500000
[[node]]
name = "master"
canopen_master = { node_id = 1 }
[[node]]
name = "io"
canopen = { node_id = 2, eds = "io.eds" }
[[master]]
read = "1008:00"
node = 2
expect = "another name"
[[master]]
read = "1017:00"
node = 2
expect = 0
[[master]]
write = "2001:00"
node = 2
value = "fine"
expect_abort = "0601 0002"
[[master]]
await = "operational"
node = 2
within = "1ms"
[[master]]
wait = "1s"
[[master]]
read = "1000:00"
node = 2
"#,
    )
    .unwrap();
    let o = cansim(&["run", scenario.to_str().unwrap()]);
    let out = text(&o.stdout);
    assert!(!o.status.success(), "{out}");
    assert!(
        text(&o.stderr).contains("failing.toml: 5 CANopen master step(s) failed"),
        "{}",
        text(&o.stderr)
    );
    for line in [
        "FAILED line 10: read 1008h:00 (Manufacturer device name) of node 2 = \"cansim IO 8x8\", \
         expected \"another name\"",
        "  line 14: read 1017h:00 (Producer heartbeat time) of node 2 = 0",
        "FAILED line 18: write 2001h:00 (Label) of node 2: done, expected abort 0601 0002",
        "FAILED line 23: await node 2 operational: not seen in time",
        "FAILED line 27: wait 1000 ms: not finished when the run ended",
        "FAILED line 29: read 1000h:00 (Device type) of node 2: not finished when the run ended",
    ] {
        assert!(out.contains(line), "no {line} in\n{out}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_master_scripts_are_refused_with_their_line() {
    let dir = scratch("canopen", "bad-script");
    std::fs::copy(example("eds/io.eds"), dir.join("io.eds")).unwrap();
    let header = "duration = \"1ms\"\n[bus]\nbitrate = 500000\n[[node]]\nname = \"io\"\n\
                  canopen = { node_id = 2, eds = \"io.eds\" }\n[[node]]\nname = \"m\"\n";
    let master = "canopen_master = { node_id = 1 }\n";
    for (text_, expected) in [
        (
            format!("{master}[[master]]\nread = \"3000:00\"\nnode = 2\n"),
            "bad.toml:11:8: 3000h:00 is not in node 2's dictionary",
        ),
        (
            format!("{master}[[master]]\nread = \"1008:00\"\nnode = 128\n"),
            "bad.toml:12:8: node-ID 128 is out of range 1..=127",
        ),
        (
            format!("{master}[[master]]\nread = \"1008:00\"\nnode = 0\n"),
            "bad.toml:12:8: node-ID 0 is out of range",
        ),
        (
            format!("{master}[[master]]\nwrite = \"1000:00\"\nnode = 9\nvalue = 1\n"),
            "bad.toml:13:9: the node's dictionary is not known here",
        ),
        (
            format!("{master}[[master]]\nwrite = \"1017:00\"\nnode = 2\nvalue = 70000\n"),
            "bad.toml:13:9: 70000 is not a value of the object's type Unsigned(2)",
        ),
        (
            format!("{master}[[master]]\nwrite = \"1017:00\"\nnode = 2\nvalue = \"ten\"\n"),
            "is not a value of the object's type",
        ),
        (
            format!("{master}[[master]]\nread = \"10x7:00\"\nnode = 2\n"),
            "bad.toml:11:8: \"10x7:00\" is not an object",
        ),
        (
            format!("{master}[[master]]\nread = \"1008:00\"\nsync = \"1ms\"\nnode = 2\n"),
            "bad.toml:10: a [[master]] step does exactly one of",
        ),
        (
            format!("{master}[[master]]\nsync = \"1ms\"\nnode = 2\n"),
            "bad.toml:12:8: node: only with",
        ),
        (
            format!("{master}[[master]]\nread = \"1008:00\"\n"),
            "bad.toml:10: this step needs node = <node-ID>",
        ),
        (
            format!("{master}[[master]]\nnmt = \"begin\"\nnode = 2\n"),
            "bad.toml:11:7: unknown variant `begin`",
        ),
        (
            format!("{master}[[master]]\nread = \"1008:00\"\nnode = 2\nexpect_abort = \"0602\"\n"),
            "is not an abort code",
        ),
        (
            format!("{master}[[master]]\nsend = \"18FEF100#00\"\n"),
            "CANopen frames have 11-bit identifiers",
        ),
        (
            format!("{master}[[master]]\nheartbeat = \"2.5ms\"\n"),
            "a heartbeat period is whole milliseconds",
        ),
        (
            "mode = \"normal\"\n[[master]]\nwait = \"1ms\"\n".to_string(),
            "[[master]] steps need a node with canopen_master",
        ),
        (
            "canopen_master = { node_id = 2 }\n".to_string(),
            "node-ID 2 is node \"io\"'s already",
        ),
        (
            "canopen_master = { node_id = 1, remote = [{ node_id = 2, eds = \"io.eds\" }] }\n"
                .to_string(),
            "node-ID 2 is known already",
        ),
        (
            "canopen_master = { node_id = 1, sdo_timeout = \"0ms\" }\n".to_string(),
            "bad.toml:9:47: a timeout of at least 1 us",
        ),
    ] {
        let file = dir.join("bad.toml");
        std::fs::write(&file, format!("{header}{text_}")).unwrap();
        let o = cansim(&["run", file.to_str().unwrap()]);
        assert!(!o.status.success(), "{text_}");
        assert!(
            text(&o.stderr).contains(expected),
            "{text_}: {}",
            text(&o.stderr)
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Our reading of entry `index`:`sub`, in the form of tests/python/eds_dump.py.
fn eds_line(index: u16, sub: u8, entry: &canopen::od::Entry) -> String {
    use canopen::od::{Access, DataType};
    let access = match entry.access {
        Access::ReadOnly => "ro",
        Access::WriteOnly => "wo",
        Access::ReadWrite => "rw",
        Access::Const => "const",
    };
    let default = match entry.data_type {
        DataType::VisibleString => String::from_utf8_lossy(&entry.value).into_owned(),
        t => t.number(&entry.value).map_or_else(
            || entry.value.iter().map(|b| format!("{b:02X}")).collect(),
            |n| n.to_string(),
        ),
    };
    format!(
        "{index:04X}:{sub:02X} type={:04X} access={access} mappable={} default={default} name={}",
        entry.data_type.index(),
        u8::from(entry.pdo_mappable),
        entry.name
    )
}

#[test]
fn python_canopen_reads_our_eds_files_as_we_do() {
    // CiA 306 read by an independent parser: every entry's data type, access, PDO mappability,
    // default value (with $NODEID resolved) and name must be the same in both.
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/eds_dump.py");
    for (eds, node_id) in [("eds/io.eds", 2u8), ("eds/drive.eds", 3)] {
        let o = Command::new(python())
            .arg(&script)
            .arg(example(eds))
            .arg(node_id.to_string())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o.stderr));
        let od = canopen::eds::load(Path::new(&example(eds)), node_id).unwrap();
        let mut ours: Vec<String> = od
            .objects
            .iter()
            .flat_map(|(index, object)| {
                object
                    .entries
                    .iter()
                    .map(|(sub, entry)| eds_line(*index, *sub, entry))
            })
            .collect();
        ours.sort();
        let theirs: Vec<String> = text(&o.stdout).lines().map(str::to_owned).collect();
        assert_eq!(ours, theirs, "{eds}");
    }
}
