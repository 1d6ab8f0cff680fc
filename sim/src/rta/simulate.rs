//! Checks the analyses on the cycle-accurate bus: every message gets its own RTL CAN core
//! ([`CanNode`]), and one scenario per message m recreates m's critical instant.
//!
//! Scenario m: the nodes of hep(m) and of the lower-priority message with the longest frame (the
//! blocker) integrate on an idle bus; the blocker requests its frame, and one bit after its start
//! of frame (t0) every message of hep(m) is released, each first instance delayed by its full
//! jitter, later instances at the fastest rate (event times t0 + i·T − J, queued at
//! max(t0, event)). Releases continue for the corrected analysis's level-m busy period, then the
//! run ends when every queued instance is sent. Lower-priority messages other than the blocker
//! stay silent. A message's instances queue in software (FIFO) while its core's single transmit
//! buffer is busy, as the analysis assumes; one core per message avoids the SJA1000's single
//! buffer blocking a queued higher-priority frame of the same node.
//!
//! A response is measured from the initiating event to the transmitter's transmit-complete
//! indication (the core's `tx_done`, a few clocks after the sample point of the last EOF bit; with
//! the bit timing used here one clock after the end of that bit). Every instance of every message
//! in every scenario is a legal behaviour, so the observed worst case of a message is the maximum
//! over all of them. Frames carry the payload with the most stuff bits for their identifier and
//! DLC ([`search_for_id`]).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use super::analysis::Analysis;
use super::message_set::{MessageSet, TimeBase};
use super::Ticks;
use crate::engine::time::{ClockSpec, FS_PER_NS};
use crate::engine::{DeviceId, Engine};
use crate::nodes::can_node::{CanNode, NodeEvent};
use golden::btr::Btr;
use golden::frame::{Frame, DOMINANT};
use golden::worst_case::search_for_id;

/// TSEG1 of the simulated nodes in tq. With sync 1 and TSEG2 2 a bit has 8 tq (the fewest CAN
/// 2.0 asks controllers to support), 16 controller clocks at BRP 0, sample point 75 %: cheap to
/// simulate (the cost is per clock per node) and an exact number of femtoseconds per clock at
/// the usual bit rates. The sample point must come well after the 6 clocks the core takes from
/// another node's edge to its own answer (input synchroniser, output register): with TSEG1 =
/// 2 tq (sample point at clock 6) receivers' acknowledgements arrive too late.
const TSEG1_TQ: u32 = 5;
/// TSEG2 of the simulated nodes in tq.
const TSEG2_TQ: u32 = 2;
/// SJW of the simulated nodes in tq (one clock domain: nothing to resynchronise).
const SJW_TQ: u32 = 1;
/// Idle bits before a scenario starts: a node takes part after 11 recessive bits.
const INTEGRATION_BITS: u64 = 14;
/// A scenario that has not finished this many busy periods after t0 (plus
/// [`RUN_LIMIT_EXTRA_BITS`]) is stuck, not slow.
const RUN_LIMIT_BUSY_PERIODS: u64 = 4;
/// Extra bit times of the run limit.
const RUN_LIMIT_EXTRA_BITS: u64 = 10_000;

/// The bit timing of every simulated node: BRP 0, 8 tq per bit.
pub fn sim_btr() -> Btr {
    Btr::from_quanta(0, TSEG1_TQ, TSEG2_TQ, SJW_TQ, false).expect("a valid bit timing")
}

/// The controller clock that gives `bitrate` with [`sim_btr`].
pub fn sim_clock(bitrate: u32) -> ClockSpec {
    ClockSpec::from_hz(f64::from(bitrate) * f64::from(sim_btr().clocks_per_bit()))
}

/// The longest response seen for one message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Observation {
    /// From the initiating event to transmit-complete, in femtoseconds.
    pub response_fs: u64,
    /// Which instance it was, counted from the scenario's critical instant (0 = first).
    pub instance: u64,
    /// Whose critical instant the scenario recreated (index of that message in the set).
    pub scenario: usize,
}

impl Observation {
    /// The response in the set's ticks (nanoseconds), rounded to the nearest, for display: a clock
    /// period need not be a whole number of nanoseconds (78.125 ns at 800 kbit/s).
    pub fn response_ticks(&self) -> Ticks {
        (self.response_fs + FS_PER_NS / 2) / FS_PER_NS
    }

