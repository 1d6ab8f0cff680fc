//! The engine choice from the command line: `CAN_ENGINE`, `cansim verilator-model` and
//! `cansim bench`; bad values and a missing Verilator fail with a message saying what to do and a
//! non-zero exit.

mod common;

use std::path::PathBuf;
use std::process::Output;

use common::{cansim_with_env as cansim, example, text};

#[test]
fn a_bad_can_engine_stops_a_run_naming_the_allowed_values() {
    let out = cansim(
        &["run", "-q", &example("replay.toml")],
        &[("CAN_ENGINE", "verilog")],
    );
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(text(&out.stdout), "");
    assert_eq!(
        text(&out.stderr),
        "cansim: CAN_ENGINE=`verilog` is not an engine: use `rust-hdl`, `rust-hdl-exhaustive`, \
         `verilator`, `compiled` or `compiled-exhaustive` (the default is `compiled`)\n"
    );
}

#[test]
fn a_bad_can_skip_edges_stops_a_run_naming_the_allowed_values() {
    let out = cansim(
        &["run", "-q", &example("replay.toml")],
        &[("CAN_SKIP_EDGES", "yes")],
    );
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(text(&out.stdout), "");
    assert_eq!(
        text(&out.stderr),
        "cansim: CAN_SKIP_EDGES=`yes` is not an edge skipping mode: use `off` (the default), `on` \
         or `checked`\n"
    );
}

#[test]
fn a_run_with_edges_skipped_says_how_many() {
    let out = cansim(
        &["run", &example("replay.toml")],
        &[("CAN_SKIP_EDGES", "on")],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let speed = stdout
        .lines()
        .find(|l| l.starts_with("real time "))
        .unwrap_or_else(|| panic!("no speed line: {stdout}"));
    assert!(
        speed.contains(" % of ") && speed.ends_with(" clock edges skipped"),
        "{speed}"
    );
    let plain = cansim(
        &["run", &example("replay.toml")],
        &[("CAN_SKIP_EDGES", "off")],
    );
    assert!(
        !text(&plain.stdout).contains("skipped"),
        "{}",
        text(&plain.stdout)
    );
}

#[test]
fn without_verilator_the_engine_says_how_to_install_it() {
    let out = cansim(&["verilator-model"], &[("PATH", "")]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(
        err.contains("needs Verilator") && err.contains("./scripts/install-tools.sh"),
        "{err}"
    );
}

#[test]
fn verilator_model_prints_the_cached_library() {
    let out = cansim(&["verilator-model"], &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let path = PathBuf::from(text(&out.stdout).trim_end());
    assert!(path.is_file(), "{}", path.display());
    assert_eq!(path.extension().unwrap(), "so");
    assert_eq!(path.parent().unwrap().file_name().unwrap(), "verilator");
}

/// `cansim bench` with the shortest runs, then `extra`.
fn quick_bench(extra: &[&str], env: &[(&str, &str)]) -> Output {
    let mut args = vec![
        "bench",
        "--frames",
        "2",
        "--runs",
        "1",
        "--no-trace",
        "--campaign-faults",
        "0",
    ];
    args.extend(extra);
    cansim(&args, env)
}

#[test]
fn bench_measures_each_engine_asked_for() {
    let out = quick_bench(&["--nodes", "3", "--engine", "rust-hdl,verilator"], &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let bench_lines: Vec<&str> = stdout.lines().filter(|l| l.starts_with("BENCH")).collect();
    assert_eq!(bench_lines.len(), 2, "{stdout}");
    for (line, engine) in bench_lines.iter().zip(["rust-hdl", "verilator"]) {
        let prefix = format!(
            "BENCH engine={engine} nodes=3 bit_rate=500k trace=off skip_edges=off pair_cycles_per_s="
        );
        assert!(line.starts_with(&prefix), "{line}");
        assert!(line.contains(" pair_cycles_per_cpu_s="), "{line}");
    }
    // Without --engine, CAN_ENGINE chooses.
    let out = quick_bench(&["--nodes", "3"], &[("CAN_ENGINE", "verilator")]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("\nBENCH engine=verilator nodes=3"),
        "{stdout}"
    );
}

#[test]
fn bench_refuses_a_single_node_and_an_unknown_engine() {
    let out = cansim(&["bench", "--nodes", "1", "--engine", "rust-hdl"], &[]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        text(&out.stderr),
        "cansim: --nodes 1: the workload needs 2 to 128 nodes\n"
    );
    let out = cansim(&["bench", "--engine", "icarus"], &[]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("`icarus` is not an engine"),
        "{}",
        text(&out.stderr)
    );
    let out = cansim(&["bench", "--bit-rate", "2M"], &[]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("bit rate \"2M\": one of 125k, 250k, 500k, 1M"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn bench_measures_each_bit_rate_asked_for() {
    let out = quick_bench(
        &[
            "--nodes",
            "2",
            "--engine",
            "compiled",
            "--bit-rate",
            "125k,1M",
        ],
        &[],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let rates: Vec<&str> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("BENCH engine=compiled nodes=2 bit_rate="))
        .map(|rest| rest.split(' ').next().unwrap())
        .collect();
    assert_eq!(rates, ["125k", "1M"], "{stdout}");
}

/// `cansim campaign` names its runner, gives the same counts with both, and refuses an unknown one.
#[test]
fn the_campaign_runs_in_lanes_or_on_the_engine_with_the_same_counts() {
    let counts = |runner: &str| {
        let out = cansim(
            &[
                "campaign", "--faults", "70", "--seed", "5", "--runner", runner,
            ],
            &[],
        );
        assert!(out.status.success(), "{}", text(&out.stderr));
        let stdout = text(&out.stdout);
        let first = stdout.lines().next().unwrap_or_default().to_string();
        let rows: Vec<String> = stdout
            .lines()
            .skip(1)
            .filter(|l| !l.contains("cases/s"))
            .map(str::to_string)
            .collect();
        (first, rows)
    };
    let (lanes_line, lanes) = counts("lanes");
    let (engine_line, engine) = counts("engine");
    assert!(lanes_line.ends_with("runner lanes (64 cases per evaluation of the gate-level core)"));
    assert!(
        engine_line.ends_with("runner engine, cores on compiled"),
        "{engine_line}"
    );
    assert_eq!(lanes, engine);
    assert!(
        lanes.iter().any(|l| l.starts_with("  Recovered")),
        "{lanes:?}"
    );

    let out = cansim(&["campaign", "--faults", "3", "--runner", "fast"], &[]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        text(&out.stderr),
        "cansim: `fast` is not a campaign runner: use `lanes` (the default) or `engine`\n"
    );
}
