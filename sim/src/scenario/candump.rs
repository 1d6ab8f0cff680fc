//! The candump notation of can-utils: frames as `123#DEADBEEF` and log files of `candump -l` lines
//! (`(1700000000.000000) can0 123#DEADBEEF`), read for scenario traffic and log replays.
//!
//! Frame notation, as `cansend` takes it and [`Frame`]'s `Display` writes it:
//! * the identifier in hex: 3 digits for a standard (11-bit) frame, 8 for an extended (29-bit) one;
//! * `#`, then the data bytes as hex pairs (optionally separated by `.`), at most 8;
//! * `_X` after 8 data bytes: the DLC 9..F sent in place of 8;
//! * or `R` for a remote frame, `R5` with a DLC (one hex digit).
//!
//! CAN FD frames (`##`) and error frames (identifiers with the CAN_ERR_FLAG bit) are refused.

use std::path::Path;

use crate::engine::time::FS_PER_S;
use golden::frame::{Frame, Id, MAX_DATA_LEN};

use super::ScenarioError;

/// Hex digits of a standard identifier.
const STANDARD_ID_DIGITS: usize = 3;
/// Hex digits of an extended identifier.
const EXTENDED_ID_DIGITS: usize = 8;

/// Parses a frame in candump notation.
pub fn parse_frame(text: &str) -> Result<Frame, String> {
    let bad = |why: String| format!("bad frame \"{text}\": {why}");
    if text.contains("##") {
        return Err(bad("CAN FD frames (##) are not supported".into()));
    }
    let (id_text, body) = text
        .split_once('#')
        .ok_or_else(|| bad("expected <id>#<data>".into()))?;
    let id = parse_id(id_text).map_err(bad)?;
    if let Some(dlc_text) = body.strip_prefix(['R', 'r']) {
        let dlc = match dlc_text {
            "" => 0,
            digit => u8::from_str_radix(digit, 16)
                .ok()
                .filter(|_| digit.len() == 1)
                .ok_or_else(|| bad(format!("remote DLC \"{digit}\" is not one hex digit")))?,
        };
        return Frame::remote(id, dlc).map_err(|e| bad(e.to_string()));
    }
    let (data_text, dlc_text) = match body.split_once('_') {
        Some((data, dlc)) => (data, Some(dlc)),
        None => (body, None),
    };
    let data = parse_data(data_text).map_err(bad)?;
    match dlc_text {
        None => Frame::data(id, &data).map_err(|e| bad(e.to_string())),
        Some(dlc_text) => {
            let dlc = u8::from_str_radix(dlc_text, 16)
                .ok()
                .filter(|&d| dlc_text.len() == 1 && usize::from(d) > MAX_DATA_LEN)
                .ok_or_else(|| bad(format!("\"_{dlc_text}\" is not a DLC 9..F")))?;
            Frame::data_with_dlc(id, dlc, &data).map_err(|e| bad(e.to_string()))
        }
    }
}

fn parse_id(text: &str) -> Result<Id, String> {
    let value = u32::from_str_radix(text, 16)
        .ok()
        .filter(|_| text.bytes().all(|b| b.is_ascii_hexdigit()))
        .ok_or_else(|| format!("identifier \"{text}\" is not hex"))?;
    match text.len() {
        STANDARD_ID_DIGITS => Id::standard(value as u16).map_err(|e| e.to_string()),
        EXTENDED_ID_DIGITS => Id::extended(value).map_err(|e| e.to_string()),
        n => Err(format!(
            "identifier \"{text}\" has {n} digits: 3 for a standard frame, 8 for an extended one"
        )),
    }
}

fn parse_data(text: &str) -> Result<Vec<u8>, String> {
    let digits: String = text.chars().filter(|&c| c != '.').collect();
    if !digits.len().is_multiple_of(2) {
        return Err(format!("data \"{text}\" has an odd number of hex digits"));
    }
    if digits.len() / 2 > MAX_DATA_LEN {
        return Err(format!(
            "data \"{text}\" has {} bytes, at most {MAX_DATA_LEN}",
            digits.len() / 2
        ));
    }
    (0..digits.len())
        .step_by(2)
        .map(|i| {
            u8::from_str_radix(&digits[i..i + 2], 16)
                .map_err(|_| format!("data \"{text}\" is not hex"))
        })
        .collect()
}

/// One line of a `candump -l` log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogLine {
    /// Line number in the file (1-based).
    pub line: usize,
    /// The timestamp in femtoseconds since the Unix epoch.
    pub time_fs: u128,
    /// The interface name (`can0`).
    pub interface: String,
    /// The frame.
    pub frame: Frame,
}

