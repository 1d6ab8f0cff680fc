"""Host side of the iCEBreaker design (icebreaker_can.v): the two controllers' registers over the
board's serial port (pyserial), and a demo that starts both at 500 kbit/s and sends a frame from
node 0 to node 1 (connect the two transceivers' CANH/CANL, 120 ohm at each end).

    python can_uart.py /dev/ttyUSB1
"""

import sys
import time

import serial


class Bridge:
    """Register reads and writes of node 0 or 1 through the bridge's 2- and 3-byte commands."""

    def __init__(self, port):
        self.port = serial.Serial(port, 115200, timeout=1)

    def write(self, node, reg, value):
        self.port.write(bytes([0x80 | node, reg, value]))

    def read(self, node, reg):
        self.port.write(bytes([node, reg]))
        answer = self.port.read(1)
        if len(answer) != 1:
            raise TimeoutError(f"no answer reading register {reg} of node {node}")
        return answer[0]

    def start(self, node, btr0=0x00, btr1=0x27):
        """The Linux driver's start: PeliCAN, bit timing (500 kbit/s at 12 MHz), open filter."""
        self.write(node, 31, 0x80)
        self.write(node, 6, btr0)
        self.write(node, 7, btr1)
        for reg in range(20, 24):
            self.write(node, reg, 0xFF)
        self.write(node, 4, 0x01)
        self.write(node, 0, 0x00)


def main():
    bridge = Bridge(sys.argv[1])
    for node in (0, 1):
        bridge.start(node)
    time.sleep(0.01)
    for reg, value in zip(range(16, 21), [0x02, 0x24, 0x60, 0xAB, 0xCD]):
        bridge.write(0, reg, value)
    bridge.write(0, 1, 0x01)
    time.sleep(0.01)
    print(f"node 1 IR {bridge.read(1, 3):02X}h (01h: a frame arrived)")
    print("node 1 RX buffer:", " ".join(f"{bridge.read(1, r):02X}" for r in range(16, 21)))


if __name__ == "__main__":
    main()
