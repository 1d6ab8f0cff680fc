//! Reads the CAN bus signal of any VCD file (with the `vcd` crate) and decodes it with a
//! [`BusDecoder`].
//!
//! * The signal is named by its full hierarchical name (`top.bus`) or by a trailing part of it
//!   (`bus`, `a.tx`); a name that matches no signal or several is an error that lists them.
//! * It must be one bit wide: a 1-bit wire, or one bit-select wire of a vector (`state[0]`); a wider
//!   vector is refused. `x` and `z` values read as recessive (an undriven CAN bus is recessive) and are
//!   counted.
//! * Times come from the file's `$timescale`, which is required.
//! * The bit timing: what the caller gives, else what the file records in a header comment written
//!   by [`timing_comment`](crate::engine::bus_timing::timing_comment) (the project's tracer writes one for every bench that knows its timing),
//!   else [`DEFAULT_BITRATE`] and [`DEFAULT_SAMPLE_POINT`].
//!
//! Every error names the file, and the line where there is one.

use std::fmt;
use std::fs::File;
use std::io::{self, BufReader};
use std::path::{Path, PathBuf};

use vcd::{Command, IdCode, ParseError, ScopeItem, Value, Var, VarType};

use crate::decode::bus_decoder::{BusDecoder, BusEvent, Remark};
use crate::engine::bus_timing::parse_timing_comment;
use crate::engine::bus_timing::BusTiming;
use crate::engine::time::FS_PER_S;
use golden::frame::{DOMINANT, RECESSIVE};

/// The signal decoded when none is named.
pub const DEFAULT_SIGNAL: &str = "bus";
/// The bit rate used when neither the caller nor the file gives one (bit/s).
pub const DEFAULT_BITRATE: f64 = 500_000.0;
/// The sample point used when neither the caller nor the file gives one (fraction of the bit).
pub const DEFAULT_SAMPLE_POINT: f64 = 0.875;
/// Signal names listed at most in an "unknown signal" error.
const LISTED_SIGNALS: usize = 20;

/// What to decode and how; `None` fields take the file's recorded timing or the defaults.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DecodeOptions {
    /// Signal name, full (`top.bus`) or a trailing part (`bus`); [`DEFAULT_SIGNAL`] when `None`.
    pub signal: Option<String>,
    /// Bit rate in bit/s.
    pub bitrate: Option<f64>,
    /// Sample point as a fraction of the bit.
    pub sample_point: Option<f64>,
    /// Synchronisation jump width as a fraction of the bit (a controller's SJW over its quanta per
    /// bit) [default: the decoder's `SJW_FRACTION`].
    pub sjw: Option<f64>,
}

/// The result of decoding one VCD.
#[derive(Clone, Debug, PartialEq)]
pub struct VcdDecode {
    /// Full hierarchical name of the decoded signal.
    pub signal: String,
    /// The timing used.
    pub timing: BusTiming,
    /// The timing the file records, if it does.
    pub file_timing: Option<BusTiming>,
    /// Number of `x` or `z` values of the signal (read as recessive).
    pub undefined_values: u64,
    /// Femtoseconds per time unit of the file (`$timescale`).
    pub timescale_fs: u64,
    /// Time of the file's last timestamp, where decoding ended.
    pub end_fs: u64,
    /// The decoded events in bus order.
    pub events: Vec<BusEvent>,
    /// The decoder's remarks in time order.
    pub remarks: Vec<Remark>,
}

