//! The transmit buffer: the 13 bytes of the frame to send, in the SJA1000 PeliCAN frame-buffer
//! layout (frame information, 2 or 4 identifier bytes, up to 8 data bytes), and copies of the
//! registers the host writes and reads back unchanged (ACR/AMR, BTR0, BTR1, OCR).
//!
//! Ports: one write port (`write`, `write_index`, `write_data`) for the host; two registered read
//! ports, `host_index` → `host_data` for the register windows and `core_index` → `core_data` for
//! the protocol engine and the acceptance filter (each the byte that was at its index before the
//! last rising edge of `clock`; 0 if that cycle wrote the buffer, for the core port only if it
//! wrote a byte of the same part: the frame, or the register copies), and `info` (byte 0, the
//! frame information the engine reads all the time). Writes act on the rising edge of `clock`;
//! indices outside the bytes kept are ignored and read 0. The synchronous `reset` clears every byte
//! (undefined on the SJA1000 for the frame; cleared here so nothing after a reset depends on
//! power-up values). With `basic_layout`
//! (BasicCAN) the frame information comes from byte 2 instead (RTR in bit 4, DLC in bits 3..0,
//! standard frames only), where the BasicCAN map writes it.
//!
//! The bytes live in two RAMs written together, one per read port, so synthesis maps them to RAM
//! (distributed RAM on Xilinx, block RAM on iCE40) instead of two 13-way multiplexers of
//! flip-flops. A RAM cannot be cleared at once: a flag per byte, cleared by `reset` and set by a
//! write, makes a byte not written since the reset read 0, and flip-flop copies give the two bytes
//! `info` is made of without a third read port. A read that may meet the byte being written reads
//! 0, so the RAMs need no read-during-write logic (`no_rw_check` in the emitted Verilog,
//! docs/FPGA.md).
//!
//! Register copies: the RAMs have room past the frame, so they also keep what the host writes to
//! ACR0..3/AMR0..3 (`READBACK_FILTER` + the filter's register index) and to BTR0, BTR1 and OCR
//! (`READBACK_CONFIGURATION` + the configuration's index). The host reads those registers from
//! here: one more byte of the block RAM instead of their read multiplexers of flip-flops. Their
//! reset value is 0, which a byte not written since the reset reads. ACR/AMR are only here: the
//! acceptance filter reads them through the core port in the clocks the protocol engine leaves it
//! (`crate::acceptance_filter`). BTR0 and BTR1 stay in the configuration's flip-flops too (the bit
//! timing runs on them every clock); OCR, which nothing runs on, is only here.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};

/// Bytes of the transmit buffer.
pub const TX_BUFFER_BYTES: usize = 13;

/// Address bits of the frame's bytes (the protocol engine's transmit stream).
const INDEX_BITS: usize = 4;
/// Words the frame's index reaches (the last three are never written).
const WORDS: usize = 1 << INDEX_BITS;
/// Address bits of the RAMs: the frame and the register copies.
pub const HOST_INDEX_BITS: usize = 5;
/// Words of each RAM.
const HOST_WORDS: usize = 1 << HOST_INDEX_BITS;
/// Index of the copy of ACR0; ACR1..3 and AMR0..3 follow in the filter's order.
pub const READBACK_FILTER: usize = 16;
/// Index of the read-back copy of BTR0; BTR1 and OCR follow in the configuration's order.
pub const READBACK_CONFIGURATION: usize = 24;
/// Register copies: ACR0..3, AMR0..3, then BTR0, BTR1, OCR.
const READBACK_BYTES: usize = 11;
/// Indices kept: the frame's bytes and the register copies.
const KEPT_BYTES: u64 =
    ((1u64 << TX_BUFFER_BYTES) - 1) | (((1u64 << READBACK_BYTES) - 1) << READBACK_FILTER);
