//! `cansim`: the command line tool of the CAN controller project. Without a subcommand it runs the demo.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use clap::{Parser, Subcommand};
use golden::btr::{calc_bittiming, format_calculation, format_table, sample_point_fraction, Btr};
use sim::decode::bus_decoder::{EventCounts, Remark};
use sim::decode::vcd_reader::{self, decode_vcd, DecodeOptions};
use sim::engine::rng::Rng;
use sim::engine::EdgeSkipping;
use sim::nodes::controller_node::ModelEngine;
use sim::rta;
use sim::scenario::canopen_node::CanopenLog;
use sim::scenario::parse::parse_time;
use sim::scenario::progress::{peak_resident_bytes, Progress};
use sim::scenario::summary::{format_counts, format_counts_table, format_report, ms, ReportParts};
use sim::scenario::{load, run, RunOptions, RunReport, Scenario};
use sim::serve::ServeOptions;
use sim::verilated;
use sim::workloads::bench::BitRate;
use sim::workloads::campaign::{
    check, describe, format_summary, random_case, run_campaign_shard, run_rtl_on, Runner,
};
use sim::workloads::campaign_slice::{merge, read_slice, write_slice, Shard, Slice};
use sim::workloads::demo::{demo_scenario, DEMO_LOG, DEMO_VCD};
use sim::workloads::replay::ReplayOptions;
use sim::workloads::sync_demo;

