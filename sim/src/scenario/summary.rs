//! What a run reports, as text: the per-node summary table (frames sent and received, TXERR,
//! RXERR, state, interrupts seen), the bus log counts, the faults as they landed, and what the
//! drivers reported, event by event.

use std::fmt;

use rtl::bsp::ecc_segment as seg;
use rtl::registers::interrupt;

use crate::decode::bus_decoder::{BusEvent, BusEventKind};
use crate::engine::time::{FS_PER_MS, FS_PER_NS};
use crate::host::driver::DriverEvent;

use super::canopen_node::CanopenLog;
use super::report::{AppliedFault, Happening, NodeCounts, NodeEvent, NodeReport, RunReport};
use super::{NodeConfig, NodeMode, Scenario};

/// Counts of the bus log's lines by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LogCounts {
    /// Frames received valid.
    pub frames: usize,
    /// Error frames.
    pub error_frames: usize,
    /// Overload frames.
    pub overload_frames: usize,
    /// Frames the run ended in.
    pub incomplete: usize,
}

impl LogCounts {
    /// Counts `event`.
    pub fn add(&mut self, event: &BusEvent) {
        match event.kind {
            BusEventKind::Frame { .. } => self.frames += 1,
            BusEventKind::ErrorFrame { .. } => self.error_frames += 1,
            BusEventKind::OverloadFrame { .. } => self.overload_frames += 1,
            BusEventKind::Incomplete { .. } => self.incomplete += 1,
        }
    }
}

/// The counts of `log`.
pub fn count_log(log: &[BusEvent]) -> LogCounts {
    let mut counts = LogCounts::default();
    log.iter().for_each(|event| counts.add(event));
    counts
}

/// The counts table of a bus that runs without end (`cansim serve`), one line per node.
pub fn format_counts_table(nodes: &[NodeCounts]) -> String {
    let width = nodes.iter().map(|n| n.name.len()).max().unwrap_or(0).max(4);
    let mut out = format!(
        "{:<width$}  sent  received  dropped  TXERR  RXERR  state\n",
        "node"
    );
    for n in nodes {
        out += &format!(
            "{:<width$}  {:>4}  {:>8}  {:>7}  {:>5}  {:>5}  {}\n",
            n.name, n.sent, n.received, n.dropped, n.tec, n.rec, n.state
        );
    }
    out
}

/// `1.234 ms`.
pub fn ms(fs: u64) -> String {
    format!("{:.3} ms", fs as f64 / FS_PER_MS as f64)
}

/// The summary table, one line per node.
pub fn format_table(nodes: &[NodeReport]) -> String {
    let width = nodes.iter().map(|n| n.name.len()).max().unwrap_or(0).max(4);
    let mut out = format!(
        "{:<width$}  sent  received  dropped  unsent  TXERR  RXERR  state          restarts  interrupts\n",
        "node"
    );
    for n in nodes {
        out += &format!(
            "{:<width$}  {:>4}  {:>8}  {:>7}  {:>6}  {:>5}  {:>5}  {:<13}  {:>8}  {}\n",
            n.name,
            n.sent,
            n.received.len(),
            n.dropped,
            n.unsent,
            n.tec,
            n.rec,
            n.state.to_string(),
            n.restarts,
            n.interrupts_text()
        );
    }
    out
}

/// `bus: 25 frames, 3 error frames, 0 overload frames`.
pub fn format_counts(counts: &LogCounts) -> String {
    let mut out = format!(
        "bus: {} frames, {} error frames, {} overload frames",
        counts.frames, counts.error_frames, counts.overload_frames
    );
    if counts.incomplete > 0 {
        out += &format!(", {} cut off by the end of the run", counts.incomplete);
    }
    out
}

impl fmt::Display for AppliedFault {
    /// `  1.234 ms  line 40: flip of the CRC delimiter of frame 3 (200#DEADBEEF from a)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:>12}  line {}: {}",
            ms(self.start_fs),
            self.line,
            self.text
        )
    }
}

