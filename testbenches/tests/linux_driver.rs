//! Linux driver replay: three RTL controllers on one bus, each driven only through its model of the
//! Linux SJA1000 driver ([`Sja1000Driver`]): probe, bit timing (500 kbit/s at 16 MHz), start, then
//! traffic driven by the interrupt handler exactly as the kernel would run it.
//!
//! A scheduler steps the engine; whenever a controller's interrupt output is asserted it runs that
//! node's `interrupt()`, and after each interrupt it hands the node its next queued frame once the
//! previous one is done (the driver's stopped queue). Phases:
//! 1. normal traffic: standard, extended and remote frames, DLC 0..15, identifiers of different nodes
//!    that collide deep in arbitration, some frames with self-reception (SRR);
//! 2. one-shot: every node restarted with `one_shot`; losers of arbitration fail (TI with TCS = 0);
//! 3. error-passive episode: one node's receiver sees a dominant bus for a while (a local fault); its
//!    REC climbs past 127 (EI to warning, EPI to passive); then traffic brings it back (EPI, EI);
//! 4. bus-off episode: one node's receiver sees a recessive bus while it transmits, so every
//!    dominant bit it sends is a bit error; TEC passes 255 (EI with SR.BS); the driver restarts it
//!    and it transmits and receives again.
//!
//! Checked throughout: every frame sent successfully is received exactly once by every other node,
//! all in bus order (so in order per sender), self-reception frames also by their sender; failed
//! one-shot and dropped frames by nobody; every queued frame ends as sent, failed or dropped; every
//! arbitration loss reports the ALC of the first arbitration bit in which the loser's frame differs
//! from the winner's.

use std::collections::VecDeque;
use std::time::Instant;

use golden::frame::{Frame, Id};
use rtl::registers::{interrupt, status};
use sim::engine::DeviceId;
use sim::host::driver::{CanState, CtrlMode, DriverConfig, DriverEvent, Sja1000Driver};
use sim::host::sja1000::{BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ};
use sim::nodes::controller_node::ControllerNode;
use testbenches::controller_bench::{bench_bit_fs, ControllerBench, INTEGRATION_BITS};
use testbenches::ecc;

const NODES: usize = 3;
/// Bits of quiet bus after the last transmission of a phase, so every receiver has serviced RI.
const SETTLE_BITS: u64 = 30;
/// Generous per-frame bus time for run limits (the longest frame is below 160 bits).
const BITS_PER_FRAME_LIMIT: u64 = 400;

/// How many frames each phase queues per node.
#[derive(Clone, Copy, Debug)]
struct Plan {
    normal: usize,
    one_shot: usize,
    recovery: usize,
}

/// The default run: a few hundred frames.
const SHORT: Plan = Plan {
    normal: 60,
    one_shot: 40,
    recovery: 40,
};

/// The full run: well over 1000 frames sent successfully.
const FULL: Plan = Plan {
    normal: 280,
    one_shot: 120,
    recovery: 40,
};

/// xorshift64*: a small deterministic generator.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// The identifier pool: per base identifier `b`, identifiers that collide deep in arbitration:
/// standard `b` and `b ^ 1` (last base bit), extended `b << 18` (same base: SRR/IDE decide),
/// `b << 18 | 0x20000` (first extension bit), `b << 18 | 1` (last identifier bit) and
/// `b << 18 | 0x3FFFF`.
fn id_pool() -> Vec<Id> {
    let bases: [u16; 6] = [0x100, 0x0FF, 0x7F0, 0x000, 0x555, 0x2AA];
    bases
        .iter()
        .flat_map(|&b| {
            let ext = u32::from(b) << 18;
            [
                Id::standard(b),
                Id::standard(b ^ 1),
                Id::extended(ext),
                Id::extended(ext | 0x2_0000),
                Id::extended(ext | 1),
                Id::extended(ext | 0x3_FFFF),
            ]
        })
        .map(|id| id.expect("pool identifiers are in range"))
        .collect()
}

/// The node that owns pool entry `j` as a data (`remote` false) or remote frame: two nodes never
/// send the same identifier in the same frame type (that is not legal CAN), but data and remote
/// frames of one identifier come from different nodes (arbitration decided at RTR).
fn owner(j: usize, remote: bool) -> usize {
    (j + remote as usize) % NODES
}

