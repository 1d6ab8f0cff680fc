//! Running a scenario: the nodes are complete controllers ([`ControllerNode`]) on one engine, each
//! driven only through its registers by the model of the Linux SJA1000 driver
//! ([`Sja1000Driver`]): probe, bit timing, start with the node's modes, `transmit` for every frame
//! the traffic releases (one in flight at a time; the rest wait in the node's queue), the
//! interrupt handler whenever the controller's `irq_n` is low, and the restart after bus-off when
//! the node has a restart delay. The bus level changes go through the streaming bus decoder
//! ([`BusDecoder`]), which gives the bus log; faults become windows of the engine, those located
//! by frame once the frame's start is seen on the bus.
//!
//! The run advances in steps of at most one bit time, so releases, restarts and interrupt service
//! happen within a bit of when they are due; it stops exactly at a start of frame when a fault
//! waits for that frame.

use std::collections::VecDeque;
use std::io;
use std::path::{Path, PathBuf};

use rtl::registers::pelican;

use crate::decode::bus_decoder::{BusDecoder, BusEvent};
use crate::engine::bus_timing::BusTiming;
use crate::engine::time::ClockSpec;
use crate::engine::{DeviceId, EdgeSkipping, Engine};
use crate::host::driver::{
    CanState, CtrlMode, DriverConfig, DriverError, DriverEvent, Sja1000Driver,
};
use crate::host::Host;
use crate::nodes::controller_node::{ControllerNode, ModelEngine};
use golden::frame::{Frame, DOMINANT, RECESSIVE};

use super::canopen_master::MasterLine;
use super::canopen_node::Firmware;
use super::faults::{install, locate, Fault, FaultKind, Place, Target};
use super::output::PendingFile;
use super::recording::RecordingFeed;
use super::report::{AppliedFault, Happening, NodeEvent, NodeReport, RunReport};
use super::traffic::Schedule;

mod live;
use super::view::{write_view, FRAME_PROBE};
use super::{NodeConfig, NodeMode, Scenario, ScenarioError};

/// Recessive time, in half bits, after which a dominant edge on the bus is a start of frame: an
/// ACK delimiter, 7 EOF bits and 2 intermission bits (or an error delimiter and 2 intermission
/// bits) are 10 bits, an overload flag starts after 8 or 9; half a bit of margin for clock offsets.
const SOF_IDLE_HALF_BITS: u64 = 19;
/// When, in quarter bits after a start of frame, the runner asks which nodes transmit the frame:
/// every node that sends it (or joins it after seeing the start of frame in its third intermission
/// bit) is in the arbitration field by then, and none can have lost yet.
const TRANSMITTERS_KNOWN_QUARTER_BITS: u64 = 5;
/// Interrupt services in a row that find nothing before the run gives up (a stuck `irq_n`).
const QUIET_SERVICE_LIMIT: usize = 1000;

/// How to run a scenario.
#[derive(Default)]
pub struct RunOptions<'p> {
    /// Write a VCD here.
    pub vcd: Option<PathBuf>,
    /// Write the bus log here (`candump -l` lines with error and overload frames).
    pub log: Option<PathBuf>,
    /// Run this long instead of the scenario's duration.
    pub until_fs: Option<u64>,
    /// Called after every step with the simulated time and the time the run ends.
    pub progress: Option<&'p mut dyn FnMut(u64, u64)>,
    /// The engine stepping the controllers (`None`: the one `CAN_ENGINE` chooses).
    pub engine: Option<ModelEngine>,
    /// Whether quiet clock edges are skipped (`None`: as `CAN_SKIP_EDGES` chooses).
    pub edge_skipping: Option<EdgeSkipping>,
}

