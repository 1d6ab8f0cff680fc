//! The fault campaign 64 cases at a time: each case's three cores in one lane of three lane models
//! ([`LaneCores`], one per node), clocked together; a lane whose case is over takes the next case
//! at once. Every case runs exactly as [`super::run_rtl_with`] runs it on the engine (the same
//! clock edges, bus levels, loads, request, fault window and end), so it gives the same [`Run`]
//! (the engines tests compare them case by case).
//!
//! The engine run, restated per clock edge of one case: at edge `k` every node sees the wired-AND
//! of what the nodes drove at edge `k − 1` (no propagation delay, one clock), changed by the
//! injection's window; the bus monitor sees it undisturbed. TEC is loaded at edge 0 and REC at
//! edge 2 (the two `run_until(now + 2 periods)` of `load_counters`, `now` being the last edge
//! processed), the bus monitor starts and node 0 requests the frame [`INTEGRATION_BITS`] bit
//! times later (edge 226 at 16 clocks a bit). The checks after each bus bit (bus-off, idle) follow the monitor's edge, as
//! the engine's `run_while` conditions do.

use golden::btr::Btr;
use golden::frame::Frame;

use super::{
    campaign_btr, window, BusMonitor, Case, Effect, NodeReport, Run, Window, CLOCK_HZ,
    INTEGRATION_BITS, MAX_BITS, NODES, SETTLED_IDLE_BITS,
};
use crate::compiled::lane_core::{LaneCores, Port, LANES};
use crate::engine::time::ClockSpec;
use crate::engine::Device as _;
use crate::host::frame_buffer::{encode_buffer, FRAME_BUFFER_BYTES};
use crate::nodes::can_node::{cycle_events, NodeEvent};
use crate::nodes::controller_node::protocol_state;
use crate::nodes::core_engine::CoreInputs;
use crate::verilated::EngineError;
use rtl::bsp::protocol::ProtocolState;

/// The edge at which TEC is loaded.
const TEC_EDGE: u64 = 0;
/// The edge at which REC is loaded.
const REC_EDGE: u64 = 2;
/// Width of the core's transmit-buffer address.
const TX_ADDR_BITS: usize = 4;

/// The ports the runner touches every clock or on events.
struct Ports {
    rx: Port,
    data: Port,
    tx: Port,
    tx_addr: Port,
    /// `tx_addr` bit by bit.
    tx_addr_bits: [Port; TX_ADDR_BITS],
    strobes: [Port; 4],
    tec: Port,
    rec: Port,
    error_passive: Port,
    bus_off: Port,
    state: Port,
}

impl Ports {
    fn new() -> Ports {
        Ports {
            rx: Port::input("rx"),
            data: Port::input("transmit$data"),
            tx: Port::output("tx"),
            tx_addr: Port::output("transmit$addr"),
            tx_addr_bits: std::array::from_fn(|j| Port::output("transmit$addr").bit(j as u32)),
            strobes: [
                "status$bus_error",
                "rx_frame$strobe",
                "rx_valid",
                "transmit$done",
            ]
            .map(Port::output),
            tec: Port::output("status$tec"),
            rec: Port::output("status$rec"),
            error_passive: Port::output("status$error_passive"),
            bus_off: Port::output("status$bus_off"),
            state: Port::output("status$state"),
        }
    }
}

/// One node of one lane's case: what the engine's `CanNode` keeps.
#[derive(Default)]
struct LaneNode {
    /// The inputs applied (but `rx`, set for all lanes each clock).
    inputs: CoreInputs,
    tx_buffer: [u8; FRAME_BUFFER_BYTES],
    tx_addr: u8,
    rx_data: [u8; 8],
    received: Vec<Frame>,
    errors: Vec<u8>,
    transmitted: bool,
    request_pending: bool,
}

impl LaneNode {
    /// The transmit-buffer byte the core addresses.
    fn data(&self) -> u8 {
        self.tx_buffer
            .get(usize::from(self.tx_addr))
            .copied()
            .unwrap_or(0)
    }
}

