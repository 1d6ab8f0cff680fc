"""SJA1000 register access through a SoC bus, with the third-party bus models of cocotb's
ecosystem: cocotbext-wishbone's WishboneMaster, cocotbext-axi's AxiLiteMaster, cocotbext-apb's
ApbHost. `Sja1000` maps register numbers to bus addresses for the wrapper's `word_stride`
(0: register n at byte address n; 1: byte lane 0 of the word at 4n), as Linux's sja1000_platform
driver does with reg-io-width 1 or 4. Copy it into your own testbench."""

from cocotb.triggers import RisingEdge


class Sja1000:
    """Byte register reads and writes of one wrapped controller (prefix `n<k>` in the tb_*.v)."""

    def __init__(self, dut, bus, node, word_stride):
        self.dut = dut
        self.bus = bus
        self.node = node
        self.word_stride = word_stride
        self.driver = None
        self.connect()

    def connect(self):
        """(Re)creates the bus model (after a reset in the middle of a transfer)."""
        dut, k = self.dut, self.node
        if self.bus == "wishbone":
            from cocotbext.wishbone.driver import WishboneMaster

            signals = {
                "cyc": "cyc", "stb": "stb", "we": "we", "adr": "adr", "datwr": "dat_w",
                "datrd": "dat_r", "ack": "ack", "sel": "sel", "stall": "stall",
            }
            self.driver = WishboneMaster(
                dut, f"n{k}_wb", dut.clock, width=32, timeout=1000, signals_dict=signals
            )
        elif self.bus == "axi4-lite":
            from cocotbext.axi import AxiLiteBus, AxiLiteMaster

            bus = AxiLiteBus.from_prefix(dut, f"n{k}_s_axil")
            self.driver = AxiLiteMaster(bus, dut.clock, dut.reset)
        elif self.bus == "apb":
            from cocotbext.apb import ApbBus, ApbHost

            self.driver = ApbHost(ApbBus.from_prefix(dut, f"n{k}_apb"), dut.clock)
        else:
            raise ValueError(f"unknown bus {self.bus}")

    def place(self, reg):
        """Byte address and lane of register `reg`."""
        if self.word_stride:
            return 4 * reg, 0
        return reg, reg % 4

    async def write(self, reg, value):
        addr, lane = self.place(reg)
        await self.write_word(addr - lane, value << (8 * lane), 1 << lane)

    async def read(self, reg):
        addr, lane = self.place(reg)
        word = await self.read_word(addr - lane, 1 << lane)
        return (word >> (8 * lane)) & 0xFF

    async def write_word(self, addr, data, strobe):
        """A 32-bit write at word address `addr` with byte strobes."""
        if self.bus == "wishbone":
            from cocotbext.wishbone.driver import WBOp

            await self.driver.send_cycle([WBOp(addr >> 2, data, sel=strobe)])
        elif self.bus == "axi4-lite":
            lanes = [k for k in range(4) if strobe >> k & 1]
            first, last = lanes[0], lanes[-1]
            payload = data.to_bytes(4, "little")[first:last + 1]
            if len(lanes) != last - first + 1:
                raise ValueError("AxiLiteMaster writes contiguous lanes")
            await self.driver.write(addr + first, payload)
        else:
            await self.driver.write(addr, data, strb=strobe)

    async def read_word(self, addr, strobe):
        """A 32-bit read at word address `addr` (Wishbone: of the lanes `strobe` selects; AXI4-Lite
        and APB: of the lane the address names)."""
        lane = (strobe & -strobe).bit_length() - 1
        if self.bus == "wishbone":
            from cocotbext.wishbone.driver import WBOp

            res = await self.driver.send_cycle([WBOp(addr >> 2, None, sel=strobe)])
            return int(res[0].datrd)
        if self.bus == "axi4-lite":
            data = await self.driver.read(addr + lane, 1)
            return data.data[0] << (8 * lane)
        data = await self.driver.read(addr + lane)
        if isinstance(data, int):
            return data
        return int.from_bytes(data, "little")


async def cycles(dut, n):
    for _ in range(n):
        await RisingEdge(dut.clock)
