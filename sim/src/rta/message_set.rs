//! Message sets: the TOML file format, its validation and the resolved [`MessageSet`].
//!
//! A file with a bit rate describes real CAN data frames; times are in milliseconds:
//!
//! ```toml
//! title = "Powertrain CAN"      # optional
//! bitrate = 500000              # bit/s
//!
//! [[message]]
//! name = "EngineSpeed"
//! id = 0x0C0                    # lower identifier = higher priority
//! extended = false              # optional: 29-bit identifier
//! dlc = 8                       # 0..=8
//! period_ms = 10
//! jitter_ms = 0.5               # optional, default 0
//! deadline_ms = 10              # optional, default the period
//! node = "ECM"                  # sending ECU
//! ```
//!
//! A file with `abstract = true` instead of a bit rate uses abstract time units with τbit = 1 and
//! gives each message's transmission time directly (`transmission`, `period`, optional `jitter`
//! and `deadline`, all non-negative integers; `node` optional, no `dlc`).

use std::fmt;
use std::ops::Range;
use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use super::{frame_bits, Ticks};
use golden::frame::{Id, MAX_DATA_LEN, MAX_EXTENDED_ID, MAX_STANDARD_ID};

/// Nanoseconds per second: ticks are nanoseconds in a set with a bit rate.
const NS_PER_S: u64 = 1_000_000_000;
/// Nanoseconds per millisecond, the unit of the times in a file with a bit rate.
const NS_PER_MS: f64 = 1e6;
/// Highest classic CAN bit rate.
const MAX_BITRATE: u32 = 1_000_000;
/// Longest time a file may give, in ticks (2^48 ns is about 78 hours), so that the analyses'
/// sums and products stay far from overflow.
pub const MAX_TIME: Ticks = 1 << 48;

/// How the times of a message set are counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeBase {
    /// Real CAN frames at this many bit/s; ticks are nanoseconds, the file gives milliseconds.
    Bitrate(u32),
    /// Abstract units: one bit time is one tick, transmission times are given directly.
    Abstract,
}

impl TimeBase {
    /// τbit in ticks.
    pub fn bit_ticks(self) -> Ticks {
        match self {
            TimeBase::Bitrate(bitrate) => NS_PER_S / u64::from(bitrate),
            TimeBase::Abstract => 1,
        }
    }

    /// The unit the times are shown in: "ms", or "" for abstract units.
    pub fn unit(self) -> &'static str {
        match self {
            TimeBase::Bitrate(_) => "ms",
            TimeBase::Abstract => "",
        }
    }

    /// `ticks` in the file's unit: milliseconds with up to six decimals (exact to the
    /// nanosecond, trailing zeros dropped), or the plain number of abstract units.
    pub fn format(self, ticks: Ticks) -> String {
        match self {
            TimeBase::Abstract => ticks.to_string(),
            TimeBase::Bitrate(_) => {
                let ns_per_ms = NS_PER_MS as u64;
                let (whole, fraction) = (ticks / ns_per_ms, ticks % ns_per_ms);
                if fraction == 0 {
                    whole.to_string()
                } else {
                    let digits = format!("{fraction:06}");
                    format!("{whole}.{}", digits.trim_end_matches('0'))
                }
            }
        }
    }
}

/// One message stream: a frame released periodically (or sporadically at least `period` apart).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Message {
    /// Name, unique in the set.
    pub name: String,
    /// Identifier; it sets the priority (see [`priority_key`]).
    pub id: Id,
    /// Sending node, if given.
    pub node: Option<String>,
    /// Data length code of the data frame (sets with a bit rate only).
    pub dlc: Option<u8>,
    /// Worst-case transmission time C, including the 3-bit intermission.
    pub transmission: Ticks,
    /// Period (minimum inter-arrival time) T.
    pub period: Ticks,
    /// Release jitter J.
    pub jitter: Ticks,
    /// Deadline D, relative to the initiating event.
    pub deadline: Ticks,
    /// Line of the message's `[[message]]` table in the file.
    pub line: usize,
}

