//! Runs sigrok's CAN protocol decoder (`sigrok-cli`, an independent implementation) on a VCD and
//! collects the frames it decodes and the warnings it prints.
//!
//! Known limits of libsigrokdecode 0.5.3's `can` decoder, which the tests work around rather than
//! hide: it reads DLC data bytes after a *remote* frame's control field and maps DLC 9..15 to CAN FD
//! lengths, so remote frames with DLC > 0 and classic frames with DLC > 8 decode wrongly; and it
//! resynchronises on every falling edge, even after a dominant bit, so a recessive glitch early in a
//! dominant bit shifts its sample points; and after an error flag that begins in the end of frame
//! it takes the flag's last dominant bits for a new start of frame, so the frame after such an
//! error frame decodes as garbage.

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

/// Whether sigrok checks should be skipped (sigrok-cli missing and the developer opted out).
pub fn skipped() -> bool {
    std::env::var_os(SKIP_ENV).is_some()
}

fn run(vcd: &Path, signal: &str, bitrate: u32, sample_point: f64, class: &str) -> String {
    let decoder =
        format!("can:can_rx={signal}:nominal_bitrate={bitrate}:sample_point={sample_point}");
    let output = Command::new("sigrok-cli")
        .args(["-I", "vcd", "-i"])
        .arg(vcd)
        .args(["-P", &decoder, "-A", &format!("can={class}")])
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run sigrok-cli ({e}): install it with `make tools`, or set {SKIP_ENV}=1 to skip")
        });
    assert!(
        output.status.success(),
        "sigrok-cli failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.trim().is_empty(), "sigrok-cli complained: {stderr}");
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// Decodes the CAN signal `signal` of `vcd`.
pub fn decode(vcd: &Path, signal: &str, bitrate: u32, sample_point_pct: f64) -> SigrokDecode {
    let warnings = run(vcd, signal, bitrate, sample_point_pct, "warnings")
        .lines()
        .map(str::to_string)
        .collect();
    let annotations = run(vcd, signal, bitrate, sample_point_pct, "fields");
    SigrokDecode {
        frames: frames_from_annotations(&annotations),
        warnings,
    }
}

fn hex_value(line: &str) -> Option<u32> {
    let start = line.rfind("(0x")? + 3;
    u32::from_str_radix(line[start..].trim_end_matches(')'), 16).ok()
}

/// Rebuilds candump-style frames from sigrok's field annotations.
fn frames_from_annotations(text: &str) -> Vec<String> {
    let mut frames = Vec::new();
    let (mut id, mut extended, mut remote, mut data) = (0u32, false, false, String::new());
    for line in text.lines() {
        let line = line.trim_start_matches("can-1: ");
        if line.starts_with("Identifier:") {
            (id, extended, remote, data) =
                (hex_value(line).unwrap_or(0), false, false, String::new());
        } else if line.starts_with("Full Identifier:") {
            (id, extended) = (hex_value(line).unwrap_or(0), true);
        } else if let Some(kind) = line.strip_prefix("Remote transmission request: ") {
            remote = kind.starts_with("remote");
        } else if let Some(rest) = line.strip_prefix("Data byte ") {
            data += rest.split("0x").nth(1).unwrap_or("??");
        } else if line.starts_with("ACK slot") {
            let id_text = if extended {
                format!("{id:08X}")
            } else {
                format!("{id:03X}")
            };
            let body = if remote {
                "R".to_string()
            } else {
                data.to_uppercase()
            };
            frames.push(format!("{id_text}#{body}"));
        }
    }
    frames
}
