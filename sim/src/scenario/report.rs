//! What a run saw, as data: per node at the end, the node events, the bus log, the faults as they
//! landed and the files written. `run` fills it; `summary` and `view` turn it into text and a
//! GTKWave view.

use std::path::PathBuf;

use golden::frame::Frame;

use super::canopen_master::MasterLine;
use crate::decode::bus_decoder::BusEvent;
use crate::host::driver::{CanState, DriverEvent, DriverStats};

/// The interrupt names, by IR bit number.
pub const INTERRUPT_NAMES: [&str; 8] = ["RI", "TI", "EI", "DOI", "WUI", "EPI", "ALI", "BEI"];

/// Everything a run saw.
#[derive(Clone, Debug)]
pub struct RunReport {
    /// Per node, at the end, in scenario order.
    pub nodes: Vec<NodeReport>,
    /// What the drivers reported and the restarts, in time order.
    pub events: Vec<NodeEvent>,
    /// The bus log: every frame, error frame and overload frame on the bus.
    pub log: Vec<BusEvent>,
    /// The faults as they landed, in time order.
    pub faults: Vec<AppliedFault>,
    /// Faults that never landed, with the reason (e.g. the bus saw fewer frames).
    pub missed_faults: Vec<String>,
    /// The CANopen master's log: its steps as they ended (failed ones marked, steps that never
    /// ended last) and what its node table saw.
    pub master: Vec<MasterLine>,
    /// When each frame started on the bus (frame 1 first).
    pub frame_starts: Vec<u64>,
    /// Simulated time.
    pub simulated_fs: u64,
    /// Clock edges of all nodes, stepped or skipped.
    pub edges: u64,
    /// How many of `edges` were skipped rather than stepped (`CAN_SKIP_EDGES`,
    /// [`crate::engine::EdgeSkipping`]).
    pub skipped_edges: u64,
    /// The VCD written, if any.
    pub vcd: Option<PathBuf>,
    /// The log file written, if any.
    pub log_file: Option<PathBuf>,
    /// The GTKWave view written beside the VCD, if any.
    pub view: Option<PathBuf>,
    /// With a recording: simulated minus capture time, from each simulated time on (the capture
    /// starts once the controllers are up; long idle stretches are shortened); empty without one.
    pub recording_shifts: Vec<(u64, i64)>,
}

impl RunReport {
    /// The capture's time of simulated time `t_fs` (the same time without a recording).
    pub fn recorded_time(&self, t_fs: u64) -> u64 {
        let k = self
            .recording_shifts
            .partition_point(|&(from, _)| from <= t_fs);
        let shift = k.checked_sub(1).map_or(0, |k| self.recording_shifts[k].1);
        t_fs.saturating_add_signed(-shift)
    }

    /// The master's steps that did not give what they expected.
    pub fn failed_steps(&self) -> usize {
        self.master.iter().filter(|line| line.failed).count()
    }

    /// The bus log as text: one `candump -l` style line per event.
    pub fn log_text(&self) -> String {
        self.log.iter().map(|e| format!("{e}\n")).collect()
    }
}

/// A node at the end of a run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeReport {
    /// Node name.
    pub name: String,
    /// Frames sent (TI for the frame in flight).
    pub sent: usize,
    /// Frames the driver read from the RX FIFO, in order.
    pub received: Vec<Frame>,
    /// Frames given up: dropped at bus-off, one-shot attempts that failed, and messages that were
    /// due but never got into the node's transmit queue by the end (their sender waited while
    /// the queue held `txqueuelen` frames).
    pub dropped: usize,
    /// Frames still waiting in the node's queue (or in flight) when the run ended.
    pub unsent: usize,
    /// TXERR at the end, read through the host.
    pub tec: u8,
    /// RXERR at the end, read through the host.
    pub rec: u8,
    /// The device state as the driver tracks it.
    pub state: CanState,
    /// Bus-off restarts by the driver.
    pub restarts: usize,
    /// The driver's statistics, interrupt counts included.
    pub stats: DriverStats,
}

impl NodeReport {
    /// `RI 11, TI 9, EPI 2` (interrupts that happened, in IR bit order).
    pub fn interrupts_text(&self) -> String {
        let seen: Vec<String> = INTERRUPT_NAMES
            .iter()
            .zip(self.stats.interrupts)
            .filter(|(_, n)| *n > 0)
            .map(|(name, n)| format!("{name} {n}"))
            .collect();
        if seen.is_empty() {
            "-".to_string()
        } else {
            seen.join(", ")
        }
    }
}

/// A node's counts while a bus runs without end (`cansim serve`), where no frame list is kept.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeCounts {
    /// Node name.
    pub name: String,
    /// Frames sent.
    pub sent: u64,
    /// Frames the driver read from the RX FIFO.
    pub received: u64,
    /// Frames given up: at bus-off, failed one-shot attempts, or refused by a full queue.
    pub dropped: u64,
    /// TXERR, read through the host.
    pub tec: u8,
    /// RXERR, read through the host.
    pub rec: u8,
    /// The device state as the driver tracks it.
    pub state: CanState,
}

/// What happened to a node, besides what its driver reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Happening {
    /// The driver reported this.
    Driver(DriverEvent),
    /// The driver began to restart the controller after bus-off (`restart-ms`).
    Restarted,
}

/// One event of a node, with its time.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeEvent {
    /// Simulated time (when the interrupt handler that reported it returned).
    pub at_fs: u64,
    /// Node name.
    pub node: String,
    /// What happened.
    pub what: Happening,
}

/// A fault as it landed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AppliedFault {
    /// Its line in the scenario file.
    pub line: usize,
    /// When it began on the bus (or at the node).
    pub start_fs: u64,
    /// When it ended.
    pub end_fs: u64,
    /// What and where, in words.
    pub text: String,
}
