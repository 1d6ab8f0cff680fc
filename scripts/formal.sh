#!/usr/bin/env bash
# Formal proofs of the emitted Verilog (fpga/rtl/*.v, what `cansim verilog` writes) with Yosys and
# ABC (bounded model checking with bmc3, complete proofs with pdr, property-directed reachability):
# one property file per guarantee in formal/, docs/FORMAL.md lists them.
#
#   scripts/formal.sh [--long] [--mutations | --mutation-texts] [NAME...]
#
# Each formal/NAME.sv is a harness module NAME that instantiates a block of the controller, leaves the
# block's inputs free but for the assumptions it states, and asserts the rule. Its `//!` header lines:
#   //! read: FILE...          Verilog files of fpga/rtl/ the harness needs (can_controller.v, ...)
#   //! reference: FILE...     Verilog files of formal/reference/ (a block as it was before a
#                              restructuring, for an equivalence proof; never mutated)
#   //! connect: WIRE = PATH   a harness wire driven by a wire inside the flattened design
#   //! bmc: N                 bounded model check of N steps from reset (always run first)
#   //! prove: pdr             then a proof for every depth (optional; without it the result is
#                              the bound)
#   //! mutation: NAME | TEXT => REPLACEMENT
#                              a deliberate break of the rule in the Verilog: with --mutations the
#                              TEXT (exactly once in the files read) is replaced and the proof must fail
#   //! mutation-long: ...     the same, only with --long (a counterexample thousands of steps deep)
#   //! start: first           a long proof: started before the others, so that it does not run
#                              alone on one processor at the end
# --mutation-texts only checks that each mutation's TEXT still occurs exactly once (seconds, for
# `make test`: a change of the Verilog that moves a mutation's text shows at once; proving that
# every mutation is caught takes minutes and is `make formal`).
# The `initial` values of the controller are removed before proving: the proofs start from the
# `reset` the harness applies, as on an FPGA flow that drops them.
# Logs, models and counterexample traces (trace.vcd, open it in GTKWave) go to build/formal/NAME/.
# BMC_SECONDS and PDR_SECONDS bound each run (default 120 and 300).
set -euo pipefail
cd "$(dirname "$0")/.."

long=0
mutations=0
names=()
while [ $# -gt 0 ]; do
  case "$1" in
    --long) long=1 ;;
    --mutations) mutations=1 ;;
    --mutation-texts) mutations=2 ;;
    -*) echo "formal.sh: unknown option $1" >&2; exit 2 ;;
    *) names+=("$1") ;;
  esac
  shift
done

command -v yosys-abc >/dev/null 2>&1 || { echo "formal.sh: yosys-abc missing (make tools)" >&2; exit 2; }
BMC_SECONDS=${BMC_SECONDS:-120}
PDR_SECONDS=${PDR_SECONDS:-300}

