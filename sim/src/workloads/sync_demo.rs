//! The bit timing demo of `cansim sync-demo`: a lower tester sends golden
//! frames, some with edges moved by whole time quanta (phase errors) and a glitch, to three nodes whose
//! bit timing logic synchronises on them. The nodes run on clocks a few thousand ppm apart and sit at
//! different propagation delays. The run writes a VCD and reports, per node and frame, whether every
//! bit was sampled right and where in the lower tester's bits the node sampled.

use std::io;
use std::path::{Path, PathBuf};

use crate::engine::bus::Drive;
use crate::engine::bus_timing::BusTiming;
use crate::engine::time::{ClockSpec, FS_PER_NS};
use crate::engine::{DeviceId, Engine};
use crate::nodes::btl_node::{BitTimingNode, BtlEventKind};
use crate::nodes::lower_tester::LowerTester;
use golden::btr::Btr;
use golden::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT};

/// Controller clock of the demo nodes.
pub const DEMO_CLOCK_HZ: f64 = 16e6;
/// 500 kbit/s at 16 MHz: BRP 0, SJW 2, TSEG1 13, TSEG2 2 (16 tq, sample point 87.5 %).
pub const DEMO_BTR: (u8, u8) = (0x40, 0x1C);
/// Idle bits before the first frame and between frames.
const GAP_BITS: usize = 12;

/// A node of the demo: name, clock offset and propagation delay.
struct NodeSpec {
    name: &'static str,
    ppm: f64,
    delay_ns: u64,
}

/// The three nodes.
const NODES: [NodeSpec; 3] = [
    NodeSpec {
        name: "a",
        ppm: 0.0,
        delay_ns: 0,
    },
    NodeSpec {
        name: "b",
        ppm: 1500.0,
        delay_ns: 60,
    },
    NodeSpec {
        name: "c",
        ppm: -2500.0,
        delay_ns: 140,
    },
];

/// A disturbance the lower tester puts into a frame.
#[derive(Clone, Copy, Debug)]
enum Disturbance {
    /// The recessive → dominant edge at the start of frame bit `bit` comes `tq` quanta late (> 0)
    /// or early (< 0).
    MoveEdge { bit: usize, tq: i32 },
    /// A one-quantum recessive glitch in the last quantum of dominant frame bit `bit`, which is followed
    /// by another dominant bit: its falling edge must not synchronise (the sampled bit was dominant).
    Glitch { bit: usize },
}

struct DemoFrame {
    frame: Frame,
    disturbance: Option<Disturbance>,
}

/// How one node received one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReception {
    /// Frame bits sampled at the value the lower tester sent.
    pub bits_right: usize,
    /// Frame bits (SOF to the last EOF bit).
    pub bits: usize,
    /// Earliest and latest sample position, in % of the nominal bit time from the start of the
    /// lower tester's bit as it reaches the node.
    pub sample_range_pct: (f64, f64),
    /// Hard synchronisations during the frame.
    pub hard_syncs: usize,
    /// Resynchronisations during the frame.
    pub resyncs: usize,
    /// For a frame with a moved edge: where the node sampled the bit after that edge, in quanta from
    /// the (moved) start of that bit.
    pub sample_after_edge_tq: Option<f64>,
}

/// One node's results.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeReport {
    /// Node name (its VCD scope).
    pub name: String,
    /// Clock offset from 16 MHz.
    pub ppm: f64,
    /// Propagation delay to and from the bus.
    pub delay_ns: u64,
    /// One entry per demo frame.
    pub frames: Vec<FrameReception>,
}

/// Everything the demo run measured.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoReport {
    /// The frames (candump notation) and what was done to them.
    pub frames: Vec<(String, String)>,
    /// Per node.
    pub nodes: Vec<NodeReport>,
    /// The VCD written, if any.
    pub vcd: Option<PathBuf>,
    /// Simulated time.
    pub simulated_fs: u64,
}

impl DemoReport {
    /// Whether every node sampled every bit of every frame right.
    pub fn all_bits_right(&self) -> bool {
        self.nodes
            .iter()
            .flat_map(|n| &n.frames)
            .all(|f| f.bits_right == f.bits)
    }
}

