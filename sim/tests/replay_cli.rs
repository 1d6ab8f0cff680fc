//! `cansim replay`: recordings of our own making, resampled as a logic analyzer would record the
//! bus (4 MHz and 1 MHz sampling, an edge jitter of one sample, a glitch), drive the bus; one
//! listen-only controller must receive every frame with RXERR 0, and the software decoder must
//! agree (`--compare`). The glitch cases follow ISO 11898-1: a dominant glitch over the sample
//! point of the CRC delimiter, a fixed-form bit, is a form error (10.9.4; the SJA1000 captures it
//! as ECC form error, receiving, segment CRC delimiter 11000); one on the idle bus shorter than the
//! sample point is a hard synchronisation whose bit samples recessive, so no start of frame
//! (10.4.2.1, 11.3.2.1). A listen-only SJA1000 keeps its error counters (data sheet, MOD.LOM).

mod common;

use std::path::Path;

use common::{cansim, scratch, text};
use golden::frame::{encode, Field, Frame};
use sim::decode::vcd_reader::SignalReader;
use sim::engine::time::{FS_PER_NS, FS_PER_US};
use sim::scenario::candump::parse_frame;
use sim::scenario::{parse, run, RunOptions};

/// The frames of the recordings: standard, extended, remote, no data, the most stuff bits.
const FRAMES: [&str; 6] = [
    "123#DEADBEEF",
    "1ABCDE01#0011223344556677",
    "7FF#R2",
    "000#",
    "555#FFFFFFFF00000000",
    "18FEF100#AA",
];
/// Time between two frames.
const GAP_US: u64 = 400;

/// Runs two nodes at `bitrate`, `a` sending [`FRAMES`] (`b` acknowledges, its clock 300 ppm off),
/// with a VCD; the bus level changes and each frame's start of frame.
fn record(dir: &Path, bitrate: u32) -> (Vec<(u64, bool)>, Vec<u64>) {
    let mut text = format!(
        "duration = \"{}us\"\n[bus]\nbitrate = {bitrate}\n[[node]]\nname = \"a\"\n\
         [[node]]\nname = \"b\"\nppm = 300\n",
        (FRAMES.len() as u64 + 2) * GAP_US * 500_000 / u64::from(bitrate)
    );
    for (k, frame) in FRAMES.iter().enumerate() {
        let at = (k as u64 + 1) * GAP_US * 500_000 / u64::from(bitrate);
        text += &format!("[[frame]]\nnode = \"a\"\nat = \"{at}us\"\nframe = \"{frame}\"\n");
    }
    let scenario = parse(&text, &dir.join("source.toml")).unwrap();
    let vcd = dir.join("source.vcd");
    let report = run(
        &scenario,
        RunOptions {
            vcd: Some(vcd.clone()),
            ..RunOptions::default()
        },
    )
    .unwrap();
    assert_eq!(report.log.len(), FRAMES.len(), "{}", report.log_text());
    let mut reader = SignalReader::open(&vcd, "top.bus").unwrap();
    let mut edges = Vec::new();
    while let Some(value) = reader.next_value().unwrap() {
        edges.push(value);
    }
    let starts = report.log.iter().map(|e| e.start_fs).collect();
    (edges, starts)
}

/// The bus level just after time `t` (`true`: recessive).
fn level_at(edges: &[(u64, bool)], t: u64) -> bool {
    let k = edges.partition_point(|&(at, _)| at <= t);
    k.checked_sub(1).is_none_or(|k| edges[k].1)
}

/// The bus as a logic analyzer sampling every `period_fs` (from an arbitrary phase) records it:
/// the changes, at sample times.
fn resample(edges: &[(u64, bool)], period_fs: u64) -> Vec<(u64, bool)> {
    let end = edges.last().unwrap().0 + 10 * FS_PER_US;
    let phase = period_fs * 3 / 7;
    let mut out = vec![(0, true)];
    let mut t = phase;
    while t < end {
        let level = level_at(edges, t);
        if level != out.last().unwrap().1 {
            out.push((t, level));
        }
        t += period_fs;
    }
    out
}

