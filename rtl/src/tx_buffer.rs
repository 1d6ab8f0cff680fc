//! The transmit buffer: the 13 bytes of the frame to send, in the SJA1000 PeliCAN frame-buffer
//! layout (frame information, 2 or 4 identifier bytes, up to 8 data bytes).
//!
//! Ports: one write port (`write`, `write_index`, `write_data`) for the host; two registered read
//! ports, `host_index` → `host_data` for the register window and `core_index` → `core_data` for the
//! protocol engine (each the byte that was at its index before the last rising edge of `clock`, 0
//! if that cycle wrote the buffer),
//! and `info` (byte 0, the frame information the engine reads all the time).
//! Writes act on the rising edge of `clock`; indices 13..15 are ignored and read 0. The synchronous
//! `reset` clears every byte (undefined on the SJA1000; cleared here so nothing after a reset
//! depends on power-up values). With `basic_layout` (BasicCAN) the frame information comes from
//! byte 2 instead (RTR in bit 4, DLC in bits 3..0, standard frames only), where the BasicCAN map
//! writes it.
//!
//! The bytes live in two 16-word RAMs written together, one per read port, so synthesis maps them
//! to RAM (distributed RAM on Xilinx, block RAM on iCE40) instead of two 13-way multiplexers of
//! flip-flops. A RAM cannot be cleared at once: a flag per byte, cleared by `reset` and set by a
//! write, makes a byte not written since the reset read 0, and flip-flop copies give the two
//! bytes `info` is made of without a third read port. A read in a write cycle reads 0, so the RAMs
//! need no read-during-write logic (`no_rw_check` in the emitted Verilog, docs/FPGA.md).

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};

/// Bytes of the transmit buffer.
pub const TX_BUFFER_BYTES: usize = 13;

/// Address bits of the RAMs.
const INDEX_BITS: usize = 4;
/// Words of the RAMs (the last three are never written).
const WORDS: usize = 1 << INDEX_BITS;

/// The transmit buffer.
#[derive(ActivityBlock, BlockDefault)]
pub struct TxBuffer {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high: clears the buffer.
    pub reset: Signal<In, Bit>,
    /// Write `write_data` at `write_index`.
    pub write: Signal<In, Bit>,
    /// Byte written.
    pub write_index: Signal<In, Bits<INDEX_BITS>>,
    /// Value written.
    pub write_data: Signal<In, Bits<8>>,
    /// Byte the host reads.
    pub host_index: Signal<In, Bits<INDEX_BITS>>,
    /// The byte that was at `host_index` before the last rising edge of `clock` (0 if that cycle
    /// wrote the buffer).
    pub host_data: Signal<Out, Bits<8>>,
    /// Byte the protocol engine reads.
    pub core_index: Signal<In, Bits<INDEX_BITS>>,
    /// The byte that was at `core_index` before the last rising edge of `clock` (0 if that cycle
    /// wrote the buffer).
    pub core_data: Signal<Out, Bits<8>>,
    /// BasicCAN buffer layout.
    pub basic_layout: Signal<In, Bit>,
    /// Frame information: byte 0, or derived from byte 2 in the BasicCAN layout.
    pub info: Signal<Out, Bits<8>>,
    #[init(cleared_ram())]
    host_ram: RAM<Bits<8>, INDEX_BITS>,
    #[init(cleared_ram())]
    core_ram: RAM<Bits<8>, INDEX_BITS>,
    /// Bit i: byte i was written since the reset.
    written: DFF<Bits<WORDS>>,
    host_written: DFF<Bit>,
    core_written: DFF<Bit>,
    /// Byte 0.
    frame_info: DFF<Bits<8>>,
    /// The frame information of the BasicCAN layout, from byte 2.
    basic_info: DFF<Bits<8>>,
    #[constant(index(TX_BUFFER_BYTES))]
    byte_count: Constant<Bits<INDEX_BITS>>,
    /// Bits 0..12 set: the buffer's bytes among the RAM words.
    #[constant((1u64 << TX_BUFFER_BYTES) - 1)]
    byte_mask: Constant<Bits<WORDS>>,
    #[constant(index(0))]
    frame_info_index: Constant<Bits<INDEX_BITS>>,
    #[constant(index(2))]
    basic_info_index: Constant<Bits<INDEX_BITS>>,
    in_range: Signal<Local, Bit>,
    /// A byte is written this cycle.
    writing: Signal<Local, Bit>,
}