#[derive(Parser)]
#[command(
    name = "cansim",
    version,
    about = "Cycle-accurate SJA1000-compatible CAN controller: simulation tools"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// The demo scenario (examples/demo.toml, built in): four CAN controllers arbitrate, one
    /// filters, an injected error, one goes error passive and back, one goes bus-off and its
    /// driver restarts it; writes a VCD and the bus log, prints what the drivers reported and a
    /// summary table (the default command).
    Demo {
        /// Where to write the waveform.
        #[arg(long, default_value = DEMO_VCD)]
        vcd: PathBuf,
        /// Where to write the bus log.
        #[arg(long, default_value = DEMO_LOG)]
        log: PathBuf,
        /// Do not write a waveform.
        #[arg(long)]
        no_vcd: bool,
        /// Print only the summary; no progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Serve a scenario's bus to socketcand clients (python-can's `interface="socketcand"`, raw
    /// mode) until Ctrl-C or SIGTERM: every client that opens the bus is a node of its own (a
    /// complete controller driven through its registers); what it sends goes on the bus, what its
    /// controller receives reaches it with the simulated time as timestamp.
    Serve {
        /// The scenario (TOML; its nodes, traffic and faults run as with `cansim run`, without
        /// end).
        scenario: PathBuf,
        #[command(flatten)]
        args: ServeArgs,
    },
    /// Replay a logic-analyzer capture (VCD, or a sigrok session .sr through sigrok-cli): it
    /// drives the bus, and one complete controller (listen-only, set up by the Linux driver model)
    /// receives it; prints what its driver read (candump lines, capture time), RXERR/TXERR and every
    /// bus error with its ECC in words. Long idle stretches are shortened.
    Replay {
        /// The capture.
        capture: PathBuf,
        /// The bus signal: its full name (top.bus) or a trailing part of it (bus, CAN_RX).
        #[arg(long, default_value = vcd_reader::DEFAULT_SIGNAL)]
        signal: String,
        /// Bit rate in bit/s (the controller's bit timing is calculated as Linux does).
        #[arg(long, required_unless_present_all = ["btr0", "btr1"])]
        bitrate: Option<u32>,
        /// Sample point, in percent (87.5) or as a fraction (0.875).
        #[arg(long, conflicts_with_all = ["btr0", "btr1"])]
        sample_point: Option<f64>,
        /// The controller's clock in Hz.
        #[arg(long, default_value_t = 16_000_000)]
        clock: u32,
        /// BTR0 (hex 0x.. or decimal), with --btr1, instead of --bitrate.
        #[arg(long, value_parser = register_arg, requires = "btr1", conflicts_with = "bitrate")]
        btr0: Option<u8>,
        /// BTR1, with --btr0.
        #[arg(long, value_parser = register_arg, requires = "btr0")]
        btr1: Option<u8>,
        /// The controller's clock offset in ppm.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        offset_ppm: f64,
        /// Also decode the capture with the software decoder; exit status 1 if its frames differ
        /// from what the controller received.
        #[arg(long)]
        compare: bool,
        /// Write the waves of the replay here (simulated time: long idle stretches shortened).
        #[arg(long)]
        vcd: Option<PathBuf>,
    },
    /// Run a scenario file: prints the bus log (candump -l lines with error and overload frames)
    /// and a summary per node; writes a VCD and the log on request.
    Run {
        /// The scenario (TOML; see docs/SCENARIOS.md).
        scenario: PathBuf,
        /// Write a waveform here.
        #[arg(long)]
        vcd: Option<PathBuf>,
        /// Write the bus log here instead of printing it.
        #[arg(long)]
        log: Option<PathBuf>,
        /// Run this long instead of the scenario's duration (e.g. 2ms, 500bits).
        #[arg(long)]
        until: Option<String>,
        /// Print what every driver reported (frames sent and received, errors, state changes).
        #[arg(long)]
        events: bool,
        /// Print only the summary; no progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Bit timing only: a lower tester sends frames with phase errors to three bit timing logics;
    /// writes a VCD and reports where each node sampled.
    SyncDemo {
        /// Where to write the waveform.
        #[arg(long, default_value = "waves/sync_demo.vcd")]
        vcd: PathBuf,
        /// Do not write a waveform.
        #[arg(long)]
        no_vcd: bool,
        /// Print only the summary line.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Fault-injection campaign: random frames from one RTL node to two others, one random fault each
    /// (a bit flipped or forced, or a glitch, seen by one node or all); prints counts per outcome and
    /// every case that broke a CAN guarantee or disagreed with the golden model.
    Campaign {
        /// Number of cases (one fault each).
        #[arg(long, default_value_t = 100_000)]
        faults: u64,
        /// Seed of the random cases.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Worker threads (default: every core).
        #[arg(long)]
        threads: Option<usize>,
        /// Run only case number CASE and print it in full.
        #[arg(long)]
        case: Option<u64>,
        /// With --case: write a VCD of that case.
        #[arg(long, requires = "case")]
        vcd: Option<PathBuf>,
        /// Run only the slice K/N of the cases (case i when i mod N = K - 1), e.g. one per machine
        /// of a cluster; merge the slices with `campaign-merge`.
        #[arg(long, default_value = "1/1", value_parser = Shard::parse, conflicts_with = "case")]
        shard: Shard,
        /// Write the counts and failures as JSON lines (the input of `campaign-merge`).
        #[arg(long, conflicts_with = "case")]
        out: Option<PathBuf>,
        /// How the cases are played: `lanes` (64 at a time in the gate-level lane model of the
        /// core) or `engine` (each alone on the simulation engine, the cores on CAN_ENGINE's
        /// model, as --case plays one); both give the same result for every case.
        #[arg(long, default_value = "lanes", conflicts_with = "case")]
        runner: String,
    },
    /// Add up campaign slices (`campaign --shard K/N --out FILE`) into the report of one run of the
    /// whole campaign; refuses slices of different campaigns, a shard given twice or missing.
    CampaignMerge {
        /// The slice files, one per shard.
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Decode the CAN bus signal of any VCD file: one candump-style line per frame, error frame and
    /// overload frame, then the count of each.
    Decode {
        /// The VCD file.
        file: PathBuf,
        /// The bus signal: its full hierarchical name (top.bus) or a trailing part of it (bus).
        #[arg(long, default_value = vcd_reader::DEFAULT_SIGNAL)]
        signal: String,
        /// Bit rate in bit/s [default: the rate the file records, else 500000].
        #[arg(long)]
        bitrate: Option<f64>,
        /// Sample point, in percent (87.5) or as a fraction (0.875) [default: the file's, else 87.5].
        #[arg(long)]
        sample_point: Option<f64>,
        /// Synchronisation jump width, in percent of the bit (6.25) or as a fraction (0.0625: a
        /// controller's 1 of 16 time quanta) [default: 25 %].
        #[arg(long)]
        sjw: Option<f64>,
        /// Say what each frame means in CANopen (NMT, SYNC, EMCY, TIME, SDO, PDO, heartbeat);
        /// NODE=EDS (e.g. 2=io.eds) names objects and decodes PDOs of that node.
        #[arg(long, num_args = 0.., value_name = "NODE=EDS")]
        canopen: Option<Vec<String>>,
        /// Also print the decoder's remarks (edges it could not follow fully, glitches, recessive
        /// reserved bits) among the events.
        #[arg(long)]
        remarks: bool,
    },
    /// Compute SJA1000 BTR0/BTR1 for a bit rate (the Linux can_calc_bittiming method).
    Bittiming {
        /// Controller clock (the SJA1000 fosc) in Hz.
        #[arg(long, default_value_t = 16_000_000)]
        clock: u32,
        /// Bit rate in bit/s.
        #[arg(long, required_unless_present = "all")]
        bitrate: Option<u32>,
        /// Sample point, in percent (87.5) or as a fraction (0.875); default 87.5 % up to 500 kbit/s,
        /// 80 % up to 800 kbit/s, 75 % above.
        #[arg(long)]
        sample_point: Option<f64>,
        /// Synchronisation jump width in time quanta (1..4).
        #[arg(long)]
        sjw: Option<u32>,
        /// Print the table for the usual bit rates.
        #[arg(long)]
        all: bool,
    },
    /// Write the controller as Verilog: DIR/can_controller.v, top module `can_controller` with the
    /// SJA1000 host port, and with --bus a wrapper top for a SoC bus (see docs/FPGA.md).
    Verilog {
        /// Output directory (created if missing).
        #[arg(long, default_value = "build/verilog")]
        out: PathBuf,
        /// The bus: native (the SJA1000 host port only), wishbone (can_controller_wb.v),
        /// axi4-lite (can_controller_axil.v) or apb (can_controller_apb.v).
        #[arg(long, default_value = "native")]
        bus: String,
    },
    /// Build the Verilator model of the controller (CAN_ENGINE=verilator) if it is not built yet;
    /// prints the path of the library. Tests and runs build it on first use as well.
    VerilatorModel,
    /// Regenerate the compiled engine's models (CAN_ENGINE=compiled) from the Verilog of rtl/
    /// through Yosys, which must be installed: the controller's (sim/src/compiled/model.rs) and the
    /// bare CAN core's (sim/src/compiled/core_model.rs); run it after every change of rtl/.
    CompiledModel {
        /// The workspace root the models' paths are relative to.
        #[arg(long, default_value = ".")]
        root: PathBuf,
    },
    /// Worst-case response-time analysis of a CAN message set: per message the worst-case frame
    /// length, blocking, queuing delay, response time and deadline verdict by the classic analysis
    /// and by the corrected analysis of Davis, Burns, Bril and Lukkien (2007), and the bus
    /// utilisation.
    #[command(long_about = RTA_HELP)]
    Rta {
        /// The message set (TOML; see docs/RTA.md and examples/rta/).
        file: PathBuf,
        /// Print CSV (one line per message) instead of the table.
        #[arg(long)]
        csv: bool,
        /// Also recreate every message's critical instant on the cycle-accurate bus and print the
        /// observed worst-case responses beside both bounds.
        #[arg(long)]
        simulate: bool,
        /// Worker threads for --simulate (default: every core).
        #[arg(long, requires = "simulate")]
        threads: Option<usize>,
    },
    /// Simulation speed on the reference workload: 16 MHz controllers at 500 kbit/s, node A sends
    /// 8-byte frames back to back through its registers, every other node reads each from its RX
    /// buffer and releases it. Prints node-pair cycles/s, frames/s and the real-time factor (median,
    /// min, max of several runs) for each node count, without and with VCD tracing, and one
    /// `BENCH ...` line per result.
    Bench {
        /// Engines of the controllers to measure (comma-separated: compiled, compiled-exhaustive,
        /// rust-hdl, rust-hdl-exhaustive, verilator)
        /// [default: the one CAN_ENGINE chooses, else compiled].
        #[arg(long, value_delimiter = ',')]
        engine: Vec<ModelEngine>,
        /// Node counts to measure (comma-separated, each at least 2).
        #[arg(long, value_delimiter = ',', default_values_t = [2, 4, 8])]
        nodes: Vec<usize>,
        /// Frames per run.
        #[arg(long, default_value_t = 100)]
        frames: usize,
        /// Bit rates to measure (comma-separated: 125k, 250k, 500k, 1M; the controllers' clock
        /// stays 16 MHz).
        #[arg(long, value_delimiter = ',', default_values_t = [BitRate::REFERENCE])]
        bit_rate: Vec<BitRate>,
        /// Runs per result (the median is reported).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Measure without VCD tracing only.
        #[arg(long)]
        no_trace: bool,
        /// Skipping of quiet clock edges to measure (comma-separated: off, on, checked; the
        /// compiled and Verilator engines skip, rust-hdl steps every edge) [default: the one
        /// CAN_SKIP_EDGES chooses, else off].
        #[arg(long, value_delimiter = ',')]
        skip_edges: Vec<EdgeSkipping>,
        /// Fault-injection cases per thread count of the campaign scaling measurement (0: skip it;
        /// a few seconds per thread count, so that starting and ending the threads do not count).
        #[arg(long, default_value_t = 2000)]
        campaign_faults: u64,
    },
}

const RTA_HELP: &str = "\
Worst-case response-time analysis of a CAN message set, two analyses side by side:
  classic    w = B + Σhp ⌈(w + J + τbit)/T⌉·C, B = max lower-priority C − τbit, R = J + w + C
             (the first instance after the critical instant only);
  corrected  Davis, Burns, Bril, Lukkien (2007): B = max lower-priority C, every instance q of
             the level-i busy period, R = max over q of J + w(q) − q·T + C.
C is the worst-case stuffed frame (44 + 8n + ⌊(34+8n)/4⌋ bits standard, 64 + 8n + ⌊(54+8n)/4⌋
extended) plus the 3-bit intermission. A message whose busy period has no end (utilisation of
its priority level ≥ 100 %) is reported as unbounded.

The file (TOML):
  bitrate = 500000                 # or: abstract = true (τbit = 1, times in units)
  title = \"Powertrain\"             # optional
  [[message]]
  name = \"EngineSpeed\"
  id = 0x0C0                       # lower identifier = higher priority
  extended = false                 # optional, 29-bit identifier
  dlc = 8                          # abstract sets: transmission = <units>
  period_ms = 10                   # abstract sets: period, jitter, deadline
  jitter_ms = 0.5                  # optional, default 0
  deadline_ms = 10                 # optional, default the period
  node = \"ECM\"                     # sending ECU (optional in abstract sets)

--simulate runs, for every message, its critical instant on the cycle-accurate bus (one RTL CAN
core per message, the longest lower-priority frame started one bit before, periodic releases for
the busy period) and prints the longest observed response of every message beside both bounds.

Exit status: 0 when the report is printed (whatever it says about deadlines); 1 for a file that
cannot be read or is invalid (the message names file and line), for --simulate on an abstract
set, or when a simulated response exceeds the corrected bound.";

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Every engine reads it; refused here with its message rather than by a panic later.
    if let Err(e) = EdgeSkipping::from_env() {
        eprintln!("cansim: {e}");
        return ExitCode::FAILURE;
    }
    let result = match cli.command.unwrap_or(Command::Demo {
        vcd: PathBuf::from(DEMO_VCD),
        log: PathBuf::from(DEMO_LOG),
        no_vcd: false,
        quiet: false,
    }) {
        Command::Demo {
            vcd,
            log,
            no_vcd,
            quiet,
        } => demo(vcd, log, no_vcd, quiet),
        Command::Run {
            scenario,
            vcd,
            log,
            until,
            events,
            quiet,
        } => run_scenario(&scenario, vcd, log, until, events, quiet),
        Command::Serve { scenario, args } => serve(&scenario, args),
        Command::Replay {
            capture,
            signal,
            bitrate,
            sample_point,
            clock,
            btr0,
            btr1,
            offset_ppm,
            compare,
            vcd,
        } => {
            let btr =
                match (btr0, btr1, bitrate) {
                    (Some(btr0), Some(btr1), _) => Ok(Btr::from_registers(btr0, btr1)),
                    (_, _, Some(bitrate)) => sample_point
                        .map(sample_point_arg)
                        .transpose()
                        .and_then(|sample_point| {
                            calc_bittiming(clock, bitrate, sample_point, None)
                                .map(|c| c.btr)
                                .map_err(|e| format!("impossible bit timing: {e}"))
                        }),
                    _ => Err("give --bitrate, or --btr0 and --btr1".to_string()),
                };
            btr.and_then(|btr| {
                replay(&ReplayOptions {
                    capture,
                    signal,
                    clock_hz: clock,
                    btr,
                    ppm: offset_ppm,
                    compare,
                    engine: None,
                    vcd: vcd.clone(),
                })
            })
        }
        Command::SyncDemo { vcd, no_vcd, quiet } => sync_demo(vcd, no_vcd, quiet),
        Command::Campaign {
            faults,
            seed,
            threads,
            case,
            vcd,
            shard,
            out,
            runner,
        } => match case {
            Some(index) => campaign_case(seed, index, vcd),
            None => campaign(faults, seed, threads, shard, out, &runner),
        },
        Command::CampaignMerge { files } => campaign_merge(&files),
        Command::Decode {
            file,
            signal,
            bitrate,
            sample_point,
            sjw,
            canopen,
            remarks,
        } => sample_point
            .map(sample_point_arg)
            .transpose()
            .and_then(|sample_point| {
                let options = DecodeOptions {
                    signal: Some(signal),
                    bitrate,
                    sample_point,
                    sjw: sjw.map(sjw_arg).transpose()?,
                };
                let canopen = canopen.map(|nodes| canopen_log(&nodes)).transpose()?;
                decode(&file, options, canopen, remarks)
            }),
        Command::Bittiming {
            clock,
            bitrate,
            sample_point,
            sjw,
            all,
        } => bittiming(clock, bitrate, sample_point, sjw, all),
        Command::Verilog { out, bus } => verilog(&out, &bus),
        Command::VerilatorModel => verilated::build_model()
            .map(|path| println!("{}", path.display()))
            .map_err(|e| e.to_string()),
        Command::CompiledModel { root } => sim::compiled::write_models(&root),
        Command::Rta {
            file,
            csv,
            simulate,
            threads,
        } => response_times(&file, csv, simulate, threads),
        Command::Bench {
            engine,
            nodes,
            frames,
            bit_rate,
            runs,
            no_trace,
            skip_edges,
            campaign_faults,
        } => bench(
            engine.clone(),
            &nodes,
            &bit_rate,
            skip_edges,
            frames,
            runs,
            no_trace,
        )
        .and_then(|()| campaign_scaling(engine, campaign_faults)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("cansim: {message}");
            ExitCode::FAILURE
        }
    }
}

/// The VCD path to write (its directory created), or `None` with `--no-vcd`.
fn vcd_path(vcd: PathBuf, no_vcd: bool) -> Result<Option<PathBuf>, String> {
    if no_vcd {
        return Ok(None);
    }
    output_path(vcd).map(Some)
}

/// An output path with its directory created.
fn output_path(path: PathBuf) -> Result<PathBuf, String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    Ok(path)
}

/// How to decode and view a VCD written with a bus of `bitrate` bit/s sampled at
/// `sample_point_pct` percent.
fn print_waves_hint(vcd: &Path, view: &Path, bitrate: f64, sample_point_pct: f64) {
    println!(
        "decode: cansim decode {0}\n        sigrok-cli -I vcd -i {0} -P can:can_rx=bus:nominal_bitrate={bitrate:.0}:sample_point={sample_point_pct} -A can=fields\nview:   gtkwave {0} {1}",
        vcd.display(),
        view.display()
    );
}

/// Where a run writes, and how long it runs.
struct Outputs {
    vcd: Option<PathBuf>,
    log: Option<PathBuf>,
    until_fs: Option<u64>,
}

/// Runs `scenario` with a progress bar on a terminal (unless `quiet`); the report and the real
/// time the run took.
fn run_with_progress(
    scenario: &Scenario,
    outputs: Outputs,
    quiet: bool,
) -> Result<(RunReport, f64), String> {
    let mut options = RunOptions {
        vcd: outputs.vcd,
        log: outputs.log,
        until_fs: outputs.until_fs,
        progress: None,
        engine: None,
        edge_skipping: None,
    };
    let show = !quiet && std::io::stderr().is_terminal();
    let mut progress = Progress::new();
    let mut draw = |simulated: u64, total: u64| {
        if let Some(line) = progress.update(simulated, total) {
            eprint!("\r{line}");
            let _ = std::io::stderr().flush();
        }
    };
    if show {
        options.progress = Some(&mut draw);
    }
    let started = Instant::now();
    let result = run(scenario, options);
    if progress.drawn() {
        eprint!("\r{:width$}\r", "", width = PROGRESS_CLEAR_WIDTH);
    }
    let report = result.map_err(|e| e.to_string())?;
    Ok((report, started.elapsed().as_secs_f64()))
}

/// Characters cleared after the progress line.
const PROGRESS_CLEAR_WIDTH: usize = 100;

/// `real time 4.2 s (1.76 ms simulated per second), peak memory 21 MB` (and the share of clock
/// edges skipped, if any).
fn speed_line(report: &RunReport, seconds: f64) -> String {
    let ms = report.simulated_fs as f64 / 1e12;
    let mut line = format!(
        "real time {seconds:.1} s ({:.2} ms simulated per second)",
        ms / seconds.max(1e-9)
    );
    if let Some(bytes) = peak_resident_bytes() {
        line += &format!(", peak memory {} MB", bytes.div_ceil(1 << 20));
    }
    if report.skipped_edges > 0 {
        line += &format!(
            ", {:.0} % of {} clock edges skipped",
            100.0 * report.skipped_edges as f64 / report.edges as f64,
            report.edges
        );
    }
    line
}

fn print_outputs(report: &RunReport, scenario: &Scenario) {
    if let Some(log) = &report.log_file {
        println!("wrote {}", log.display());
    }
    if let (Some(vcd), Some(view)) = (&report.vcd, &report.view) {
        println!("wrote {} and {}", vcd.display(), view.display());
        let bus = &scenario.bus;
        print_waves_hint(
            vcd,
            view,
            bus.btr.bitrate(f64::from(bus.clock_hz)),
            bus.btr.sample_point() * 100.0,
        );
    }
}

fn demo(vcd: PathBuf, log: PathBuf, no_vcd: bool, quiet: bool) -> Result<(), String> {
    let scenario = demo_scenario().map_err(|e| e.to_string())?;
    let outputs = Outputs {
        vcd: vcd_path(vcd, no_vcd)?,
        log: Some(output_path(log)?),
        until_fs: None,
    };
    let (report, seconds) = run_with_progress(&scenario, outputs, quiet)?;
    let parts = ReportParts {
        events: !quiet,
        ..ReportParts::default()
    };
    print!("{}", format_report(&scenario, &report, parts));
    println!("{}", speed_line(&report, seconds));
    print_outputs(&report, &scenario);
    Ok(())
}

fn run_scenario(
    path: &Path,
    vcd: Option<PathBuf>,
    log: Option<PathBuf>,
    until: Option<String>,
    events: bool,
    quiet: bool,
) -> Result<(), String> {
    let scenario = load(path).map_err(|e| e.to_string())?;
    let until_fs = until
        .map(|text| parse_time(&scenario, &text).map_err(|e| format!("--until: {e}")))
        .transpose()?;
    let outputs = Outputs {
        vcd: vcd.map(output_path).transpose()?,
        log: log.map(output_path).transpose()?,
        until_fs,
    };
    let log_to_stdout = outputs.log.is_none() && !quiet;
    let (report, seconds) = run_with_progress(&scenario, outputs, quiet)?;
    let parts = ReportParts {
        log: log_to_stdout,
        events,
        receptions: true,
    };
    print!("{}", format_report(&scenario, &report, parts));
    println!("{}", speed_line(&report, seconds));
    print_outputs(&report, &scenario);
    match report.failed_steps() {
        0 => Ok(()),
        failed => Err(format!(
            "{}: {failed} CANopen master step(s) failed (marked FAILED above)",
            path.display()
        )),
    }
}

/// The options of `cansim serve` besides the scenario.
#[derive(clap::Args)]
struct ServeArgs {
    /// Where to listen (HOST:PORT; port 0 picks a free one and prints it).
    #[arg(long, default_value = "127.0.0.1:29536")]
    listen: String,
    /// The bus name clients open.
    #[arg(long, default_value = "can0")]
    channel: String,
    /// Pace the bus to the wall clock (says so once if it cannot keep up).
    #[arg(long)]
    realtime: bool,
    /// Without --realtime: how far the bus may run past the last thing a client did.
    #[arg(long, default_value = "10ms")]
    slice: String,
    /// Stop at this simulated time (e.g. 2s, 500ms).
    #[arg(long)]
    until: Option<String>,
    /// Write a waveform of the bus and the scenario's nodes here.
    #[arg(long)]
    vcd: Option<PathBuf>,
    /// Write the bus log here as it happens (candump -l lines with error and overload frames).
    #[arg(long)]
    log: Option<PathBuf>,
}

/// Set by Ctrl-C or SIGTERM: `cansim serve` stops, finishing its files.
static STOP: AtomicBool = AtomicBool::new(false);

fn serve(path: &Path, args: ServeArgs) -> Result<(), String> {
    let scenario = load(path).map_err(|e| e.to_string())?;
    let time = |option: &str, text: &str| {
        parse_time(&scenario, text).map_err(|e| format!("--{option}: {e}"))
    };
    let slice_fs = time("slice", &args.slice)?;
    let until_fs = args
        .until
        .as_deref()
        .map(|t| time("until", t))
        .transpose()?;
    let listener = sim::serve::listen(&args.listen)?;
    let address = listener.local_addr().map_err(|e| e.to_string())?;
    ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::Relaxed) {
            std::process::exit(130);
        }
    })
    .map_err(|e| format!("cannot catch Ctrl-C: {e}"))?;
    // A closed stdout (`cansim serve | head`) must not stop the server.
    let say = |line: &str| {
        let mut out = std::io::stdout();
        let _ = writeln!(out, "{line}").and_then(|_| out.flush());
    };
    say(&format!(
        "serving {} on {address} (socketcand, raw mode, bus {}); Ctrl-C stops\n  python: \
         can.Bus(interface=\"socketcand\", host=\"{}\", port={}, channel=\"{}\")",
        path.display(),
        args.channel,
        address.ip(),
        address.port(),
        args.channel
    ));
    let options = ServeOptions {
        channel: args.channel,
        realtime: args.realtime,
        slice_fs,
        until_fs,
        vcd: args.vcd.map(output_path).transpose()?,
        log: args.log.map(output_path).transpose()?,
        engine: None,
        stop: &STOP,
    };
    let summary = sim::serve::serve(&scenario, &listener, options, &mut |line| say(line))
        .map_err(|e| e.to_string())?;
    say(&format_counts(&summary.bus));
    say(format_counts_table(&summary.nodes).trim_end());
    say(&format!(
        "simulated {} with {} clients ({:.3}x real time), peak memory {} MB",
        ms(summary.simulated_fs),
        summary.clients,
        summary.factor,
        peak_resident_bytes().unwrap_or(0).div_ceil(1 << 20)
    ));
    if let Some(vcd) = summary.vcd {
        say(&format!("wrote {}", vcd.display()));
    }
    match summary.failed_steps {
        0 => Ok(()),
        failed => Err(format!(
            "{failed} CANopen master step(s) failed or did not end (marked FAILED above)"
        )),
    }
}

