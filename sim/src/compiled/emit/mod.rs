//! Turns a word-level Yosys [`Netlist`] into straight-line Rust: a struct holding the inputs, every
//! flip-flop (`q`, and `n`, its value after the next edge), every memory, and three methods:
//! `set_inputs` takes the input word, `eval` computes the combinational logic, the flip-flops' next
//! values and the output word, `edge` loads the flip-flops and memories.
//!
//! The cells are grouped by the rust-hdl block (Verilog module) they come from (`groups`: runs of
//! one block's cells in a dependency order), and the groups run in that order. `eval` runs a group
//! only when something it reads changed since it last ran: an input, a flip-flop or memory output
//! loaded at the edge, or a value of an earlier group. Values read outside their group live in
//! fields, compared when written. Every group computes a pure function of what it reads, so the
//! skipped groups' values are the ones a full evaluation would compute.
//!
//! Values are `u64`s holding a signal's bits from bit 0, always masked to the signal's width. A cell
//! the generator does not know, a signed operation, a signal wider than 64 bits (other than a
//! constant table indexed by `$shiftx`) or a second clock are refused with the cell's name: the
//! generated model must mean exactly what the Verilog means.

use std::collections::{BTreeSet, HashMap};
use std::fmt::Write as _;

use super::cells::{cell_value, Operands};
use super::groups::{group_cells, Groups, Item};
use super::netlist::{Bit, Cell, Netlist};

mod operands;
mod quiet;
mod state;

/// Groups per block of calls in `eval` (see `eval_body`).
const CALL_BLOCK: usize = 8;

/// Where the model's ports sit in the input and output words.
pub(crate) struct Interface<'a> {
    /// The clock input (seen as data it reads 0: outputs are read with the clock low).
    pub clock: &'a str,
    /// Input port and its bit position in the input word.
    pub inputs: &'a [(&'a str, u32)],
    /// Output port or named net, and its bit position in the output word.
    pub outputs: &'a [(&'a str, u32)],
    /// The Verilog the netlist was made from (its module boundaries group the cells).
    pub verilog: &'a str,
    /// Flip-flop outputs (named nets) the model reads and writes by their index in this list, for
    /// the engine's edge skipping (`crate::compiled::quiet`); `true` marks a free-running one, which the
    /// skipped cycles may change. Empty: the model has no skipping methods.
    pub state: &'a [(&'a str, bool)],
}

/// The generated source of the model for `netlist`.
pub(crate) fn emit(netlist: &Netlist, io: &Interface, header: &str) -> Result<String, String> {
    Emitter::new(netlist, io)?.source(header)
}

pub(crate) fn mask(width: usize) -> u64 {
    if width >= 64 {
        u64::MAX
    } else {
        (1u64 << width) - 1
    }
}

pub(crate) fn hex(value: u64) -> String {
    format!("{value:#x}")
}

/// What a variable of the generated code is.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Source {
    /// The clock as data: always 0.
    Zero,
    Input,
    Reg,
    MemRead,
    /// The output of combinational cell `k` (`c<k>`, in field `v<k>` when read outside its group).
    Comb(usize),
}

#[derive(Clone)]
struct Var {
    /// The field (inputs, flip-flops, memory read data) or the local (`c<k>`).
    expr: String,
    width: usize,
    source: Source,
}

const FLIP_FLOPS: [&str; 5] = ["dff", "dffe", "sdff", "sdffe", "sdffce"];

pub(crate) struct Emitter<'a> {
    netlist: &'a Netlist,
    io: &'a Interface<'a>,
    /// Which variable and bit drives each net.
    drivers: HashMap<u64, (usize, usize)>,
    vars: Vec<Var>,
    comb: Vec<&'a Cell>,
    regs: Vec<&'a Cell>,
    mems: Vec<&'a Cell>,
    groups: Groups,
    /// The group whose code is being written (its own values are locals).
    current: usize,
    /// Comb cells read outside their group (they get a field).
    exported: BTreeSet<usize>,
    /// The variables the outputs read.
    output_reads: BTreeSet<usize>,
    tables: String,
}

