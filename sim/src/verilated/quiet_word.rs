//! The quiet word of a Verilated controller: the nets of [`quiet::CONTROLLER_STATE`] as the
//! wrapper brings them out (`sources::wrapper_verilog`), where each sits (found in the generated
//! Verilog, [`StateElements`]), read and written as the compiled engine's [`quiet::Counters`], so
//! that both engines skip the same edges by the same arithmetic (`crate::compiled::quiet`).

use crate::compiled::quiet::{self, Counters};
use crate::verilated::verilog::TOP_MODULE;

/// Bit of the quiet state (`VerilatedController::quiet_state`) that says every flip-flop but the
/// counters and every memory is settled (the wrapper's `p_settled`, below the state nets).
pub(crate) const QUIET_SETTLED: u32 = 63;

/// The flip-flops and memories of the generated controller, by instance path below the top module
/// (`core.bit_timing.clocks`): rust-hdl emits each `DFF` as a module with the ports `d`, `q`,
/// `clock` and each RAM as one with `read_address` … `write_enable`, every one instantiated once.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct StateElements {
    /// Each flip-flop's path and width.
    pub flip_flops: Vec<(String, u32)>,
    /// Each memory's path.
    pub memories: Vec<String>,
}

const DFF_PORTS: &str = "(d,q,clock);";
const RAM_PORTS: &str =
    "(read_address,read_clock,read_data,write_address,write_clock,write_data,write_enable);";

impl StateElements {
    /// Finds them in `verilog` by walking the instances from [`TOP_MODULE`].
    pub(crate) fn of(verilog: &str) -> StateElements {
        let mut modules = std::collections::HashMap::new();
        for text in verilog.split("\nmodule ").skip(1) {
            let name = text.split('(').next().unwrap_or_default();
            modules.insert(name, text);
        }
        let mut found = StateElements::default();
        let mut pending = vec![(String::new(), TOP_MODULE)];
        while let Some((path, module)) = pending.pop() {
            let text = modules[module];
            let header = text.lines().next().unwrap_or_default();
            if header.ends_with(DFF_PORTS) {
                found.flip_flops.push((path, output_width(text, "q")));
                continue;
            }
            if header.ends_with(RAM_PORTS) {
                found.memories.push(path);
                continue;
            }
            for line in text.lines().skip(1) {
                let mut words = line.trim().split(' ');
                if let (Some(child), Some(instance), None) =
                    (words.next(), words.next(), words.next())
                {
                    if let (Some(child), Some(instance)) =
                        (modules.get_key_value(child), instance.strip_suffix('('))
                    {
                        let at = if path.is_empty() {
                            instance.to_string()
                        } else {
                            format!("{path}.{instance}")
                        };
                        pending.push((at, child.0));
                    }
                }
            }
        }
        found.flip_flops.sort();
        found.memories.sort();
        found
    }
}

/// The width of output `port` declared in a module's text (`output reg [5:0] q;`).
fn output_width(module: &str, port: &str) -> u32 {
    let decl = module
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("output") && l.ends_with(&format!(" {port};")))
        .unwrap_or_else(|| panic!("a flip-flop module without output {port}"));
    match decl.find('[') {
        Some(open) => {
            decl[open + 1..decl.find(':').unwrap()]
                .parse::<u32>()
                .unwrap()
                + 1
        }
        None => 1,
    }
}

/// One net of [`quiet::CONTROLLER_STATE`] in the quiet word.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct QuietField {
    /// The flip-flop's instance path (the state net without its `.q`).
    pub path: String,
    /// Its lowest bit in the word.
    pub shift: u32,
    /// Its width.
    pub width: u32,
    /// A free-running counter that a skip loads.
    pub counter: bool,
}

/// Where each net of [`quiet::CONTROLLER_STATE`] sits in the quiet word (below [`QUIET_SETTLED`]),
/// in that table's order.
pub(crate) fn quiet_layout(elements: &StateElements) -> Vec<QuietField> {
    let mut shift = 0;
    let layout: Vec<QuietField> = quiet::CONTROLLER_STATE
        .iter()
        .map(|&(net, counter)| {
            let path = net.strip_suffix(".q").expect("a flip-flop's output");
            let width = elements
                .flip_flops
                .iter()
                .find(|(p, _)| p == path)
                .unwrap_or_else(|| panic!("{net} is no flip-flop of the generated Verilog"))
                .1;
            let field = QuietField {
                path: path.to_string(),
                shift,
                width,
                counter,
            };
            shift += width;
            field
        })
        .collect();
    assert!(
        shift <= QUIET_SETTLED,
        "the quiet state fits below the settled bit"
    );
    layout
}

/// A quiet word with the layout of its library; `set_state` changes the copy, which the caller
/// then loads into the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct QuietWord<'a> {
    /// The state nets, each at its field of `layout`.
    pub word: u64,
    /// Where each net of [`quiet::CONTROLLER_STATE`] is, in that table's order.
    pub layout: &'a [QuietField],
}

impl QuietWord<'_> {
    /// The names of the state nets in which two words differ.
    pub(super) fn differences(self, other: QuietWord) -> Vec<&'static str> {
        (0..self.layout.len())
            .filter(|&i| self.state(i) != other.state(i))
            .map(|i| quiet::CONTROLLER_STATE[i].0)
            .collect()
    }
}

fn mask(field: &QuietField) -> u64 {
    ((1u64 << field.width) - 1) << field.shift
}

impl Counters for QuietWord<'_> {
    const CONTROLLER: bool = true;

    fn state(&self, i: usize) -> u64 {
        let field = &self.layout[i];
        (self.word & mask(field)) >> field.shift
    }

    fn set_state(&mut self, i: usize, value: u64) {
        let field = &self.layout[i];
        self.word = self.word & !mask(field) | value << field.shift & mask(field);
    }

    /// Nothing to evaluate in a copy: loading it into the model evaluates.
    fn evaluate(&mut self) {}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::verilated::verilog::controller_verilog;

    #[test]
    fn every_state_net_reads_back_what_was_written_without_touching_the_others() {
        let layout = quiet_layout(&StateElements::of(&controller_verilog()));
        let mut word = QuietWord {
            word: 0,
            layout: &layout,
        };
        for (i, field) in layout.iter().enumerate() {
            let net = quiet::CONTROLLER_STATE[i].0;
            let all_ones = (1u64 << field.width) - 1;
            word.set_state(i, all_ones);
            assert_eq!(word.state(i), all_ones, "{net}");
            assert_eq!(word.word.count_ones(), field.width, "{net} alone");
            word.set_state(i, 0);
        }
        assert_eq!(word.word, 0);
    }

    /// The wrapper compares every flip-flop but the counters the skip loads, and every memory.
    #[test]
    fn the_elements_found_are_the_controllers_flip_flops_and_three_memories() {
        let elements = StateElements::of(&controller_verilog());
        assert_eq!(elements.memories.len(), 3, "{:?}", elements.memories);
        let bits: u32 = elements.flip_flops.iter().map(|(_, w)| w).sum();
        // rust-hdl's flip-flops hold the controller's registers (iCE40 maps 403 of them after
        // optimisation; the Verilog has more, e.g. constant or merged bits).
        assert!(bits >= 403, "{bits} flip-flop bits");
        for (net, _) in quiet::CONTROLLER_STATE {
            let path = net.strip_suffix(".q").unwrap();
            assert!(
                elements.flip_flops.iter().any(|(p, _)| p == path),
                "{net} not found"
            );
        }
    }
}
