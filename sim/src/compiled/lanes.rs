//! The generator of the lane model: the CAN core's Verilog, mapped by Yosys to single-bit gates
//! and plain flip-flops, written as straight-line Rust in which every net is a `u64` whose bit
//! `l` is the net's value in lane `l`: one evaluation clocks 64 independent cores (the fault
//! campaign's cases side by side, [`crate::compiled::lane_core`]).
//!
//! The gate netlist is a second, independent reading of the same Verilog: Yosys's techmap and ABC
//! instead of the word-level cells of the compiled model, so the lane model agreeing with the
//! compiled core cycle for cycle (the engines tests) checks both.

use std::collections::HashMap;
use std::fmt::Write as _;

use super::netlist::{Bit, Cell, Netlist};

/// The Yosys commands after reading the core: the word-level flow of the compiled model, then
/// memories as flip-flops, cells as gates, flip-flop enables and resets as logic in front of plain
/// flip-flops, and ABC's gate library that maps one gate to one or two bitwise operations.
pub(super) fn yosys_script(verilog: &str, top: &str, json: &str) -> String {
    format!(
        "read_verilog {verilog}\nhierarchy -top {top}\nproc\nflatten\nopt -full\nwreduce\n\
         opt_clean\nmemory\nopt -full\ntechmap\nopt -fast -full\ndffunmap\n\
         abc -g AND,NAND,OR,NOR,XOR,XNOR,ANDNOT,ORNOT,MUX\nopt_clean\nwrite_json {json}\n"
    )
}

/// Where a net's value comes from in the generated code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    /// Bit `k` of the input word.
    Input(u32),
    /// Flip-flop `k`'s output.
    State(usize),
    /// The output of gate cell `k` (index into the netlist's cells).
    Gate(usize),
}

/// The flip-flops of the netlist, in cell order: (D bit, power-up value).
type FlipFlops = Vec<(Bit, bool)>;

/// The source of the lane model for `netlist`: `inputs` and `outputs` name every port with its
/// bit position in the input and output words.
pub(super) fn emit(
    netlist: &Netlist,
    inputs: &[(&str, u32)],
    outputs: &[(&str, u32)],
    header: &str,
) -> Result<String, String> {
    let (sources, flip_flops) = sources(netlist, inputs)?;
    let mut code = Code {
        netlist,
        sources: &sources,
        emitted: vec![false; netlist.cells.len()],
        visiting: vec![false; netlist.cells.len()],
        text: String::new(),
    };
    let mut out = String::from(header);
    write_state(&mut out, &flip_flops);
    write_next_state(&mut out, &mut code, &flip_flops)?;
    write_outputs(&mut out, &mut code, outputs)?;
    Ok(out)
}

/// Where each net comes from (an input bit, a flip-flop, a gate), and the flip-flops.
fn sources(
    netlist: &Netlist,
    inputs: &[(&str, u32)],
) -> Result<(HashMap<u64, Source>, FlipFlops), String> {
    let mut sources = HashMap::new();
    for (name, bits) in &netlist.inputs {
        let Some(&(_, at)) = inputs.iter().find(|(port, _)| port == name) else {
            continue; // the clock
        };
        for (k, bit) in bits.iter().enumerate() {
            if let Bit::Net(n) = bit {
                sources.insert(*n, Source::Input(at + k as u32));
            }
        }
    }
    let mut flip_flops = Vec::new();
    for (k, cell) in netlist.cells.iter().enumerate() {
        match cell.kind.as_str() {
            "_DFF_P_" => {
                let q = single_net(cell, "Q")?;
                let init = netlist.init.get(&q).copied().unwrap_or(false);
                sources.insert(q, Source::State(flip_flops.len()));
                flip_flops.push((cell.port("D")?[0], init));
            }
            kind if gate_expression(kind, "", "", "").is_some() => {
                sources.insert(single_net(cell, "Y")?, Source::Gate(k));
            }
            kind => return Err(format!("cell {} of kind {kind}: not a gate", cell.name)),
        }
    }
    Ok((sources, flip_flops))
}

/// `next_state`: the gates the flip-flops' D inputs depend on, then the new state.
fn write_next_state(
    out: &mut String,
    code: &mut Code,
    flip_flops: &FlipFlops,
) -> Result<(), String> {
    for (d, _) in flip_flops {
        code.define(*d)?;
    }
    let next: Vec<String> = flip_flops.iter().map(|(d, _)| code.operand(*d)).collect();
    writeln!(
        out,
        "\n/// The flip-flops' values after a rising edge with inputs `i`.\n\
         #[inline(never)]\npub(super) fn next_state(q: &[u64; STATE_BITS], i: &[u64; 64]) -> \
         [u64; STATE_BITS] {{\n{}    [{}]\n}}",
        code.take(),
        next.join(", ")
    )
    .unwrap();
    Ok(())
}