/// Runs `scenario`.
pub fn run(scenario: &Scenario, options: RunOptions) -> Result<RunReport, ScenarioError> {
    let RunOptions {
        vcd,
        log,
        until_fs,
        mut progress,
        engine,
        edge_skipping,
    } = options;
    let engine = match engine {
        Some(engine) => engine,
        None => ModelEngine::from_env().map_err(ScenarioError::new)?,
    };
    let log_file = log.map(|path| PendingFile::create(&path)).transpose()?;
    let end = until_fs.unwrap_or(scenario.duration_fs);
    let mut runner = Runner::new(scenario, engine)?;
    if let Some(skipping) = edge_skipping {
        runner.engine.set_edge_skipping(skipping);
    }
    if let Some(path) = &vcd {
        runner.trace(path)?;
    }
    let mut report = match runner.simulate(end, &mut progress) {
        Ok(report) => report,
        Err(e) => {
            // The engine would finish the VCD when dropped; a failed run leaves none.
            runner.engine.discard_trace();
            return Err(e);
        }
    };
    if let Some(path) = &report.vcd {
        report.view = Some(write_view(scenario, &report, path)?);
    }
    if let Some(file) = log_file {
        report.log_file = Some(file.commit(report.log_text().as_bytes())?);
    }
    Ok(report)
}

fn io_error(e: io::Error) -> ScenarioError {
    ScenarioError::new(e.to_string())
}

/// Counts starts of frame in the bus level changes.
#[derive(Clone, Copy, Debug)]
struct SofWatch {
    idle_fs: u64,
    level: bool,
    since_fs: u64,
    count: u64,
}

impl SofWatch {
    fn new(bit_fs: u64) -> SofWatch {
        SofWatch {
            idle_fs: bit_fs * SOF_IDLE_HALF_BITS / 2,
            level: RECESSIVE,
            since_fs: 0,
            count: 0,
        }
    }

    /// The bus is at `level` from `t_fs` on; the number of the frame this starts, if it does.
    fn level(&mut self, t_fs: u64, level: bool) -> Option<u64> {
        if level == self.level {
            return None;
        }
        let idle = self.level == RECESSIVE && t_fs - self.since_fs >= self.idle_fs;
        (self.level, self.since_fs) = (level, t_fs);
        if level == DOMINANT && idle {
            self.count += 1;
            Some(self.count)
        } else {
            None
        }
    }
}

/// A controller, its driver and what waits for it.
pub(crate) struct RunNode {
    config: NodeConfig,
    /// On the bus (a node that joined while running may have left).
    present: bool,
    id: DeviceId,
    driver: Sja1000Driver,
    /// Frames waiting for the driver, at most the node's `txqueuelen`.
    queue: VecDeque<Frame>,
    /// The CANopen device its firmware runs, if any.
    firmware: Option<Firmware>,
    events: Vec<(u64, Happening)>,
    bus_off_at: Option<u64>,
    restarts: usize,
}

pub(crate) struct Runner<'s> {
    scenario: &'s Scenario,
    model: ModelEngine,
    pub(crate) engine: Engine,
    nodes: Vec<RunNode>,
    targets: Vec<Target>,
    schedule: Schedule<'s>,
    /// Faults located by frame, in frame order.
    frame_faults: VecDeque<&'s Fault>,
    sof: SofWatch,
    frame_starts: Vec<u64>,
    decoder: BusDecoder,
    /// The capture driving the bus, if any.
    recording: Option<RecordingFeed>,
    /// The CANopen devices have been powered on.
    firmware_started: bool,
    /// The CANopen master's log so far, and how many of its steps ended.
    master_lines: Vec<MasterLine>,
    master_finished: usize,
    log: Vec<BusEvent>,
    applied: Vec<AppliedFault>,
    bit_fs: u64,
    /// Every clock edge before this time has been processed.
    clock: u64,
}

