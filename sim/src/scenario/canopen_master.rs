//! The CANopen master of a scenario (`canopen_master = { … }` on a node, its script in
//! `[[master]]` steps): the script as parsed, with what each step expects, and the master's
//! reports turned into log lines that say whether each step got what it expected.

use std::path::PathBuf;

use canopen::master::{Action, MasterConfig, MasterEvent, Outcome, Step};
use canopen::node_table::Notice;
use canopen::od::{DataType, ObjectDictionary};
use canopen::sdo::Abort;

use crate::engine::time::FS_PER_US;

/// The master of a scenario and its script.
#[derive(Clone, Debug, PartialEq)]
pub struct MasterScript {
    /// Node-ID, heartbeat, timeouts.
    pub config: MasterConfig,
    /// The steps, in file order.
    pub steps: Vec<ScriptStep>,
    /// Nodes outside the scenario it talks to, with their EDS (for values and the log).
    pub remote: Vec<RemoteNode>,
}

/// A node the master knows from an EDS of its own (`remote = [{ node_id, eds }]`).
#[derive(Clone, Debug, PartialEq)]
pub struct RemoteNode {
    /// Node-ID.
    pub node_id: u8,
    /// The EDS.
    pub eds: PathBuf,
    /// Its dictionary.
    pub od: ObjectDictionary,
}

/// One step of the script.
#[derive(Clone, Debug, PartialEq)]
pub struct ScriptStep {
    /// Its line in the scenario file.
    pub line: usize,
    /// What the master does.
    pub step: Step,
    /// The step in words: `read 1008h:00 (Manufacturer device name) of node 2`.
    pub text: String,
    /// What it must give.
    pub expect: Expect,
    /// The type of the object it reads or writes, if known (to show values).
    pub data_type: Option<DataType>,
}

/// What a step must give besides success.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Expect {
    /// Success.
    Success,
    /// A read giving these bytes.
    Data(Vec<u8>),
    /// An SDO abort with this code.
    Abort(Abort),
}

/// A line of the master's log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MasterLine {
    /// Simulated time.
    pub at_fs: u64,
    /// What happened.
    pub text: String,
    /// A step that did not give what it expected.
    pub failed: bool,
}

impl std::fmt::Display for MasterLine {
    /// `   12.345 ms  line 40: read 1008h:00 of node 2 = "cansim IO 8x8"`, `FAILED` before the
    /// text of a failed step.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let ms = self.at_fs as f64 / (1000.0 * FS_PER_US as f64);
        let failed = if self.failed { "FAILED " } else { "" };
        write!(f, "{ms:10.3} ms  {failed}{}", self.text)
    }
}

impl MasterScript {
    /// The log lines of the master's `events` (µs times); `finished` counts the steps that ended.
    pub fn lines(&self, events: &[(u64, MasterEvent)], finished: &mut usize) -> Vec<MasterLine> {
        let mut lines = Vec::new();
        for (at_us, event) in events {
            let at_fs = at_us * FS_PER_US;
            let (text, failed) = match event {
                MasterEvent::Began(_) => continue,
                MasterEvent::Finished { step, outcome } => {
                    *finished += 1;
                    let step = &self.steps[*step];
                    let (result, failed) = judge(step, outcome);
                    (format!("line {}: {}{result}", step.line, step.text), failed)
                }
                MasterEvent::Notice(notice) => (notice_text(notice), false),
            };
            lines.push(MasterLine {
                at_fs,
                text,
                failed,
            });
        }
        lines
    }

    /// Failed lines for the steps after the first `finished` that never ended by `end_fs`.
    pub fn unfinished(&self, finished: usize, end_fs: u64) -> Vec<MasterLine> {
        self.steps[finished.min(self.steps.len())..]
            .iter()
            .map(|step| MasterLine {
                at_fs: end_fs,
                text: format!(
                    "line {}: {}: not finished when the run ended",
                    step.line, step.text
                ),
                failed: true,
            })
            .collect()
    }
}

