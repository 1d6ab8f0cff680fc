//! A bus node made of the complete RTL controller [`rtl::can_controller::CanController`], reachable only
//! through its host port: register reads and writes, one per clock cycle, queued by a host model
//! ([`crate::host`]) and applied on the node's own clock edges.
//!
//! Stepping: a queued access drives `addr`/`wdata`/`we`/`re` for exactly one clock cycle; a read's
//! data is taken from `rdata` right after that edge (the port contract's registered read data). The
//! node also records `irq_n` and, for traces, a few internal signals of the core.
//!
//! Three engines step the controller ([`ModelEngine`]): the rust-hdl model itself, its generated
//! Verilog compiled by Verilator ([`crate::verilated`]), or that Verilog's Yosys netlist as
//! straight-line Rust ([`crate::compiled`], the default). All give the same outputs after every
//! edge; `CAN_ENGINE` chooses for every node made with [`ControllerNode::new`].

use std::any::Any;
use std::collections::VecDeque;
use std::fmt;
use std::str::FromStr;

use rtl::activity::Child;
use rtl::bsp::protocol::ProtocolState;
use rtl::can_controller::CanController;
use rust_hdl::prelude::*;

use crate::compiled::CompiledController;
use crate::engine::bus::Drive;
use crate::engine::rtl_step::clock_cycle_with;
use crate::engine::time::ClockSpec;
use crate::engine::trace::Probe;
use crate::engine::Device;
use crate::nodes::can_node::{core_probe_values, core_probes, CORE_PROBES, CORE_PROBE_BITS};
use crate::nodes::core_engine::CoreOutputs;
use crate::verilated::sources::{STATE, TRANSMITTING};
pub use crate::verilated::EngineError;
use crate::verilated::{PortInputs, PortOutputs, VerilatedController, MIN_SKIPPED_CYCLES};

/// The environment variable that chooses the engine of [`ControllerNode::new`].
pub const ENGINE_ENV: &str = "CAN_ENGINE";

/// Which model of the controller a [`ControllerNode`] steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ModelEngine {
    /// The rust-hdl model of `rtl/`, settled activity-driven (`rtl::activity`).
    RustHdl,
    /// The same model with every kernel run on every settle pass, as rust-hdl's own derive does:
    /// about 4 times slower, for cross-checking the activity-driven settle.
    RustHdlExhaustive,
    /// The generated Verilog, compiled by Verilator and loaded as a library.
    Verilator,
    /// The generated Verilog turned into straight-line Rust through Yosys ([`crate::compiled`]),
    /// compiled with the crate: no tool needed at run time; a group of cells runs only when
    /// something it reads changed. The default: the fastest engine.
    #[default]
    Compiled,
    /// The same with every group run at every evaluation: for checking the skipping.
    CompiledExhaustive,
}

impl ModelEngine {
    /// Every engine.
    pub const ALL: [ModelEngine; 5] = [
        ModelEngine::RustHdl,
        ModelEngine::RustHdlExhaustive,
        ModelEngine::Verilator,
        ModelEngine::Compiled,
        ModelEngine::CompiledExhaustive,
    ];

    /// The name `CAN_ENGINE` takes.
    pub fn name(self) -> &'static str {
        match self {
            ModelEngine::RustHdl => "rust-hdl",
            ModelEngine::RustHdlExhaustive => "rust-hdl-exhaustive",
            ModelEngine::Verilator => "verilator",
            ModelEngine::Compiled => "compiled",
            ModelEngine::CompiledExhaustive => "compiled-exhaustive",
        }
    }

    /// The engine `CAN_ENGINE` chooses: unset or empty is [`ModelEngine::Compiled`]; any value
    /// other than an engine's name is an error naming the allowed values.
    pub fn from_env() -> Result<ModelEngine, String> {
        let parsed = match std::env::var(ENGINE_ENV) {
            Ok(value) if !value.is_empty() => value.parse(),
            Ok(_) | Err(std::env::VarError::NotPresent) => Ok(ModelEngine::default()),
            Err(std::env::VarError::NotUnicode(value)) => {
                Err(unknown_engine(&value.to_string_lossy()))
            }
        };
        parsed.map_err(|e| format!("{ENGINE_ENV}={e}"))
    }
}

fn unknown_engine(value: &str) -> String {
    let names: Vec<String> = ModelEngine::ALL
        .iter()
        .map(|e| format!("`{}`", e.name()))
        .collect();
    let (last, first) = names.split_last().expect("engines");
    format!(
        "`{value}` is not an engine: use {} or {last} (the default is `{}`)",
        first.join(", "),
        ModelEngine::default().name()
    )
}

