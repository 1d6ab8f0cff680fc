//! Scenario nodes whose firmware is a CANopen stack of the `canopen` crate, a device
//! (`canopen = { node_id, eds }`) or the master (`canopen_master = { … }`): the stack gets every
//! frame the node's driver read from the RX FIFO, with its time, and the time as it passes; what it sends goes to the node's driver like any frame of the
//! traffic, through the SJA1000 registers and the cycle-accurate bus.

use std::collections::VecDeque;
use std::path::PathBuf;

use canopen::device::Device;
use canopen::master::{Master, MasterEvent};
use canopen::od::ObjectDictionary;
use canopen::trace::Tracer;
use canopen::CanFrame;
use golden::frame::{Frame, Id};

use crate::decode::bus_decoder::{BusEvent, BusEventKind};
use crate::engine::time::FS_PER_US;
use crate::host::driver::DriverEvent;

use super::report::Happening;
use super::{NodeConfig, ScenarioError};

/// A node's CANopen device: its node-ID and object dictionary.
#[derive(Clone, Debug, PartialEq)]
pub struct CanopenConfig {
    /// Node-ID, 1 to 127.
    pub node_id: u8,
    /// The EDS it was read from.
    pub eds: PathBuf,
    /// The object dictionary the EDS describes, at its defaults.
    pub od: ObjectDictionary,
}

/// The CANopen stack a node runs.
enum Stack {
    Device(Box<Device>),
    Master(Box<Master>),
}

/// The CANopen firmware of a running node.
pub(crate) struct Firmware {
    stack: Stack,
    /// Events of the node already handed to the device.
    seen: usize,
    /// What the device sent that the driver's queue had no room for yet (a block upload sends up
    /// to 127 segments at once): the stack's own transmit buffer, which waits instead of dropping.
    outbox: VecDeque<Frame>,
}

impl Firmware {
    /// The firmware of node `config`, if it runs CANopen; not started yet.
    pub(crate) fn of_node(config: &NodeConfig) -> Result<Option<Firmware>, ScenarioError> {
        let stack = match (&config.canopen, &config.canopen_master) {
            (Some(device), _) => {
                let device = Device::new(device.node_id, device.od.clone());
                Stack::Device(Box::new(device.map_err(ScenarioError::new)?))
            }
            (None, Some(script)) => {
                let steps = script.steps.iter().map(|s| s.step.clone()).collect();
                let master = Master::new(script.config, steps).map_err(ScenarioError::new)?;
                Stack::Master(Box::new(master))
            }
            (None, None) => return Ok(None),
        };
        Ok(Some(Firmware {
            stack,
            seen: 0,
            outbox: VecDeque::new(),
        }))
    }

    /// Power-on at `now_fs`: the boot-up message goes to the outbox.
    pub(crate) fn start(&mut self, now_fs: u64) {
        let now_us = now_fs / FS_PER_US;
        let frames = match &mut self.stack {
            Stack::Device(device) => device.start(now_us),
            Stack::Master(master) => master.start(now_us),
        };
        self.outbox.extend(frames.iter().map(to_frame));
    }

    /// What the master reported since the last call (nothing for a device).
    pub(crate) fn take_master_events(&mut self) -> Vec<(u64, MasterEvent)> {
        match &mut self.stack {
            Stack::Master(master) => master.take_events(),
            Stack::Device(_) => Vec::new(),
        }
    }

    /// The next frame of the outbox, for the driver's queue.
    pub(crate) fn next_frame(&mut self) -> Option<Frame> {
        self.outbox.pop_front()
    }

