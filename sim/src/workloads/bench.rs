//! The reference workload of `cansim bench`: complete controllers at 16 MHz on a 500 kbit/s bus
//! (BTR0 0x40, BTR1 0x1C; [`BitRate`] gives the other rates measured). Node A sends 8-byte standard
//! data frames back to back through its registers (TX buffer, CMR TR, wait for TI); every other
//! node takes each frame from its RX buffer on RI, checks it and releases the buffer. Speed is
//! counted in node-pair clock cycles (all nodes' rising edges / 2) and frames per second of real
//! time. Either engine of the controller ([`ModelEngine`]) runs it.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;
use std::time::Instant;

use rtl::registers::{command, interrupt, mode, pelican, status};

use crate::engine::time::{ClockSpec, FS_PER_MS};
use crate::engine::{Device, DeviceId, EdgeSkipping, Engine};
use crate::host::sja1000::{
    enter_operating_mode, read_rx_message, release_rx, set_up_pelican, transmit, PelicanSetup,
    BTR0_125K_SJW2_AT_16MHZ, BTR0_1M_SJW2_AT_16MHZ, BTR0_250K_SJW2_AT_16MHZ,
    BTR0_500K_SJW2_AT_16MHZ, BTR1_1M_AT_16MHZ, BTR1_500K_AT_16MHZ,
};
use crate::host::Host;
use crate::nodes::controller_node::{ControllerNode, ModelEngine};
use crate::workloads::campaign::Runner;
use golden::frame::{Frame, Id};

/// Controller clock of the workload.
pub const CLOCK_HZ: f64 = 16e6;
/// Clock offset between neighbouring nodes, so receivers resynchronise as on a real bus.
const PPM_STEP: f64 = 100.0;
/// Clock offsets repeat after this many nodes (0 to 700 ppm), inside the oscillator tolerance of
/// the workload's bit timing whatever the node count.
const PPM_STEPS: usize = 8;
/// The most nodes the workload runs.
pub const MAX_NODES: usize = 128;
/// Longest wait for an interrupt or for a node to see the bus idle at 500 kbit/s (a frame takes
/// about 0.25 ms); longer in proportion at lower rates.
const WAIT_LIMIT_FS: u64 = FS_PER_MS;

/// A bit rate of the workload at its 16 MHz clock, SJW 2 quanta: 16 quanta per bit up to 500 kbit/s
/// (sample point at 14 of 16), 8 at 1 Mbit/s (6 of 8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BitRate {
    kbit_s: u32,
    btr0: u8,
    btr1: u8,
}

impl BitRate {
    /// The rates `cansim bench --bit-rate` offers.
    pub const ALL: [BitRate; 4] = [
        BitRate::new(125, BTR0_125K_SJW2_AT_16MHZ, BTR1_500K_AT_16MHZ),
        BitRate::new(250, BTR0_250K_SJW2_AT_16MHZ, BTR1_500K_AT_16MHZ),
        BitRate::REFERENCE,
        BitRate::new(1000, BTR0_1M_SJW2_AT_16MHZ, BTR1_1M_AT_16MHZ),
    ];

    /// The reference workload's 500 kbit/s.
    pub const REFERENCE: BitRate = BitRate::new(500, BTR0_500K_SJW2_AT_16MHZ, BTR1_500K_AT_16MHZ);

    const fn new(kbit_s: u32, btr0: u8, btr1: u8) -> BitRate {
        BitRate { kbit_s, btr0, btr1 }
    }

    /// Bits per second.
    pub fn bits_per_s(self) -> f64 {
        f64::from(self.kbit_s) * 1e3
    }

    fn wait_limit_fs(self) -> u64 {
        WAIT_LIMIT_FS * 500 / u64::from(self.kbit_s)
    }
}

impl fmt::Display for BitRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kbit_s {
            1000 => f.write_str("1M"),
            k => write!(f, "{k}k"),
        }
    }
}

impl FromStr for BitRate {
    type Err = String;

    fn from_str(text: &str) -> Result<BitRate, String> {
        BitRate::ALL
            .into_iter()
            .find(|rate| rate.to_string().eq_ignore_ascii_case(text))
            .ok_or_else(|| {
                let names: Vec<String> = BitRate::ALL.iter().map(|r| r.to_string()).collect();
                format!("bit rate {text:?}: one of {}", names.join(", "))
            })
    }
}