/// The bits that decide arbitration, in ALC order: ID.28..18, SRR/RTR, IDE, ID.17..0, RTR
/// (extended). Recessive = true.
fn arbitration_bits(frame: &Frame) -> Vec<bool> {
    let mut bits = Vec::new();
    match frame.id() {
        Id::Standard(id) => {
            bits.extend((0..11).rev().map(|i| id >> i & 1 == 1));
            bits.push(frame.is_remote());
            bits.push(false);
        }
        Id::Extended(id) => {
            bits.extend((18..29).rev().map(|i| id >> i & 1 == 1));
            bits.push(true);
            bits.push(true);
            bits.extend((0..18).rev().map(|i| id >> i & 1 == 1));
            bits.push(frame.is_remote());
        }
    }
    bits
}

/// The ALC position at which `loser` loses against `winner`: the first differing arbitration bit,
/// where the loser sends recessive.
fn expected_alc(loser: &Frame, winner: &Frame) -> Option<u8> {
    let (l, w) = (arbitration_bits(loser), arbitration_bits(winner));
    let k = l.iter().zip(&w).position(|(a, b)| a != b)?;
    (l[k] && !w[k]).then_some(k as u8)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Tx {
    frame: Frame,
    loopback: bool,
}

/// An arbitration loss: who lost with which frame, the ALC read, and the number of successful
/// frames on the bus at that time (the winner is the next one).
#[derive(Clone, Copy, Debug)]
struct Loss {
    node: usize,
    frame: Frame,
    alc: u8,
    bus_index: usize,
}

/// A state change as the driver reported it.
#[derive(Clone, Copy, Debug)]
struct Change {
    state: CanState,
    ir: u8,
    sr: u8,
    txerr: u8,
    rxerr: u8,
}

struct Node {
    id: DeviceId,
    driver: Sja1000Driver,
    queue: VecDeque<Tx>,
    /// The frame handed to the driver and not yet reported back.
    current: Option<Tx>,
    /// The frame of the last transmit (for ALI, which the driver may report after TI).
    last_tx: Option<Tx>,
    received: Vec<Frame>,
    /// Every event with the phase it happened in.
    events: Vec<(usize, DriverEvent)>,
    interrupts: u64,
}

struct Replay {
    bench: ControllerBench,
    nodes: Vec<Node>,
    /// Frames sent successfully, in bus order, with their sender.
    bus: Vec<(usize, Tx)>,
    failed: Vec<(usize, Tx)>,
    dropped: Vec<(usize, Tx)>,
    losses: Vec<Loss>,
    queued: usize,
    phase: usize,
    rng: Rng,
    pool: Vec<Id>,
}

impl Replay {
    /// Three controllers after a hardware reset, each probed, set to 500 kbit/s and started by its
    /// driver with `mode`.
    fn new(mode: CtrlMode) -> Replay {
        let mut bench = ControllerBench::new(NODES);
        let mut nodes = Vec::new();
        for n in 0..NODES {
            let id = bench.id(n);
            let mut driver = Sja1000Driver::new(id, DriverConfig::default());
            driver.probe(&mut bench.engine).expect("probe");
            assert_eq!(driver.state(), CanState::Stopped);
            if n == 0 {
                let btr = driver
                    .set_bitrate(&mut bench.engine, 500_000)
                    .expect("bit timing");
                assert_eq!(
                    (btr.btr0(), btr.btr1()),
                    (BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ),
                    "the Linux calculator at 16 MHz, 500 kbit/s"
                );
            } else {
                driver
                    .set_bittiming(&mut bench.engine, BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ)
                    .expect("bit timing");
            }
            nodes.push(Node {
                id,
                driver,
                queue: VecDeque::new(),
                current: None,
                last_tx: None,
                received: Vec::new(),
                events: Vec::new(),
                interrupts: 0,
            });
        }
        let mut replay = Replay {
            bench,
            nodes,
            bus: Vec::new(),
            failed: Vec::new(),
            dropped: Vec::new(),
            losses: Vec::new(),
            queued: 0,
            phase: 0,
            rng: Rng(0x5EED_CA11_D00D_F00D),
            pool: id_pool(),
        };
        replay.start_all(mode);
        replay
    }

    fn driver(&self, n: usize) -> &Sja1000Driver {
        &self.nodes[n].driver
    }

    /// (Re)starts every driver with `mode` on a quiet bus, then lets all integrate.
    fn start_all(&mut self, mode: CtrlMode) {
        assert!(self.idle(), "start only on a quiet bus");
        for node in &mut self.nodes {
            let dropped = node
                .driver
                .start(&mut self.bench.engine, mode)
                .expect("start");
            assert_eq!(dropped, None, "nothing in flight");
            assert_eq!(node.driver.state(), CanState::ErrorActive);
        }
        self.run_bits(INTEGRATION_BITS);
    }

    /// A random frame owned by node `n`; self-reception with probability `loopback_pct` %.
    fn random_tx(&mut self, n: usize, loopback_pct: u64) -> Tx {
        let owned: Vec<(usize, bool)> = (0..self.pool.len())
            .flat_map(|j| [(j, false), (j, true)])
            .filter(|&(j, remote)| owner(j, remote) == n)
            .collect();
        let (j, remote) = owned[self.rng.below(owned.len() as u64) as usize];
        let id = self.pool[j];
        let frame = if remote {
            Frame::remote(id, self.rng.below(16) as u8).unwrap()
        } else {
            let dlc = if self.rng.below(100) < 15 {
                9 + self.rng.below(7) as u8
            } else {
                self.rng.below(9) as u8
            };
            let data: Vec<u8> = (0..dlc.min(8)).map(|_| self.rng.next() as u8).collect();
            Frame::data_with_dlc(id, dlc, &data).unwrap()
        };
        Tx {
            frame,
            loopback: self.rng.below(100) < loopback_pct,
        }
    }

    /// Queues `count` random frames on every node.
    fn queue_random(&mut self, count: usize, loopback_pct: u64) {
        for _ in 0..count {
            for n in 0..NODES {
                let tx = self.random_tx(n, loopback_pct);
                self.queue(n, tx);
            }
        }
    }

    fn queue(&mut self, n: usize, tx: Tx) {
        self.nodes[n].queue.push_back(tx);
        self.queued += 1;
    }

    /// Hands node `n` its next frame if the driver's queue is open.
    fn kick(&mut self, n: usize) {
        let node = &mut self.nodes[n];
        if !node.driver.can_transmit() {
            return;
        }
        let Some(tx) = node.queue.pop_front() else {
            return;
        };
        node.driver
            .transmit(&mut self.bench.engine, &tx.frame, tx.loopback)
            .expect("transmit");
        node.current = Some(tx);
        node.last_tx = Some(tx);
    }

    fn kick_all(&mut self) {
        for n in 0..NODES {
            self.kick(n);
        }
    }

    /// Runs node `n`'s interrupt handler and books what it reports.
    fn service(&mut self, n: usize) {
        let events = self.nodes[n].driver.interrupt(&mut self.bench.engine);
        self.nodes[n].interrupts += 1;
        for event in events {
            self.record(n, event);
        }
        self.kick(n);
    }

    fn record(&mut self, n: usize, event: DriverEvent) {
        let node = &mut self.nodes[n];
        node.events.push((self.phase, event));
        match event {
            DriverEvent::TxDone(frame) => {
                let tx = node.current.take().expect("TI for a frame in flight");
                assert_eq!(tx.frame, frame);
                self.bus.push((n, tx));
            }
            DriverEvent::TxFailed(frame) | DriverEvent::TxDropped(frame) => {
                let tx = node.current.take().expect("a frame in flight");
                assert_eq!(tx.frame, frame);
                if matches!(event, DriverEvent::TxFailed(_)) {
                    self.failed.push((n, tx));
                } else {
                    self.dropped.push((n, tx));
                }
            }
            DriverEvent::Received(frame) => node.received.push(frame),
            DriverEvent::ArbitrationLost { alc, .. } => {
                let tx = node
                    .last_tx
                    .expect("arbitration lost without a transmission");
                self.losses.push(Loss {
                    node: n,
                    frame: tx.frame,
                    alc,
                    bus_index: self.bus.len(),
                });
            }
            DriverEvent::SpuriousTxInterrupt { sr } => {
                panic!("node {n}: TI without a frame in flight (SR {sr:#04x})")
            }
            DriverEvent::Overrun(_) => panic!("node {n}: data overrun"),
            DriverEvent::WakeUp => panic!("node {n}: wake-up interrupt without sleep"),
            DriverEvent::BusError { .. } | DriverEvent::StateChanged { .. } => {}
        }
    }

    /// Steps the engine, servicing interrupts as they come, until `done` holds (checked after each
    /// service and at the start) or `bits` bit times have passed. Returns whether `done` held.
    fn run_until(&mut self, bits: u64, done: impl Fn(&Replay) -> bool) -> bool {
        let limit = self.bench.engine.now() + bits * bench_bit_fs();
        let ids: Vec<DeviceId> = self.nodes.iter().map(|n| n.id).collect();
        let mut quiet_services = 0;
        loop {
            if done(self) {
                return true;
            }
            let irq = self
                .bench
                .engine
                .run_while(limit, |e| {
                    ids.iter().any(|&id| e.device::<ControllerNode>(id).irq())
                })
                .expect("simulation");
            if !irq {
                return done(self);
            }
            for (n, &id) in ids.iter().enumerate() {
                if self.bench.engine.device::<ControllerNode>(id).irq() {
                    let before = self.nodes[n].events.len();
                    self.service(n);
                    if self.nodes[n].events.len() == before {
                        quiet_services += 1;
                        assert!(
                            quiet_services < 1000,
                            "node {n}: irq stays asserted but the handler finds nothing"
                        );
                    }
                }
            }
        }
    }

    fn run_bits(&mut self, bits: u64) {
        self.run_until(bits, |_| false);
    }

    /// No frame queued or in flight.
    fn idle(&self) -> bool {
        self.nodes
            .iter()
            .all(|n| n.queue.is_empty() && n.current.is_none())
    }

    /// Kicks every node, runs until every queue is empty and nothing is in flight, then lets the
    /// bus settle.
    fn drain(&mut self) {
        self.kick_all();
        let frames: usize = self
            .nodes
            .iter()
            .map(|n| n.queue.len() + n.current.is_some() as usize)
            .sum();
        let limit = (frames as u64 + 4) * BITS_PER_FRAME_LIMIT;
        assert!(
            self.run_until(limit, Replay::idle),
            "traffic did not finish: {}",
            self.report()
        );
        self.run_bits(SETTLE_BITS);
    }

    /// Every node received exactly the frames sent successfully by the others (and its own
    /// self-reception frames), in bus order; every queued frame is accounted for.
    fn check_accounting(&self) {
        for (r, node) in self.nodes.iter().enumerate() {
            let expected: Vec<Frame> = self
                .bus
                .iter()
                .filter(|(s, tx)| *s != r || tx.loopback)
                .map(|(_, tx)| tx.frame)
                .collect();
            if let Some(k) = (0..expected.len().max(node.received.len()))
                .find(|&k| expected.get(k) != node.received.get(k))
            {
                panic!(
                    "node {r}: received frame {k} is {:?}, expected {:?} ({} received, {} expected)",
                    node.received.get(k).map(Frame::to_string),
                    expected.get(k).map(Frame::to_string),
                    node.received.len(),
                    expected.len()
                );
            }
        }
        let pending: usize = self
            .nodes
            .iter()
            .map(|n| n.queue.len() + n.current.is_some() as usize)
            .sum();
        assert_eq!(
            self.bus.len() + self.failed.len() + self.dropped.len() + pending,
            self.queued,
            "every queued frame is sent, failed, dropped or pending"
        );
        for node in &self.nodes {
            let stats = node.driver.stats();
            assert_eq!(stats.spurious_tx, 0);
            assert_eq!(stats.rx_overruns, 0);
        }
    }

    /// Every arbitration loss carries the ALC of the first arbitration bit in which the loser's
    /// frame differs from the winner's (the next frame that completed).
    fn check_arbitration(&self) {
        for loss in &self.losses {
            let (winner_node, winner) = self
                .bus
                .get(loss.bus_index)
                .unwrap_or_else(|| panic!("{loss:?}: no frame won"));
            assert_ne!(*winner_node, loss.node, "{loss:?}: the loser won");
            assert_eq!(
                Some(loss.alc & 0x1F),
                expected_alc(&loss.frame, &winner.frame),
                "node {} lost with {} against {}",
                loss.node,
                loss.frame,
                winner.frame
            );
        }
    }

    /// The state changes node `n` reported in `phase`, with IR, SR and the counters.
    fn state_changes(&self, n: usize, phase: usize) -> Vec<Change> {
        self.nodes[n]
            .events
            .iter()
            .filter(|(p, _)| *p == phase)
            .filter_map(|(_, e)| match *e {
                DriverEvent::StateChanged {
                    state,
                    ir,
                    sr,
                    counters,
                } => Some(Change {
                    state,
                    ir,
                    sr,
                    txerr: counters.txerr,
                    rxerr: counters.rxerr,
                }),
                _ => None,
            })
            .collect()
    }

    /// How many events of node `n` in `phase` match `kind`.
    fn count(&self, n: usize, phase: usize, kind: impl Fn(&DriverEvent) -> bool) -> usize {
        self.nodes[n]
            .events
            .iter()
            .filter(|(p, e)| *p == phase && kind(e))
            .count()
    }

    /// The ECC values of node `n`'s bus errors in `phase`.
    fn bus_errors(&self, n: usize, phase: usize) -> Vec<u8> {
        self.nodes[n]
            .events
            .iter()
            .filter(|(p, _)| *p == phase)
            .filter_map(|(_, e)| match e {
                DriverEvent::BusError { ecc, .. } => Some(*ecc),
                _ => None,
            })
            .collect()
    }

    fn report(&self) -> String {
        let mut out = String::new();
        for (n, node) in self.nodes.iter().enumerate() {
            let s = node.driver.stats();
            let sent = self.bus.iter().filter(|(s, _)| *s == n).count();
            let loopback = self
                .bus
                .iter()
                .filter(|(s, tx)| *s == n && tx.loopback)
                .count();
            out += &format!(
                "node {n}: sent {sent} ({loopback} self-reception), one-shot failed {}, dropped {}, \
                 received {}; interrupts {}; ALI {}, BEI {} (tx {}, rx {}), to warning {}, to \
                 passive {}, bus-off {}, restarts {}; state {}, {} queued\n",
                s.tx_failed,
                s.tx_dropped,
                node.received.len(),
                node.interrupts,
                s.arbitration_lost,
                s.bus_errors,
                s.bus_errors_tx,
                s.bus_errors_rx,
                s.error_warning,
                s.error_passive,
                s.bus_off,
                s.restarts,
                node.driver.state(),
                node.queue.len(),
            );
        }
        out += &format!(
            "bus: {} frames sent, {} one-shot failures, {} dropped, {} arbitration losses checked",
            self.bus.len(),
            self.failed.len(),
            self.dropped.len(),
            self.losses.len()
        );
        out
    }
}

/// Phase numbers (events are tagged with them).
const NORMAL: usize = 0;
const ONE_SHOT: usize = 1;
const PASSIVE_FAULT: usize = 2;
const PASSIVE_RECOVERY: usize = 3;
const BUS_OFF: usize = 4;
const AFTER_RESTART: usize = 5;

/// Runs every phase with `plan`; returns the number of frames sent successfully.
fn replay(plan: Plan) -> usize {
    let started = Instant::now();
    let mode = CtrlMode {
        berr_reporting: true,
        ..CtrlMode::default()
    };
    let mut r = Replay::new(mode);

    // ---- 1. Normal traffic with collisions and self-reception.
    r.phase = NORMAL;
    r.queue_random(plan.normal, 10);
    r.drain();
    r.check_accounting();
    r.check_arbitration();
    assert!(r.failed.is_empty() && r.dropped.is_empty());
    assert!(!r.losses.is_empty(), "collisions happened");
    let t_normal = started.elapsed();

    // ---- 2. One-shot: losers of arbitration fail once and for all.
    r.phase = ONE_SHOT;
    r.start_all(CtrlMode {
        one_shot: true,
        ..mode
    });
    r.queue_random(plan.one_shot, 10);
    r.drain();
    r.check_accounting();
    r.check_arbitration();
    assert!(!r.failed.is_empty(), "one-shot frames lost arbitration");
    assert!(r.dropped.is_empty());
    for n in 0..NODES {
        let ali = r.count(n, ONE_SHOT, |e| {
            matches!(e, DriverEvent::ArbitrationLost { .. })
        });
        let failed = r.count(n, ONE_SHOT, |e| matches!(e, DriverEvent::TxFailed(_)));
        assert_eq!(
            ali, failed,
            "node {n}: each one-shot failure is one lost arbitration"
        );
    }
    for phase in [NORMAL, ONE_SHOT] {
        for n in 0..NODES {
            let errors = r.count(n, phase, |e| {
                matches!(
                    e,
                    DriverEvent::BusError { .. } | DriverEvent::StateChanged { .. }
                )
            });
            assert_eq!(errors, 0, "node {n}: no bus error in phase {phase}");
        }
    }
    r.start_all(mode);
    let t_one_shot = started.elapsed();

    // ---- 3. Error-passive episode: node 1 sees a dominant bus for 170 bits on an idle bus. It
    // takes it for a frame, finds a stuff error, and counts +8 for each 8 dominant bits after its
    // error flag: EI (REC ≥ 96, warning), EPI (REC ≥ 128, passive).
    let victim = 1;
    r.phase = PASSIVE_FAULT;
    let bit = bench_bit_fs();
    let from = r.bench.engine.now() + bit;
    let to = from + 170 * bit;
    r.bench
        .engine
        .disturb_rx(r.nodes[victim].id, from, to, golden::frame::DOMINANT);
    r.run_bits(175 + SETTLE_BITS);
    let changes = r.state_changes(victim, PASSIVE_FAULT);
    let states: Vec<CanState> = changes.iter().map(|c| c.state).collect();
    assert_eq!(
        states,
        vec![CanState::ErrorWarning, CanState::ErrorPassive],
        "{changes:x?}"
    );
    let [warning, passive] = [changes[0], changes[1]];
    assert!(
        warning.ir & interrupt::EI != 0
            && warning.sr & status::ES != 0
            && (96..128).contains(&warning.rxerr),
        "EI with SR.ES at RXERR 96..127: {warning:x?}"
    );
    assert!(
        passive.ir & interrupt::EPI != 0 && passive.rxerr >= 128,
        "EPI at RXERR ≥ 128: {passive:x?}"
    );
    assert_eq!(
        r.bus_errors(victim, PASSIVE_FAULT).first(),
        Some(&ecc::ecc(ecc::STUFF, true, ecc::SEG_ID_28_21)),
        "the first error: a stuff error after SOF and five dominant identifier bits"
    );
    for n in (0..NODES).filter(|&n| n != victim) {
        assert_eq!(r.driver(n).state(), CanState::ErrorActive, "node {n}");
    }
    // Traffic again: the first frame received takes REC back to 127 (EPI: passive → warning), 32
    // more take it below 96 (EI: active). Frames are still all accounted for.
    r.phase = PASSIVE_RECOVERY;
    r.queue_random(plan.recovery, 10);
    r.drain();
    r.check_accounting();
    r.check_arbitration();
    let changes = r.state_changes(victim, PASSIVE_RECOVERY);
    let states: Vec<CanState> = changes.iter().map(|c| c.state).collect();
    assert_eq!(
        states,
        vec![CanState::ErrorWarning, CanState::ErrorActive],
        "{changes:x?}"
    );
    let [warning, active] = [changes[0], changes[1]];
    assert!(
        warning.ir & interrupt::EPI != 0 && (96..128).contains(&warning.rxerr),
        "EPI on leaving passive, RXERR back to 96..127: {warning:x?}"
    );
    assert!(
        active.ir & interrupt::EI != 0 && active.sr & status::ES == 0 && active.rxerr < 96,
        "EI with SR.ES = 0 below 96: {active:x?}"
    );
    let t_passive = started.elapsed();

    // ---- 4. Bus-off: node 2 sees a recessive bus while it transmits. Each dominant bit it sends
    // (SOF, then every bit of its active error flag) is a bit error, +8 each: warning, passive;
    // as passive transmitter each new attempt fails at SOF, +8, until TEC passes 255.
    let victim = 2;
    r.phase = BUS_OFF;
    let from = r.bench.engine.now();
    let to = from + 1000 * bit;
    r.bench
        .engine
        .disturb_rx(r.nodes[victim].id, from, to, golden::frame::RECESSIVE);
    let doomed = r.random_tx(victim, 0);
    r.queue(victim, doomed);
    r.kick(victim);
    assert!(
        r.run_until(900, |r| r.driver(victim).state() == CanState::BusOff),
        "bus-off: {}",
        r.report()
    );
    let changes = r.state_changes(victim, BUS_OFF);
    let states: Vec<CanState> = changes.iter().map(|c| c.state).collect();
    assert_eq!(
        states,
        vec![
            CanState::ErrorWarning,
            CanState::ErrorPassive,
            CanState::BusOff
        ],
        "{changes:x?}"
    );
    let [warning, passive, bus_off] = [changes[0], changes[1], changes[2]];
    assert!(
        warning.ir & interrupt::EI != 0 && (96..128).contains(&warning.txerr),
        "EI at TXERR 96..127: {warning:x?}"
    );
    assert!(
        passive.ir & interrupt::EPI != 0 && passive.txerr >= 128,
        "EPI at TXERR ≥ 128: {passive:x?}"
    );
    assert!(
        bus_off.ir & interrupt::EI != 0 && bus_off.sr & status::BS != 0,
        "bus-off by EI with SR.BS: {bus_off:x?}"
    );
    assert_eq!(
        (bus_off.txerr, bus_off.rxerr),
        (127, 0),
        "bus-off entered with TXERR 127, RXERR 0"
    );
    assert_eq!(
        r.dropped,
        vec![(victim, doomed)],
        "the echo frame is dropped"
    );
    let errors = r.bus_errors(victim, BUS_OFF);
    assert_eq!(
        errors.first(),
        Some(&ecc::ecc(ecc::BIT, false, ecc::SEG_SOF)),
        "the first error: bit error in SOF while transmitting"
    );
    assert!(
        errors.iter().all(|&e| e & 0xE0 == 0),
        "only bit errors while transmitting: {errors:x?}"
    );
    for n in (0..NODES).filter(|&n| n != victim) {
        assert_eq!(r.driver(n).state(), CanState::ErrorActive, "node {n}");
    }
    // Wait out the fault, then the driver's restart: TXERR = 0 in reset mode, no 128 × 11 bits.
    let remaining = (to - r.bench.engine.now()).div_ceil(bit);
    r.run_bits(remaining + 1);
    assert_eq!(r.driver(victim).state(), CanState::BusOff);
    r.nodes[victim]
        .driver
        .restart(&mut r.bench.engine)
        .expect("restart");
    assert_eq!(r.driver(victim).state(), CanState::ErrorActive);
    r.run_bits(INTEGRATION_BITS);
    r.phase = AFTER_RESTART;
    r.queue(victim, doomed);
    r.queue_random(3, 30);
    r.drain();
    r.check_accounting();
    r.check_arbitration();
    let sent_after: Vec<usize> = (0..NODES)
        .map(|n| {
            r.nodes[n]
                .events
                .iter()
                .filter(|(p, e)| *p == AFTER_RESTART && matches!(e, DriverEvent::TxDone(_)))
                .count()
        })
        .collect();
    let received_after = r.nodes[victim]
        .events
        .iter()
        .filter(|(p, e)| *p == AFTER_RESTART && matches!(e, DriverEvent::Received(_)))
        .count();
    assert_eq!(
        sent_after,
        vec![3, 3, 4],
        "everyone sends after the restart"
    );
    assert!(received_after >= 6, "the restarted node receives");
    assert_eq!(r.driver(victim).stats().restarts, 1);
    let t_bus_off = started.elapsed();

    println!("{}", r.report());
    println!(
        "plan {plan:?}: {} frames sent successfully; wall time: normal {:.1?}, one-shot {:.1?}, \
         error-passive {:.1?}, bus-off {:.1?}",
        r.bus.len(),
        t_normal,
        t_one_shot - t_normal,
        t_passive - t_one_shot,
        t_bus_off - t_passive
    );
    r.bus.len()
}

#[test]
fn linux_driver_replay() {
    replay(SHORT);
}

#[test]
#[ignore = "long: full run (well over 1000 frames, in make test-long); see the timings it prints"]
fn linux_driver_replay_full() {
    let sent = replay(FULL);
    assert!(sent >= 1000, "{sent} frames sent successfully");
}
