//! The CAN core alone ([`rtl::can_core::CanCore`]) on the compiled engine: its ports packed into the
//! model's input and output words, one clock cycle per call, with the semantics of the rust-hdl
//! core ([`crate::nodes::core_engine`]): inputs applied before the rising edge, outputs read after
//! it with the clock low.

use rtl::can_core::CanCore;
use rust_hdl::prelude::*;

use super::{check_model_is_current, core_model, emit, Design};
use crate::nodes::controller_node::protocol_state;
use crate::nodes::core_engine::{CoreInputs, CoreOutputs};
use crate::verilated::EngineError;

/// The top module of the core's Verilog (rust-hdl's name for the block generated).
pub(super) const TOP: &str = "top";

/// The core's input ports and their widths, in the order they are packed into the input word.
pub(super) const INPUTS: [(&str, u32); 18] = [
    ("reset", 1),
    ("rx", 1),
    ("enable", 1),
    ("brp", 6),
    ("tseg1", 4),
    ("tseg2", 3),
    ("sjw", 2),
    ("sam", 1),
    ("listen_only", 1),
    ("self_test", 1),
    ("transmit$request", 1),
    ("transmit$single_shot", 1),
    ("transmit$abort", 1),
    ("transmit$info", 8),
    ("transmit$data", 8),
    ("counters$load_tec", 1),
    ("counters$load_rec", 1),
    ("counters$value", 8),
];

/// The core's output ports and their widths, in the order they are packed into the output word
/// (and read back by [`outputs`]).
pub(super) const OUTPUTS: [(&str, u32); 26] = [
    ("tx", 1),
    ("rx_valid", 1),
    ("transmit$addr", 4),
    ("transmit$done", 1),
    ("transmit$success", 1),
    ("rx_frame$header", 1),
    ("rx_frame$id", 29),
    ("rx_frame$ide", 1),
    ("rx_frame$rtr", 1),
    ("rx_frame$dlc", 4),
    ("rx_frame$strobe", 1),
    ("rx_frame$data", 8),
    ("rx_frame$index", 3),
    ("status$bus_error", 1),
    ("status$ecc", 8),
    ("status$arbitration_lost", 1),
    ("status$alc", 5),
    ("status$tec", 8),
    ("status$rec", 8),
    ("status$error_passive", 1),
    ("status$bus_off", 1),
    ("status$transmitting", 1),
    ("status$receiving", 1),
    ("status$state", 5),
    ("sample_point", 1),
    ("segment", 2),
];

/// The outputs only a trace shows, which a skip of quiet edges in an untraced run may change on
/// the way (`super::quiet`): the sample point and the segment.
fn untraced_outputs() -> u128 {
    OUTPUTS
        .iter()
        .zip(PACKED_OUTPUTS)
        .filter(|((name, _), _)| ["sample_point", "segment"].contains(name))
        .fold(0, |mask, ((_, width), (_, at))| {
            mask | ((1u128 << width) - 1) << at
        })
}

/// `ports` (name, width) as (name, bit position) when packed one after the other in that order.
const fn packed<const N: usize>(ports: &[(&'static str, u32); N]) -> [(&'static str, u32); N] {
    let mut placed = *ports;
    let mut at = 0;
    let mut k = 0;
    while k < N {
        placed[k].1 = at;
        at += ports[k].1;
        k += 1;
    }
    placed
}

/// The input ports at their positions in the input word.
pub(super) static PACKED_INPUTS: [(&str, u32); INPUTS.len()] = packed(&INPUTS);
/// The output ports at their positions in the output word.
pub(super) static PACKED_OUTPUTS: [(&str, u32); OUTPUTS.len()] = packed(&OUTPUTS);

/// The Verilog of [`CanCore`] as rust-hdl generates it (top module [`TOP`]).
pub(super) fn core_verilog() -> String {
    let mut uut = CanCore::default();
    uut.connect_all();
    check_all(&uut).expect("rust-hdl connectivity checks of the CAN core");
    generate_verilog(&uut)
}

/// Where the core's ports sit in the model's words.
pub(super) fn interface(verilog: &str) -> emit::Interface<'_> {
    emit::Interface {
        clock: "clock",
        inputs: &PACKED_INPUTS,
        outputs: &PACKED_OUTPUTS,
        verilog,
        state: &super::quiet::CORE_STATE,
    }
}

/// The input word of `inputs` (ports in [`INPUTS`] order).
pub(super) fn input_word(i: &CoreInputs) -> u64 {
    let values = [
        u64::from(i.reset),
        u64::from(i.rx),
        u64::from(i.enable),
        u64::from(i.brp),
        u64::from(i.tseg1),
        u64::from(i.tseg2),
        u64::from(i.sjw),
        u64::from(i.sam),
        u64::from(i.listen_only),
        u64::from(i.self_test),
        u64::from(i.request),
        u64::from(i.single_shot),
        u64::from(i.abort),
        u64::from(i.info),
        u64::from(i.data),
        u64::from(i.load_tec),
        u64::from(i.load_rec),
        u64::from(i.value),
    ];
    values
        .iter()
        .zip(PACKED_INPUTS)
        .zip(INPUTS)
        .fold(0, |word, ((v, (_, at)), (_, width))| {
            word | (v & ((1 << width) - 1)) << at
        })
}

/// Reads the ports of the output word in [`OUTPUTS`] order.
struct Reader {
    word: u128,
    next: usize,
}

impl Reader {
    fn field(&mut self) -> u64 {
        let ((_, at), (_, width)) = (PACKED_OUTPUTS[self.next], OUTPUTS[self.next]);
        self.next += 1;
        (self.word >> at) as u64 & ((1 << width) - 1)
    }

