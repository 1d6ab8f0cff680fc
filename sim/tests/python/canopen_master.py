"""python canopen 2.4.1 as the master of our CANopen device (node 2, examples/eds/io.eds) on the bus of
`cansim serve examples/canopen_device.toml` (run by sim/tests/canopen_cli.rs).

The device is our stack running as the firmware of a simulated node, reaching the bus through the
SJA1000 registers; python canopen (over python-can's socketcand interface) is the independent judge.
Every expected value is what CiA 301 and the shared EDS say. Prints one line per check; exits non-zero on
the first failure.
"""

import sys
import time

import canopen
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

PORT = int(sys.argv[1])
EDS = sys.argv[2]
# The simulated bus runs at about a hundredth of real time: wall-clock timeouts are generous.
WAIT_S = 120
NO_ANSWER_S = 3


def check(condition, text):
    if not condition:
        raise SystemExit(f"FAIL: {text}")
    print(f"ok: {text}")


def abort_code(action):
    try:
        action()
    except SdoAbortedError as e:
        return e.code
    return None


network = canopen.Network()
network.connect(interface="socketcand", host="127.0.0.1", port=PORT, channel="can0")
node = network.add_node(2, EDS)
node.sdo.RESPONSE_TIMEOUT = WAIT_S

# NMT reset communication: the device sends its boot-up message (CiA 301 7.3.2.2.1).
node.nmt.state = "RESET COMMUNICATION"
node.nmt.wait_for_bootup(WAIT_S)
check(True, "boot-up (700h + 2, 00h) after reset communication")

# SDO upload, expedited (<= 4 bytes) and segmented (the 13-byte device name).
check(node.sdo["Device type"].raw == 0x191, "expedited upload: 1000h = 0x191")
check(node.sdo[0x1018][1].raw == 0x00C0FFEE, "expedited upload: 1018h:1 vendor-ID")
check(node.sdo[0x1018][4].raw == 0x12340002, "1018h:4 = $NODEID+0x12340000 for node 2")
check(node.sdo["Manufacturer device name"].raw == "cansim IO 8x8", "segmented upload: 1008h")

# SDO download, expedited, then the heartbeat it turns on (1017h, ms).
node.sdo["Producer heartbeat time"].raw = 10
check(node.sdo["Producer heartbeat time"].raw == 10, "expedited download: 1017h = 10 ms")
check(node.nmt.wait_for_heartbeat(WAIT_S) == "PRE-OPERATIONAL", "heartbeat 7Fh: pre-operational")

# NMT commands and the state the heartbeat reports (CiA 301 Table 54). The first heartbeat after a
# command may have been on its way already; the second is surely after it.
for command in ["OPERATIONAL", "STOPPED", "PRE-OPERATIONAL", "OPERATIONAL"]:
    node.nmt.state = command
    node.nmt.wait_for_heartbeat(WAIT_S)
    check(node.nmt.wait_for_heartbeat(WAIT_S) == command, f"NMT {command}: heartbeat says so")

# Stopped: no SDO (CiA 301 Table 82), the request times out; then operational serves again.
node.nmt.state = "STOPPED"
node.nmt.wait_for_heartbeat(WAIT_S)
node.nmt.wait_for_heartbeat(WAIT_S)
node.sdo.RESPONSE_TIMEOUT = NO_ANSWER_S
try:
    node.sdo["Device type"].raw
    answered = True
except SdoCommunicationError:
    answered = False
check(not answered, "stopped: an SDO request gets no answer")
node.sdo.RESPONSE_TIMEOUT = WAIT_S
node.nmt.state = "OPERATIONAL"
node.nmt.wait_for_heartbeat(WAIT_S)
node.nmt.wait_for_heartbeat(WAIT_S)

# SDO download, segmented (a 16-byte string), read back.
node.sdo["Label"].raw = "left door sensor"
check(node.sdo["Label"].raw == "left door sensor", "segmented download: 2001h read back")
node.sdo["Input debounce time"].raw = 250
check(node.sdo["Input debounce time"].raw == 250, "2000h = 250 within 1..1000")

# SDO block transfers (CiA 301 7.2.4.3.9-16) with CRC: 200 bytes down in one sub-block of 29
# segments, and up again in sub-blocks of the client's size (127).
payload = bytes((k * 7 + 3) % 95 + 32 for k in range(200))
with node.sdo[0x2001].open("wb", size=len(payload), block_transfer=True) as stream:
    stream.write(payload)
with node.sdo[0x2001].open("rb", block_transfer=True) as stream:
    back = stream.read()
check(back == payload, "block download of 200 bytes, block upload of the same")
check(node.sdo["Label"].raw == payload.decode("ascii"), "segmented upload agrees")
node.sdo["Label"].raw = "left door sensor"

# Aborts (CiA 301 Table 22).
check(abort_code(lambda: setattr(node.sdo["Device type"], "raw", 5)) == 0x06010002,
      "write to read-only 1000h: abort 0601 0002")
check(abort_code(lambda: node.sdo.upload(0x3000, 0)) == 0x06020000,
      "upload of absent 3000h: abort 0602 0000")
check(abort_code(lambda: node.sdo.upload(0x1018, 9)) == 0x06090011,
      "upload of absent 1018h:9: abort 0609 0011")
check(abort_code(lambda: node.sdo.download(0x2000, 0, (5000).to_bytes(2, "little"))) == 0x06090031,
      "2000h = 5000 above HighLimit 1000: abort 0609 0031")
