//! Reading a scenario file: TOML into the checked [`Scenario`]. Every table refuses unknown keys,
//! and every error names the file, line and column it is about (a replayed log's errors name the
//! log file and its line). `docs/SCENARIOS.md` describes every key.

mod canopen;
mod sdo_step;

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use crate::engine::time::{FS_PER_MS, FS_PER_NS, FS_PER_S, FS_PER_US};
use crate::host::acceptance::FilterConfig;
use crate::host::driver::open_filter;
use golden::btr::{calc_bittiming, sample_point_fraction, Btr};
use golden::frame::{Field, Frame, DOMINANT, RECESSIVE};
use golden::worst_case::unstuffed_len;

use self::canopen::{CanopenToml, MasterToml, StepToml};
use super::candump::{parse_frame, parse_log};
use super::faults::{Fault, FaultKind, Place};
use super::recording::{open_capture, Recording};
use super::traffic::{Once, Pattern, Periodic, Traffic};
use super::{BusConfig, NodeConfig, NodeMode, Scenario, ScenarioError, DEFAULT_TXQUEUELEN};
use crate::decode::vcd_reader::DEFAULT_SIGNAL;

/// Controller clock of the bus and of every node that names none.
pub const DEFAULT_CLOCK_HZ: u32 = 16_000_000;
/// Largest clock offset accepted, in ppm (a 5 % error is far beyond what CAN tolerates).
pub const MAX_PPM: f64 = 50_000.0;
/// Longest time a scenario may give (the femtosecond clock of the engine lasts about 5 hours).
pub const MAX_TIME_FS: u64 = 3600 * FS_PER_S;
/// The name of the VCD scope that holds the bus: no node may take it.
const BUS_SCOPE: &str = "top";
/// The largest transmit queue a node may have (it bounds the memory a node's waiting frames take).
pub const MAX_TXQUEUELEN: usize = 100_000;
/// Recessive bits after a frame before the next one can start: the intermission (ISO 11898-1
/// 10.4.6.2).
const INTERMISSION_BITS: u64 = 3;

/// Reads and checks the scenario in `path`.
pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ScenarioError::in_file(path, format!("cannot read the scenario: {e}")))?;
    parse(&text, path)
}

/// Checks the scenario `text`; `path` names it in messages, and replayed logs are found relative
/// to its directory.
pub fn parse(text: &str, path: &Path) -> Result<Scenario, ScenarioError> {
    let source = Source { text, path };
    let file: FileToml = toml::from_str(text).map_err(|e| source.toml_error(&e))?;
    Builder::new(source, &file.bus)?.build(file)
}

/// A time given on the command line (`--until 2ms`), with the bit and quantum of `scenario`'s bus.
pub fn parse_time(scenario: &Scenario, text: &str) -> Result<u64, String> {
    Units {
        bit_fs: scenario.bus.bit_fs(),
        tq_fs: scenario.bus.tq_fs(),
    }
    .time(text)
}

// ---- The file as TOML -------------------------------------------------------------------------

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileToml {
    duration: Spanned<String>,
    #[serde(default)]
    seed: u64,
    bus: Spanned<BusToml>,
    #[serde(default)]
    node: Vec<Spanned<NodeToml>>,
    #[serde(default)]
    frame: Vec<Spanned<FrameToml>>,
    #[serde(default)]
    periodic: Vec<Spanned<PeriodicToml>>,
    #[serde(default)]
    replay: Vec<Spanned<ReplayToml>>,
    #[serde(default)]
    fault: Vec<Spanned<FaultToml>>,
    #[serde(default)]
    master: Vec<Spanned<StepToml>>,
}

