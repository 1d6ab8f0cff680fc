//! The expression of a list of bits as seen from the group being written: runs of one variable's
//! consecutive bits become one shift and mask, constants one literal, values of other groups their
//! fields.

use std::fmt::Write as _;

use super::{hex, mask, Emitter, Source};
use crate::compiled::cells::Operands;
use crate::compiled::netlist::Bit;

impl Operands for Emitter<'_> {
    /// The expression of a list of bits (least significant first), at most 64 of them, as seen
    /// from the group being written.
    fn operand(&self, bits: &[Bit]) -> Result<String, String> {
        if bits.len() > 64 {
            return Err(format!("a {}-bit operand (at most 64 bits)", bits.len()));
        }
        let mut constant = 0u64;
        // (var, first bit of var, position, length)
        let mut runs: Vec<(usize, usize, usize, usize)> = Vec::new();
        for (at, bit) in bits.iter().enumerate() {
            let Bit::Net(n) = bit else {
                constant |= u64::from(*bit == Bit::Const(true)) << at;
                continue;
            };
            let Some(&(var, from)) = self.drivers.get(n) else {
                continue; // undriven: Yosys's x, read as 0
            };
            if self.vars[var].source == Source::Zero {
                continue;
            }
            match runs.last_mut() {
                Some(run) if run.0 == var && run.1 + run.3 == from && run.2 + run.3 == at => {
                    run.3 += 1
                }
                _ => runs.push((var, from, at, 1)),
            }
        }
        let mut terms: Vec<String> = runs
            .iter()
            .map(|&(var, from, at, len)| {
                let v = &self.vars[var];
                let name = match v.source {
                    Source::Comb(k) if self.groups.of_comb[k] != self.current => {
                        format!("self.v{k}")
                    }
                    _ => v.expr.clone(),
                };
                let mut t = if from == 0 {
                    name
                } else {
                    format!("({name} >> {from})")
                };
                if from + len < v.width {
                    t = format!("({t} & {})", hex(mask(len)));
                }
                if at > 0 {
                    t = format!("({t} << {at})");
                }
                t
            })
            .collect();
        if constant != 0 || terms.is_empty() {
            terms.push(hex(constant));
        }
        Ok(terms.join(" | "))
    }

    fn table(&mut self, words: &[u64]) -> String {
        let name = format!("TABLE_{}", self.tables.lines().count());
        let list: Vec<String> = words.iter().map(|w| hex(*w)).collect();
        writeln!(
            self.tables,
            "const {name}: [u64; {}] = [{}];",
            words.len(),
            list.join(", ")
        )
        .unwrap();
        name
    }
}
