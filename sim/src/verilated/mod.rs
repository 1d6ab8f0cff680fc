//! The Verilator engine: the generated Verilog of the controller ([`crate::verilated::verilog`]) compiled by
//! Verilator into a shared library, loaded into this process and stepped one clock cycle per call.
//!
//! The library is built on first use and cached under `target/verilator/` (see `cache`); every
//! model of the process shares it. A [`VerilatedController`] is one controller: [`PortInputs`] in,
//! [`PortOutputs`] out, with the semantics of [`crate::nodes::controller_node::ControllerNode`]'s rust-hdl
//! model: the inputs are applied before the rising edge and the outputs read after it with the
//! clock low again.

mod cache;
pub(crate) use cache::fnv1a;
mod dl;
mod quiet_word;
pub(crate) mod sources;
mod training;
pub mod verilog;

use std::ffi::c_void;
use std::fmt;
use std::path::{Path, PathBuf};
use std::ptr::NonNull;
use std::sync::OnceLock;

use dl::Library;
use quiet_word::{QuietField, QuietWord, QUIET_SETTLED};

use crate::compiled::quiet;
use crate::nodes::can_node::CORE_PROBE_BITS;
use sources::{
    ABI_VERSION, INTERNAL_SHIFTS, INTERNAL_SIGNALS, IN_ADDR, IN_RE, IN_RESET, IN_RX, IN_WDATA,
    IN_WE, OUT_CLKOUT, OUT_IRQ_N, OUT_RDATA, OUT_TX, UNTRACED_OUTPUTS,
};

/// The shortest quiet stretch worth skipping on the Verilated controller, and the shortest the
/// engine parks: a single quiet edge costs less stepped than its `settled` evaluation and load.
/// Callgrind, the reference workload with skipping on (`Engine::step_before` inclusive, the
/// profile-guided library, parking): 2 nodes, 20 frames: 85.0 M instructions from 1 cycle on,
/// 84.9 M from 2, 86.9 M from 3, 105.5 M from 4; 8 nodes, 10 frames: 175.4 M from 2, 177.8 M
/// from 3. (Before parking, with every device's event ending everyone's stretch, 3 was best.)
pub(crate) const MIN_SKIPPED_CYCLES: u64 = 2;

/// Why the Verilator engine is not available.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum EngineError {
    /// `verilator` cannot be run (with the reason).
    VerilatorMissing(String),
    /// Verilator or the C++ compiler failed (with the end of their output).
    Build(String),
    /// The built library cannot be loaded or lacks the expected interface.
    Load(String),
    /// A file of the build cannot be written.
    Io(String),
}

impl EngineError {
    fn io(path: &Path, error: std::io::Error) -> EngineError {
        EngineError::Io(format!("{}: {error}", path.display()))
    }
}

impl fmt::Display for EngineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EngineError::VerilatorMissing(why) => write!(
                f,
                "the Verilator engine needs Verilator, which cannot be run ({why}): install it \
                 with ./scripts/install-tools.sh (or `make tools`), or use CAN_ENGINE=rust-hdl"
            ),
            EngineError::Build(output) => {
                write!(f, "building the Verilator model failed: {output}")
            }
            EngineError::Load(why) => write!(f, "loading the Verilator model failed: {why}"),
            EngineError::Io(why) => write!(f, "building the Verilator model failed: {why}"),
        }
    }
}

impl std::error::Error for EngineError {}

type CreateFn = unsafe extern "C" fn() -> *mut c_void;
type DestroyFn = unsafe extern "C" fn(*mut c_void);
type CycleFn = unsafe extern "C" fn(*mut c_void, u32) -> u64;
type QuietFn = unsafe extern "C" fn(*mut c_void) -> u64;
type SettledFn = unsafe extern "C" fn(*mut c_void) -> u32;
type SkipFn = unsafe extern "C" fn(*mut c_void, u64) -> u64;
type AbiFn = unsafe extern "C" fn() -> u32;