check(abort_code(lambda: node.sdo.download(0x2000, 0, (0).to_bytes(2, "little"))) == 0x06090032,
      "2000h = 0 below LowLimit 1: abort 0609 0032")
check(abort_code(lambda: node.sdo.download(0x2000, 0, b"\x01\x00\x00")) == 0x06070012,
      "3 bytes for an UNSIGNED16: abort 0607 0012")
check(node.sdo["Input debounce time"].raw == 250, "the refused writes changed nothing")

# SYNC producer (CiA 301 7.2.5): 1006h = 2000 us and 1005h bit 30 make the device send 080h every 2 ms
# of simulated time, with a counter 1..3 when 1019h = 3.
syncs = []
network.subscribe(0x080, lambda can_id, data, timestamp: syncs.append((timestamp, bytes(data))))
node.sdo[0x1019].raw = 3
node.sdo[0x1006].raw = 2000
node.sdo[0x1005].raw = 0x40000080
deadline = time.time() + WAIT_S
while len(syncs) < 4 and time.time() < deadline:
    time.sleep(0.05)
node.sdo[0x1005].raw = 0x00000080
check(len(syncs) >= 4, f"SYNC producer: {len(syncs)} SYNCs")
gaps = [later[0] - earlier[0] for earlier, later in zip(syncs, syncs[1:4])]
check(all(abs(gap - 0.002) < 0.0001 for gap in gaps), f"SYNC every 2 ms: {gaps}")
counters = [data[0] for _, data in syncs[:4]]
check(counters in ([1, 2, 3, 1], [2, 3, 1, 2], [3, 1, 2, 3]), f"SYNC counter 1..3: {counters}")

# Heartbeat consumer (7.2.8.3.2.2) and EMCY (7.2.7): 1016h:1 watches node 5 with 50 ms; after one
# heartbeat of node 5 and then none, the device reports EMCY 8130h (heartbeat error, Table 21) with
# the error register's communication and generic bits (11h), keeps it in 1003h, and sends an error
# reset (0000h) when node 5 is back.
node.sdo[0x1016][1].raw = (5 << 16) | 50
network.send_message(0x705, [0x05])
emcy = node.emcy.wait(0x8130, WAIT_S)
check(emcy is not None and emcy.register == 0x11, f"EMCY 8130h with register 11h: {emcy}")
check(node.sdo[0x1001].raw == 0x11, "1001h error register = 11h")
check(node.sdo[0x1003][0].raw == 1 and node.sdo[0x1003][1].raw == 0x8130, "1003h:1 = 8130h")
network.send_message(0x705, [0x05])
reset = node.emcy.wait(0x0000, WAIT_S)
check(reset is not None and reset.register == 0, "node 5 back: EMCY 0000h, register 0")
node.sdo[0x1016][1].raw = 0

# PDOs (CiA 301 7.2.2): TPDO1 maps the inputs (6000h:1) and 2000h, sent on every SYNC; RPDO1 maps
# the outputs (6200h:1). python canopen configures them by SDO as 7.5.2.38 prescribes (COB-ID not
# valid, count 0, entries, count, COB-ID valid).
node.nmt.state = "PRE-OPERATIONAL"
node.tpdo.read()
node.rpdo.read()
tpdo = node.tpdo[1]
tpdo.clear()
tpdo.add_variable(0x6000, 1)
tpdo.add_variable("Input debounce time")
tpdo.trans_type = 1
tpdo.enabled = True
tpdo.save()
rpdo = node.rpdo[1]
rpdo.clear()
rpdo.add_variable(0x6200, 1)
rpdo.enabled = True
rpdo.save()
check(node.sdo[0x1A00][1].raw == 0x60000108 and node.sdo[0x1A00][2].raw == 0x20000010,
      "TPDO1 mapping: 6000h:1 (8 bits), 2000h:0 (16 bits)")
check(node.sdo[0x1800][1].raw & 0x7FF == 0x182, "TPDO1 COB-ID 180h + 2, valid")
node.nmt.state = "OPERATIONAL"
network.sync.transmit()
tpdo.wait_for_reception(WAIT_S)
check(tpdo.map[0].raw == 0x5A and tpdo.map[1].raw == 250,
      f"SYNC: TPDO1 (182h) carries 6000h:1 = 5Ah and 2000h = 250")
rpdo.map[0].raw = 0x33
rpdo.transmit()
check(node.sdo[0x6200][1].raw == 0x33, "RPDO1 (202h) wrote 6200h:1 = 33h")
node.nmt.state = "PRE-OPERATIONAL"
not_mappable = (0x1008 << 16) | 8
check(abort_code(lambda: (node.sdo.download(0x1A01, 1, not_mappable.to_bytes(4, "little")),
                          node.sdo.download(0x1A01, 0, b"\x01"))) == 0x06040041,
      "mapping 1008h (not mappable): abort 0604 0041")
for sub in range(1, 6):
    node.sdo.download(0x1A01, sub, ((0x2000 << 16) | 16).to_bytes(4, "little"))
check(abort_code(lambda: node.sdo.download(0x1A01, 0, b"\x05")) == 0x06040042,
      "five 16-bit objects (80 bits): abort 0604 0042")

# Reset node: every object back to its EDS default, boot-up again.
node.nmt.state = "RESET"
node.nmt.wait_for_bootup(WAIT_S)
check(node.sdo["Label"].raw == "unnamed", "reset node: 2001h back to its default")
check(node.sdo["Producer heartbeat time"].raw == 0, "reset node: 1017h back to 0")
network.disconnect()
print("PASS")
