"""python canopen 2.4.1's LocalNode as a CANopen slave (examples/eds/io.eds) on the bus of
`cansim serve` (run by sim/tests/canopen_cli.rs): the independent device our CANopen master is
checked against. Usage: canopen_local_node.py PORT EDS NODE_ID. Sends its boot-up message and
enters pre-operational (python canopen's NmtSlave), prints READY, then serves SDO and NMT until
its standard input closes."""

import sys

import canopen

PORT = int(sys.argv[1])
EDS = sys.argv[2]
NODE_ID = int(sys.argv[3])

network = canopen.Network()
network.connect(interface="socketcand", host="127.0.0.1", port=PORT, channel="can0")
node = canopen.LocalNode(NODE_ID, EDS)
network.add_node(node)
# Reset node: state initialising, which sends the boot-up message; then pre-operational.
node.nmt.send_command(0x81)
node.nmt.send_command(0x80)
print("READY", flush=True)
sys.stdin.read()
network.disconnect()