/// One run of the workload.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchRun {
    /// Node-pair clock cycles simulated per second of real time.
    pub pair_cycles_per_s: f64,
    /// The same per second of the running thread's processor time: what the run costs whatever
    /// else the machine runs.
    pub pair_cycles_per_cpu_s: f64,
    /// Frames sent and received per second of real time.
    pub frames_per_s: f64,
    /// The share of the measured clock edges skipped rather than stepped (0 to 1).
    pub skipped_share: f64,
}

impl BenchRun {
    /// Simulated time per real time (real time is `CLOCK_HZ` cycles per second of each node).
    pub fn real_time_factor(&self) -> f64 {
        self.pair_cycles_per_s / CLOCK_HZ
    }
}

/// What went wrong in a run: a frame that did not arrive intact (a design or engine bug), or the
/// trace file.
#[derive(Debug)]
pub struct BenchError(pub String);

impl std::fmt::Display for BenchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BenchError {}

/// Runs the workload once: `nodes` controllers (at least 2) stepped by `model`, `frames` frames at
/// `bit_rate`, a VCD written to `trace` when given (and deleted afterwards).
pub fn run_workload(
    model: ModelEngine,
    nodes: usize,
    frames: usize,
    bit_rate: BitRate,
    trace: Option<&PathBuf>,
    skipping: EdgeSkipping,
) -> Result<BenchRun, BenchError> {
    if nodes < 2 {
        return Err(BenchError(format!(
            "the workload needs a sender and at least one receiver, not {nodes} node(s)"
        )));
    }
    let mut engine = Engine::new();
    engine.set_edge_skipping(skipping);
    let mut ids = Vec::with_capacity(nodes);
    for n in 0..nodes {
        let clock = ClockSpec::with_ppm(CLOCK_HZ, PPM_STEP * (n % PPM_STEPS) as f64);
        let node = ControllerNode::with_engine(&node_name(n), clock, model)
            .map_err(|e| BenchError(e.to_string()))?;
        ids.push(engine.add(node, 0));
    }
    for &id in &ids {
        configure(&mut engine, id, bit_rate);
    }
    for &id in &ids {
        wait_for_bus_idle(&mut engine, id, bit_rate)?;
    }
    if let Some(path) = trace {
        engine
            .trace_vcd(path)
            .map_err(|e| BenchError(format!("{}: {e}", path.display())))?;
    }
    let cpu_start = thread_cpu_seconds();
    let start = Instant::now();
    let (edges_before, skipped_before) = (engine.edges(), engine.skipped_edges());
    for i in 0..frames {
        transfer(&mut engine, &ids, &workload_frame(i), bit_rate)?;
    }
    let trace_result = engine.finish_trace();
    let seconds = start.elapsed().as_secs_f64();
    let cpu_seconds = thread_cpu_seconds() - cpu_start;
    if let Some(path) = trace {
        trace_result.map_err(|e| BenchError(format!("{}: {e}", path.display())))?;
        std::fs::remove_file(path).ok();
    }
    let edges = engine.edges() - edges_before;
    let pair_cycles = edges as f64 / 2.0;
    Ok(BenchRun {
        skipped_share: (engine.skipped_edges() - skipped_before) as f64 / edges.max(1) as f64,
        pair_cycles_per_s: pair_cycles / seconds,
        pair_cycles_per_cpu_s: pair_cycles / cpu_seconds,
        frames_per_s: frames as f64 / seconds,
    })
}

/// `a` … `z`, then `n26`, `n27`, …
fn node_name(n: usize) -> String {
    match u8::try_from(n) {
        Ok(letter @ 0..=25) => char::from(b'a' + letter).to_string(),
        _ => format!("n{n}"),
    }
}

/// Frame `i` of the workload: 8 data bytes, a different identifier and payload each time.
pub fn workload_frame(i: usize) -> Frame {
    let id = Id::standard((i % 0x800) as u16).expect("11-bit identifier");
    let data: Vec<u8> = (0..8).map(|k| (i * 8 + k) as u8).collect();
    Frame::data(id, &data).expect("8 data bytes")
}

/// PeliCAN at `bit_rate`, filter open, TI and RI enabled, operating mode.
fn configure(engine: &mut Engine, id: DeviceId, bit_rate: BitRate) {
    let mut host = Host::new(engine, id);
    let setup =
        PelicanSetup::open(bit_rate.btr0, bit_rate.btr1).with_ier(interrupt::RI | interrupt::TI);
    set_up_pelican(&mut host, &setup);
    assert_eq!(
        enter_operating_mode(&mut host, 0) & mode::RM,
        0,
        "operating mode"
    );
}