/// The loaded library and its functions.
struct ModelLibrary {
    path: PathBuf,
    create: CreateFn,
    destroy: DestroyFn,
    cycle: CycleFn,
    quiet: QuietFn,
    settled: SettledFn,
    skip: SkipFn,
    /// Where the quiet word holds each state net.
    layout: Vec<QuietField>,
    handle: Library,
}

impl ModelLibrary {
    fn open((path, layout): (PathBuf, Vec<QuietField>)) -> Result<ModelLibrary, EngineError> {
        let fail = |why: String| {
            EngineError::Load(format!(
                "{}: {why} (delete the file to rebuild it)",
                path.display()
            ))
        };
        let library = Library::open(&path).map_err(fail)?;
        // SAFETY: the types are those of the shim (`sources::shim_cpp`), whose version is checked
        // before any other function is called.
        unsafe {
            let abi: AbiFn = library.function("cc_abi_version").map_err(fail)?;
            let version = abi();
            if version != ABI_VERSION {
                return Err(fail(format!(
                    "interface version {version}, expected {ABI_VERSION}"
                )));
            }
            Ok(ModelLibrary {
                create: library.function("cc_create").map_err(fail)?,
                destroy: library.function("cc_destroy").map_err(fail)?,
                cycle: library.function("cc_cycle").map_err(fail)?,
                quiet: library.function("cc_quiet").map_err(fail)?,
                settled: library.function("cc_settled").map_err(fail)?,
                skip: library.function("cc_skip").map_err(fail)?,
                path,
                layout,
                handle: library,
            })
        }
    }
}

/// The library of this process: built or found in the cache, loaded once.
fn model_library() -> Result<&'static ModelLibrary, EngineError> {
    static LIBRARY: OnceLock<Result<ModelLibrary, EngineError>> = OnceLock::new();
    LIBRARY
        .get_or_init(|| cache::library().and_then(ModelLibrary::open))
        .as_ref()
        .map_err(Clone::clone)
}

/// Builds the Verilator model if the cache does not hold it yet and loads it; returns the path of
/// the library (for `cansim verilator-model`, `make verilator-model`).
pub fn build_model() -> Result<PathBuf, EngineError> {
    model_library().map(|library| library.path.clone())
}

/// The inputs of one clock cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PortInputs {
    /// Synchronous reset.
    pub reset: bool,
    /// Register address.
    pub addr: u8,
    /// Write data.
    pub wdata: u8,
    /// Write strobe.
    pub we: bool,
    /// Read strobe.
    pub re: bool,
    /// Bus level seen (`true` = recessive).
    pub rx: bool,
}

impl Default for PortInputs {
    /// No reset, no access, a recessive bus.
    fn default() -> PortInputs {
        PortInputs {
            reset: false,
            addr: 0,
            wdata: 0,
            we: false,
            re: false,
            rx: true,
        }
    }
}

impl PortInputs {
    /// The input word of the shim.
    pub(crate) fn word(&self) -> u32 {
        u32::from(self.wdata) << IN_WDATA
            | u32::from(self.addr) << IN_ADDR
            | u32::from(self.we) << IN_WE
            | u32::from(self.re) << IN_RE
            | u32::from(self.rx) << IN_RX
            | u32::from(self.reset) << IN_RESET
    }
}

/// The outputs after one clock cycle, and the internal signals the wrapper brings out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PortOutputs(u64);

impl PortOutputs {
    /// The outputs carried by an output word.
    pub(crate) fn from_word(word: u64) -> PortOutputs {
        PortOutputs(word)
    }

    fn bit(self, at: u32) -> bool {
        self.0 >> at & 1 != 0
    }

    /// Registered read data.
    pub fn rdata(self) -> u8 {
        (self.0 >> OUT_RDATA) as u8
    }

    /// Bus output (`true` = recessive).
    pub fn tx(self) -> bool {
        self.bit(OUT_TX)
    }

    /// Interrupt output, active low.
    pub fn irq_n(self) -> bool {
        self.bit(OUT_IRQ_N)
    }

