//! The complete controller as the IUT of the protocol scenarios, observed only through its registers:
//! a [`ControllerNode`] with an interrupt-driven host.
//!
//! The host services `irq_n` the way a driver's interrupt handler does, one register access per clock
//! cycle: it reads IR, then SR, and for each interrupt it found reads what explains it (BEI: ECC;
//! ALI: ALC; RI: RMC and the head message from the RX buffer window, then CMR = RRB; EI/EPI: TXERR and
//! RXERR; DOI: CMR = CDO), and reads IR again until it is 0. What it read becomes the [`NodeEvent`]s
//! the bare core reports from its strobes (BEI → `BusError(ECC)`, ALI → `ArbitrationLost(ALC)`,
//! RI → `Received(RX buffer)`, TI → `TransmitDone(SR.TCS)`), in the core's order within one pass, and
//! one [`InterruptPass`] per IR value.
//!
//! Accesses asked for by the bench ([`IutHost`]) take the cycles the handler leaves free, like code
//! that an interrupt handler preempts.

use std::any::Any;
use std::collections::VecDeque;

use rtl::registers::{command, interrupt, pelican, status};
use sim::engine::bus::Drive;
use sim::engine::time::ClockSpec;
use sim::engine::trace::Probe;
use sim::engine::{Device, DeviceId, Engine};
use sim::host::frame_buffer::{buffer_len, decode_buffer, FRAME_BUFFER_BYTES};
use sim::host::{RegisterPort, ACCESS_TIMEOUT_FS};
use sim::nodes::can_node::NodeEvent;
use sim::nodes::controller_node::{ControllerNode, HostAccess, ModelEngine};

/// The bits of ALC that hold the arbitration position (bits 7..5 are reserved).
const ALC_POSITION: u8 = 0x1F;

/// One register access of the interrupt handler.
#[derive(Clone, Copy, Debug)]
enum Step {
    ReadIr,
    ReadSr,
    ReadEcc,
    ReadAlc,
    ReadRmc,
    ReadFrame(usize),
    ReleaseRx,
    ClearOverrun,
    ReadTxerr,
    ReadRxerr,
}

impl Step {
    fn access(self) -> HostAccess {
        let read = |addr| HostAccess::Read { addr };
        let command = |value| HostAccess::Write {
            addr: pelican::CMR,
            value,
        };
        match self {
            Step::ReadIr => read(pelican::IR),
            Step::ReadSr => read(pelican::SR),
            Step::ReadEcc => read(pelican::ECC),
            Step::ReadAlc => read(pelican::ALC),
            Step::ReadRmc => read(pelican::RMC),
            Step::ReadFrame(i) => read(pelican::FRAME + i as u8),
            Step::ReleaseRx => command(command::RRB),
            Step::ClearOverrun => command(command::CDO),
            Step::ReadTxerr => read(pelican::TXERR),
            Step::ReadRxerr => read(pelican::RXERR),
        }
    }
}

/// What the interrupt handler read for one nonzero IR value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InterruptPass {
    /// Time of the clock edge of the IR read.
    pub at_fs: u64,
    /// IR as read.
    pub ir: u8,
    /// SR, read right after IR.
    pub sr: u8,
    /// ECC (on BEI).
    pub ecc: Option<u8>,
    /// ALC bits 4..0 (on ALI).
    pub alc: Option<u8>,
    /// RMC before the head message was released (on RI).
    pub rmc: Option<u8>,
    /// The head message's bytes from the RX buffer window, as many as its frame information says
    /// (on RI).
    pub rx_bytes: Option<Vec<u8>>,
    /// TXERR and RXERR (on EI or EPI).
    pub counters: Option<(u8, u8)>,
}

impl InterruptPass {
    fn new(at_fs: u64, ir: u8) -> InterruptPass {
        InterruptPass {
            at_fs,
            ir,
            sr: 0,
            ecc: None,
            alc: None,
            rmc: None,
            rx_bytes: None,
            counters: None,
        }
    }

    /// The events the core would have reported, in the order the core reports strobes of one
    /// clock cycle: bus error, arbitration lost, frame received, transmission ended.
    fn events(&self) -> Vec<NodeEvent> {
        let mut events = Vec::new();
        events.extend(self.ecc.map(NodeEvent::BusError));
        events.extend(self.alc.map(NodeEvent::ArbitrationLost));
        if let Some(bytes) = &self.rx_bytes {
            events.push(NodeEvent::Received(decode_buffer(bytes)));
        }
        if self.ir & interrupt::TI != 0 {
            events.push(NodeEvent::TransmitDone(self.sr & status::TCS != 0));
        }
        events
    }
}

/// Who asked for the access under way.
#[derive(Clone, Copy, Debug)]
enum Origin {
    Handler(Step),
    Bench,
}