/// One case under way in a lane.
struct Lane {
    number: u64,
    case: Case,
    /// The edge the next clock is.
    edge: u64,
    monitor: BusMonitor,
    nodes: [LaneNode; NODES],
    /// The injection's window in edges, once its bit has started.
    window: Option<Window>,
    bits: usize,
    idle_bits: usize,
}

/// Runs campaign cases 64 at a time.
pub(crate) struct LaneRunner {
    cores: Vec<LaneCores>,
    ports: Ports,
    lanes: Vec<Option<Lane>>,
    /// What each node drove at the last edge, per lane (recessive = 1).
    drive: [u64; NODES],
    /// Each node's transmit-buffer address after the last clock, bit by bit, per lane.
    tx_addr: [[u64; TX_ADDR_BITS]; NODES],
    btr: Btr,
    clock: ClockSpec,
    /// The edge from which the monitor reads and node 0 requests the frame.
    start_edge: u64,
}

impl LaneRunner {
    /// A runner with every lane free; an error if the lane model does not match `rtl/`.
    pub(crate) fn new() -> Result<LaneRunner, EngineError> {
        let btr = campaign_btr();
        Ok(LaneRunner {
            cores: (0..NODES)
                .map(|_| LaneCores::new())
                .collect::<Result<_, _>>()?,
            ports: Ports::new(),
            lanes: (0..LANES).map(|_| None).collect(),
            drive: [!0; NODES],
            tx_addr: [[0; TX_ADDR_BITS]; NODES],
            start_edge: REC_EDGE + INTEGRATION_BITS * u64::from(btr.clocks_per_bit()),
            btr,
            clock: ClockSpec::from_hz(CLOCK_HZ),
        })
    }

    /// Runs every case `next` gives (its number and the case) and hands each result to `done`
    /// as it ends (not in order).
    pub(crate) fn run(
        &mut self,
        mut next: impl FnMut() -> Option<(u64, Case)>,
        mut done: impl FnMut(u64, Case, Run),
    ) {
        let mut exhausted = false;
        loop {
            let mut starting = 0u64;
            if !exhausted {
                for l in 0..LANES {
                    if self.lanes[l].is_some() {
                        continue;
                    }
                    match next() {
                        Some((number, case)) => {
                            self.start(l, number, case);
                            starting |= 1 << l;
                        }
                        None => {
                            exhausted = true;
                            break;
                        }
                    }
                }
            }
            if self.lanes.iter().all(Option::is_none) {
                return;
            }
            self.clock(starting);
            for l in 0..LANES {
                if self.lanes[l].as_ref().is_some_and(|lane| self.over(lane)) {
                    let lane = self.lanes[l].take().expect("a case");
                    let run = self.finish(l, &lane);
                    done(lane.number, lane.case, run);
                }
            }
        }
    }

    /// Puts `case` into lane `l`: its cores at power-up, reset in the next clock.
    fn start(&mut self, l: usize, number: u64, case: Case) {
        let reset = CoreInputs {
            reset: true,
            rx: true,
            enable: true,
            brp: self.btr.brp,
            tseg1: self.btr.tseg1,
            tseg2: self.btr.tseg2,
            sjw: self.btr.sjw,
            sam: self.btr.sam,
            ..CoreInputs::default()
        };
        for core in &mut self.cores {
            core.power_up(1 << l);
            core.set_lane(l, &reset);
        }
        let nodes = std::array::from_fn(|_| LaneNode {
            inputs: CoreInputs {
                reset: false,
                ..reset
            },
            ..LaneNode::default()
        });
        self.lanes[l] = Some(Lane {
            number,
            case,
            edge: 0,
            monitor: BusMonitor::new(self.clock, &self.btr),
            nodes,
            window: None,
            bits: 0,
            idle_bits: 0,
        });
    }

