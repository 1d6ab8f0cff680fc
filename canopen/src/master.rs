//! A CANopen master: the NMT master (CiA 301 7.2.8.3.1), an SDO client for expedited, segmented
//! and block transfers, a SYNC producer (7.2.5), a TIME producer (7.2.6), its own heartbeat, and
//! the [`NodeTable`] (heartbeat and EMCY consumer). It works through a script of [`Step`]s one
//! after the other and reports how each ended, with what its node table saw, as
//! [`MasterEvent`]s.
//!
//! The master is a node of its own: at start it sends its boot-up message (700h + its node-ID)
//! and, with a heartbeat period, heartbeats with state operational (05h).

use crate::nmt::{NmtCommand, NmtState};
use crate::node_table::{NodeTable, Notice};
use crate::sdo::{Abort, SdoFrame};
use crate::sdo_block_client::BlockClient;
use crate::sdo_client::{SdoClient, SdoOutcome};
use crate::time_stamp::{TimeOfDay, DEFAULT_TIME_COB_ID};
use crate::CanFrame;

const NMT_COB_ID: u16 = 0x000;
const SYNC_COB_ID: u16 = 0x080;
const SDO_RESPONSE: u16 = 0x580;
const SDO_REQUEST: u16 = 0x600;
const ERROR_CONTROL: u16 = 0x700;
/// Byte 0 of an SDO abort (client and server alike).
const SDO_ABORT: u8 = 0x80;

/// What the master is and does besides its script.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MasterConfig {
    /// Its node-ID (1 to 127).
    pub node_id: u8,
    /// Its heartbeat period in ms (0: none).
    pub heartbeat_ms: u16,
    /// Heartbeat consumer time for every node it hears, in µs (0: no node is watched).
    pub heartbeat_timeout_us: u64,
    /// How long an SDO server may take to answer, in µs, before the transfer is aborted
    /// (0504 0000).
    pub sdo_timeout_us: u64,
    /// The time of day its TIME producer gives at time 0.
    pub time_start: TimeOfDay,
}

/// What a step does.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Action {
    /// Sends an NMT command to `node` (0: every node).
    Nmt {
        /// The command.
        command: NmtCommand,
        /// The node-ID, 0 for all.
        node: u8,
    },
    /// Reads `index`:`sub` of `node` (expedited or segmented as the server chooses; or block).
    Read {
        /// The server's node-ID.
        node: u8,
        /// Object.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// By block upload.
        block: bool,
    },
    /// Writes `data` to `index`:`sub` of `node` (expedited up to 4 bytes, else segmented; or block).
    Write {
        /// The server's node-ID.
        node: u8,
        /// Object.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The value's bytes.
        data: Vec<u8>,
        /// By block download.
        block: bool,
    },
    /// Sends one frame (a PDO for a device's RPDO, say).
    Send(CanFrame),
    /// The SYNC producer sends every `period_us` from now (0: stops it).
    Sync {
        /// Communication cycle period.
        period_us: u64,
    },
    /// The TIME producer sends every `period_us` from now (0: stops it).
    Time {
        /// Period.
        period_us: u64,
    },
    /// The master's own heartbeat: every `period_ms` from now (0: stops it).
    Heartbeat {
        /// Producer heartbeat time.
        period_ms: u16,
    },
    /// Waits this long.
    Wait {
        /// Microseconds.
        us: u64,
    },
    /// Waits until the node table shows `node` in `state`, at most `within_us`.
    AwaitState {
        /// Node-ID.
        node: u8,
        /// The state awaited.
        state: Awaited,
        /// The longest wait.
        within_us: u64,
    },
    /// Waits for an EMCY of `node` with `code` received since the step began, at most
    /// `within_us`.
    AwaitEmergency {
        /// Node-ID.
        node: u8,
        /// Error code.
        code: u16,
        /// The longest wait.
        within_us: u64,
    },
}

/// A state a script waits for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Awaited {
    /// A boot-up message.
    BootUp,
    /// A heartbeat with this state.
    State(NmtState),
    /// The heartbeat stayed away longer than the consumer time.
    Lost,
}

/// One step of the script.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Step {
    /// It begins once the step before has ended, not before this time.
    pub not_before_us: u64,
    /// What it does.
    pub action: Action,
}