    /// Clock output.
    pub fn clkout(self) -> bool {
        self.bit(OUT_CLKOUT)
    }

    /// The core probes (the first internal signals) as they sit in the word: each above the
    /// previous one, the first at bit 0.
    pub(crate) fn core_probe_bits(self) -> u64 {
        self.0 >> INTERNAL_SHIFTS[0] & ((1 << CORE_PROBE_BITS) - 1)
    }

    /// Internal signal `index` of [`sources::INTERNAL_SIGNALS`].
    pub(crate) fn internal(self, index: usize) -> u64 {
        let width = INTERNAL_SIGNALS[index].width;
        self.0 >> INTERNAL_SHIFTS[index] & ((1u64 << width) - 1)
    }
}

/// One controller in the Verilated model.
pub struct VerilatedController {
    model: NonNull<c_void>,
    library: &'static ModelLibrary,
    outputs: PortOutputs,
    /// The inputs of the last cycle, which the wrapper's input registers hold.
    applied: Option<PortInputs>,
}

// SAFETY: the model is owned by this value alone and used through `&mut self`; a Verilated model
// with its own context may be stepped from any one thread at a time.
unsafe impl Send for VerilatedController {}

impl VerilatedController {
    /// A new controller at power-up (the values of the Verilog's `initial` blocks; apply a reset
    /// before use, as with the hardware). Builds and loads the library on first use.
    pub fn new() -> Result<VerilatedController, EngineError> {
        VerilatedController::with_library(model_library()?)
    }

    /// A new controller of `library`.
    fn with_library(library: &'static ModelLibrary) -> Result<VerilatedController, EngineError> {
        // SAFETY: `create` takes no arguments and returns an owned model or null.
        let model = NonNull::new(unsafe { (library.create)() })
            .ok_or_else(|| EngineError::Load("out of memory creating a model".into()))?;
        Ok(VerilatedController {
            model,
            library,
            outputs: PortOutputs(0),
            applied: None,
        })
    }

    /// One clock cycle: `inputs` applied, the rising edge, the clock low again.
    pub fn cycle(&mut self, inputs: PortInputs) -> PortOutputs {
        // SAFETY: the model is live and exclusively borrowed.
        self.outputs =
            PortOutputs(unsafe { (self.library.cycle)(self.model.as_ptr(), inputs.word()) });
        self.applied = Some(inputs);
        self.outputs
    }

    /// The outputs after the last cycle (all zero before the first).
    pub fn outputs(&self) -> PortOutputs {
        self.outputs
    }