    /// Whether the response is longer than `bound` ticks, compared to the femtosecond.
    pub fn exceeds(&self, bound: Ticks) -> bool {
        self.response_fs > bound * FS_PER_NS
    }
}

/// What the simulation saw.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Simulation {
    /// The frame each message sent (in the set's order).
    pub frames: Vec<Frame>,
    /// Each message's longest observed response; `None` if it never sent (its own scenario was
    /// skipped because its busy period is unbounded, and no other scenario released it).
    pub observed: Vec<Option<Observation>>,
    /// Messages whose scenario was skipped: the corrected analysis found no finite busy period.
    pub skipped: Vec<usize>,
    /// Frames sent, all scenarios together.
    pub frames_sent: u64,
    /// Simulated bus time, all scenarios together, in femtoseconds.
    pub simulated_fs: u64,
}

/// Runs one scenario per message of `set` on `threads` threads and collects the longest
/// responses; `progress(done, total)` is called after each scenario. Fails for an abstract set
/// (it has no frames) or if the bus misbehaves (a bus error, a frame not sent).
pub fn simulate(
    set: &MessageSet,
    analysis: &Analysis,
    threads: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Simulation, String> {
    let TimeBase::Bitrate(bitrate) = set.time_base else {
        return Err(
            "abstract message sets cannot be simulated: give a bitrate and DLCs".to_string(),
        );
    };
    let frames: Vec<Frame> = set
        .messages
        .iter()
        .map(|m| {
            let dlc = m
                .dlc
                .expect("a set with a bit rate gives every message a DLC");
            search_for_id(m.id, usize::from(dlc)).frame
        })
        .collect();
    let bench = Bench {
        set,
        frames: &frames,
        clock: sim_clock(bitrate),
        btr: sim_btr(),
    };
    let count = set.messages.len();
    let next = AtomicUsize::new(0);
    let results = Mutex::new((0..count).map(|_| None).collect::<Vec<_>>());
    let done = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..threads.clamp(1, count) {
            scope.spawn(|| loop {
                let focus = next.fetch_add(1, Ordering::Relaxed);
                if focus >= count {
                    break;
                }
                let result = match &analysis.messages[focus].corrected {
                    Ok(bounds) => bench.run(focus, bounds.busy_period).map(Some),
                    Err(_) => Ok(None),
                };
                results.lock().expect("no worker panicked")[focus] = Some(result);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, count);
            });
        }
    });
    let mut simulation = Simulation {
        frames,
        observed: vec![None; count],
        skipped: Vec::new(),
        frames_sent: 0,
        simulated_fs: 0,
    };
    let results = results.into_inner().expect("no worker panicked");
    for (focus, result) in results.into_iter().enumerate() {
        let Some(run) = result.expect("every scenario ran")? else {
            simulation.skipped.push(focus);
            continue;
        };
        simulation.frames_sent += run.responses.len() as u64;
        simulation.simulated_fs += run.simulated_fs;
        for (message, instance, response_fs) in run.responses {
            let slot = &mut simulation.observed[message];
            if slot.is_none_or(|o| response_fs > o.response_fs) {
                *slot = Some(Observation {
                    response_fs,
                    instance,
                    scenario: focus,
                });
            }
        }
    }
    Ok(simulation)
}

/// The messages (indices) whose observed worst case exceeds their corrected bound: that would
/// mean the analysis, or the bus, is wrong.
pub fn violations(analysis: &Analysis, sim: &Simulation) -> Vec<usize> {
    analysis
        .messages
        .iter()
        .zip(&sim.observed)
        .enumerate()
        .filter(
            |(_, (bounds, observed))| match (&bounds.corrected, observed) {
                (Ok(c), Some(o)) => o.exceeds(c.worst.response),
                _ => false,
            },
        )
        .map(|(i, _)| i)
        .collect()
}

/// What is shared by the scenarios of one set.
struct Bench<'a> {
    set: &'a MessageSet,
    frames: &'a [Frame],
    clock: ClockSpec,
    btr: Btr,
}

/// One scenario's outcome.
struct Run {
    /// (message, instance, response in fs) of every frame sent.
    responses: Vec<(usize, u64, u64)>,
    /// Bus time simulated.
    simulated_fs: u64,
}

