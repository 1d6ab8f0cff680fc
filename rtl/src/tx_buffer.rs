//! The transmit buffer: the 13 bytes of the frame to send, in the SJA1000 PeliCAN frame-buffer
//! layout (frame information, 2 or 4 identifier bytes, up to 8 data bytes).
//!
//! Ports: one write port (`write`, `write_index`, `write_data`) for the host; a registered read port
//! for the register window (`host_index` → `host_data` the cycle after, like a read from the RX
//! FIFO's RAM), a combinational one for the protocol engine (`core_index` → `core_data`), and `info`
//! (byte 0, the frame information the engine reads all the time).
//! Writes act on the rising edge of `clock`; indices 13..15 are ignored and read 0. The synchronous
//! `reset` clears every byte (undefined on the SJA1000; cleared here so nothing after a reset
//! depends on power-up values). With
//! `basic_layout` (BasicCAN) the frame information comes from byte 2 instead (RTR in bit 4, DLC in
//! bits 3..0, standard frames only), where the BasicCAN map writes it.
//!
//! Flip-flops rather than a RAM block: the engine and the host read at the same time, and 13 bytes
//! are too few to be worth a second memory.

use rust_hdl::prelude::*;

/// Bytes of the transmit buffer.
pub const TX_BUFFER_BYTES: usize = 13;

/// The transmit buffer.
#[derive(LogicBlock, Default)]
pub struct TxBuffer {
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high: clears the buffer.
    pub reset: Signal<In, Bit>,
    /// Write `write_data` at `write_index`.
    pub write: Signal<In, Bit>,
    /// Byte written.
    pub write_index: Signal<In, Bits<4>>,
    /// Value written.
    pub write_data: Signal<In, Bits<8>>,
    /// Byte the host reads.
    pub host_index: Signal<In, Bits<4>>,
    /// The byte that was at `host_index` before the last rising edge of `clock`.
    pub host_data: Signal<Out, Bits<8>>,
    /// Byte the protocol engine reads.
    pub core_index: Signal<In, Bits<4>>,
    /// The byte at `core_index`.
    pub core_data: Signal<Out, Bits<8>>,
    /// BasicCAN buffer layout.
    pub basic_layout: Signal<In, Bit>,
    /// Frame information: byte 0, or derived from byte 2 in the BasicCAN layout.
    pub info: Signal<Out, Bits<8>>,
    bytes: [DFF<Bits<8>>; TX_BUFFER_BYTES],
    host_read: DFF<Bits<8>>,
}

impl Logic for TxBuffer {
    #[hdl_gen]
    fn update(&mut self) {
        for i in 0..TX_BUFFER_BYTES {
            self.bytes[i].clock.next = self.clock.val();
            self.bytes[i].d.next = self.bytes[i].q.val();
        }
        dff_setup!(self, clock, host_read);
        self.host_data.next = self.host_read.q.val();
        self.host_read.d.next = 0.into();
        self.core_data.next = 0.into();
        self.info.next = self.bytes[0].q.val();
        if self.basic_layout.val() {
            self.info.next = bit_cast::<8, 4>(bit_cast::<4, 8>(self.bytes[2].q.val()))
                .replace_bit(6, self.bytes[2].q.val().get_bit(4));
        }
        for i in 0..TX_BUFFER_BYTES {
            if self.write.val() & (self.write_index.val().index() == i) {
                self.bytes[i].d.next = self.write_data.val();
            }
            if self.host_index.val().index() == i {
                self.host_read.d.next = self.bytes[i].q.val();
            }
            if self.core_index.val().index() == i {
                self.core_data.next = self.bytes[i].q.val();
            }
            if self.reset.val() {
                self.bytes[i].d.next = 0.into();
            }
        }
    }
}
