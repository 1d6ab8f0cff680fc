//! Scenario nodes whose firmware is the CANopen device stack (`canopen = { node_id, eds }`): the
//! stack of the `canopen` crate gets every frame the node's driver read from the RX FIFO, with its
//! time, and the time as it passes; what it sends goes to the node's driver like any frame of the
//! traffic, through the SJA1000 registers and the cycle-accurate bus.

use std::collections::VecDeque;
use std::path::PathBuf;

use canopen::device::Device;
use canopen::od::ObjectDictionary;
use canopen::trace::Tracer;
use canopen::CanFrame;
use golden::frame::{Frame, Id};

use crate::decode::bus_decoder::{BusEvent, BusEventKind};
use crate::engine::time::FS_PER_US;
use crate::host::driver::DriverEvent;

use super::report::Happening;
use super::ScenarioError;

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

/// The CANopen firmware of a running node.
pub(crate) struct Firmware {
    device: Device,
    /// Events of the node already handed to the device.
    seen: usize,
    /// What the device sent that the driver's queue had no room for yet (a block upload sends up
    /// to 127 segments at once): the stack's own transmit buffer, which waits instead of dropping.
    outbox: VecDeque<Frame>,
}

impl Firmware {
    /// The firmware of `config`, not started yet.
    pub(crate) fn new(config: &CanopenConfig) -> Result<Firmware, ScenarioError> {
        let device = Device::new(config.node_id, config.od.clone()).map_err(ScenarioError::new)?;
        Ok(Firmware {
            device,
            seen: 0,
            outbox: VecDeque::new(),
        })
    }

    /// Power-on at `now_fs`: the device's boot-up message goes to its outbox.
    pub(crate) fn start(&mut self, now_fs: u64) {
        let frames = self.device.start(now_fs / FS_PER_US);
        self.outbox.extend(frames.iter().map(to_frame));
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
                    out.extend(self.device.receive(&frame, at_fs / FS_PER_US));
                }
            }
        }
        self.seen = events.len();
        out.extend(self.device.tick(now_fs / FS_PER_US));
        self.outbox.extend(out.iter().map(to_frame));
    }

    /// The node's events were taken away: count from the start again.
    pub(crate) fn events_taken(&mut self) {
        self.seen = 0;
    }

    /// When the device next has something due.
    pub(crate) fn deadline_fs(&self) -> Option<u64> {
        self.device.next_deadline().map(|us| us * FS_PER_US)
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

    /// The log of the CANopen devices among `nodes`, if there is one.
    pub fn of_nodes(nodes: &[super::NodeConfig]) -> Option<CanopenLog> {
        let devices: Vec<(u8, ObjectDictionary)> = nodes
            .iter()
            .filter_map(|n| n.canopen.as_ref())
            .map(|c| (c.node_id, c.od.clone()))
            .collect();
        (!devices.is_empty()).then(|| CanopenLog::new(devices))
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