    /// One clock of every lane: the reset cycle of the lanes in `starting`, the next edge of the
    /// others.
    fn clock(&mut self, starting: u64) {
        let bus = self.drive.iter().fold(!0, |level, drive| level & drive);
        let mut rx = [bus | starting; NODES];
        let mut cut = [0u64; NODES];
        for l in 0..LANES {
            let Some(lane) = self.lanes[l].as_mut() else {
                continue;
            };
            if starting >> l & 1 != 0 {
                continue;
            }
            let k = lane.edge;
            let t = self.clock.edge(k);
            self.prepare_inputs(l, k);
            let lane = self.lanes[l].as_mut().expect("a case");
            lane.monitor.rising_edge(t, bus >> l & 1 != 0);
            if let Some(w) = lane.window.filter(|w| (w.from_fs..w.to_fs).contains(&t)) {
                apply_window(&w, l, &mut rx, &mut cut);
            }
        }
        for n in 0..NODES {
            let core = &mut self.cores[n];
            core.set_mask(self.ports.rx, rx[n]);
            core.cycle();
            self.drive[n] = core.mask(self.ports.tx) | cut[n] | starting;
        }
        self.collect(starting);
        for l in 0..LANES {
            if let Some(lane) = self.lanes[l].as_mut() {
                if starting >> l & 1 == 0 {
                    lane.edge += 1;
                }
            }
        }
        self.after_edge(starting);
    }

    /// Sets the inputs of lane `l` that change at edge `k`: the counter loads, the request.
    fn prepare_inputs(&mut self, l: usize, k: u64) {
        let lane = self.lanes[l].as_mut().expect("a case");
        let mut changed = [false; NODES];
        match k {
            TEC_EDGE | REC_EDGE => {
                for (n, node) in lane.nodes.iter_mut().enumerate() {
                    node.inputs.load_tec = k == TEC_EDGE;
                    node.inputs.load_rec = k == REC_EDGE;
                    node.inputs.value = if k == TEC_EDGE {
                        lane.case.tec[n]
                    } else {
                        lane.case.rec[n]
                    };
                    changed[n] = true;
                }
            }
            _ if k == TEC_EDGE + 1 || k == REC_EDGE + 1 => {
                for (n, node) in lane.nodes.iter_mut().enumerate() {
                    node.inputs.load_tec = false;
                    node.inputs.load_rec = false;
                    node.inputs.value = 0;
                    changed[n] = true;
                }
            }
            _ if k == self.start_edge => {
                lane.monitor.start();
                let node = &mut lane.nodes[0];
                node.tx_buffer = encode_buffer(&lane.case.frame);
                node.request_pending = true;
                node.inputs.info = node.tx_buffer[0];
                node.inputs.single_shot = false;
                node.inputs.request = true;
                changed[0] = true;
            }
            _ => {}
        }
        for (n, node) in lane.nodes.iter_mut().enumerate() {
            if changed[n] {
                node.inputs.data = node.data();
                self.cores[n].set_lane(l, &node.inputs);
            }
        }
    }

    /// Records the strobes of the clock, and follows each node's transmit-buffer address.
    fn collect(&mut self, starting: u64) {
        for n in 0..NODES {
            self.collect_strobes(n, starting);
            self.follow_tx_addr(n, starting);
        }
    }

    /// Records node `n`'s strobes as its `CanNode` would (lanes just out of reset have none).
    fn collect_strobes(&mut self, n: usize, starting: u64) {
        let core = &mut self.cores[n];
        let strobes = self
            .ports
            .strobes
            .iter()
            .fold(0, |any, &port| any | core.mask(port));
        for l in set_lanes(strobes & !starting) {
            let Some(lane) = self.lanes[l].as_mut() else {
                continue;
            };
            let node = &mut lane.nodes[n];
            let out = core.lane_outputs(l);
            let mut request_ended = false;
            cycle_events(&out, &mut node.rx_data, |event| match event {
                NodeEvent::Received(frame) => node.received.push(frame),
                NodeEvent::BusError(ecc) => node.errors.push(ecc),
                NodeEvent::TransmitDone(success) => {
                    node.transmitted |= success;
                    request_ended = true;
                }
                NodeEvent::ArbitrationLost(_) => {}
            });
            if request_ended {
                node.request_pending = false;
                node.inputs.request = false;
                core.set_lane(l, &node.inputs);
            }
        }
    }