fn sync_demo(vcd: PathBuf, no_vcd: bool, quiet: bool) -> Result<(), String> {
    let path = vcd_path(vcd, no_vcd)?;
    let report = sync_demo::run_demo(path.as_deref()).map_err(|e| e.to_string())?;
    if quiet {
        let verdict = if report.all_bits_right() {
            "every bit sampled right"
        } else {
            "BITS SAMPLED WRONG"
        };
        println!("cansim sync-demo: {verdict}");
    } else {
        print!("{}", sync_demo::format_report(&report));
    }
    if let Some(vcd) = &report.vcd {
        println!("wrote {}", vcd.display());
        if !quiet {
            let btr = Btr::from_registers(sync_demo::DEMO_BTR.0, sync_demo::DEMO_BTR.1);
            let bitrate = btr.bitrate(sync_demo::DEMO_CLOCK_HZ);
            let view = Path::new("waves/sync_demo.gtkw");
            print_waves_hint(vcd, view, bitrate, btr.sample_point() * 100.0);
        }
    }
    if report.all_bits_right() {
        Ok(())
    } else {
        Err("a node sampled a bit wrong".into())
    }
}

fn campaign(
    faults: u64,
    seed: u64,
    threads: Option<usize>,
    shard: Shard,
    out: Option<PathBuf>,
    runner: &str,
) -> Result<(), String> {
    if faults == 0 {
        return Err("--faults must be at least 1".into());
    }
    let threads = default_threads(threads);
    let cases = shard.len(faults);
    let runner = Runner::parse(runner, ModelEngine::from_env()?)?;
    if shard == Shard::WHOLE {
        println!(
            "cansim campaign: {faults} faults, seed {seed}, {threads} threads, runner {runner}"
        );
    } else {
        println!(
            "cansim campaign: shard {}/{} of {faults} faults ({cases} cases), seed {seed}, {threads} threads, runner {runner}",
            shard.index, shard.count
        );
    }
    let start = Instant::now();
    let last_shown = Mutex::new(Instant::now());
    let show = std::io::stderr().is_terminal();
    let progress = |done: u64| {
        let mut last = last_shown.lock().expect("progress lock");
        if show && (last.elapsed().as_millis() >= 500 || done == cases) {
            *last = Instant::now();
            let rate = done as f64 / start.elapsed().as_secs_f64();
            let eta = cases.saturating_sub(done) as f64 / rate.max(1e-9);
            eprint!("\r{done}/{cases} cases, {rate:.0} cases/s, {eta:.0} s to go   ");
        }
    };
    let summary = run_campaign_shard(seed, faults, shard, runner, threads, &progress)?;
    if show {
        eprintln!();
    }
    if let Some(path) = &out {
        let slice = Slice {
            seed,
            faults,
            shard,
            summary: summary.clone(),
        };
        write_slice(path, &slice).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("slice written to {}", path.display());
    }
    let seconds = start.elapsed().as_secs_f64();
    print!("{}", format_summary(&summary));
    println!(
        "{:.1} s, {:.0} cases/s on {threads} threads",
        seconds,
        summary.cases as f64 / seconds
    );
    if summary.failures.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} cases broke a rule; rerun one with --seed {seed} --case N",
            summary.failures.len()
        ))
    }
}

