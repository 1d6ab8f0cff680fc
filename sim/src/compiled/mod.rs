//! The compiled engine: the controller's generated Verilog, read by Yosys into a word-level netlist
//! and turned into straight-line Rust (`model.rs`, checked in), stepped one clock cycle per call
//! with the semantics of the other engines: inputs applied before the rising edge, outputs read
//! after it with the clock low. The CAN core alone (the bare nodes of the fault campaign) is
//! compiled the same way (`core_model.rs`, [`core`]).
//!
//! No tool is needed to run it: the models are generated ahead (`cansim compiled-model`, `make
//! compiled-model`, which need Yosys) and compiled with the rest of the crate. A model older than
//! `rtl/` is refused at start with the command that regenerates it: the file records a hash of the
//! Verilog it was made from, checked against the Verilog of the running build once per process.
//!
//! Why it is fast: every cell is one or two machine operations on a `u64` in a fixed order, with no
//! per-signal bookkeeping; the cells are grouped by rust-hdl block and a group runs only when
//! something it reads changed (`groups`, `emit`); a cycle whose inputs did not change evaluates
//! once (after the edge), as the Verilator wrapper does.

mod cells;
pub mod core;
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, unused_parens)]
mod core_model;
mod emit;
mod groups;
pub mod lane_core;
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, unused_parens)]
mod lane_model;
mod lanes;
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, unused_parens)]
mod model;
mod netlist;
pub(crate) mod quiet;

use std::io::Write as _;
use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;

use crate::verilated::sources::{
    INTERNAL_SHIFTS, INTERNAL_SIGNALS, IN_ADDR, IN_RE, IN_RESET, IN_RX, IN_WDATA, IN_WE,
    OUT_CLKOUT, OUT_IRQ_N, OUT_RDATA, OUT_TX, UNTRACED_OUTPUTS,
};
use crate::verilated::verilog::{controller_verilog, TOP_MODULE};
use crate::verilated::{fnv1a, EngineError, PortInputs, PortOutputs};

/// Where the controller's generated model lives in the source tree (relative to the workspace
/// root).
pub const MODEL_PATH: &str = "sim/src/compiled/model.rs";
/// Where the CAN core's generated model lives.
pub const CORE_MODEL_PATH: &str = "sim/src/compiled/core_model.rs";
/// Where the CAN core's generated lane model (64 cores in one evaluation) lives.
pub const LANE_MODEL_PATH: &str = "sim/src/compiled/lane_model.rs";

/// A design the generator turns into a model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Design {
    /// The complete controller with the SJA1000 host port (`can_controller`): the controller
    /// nodes' engine ([`CompiledController`]).
    Controller,
    /// The CAN core alone (`rtl::can_core::CanCore`): the bare nodes of the fault campaign and
    /// the response-time simulation ([`core::CompiledCore`]).
    Core,
}

impl Design {
    /// Every design with a checked-in model.
    pub const ALL: [Design; 2] = [Design::Controller, Design::Core];

    /// Where the design's model lives (relative to the workspace root).
    pub fn model_path(self) -> &'static str {
        match self {
            Design::Controller => MODEL_PATH,
            Design::Core => CORE_MODEL_PATH,
        }
    }

    fn verilog(self) -> String {
        match self {
            Design::Controller => controller_verilog(),
            Design::Core => core::core_verilog(),
        }
    }

    fn top(self) -> &'static str {
        match self {
            Design::Controller => TOP_MODULE,
            Design::Core => core::TOP,
        }
    }

    /// The name of the Verilog and netlist files Yosys reads and writes.
    fn file_stem(self) -> &'static str {
        match self {
            Design::Controller => "can_controller",
            Design::Core => "can_core",
        }
    }

    /// What the model holds, for its header.
    fn what(self) -> &'static str {
        match self {
            Design::Controller => "The controller",
            Design::Core => "The CAN core (bit timing and protocol engine, no registers)",
        }
    }

    /// Internal wires the model brings out (kept through the optimisation).
    fn kept_wires(self) -> Vec<&'static str> {
        match self {
            Design::Controller => INTERNAL_SIGNALS.iter().map(|s| s.wire).collect(),
            Design::Core => Vec::new(),
        }
    }

    fn interface(self, verilog: &str) -> emit::Interface<'_> {
        match self {
            Design::Controller => controller_interface(verilog),
            Design::Core => core::interface(verilog),
        }
    }

    /// The hash of the Verilog this build gives for the design (computed once per process).
    fn current_hash(self) -> u64 {
        static HASHES: [OnceLock<u64>; 2] = [OnceLock::new(), OnceLock::new()];
        *HASHES[self as usize].get_or_init(|| verilog_hash(&self.verilog()))
    }
}

