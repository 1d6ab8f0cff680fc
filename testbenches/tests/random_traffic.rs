//! Property test (a) of the conformance plan: random multi-node traffic with identifier collisions.
//!
//! 2–4 RTL CAN nodes ([`CanNode`]) share one bus (same 16 MHz clock, no propagation delay,
//! 500 kbit/s). Each node gets 1–4 frames (standard and extended, data and remote, DLC 0–8) with
//! request times 0–2000 µs after the nodes have integrated; a node is handed its next frame once that
//! frame's time has come and its previous one has left the transmit buffer (half of the request times
//! lie on a coarse grid, so requests often coincide). The identifiers come from a small pool built so
//! that frames of different nodes collide deep in arbitration: the same base identifier in standard and
//! extended format (decided at SRR/IDE), identifiers that differ only in the last base bit, in the first
//! or the last extension bit, and data vs remote frames of the same identifier (decided at RTR). Two
//! nodes never send the same identifier in the same frame type: that is not legal CAN (both win
//! arbitration, then bit errors follow).
//!
//! Checked for every scenario:
//! 1. every node received exactly the frames the other nodes sent, in the order in which they completed
//!    on the bus (ordered by the transmitters' `TransmitDone(true)` times);
//! 2. no node reported a bus error, and every TEC and REC is 0 at the end;
//! 3. every `TransmitDone` is a success, and every frame is sent within the time limit;
//! 4. every `ArbitrationLost` carries the ALC of the first arbitration bit in which the loser's frame
//!    differs from the frame that won (the next frame another node completed).
//!
//! A fixed scenario checks arbitration itself: three simultaneous requests, the bus order they imply,
//! and the SJA1000 arbitration-lost positions (ALC) the losers report.

use std::fmt;

use golden::btr::Btr;
use golden::frame::{Frame, Id};
use proptest::prelude::*;
use sim::engine::time::{ClockSpec, FS_PER_US};
use sim::engine::{DeviceId, Engine};
use sim::nodes::can_node::{CanNode, NodeEvent};
use testbenches::bench_engine;

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
/// Generous limit: the whole request window plus 500 µs (≈ 3 longest frames) for each of up to 16
/// frames.
const LIMIT_US: u64 = START_US + REQUEST_WINDOW_US + 16 * 500;

/// The identifier pool: 4 base identifiers `b` (0x100 and 0x0FF differ from the third bit on, 0x7F0
/// and 0x000 are stuffed heavily) with 6 identifiers each that collide deep in arbitration:
/// * standard `b` and standard `b ^ 1`: differ in the last base bit (ALC 10);
/// * extended `b << 18`: same base as standard `b`, loses at SRR (ALC 11) to a standard data frame
///   and at IDE (ALC 12) to a standard remote frame;
/// * extended `b << 18 | 0x20000`: differs from `b << 18` in the first extension bit (ALC 13);
/// * extended `b << 18 | 1`: differs from `b << 18` in the last identifier bit (ALC 30);
/// * extended `b << 18 | 0x3FFFF`: all extension bits recessive.
///
/// 24 entries, divisible by 2, 3 and 4 nodes.
fn id_pool() -> Vec<Id> {
    let bases: [u16; 4] = [0x100, 0x0FF, 0x7F0, 0x000];
    bases
        .iter()
        .flat_map(|&b| {
            let ext = u32::from(b) << 18;
            [
                Id::standard(b),
                Id::extended(ext),
                Id::extended(ext | 0x2_0000),
                Id::standard(b ^ 1),
                Id::extended(ext | 1),
                Id::extended(ext | 0x3_FFFF),
            ]
        })
        .map(|id| id.expect("pool identifiers are in range"))
        .collect()
}