/// Why a VCD could not be decoded: the file, the line if known, and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VcdError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line, where the problem is on one line.
    pub line: Option<u64>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for VcdError {
    /// `waves/x.vcd:12: message`, or `waves/x.vcd: message` without a line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for VcdError {}

/// A variable of the header with its full hierarchical name.
struct NamedVar {
    name: String,
    var: Var,
}

/// Every variable under `items`, named `scope.scope.reference[index]`.
fn collect_vars(items: &[ScopeItem], prefix: &str, out: &mut Vec<NamedVar>) {
    for item in items {
        match item {
            ScopeItem::Scope(scope) => {
                let path = format!("{prefix}{}.", scope.identifier);
                collect_vars(&scope.items, &path, out);
            }
            ScopeItem::Var(var) => {
                let index = var.index.map(|i| i.to_string()).unwrap_or_default();
                out.push(NamedVar {
                    name: format!("{prefix}{}{index}", var.reference),
                    var: var.clone(),
                });
            }
            _ => {}
        }
    }
}

/// The variable `wanted` names: an exact full name, else the one name ending in `.wanted`.
fn find_var<'a>(vars: &'a [NamedVar], wanted: &str) -> Result<&'a NamedVar, String> {
    let wanted: String = wanted.split_whitespace().collect();
    if let Some(exact) = vars.iter().find(|v| v.name == wanted) {
        return Ok(exact);
    }
    let suffix = format!(".{wanted}");
    let matches: Vec<&NamedVar> = vars.iter().filter(|v| v.name.ends_with(&suffix)).collect();
    match matches[..] {
        [one] => Ok(one),
        [] => {
            let is_bit_of = |name: &str| {
                let vector = name.split_once('[').map_or(name, |(vector, _)| vector);
                name.contains('[') && (vector == wanted || vector.ends_with(&suffix))
            };
            let bits: Vec<&str> = vars
                .iter()
                .map(|v| v.name.as_str())
                .filter(|name| is_bit_of(name))
                .collect();
            if !bits.is_empty() {
                return Err(format!(
                    "signal `{wanted}` is written as bit-select wires {}; name one of them",
                    bits.join(", ")
                ));
            }
            let names: Vec<&str> = vars.iter().map(|v| v.name.as_str()).collect();
            let more = names.len().saturating_sub(LISTED_SIGNALS);
            let mut list = names[..names.len().min(LISTED_SIGNALS)].join(", ");
            if more > 0 {
                list += &format!(" and {more} more");
            }
            if names.is_empty() {
                list = "none".into();
            }
            Err(format!("no signal `{wanted}`; the signals are: {list}"))
        }
        _ => {
            let names: Vec<&str> = matches.iter().map(|v| v.name.as_str()).collect();
            Err(format!(
                "signal `{wanted}` is ambiguous: {}; give the full name",
                names.join(", ")
            ))
        }
    }
}

/// Checks the bus variable is one bit of logic.
fn check_bus_var(named: &NamedVar) -> Result<(), String> {
    if matches!(
        named.var.var_type,
        VarType::Real | VarType::String | VarType::Event
    ) {
        return Err(format!(
            "signal `{}` has type {}, not a logic signal",
            named.name, named.var.var_type
        ));
    }
    if named.var.size != 1 {
        return Err(format!(
            "signal `{}` is {} bits wide; the CAN bus must be a 1-bit signal (name one bit-select wire, e.g. `{}[0]`)",
            named.name, named.var.size, named.var.reference
        ));
    }
    Ok(())
}

/// The bus level of a VCD value (`None`: x or z).
fn level_of(value: Value) -> Option<bool> {
    match value {
        Value::V0 => Some(DOMINANT),
        Value::V1 => Some(RECESSIVE),
        Value::X | Value::Z => None,
    }
}

/// Femtoseconds per VCD time unit.
fn timescale_fs(header: &vcd::Header) -> Result<u64, String> {
    let (count, unit) = header
        .timescale
        .ok_or("the header has no $timescale (add one, e.g. `$timescale 1 ns $end`)")?;
    (FS_PER_S / unit.divisor())
        .checked_mul(u64::from(count))
        .ok_or_else(|| format!("$timescale {count} {unit} is too large"))
}

/// The timing recorded in the header's comments, if any.
fn recorded_timing(items: &[ScopeItem]) -> Result<Option<BusTiming>, String> {
    let comments = items.iter().filter_map(|item| match item {
        ScopeItem::Comment(text) => Some(text.as_str()),
        _ => None,
    });
    comments.filter_map(parse_timing_comment).next().transpose()
}