/// How a step ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Done (NMT command or frame sent, producer set, wait over).
    Done,
    /// An upload's data.
    Uploaded(Vec<u8>),
    /// A download was confirmed.
    Downloaded,
    /// The transfer was aborted with this code (by the server, or by the master: timeout,
    /// protocol error).
    Aborted(Abort),
    /// What was awaited happened.
    Seen,
    /// What was awaited did not happen in time.
    NotSeen,
}

/// What the master reports.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MasterEvent {
    /// Step `step` (its index in the script) began.
    Began(usize),
    /// Step `step` ended.
    Finished {
        /// Its index in the script.
        step: usize,
        /// How.
        outcome: Outcome,
    },
    /// The node table saw this.
    Notice(Notice),
}

/// A block or a classic SDO transfer.
enum Transfer {
    Classic(SdoClient),
    Block(BlockClient),
}

/// What the master is busy with.
enum Running {
    Idle,
    Sdo { node: u8, transfer: Transfer },
    Wait { until_us: u64 },
    Await { since_us: u64, until_us: u64 },
}

/// A periodic producer.
#[derive(Clone, Copy, Debug, Default)]
struct Periodic {
    period_us: u64,
    next_us: Option<u64>,
}

impl Periodic {
    fn set(&mut self, period_us: u64, now_us: u64) {
        self.period_us = period_us;
        self.next_us = (period_us > 0).then_some(now_us + period_us);
    }

    /// Whether it is due at `now_us` (then it is rescheduled).
    fn due(&mut self, now_us: u64) -> bool {
        let due = self.next_us.is_some_and(|at| now_us >= at);
        if due {
            self.next_us = self.next_us.map(|at| at + self.period_us);
        }
        due
    }
}

/// The master.
pub struct Master {
    config: MasterConfig,
    steps: Vec<Step>,
    next: usize,
    running: Running,
    table: NodeTable,
    sync: Periodic,
    time: Periodic,
    heartbeat: Periodic,
    events: Vec<(u64, MasterEvent)>,
}

impl Master {
    /// A master with `config` that will run `steps`.
    pub fn new(config: MasterConfig, steps: Vec<Step>) -> Result<Master, String> {
        if !(1..=127).contains(&config.node_id) {
            return Err(format!(
                "node-ID {} is out of range 1..=127",
                config.node_id
            ));
        }
        Ok(Master {
            config,
            steps,
            next: 0,
            running: Running::Idle,
            table: NodeTable::new(config.heartbeat_timeout_us),
            sync: Periodic::default(),
            time: Periodic::default(),
            heartbeat: Periodic::default(),
            events: Vec::new(),
        })
    }

    /// Power-on at `now_us`: its boot-up message, then the script begins.
    pub fn start(&mut self, now_us: u64) -> Vec<CanFrame> {
        self.heartbeat
            .set(u64::from(self.config.heartbeat_ms) * 1000, now_us);
        let mut out = vec![CanFrame::new(self.own_error_control(), &[0x00])];
        out.extend(self.advance(now_us));
        out
    }

    /// Whether every step has ended.
    pub fn finished(&self) -> bool {
        self.next == self.steps.len() && matches!(self.running, Running::Idle)
    }

    /// Takes what it reported since the last call, with the times.
    pub fn take_events(&mut self) -> Vec<(u64, MasterEvent)> {
        std::mem::take(&mut self.events)
    }

    fn own_error_control(&self) -> u16 {
        ERROR_CONTROL + u16::from(self.config.node_id)
    }

    /// `frame` arrived at `now_us`; what the master sends in answer.
    pub fn receive(&mut self, frame: &CanFrame, now_us: u64) -> Vec<CanFrame> {
        if let Some(notice) = self.table.receive(frame, now_us) {
            self.events.push((now_us, MasterEvent::Notice(notice)));
        }
        let mut out = Vec::new();
        if let Running::Sdo { node, transfer } = &mut self.running {
            if frame.id == SDO_RESPONSE + u16::from(*node) && !frame.remote {
                let request = SDO_REQUEST + u16::from(*node);
                let server_aborted = frame.data.first() == Some(&SDO_ABORT);
                match respond(transfer, &frame.data, now_us) {
                    Ok(frames) => out.extend(frames.iter().map(|f| CanFrame::new(request, f))),
                    Err((answer, outcome)) => {
                        if let (Some(answer), false) = (answer, server_aborted) {
                            out.push(CanFrame::new(request, &answer));
                        }
                        self.finish(now_us, outcome);
                    }
                }
            }
        }
        self.check_awaited(now_us);
        out.extend(self.advance(now_us));
        out
    }

