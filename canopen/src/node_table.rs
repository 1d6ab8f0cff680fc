//! The master's view of the network: a heartbeat consumer that keeps a table of the nodes it has
//! heard (their NMT state from boot-up and heartbeat messages, 700h + node-ID, CiA 301
//! 7.2.8.3.2), marks a node lost when its heartbeat stays away longer than the consumer time,
//! and an EMCY consumer (80h + node-ID: error code, error register, 5 manufacturer bytes,
//! 7.2.7.3.1).

use std::collections::{BTreeMap, VecDeque};

use crate::nmt::NmtState;
use crate::CanFrame;

const HEARTBEAT_BASE: u16 = 0x700;
const EMCY_BASE: u16 = 0x080;
/// EMCY messages kept for the script to find; older ones are forgotten.
const KEPT_EMERGENCIES: usize = 64;

/// What the table saw.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Notice {
    /// A node sent its boot-up message.
    BootUp(u8),
    /// A node's heartbeat shows a new state.
    State(u8, NmtState),
    /// A node's heartbeat stayed away longer than the consumer time.
    HeartbeatLost(u8),
    /// An EMCY message.
    Emergency(Emergency),
}

/// An EMCY message as received.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emergency {
    /// The node that sent it.
    pub node: u8,
    /// Its error code (CiA 301 Table 21).
    pub code: u16,
    /// The error register 1001h.
    pub register: u8,
    /// When it arrived.
    pub at_us: u64,
}

/// What the master knows of one node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeStatus {
    /// Its last state (`Initialisation` after a boot-up message).
    pub state: NmtState,
    /// When its last heartbeat or boot-up came.
    pub last_us: u64,
    /// Its heartbeat is overdue.
    pub lost: bool,
}

/// The heartbeat and EMCY consumer.
#[derive(Clone, Debug, Default)]
pub struct NodeTable {
    /// Heartbeat consumer time; 0: no node is watched.
    timeout_us: u64,
    nodes: BTreeMap<u8, NodeStatus>,
    emergencies: VecDeque<Emergency>,
}

impl NodeTable {
    /// A table that calls a node lost after `timeout_us` without its heartbeat (0: never).
    pub fn new(timeout_us: u64) -> NodeTable {
        NodeTable {
            timeout_us,
            ..NodeTable::default()
        }
    }

    /// What it knows of `node`.
    pub fn status(&self, node: u8) -> Option<NodeStatus> {
        self.nodes.get(&node).copied()
    }

    /// `frame` arrived at `now_us`: what it tells, if anything.
    pub fn receive(&mut self, frame: &CanFrame, now_us: u64) -> Option<Notice> {
        let node = (frame.id & 0x7F) as u8;
        if frame.remote || node == 0 {
            return None;
        }
        match frame.id & !0x7F {
            HEARTBEAT_BASE => self.heartbeat(node, *frame.data.first()?, now_us),
            EMCY_BASE => self.emergency(node, &frame.data, now_us),
            _ => None,
        }
    }

    fn heartbeat(&mut self, node: u8, code: u8, now_us: u64) -> Option<Notice> {
        let state = [
            NmtState::Initialisation,
            NmtState::PreOperational,
            NmtState::Operational,
            NmtState::Stopped,
        ]
        .into_iter()
        .find(|s| s.code() == code & 0x7F)?;
        let before = self.nodes.insert(
            node,
            NodeStatus {
                state,
                last_us: now_us,
                lost: false,
            },
        );
        match (state, before) {
            (NmtState::Initialisation, _) => Some(Notice::BootUp(node)),
            (_, Some(b)) if b.state == state && !b.lost => None,
            _ => Some(Notice::State(node, state)),
        }
    }

    fn emergency(&mut self, node: u8, data: &[u8], now_us: u64) -> Option<Notice> {
        let [c0, c1, register, ..] = *data else {
            return None;
        };
        let emergency = Emergency {
            node,
            code: u16::from_le_bytes([c0, c1]),
            register,
            at_us: now_us,
        };
        if self.emergencies.len() == KEPT_EMERGENCIES {
            self.emergencies.pop_front();
        }
        self.emergencies.push_back(emergency);
        Some(Notice::Emergency(emergency))
    }

    /// Takes the oldest EMCY of `node` with `code` received at or after `since_us`, if one came.
    pub fn take_emergency(&mut self, node: u8, code: u16, since_us: u64) -> Option<Emergency> {
        let at = self
            .emergencies
            .iter()
            .position(|e| e.node == node && e.code == code && e.at_us >= since_us)?;
        self.emergencies.remove(at)
    }

    /// At `now_us`: the nodes whose heartbeat just became overdue.
    pub fn tick(&mut self, now_us: u64) -> Vec<Notice> {
        if self.timeout_us == 0 {
            return Vec::new();
        }
        let mut lost = Vec::new();
        for (node, status) in &mut self.nodes {
            if !status.lost && now_us >= status.last_us + self.timeout_us {
                status.lost = true;
                lost.push(Notice::HeartbeatLost(*node));
            }
        }
        lost
    }

    /// When a watched heartbeat falls overdue next.
    pub fn deadline(&self) -> Option<u64> {
        if self.timeout_us == 0 {
            return None;
        }
        let watched = self.nodes.values().filter(|s| !s.lost);
        watched.map(|s| s.last_us + self.timeout_us).min()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn heartbeat(node: u16, state: u8) -> CanFrame {
        CanFrame::new(0x700 + node, &[state])
    }

    #[test]
    fn boot_up_then_state_changes_then_loss_after_the_consumer_time() {
        let mut table = NodeTable::new(25_000);
        assert_eq!(
            table.receive(&heartbeat(2, 0x00), 100),
            Some(Notice::BootUp(2))
        );
        assert_eq!(
            table.receive(&heartbeat(2, 0x7F), 10_100),
            Some(Notice::State(2, NmtState::PreOperational))
        );
        assert_eq!(table.receive(&heartbeat(2, 0x7F), 20_100), None);
        assert_eq!(
            table.receive(&heartbeat(2, 0x05), 30_100),
            Some(Notice::State(2, NmtState::Operational))
        );
        assert_eq!(table.deadline(), Some(55_100));
        assert!(table.tick(55_099).is_empty());
        assert_eq!(table.tick(55_100), [Notice::HeartbeatLost(2)]);
        assert!(table.tick(90_000).is_empty(), "reported once");
        assert_eq!(table.deadline(), None);
        // Back: its state again, even though it did not change.
        assert_eq!(
            table.receive(&heartbeat(2, 0x05), 95_000),
            Some(Notice::State(2, NmtState::Operational))
        );
    }

    #[test]
    fn emergencies_are_kept_until_taken() {
        let mut table = NodeTable::new(0);
        let emcy = CanFrame::new(0x082, &[0x30, 0x81, 0x11, 0, 0, 0, 0, 0]);
        let expected = Emergency {
            node: 2,
            code: 0x8130,
            register: 0x11,
            at_us: 500,
        };
        assert_eq!(table.receive(&emcy, 500), Some(Notice::Emergency(expected)));
        assert_eq!(table.take_emergency(2, 0x8130, 600), None, "too old");
        assert_eq!(table.take_emergency(2, 0x8130, 0), Some(expected));
        assert_eq!(table.take_emergency(2, 0x8130, 0), None, "taken");
        assert!(table.tick(1_000_000).is_empty(), "no consumer time");
        assert_eq!(table.receive(&CanFrame::new(0x080, &[]), 1), None, "SYNC");
    }
}
