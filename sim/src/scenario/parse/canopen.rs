//! The CANopen keys of a scenario: `canopen = { node_id, eds }` (a device),
//! `canopen_master = { node_id, … }` (the master) and the master's script, `[[master]]` steps.
//! Values are written and checked by the type the target's EDS gives; an object the EDS does not
//! have is refused (unless the step expects the abort that brings).

use std::ops::Range;

use ::canopen::master::{Action, Awaited, MasterConfig, Step};
use ::canopen::nmt::{NmtCommand, NmtState};
use ::canopen::od::{DataType, ObjectDictionary};
use ::canopen::time_stamp::TimeOfDay;
use ::canopen::CanFrame;
use golden::frame::Id;
use serde::Deserialize;
use toml::{Spanned, Value};

use super::Builder;
use crate::engine::time::FS_PER_US;
use crate::scenario::canopen_master::{describe, Expect, MasterScript, RemoteNode, ScriptStep};
use crate::scenario::canopen_node::CanopenConfig;
use crate::scenario::{NodeMode, ScenarioError};

/// Defaults of the master: no heartbeat consumer time, SDO answers within 50 ms.
const DEFAULT_SDO_TIMEOUT_US: u64 = 50_000;

/// `canopen = { node_id = 2, eds = "io.eds" }`: the node's firmware is a CANopen device.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CanopenToml {
    node_id: Spanned<i64>,
    eds: Spanned<String>,
}

/// `canopen_master = { node_id = 1, heartbeat = "10ms", … }`: the node's firmware is the master.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MasterToml {
    node_id: Spanned<i64>,
    heartbeat: Option<Spanned<String>>,
    heartbeat_timeout: Option<Spanned<String>>,
    sdo_timeout: Option<Spanned<String>>,
    #[serde(default)]
    remote: Vec<Spanned<CanopenToml>>,
}

/// A `[[master]]` step: one action key and what goes with it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct StepToml {
    pub(super) at: Option<Spanned<String>>,
    pub(super) node: Option<Spanned<i64>>,
    nmt: Option<Spanned<NmtToml>>,
    pub(super) read: Option<Spanned<String>>,
    pub(super) write: Option<Spanned<String>>,
    pub(super) value: Option<Spanned<Value>>,
    pub(super) data: Option<Spanned<String>>,
    pub(super) block: Option<bool>,
    pub(super) expect: Option<Spanned<Value>>,
    pub(super) expect_data: Option<Spanned<String>>,
    pub(super) expect_abort: Option<Spanned<String>>,
    send: Option<Spanned<String>>,
    sync: Option<Spanned<String>>,
    time: Option<Spanned<String>>,
    heartbeat: Option<Spanned<String>>,
    wait: Option<Spanned<String>>,
    #[serde(rename = "await")]
    awaits: Option<Spanned<AwaitToml>>,
    await_emcy: Option<Spanned<i64>>,
    within: Option<Spanned<String>>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum NmtToml {
    Start,
    Stop,
    PreOperational,
    ResetNode,
    ResetCommunication,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "kebab-case")]
enum AwaitToml {
    BootUp,
    PreOperational,
    Operational,
    Stopped,
    Lost,
}

/// The action keys of a step.
const ACTIONS: &str = "nmt, read, write, send, sync, time, heartbeat, wait, await or await_emcy";