/// The pool entry that frame choice `index` of node `node` (of `nodes`) uses. Entry `j` belongs to node
/// `j % nodes` for data frames and to node `(j + 1) % nodes` for remote frames, so two nodes never
/// send the same identifier in the same frame type (not legal CAN: both win arbitration, then a bit
/// error follows unless the frames are identical), a data and a remote frame of the same identifier
/// do meet (the data frame wins at RTR: ALC 11 standard, 31 extended), and neighbouring entries go to
/// different nodes.
fn owned_pool_index(index: usize, node: usize, nodes: usize, remote: bool) -> usize {
    let owner_offset = if remote { 1 } else { 0 };
    index - index % nodes + (node + nodes - owner_offset) % nodes
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
        request_time(),
    )
}

/// A request time after `START_US` in µs: half of them on a 250 µs grid, so that requests of
/// different nodes often coincide (and then arbitrate from the same SOF).
fn request_time() -> impl Strategy<Value = u64> {
    prop_oneof![
        (0..REQUEST_WINDOW_US / 250).prop_map(|slot| slot * 250),
        0..REQUEST_WINDOW_US,
    ]
}

/// The request `raw` becomes for node `node` of `nodes`.
fn request(raw: RawRequest, node: usize, nodes: usize, pool: &[Id]) -> Request {
    let (index, remote, dlc, data, at_us) = raw;
    let id = pool[owned_pool_index(index, node, nodes, remote)];
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
    let mut engine = bench_engine(&btr, clock);
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
    for (k, &id) in ids.iter().enumerate() {
        let node = engine.device::<CanNode>(id);
        text += &format!("n{k} (TEC {}, REC {}):\n", node.tec(), node.rec());
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

/// A frame that completed on the bus: the transmitter's `TransmitDone(true)` time, its node index and
/// the frame.
#[derive(Clone, Copy, Debug)]
struct Completed {
    at: u64,
    node: usize,
    frame: Frame,
}

/// The frames in the order they completed on the bus. The frames of one node complete in the order it
/// handed them out.
fn bus_order(engine: &Engine, ids: &[DeviceId], scenario: &Scenario) -> Vec<Completed> {
    let mut done = Vec::new();
    for (k, &id) in ids.iter().enumerate() {
        let node = engine.device::<CanNode>(id);
        let times = node
            .events()
            .iter()
            .filter(|(_, e)| *e == NodeEvent::TransmitDone(true))
            .map(|(t, _)| *t);
        for (at, req) in times.zip(&scenario.nodes[k]) {
            done.push(Completed {
                at,
                node: k,
                frame: req.frame,
            });
        }
    }
    done.sort_by_key(|c| (c.at, c.node));
    done
}

/// The bits of the arbitration field of `frame` (recessive = `true`), indexed like the SJA1000 ALC:
/// base identifier (0..=10), RTR or SRR (11), IDE (12), then for extended frames the identifier
/// extension (13..=30) and RTR (31).
fn arbitration_bits(frame: &Frame) -> Vec<bool> {
    let bits = |value: u32, width: u32| (0..width).rev().map(move |i| value >> i & 1 == 1);
    match frame.id() {
        Id::Standard(id) => bits(u32::from(id), 11)
            .chain([frame.is_remote(), false])
            .collect(),
        Id::Extended(id) => bits(id >> 18, 11)
            .chain([true, true])
            .chain(bits(id, 18))
            .chain([frame.is_remote()])
            .collect(),
    }
}

/// The ALC at which `loser` loses arbitration to `winner`: the first arbitration bit in which they
/// differ, if `loser` sends it recessive there.
fn expected_alc(loser: &Frame, winner: &Frame) -> Option<u8> {
    let (l, w) = (arbitration_bits(loser), arbitration_bits(winner));
    let at = l.iter().zip(&w).position(|(a, b)| a != b)?;
    l[at].then_some(at as u8)
}

/// Invariant 4: every `ArbitrationLost` of node `k` is reported at the position where its pending frame
/// first differs from the frame that then won the bus (the next frame another node completed).
fn check_arbitration(
    k: usize,
    node: &CanNode,
    order: &[Completed],
    own: &[Request],
) -> Result<(), String> {
    let mut sent = 0;
    for &(t, ref event) in node.events() {
        match *event {
            NodeEvent::TransmitDone(true) => sent += 1,
            NodeEvent::ArbitrationLost(alc) => {
                let loser = own[sent].frame;
                let Some(winner) = order.iter().find(|c| c.at > t && c.node != k) else {
                    return Err(format!("n{k} lost arbitration but no other frame followed"));
                };
                let expected = expected_alc(&loser, &winner.frame);
                if expected != Some(alc) {
                    return Err(format!(
                        "n{k} lost with {loser} against {} at ALC {alc}, expected {expected:?}",
                        winner.frame
                    ));
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Checks invariants 1–4 of the module documentation after [`run`].
fn check(engine: &Engine, ids: &[DeviceId], scenario: &Scenario) -> Result<(), String> {
    let fail = |what: String| Err(format!("{what}\n{}", report(engine, ids)));
    let order = bus_order(engine, ids, scenario);
    for (k, &id) in ids.iter().enumerate() {
        let node = engine.device::<CanNode>(id);
        let expected: Vec<Frame> = order
            .iter()
            .filter(|c| c.node != k)
            .map(|c| c.frame)
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
        check_arbitration(k, node, &order, &scenario.nodes[k]).or_else(fail)?;
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
    #![proptest_config(ProptestConfig {
        cases: 48,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_traffic_is_received_by_every_other_node_in_bus_order(scenario in scenario()) {
        run_and_check(&scenario).map_err(TestCaseError::fail)?;
    }
}

/// Every pool identifier is distinct, and every frame choice of every node maps to a pool entry that
/// node owns for that frame type.
#[test]
fn pool_identifiers_are_distinct_and_owned_once() {
    let pool = id_pool();
    assert_eq!(pool.len(), 24);
    for (i, a) in pool.iter().enumerate() {
        assert!(!pool[i + 1..].contains(a), "{a} twice in the pool");
    }
    for nodes in 2..=4 {
        for index in 0..24 {
            for node in 0..nodes {
                let data = owned_pool_index(index, node, nodes, false);
                let remote = owned_pool_index(index, node, nodes, true);
                assert!(
                    data < 24 && data % nodes == node,
                    "data {data}, n{node} of {nodes}"
                );
                assert!(
                    remote < 24 && (remote + 1) % nodes == node,
                    "remote {remote}, n{node}"
                );
            }
        }
    }
}

/// The ALC model of invariant 4 on hand-checked pairs.
#[test]
fn expected_alc_positions() {
    let std = |id| Frame::data(Id::standard(id).unwrap(), &[]).unwrap();
    let ext = |id| Frame::data(Id::extended(id).unwrap(), &[]).unwrap();
    let remote = |f: Frame| Frame::remote(f.id(), 0).unwrap();
    let cases = [
        (std(0x100), std(0x0FF), Some(2)),  // 001… vs 000…: third base bit
        (std(0x0FF), std(0x100), None),     // the winner loses nothing
        (std(0x101), std(0x100), Some(10)), // last base bit
        (ext(0x100 << 18), std(0x100), Some(11)), // SRR vs dominant RTR
        (ext(0x100 << 18), remote(std(0x100)), Some(12)), // IDE
        (remote(std(0x100)), std(0x100), Some(11)), // RTR
        (ext(0x100 << 18 | 0x2_0000), ext(0x100 << 18), Some(13)), // first extension bit
        (ext(0x100 << 18 | 1), ext(0x100 << 18), Some(30)), // last extension bit
        (remote(ext(0x100 << 18)), ext(0x100 << 18), Some(31)), // extended RTR
    ];
    for (loser, winner, alc) in cases {
        assert_eq!(expected_alc(&loser, &winner), alc, "{loser} vs {winner}");
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
        .map(|c| c.frame)
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
