//! Response-time analysis of CAN message sets, checked on the cycle-accurate bus: the worked
//! examples of the classic analysis, the counterexample of Davis et al. (2007), and realistic
//! sets whose every observed response must stay within the corrected bound.

use std::path::PathBuf;

use golden::frame::encode;
use golden::worst_case::{length_bound, search};
use sim::engine::time::FS_PER_NS;
use sim::rta::analysis::{Analysis, MessageBounds};
use sim::rta::frame_bits;
use sim::rta::message_set::MessageSet;
use sim::rta::report::sent_bits;
use sim::rta::simulate::{sim_btr, sim_clock, simulate, violations, Observation, Simulation};
use sim::rta::Ticks;

/// Bits of the intermission (ISO 11898-1), as the bus time of a frame counts it.
const INTERMISSION_BITS: u64 = golden::frame::INTERMISSION_BITS as u64;

/// Scenarios run one after the other: the test harness already runs tests in parallel.
const THREADS: usize = 1;

fn examples_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/rta")
}

fn example(name: &str) -> MessageSet {
    let path = examples_dir().join(format!("{name}.toml"));
    MessageSet::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn index(set: &MessageSet, name: &str) -> usize {
    set.messages
        .iter()
        .position(|m| m.name == name)
        .unwrap_or_else(|| panic!("no message {name}"))
}

fn bounds<'a>(set: &MessageSet, analysis: &'a Analysis, name: &str) -> &'a MessageBounds {
    &analysis.messages[index(set, name)]
}

fn classic_queuing(analysis: &Analysis) -> Vec<Ticks> {
    analysis
        .messages
        .iter()
        .map(|b| b.classic.expect("converges").queuing)
        .collect()
}

fn classic_meets_deadlines(set: &MessageSet, analysis: &Analysis) -> Vec<bool> {
    set.messages
        .iter()
        .zip(&analysis.messages)
        .map(|(m, b)| b.classic.expect("converges").response <= m.deadline)
        .collect()
}

