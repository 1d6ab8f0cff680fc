//! Property test (a) of the conformance plan: random multi-node traffic with identifier collisions.
//!
//! 2–4 RTL CAN nodes ([`CanNode`]) share one bus (same 16 MHz clock, no propagation delay,
//! 500 kbit/s). Each node gets 1–4 frames (standard and extended, data and remote, DLC 0–8) with
//! request times 0–2000 µs after the nodes have integrated; a node is handed its next frame once that
//! frame's time has come and its previous one has left the transmit buffer. The identifiers come from a
//! small pool built so that frames of different nodes collide in arbitration: the same base identifier
//! in standard and extended format (decided at SRR/IDE), extended identifiers that differ only in the
//! last bit, standard identifiers that differ only in the last bit. Every pool entry belongs to one node:
//! two nodes sending the very same identifier is not legal CAN (both win arbitration, then bit errors).
//!
//! Checked for every scenario:
//! 1. every node received exactly the frames the other nodes sent, in the order in which they completed
//!    on the bus (ordered by the transmitters' `TransmitDone(true)` times);
//! 2. no node reported a bus error, and every TEC and REC is 0 at the end;
//! 3. every `TransmitDone` is a success, and every frame is sent within the time limit.
//!
//! A fixed scenario checks arbitration itself: three simultaneous requests, the bus order they imply,
//! and the SJA1000 arbitration-lost positions (ALC) the losers report.

use std::fmt;

use proptest::prelude::*;
use sim::btr::Btr;
use sim::can_node::{CanNode, NodeEvent};
use sim::engine::{DeviceId, Engine};
use sim::frame::{Frame, Id};
use sim::time::{ClockSpec, FS_PER_US};

/// Controller clock.
const CLOCK_HZ: f64 = 16e6;
/// 500 kbit/s at 16 MHz: BRP 0, SJW 2, TSEG1 13, TSEG2 2 (16 tq per bit).
const BTR: (u8, u8) = (0x40, 0x1C);
/// First request time: after reset a node integrates on 11 recessive bits (22 µs).
const START_US: u64 = 30;
/// Request times are drawn from `START_US + 0..REQUEST_WINDOW_US`.
const REQUEST_WINDOW_US: u64 = 2000;
/// The driver hands out frames at multiples of this step.
const STEP_US: u64 = 10;
/// Bus time after the last successful transmission in which nothing more may go wrong (20 bits).
const TAIL_US: u64 = 40;
/// Generous limit: the whole request window plus 500 µs (≈ 3 longest frames) per frame.
const LIMIT_US: u64 = START_US + REQUEST_WINDOW_US + 16 * 500;

/// The identifier pool, in groups of four around one base identifier `b`: standard `b`, extended
/// `b << 18` (same base, loses to standard `b` at SRR), extended `b << 18 | 1` (differs from the
/// previous one in the last identifier bit only) and standard `b ^ 1` (differs from `b` in the last
/// base bit only). 24 entries, divisible by 2, 3 and 4 nodes.
fn id_pool() -> Vec<Id> {
    let bases: [u16; 6] = [0x100, 0x0FF, 0x123, 0x7F0, 0x000, 0x7FF];
    bases
        .iter()
        .flat_map(|&b| {
            let ext = u32::from(b) << 18;
            [
                Id::standard(b),
                Id::extended(ext),
                Id::extended(ext | 1),
                Id::standard(b ^ 1),
            ]
        })
        .map(|id| id.expect("pool identifiers are in range"))
        .collect()
}

/// The pool entry that frame choice `index` of node `node` (of `nodes`) uses: entry `j` belongs to node
/// `j % nodes`, so no two nodes ever send the same identifier, while neighbouring entries (which
/// collide) go to different nodes.
fn owned_pool_index(index: usize, node: usize, nodes: usize) -> usize {
    index - index % nodes + node
}

/// One frame request of one node.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Request {
    /// Request time after `START_US`, in µs.
    at_us: u64,
    frame: Frame,
}

impl fmt::Debug for Request {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "+{} µs {}", self.at_us, self.frame)
    }
}

/// The requests of every node, in the order each node hands them out.
#[derive(Clone, PartialEq, Eq)]
struct Scenario {
    nodes: Vec<Vec<Request>>,
}

impl fmt::Debug for Scenario {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, requests) in self.nodes.iter().enumerate() {
            writeln!(f, "n{k}: {requests:?}")?;
        }
        Ok(())
    }
}

/// A random frame of pool choice `index`, not yet assigned to a node: (index, remote, DLC, data,
/// request time).
type RawRequest = (usize, bool, u8, [u8; 8], u64);

fn raw_request() -> impl Strategy<Value = RawRequest> {
    (
        0..24usize,
        any::<bool>(),
        0..=8u8,
        any::<[u8; 8]>(),
        0..REQUEST_WINDOW_US,
    )
}

