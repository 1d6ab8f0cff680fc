#!/usr/bin/env bash
# Installs the external tools, from Debian's packages, when they are missing.
# For the tests (`make tools`):
#   sigrok-cli: independent CAN decoder that checks our VCD files;
#   iverilog (with vvp): runs the generated Verilog in the equivalence tests;
#   verilator: lints the generated Verilog (`make lint`) and runs it in the equivalence tests too;
#   yosys (with yosys-abc): the formal proofs of the generated Verilog (`make formal`).
# With --synth also the FPGA tools of `make synth`: nextpnr-ice40 (with fpga-icestorm).
set -euo pipefail

packages=()
command -v sigrok-cli >/dev/null 2>&1 || packages+=(sigrok-cli)
command -v iverilog >/dev/null 2>&1 || packages+=(iverilog)
command -v verilator >/dev/null 2>&1 || packages+=(verilator)
command -v yosys-abc >/dev/null 2>&1 || packages+=(yosys)
if [ "${1:-}" = "--synth" ]; then
  command -v nextpnr-ice40 >/dev/null 2>&1 || packages+=(nextpnr-ice40 fpga-icestorm)
fi

if [ ${#packages[@]} -eq 0 ]; then
  exit 0
fi
echo "installing: ${packages[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null 2>&1 || { echo "need root or sudo to install ${packages[*]}" >&2; exit 1; }
  sudo="sudo"
fi
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${packages[@]}" >/dev/null
