# Entry points of the project. `make test` is what CI runs.
CARGO ?= cargo

.PHONY: bitstream formal formal-long fpga-rtl pyenv test test-long test-verilator check tools demo waves waves-check waves-compare lint verilog verilator-model compiled-model synth bench campaign clean

## Install the external tools (sigrok-cli, iverilog, verilator) and the Python ones (python-can,
## cantools, pinned, in build/pyenv), then run every test (the long single-threaded Icarus
## equivalence run beside the others: scripts/test.sh).
test: tools pyenv
	CARGO=$(CARGO) ./scripts/test.sh

## The long runs kept out of `make test`: the driver replay of more than 1 000 frames and the
## powertrain and body message sets on the bus (a few minutes).
test-long: tools
	$(CARGO) test -p testbenches --test linux_driver --test rta -- --ignored

## The register-level testbenches and the protocol scenarios on the complete controller
## (on_registers::), with the controller stepped by the Verilator engine (docs/ENGINES.md).
REGISTER_SUITES = registers rx_fifo modes controller_conformance register_iut linux_driver \
	scenarios examples demo waves_on_request conformance_matrix
## The ISO 16845-1 suites (testbenches/tests/iso_*.rs) run there too.
ISO_SUITES = $(basename $(notdir $(wildcard testbenches/tests/iso_*.rs)))
PROTOCOL_SUITES = arbitration bit_timing error_kinds errors fault_confinement frames interframe \
	synchronisation $(ISO_SUITES)
test-verilator: tools
	CAN_ENGINE=verilator $(CARGO) test -p testbenches $(addprefix --test ,$(REGISTER_SUITES))
	CAN_ENGINE=verilator $(CARGO) test -p testbenches $(addprefix --test ,$(PROTOCOL_SUITES)) -- on_registers::

## The Python virtual environment of the tests: python-can and cantools, pinned
## (scripts/python-requirements.txt), judge what `cansim serve` puts on the wire.
pyenv:
	./scripts/pyenv.sh

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

## Every testbench writes its VCD into waves/ (CANSIM_WAVES=1), then waves-compare. The comparison
## of the suite's ~7 000 files takes about 3 minutes on two cores.
waves-check: tools
	rm -f waves/*.vcd
	CANSIM_WAVES=1 $(CARGO) test -p testbenches
	$(MAKE) waves-compare

## Our bus decoder and sigrok's CAN decoder compared frame by frame on every VCD in waves/, with the
## sigrok-limit exclusions per file (testbenches/tests/waves_agreement.rs, built as `cargo test` builds;
## `cargo run -p testbenches --bin waves_check -- -v waves` lists each exclusion).
waves-compare:
	$(CARGO) test -p testbenches --test waves_agreement -- --ignored --nocapture

## Speed figures: the reference workload (cansim bench) on both engines of the complete controller,
## then the bit-timing and core-only devices.
bench:
	$(CARGO) run --release -p sim --bin cansim -- bench --engine compiled,rust-hdl,verilator --skip-edges off,on
	$(CARGO) bench -p sim --bench engine

## Fault-injection campaign on every core (FAULTS=100000 by default, SEED=1).
FAULTS ?= 100000
SEED ?= 1
campaign:
	$(CARGO) run --release -- campaign --faults $(FAULTS) --seed $(SEED)

## The controller as Verilog: build/verilog/can_controller.v and the bus wrappers
## (can_controller_wb.v, can_controller_axil.v, can_controller_apb.v).
verilog:
	$(CARGO) run -q -p sim --bin cansim -- verilog --out build/verilog
	for bus in wishbone axi4-lite apb; do \
		$(CARGO) run -q -p sim --bin cansim -- verilog --bus $$bus --out build/verilog || exit 1; \
	done

## The iCEBreaker design (fpga/boards/icebreaker/) as a bitstream: build/bitstream/icebreaker_can.bin,
## with its resources and maximum clock (fails below the board's 12 MHz).
bitstream:
	./scripts/bitstream.sh

## The Verilog shipped in fpga/rtl/ for FuseSoC, LiteX and users without Rust (a test checks that it
## equals what cansim writes; run this after changing rtl/).
fpga-rtl:
	for bus in wishbone axi4-lite apb; do \
		$(CARGO) run -q -p sim --bin cansim -- verilog --bus $$bus --out fpga/rtl || exit 1; \
	done

## The Verilator engine's model (CAN_ENGINE=verilator), built into target/verilator/ if it is not
## there yet (tests and runs build it on first use too); prints the library's path.
verilator-model: tools
	$(CARGO) run -q -p sim --bin cansim -- verilator-model

## The compiled engine's model (the default CAN_ENGINE): the Verilog of rtl/ through Yosys into
## straight-line Rust, sim/src/compiled/model.rs. Run it after changing rtl/ and commit the file (the
## test compiled_model fails, and the engine refuses to start, while it is older than rtl/).
compiled-model: tools
	$(CARGO) run -q --release -p sim --bin cansim -- compiled-model

## Formal proofs of the generated Verilog (formal/*.sv, docs/FORMAL.md): each property proved with
## Yosys and ABC (pdr for every depth, or bmc to its stated bound), then each deliberate break of a
## rule (a mutation of the Verilog) shown to fail its proof (testbenches/tests/formal.rs, about 4
## minutes; `make test` runs the proofs and only checks that each mutation still applies). Run it
## after changing rtl/. formal-long adds the mutations whose counterexamples are thousands of clocks
## deep (minutes each).
formal: tools
	$(CARGO) test -p testbenches --test formal -- --ignored --nocapture

formal-long: tools
	./scripts/formal.sh --long --mutations

## Lint of the generated Verilog: warning counts per category (Verilator -Wall, Icarus -Wall).
lint: tools
	./scripts/lint.sh

## Synthesis figures (Yosys iCE40 and Xilinx, nextpnr-ice40 max clock); writes build/synth/report.txt.
synth:
	./scripts/install-tools.sh --synth
	./scripts/synth.sh

clean:
	$(CARGO) clean
	rm -rf build waves/*.vcd waves/*.log waves/*.frames.filter