impl FromStr for ModelEngine {
    type Err = String;

    fn from_str(value: &str) -> Result<ModelEngine, String> {
        ModelEngine::ALL
            .into_iter()
            .find(|e| e.name() == value)
            .ok_or_else(|| unknown_engine(value))
    }
}

impl fmt::Display for ModelEngine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One host bus cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostAccess {
    /// Write `value` to register `addr`.
    Write {
        /// Register address.
        addr: u8,
        /// Value written.
        value: u8,
    },
    /// Read register `addr`.
    Read {
        /// Register address.
        addr: u8,
    },
}

/// The model a node steps.
enum Model {
    RustHdl {
        uut: Box<CanController>,
        /// The inputs the model holds (`None` before the first cycle).
        applied: Option<PortInputs>,
    },
    Verilator(VerilatedController),
    Compiled(CompiledController),
}

impl Model {
    fn new(engine: ModelEngine) -> Result<Model, EngineError> {
        Ok(match engine {
            ModelEngine::RustHdl | ModelEngine::RustHdlExhaustive => {
                let mut uut = Box::<CanController>::default();
                uut.connect_all();
                uut.set_exhaustive(engine == ModelEngine::RustHdlExhaustive);
                Model::RustHdl { uut, applied: None }
            }
            ModelEngine::Verilator => Model::Verilator(VerilatedController::new()?),
            ModelEngine::Compiled | ModelEngine::CompiledExhaustive => {
                let mut model = CompiledController::new()?;
                model.set_every_group(engine == ModelEngine::CompiledExhaustive);
                Model::Compiled(model)
            }
        })
    }

    /// One clock cycle with `inputs`.
    fn cycle(&mut self, inputs: PortInputs) {
        match self {
            Model::RustHdl { uut, applied } => rust_hdl_cycle(uut, applied, inputs),
            Model::Verilator(model) => {
                model.cycle(inputs);
            }
            Model::Compiled(model) => {
                model.cycle(inputs);
            }
        }
    }

    /// An output: read from the rust-hdl model by `rust_hdl`, from the output word of the other
    /// engines by `word`.
    fn output<T>(
        &self,
        rust_hdl: impl FnOnce(&CanController) -> T,
        word: impl FnOnce(PortOutputs) -> T,
    ) -> T {
        match self {
            Model::RustHdl { uut, .. } => rust_hdl(uut),
            Model::Verilator(model) => word(model.outputs()),
            Model::Compiled(model) => word(model.outputs()),
        }
    }

    fn tx(&self) -> bool {
        self.output(|u| u.tx.val(), PortOutputs::tx)
    }

    fn irq_n(&self) -> bool {
        self.output(|u| u.irq_n.val(), PortOutputs::irq_n)
    }

    fn clkout(&self) -> bool {
        self.output(|u| u.clkout.val(), PortOutputs::clkout)
    }

    fn rdata(&self) -> u8 {
        self.output(|u| u.rdata.val().to_u8(), PortOutputs::rdata)
    }
}

/// Every protocol state, in declaration order (the encoding rust-hdl gives them in the Verilog).
const PROTOCOL_STATES: [ProtocolState; 16] = [
    ProtocolState::Integrating,
    ProtocolState::Idle,
    ProtocolState::Suspend,
    ProtocolState::BusOff,
    ProtocolState::ErrorFlag,
    ProtocolState::OverloadFlag,
    ProtocolState::Delimiter,
    ProtocolState::Intermission,
    ProtocolState::Arbitration,
    ProtocolState::Control,
    ProtocolState::Data,
    ProtocolState::Crc,
    ProtocolState::CrcDelimiter,
    ProtocolState::AckSlot,
    ProtocolState::AckDelimiter,
    ProtocolState::EndOfFrame,
];

/// One clock cycle of the rust-hdl controller with `inputs` on its ports. `applied` holds the
/// inputs of the last cycle (`None` before the first): the design is settled again only when they
/// change.
pub fn rust_hdl_cycle(
    uut: &mut CanController,
    applied: &mut Option<PortInputs>,
    inputs: PortInputs,
) {
    let changed = *applied != Some(inputs);
    if changed {
        uut.reset.next = inputs.reset;
        uut.addr.next = u64::from(inputs.addr).to_bits();
        uut.wdata.next = u64::from(inputs.wdata).to_bits();
        uut.we.next = inputs.we;
        uut.re.next = inputs.re;
        uut.rx.next = inputs.rx;
        *applied = Some(inputs);
    }
    clock_cycle_with(uut, |u| &mut u.clock, "CAN controller", changed);
}