/// A RAM whose every word is initialised (unwritten RAM reads X in Verilog, RUST_HDL.md).
fn cleared_ram() -> RAM<Bits<8>, INDEX_BITS> {
    RAM::from((0..WORDS).map(|_| Bits::<8>::from(0u64)))
}

fn index(value: usize) -> Bits<INDEX_BITS> {
    (value as u64).into()
}

impl Logic for TxBuffer {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            written,
            host_written,
            core_written,
            frame_info,
            basic_info
        );
        self.host_ram.write_clock.next = self.clock.val();
        self.host_ram.read_clock.next = self.clock.val();
        self.core_ram.write_clock.next = self.clock.val();
        self.core_ram.read_clock.next = self.clock.val();
        self.in_range.next = self.write_index.val() < self.byte_count.val();
        self.writing.next = self.write.val() & self.in_range.val();
        self.host_ram.write_enable.next = self.writing.val();
        self.host_ram.write_address.next = self.write_index.val();
        self.host_ram.write_data.next = self.write_data.val();
        self.core_ram.write_enable.next = self.writing.val();
        self.core_ram.write_address.next = self.write_index.val();
        self.core_ram.write_data.next = self.write_data.val();
        self.host_ram.read_address.next = self.host_index.val();
        self.core_ram.read_address.next = self.core_index.val();
        // A read in a write cycle gives 0, not the RAM's read data: the emitted RAMs carry
        // `no_rw_check` (synthesis adds no read-during-write logic, so block RAM may return the old
        // or the new byte then), and this keeps the outputs defined and equal to the model's. The
        // host never reads in a write cycle (port contract); the engine never reads the buffer
        // while the host may write it (TBS is 0 from the request to the end).
        self.host_written.d.next = self.written.q.val().get_bit(self.host_index.val().index())
            & (self.writing.val() == false);
        self.core_written.d.next = self.written.q.val().get_bit(self.core_index.val().index())
            & (self.writing.val() == false);

        // Outputs from flip-flops and RAM read registers only (Verilator loops, RUST_HDL.md).
        self.host_data.next = 0.into();
        if self.host_written.q.val() {
            self.host_data.next = self.host_ram.read_data.val();
        }
        self.core_data.next = 0.into();
        if self.core_written.q.val() {
            self.core_data.next = self.core_ram.read_data.val();
        }
        self.info.next = self.frame_info.q.val();
        if self.basic_layout.val() {
            self.info.next = self.basic_info.q.val();
        }

        if self.writing.val() {
            // Only bytes 0..12 are ever written: the mask makes that visible to synthesis, which
            // then keeps no flip-flops for 13..15.
            self.written.d.next = self
                .written
                .q
                .val()
                .replace_bit(self.write_index.val().index(), true)
                & self.byte_mask.val();
            if self.write_index.val() == self.frame_info_index.val() {
                self.frame_info.d.next = self.write_data.val();
            }
            if self.write_index.val() == self.basic_info_index.val() {
                self.basic_info.d.next = bit_cast::<8, 4>(bit_cast::<4, 8>(self.write_data.val()))
                    .replace_bit(6, self.write_data.val().get_bit(4));
            }
        }
        if self.reset.val() {
            self.written.d.next = 0.into();
            self.host_written.d.next = false;
            self.core_written.d.next = false;
            self.frame_info.d.next = 0.into();
            self.basic_info.d.next = 0.into();
        }
    }
}