/// An instance waiting for or in transmission; its event time may precede time 0 (jitter).
#[derive(Clone, Copy, Debug)]
struct Instance {
    number: u64,
    event_fs: i128,
}

/// A message's node and its software queue.
struct Sender {
    message: usize,
    node: DeviceId,
    backlog: VecDeque<Instance>,
    in_flight: Option<Instance>,
    events_seen: usize,
}

impl Sender {
    fn idle(&self) -> bool {
        self.in_flight.is_none() && self.backlog.is_empty()
    }
}

/// One instance of one sender (index into the scenario's senders) queued at `at_fs`.
struct Release {
    at_fs: u64,
    sender: usize,
    instance: Instance,
}

impl Bench<'_> {
    fn bit_fs(&self) -> u64 {
        self.clock.period_fs() * u64::from(self.btr.clocks_per_bit())
    }

    fn name(&self, message: usize) -> &str {
        &self.set.messages[message].name
    }

    /// The scenario of message `focus`, releasing for `busy_period` ticks after t0.
    fn run(&self, focus: usize, busy_period: Ticks) -> Result<Run, String> {
        let messages = &self.set.messages;
        let blocker = (focus + 1..messages.len()).max_by_key(|&k| (messages[k].transmission, k));
        let mut scenario = Scenario::new(self, (0..=focus).chain(blocker));
        scenario.run_for(INTEGRATION_BITS * self.bit_fs())?;
        let t0 = match blocker {
            Some(_) => scenario.start_blocker(focus + 1)? + self.bit_fs(),
            None => scenario.engine.now(),
        };
        let busy_fs = busy_period * FS_PER_NS;
        let releases = self.releases(&scenario.senders[..=focus], t0, t0 + busy_fs);
        let limit = t0 + RUN_LIMIT_BUSY_PERIODS * busy_fs + RUN_LIMIT_EXTRA_BITS * self.bit_fs();
        scenario.play(&releases, limit).map_err(|e| {
            let ms = scenario.engine.now().saturating_sub(t0) / crate::engine::time::FS_PER_MS;
            format!(
                "scenario of {} ({ms} ms after the critical instant): {e}",
                self.name(focus)
            )
        })?;
        Ok(Run {
            simulated_fs: scenario.engine.now(),
            responses: scenario.responses,
        })
    }

    /// The instances of the senders `hep` queued from `t0` until `horizon`, in time order: the
    /// first of each at `t0` after its full jitter, the others at the fastest rate.
    fn releases(&self, hep: &[Sender], t0: u64, horizon: u64) -> Vec<Release> {
        let mut releases = Vec::new();
        for (index, sender) in hep.iter().enumerate() {
            let m = &self.set.messages[sender.message];
            let (period, jitter) = (m.period * FS_PER_NS, m.jitter * FS_PER_NS);
            for number in 0.. {
                let event_fs =
                    t0 as i128 + i128::from(number) * i128::from(period) - i128::from(jitter);
                let at_fs = event_fs.max(t0 as i128) as u64;
                if at_fs >= horizon {
                    break;
                }
                releases.push(Release {
                    at_fs,
                    sender: index,
                    instance: Instance { number, event_fs },
                });
            }
        }
        releases.sort_by_key(|r| r.at_fs);
        releases
    }
}

/// The nodes of one scenario on their bus, and the responses seen so far.
struct Scenario<'a> {
    bench: &'a Bench<'a>,
    engine: Engine,
    senders: Vec<Sender>,
    /// A node that only acknowledges, when a single message is on the bus.
    listener: Option<DeviceId>,
    responses: Vec<(usize, u64, u64)>,
}

impl<'a> Scenario<'a> {
    /// A node for each of `messages`, plus a listener if that is a single node (a frame needs a
    /// receiver to acknowledge it).
    fn new(bench: &'a Bench<'a>, messages: impl Iterator<Item = usize>) -> Self {
        let mut engine = Engine::new();
        let mut node = |name: &str| engine.add(CanNode::new(name, bench.clock, bench.btr), 0);
        let senders: Vec<Sender> = messages
            .map(|message| Sender {
                message,
                node: node(bench.name(message)),
                backlog: VecDeque::new(),
                in_flight: None,
                events_seen: 0,
            })
            .collect();
        let listener = (senders.len() < 2).then(|| node("ack"));
        Scenario {
            bench,
            engine,
            senders,
            listener,
            responses: Vec::new(),
        }
    }