/// Polls node `id`'s status register until it has seen the bus idle (neither receiving nor
/// transmitting: integration done), so that it takes part in the first frame.
fn wait_for_bus_idle(
    engine: &mut Engine,
    id: DeviceId,
    bit_rate: BitRate,
) -> Result<(), BenchError> {
    let mut host = Host::new(engine, id);
    let limit = host.engine().now() + bit_rate.wait_limit_fs();
    while host.read(pelican::SR) & (status::RS | status::TS) != 0 {
        if host.engine().now() > limit {
            return Err(BenchError(format!(
                "node {} never saw the bus idle",
                host.node().name()
            )));
        }
    }
    Ok(())
}

/// Which of the workload's nodes hold their interrupt line, kept up to date edge by edge: a node's
/// line changes only at its own clock edge, so only the node just stepped is looked at (looking at
/// every node at every edge was 40 % of a 64-node run).
struct Interrupts {
    /// By device number: whether it is a workload node, and its line.
    asserted: Vec<Option<bool>>,
    count: usize,
    /// The nodes, for the debug builds' check against polling every node.
    ids: Vec<DeviceId>,
}

impl Interrupts {
    fn of(engine: &Engine, ids: &[DeviceId]) -> Interrupts {
        let mut asserted = vec![None; ids.iter().map(|id| id.0 + 1).max().unwrap_or(0)];
        for &id in ids {
            asserted[id.0] = Some(engine.device::<ControllerNode>(id).irq());
        }
        let count = asserted.iter().filter(|a| **a == Some(true)).count();
        Interrupts {
            asserted,
            count,
            ids: ids.to_vec(),
        }
    }

    /// Whether any node holds its line after the engine's last step.
    fn any_after_step(&mut self, engine: &Engine) -> bool {
        if let Some(id) = engine.last_stepped() {
            if let Some(Some(was)) = self.asserted.get(id.0).copied() {
                let now = engine.device::<ControllerNode>(id).irq();
                if now != was {
                    self.asserted[id.0] = Some(now);
                    if now {
                        self.count += 1;
                    } else {
                        self.count -= 1;
                    }
                }
            }
        }
        debug_assert_eq!(
            self.count > 0,
            self.ids
                .iter()
                .any(|&id| engine.device::<ControllerNode>(id).irq()),
            "following the stepped node missed an interrupt line"
        );
        self.count > 0
    }
}

/// Node `ids[0]` sends `frame`; returns when it reported TI and every receiver has taken the frame.
fn transfer(
    engine: &mut Engine,
    ids: &[DeviceId],
    frame: &Frame,
    bit_rate: BitRate,
) -> Result<(), BenchError> {
    let (sender, receivers) = ids.split_first().expect("a sender");
    let mut host = Host::new(engine, *sender);
    transmit(&mut host, frame, command::TR);
    let mut sent = false;
    let mut received = vec![false; receivers.len()];
    while !sent || received.contains(&false) {
        let limit = engine.now() + bit_rate.wait_limit_fs();
        let mut interrupts = Interrupts::of(engine, ids);
        let interrupted = engine
            .run_while(limit, |e| interrupts.any_after_step(e))
            .map_err(|e| BenchError(format!("simulation: {e}")))?;
        if !interrupted {
            return Err(BenchError(format!(
                "no interrupt within {} ms while sending {frame:?}",
                bit_rate.wait_limit_fs() as f64 / FS_PER_MS as f64
            )));
        }
        for (r, &id) in receivers.iter().enumerate() {
            if engine.device::<ControllerNode>(id).irq() {
                if let Some(got) = take_frame(engine, id) {
                    if got != *frame {
                        return Err(BenchError(format!(
                            "node {} received {got:?} instead of {frame:?}",
                            node_name(r + 1)
                        )));
                    }
                    received[r] = true;
                }
            }
        }
        if engine.device::<ControllerNode>(*sender).irq() {
            sent |= Host::new(engine, *sender).read(pelican::IR) & interrupt::TI != 0;
        }
    }
    Ok(())
}

/// Services node `id`'s interrupt: the received frame if RI was set (the buffer released).
fn take_frame(engine: &mut Engine, id: DeviceId) -> Option<Frame> {
    let mut host = Host::new(engine, id);
    if host.read(pelican::IR) & interrupt::RI == 0 {
        return None;
    }
    let frame = read_rx_message(&mut host);
    release_rx(&mut host);
    Some(frame)
}

