"""A minimal LiteX SoC with the cansim CAN controller: no CPU, a UART bridge (UARTBone) as the bus
master (a host drives the registers with litex_server / RemoteClient), the controller on the
Wishbone bus with its interrupt. Elaborates the SoC's Verilog (no toolchain, no software build):
minimal_soc.py OUTPUT_DIR VERILOG_DIR."""

import os
import sys

from migen import ClockDomain, Module

from litex.build.generic_platform import Pins, Subsignal
from litex.build.sim import SimPlatform
from litex.soc.integration.builder import Builder
from litex.soc.integration.soc import SoCRegion
from litex.soc.integration.soc_core import SoCMini

from cansim_can import CanController

IOS = [
    ("sys_clk", 0, Pins(1)),
    ("sys_rst", 0, Pins(1)),
    ("serial", 0, Subsignal("tx", Pins(1)), Subsignal("rx", Pins(1))),
    ("can", 0, Subsignal("rx", Pins(1)), Subsignal("tx", Pins(1))),
    ("can_irq", 0, Pins(1)),
]


class CanSoC(SoCMini):
    def __init__(self, platform, verilog_dir):
        sys_clk_freq = int(16e6)
        SoCMini.__init__(self, platform, clk_freq=sys_clk_freq, ident="cansim CAN on LiteX")
        self.crg = Module()
        self.crg.clock_domains.cd_sys = ClockDomain()
        self.crg.comb += [
            self.crg.cd_sys.clk.eq(platform.request("sys_clk")),
            self.crg.cd_sys.rst.eq(platform.request("sys_rst")),
        ]
        self.add_uartbone(name="serial", baudrate=115200)
        self.can0 = CanController(platform, pads=platform.request("can"), verilog_dir=verilog_dir)
        self.bus.add_slave("can0", self.can0.bus,
                           SoCRegion(origin=0x9000_0000, size=self.can0.size, cached=False))
        # No CPU here, so no interrupt controller: the interrupt is an output of the SoC, and its
        # EventManager's CSRs (status, pending, enable) show it through the bridge. With a CPU:
        # self.irq.add("can0", use_loc_if_exists=True).
        self.comb += platform.request("can_irq").eq(self.can0.ev.irq)


def main():
    output, verilog_dir = sys.argv[1], sys.argv[2]
    platform = SimPlatform("SIM", IOS)
    soc = CanSoC(platform, verilog_dir)
    builder = Builder(soc, output_dir=output, compile_gateware=False, compile_software=False)
    builder.build(run=False, build=False)
    # The SoC's own Verilog (the controller's files are the platform's sources).
    verilog = platform.get_verilog(soc, name="cansoc")
    verilog.write(os.path.join(output, "cansoc.v"))
    print(os.path.join(output, "cansoc.v"))


if __name__ == "__main__":
    main()
