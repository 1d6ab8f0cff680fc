//! Scenario files: a CAN bus described in TOML and run without writing Rust (`cansim run`).
//!
//! A scenario names the nodes (complete RTL controllers, each driven only through its registers by
//! the model of the Linux SJA1000 driver), their clocks, clock offsets, propagation delays, bit
//! timing, modes and acceptance filters; the traffic (frames at given times, periodic messages,
//! replays of `candump -l` logs); the faults (bits flipped or forced, located by frame number,
//! field and bit or by time; glitches of some time quanta; nodes disconnected or stuck dominant);
//! and the duration. Running it gives a bus log in `candump -l` format annotated with error and
//! overload frames, a per-node summary and, if asked, a VCD. `docs/SCENARIOS.md` describes the
//! file format.
//!
//! * [`mod@parse`] reads a file (TOML with every key checked; errors name the file, line and column),
//! * [`candump`] the candump frame notation and log files,
//! * [`traffic`] when which node hands which frame to its driver,
//! * [`faults`] where a fault lands and what it does to the bus,
//! * [`canopen_node`] nodes whose firmware is the CANopen device stack, [`canopen_master`] the
//!   CANopen master with its script,
//! * [`recording`] a captured bus that drives the simulated one,
//! * [`mod@run`] runs a scenario, [`summary`] prints its results, [`progress`] shows a run going,
//!   [`view`] writes a GTKWave view beside its VCD.

pub mod candump;
pub mod canopen_master;
pub mod canopen_node;
pub mod faults;
mod output;
pub mod parse;
pub mod progress;
pub mod recording;
pub mod report;
pub mod run;
pub mod summary;
pub mod traffic;
pub mod view;

use std::fmt;
use std::path::{Path, PathBuf};

use crate::engine::time::ClockSpec;
use crate::host::acceptance::FilterConfig;
use golden::btr::Btr;

pub use parse::{load, parse};
pub use report::RunReport;
pub use run::{run, RunOptions};

/// What went wrong with a scenario: a message, with the file and line (and column) it is about
/// when there is one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScenarioError {
    /// The file the message is about.
    pub file: Option<PathBuf>,
    /// 1-based line in that file.
    pub line: Option<usize>,
    /// 1-based column in that line.
    pub column: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl ScenarioError {
    /// An error not tied to a file.
    pub fn new(message: impl Into<String>) -> ScenarioError {
        ScenarioError {
            file: None,
            line: None,
            column: None,
            message: message.into(),
        }
    }

    /// An error about a whole file.
    pub fn in_file(file: &Path, message: impl Into<String>) -> ScenarioError {
        ScenarioError {
            file: Some(file.to_path_buf()),
            ..ScenarioError::new(message)
        }
    }

    /// An error about one line of a file.
    pub fn at_line(file: &Path, line: usize, message: impl Into<String>) -> ScenarioError {
        ScenarioError {
            line: Some(line),
            ..ScenarioError::in_file(file, message)
        }
    }
}

impl fmt::Display for ScenarioError {
    /// `FILE:LINE:COLUMN: message`, leaving out what is unknown.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(file) = &self.file {
            write!(f, "{}:", file.display())?;
            if let Some(line) = self.line {
                write!(f, "{line}:")?;
                if let Some(column) = self.column {
                    write!(f, "{column}:")?;
                }
            }
            f.write_str(" ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for ScenarioError {}

/// The bus: the reference bit timing that decodes the log, that every node uses unless it has its
/// own, and that gives durations in bits and time quanta their length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BusConfig {
    /// The controller clock the reference timing is for (and every node's default clock), in Hz.
    pub clock_hz: u32,
    /// The reference bit timing.
    pub btr: Btr,
}

impl BusConfig {
    /// The nominal bit time.
    pub fn bit_fs(&self) -> u64 {
        node_bit_fs(self.clock_hz, 0.0, &self.btr)
    }

    /// The nominal time quantum.
    pub fn tq_fs(&self) -> u64 {
        self.bit_fs() / u64::from(self.btr.quanta_per_bit())
    }
}

/// The bit time of a controller on a clock of `clock_hz` offset by `ppm`, with bit timing `btr`.
pub fn node_bit_fs(clock_hz: u32, ppm: f64, btr: &Btr) -> u64 {
    let period = ClockSpec::with_ppm(f64::from(clock_hz), ppm).period_fs();
    period * u64::from(btr.clocks_per_bit())
}

/// Linux's default `txqueuelen` of a CAN interface.
pub const DEFAULT_TXQUEUELEN: usize = 10;

/// How a node's driver starts its controller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeMode {
    /// Sends, receives and acknowledges.
    Normal,
    /// Receives only: never acknowledges, never sends (MOD.LOM).
    ListenOnly,
    /// A transmission succeeds without an acknowledgement, and the node receives its own frames
    /// (MOD.STM, transmissions by self-reception request).
    SelfTest,
}

/// A node of the scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeConfig {
    /// Name: VCD scope and label in the log and summary.
    pub name: String,
    /// Nominal controller clock in Hz.
    pub clock_hz: u32,
    /// Clock offset in parts per million (positive: fast).
    pub ppm: f64,
    /// Propagation delay between the node and the bus, each way.
    pub delay_fs: u64,
    /// Bit timing (BTR0/BTR1).
    pub btr: Btr,
    /// How the driver starts the controller.
    pub mode: NodeMode,
    /// The acceptance filter.
    pub filter: FilterConfig,
    /// After bus-off, the driver restarts the controller this long after reporting it
    /// (SocketCAN `restart-ms`); `None`: it stays bus-off.
    pub restart_fs: Option<u64>,
    /// Bus-error reporting (BEI enabled: the driver reads ECC on every bus error).
    pub berr_reporting: bool,
    /// One-shot mode: every frame gets one attempt (CMR.AT).
    pub one_shot: bool,
    /// Frames the driver's transmit queue holds besides the one in flight (Linux `txqueuelen`);
    /// while it is full, the node's further messages wait (as a sender retrying a full queue).
    pub txqueuelen: usize,
    /// The CANopen device its firmware runs, if any.
    pub canopen: Option<canopen_node::CanopenConfig>,
    /// The CANopen master its firmware runs, with its script, if any.
    pub canopen_master: Option<canopen_master::MasterScript>,
}

impl NodeConfig {
    /// The node's actual bit time (its clock offset included).
    pub fn bit_fs(&self) -> u64 {
        node_bit_fs(self.clock_hz, self.ppm, &self.btr)
    }
}

/// A parsed, checked scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// The file it came from (named in messages).
    pub path: PathBuf,
    /// How long the run lasts.
    pub duration_fs: u64,
    /// Seed of the random payloads.
    pub seed: u64,
    /// The reference bit timing.
    pub bus: BusConfig,
    /// The nodes, in file order.
    pub nodes: Vec<NodeConfig>,
    /// What the nodes send.
    pub traffic: traffic::Traffic,
    /// What goes wrong.
    pub faults: Vec<faults::Fault>,
    /// A capture that drives the bus, if any.
    pub recording: Option<recording::Recording>,
}