/// Processor time of the calling thread, in seconds (64-bit Linux `clock_gettime`).
fn thread_cpu_seconds() -> f64 {
    #[repr(C)]
    struct Timespec {
        tv_sec: i64,
        tv_nsec: i64,
    }
    extern "C" {
        fn clock_gettime(clock: i32, time: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut time = Timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `time` is a valid out-parameter with the layout of 64-bit Linux's `struct timespec`.
    let status = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut time) };
    assert_eq!(status, 0, "clock_gettime of the thread's CPU clock");
    time.tv_sec as f64 + time.tv_nsec as f64 * 1e-9
}

/// Fault-injection cases per second of real time when `threads` workers share `faults` cases of the
/// campaign with `seed` (`cansim campaign`) played by `runner`; fails if a case broke a CAN rule.
pub fn campaign_rate(
    seed: u64,
    faults: u64,
    runner: Runner,
    threads: usize,
) -> Result<f64, BenchError> {
    let start = Instant::now();
    let summary = crate::workloads::campaign::run_campaign(seed, faults, runner, threads, &|_| {})
        .map_err(BenchError)?;
    let seconds = start.elapsed().as_secs_f64();
    if let Some((index, violations)) = summary.failures.first() {
        return Err(BenchError(format!(
            "campaign case {index} broke a rule: {}",
            violations.join("; ")
        )));
    }
    Ok(summary.cases as f64 / seconds)
}

/// Median, minimum and maximum of several runs (by node-pair cycles per second).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchSummary {
    /// The median run.
    pub median: BenchRun,
    /// The slowest run.
    pub min: BenchRun,
    /// The fastest run.
    pub max: BenchRun,
}

/// Summarises `runs` (at least one).
pub fn summarise(mut runs: Vec<BenchRun>) -> BenchSummary {
    assert!(!runs.is_empty(), "at least one run");
    runs.sort_by(|x, y| x.pair_cycles_per_s.total_cmp(&y.pair_cycles_per_s));
    BenchSummary {
        median: runs[runs.len() / 2],
        min: runs[0],
        max: runs[runs.len() - 1],
    }
}

/// The machine-readable result line.
pub fn bench_line(
    engine: &str,
    nodes: usize,
    bit_rate: BitRate,
    trace: bool,
    skipping: EdgeSkipping,
    summary: &BenchSummary,
) -> String {
    format!(
        "BENCH engine={engine} nodes={nodes} bit_rate={bit_rate} trace={} skip_edges={} \
         pair_cycles_per_s={:.0} pair_cycles_per_cpu_s={:.0} frames_per_s={:.1} \
         skipped_percent={:.1}",
        if trace { "on" } else { "off" },
        skipping.name(),
        summary.median.pair_cycles_per_s,
        summary.median.pair_cycles_per_cpu_s,
        summary.median.frames_per_s,
        100.0 * summary.median.skipped_share
    )
}

