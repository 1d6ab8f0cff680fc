//! `scripts/lut_attribution.py`, the per-block table of `make synth`: on a design whose blocks'
//! logic is known, each block gets the LUTs that feed its flip-flops, and the table adds up to
//! Yosys's own cell counts.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Three blocks: `wide` registers the XOR of four bytes (8 flip-flops, 8 LUT4 of 4 inputs, nothing
/// shared with the others); `narrow` registers the AND of 16 bits (1 flip-flop, 5 LUT4); `counter`
/// holds its count in a child register module as rust-hdl writes a `DFF` (the net
/// `u_counter.count.q` is register `count` of block `u_counter`).
const DESIGN: &str = "
module wide (input clock, input [31:0] x, output reg [7:0] sum);
    always @(posedge clock) sum <= x[7:0] ^ x[15:8] ^ x[23:16] ^ x[31:24];
endmodule
module narrow (input clock, input [15:0] y, output reg all);
    always @(posedge clock) all <= &y;
endmodule
module dff4 (input clock, input [3:0] d, output reg [3:0] q);
    always @(posedge clock) q <= d;
endmodule
module counter (input clock, input up, output [3:0] value);
    wire [3:0] next = value + {3'b000, up};
    dff4 count (.clock(clock), .d(next), .q(value));
endmodule
module top (input clock, input [31:0] x, input [15:0] y, input up, output [7:0] a, output b,
            output [3:0] c);
    wide u_wide (.clock(clock), .x(x), .sum(a));
    narrow u_narrow (.clock(clock), .y(y), .all(b));
    counter u_counter (.clock(clock), .up(up), .value(c));
endmodule
";

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A row of the script's table: block, SB_LUT4 share, flip-flops.
type Row = (String, f64, u32);

/// The script's table rows, and its total row (SB_LUT4, flip-flops).
fn attribution(netlist: &Path) -> (Vec<Row>, (u32, u32)) {
    let out = Command::new("python3")
        .arg(repository().join("scripts/lut_attribution.py"))
        .arg(netlist)
        .arg("top")
        .output()
        .expect("python3 runs");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "lut_attribution.py failed: {}{}",
        text,
        String::from_utf8_lossy(&out.stderr)
    );
    let mut rows = Vec::new();
    let mut total = None;
    for line in text.lines().skip(1) {
        let fields: Vec<&str> = line.split_whitespace().collect();
        let [block, luts, _carries, flops] = fields[..] else {
            panic!("unexpected line {line:?}");
        };
        if block == "total" {
            total = Some((luts.parse().unwrap(), flops.parse().unwrap()));
        } else {
            rows.push((
                block.to_string(),
                luts.parse().unwrap(),
                flops.parse().unwrap(),
            ));
        }
    }
    (rows, total.expect("a total row"))
}

#[test]
fn each_block_gets_the_luts_feeding_its_flip_flops_and_the_table_adds_up() {
    let dir = std::env::temp_dir().join(format!("synth_report_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let verilog = dir.join("design.v");
    let netlist = dir.join("design.json");
    let stat = dir.join("stat.txt");
    std::fs::write(&verilog, DESIGN).unwrap();
    let script = format!(
        "read_verilog {}; synth_ice40 -top top -json {}; tee -q -o {} stat",
        verilog.display(),
        netlist.display(),
        stat.display()
    );
    let out = Command::new("yosys")
        .args(["-q", "-p", &script])
        .output()
        .expect("yosys runs (scripts/install-tools.sh --synth)");
    assert!(
        out.status.success(),
        "yosys: {}",
        String::from_utf8_lossy(&out.stderr)
    );

    let (rows, (total_luts, total_flops)) = attribution(&netlist);
    let stat = std::fs::read_to_string(&stat).unwrap();
    let count = |prefix: &str| -> u32 {
        stat.lines()
            .filter_map(|l| {
                let f: Vec<&str> = l.split_whitespace().collect();
                (f.len() == 2 && f[0].starts_with(prefix)).then(|| f[1].parse::<u32>().unwrap())
            })
            .sum()
    };
    assert_eq!(total_luts, count("SB_LUT4"), "{stat}");
    assert_eq!(total_flops, count("SB_DFF"), "{stat}");
    let row = |name: &str| {
        rows.iter()
            .find(|(block, _, _)| block == name)
            .unwrap_or_else(|| panic!("no row {name} in {rows:?}"))
            .clone()
    };
    let (_, wide_luts, wide_flops) = row("u_wide");
    let (_, narrow_luts, narrow_flops) = row("u_narrow");
    let (_, counter_luts, counter_flops) = row("u_counter");
    assert_eq!((wide_flops, narrow_flops, counter_flops), (8, 1, 4));
    assert!(counter_luts >= 3.0, "{rows:?}");
    assert!((7.5..=8.5).contains(&wide_luts), "{rows:?}");
    assert!((4.5..=5.5).contains(&narrow_luts), "{rows:?}");
    let shared: f64 = rows.iter().map(|(_, luts, _)| luts).sum();
    assert!((shared - f64::from(total_luts)).abs() < 0.5, "{rows:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