/// What a step's outcome says, and whether it failed.
fn judge(step: &ScriptStep, outcome: &Outcome) -> (String, bool) {
    let show = |data: &[u8]| show_value(data, step.data_type);
    match (outcome, &step.expect) {
        (Outcome::Uploaded(data), Expect::Data(expected)) if data != expected => (
            format!(" = {}, expected {}", show(data), show(expected)),
            true,
        ),
        (Outcome::Uploaded(data), Expect::Abort(abort)) => {
            (format!(" = {}, expected abort {abort}", show(data)), true)
        }
        (Outcome::Uploaded(data), _) => (format!(" = {}", show(data)), false),
        (Outcome::Downloaded, Expect::Abort(abort)) => {
            (format!(": done, expected abort {abort}"), true)
        }
        (Outcome::Aborted(abort), Expect::Abort(expected)) if abort == expected => {
            (format!(": abort {abort}, as expected"), false)
        }
        (Outcome::Aborted(abort), _) => (format!(": abort {abort}"), true),
        (Outcome::NotSeen, _) => (": not seen in time".to_string(), true),
        (Outcome::Seen, _) => (": seen".to_string(), false),
        (Outcome::Downloaded | Outcome::Done, _) => (": done".to_string(), false),
    }
}

/// A value of `data_type` in words: numbers in decimal, strings quoted, anything else in hex.
pub fn show_value(data: &[u8], data_type: Option<DataType>) -> String {
    match data_type {
        Some(DataType::VisibleString) => format!("{:?}", String::from_utf8_lossy(data)),
        Some(t) if t.size() == Some(data.len()) && t.number(data).is_some() => {
            t.number(data).expect("checked").to_string()
        }
        _ => {
            let hex: Vec<String> = data.iter().map(|b| format!("{b:02X}")).collect();
            format!("{} (hex)", hex.join(" "))
        }
    }
}

fn notice_text(notice: &Notice) -> String {
    match notice {
        Notice::BootUp(node) => format!("node {node}: boot-up"),
        Notice::State(node, state) => format!("node {node}: heartbeat, {}", state_name(*state)),
        Notice::HeartbeatLost(node) => format!("node {node}: heartbeat lost"),
        Notice::Emergency(e) => format!(
            "node {}: EMCY {:04X}h, error register {:02X}h",
            e.node, e.code, e.register
        ),
    }
}

/// An NMT state as the script names it.
pub fn state_name(state: canopen::nmt::NmtState) -> &'static str {
    use canopen::nmt::NmtState;
    match state {
        NmtState::Initialisation => "boot-up",
        NmtState::PreOperational => "pre-operational",
        NmtState::Operational => "operational",
        NmtState::Stopped => "stopped",
    }
}

/// The step `action` in words, `name` naming its object.
pub fn describe(action: &Action, name: &str) -> String {
    match action {
        Action::Nmt { command, node } => {
            let target = match node {
                0 => "all nodes".to_string(),
                n => format!("node {n}"),
            };
            format!("NMT {command:?} to {target}")
        }
        Action::Read {
            node,
            index,
            sub,
            block,
        } => format!(
            "{}read {index:04X}h:{sub:02X}{name} of node {node}",
            if *block { "block " } else { "" }
        ),
        Action::Write {
            node,
            index,
            sub,
            block,
            ..
        } => format!(
            "{}write {index:04X}h:{sub:02X}{name} of node {node}",
            if *block { "block " } else { "" }
        ),
        Action::Send(frame) => {
            let data: String = frame.data.iter().map(|b| format!("{b:02X}")).collect();
            format!("send {:03X}#{data}", frame.id)
        }
        Action::Sync { period_us } => producer("SYNC", *period_us),
        Action::Time { period_us } => producer("TIME", *period_us),
        Action::Heartbeat { period_ms } => producer("heartbeat", u64::from(*period_ms) * 1000),
        Action::Wait { us } => format!("wait {} ms", *us as f64 / 1000.0),
        Action::AwaitState { node, state, .. } => {
            let state = match state {
                canopen::master::Awaited::BootUp => "boot-up",
                canopen::master::Awaited::Lost => "heartbeat lost",
                canopen::master::Awaited::State(s) => state_name(*s),
            };
            format!("await node {node} {state}")
        }
        Action::AwaitEmergency { node, code, .. } => {
            format!("await EMCY {code:04X}h of node {node}")
        }
    }
}

fn producer(what: &str, period_us: u64) -> String {
    match period_us {
        0 => format!("{what} off"),
        us => format!("{what} every {} ms", us as f64 / 1000.0),
    }
}