fn campaign_merge(files: &[PathBuf]) -> Result<(), String> {
    let slices = files
        .iter()
        .map(|path| read_slice(path))
        .collect::<Result<Vec<_>, _>>()?;
    let merged = merge(&slices)?;
    println!(
        "cansim campaign-merge: {} slices of {} faults, seed {}",
        slices.len(),
        merged.faults,
        merged.seed
    );
    print!("{}", format_summary(&merged.summary));
    if merged.summary.failures.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} cases broke a rule; rerun one with --seed {} --case N",
            merged.summary.failures.len(),
            merged.seed
        ))
    }
}

fn campaign_case(seed: u64, index: u64, vcd: Option<PathBuf>) -> Result<(), String> {
    let case = random_case(&mut Rng::for_case(seed, index));
    let path = vcd.map(|v| vcd_path(v, false)).transpose()?.flatten();
    let model = ModelEngine::from_env()?;
    let run = run_rtl_on(&case, model, path.as_deref()).map_err(|e| e.to_string())?;
    let verdict = check(&case, &run);
    println!(
        "case {index} of seed {seed}:\n{}outcome {:?}",
        describe(&case, &run),
        verdict.outcome
    );
    if verdict.violations.is_empty() {
        Ok(())
    } else {
        Err(verdict.violations.join("; "))
    }
}

