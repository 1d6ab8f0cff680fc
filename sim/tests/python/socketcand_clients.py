"""Two python-can clients on the bus of `cansim serve examples/serve.toml` (run by sim/tests/serve_cli.rs).

python-can's own socketcand interface (python-can 4.6.1) and cantools (on examples/engine.dbc) are the
judges: what they parse is what a user's script gets. Checks, with python-can's message objects:
  * frames of client a reach client b with identifier, extended flag, data and order intact, and b's
    reach a; a client never gets its own frames back (SocketCAN semantics);
  * the scenario's ecu frames arrive and cantools decodes them as the DBC says (2000 rpm, 50 degC,
    counting first byte);
  * timestamps are simulated seconds, increasing, and the bus log's order is kept.
Prints one line per check; exits non-zero on the first failure.
"""

import sys
import time

import can
import cantools

PORT = int(sys.argv[1])
DBC = sys.argv[2]
TIMEOUT_S = 120


def bus():
    return can.Bus(interface="socketcand", host="127.0.0.1", port=PORT, channel="can0")


def collect(client, wanted, count):
    """Messages with identifiers in `wanted` until `count` of them came, and everything else seen."""
    got, other = [], []
    deadline = time.time() + TIMEOUT_S
    while len(got) < count:
        if time.time() > deadline:
            raise SystemExit(f"FAIL: timeout, got {got} and {len(other)} others")
        message = client.recv(timeout=1.0)
        if message is None:
            continue
        (got if message.arbitration_id in wanted else other).append(message)
    return got, other


def check(condition, text):
    if not condition:
        raise SystemExit(f"FAIL: {text}")
    print(f"ok: {text}")


a, b = bus(), bus()
sent_by_a = [
    can.Message(arbitration_id=0x123, data=[1, 2, 3], is_extended_id=False),
    can.Message(arbitration_id=0x1ABCDE01, data=[], is_extended_id=True),
    can.Message(arbitration_id=0x7FF, data=[0xDE, 0xAD, 0xBE, 0xEF, 0, 1, 2, 0xFF], is_extended_id=False),
]
for message in sent_by_a:
    a.send(message)
got, other_b = collect(b, {m.arbitration_id for m in sent_by_a}, len(sent_by_a))
check([m.arbitration_id for m in got] == [0x123, 0x1ABCDE01, 0x7FF], "b gets a's frames in order")
check([m.is_extended_id for m in got] == [False, True, False], "b sees which identifiers are extended")
check([bytes(m.data) for m in got] == [bytes(m.data) for m in sent_by_a], "b gets a's data")
stamps = [m.timestamp for m in got]
check(stamps == sorted(stamps) and 0 < stamps[0] < 60, f"timestamps are simulated seconds: {stamps}")

b.send(can.Message(arbitration_id=0x321, data=[0x55], is_extended_id=False))
got, other_a = collect(a, {0x321}, 1)
check(bytes(got[0].data) == b"\x55" and not got[0].is_extended_id, "a gets b's frame")
check(all(m.arbitration_id not in {0x123, 0x1ABCDE01, 0x7FF} for m in other_a), "a never gets its own frames")

db = cantools.database.load_file(DBC)
engine, _ = collect(b, {0x0C0}, 2)
decoded = [db.decode_message(m.arbitration_id, m.data) for m in engine]
check(all(d["EngineSpeed"] == 2000.0 and d["CoolantTemp"] == 50 for d in decoded),
      f"cantools decodes the ecu's EngineStatus: {decoded[0]}")
check(decoded[1]["Counter"] == (decoded[0]["Counter"] + 1) % 256, "its counter counts")
check(engine[1].timestamp - engine[0].timestamp > 0.009, "10 ms apart in simulated time")
gateway, _ = collect(b, {0x18FEF100}, 1)
check(gateway[0].is_extended_id and bytes(gateway[0].data) == b"\xff\x00", "the gateway's extended frame")
a.shutdown()
b.shutdown()
print("PASS")
