"""python canopen 2.4.1's LocalNode as an SDO server (node 1, examples/eds/io.eds) on the bus of
`cansim serve` (run by sim/tests/canopen_cli.rs): the independent server our SDO client is checked
against. Prints READY once on the bus; serves until its standard input closes."""

import sys

import canopen

PORT = int(sys.argv[1])
EDS = sys.argv[2]

network = canopen.Network()
network.connect(interface="socketcand", host="127.0.0.1", port=PORT, channel="can0")
node = canopen.LocalNode(1, EDS)
network.add_node(node)
print("READY", flush=True)
sys.stdin.read()
network.disconnect()