fn default_threads(threads: Option<usize>) -> usize {
    threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1)
}

fn response_times(
    file: &std::path::Path,
    csv: bool,
    simulate: bool,
    threads: Option<usize>,
) -> Result<(), String> {
    let set = rta::message_set::MessageSet::load(file).map_err(|e| e.to_string())?;
    let analysis = rta::analysis::Analysis::of(&set);
    let simulation = simulate
        .then(|| simulate_with_progress(&set, &analysis, default_threads(threads)))
        .transpose()?;
    if csv {
        let sim = simulation.as_ref();
        print!("{}", rta::report::format_csv(&set, &analysis, sim));
    } else {
        print!("{}", rta::report::format_table(&set, &analysis));
        if let Some(sim) = &simulation {
            print!("{}", rta::report::format_simulation(&set, &analysis, sim));
        }
    }
    let violations =
        simulation.map_or(Vec::new(), |sim| rta::simulate::violations(&analysis, &sim));
    if violations.is_empty() {
        return Ok(());
    }
    let names: Vec<&str> = violations
        .iter()
        .map(|&i| set.messages[i].name.as_str())
        .collect();
    Err(format!(
        "observed responses exceed the corrected bound: {}",
        names.join(", ")
    ))
}

/// `rta::simulate::simulate`, with progress on stderr when that is a terminal.
fn simulate_with_progress(
    set: &rta::message_set::MessageSet,
    analysis: &rta::analysis::Analysis,
    threads: usize,
) -> Result<rta::simulate::Simulation, String> {
    let start = Instant::now();
    let show = std::io::stderr().is_terminal();
    let progress = |done: usize, total: usize| {
        if show {
            eprint!("\rsimulating critical instants: {done}/{total}   ");
        }
    };
    let sim = rta::simulate::simulate(set, analysis, threads, &progress)?;
    if show {
        let seconds = start.elapsed().as_secs_f64();
        eprintln!(
            "\rsimulated {} critical instants in {seconds:.1} s",
            set.messages.len()
        );
    }
    Ok(sim)
}