/// The cost of tracing as a machine-readable line: the median over the run pairs (run k without
/// and run k with tracing, taken one after the other) of the processor time tracing added.
pub fn trace_cost_line(
    engine: &str,
    nodes: usize,
    bit_rate: BitRate,
    skipping: EdgeSkipping,
    off: &[BenchRun],
    on: &[BenchRun],
) -> String {
    let mut costs: Vec<f64> = off
        .iter()
        .zip(on)
        .map(|(off, on)| 100.0 * (1.0 - on.pair_cycles_per_cpu_s / off.pair_cycles_per_cpu_s))
        .collect();
    assert!(!costs.is_empty(), "at least one pair of runs");
    costs.sort_by(f64::total_cmp);
    format!(
        "BENCH engine={engine} nodes={nodes} bit_rate={bit_rate} skip_edges={} \
         trace_cost_percent={:.1}",
        skipping.name(),
        costs[costs.len() / 2]
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_trace_cost_is_the_median_over_run_pairs() {
        let run = |c: f64| BenchRun {
            pair_cycles_per_s: c,
            pair_cycles_per_cpu_s: c,
            frames_per_s: 1.0,
            skipped_share: 0.0,
        };
        // Pairs cost 10 %, 50 % and 20 %: the median is 20 %, whatever the run-to-run spread.
        let off = [run(100.0), run(200.0), run(50.0)];
        let on = [run(90.0), run(100.0), run(40.0)];
        assert_eq!(
            trace_cost_line(
                "verilator",
                4,
                BitRate::REFERENCE,
                EdgeSkipping::Off,
                &off,
                &on
            ),
            "BENCH engine=verilator nodes=4 bit_rate=500k skip_edges=off trace_cost_percent=20.0"
        );
    }

    #[test]
    fn every_receiver_gets_every_frame_and_the_speed_is_counted_on_both_engines() {
        for model in ModelEngine::ALL {
            let run = run_workload(model, 3, 2, BitRate::REFERENCE, None, EdgeSkipping::Off)
                .unwrap_or_else(|e| panic!("{model}: frames arrive intact: {e}"));
            assert!(run.pair_cycles_per_s > 0.0 && run.frames_per_s > 0.0);
            assert!(run.pair_cycles_per_cpu_s > 0.0);
        }
    }

    /// The frame rate follows the bit rate: simulated time per frame is the frame's bits at the
    /// rate chosen: an 8-byte standard data frame is 108 bits before stuffing (SOF, identifier 11,
    /// RTR, IDE, r0, DLC 4, data 64, CRC 15, CRC delimiter, ACK slot and delimiter, EOF 7), then 3
    /// of intermission; the payloads add a few stuff bits, the host's accesses between frames
    /// little.
    #[test]
    fn every_bit_rate_carries_the_frames_and_names_itself() {
        for rate in BitRate::ALL {
            assert_eq!(rate.to_string().parse::<BitRate>(), Ok(rate));
            let run = run_workload(ModelEngine::Compiled, 2, 2, rate, None, EdgeSkipping::Off)
                .unwrap_or_else(|e| panic!("{rate}: frames arrive intact: {e}"));
            let seconds_per_frame = run.pair_cycles_per_s / run.frames_per_s / CLOCK_HZ;
            let bit_times = seconds_per_frame * rate.bits_per_s();
            assert!(
                (111.0..=130.0).contains(&bit_times),
                "{rate}: a frame took {bit_times:.1} bit times"
            );
        }
        assert!("2M"
            .parse::<BitRate>()
            .unwrap_err()
            .contains("125k, 250k, 500k, 1M"));
    }

    /// With the quiet edges skipped the workload moves the same frames in the same simulated time
    /// with most edges skipped; without, none is.
    #[test]
    fn skipping_quiet_edges_skips_most_of_the_workload() {
        let plain = run_workload(
            ModelEngine::Compiled,
            2,
            2,
            BitRate::REFERENCE,
            None,
            EdgeSkipping::Off,
        )
        .unwrap();
        let skipping = run_workload(
            ModelEngine::Compiled,
            2,
            2,
            BitRate::REFERENCE,
            None,
            EdgeSkipping::Checked,
        )
        .unwrap();
        assert_eq!(plain.skipped_share, 0.0);
        assert!(skipping.skipped_share > 0.5, "{}", skipping.skipped_share);
        let cycles_per_frame = |r: &BenchRun| r.pair_cycles_per_s / r.frames_per_s;
        assert_eq!(
            cycles_per_frame(&plain).round(),
            cycles_per_frame(&skipping).round()
        );
    }

    #[test]
    fn the_campaign_rate_counts_cases() {
        for runner in [Runner::Lanes, Runner::Engine(ModelEngine::Compiled)] {
            assert!(campaign_rate(1, 4, runner, 2).expect("no case breaks a rule") > 0.0);
        }
    }

    #[test]
    fn one_node_is_refused() {
        let err = run_workload(
            ModelEngine::RustHdl,
            1,
            1,
            BitRate::REFERENCE,
            None,
            EdgeSkipping::Off,
        )
        .unwrap_err();
        assert!(err.0.contains("at least one receiver"), "{err}");
    }

    #[test]
    fn the_summary_is_the_median_of_the_runs() {
        let run = |c: f64| BenchRun {
            pair_cycles_per_s: c,
            pair_cycles_per_cpu_s: 2.0 * c,
            frames_per_s: c / 100.0,
            skipped_share: c / 4.0,
        };
        let s = summarise(vec![run(3.0), run(1.0), run(2.0)]);
        assert_eq!((s.min, s.median, s.max), (run(1.0), run(2.0), run(3.0)));
        assert_eq!(
            bench_line("rust-hdl", 2, BitRate::REFERENCE, false, EdgeSkipping::On, &s),
            "BENCH engine=rust-hdl nodes=2 bit_rate=500k trace=off skip_edges=on pair_cycles_per_s=2 \
             pair_cycles_per_cpu_s=4 frames_per_s=0.0 skipped_percent=50.0"
        );
    }
}