/// The Yosys commands that make the netlist: the internal signals the model brings out are kept,
/// then processes become cells, the hierarchy is flattened, the logic optimised and memories kept
/// whole.
fn yosys_script(design: Design, verilog: &str, json: &str) -> String {
    let keep: String = design
        .kept_wires()
        .iter()
        .map(|wire| format!("setattr -set keep 1 w:{wire}\n"))
        .collect();
    let top = design.top();
    format!(
        "read_verilog {verilog}\nhierarchy -top {top}\n{keep}proc\nflatten\nopt -full\n\
         wreduce\nopt_clean\nmemory -nomap\nopt -full\nwrite_json {json}\n"
    )
}

/// The hash of the Verilog a model is made from.
fn verilog_hash(verilog: &str) -> u64 {
    fnv1a(&[verilog])
}

/// The source of `design`'s model for the current `rtl/`: runs Yosys (which must be installed) in
/// a temporary directory.
pub fn generate_model_source(design: Design) -> Result<String, String> {
    let (verilog, netlist) = yosys_netlist(design, |v, json| yosys_script(design, v, json))?;
    emit::emit(
        &netlist,
        &design.interface(&verilog),
        &header(design, verilog_hash(&verilog)),
    )
}

/// The source of the CAN core's lane model for the current `rtl/` ([`lanes`]): runs Yosys (which
/// must be installed) in a temporary directory.
pub fn generate_lane_model_source() -> Result<String, String> {
    let design = Design::Core;
    let (verilog, netlist) =
        yosys_netlist(design, |v, json| lanes::yosys_script(v, design.top(), json))?;
    let header = format!(
        "//! The CAN core in 64 lanes (bit `l` of every value is lane `l`'s), generated by `cansim \
         compiled-model`\n//! (`make compiled-model`) from the Verilog of `rtl/` through Yosys's \
         gate mapping; do not edit.\n\n/// Hash of the Verilog this model was made from.\n\
         pub(super) const VERILOG_HASH: u64 = {:#018x};\n",
        verilog_hash(&verilog)
    );
    let io = design.interface(&verilog);
    lanes::emit(&netlist, io.inputs, io.outputs, &header)
}

