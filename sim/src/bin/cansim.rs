//! `cansim`: the command line tool of the CAN controller project. Without a subcommand it runs the demo.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use sim::btr::{calc_bittiming, format_calculation, format_table};
use sim::demo::{format_report, run_demo};

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
    /// Lower tester sends frames with phase errors to three nodes; writes a VCD and reports where each
    /// node sampled (the default command).
    Demo {
        /// Where to write the waveform.
        #[arg(long, default_value = "waves/demo.vcd")]
        vcd: PathBuf,
        /// Do not write a waveform.
        #[arg(long)]
        no_vcd: bool,
        /// Print only the summary line.
        #[arg(long, short)]
        quiet: bool,
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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command.unwrap_or(Command::Demo {
        vcd: PathBuf::from("waves/demo.vcd"),
        no_vcd: false,
        quiet: false,
    }) {
        Command::Demo { vcd, no_vcd, quiet } => demo(vcd, no_vcd, quiet),
        Command::Bittiming {
            clock,
            bitrate,
            sample_point,
            sjw,
            all,
        } => bittiming(clock, bitrate, sample_point, sjw, all),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("cansim: {message}");
            ExitCode::FAILURE
        }
    }
}

fn demo(vcd: PathBuf, no_vcd: bool, quiet: bool) -> Result<(), String> {
    let path = (!no_vcd).then_some(vcd);
    if let Some(dir) = path
        .as_ref()
        .and_then(|p| p.parent())
        .filter(|d| !d.as_os_str().is_empty())
    {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let report = run_demo(path.as_deref()).map_err(|e| e.to_string())?;
    if quiet {
        let verdict = if report.all_bits_right() {
            "every bit sampled right"
        } else {
            "BITS SAMPLED WRONG"
        };
        println!("cansim demo: {verdict}");
    } else {
        print!("{}", format_report(&report));
    }
    if let Some(vcd) = &report.vcd {
        println!("wrote {}", vcd.display());
        if !quiet {
            println!(
                "decode: sigrok-cli -I vcd -i {0} -P can:can_rx=bus:nominal_bitrate=500000:sample_point=87.5 -A can=fields\nview:   gtkwave {0} waves/demo.gtkw",
                vcd.display()
            );
        }
    }
    if report.all_bits_right() {
        Ok(())
    } else {
        Err("a node sampled a bit wrong".into())
    }
}

/// `--sample-point` accepts percent (87.5) or a fraction (0.875).
fn sample_point_fraction(value: f64) -> Result<f64, String> {
    match value {
        v if v > 0.0 && v < 1.0 => Ok(v),
        v if v > 1.0 && v < 100.0 => Ok(v / 100.0),
        v => Err(format!(
            "--sample-point {v} is out of range: give a percentage between 0 and 100 (87.5) or a fraction between 0 and 1 (0.875)"
        )),
    }
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
    let sample_point = sample_point.map(sample_point_fraction).transpose()?;
    let calc = calc_bittiming(clock, bitrate, sample_point, sjw).map_err(|e| e.to_string())?;
    print!("{}", format_calculation(clock, &calc));
    Ok(())
}