/// The complete controller with its interrupt-driven host, as a bus [`Device`].
pub struct RegisterIut {
    node: ControllerNode,
    /// The handler's next accesses, front first; empty between passes.
    steps: VecDeque<Step>,
    /// The pass under way (after a nonzero IR read).
    pass: Option<InterruptPass>,
    /// The handler is running (from `irq_n` asserted until it reads IR = 0).
    handling: bool,
    /// The host services `irq_n` at all.
    servicing: bool,
    in_flight: Option<(Origin, HostAccess)>,
    requests: VecDeque<HostAccess>,
    request_reads: VecDeque<u8>,
    events: Vec<(u64, NodeEvent)>,
    passes: Vec<InterruptPass>,
    /// Every access that ended, with its edge and the value read, once asked for.
    accesses: Option<Vec<(u64, HostAccess, Option<u8>)>>,
}

impl RegisterIut {
    /// A controller on `clock`, stepped by `engine`, after a hardware reset (reset mode, BasicCAN);
    /// configure it through an [`IutHost`]. Panics if that engine cannot run.
    pub fn with_engine(name: &str, clock: ClockSpec, engine: ModelEngine) -> RegisterIut {
        let node = ControllerNode::with_engine(name, clock, engine)
            .unwrap_or_else(|e| panic!("{name} on {engine}: {e}"));
        RegisterIut {
            node,
            steps: VecDeque::new(),
            pass: None,
            handling: false,
            servicing: true,
            in_flight: None,
            requests: VecDeque::new(),
            request_reads: VecDeque::new(),
            events: Vec::new(),
            passes: Vec::new(),
            accesses: None,
        }
    }

    /// From now on, keep every register access with its clock edge and the value read.
    pub fn record_accesses(&mut self) {
        self.accesses.get_or_insert_with(Vec::new);
    }

    /// The accesses kept since [`RegisterIut::record_accesses`] (none before).
    pub fn accesses(&self) -> &[(u64, HostAccess, Option<u8>)] {
        self.accesses.as_deref().unwrap_or_default()
    }

    /// The controller.
    pub fn node(&self) -> &ControllerNode {
        &self.node
    }

    /// The events the interrupt handler derived so far, with the time of the IR read that found
    /// them, oldest first.
    pub fn events(&self) -> &[(u64, NodeEvent)] {
        &self.events
    }

    /// Every pass of the interrupt handler so far, oldest first.
    pub fn interrupt_passes(&self) -> &[InterruptPass] {
        &self.passes
    }

    /// From now on the host leaves `irq_n` alone (a comparison run: what the controller drives
    /// without the handler's accesses). Events and interrupt passes stay as they are.
    pub fn ignore_interrupts(&mut self) {
        self.servicing = false;
    }

    /// The interrupt handler has nothing to do: not running and `irq_n` released.
    pub fn handler_idle(&self) -> bool {
        !self.handling && !self.node.irq()
    }

    fn request(&mut self, access: HostAccess) {
        self.requests.push_back(access);
    }

    fn requests_done(&self) -> bool {
        self.requests.is_empty() && !matches!(self.in_flight, Some((Origin::Bench, _)))
    }

    /// Starts the next access: the handler's first, then the bench's.
    fn start_access(&mut self) {
        let (access, origin) = if let Some(step) = self.steps.pop_front() {
            (step.access(), Origin::Handler(step))
        } else if let Some(access) = self.requests.pop_front() {
            (access, Origin::Bench)
        } else {
            return;
        };
        self.node.queue(access);
        self.in_flight = Some((origin, access));
    }

    /// Takes the result of the access that ended at the edge at `t_fs`.
    fn finish_access(&mut self, t_fs: u64) {
        let Some((origin, access)) = self.in_flight.take() else {
            return;
        };
        let value = self.node.take_read();
        if let Some(accesses) = &mut self.accesses {
            accesses.push((t_fs, access, value));
        }
        match origin {
            Origin::Bench => self.request_reads.extend(value),
            Origin::Handler(step) => {
                self.handler_step_done(step, value, t_fs);
                if self.steps.is_empty() {
                    self.end_pass();
                }
            }
        }
    }