/// `--sample-point` accepts percent (87.5) or a fraction (0.875).
/// A register value: `0x1C`, `1c` with 0x, or decimal.
fn register_arg(text: &str) -> Result<u8, String> {
    let parsed = match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(hex) => u8::from_str_radix(hex, 16),
        None => text.parse(),
    };
    parsed.map_err(|_| format!("`{text}` is not a register value (0x00..0xFF or 0..255)"))
}

/// Replays a capture: prints the report; an error when `--compare` finds a difference.
fn replay(options: &ReplayOptions) -> Result<(), String> {
    let outcome = sim::workloads::replay::replay(options).map_err(|e| e.to_string())?;
    print!("{}", outcome.text);
    match outcome.agrees {
        Some(false) => Err("the controller and the software decoder disagree".to_string()),
        _ => Ok(()),
    }
}

fn sample_point_arg(value: f64) -> Result<f64, String> {
    sample_point_fraction(value).ok_or_else(|| {
        format!(
            "--sample-point {value} is out of range: give a percentage between 0 and 100 (87.5) or a fraction between 0 and 1 (0.875)"
        )
    })
}

/// An SJW in percent of the bit or as a fraction of it.
fn sjw_arg(value: f64) -> Result<f64, String> {
    sample_point_fraction(value).ok_or_else(|| {
        format!(
            "--sjw {value} is out of range: a percentage of the bit (6.25) or a fraction (0.0625)"
        )
    })
}