/// A validated message set, highest priority first.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MessageSet {
    /// Where the set came from (the file name), for messages.
    pub source: String,
    /// Optional title from the file.
    pub title: Option<String>,
    /// Bit rate or abstract units.
    pub time_base: TimeBase,
    /// The messages, highest priority (lowest identifier) first.
    pub messages: Vec<Message>,
}

impl MessageSet {
    /// Reads and validates the message set in `path`.
    pub fn load(path: &Path) -> Result<MessageSet, InputError> {
        let source = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| InputError {
            source: source.clone(),
            line: None,
            message: format!("cannot read: {e}"),
        })?;
        MessageSet::parse(&text, &source)
    }

    /// Parses and validates a message set; `source` names it in error messages.
    pub fn parse(text: &str, source: &str) -> Result<MessageSet, InputError> {
        let error = |span: Option<Range<usize>>, message: String| InputError {
            source: source.to_string(),
            line: span.map(|s| line_of(text, s.start)),
            message,
        };
        let raw: RawSet =
            toml::from_str(text).map_err(|e| error(e.span(), e.message().to_string()))?;
        let time_base = time_base(&raw).map_err(|m| error(None, m))?;
        let mut messages = Vec::with_capacity(raw.message.len());
        for spanned in &raw.message {
            let line = line_of(text, spanned.span().start);
            let message = resolve(spanned.get_ref(), time_base, line)
                .map_err(|m| error(Some(spanned.span()), m))?;
            messages.push(message);
        }
        if messages.is_empty() {
            return Err(error(None, "no [[message]] in the file".into()));
        }
        check_unique(&messages).map_err(|(line, m)| InputError {
            source: source.to_string(),
            line: Some(line),
            message: m,
        })?;
        messages.sort_by_key(|m| priority_key(m.id));
        Ok(MessageSet {
            source: source.to_string(),
            title: raw.title,
            time_base,
            messages,
        })
    }

    /// Bus utilisation Σ C/T.
    pub fn utilisation(&self) -> f64 {
        utilisation(&self.messages)
    }
}

/// Σ C/T of `messages`.
pub(crate) fn utilisation<'a>(messages: impl IntoIterator<Item = &'a Message>) -> f64 {
    messages
        .into_iter()
        .map(|m| m.transmission as f64 / m.period as f64)
        .sum()
}

/// Arbitration order of data frames: the lower key wins. The 11 base identifier bits decide
/// first; on equal base bits a standard frame (dominant RTR) beats an extended one (recessive
/// SRR); extended frames then compare their 18 extension bits.
pub fn priority_key(id: Id) -> (u32, bool, u32) {
    match id {
        Id::Standard(id) => (u32::from(id), false, 0),
        Id::Extended(id) => (id >> 18, true, id & 0x3_FFFF),
    }
}

/// A message set that could not be read, with the file and line it concerns.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputError {
    /// The file.
    pub source: String,
    /// The line (1-based), when the error concerns one.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}: {}", self.source, self.message),
            None => write!(f, "{}: {}", self.source, self.message),
        }
    }
}