impl fmt::Display for NodeEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:>12}  {}  ", ms(self.at_fs), self.node)?;
        let event = match self.what {
            Happening::Restarted => return f.write_str("restarted by its driver after bus-off"),
            Happening::Driver(event) => event,
        };
        match event {
            DriverEvent::Received(frame) => write!(f, "received {frame}"),
            DriverEvent::TxDone(frame) => write!(f, "sent {frame}"),
            DriverEvent::TxFailed(frame) => write!(f, "gave up {frame} (one-shot)"),
            DriverEvent::TxDropped(frame) => write!(f, "dropped {frame}"),
            DriverEvent::BusError { ecc, counters } => write!(
                f,
                "bus error, ECC 0x{ecc:02X} ({}); TXERR {}, RXERR {}",
                ecc_text(ecc),
                counters.txerr,
                counters.rxerr
            ),
            DriverEvent::ArbitrationLost { alc, .. } => {
                write!(f, "lost arbitration at bit {} (ALC)", alc & 0x1F)
            }
            DriverEvent::StateChanged {
                state,
                ir,
                counters,
                ..
            } => write!(
                f,
                "{state} ({}); TXERR {}, RXERR {}",
                state_irq_text(ir),
                counters.txerr,
                counters.rxerr
            ),
            DriverEvent::Overrun(_) => write!(f, "data overrun"),
            DriverEvent::WakeUp => write!(f, "woke up"),
            DriverEvent::SpuriousTxInterrupt { sr } => {
                write!(f, "TI without a frame in flight (SR 0x{sr:02X})")
            }
        }
    }
}

/// What [`format_report`] prints besides the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReportParts {
    /// The bus log.
    pub log: bool,
    /// What the drivers reported (frames sent, errors, state changes, restarts).
    pub events: bool,
    /// With `events`: the frames each driver received too.
    pub receptions: bool,
}

/// The report of a run of `scenario`: the nodes, `parts` of the log and events, the faults as they
/// landed, the bus counts and the summary table.
pub fn format_report(scenario: &Scenario, report: &RunReport, parts: ReportParts) -> String {
    let bus = &scenario.bus;
    let mut out = format!(
        "{}: {} nodes, {:.0} kbit/s at {} MHz ({}, sample point {:.1} %)\n",
        scenario.path.display(),
        scenario.nodes.len(),
        bus.btr.bitrate(f64::from(bus.clock_hz)) / 1000.0,
        f64::from(bus.clock_hz) / 1e6,
        bus.btr,
        bus.btr.sample_point() * 100.0
    );
    for node in &scenario.nodes {
        out += &format!("  {}\n", describe_node(node, scenario));
    }
    if parts.log {
        out += "\n";
        match CanopenLog::of_nodes(&scenario.nodes) {
            Some(mut canopen) => {
                for event in &report.log {
                    out += &canopen.line(event);
                    out += "\n";
                }
            }
            None => out += &report.log_text(),
        }
    }
    if parts.events {
        out += "\n";
        let shown: Vec<&NodeEvent> = report
            .events
            .iter()
            .filter(|e| {
                parts.receptions || !matches!(e.what, Happening::Driver(DriverEvent::Received(_)))
            })
            .collect();
        out += &format_events(&shown);
    }
    if !report.master.is_empty() {
        out += "\nCANopen master:\n";
        for line in &report.master {
            out += &format!("{line}\n");
        }
    }
    if !report.faults.is_empty() || !report.missed_faults.is_empty() {
        out += "\nfaults:\n";
        for fault in &report.faults {
            out += &format!("{fault}\n");
        }
        for missed in &report.missed_faults {
            out += &format!("  warning: {missed}\n");
        }
    }
    out += &format!("\n{}\n", format_counts(&count_log(&report.log)));
    out += &format_table(&report.nodes);
    out += &format!("simulated {}\n", ms(report.simulated_fs));
    out
}

/// One line per event, except that a run of bus errors of one node with the same ECC value shows
/// as its first and last.
fn format_events(events: &[&NodeEvent]) -> String {
    let mut out = String::new();
    let mut i = 0;
    while i < events.len() {
        let first = events[i];
        let run = events[i..]
            .iter()
            .take_while(|e| same_bus_error(first, e))
            .count()
            .max(1);
        out += &format!("{first}\n");
        if run > 1 {
            let last = events[i + run - 1];
            out += &format!("{last}  ({run} in a row)\n");
        }
        i += run;
    }
    out
}

/// Both are bus errors of the same node with the same ECC value.
fn same_bus_error(a: &NodeEvent, b: &NodeEvent) -> bool {
    match (a.what, b.what) {
        (
            Happening::Driver(DriverEvent::BusError { ecc: x, .. }),
            Happening::Driver(DriverEvent::BusError { ecc: y, .. }),
        ) => a.node == b.node && x == y,
        _ => false,
    }
}

