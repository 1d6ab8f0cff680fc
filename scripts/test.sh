#!/usr/bin/env bash
# Every test of the workspace (`make test`), with one long single-threaded test run beside the rest.
#
# Why: the scripted Verilog equivalence run (testbenches/tests/verilog_equivalence.rs,
# scripted_scenario_rust_hdl_equals_verilog) spends about 4.5 minutes in one Icarus process, and
# `cargo test` runs one test binary after the other, so the second core idled for that long. Here
# it runs in a second `cargo test` beside `cargo test --workspace`, which skips it; both share the
# one build made first. Its output goes to build/test-logs/ and is printed when it ends. The exit
# status is non-zero when either run fails. Extra arguments go to both `cargo test` commands.
set -uo pipefail
cd "$(dirname "$0")/.."
CARGO=${CARGO:-cargo}
BESIDE=scripted_scenario_rust_hdl_equals_verilog
log=build/test-logs/$BESIDE.log

"$CARGO" test --workspace --no-run "$@" || exit 1
mkdir -p build/test-logs
echo "test.sh: $BESIDE runs beside the other tests; its output: $log"
"$CARGO" test -p testbenches --test verilog_equivalence "$@" -- --exact "$BESIDE" >"$log" 2>&1 &
beside=$!
"$CARGO" test --workspace "$@" -- --skip "$BESIDE"
status=$?
wait "$beside"
beside_status=$?
echo "---- $BESIDE (ran beside the others; $log) ----"
cat "$log"
if ! grep -q "^test $BESIDE \.\.\. ok$" "$log"; then
    echo "test.sh: $BESIDE did not pass (exit status $beside_status)" >&2
    beside_status=1
fi
if [ "$status" -ne 0 ] || [ "$beside_status" -ne 0 ]; then
    echo "test.sh: FAILED (workspace: exit $status; $BESIDE: exit $beside_status)" >&2
    exit 1
fi
