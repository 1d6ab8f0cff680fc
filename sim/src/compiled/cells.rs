//! What each Yosys cell type computes, as a Rust expression over `u64` values masked to their
//! widths (the semantics of Yosys's internal cell library for unsigned operands: operands are
//! zero-extended, results truncated to `Y_WIDTH`; comparisons and reductions give one bit).

use std::fmt::Write as _;

use super::emit::{hex, mask};
use super::netlist::{Bit, Cell};

/// Expressions of a cell's operands, as seen from where the cell's code is written.
pub(crate) trait Operands {
    /// The expression of `bits` (least significant first, at most 64).
    fn operand(&self, bits: &[Bit]) -> Result<String, String>;

    /// A constant table of 64-bit words; returns its name.
    fn table(&mut self, words: &[u64]) -> String;

    /// The expression of port `port` of `cell`, in parentheses.
    fn input(&self, cell: &Cell, port: &str) -> Result<String, String> {
        self.operand(cell.port(port)?)
            .map(|e| format!("({e})"))
            .map_err(|e| format!("cell {} port {port}: {e}", cell.name))
    }
}

/// The expression of a combinational cell's `Y`.
pub(crate) fn cell_value(ops: &mut impl Operands, cell: &Cell) -> Result<String, String> {
    if cell.flag("A_SIGNED", false)? || cell.flag("B_SIGNED", false)? {
        return Err(format!("cell {} (${}) is signed", cell.name, cell.kind));
    }
    let y = cell.port("Y")?.len();
    let m = hex(mask(y));
    let a = ops.input(cell, "A");
    let b = ops.input(cell, "B");
    let bool_of = |e: String| format!("u64::from({e})");
    Ok(match cell.kind.as_str() {
        "and" => format!("{} & {} & {m}", a?, b?),
        "or" => format!("({} | {}) & {m}", a?, b?),
        "xor" => format!("({} ^ {}) & {m}", a?, b?),
        "xnor" => format!("!({} ^ {}) & {m}", a?, b?),
        "add" => format!("{}.wrapping_add({}) & {m}", a?, b?),
        "sub" => format!("{}.wrapping_sub({}) & {m}", a?, b?),
        "not" => format!("!{} & {m}", a?),
        "eq" => bool_of(format!("{} == {}", a?, b?)),
        "ne" => bool_of(format!("{} != {}", a?, b?)),
        "lt" => bool_of(format!("{} < {}", a?, b?)),
        "le" => bool_of(format!("{} <= {}", a?, b?)),
        "gt" => bool_of(format!("{} > {}", a?, b?)),
        "ge" => bool_of(format!("{} >= {}", a?, b?)),
        "logic_not" => bool_of(format!("{} == 0", a?)),
        "logic_and" => bool_of(format!("{} != 0 && {} != 0", a?, b?)),
        "logic_or" => bool_of(format!("{} != 0 || {} != 0", a?, b?)),
        "reduce_and" => {
            let all = hex(mask(cell.port("A")?.len()));
            bool_of(format!("{} == {all}", a?))
        }
        "reduce_or" | "reduce_bool" => bool_of(format!("{} != 0", a?)),
        "reduce_xor" => format!("u64::from({}.count_ones() & 1)", a?),
        "mux" => format!(
            "if {} != 0 {{ {} }} else {{ {} }}",
            ops.input(cell, "S")?,
            b?,
            a?
        ),
        "pmux" => pmux(ops, cell, y)?,
        "shiftx" | "shr" => shift_right(ops, cell, y)?,
        "shl" => format!(
            "(if {b} < 64 {{ {} << {b} }} else {{ 0 }}) & {m}",
            a?,
            b = b?
        ),
        other => {
            return Err(format!(
                "cell {}: type ${other} is not supported",
                cell.name
            ))
        }
    })
}

/// `$pmux`: the first case whose select bit is set (the cases of one `match` exclude each other),
/// else `A`.
fn pmux(ops: &impl Operands, cell: &Cell, width: usize) -> Result<String, String> {
    let s = ops.input(cell, "S")?;
    let mut e = format!("{{ let s = {s}; ");
    for (k, case) in cell.port("B")?.chunks(width).enumerate() {
        let value = ops.operand(case)?;
        write!(e, "if s >> {k} & 1 != 0 {{ {value} }} else ").unwrap();
    }
    write!(e, "{{ {} }} }}", ops.input(cell, "A")?).unwrap();
    Ok(e)
}

/// `$shiftx`/`$shr`: `A >> B`, bits shifted in from beyond `A` read 0. A constant `A` wider than
/// 64 bits (an address-decode table) becomes a table of words read one bit at a time.
fn shift_right(ops: &mut impl Operands, cell: &Cell, width: usize) -> Result<String, String> {
    let a_bits = cell.port("A")?;
    let a_width = a_bits.len();
    let b = ops.input(cell, "B")?;
    let m = hex(mask(width));
    if a_width <= 64 {
        let a = ops.input(cell, "A")?;
        return Ok(format!(
            "if {b} < {a_width} {{ {a} >> {b} & {m} }} else {{ 0 }}"
        ));
    }
    let constant: Option<Vec<bool>> = a_bits
        .iter()
        .map(|bit| match bit {
            Bit::Const(v) => Some(*v),
            Bit::Net(_) => None,
        })
        .collect();
    let (Some(constant), 1) = (constant, width) else {
        return Err(format!(
            "cell {}: a {a_width}-bit shifted value must be a constant read one bit at a time",
            cell.name
        ));
    };
    let words: Vec<u64> = constant
        .chunks(64)
        .map(|chunk| {
            chunk
                .iter()
                .enumerate()
                .fold(0, |w, (i, v)| w | u64::from(*v) << i)
        })
        .collect();
    let table = ops.table(&words);
    Ok(format!(
        "{{ let s = {b}; if s < {a_width} {{ {table}[(s >> 6) as usize] >> (s & 63) & 1 }} else {{ 0 }} }}"
    ))
}