    /// Records what the handler's access `step` read (`value`, none for a write) and plans the
    /// accesses that follow from it.
    fn handler_step_done(&mut self, step: Step, value: Option<u8>, t_fs: u64) {
        let value = value.unwrap_or_default();
        if let Step::ReadIr = step {
            if value == 0 {
                self.handling = false;
            } else {
                self.pass = Some(InterruptPass::new(t_fs, value));
                self.steps.push_back(Step::ReadSr);
            }
            return;
        }
        let pass = self.pass.as_mut().expect("a pass is under way");
        match step {
            Step::ReadSr => {
                pass.sr = value;
                let ir = pass.ir;
                let wanted = [
                    (interrupt::BEI, &[Step::ReadEcc][..]),
                    (interrupt::ALI, &[Step::ReadAlc]),
                    (interrupt::RI, &[Step::ReadRmc, Step::ReadFrame(0)]),
                    (
                        interrupt::EI | interrupt::EPI,
                        &[Step::ReadTxerr, Step::ReadRxerr],
                    ),
                    (interrupt::DOI, &[Step::ClearOverrun]),
                ];
                for (bits, steps) in wanted {
                    if ir & bits != 0 {
                        self.steps.extend(steps);
                    }
                }
            }
            Step::ReadEcc => pass.ecc = Some(value),
            Step::ReadAlc => pass.alc = Some(value & ALC_POSITION),
            Step::ReadRmc => pass.rmc = Some(value),
            Step::ReadFrame(0) => {
                let len = buffer_len(value);
                let mut bytes = Vec::with_capacity(FRAME_BUFFER_BYTES);
                bytes.push(value);
                pass.rx_bytes = Some(bytes);
                // The rest of this message, then its release, before the other steps of the pass.
                self.steps.push_front(Step::ReleaseRx);
                for i in (1..len).rev() {
                    self.steps.push_front(Step::ReadFrame(i));
                }
            }
            Step::ReadFrame(_) => pass
                .rx_bytes
                .as_mut()
                .expect("frame information read first")
                .push(value),
            // RXERR is read right after TXERR.
            Step::ReadTxerr => pass.counters = Some((value, 0)),
            Step::ReadRxerr => pass.counters.as_mut().expect("TXERR read first").1 = value,
            // IR was read above; the writes read nothing.
            Step::ReadIr | Step::ReleaseRx | Step::ClearOverrun => {}
        }
    }

    /// Records the pass under way (if any) and reads IR again, as long as the handler runs.
    fn end_pass(&mut self) {
        if let Some(pass) = self.pass.take() {
            let at = pass.at_fs;
            self.events
                .extend(pass.events().into_iter().map(|event| (at, event)));
            self.passes.push(pass);
        }
        if self.handling {
            self.steps.push_back(Step::ReadIr);
        }
    }
}

impl Device for RegisterIut {
    fn name(&self) -> &str {
        self.node.name()
    }

    fn clock(&self) -> ClockSpec {
        self.node.clock()
    }

    fn rising_edge(&mut self, t_fs: u64, rx: bool) -> Drive {
        self.start_access();
        let drive = self.node.rising_edge(t_fs, rx);
        self.finish_access(t_fs);
        if self.servicing && !self.handling && self.node.irq() {
            self.handling = true;
            self.steps.push_back(Step::ReadIr);
        }
        drive
    }

    fn quiet_edges(&self, rx: bool, traced: bool) -> u64 {
        let idle = self.steps.is_empty()
            && self.in_flight.is_none()
            && self.requests.is_empty()
            && !(self.servicing && !self.handling && self.node.irq());
        if idle {
            self.node.quiet_edges(rx, traced)
        } else {
            0
        }
    }

    fn skip_edges(&mut self, edges: u64, rx: bool, traced: bool, checked: bool) {
        self.node.skip_edges(edges, rx, traced, checked);
    }

    fn probes(&self) -> Vec<Probe> {
        self.node.probes()
    }

    fn probe_values(&self, values: &mut [u64]) {
        self.node.probe_values(values);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// The bench's register access to a [`RegisterIut`] of an engine: each access waits (the engine
/// running) until the interrupt handler leaves a cycle free and the access is done.
pub struct IutHost<'e> {
    engine: &'e mut Engine,
    iut: DeviceId,
}

impl<'e> IutHost<'e> {
    /// The host of the [`RegisterIut`] `iut`.
    pub fn new(engine: &'e mut Engine, iut: DeviceId) -> IutHost<'e> {
        IutHost { engine, iut }
    }

    /// The IUT.
    pub fn iut(&self) -> &RegisterIut {
        self.engine.device(self.iut)
    }

    /// Runs until the interrupt handler has serviced every pending interrupt.
    pub fn settle(&mut self) {
        let iut = self.iut;
        let limit = self.engine.now() + ACCESS_TIMEOUT_FS;
        let settled = self
            .engine
            .run_while(limit, |e| e.device::<RegisterIut>(iut).handler_idle())
            .expect("simulation");
        assert!(settled, "the interrupt handler never finished");
    }

    /// Writes `value` to register `addr`.
    pub fn write(&mut self, addr: u8, value: u8) {
        self.access(HostAccess::Write { addr, value });
    }

    /// Reads register `addr` (with the read's side effects).
    pub fn read(&mut self, addr: u8) -> u8 {
        self.access(HostAccess::Read { addr });
        self.engine
            .device_mut::<RegisterIut>(self.iut)
            .request_reads
            .pop_front()
            .expect("a read access returns its data")
    }

    fn access(&mut self, access: HostAccess) {
        let iut = self.iut;
        self.engine.device_mut::<RegisterIut>(iut).request(access);
        let limit = self.engine.now() + ACCESS_TIMEOUT_FS;
        let done = self
            .engine
            .run_while(limit, |e| e.device::<RegisterIut>(iut).requests_done())
            .expect("simulation");
        assert!(done, "host access {access:?} never completed");
    }
}

impl RegisterPort for IutHost<'_> {
    fn write(&mut self, addr: u8, value: u8) {
        IutHost::write(self, addr, value);
    }

    fn read(&mut self, addr: u8) -> u8 {
        IutHost::read(self, addr)
    }
}