impl std::error::Error for InputError {}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSet {
    title: Option<String>,
    bitrate: Option<i64>,
    #[serde(rename = "abstract", default)]
    abstract_units: bool,
    #[serde(default)]
    message: Vec<Spanned<RawMessage>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMessage {
    name: String,
    id: i64,
    #[serde(default)]
    extended: bool,
    node: Option<String>,
    dlc: Option<i64>,
    period_ms: Option<f64>,
    jitter_ms: Option<f64>,
    deadline_ms: Option<f64>,
    transmission: Option<i64>,
    period: Option<i64>,
    jitter: Option<i64>,
    deadline: Option<i64>,
}

fn time_base(raw: &RawSet) -> Result<TimeBase, String> {
    match (raw.bitrate, raw.abstract_units) {
        (Some(_), true) => Err("give either `bitrate` or `abstract = true`, not both".into()),
        (None, false) => {
            Err("missing `bitrate = ...` (bit/s) or `abstract = true` (abstract time units)".into())
        }
        (None, true) => Ok(TimeBase::Abstract),
        (Some(bitrate), false) => {
            let valid = u32::try_from(bitrate)
                .ok()
                .filter(|&b| (1..=MAX_BITRATE).contains(&b));
            match valid {
                Some(b) if NS_PER_S.is_multiple_of(u64::from(b)) => Ok(TimeBase::Bitrate(b)),
                Some(b) => Err(format!(
                    "bitrate {b}: the bit time must be a whole number of nanoseconds (e.g. 125000, 500000)"
                )),
                None => Err(format!(
                    "bitrate {bitrate} is out of range 1..={MAX_BITRATE} bit/s"
                )),
            }
        }
    }
}

/// The message `raw` with its times in ticks.
fn resolve(raw: &RawMessage, base: TimeBase, line: usize) -> Result<Message, String> {
    let name = raw.name.trim().to_string();
    if name.is_empty() {
        return Err("empty message name".into());
    }
    let context = |m: String| format!("message '{name}': {m}");
    let id = identifier(raw.id, raw.extended).map_err(context)?;
    let timing = match base {
        TimeBase::Bitrate(_) => bit_timing(raw, base),
        TimeBase::Abstract => abstract_timing(raw),
    }
    .map_err(context)?;
    if timing.period == 0 {
        return Err(context("zero period".into()));
    }
    if timing.deadline == Some(0) {
        return Err(context("zero deadline".into()));
    }
    if timing.transmission == 0 {
        return Err(context("zero transmission time".into()));
    }
    let node = raw.node.as_ref().map(|n| n.trim().to_string());
    if node.as_deref() == Some("") {
        return Err(context("empty node name".into()));
    }
    if node.is_none() && matches!(base, TimeBase::Bitrate(_)) {
        return Err(context("missing `node` (the sending ECU)".into()));
    }
    Ok(Message {
        name,
        id,
        node,
        dlc: timing.dlc,
        transmission: timing.transmission,
        period: timing.period,
        jitter: timing.jitter,
        deadline: timing.deadline.unwrap_or(timing.period),
        line,
    })
}

/// The timing fields of one message, in ticks.
struct Timing {
    dlc: Option<u8>,
    transmission: Ticks,
    period: Ticks,
    jitter: Ticks,
    deadline: Option<Ticks>,
}

fn identifier(raw: i64, extended: bool) -> Result<Id, String> {
    let max = if extended {
        i64::from(MAX_EXTENDED_ID)
    } else {
        i64::from(MAX_STANDARD_ID)
    };
    if !(0..=max).contains(&raw) {
        let kind = if extended { "extended" } else { "standard" };
        return Err(format!(
            "identifier {raw:#X} is out of the {kind} range 0..={max:#X}"
        ));
    }
    // In range, so the casts are lossless.
    Ok(if extended {
        Id::Extended(raw as u32)
    } else {
        Id::Standard(raw as u16)
    })
}

/// Refuses the first of `keys` (name, given) that is given: it belongs to the other kind of set.
fn refuse_keys(keys: [(&str, bool); 4], why: &str) -> Result<(), String> {
    match keys.iter().find(|(_, given)| *given) {
        Some((key, _)) => Err(format!("`{key}` {why}")),
        None => Ok(()),
    }
}

fn bit_timing(raw: &RawMessage, base: TimeBase) -> Result<Timing, String> {
    refuse_keys(
        [
            ("transmission", raw.transmission.is_some()),
            ("period", raw.period.is_some()),
            ("jitter", raw.jitter.is_some()),
            ("deadline", raw.deadline.is_some()),
        ],
        "is for abstract sets; with a bitrate use `dlc` and times in ms (`period_ms`, `jitter_ms`, `deadline_ms`)",
    )?;
    let dlc = raw.dlc.ok_or("missing `dlc`")?;
    let dlc = u8::try_from(dlc)
        .ok()
        .filter(|&d| usize::from(d) <= MAX_DATA_LEN)
        .ok_or_else(|| {
            format!("DLC {dlc} is out of range 0..={MAX_DATA_LEN} (a classic frame carries at most 8 data bytes)")
        })?;
    let extended = raw.extended;
    let transmission = frame_bits(extended, dlc) * base.bit_ticks();
    let period = milliseconds("period_ms", raw.period_ms.ok_or("missing `period_ms`")?)?;
    Ok(Timing {
        dlc: Some(dlc),
        transmission,
        period,
        jitter: raw
            .jitter_ms
            .map(|j| milliseconds("jitter_ms", j))
            .transpose()?
            .unwrap_or(0),
        deadline: raw
            .deadline_ms
            .map(|d| milliseconds("deadline_ms", d))
            .transpose()?,
    })
}

fn abstract_timing(raw: &RawMessage) -> Result<Timing, String> {
    refuse_keys(
        [
            ("dlc", raw.dlc.is_some()),
            ("period_ms", raw.period_ms.is_some()),
            ("jitter_ms", raw.jitter_ms.is_some()),
            ("deadline_ms", raw.deadline_ms.is_some()),
        ],
        "needs a bitrate; abstract sets give `transmission`, `period`, `jitter`, `deadline`",
    )?;
    let units = |key: &str, value: i64| match u64::try_from(value) {
        Err(_) => Err(format!("{key} {value} is negative")),
        Ok(v) if v > MAX_TIME => Err(format!("{key} {value} is above {MAX_TIME}")),
        Ok(v) => Ok(v),
    };
    let required = |key: &str, value: Option<i64>| {
        value
            .ok_or_else(|| format!("missing `{key}`"))
            .and_then(|v| units(key, v))
    };
    Ok(Timing {
        dlc: None,
        transmission: required("transmission", raw.transmission)?,
        period: required("period", raw.period)?,
        jitter: raw
            .jitter
            .map(|j| units("jitter", j))
            .transpose()?
            .unwrap_or(0),
        deadline: raw.deadline.map(|d| units("deadline", d)).transpose()?,
    })
}

/// Milliseconds to nanoseconds (rounded to the nanosecond).
fn milliseconds(key: &str, ms: f64) -> Result<Ticks, String> {
    let ns = (ms * NS_PER_MS).round();
    if !ns.is_finite() || ns < 0.0 || ns > MAX_TIME as f64 {
        return Err(format!("{key} {ms} is not a usable time in milliseconds"));
    }
    Ok(ns as Ticks)
}

/// Rejects two messages with the same identifier or the same name; the error names the line of
/// the second one.
fn check_unique(messages: &[Message]) -> Result<(), (usize, String)> {
    for (i, later) in messages.iter().enumerate() {
        for earlier in &messages[..i] {
            if earlier.id == later.id {
                return Err((
                    later.line,
                    format!(
                        "duplicate identifier {:#X}: messages '{}' (line {}) and '{}' would both send it",
                        later.id.raw(),
                        earlier.name,
                        earlier.line,
                        later.name
                    ),
                ));
            }
            if earlier.name == later.name {
                return Err((
                    later.line,
                    format!(
                        "duplicate message name '{}' (also on line {})",
                        later.name, earlier.line
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
bitrate = 500000
[[message]]
name = "a"
id = 0x100
dlc = 8
period_ms = 10
node = "ecu"
"#;

    fn parse(text: &str) -> Result<MessageSet, InputError> {
        MessageSet::parse(text, "set.toml")
    }

    fn error(text: &str) -> String {
        parse(text).expect_err("must be refused").to_string()
    }

    #[test]
    fn a_minimal_set_resolves_times_in_nanoseconds() {
        let set = parse(MINIMAL).unwrap();
        assert_eq!(set.time_base, TimeBase::Bitrate(500_000));
        let m = &set.messages[0];
        assert_eq!(m.id, Id::Standard(0x100));
        assert_eq!(m.period, 10_000_000);
        assert_eq!(m.deadline, m.period);
        assert_eq!(m.jitter, 0);
        // 8 bytes standard: 44 + 64 + 24 stuff bits + 3 intermission = 135 bits of 2 µs.
        assert_eq!(m.transmission, 135 * 2_000);
        assert_eq!(m.line, 3);
    }

    #[test]
    fn messages_are_sorted_by_arbitration_priority() {
        let text = r#"
abstract = true
[[message]]
name = "ext_low"
id = 0x0400_0001
extended = true
transmission = 1
period = 10
[[message]]
name = "std"
id = 0x100
transmission = 1
period = 10
[[message]]
name = "ext_same_base"
id = 0x0400_0000
extended = true
transmission = 1
period = 10
[[message]]
name = "high"
id = 0x0FF
transmission = 1
period = 10
"#;
        let names: Vec<_> = parse(text)
            .unwrap()
            .messages
            .iter()
            .map(|m| m.name.clone())
            .collect();
        // 0x0400_0000 has base identifier 0x100: it loses to the standard 0x100 (SRR recessive).
        assert_eq!(names, ["high", "std", "ext_same_base", "ext_low"]);
    }

    #[test]
    fn times_format_in_milliseconds_exactly() {
        let base = TimeBase::Bitrate(125_000);
        assert_eq!(base.bit_ticks(), 8_000);
        assert_eq!(base.format(2_500_000), "2.5");
        assert_eq!(base.format(1_000_000), "1");
        assert_eq!(base.format(8_000), "0.008");
        assert_eq!(base.format(1), "0.000001");
        assert_eq!(TimeBase::Abstract.format(7), "7");
    }

    #[test]
    fn bad_sets_are_refused_with_file_line_and_reason() {
        let with = |extra: &str| MINIMAL.replace("node = \"ecu\"", extra);
        let cases = [
            (
                MINIMAL.replace("dlc = 8", "dlc = 9"),
                "set.toml:3: message 'a': DLC 9 is out of range",
            ),
            (
                MINIMAL.replace("period_ms = 10", "period_ms = 0"),
                "set.toml:3: message 'a': zero period",
            ),
            (
                with("node = \"ecu\"\ncolour = 1"),
                "set.toml:9: unknown field `colour`",
            ),
            (
                MINIMAL.replace("id = 0x100", "id = 0x800"),
                "identifier 0x800 is out of the standard range",
            ),
            (MINIMAL.replace("node = \"ecu\"", ""), "missing `node`"),
            (
                MINIMAL.replace("bitrate = 500000", "bitrate = 300000"),
                "whole number of nanoseconds",
            ),
            (MINIMAL.replace("bitrate = 500000", ""), "missing `bitrate"),
            (
                MINIMAL.replace("dlc = 8", "dlc = 8\nperiod = 3"),
                "`period` is for abstract sets",
            ),
            (
                MINIMAL.replace("period_ms = 10", "period_ms = \"10 ms\""),
                "set.toml:7: invalid type",
            ),
            (
                MINIMAL.replace("name = \"a\"", "name = \"a\nid"),
                "set.toml:4:",
            ),
            (
                MINIMAL
                    .replace("[[message]]\n", "")
                    .replace("name = \"a\"\n", ""),
                "unknown field `id`",
            ),
            ("bitrate = 500000\n".to_string(), "no [[message]]"),
        ];
        for (text, expected) in cases {
            let message = error(&text);
            assert!(message.contains(expected), "{message:?} lacks {expected:?}");
        }
    }

    #[test]
    fn duplicate_identifiers_name_both_messages() {
        let text = format!(
            "{MINIMAL}\n[[message]]\nname = \"b\"\nid = 0x100\ndlc = 1\nperiod_ms = 5\nnode = \"x\"\n"
        );
        let message = error(&text);
        assert_eq!(
            message,
            "set.toml:10: duplicate identifier 0x100: messages 'a' (line 3) and 'b' would both send it"
        );
        // The same value as an extended identifier is another identifier.
        let extended = text.replace(
            "id = 0x100\ndlc = 1",
            "id = 0x100\nextended = true\ndlc = 1",
        );
        assert_eq!(parse(&extended).unwrap().messages.len(), 2);
    }

    #[test]
    fn abstract_sets_take_transmission_times() {
        let text = r#"
abstract = true
[[message]]
name = "m"
id = 1
transmission = 3
period = 10
deadline = 8
jitter = 1
"#;
        let m = &parse(text).unwrap().messages[0];
        assert_eq!(
            (m.transmission, m.period, m.deadline, m.jitter),
            (3, 10, 8, 1)
        );
        assert!(
            error(&text.replace("transmission = 3", "dlc = 3")).contains("`dlc` needs a bitrate")
        );
        assert!(error(&text.replace("jitter = 1", "jitter = -1")).contains("jitter -1 is negative"));
    }
}