fn demo_frames() -> Vec<DemoFrame> {
    let std_id = |id| Id::standard(id).expect("demo id");
    let ext_id = |id| Id::extended(id).expect("demo id");
    vec![
        DemoFrame {
            frame: Frame::data(std_id(0x123), &[0xDE, 0xAD, 0xBE, 0xEF]).expect("demo frame"),
            disturbance: None,
        },
        DemoFrame {
            frame: Frame::data(ext_id(0x1ABC_DEF0), &[0x00, 0x11, 0x22]).expect("demo frame"),
            disturbance: Some(Disturbance::MoveEdge { bit: 0, tq: 3 }),
        },
        DemoFrame {
            frame: Frame::data(std_id(0x555), &[0x0F; 8]).expect("demo frame"),
            disturbance: Some(Disturbance::MoveEdge { bit: 0, tq: -1 }),
        },
        DemoFrame {
            frame: Frame::remote(std_id(0x3F0), 0).expect("demo frame"),
            disturbance: Some(Disturbance::Glitch { bit: 0 }),
        },
    ]
}

/// The frame bit (index > 8) where a disturbance goes: the first recessive → dominant edge for moved
/// edges, the first dominant bit followed by a dominant bit for glitches.
fn disturbance_bit(encoded: &EncodedFrame, d: Disturbance) -> Disturbance {
    let after = 9;
    match d {
        Disturbance::MoveEdge { tq, .. } => {
            let bit = (after..encoded.len())
                .find(|&i| encoded.bits[i] == DOMINANT && encoded.bits[i - 1] != DOMINANT)
                .expect("a frame has edges");
            Disturbance::MoveEdge { bit, tq }
        }
        Disturbance::Glitch { .. } => {
            let bit = (after..encoded.len())
                .find(|&i| encoded.bits[i] == DOMINANT && encoded.bits[i + 1] == DOMINANT)
                .expect("a frame has two dominant bits in a row");
            Disturbance::Glitch { bit }
        }
    }
}

fn describe(d: Option<Disturbance>) -> String {
    match d {
        None => "-".into(),
        Some(Disturbance::MoveEdge { bit, tq }) if tq > 0 => {
            format!("edge before bit {bit} {tq} tq late")
        }
        Some(Disturbance::MoveEdge { bit, tq }) => {
            format!("edge before bit {bit} {} tq early", -tq)
        }
        Some(Disturbance::Glitch { bit }) => {
            format!("1-tq recessive glitch at the end of bit {bit}")
        }
    }
}

/// A frame as placed in the lower tester's script.
struct PlacedFrame {
    /// Script bit of the SOF.
    sof: usize,
    /// The bits on the bus: the transmitter's bits with the ACK slot dominant.
    bus_bits: Vec<bool>,
    /// The disturbance, with its frame bit.
    disturbance: Option<Disturbance>,
}

struct Script {
    frames: Vec<PlacedFrame>,
}

fn write_script(lt: &mut LowerTester, frames: &[DemoFrame]) -> Script {
    let mut placed = Vec::new();
    lt.release(GAP_BITS);
    for f in frames {
        let encoded = encode(&f.frame);
        let sof = lt.script_len();
        lt.send_bits(encoded.bits.iter().by_vals());
        // A receiver acknowledges: the bus carries the frame as a working network would.
        let ack = encoded.position(Field::AckSlot, 0).expect("ack slot");
        lt.set_bit(sof + ack, Drive::Dominant);
        let d = f.disturbance.map(|d| disturbance_bit(&encoded, d));
        match d {
            Some(Disturbance::MoveEdge { bit, tq }) => {
                lt.lengthen_bit(sof + bit - 1, tq);
            }
            Some(Disturbance::Glitch { bit }) => {
                let last_quantum = lt.quanta_per_bit() - 1;
                lt.force(sof + bit, last_quantum, 1, Drive::Recessive);
            }
            None => {}
        }
        lt.release(GAP_BITS);
        let mut bus_bits: Vec<bool> = encoded.bits.iter().by_vals().collect();
        bus_bits[ack] = DOMINANT;
        placed.push(PlacedFrame {
            sof,
            bus_bits,
            disturbance: d,
        });
    }
    Script { frames: placed }
}

