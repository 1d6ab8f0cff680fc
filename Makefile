# Entry points of the project. `make test` is what CI runs.
CARGO ?= cargo

.PHONY: test test-long check tools demo waves lint verilog synth bench campaign clean

## Install the external tools (sigrok-cli, iverilog), then run every test.
test: tools
	$(CARGO) test --workspace

## The long runs kept out of `make test`: the 200 000-cycle Icarus equivalence run and the driver
## replay of more than 1 000 frames (a few minutes).
test-long: tools
	$(CARGO) test -p testbenches --test verilog_equivalence --test linux_driver -- --ignored

## Formatting and clippy, warnings are errors.
check:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

## External tools the tests need (Debian packages, installed when missing).
tools:
	./scripts/install-tools.sh

## The main job: the demo simulation, writes waves/demo.vcd and prints what happened.
demo:
	$(CARGO) run --release -- demo

## Run the demo and show how to open its waves.
waves: demo
	@echo "open: gtkwave waves/demo.vcd waves/demo.gtkw"

## Speed figures of the simulation engine.
bench:
	$(CARGO) bench -p sim --bench engine

## Fault-injection campaign on every core (FAULTS=100000 by default, SEED=1).
FAULTS ?= 100000
SEED ?= 1
campaign:
	$(CARGO) run --release -- campaign --faults $(FAULTS) --seed $(SEED)

lint verilog synth:
	@echo "make $@: not yet (Verilog generation and lint come with the Verilog issue)"; exit 1

clean:
	$(CARGO) clean
	rm -rf build waves/*.vcd waves/*.log waves/*.frames.filter
