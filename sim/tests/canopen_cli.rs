//! CANopen devices of our stack on the simulated bus, mastered by an independent implementation:
//! python canopen 2.4.1 (from build/pyenv, made by `make pyenv`) over python-can's socketcand
//! interface and `cansim serve examples/canopen_device.toml` (tests/python/canopen_master.py): NMT,
//! boot-up, heartbeat states, SDO expedited, segmented and block (with CRC) in both directions,
//! the abort codes, PDO mapping by SDO with its aborts, a TPDO on SYNC and an RPDO, the SYNC
//! producer with its counter, a heartbeat loss reported by EMCY 8130h and its error reset, the
//! resets; both read the same EDS (examples/eds/io.eds). Our SDO client against python canopen's
//! LocalNode as the server. Node guarding with our own nodes, the CANopen trace of `cansim
//! decode`, and bad CANopen configuration in a scenario refused with its line.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};

use canopen::sdo::Abort;
use canopen::sdo_client::{SdoClient, SdoOutcome};
use common::{cansim, example, python, scratch, text, Raw, ServeProcess};

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

/// Runs one transfer of `client` with the server of node 1 through `bus`: the outcome.
fn sdo_transfer(bus: &mut Raw, client: &mut SdoClient, first: [u8; 8]) -> SdoOutcome {
    let mut request = first;
    loop {
        bus.send_frame(0x601, &request);
        let answer = bus.frame_on(0x581);
        match client.response(&answer, 0) {
            Ok(next) => request = next,
            Err(outcome) => return outcome,
        }
    }
}

#[test]
fn our_sdo_client_works_against_python_canopens_local_node() {
    // The independent server: python canopen's LocalNode (node 1, the same EDS). Our client
    // (canopen::sdo_client) speaks to it over the simulated bus from a raw socketcand connection.
    let mut server = ServeProcess::start(&example("canopen_device.toml"), &[]);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/canopen_local_node.py");
    let mut local = Command::new(python())
        .arg(&script)
        .arg(server.port.to_string())
        .arg(example("eds/io.eds"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut ready = String::new();
    BufReader::new(local.stdout.take().unwrap())
        .read_line(&mut ready)
        .unwrap();
    assert_eq!(ready, "READY\n");
    let mut bus = Raw::raw_mode(server.port);
    let mut client = SdoClient::default();
    // Segmented upload of the device name, expedited download and upload of 1017h.
    let first = client.upload(0x1008, 0, 0);
    assert_eq!(
        sdo_transfer(&mut bus, &mut client, first),
        SdoOutcome::Uploaded(b"cansim IO 8x8".to_vec())
    );
    let first = client.download(0x1017, 0, &500u16.to_le_bytes(), 0);
    assert_eq!(
        sdo_transfer(&mut bus, &mut client, first),
        SdoOutcome::Downloaded
    );
    let first = client.upload(0x1017, 0, 0);
    assert_eq!(
        sdo_transfer(&mut bus, &mut client, first),
        SdoOutcome::Uploaded(vec![0xF4, 0x01])
    );
    // Segmented download of 26 bytes, read back segmented.
    let label = b"written by our SDO client!";
    let first = client.download(0x2001, 0, label, 0);
    assert_eq!(
        sdo_transfer(&mut bus, &mut client, first),
        SdoOutcome::Downloaded
    );
    let first = client.upload(0x2001, 0, 0);
    assert_eq!(
        sdo_transfer(&mut bus, &mut client, first),
        SdoOutcome::Uploaded(label.to_vec())
    );
    // The server's aborts reach the client: an object that does not exist (0602 0000).
    let first = client.upload(0x3000, 0, 0);
    assert_eq!(
        sdo_transfer(&mut bus, &mut client, first),
        SdoOutcome::Aborted(Abort(0x0602_0000))
    );
    drop(local.stdin.take());
    local.wait().unwrap();
    server.stop();
}