/// The request `raw` becomes for node `node` of `nodes`.
fn request(raw: RawRequest, node: usize, nodes: usize, pool: &[Id]) -> Request {
    let (index, remote, dlc, data, at_us) = raw;
    let id = pool[owned_pool_index(index, node, nodes)];
    let frame = if remote {
        Frame::remote(id, dlc)
    } else {
        Frame::data(id, &data[..usize::from(dlc)])
    };
    Request {
        at_us,
        frame: frame.expect("DLC 0..=8 is valid"),
    }
}

/// 2–4 nodes with 1–4 requests each.
fn scenario() -> impl Strategy<Value = Scenario> {
    (2..=4usize)
        .prop_flat_map(|n| {
            (
                Just(n),
                proptest::collection::vec(proptest::collection::vec(raw_request(), 1..=4), n),
            )
        })
        .prop_map(|(n, raw)| {
            let pool = id_pool();
            let nodes = raw
                .into_iter()
                .enumerate()
                .map(|(k, list)| list.into_iter().map(|r| request(r, k, n, &pool)).collect())
                .collect();
            Scenario { nodes }
        })
}

/// A bus of `nodes` RTL nodes on the same clock, no propagation delay.
fn bus(nodes: usize) -> (Engine, Vec<DeviceId>) {
    let clock = ClockSpec::from_hz(CLOCK_HZ);
    let btr = Btr::from_registers(BTR.0, BTR.1);
    let mut engine = Engine::new();
    let ids = (0..nodes)
        .map(|k| engine.add(CanNode::new(&format!("n{k}"), clock, btr), 0))
        .collect();
    (engine, ids)
}

/// Number of `TransmitDone(true)` events of `node`.
fn successes(node: &CanNode) -> usize {
    node.events()
        .iter()
        .filter(|(_, e)| *e == NodeEvent::TransmitDone(true))
        .count()
}

/// Runs `scenario` until every node has sent all its frames (plus [`TAIL_US`]); returns the engine and
/// the node ids, or an error if the time limit is reached first.
fn run(scenario: &Scenario) -> Result<(Engine, Vec<DeviceId>), String> {
    let (mut engine, ids) = bus(scenario.nodes.len());
    let mut next = vec![0usize; ids.len()];
    let mut now_us = 0;
    let all_sent = |engine: &Engine| {
        ids.iter()
            .zip(&scenario.nodes)
            .all(|(&id, reqs)| successes(engine.device::<CanNode>(id)) == reqs.len())
    };
    while !all_sent(&engine) {
        if now_us >= LIMIT_US {
            return Err(format!(
                "not every frame was sent within {LIMIT_US} µs\n{}",
                report(&engine, &ids)
            ));
        }
        for (k, &id) in ids.iter().enumerate() {
            let node = engine.device_mut::<CanNode>(id);
            if let Some(req) = scenario.nodes[k].get(next[k]) {
                if START_US + req.at_us <= now_us && !node.transmit_pending() {
                    node.send(&req.frame, false);
                    next[k] += 1;
                }
            }
        }
        now_us += STEP_US;
        engine.run_until(now_us * FS_PER_US).expect("simulation");
    }
    engine
        .run_until(engine.now() + TAIL_US * FS_PER_US)
        .expect("simulation");
    Ok((engine, ids))
}

/// Every node's events, one per line, for failure messages.
fn report(engine: &Engine, ids: &[DeviceId]) -> String {
    let mut text = String::new();
    for &id in ids {
        let node = engine.device::<CanNode>(id);
        text += &format!(
            "{} (TEC {}, REC {}):\n",
            node_name(id),
            node.tec(),
            node.rec()
        );
        for (t, event) in node.events() {
            let event = match event {
                NodeEvent::Received(f) => format!("Received({f})"),
                other => format!("{other:?}"),
            };
            text += &format!("  {:>10.3} µs {event}\n", *t as f64 / FS_PER_US as f64);
        }
    }
    text
}

fn node_name(id: DeviceId) -> String {
    format!("n{}", id.0)
}

/// The frames in the order they completed on the bus, as (transmitting node index, frame). The frames of
/// one node complete in the order it handed them out.
fn bus_order(engine: &Engine, ids: &[DeviceId], scenario: &Scenario) -> Vec<(usize, Frame)> {
    let mut done: Vec<(u64, usize, Frame)> = Vec::new();
    for (k, &id) in ids.iter().enumerate() {
        let node = engine.device::<CanNode>(id);
        let times = node
            .events()
            .iter()
            .filter(|(_, e)| *e == NodeEvent::TransmitDone(true))
            .map(|(t, _)| *t);
        for (t, req) in times.zip(&scenario.nodes[k]) {
            done.push((t, k, req.frame));
        }
    }
    done.sort_by_key(|&(t, k, _)| (t, k));
    done.into_iter().map(|(_, k, f)| (k, f)).collect()
}