fn simulated(set: &MessageSet, analysis: &Analysis) -> Simulation {
    simulate(set, analysis, THREADS, &|_, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn observed(set: &MessageSet, sim: &Simulation, name: &str) -> Observation {
    sim.observed[index(set, name)].unwrap_or_else(|| panic!("{name} was never sent"))
}

/// Every message was observed and none beyond its corrected bound.
fn assert_within_corrected_bounds(set: &MessageSet, analysis: &Analysis, sim: &Simulation) {
    let over: Vec<&str> = violations(analysis, sim)
        .iter()
        .map(|&i| set.messages[i].name.as_str())
        .collect();
    assert!(
        over.is_empty(),
        "observed beyond the corrected bound: {over:?}"
    );
    for (m, o) in set.messages.iter().zip(&sim.observed) {
        assert!(o.is_some(), "{} was never sent", m.name);
    }
}

#[test]
fn every_example_set_loads_and_every_bound_converges() {
    let mut count = 0;
    for entry in std::fs::read_dir(examples_dir()).expect("examples/rta") {
        let path = entry.expect("directory entry").path();
        let set = MessageSet::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let analysis = Analysis::of(&set);
        for (m, b) in set.messages.iter().zip(&analysis.messages) {
            assert!(
                b.classic.is_ok() && b.corrected.is_ok(),
                "{}: {}",
                set.source,
                m.name
            );
        }
        count += 1;
    }
    assert_eq!(count, 7, "the example sets");
}

#[test]
fn classic_worked_example_1_queues_2_4_2_and_meets_every_deadline() {
    let set = example("classic_example_1");
    let analysis = Analysis::of(&set);
    assert_eq!(classic_queuing(&analysis), [2, 4, 2]);
    assert_eq!(classic_meets_deadlines(&set, &analysis), [true; 3]);
}

#[test]
fn classic_worked_example_2_queues_3_5_2_and_the_first_misses() {
    let set = example("classic_example_2");
    let analysis = Analysis::of(&set);
    assert_eq!(classic_queuing(&analysis), [3, 5, 2]);
    assert_eq!(analysis.messages[0].classic.unwrap().response, 4);
    assert_eq!(set.messages[0].period, 3);
    assert_eq!(
        classic_meets_deadlines(&set, &analysis),
        [false, true, true]
    );
}

#[test]
fn worst_case_frame_time_bounds_every_real_frame() {
    for extended in [false, true] {
        for dlc in 0..=8u8 {
            let n = usize::from(dlc);
            let bits = frame_bits(extended, dlc);
            assert_eq!(bits, length_bound(extended, n) as u64 + INTERMISSION_BITS);
            let longest = search(extended, n);
            assert_eq!(encode(&longest.frame).len(), longest.len);
            assert!(
                longest.len as u64 + INTERMISSION_BITS <= bits,
                "{extended} {dlc}"
            );
        }
    }
    let ext8 = frame_bits(true, 8);
    assert_eq!((frame_bits(false, 8), ext8), (135, 160));
}

#[test]
fn davis_2007_published_set_classic_3_ms_corrected_3_5_ms() {
    let set = example("davis2007");
    let analysis = Analysis::of(&set);
    const MS: Ticks = 1_000_000;
    for m in &set.messages {
        assert_eq!(m.transmission, MS, "7-byte frames: 125 bits of 8 µs");
    }
    let c = bounds(&set, &analysis, "C");
    let classic = c.classic.unwrap();
    let corrected = c.corrected.unwrap();
    assert_eq!(classic.response, 3 * MS);
    assert_eq!(corrected.first_response, 3 * MS);
    assert_eq!(corrected.worst.response, 3 * MS + MS / 2);
    assert_eq!((corrected.worst_instance, corrected.instances), (1, 2));
    assert_eq!(corrected.busy_period, 7 * MS);
    let deadline = set.messages[index(&set, "C")].deadline;
    assert!(classic.response <= deadline && corrected.worst.response > deadline);
}

#[test]
fn davis_2007_counterexample_reproduced_on_the_bus() {
    let set = example("davis2007_on_bus");
    let analysis = Analysis::of(&set);
    let sim = simulated(&set, &analysis);
    assert_within_corrected_bounds(&set, &analysis, &sim);
    let c = bounds(&set, &analysis, "C");
    let seen = observed(&set, &sim, "C");
    let deadline = set.messages[index(&set, "C")].deadline;
    assert!(seen.exceeds(c.classic.unwrap().response), "{seen:?}");
    assert!(
        seen.exceeds(deadline),
        "C misses its deadline on the bus: {seen:?}"
    );
    assert_eq!(seen.instance, 1, "the second instance of the busy period");
    for name in ["A", "B"] {
        let classic = bounds(&set, &analysis, name).classic.unwrap();
        assert!(
            !observed(&set, &sim, name).exceeds(classic.response),
            "{name}"
        );
    }
}

#[test]
fn davis_2007_published_timing_is_a_tie_real_frames_never_reach() {
    // Five frames at exactly the stuffing bound end when A's third instance is released; real
    // frames are a few bits shorter, so C's second instance is sent first.
    let set = example("davis2007");
    let analysis = Analysis::of(&set);
    let sim = simulated(&set, &analysis);
    assert_within_corrected_bounds(&set, &analysis, &sim);
    for (m, frame) in set.messages.iter().zip(&sim.frames) {
        assert!(sent_bits(frame) < m.transmission / set.time_base.bit_ticks());
    }
    let c = bounds(&set, &analysis, "C").classic.unwrap();
    assert!(!observed(&set, &sim, "C").exceeds(c.response));
}

#[test]
fn top_priority_response_is_the_blocking_rest_plus_its_own_frame() {
    let set = MessageSet::parse(
        r#"
bitrate = 500000
[[message]]
name = "top"
id = 0x010
dlc = 2
period_ms = 10
node = "a"
[[message]]
name = "blocker"
id = 0x020
dlc = 8
period_ms = 10
node = "b"
"#,
        "two.toml",
    )
    .unwrap();
    let analysis = Analysis::of(&set);
    let sim = simulated(&set, &analysis);
    let clock_fs = sim_clock(500_000).period_fs();
    let bit_fs = u64::from(sim_btr().clocks_per_bit()) * clock_fs;
    let wire = |i: usize| encode(&sim.frames[i]).len() as u64;
    // The blocker started one bit before the release; the top frame starts after the blocker's
    // intermission, 6 clocks late (the core's receive-to-transmit delay after another node's
    // frame), and transmit-complete comes one clock after its last EOF bit.
    let expected = (wire(1) + INTERMISSION_BITS - 1 + wire(0)) * bit_fs + 7 * clock_fs;
    assert_eq!(sim.observed[0].unwrap().response_fs, expected);
    assert!(!sim.observed[0]
        .unwrap()
        .exceeds(analysis.messages[0].classic.unwrap().response));
}

#[test]
fn jitter_counts_in_the_response_and_queued_instances_wait_their_turn() {
    // B's first instance is queued at the critical instant after its full 1 ms jitter and its
    // second 1.3 ms later, while the first still waits behind A: the second waits in B's queue.
    let set = MessageSet::parse(
        r#"
bitrate = 125000
[[message]]
name = "A"
id = 0x100
dlc = 8
period_ms = 2.2
node = "a"
[[message]]
name = "B"
id = 0x200
dlc = 8
period_ms = 2.3
jitter_ms = 1
node = "b"
"#,
        "jitter.toml",
    )
    .unwrap();
    let analysis = Analysis::of(&set);
    let sim = simulated(&set, &analysis);
    assert_within_corrected_bounds(&set, &analysis, &sim);
    assert!(analysis.messages[1].corrected.unwrap().instances > 1);
    // The first instance's event came 1 ms before it was queued, then it waited for A's frame.
    let b = sim.observed[1].unwrap();
    assert_eq!(b.instance, 0);
    let bit_fs = 8_000 * FS_PER_NS;
    let wire = |i: usize| encode(&sim.frames[i]).len() as u64;
    let least =
        set.messages[1].jitter * FS_PER_NS + (wire(0) + INTERMISSION_BITS + wire(1)) * bit_fs;
    assert!(b.response_fs >= least, "{b:?} < {least}");
}

#[test]
fn chassis_500k_every_observed_response_within_the_corrected_bound() {
    let set = example("chassis_500k");
    let analysis = Analysis::of(&set);
    let sim = simulated(&set, &analysis);
    assert_within_corrected_bounds(&set, &analysis, &sim);
    // The radar's object list misses its 2 ms deadline by both analyses and on the bus.
    let radar = index(&set, "RadarObjects");
    assert!(sim.observed[radar]
        .unwrap()
        .exceeds(set.messages[radar].deadline));
}

#[test]
#[ignore = "long: 16 critical instants of 16 RTL cores at 500 kbit/s (about 15 s)"]
fn powertrain_500k_every_observed_response_within_the_corrected_bound() {
    let set = example("powertrain_500k");
    let analysis = Analysis::of(&set);
    assert_within_corrected_bounds(&set, &analysis, &simulated(&set, &analysis));
}

#[test]
#[ignore = "long: 14 critical instants of 14 RTL cores at 125 kbit/s (about 12 s)"]
fn body_125k_every_observed_response_within_the_corrected_bound() {
    let set = example("body_125k");
    let analysis = Analysis::of(&set);
    assert_within_corrected_bounds(&set, &analysis, &simulated(&set, &analysis));
}
