//! The generated methods the engine's edge skipping uses (`crate::compiled::quiet`): reading
//! and writing named flip-flops, and telling whether the next edge would change anything but the
//! free-running ones.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::{hex, Emitter};
use crate::compiled::cells::Operands;
use crate::compiled::netlist::Bit;

impl Emitter<'_> {
    /// `state`, `set_state` (the free-running nets only, which must be flip-flop outputs),
    /// `settled` and `differences` for the nets of [`super::Interface::state`] (nothing when the
    /// list is empty).
    pub(super) fn quiet(&self) -> Result<String, String> {
        if self.io.state.is_empty() {
            return Ok(String::new());
        }
        let (mut get, mut set) = (String::new(), String::new());
        let mut free = vec![false; self.regs.len()];
        for (i, (name, free_running)) in self.io.state.iter().enumerate() {
            let bits = self.output_bits(name)?;
            writeln!(get, "            {i} => {}, // {name}", self.operand(bits)?).unwrap();
            if !free_running {
                continue; // read only: a register, or an input
            }
            let flip_flops = self.flip_flop_bits(name, bits)?;
            for &k in flip_flops.keys() {
                free[k] = true;
            }
            writeln!(set, "            {i} => {{ // {name}").unwrap();
            for (k, placed) in &flip_flops {
                let clear = placed.iter().fold(0u64, |m, &(_, at)| m | 1 << at);
                let moves: String = placed
                    .iter()
                    .map(|&(from, at)| format!(" | (value >> {from} & 1) << {at}"))
                    .collect();
                let readers = self.readers_mask(&self.reads(self.regs[*k].port("Q")?), None);
                writeln!(
                    set,
                    "                let q = self.q{k} & !{}{moves};\n                \
                     if q != self.q{k} {{ self.q{k} = q; self.dirty |= {readers:#x}; }}",
                    hex(clear)
                )
                .unwrap();
            }
            set.push_str("            }\n");
        }
        let settled = self.settled_code(&free);
        let differences = self.differences_code()?;
        Ok(format!(
            "
    /// The value of net `i` of the design's state list for edge skipping (flip-flop outputs and
    /// inputs).
    pub(super) fn state(&self, i: usize) -> u64 {{
        match i {{
{get}            _ => panic!(\"no state net {{i}}\"),
        }}
    }}

    /// Writes `value` into the flip-flops of free-running state net `i` (as if an edge had
    /// loaded it); the groups that read a changed one run at the next `eval`.
    pub(super) fn set_state(&mut self, i: usize, value: u64) {{
        match i {{
{set}            _ => panic!(\"no free-running state net {{i}}\"),
        }}
    }}

    /// The next edge writes no memory, changes no memory's read register and no flip-flop but the
    /// free-running ones of the state list: the groups that did not run since the last edge hold (`n` equals `q`), those
    /// that ran are compared.
    pub(super) fn settled(&self) -> bool {{
        let ran = self.ran;
{settled}        true
    }}

    /// The flip-flops, memories, values and output word that differ from `other`'s (which
    /// groups ran since the last edge may differ), by name.
    pub(super) fn differences(&self, other: &Model) -> Vec<&'static str> {{
        let mut names = Vec::new();
{differences}        names
    }}
"
        ))
    }

    /// The flip-flops behind `bits` of net `name` (constant bits left out): for each, the (net
    /// bit, flip-flop bit) pairs.
    fn flip_flop_bits(
        &self,
        name: &str,
        bits: &[Bit],
    ) -> Result<BTreeMap<usize, Vec<(usize, usize)>>, String> {
        let mut flip_flops: BTreeMap<usize, Vec<(usize, usize)>> = BTreeMap::new();
        for (from, bit) in bits.iter().enumerate() {
            if let Bit::Const(_) = bit {
                continue; // a constant bit of the register: nothing to read or write
            }
            let found = self.regs.iter().enumerate().find_map(|(k, cell)| {
                let q = cell.port("Q").ok()?;
                q.iter().position(|b| b == bit).map(|at| (k, at))
            });
            let Some((k, at)) = found else {
                return Err(format!(
                    "state net `{name}` bit {from} is not a flip-flop output"
                ));
            };
            flip_flops.entry(k).or_default().push((from, at));
        }
        Ok(flip_flops)
    }

    /// The comparisons of `differences`.
    fn differences_code(&self) -> Result<String, String> {
        let mut code = String::new();
        let mut compare = |field: String, name: &str| {
            writeln!(
                code,
                "        if self.{field} != other.{field} {{ names.push(\"{field} {}\"); }}",
                name.replace(['\\', '"'], "")
            )
            .unwrap();
        };
        for (k, cell) in self.regs.iter().enumerate() {
            compare(format!("q{k}"), &cell.name);
            compare(format!("n{k}"), &cell.name);
        }
        for (k, cell) in self.mems.iter().enumerate() {
            for field in ["", "_rd", "_re", "_ra", "_wa", "_wd", "_we"] {
                compare(format!("m{k}{field}"), &cell.name);
            }
        }
        for k in &self.exported {
            compare(format!("v{k}"), &self.comb[*k].name);
        }
        compare("dirty".into(), "");
        compare("out".into(), "");
        Ok(code)
    }

    /// The tests of `settled`: memory write enables and read registers, then per group that ran its flip-flops that
    /// are not free-running.
    fn settled_code(&self, free: &[bool]) -> String {
        let mut code = String::new();
        for k in 0..self.mems.len() {
            writeln!(
                code,
                "        if self.m{k}_we != 0 || self.m{k}_re && \
                 self.m{k}.get(self.m{k}_ra).copied().unwrap_or(0) != self.m{k}_rd {{ return false; }}"
            )
            .unwrap();
        }
        for g in 0..self.groups.count {
            let tests: Vec<String> = (0..self.regs.len())
                .filter(|&k| self.groups.of_reg[k] == g && !free[k])
                .map(|k| format!("self.q{k} != self.n{k}"))
                .collect();
            if !tests.is_empty() {
                writeln!(
                    code,
                    "        if ran >> {g} & 1 != 0 && ({}) {{ return false; }}",
                    tests.join(" || ")
                )
                .unwrap();
            }
        }
        code
    }
}
