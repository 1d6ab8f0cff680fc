//! A bus node made of the complete RTL controller [`rtl::can_controller::CanController`], reachable only
//! through its host port: register reads and writes, one per clock cycle, queued by a host model
//! ([`crate::host`]) and applied on the node's own clock edges.
//!
//! Stepping: a queued access drives `addr`/`wdata`/`we`/`re` for exactly one clock cycle; a read's
//! data is taken from `rdata` right after that edge (the port contract's registered read data). The
//! node also records `irq_n` and, for traces, a few internal signals of the core.

use std::any::Any;
use std::collections::VecDeque;

use rtl::bsp::protocol::ProtocolState;
use rtl::can_controller::CanController;
use rust_hdl::prelude::*;

use crate::bus::Drive;
use crate::can_node::{core_probe_values, core_probes, CORE_PROBES};
use crate::engine::Device;
use crate::rtl_step::clock_cycle_with;
use crate::time::ClockSpec;
use crate::trace::Probe;

/// One host bus cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostAccess {
    /// Write `value` to register `addr`.
    Write {
        /// Register address.
        addr: u8,
        /// Value written.
        value: u8,
    },
    /// Read register `addr`.
    Read {
        /// Register address.
        addr: u8,
    },
}

/// The RTL controller as a bus [`Device`] with a host access queue.
pub struct ControllerNode {
    name: String,
    clock: ClockSpec,
    uut: CanController,
    queue: VecDeque<HostAccess>,
    reads: VecDeque<u8>,
    access_active: bool,
    inputs_changed: bool,
    edges: u64,
}

impl ControllerNode {
    /// A controller on `clock` after a hardware reset (reset mode, BasicCAN, as the data sheet
    /// leaves it); configure it through a host.
    pub fn new(name: &str, clock: ClockSpec) -> ControllerNode {
        let mut uut = CanController::default();
        uut.connect_all();
        uut.rx.next = true;
        uut.reset.next = true;
        let mut node = ControllerNode {
            name: name.to_string(),
            clock,
            uut,
            queue: VecDeque::new(),
            reads: VecDeque::new(),
            access_active: false,
            inputs_changed: true,
            edges: 0,
        };
        node.clock_edge();
        node.uut.reset.next = false;
        node.inputs_changed = true;
        node
    }

    /// Queues a host access; it happens on one of the next clock edges, in order.
    pub fn queue(&mut self, access: HostAccess) {
        self.queue.push_back(access);
    }

    /// No access is queued or under way.
    pub fn host_idle(&self) -> bool {
        self.queue.is_empty() && !self.access_active
    }

    /// The oldest read result not yet taken.
    pub fn take_read(&mut self) -> Option<u8> {
        self.reads.pop_front()
    }

    /// The interrupt output is asserted (`irq_n` low).
    pub fn irq(&self) -> bool {
        !self.uut.irq_n.val()
    }

    /// The `clkout` pin.
    pub fn clkout(&self) -> bool {
        self.uut.clkout.val()
    }

    /// The `tx` pin.
    pub fn tx(&self) -> bool {
        self.uut.tx.val()
    }

    /// Rising clock edges so far.
    pub fn edges(&self) -> u64 {
        self.edges
    }

    /// Protocol state of the core (for waves and diagnostics; tests observe registers).
    pub fn state(&self) -> ProtocolState {
        self.uut.core.state.val()
    }

    /// The core is transmitting a frame (it has not lost arbitration), for locating faults in the
    /// frame on the bus.
    pub fn transmitting(&self) -> bool {
        self.uut.core.transmitting.val()
    }

    /// Drives or releases the hardware `reset` input from the next edge on.
    pub fn set_reset(&mut self, active: bool) {
        self.uut.reset.next = active;
        self.inputs_changed = true;
    }

    fn clock_edge(&mut self) {
        let changed = std::mem::take(&mut self.inputs_changed);
        clock_cycle_with(&mut self.uut, |u| &mut u.clock, "CAN controller", changed);
        self.edges += 1;
    }

    fn apply(&mut self, access: Option<HostAccess>) {
        let u = &mut self.uut;
        let (we, re, addr, value) = match access {
            Some(HostAccess::Write { addr, value }) => (true, false, addr, value),
            Some(HostAccess::Read { addr }) => (false, true, addr, 0),
            None => (false, false, u.addr.val().to_u8(), u.wdata.val().to_u8()),
        };
        if we != u.we.val() || re != u.re.val() || addr != u.addr.val().to_u8() {
            self.inputs_changed = true;
        }
        if value != u.wdata.val().to_u8() {
            self.inputs_changed = true;
        }
        u.we.next = we;
        u.re.next = re;
        u.addr.next = (addr as u64).to_bits();
        u.wdata.next = (value as u64).to_bits();
    }
}

impl Device for ControllerNode {
    fn name(&self) -> &str {
        &self.name
    }

    fn clock(&self) -> ClockSpec {
        self.clock
    }

    fn rising_edge(&mut self, _t_fs: u64, rx: bool) -> Drive {
        let access = self.queue.pop_front();
        self.access_active = access.is_some();
        self.apply(access);
        if rx != self.uut.rx.val() {
            self.uut.rx.next = rx;
            self.inputs_changed = true;
        }
        self.clock_edge();
        if let Some(HostAccess::Read { .. }) = access {
            self.reads.push_back(self.uut.rdata.val().to_u8());
        }
        self.access_active = false;
        if access.is_some() && self.queue.is_empty() {
            self.apply(None);
        }
        Drive::from_level(self.uut.tx.val())
    }

    fn probes(&self) -> Vec<Probe> {
        let mut probes = core_probes();
        probes.extend([Probe::bit("irq_n"), Probe::bit("clkout")]);
        probes
    }

    fn probe_values(&self, values: &mut [u64]) {
        let u = &self.uut;
        let (core, own) = values.split_at_mut(CORE_PROBES);
        core_probe_values(&u.core, core);
        own.copy_from_slice(&[u.irq_n.val() as u64, u.clkout.val() as u64]);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}
