#!/usr/bin/env bash
# make lint: generates build/verilog/can_controller.v and lints it with Verilator (--lint-only -Wall)
# and Icarus (-g2005 -Wall); prints the warnings per category and the WIDTH warnings per kind.
# Fails on a category docs/VERILOG.md does not explain, on any error, and on any Icarus message.
# (The test testbenches/tests/verilog_lint.rs checks the same in `make test`, and the WIDTH kinds.)
set -euo pipefail
cd "$(dirname "$0")/.."

EXPLAINED="WIDTH UNUSEDPARAM UNUSEDSIGNAL DECLFILENAME"
DIR=build/verilog
VERILOG=$DIR/can_controller.v
cargo run -q -p sim --bin cansim -- verilog --out "$DIR" >/dev/null

verilator --lint-only -Wall --top-module can_controller "$VERILOG" >"$DIR/verilator.log" 2>&1 || true
iverilog -g2005 -Wall -o /dev/null "$VERILOG" >"$DIR/iverilog.log" 2>&1 || true

echo "Verilator --lint-only -Wall ($(verilator --version)): warnings per category"
grep -o '^%Warning-[A-Z0-9_]*' "$DIR/verilator.log" | sed 's/%Warning-//' | sort | uniq -c | sort -rn || true
echo "WIDTH warnings per kind (operator/operand, see docs/VERILOG.md):"
grep '^%Warning-WIDTH' "$DIR/verilator.log" \
    | sed -E "s/.*Operator ([A-Z]+) .*'s ([A-Z]+).*/\1\/\2/" | sort | uniq -c | sort -rn || true
echo "Icarus -g2005 -Wall: $(wc -l <"$DIR/iverilog.log") lines"
cat "$DIR/iverilog.log"

status=0
for category in $(grep -o '^%Warning-[A-Z0-9_]*' "$DIR/verilator.log" | sed 's/%Warning-//' | sort -u); do
    case " $EXPLAINED " in
        *" $category "*) ;;
        *) echo "lint: category $category is not explained in docs/VERILOG.md" >&2; status=1 ;;
    esac
done
if grep '^%Error' "$DIR/verilator.log" | grep -v 'Exiting due to' >&2; then
    status=1
fi
if [ -s "$DIR/iverilog.log" ]; then
    echo "lint: Icarus printed messages" >&2
    status=1
fi
exit $status
