//! Lint of the generated Verilog with Verilator (`--lint-only -Wall`): warnings counted per category,
//! and the WIDTH warnings sorted into the kinds docs/VERILOG.md explains, so a test can refuse a
//! category or a kind nobody has reviewed.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

/// Warning categories the generated Verilog may show, each explained in docs/VERILOG.md.
pub const EXPLAINED_CATEGORIES: [&str; 4] =
    ["WIDTH", "UNUSEDPARAM", "UNUSEDSIGNAL", "DECLFILENAME"];

/// Verilog operators that compare: a WIDTH warning on one of their operands is harmless only when
/// that operand is a plain signal, slice or literal (zero extension), never arithmetic (which wraps
/// at its own width in Rust but not in Verilog's wider context).
const COMPARISONS: [&str; 6] = ["EQ", "NEQ", "LT", "LTE", "GT", "GTE"];
/// Expression kinds whose value depends on the width they are evaluated at.
const WIDTH_SENSITIVE: [&str; 6] = ["ADD", "SUB", "MUL", "SHIFTL", "NOT", "NEGATE"];

/// What Verilator reported.
#[derive(Debug, Default)]
pub struct LintReport {
    /// Warnings per category (`WIDTH`, `UNUSEDSIGNAL`, …).
    pub categories: BTreeMap<String, usize>,
    /// WIDTH warnings per kind: `OPERATOR/OPERAND` (e.g. `ASSIGN/CONST`: a 32-bit literal assigned
    /// to a narrower signal).
    pub width_kinds: BTreeMap<String, usize>,
    /// `%Error` lines.
    pub errors: Vec<String>,
    /// The WIDTH warnings of a silently-different kind (a comparison of a width-sensitive
    /// expression), with their source line.
    pub suspicious: Vec<String>,
}

impl LintReport {
    /// Categories outside [`EXPLAINED_CATEGORIES`].
    pub fn unexplained(&self) -> Vec<&str> {
        self.categories
            .keys()
            .map(String::as_str)
            .filter(|c| !EXPLAINED_CATEGORIES.contains(c))
            .collect()
    }
}

/// Runs `verilator --lint-only -Wall` on `file` (top module `top`) and sorts what it prints.
pub fn verilator_lint(file: &Path, top: &str) -> Result<LintReport, String> {
    verilator_lint_files(&[file], top)
}

/// Like [`verilator_lint`] on several files (a wrapper and the controller it instantiates).
pub fn verilator_lint_files(files: &[&Path], top: &str) -> Result<LintReport, String> {
    let out = Command::new("verilator")
        .args(["--lint-only", "-Wall", "--top-module", top])
        .args(files)
        .output()
        .map_err(|e| format!("cannot run verilator: {e}"))?;
    Ok(parse(&String::from_utf8_lossy(&out.stderr)))
}

/// Sorts Verilator's messages.
pub fn parse(stderr: &str) -> LintReport {
    let mut report = LintReport::default();
    for line in stderr.lines() {
        if line.starts_with("%Error") && !line.starts_with("%Error: Exiting due to") {
            report.errors.push(line.to_string());
        }
        let Some(rest) = line.strip_prefix("%Warning-") else {
            continue;
        };
        let category = rest.split(':').next().unwrap_or_default().to_string();
        if category == "WIDTH" {
            if let Some((operator, operand)) = width_kind(rest) {
                if COMPARISONS.contains(&operator.as_str())
                    && WIDTH_SENSITIVE.contains(&operand.as_str())
                {
                    report.suspicious.push(line.to_string());
                }
                *report
                    .width_kinds
                    .entry(format!("{operator}/{operand}"))
                    .or_default() += 1;
            }
        }
        *report.categories.entry(category).or_default() += 1;
    }
    report
}

/// `("EQ", "VARREF")` from "… Operator EQ expects 32 bits on the LHS, but LHS's VARREF 'x'
/// generates 5 bits."
fn width_kind(message: &str) -> Option<(String, String)> {
    let operator = message.split("Operator ").nth(1)?.split(' ').next()?;
    let operand = message.split("'s ").nth(1)?.split([' ', '.']).next()?;
    Some((operator.to_string(), operand.to_string()))
}

/// Lines of `verilog` with a negation inside a shift (`(~x) << n`, the generator's form of
/// `replace_bit(n, !x)`) or a negated vector compared with zero (`~x == 0`): both widen `x`
/// before negating in Verilog.
pub fn negation_patterns(verilog: &str) -> Vec<String> {
    verilog
        .lines()
        .filter(|l| {
            (l.contains("((~") && l.contains("<<"))
                || l.split("~").skip(1).any(|after| {
                    let operand_end = after.find([')', '&', '|']).unwrap_or(after.len());
                    after[..operand_end].contains("== 32'h0")
                })
        })
        .map(|l| l.trim().to_string())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sorts_categories_and_width_kinds() {
        let stderr = "\
%Warning-WIDTH: a.v:3:5: Operator EQ expects 32 bits on the LHS, but LHS's VARREF 'count$q' generates 5 bits.
%Warning-WIDTH: a.v:4:5: Operator ASSIGN expects 4 bits on the Assign RHS, but Assign RHS's CONST '32'h1' generates 32 bits.
%Warning-WIDTH: a.v:5:5: Operator EQ expects 32 bits on the LHS, but LHS's ADD generates 5 bits.
%Warning-UNOPTFLAT: a.v:6:5: Signal unoptimizable: Circular combinational logic: 'x'
%Error: a.v:7:1: syntax error
%Error: Exiting due to 1 error(s)
";
        let r = parse(stderr);
        assert_eq!(r.categories["WIDTH"], 3);
        assert_eq!(r.width_kinds["EQ/VARREF"], 1);
        assert_eq!(r.width_kinds["ASSIGN/CONST"], 1);
        assert_eq!(r.suspicious.len(), 1);
        assert!(r.suspicious[0].contains("a.v:5:5"));
        assert_eq!(r.unexplained(), vec!["UNOPTFLAT"]);
        assert_eq!(r.errors, vec!["%Error: a.v:7:1: syntax error"]);
    }

    #[test]
    fn finds_negations_that_widen() {
        let v = "  x = ((y) & ~(1 << (32'h2)) | ((~b) << (32'h2)));\n  if (~v == 32'h0) z = 1;\n  a = ~b & c;\n";
        assert_eq!(negation_patterns(v).len(), 2);
    }
}