/// `b: 16 MHz +1500 ppm, 60 ns from the bus, listen-only, filter ACR 20000000 AMR 1FFFFFFF`.
fn describe_node(node: &NodeConfig, scenario: &Scenario) -> String {
    let mut out = format!(
        "{}: {} MHz {:+} ppm, {} ns from the bus",
        node.name,
        f64::from(node.clock_hz) / 1e6,
        node.ppm,
        node.delay_fs / FS_PER_NS
    );
    if node.btr != scenario.bus.btr || node.clock_hz != scenario.bus.clock_hz {
        out += &format!(", {}", node.btr);
    }
    match node.mode {
        NodeMode::Normal => {}
        NodeMode::ListenOnly => out += ", listen-only",
        NodeMode::SelfTest => out += ", self-test",
    }
    if node.filter != crate::host::driver::open_filter() {
        let word = |bytes: [u8; 4]| u32::from_be_bytes(bytes);
        out += &format!(
            ", {} filter ACR {:08X} AMR {:08X}",
            if node.filter.single_filter {
                "single"
            } else {
                "dual"
            },
            word(node.filter.acr),
            word(node.filter.amr)
        );
    }
    if let Some(restart) = node.restart_fs {
        out += &format!(", restart {} after bus-off", ms(restart));
    }
    if node.one_shot {
        out += ", one-shot";
    }
    if let Some(canopen) = &node.canopen {
        let eds = canopen
            .eds
            .file_name()
            .unwrap_or_default()
            .to_string_lossy();
        out += &format!(", CANopen device {} ({eds})", canopen.node_id);
    }
    if let Some(master) = &node.canopen_master {
        let steps = master.steps.len();
        out += &format!(", CANopen master {} ({steps} steps)", master.config.node_id);
    }
    out
}

/// The interrupt bits of a state change, as names.
fn state_irq_text(ir: u8) -> String {
    let names: Vec<&str> = [(interrupt::EI, "EI"), (interrupt::EPI, "EPI")]
        .iter()
        .filter(|(bit, _)| ir & bit != 0)
        .map(|(_, name)| *name)
        .collect();
    names.join("+")
}

/// The SJA1000 ECC value in words: error type, direction, segment.
pub fn ecc_text(ecc: u8) -> String {
    let kind = ["bit error", "form error", "stuff error", "other error"][(ecc >> 6) as usize];
    let direction = if ecc & 0x20 != 0 {
        "receiving"
    } else {
        "transmitting"
    };
    let segment = match u64::from(ecc & 0x1F) {
        seg::SOF => "start of frame",
        seg::ID_28_21 | seg::ID_20_18 | seg::ID_17_13 | seg::ID_12_5 | seg::ID_4_0 => "identifier",
        seg::SRTR => "SRTR/RTR",
        seg::IDE => "IDE",
        seg::RTR => "RTR",
        seg::R1 | seg::R0 => "reserved bit",
        seg::DLC => "DLC",
        seg::DATA => "data field",
        seg::CRC => "CRC sequence",
        seg::CRC_DELIMITER => "CRC delimiter",
        seg::ACK_SLOT => "ACK slot",
        seg::ACK_DELIMITER => "ACK delimiter",
        seg::EOF => "end of frame",
        seg::INTERMISSION => "intermission",
        seg::ACTIVE_ERROR_FLAG => "active error flag",
        seg::PASSIVE_ERROR_FLAG => "passive error flag",
        seg::TOLERATE_DOMINANT => "tolerated dominant bits",
        seg::ERROR_DELIMITER => "error delimiter",
        seg::OVERLOAD_FLAG => "overload flag",
        _ => "unknown segment",
    };
    format!("{kind}, {direction}, {segment}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::host::driver::{CanState, DriverStats};

    #[test]
    fn ecc_values_read_as_words() {
        assert_eq!(ecc_text(0x78), "form error, receiving, CRC delimiter");
        assert_eq!(ecc_text(0xD9), "other error, transmitting, ACK slot");
    }

    #[test]
    fn the_table_lists_counts_state_and_the_interrupts_seen() {
        let mut stats = DriverStats::default();
        stats.interrupts[0] = 11;
        stats.interrupts[5] = 2;
        let node = NodeReport {
            name: "a".into(),
            sent: 9,
            received: vec![],
            dropped: 1,
            unsent: 0,
            tec: 127,
            rec: 0,
            state: CanState::ErrorWarning,
            restarts: 0,
            stats,
        };
        let table = format_table(&[node]);
        let row = table.lines().nth(1).unwrap();
        assert_eq!(
            row,
            "a        9         0        1       0    127      0  error-warning         0  RI 11, EPI 2"
        );
    }
}