/// The protocol state encoded as `value` in the Verilog.
pub(crate) fn protocol_state(value: u64) -> ProtocolState {
    *PROTOCOL_STATES
        .get(value as usize)
        .unwrap_or_else(|| panic!("protocol state {value} of the Verilated model has no name"))
}

/// The RTL controller as a bus [`Device`] with a host access queue.
pub struct ControllerNode {
    name: String,
    clock: ClockSpec,
    engine: ModelEngine,
    model: Model,
    /// The inputs of the next cycle (`addr` and `wdata` stay as the last access left them).
    inputs: PortInputs,
    queue: VecDeque<HostAccess>,
    reads: VecDeque<u8>,
    edges: u64,
}

impl ControllerNode {
    /// A controller on `clock` after a hardware reset (reset mode, BasicCAN, as the data sheet
    /// leaves it); configure it through a host. The engine is the one `CAN_ENGINE` chooses
    /// ([`ModelEngine::from_env`]).
    ///
    /// Panics with the reason if `CAN_ENGINE` names no engine or the engine cannot be had
    /// (Verilator missing or failing); [`ControllerNode::with_engine`] returns the error instead.
    pub fn new(name: &str, clock: ClockSpec) -> ControllerNode {
        let engine = ModelEngine::from_env().unwrap_or_else(|e| panic!("{e}"));
        ControllerNode::with_engine(name, clock, engine).unwrap_or_else(|e| panic!("{e}"))
    }

    /// A controller on `clock` stepped by `engine`, after a hardware reset.
    pub fn with_engine(
        name: &str,
        clock: ClockSpec,
        engine: ModelEngine,
    ) -> Result<ControllerNode, EngineError> {
        let mut node = ControllerNode {
            name: name.to_string(),
            clock,
            engine,
            model: Model::new(engine)?,
            inputs: PortInputs {
                reset: true,
                ..PortInputs::default()
            },
            queue: VecDeque::new(),
            reads: VecDeque::new(),
            edges: 0,
        };
        node.model.cycle(node.inputs);
        node.edges += 1;
        node.inputs.reset = false;
        Ok(node)
    }

    /// The engine stepping this node.
    pub fn engine(&self) -> ModelEngine {
        self.engine
    }

    /// Queues a host access; it happens on one of the next clock edges, in order.
    pub fn queue(&mut self, access: HostAccess) {
        self.queue.push_back(access);
    }

    /// No access is queued or under way.
    pub fn host_idle(&self) -> bool {
        self.queue.is_empty()
    }

    /// The oldest read result not yet taken.
    pub fn take_read(&mut self) -> Option<u8> {
        self.reads.pop_front()
    }

    /// The interrupt output is asserted (`irq_n` low).
    pub fn irq(&self) -> bool {
        !self.model.irq_n()
    }

    /// The `clkout` pin.
    pub fn clkout(&self) -> bool {
        self.model.clkout()
    }

    /// The `tx` pin.
    pub fn tx(&self) -> bool {
        self.model.tx()
    }

    /// Rising clock edges so far.
    pub fn edges(&self) -> u64 {
        self.edges
    }

    /// Protocol state of the core (for waves and diagnostics; tests observe registers).
    pub fn state(&self) -> ProtocolState {
        self.model.output(
            |u| u.core.status.state.val(),
            |w| protocol_state(w.internal(STATE)),
        )
    }

    /// The core is transmitting a frame (it has not lost arbitration), for locating faults in the
    /// frame on the bus.
    pub fn transmitting(&self) -> bool {
        self.model.output(
            |u| u.core.status.transmitting.val(),
            |w| w.internal(TRANSMITTING) != 0,
        )
    }

    /// Drives or releases the hardware `reset` input from the next edge on.
    pub fn set_reset(&mut self, active: bool) {
        self.inputs.reset = active;
    }

    /// The inputs of an edge without a host access at which the node sees `rx`.
    fn idle_inputs(&self, rx: bool) -> PortInputs {
        PortInputs {
            we: false,
            re: false,
            rx,
            ..self.inputs
        }
    }