/// Runs the demo; writes the VCD to `vcd` if given.
pub fn run_demo(vcd: Option<&Path>) -> io::Result<DemoReport> {
    let btr = Btr::from_registers(DEMO_BTR.0, DEMO_BTR.1);
    let nominal = ClockSpec::from_hz(DEMO_CLOCK_HZ);
    let mut engine = Engine::new();
    engine.keep_history();
    let mut lt = LowerTester::new("lt", nominal, btr);
    let frames = demo_frames();
    let script = write_script(&mut lt, &frames);
    let lt = engine.add(lt, 0);
    let nodes: Vec<DeviceId> = NODES
        .iter()
        .map(|n| {
            let clock = ClockSpec::with_ppm(DEMO_CLOCK_HZ, n.ppm);
            engine.add(
                BitTimingNode::new(n.name, clock, btr),
                n.delay_ns * FS_PER_NS,
            )
        })
        .collect();
    if let Some(path) = vcd {
        engine.trace_vcd_timed(path, BusTiming::from_btr(&btr, nominal))?;
    }
    engine.run_while(u64::MAX, |e| e.device::<LowerTester>(lt).finished())?;
    let written = engine.finish_trace()?;
    let lt_ref = engine.device::<LowerTester>(lt);
    let reports = NODES
        .iter()
        .zip(&nodes)
        .map(|(spec, id)| NodeReport {
            name: spec.name.to_string(),
            ppm: spec.ppm,
            delay_ns: spec.delay_ns,
            frames: script
                .frames
                .iter()
                .map(|f| {
                    reception(
                        lt_ref,
                        engine.device(*id),
                        spec.delay_ns * FS_PER_NS,
                        f,
                        btr,
                    )
                })
                .collect(),
        })
        .collect();
    Ok(DemoReport {
        frames: script
            .frames
            .iter()
            .zip(&frames)
            .map(|(placed, f)| (f.frame.to_string(), describe(placed.disturbance)))
            .collect(),
        nodes: reports,
        vcd: written,
        simulated_fs: engine.now(),
    })
}

fn reception(
    lt: &LowerTester,
    node: &BitTimingNode,
    delay_fs: u64,
    placed: &PlacedFrame,
    btr: Btr,
) -> FrameReception {
    let (sof, bits) = (placed.sof, &placed.bus_bits);
    let bit_fs = btr.quanta_per_bit() as f64 * lt.tq_fs() as f64;
    let start = |bit: usize| lt.bit_time(bit).expect("lower tester started") + delay_fs;
    let samples: Vec<(u64, bool)> = node.samples().collect();
    let mut right = 0;
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    let mut after_edge = None;
    for (i, &sent) in bits.iter().enumerate() {
        let (from, to) = (start(sof + i), start(sof + i + 1));
        let Some(&(at, bit)) = samples.iter().find(|(at, _)| *at > from && *at <= to) else {
            continue;
        };
        right += usize::from(bit == sent);
        let pct = 100.0 * (at - from) as f64 / bit_fs;
        lo = lo.min(pct);
        hi = hi.max(pct);
        if matches!(placed.disturbance, Some(Disturbance::MoveEdge { bit, .. }) if bit == i) {
            after_edge = Some((at - from) as f64 / lt.tq_fs() as f64);
        }
    }
    let (from, to) = (start(sof), start(sof + bits.len()));
    let count = |kind: BtlEventKind| {
        node.events()
            .iter()
            .filter(|e| {
                e.kind == kind && e.at_fs >= from.saturating_sub(bit_fs as u64) && e.at_fs < to
            })
            .count()
    };
    FrameReception {
        bits_right: right,
        bits: bits.len(),
        sample_range_pct: (lo, hi),
        hard_syncs: count(BtlEventKind::HardSync),
        resyncs: count(BtlEventKind::Resync),
        sample_after_edge_tq: after_edge,
    }
}

/// The report as text for the terminal.
pub fn format_report(report: &DemoReport) -> String {
    let btr = Btr::from_registers(DEMO_BTR.0, DEMO_BTR.1);
    let mut out = format!(
        "cansim sync-demo: a lower tester sends {} golden frames at {:.0} kbit/s ({btr}) to {} nodes\n\n",
        report.frames.len(),
        btr.bitrate(DEMO_CLOCK_HZ) / 1000.0,
        report.nodes.len()
    );
    out += "frame  content                       disturbance\n";
    for (i, (content, what)) in report.frames.iter().enumerate() {
        out += &format!("{:>5}  {content:<28}  {what}\n", i + 1);
    }
    for node in &report.nodes {
        out += &format!(
            "\n{} (16 MHz {:+} ppm, {} ns from the bus): sample point of each bit, from the start of the bit as it reaches the node\n",
            node.name, node.ppm, node.delay_ns
        );
        for (i, f) in node.frames.iter().enumerate() {
            out += &format!(
                "  frame {}: {:>3}/{} bits right, sampled at {:.1}..{:.1} % of the bit, {} hard sync, {} resyncs",
                i + 1,
                f.bits_right,
                f.bits,
                f.sample_range_pct.0,
                f.sample_range_pct.1,
                f.hard_syncs,
                f.resyncs
            );
            if let Some(tq) = f.sample_after_edge_tq {
                out += &format!("; after the moved edge at {tq:.2} tq");
            }
            out += "\n";
        }
    }
    out += &format!(
        "\nsimulated {:.3} ms; every bit sampled right: {}\n",
        report.simulated_fs as f64 / 1e12,
        if report.all_bits_right() { "yes" } else { "NO" }
    );
    out
}
