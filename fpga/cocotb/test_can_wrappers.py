"""cocotb tests of the bus wrappers (can_controller_wb, can_controller_axil, can_controller_apb),
driven by third-party bus models (sja1000_bus.py) on two controllers sharing one CAN bus
(tb_<bus>.v). The bus and the register layout come from the environment (CAN_BUS, WORD_STRIDE):
run.py builds and runs every combination. Expected values are the SJA1000 data sheet's (register
numbers and reset values: section 6 and Table 3/4/16 of the PeliCAN map)."""

import os

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, First, RisingEdge, Timer

from sja1000_bus import Sja1000, cycles

BUS = os.environ.get("CAN_BUS", "axi4-lite")
WORD_STRIDE = int(os.environ.get("WORD_STRIDE", "0"))

# PeliCAN registers (data sheet 6.5, Table 3).
MOD, CMR, SR, IR, IER, BTR0, BTR1, OCR = 0, 1, 2, 3, 4, 6, 7, 8
EWLR, RXERR, TXERR, TX_FRAME, ACR0, AMR0, RMC, RBSA, CDR = 13, 14, 15, 16, 16, 20, 29, 30, 31
# BTR0 0, BTR1 0x14: tq = 2 clocks, 1 + 5 + 2 tq: 16 clocks per bit.
FAST_BTR1 = 0x14
FRAME_CYCLES = 200 * 16


async def start(dut):
    cocotb.start_soon(Clock(dut.clock, 10, unit="ns").start())
    nodes = [Sja1000(dut, BUS, k, WORD_STRIDE) for k in (0, 1)]
    dut.reset.value = 1
    await ClockCycles(dut.clock, 4)
    dut.reset.value = 0
    await ClockCycles(dut.clock, 2)
    return nodes


async def linux_start(node, ier):
    """The Linux sja1000 driver's start: PeliCAN in reset mode, bit timing, open filter (AMR all
    ones), interrupts, then operating mode."""
    await node.write(CDR, 0x80)
    await node.write(BTR0, 0x00)
    await node.write(BTR1, FAST_BTR1)
    for k in range(4):
        await node.write(ACR0 + k, 0x00)
        await node.write(AMR0 + k, 0xFF)
    await node.write(IER, ier)
    await node.write(MOD, 0x00)
    assert await node.read(MOD) == 0x00, "operating mode"


async def transmit(node, frame):
    for k, b in enumerate(frame):
        await node.write(TX_FRAME + k, b)
    await node.write(CMR, 0x01)


async def wait_irq(dut, k, limit):
    irq = getattr(dut, f"n{k}_irq")
    for _ in range(limit):
        if int(irq.value) == 1:
            return True
        await RisingEdge(dut.clock)
    return False


@cocotb.test()
async def reset_values_of_the_pelican_map(dut):
    """Data sheet: after a hardware reset the BasicCAN control register reads 21h (reset request,
    bit 5 reads 1); in PeliCAN reset mode MOD 01h, SR 3Ch, IR 0, IER 0, EWLR 96, RXERR/TXERR 0,
    RMC 0, RBSA 0."""
    n0, _ = await start(dut)
    assert await n0.read(MOD) == 0x21
    await n0.write(CDR, 0x80)
    expected = {MOD: 0x01, SR: 0x3C, IR: 0x00, IER: 0x00, EWLR: 96, RXERR: 0, TXERR: 0,
                RMC: 0, RBSA: 0, CDR: 0x80}
    for reg, value in expected.items():
        got = await n0.read(reg)
        assert got == value, f"register {reg}: {got:#04x}, expected {value:#04x}"