/// `outputs`: the gates the output ports depend on (their own cone, defined again), then each
/// output bit at its place in the output word.
fn write_outputs(out: &mut String, code: &mut Code, outputs: &[(&str, u32)]) -> Result<(), String> {
    code.emitted.fill(false);
    let mut assigns = String::new();
    for (name, bits) in &code.netlist.outputs {
        let &(_, at) = outputs
            .iter()
            .find(|(port, _)| port == name)
            .ok_or_else(|| format!("output {name} has no place in the output word"))?;
        for (k, bit) in bits.iter().enumerate() {
            code.define(*bit)?;
            let operand = code.operand(*bit);
            writeln!(assigns, "    o[{}] = {operand};", at + k as u32).unwrap();
        }
    }
    writeln!(
        out,
        "\n/// The outputs with flip-flops `q` and inputs `i` (bit `k` of the output word in `o[k]`).\n\
         #[inline(never)]\npub(super) fn outputs(q: &[u64; STATE_BITS], i: &[u64; 64], o: &mut \
         [u64; 128]) {{\n{}{assigns}}}",
        code.take()
    )
    .unwrap();
    Ok(())
}

/// The number of flip-flops and their power-up values, one bit per flip-flop.
fn write_state(out: &mut String, flip_flops: &FlipFlops) {
    let init: Vec<&str> = flip_flops
        .iter()
        .map(|(_, init)| if *init { "true" } else { "false" })
        .collect();
    writeln!(
        out,
        "\n/// Flip-flops of one core.\npub(super) const STATE_BITS: usize = {};\n\n\
         /// Their power-up values.\npub(super) const POWER_UP: [bool; STATE_BITS] = [{}];",
        flip_flops.len(),
        init.join(", ")
    )
    .unwrap();
}

fn single_net(cell: &Cell, port: &str) -> Result<u64, String> {
    match cell.port(port)? {
        [Bit::Net(n)] => Ok(*n),
        other => Err(format!("cell {} port {port}: {other:?}", cell.name)),
    }
}

/// The bitwise expression of a gate of kind `kind` over operands `a`, `b` and `s`.
fn gate_expression(kind: &str, a: &str, b: &str, s: &str) -> Option<String> {
    Some(match kind {
        "_NOT_" => format!("!{a}"),
        "_AND_" => format!("{a} & {b}"),
        "_NAND_" => format!("!({a} & {b})"),
        "_OR_" => format!("{a} | {b}"),
        "_NOR_" => format!("!({a} | {b})"),
        "_XOR_" => format!("{a} ^ {b}"),
        "_XNOR_" => format!("!({a} ^ {b})"),
        "_ANDNOT_" => format!("{a} & !{b}"),
        "_ORNOT_" => format!("{a} | !{b}"),
        // Y = S ? B : A
        "_MUX_" => format!("{a} ^ (({a} ^ {b}) & {s})"),
        _ => return None,
    })
}

/// The statements of one function, each gate once, in dependency order.
struct Code<'a> {
    netlist: &'a Netlist,
    sources: &'a HashMap<u64, Source>,
    emitted: Vec<bool>,
    /// Gates whose inputs are being defined (met again: a combinational loop).
    visiting: Vec<bool>,
    text: String,
}

impl Code<'_> {
    /// Emits the gates `bit` depends on (depth first, with an explicit stack: the cones are deep).
    fn define(&mut self, bit: Bit) -> Result<(), String> {
        let mut stack = vec![(bit, false)];
        while let Some((bit, inputs_done)) = stack.pop() {
            let Bit::Net(net) = bit else { continue };
            let k = match self.sources.get(&net) {
                Some(Source::Gate(k)) => *k,
                Some(_) => continue,
                None => return Err(format!("net {net} has no driver")),
            };
            if self.emitted[k] {
                continue;
            }
            if !inputs_done && self.visiting[k] {
                return Err(format!("a combinational loop through net {net}"));
            }
            let cell = &self.netlist.cells[k];
            let operands: Vec<Bit> = ["A", "B", "S"]
                .iter()
                .filter_map(|p| cell.connections.get(*p).map(|b| b[0]))
                .collect();
            if inputs_done {
                let [a, b, s] = [0, 1, 2].map(|j| {
                    operands
                        .get(j)
                        .map_or_else(String::new, |bit| self.operand(*bit))
                });
                let expression = gate_expression(&cell.kind, &a, &b, &s).expect("a gate");
                writeln!(self.text, "    let n{net} = {expression};").unwrap();
                self.emitted[k] = true;
                self.visiting[k] = false;
            } else {
                self.visiting[k] = true;
                stack.push((bit, true));
                stack.extend(operands.into_iter().map(|b| (b, false)));
            }
        }
        Ok(())
    }

    /// The expression of an already defined bit.
    fn operand(&self, bit: Bit) -> String {
        match bit {
            Bit::Const(false) => "0u64".into(),
            Bit::Const(true) => "!0u64".into(),
            Bit::Net(net) => match self.sources[&net] {
                Source::Input(k) => format!("i[{k}]"),
                Source::State(k) => format!("q[{k}]"),
                Source::Gate(_) => format!("n{net}"),
            },
        }
    }

    fn take(&mut self) -> String {
        std::mem::take(&mut self.text)
    }
}