    /// Sets the host port inputs of the next edge for `access` (`None`: no access; the address
    /// and write data keep their values).
    fn apply(&mut self, access: Option<HostAccess>) {
        let i = &mut self.inputs;
        match access {
            Some(HostAccess::Write { addr, value }) => {
                (i.we, i.re, i.addr, i.wdata) = (true, false, addr, value);
            }
            Some(HostAccess::Read { addr }) => {
                (i.we, i.re, i.addr, i.wdata) = (false, true, addr, 0)
            }
            None => (i.we, i.re) = (false, false),
        }
    }
}

impl Device for ControllerNode {
    fn name(&self) -> &str {
        &self.name
    }

    fn clock(&self) -> ClockSpec {
        self.clock
    }

    fn rising_edge(&mut self, _t_fs: u64, rx: bool) -> Drive {
        let access = self.queue.pop_front();
        self.apply(access);
        self.inputs.rx = rx;
        self.model.cycle(self.inputs);
        self.edges += 1;
        if let Some(HostAccess::Read { .. }) = access {
            self.reads.push_back(self.model.rdata());
        }
        Drive::from_level(self.model.tx())
    }

    fn quiet_edges(&self, rx: bool, traced: bool) -> u64 {
        match &self.model {
            Model::Compiled(model) if self.queue.is_empty() => {
                model.quiet_cycles(self.idle_inputs(rx), traced)
            }
            Model::Verilator(model) if self.queue.is_empty() => {
                model.quiet_cycles(self.idle_inputs(rx), traced, MIN_SKIPPED_CYCLES)
            }
            _ => 0,
        }
    }

    fn skip_edges(&mut self, edges: u64, rx: bool, traced: bool, checked: bool) {
        match &mut self.model {
            Model::Compiled(model) => model.skip(edges, traced, checked),
            Model::Verilator(model) => model.skip(edges, traced, checked),
            Model::RustHdl { .. } => unreachable!("the rust-hdl engine has no quiet edges"),
        }
        self.apply(None);
        self.inputs.rx = rx;
        self.edges += edges;
    }

    fn probes(&self) -> Vec<Probe> {
        let mut probes = core_probes();
        probes.extend([Probe::bit("irq_n"), Probe::bit("clkout")]);
        probes
    }

    fn probe_values(&self, values: &mut [u64]) {
        let (core, own) = values.split_at_mut(CORE_PROBES);
        let from_word = |word: PortOutputs, core: &mut [u64]| {
            for (i, value) in core.iter_mut().enumerate() {
                *value = word.internal(i);
            }
        };
        match &self.model {
            Model::RustHdl { uut, .. } => core_probe_values(&CoreOutputs::of(&uut.core), core),
            Model::Verilator(model) => from_word(model.outputs(), core),
            Model::Compiled(model) => from_word(model.outputs(), core),
        }
        own.copy_from_slice(&[
            u64::from(self.model.irq_n()),
            u64::from(self.model.clkout()),
        ]);
    }

    fn packed_probe_values(&self) -> Option<u64> {
        let word = match &self.model {
            Model::RustHdl { .. } => return None,
            Model::Verilator(model) => model.outputs(),
            Model::Compiled(model) => model.outputs(),
        };
        Some(
            word.core_probe_bits()
                | u64::from(word.irq_n()) << CORE_PROBE_BITS
                | u64::from(word.clkout()) << (CORE_PROBE_BITS + 1),
        )
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_state_table_lists_every_protocol_state_at_its_encoding() {
        let TypeKind::Enum(names) = ProtocolState::descriptor().kind else {
            panic!("ProtocolState is an enum");
        };
        assert_eq!(
            names.len(),
            PROTOCOL_STATES.len(),
            "a protocol state was added or removed: update PROTOCOL_STATES"
        );
        for (k, state) in PROTOCOL_STATES.iter().enumerate() {
            assert_eq!(*state as usize, k, "{state:?}");
            assert_eq!(protocol_state(k as u64), *state);
        }
    }

    #[test]
    fn engine_names_parse_and_anything_else_is_refused_with_the_allowed_values() {
        for engine in ModelEngine::ALL {
            assert_eq!(engine.name().parse::<ModelEngine>(), Ok(engine));
            assert_eq!(engine.to_string(), engine.name());
        }
        let err = "verilog".parse::<ModelEngine>().unwrap_err();
        assert_eq!(
            err,
            "`verilog` is not an engine: use `rust-hdl`, `rust-hdl-exhaustive`, `verilator`, \
             `compiled` or `compiled-exhaustive` (the default is `compiled`)"
        );
    }
}