impl<'a> Emitter<'a> {
    fn new(netlist: &'a Netlist, io: &'a Interface<'a>) -> Result<Emitter<'a>, String> {
        let mut e = Emitter {
            netlist,
            io,
            drivers: HashMap::new(),
            vars: Vec::new(),
            comb: Vec::new(),
            regs: Vec::new(),
            mems: Vec::new(),
            groups: Groups::default(),
            current: 0,
            exported: BTreeSet::new(),
            output_reads: BTreeSet::new(),
            tables: String::new(),
        };
        for (name, bits) in &netlist.inputs {
            if name == io.clock {
                e.drive(bits, "0".into(), Source::Zero);
            } else {
                e.drive(bits, format!("self.i_{}", field_name(name)), Source::Input);
            }
        }
        for cell in &netlist.cells {
            if FLIP_FLOPS.contains(&cell.kind.as_str()) {
                e.check_clock(cell, "CLK")?;
                let expr = format!("self.q{}", e.regs.len());
                e.drive(cell.port("Q")?, expr, Source::Reg);
                e.regs.push(cell);
            } else if cell.kind == "mem_v2" {
                e.check_memory(cell)?;
                let expr = format!("self.m{}_rd", e.mems.len());
                e.drive(cell.port("RD_DATA")?, expr, Source::MemRead);
                e.mems.push(cell);
            } else {
                let k = e.comb.len();
                e.drive(cell.port("Y")?, format!("c{k}"), Source::Comb(k));
                e.comb.push(cell);
            }
        }
        let groups = group_cells(&e.comb, &e.regs, &e.mems, |bits| e.comb_reads(bits), io)?;
        e.groups = groups;
        e.groups.reads = e.group_reads();
        e.exported = e.find_exported()?;
        for (name, _) in io.outputs {
            let reads = e.reads(e.output_bits(name)?);
            e.output_reads.extend(reads);
        }
        Ok(e)
    }

    fn drive(&mut self, bits: &[Bit], expr: String, source: Source) {
        let var = self.vars.len();
        for (at, bit) in bits.iter().enumerate() {
            if let Bit::Net(n) = bit {
                self.drivers.insert(*n, (var, at));
            }
        }
        self.vars.push(Var {
            expr,
            width: bits.len(),
            source,
        });
    }

    /// The variables (by index) that `bits` read.
    fn reads(&self, bits: &[Bit]) -> BTreeSet<usize> {
        bits.iter()
            .filter_map(|b| match b {
                Bit::Net(n) => self.drivers.get(n).map(|(v, _)| *v),
                Bit::Const(_) => None,
            })
            .collect()
    }

    /// The combinational cells (by number) that `bits` read.
    fn comb_reads(&self, bits: &[Bit]) -> Vec<usize> {
        self.reads(bits)
            .into_iter()
            .filter_map(|v| match self.vars[v].source {
                Source::Comb(k) => Some(k),
                _ => None,
            })
            .collect()
    }

    fn check_clock(&self, cell: &Cell, port: &str) -> Result<(), String> {
        let clock = self
            .netlist
            .inputs
            .iter()
            .find(|(name, _)| name == self.io.clock)
            .map(|(_, bits)| bits.as_slice());
        if Some(cell.port(port)?) != clock || !cell.flag(&format!("{port}_POLARITY"), true)? {
            return Err(format!(
                "cell {} is not clocked by the rising edge of `{}`",
                cell.name, self.io.clock
            ));
        }
        Ok(())
    }

    fn check_memory(&self, cell: &Cell) -> Result<(), String> {
        let one_port = cell.param("RD_PORTS")? == 1 && cell.param("WR_PORTS")? == 1;
        let plain_read = cell.param("RD_CLK_ENABLE")? == 1
            && cell.param("RD_TRANSPARENCY_MASK")? == 0
            && cell.param("OFFSET")? == 0
            && cell.port("RD_SRST")? == [Bit::Const(false)]
            && cell.port("RD_ARST")? == [Bit::Const(false)];
        if !one_port || !plain_read || cell.param("WR_CLK_ENABLE")? != 1 {
            return Err(format!(
                "memory {}: only one clocked, non-transparent read port without resets and one \
                 clocked write port are supported",
                cell.name
            ));
        }
        self.check_clock(cell, "RD_CLK")?;
        self.check_clock(cell, "WR_CLK")
    }

    /// Every port an item of a group reads, with the item's group: the inputs of combinational
    /// cells, of flip-flops (and their own output, which a hold reads) and of memories.
    fn item_inputs(&self) -> Vec<(usize, &'a [Bit])> {
        let mut list = Vec::new();
        let mut add = |group: usize, cell: &'a Cell, output: &str| {
            for (port, bits) in &cell.connections {
                if port != output {
                    list.push((group, bits.as_slice()));
                }
            }
        };
        for (k, cell) in self.comb.iter().enumerate() {
            add(self.groups.of_comb[k], cell, "Y");
        }
        for (k, cell) in self.regs.iter().enumerate() {
            add(self.groups.of_reg[k], cell, "");
        }
        for (k, cell) in self.mems.iter().enumerate() {
            add(self.groups.of_mem[k], cell, "RD_DATA");
        }
        list
    }