/// A read or parse error of the parser at line `current`: the line it carries or the current one
/// (none at the end of the file), and the message without the line.
fn read_error(error: &io::Error, current: u64) -> (Option<u64>, String) {
    if let Some(parse) = error.get_ref().and_then(|e| e.downcast_ref::<ParseError>()) {
        return (
            Some(parse.line()),
            format!("malformed VCD: {}", parse.kind()),
        );
    }
    match error.kind() {
        io::ErrorKind::UnexpectedEof => (None, format!("malformed VCD: {error}")),
        io::ErrorKind::InvalidData => (Some(current), format!("malformed VCD: {error}")),
        _ => (Some(current), format!("cannot read: {error}")),
    }
}

/// Decodes the CAN bus signal of the VCD file at `path`.
pub fn decode_vcd(path: &Path, options: &DecodeOptions) -> Result<VcdDecode, VcdError> {
    let wanted = options.signal.as_deref().unwrap_or(DEFAULT_SIGNAL);
    let mut reader = SignalReader::open(path, wanted)?;
    let timing = resolve_timing(options, reader.file_timing).map_err(|e| reader.error(None, e))?;
    let mut decoder = BusDecoder::with_timing(timing);
    if let Some(sjw) = options.sjw {
        decoder = decoder.with_sjw(sjw);
    }
    while let Some((t_fs, level)) = reader.next_value()? {
        decoder.level(t_fs, level);
    }
    decoder.finish(reader.now_fs);
    Ok(VcdDecode {
        signal: reader.name.clone(),
        timing,
        file_timing: reader.file_timing,
        undefined_values: reader.undefined_values,
        timescale_fs: reader.scale_fs,
        end_fs: reader.now_fs,
        events: decoder.drain(),
        remarks: decoder.drain_remarks(),
    })
}

/// One 1-bit signal of a VCD file, read value by value as it is needed (a file of any length
/// takes no more memory than its header).
pub struct SignalReader {
    path: PathBuf,
    parser: vcd::Parser<BufReader<File>>,
    code: IdCode,
    /// The signal's full name.
    pub name: String,
    /// The bus timing the file records, if it does.
    pub file_timing: Option<BusTiming>,
    /// The file's time unit in femtoseconds.
    pub scale_fs: u64,
    /// The last timestamp read.
    pub now_fs: u64,
    /// `x` and `z` values read (taken as recessive).
    pub undefined_values: u64,
}

impl SignalReader {
    /// Opens `path` and finds `signal` (full name or trailing part).
    pub fn open(path: &Path, signal: &str) -> Result<SignalReader, VcdError> {
        let fail = |line: Option<u64>, message: String| VcdError {
            path: path.to_path_buf(),
            line,
            message,
        };
        let file = File::open(path).map_err(|e| fail(None, format!("cannot open: {e}")))?;
        let mut parser = vcd::Parser::new(BufReader::with_capacity(1 << 16, file));
        let header = parser.parse_header().map_err(|e| {
            let (line, message) = read_error(&e, parser.line());
            fail(line, message)
        })?;
        let scale_fs = timescale_fs(&header).map_err(|e| fail(None, e))?;
        let file_timing = recorded_timing(&header.items).map_err(|e| fail(None, e))?;
        let mut vars = Vec::new();
        collect_vars(&header.items, "", &mut vars);
        let bus = find_var(&vars, signal).map_err(|e| fail(None, e))?;
        check_bus_var(bus).map_err(|e| fail(None, e))?;
        Ok(SignalReader {
            path: path.to_path_buf(),
            parser,
            code: bus.var.code,
            name: bus.name.clone(),
            file_timing,
            scale_fs,
            now_fs: 0,
            undefined_values: 0,
        })
    }

    /// An error about this file.
    pub fn error(&self, line: Option<u64>, message: String) -> VcdError {
        VcdError {
            path: self.path.clone(),
            line,
            message,
        }
    }