/// Bit timing keys, in `[bus]` and in a `[[node]]`.
#[derive(Default)]
struct TimingToml {
    bitrate: Option<Spanned<u32>>,
    sample_point: Option<Spanned<f64>>,
    sjw: Option<Spanned<u32>>,
    btr0: Option<Spanned<u8>>,
    btr1: Option<Spanned<u8>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BusToml {
    clock: Option<Spanned<u32>>,
    bitrate: Option<Spanned<u32>>,
    sample_point: Option<Spanned<f64>>,
    sjw: Option<Spanned<u32>>,
    btr0: Option<Spanned<u8>>,
    btr1: Option<Spanned<u8>>,
    /// A capture that drives the bus (VCD or sigrok session), relative to the scenario.
    recording: Option<Spanned<String>>,
    /// The bus signal in it.
    signal: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NodeToml {
    name: Spanned<String>,
    clock: Option<Spanned<u32>>,
    ppm: Option<Spanned<f64>>,
    delay: Option<Spanned<String>>,
    bitrate: Option<Spanned<u32>>,
    sample_point: Option<Spanned<f64>>,
    sjw: Option<Spanned<u32>>,
    btr0: Option<Spanned<u8>>,
    btr1: Option<Spanned<u8>>,
    mode: Option<ModeToml>,
    filter: Option<Spanned<FilterToml>>,
    restart: Option<Spanned<String>>,
    berr_reporting: Option<bool>,
    one_shot: Option<bool>,
    txqueuelen: Option<Spanned<usize>>,
    canopen: Option<Spanned<CanopenToml>>,
    canopen_master: Option<Spanned<MasterToml>>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum ModeToml {
    Normal,
    ListenOnly,
    SelfTest,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilterToml {
    /// Identifier form: the code and the don't-care mask of the identifier.
    id: Option<Spanned<u32>>,
    mask: Option<Spanned<u32>>,
    extended: Option<bool>,
    /// Register form.
    acr: Option<Spanned<Vec<u8>>>,
    amr: Option<Spanned<Vec<u8>>>,
    single: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FrameToml {
    node: Spanned<String>,
    at: Spanned<String>,
    frame: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PeriodicToml {
    node: Spanned<String>,
    frame: Spanned<String>,
    period: Spanned<String>,
    start: Option<Spanned<String>>,
    count: Option<u64>,
    pattern: Option<Spanned<PatternToml>>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum PatternToml {
    Fixed,
    Counter,
    Random,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ReplayToml {
    node: Spanned<String>,
    file: Spanned<String>,
    start: Option<Spanned<String>>,
    interface: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FaultToml {
    kind: KindToml,
    at: Option<Spanned<String>>,
    frame: Option<Spanned<u64>>,
    field: Option<Spanned<FieldToml>>,
    bit: Option<Spanned<u16>>,
    offset: Option<Spanned<String>>,
    duration: Option<Spanned<String>>,
    level: Option<Spanned<LevelToml>>,
    quanta: Option<Spanned<u32>>,
    node: Option<Spanned<String>>,
    nodes: Option<Vec<Spanned<String>>>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
enum KindToml {
    Flip,
    Force,
    Glitch,
    Disconnect,
    StuckDominant,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
enum FieldToml {
    Sof,
    Id,
    Srr,
    Ide,
    ExtId,
    Rtr,
    R1,
    R0,
    Dlc,
    Data,
    Crc,
    CrcDelim,
    AckSlot,
    AckDelim,
    Eof,
}

impl From<FieldToml> for Field {
    fn from(field: FieldToml) -> Field {
        match field {
            FieldToml::Sof => Field::Sof,
            FieldToml::Id => Field::BaseId,
            FieldToml::Srr => Field::Srr,
            FieldToml::Ide => Field::Ide,
            FieldToml::ExtId => Field::ExtId,
            FieldToml::Rtr => Field::Rtr,
            FieldToml::R1 => Field::R1,
            FieldToml::R0 => Field::R0,
            FieldToml::Dlc => Field::Dlc,
            FieldToml::Data => Field::Data,
            FieldToml::Crc => Field::Crc,
            FieldToml::CrcDelim => Field::CrcDelim,
            FieldToml::AckSlot => Field::AckSlot,
            FieldToml::AckDelim => Field::AckDelim,
            FieldToml::Eof => Field::Eof,
        }
    }
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum LevelToml {
    Dominant,
    Recessive,
}

impl From<LevelToml> for bool {
    fn from(level: LevelToml) -> bool {
        match level {
            LevelToml::Dominant => DOMINANT,
            LevelToml::Recessive => RECESSIVE,
        }
    }
}

// ---- Checking ---------------------------------------------------------------------------------

/// The text of the file, to turn byte spans into lines and columns.
#[derive(Clone, Copy)]
struct Source<'a> {
    text: &'a str,
    path: &'a Path,
}

impl Source<'_> {
    fn error(&self, span: Range<usize>, message: impl Into<String>) -> ScenarioError {
        let before = &self.text[..span.start.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
        ScenarioError {
            column: Some(column),
            ..ScenarioError::at_line(self.path, line, message)
        }
    }

    /// The line where `span` begins (a table's: its header line).
    fn line(&self, span: &Range<usize>) -> usize {
        self.text[..span.start.min(self.text.len())]
            .matches('\n')
            .count()
            + 1
    }

    /// An error about a whole table, at its header line.
    fn table_error(&self, span: Range<usize>, message: impl Into<String>) -> ScenarioError {
        ScenarioError::at_line(self.path, self.line(&span), message)
    }

    fn toml_error(&self, e: &toml::de::Error) -> ScenarioError {
        // One line: the TOML parser puts what it expected on a second one.
        let message = e.message().trim_end().replace('\n', "; ");
        match e.span() {
            Some(span) => self.error(span, message),
            None => ScenarioError::in_file(self.path, message),
        }
    }
}

/// Units of the durations of a scenario.
#[derive(Clone, Copy)]
struct Units {
    bit_fs: u64,
    tq_fs: u64,
}

impl Units {
    /// A duration such as `100us`, `1.5 ms`, `20 bits` or `3tq`.
    fn time(&self, text: &str) -> Result<u64, String> {
        let text = text.trim();
        let split = text.find(|c: char| c.is_alphabetic()).unwrap_or(text.len());
        let (number, unit) = (text[..split].trim(), text[split..].trim());
        let value: f64 = number
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| format!("\"{text}\" is not a time: expected e.g. 100us, 2ms, 20bits"))?;
        let unit_fs = match unit {
            "fs" => 1,
            "ps" => 1_000,
            "ns" => FS_PER_NS,
            "us" | "µs" => FS_PER_US,
            "ms" => FS_PER_MS,
            "s" => FS_PER_S,
            "bit" | "bits" => self.bit_fs,
            "tq" => self.tq_fs,
            "" => return Err(format!("\"{text}\" has no unit: s, ms, us, ns, bits or tq")),
            other => {
                return Err(format!(
                    "unknown unit \"{other}\" in \"{text}\": s, ms, us, ns, bits or tq"
                ))
            }
        };
        let fs = value * unit_fs as f64;
        if fs > MAX_TIME_FS as f64 {
            return Err(format!("\"{text}\" is longer than an hour"));
        }
        Ok(fs.round() as u64)
    }
}

struct Builder<'a> {
    source: Source<'a>,
    bus: BusConfig,
    units: Units,
    nodes: Vec<NodeConfig>,
}

impl<'a> Builder<'a> {
    fn new(source: Source<'a>, bus: &Spanned<BusToml>) -> Result<Builder<'a>, ScenarioError> {
        let b = bus.get_ref();
        let clock_hz = match &b.clock {
            Some(clock) => checked_clock(source, clock)?,
            None => DEFAULT_CLOCK_HZ,
        };
        let timing = TimingToml {
            bitrate: b.bitrate.clone(),
            sample_point: b.sample_point.clone(),
            sjw: b.sjw.clone(),
            btr0: b.btr0.clone(),
            btr1: b.btr1.clone(),
        };
        let btr = timing_btr(source, &timing, clock_hz)?.ok_or_else(|| {
            source.table_error(
                bus.span(),
                "[bus] needs a bit timing: bitrate (and sample_point, sjw) or btr0 and btr1",
            )
        })?;
        let bus = BusConfig { clock_hz, btr };
        let units = Units {
            bit_fs: bus.bit_fs(),
            tq_fs: bus.tq_fs(),
        };
        Ok(Builder {
            source,
            bus,
            units,
            nodes: Vec::new(),
        })
    }

    fn error(&self, span: Range<usize>, message: impl Into<String>) -> ScenarioError {
        self.source.error(span, message)
    }

    fn time(&self, text: &Spanned<String>) -> Result<u64, ScenarioError> {
        self.units
            .time(text.get_ref())
            .map_err(|m| self.error(text.span(), m))
    }

    fn node_index(&self, name: &Spanned<String>) -> Result<usize, ScenarioError> {
        self.nodes
            .iter()
            .position(|n| n.name == *name.get_ref())
            .ok_or_else(|| {
                let known: Vec<&str> = self.nodes.iter().map(|n| n.name.as_str()).collect();
                self.error(
                    name.span(),
                    format!(
                        "unknown node \"{}\" (the nodes are: {})",
                        name.get_ref(),
                        known.join(", ")
                    ),
                )
            })
    }

    /// The index of a node that sends: not listen-only.
    fn sender(&self, name: &Spanned<String>) -> Result<usize, ScenarioError> {
        let node = self.node_index(name)?;
        if self.nodes[node].mode == NodeMode::ListenOnly {
            return Err(self.error(
                name.span(),
                format!("node \"{}\" is listen-only: it cannot send", name.get_ref()),
            ));
        }
        Ok(node)
    }

    fn frame(&self, text: &Spanned<String>) -> Result<Frame, ScenarioError> {
        parse_frame(text.get_ref()).map_err(|m| self.error(text.span(), m))
    }

    fn build(mut self, file: FileToml) -> Result<Scenario, ScenarioError> {
        let duration_fs = self.time(&file.duration)?;
        if duration_fs == 0 {
            return Err(self.error(file.duration.span(), "the duration must not be 0"));
        }
        if file.node.is_empty() {
            return Err(ScenarioError::in_file(
                self.source.path,
                "no [[node]]: a scenario needs at least one node",
            ));
        }
        for node in &file.node {
            let config = self.node(node)?;
            self.nodes.push(config);
        }
        self.master_script(&file.master)?;
        let mut traffic = Traffic::default();
        for frame in &file.frame {
            let f = frame.get_ref();
            traffic.once.push(Once {
                node: self.sender(&f.node)?,
                at_fs: self.time(&f.at)?,
                frame: self.frame(&f.frame)?,
            });
        }
        for periodic in &file.periodic {
            traffic.periodic.push(self.periodic(periodic)?);
        }
        for replay in &file.replay {
            traffic.once.extend(self.replay(replay.get_ref())?);
        }
        let faults = file
            .fault
            .iter()
            .map(|f| self.fault(f))
            .collect::<Result<Vec<_>, _>>()?;
        let recording = self.recording(file.bus.get_ref())?;
        Ok(Scenario {
            path: self.source.path.to_path_buf(),
            duration_fs,
            seed: file.seed,
            bus: self.bus,
            nodes: self.nodes,
            traffic,
            faults,
            recording,
        })
    }

    fn node(&self, spanned: &Spanned<NodeToml>) -> Result<NodeConfig, ScenarioError> {
        let n = spanned.get_ref();
        let name = n.name.get_ref();
        let valid = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !valid || name == BUS_SCOPE {
            return Err(self.error(
                n.name.span(),
                format!(
                    "node name \"{name}\" is not usable: letters, digits, _ and - only, and not \
                     \"{BUS_SCOPE}\" (the VCD scope of the bus)"
                ),
            ));
        }
        if self.nodes.iter().any(|other| other.name == *name) {
            return Err(self.error(n.name.span(), format!("two nodes are called \"{name}\"")));
        }
        let clock_hz = match &n.clock {
            Some(clock) => checked_clock(self.source, clock)?,
            None => self.bus.clock_hz,
        };
        let ppm = n.ppm.as_ref().map_or(0.0, |p| *p.get_ref());
        if let Some(spanned_ppm) = n
            .ppm
            .as_ref()
            .filter(|_| !ppm.is_finite() || ppm.abs() > MAX_PPM)
        {
            return Err(self.error(
                spanned_ppm.span(),
                format!("clock offset {ppm} ppm is out of range ±{MAX_PPM} ppm"),
            ));
        }
        let timing = TimingToml {
            bitrate: n.bitrate.clone(),
            sample_point: n.sample_point.clone(),
            sjw: n.sjw.clone(),
            btr0: n.btr0.clone(),
            btr1: n.btr1.clone(),
        };
        let btr = match timing_btr(self.source, &timing, clock_hz)? {
            Some(btr) => btr,
            None if clock_hz == self.bus.clock_hz => self.bus.btr,
            None => self.bus_timing_for(clock_hz, spanned)?,
        };
        let mode = match n.mode.unwrap_or(ModeToml::Normal) {
            ModeToml::Normal => NodeMode::Normal,
            ModeToml::ListenOnly => NodeMode::ListenOnly,
            ModeToml::SelfTest => NodeMode::SelfTest,
        };
        Ok(NodeConfig {
            name: name.clone(),
            clock_hz,
            ppm,
            delay_fs: n
                .delay
                .as_ref()
                .map(|d| self.time(d))
                .transpose()?
                .unwrap_or(0),
            btr,
            mode,
            filter: match &n.filter {
                Some(filter) => self.filter(filter)?,
                None => open_filter(),
            },
            restart_fs: n.restart.as_ref().map(|r| self.time(r)).transpose()?,
            berr_reporting: n.berr_reporting.unwrap_or(true),
            one_shot: n.one_shot.unwrap_or(false),
            txqueuelen: self.txqueuelen(n)?,
            canopen: n
                .canopen
                .as_ref()
                .map(|c| self.canopen(c, mode))
                .transpose()?,
            canopen_master: n
                .canopen_master
                .as_ref()
                .map(|m| self.canopen_master(m, mode))
                .transpose()?,
        })
    }

    fn txqueuelen(&self, n: &NodeToml) -> Result<usize, ScenarioError> {
        let Some(spanned) = &n.txqueuelen else {
            return Ok(DEFAULT_TXQUEUELEN);
        };
        let length = *spanned.get_ref();
        if !(1..=MAX_TXQUEUELEN).contains(&length) {
            return Err(self.error(
                spanned.span(),
                format!("txqueuelen {length} is out of range 1..={MAX_TXQUEUELEN}"),
            ));
        }
        Ok(length)
    }

    /// The bus bit rate at another controller clock.
    fn bus_timing_for(
        &self,
        clock_hz: u32,
        node: &Spanned<NodeToml>,
    ) -> Result<Btr, ScenarioError> {
        let bitrate = self.bus.btr.bitrate(f64::from(self.bus.clock_hz)).round() as u32;
        let sample_point = Some(self.bus.btr.sample_point());
        calc_bittiming(clock_hz, bitrate, sample_point, None)
            .map(|c| c.btr)
            .map_err(|e| {
                self.source.table_error(
                    node.span(),
                    format!("the bus bit rate at this node's {clock_hz} Hz clock: {e}"),
                )
            })
    }

    fn filter(&self, spanned: &Spanned<FilterToml>) -> Result<FilterConfig, ScenarioError> {
        let f = spanned.get_ref();
        let by_id = f.id.is_some() || f.mask.is_some() || f.extended.is_some();
        let by_registers = f.acr.is_some() || f.amr.is_some() || f.single.is_some();
        let fail = |m: &str| Err(self.error(spanned.span(), m.to_string()));
        match (by_id, by_registers) {
            (true, true) => fail("a filter is either id/mask/extended or acr/amr/single, not both"),
            (false, false) => fail("a filter needs id (and mask) or acr and amr"),
            (true, false) => self.id_filter(f, spanned),
            (false, true) => {
                let (Some(acr), Some(amr)) = (&f.acr, &f.amr) else {
                    return fail("a register filter needs both acr and amr");
                };
                let acr = self.four_bytes(acr)?;
                let amr = self.four_bytes(amr)?;
                Ok(if f.single.unwrap_or(true) {
                    FilterConfig::single(acr, amr)
                } else {
                    FilterConfig::dual(acr, amr)
                })
            }
        }
    }

    /// A single filter on the identifier only: bits set in `mask` are don't care.
    fn id_filter(
        &self,
        f: &FilterToml,
        spanned: &Spanned<FilterToml>,
    ) -> Result<FilterConfig, ScenarioError> {
        let Some(id) = &f.id else {
            return Err(self.error(spanned.span(), "an identifier filter needs id"));
        };
        let extended = f.extended.unwrap_or(false);
        let (bits, max) = if extended {
            (29, golden::frame::MAX_EXTENDED_ID)
        } else {
            (11, u32::from(golden::frame::MAX_STANDARD_ID))
        };
        let mask = f.mask.as_ref().map_or(0, |m| *m.get_ref());
        for value in [id].into_iter().chain(&f.mask) {
            if *value.get_ref() > max {
                return Err(self.error(
                    value.span(),
                    format!(
                        "0x{:X} does not fit a {bits}-bit identifier",
                        value.get_ref()
                    ),
                ));
            }
        }
        // The identifier fills the code registers from ACR0 bit 7 on; the rest is don't care.
        let shift = 32 - bits;
        let acr = (*id.get_ref() << shift).to_be_bytes();
        let amr = ((mask << shift) | ((1 << shift) - 1)).to_be_bytes();
        Ok(FilterConfig::single(acr, amr))
    }

    fn four_bytes(&self, bytes: &Spanned<Vec<u8>>) -> Result<[u8; 4], ScenarioError> {
        <[u8; 4]>::try_from(bytes.get_ref().as_slice()).map_err(|_| {
            self.error(
                bytes.span(),
                format!("expected 4 register values, got {}", bytes.get_ref().len()),
            )
        })
    }

    fn periodic(&self, spanned: &Spanned<PeriodicToml>) -> Result<Periodic, ScenarioError> {
        let p = spanned.get_ref();
        let template = self.frame(&p.frame)?;
        let period_fs = self.time(&p.period)?;
        if period_fs == 0 {
            return Err(self.error(p.period.span(), "the period must not be 0"));
        }
        let pattern = match p.pattern.as_ref().map(|p| *p.get_ref()) {
            None | Some(PatternToml::Fixed) => Pattern::Fixed,
            Some(PatternToml::Counter) => Pattern::Counter,
            Some(PatternToml::Random) => Pattern::Random,
        };
        let no_data = template.is_remote() || template.data_bytes().is_empty();
        if let Some(spanned_pattern) = p.pattern.as_ref().filter(|_| no_data) {
            if pattern != Pattern::Fixed {
                return Err(self.error(
                    spanned_pattern.span(),
                    format!("pattern needs data bytes to change, and {template} has none"),
                ));
            }
        }
        let node = self.sender(&p.node)?;
        self.check_period(&p.period, period_fs, &template, &self.nodes[node])?;
        Ok(Periodic {
            node,
            template,
            first_fs: p
                .start
                .as_ref()
                .map(|s| self.time(s))
                .transpose()?
                .unwrap_or(0),
            period_fs,
            count: p.count,
            pattern,
        })
    }

    /// Refuses a period in which the node could not even send the message once: shorter than the
    /// frame without stuff bits and its intermission.
    fn check_period(
        &self,
        spanned: &Spanned<String>,
        period_fs: u64,
        frame: &Frame,
        node: &NodeConfig,
    ) -> Result<(), ScenarioError> {
        let data_bytes = if frame.is_remote() {
            0
        } else {
            frame.data_bytes().len()
        };
        let bits = unstuffed_len(frame.id().is_extended(), data_bytes) as u64 + INTERMISSION_BITS;
        let shortest_fs = bits * node.bit_fs();
        if period_fs >= shortest_fs {
            return Ok(());
        }
        Err(self.error(
            spanned.span(),
            format!(
                "period {:?} is shorter than {frame} takes on the bus ({bits} bits with the \
                 intermission, {:.1} us at node {}'s bit rate): the node could never keep up",
                spanned.get_ref(),
                shortest_fs as f64 / FS_PER_US as f64,
                node.name
            ),
        ))
    }

    fn replay(&self, r: &ReplayToml) -> Result<Vec<Once>, ScenarioError> {
        let node = self.sender(&r.node)?;
        let start = r
            .start
            .as_ref()
            .map(|s| self.time(s))
            .transpose()?
            .unwrap_or(0);
        let path = self.replay_path(r.file.get_ref());
        let text = std::fs::read_to_string(&path).map_err(|e| {
            self.error(
                r.file.span(),
                format!("cannot read the log {}: {e}", path.display()),
            )
        })?;
        let lines = parse_log(&text, &path)?;
        let wanted = r.interface.as_ref().map(|i| i.get_ref().as_str());
        let lines: Vec<_> = lines
            .into_iter()
            .filter(|l| wanted.is_none_or(|w| l.interface == w))
            .collect();
        let Some(first) = lines.first().map(|l| l.time_fs) else {
            let what = wanted.map_or(String::new(), |w| format!(" of interface {w}"));
            return Err(self.error(
                r.file.span(),
                format!("{} has no frame{what} to replay", path.display()),
            ));
        };
        lines
            .iter()
            .map(|l| {
                let offset = l.time_fs - first;
                if offset > u128::from(MAX_TIME_FS) {
                    return Err(ScenarioError::at_line(
                        &path,
                        l.line,
                        "more than an hour after the first line",
                    ));
                }
                Ok(Once {
                    node,
                    at_fs: start + offset as u64,
                    frame: l.frame,
                })
            })
            .collect()
    }

    /// A replayed log's path: as given if absolute, else relative to the scenario's directory.
    /// `[bus] recording` and `signal`: the capture must open and have the signal.
    fn recording(&self, bus: &BusToml) -> Result<Option<Recording>, ScenarioError> {
        let Some(file) = &bus.recording else {
            return match &bus.signal {
                Some(signal) => Err(self.error(signal.span(), "signal needs a recording")),
                None => Ok(None),
            };
        };
        let path = self.replay_path(file.get_ref());
        let signal = bus
            .signal
            .as_ref()
            .map_or(DEFAULT_SIGNAL.to_string(), |s| s.get_ref().clone());
        open_capture(&path, &signal)
            .map_err(|e| self.error(file.span(), format!("recording: {e}")))?;
        Ok(Some(Recording {
            path,
            signal,
            idle_keep_fs: None,
            end_after_fs: None,
        }))
    }

    fn replay_path(&self, file: &str) -> PathBuf {
        let base = self.source.path.parent().unwrap_or(Path::new(""));
        base.join(file)
    }

    fn fault(&self, spanned: &Spanned<FaultToml>) -> Result<Fault, ScenarioError> {
        let f = spanned.get_ref();
        let line = self.source.line(&spanned.span());
        let whole = || spanned.span();
        let unused = |present: Option<Range<usize>>, key: &str, why: &str| match present {
            Some(span) => Err(self.error(span, format!("{key} is not used by this fault: {why}"))),
            None => Ok(()),
        };
        let node_fault = matches!(f.kind, KindToml::Disconnect | KindToml::StuckDominant);
        let place = self.place(f, whole())?;
        let offset_fs = f
            .offset
            .as_ref()
            .map(|o| self.time(o))
            .transpose()?
            .unwrap_or(0);
        let duration = f.duration.as_ref().map(|d| self.time(d)).transpose()?;
        if duration == Some(0) {
            let span = f.duration.as_ref().map(Spanned::span).unwrap_or_else(whole);
            return Err(self.error(span, "the duration must not be 0"));
        }
        let kind = match f.kind {
            KindToml::Flip => {
                unused(
                    f.level.as_ref().map(Spanned::span),
                    "level",
                    "a flip inverts",
                )?;
                FaultKind::Flip
            }
            KindToml::Force => {
                let level = f
                    .level
                    .as_ref()
                    .ok_or_else(|| self.source.table_error(whole(), "a force needs level"))?;
                FaultKind::Force((*level.get_ref()).into())
            }
            KindToml::Glitch => {
                unused(
                    f.duration.as_ref().map(Spanned::span),
                    "duration",
                    "a glitch lasts `quanta` time quanta",
                )?;
                FaultKind::Glitch(f.level.as_ref().map(|l| (*l.get_ref()).into()))
            }
            KindToml::Disconnect | KindToml::StuckDominant => {
                let node = f.node.as_ref().ok_or_else(|| {
                    self.source
                        .table_error(whole(), "this fault needs node (the node it happens to)")
                })?;
                let node = self.node_index(node)?;
                unused(
                    f.level.as_ref().map(Spanned::span),
                    "level",
                    "it is about a node",
                )?;
                if f.kind == KindToml::Disconnect {
                    FaultKind::Disconnect(node)
                } else {
                    FaultKind::StuckDominant(node)
                }
            }
        };
        if node_fault {
            let first_node = f.nodes.as_ref().and_then(|n| n.first()).map(Spanned::span);
            unused(first_node, "nodes", "it is about one node")?;
            if matches!(place, Place::Bit { .. }) {
                return Err(self
                    .source
                    .table_error(whole(), "a node fault begins at a time (at), not a bit"));
            }
            if duration.is_none() {
                return Err(self
                    .source
                    .table_error(whole(), "a node fault needs duration"));
            }
        } else {
            unused(
                f.node.as_ref().map(Spanned::span),
                "node",
                "use nodes = [...]",
            )?;
        }
        let duration_fs = match (f.kind, &f.quanta) {
            (KindToml::Glitch, None) => {
                return Err(self
                    .source
                    .table_error(whole(), "a glitch needs quanta (its length)"))
            }
            (KindToml::Glitch, Some(quanta)) if *quanta.get_ref() == 0 => {
                return Err(self.error(quanta.span(), "a glitch lasts at least 1 quantum"))
            }
            (KindToml::Glitch, Some(quanta)) => u64::from(*quanta.get_ref()) * self.units.tq_fs,
            (_, Some(quanta)) => {
                return Err(self.error(
                    quanta.span(),
                    "quanta is not used by this fault: only a glitch has it",
                ))
            }
            (_, None) => duration.unwrap_or(self.units.bit_fs),
        };
        let nodes = f
            .nodes
            .iter()
            .flatten()
            .map(|n| self.node_index(n))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Fault {
            line,
            kind,
            place,
            offset_fs,
            duration_fs,
            nodes,
        })
    }

    fn place(&self, f: &FaultToml, whole: Range<usize>) -> Result<Place, ScenarioError> {
        match (&f.at, &f.frame) {
            (Some(_), Some(frame)) => Err(self.error(
                frame.span(),
                "a fault begins at a time (at) or at a frame bit (frame, field, bit), not both",
            )),
            (None, None) => Err(self.source.table_error(
                whole,
                "a fault needs at (a time) or frame and field (a bit of a frame on the bus)",
            )),
            (Some(at), None) => {
                for (key, span) in [
                    ("field", f.field.as_ref().map(Spanned::span)),
                    ("bit", f.bit.as_ref().map(Spanned::span)),
                ] {
                    if let Some(span) = span {
                        return Err(self.error(span, format!("{key} needs frame, not at")));
                    }
                }
                Ok(Place::At(self.time(at)?))
            }
            (None, Some(frame)) => {
                if *frame.get_ref() == 0 {
                    return Err(self.error(frame.span(), "frames count from 1"));
                }
                let field = f
                    .field
                    .as_ref()
                    .ok_or_else(|| self.source.table_error(whole, "frame needs field"))?;
                let field_value: Field = (*field.get_ref()).into();
                if field_value == Field::Sof {
                    return Err(self.error(
                        field.span(),
                        "a fault cannot begin at the SOF bit that counts its frame: give a time",
                    ));
                }
                Ok(Place::Bit {
                    frame: *frame.get_ref(),
                    field: field_value,
                    index: f.bit.as_ref().map_or(0, |b| *b.get_ref()),
                })
            }
        }
    }
}

fn checked_clock(source: Source, clock: &Spanned<u32>) -> Result<u32, ScenarioError> {
    match *clock.get_ref() {
        0 => Err(source.error(clock.span(), "the clock must not be 0 Hz")),
        hz => Ok(hz),
    }
}

/// The bit timing the keys give for a controller clock of `clock_hz`, or `None` if they give
/// none: BTR0 and BTR1 as written, or the Linux calculation of `cansim bittiming`.
fn timing_btr(source: Source, t: &TimingToml, clock_hz: u32) -> Result<Option<Btr>, ScenarioError> {
    let calculated = [
        t.bitrate.as_ref().map(Spanned::span),
        t.sample_point.as_ref().map(Spanned::span),
        t.sjw.as_ref().map(Spanned::span),
    ];
    match (&t.btr0, &t.btr1) {
        (Some(btr0), Some(btr1)) => {
            if let Some(span) = calculated.into_iter().flatten().next() {
                return Err(source.error(
                    span,
                    "give btr0 and btr1, or bitrate (sample_point, sjw), not both",
                ));
            }
            Ok(Some(Btr::from_registers(*btr0.get_ref(), *btr1.get_ref())))
        }
        (Some(one), None) | (None, Some(one)) => {
            Err(source.error(one.span(), "btr0 and btr1 go together"))
        }
        (None, None) => {
            let Some(bitrate) = &t.bitrate else {
                return match calculated.into_iter().flatten().next() {
                    Some(span) => Err(source.error(span, "sample_point and sjw need bitrate")),
                    None => Ok(None),
                };
            };
            let sample_point = t
                .sample_point
                .as_ref()
                .map(|sp| {
                    sample_point_fraction(*sp.get_ref()).ok_or_else(|| {
                        source.error(
                            sp.span(),
                            format!(
                                "sample point {} is out of range: a percentage (87.5) or a \
                                 fraction (0.875)",
                                sp.get_ref()
                            ),
                        )
                    })
                })
                .transpose()?;
            let sjw = t.sjw.as_ref().map(|s| *s.get_ref());
            calc_bittiming(clock_hz, *bitrate.get_ref(), sample_point, sjw)
                .map(|c| Some(c.btr))
                .map_err(|e| source.error(bitrate.span(), format!("impossible bit timing: {e}")))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "duration = \"1ms\"\n[bus]\nbitrate = 500000\n[[node]]\nname = \"a\"\n";

    fn parse_text(text: &str) -> Result<Scenario, ScenarioError> {
        parse(text, Path::new("s.toml"))
    }

    #[test]
    fn a_minimal_scenario_gets_the_defaults() {
        let s = parse_text(MINIMAL).unwrap();
        assert_eq!(s.duration_fs, FS_PER_MS);
        assert_eq!((s.bus.btr.btr0(), s.bus.btr.btr1()), (0x00, 0x1C));
        assert_eq!(s.bus.bit_fs(), 2 * FS_PER_US);
        let a = &s.nodes[0];
        assert_eq!(
            (a.clock_hz, a.delay_fs, a.mode),
            (DEFAULT_CLOCK_HZ, 0, NodeMode::Normal)
        );
        assert_eq!(a.filter, open_filter());
        assert!(a.berr_reporting && !a.one_shot && a.restart_fs.is_none());
    }

    #[test]
    fn times_take_every_unit() {
        let units = Units {
            bit_fs: 2 * FS_PER_US,
            tq_fs: 125 * FS_PER_NS,
        };
        for (text, fs) in [
            ("1.5ms", 1_500 * FS_PER_US),
            ("100 us", 100 * FS_PER_US),
            ("60ns", 60 * FS_PER_NS),
            ("20bits", 40 * FS_PER_US),
            ("3tq", 375 * FS_PER_NS),
            ("2s", 2 * FS_PER_S),
            ("0.5µs", 500 * FS_PER_NS),
        ] {
            assert_eq!(units.time(text), Ok(fs), "{text}");
        }
        for (text, message) in [
            ("12", "no unit"),
            ("1 fortnight", "unknown unit \"fortnight\""),
            ("-1ms", "not a time"),
            ("2h", "unknown unit"),
            ("5000s", "longer than an hour"),
        ] {
            let error = units.time(text).unwrap_err();
            assert!(error.contains(message), "{text}: {error}");
        }
    }

    #[test]
    fn an_identifier_filter_passes_the_masked_identifiers_only() {
        let text = format!("{MINIMAL}filter = {{ id = 0x100, mask = 0x0FF }}\n");
        let filter = parse_text(&text).unwrap().nodes[0].filter;
        let passes = |id| {
            let frame = Frame::data(golden::frame::Id::standard(id).unwrap(), &[1, 2]).unwrap();
            crate::host::acceptance::accepts(&filter, &frame)
        };
        assert!(passes(0x100) && passes(0x1FF) && passes(0x155));
        assert!(!passes(0x200) && !passes(0x0FF) && !passes(0x300));
    }

    #[test]
    fn node_timing_is_inherited_recalculated_or_given() {
        let text = "duration = \"1ms\"\n[bus]\nbitrate = 250000\n\
                    [[node]]\nname = \"a\"\n\
                    [[node]]\nname = \"b\"\nclock = 8000000\n\
                    [[node]]\nname = \"c\"\nbtr0 = 0x01\nbtr1 = 0x1C\n";
        let s = parse_text(text).unwrap();
        let rates: Vec<f64> = s
            .nodes
            .iter()
            .map(|n| n.btr.bitrate(f64::from(n.clock_hz)))
            .collect();
        assert_eq!(rates, [250_000.0, 250_000.0, 250_000.0]);
        assert_eq!(s.nodes[1].btr.sample_point(), 0.875);
    }
}
