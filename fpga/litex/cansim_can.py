"""LiteX peripheral: the cansim CAN controller (SJA1000 register map) on a LiteX SoC's Wishbone bus,
from the generated Verilog (can_controller.v and can_controller_wb.v, `cansim verilog --bus
wishbone`), with its interrupt through a LiteX EventManager.

    can = CanController(platform, pads=platform.request("can"), verilog_dir="fpga/rtl")
    soc.add_module("can0", can)
    soc.bus.add_slave("can0", can.bus, SoCRegion(origin=0x9000_0000, size=can.size, cached=False))
    soc.irq.add("can0", use_loc_if_exists=True)

Linux: a `nxp,sja1000` node with reg-io-width <1> (word_stride 0) or <4> (word_stride 1), the
sys_clk frequency as nxp,external-clock-frequency (docs/FPGA.md)."""

import os

from migen import ClockSignal, Instance, Module, ResetSignal, Signal

from litex.soc.interconnect import wishbone
from litex.soc.interconnect.csr import AutoCSR
from litex.soc.interconnect.csr_eventmanager import EventManager, EventSourceLevel


class CanController(Module, AutoCSR):
    """One controller. `pads` has `rx` and `tx` (to a CAN transceiver); without pads the
    controller listens to its own `tx` (a bus of one). `word_stride` chooses the register layout."""

    def __init__(self, platform, pads=None, word_stride=0, verilog_dir="fpga/rtl"):
        self.bus = wishbone.Interface(data_width=32, address_width=32, addressing="word")
        self.size = 0x400 if word_stride else 0x100
        self.rx = Signal()
        self.tx = Signal()
        irq = Signal()

        self.ev = EventManager()
        self.ev.can = EventSourceLevel(description="IR & IER of the controller is not 0")
        self.ev.finalize()
        self.comb += self.ev.can.trigger.eq(irq)

        if pads is not None:
            self.comb += [self.rx.eq(pads.rx), pads.tx.eq(self.tx)]
        else:
            self.comb += self.rx.eq(self.tx)

        self.comb += self.bus.err.eq(0)
        self.specials += Instance(
            "can_controller_wb",
            p_word_stride=word_stride,
            i_clock=ClockSignal("sys"),
            i_reset=ResetSignal("sys"),
            i_wb_cyc=self.bus.cyc,
            i_wb_stb=self.bus.stb,
            i_wb_we=self.bus.we,
            i_wb_adr=self.bus.adr[:8],
            i_wb_sel=self.bus.sel,
            i_wb_dat_w=self.bus.dat_w,
            o_wb_dat_r=self.bus.dat_r,
            o_wb_ack=self.bus.ack,
            o_wb_stall=Signal(),
            i_rx=self.rx,
            o_tx=self.tx,
            o_irq=irq,
            o_clkout=Signal(),
        )
        for name in ("can_controller.v", "can_controller_wb.v"):
            platform.add_source(os.path.join(verilog_dir, name))
