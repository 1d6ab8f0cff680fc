//! Lint of the generated Verilog (`cansim verilog`): Verilator `-Wall` shows only the warning
//! categories docs/VERILOG.md explains, no WIDTH warning of a kind that makes the Verilog behave
//! differently from the rust-hdl model, and Icarus `-Wall` prints nothing.
//!
//! Needs `verilator` and `iverilog` (`make tools`); a developer without them may skip with
//! `CANSIM_SKIP_ICARUS=1` (Icarus) or `CANSIM_SKIP_VERILATOR=1` (Verilator).

use std::path::PathBuf;
use std::process::Command;

use sim::verilated::verilog::{
    wrapper_verilog, write_bus_verilog, write_controller_verilog, Bus, TOP_MODULE,
};
use testbenches::equivalence::{icarus_skipped, Simulator};
use testbenches::lint::{
    negation_patterns, verilator_lint, verilator_lint_files, EXPLAINED_CATEGORIES,
};

/// Environment variable that lets a developer without Verilator skip the Verilator lint.
const SKIP_VERILATOR_ENV: &str = "CANSIM_SKIP_VERILATOR";

fn verilog_file(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("verilog_lint_{name}_{}", std::process::id()));
    write_controller_verilog(&dir).expect("write the Verilog")
}

fn verilator_skipped(test: &str) -> bool {
    if Simulator::Verilator.available() {
        return false;
    }
    if std::env::var_os(SKIP_VERILATOR_ENV).is_some() {
        eprintln!("{test}: skipped, verilator not on PATH and {SKIP_VERILATOR_ENV} set");
        return true;
    }
    panic!(
        "{test}: verilator not on PATH: run `make tools`, or set {SKIP_VERILATOR_ENV}=1 to skip"
    );
}

#[test]
fn verilator_wall_shows_only_explained_categories_and_no_suspicious_width() {
    if verilator_skipped("verilator_wall_shows_only_explained_categories_and_no_suspicious_width") {
        return;
    }
    let file = verilog_file("verilator");
    let report = verilator_lint(&file, TOP_MODULE).expect("verilator");
    eprintln!(
        "Verilator -Wall: {:?}\nWIDTH kinds: {:?}",
        report.categories, report.width_kinds
    );
    assert!(report.errors.is_empty(), "errors: {:#?}", report.errors);
    assert!(
        report.unexplained().is_empty(),
        "categories not explained in docs/VERILOG.md (explained: {EXPLAINED_CATEGORIES:?}): {:?}",
        report.unexplained()
    );
    assert!(
        report.suspicious.is_empty(),
        "WIDTH warnings on a comparison of arithmetic (silently different in Verilog):\n{}",
        report.suspicious.join("\n")
    );
    let _ = std::fs::remove_dir_all(file.parent().unwrap());
}

#[test]
fn no_negation_is_widened_before_it_applies() {
    let verilog = sim::verilated::verilog::controller_verilog();
    let found = negation_patterns(&verilog);
    assert!(
        found.is_empty(),
        "negations inside shifts or compared with 0:\n{}",
        found.join("\n")
    );
}

#[test]
fn icarus_wall_is_silent() {
    if icarus_skipped("icarus_wall_is_silent") {
        return;
    }
    let file = verilog_file("icarus");
    let out = Command::new("iverilog")
        .args(["-g2005", "-Wall", "-o", "/dev/null"])
        .arg(&file)
        .output()
        .expect("iverilog");
    let printed = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success() && printed.trim().is_empty(),
        "iverilog -Wall: {printed}"
    );
    let _ = std::fs::remove_dir_all(file.parent().unwrap());
}

/// The bus wrappers, each with the controller: Verilator `-Wall` shows only the explained
/// categories (no UNOPTFLAT, LATCH, UNDRIVEN...), no suspicious WIDTH, no widened negation, and
/// Icarus `-Wall` prints nothing.
#[test]
fn the_bus_wrappers_lint_like_the_controller() {
    let skip_verilator = verilator_skipped("the_bus_wrappers_lint_like_the_controller");
    let skip_icarus = icarus_skipped("the_bus_wrappers_lint_like_the_controller");
    let dir = std::env::temp_dir().join(format!("verilog_lint_wrappers_{}", std::process::id()));
    for bus in [Bus::Wishbone, Bus::AxiLite, Bus::Apb] {
        let files = write_bus_verilog(&dir, bus).expect("write the Verilog");
        let paths: Vec<&std::path::Path> = files.iter().map(PathBuf::as_path).collect();
        let top = bus.top_module();
        let found = negation_patterns(&wrapper_verilog(bus));
        assert!(found.is_empty(), "{top}: {}", found.join("\n"));
        if !skip_verilator {
            let report = verilator_lint_files(&paths, top).expect("verilator");
            assert!(report.errors.is_empty(), "{top}: {:#?}", report.errors);
            assert!(
                report.unexplained().is_empty(),
                "{top}: {:?}",
                report.unexplained()
            );
            assert!(
                report.suspicious.is_empty(),
                "{top}: {:?}",
                report.suspicious
            );
        }
        if !skip_icarus {
            let out = Command::new("iverilog")
                .args(["-g2005", "-Wall", "-o", "/dev/null", "-s", top])
                .args(&paths)
                .output()
                .expect("iverilog");
            let printed = format!(
                "{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            assert!(
                out.status.success() && printed.trim().is_empty(),
                "{top}: iverilog -Wall: {printed}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