impl<'s> Runner<'s> {
    /// The scenario's nodes on a new engine stepped by `model` (not brought up yet).
    pub(crate) fn new(
        scenario: &'s Scenario,
        model: ModelEngine,
    ) -> Result<Runner<'s>, ScenarioError> {
        let mut engine = Engine::new();
        let mut nodes = Vec::new();
        let mut targets = Vec::new();
        for n in &scenario.nodes {
            let node = controller(n, model)?;
            let id = engine.add(node, n.delay_fs);
            nodes.push(RunNode::new(n, id)?);
            targets.push(Target {
                id,
                delay_fs: n.delay_fs,
            });
        }
        let recording = scenario
            .recording
            .as_ref()
            .map(|r| RecordingFeed::new(r, &mut engine))
            .transpose()?;
        engine.watch_bus();
        let mut frame_faults: Vec<&Fault> = scenario
            .faults
            .iter()
            .filter(|f| matches!(f.place, Place::Bit { .. }))
            .collect();
        frame_faults.sort_by_key(|f| frame_number(f));
        let bit_fs = scenario.bus.bit_fs();
        Ok(Runner {
            scenario,
            model,
            engine,
            nodes,
            targets,
            schedule: Schedule::new(&scenario.traffic, scenario.seed),
            frame_faults: frame_faults.into(),
            sof: SofWatch::new(bit_fs),
            frame_starts: Vec::new(),
            decoder: BusDecoder::new(bit_fs, scenario.bus.btr.sample_point()),
            recording,
            firmware_started: false,
            master_lines: Vec::new(),
            master_finished: 0,
            log: Vec::new(),
            applied: Vec::new(),
            bit_fs,
            clock: 0,
        })
    }

    /// Writes a VCD of the bus (with the frame numbers) and of the scenario's nodes to `path`.
    pub(crate) fn trace(&mut self, path: &Path) -> Result<(), ScenarioError> {
        let mut frames = self.sof;
        self.engine.annotate_bus(
            FRAME_PROBE,
            Box::new(move |t, level| frames.level(t, level)),
        );
        let bus = &self.scenario.bus;
        let timing = BusTiming::from_btr(&bus.btr, ClockSpec::from_hz(f64::from(bus.clock_hz)));
        self.engine.trace_vcd_timed(path, timing).map_err(io_error)
    }

    /// The name of node `node`.
    pub(crate) fn name(&self, node: usize) -> &str {
        &self.nodes[node].config.name
    }

    fn driver_error(&self, node: usize, what: &str, e: DriverError) -> ScenarioError {
        ScenarioError::new(format!("{}: {what}: {e}", self.name(node)))
    }

    fn install_timed_faults(&mut self) {
        for fault in &self.scenario.faults {
            if let Place::At(at) = fault.place {
                let start = at + fault.offset_fs;
                install(&mut self.engine, fault, start, &self.targets);
                let text = format!("{} {}", fault.kind.name(), self.fault_scope(fault));
                self.record_fault(fault, start, text);
            }
        }
    }

    /// Who a fault is about: `on the bus`, `seen by b, c`, `of node d`.
    fn fault_scope(&self, fault: &Fault) -> String {
        match fault.kind {
            FaultKind::Disconnect(node) | FaultKind::StuckDominant(node) => {
                format!("of node {}", self.name(node))
            }
            _ if fault.nodes.is_empty() => "on the bus".to_string(),
            _ => {
                let names: Vec<&str> = fault.nodes.iter().map(|&n| self.name(n)).collect();
                format!("seen by {}", names.join(", "))
            }
        }
    }

    fn record_fault(&mut self, fault: &Fault, start_fs: u64, text: String) {
        self.applied.push(AppliedFault {
            line: fault.line,
            start_fs,
            end_fs: start_fs + fault.duration_fs,
            text,
        });
    }

    /// Brings the interfaces up as Linux would: every driver probes its controller, then each
    /// gets its bit timing, then each is started with its modes.
    fn bring_up(&mut self) -> Result<(), ScenarioError> {
        for n in 0..self.nodes.len() {
            self.probe(n)?;
        }
        for n in 0..self.nodes.len() {
            self.set_bittiming(n)?;
        }
        for n in 0..self.nodes.len() {
            self.start(n)?;
        }
        self.clock = self.engine.now();
        Ok(())
    }

    /// Powers the CANopen devices on (their boot-up messages) once every controller of the
    /// scenario takes part in the traffic: the network comes up together, and a boot-up message
    /// sent while the others still integrate would go unacknowledged.
    fn start_firmware(&mut self) {
        if self.firmware_started || !(0..self.nodes.len()).all(|n| self.integrated(n)) {
            return;
        }
        self.firmware_started = true;
        let now = self.engine.now();
        for node in &mut self.nodes {
            if let Some(firmware) = &mut node.firmware {
                firmware.start(now);
            }
        }
    }

    /// Hands the CANopen devices what their drivers read and the time; moves what they send into
    /// their drivers' queues as far as there is room.
    fn run_firmware(&mut self) {
        if !self.firmware_started {
            return;
        }
        let now = self.clock;
        for node in &mut self.nodes {
            let Some(firmware) = &mut node.firmware else {
                continue;
            };
            firmware.run(&node.events, now);
            if let Some(script) = &node.config.canopen_master {
                let events = firmware.take_master_events();
                let lines = script.lines(&events, &mut self.master_finished);
                self.master_lines.extend(lines);
            }
            while node.queue.len() < node.config.txqueuelen {
                let Some(frame) = firmware.next_frame() else {
                    break;
                };
                node.queue.push_back(frame);
            }
        }
    }

    /// When a CANopen device next has something due.
    fn firmware_deadline(&self) -> Option<u64> {
        if !self.firmware_started {
            return None;
        }
        let firmware = self.nodes.iter().filter_map(|n| n.firmware.as_ref());
        firmware.filter_map(Firmware::deadline_fs).min()
    }

    fn probe(&mut self, n: usize) -> Result<(), ScenarioError> {
        let result = self.nodes[n].driver.probe(&mut self.engine);
        result.map_err(|e| self.driver_error(n, "probe", e))
    }

    fn set_bittiming(&mut self, n: usize) -> Result<(), ScenarioError> {
        let node = &mut self.nodes[n];
        let btr = node.config.btr;
        let result = node
            .driver
            .set_bittiming(&mut self.engine, btr.btr0(), btr.btr1());
        result.map_err(|e| self.driver_error(n, "bit timing", e))
    }

    fn start(&mut self, n: usize) -> Result<(), ScenarioError> {
        let config = &self.nodes[n].config;
        let mode = CtrlMode {
            listen_only: config.mode == NodeMode::ListenOnly,
            presume_ack: config.mode == NodeMode::SelfTest,
            one_shot: config.one_shot,
            berr_reporting: config.berr_reporting,
        };
        let result = self.nodes[n].driver.start(&mut self.engine, mode);
        result
            .map(|_| ())
            .map_err(|e| self.driver_error(n, "start", e))
    }

    /// Installs the faults placed by time and brings the scenario's nodes up.
    pub(crate) fn begin(&mut self) -> Result<(), ScenarioError> {
        self.install_timed_faults();
        self.bring_up()
    }

    /// Every clock edge before this time has been processed.
    pub(crate) fn clock(&self) -> u64 {
        self.clock
    }

    /// Hands out what is due, then runs for at most a bit time.
    pub(crate) fn step(&mut self, end: u64) -> Result<(), ScenarioError> {
        let mut room: Vec<usize> = self
            .nodes
            .iter()
            .map(|n| n.config.txqueuelen.saturating_sub(n.queue.len()))
            .collect();
        let released = self.schedule.release(self.clock, |n| {
            let free = room[n] > 0;
            room[n] = room[n].saturating_sub(1);
            free
        });
        for (node, frame) in released {
            self.nodes[node].queue.push_back(frame);
        }
        self.restart_due()?;
        self.start_transmissions()?;
        let next = [
            Some(self.clock + self.bit_fs),
            Some(end),
            self.schedule.next_time_after(self.clock),
            self.next_restart(),
            self.firmware_deadline(),
        ];
        let target = next
            .into_iter()
            .flatten()
            .min()
            .expect("the bit time is always there")
            .max(self.clock + 1);
        if let Some(recording) = &mut self.recording {
            recording.feed(&mut self.engine, target + self.bit_fs)?;
        }
        let armed = self.frame_faults.front().map(|f| frame_number(f)) == Some(self.sof.count + 1);
        self.run_chunk(target, armed)?;
        self.clock = target.max(self.engine.now());
        self.observe_bus()?;
        self.start_firmware();
        self.run_firmware();
        Ok(())
    }

    fn next_restart(&self) -> Option<u64> {
        self.nodes
            .iter()
            .filter(|node| node.present)
            .filter_map(|node| Some(node.bus_off_at? + node.config.restart_fs?))
            .min()
    }

    fn restart_due(&mut self) -> Result<(), ScenarioError> {
        for n in 0..self.nodes.len() {
            let node = &mut self.nodes[n];
            let Some(delay) = node.config.restart_fs.filter(|_| node.present) else {
                continue;
            };
            if node.bus_off_at.is_none_or(|at| at + delay > self.clock) {
                continue;
            }
            node.bus_off_at = None;
            node.restarts += 1;
            node.events.push((self.engine.now(), Happening::Restarted));
            let result = node.driver.restart(&mut self.engine);
            result.map_err(|e| self.driver_error(n, "restart", e))?;
        }
        Ok(())
    }

    fn start_transmissions(&mut self) -> Result<(), ScenarioError> {
        for n in 0..self.nodes.len() {
            let node = &mut self.nodes[n];
            let self_test = node.config.mode == NodeMode::SelfTest;
            if !node.present || !node.driver.can_transmit() {
                continue;
            }
            let Some(frame) = node.queue.pop_front() else {
                continue;
            };
            let result = node.driver.transmit(&mut self.engine, &frame, self_test);
            result.map_err(|e| self.driver_error(n, &format!("transmit {frame}"), e))?;
        }
        Ok(())
    }

    /// Runs the edges before `limit`, running a node's interrupt handler whenever its `irq_n` is
    /// low (as the kernel would). With `stop_at_sof`, returns early (`true`) right after a start
    /// of frame on the bus.
    fn run_chunk(&mut self, limit: u64, stop_at_sof: bool) -> Result<bool, ScenarioError> {
        let ids: Vec<(usize, DeviceId)> = (self.nodes.iter().enumerate())
            .filter(|(_, node)| node.present)
            .map(|(n, node)| (n, node.id))
            .collect();
        let mut watch = self.sof;
        let mut quiet = 0;
        loop {
            let mut sof = false;
            let stopped = self
                .engine
                .run_while(limit, |e| {
                    if ids
                        .iter()
                        .any(|&(_, id)| e.device::<ControllerNode>(id).irq())
                    {
                        return true;
                    }
                    if stop_at_sof {
                        let level = e.bus_level_before(e.now() + 1);
                        sof = watch.level(e.now(), level).is_some();
                    }
                    sof
                })
                .map_err(io_error)?;
            if !stopped {
                return Ok(false);
            }
            for &(n, id) in &ids {
                if self.engine.device::<ControllerNode>(id).irq() && !self.service(n) {
                    quiet += 1;
                    if quiet >= QUIET_SERVICE_LIMIT {
                        return Err(ScenarioError::new(format!(
                            "{}: irq_n stays low but the interrupt handler finds nothing",
                            self.name(n)
                        )));
                    }
                }
            }
            if sof {
                return Ok(true);
            }
        }
    }

    /// Runs node `n`'s interrupt handler and books what its driver reports; whether it reported
    /// anything.
    fn service(&mut self, n: usize) -> bool {
        let node = &mut self.nodes[n];
        let events = node.driver.interrupt(&mut self.engine);
        let at = self.engine.now();
        for event in &events {
            if let DriverEvent::StateChanged {
                state: CanState::BusOff,
                ..
            } = event
            {
                node.bus_off_at = Some(at);
            }
            node.events.push((at, Happening::Driver(*event)));
        }
        !events.is_empty()
    }

    /// Feeds the bus level changes so far to the decoder and the start-of-frame count, and places
    /// the faults that wait for a frame that started.
    fn observe_bus(&mut self) -> Result<(), ScenarioError> {
        let mut starts = Vec::new();
        for (t, level) in self.engine.take_bus_changes().map_err(io_error)? {
            self.decoder.level(t, level);
            if let Some(frame) = self.sof.level(t, level) {
                starts.push((frame, t));
                self.frame_starts.push(t);
            }
        }
        self.log.extend(self.decoder.drain());
        for (frame, sof_fs) in starts {
            while self
                .frame_faults
                .front()
                .is_some_and(|f| frame_number(f) == frame)
            {
                let fault = self.frame_faults.pop_front().expect("just looked at it");
                self.place_frame_fault(fault, frame, sof_fs)?;
            }
        }
        Ok(())
    }

    /// Places `fault` in frame number `frame`, which started at `sof_fs`: the frame on the bus is
    /// the one that wins the arbitration among the nodes transmitting 1¼ bits after the SOF. A
    /// fault that should begin before that (in the first identifier bit) begins then.
    fn place_frame_fault(
        &mut self,
        fault: &Fault,
        frame: u64,
        sof_fs: u64,
    ) -> Result<(), ScenarioError> {
        let Place::Bit { field, index, .. } = fault.place else {
            unreachable!("only faults located by frame wait for one");
        };
        let probe_fs = sof_fs + self.bit_fs * TRANSMITTERS_KNOWN_QUARTER_BITS / 4;
        if self.engine.now() < probe_fs {
            self.run_chunk(probe_fs, false)?;
        }
        let senders: Vec<(usize, Frame)> = (0..self.nodes.len())
            .filter(|&n| {
                let node = &self.nodes[n];
                node.present && self.engine.device::<ControllerNode>(node.id).transmitting()
            })
            .filter_map(|n| Some((n, self.nodes[n].driver.in_flight()?)))
            .collect();
        let frames: Vec<Frame> = senders.iter().map(|(_, f)| *f).collect();
        let (winner, position) = locate(&frames, field, index).map_err(|m| {
            ScenarioError::at_line(
                &self.scenario.path,
                fault.line,
                format!("frame {frame} on the bus: {m}"),
            )
        })?;
        let sender = senders
            .iter()
            .find(|(_, f)| *f == winner)
            .map(|(n, _)| *n)
            .expect("the winner is one of the senders' frames");
        let bit_fs = self.nodes[sender].config.bit_fs();
        let start =
            (sof_fs + position as u64 * bit_fs + fault.offset_fs).max(self.engine.now() + 1);
        install(&mut self.engine, fault, start, &self.targets);
        let text = format!(
            "{} {}: {field} bit {index} of frame {frame} ({winner} from {})",
            fault.kind.name(),
            self.fault_scope(fault),
            self.name(sender)
        );
        self.record_fault(fault, start, text);
        Ok(())
    }

    /// Brings the nodes up, runs until `end` and gathers the report.
    fn simulate(
        &mut self,
        end: u64,
        progress: &mut Option<&mut dyn FnMut(u64, u64)>,
    ) -> Result<RunReport, ScenarioError> {
        self.begin()?;
        while self.clock < end.min(self.recording_end()) {
            self.step(end)?;
            if let Some(progress) = progress.as_mut() {
                progress(self.clock.min(end), end);
            }
        }
        self.finish()
    }

    /// Finishes the VCD, if tracing; its path.
    pub(crate) fn finish_trace(&mut self) -> Result<Option<PathBuf>, ScenarioError> {
        self.engine.finish_trace().map_err(io_error)
    }

    /// When a run on a capture that ends it is over: that long after the capture's last change.
    fn recording_end(&self) -> u64 {
        let recording = self.scenario.recording.as_ref();
        let after = recording.and_then(|r| r.end_after_fs);
        let ended = self.recording.as_ref().and_then(RecordingFeed::ended_at);
        match (after, ended) {
            (Some(after), Some(ended)) => ended.saturating_add(after),
            _ => u64::MAX,
        }
    }

    fn finish(&mut self) -> Result<RunReport, ScenarioError> {
        let registers: Vec<(u8, u8)> = (0..self.nodes.len())
            .map(|n| {
                let mut host = Host::new(&mut self.engine, self.nodes[n].id);
                (host.read(pelican::TXERR), host.read(pelican::RXERR))
            })
            .collect();
        self.observe_bus()?;
        let simulated_fs = self.engine.now();
        self.decoder.finish(simulated_fs);
        self.log.extend(self.decoder.drain());
        let vcd = self.engine.finish_trace().map_err(io_error)?;
        let missed_faults = self
            .frame_faults
            .iter()
            .map(|f| {
                format!(
                    "line {}: not applied: the bus saw only {} frames",
                    f.line, self.sof.count
                )
            })
            .collect();
        let mut events: Vec<NodeEvent> = Vec::new();
        for (n, node) in self.nodes.iter().enumerate() {
            events.extend(node.events.iter().map(|(at, what)| NodeEvent {
                at_fs: *at,
                node: self.nodes[n].config.name.clone(),
                what: *what,
            }));
        }
        events.sort_by_key(|e| e.at_fs);
        let unfinished = self.unfinished_master_steps();
        self.master_lines.extend(unfinished);
        let nodes = self
            .nodes
            .iter()
            .zip(registers)
            .zip(self.schedule.overdue(self.clock, self.nodes.len()))
            .map(|((node, (tec, rec)), overdue)| node_report(node, tec, rec, overdue))
            .collect();
        self.applied.sort_by_key(|f| f.start_fs);
        Ok(RunReport {
            nodes,
            events,
            log: std::mem::take(&mut self.log),
            faults: std::mem::take(&mut self.applied),
            missed_faults,
            master: std::mem::take(&mut self.master_lines),
            frame_starts: std::mem::take(&mut self.frame_starts),
            simulated_fs,
            edges: self.engine.edges(),
            skipped_edges: self.engine.skipped_edges(),
            vcd,
            log_file: None,
            view: None,
            recording_shifts: self
                .recording
                .as_ref()
                .map(|r| r.shifts().to_vec())
                .unwrap_or_default(),
        })
    }
}

