//! `cansim replay`: a logic-analyzer capture drives the bus, and one complete controller receives
//! it: the RTL, in listen-only mode, set up by the model of the Linux driver like any scenario node
//! (probe, bit timing, start with bus-error reporting). What its driver read comes out as candump
//! lines in the capture's time, then TXERR and RXERR and every bus error with its ECC in words;
//! with `compare`, the frames our software decoder finds in the same capture go beside them.
//!
//! Recessive stretches longer than [`IDLE_KEEP_BITS`] are shortened to that: a listen-only
//! controller that has seen the bus idle that long behaves the same whatever the length of the
//! idle, so it sees the same frames, only sooner.

use std::path::PathBuf;

use crate::decode::bus_decoder::BusEventKind;
use crate::decode::vcd_reader::{decode_vcd, DecodeOptions};
use crate::engine::time::seconds_micros;
use crate::host::driver::{open_filter, DriverEvent};
use crate::nodes::controller_node::ModelEngine;
use crate::scenario::recording::{CaptureVcd, Recording};
use crate::scenario::report::Happening;
use crate::scenario::summary::ecc_text;
use crate::scenario::{
    run, BusConfig, NodeConfig, NodeMode, RunOptions, Scenario, ScenarioError, DEFAULT_TXQUEUELEN,
};
use golden::btr::Btr;
use golden::frame::Frame;

/// Idle bit times kept of a longer recessive stretch (more than the 11 bits of integration and
/// the 10 after an error or overload flag).
pub const IDLE_KEEP_BITS: u64 = 64;
/// Bit times simulated after the capture's last change.
const TAIL_BITS: u64 = 32;
/// Where simulated time would end (femtoseconds in a `u64`).
const NO_END_FS: u64 = u64::MAX / 2;
/// The name of the receiving node.
const NODE: &str = "replay";

/// What to replay and how the controller is set up.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// The capture (VCD or sigrok session).
    pub capture: PathBuf,
    /// The bus signal in it.
    pub signal: String,
    /// The controller's clock in Hz.
    pub clock_hz: u32,
    /// Its bit timing.
    pub btr: Btr,
    /// Its clock offset in ppm.
    pub ppm: f64,
    /// Also decode the capture with the software decoder and compare.
    pub compare: bool,
    /// The engine stepping the controller (`None`: the one `CAN_ENGINE` chooses).
    pub engine: Option<ModelEngine>,
    /// Write the waves of the replay (the bus as the controller saw it, and the controller) here.
    pub vcd: Option<PathBuf>,
}

/// What a replay gave.
#[derive(Clone, Debug)]
pub struct ReplayOutcome {
    /// The report as text.
    pub text: String,
    /// The frames the controller's driver read.
    pub received: Vec<Frame>,
    /// With `compare`: whether the software decoder found the same frames.
    pub agrees: Option<bool>,
}

/// The scenario of a replay: the capture on the bus and one listen-only controller.
pub fn replay_scenario(options: &ReplayOptions) -> Scenario {
    let bus = BusConfig {
        clock_hz: options.clock_hz,
        btr: options.btr,
    };
    let node = NodeConfig {
        name: NODE.to_string(),
        clock_hz: options.clock_hz,
        ppm: options.ppm,
        delay_fs: 0,
        btr: options.btr,
        mode: NodeMode::ListenOnly,
        filter: open_filter(),
        restart_fs: None,
        berr_reporting: true,
        one_shot: false,
        txqueuelen: DEFAULT_TXQUEUELEN,
        canopen: None,
        canopen_master: None,
    };
    Scenario {
        path: options.capture.clone(),
        duration_fs: NO_END_FS,
        seed: 0,
        bus,
        nodes: vec![node],
        traffic: Default::default(),
        faults: Vec::new(),
        recording: Some(Recording {
            path: options.capture.clone(),
            signal: options.signal.clone(),
            idle_keep_fs: Some(IDLE_KEEP_BITS * bus.bit_fs()),
            end_after_fs: Some(TAIL_BITS * bus.bit_fs()),
        }),
    }
}