if [ ${#names[@]} -eq 0 ]; then
  for f in formal/*.sv; do names+=("$(basename "$f" .sv)"); done
fi

# header KEY FILE: the values of `//! KEY:` lines, one per line.
header() { sed -n "s|^//! $1: *||p" "$2"; }

# build_model NAME SV OUTDIR VERILOG_DIR: the harness and the design as an and-inverter graph
# (model.aig, its symbols model.aim) and as RTLIL (model.il) for replaying a counterexample.
build_model() {
  local name=$1 sv=$2 out=$3 vdir=$4 script
  script=$out/model.ys
  {
    for file in $(header read "$sv"); do echo "read_verilog -sv $vdir/$file"; done
    for file in $(header reference "$sv"); do echo "read_verilog -sv formal/reference/$file"; done
    echo "setattr -unset init w:*"
    echo "read_verilog -sv -formal $sv"
    echo "hierarchy -check -top $name"
    echo "proc"
    echo "flatten"
    header connect "$sv" | while IFS='=' read -r lhs rhs; do
      # -nounset: the harness wire keeps its aliases (a plain `-set` would cut them off, undriven).
      echo "connect -nounset -set $(echo "$lhs" | xargs) $(echo "$rhs" | xargs)"
    done
    echo "prep -top $name"
    echo "check -assert"
    echo "async2sync"
    echo "dffunmap"
    echo "memory_map"
    echo "opt -nodffe -nosdff"
    echo "techmap"
    echo "opt -fast -nodffe -nosdff"
    echo "abc -g AND -fast"
    echo "opt_clean"
    echo "dffunmap"
    echo "write_rtlil $out/model.il"
    echo "write_aiger -zinit -map $out/model.aim $out/model.aig"
  } >"$script"
  yosys -q -l "$out/yosys.log" "$script" >/dev/null
}

# counterexample OUTDIR: the failing trace as OUTDIR/trace.vcd; prints the assertion that failed.
counterexample() {
  local out=$1
  yosys -q -l "$out/replay.log" -p "read_rtlil $out/model.il; sim -clock clock -r $out/model.aiw -map $out/model.aim -vcd $out/trace.vcd" >/dev/null 2>&1 || true
  grep -m1 -o 'Assert .* failed' "$out/replay.log" | sed 's/^Assert [^ ]* //; s/ failed$//' || echo "(see $out/replay.log)"
}

# prove NAME SV OUTDIR: a bounded check from reset (ABC bmc3), then, when the header asks for it, a
# proof for every depth (ABC pdr, property-directed reachability). With --mutation-texts (`make
# test`) a property with a proof skips the bounded check, which the proof for every depth implies
# (it only finds a failing mutation's counterexample sooner). Prints one line; returns 1 when the
# property fails or is not decided.
prove() {
  local name=$1 sv=$2 out=$3 depth complete log
  depth=$(header bmc "$sv")
  complete=$(header prove "$sv")
  if [ "$complete" = pdr ] && [ "$mutations" -eq 2 ]; then
    prove_every_depth "$out" "pdr"
    return
  fi
  log=$out/bmc.log
  yosys-abc -c "read_aiger $out/model.aig; fold; strash; bmc3 -F $depth -T $BMC_SECONDS; write_cex -a $out/model.aiw" >"$log" 2>&1 || true
  if grep -q 'was asserted in frame' "$log"; then
    echo "FAIL at step $(grep -o 'asserted in frame [0-9]*' "$log" | grep -o '[0-9]*$') of $depth: $(counterexample "$out")"
    return 1
  fi
  if ! grep -q 'No output asserted in' "$log" || grep -q 'Resource limit reached (timeout' "$log"; then
    echo "FAIL bmc $depth not finished in ${BMC_SECONDS}s"
    return 1
  fi
  if [ "$complete" != pdr ]; then
    echo "bounded: holds for $depth steps from reset"
    return 0
  fi
  prove_every_depth "$out" "pdr; bmc $depth"
}

# prove_every_depth OUTDIR HOW: ABC's pdr on OUTDIR/model.aig; HOW goes into the result line.
prove_every_depth() {
  local out=$1 how=$2 log=$1/pdr.log
  yosys-abc -c "read_aiger $out/model.aig; fold; strash; pdr -T $PDR_SECONDS; write_cex -a $out/model.aiw" >"$log" 2>&1 || true
  if grep -q 'Property proved' "$log"; then
    echo "proved for every depth ($how)"
  elif grep -q 'was asserted in frame' "$log"; then
    echo "FAIL at step $(grep -o 'asserted in frame [0-9]*' "$log" | grep -o '[0-9]*$'): $(counterexample "$out")"
    return 1
  else
    echo "FAIL pdr undecided in ${PDR_SECONDS}s ($how)"
    return 1
  fi
}

# apply_mutation SV LINE OUTDIR: OUTDIR/rtl holds the Verilog with the mutation's text replaced;
# prints how often the text occurred.
apply_mutation() {
  local sv=$1 line=$2 mout=$3 rest text replacement hits=0 n file
  rest=${line#*|}
  text=${rest%% => *}
  replacement=${rest#* => }
  text=$(echo "$text" | sed 's/^ *//; s/ *$//')
  replacement=$(echo "$replacement" | sed 's/^ *//; s/ *$//')
  mkdir -p "$mout/rtl"
  cp fpga/rtl/*.v "$mout/rtl/"
  for file in $(header read "$sv"); do
    n=$(TEXT="$text" perl -0ne 'my $t = $ENV{TEXT}; my $c = () = /\Q$t\E/g; print $c' "$mout/rtl/$file")
    if [ "$n" -gt 0 ]; then
      TEXT="$text" REPL="$replacement" perl -0pi -e 'my $t = $ENV{TEXT}; my $r = $ENV{REPL}; s/\Q$t\E/$r/g' "$mout/rtl/$file"
    fi
    hits=$((hits + n))
  done
  echo "$hits"
}

# check_property NAME: the proof of formal/NAME.sv; prints its FORMAL line.
check_property() {
  local name=$1 sv=formal/$1.sv out=build/formal/$1 start=$SECONDS result
  build_model "$name" "$sv" "$out" fpga/rtl
  if result=$(prove "$name" "$sv" "$out"); then
    printf 'FORMAL %-22s %s  %ds\n' "$name" "$result" $((SECONDS - start))
  else
    printf 'FORMAL %-22s %s  %ds  (trace: %s/trace.vcd)\n' "$name" "$result" $((SECONDS - start)) "$out"
  fi
}

# check_mutation NAME LINE: the proof of formal/NAME.sv on the mutated Verilog must fail on an
# assertion (a timeout does not count); prints its MUTATION line.
check_mutation() {
  local name=$1 line=$2 sv=formal/$1.sv mname mout start=$SECONDS hits result
  mname=$(echo "${line%%|*}" | xargs)
  mout=build/formal/$name/mutation-$mname
  hits=$(apply_mutation "$sv" "$line" "$mout")
  if [ "$hits" -ne 1 ]; then
    printf 'MUTATION %-20s %-26s not applied: the text occurs %d times (must be once)\n' "$name" "$mname" "$hits"
    return
  fi
  if [ "$mutations" -eq 2 ]; then
    printf 'MUTATION %-20s %-26s applies (not proved: make formal)\n' "$name" "$mname"
    return
  fi
  build_model "$name" "$sv" "$mout" "$mout/rtl"
  result=$(prove "$name" "$sv" "$mout") || true
  if [[ "$result" == "FAIL at step"* ]]; then
    printf 'MUTATION %-20s %-26s caught: %s  %ds\n' "$name" "$mname" "$result" $((SECONDS - start))
  else
    printf 'MUTATION %-20s %-26s NOT caught: %s  %ds\n' "$name" "$mname" "$result" $((SECONDS - start))
  fi
}

# The work, one task per proof, FORMAL_JOBS at a time (default: the number of processors); the
# lines are printed in the order of the property files.
tasks=()
for name in "${names[@]}"; do
  sv=formal/$name.sv
  [ -f "$sv" ] || { echo "formal.sh: no property $sv" >&2; exit 2; }
  rm -rf "build/formal/$name" && mkdir -p "build/formal/$name"
  tasks+=("$name")
  if [ $mutations -ge 1 ]; then
    while IFS= read -r line; do tasks+=("$name|$line"); done < <(header mutation "$sv")
    if [ $long -eq 1 ]; then
      while IFS= read -r line; do tasks+=("$name|$line"); done < <(header mutation-long "$sv")
    fi
  fi
done

# Start order: the proofs marked `start: first`, then the rest in file order.
order=()
for pass in first rest; do
  for i in "${!tasks[@]}"; do
    task=${tasks[$i]}
    if [[ "$task" != *"|"* ]] && [ "$(header start "formal/$task.sv")" = first ]; then
      [ $pass = first ] && order+=("$i")
    else
      [ $pass = rest ] && order+=("$i")
    fi
  done
done

jobs_max=${FORMAL_JOBS:-$(nproc)}
results=$(mktemp -d)
trap 'rm -rf "$results"' EXIT
for i in "${order[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do wait -n || true; done
  task=${tasks[$i]}
  if [[ "$task" == *"|"* ]]; then
    check_mutation "${task%%|*}" "${task#*|}" >"$results/$i" &
  else
    check_property "$task" >"$results/$i" &
  fi
done
wait

failures=0
for i in "${!tasks[@]}"; do
  [ -s "$results/$i" ] || echo "FAILED ${tasks[$i]%%|*}: no result (an error above)" >"$results/$i"
  cat "$results/$i"
  if grep -qE '^FAILED' "$results/$i" || grep -qE '^FORMAL .* FAIL|^MUTATION .*(NOT caught|not applied)' "$results/$i"; then
    failures=$((failures + 1))
  fi
done

if [ $failures -gt 0 ]; then
  echo "formal: $failures failure(s)"
  exit 1
fi
echo "formal: all passed"