    /// The time is `now_us`: what falls due (producers, timeouts, the next steps).
    pub fn tick(&mut self, now_us: u64) -> Vec<CanFrame> {
        let mut out = Vec::new();
        for notice in self.table.tick(now_us) {
            self.events.push((now_us, MasterEvent::Notice(notice)));
        }
        if self.heartbeat.due(now_us) {
            let operational = NmtState::Operational.code();
            out.push(CanFrame::new(self.own_error_control(), &[operational]));
        }
        if self.sync.due(now_us) {
            out.push(CanFrame::new(SYNC_COB_ID, &[]));
        }
        if self.time.due(now_us) {
            let time = self.config.time_start.plus_us(now_us);
            out.push(CanFrame::new(DEFAULT_TIME_COB_ID, &time.encode()));
        }
        out.extend(self.sdo_timeout(now_us));
        self.check_awaited(now_us);
        match self.running {
            Running::Wait { until_us } if now_us >= until_us => self.finish(now_us, Outcome::Done),
            Running::Await { until_us, .. } if now_us >= until_us => {
                self.finish(now_us, Outcome::NotSeen)
            }
            _ => {}
        }
        out.extend(self.advance(now_us));
        out
    }

    /// When something falls due next, if anything will.
    pub fn next_deadline(&self) -> Option<u64> {
        let running = match &self.running {
            Running::Idle => self.steps.get(self.next).map(|s| s.not_before_us),
            Running::Sdo { transfer, .. } => Some(transfer.last_us() + self.config.sdo_timeout_us),
            Running::Wait { until_us } | Running::Await { until_us, .. } => Some(*until_us),
        };
        [
            running,
            self.sync.next_us,
            self.time.next_us,
            self.heartbeat.next_us,
            self.table.deadline(),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    fn sdo_timeout(&mut self, now_us: u64) -> Option<CanFrame> {
        let Running::Sdo { node, transfer } = &self.running else {
            return None;
        };
        if now_us < transfer.last_us() + self.config.sdo_timeout_us {
            return None;
        }
        let abort = transfer.abort_frame(Abort::TIMEOUT);
        let frame = CanFrame::new(SDO_REQUEST + u16::from(*node), &abort);
        self.finish(now_us, Outcome::Aborted(Abort::TIMEOUT));
        Some(frame)
    }

    fn check_awaited(&mut self, now_us: u64) {
        let Running::Await { since_us, .. } = self.running else {
            return;
        };
        let Some(Step { action, .. }) = self.next.checked_sub(1).map(|i| &self.steps[i]) else {
            return;
        };
        let seen = match *action {
            Action::AwaitState { node, state, .. } => {
                self.table.status(node).is_some_and(|s| match state {
                    Awaited::Lost => s.lost,
                    Awaited::BootUp => s.state == NmtState::Initialisation && s.last_us >= since_us,
                    Awaited::State(state) => s.state == state && !s.lost,
                })
            }
            Action::AwaitEmergency { node, code, .. } => {
                self.table.take_emergency(node, code, since_us).is_some()
            }
            _ => false,
        };
        if seen {
            self.finish(now_us, Outcome::Seen);
        }
    }

    fn finish(&mut self, now_us: u64, outcome: Outcome) {
        self.running = Running::Idle;
        let step = self.next - 1;
        self.events
            .push((now_us, MasterEvent::Finished { step, outcome }));
    }

    /// Begins the steps that are due while nothing runs; the frames they send.
    fn advance(&mut self, now_us: u64) -> Vec<CanFrame> {
        let mut out = Vec::new();
        while matches!(self.running, Running::Idle) {
            let Some(step) = self.steps.get(self.next) else {
                break;
            };
            if now_us < step.not_before_us {
                break;
            }
            let action = step.action.clone();
            self.events.push((now_us, MasterEvent::Began(self.next)));
            self.next += 1;
            out.extend(self.begin(action, now_us));
            self.check_awaited(now_us);
        }
        out
    }

    fn begin(&mut self, action: Action, now_us: u64) -> Vec<CanFrame> {
        let (frame, running) = match action {
            Action::Nmt { command, node } => {
                let frame = CanFrame::new(NMT_COB_ID, &[command.specifier(), node]);
                (Some(frame), Running::Idle)
            }
            Action::Read {
                node,
                index,
                sub,
                block,
            } => {
                let (transfer, request) = if block {
                    let (client, request) = BlockClient::upload(index, sub, now_us);
                    (Transfer::Block(client), request)
                } else {
                    let mut client = SdoClient::default();
                    let request = client.upload(index, sub, now_us);
                    (Transfer::Classic(client), request)
                };
                let frame = CanFrame::new(SDO_REQUEST + u16::from(node), &request);
                (Some(frame), Running::Sdo { node, transfer })
            }
            Action::Write {
                node,
                index,
                sub,
                data,
                block,
            } => {
                let (transfer, request) = if block {
                    let (client, request) = BlockClient::download(index, sub, &data, now_us);
                    (Transfer::Block(client), request)
                } else {
                    let mut client = SdoClient::default();
                    let request = client.download(index, sub, &data, now_us);
                    (Transfer::Classic(client), request)
                };
                let frame = CanFrame::new(SDO_REQUEST + u16::from(node), &request);
                (Some(frame), Running::Sdo { node, transfer })
            }
            Action::Send(frame) => (Some(frame), Running::Idle),
            Action::Sync { period_us } => {
                self.sync.set(period_us, now_us);
                (None, Running::Idle)
            }
            Action::Time { period_us } => {
                self.time.set(period_us, now_us);
                (None, Running::Idle)
            }
            Action::Heartbeat { period_ms } => {
                self.heartbeat.set(u64::from(period_ms) * 1000, now_us);
                (None, Running::Idle)
            }
            Action::Wait { us } => (
                None,
                Running::Wait {
                    until_us: now_us + us,
                },
            ),
            Action::AwaitState { within_us, .. } | Action::AwaitEmergency { within_us, .. } => (
                None,
                Running::Await {
                    since_us: now_us,
                    until_us: now_us + within_us,
                },
            ),
        };
        self.running = running;
        if matches!(self.running, Running::Idle) {
            self.events.push((
                now_us,
                MasterEvent::Finished {
                    step: self.next - 1,
                    outcome: Outcome::Done,
                },
            ));
        }
        frame.into_iter().collect()
    }
}

/// The next requests of `transfer` after the server's `data`, or the outcome with the frame the
/// client still sends (its abort, or a block upload's end confirmation).
fn respond(
    transfer: &mut Transfer,
    data: &[u8],
    now_us: u64,
) -> Result<Vec<SdoFrame>, (Option<SdoFrame>, Outcome)> {
    let result = match transfer {
        Transfer::Classic(client) => client.response(data, now_us).map(|f| vec![f]),
        Transfer::Block(client) => client.response(data, now_us),
    };
    match result {
        Ok(frames) => Ok(frames),
        Err(SdoOutcome::Uploaded(data)) => {
            let confirm =
                matches!(transfer, Transfer::Block(_)).then(BlockClient::end_confirmation);
            Err((confirm, Outcome::Uploaded(data)))
        }
        Err(SdoOutcome::Downloaded) => Err((None, Outcome::Downloaded)),
        Err(SdoOutcome::Aborted(abort)) => {
            Err((Some(transfer.abort_frame(abort)), Outcome::Aborted(abort)))
        }
    }
}

impl Transfer {
    fn abort_frame(&self, abort: Abort) -> SdoFrame {
        match self {
            Transfer::Classic(client) => client.abort_frame(abort),
            Transfer::Block(client) => client.abort_frame(abort),
        }
    }

    /// When the server last answered (or the transfer began).
    fn last_us(&self) -> u64 {
        match self {
            Transfer::Classic(client) => client.last_us(),
            Transfer::Block(client) => client.last_us(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Device;
    use crate::eds;
    use std::collections::VecDeque;
    use std::path::Path;

    /// A frame takes this long on the bus (about 110 bits at 500 kbit/s).
    const FRAME_US: u64 = 220;
    const MASTER: u8 = 1;
    const IO: u8 = 2;

    /// The master and I/O modules on an ideal bus: frames go out one after the other, each seen
    /// by every other node.
    struct Network {
        master: Master,
        devices: Vec<Device>,
        now: u64,
        queue: VecDeque<(Option<usize>, CanFrame)>,
        log: Vec<(u64, CanFrame)>,
        events: Vec<(u64, MasterEvent)>,
    }

    fn io_module(node_id: u8) -> Device {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/eds/io.eds");
        Device::new(node_id, eds::load(&path, node_id).unwrap()).unwrap()
    }

    fn config() -> MasterConfig {
        MasterConfig {
            node_id: MASTER,
            heartbeat_ms: 10,
            heartbeat_timeout_us: 25_000,
            sdo_timeout_us: 20_000,
            time_start: TimeOfDay::Y2000,
        }
    }

    impl Network {
        fn new(steps: Vec<Step>) -> Network {
            let mut net = Network {
                master: Master::new(config(), steps).unwrap(),
                devices: vec![io_module(IO)],
                now: 0,
                queue: VecDeque::new(),
                log: Vec::new(),
                events: Vec::new(),
            };
            let out = net.master.start(0);
            net.send(None, out);
            for d in 0..net.devices.len() {
                let out = net.devices[d].start(0);
                net.send(Some(d), out);
            }
            net
        }

        fn send(&mut self, from: Option<usize>, frames: Vec<CanFrame>) {
            self.queue.extend(frames.into_iter().map(|f| (from, f)));
        }

        fn run_until(&mut self, end_us: u64) {
            while self.now < end_us {
                if let Some((from, frame)) = self.queue.pop_front() {
                    self.now += FRAME_US;
                    self.log.push((self.now, frame.clone()));
                    if from.is_some() {
                        let out = self.master.receive(&frame, self.now);
                        self.send(None, out);
                    }
                    for d in 0..self.devices.len() {
                        if from != Some(d) {
                            let out = self.devices[d].receive(&frame, self.now);
                            self.send(Some(d), out);
                        }
                    }
                } else {
                    let deadlines = self.devices.iter().filter_map(Device::next_deadline);
                    let next = deadlines.chain(self.master.next_deadline()).min();
                    self.now = next.unwrap_or(end_us).clamp(self.now + 1, end_us);
                    let out = self.master.tick(self.now);
                    self.send(None, out);
                    for d in 0..self.devices.len() {
                        let out = self.devices[d].tick(self.now);
                        self.send(Some(d), out);
                    }
                }
                self.events.extend(self.master.take_events());
            }
        }

        /// How each step ended, in order.
        fn outcomes(&self) -> Vec<Outcome> {
            let finished = self.events.iter().filter_map(|(_, e)| match e {
                MasterEvent::Finished { outcome, .. } => Some(outcome.clone()),
                _ => None,
            });
            finished.collect()
        }

        fn frames_on(&self, id: u16) -> Vec<&(u64, CanFrame)> {
            self.log.iter().filter(|(_, f)| f.id == id).collect()
        }
    }

    fn step(action: Action) -> Step {
        Step {
            not_before_us: 0,
            action,
        }
    }

    fn read(node: u8, index: u16, sub: u8, block: bool) -> Step {
        step(Action::Read {
            node,
            index,
            sub,
            block,
        })
    }

    fn write(node: u8, index: u16, sub: u8, data: &[u8], block: bool) -> Step {
        step(Action::Write {
            node,
            index,
            sub,
            data: data.to_vec(),
            block,
        })
    }

    fn await_state(state: Awaited) -> Step {
        step(Action::AwaitState {
            node: IO,
            state,
            within_us: 50_000,
        })
    }

    #[test]
    fn nmt_and_sdo_in_every_form_against_our_device() {
        let label = b"a label of forty bytes, sent by block!!!";
        let mut net = Network::new(vec![
            await_state(Awaited::BootUp),
            read(IO, 0x1008, 0, false),
            write(IO, 0x2001, 0, label, true),
            read(IO, 0x2001, 0, true),
            read(IO, 0x2001, 0, false),
            write(IO, 0x1017, 0, &10u16.to_le_bytes(), false),
            step(Action::Nmt {
                command: NmtCommand::Start,
                node: IO,
            }),
            await_state(Awaited::State(NmtState::Operational)),
            read(IO, 0x3000, 0, false),
            write(IO, 0x1008, 0, b"x", false),
            read(9, 0x1000, 0, false),
        ]);
        net.run_until(200_000);
        assert_eq!(
            net.outcomes(),
            [
                Outcome::Seen,
                Outcome::Uploaded(b"cansim IO 8x8".to_vec()),
                Outcome::Downloaded,
                Outcome::Uploaded(label.to_vec()),
                Outcome::Uploaded(label.to_vec()),
                Outcome::Downloaded,
                Outcome::Done,
                Outcome::Seen,
                // CiA 301 Table 22: object does not exist; attempt to write a read only object.
                Outcome::Aborted(Abort::NO_OBJECT),
                Outcome::Aborted(Abort::READ_ONLY),
                Outcome::Aborted(Abort::TIMEOUT),
            ]
        );
        assert!(net.master.finished());
        // The NMT command: 000#01 02. The timeout's abort: 609#80 0010 00 00000405.
        assert_eq!(net.frames_on(0x000)[0].1.data, [0x01, IO]);
        let abort = &net.frames_on(0x609).last().unwrap().1;
        assert_eq!(abort.data, [0x80, 0x00, 0x10, 0, 0x00, 0x00, 0x04, 0x05]);
        // A block download's sub-block: 6 segments of 7 bytes, numbered 1..6, the last with bit 7.
        let segments: Vec<u8> = net
            .frames_on(0x602)
            .iter()
            .map(|(_, f)| f.data[0])
            .skip_while(|&b| b != 1)
            .take(6)
            .collect();
        assert_eq!(segments, [1, 2, 3, 4, 5, 0x86]);
    }

    #[test]
    fn sync_time_and_heartbeats_go_out_with_their_periods() {
        let mut net = Network::new(vec![
            step(Action::Sync { period_us: 2_000 }),
            step(Action::Time { period_us: 5_000 }),
            step(Action::Wait { us: 10_000 }),
            step(Action::Sync { period_us: 0 }),
        ]);
        net.run_until(31_000);
        let syncs: Vec<u64> = net.frames_on(0x080).iter().map(|(t, _)| *t).collect();
        assert_eq!(syncs.len(), 5, "2, 4, 6, 8 and 10 ms: {syncs:?}");
        let times = net.frames_on(0x100);
        assert_eq!(times.len(), 6, "every 5 ms");
        // The first TIME is 5 ms after 2000-01-01 00:00 (it may go out a frame later).
        assert_eq!(times[0].1.data, TimeOfDay::Y2000.plus_us(5_000).encode());
        // The device consumed them (1012h: 8000 0100h): it keeps the last one's time.
        let (at, last) = times.last().unwrap();
        assert_eq!(TimeOfDay::decode(&last.data).map(|t| t.ms), Some(30));
        assert_eq!(net.devices[0].time_of_day(*at).map(|t| t.ms), Some(30));
        let heartbeats = net.frames_on(0x701);
        assert_eq!(heartbeats[0].1.data, [0x00], "boot-up");
        assert_eq!(heartbeats[1].1.data, [0x05], "operational");
        assert_eq!(heartbeats.len(), 4, "boot-up, 10, 20, 30 ms");
    }

    #[test]
    fn a_lost_heartbeat_and_an_emcy_are_seen() {
        let watch_master = ((u32::from(MASTER) << 16) | 30).to_le_bytes();
        let mut net = Network::new(vec![
            write(IO, 0x1017, 0, &10u16.to_le_bytes(), false),
            write(IO, 0x1016, 1, &watch_master, false),
            await_state(Awaited::State(NmtState::PreOperational)),
            // The device stops its heartbeat: after 25 ms the master calls it lost.
            write(IO, 0x1017, 0, &0u16.to_le_bytes(), false),
            await_state(Awaited::Lost),
            // The master stops its own: after 30 ms the device sends EMCY 8130h.
            step(Action::Heartbeat { period_ms: 0 }),
            step(Action::AwaitEmergency {
                node: IO,
                code: 0x8130,
                within_us: 50_000,
            }),
            step(Action::AwaitEmergency {
                node: IO,
                code: 0x8130,
                within_us: 50_000,
            }),
        ]);
        net.run_until(300_000);
        assert_eq!(
            net.outcomes(),
            [
                Outcome::Downloaded,
                Outcome::Downloaded,
                Outcome::Seen,
                Outcome::Downloaded,
                Outcome::Seen,
                Outcome::Done,
                Outcome::Seen,
                Outcome::NotSeen,
            ]
        );
        let notices: Vec<&Notice> = net
            .events
            .iter()
            .filter_map(|(_, e)| match e {
                MasterEvent::Notice(n) => Some(n),
                _ => None,
            })
            .collect();
        assert!(notices.contains(&&Notice::HeartbeatLost(IO)));
        let emcy = notices.iter().find_map(|n| match n {
            Notice::Emergency(e) => Some((e.code, e.register)),
            _ => None,
        });
        // CiA 301 7.2.8.3.2.2 and Table 21/48: 8130h, communication and generic error bits.
        assert_eq!(emcy, Some((0x8130, 0x11)));
    }

    #[test]
    fn node_ids_outside_1_to_127_are_refused() {
        for node_id in [0, 128] {
            let config = MasterConfig {
                node_id,
                ..config()
            };
            assert!(Master::new(config, Vec::new()).is_err());
        }
    }
}