    /// The state nets of the quiet word (its settled bit 0).
    fn quiet_word(&self) -> QuietWord<'static> {
        // SAFETY: the model is live; `quiet` only reads it.
        let word = unsafe { (self.library.quiet)(self.model.as_ptr()) };
        let library: &'static ModelLibrary = self.library;
        QuietWord {
            word,
            layout: &library.layout,
        }
    }

    /// No flip-flop but the counters and no memory changes at the next edge.
    fn settled(&self) -> bool {
        // SAFETY: the model is live and used by one thread (`VerilatedController` is not `Sync`);
        // `settled` evaluates only the wrapper's comparison, no state of the design.
        unsafe { (self.library.settled)(self.model.as_ptr()) != 0 }
    }

    /// The state the quiet-edge skipping reads and loads, as one word: the bit timing's and the
    /// CLKOUT divider's flip-flops (`compiled::quiet::CONTROLLER_STATE`) and, in bit 63, whether
    /// every other flip-flop and memory is settled. Two models in the same state give the same
    /// word (for tests that compare a skip with stepping).
    pub fn quiet_state(&self) -> u64 {
        self.quiet_word().word | u64::from(self.settled()) << QUIET_SETTLED
    }

    /// How many cycles from the next one on, all with `inputs`, change nothing outside the
    /// controller's counters: no output but those only a trace shows (CLKOUT, the sample point
    /// and the segment, which may change unless `traced`), no register, no memory; the same arithmetic as the compiled engine's
    /// (`CompiledController::quiet_cycles`), on the state the wrapper brings out. 0 when `inputs`
    /// differ from the last cycle's, and when fewer than `at_least` cycles are quiet (then the
    /// wrapper's `settled` comparison, an evaluation, is not spent).
    pub fn quiet_cycles(&self, inputs: PortInputs, traced: bool, at_least: u64) -> u64 {
        if self.applied != Some(inputs) || inputs.reset {
            return 0;
        }
        // The counters' arithmetic first: it rules out most edges without an evaluation.
        match quiet::quiet_cycles(&self.quiet_word(), inputs.rx, traced) {
            cycles if cycles < at_least.max(1) => 0,
            cycles if self.settled() => cycles,
            _ => 0,
        }
    }

    /// Runs `cycles` quiet cycles (at most [`VerilatedController::quiet_cycles`] gave) in one
    /// step: the wrapper loads the counters with their values after them. `checked`: steps the
    /// cycles one by one instead and panics unless every output stayed (those only a trace
    /// shows only if `traced`), everything but the counters stayed settled after each, and the state ends
    /// where the skip would have put it (a model cannot be copied to do both; the skip's load
    /// itself is checked against stepping by `testbenches::equivalence::verilated_skips_agree`
    /// and by the examples run with skipping on, `testbenches/tests/engines.rs`).
    pub fn skip(&mut self, cycles: u64, traced: bool, checked: bool) {
        let mut after = self.quiet_word();
        quiet::advance(&mut after, cycles);
        if checked {
            let inputs = self.applied.expect("a cycle ran before the skip");
            let seen = if traced { u64::MAX } else { !UNTRACED_OUTPUTS };
            // Compared after each edge: the outputs and, above them, that every flip-flop but
            // the counters and every memory stays settled up to the last skipped edge (so none
            // of them changes at any).
            let watched = |outputs: PortOutputs, settled: bool| {
                u128::from(outputs.0 & seen) | u128::from(settled) << 64
            };
            let before = watched(self.outputs, true);
            let mut stepped = 0;
            let step = || {
                let outputs = self.cycle(inputs);
                stepped += 1;
                watched(outputs, stepped == cycles || self.settled())
            };
            quiet::assert_stepping_agrees("Verilated controller", cycles, before, step);
            let differences = self.quiet_word().differences(after);
            quiet::assert_same_state("Verilated controller", cycles, differences);
        } else {
            // SAFETY: the model is live and exclusively borrowed.
            self.outputs =
                PortOutputs(unsafe { (self.library.skip)(self.model.as_ptr(), after.word) });
        }
    }
}

impl Drop for VerilatedController {
    fn drop(&mut self) {
        // SAFETY: created by this library's `create`, destroyed once.
        unsafe { (self.library.destroy)(self.model.as_ptr()) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_fields_land_on_their_bits() {
        let word = PortInputs {
            reset: true,
            addr: 0x12,
            wdata: 0xA5,
            we: true,
            re: false,
            rx: false,
        }
        .word();
        assert_eq!(
            word,
            1 << IN_RESET | 0x12 << IN_ADDR | 0xA5 << IN_WDATA | 1 << IN_WE
        );
        assert_eq!(PortInputs::default().word(), 1 << IN_RX);
    }

    #[test]
    fn output_fields_are_read_from_their_bits() {
        let state = 0b1_0110u64;
        let out = PortOutputs(
            0x3C << OUT_RDATA
                | 1 << OUT_IRQ_N
                | state << INTERNAL_SHIFTS[sources::STATE]
                | 1 << INTERNAL_SHIFTS[sources::TRANSMITTING],
        );
        assert_eq!(out.rdata(), 0x3C);
        assert!(!out.tx() && out.irq_n() && !out.clkout());
        assert_eq!(out.internal(sources::STATE), state);
        assert_eq!(out.internal(sources::TRANSMITTING), 1);
        assert_eq!(out.internal(0), 0);
    }
}
