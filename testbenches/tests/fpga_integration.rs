//! What an FPGA engineer gets without Rust: the generated Verilog shipped in fpga/rtl/ (kept equal to
//! `cansim verilog`), the Verilator waivers shipped beside it (fpga/can_controller.vlt: with them
//! `-Wall` reports nothing on the controller and every wrapper), the FuseSoC core
//! (can_controller.core: its `lint` and `sim` targets, fusesoc 2.4.3 from build/pyenv) and the
//! LiteX peripheral (fpga/litex/: a minimal LiteX 2024.12 SoC with the controller on its Wishbone bus
//! elaborates, and its Verilog lints with no warning from our files); the iCEBreaker design
//! (fpga/boards/icebreaker/: its serial register bridge and two controllers, in Icarus).

use std::path::{Path, PathBuf};
use std::process::Command;

use sim::verilated::verilog::{controller_verilog_file, wrapper_file, Bus};
use testbenches::equivalence::Simulator;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn pyenv(tool: &str) -> PathBuf {
    let path = workspace().join("build/pyenv/bin").join(tool);
    assert!(
        path.exists(),
        "{} is missing: run `make pyenv`",
        path.display()
    );
    path
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

const TOPS: [(&str, &[&str]); 4] = [
    ("can_controller", &["can_controller.v"]),
    (
        "can_controller_wb",
        &["can_controller_wb.v", "can_controller.v"],
    ),
    (
        "can_controller_axil",
        &["can_controller_axil.v", "can_controller.v"],
    ),
    (
        "can_controller_apb",
        &["can_controller_apb.v", "can_controller.v"],
    ),
];

#[test]
fn the_shipped_verilog_is_what_cansim_verilog_writes() {
    let rtl = workspace().join("fpga/rtl");
    let read = |name: &str| std::fs::read_to_string(rtl.join(name)).unwrap();
    assert!(
        read("can_controller.v") == controller_verilog_file(),
        "fpga/rtl/can_controller.v is stale: run `make fpga-rtl`"
    );
    for bus in [Bus::Wishbone, Bus::AxiLite, Bus::Apb] {
        assert!(
            read(&bus.file_name()) == wrapper_file(bus),
            "fpga/rtl/{} is stale: run `make fpga-rtl`",
            bus.file_name()
        );
    }
}

#[test]
fn with_the_shipped_waivers_verilator_wall_says_nothing() {
    if !Simulator::Verilator.available() {
        panic!("verilator not on PATH: run `make tools`");
    }
    let fpga = workspace().join("fpga");
    for (top, files) in TOPS {
        let out = Command::new("verilator")
            .args(["--lint-only", "-Wall", "--top-module", top])
            .arg(fpga.join("can_controller.vlt"))
            .args(files.iter().map(|f| fpga.join("rtl").join(f)))
            .output()
            .expect("verilator");
        let said = text(&out.stderr);
        assert!(
            out.status.success() && said.trim().is_empty(),
            "{top}: {said}"
        );
    }
}

#[test]
fn fusesoc_lint_and_sim_targets_pass() {
    let build = std::env::temp_dir().join(format!("cansim-fusesoc-{}", std::process::id()));
    for target in ["lint", "sim"] {
        let out = Command::new(pyenv("fusesoc"))
            .arg("--cores-root")
            .arg(workspace())
            .args(["run", "--build-root"])
            .arg(&build)
            .args(["--target", target, "cansim:can:can_controller"])
            .output()
            .expect("fusesoc");
        let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
        assert!(out.status.success(), "fusesoc --target {target}:\n{said}");
        if target == "sim" {
            assert!(said.contains("PASS"), "{said}");
        }
    }
    std::fs::remove_dir_all(&build).ok();
}

#[test]
fn a_litex_soc_with_the_controller_elaborates_and_lints() {
    let out_dir = std::env::temp_dir().join(format!("cansim-litex-{}", std::process::id()));
    let litex = workspace().join("fpga/litex");
    let out = Command::new(pyenv("python"))
        .arg(litex.join("minimal_soc.py"))
        .arg(&out_dir)
        .arg(workspace().join("fpga/rtl"))
        .current_dir(&litex)
        .output()
        .expect("python");
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let soc = out_dir.join("cansoc.v");
    let verilog = std::fs::read_to_string(&soc).unwrap();
    assert!(
        verilog.contains("can_controller_wb #("),
        "the controller is instantiated"
    );
    let fpga = workspace().join("fpga");
    let lint = Command::new("verilator")
        .args(["--lint-only", "-Wall", "--top-module", "cansoc"])
        .arg(fpga.join("can_controller.vlt"))
        .arg(&soc)
        .arg(fpga.join("rtl/can_controller_wb.v"))
        .arg(fpga.join("rtl/can_controller.v"))
        .output()
        .expect("verilator");
    let said = text(&lint.stderr);
    let errors: Vec<&str> = said
        .lines()
        .filter(|l| l.starts_with("%Error") && !l.starts_with("%Error: Exiting due to"))
        .collect();
    assert!(errors.is_empty(), "{errors:#?}");
    // LiteX's own Verilog has its warnings; ours (the controller and the wrapper) has none.
    let ours: Vec<&str> = said
        .lines()
        .filter(|l| l.starts_with("%Warning") && l.contains("can_controller"))
        .collect();
    assert!(ours.is_empty(), "{ours:#?}");
    std::fs::remove_dir_all(&out_dir).ok();
}

#[test]
fn the_icebreaker_design_bridges_the_serial_port_to_both_controllers() {
    // tb_icebreaker_can.v: the host configures both controllers over the serial line, node 0 sends
    // a frame over the PMOD pins joined as one bus, the host reads it back from node 1 (SJA1000
    // register values: CR 21h after reset, IR 01h, the RX buffer) and checks the LEDs.
    let board = workspace().join("fpga/boards/icebreaker");
    let dir = std::env::temp_dir().join(format!("cansim-icebreaker-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vvp = dir.join("tb.vvp");
    let compile = Command::new("iverilog")
        .args(["-g2005", "-Wall", "-s", "tb_icebreaker_can", "-o"])
        .arg(&vvp)
        .args(
            [
                "tb_icebreaker_can.v",
                "icebreaker_can.v",
                "uart_rx.v",
                "uart_tx.v",
            ]
            .iter()
            .map(|f| board.join(f)),
        )
        .arg(workspace().join("fpga/rtl/can_controller.v"))
        .output()
        .expect("iverilog");
    let said = format!("{}{}", text(&compile.stdout), text(&compile.stderr));
    assert!(compile.status.success() && said.trim().is_empty(), "{said}");
    let run = Command::new("vvp")
        .arg("-n")
        .arg(&vvp)
        .output()
        .expect("vvp");
    let out = text(&run.stdout);
    assert!(run.status.success() && out.contains("PASS"), "{out}");
    let lint = Command::new("verilator")
        .args(["--lint-only", "-Wall", "--top-module", "icebreaker_can"])
        .arg(workspace().join("fpga/can_controller.vlt"))
        .args(
            ["icebreaker_can.v", "uart_rx.v", "uart_tx.v"]
                .iter()
                .map(|f| board.join(f)),
        )
        .arg(workspace().join("fpga/rtl/can_controller.v"))
        .output()
        .expect("verilator");
    assert!(
        lint.status.success() && text(&lint.stderr).trim().is_empty(),
        "{}",
        text(&lint.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}
