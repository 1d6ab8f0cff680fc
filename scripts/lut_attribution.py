#!/usr/bin/env python3
"""Per-block logic of a flattened Yosys synth_ice40 netlist (make synth).

`synth_ice40 -noflatten` counts each block alone, without the optimisation across blocks, so its
figures add up to far more than the design. This counts the flattened design instead: every
SB_LUT4 (and SB_CARRY) is shared equally among the blocks whose flip-flops, block RAMs or output
ports it feeds, following LUTs and carries forward until a flip-flop, a RAM or an output. A
flip-flop belongs to the block of its register (`core.protocol.faults.rec_count.q` is a register of
`core.protocol.faults`); a RAM to the block holding the memory. The shares add up to the design's
totals, which the script checks.

    scripts/lut_attribution.py NETLIST.json [TOP]

prints one line per block: SB_LUT4 share, SB_CARRY share, flip-flops, largest first. A memory
(`fifo.ram`) is a block of its own: the logic that feeds its write port and address, and the
flip-flops synthesis adds around it.
"""

import collections
import json
import re
import sys

AUTO_NAME = "_SB_"  # nets Yosys names after the cells around them


def register_name(aliases):
    """The register a flip-flop's output net belongs to, from the net's names."""
    own = [a for a in aliases if not a.startswith("$") and AUTO_NAME not in a]
    for suffix in (".q", "$q"):
        named = [a for a in own if a.endswith(suffix)]
        if named:
            return min(named, key=len)[: -len(suffix)]
    candidates = own or [a for a in aliases if not a.startswith("$")] or ["?"]
    return max(candidates, key=lambda a: (a.count("."), -len(a)))


def block_of(register):
    """`a.b.reg` -> `a.b`; `a.b$port` -> `a.b`; a memory's cells and nets (`a.ram.mem.0...`) ->
    the memory's block `a.ram`; a top-level register -> "" (the top)."""
    register = re.sub(r"\[\d+\]$", "", register)
    register = register.split(AUTO_NAME)[0]
    register = register.split("$")[0]
    parts = register.split(".")
    if "mem" in parts:
        return ".".join(parts[: parts.index("mem")])
    return ".".join(parts[:-1]) if len(parts) > 1 else ""


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    netlist = json.load(open(sys.argv[1]))
    top = sys.argv[2] if len(sys.argv) == 3 else "can_controller"
    module = netlist["modules"][top]
    cells = module["cells"]

    aliases = collections.defaultdict(list)
    for name, net in module["netnames"].items():
        for bit in net["bits"]:
            if isinstance(bit, int):
                aliases[bit].append(name)
    sinks = collections.defaultdict(list)
    for name, cell in cells.items():
        directions = cell.get("port_directions", {})
        for port, bits in cell["connections"].items():
            if directions.get(port) == "input":
                for bit in bits:
                    if isinstance(bit, int):
                        sinks[bit].append(name)
    outputs = {
        bit: f"output {port}"
        for port, p in module["ports"].items()
        if p["direction"] == "output"
        for bit in p["bits"]
        if isinstance(bit, int)
    }

    def owner(name):
        cell = cells[name]
        if cell["type"].startswith("SB_DFF"):
            return block_of(register_name(aliases[cell["connections"]["Q"][0]])) or top
        if cell["type"].startswith("SB_RAM"):
            return block_of(name) or top
        return None

    reached = {}

    def destinations(name):
        """The blocks a combinational cell feeds (memoised; cycles through logic are cut)."""
        if name in reached:
            return reached[name]
        reached[name] = frozenset()
        found = set()
        cell = cells[name]
        directions = cell.get("port_directions", {})
        for port, bits in cell["connections"].items():
            if directions.get(port) != "output":
                continue
            for bit in bits:
                if bit in outputs:
                    found.add(outputs[bit])
                for sink in sinks.get(bit, []):
                    block = owner(sink)
                    if block is not None:
                        found.add(block)
                    elif cells[sink]["type"] in ("SB_LUT4", "SB_CARRY"):
                        found |= destinations(sink)
        reached[name] = frozenset(found)
        return reached[name]

    sys.setrecursionlimit(100_000)
    share = collections.defaultdict(lambda: [0.0, 0.0, 0])
    totals = collections.Counter()
    for name, cell in cells.items():
        kind = cell["type"]
        if kind in ("SB_LUT4", "SB_CARRY"):
            totals[kind] += 1
            blocks = destinations(name) or {"(feeds nothing)"}
            for block in blocks:
                share[block][0 if kind == "SB_LUT4" else 1] += 1 / len(blocks)
        elif kind.startswith("SB_DFF"):
            totals["flip-flops"] += 1
            share[owner(name)][2] += 1

    for index, kind in enumerate(("SB_LUT4", "SB_CARRY", "flip-flops")):
        counted = sum(row[index] for row in share.values())
        assert abs(counted - totals[kind]) < 1e-6, f"{kind}: {counted} shared, {totals[kind]} cells"
    width = max(len(block) for block in share)
    print(f"  {'block':<{width}}  SB_LUT4  SB_CARRY  flip-flops")
    for block, (luts, carries, flops) in sorted(share.items(), key=lambda kv: -kv[1][0]):
        print(f"  {block:<{width}}  {luts:7.1f}  {carries:8.1f}  {flops:10d}")
    print(
        f"  {'total':<{width}}  {totals['SB_LUT4']:7d}  {totals['SB_CARRY']:8d}  {totals['flip-flops']:10d}"
    )


if __name__ == "__main__":
    main()
