//! The host model: a CPU that talks to one [`ControllerNode`] only through its registers.
//!
//! Every access takes one clock cycle of the node, like a real bus cycle; the engine keeps running
//! (all other devices too) while the host waits for its access. A read returns the registered read
//! data of the port contract.

pub mod acceptance;
pub mod driver;
pub mod frame_buffer;
pub mod sja1000;

use crate::engine::{DeviceId, Engine};
use crate::nodes::controller_node::{ControllerNode, HostAccess};

/// Longest time an access may wait for its clock edge before the host gives up (a stopped clock).
pub const ACCESS_TIMEOUT_FS: u64 = 1_000_000_000_000;

/// Register access to a controller, one host bus cycle per access: what configuration and transmit
/// helpers need, whichever host model performs the cycles.
pub trait RegisterPort {
    /// Writes `value` to register `addr`.
    fn write(&mut self, addr: u8, value: u8);
    /// Reads register `addr` (with the read's side effects).
    fn read(&mut self, addr: u8) -> u8;
}

/// Register access to one controller of an engine.
pub struct Host<'e> {
    engine: &'e mut Engine,
    node: DeviceId,
}

impl<'e> Host<'e> {
    /// The host of the [`ControllerNode`] `node`.
    pub fn new(engine: &'e mut Engine, node: DeviceId) -> Host<'e> {
        Host { engine, node }
    }

    /// Writes `value` to register `addr` (one clock cycle).
    pub fn write(&mut self, addr: u8, value: u8) {
        self.access(HostAccess::Write { addr, value });
    }

    /// Reads register `addr` (one clock cycle; the side effects of the read happen).
    pub fn read(&mut self, addr: u8) -> u8 {
        self.access(HostAccess::Read { addr });
        self.node_mut()
            .take_read()
            .expect("a read access returns its data")
    }

    /// Lets `cycles` clock cycles of the node pass without an access.
    pub fn idle(&mut self, cycles: u64) {
        self.engine
            .run_edges(self.node, cycles)
            .expect("simulation");
    }

    /// The engine (to run the bus between accesses).
    pub fn engine(&mut self) -> &mut Engine {
        self.engine
    }

    /// The node.
    pub fn node(&self) -> &ControllerNode {
        self.engine.device(self.node)
    }

    fn node_mut(&mut self) -> &mut ControllerNode {
        self.engine.device_mut(self.node)
    }

    fn access(&mut self, access: HostAccess) {
        let node = self.node;
        self.node_mut().queue(access);
        let limit = self.engine.now() + ACCESS_TIMEOUT_FS;
        let done = self
            .engine
            .run_while(limit, |e| e.device::<ControllerNode>(node).host_idle())
            .expect("simulation");
        assert!(done, "host access {access:?} never completed");
    }
}

impl RegisterPort for Host<'_> {
    fn write(&mut self, addr: u8, value: u8) {
        Host::write(self, addr, value);
    }

    fn read(&mut self, addr: u8) -> u8 {
        Host::read(self, addr)
    }
}