    /// Gives node `n` the transmit-buffer byte at its address in the lanes where the address moved
    /// (and in those just out of reset, which also get the inputs of their first edge).
    fn follow_tx_addr(&mut self, n: usize, starting: u64) {
        let core = &mut self.cores[n];
        let addr = self.ports.tx_addr_bits.map(|port| core.mask(port));
        let moved = addr
            .iter()
            .zip(&self.tx_addr[n])
            .fold(0, |any, (now, before)| any | (now ^ before));
        self.tx_addr[n] = addr;
        for l in set_lanes(moved | starting) {
            let Some(lane) = self.lanes[l].as_mut() else {
                continue;
            };
            let node = &mut lane.nodes[n];
            node.tx_addr = core.value(self.ports.tx_addr, l) as u8;
            node.inputs.data = node.data();
            if starting >> l & 1 != 0 {
                core.set_lane(l, &node.inputs);
            } else {
                core.set_value(self.ports.data, l, u64::from(node.inputs.data));
            }
        }
    }

    /// What follows each lane's edge: the injection's window placed when its bit starts, and
    /// after each bus bit the monitor read, a node at bus-off put in reset mode (as the SJA1000
    /// register block does) and the idle bits counted.
    fn after_edge(&mut self, starting: u64) {
        for l in 0..LANES {
            if starting >> l & 1 != 0 {
                continue;
            }
            let Some(lane) = self.lanes[l].as_mut() else {
                continue;
            };
            if let Some(injection) = lane.case.injection.as_ref() {
                let bit = injection.bit();
                if lane.window.is_none() && lane.monitor.bit_starts.len() > bit && lane.bits == bit
                {
                    let start = lane.monitor.bit_starts[bit];
                    lane.window = Some(window(injection, start, self.clock.period_fs(), &self.btr));
                }
            }
            if lane.monitor.samples.len() <= lane.bits {
                continue;
            }
            lane.bits += 1;
            let mut idle = true;
            for (n, core) in self.cores.iter_mut().enumerate() {
                let bus_off = core.value(self.ports.bus_off, l) != 0;
                if bus_off && lane.nodes[n].inputs.enable {
                    lane.nodes[n].inputs.enable = false;
                    core.set_lane(l, &lane.nodes[n].inputs);
                }
                let state = core.value(self.ports.state, l);
                idle &= bus_off || protocol_state(state) == ProtocolState::Idle;
            }
            let done =
                !lane.nodes[0].request_pending || self.cores[0].value(self.ports.bus_off, l) != 0;
            lane.idle_bits = if done && idle { lane.idle_bits + 1 } else { 0 };
        }
    }

    /// Whether `lane`'s case is over: as many bits as the engine run's loop reads.
    fn over(&self, lane: &Lane) -> bool {
        lane.bits >= MAX_BITS || lane.idle_bits >= SETTLED_IDLE_BITS
    }

    /// The result of the case in lane `l`.
    fn finish(&self, l: usize, lane: &Lane) -> Run {
        let nodes = lane
            .nodes
            .iter()
            .zip(&self.cores)
            .map(|(node, core)| NodeReport {
                received: node.received.clone(),
                errors: node.errors.clone(),
                tec: core.value(self.ports.tec, l) as u8,
                rec: core.value(self.ports.rec, l) as u8,
                error_passive: core.value(self.ports.error_passive, l) != 0,
                bus_off: core.value(self.ports.bus_off, l) != 0,
            })
            .collect();
        Run {
            bus: lane.monitor.samples.clone(),
            nodes,
            transmitted: lane.nodes[0].transmitted,
        }
    }
}

/// Lane `l`'s injection window `w`, in force this clock: changes the levels the nodes see (`rx`)
/// or cuts their drives from the bus (`cut`).
fn apply_window(w: &Window, l: usize, rx: &mut [u64; NODES], cut: &mut [u64; NODES]) {
    let bit = 1 << l;
    for n in (0..NODES).filter(|&n| w.node.is_none_or(|m| m == n)) {
        match w.effect {
            Effect::Force(true) => rx[n] |= bit,
            Effect::Force(false) => rx[n] &= !bit,
            Effect::Invert => rx[n] ^= bit,
            Effect::Cut => cut[n] |= bit,
        }
    }
}

/// The lanes whose bit is set in `mask`, lowest first.
fn set_lanes(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            l
        })
    })
}
