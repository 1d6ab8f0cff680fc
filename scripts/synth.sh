#!/usr/bin/env bash
# make synth: synthesis figures of the generated Verilog (build/verilog/can_controller.v).
#   iCE40:  Yosys synth_ice40 (LUT4, flip-flops, block RAM, carries), per block without flattening,
#           nextpnr-ice40 --hx8k --package ct256 max clock frequency (median of SEEDS seeds);
#           and per block in the flattened design (scripts/lut_attribution.py);
#   Xilinx: Yosys synth_xilinx -flatten -abc9 (LUTs, flip-flops); the default ABC mapper's count is
#           printed beside it for comparison (it moved by +-60 LUTs over logic-equivalent designs).
# Writes build/synth/report.txt and prints it. Needs yosys and nextpnr-ice40 (scripts/install-tools.sh
# --synth installs them). SEEDS=1 for a quick run.
# Fails when a figure is worse than the one recorded in docs/FPGA.md ("Resources and speed"): more
# SB_LUT4, flip-flops, block RAMs or Xilinx LUTs, or a max clock more than FMAX_TOLERANCE percent
# (default 5: placement moves the same logic by a few percent between designs) below the recorded one. After an improvement, record
# the new figures there.
set -euo pipefail
cd "$(dirname "$0")/.."

SEEDS=${SEEDS:-3}
DIR=build/synth
VERILOG=build/verilog/can_controller.v
mkdir -p "$DIR"

for tool in yosys nextpnr-ice40; do
    command -v "$tool" >/dev/null || { echo "synth: $tool not found; run scripts/install-tools.sh --synth" >&2; exit 1; }
done
cargo run -q --release -p sim --bin cansim -- verilog --out build/verilog >/dev/null

# Sum of the cells in a Yosys `stat` output whose type matches the regex $2.
cells() { awk -v re="$2" '$1 ~ re && $2 ~ /^[0-9]+$/ { n += $2 } END { print n + 0 }' "$1"; }

echo "synth: Yosys synth_ice40" >&2
yosys -q -p "read_verilog $VERILOG; synth_ice40 -top can_controller -json $DIR/ice40.json; tee -q -o $DIR/ice40_stat.txt stat" >"$DIR/yosys_ice40.log" 2>&1
echo "synth: Yosys synth_ice40 per block" >&2
yosys -q -p "read_verilog $VERILOG; synth_ice40 -noflatten -top can_controller; tee -q -o $DIR/ice40_blocks.txt stat" >"$DIR/yosys_ice40_blocks.log" 2>&1
echo "synth: Yosys synth_xilinx -abc9" >&2
yosys -q -p "read_verilog $VERILOG; synth_xilinx -flatten -abc9 -top can_controller; tee -q -o $DIR/xilinx_stat.txt stat" >"$DIR/yosys_xilinx.log" 2>&1
echo "synth: Yosys synth_xilinx (default ABC mapper)" >&2
yosys -q -p "read_verilog $VERILOG; synth_xilinx -flatten -top can_controller; tee -q -o $DIR/xilinx_abc_stat.txt stat" >"$DIR/yosys_xilinx_abc.log" 2>&1

# The memories that became block RAMs, from the per-block statistics: "name count, ...".
ram_blocks() {
    awk '/^=== /{ block = $2 } $1 == "SB_RAM40_4K" && block != "design" { printf "%s%s %d", sep, block, $2; sep = ", " }' "$DIR/ice40_blocks.txt"
}

freqs=()
for seed in $(seq 1 "$SEEDS"); do
    echo "synth: nextpnr-ice40 seed $seed of $SEEDS (minutes)" >&2
    nextpnr-ice40 --hx8k --package ct256 --json "$DIR/ice40.json" --freq 70 --timing-allow-fail --seed "$seed" \
        >"$DIR/nextpnr_seed$seed.log" 2>&1 || { echo "synth: nextpnr failed, see $DIR/nextpnr_seed$seed.log" >&2; exit 1; }
    freqs+=("$(grep -o "Max frequency for clock '[^']*': [0-9.]* MHz" "$DIR/nextpnr_seed$seed.log" | tail -1 | grep -o '[0-9.]* MHz$' | cut -d' ' -f1)")
done
median=$(printf '%s\n' "${freqs[@]}" | sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }')

