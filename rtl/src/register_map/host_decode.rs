//! Host address decoding: which register window an access hits in the current map (PeliCAN or
//! BasicCAN, SJA1000 data sheet register tables), the byte index inside it, and the command strobes
//! of a CMR write.
//!
//! Ports in: the host bus `host` (`addr`, `we`, `wdata`), and the map state `pelican` (CDR.7) and
//! `reset_mode` (MOD.RM), all straight from the controller's inputs and flip-flops. Out, purely
//! combinational: the window flags and indices, `command` (a CMR write outside reset mode) and its
//! bits. No clock (no flip-flops): the controller's blocks act on these in the same cycle. Because every input comes
//! straight from a port or a flip-flop, the controller may read these outputs and drive other
//! blocks from them without a Verilator loop (docs/VERILOG.md).

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::register_map::HostWrite;
use crate::registers::{basic, pelican};

/// Host addresses: the `addr` port is 8 bits wide.
const ADDRESSES: usize = 256;

/// The addresses from `first` to `last`, both included, as a bit map indexed by the address.
fn window(first: u8, last: u8) -> Bits<ADDRESSES> {
    let addresses = usize::from(first)..usize::from(last) + 1;
    addresses.fold(Bits::<ADDRESSES>::default(), |map, a| {
        map.replace_bit(a, true)
    })
}

/// The low `N` bits of an address.
fn low_bits<const N: usize>(value: u8) -> Bits<N> {
    ((value as u64) & ((1 << N) - 1)).into()
}

/// Address and command decoding of the host port.
#[derive(ActivityBlock, BlockDefault)]
pub struct HostDecode {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// The host bus: address, write strobe, write data.
    #[interface]
    pub host: HostWrite,
    /// PeliCAN map (CDR.7); 0 = BasicCAN.
    pub pelican: Signal<In, Bit>,
    /// Reset mode (MOD.RM / CR.RR).
    pub reset_mode: Signal<In, Bit>,
    /// PeliCAN frame window (16..28: TX buffer / RX buffer in operating mode, ACR/AMR in reset mode).
    pub in_frame_window: Signal<Out, Bit>,
    /// PeliCAN RX FIFO RAM window (32..95).
    pub in_rx_ram: Signal<Out, Bit>,
    /// PeliCAN TX buffer RAM window (96..108).
    pub in_tx_ram: Signal<Out, Bit>,
    /// BasicCAN TX buffer (10..19).
    pub in_basic_tx: Signal<Out, Bit>,
    /// BasicCAN RX buffer (20..29).
    pub in_basic_rx: Signal<Out, Bit>,
    /// BasicCAN ACR, AMR, BTR0, BTR1, OCR (4..8): read 0xFF in operating mode.
    pub in_basic_config: Signal<Out, Bit>,
    /// Index in the frame window (byte 0 = frame information).
    pub frame_index: Signal<Out, Bits<4>>,
    /// Index in the TX RAM window.
    pub tx_ram_index: Signal<Out, Bits<4>>,
    /// Index in the BasicCAN TX buffer, as a frame-buffer byte (its first byte is byte 1).
    pub basic_tx_index: Signal<Out, Bits<4>>,
    /// Index in the BasicCAN RX buffer, as a FIFO message byte (its first byte is byte 1).
    pub basic_rx_index: Signal<Out, Bits<4>>,
    /// Index in the RX RAM window (FIFO byte).
    pub rx_ram_index: Signal<Out, Bits<6>>,
    /// A CMR write (the same address in both maps), ignored in reset mode.
    pub command: Signal<Out, Bit>,
    /// CMR.TR.
    pub cmd_transmit: Signal<Out, Bit>,
    /// CMR.AT.
    pub cmd_abort: Signal<Out, Bit>,
    /// CMR.RRB.
    pub cmd_release: Signal<Out, Bit>,
    /// CMR.CDO.
    pub cmd_clear_overrun: Signal<Out, Bit>,
    /// CMR.SRR (PeliCAN), unless TR is set too: TR with SRR is a plain TR (data sheet).
    pub cmd_self_reception: Signal<Out, Bit>,
    /// CMR.GTS (BasicCAN, bit 4 of the written value; meaningful with `command`).
    pub cmd_sleep: Signal<Out, Bit>,
    // Byte indices inside the windows, computed at the width they need: the low bits of a
    // difference depend only on the low bits of its operands.
    addr_low4: Signal<Local, Bits<4>>,
    addr_low6: Signal<Local, Bits<6>>,
    #[constant(u64::from(pelican::CMR))]
    cmr: Constant<Bits<8>>,
    // Address windows, as bit maps indexed by the address (`>=`/`<=` pairs would become carry
    // chains on FPGAs), and the low address bits of their first bytes.
    #[constant(window(pelican::FRAME, pelican::FRAME_LAST))]
    frame_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(pelican::RX_RAM, pelican::RX_RAM_LAST))]
    rx_ram_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(pelican::TX_RAM, pelican::TX_RAM_LAST))]
    tx_ram_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(basic::TX, basic::TX_LAST))]
    basic_tx_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(basic::RX, basic::RX_LAST))]
    basic_rx_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(basic::ACR, basic::OCR))]
    basic_config_window: Constant<Bits<ADDRESSES>>,
    #[constant(low_bits(pelican::FRAME))]
    frame_base: Constant<Bits<4>>,
    #[constant(low_bits(pelican::TX_RAM))]
    tx_ram_base: Constant<Bits<4>>,
    // The byte before each BasicCAN buffer: buffer byte 1 is the first identifier byte.
    #[constant(low_bits(basic::TX - 1))]
    basic_tx_base: Constant<Bits<4>>,
    #[constant(low_bits(basic::RX - 1))]
    basic_rx_base: Constant<Bits<4>>,
    #[constant(low_bits(pelican::RX_RAM))]
    rx_ram_base: Constant<Bits<6>>,
}

