//! What a bus that runs without end (`cansim serve`) asks of the runner besides stepping: nodes
//! that join and leave while it runs, room in their queues, and events and log taken away as they
//! come, so nothing accumulates.

use golden::frame::Frame;
use rtl::bsp::protocol::ProtocolState;
use rtl::registers::pelican;

use crate::decode::bus_decoder::BusEvent;
use crate::host::Host;
use crate::nodes::controller_node::ControllerNode;
use crate::scenario::canopen_master::MasterLine;
use crate::scenario::report::{Happening, NodeCounts};
use crate::scenario::{NodeConfig, ScenarioError};

use super::{controller, RunNode, Runner};

impl Runner<'_> {
    /// A node joins the running bus: its controller is added (taking the place of one that left,
    /// if any) and its driver brings it up as Linux would. Returns its index.
    pub(crate) fn join(&mut self, config: &NodeConfig) -> Result<usize, ScenarioError> {
        let id = self
            .engine
            .join(controller(config, self.model)?, config.delay_fs);
        let node = RunNode::new(config, id)?;
        let n = match self.nodes.iter().position(|node| !node.present) {
            Some(n) => {
                self.nodes[n] = node;
                n
            }
            None => {
                self.nodes.push(node);
                self.nodes.len() - 1
            }
        };
        self.probe(n)?;
        self.set_bittiming(n)?;
        self.start(n)?;
        self.clock = self.clock.max(self.engine.now());
        Ok(n)
    }

    /// Whether node `n`'s controller takes part in the traffic: out of reset mode and done with
    /// its integration (11 recessive bits, ISO 11898-1 10.8).
    pub(crate) fn integrated(&self, n: usize) -> bool {
        let controller = self.engine.device::<ControllerNode>(self.nodes[n].id);
        controller.state() != ProtocolState::Integrating
    }

    /// Whether node `n` can leave without disturbing the bus: nothing of its own to send and its
    /// controller not taking part in a frame.
    pub(crate) fn can_leave(&self, n: usize) -> bool {
        let node = &self.nodes[n];
        let controller = self.engine.device::<ControllerNode>(node.id);
        node.queue.is_empty()
            && node.driver.in_flight().is_none()
            && matches!(
                controller.state(),
                ProtocolState::Idle | ProtocolState::Integrating | ProtocolState::BusOff
            )
    }

    /// Node `n` leaves the bus now (its frames waiting are forgotten).
    pub(crate) fn leave(&mut self, n: usize) {
        let node = &mut self.nodes[n];
        node.queue.clear();
        node.present = false;
        self.engine.leave(node.id);
    }

    /// The nodes so far, those that left included.
    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Whether node `n` is on the bus.
    pub(crate) fn present(&self, n: usize) -> bool {
        self.nodes[n].present
    }

    /// Queues `frame` for node `n`'s driver; whether its queue had room (`txqueuelen`).
    pub(crate) fn offer(&mut self, n: usize, frame: Frame) -> bool {
        self.nodes[n].offer(frame)
    }

    /// Whether node `n`'s queue has room for a frame.
    pub(crate) fn has_room(&self, n: usize) -> bool {
        let node = &self.nodes[n];
        node.queue.len() < node.config.txqueuelen
    }

    /// Queues `frame` for node `n`'s driver even beyond `txqueuelen` (the last frames of a client
    /// that went away, bounded by what it had sent).
    pub(crate) fn push_unbounded(&mut self, n: usize, frame: Frame) {
        self.nodes[n].queue.push_back(frame);
    }

    /// What node `n`'s driver reported since the last call, oldest first.
    pub(crate) fn take_events(&mut self, n: usize) -> Vec<(u64, Happening)> {
        if let Some(firmware) = &mut self.nodes[n].firmware {
            firmware.events_taken();
        }
        std::mem::take(&mut self.nodes[n].events)
    }

    /// The CANopen master's log lines since the last call.
    pub(crate) fn take_master_lines(&mut self) -> Vec<MasterLine> {
        std::mem::take(&mut self.master_lines)
    }

    /// Failed lines for the master's steps that have not ended by now.
    pub(crate) fn unfinished_master_steps(&self) -> Vec<MasterLine> {
        let scripts = self
            .nodes
            .iter()
            .filter_map(|n| n.config.canopen_master.as_ref());
        scripts
            .flat_map(|s| s.unfinished(self.master_finished, self.clock))
            .collect()
    }

    /// The bus log since the last call (the frame starts are forgotten: a run without end keeps
    /// nothing).
    pub(crate) fn take_log(&mut self) -> Vec<BusEvent> {
        self.frame_starts.clear();
        std::mem::take(&mut self.log)
    }

    /// Node `n`'s counts so far: frames sent, received, dropped, TXERR and RXERR (read through
    /// the host), and its state.
    pub(crate) fn counts(&mut self, n: usize) -> NodeCounts {
        let node = &self.nodes[n];
        let stats = *node.driver.stats();
        let mut host = Host::new(&mut self.engine, node.id);
        let (tec, rec) = (host.read(pelican::TXERR), host.read(pelican::RXERR));
        let node = &self.nodes[n];
        NodeCounts {
            name: node.config.name.clone(),
            sent: stats.tx_frames,
            received: stats.rx_frames,
            dropped: stats.tx_dropped + stats.tx_failed,
            tec,
            rec,
            state: node.driver.state(),
        }
    }
}
