#!/usr/bin/env bash
# `make bitstream`: the iCEBreaker design (fpga/boards/icebreaker/) to a bitstream with Yosys,
# nextpnr-ice40 (the board's pins, timing against its 12 MHz clock) and icepack, from the Verilog
# shipped in fpga/rtl/ (no Rust needed). Prints the resources and the maximum clock; fails when
# nextpnr does not meet 12 MHz. Output: build/bitstream/icebreaker_can.bin and nextpnr.log.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-tools.sh --synth
board=fpga/boards/icebreaker
out=build/bitstream
mkdir -p $out
yosys -q -l $out/yosys.log -p "read_verilog $board/icebreaker_can.v $board/uart_rx.v $board/uart_tx.v fpga/rtl/can_controller.v; synth_ice40 -top icebreaker_can -json $out/icebreaker_can.json"
nextpnr-ice40 --up5k --package sg48 --pcf $board/icebreaker.pcf --json $out/icebreaker_can.json \
  --asc $out/icebreaker_can.asc --freq 12 --seed 1 2> $out/nextpnr.log || { tail -20 $out/nextpnr.log; exit 1; }
icepack $out/icebreaker_can.asc $out/icebreaker_can.bin
grep -E "(ICESTORM_LC|ICESTORM_RAM|SB_IO): +[0-9]+\/" $out/nextpnr.log | sed -E "s/^Info:[[:space:]]+//"
fmax=$(grep "Max frequency for clock" $out/nextpnr.log | tail -1)
echo "${fmax#Info: }"
case "$fmax" in
  *"PASS at 12.00 MHz"*) echo "wrote $out/icebreaker_can.bin" ;;
  *) echo "timing not met at 12 MHz" >&2; exit 1 ;;
esac