/// `design`'s Verilog for the current `rtl/`, and the netlist the Yosys script `script(verilog
/// file, netlist file)` makes of it, in a temporary directory of its own (generators may run in
/// parallel threads).
fn yosys_netlist(
    design: Design,
    script: impl Fn(&str, &str) -> String,
) -> Result<(String, netlist::Netlist), String> {
    let verilog = design.verilog();
    static RUNS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let run = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("cansim-compiled-{}-{run}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let stem = design.file_stem();
    let script = script(&format!("{stem}.v"), &format!("{stem}.json"));
    let netlist = run_yosys(stem, &dir, &verilog, &script)
        .and_then(|json| netlist::Netlist::parse(&json, design.top()));
    let _ = std::fs::remove_dir_all(&dir);
    Ok((verilog, netlist?))
}

/// Writes every design's model, and the core's lane model, under the workspace root `root`.
pub fn write_models(root: &Path) -> Result<(), String> {
    let write = |path: &str, text: String| {
        let path = root.join(path);
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
    };
    for design in Design::ALL {
        write(design.model_path(), generate_model_source(design)?)?;
    }
    write(LANE_MODEL_PATH, generate_lane_model_source()?)
}

/// Runs Yosys in `dir` with `script` on `verilog` (written to `<stem>.v`, the netlist read back
/// from `<stem>.json`); the file names are relative, so that the names Yosys gives cells (which
/// carry the source file) do not depend on the directory.
fn run_yosys(stem: &str, dir: &Path, verilog: &str, script: &str) -> Result<String, String> {
    let (v, json) = (format!("{stem}.v"), format!("{stem}.json"));
    let script_file = "netlist.ys";
    std::fs::write(dir.join(&v), verilog).map_err(|e| format!("{}: {e}", dir.display()))?;
    std::fs::File::create(dir.join(script_file))
        .and_then(|mut f| f.write_all(script.as_bytes()))
        .map_err(|e| format!("{}: {e}", dir.display()))?;
    let output = Command::new("yosys")
        .current_dir(dir)
        .arg("-q")
        .arg("-s")
        .arg(script_file)
        .output()
        .map_err(|e| {
            format!("yosys cannot be run ({e}): install it with ./scripts/install-tools.sh")
        })?;
    if !output.status.success() {
        return Err(format!(
            "yosys failed: {}",
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    std::fs::read_to_string(dir.join(json)).map_err(|e| format!("{}: {e}", dir.display()))
}

fn controller_interface(verilog: &str) -> emit::Interface<'_> {
    static OUTPUTS: OnceLock<Vec<(&'static str, u32)>> = OnceLock::new();
    let outputs = OUTPUTS.get_or_init(|| {
        let mut list = vec![
            ("rdata", OUT_RDATA),
            ("tx", OUT_TX),
            ("irq_n", OUT_IRQ_N),
            ("clkout", OUT_CLKOUT),
        ];
        list.extend(INTERNAL_SIGNALS.iter().map(|s| s.wire).zip(INTERNAL_SHIFTS));
        list
    });
    emit::Interface {
        clock: "clock",
        inputs: &[
            ("wdata", IN_WDATA),
            ("addr", IN_ADDR),
            ("we", IN_WE),
            ("re", IN_RE),
            ("rx", IN_RX),
            ("reset", IN_RESET),
        ],
        outputs,
        verilog,
        state: &quiet::CONTROLLER_STATE,
    }
}

fn header(design: Design, hash: u64) -> String {
    format!(
        "//! {} as straight-line Rust, generated by `cansim compiled-model` (`make \
         compiled-model`)\n//! from the Verilog of `rtl/` through Yosys; do not edit.\n\n\
         /// Hash of the Verilog this model was made from.\npub(super) const VERILOG_HASH: u64 = \
         {hash:#018x};\n",
        design.what()
    )
}

/// `design`'s checked-in model, made from Verilog of hash `made_from`, is made from the Verilog
/// of this build.
fn check_model_is_current(design: Design, made_from: u64) -> Result<(), EngineError> {
    check_made_from(design.model_path(), made_from, design.current_hash())
}

/// A model made from Verilog of hash `made_from` may run when `rtl/` now gives `current`.
fn check_made_from(model_path: &str, made_from: u64, current: u64) -> Result<(), EngineError> {
    if made_from == current {
        Ok(())
    } else {
        Err(EngineError::Load(format!(
            "the compiled model ({}) was made from other Verilog than rtl/ gives now: \
             regenerate it with `make compiled-model` (needs Yosys), or use CAN_ENGINE=rust-hdl",
            model_path
        )))
    }
}

/// One controller of the compiled engine.
#[derive(Clone)]
pub struct CompiledController {
    model: Box<model::Model>,
    applied: Option<PortInputs>,
    every_group: bool,
}

impl CompiledController {
    /// A new controller at power-up (apply a reset before use, as with the hardware); an error if
    /// the checked-in model does not match `rtl/`.
    pub fn new() -> Result<CompiledController, EngineError> {
        check_model_is_current(Design::Controller, model::VERILOG_HASH)?;
        Ok(CompiledController {
            model: Box::new(model::Model::new()),
            applied: None,
            every_group: false,
        })
    }

    /// Runs every group of cells at every evaluation instead of only those whose inputs changed
    /// (slower; for checking that skipping the others changes nothing).
    pub fn set_every_group(&mut self, every_group: bool) {
        self.every_group = every_group;
    }

    /// One clock cycle: `inputs` applied, the rising edge, the clock low again.
    pub fn cycle(&mut self, inputs: PortInputs) -> PortOutputs {
        if self.applied != Some(inputs) {
            self.model.set_inputs(inputs.word());
            self.model.eval(self.every_group);
            self.applied = Some(inputs);
        }
        self.model.edge();
        self.model.eval(self.every_group);
        self.outputs()
    }

    /// The outputs after the last cycle.
    pub fn outputs(&self) -> PortOutputs {
        PortOutputs::from_word(self.model.outputs())
    }

    /// How many cycles from the next one on, all with `inputs`, change nothing outside the
    /// controller's counters: no output but those only a trace shows (CLKOUT, the sample point
    /// and the segment, which may change unless `traced`), no register, no memory ([`quiet`]). 0
    /// when `inputs` differ from the last cycle's.
    pub fn quiet_cycles(&self, inputs: PortInputs, traced: bool) -> u64 {
        if self.applied != Some(inputs) || inputs.reset {
            return 0;
        }
        // The counters' arithmetic first: it rules out most edges at less cost than `settled`.
        match quiet::quiet_cycles(&*self.model, inputs.rx, traced) {
            0 => 0,
            cycles if self.model.settled() => cycles,
            _ => 0,
        }
    }

    /// Runs `cycles` quiet cycles (at most [`CompiledController::quiet_cycles`] gave) in one
    /// step. `checked`: also runs them one by one on a copy and panics unless every output stayed
    /// (those only a trace shows only if `traced`) and the two end in the same state.
    pub fn skip(&mut self, cycles: u64, traced: bool, checked: bool) {
        let copy = checked.then(|| self.clone());
        quiet::advance(&mut *self.model, cycles);
        if let Some(mut copy) = copy {
            let inputs = copy.applied.expect("a cycle ran before the skip");
            let seen = if traced { u64::MAX } else { !UNTRACED_OUTPUTS };
            let before = copy.model.outputs() & seen;
            let step = || {
                copy.cycle(inputs);
                copy.model.outputs() & seen
            };
            quiet::assert_stepping_agrees("controller", cycles, before, step);
            quiet::assert_same_state("controller", cycles, copy.model.differences(&self.model));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_model_of_other_verilog_is_refused_with_the_command_that_regenerates_it() {
        assert_eq!(check_made_from(CORE_MODEL_PATH, 7, 7), Ok(()));
        let refused = check_made_from(CORE_MODEL_PATH, 7, 8)
            .unwrap_err()
            .to_string();
        assert!(refused.contains("make compiled-model"), "{refused}");
        assert!(refused.contains(CORE_MODEL_PATH), "{refused}");
    }

    #[test]
    fn the_checked_in_model_runs_and_leaves_reset_recessive() {
        let mut node = CompiledController::new().expect("model made from this rtl/");
        let reset = PortInputs {
            reset: true,
            ..PortInputs::default()
        };
        node.cycle(reset);
        let out = node.cycle(PortInputs::default());
        assert!(out.tx(), "tx recessive after reset");
        assert!(out.irq_n(), "no interrupt after reset");
    }
}