    fn bit(&mut self) -> bool {
        self.field() != 0
    }

    fn byte(&mut self) -> u8 {
        self.field() as u8
    }
}

/// The outputs packed in `word` (struct fields are evaluated in the order written: [`OUTPUTS`]'s).
pub(super) fn outputs(word: u128) -> CoreOutputs {
    let mut r = Reader { word, next: 0 };
    let out = CoreOutputs {
        tx: r.bit(),
        rx_valid: r.bit(),
        tx_addr: r.byte(),
        tx_done: r.bit(),
        tx_success: r.bit(),
        rx_header: r.bit(),
        rx_id: r.field() as u32,
        rx_ide: r.bit(),
        rx_rtr: r.bit(),
        rx_dlc: r.byte(),
        rx_strobe: r.bit(),
        rx_data: r.byte(),
        rx_index: r.byte(),
        bus_error: r.bit(),
        ecc: r.byte(),
        arbitration_lost: r.bit(),
        alc: r.byte(),
        tec: r.byte(),
        rec: r.byte(),
        error_passive: r.bit(),
        bus_off: r.bit(),
        transmitting: r.bit(),
        receiving: r.bit(),
        state: protocol_state(r.field()),
        sample_point: r.bit(),
        segment: r.byte(),
    };
    debug_assert_eq!(r.next, OUTPUTS.len(), "every output read");
    out
}

/// One CAN core of the compiled engine.
#[derive(Clone)]
pub struct CompiledCore {
    model: Box<core_model::Model>,
    /// The inputs the model holds (`None` before the first cycle).
    applied: Option<CoreInputs>,
    /// The output word of the last cycle and its ports (most cycles change no output: they are
    /// unpacked only when the word changed).
    word: u128,
    out: CoreOutputs,
    every_group: bool,
}

impl CompiledCore {
    /// A core at power-up (apply a reset before use); `every_group` runs every group of cells at
    /// every evaluation (for checking the skipping). An error if the checked-in model does not
    /// match `rtl/`.
    pub fn new(every_group: bool) -> Result<CompiledCore, EngineError> {
        check_model_is_current(Design::Core, core_model::VERILOG_HASH)?;
        let model = Box::new(core_model::Model::new());
        let word = model.outputs();
        Ok(CompiledCore {
            model,
            applied: None,
            word,
            out: outputs(word),
            every_group,
        })
    }

    /// One clock cycle: `inputs` applied, the rising edge, the clock low again.
    pub fn cycle(&mut self, inputs: &CoreInputs) -> CoreOutputs {
        if self.applied != Some(*inputs) {
            self.model.set_inputs(input_word(inputs));
            self.model.eval(self.every_group);
            self.applied = Some(*inputs);
        }
        self.model.edge();
        self.model.eval(self.every_group);
        self.take_outputs()
    }

    /// The outputs after the last cycle (unpacked again only when the word changed).
    fn take_outputs(&mut self) -> CoreOutputs {
        let word = self.model.outputs();
        if word != self.word {
            self.word = word;
            self.out = outputs(word);
        }
        self.out
    }

    /// How many cycles from the next one on, all with `inputs`, change nothing outside the
    /// core's bit timing counters (no output but, unless `traced`, the sample point and the
    /// segment; no other register: [`super::quiet`]). 0 when `inputs` differ from the last
    /// cycle's.
    pub fn quiet_cycles(&self, inputs: &CoreInputs, traced: bool) -> u64 {
        if self.applied != Some(*inputs) || inputs.reset {
            return 0;
        }
        match super::quiet::quiet_cycles(&*self.model, inputs.rx, traced) {
            0 => 0,
            cycles if self.model.settled() => cycles,
            _ => 0,
        }
    }

    /// Runs `cycles` quiet cycles (at most [`CompiledCore::quiet_cycles`] gave) in one step.
    /// `checked`: also runs them one by one on a copy and panics unless every output stayed (the
    /// sample point and the segment only if `traced`) and the two end in the same state.
    pub fn skip(&mut self, cycles: u64, traced: bool, checked: bool) {
        let copy = checked.then(|| self.clone());
        super::quiet::advance(&mut *self.model, cycles);
        self.take_outputs();
        if let Some(mut copy) = copy {
            let inputs = copy.applied.expect("a cycle ran before the skip");
            let seen = if traced {
                u128::MAX
            } else {
                !untraced_outputs()
            };
            let before = copy.model.outputs() & seen;
            let step = || {
                copy.cycle(&inputs);
                copy.model.outputs() & seen
            };
            super::quiet::assert_stepping_agrees("core", cycles, before, step);
            super::quiet::assert_same_state("core", cycles, copy.model.differences(&self.model));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ports_fit_their_words() {
        let last_in = INPUTS.len() - 1;
        assert!(PACKED_INPUTS[last_in].1 + INPUTS[last_in].1 <= 64);
        let last_out = OUTPUTS.len() - 1;
        assert!(PACKED_OUTPUTS[last_out].1 + OUTPUTS[last_out].1 <= 128);
    }

    #[test]
    fn every_input_lands_at_its_port() {
        let inputs = CoreInputs {
            brp: 0x3f,
            value: 0x81,
            ..CoreInputs::default()
        };
        let word = input_word(&inputs);
        assert_eq!(word >> PACKED_INPUTS[3].1 & 0x3f, 0x3f, "brp");
        assert_eq!(word >> PACKED_INPUTS[17].1, 0x81, "value, the last port");
        assert_eq!(word.count_ones(), 8);
    }
}
