//! Queries on the report of a scenario run (`sim::scenario::run`): what one node's driver reported,
//! and what the bus log shows, in forms tests compare easily.

use golden::frame::Frame;
use sim::decode::bus_decoder::BusEventKind;
use sim::host::driver::{CanState, DriverEvent};
use sim::scenario::report::{Happening, NodeReport};
use sim::scenario::RunReport;

/// What node `node`'s driver reported, in order, with the times.
pub fn driver_events(report: &RunReport, node: &str) -> Vec<(u64, DriverEvent)> {
    report
        .events
        .iter()
        .filter(|e| e.node == node)
        .filter_map(|e| match e.what {
            Happening::Driver(event) => Some((e.at_fs, event)),
            Happening::Restarted => None,
        })
        .collect()
}

/// When node `node`'s driver restarted it after bus-off.
pub fn restarts(report: &RunReport, node: &str) -> Vec<u64> {
    report
        .events
        .iter()
        .filter(|e| e.node == node && e.what == Happening::Restarted)
        .map(|e| e.at_fs)
        .collect()
}

/// The ECC values node `node`'s driver read (BEI), in order.
pub fn bus_errors(report: &RunReport, node: &str) -> Vec<u8> {
    driver_events(report, node)
        .into_iter()
        .filter_map(|(_, e)| match e {
            DriverEvent::BusError { ecc, .. } => Some(ecc),
            _ => None,
        })
        .collect()
}

/// The arbitration positions node `node`'s driver read from ALC (ALI), in order.
pub fn losses(report: &RunReport, node: &str) -> Vec<u8> {
    driver_events(report, node)
        .into_iter()
        .filter_map(|(_, e)| match e {
            DriverEvent::ArbitrationLost { alc, .. } => Some(alc & 0x1F),
            _ => None,
        })
        .collect()
}

/// The device states node `node`'s driver went through, in order.
pub fn states(report: &RunReport, node: &str) -> Vec<CanState> {
    driver_events(report, node)
        .into_iter()
        .filter_map(|(_, e)| match e {
            DriverEvent::StateChanged { state, .. } => Some(state),
            _ => None,
        })
        .collect()
}

/// The frames every node sent (TI), in the order of the reports, with the sender.
pub fn sent_frames(report: &RunReport) -> Vec<(String, Frame)> {
    report
        .events
        .iter()
        .filter_map(|e| match e.what {
            Happening::Driver(DriverEvent::TxDone(frame)) => Some((e.node.clone(), frame)),
            _ => None,
        })
        .collect()
}

/// The node called `name`.
pub fn node<'r>(report: &'r RunReport, name: &str) -> &'r NodeReport {
    report
        .nodes
        .iter()
        .find(|n| n.name == name)
        .unwrap_or_else(|| panic!("no node {name} in the report"))
}

/// The valid frames of the bus log, in order.
pub fn log_frames(report: &RunReport) -> Vec<Frame> {
    report
        .log
        .iter()
        .filter_map(|e| match &e.kind {
            BusEventKind::Frame { frame, .. } => Some(*frame),
            _ => None,
        })
        .collect()
}

/// How many error frames the bus log has.
pub fn error_frames(report: &RunReport) -> usize {
    report
        .log
        .iter()
        .filter(|e| matches!(e.kind, BusEventKind::ErrorFrame { .. }))
        .count()
}

/// The lines of the bus log that contain `text`.
pub fn log_lines_with(report: &RunReport, text: &str) -> Vec<String> {
    report
        .log_text()
        .lines()
        .filter(|l| l.contains(text))
        .map(str::to_string)
        .collect()
}