@cocotb.test()
async def two_controllers_exchange_standard_and_extended_frames(dut):
    """Node 0 sends standard frame 123h [ABh CDh], node 1 extended frame 1ABCDE5h [5Ah]; each
    receiver's irq rises with RI (IR 01h). Reading IR clears every bit but RI, which stays set
    while the RX FIFO holds a message (data sheet 6.5.4): irq falls only after the release (RRB).
    The RX buffer holds the frame (frame information, identifier, data as in 6.5.3)."""
    n0, n1 = await start(dut)
    await linux_start(n0, 0x03)
    await linux_start(n1, 0x03)
    await cycles(dut, 12 * 16)
    standard = [0x02, 0x24, 0x60, 0xAB, 0xCD]
    await transmit(n0, standard)
    assert await wait_irq(dut, 1, FRAME_CYCLES), "node 1 interrupt"
    assert await n1.read(IR) == 0x01, "RI"
    assert int(dut.n1_irq.value) == 1, "RI stays while the message is stored"
    assert [await n1.read(TX_FRAME + k) for k in range(5)] == standard
    assert await n1.read(RMC) == 1
    await n1.write(CMR, 0x04)
    assert await n1.read(RMC) == 0
    assert int(dut.n1_irq.value) == 0, "irq falls with the release"
    assert await n0.read(IR) == 0x02, "TI at the sender"
    extended = [0x81, 0x35, 0x79, 0xBC, 0xA8, 0x5A]
    await transmit(n1, extended)
    assert await wait_irq(dut, 0, FRAME_CYCLES), "node 0 interrupt"
    assert await n0.read(IR) == 0x01
    assert [await n0.read(TX_FRAME + k) for k in range(6)] == extended
    assert await n0.read(SR) & 0x01 == 0x01, "RBS"


@cocotb.test()
async def back_to_back_and_interleaved_accesses(dut):
    """Acceptance code and mask registers written and read back with no idle cycle between
    accesses, both nodes at once (AXI4-Lite: reads and writes in flight together)."""
    n0, n1 = await start(dut)
    for node in (n0, n1):
        await node.write(CDR, 0x80)
    values = [0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88]

    async def exercise(node, offset):
        for k, v in enumerate(values):
            await node.write(ACR0 + k, v ^ offset)
        return [await node.read(ACR0 + k) for k in range(8)]

    t0 = cocotb.start_soon(exercise(n0, 0x00))
    t1 = cocotb.start_soon(exercise(n1, 0xF0))
    assert await t0 == values
    assert await t1 == [v ^ 0xF0 for v in values]
    if BUS == "axi4-lite":
        # A write and a read of the same node in flight together: each gives its own result.
        w = cocotb.start_soon(n0.write(OCR, 0x5A))
        r = cocotb.start_soon(n0.read(ACR0 + 1))
        await w
        assert await r == 0x22
        assert await n0.read(OCR) == 0x5A


@cocotb.test()
async def partial_writes_touch_only_their_lanes(dut):
    """Byte strobes: a write with some lanes enabled changes only those registers (byte layout);
    with the word layout only lane 0 of a word is a register."""
    n0, _ = await start(dut)
    await n0.write(CDR, 0x80)
    if WORD_STRIDE:
        await n0.write_word(4 * ACR0, 0xDDCCBB55, 0xF)
        assert await n0.read(ACR0) == 0x55
        assert await n0.read(ACR0 + 1) == 0x00, "lanes 1..3 of the word are no registers"
        return
    if BUS == "axi4-lite":
        await n0.write_word(ACR0, 0x44332211, 0xF)
        await n0.write_word(ACR0, 0x0000AA00, 0x2)
        await n0.write_word(ACR0, 0xBBCC0000, 0xC)
        expected = [0x11, 0xAA, 0xCC, 0xBB]
    else:
        await n0.write_word(ACR0, 0x44332211, 0xF)
        await n0.write_word(ACR0, 0xBB00AA00, 0xA)
        expected = [0x11, 0xAA, 0x33, 0xBB]
    assert [await n0.read(ACR0 + k) for k in range(4)] == expected


@cocotb.test()
async def reset_in_the_middle_of_a_transfer(dut):
    """A reset during an access drops it; afterwards the controller is as after a hardware reset
    (BasicCAN CR 21h) and the next accesses work."""
    n0, _ = await start(dut)
    await n0.write(CDR, 0x80)
    pending = cocotb.start_soon(n0.write(ACR0, 0x77))
    await ClockCycles(dut.clock, 3)
    dut.reset.value = 1
    await ClockCycles(dut.clock, 2)
    dut.reset.value = 0
    pending.cancel()
    for name in ("n0_wb_cyc", "n0_wb_stb", "n0_apb_psel", "n0_apb_penable"):
        if hasattr(dut, name):
            getattr(dut, name).value = 0
    await ClockCycles(dut.clock, 2)
    n0.connect()
    await ClockCycles(dut.clock, 2)
    assert await n0.read(MOD) == 0x21
    await n0.write(CDR, 0x80)
    await n0.write(ACR0, 0x3C)
    assert await n0.read(ACR0) == 0x3C