/// Replays the capture of `options`.
pub fn replay(options: &ReplayOptions) -> Result<ReplayOutcome, ScenarioError> {
    let scenario = replay_scenario(options);
    let report = run(
        &scenario,
        RunOptions {
            engine: options.engine,
            edge_skipping: None,
            vcd: options.vcd.clone(),
            ..RunOptions::default()
        },
    )?;
    let bus = &scenario.bus;
    let mut text = format!(
        "{}, signal {}: a listen-only controller at {:.0} bit/s ({} MHz, BTR0 0x{:02X} BTR1 0x{:02X}, \
         sample point {:.1} %), clock {:+} ppm\n",
        options.capture.display(),
        options.signal,
        bus.btr.bitrate(f64::from(bus.clock_hz)),
        f64::from(bus.clock_hz) / 1e6,
        bus.btr.btr0(),
        bus.btr.btr1(),
        bus.btr.sample_point() * 100.0,
        options.ppm
    );
    let mut received = Vec::new();
    let mut errors = Vec::new();
    for event in &report.events {
        let at = seconds_micros(report.recorded_time(event.at_fs));
        match event.what {
            Happening::Driver(DriverEvent::Received(frame)) => {
                text += &format!("({at}) can0 {frame}\n");
                received.push(frame);
            }
            Happening::Driver(DriverEvent::BusError { ecc, counters }) => errors.push(format!(
                "  ({at}) ECC 0x{ecc:02X}: {}; RXERR {}\n",
                ecc_text(ecc),
                counters.rxerr
            )),
            _ => {}
        }
    }
    let node = &report.nodes[0];
    text += &format!(
        "{} frames received; RXERR {}, TXERR {}; {} bus errors\n",
        received.len(),
        node.rec,
        node.tec,
        errors.len()
    );
    errors.iter().for_each(|line| text += line);
    let agrees = options
        .compare
        .then(|| compare(options, &received, &mut text))
        .transpose()?;
    Ok(ReplayOutcome {
        text,
        received,
        agrees,
    })
}

/// Decodes the capture with the software decoder at the controller's bit timing (its sample point
/// and synchronisation jump width) and writes the
/// comparison of its frames with `received`; whether they are the same.
fn compare(
    options: &ReplayOptions,
    received: &[Frame],
    text: &mut String,
) -> Result<bool, ScenarioError> {
    let decode_options = DecodeOptions {
        signal: Some(options.signal.clone()),
        bitrate: Some(options.btr.bitrate(f64::from(options.clock_hz))),
        sample_point: Some(options.btr.sample_point()),
        sjw: Some(f64::from(options.btr.sjw + 1) / f64::from(options.btr.quanta_per_bit())),
    };
    let vcd = CaptureVcd::new(&options.capture).map_err(ScenarioError::new)?;
    let decoded =
        decode_vcd(vcd.path(), &decode_options).map_err(|e| ScenarioError::new(e.to_string()))?;
    let frames: Vec<Frame> = decoded
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            BusEventKind::Frame { frame, .. } => Some(*frame),
            _ => None,
        })
        .collect();
    if frames == received {
        *text += &format!(
            "compare: the software decoder finds the same {} frames\n",
            frames.len()
        );
        return Ok(true);
    }
    *text += &format!(
        "compare: the software decoder finds {} frames, the controller read {}:\n  {:<24}  {}\n",
        frames.len(),
        received.len(),
        "controller",
        "decoder"
    );
    for k in 0..frames.len().max(received.len()) {
        let show = |f: Option<&Frame>| f.map_or("-".to_string(), |f| f.to_string());
        let (ours, theirs) = (received.get(k), frames.get(k));
        let mark = if ours == theirs { " " } else { "*" };
        *text += &format!("{mark} {:<24}  {}\n", show(ours), show(theirs));
    }
    Ok(false)
}