/// The complete controller of node `config`, stepped by `model`.
fn controller(config: &NodeConfig, model: ModelEngine) -> Result<ControllerNode, ScenarioError> {
    let clock = ClockSpec::with_ppm(f64::from(config.clock_hz), config.ppm);
    ControllerNode::with_engine(&config.name, clock, model)
        .map_err(|e| ScenarioError::new(e.to_string()))
}

impl RunNode {
    fn new(config: &NodeConfig, id: DeviceId) -> Result<RunNode, ScenarioError> {
        let driver_config = DriverConfig {
            clock_hz: config.clock_hz,
            filter: config.filter,
            ..DriverConfig::default()
        };
        Ok(RunNode {
            config: config.clone(),
            present: true,
            id,
            driver: Sja1000Driver::new(id, driver_config),
            queue: VecDeque::new(),
            events: Vec::new(),
            bus_off_at: None,
            restarts: 0,
            firmware: Firmware::of_node(config)?,
        })
    }

    /// Queues `frame` for the driver if the queue has room (`txqueuelen`); whether it had.
    fn offer(&mut self, frame: Frame) -> bool {
        let room = self.queue.len() < self.config.txqueuelen;
        if room {
            self.queue.push_back(frame);
        }
        room
    }
}

/// The frame a fault located by frame waits for.
fn frame_number(fault: &Fault) -> u64 {
    match fault.place {
        Place::Bit { frame, .. } => frame,
        Place::At(_) => 0,
    }
}