impl Builder<'_> {
    /// A CANopen device: a node-ID of 1 to 127 no other node has, an EDS that reads, a node that
    /// sends.
    pub(super) fn canopen(
        &self,
        spanned: &Spanned<CanopenToml>,
        mode: NodeMode,
    ) -> Result<CanopenConfig, ScenarioError> {
        let c = spanned.get_ref();
        self.sending_canopen_node(spanned.span(), mode)?;
        let node_id = self.free_node_id(&c.node_id)?;
        let (eds, od) = self.eds(&c.eds, node_id)?;
        Ok(CanopenConfig { node_id, eds, od })
    }

    /// The CANopen master: its node-ID and settings (the script comes from `[[master]]`).
    pub(super) fn canopen_master(
        &self,
        spanned: &Spanned<MasterToml>,
        mode: NodeMode,
    ) -> Result<MasterScript, ScenarioError> {
        let m = spanned.get_ref();
        self.sending_canopen_node(spanned.span(), mode)?;
        let node_id = self.free_node_id(&m.node_id)?;
        let heartbeat_ms = match &m.heartbeat {
            Some(period) => self.heartbeat_ms(period)?,
            None => 0,
        };
        let us = |t: &Option<Spanned<String>>, default| -> Result<u64, ScenarioError> {
            let Some(t) = t else {
                return Ok(default);
            };
            match self.time(t)? / FS_PER_US {
                0 => Err(self.error(t.span(), "a timeout of at least 1 us")),
                us => Ok(us),
            }
        };
        let mut remote: Vec<RemoteNode> = Vec::new();
        for r in &m.remote {
            let id = self.node_id(&r.get_ref().node_id)?;
            if id == node_id
                || self.dictionary(id).is_some()
                || remote.iter().any(|n| n.node_id == id)
            {
                return Err(self.error(
                    r.get_ref().node_id.span(),
                    format!("node-ID {id} is known already"),
                ));
            }
            let (eds, od) = self.eds(&r.get_ref().eds, id)?;
            remote.push(RemoteNode {
                node_id: id,
                eds,
                od,
            });
        }
        Ok(MasterScript {
            config: MasterConfig {
                node_id,
                heartbeat_ms,
                heartbeat_timeout_us: us(&m.heartbeat_timeout, 0)?,
                sdo_timeout_us: us(&m.sdo_timeout, DEFAULT_SDO_TIMEOUT_US)?,
                time_start: TimeOfDay::Y2000,
            },
            steps: Vec::new(),
            remote,
        })
    }

    fn sending_canopen_node(
        &self,
        span: Range<usize>,
        mode: NodeMode,
    ) -> Result<(), ScenarioError> {
        if mode == NodeMode::ListenOnly {
            return Err(self.error(
                span,
                "a CANopen node sends (boot-up, SDO, heartbeat): it cannot be listen-only",
            ));
        }
        Ok(())
    }

    fn node_id(&self, id: &Spanned<i64>) -> Result<u8, ScenarioError> {
        let value = *id.get_ref();
        u8::try_from(value)
            .ok()
            .filter(|id| (1..=127).contains(id))
            .ok_or_else(|| {
                self.error(
                    id.span(),
                    format!("node-ID {value} is out of range 1..=127 (CiA 301)"),
                )
            })
    }

    /// A node-ID of 1 to 127 that no CANopen node of the scenario has yet.
    fn free_node_id(&self, id: &Spanned<i64>) -> Result<u8, ScenarioError> {
        let node_id = self.node_id(id)?;
        let taken = self.nodes.iter().find(|n| {
            let device = n.canopen.as_ref().map(|c| c.node_id);
            let master = n.canopen_master.as_ref().map(|m| m.config.node_id);
            device == Some(node_id) || master == Some(node_id)
        });
        if let Some(other) = taken {
            return Err(self.error(
                id.span(),
                format!("node-ID {node_id} is node \"{}\"'s already", other.name),
            ));
        }
        Ok(node_id)
    }

    fn eds(
        &self,
        file: &Spanned<String>,
        node_id: u8,
    ) -> Result<(std::path::PathBuf, ObjectDictionary), ScenarioError> {
        let eds = self.replay_path(file.get_ref());
        let od = ::canopen::eds::load(&eds, node_id)
            .map_err(|e| self.error(file.span(), format!("EDS: {e}")))?;
        Ok((eds, od))
    }

    /// The dictionary of node-ID `id`: a device of the scenario, or a remote node of the master.
    pub(super) fn dictionary(&self, id: u8) -> Option<&ObjectDictionary> {
        self.nodes.iter().find_map(|n| {
            let device = n
                .canopen
                .as_ref()
                .filter(|c| c.node_id == id)
                .map(|c| &c.od);
            let remote = n
                .canopen_master
                .as_ref()
                .and_then(|m| m.remote.iter().find(|r| r.node_id == id).map(|r| &r.od));
            device.or(remote)
        })
    }

    fn heartbeat_ms(&self, period: &Spanned<String>) -> Result<u16, ScenarioError> {
        if period.get_ref() == "off" {
            return Ok(0);
        }
        let ms = self.time(period)? as f64 / (1000.0 * FS_PER_US as f64);
        if ms.fract() != 0.0 || !(1.0..=65535.0).contains(&ms) {
            return Err(self.error(
                period.span(),
                "a heartbeat period is whole milliseconds, 1 to 65535 (1017h is UNSIGNED16 ms)",
            ));
        }
        Ok(ms as u16)
    }

    /// The `[[master]]` steps, given to the scenario's master.
    pub(super) fn master_script(
        &mut self,
        steps: &[Spanned<StepToml>],
    ) -> Result<(), ScenarioError> {
        let masters: Vec<usize> = (0..self.nodes.len())
            .filter(|&n| self.nodes[n].canopen_master.is_some())
            .collect();
        let master = match (masters.as_slice(), steps.first()) {
            ([], None) => return Ok(()),
            ([], Some(first)) => {
                return Err(self.source.table_error(
                    first.span(),
                    "[[master]] steps need a node with canopen_master = { node_id = … }",
                ))
            }
            ([one], _) => *one,
            (_, _) => {
                return Err(ScenarioError::in_file(
                    self.source.path,
                    "more than one node has canopen_master: a scenario has one CANopen master",
                ))
            }
        };
        let script = steps
            .iter()
            .map(|s| self.step(s))
            .collect::<Result<Vec<_>, _>>()?;
        let config = self.nodes[master].canopen_master.as_mut().expect("found");
        config.steps = script;
        Ok(())
    }

    fn step(&self, spanned: &Spanned<StepToml>) -> Result<ScriptStep, ScenarioError> {
        let s = spanned.get_ref();
        let line = self.source.line(&spanned.span());
        let actions = [
            s.nmt.is_some(),
            s.read.is_some(),
            s.write.is_some(),
            s.send.is_some(),
            s.sync.is_some(),
            s.time.is_some(),
            s.heartbeat.is_some(),
            s.wait.is_some(),
            s.awaits.is_some(),
            s.await_emcy.is_some(),
        ];
        if actions.iter().filter(|a| **a).count() != 1 {
            return Err(self.source.table_error(
                spanned.span(),
                format!("a [[master]] step does exactly one of: {ACTIONS}"),
            ));
        }
        let not_before_us = match &s.at {
            Some(at) => self.time(at)? / FS_PER_US,
            None => 0,
        };
        self.keys_of(s)?;
        let (action, expect, data_type, name) = self.action(s, spanned.span())?;
        Ok(ScriptStep {
            line,
            text: describe(&action, &name),
            step: Step {
                not_before_us,
                action,
            },
            expect,
            data_type,
        })
    }

    /// Refuses keys the step's action does not use.
    fn keys_of(&self, s: &StepToml) -> Result<(), ScenarioError> {
        let sdo = s.read.is_some() || s.write.is_some();
        let awaits = s.awaits.is_some() || s.await_emcy.is_some();
        let rules: [(Option<Range<usize>>, bool, &str); 7] = [
            (
                s.value.as_ref().map(|v| v.span()),
                s.write.is_some(),
                "value: only with write",
            ),
            (
                s.data.as_ref().map(|v| v.span()),
                s.write.is_some(),
                "data: only with write",
            ),
            (
                s.expect.as_ref().map(|v| v.span()),
                s.read.is_some(),
                "expect: only with read",
            ),
            (
                s.expect_data.as_ref().map(|v| v.span()),
                s.read.is_some(),
                "expect_data: only with read",
            ),
            (
                s.expect_abort.as_ref().map(|v| v.span()),
                sdo,
                "expect_abort: only with read or write",
            ),
            (
                s.within.as_ref().map(|v| v.span()),
                awaits,
                "within: only with await or await_emcy",
            ),
            (
                s.node.as_ref().map(|v| v.span()),
                sdo || awaits || s.nmt.is_some(),
                "node: only with nmt, read, write, await or await_emcy",
            ),
        ];
        for (span, allowed, message) in rules {
            if let (Some(span), false) = (span, allowed) {
                return Err(self.error(span, message));
            }
        }
        Ok(())
    }

    /// The step's action, what it expects, the type and name of its object.
    fn action(
        &self,
        s: &StepToml,
        whole: Range<usize>,
    ) -> Result<(Action, Expect, Option<DataType>, String), ScenarioError> {
        let simple = |action| Ok((action, Expect::Success, None, String::new()));
        if let Some(command) = &s.nmt {
            let node = self.target(s, whole, true)?;
            let command = match command.get_ref() {
                NmtToml::Start => NmtCommand::Start,
                NmtToml::Stop => NmtCommand::Stop,
                NmtToml::PreOperational => NmtCommand::EnterPreOperational,
                NmtToml::ResetNode => NmtCommand::ResetNode,
                NmtToml::ResetCommunication => NmtCommand::ResetCommunication,
            };
            return simple(Action::Nmt { command, node });
        }
        if let Some(address) = s.read.as_ref().or(s.write.as_ref()) {
            return self.sdo(s, address, whole);
        }
        if let Some(text) = &s.send {
            return simple(Action::Send(self.canopen_frame(text)?));
        }
        if let Some(period) = &s.sync {
            return simple(Action::Sync {
                period_us: self.period_us(period)?,
            });
        }
        if let Some(period) = &s.time {
            return simple(Action::Time {
                period_us: self.period_us(period)?,
            });
        }
        if let Some(period) = &s.heartbeat {
            return simple(Action::Heartbeat {
                period_ms: self.heartbeat_ms(period)?,
            });
        }
        if let Some(wait) = &s.wait {
            return simple(Action::Wait {
                us: self.time(wait)? / FS_PER_US,
            });
        }
        let node = self.target(s, whole, false)?;
        let within_us = match &s.within {
            Some(within) => self.time(within)? / FS_PER_US,
            None => u64::MAX / 2,
        };
        if let Some(state) = &s.awaits {
            let state = match state.get_ref() {
                AwaitToml::BootUp => Awaited::BootUp,
                AwaitToml::PreOperational => Awaited::State(NmtState::PreOperational),
                AwaitToml::Operational => Awaited::State(NmtState::Operational),
                AwaitToml::Stopped => Awaited::State(NmtState::Stopped),
                AwaitToml::Lost => Awaited::Lost,
            };
            return simple(Action::AwaitState {
                node,
                state,
                within_us,
            });
        }
        let code = s.await_emcy.as_ref().expect("the one action left");
        let code = u16::try_from(*code.get_ref())
            .map_err(|_| self.error(code.span(), "an EMCY error code has 16 bits"))?;
        simple(Action::AwaitEmergency {
            node,
            code,
            within_us,
        })
    }

    /// The step's node: 1 to 127 (0 too, for all nodes, with `all`).
    pub(super) fn target(
        &self,
        s: &StepToml,
        whole: Range<usize>,
        all: bool,
    ) -> Result<u8, ScenarioError> {
        let Some(node) = &s.node else {
            return Err(self
                .source
                .table_error(whole, "this step needs node = <node-ID>"));
        };
        if all && *node.get_ref() == 0 {
            return Ok(0);
        }
        self.node_id(node)
    }

    /// A frame in candump notation with a standard identifier, as CANopen sends them.
    fn canopen_frame(&self, text: &Spanned<String>) -> Result<CanFrame, ScenarioError> {
        let frame = self.frame(text)?;
        let Id::Standard(id) = frame.id() else {
            return Err(self.error(text.span(), "CANopen frames have 11-bit identifiers"));
        };
        Ok(if frame.is_remote() {
            CanFrame {
                id,
                remote: true,
                data: vec![0; usize::from(frame.dlc())],
            }
        } else {
            CanFrame::new(id, frame.data_bytes())
        })
    }

    fn period_us(&self, period: &Spanned<String>) -> Result<u64, ScenarioError> {
        if period.get_ref() == "off" {
            return Ok(0);
        }
        let us = self.time(period)? / FS_PER_US;
        if us == 0 {
            return Err(self.error(period.span(), "a period of at least 1 us, or \"off\""));
        }
        Ok(us)
    }
}
