//! Runs sigrok's CAN protocol decoder (`sigrok-cli`, an independent implementation) on a VCD and
//! collects the frames it decodes (with their sample ranges, [`decode_frames`]) and the warnings it
//! prints.
//!
//! Known limits of libsigrokdecode 0.5.3's `can` decoder, which the tests work around rather than
//! hide: it reads DLC data bytes after a *remote* frame's control field and maps DLC 9..15 to CAN FD
//! lengths, so remote frames with DLC > 0 and classic frames with DLC > 8 decode wrongly; it reads a
//! recessive r0 (r1 in extended frames) as CAN FD's FDF bit; it resynchronises fully on every falling
//! edge, even after a dominant bit, so a recessive glitch early in a dominant bit or a phase error
//! beyond the SJW shifts its sample points; it starts a decode at any dominant level on the idle bus
//! (a glitch too) and detects no error, so it reads error and overload flags as frame bits; after an
//! error flag that begins in the end of frame it takes the flag's last dominant bits for a new start of
//! frame, so the frame after such an error frame decodes as garbage.

use std::path::Path;
use std::process::Command;

/// Environment variable that lets a developer without sigrok-cli skip the sigrok checks (CI never sets
/// it; `make tools` installs sigrok-cli).
pub const SKIP_ENV: &str = "CANSIM_SKIP_SIGROK";

/// What sigrok decoded.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct SigrokDecode {
    /// Frames in candump notation (`123#DEADBEEF`, `1ABCDEF0#00`, `123#R`), in bus order.
    pub frames: Vec<String>,
    /// Lines of the decoder's warnings annotation class.
    pub warnings: Vec<String>,
}

/// One frame decode sigrok started. Its decoder starts at a dominant level while idle and reads a
/// whole frame's worth of bits without detecting any error, so error and overload flags also start
/// decodes, and a decode that reads through a flag lasts as long as its (garbage) header says.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SigrokFrame {
    /// Sample number of the start of its SOF bit (the VCD time in the file's time unit).
    pub start: u64,
    /// Sample number of the end of its EOF, if it got there.
    pub end: Option<u64>,
    /// The frame in candump notation, if the decode reached the ACK slot.
    pub frame: Option<String>,
}

/// Whether sigrok checks should be skipped (sigrok-cli missing and the developer opted out).
pub fn skipped() -> bool {
    std::env::var_os(SKIP_ENV).is_some()
}

fn run(
    vcd: &Path,
    signal: &str,
    bitrate: u32,
    sample_point: f64,
    class: &str,
    samples: bool,
) -> String {
    let decoder =
        format!("can:can_rx={signal}:nominal_bitrate={bitrate}:sample_point={sample_point}");
    let mut command = Command::new("sigrok-cli");
    command.args(["-I", "vcd", "-i"]).arg(vcd).args([
        "-P",
        &decoder,
        "-A",
        &format!("can={class}"),
    ]);
    if samples {
        command.arg("--protocol-decoder-samplenum");
    }
    let output = command.output().unwrap_or_else(|e| {
        panic!("cannot run sigrok-cli ({e}): install it with `make tools`, or set {SKIP_ENV}=1 to skip")
    });
    assert!(
        output.status.success(),
        "sigrok-cli failed on {}: {}",
        vcd.display(),
        String::from_utf8_lossy(&output.stderr)
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.trim().is_empty(),
        "sigrok-cli complained about {}: {stderr}",
        vcd.display()
    );
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// Decodes the CAN signal `signal` of `vcd`.
pub fn decode(vcd: &Path, signal: &str, bitrate: u32, sample_point_pct: f64) -> SigrokDecode {
    let warnings = run(vcd, signal, bitrate, sample_point_pct, "warnings", false)
        .lines()
        .map(str::to_string)
        .collect();
    SigrokDecode {
        frames: decode_frames(vcd, signal, bitrate, sample_point_pct)
            .into_iter()
            .filter_map(|d| d.frame)
            .collect(),
        warnings,
    }
}

/// Every decode sigrok starts on the CAN signal `signal` of `vcd`, with its sample range.
pub fn decode_frames(
    vcd: &Path,
    signal: &str,
    bitrate: u32,
    sample_point_pct: f64,
) -> Vec<SigrokFrame> {
    decodes_from_annotations(&run(vcd, signal, bitrate, sample_point_pct, "fields", true))
}

fn hex_value(line: &str) -> Option<u32> {
    let start = line.rfind("(0x")? + 3;
    u32::from_str_radix(line[start..].trim_end_matches(')'), 16).ok()
}

/// A decode being read from the annotations.
#[derive(Default)]
struct Partial {
    id: u32,
    extended: bool,
    remote: bool,
    data: String,
}

impl Partial {
    /// The frame in candump notation.
    fn frame(&self) -> String {
        let id = if self.extended {
            format!("{:08X}", self.id)
        } else {
            format!("{:03X}", self.id)
        };
        let body = if self.remote {
            "R".to_string()
        } else {
            self.data.to_uppercase()
        };
        format!("{id}#{body}")
    }
}

/// Rebuilds the decodes from sigrok's field annotations (`start-end can-1: text` lines).
fn decodes_from_annotations(text: &str) -> Vec<SigrokFrame> {
    let mut decodes: Vec<SigrokFrame> = Vec::new();
    let mut partial = Partial::default();
    for line in text.lines() {
        let (range, annotation) = line.split_once(" can-1: ").unwrap_or(("", line));
        let (start, end) = range.split_once('-').unwrap_or(("", ""));
        let (start, end) = (start.parse().ok(), end.parse().ok());
        if annotation.starts_with("Start of frame") {
            partial = Partial::default();
            decodes.push(SigrokFrame {
                start: start.unwrap_or(0),
                end: None,
                frame: None,
            });
        } else if annotation.starts_with("Identifier:") {
            partial.id = hex_value(annotation).unwrap_or(0);
        } else if annotation.starts_with("Full Identifier:") {
            (partial.id, partial.extended) = (hex_value(annotation).unwrap_or(0), true);
        } else if let Some(kind) = annotation.strip_prefix("Remote transmission request: ") {
            partial.remote = kind.starts_with("remote");
        } else if let Some(rest) = annotation.strip_prefix("Data byte ") {
            partial.data += rest.split("0x").nth(1).unwrap_or("??");
        } else if let Some(decode) = decodes.last_mut() {
            if annotation.starts_with("ACK slot") {
                decode.frame = Some(partial.frame());
            } else if annotation.starts_with("End of frame") {
                decode.end = end;
            }
        }
    }
    decodes
}