// The copies follow the frame's bytes (the kernel's literals 4 and 5 are the two index widths); their
// first indices are aligned, so the controller ORs a register's index into them.
const _: () = assert!(
    TX_BUFFER_BYTES <= WORDS
        && READBACK_FILTER == WORDS
        && INDEX_BITS == 4
        && HOST_INDEX_BITS == 5
        && READBACK_FILTER + 8 == READBACK_CONFIGURATION
        && READBACK_FILTER + READBACK_BYTES <= HOST_WORDS
        && READBACK_FILTER.is_multiple_of(8)
        && READBACK_CONFIGURATION.is_multiple_of(4)
);

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
    /// Byte written (a frame byte or a read-back copy).
    pub write_index: Signal<In, Bits<HOST_INDEX_BITS>>,
    /// Value written.
    pub write_data: Signal<In, Bits<8>>,
    /// Byte the host reads (a frame byte or a read-back copy).
    pub host_index: Signal<In, Bits<HOST_INDEX_BITS>>,
    /// The byte that was at `host_index` before the last rising edge of `clock` (0 if that cycle
    /// wrote the buffer).
    pub host_data: Signal<Out, Bits<8>>,
    /// Byte the protocol engine (a frame byte) or the acceptance filter (an ACR/AMR copy) reads.
    pub core_index: Signal<In, Bits<HOST_INDEX_BITS>>,
    /// The byte that was at `core_index` before the last rising edge of `clock` (0 if that cycle
    /// wrote a byte of the same part: the frame, or the register copies).
    pub core_data: Signal<Out, Bits<8>>,
    /// BasicCAN buffer layout.
    pub basic_layout: Signal<In, Bit>,
    /// Frame information: byte 0, or derived from byte 2 in the BasicCAN layout.
    pub info: Signal<Out, Bits<8>>,
    #[init(cleared_ram())]
    host_ram: RAM<Bits<8>, HOST_INDEX_BITS>,
    #[init(cleared_ram())]
    core_ram: RAM<Bits<8>, HOST_INDEX_BITS>,
    /// Bit i: host byte i was written since the reset.
    written: DFF<Bits<HOST_WORDS>>,
    host_written: DFF<Bit>,
    core_written: DFF<Bit>,
    /// Byte 0.
    frame_info: DFF<Bits<8>>,
    /// The frame information of the BasicCAN layout, from byte 2.
    basic_info: DFF<Bits<8>>,
    /// The host indices kept: the frame's bytes 0..12 and the read-back copies.
    #[constant(KEPT_BYTES)]
    kept_bytes: Constant<Bits<HOST_WORDS>>,
    #[constant(index(0))]
    frame_info_index: Constant<Bits<HOST_INDEX_BITS>>,
    #[constant(index(2))]
    basic_info_index: Constant<Bits<HOST_INDEX_BITS>>,
    /// A byte is written this cycle.
    writing: Signal<Local, Bit>,
}

/// A RAM whose every word is initialised (unwritten RAM reads X in Verilog, RUST_HDL.md).
fn cleared_ram<const N: usize>() -> RAM<Bits<8>, N> {
    RAM::from((0..1usize << N).map(|_| Bits::<8>::from(0u64)))
}

fn index(value: usize) -> Bits<HOST_INDEX_BITS> {
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
        self.writing.next = self.write.val()
            & self
                .kept_bytes
                .val()
                .get_bit(self.write_index.val().index());
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
        // while the host may write it (TBS is 0 from the request to the end), but the filter reads
        // ACR/AMR (written in reset mode only) while the host may write the frame, so the core port
        // gives 0 only when the write is in the same part (index bit 4: frame or copies).
        self.host_written.d.next = self.written.q.val().get_bit(self.host_index.val().index())
            & (self.writing.val() == false);
        self.core_written.d.next = self.written.q.val().get_bit(self.core_index.val().index())
            & !(self.writing.val()
                & (self.write_index.val().get_bit(4) == self.core_index.val().get_bit(4)));

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
            // Only the kept bytes are ever written: the mask makes that visible to synthesis, which
            // then keeps no flip-flops for the other words.
            self.written.d.next = self
                .written
                .q
                .val()
                .replace_bit(self.write_index.val().index(), true)
                & self.kept_bytes.val();
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