{
    echo "can_controller synthesis ($(date -u +%Y-%m-%d), cansim $(cargo run -q --release -p sim --bin cansim -- --version | cut -d' ' -f2))"
    echo
    echo "iCE40 (Yosys synth_ice40, nextpnr-ice40 --hx8k --package ct256)"
    echo "  SB_LUT4      $(cells "$DIR/ice40_stat.txt" '^SB_LUT4$')   (target <= 1600)"
    echo "  flip-flops   $(cells "$DIR/ice40_stat.txt" '^SB_DFF')   (target <= 700)"
    echo "  block RAM    $(cells "$DIR/ice40_stat.txt" '^SB_RAM40_4K')   (target: the RX FIFO in exactly 1): $(ram_blocks)"
    echo "  SB_CARRY     $(cells "$DIR/ice40_stat.txt" '^SB_CARRY$')"
    echo "  max clock    ${median} MHz median of seeds 1..$SEEDS: ${freqs[*]} MHz   (target >= 70)"
    echo
    echo "Xilinx 7-series (Yosys synth_xilinx -flatten -abc9)"
    echo "  LUT          $(cells "$DIR/xilinx_stat.txt" '^LUT[1-6]$')   (target <= 900; default ABC mapper: $(cells "$DIR/xilinx_abc_stat.txt" '^LUT[1-6]$') LUTs + $(cells "$DIR/xilinx_abc_stat.txt" '^MUXF[78]$') MUXF7/F8)"
    echo "  flip-flops   $(cells "$DIR/xilinx_stat.txt" '^FD')"
    echo "  MUXF7/F8     $(cells "$DIR/xilinx_stat.txt" '^MUXF[78]$')"
    echo "  distributed RAM cells $(cells "$DIR/xilinx_stat.txt" '^RAM')"
    echo
    echo "iCE40 SB_LUT4 per block (synth_ice40 -noflatten: no optimisation across blocks, so the sum"
    echo "is above the flattened total)"
    awk '/^=== /{ block = $2 } $1 == "SB_LUT4" { printf "  %-40s %5d\n", block, $2 }' "$DIR/ice40_blocks.txt" | sort -k2 -nr
    echo
    echo "iCE40 per block in the flattened design (each SB_LUT4 and SB_CARRY shared among the blocks"
    echo "whose flip-flops, RAMs or outputs it feeds; scripts/lut_attribution.py)"
    python3 scripts/lut_attribution.py "$DIR/ice40.json"
} | tee "$DIR/report.txt"

# recorded ROW: the measured figure of a row of docs/FPGA.md's resources table (spaces removed).
recorded() {
    awk -F'|' -v row="$1" '$2 ~ "^ *" row " *$" { gsub(/ /, "", $3); match($3, /^[0-9.]+/); print substr($3, RSTART, RLENGTH); exit }' docs/FPGA.md
}

regressions=()
check_at_most() { # NAME MEASURED RECORDED
    [ -n "$3" ] || { regressions+=("$1: no recorded figure in docs/FPGA.md"); return; }
    [ "$2" -le "$3" ] || regressions+=("$1: $2, recorded $3")
}
check_at_most "iCE40 SB_LUT4" "$(cells "$DIR/ice40_stat.txt" '^SB_LUT4$')" "$(recorded 'iCE40 SB_LUT4')"
check_at_most "iCE40 flip-flops" "$(cells "$DIR/ice40_stat.txt" '^SB_DFF')" "$(recorded 'iCE40 flip-flops')"
check_at_most "iCE40 block RAM" "$(cells "$DIR/ice40_stat.txt" '^SB_RAM40_4K')" "$(recorded 'iCE40 block RAM')"
check_at_most "Xilinx LUT" "$(cells "$DIR/xilinx_stat.txt" '^LUT[1-6]$')" "$(recorded 'Xilinx LUT1..6')"
fmax_recorded=$(recorded 'iCE40 max clock \\(HX8K\\)')
if [ -z "$fmax_recorded" ]; then
    regressions+=("max clock: no recorded figure in docs/FPGA.md")
elif ! awk -v m="$median" -v r="$fmax_recorded" -v t="${FMAX_TOLERANCE:-5}" 'BEGIN { exit !(m >= r * (1 - t / 100)) }'; then
    regressions+=("max clock: $median MHz, recorded $fmax_recorded MHz (tolerance ${FMAX_TOLERANCE:-5} %)")
fi
if [ ${#regressions[@]} -gt 0 ]; then
    printf 'synth: worse than docs/FPGA.md: %s\n' "${regressions[@]}" >&2
    exit 1
fi
echo "synth: no figure worse than docs/FPGA.md"