/// The CANopen log of `--canopen NODE=EDS …`.
fn canopen_log(nodes: &[String]) -> Result<CanopenLog, String> {
    let devices = nodes
        .iter()
        .map(|text| {
            let (node, eds) = text
                .split_once('=')
                .ok_or_else(|| format!("--canopen {text}: expected NODE=EDS, e.g. 2=io.eds"))?;
            let node_id = node
                .trim()
                .parse::<u8>()
                .ok()
                .filter(|id| (1..=127).contains(id))
                .ok_or_else(|| {
                    format!("--canopen {text}: node-ID {node} is out of range 1..=127")
                })?;
            let od = canopen::eds::load(Path::new(eds), node_id).map_err(|e| e.to_string())?;
            Ok((node_id, od))
        })
        .collect::<Result<Vec<_>, String>>()?;
    Ok(CanopenLog::new(devices))
}

fn decode(
    file: &Path,
    options: DecodeOptions,
    mut canopen: Option<CanopenLog>,
    show_remarks: bool,
) -> Result<(), String> {
    let decoded = decode_vcd(file, &options).map_err(|e| e.to_string())?;
    let source = match decoded.file_timing {
        Some(recorded) if recorded == decoded.timing => " (recorded in the file)",
        _ => "",
    };
    println!(
        "{} {} at {}{source}",
        file.display(),
        decoded.signal,
        decoded.timing
    );
    let remarks: &[Remark] = if show_remarks { &decoded.remarks } else { &[] };
    let mut remarks = remarks.iter().peekable();
    for event in &decoded.events {
        while let Some(remark) = remarks.next_if(|r| r.t_fs < event.start_fs) {
            println!("{remark}");
        }
        match &mut canopen {
            Some(canopen) => println!("{}", canopen.line(event)),
            None => println!("{event}"),
        }
    }
    remarks.for_each(|remark| println!("{remark}"));
    if !show_remarks && !decoded.remarks.is_empty() {
        let n = decoded.remarks.len();
        let plural = if n == 1 { "" } else { "s" };
        println!("{n} remark{plural} (--remarks shows them)");
    }
    if decoded.undefined_values > 0 {
        println!(
            "{} x/z values of {} read as recessive",
            decoded.undefined_values, decoded.signal
        );
    }
    println!("{}", EventCounts::of(&decoded.events));
    Ok(())
}

fn bittiming(
    clock: u32,
    bitrate: Option<u32>,
    sample_point: Option<f64>,
    sjw: Option<u32>,
    all: bool,
) -> Result<(), String> {
    if all {
        print!("{}", format_table(clock));
        return Ok(());
    }
    let bitrate = bitrate.ok_or("--bitrate is required without --all")?;
    let sample_point = sample_point.map(sample_point_arg).transpose()?;
    let calc = calc_bittiming(clock, bitrate, sample_point, sjw).map_err(|e| e.to_string())?;
    print!("{}", format_calculation(clock, &calc));
    Ok(())
}

