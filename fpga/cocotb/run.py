"""Builds and runs the cocotb tests of the bus wrappers (test_can_wrappers.py) with cocotb's runner:
run.py VERILOG_DIR BUILD_DIR [--sim icarus] [--bus wishbone|axi4-lite|apb ...] [--stride 0|1 ...].
VERILOG_DIR holds can_controller.v and the wrappers (`cansim verilog --bus ...`). Prints one line per
combination and exits 1 if any test failed."""

import argparse
import os
import sys
from pathlib import Path

from cocotb_tools.runner import get_results, get_runner

HERE = Path(__file__).resolve().parent
TOPS = {"wishbone": ("can_controller_wb", "tb_wishbone"),
        "axi4-lite": ("can_controller_axil", "tb_axil"),
        "apb": ("can_controller_apb", "tb_apb")}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("verilog")
    parser.add_argument("build")
    parser.add_argument("--sim", default="icarus")
    parser.add_argument("--bus", action="append", choices=list(TOPS))
    parser.add_argument("--stride", action="append", type=int, choices=[0, 1])
    args = parser.parse_args()
    verilog = Path(args.verilog).resolve()
    failed = 0
    for bus in args.bus or list(TOPS):
        wrapper, tb = TOPS[bus]
        for stride in args.stride or [0, 1]:
            build = Path(args.build).resolve() / f"{args.sim}-{bus}-{stride}"
            runner = get_runner(args.sim)
            runner.build(
                sources=[verilog / "can_controller.v", verilog / f"{wrapper}.v", HERE / f"{tb}.v"],
                hdl_toplevel=tb,
                parameters={"WORD_STRIDE": stride},
                build_dir=build,
                always=True,
                timescale=("1ns", "1ps"),
                # The categories docs/VERILOG.md explains are warnings, not errors.
                build_args=["-Wno-fatal", "-Wno-lint", "-Wno-style"] if args.sim == "verilator" else [],
            )
            results = runner.test(
                hdl_toplevel=tb,
                test_module="test_can_wrappers",
                test_dir=HERE,
                build_dir=build,
                extra_env={"CAN_BUS": bus, "WORD_STRIDE": str(stride),
                           "PYTHONPATH": str(HERE) + os.pathsep + os.environ.get("PYTHONPATH", "")},
                results_xml=build / "results.xml",
            )
            tests, fails = get_results(results)
            failed += fails
            print(f"COCOTB {args.sim} {bus} word_stride={stride}: {tests - fails}/{tests} passed",
                  flush=True)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