/// Moves every change by -1, 0 or +1 sample (a fixed pseudo-random sequence), keeping their order.
fn jitter(changes: &[(u64, bool)], period_fs: u64) -> Vec<(u64, bool)> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut out: Vec<(u64, bool)> = Vec::new();
    for &(t, level) in changes {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let moved = match state % 3 {
            0 => t.saturating_sub(period_fs),
            1 => t,
            _ => t + period_fs,
        };
        let after_previous = out.last().map_or(0, |&(at, _)| at + period_fs);
        out.push((moved.max(after_previous), level));
    }
    out
}

/// Adds a dominant pulse over `from_fs..to_fs` to recessive `changes`.
fn glitch(changes: &[(u64, bool)], from_fs: u64, to_fs: u64) -> Vec<(u64, bool)> {
    assert!(
        level_at(changes, from_fs) && level_at(changes, to_fs),
        "a recessive stretch"
    );
    let mut out: Vec<(u64, bool)> = changes
        .iter()
        .copied()
        .filter(|&(t, _)| t < from_fs)
        .collect();
    out.extend([(from_fs, false), (to_fs, true)]);
    out.extend(changes.iter().copied().filter(|&(t, _)| t > to_fs));
    out
}

/// Writes `changes` as the logic analyzer's VCD: channel `CAN_RX` in scope `la`, 1 ns units,
/// ending 100 us after the last change (where the capture stopped).
fn write_capture(path: &Path, changes: &[(u64, bool)]) {
    let mut vcd = String::from(
        "$timescale 1 ns $end\n$scope module la $end\n$var wire 1 ! CAN_RX $end\n$upscope $end\n\
         $enddefinitions $end\n",
    );
    for &(t, level) in changes {
        vcd += &format!("#{}\n{}!\n", t / FS_PER_NS, if level { '1' } else { '0' });
    }
    let end = changes.last().map_or(0, |&(t, _)| t) + 100 * FS_PER_US;
    vcd += &format!("#{}\n", end / FS_PER_NS);
    std::fs::write(path, vcd).unwrap();
}