/// Parses a `candump -l` log (`path` only names the file in errors). Blank lines are skipped;
/// anything else must be `(SECONDS.MICROS) IFACE FRAME`, with timestamps that never go back.
pub fn parse_log(text: &str, path: &Path) -> Result<Vec<LogLine>, ScenarioError> {
    let mut lines: Vec<LogLine> = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let number = index + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() {
            continue;
        }
        let line = parse_log_line(trimmed, number)
            .map_err(|message| ScenarioError::at_line(path, number, message))?;
        if let Some(previous) = lines.last() {
            if line.time_fs < previous.time_fs {
                return Err(ScenarioError::at_line(
                    path,
                    number,
                    format!("timestamp goes back (line {} is later)", previous.line),
                ));
            }
        }
        lines.push(line);
    }
    Ok(lines)
}

fn parse_log_line(text: &str, number: usize) -> Result<LogLine, String> {
    let fields: Vec<&str> = text.split_whitespace().collect();
    let [stamp, interface, frame] = fields[..] else {
        return Err(format!(
            "expected \"(SECONDS.MICROS) INTERFACE FRAME\", got \"{text}\""
        ));
    };
    Ok(LogLine {
        line: number,
        time_fs: parse_timestamp(stamp)?,
        interface: interface.to_string(),
        frame: parse_frame(frame)?,
    })
}

/// `(1700000000.000123)` in femtoseconds.
fn parse_timestamp(text: &str) -> Result<u128, String> {
    let bad = || format!("bad timestamp \"{text}\": expected (SECONDS.MICROS)");
    let inner = text
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .ok_or_else(bad)?;
    let (seconds, fraction) = inner.split_once('.').ok_or_else(bad)?;
    let all_digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !all_digits(seconds) || !all_digits(fraction) || fraction.len() > 15 {
        return Err(bad());
    }
    let seconds: u128 = seconds.parse().map_err(|_| bad())?;
    let scale = 10u128.pow(15 - fraction.len() as u32);
    let fraction: u128 = fraction.parse::<u128>().map_err(|_| bad())? * scale;
    Ok(seconds * u128::from(FS_PER_S) + fraction)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_parse_back_from_their_display() {
        for text in [
            "123#DEADBEEF",
            "7FF#",
            "000#R",
            "123#R5",
            "1FFFFFFF#0011223344556677",
            "00000001#R",
            "123#0011223344556677_F",
        ] {
            assert_eq!(parse_frame(text).unwrap().to_string(), text);
        }
        assert_eq!(parse_frame("123#de.ad").unwrap().to_string(), "123#DEAD");
    }

    #[test]
    fn bad_frames_say_why() {
        for (text, why) in [
            ("800#00", "out of range"),
            ("12#00", "has 2 digits"),
            ("123#001", "odd number"),
            ("123#001122334455667788", "9 bytes"),
            ("123##1", "CAN FD"),
            ("123", "expected <id>#<data>"),
            ("12G#00", "not hex"),
            ("123#ZZ", "not hex"),
            ("123#R10", "not one hex digit"),
            ("123#00_F", "does not match DLC 15"),
            ("123#0011223344556677_3", "not a DLC 9..F"),
            ("20000000#00", "out of range"),
        ] {
            let error = parse_frame(text).unwrap_err();
            assert!(error.contains(why), "{text}: {error}");
        }
    }

    #[test]
    fn a_log_gives_times_interfaces_and_frames() {
        let text = "(1700000000.000000) can0 123#DEADBEEF\n\n(1700000000.001500) can1 12345678#R\n";
        let lines = parse_log(text, Path::new("x.log")).unwrap();
        assert_eq!(lines.len(), 2);
        assert_eq!(lines[1].line, 3);
        assert_eq!(lines[1].interface, "can1");
        assert_eq!(lines[1].time_fs - lines[0].time_fs, 1_500_000_000_000);
        assert_eq!(lines[1].frame.to_string(), "12345678#R");
    }

    #[test]
    fn log_errors_name_the_file_and_line() {
        for (text, message) in [
            (
                "(1.0) can0 123#00\n1.5 can0 123#00\n",
                "x.log:2: bad timestamp",
            ),
            ("(1.0) can0 123#00\n(2.0) can0\n", "x.log:2: expected"),
            (
                "(2.0) can0 123#00\n(1.0) can0 123#00\n",
                "x.log:2: timestamp goes back",
            ),
            ("(1.0) can0 123#0\n", "x.log:1: bad frame \"123#0\""),
        ] {
            let error = parse_log(text, Path::new("x.log")).unwrap_err().to_string();
            assert!(error.starts_with(message), "{error}");
        }
    }
}