/// The report of `node`; `overdue`: its messages that were due and never got into its queue.
fn node_report(node: &RunNode, tec: u8, rec: u8, overdue: u64) -> NodeReport {
    let driver_events = || {
        node.events.iter().filter_map(|(_, what)| match what {
            Happening::Driver(event) => Some(event),
            Happening::Restarted => None,
        })
    };
    let count = |kind: fn(&DriverEvent) -> bool| driver_events().filter(|e| kind(e)).count();
    NodeReport {
        name: node.config.name.clone(),
        sent: count(|e| matches!(e, DriverEvent::TxDone(_))),
        received: driver_events()
            .filter_map(|e| match e {
                DriverEvent::Received(frame) => Some(*frame),
                _ => None,
            })
            .collect(),
        dropped: count(|e| matches!(e, DriverEvent::TxDropped(_) | DriverEvent::TxFailed(_)))
            + overdue as usize,
        unsent: node.queue.len() + usize::from(node.driver.in_flight().is_some()),
        tec,
        rec,
        state: node.driver.state(),
        restarts: node.restarts,
        stats: *node.driver.stats(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_start_of_frame_needs_nine_and_a_half_idle_bits() {
        let bit = 1000;
        let mut watch = SofWatch::new(bit);
        assert_eq!(watch.level(9_500, DOMINANT), Some(1));
        assert_eq!(watch.level(10_000, RECESSIVE), None);
        // An overload flag after 9 recessive bits is no start of frame; after 10 there is one.
        assert_eq!(watch.level(19_000, DOMINANT), None);
        assert_eq!(watch.level(25_000, RECESSIVE), None);
        assert_eq!(watch.level(35_000, DOMINANT), Some(2));
    }
}