    /// The variables each group reads (for the dirty masks).
    fn group_reads(&self) -> Vec<BTreeSet<usize>> {
        let mut reads = vec![BTreeSet::new(); self.groups.count];
        for (g, bits) in self.item_inputs() {
            reads[g].extend(self.reads(bits));
        }
        reads
    }

    /// Comb cells read by an item of another group or by the outputs (they get a field).
    fn find_exported(&self) -> Result<BTreeSet<usize>, String> {
        let mut exported = BTreeSet::new();
        for (g, bits) in self.item_inputs() {
            exported.extend(
                self.comb_reads(bits)
                    .into_iter()
                    .filter(|&k| self.groups.of_comb[k] != g),
            );
        }
        for (name, _) in self.io.outputs {
            exported.extend(self.comb_reads(self.output_bits(name)?));
        }
        Ok(exported)
    }

    fn output_bits(&self, name: &str) -> Result<&'a [Bit], String> {
        let netlist: &'a Netlist = self.netlist;
        netlist
            .outputs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| b.as_slice())
            .or_else(|| netlist.names.get(name).map(Vec::as_slice))
            .ok_or_else(|| format!("the netlist has no output or net `{name}`"))
    }

    /// The mask of the groups that read any of `vars` (other than the writer's own group), with
    /// the output word's bit ([`Emitter::output_bit`]) if an output reads one of them.
    fn readers_mask(&self, vars: &BTreeSet<usize>, own: Option<usize>) -> u128 {
        let mut mask = 0u128;
        for (g, reads) in self.groups.reads.iter().enumerate() {
            if Some(g) != own && !reads.is_disjoint(vars) {
                mask |= 1 << g;
            }
        }
        if !self.output_reads.is_disjoint(vars) {
            mask |= 1 << self.output_bit();
        }
        mask
    }

    /// The dirty bit of the output word: the one after the groups' (the word is computed again
    /// only when something it reads changed).
    fn output_bit(&self) -> usize {
        self.groups.count
    }

    fn source(mut self, header: &str) -> Result<String, String> {
        let (body, groups) = self.eval_body()?;
        let (fields, init, edge) = self.state()?;
        self.current = usize::MAX;
        let mut ports = Vec::new();
        for (name, at) in self.io.outputs {
            ports.push((*name, *at as usize, self.output_bits(name)?.len()));
        }
        let out = word_type(packed_width(ports)?, "output")?;
        let mut outputs = String::new();
        for (name, at) in self.io.outputs {
            let operand = self.operand(self.output_bits(name)?)?;
            write!(outputs, " | (({operand}) as {out}) << {at}").unwrap();
        }
        let (inputs, input_fields, input_init, input) = self.inputs()?;
        let quiet = self.quiet()?;
        let out_bit = self.output_bit();
        // The groups' bits and the output word's.
        let all = u128::MAX >> (127 - out_bit);
        Ok(format!(
            "{header}
{tables}
/// The design's state: inputs, flip-flops (`q` now, `n` after the next edge), memories, the
/// values read across groups, the groups to run at the next `eval` and those run since the last edge.
#[derive(Clone, PartialEq)]
pub(super) struct Model {{
{input_fields}{fields}    dirty: u128,
    ran: u128,
    out: {out},
}}

impl Model {{
    /// The power-up state (the `init` values of the Verilog); every group runs at the first `eval`.
    pub(super) fn new() -> Model {{
        Model {{
{input_init}{init}            dirty: {all:#x},
            ran: {all:#x},
            out: 0,
        }}
    }}

    /// Takes the input word.
    pub(super) fn set_inputs(&mut self, word: {input}) {{
{inputs}    }}

    /// The output word computed by the last `eval`.
    pub(super) fn outputs(&self) -> {out} {{
        self.out
    }}

    /// The groups whose inputs changed (all with `every_group`), in dependency order (a group
    /// marks only later ones); then the output word if something it reads changed.
    pub(super) fn eval(&mut self, every_group: bool) {{
        let mut dirty = if every_group {{ {all:#x} }} else {{ self.dirty }};
{body}        self.dirty = 0;
        self.ran |= dirty;
        if dirty >> {out_bit} & 1 != 0 {{
            self.out = 0{outputs};
        }}
    }}

    /// The rising clock edge: memories read, then written; the flip-flops of the groups run since
    /// the last edge loaded (the others' `n` still equals `q`).
    pub(super) fn edge(&mut self) {{
        let mut dirty = 0u128;
{edge}        self.dirty |= dirty;
    }}
{quiet}{groups}}}
",
            tables = self.tables
        ))
    }

    /// The code of `set_inputs`, the input fields, their power-up values and the input word's type.
    fn inputs(&self) -> Result<(String, String, String, &'static str), String> {
        let (mut code, mut fields, mut init) = (String::new(), String::new(), String::new());
        let mut ports = Vec::new();
        for (port, at) in self.io.inputs {
            let (_, bits) = self
                .netlist
                .inputs
                .iter()
                .find(|(n, _)| n == port)
                .ok_or_else(|| format!("the netlist has no input `{port}`"))?;
            ports.push((*port, *at as usize, bits.len()));
            let name = field_name(port);
            let readers = self.readers_mask(&self.reads(bits), None);
            let m = hex(mask(bits.len()));
            writeln!(
                code,
                "        let v = (word >> {at}) as u64 & {m};\n        if v != self.i_{name} {{ \
                 self.i_{name} = v; self.dirty |= {readers:#x}; }}"
            )
            .unwrap();
            writeln!(fields, "    i_{name}: u64,").unwrap();
            writeln!(init, "            i_{name}: 0,").unwrap();
        }
        Ok((
            code,
            fields,
            init,
            word_type(packed_width(ports)?, "input")?,
        ))
    }

    /// The calls of the groups, each behind its dirty bit, in blocks of [`CALL_BLOCK`] behind one
    /// test of their bits (a group marks only later ones, so a block's bits are final when it is
    /// reached; most evaluations run a few groups, and testing every bit was a fifth of `eval`),
    /// and the groups as methods (one function per group keeps the compiler's work per function
    /// small).
    fn eval_body(&mut self) -> Result<(String, String), String> {
        let (mut calls, mut methods) = (String::new(), String::new());
        for g in 0..self.groups.count {
            self.current = g;
            let name = &self.groups.names[g];
            if g % CALL_BLOCK == 0 {
                if g > 0 {
                    calls.push_str("        }\n");
                }
                let mask = (1u128 << CALL_BLOCK.min(self.groups.count - g)) - 1;
                writeln!(calls, "        if dirty >> {g} & {mask:#x} != 0 {{").unwrap();
            }
            writeln!(
                calls,
                "            if dirty >> {g} & 1 != 0 {{ self.group_{g}(&mut dirty); }} // {name}"
            )
            .unwrap();
            writeln!(
                methods,
                "\n    /// The cells of {name}.\n    fn group_{g}(&mut self, dirty: &mut u128) {{"
            )
            .unwrap();
            for item in self.groups.items[g].clone() {
                match item {
                    Item::Comb(k) => self.comb_item(&mut methods, k, g)?,
                    Item::Reg(k) => {
                        let value = self.next_state(k)?;
                        writeln!(methods, "        self.n{k} = {value};").unwrap();
                    }
                    Item::Mem(k) => self.memory_item(&mut methods, k)?,
                }
            }
            writeln!(methods, "        let _ = &dirty;\n    }}").unwrap();
        }
        if self.groups.count > 0 {
            calls.push_str("        }\n");
        }
        Ok((calls, methods))
    }

    fn comb_item(&mut self, body: &mut String, k: usize, g: usize) -> Result<(), String> {
        let cell = self.comb[k];
        let value = cell_value(self, cell)?;
        writeln!(body, "        let c{k}: u64 = {value};").unwrap();
        if self.exported.contains(&k) {
            let var = self.drivers[&first_net(cell.port("Y")?)?].0;
            let readers = self.readers_mask(&BTreeSet::from([var]), Some(g));
            if readers & ((1u128 << (g + 1)) - 1) != 0 {
                return Err(format!(
                    "cell {} (group {g}) is read by an earlier group: the groups are out of order",
                    cell.name
                ));
            }
            writeln!(
                body,
                "        if self.v{k} != c{k} {{ self.v{k} = c{k}; *dirty |= {readers:#x}; }}"
            )
            .unwrap();
        }
        Ok(())
    }

    fn memory_item(&self, body: &mut String, k: usize) -> Result<(), String> {
        let cell = self.mems[k];
        writeln!(
            body,
            "        self.m{k}_re = {} != 0;\n        self.m{k}_ra = {} as usize;\n        \
             self.m{k}_wa = {} as usize;\n        self.m{k}_wd = {};\n        self.m{k}_we = {};",
            self.input(cell, "RD_EN")?,
            self.input(cell, "RD_ADDR")?,
            self.input(cell, "WR_ADDR")?,
            self.input(cell, "WR_DATA")?,
            self.input(cell, "WR_EN")?,
        )
        .unwrap();
        Ok(())
    }
}

/// A port's name as a Rust identifier (rust-hdl joins the names of interface ports with `$`).
fn field_name(port: &str) -> String {
    port.replace(|c: char| !c.is_ascii_alphanumeric(), "_")
}

/// The bits a word of `ports` (name, position, width) needs; an error if two ports overlap (a
/// port wider than the interface expects).
fn packed_width(mut ports: Vec<(&str, usize, usize)>) -> Result<usize, String> {
    ports.sort_by_key(|&(_, at, _)| at);
    for pair in ports.windows(2) {
        let ((a, a_at, a_width), (b, b_at, _)) = (pair[0], pair[1]);
        if a_at + a_width > b_at {
            return Err(format!("ports `{a}` and `{b}` overlap in the word"));
        }
    }
    Ok(ports.last().map_or(0, |&(_, at, width)| at + width))
}

/// The smallest unsigned type holding `width` bits of the `what` word.
fn word_type(width: usize, what: &str) -> Result<&'static str, String> {
    match width {
        0..=32 => Ok("u32"),
        33..=64 => Ok("u64"),
        65..=128 => Ok("u128"),
        _ => Err(format!("the {what} word needs {width} bits (at most 128)")),
    }
}

fn first_net(bits: &[Bit]) -> Result<u64, String> {
    bits.iter()
        .find_map(|b| match b {
            Bit::Net(n) => Some(*n),
            Bit::Const(_) => None,
        })
        .ok_or_else(|| "a cell output without nets".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A module `top` with a clock, a 2-bit input `a` (nets 3, 4) and a 2-bit output `y` (nets 5,
    /// 6), holding `cells` (JSON members).
    fn netlist(cells: &str) -> Netlist {
        let json = format!(
            r#"{{"modules":{{"top":{{"ports":{{
                "clock":{{"direction":"input","bits":[2]}},
                "a":{{"direction":"input","bits":[3,4]}},
                "y":{{"direction":"output","bits":[5,6]}}}},
              "cells":{{{cells}}},"netnames":{{}}}}}}}}"#
        );
        Netlist::parse(&json, "top").expect("netlist")
    }

    fn cell(name: &str, kind: &str, signed: bool, a: &str, y: &str) -> String {
        let s = u8::from(signed);
        format!(
            r#""{name}":{{"type":"{kind}","attributes":{{}},
               "parameters":{{"A_SIGNED":"{s}","B_SIGNED":"{s}","A_WIDTH":"10","B_WIDTH":"10","Y_WIDTH":"10"}},
               "connections":{{"A":{a},"B":{a},"Y":{y}}}}}"#
        )
    }

    fn generate(cells: &str) -> Result<String, String> {
        let io = Interface {
            clock: "clock",
            inputs: &[("a", 0)],
            outputs: &[("y", 0)],
            state: &[],
            verilog: "",
        };
        emit(&netlist(cells), &io, "")
    }

    #[test]
    fn a_supported_cell_becomes_one_expression() {
        let code = generate(&cell("sum", "$add", false, "[3,4]", "[5,6]")).unwrap();
        assert!(
            code.contains("let c0: u64 = (self.i_a).wrapping_add((self.i_a)) & 0x3;"),
            "{code}"
        );
        assert!(
            code.contains("self.out = 0 | ((self.v0) as u32) << 0;"),
            "{code}"
        );
    }

    #[test]
    fn a_cell_type_it_does_not_know_is_refused_by_name() {
        let err = generate(&cell("product", "$mul", false, "[3,4]", "[5,6]")).unwrap_err();
        assert_eq!(err, "cell product: type $mul is not supported");
    }

    #[test]
    fn a_signed_operation_is_refused() {
        let err = generate(&cell("sum", "$add", true, "[3,4]", "[5,6]")).unwrap_err();
        assert_eq!(err, "cell sum ($add) is signed");
    }

    #[test]
    fn a_combinational_loop_is_refused() {
        let cells = [
            cell("first", "$and", false, "[3,6]", "[5,7]"),
            cell("second", "$and", false, "[7,4]", "[8,6]"),
        ]
        .join(",");
        let err = generate(&cells).unwrap_err();
        assert!(err.contains("combinational loop"), "{err}");
    }
}
