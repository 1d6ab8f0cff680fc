//! The quiet word of a Verilated controller (`sources::wrapper_verilog`: the nets of
//! [`quiet::CONTROLLER_STATE`]) read and written as the
//! compiled engine's [`quiet::Counters`], so that both engines skip the same edges by the same
//! arithmetic (`crate::compiled::quiet`).

use super::sources::QuietField;
use crate::compiled::quiet::{self, Counters};

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
    const DIVIDER: bool = true;

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
    use crate::verilated::sources::{quiet_layout, StateElements};
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
        // rust-hdl's flip-flops hold the controller's registers (iCE40 maps 441 of them after
        // optimisation; the Verilog has more, e.g. constant or merged bits).
        assert!(bits >= 441, "{bits} flip-flop bits");
        for (net, _) in quiet::CONTROLLER_STATE {
            let path = net.strip_suffix(".q").unwrap();
            assert!(
                elements.flip_flops.iter().any(|(p, _)| p == path),
                "{net} not found"
            );
        }
    }
}