/// `cansim replay` on `capture` at `bitrate` and `sample_point` (percent) with `--compare`: its
/// output, after checking it ran and the software decoder agreed.
fn replay(capture: &Path, bitrate: u32, sample_point: f64) -> String {
    let o = cansim(&[
        "replay",
        capture.to_str().unwrap(),
        "--signal",
        "CAN_RX",
        "--bitrate",
        &bitrate.to_string(),
        "--sample-point",
        &sample_point.to_string(),
        "--compare",
    ]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{out}{}", text(&o.stderr));
    out
}

/// The frames of the candump lines of `out`.
fn received(out: &str) -> Vec<Frame> {
    out.lines()
        .filter_map(|l| l.split_once(") can0 "))
        .map(|(_, frame)| parse_frame(frame).unwrap())
        .collect()
}

fn frames(texts: &[&str]) -> Vec<Frame> {
    texts.iter().map(|t| parse_frame(t).unwrap()).collect()
}

/// A sampled edge is up to one sample late, so a bit may look up to one sample shorter (and the
/// receiver's ACK is early by its own clock's drift): 8 samples per bit with the sample point at
/// 75 % keep two samples of margin before the bit's end. At 87.5 % only one is left, and whether a
/// bit that looks one sample short is read correctly depends on where in its time quantum each
/// receiver saw the edge before it (the controller and the software decoder may then differ).
const SAMPLED_SAMPLE_POINT: f64 = 75.0;

#[test]
fn every_frame_of_a_4_mhz_and_a_1_mhz_recording_is_received_with_rxerr_0() {
    let dir = scratch("replay", "sampled");
    for (bitrate, sample_ns) in [(500_000, 250), (125_000, 1000)] {
        let (edges, _) = record(&dir, bitrate);
        let capture = dir.join(format!("la-{bitrate}.vcd"));
        write_capture(&capture, &resample(&edges, sample_ns * FS_PER_NS));
        let out = replay(&capture, bitrate, SAMPLED_SAMPLE_POINT);
        assert_eq!(received(&out), frames(&FRAMES), "{bitrate}: {out}");
        assert!(
            out.contains("6 frames received; RXERR 0, TXERR 0; 0 bus errors"),
            "{out}"
        );
        assert!(
            out.contains("compare: the software decoder finds the same 6 frames"),
            "{out}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn edges_jittered_by_one_sample_still_give_every_frame() {
    // 250 kbit/s at 16 MHz: 16 quanta of 250 ns, one sample of a 4 MHz analyzer each. Two edges
    // moved apart by one sample each make a bit 2 samples (1/8 bit) shorter or longer; the sample
    // point at 75 % leaves 4 samples of margin.
    let dir = scratch("replay", "jitter");
    let (edges, _) = record(&dir, 250_000);
    let period = 250 * FS_PER_NS;
    let capture = dir.join("jitter.vcd");
    write_capture(&capture, &jitter(&resample(&edges, period), period));
    let out = replay(&capture, 250_000, SAMPLED_SAMPLE_POINT);
    assert_eq!(received(&out), frames(&FRAMES), "{out}");
    assert!(out.contains("RXERR 0, TXERR 0; 0 bus errors"), "{out}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_glitch_on_the_crc_delimiter_is_a_form_error_and_one_on_the_idle_bus_is_nothing() {
    let dir = scratch("replay", "glitch");
    let (edges, starts) = record(&dir, 500_000);
    let bit = 2 * FS_PER_US;
    let sample_point = bit * 7 / 8; // 87.5 %
    let period = 250 * FS_PER_NS;
    let sampled = resample(&edges, period);
    // Frame 2 (1ABCDE01#...): its CRC delimiter as the analyzer recorded it (from its start of
    // frame, the recessive stretch around the nominal sample point, up to the receiver's ACK) is
    // dominant from a quarter bit on to one sample before the ACK: over every sample point a
    // receiver can have there.
    let second = parse_frame(FRAMES[1]).unwrap();
    let delimiter = encode(&second).position(Field::CrcDelim, 0).unwrap() as u64;
    let sof = sampled
        .iter()
        .find(|&&(t, level)| t + bit >= starts[1] && !level)
        .unwrap()
        .0;
    let nominal = sof + delimiter * bit + sample_point;
    let begin = sampled.iter().rev().find(|&&(t, _)| t <= nominal).unwrap();
    let ack = sampled.iter().find(|&&(t, _)| t > nominal).unwrap();
    assert!(
        begin.1 && !ack.1,
        "a recessive delimiter, then the dominant ACK slot"
    );
    let with_glitch = glitch(&sampled, begin.0 + bit / 4, ack.0 - period);
    // And two samples (a quarter bit) dominant on the idle bus, 100 us before frame 4.
    let idle = starts[3] - 100 * FS_PER_US;
    let capture = dir.join("glitch.vcd");
    write_capture(&capture, &glitch(&with_glitch, idle, idle + 2 * period));
    let out = replay(&capture, 500_000, 87.5);
    let mut expected = FRAMES.to_vec();
    expected.remove(1);
    assert_eq!(received(&out), frames(&expected), "{out}");
    assert!(
        out.contains("5 frames received; RXERR 0, TXERR 0; 1 bus errors"),
        "{out}"
    );
    assert!(
        out.contains("ECC 0x78: form error, receiving, CRC delimiter; RXERR 0"),
        "{out}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_sigrok_session_is_read_through_sigrok_cli() {
    let dir = scratch("replay", "sigrok");
    let (edges, _) = record(&dir, 500_000);
    let vcd = dir.join("la.vcd");
    write_capture(&vcd, &resample(&edges, 250 * FS_PER_NS));
    let session = dir.join("la.sr");
    let status = std::process::Command::new("sigrok-cli")
        .arg("-I")
        .arg("vcd")
        .arg("-i")
        .arg(&vcd)
        .arg("-o")
        .arg(&session)
        .status()
        .expect("sigrok-cli is installed (make tools)");
    assert!(status.success());
    let out = replay(&session, 500_000, 87.5);
    assert_eq!(received(&out), frames(&FRAMES), "{out}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_captures_and_options_are_clear_errors() {
    let dir = scratch("replay", "bad");
    let missing = dir.join("missing.vcd");
    let vcd = dir.join("la.vcd");
    write_capture(&vcd, &[(0, true)]);
    let session = dir.join("junk.sr");
    std::fs::write(&session, "not a session").unwrap();
    for (args, expected) in [
        (
            vec![missing.to_str().unwrap(), "--bitrate", "500000"],
            "cannot open",
        ),
        (
            vec![vcd.to_str().unwrap(), "--bitrate", "500000"],
            "no signal `bus`",
        ),
        (
            vec![
                vcd.to_str().unwrap(),
                "--signal",
                "CAN_RX",
                "--bitrate",
                "7",
            ],
            "impossible bit timing",
        ),
        (
            vec![vcd.to_str().unwrap(), "--signal", "CAN_RX"],
            "--bitrate",
        ),
        (
            vec![session.to_str().unwrap(), "--bitrate", "500000"],
            "sigrok-cli could not read it",
        ),
    ] {
        let mut all = vec!["replay"];
        all.extend(args);
        let o = cansim(&all);
        assert!(!o.status.success(), "{all:?}");
        assert!(
            text(&o.stderr).contains(expected),
            "{all:?}: {}",
            text(&o.stderr)
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn scenario_nodes_receive_and_answer_a_recorded_bus() {
    // `[bus] recording`: the capture drives the bus; r receives (and acknowledges, on top of the
    // recorded ACK); t sends its own frame in a gap between two recorded ones.
    let dir = scratch("replay", "scenario");
    let (edges, _) = record(&dir, 500_000);
    write_capture(&dir.join("la.vcd"), &resample(&edges, 250 * FS_PER_NS));
    let text = "duration = \"3.2ms\"\n[bus]\nbitrate = 500000\nrecording = \"la.vcd\"\n\
                signal = \"CAN_RX\"\n[[node]]\nname = \"r\"\n[[node]]\nname = \"t\"\n\
                [[frame]]\nnode = \"t\"\nat = \"600us\"\nframe = \"0F0#0102\"\n";
    let scenario = parse(text, &dir.join("recorded.toml")).unwrap();
    let report = run(&scenario, RunOptions::default()).unwrap();
    let log: Vec<String> = report.log.iter().map(|e| e.to_string()).collect();
    let mut expected: Vec<&str> = FRAMES.to_vec();
    expected.insert(1, "0F0#0102");
    let on_bus: Vec<String> = log
        .iter()
        .map(|line| line.split_once(") can0 ").unwrap().1.to_string())
        .collect();
    assert_eq!(on_bus, expected, "{log:?}");
    let r = report.nodes.iter().find(|n| n.name == "r").unwrap();
    assert_eq!(r.received, frames(&expected));
    assert_eq!((r.rec, r.tec), (0, 0));
    let t = report.nodes.iter().find(|n| n.name == "t").unwrap();
    assert_eq!((t.sent, t.tec), (1, 0));
    // A recording that is not there, or has no such signal, is refused with the key's line.
    for (recording, expected) in [
        ("nowhere.vcd", "recorded.toml:4:13: recording: "),
        (
            "la.vcd\"\nsignal = \"CAN_TX",
            "recorded.toml:4:13: recording: ",
        ),
    ] {
        let text = text.replace("la.vcd\"\nsignal = \"CAN_RX", recording);
        let e = parse(&text, &dir.join("recorded.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(expected), "{e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_minute_of_idle_bus_is_shortened_but_the_times_stay_the_capture_s() {
    // The last three frames come a minute later. Stepping a 16 MHz controller through a minute
    // of idle bus would take about 20 minutes here; shortened, the replay takes a moment, and the
    // candump times are still the capture's.
    let dir = scratch("replay", "idle");
    let (edges, starts) = record(&dir, 500_000);
    let minute = 60 * 1_000_000 * FS_PER_US;
    let gap_from = starts[3] - 100 * FS_PER_US;
    let moved: Vec<(u64, bool)> = resample(&edges, 250 * FS_PER_NS)
        .into_iter()
        .map(|(t, level)| (if t > gap_from { t + minute } else { t }, level))
        .collect();
    let capture = dir.join("idle.vcd");
    write_capture(&capture, &moved);
    let out = replay(&capture, 500_000, 87.5);
    assert_eq!(received(&out), frames(&FRAMES), "{out}");
    let times: Vec<f64> = out
        .lines()
        .filter_map(|l| l.strip_prefix('(')?.split_once(')'))
        .map(|(t, _)| t.parse().unwrap())
        .collect();
    assert!(times[..3].iter().all(|&t| t < 0.01), "{times:?}");
    assert!(
        times[3..].iter().all(|&t| (60.0..60.01).contains(&t)),
        "{times:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