    /// The signal's next value (time, level; it may repeat the level), or `None` at the end.
    pub fn next_value(&mut self) -> Result<Option<(u64, bool)>, VcdError> {
        while let Some(command) = self.parser.next() {
            let command = command.map_err(|e| {
                let (line, message) = read_error(&e, self.parser.line());
                self.error(line, message)
            })?;
            let value = self
                .command(command)
                .map_err(|e| self.error(Some(self.parser.line()), e))?;
            if let Some(value) = value {
                let level = level_of(value).unwrap_or_else(|| {
                    self.undefined_values += 1;
                    RECESSIVE
                });
                return Ok(Some((self.now_fs, level)));
            }
        }
        Ok(None)
    }

    /// Follows the time of `command`; the signal's value if it sets it.
    fn command(&mut self, command: Command) -> Result<Option<Value>, String> {
        match command {
            Command::Timestamp(t) => {
                let t_fs = t
                    .checked_mul(self.scale_fs)
                    .ok_or_else(|| format!("timestamp #{t} is too large"))?;
                if t_fs < self.now_fs {
                    return Err(format!("timestamp #{t} goes back in time"));
                }
                self.now_fs = t_fs;
                Ok(None)
            }
            Command::ChangeScalar(code, value) if code == self.code => Ok(Some(value)),
            Command::ChangeVector(code, vector) if code == self.code => {
                let [value] = vector.iter().collect::<Vec<_>>()[..] else {
                    return Err(format!(
                        "a {}-bit value for the 1-bit bus signal",
                        vector.len()
                    ));
                };
                Ok(Some(value))
            }
            _ => Ok(None),
        }
    }
}

fn resolve_timing(
    options: &DecodeOptions,
    file_timing: Option<BusTiming>,
) -> Result<BusTiming, String> {
    let sample_point = options
        .sample_point
        .or(file_timing.map(|t| t.sample_point))
        .unwrap_or(DEFAULT_SAMPLE_POINT);
    match (options.bitrate, file_timing) {
        (Some(bitrate), _) => BusTiming::from_bitrate(bitrate, sample_point),
        (None, Some(file)) => BusTiming::new(file.bit_time_fs, sample_point),
        (None, None) => BusTiming::from_bitrate(DEFAULT_BITRATE, sample_point),
    }
}

/// Feeds the bus variable's changes into the decoder.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::decode::bus_decoder::BusEventKind;
    use crate::engine::bus_timing::{timing_comment, TIMING_COMMENT_PREFIX};
    use golden::frame::{encode, Field, Frame, Id};

    /// A file in the temporary directory, removed on drop.
    struct TempVcd(PathBuf);

    impl TempVcd {
        fn new(name: &str, text: &str) -> TempVcd {
            let path = std::env::temp_dir().join(format!(
                "cansim-vcd-reader-{}-{name}.vcd",
                std::process::id()
            ));
            std::fs::write(&path, text).unwrap();
            TempVcd(path)
        }
    }

    impl Drop for TempVcd {
        fn drop(&mut self) {
            std::fs::remove_file(&self.0).ok();
        }
    }

    fn frame() -> Frame {
        Frame::data(Id::Standard(0x123), &[0xDE, 0xAD]).unwrap()
    }

    const HEADER: &str = "$timescale 1 ns $end
