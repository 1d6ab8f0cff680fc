//! The generated code of the state: the next value of each flip-flop (by its cell type), and the
//! fields, power-up values and edge code of flip-flops, memories and the values read across groups.

use std::fmt::Write as _;

use super::{hex, Emitter};
use crate::compiled::cells::Operands;
use crate::compiled::netlist::Bit;

impl Emitter<'_> {
    /// The value flip-flop `k` takes at the next edge, by its cell type (a synchronous reset wins
    /// over the enable in `$sdffe`, the enable over the reset in `$sdffce`, as in Yosys).
    pub(super) fn next_state(&self, k: usize) -> Result<String, String> {
        let cell = self.regs[k];
        let d = self.input(cell, "D")?;
        let hold = format!("self.q{k}");
        let when = |port: &str| -> Result<String, String> {
            let active = if cell.flag(&format!("{port}_POLARITY"), true)? {
                "!="
            } else {
                "=="
            };
            Ok(format!("{} {active} 0", self.input(cell, port)?))
        };
        let reset_value = || -> Result<String, String> { Ok(hex(cell.param("SRST_VALUE")?)) };
        Ok(match cell.kind.as_str() {
            "dff" => d,
            "dffe" => format!("if {} {{ {d} }} else {{ {hold} }}", when("EN")?),
            "sdff" => format!(
                "if {} {{ {} }} else {{ {d} }}",
                when("SRST")?,
                reset_value()?
            ),
            "sdffe" => format!(
                "if {} {{ {} }} else if {} {{ {d} }} else {{ {hold} }}",
                when("SRST")?,
                reset_value()?,
                when("EN")?
            ),
            "sdffce" => format!(
                "if {} {{ if {} {{ {} }} else {{ {d} }} }} else {{ {hold} }}",
                when("EN")?,
                when("SRST")?,
                reset_value()?
            ),
            other => return Err(format!("cell {}: flip-flop ${other}", cell.name)),
        })
    }

    /// Fields, initial values and edge code of flip-flops, memories and exported values.
    pub(super) fn state(&self) -> Result<(String, String, String), String> {
        let (mut fields, mut init, mut edge) = (String::new(), String::new(), String::new());
        for (k, cell) in self.mems.iter().enumerate() {
            let size = cell.param("SIZE")? as usize;
            let width = cell.param("WIDTH")? as usize;
            let contents: Vec<String> = cell
                .param_bits("INIT")?
                .chunks(width)
                .chain(std::iter::repeat(&[][..]))
                .take(size)
                .map(|w| {
                    hex(w
                        .iter()
                        .enumerate()
                        .fold(0, |v, (i, b)| v | u64::from(*b) << i))
                })
                .collect();
            writeln!(
                fields,
                "    m{k}: [u64; {size}],\n    m{k}_rd: u64,\n    m{k}_re: bool,\n    m{k}_ra: usize,\n    \
                 m{k}_wa: usize,\n    m{k}_wd: u64,\n    m{k}_we: u64,"
            )
            .unwrap();
            writeln!(
                init,
                "            m{k}: [{}],\n            m{k}_rd: 0,\n            m{k}_re: false,\n            \
                 m{k}_ra: 0,\n            m{k}_wa: 0,\n            m{k}_wd: 0,\n            m{k}_we: 0,",
                contents.join(", ")
            )
            .unwrap();
            let readers = self.readers_mask(&self.reads(cell.port("RD_DATA")?), None);
            writeln!(
                edge,
                "        if self.m{k}_re {{ let v = self.m{k}.get(self.m{k}_ra).copied().unwrap_or(0); \
                 if v != self.m{k}_rd {{ self.m{k}_rd = v; dirty |= {readers:#x}; }} }} // {}",
                cell.name
            )
            .unwrap();
        }
        // Every memory reads before any is written: the read ports return the old word.
        for k in 0..self.mems.len() {
            writeln!(
                edge,
                "        if self.m{k}_we != 0 {{ if let Some(word) = self.m{k}.get_mut(self.m{k}_wa) {{ \
                 *word = *word & !self.m{k}_we | self.m{k}_wd & self.m{k}_we; }} }}"
            )
            .unwrap();
        }
        // A flip-flop's `n` changes only when its group runs: the others are not compared.
        let mut loads: Vec<String> = vec![String::new(); self.groups.count];
        for (k, cell) in self.regs.iter().enumerate() {
            let q = cell.port("Q")?;
            let start = q.iter().enumerate().fold(0u64, |v, (i, bit)| match bit {
                Bit::Net(n) => v | u64::from(self.netlist.init.get(n) == Some(&true)) << i,
                Bit::Const(_) => v,
            });
            writeln!(fields, "    q{k}: u64,\n    n{k}: u64,").unwrap();
            writeln!(
                init,
                "            q{k}: {0},\n            n{k}: {0},",
                hex(start)
            )
            .unwrap();
            let readers = self.readers_mask(&self.reads(q), None);
            writeln!(
                loads[self.groups.of_reg[k]],
                "            if self.q{k} != self.n{k} {{ self.q{k} = self.n{k}; dirty |= {readers:#x}; }} // {}",
                cell.name
            )
            .unwrap();
        }
        writeln!(edge, "        let ran = self.ran;\n        self.ran = 0;").unwrap();
        for (g, code) in loads.iter().enumerate().filter(|(_, c)| !c.is_empty()) {
            writeln!(edge, "        if ran >> {g} & 1 != 0 {{\n{code}        }}").unwrap();
        }
        for k in &self.exported {
            writeln!(fields, "    v{k}: u64,").unwrap();
            writeln!(init, "            v{k}: 0,").unwrap();
        }
        Ok((fields, init, edge))
    }
}