fn verilog(out: &Path, bus: &str) -> Result<(), String> {
    use sim::verilated::verilog::{write_bus_verilog, Bus};
    let bus = Bus::from_name(bus).map_err(|e| format!("--bus: {e}"))?;
    for path in write_bus_verilog(out, bus).map_err(|e| e.to_string())? {
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// `cansim bench`: the reference workload on each engine, node count and trace setting.
fn bench(
    engines: Vec<ModelEngine>,
    nodes: &[usize],
    bit_rates: &[BitRate],
    skip_edges: Vec<EdgeSkipping>,
    frames: usize,
    runs: usize,
    no_trace: bool,
) -> Result<(), String> {
    if runs == 0 || frames == 0 {
        return Err("--runs and --frames must be at least 1".into());
    }
    let most = sim::workloads::bench::MAX_NODES;
    if let Some(n) = nodes.iter().find(|&&n| !(2..=most).contains(&n)) {
        return Err(format!("--nodes {n}: the workload needs 2 to {most} nodes"));
    }
    let engines = if engines.is_empty() {
        vec![ModelEngine::from_env()?]
    } else {
        engines
    };
    let skip_edges = if skip_edges.is_empty() {
        vec![EdgeSkipping::from_env()?]
    } else {
        skip_edges
    };
    let skip_edges = skip_edges.as_slice();
    let trace_file = std::env::temp_dir().join(format!("cansim-bench-{}.vcd", std::process::id()));
    let traces: &[bool] = if no_trace { &[false] } else { &[false, true] };
    println!(
        "reference workload: {frames} frames of 8 bytes, 16 MHz; median of {runs} runs (min..max)"
    );
    println!(
        "{:<10} {:>5} {:>5} {:>5} {:>7} {:>28} {:>12} {:>10} {:>10}",
        "engine",
        "nodes",
        "bit/s",
        "trace",
        "skip",
        "node-pair cycles/s",
        "per CPU s",
        "frames/s",
        "real time"
    );
    let progress = std::io::stderr().is_terminal();
    let mut lines = Vec::new();
    let cases = engines.iter().flat_map(|&engine| {
        nodes.iter().flat_map(move |&n| {
            bit_rates
                .iter()
                .flat_map(move |&rate| skip_edges.iter().map(move |&skip| (engine, n, rate, skip)))
        })
    });
    for (engine, n, rate, skip) in cases {
        // Runs with and without tracing alternate, so that a change in the machine's speed
        // during the measurement does not show up as a cost of tracing.
        let mut results: Vec<Vec<sim::workloads::bench::BenchRun>> = vec![Vec::new(); traces.len()];
        for run in 0..runs {
            for (k, &trace) in traces.iter().enumerate() {
                if progress {
                    eprint!(
                        "\r{engine}, {n} nodes, {rate}bit/s, trace {}, skip {}: run {}/{runs} ",
                        on_off(trace),
                        skip.name(),
                        run + 1
                    );
                }
                let path = trace.then_some(&trace_file);
                let result =
                    sim::workloads::bench::run_workload(engine, n, frames, rate, path, skip);
                results[k].push(result.map_err(|e| e.to_string())?);
            }
        }
        if progress {
            eprint!("\r{:60}\r", "");
        }
        if let [off, on] = results.as_slice() {
            lines.push(sim::workloads::bench::trace_cost_line(
                engine.name(),
                n,
                rate,
                skip,
                off,
                on,
            ));
        }
        for (&trace, runs) in traces.iter().zip(results) {
            let s = sim::workloads::bench::summarise(runs);
            println!(
                "{:<10} {n:>5} {rate:>5} {:>5} {:>7} {:>10.0} ({:.0}..{:.0}) {:>12.0} {:>10.1} {:>9.4}x",
                engine.name(),
                on_off(trace),
                skip.name(),
                s.median.pair_cycles_per_s,
                s.min.pair_cycles_per_s,
                s.max.pair_cycles_per_s,
                s.median.pair_cycles_per_cpu_s,
                s.median.frames_per_s,
                s.median.real_time_factor()
            );
            lines.push(sim::workloads::bench::bench_line(
                engine.name(),
                n,
                rate,
                trace,
                skip,
                &s,
            ));
        }
    }
    for line in lines {
        println!("{line}");
    }
    Ok(())
}

fn on_off(flag: bool) -> &'static str {
    if flag {
        "on"
    } else {
        "off"
    }
}

/// Campaign throughput with the lane runner and with each engine (the bare cores have no
/// Verilator model) on 1, 2, ... threads up to the number of cores.
fn campaign_scaling(engines: Vec<ModelEngine>, faults: u64) -> Result<(), String> {
    if faults == 0 {
        return Ok(());
    }
    let engines = if engines.is_empty() {
        vec![ModelEngine::from_env()?]
    } else {
        engines
    };
    let cores = default_threads(None);
    let mut runners = vec![Runner::Lanes];
    for engine in engines {
        if engine == ModelEngine::Verilator {
            println!("fault-injection campaign: no Verilator model of the bare core, skipped");
        } else {
            runners.push(Runner::Engine(engine));
        }
    }
    for runner in runners {
        println!(
            "fault-injection campaign, runner {runner}: {faults} cases per thread count, {cores} cores"
        );
        println!("{:>7} {:>10} {:>8}", "threads", "cases/s", "speedup");
        let name = match runner {
            Runner::Lanes => "lanes".to_string(),
            Runner::Engine(engine) => engine.to_string(),
        };
        let mut single = None;
        for threads in 1..=cores {
            let rate = sim::workloads::bench::campaign_rate(1, faults, runner, threads)
                .map_err(|e| e.to_string())?;
            let speedup = rate / *single.get_or_insert(rate);
            println!("{threads:>7} {rate:>10.1} {speedup:>7.2}x");
            println!(
                "BENCH campaign engine={name} threads={threads} cases_per_s={rate:.1} \
                 speedup={speedup:.2}"
            );
        }
    }
    Ok(())
}