$scope module top $end
$var wire 1 ! bus $end
$upscope $end
$scope module a $end
$var wire 1 \" tx $end
$var wire 2 # state $end
$var wire 1 $ flag [0] $end
$upscope $end
$scope module b $end
$var wire 1 % tx $end
$upscope $end
$enddefinitions $end
";

    /// Value changes of `frame` (acknowledged) on wire `code`, one bit every `bit_ns`, from 100 ns on,
    /// then 20 idle bits.
    fn changes(code: char, bit_ns: u64, set: impl Fn(bool) -> String) -> String {
        let mut bits = encode(&frame()).bits;
        let ack = encode(&frame()).position(Field::AckSlot, 0).unwrap();
        bits.set(ack, false);
        let mut text = format!("#0\n{}{code}\n", set(true));
        let mut last = true;
        for (i, bit) in bits.iter().by_vals().enumerate() {
            if bit != last {
                text += &format!("#{}\n{}{code}\n", 100 + i as u64 * bit_ns, set(bit));
                last = bit;
            }
        }
        text += &format!("#{}\n", 100 + (bits.len() as u64 + 20) * bit_ns);
        text
    }

    fn scalar(level: bool) -> String {
        u8::from(level).to_string()
    }

    fn decode(path: &Path, signal: Option<&str>) -> Result<VcdDecode, VcdError> {
        let options = DecodeOptions {
            signal: signal.map(str::to_string),
            ..DecodeOptions::default()
        };
        decode_vcd(path, &options)
    }

    /// The events as `123#DEAD acked=true` for frames, their debug form otherwise.
    fn frames(decoded: &VcdDecode) -> Vec<String> {
        let text = |event: &BusEvent| match &event.kind {
            BusEventKind::Frame { frame, acked } => format!("{frame} acked={acked}"),
            other => format!("{other:?}"),
        };
        decoded.events.iter().map(text).collect()
    }

    #[test]
    fn decodes_the_bus_by_bare_or_full_name() {
        let vcd = TempVcd::new("names", &(HEADER.to_string() + &changes('!', 2000, scalar)));
        for name in [None, Some("bus"), Some("top.bus")] {
            let decoded = decode(&vcd.0, name).unwrap();
            assert_eq!(decoded.signal, "top.bus");
            assert_eq!(frames(&decoded), ["123#DEAD acked=true"]);
            assert_eq!(decoded.events[0].start_fs, 100 * 1_000_000);
            assert_eq!(
                decoded.timing,
                BusTiming::new(2_000_000_000, 0.875).unwrap()
            );
            assert_eq!(decoded.file_timing, None);
        }
    }

    #[test]
    fn decodes_a_bit_select_and_a_vector_value_change_with_timescale_and_recorded_timing() {
        // 100 kbit/s in units of 10 ns; the comment records the timing.
        let timing = BusTiming::from_bitrate(100_000.0, 0.75).unwrap();
        let header = format!(
            "$comment\n  {}\n$end\n{}",
            timing_comment(&timing),
            HEADER.replace("1 ns", "10 ns")
        );
        let vector = |level: bool| format!("b{} ", u8::from(level));
        let vcd = TempVcd::new("bitselect", &(header + &changes('$', 1000, vector)));
        let decoded = decode(&vcd.0, Some("flag[0]")).unwrap();
        assert_eq!(decoded.signal, "a.flag[0]");
        assert_eq!(decoded.file_timing, Some(timing));
        assert_eq!(decoded.timing, timing);
        assert_eq!(frames(&decoded), ["123#DEAD acked=true"]);
        assert_eq!(decoded.events[0].start_fs, 100 * 10 * 1_000_000);
    }

    #[test]
    fn options_override_the_recorded_timing() {
        let recorded = BusTiming::from_bitrate(125_000.0, 0.5).unwrap();
        let header = format!("$comment {} $end\n{HEADER}", timing_comment(&recorded));
        let vcd = TempVcd::new("override", &(header + &changes('!', 2000, scalar)));
        let options = DecodeOptions {
            bitrate: Some(500_000.0),
            ..DecodeOptions::default()
        };
        let decoded = decode_vcd(&vcd.0, &options).unwrap();
        assert_eq!(decoded.timing, BusTiming::new(2_000_000_000, 0.5).unwrap());
        assert_eq!(frames(&decoded), ["123#DEAD acked=true"]);
        // At the recorded 125 kbit/s the 500 kbit/s frame is no frame.
        let decoded = decode(&vcd.0, None).unwrap();
        assert_eq!(decoded.timing, recorded);
        assert!(
            !frames(&decoded).iter().any(|f| f.starts_with("123#")),
            "{decoded:?}"
        );
    }

    #[test]
    fn x_and_z_read_as_recessive() {
        let body = changes('!', 2000, scalar).replacen("#0\n1!", "#0\nx!", 1);
        let body = body + "z!\n";
        let vcd = TempVcd::new("xz", &(HEADER.to_string() + &body));
        let decoded = decode(&vcd.0, None).unwrap();
        assert_eq!(decoded.undefined_values, 2);
        assert_eq!(frames(&decoded), ["123#DEAD acked=true"]);
    }

    fn error_of(name: &str, text: &str, signal: Option<&str>) -> String {
        let vcd = TempVcd::new(name, text);
        let error = decode(&vcd.0, signal).unwrap_err();
        assert_eq!(error.path, vcd.0);
        error
            .to_string()
            .replace(&vcd.0.display().to_string(), "FILE")
    }

    #[test]
    fn signal_errors_list_the_signals() {
        let text = HEADER.to_string() + "#0\n1!\n";
        assert_eq!(
            error_of("unknown", &text, Some("can_rx")),
            "FILE: no signal `can_rx`; the signals are: top.bus, a.tx, a.state, a.flag[0], b.tx"
        );
        assert_eq!(
            error_of("ambiguous", &text, Some("tx")),
            "FILE: signal `tx` is ambiguous: a.tx, b.tx; give the full name"
        );
        assert_eq!(
            error_of("vector", &text, Some("a.state")),
            "FILE: signal `a.state` is 2 bits wide; the CAN bus must be a 1-bit signal (name one bit-select wire, e.g. `state[0]`)"
        );
        assert_eq!(
            error_of("bit-selects", &text, Some("flag")),
            "FILE: signal `flag` is written as bit-select wires a.flag[0]; name one of them"
        );
        let real = text.replace("$var wire 1 % tx $end", "$var real 1 % tx $end");
        assert_eq!(
            error_of("real", &real, Some("b.tx")),
            "FILE: signal `b.tx` has type real, not a logic signal"
        );
    }

    #[test]
    fn file_errors_name_the_file_and_line() {
        let missing = Path::new("/nonexistent/cansim/x.vcd");
        let error = decode(missing, None).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("/nonexistent/cansim/x.vcd: cannot open: "),
            "{error}"
        );
        assert_eq!(
            error_of(
                "no-timescale",
                &HEADER.replace("$timescale 1 ns $end\n", ""),
                None
            ),
            "FILE: the header has no $timescale (add one, e.g. `$timescale 1 ns $end`)"
        );
        assert_eq!(
            error_of("garbage", &(HEADER.to_string() + "#0\n1!\n#10\n?!\n"), None),
            "FILE:17: malformed VCD: unexpected character at start of command"
        );
        assert_eq!(
            error_of(
                "bad-header",
                "$timescale 1 ns $end\n$scope module top $end\n$var wire 1 ! bus\n",
                None
            ),
            "FILE: malformed VCD: unexpected end of VCD file"
        );
        assert_eq!(
            error_of(
                "backwards",
                &(HEADER.to_string() + "#10\n1!\n#5\n0!\n"),
                None
            ),
            "FILE:16: timestamp #5 goes back in time"
        );
        assert_eq!(
            error_of("wide-value", &(HEADER.to_string() + "#0\nb10 !\n"), None),
            "FILE:15: a 2-bit value for the 1-bit bus signal"
        );
        let bad_comment = format!(
            "$comment {TIMING_COMMENT_PREFIX} bit_time_fs=0 sample_point=0.5 $end\n{HEADER}"
        );
        assert_eq!(
            error_of("bad-comment", &bad_comment, None),
            "FILE: bad bus timing comment: the bit time must be positive"
        );
        assert_eq!(
            error_of("empty", "", None),
            "FILE: malformed VCD: unexpected end of VCD file before $enddefinitions"
        );
    }
}
