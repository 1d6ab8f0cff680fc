#!/usr/bin/env bash
# Installs the external tools the tests need, from Debian's packages, when they are missing.
# sigrok-cli: independent CAN decoder that checks our VCD files.
# iverilog (with vvp): runs the generated Verilog in the equivalence tests.
set -euo pipefail

packages=()
command -v sigrok-cli >/dev/null 2>&1 || packages+=(sigrok-cli)
command -v iverilog >/dev/null 2>&1 || packages+=(iverilog)

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
