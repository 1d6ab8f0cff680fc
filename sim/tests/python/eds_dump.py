"""What python canopen 2.4.1 reads from an EDS (the independent reader our EDS parser is checked
against, by sim/tests/canopen_cli.rs): one line per entry, `IIII:SS type=TTTT access=A
mappable=M default=V name=N`, sorted. Usage: eds_dump.py EDS NODE_ID."""

import sys

import canopen

EDS = sys.argv[1]
NODE_ID = int(sys.argv[2])

# CiA 306 rww and rwr are read-write entries that PDOs write or read.
ACCESS = {"rww": "rw", "rwr": "rw"}


def line(index, sub, var):
    default = var.default
    if isinstance(default, bytes):
        default = default.hex().upper()
    access = ACCESS.get(var.access_type, var.access_type)
    return (
        f"{index:04X}:{sub:02X} type={var.data_type:04X} access={access} "
        f"mappable={int(bool(var.pdo_mappable))} default={default} name={var.name}"
    )


od = canopen.import_od(EDS, NODE_ID)
lines = []
for index in od.indices:
    obj = od[index]
    if isinstance(obj, canopen.objectdictionary.ODVariable):
        lines.append(line(index, 0, obj))
    else:
        for sub in obj.subindices:
            lines.append(line(index, sub, obj[sub]))
print("\n".join(sorted(lines)))