impl Logic for HostDecode {
    #[hdl_gen]
    fn update(&mut self) {
        self.addr_low4.next = bit_cast::<4, 8>(self.host.addr.val());
        self.addr_low6.next = bit_cast::<6, 8>(self.host.addr.val());
        self.frame_index.next = self.addr_low4.val() - self.frame_base.val();
        self.tx_ram_index.next = self.addr_low4.val() - self.tx_ram_base.val();
        self.basic_tx_index.next = self.addr_low4.val() - self.basic_tx_base.val();
        self.basic_rx_index.next = self.addr_low4.val() - self.basic_rx_base.val();
        self.rx_ram_index.next = self.addr_low6.val() - self.rx_ram_base.val();
        self.in_frame_window.next = self
            .frame_window
            .val()
            .get_bit(self.host.addr.val().index());
        self.in_rx_ram.next = self
            .rx_ram_window
            .val()
            .get_bit(self.host.addr.val().index());
        self.in_tx_ram.next = self
            .tx_ram_window
            .val()
            .get_bit(self.host.addr.val().index());
        self.in_basic_tx.next = self
            .basic_tx_window
            .val()
            .get_bit(self.host.addr.val().index());
        self.in_basic_rx.next = self
            .basic_rx_window
            .val()
            .get_bit(self.host.addr.val().index());
        self.in_basic_config.next = self
            .basic_config_window
            .val()
            .get_bit(self.host.addr.val().index());
        if self.pelican.val() == false {
            self.in_frame_window.next = false;
            self.in_rx_ram.next = false;
            self.in_tx_ram.next = false;
        } else {
            self.in_basic_tx.next = false;
            self.in_basic_rx.next = false;
        }

        self.command.next = self.host.we.val()
            & (self.host.addr.val() == self.cmr.val())
            & (self.reset_mode.val() == false);
        self.cmd_transmit.next = self.command.val() & self.host.wdata.val().get_bit(0);
        self.cmd_abort.next = self.command.val() & self.host.wdata.val().get_bit(1);
        self.cmd_release.next = self.command.val() & self.host.wdata.val().get_bit(2);
        self.cmd_clear_overrun.next = self.command.val() & self.host.wdata.val().get_bit(3);
        self.cmd_self_reception.next = self.command.val()
            & self.host.wdata.val().get_bit(4)
            & self.pelican.val()
            & (self.cmd_transmit.val() == false);
        self.cmd_sleep.next = self.host.wdata.val().get_bit(4) & (self.pelican.val() == false);
    }
}