/// Checks invariants 1–3 of the module documentation after [`run`].
fn check(engine: &Engine, ids: &[DeviceId], scenario: &Scenario) -> Result<(), String> {
    let fail = |what: String| Err(format!("{what}\n{}", report(engine, ids)));
    let order = bus_order(engine, ids, scenario);
    for (k, &id) in ids.iter().enumerate() {
        let node = engine.device::<CanNode>(id);
        let expected: Vec<Frame> = order
            .iter()
            .filter(|(from, _)| *from != k)
            .map(|&(_, f)| f)
            .collect();
        let received = node.received();
        if received != expected {
            return fail(format!(
                "n{k} received {} instead of {}",
                frames(&received),
                frames(&expected)
            ));
        }
        if !node.bus_errors().is_empty() {
            return fail(format!(
                "n{k} saw bus errors (ECC) {:02X?}",
                node.bus_errors()
            ));
        }
        if (node.tec(), node.rec()) != (0, 0) {
            return fail(format!(
                "n{k} ends with TEC {} REC {}",
                node.tec(),
                node.rec()
            ));
        }
        if node
            .events()
            .iter()
            .any(|(_, e)| *e == NodeEvent::TransmitDone(false))
        {
            return fail(format!("n{k} reported a failed transmission"));
        }
    }
    Ok(())
}

/// candump-style list of frames.
fn frames(list: &[Frame]) -> String {
    let items: Vec<String> = list.iter().map(Frame::to_string).collect();
    format!("[{}]", items.join(", "))
}

/// Runs and checks one scenario.
fn run_and_check(scenario: &Scenario) -> Result<(), String> {
    let (engine, ids) = run(scenario)?;
    check(&engine, &ids, scenario)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    #[test]
    fn random_traffic_is_received_by_every_other_node_in_bus_order(scenario in scenario()) {
        run_and_check(&scenario).map_err(TestCaseError::fail)?;
    }
}

#[test]
fn pool_identifiers_are_distinct() {
    let pool = id_pool();
    for (i, a) in pool.iter().enumerate() {
        assert!(!pool[i + 1..].contains(a), "{a} twice in the pool");
    }
    assert_eq!(pool.len(), 24);
    for nodes in 2..=4 {
        for index in 0..24 {
            for node in 0..nodes {
                let j = owned_pool_index(index, node, nodes);
                assert!(
                    j < 24 && j % nodes == node,
                    "entry {j} for n{node} of {nodes}"
                );
            }
        }
    }
}

/// Three nodes request at the same instant:
/// * n0: standard 0x100 = 001 0000 0000
/// * n1: extended 0x100 << 18 | 5 (base 0x100, extension 0x00005)
/// * n2: standard 0x0FF = 000 1111 1111
///
/// First round: n2 sends a dominant ID.8 (base bit index 2) where n0 and n1 send recessive: both lose
/// at ALC 2 (ALC 0 = ID.28, the first base bit; 1 = ID.27; 2 = ID.26, i.e. standard ID.8). n2's
/// 0x0FF goes first.
/// Second round: n0 and n1 have the same base; n0 sends a dominant RTR (data frame) where n1 sends the
/// recessive SRR: n1 loses at ALC 11 (the bit after the 11 base bits). 0x100 goes second.
/// Third round: n1 alone.
#[test]
fn simultaneous_requests_arbitrate_by_identifier() {
    let f0 = Frame::data(Id::standard(0x100).unwrap(), &[0x00]).unwrap();
    let f1 = Frame::data(Id::extended(0x100 << 18 | 5).unwrap(), &[0x11, 0x22]).unwrap();
    let f2 = Frame::data(Id::standard(0x0FF).unwrap(), &[0xFF, 0xEE, 0xDD]).unwrap();
    let request = |frame| Request { at_us: 0, frame };
    let scenario = Scenario {
        nodes: vec![vec![request(f0)], vec![request(f1)], vec![request(f2)]],
    };
    let (engine, ids) = run(&scenario).unwrap_or_else(|e| panic!("{e}"));
    check(&engine, &ids, &scenario).unwrap_or_else(|e| panic!("{e}"));
    let order: Vec<Frame> = bus_order(&engine, &ids, &scenario)
        .into_iter()
        .map(|(_, f)| f)
        .collect();
    assert_eq!(order, [f2, f0, f1], "bus order");
    let alc = |k: usize| -> Vec<u8> {
        engine
            .device::<CanNode>(ids[k])
            .events()
            .iter()
            .filter_map(|(_, e)| match e {
                NodeEvent::ArbitrationLost(alc) => Some(*alc),
                _ => None,
            })
            .collect()
    };
    assert_eq!(alc(0), [2], "n0 (0x100) loses to 0x0FF at ID.8");
    assert_eq!(alc(1), [2, 11], "n1 (extended) loses at ID.26, then at SRR");
    assert_eq!(alc(2), [] as [u8; 0], "n2 (0x0FF) never loses");
}