    fn run_for(&mut self, fs: u64) -> Result<(), String> {
        let end = self.engine.now() + fs;
        self.engine.run_until(end).map_err(|e| e.to_string())
    }

    /// Requests the frame of sender `index` on the idle bus; returns when its start of frame
    /// reaches the bus.
    fn start_blocker(&mut self, index: usize) -> Result<u64, String> {
        let event_fs = i128::from(self.engine.now());
        self.queue(
            index,
            Instance {
                number: 0,
                event_fs,
            },
        );
        let limit = self.engine.now() + INTEGRATION_BITS * self.bench.bit_fs();
        let started = self
            .engine
            .run_while(limit, |e| e.bus_level_before(e.now() + 1) == DOMINANT)
            .map_err(|e| e.to_string())?;
        match started {
            true => Ok(self.engine.now()),
            false => Err("the blocking frame never started".into()),
        }
    }

    /// Queues `releases` at their times and runs until every queue is empty.
    fn play(&mut self, releases: &[Release], limit: u64) -> Result<(), String> {
        let bit_fs = self.bench.bit_fs();
        let mut next = 0;
        let mut time = self.engine.now();
        while next < releases.len() || !self.senders.iter().all(Sender::idle) {
            if time > limit {
                return Err("frames are still queued".into());
            }
            // Steps of at most a bit: a queued instance is requested within a bit of its
            // predecessor's transmit-complete, well before the next arbitration (3 bits later).
            let target = releases
                .get(next)
                .map_or(time + bit_fs, |r| r.at_fs.min(time + bit_fs));
            // Every edge before `target` is processed; requests made now act from `target` on.
            self.engine.run_until(target).map_err(|e| e.to_string())?;
            time = target.max(time);
            for index in 0..self.senders.len() {
                self.collect(index)?;
            }
            while let Some(release) = releases.get(next).filter(|r| r.at_fs <= time) {
                self.queue(release.sender, release.instance);
                next += 1;
            }
        }
        let ack = self
            .listener
            .map(|id| self.engine.device::<CanNode>(id).bus_errors());
        match ack.iter().flatten().next() {
            Some(&ecc) => Err(bus_error("ack", ecc)),
            None => Ok(()),
        }
    }

    /// Queues `instance` on sender `index`: requested at once if its transmit buffer is free.
    fn queue(&mut self, index: usize, instance: Instance) {
        if self.senders[index].in_flight.is_some() {
            self.senders[index].backlog.push_back(instance);
        } else {
            self.request(index, instance);
        }
    }

    fn request(&mut self, index: usize, instance: Instance) {
        let sender = &mut self.senders[index];
        let frame = &self.bench.frames[sender.message];
        self.engine
            .device_mut::<CanNode>(sender.node)
            .send(frame, false);
        sender.in_flight = Some(instance);
    }

    /// Takes sender `index`'s new events: a completed transmission records its response and
    /// requests the next queued instance; a bus error or a failed transmission is an error (the
    /// scenarios have no faults, so either is a bug).
    fn collect(&mut self, index: usize) -> Result<(), String> {
        let sender = &mut self.senders[index];
        let name = self.bench.name(sender.message);
        let node = self.engine.device::<CanNode>(sender.node);
        let mut done = Vec::new();
        for (t, event) in &node.events()[sender.events_seen..] {
            match event {
                NodeEvent::TransmitDone(true) => done.push(*t),
                NodeEvent::TransmitDone(false) => {
                    return Err(format!("{name}: a frame was not sent"))
                }
                NodeEvent::BusError(ecc) => return Err(bus_error(name, *ecc)),
                NodeEvent::Received(_) | NodeEvent::ArbitrationLost(_) => {}
            }
        }
        sender.events_seen = node.events().len();
        for t in done {
            let sender = &mut self.senders[index];
            let instance = sender
                .in_flight
                .take()
                .expect("a transmission ends only after a request");
            let response = i128::from(t) - instance.event_fs;
            self.responses
                .push((sender.message, instance.number, response as u64));
            if let Some(next) = sender.backlog.pop_front() {
                self.request(index, next);
            }
        }
        Ok(())
    }
}

fn bus_error(name: &str, ecc: u8) -> String {
    format!("{name}: unexpected bus error (ECC {ecc:#04X}) in a fault-free scenario")
}