    /// Hands the device the frames among `events` it has not seen (what the driver read), then the
    /// time `now_fs`; what it sends goes to the outbox.
    pub(crate) fn run(&mut self, events: &[(u64, Happening)], now_fs: u64) {
        let mut out = Vec::new();
        for (at_fs, what) in &events[self.seen.min(events.len())..] {
            if let Happening::Driver(DriverEvent::Received(frame)) = what {
                if let Some(frame) = from_frame(frame) {
                    let at_us = at_fs / FS_PER_US;
                    out.extend(match &mut self.stack {
                        Stack::Device(device) => device.receive(&frame, at_us),
                        Stack::Master(master) => master.receive(&frame, at_us),
                    });
                }
            }
        }
        self.seen = events.len();
        let now_us = now_fs / FS_PER_US;
        out.extend(match &mut self.stack {
            Stack::Device(device) => device.tick(now_us),
            Stack::Master(master) => master.tick(now_us),
        });
        self.outbox.extend(out.iter().map(to_frame));
    }

    /// The node's events were taken away: count from the start again.
    pub(crate) fn events_taken(&mut self) {
        self.seen = 0;
    }

    /// When the device next has something due.
    pub(crate) fn deadline_fs(&self) -> Option<u64> {
        let deadline = match &self.stack {
            Stack::Device(device) => device.next_deadline(),
            Stack::Master(master) => master.next_deadline(),
        };
        deadline.map(|us| us.saturating_mul(FS_PER_US))
    }
}

/// Column at which a log line's CANopen meaning starts.
const MEANING_COLUMN: usize = 44;

/// Bus-log lines with their CANopen meaning:
/// `(0.000036) can0 702#00                      ; boot-up of node 2`.
pub struct CanopenLog {
    tracer: Tracer,
}

impl CanopenLog {
    /// A log that knows the dictionaries of `nodes` (node-ID, dictionary at its defaults).
    pub fn new(nodes: impl IntoIterator<Item = (u8, ObjectDictionary)>) -> CanopenLog {
        CanopenLog {
            tracer: Tracer::new(nodes.into_iter().collect()),
        }
    }

    /// The log of a scenario with CANopen `nodes` (devices or a master), if it has any.
    pub fn of_nodes(nodes: &[NodeConfig]) -> Option<CanopenLog> {
        let devices = nodes
            .iter()
            .filter_map(|n| n.canopen.as_ref())
            .map(|c| (c.node_id, c.od.clone()));
        let remote = nodes
            .iter()
            .filter_map(|n| n.canopen_master.as_ref())
            .flat_map(|m| m.remote.iter().map(|r| (r.node_id, r.od.clone())));
        let known: Vec<(u8, ObjectDictionary)> = devices.chain(remote).collect();
        let canopen = nodes
            .iter()
            .any(|n| n.canopen.is_some() || n.canopen_master.is_some());
        canopen.then(|| CanopenLog::new(known))
    }

    /// `event`'s log line, with what a frame with a standard identifier means in CANopen.
    pub fn line(&mut self, event: &BusEvent) -> String {
        let line = event.to_string();
        let BusEventKind::Frame { frame, .. } = &event.kind else {
            return line;
        };
        let meaning = from_frame(frame).map(|f| self.tracer.describe(&f));
        match meaning.filter(|m| !m.is_empty()) {
            Some(meaning) => format!("{line:<MEANING_COLUMN$}; {meaning}"),
            None => line,
        }
    }
}

/// A received frame as CANopen sees it: standard identifiers only (CANopen uses CAN 2.0A).
fn from_frame(frame: &Frame) -> Option<CanFrame> {
    let Id::Standard(id) = frame.id() else {
        return None;
    };
    Some(CanFrame {
        id,
        remote: frame.is_remote(),
        data: if frame.is_remote() {
            vec![0; usize::from(frame.dlc())]
        } else {
            frame.data_bytes().to_vec()
        },
    })
}

/// A frame the device sends.
fn to_frame(frame: &CanFrame) -> Frame {
    let id = Id::standard(frame.id).expect("CANopen COB-IDs have 11 bits");
    if frame.remote {
        Frame::remote(id, frame.data.len() as u8).expect("a DLC of at most 8")
    } else {
        Frame::data(id, &frame.data).expect("at most 8 data bytes")
    }
}
