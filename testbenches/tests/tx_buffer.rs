//! The TX buffer block alone (`rtl::tx_buffer`): what its two read ports give around a write.
//!
//! The block's contract (its doc comment): each read port gives the byte that was at its index
//! before the clock edge; the host port gives 0 when that cycle wrote the buffer, the core port when
//! that cycle wrote a byte of the same part (the frame, or the register copies), so that the emitted
//! RAMs need no read-during-write logic (`no_rw_check`, docs/VERILOG.md). The host side never sees
//! the 0: the SJA1000 port contract has `we` and `re` never high in the same cycle (docs/FPGA.md);
//! the engine only reads while TBS is 0, when host writes to the buffer are dropped (registers.rs,
//! "writes while TBS = 0 are lost"), and the acceptance filter reads ACR/AMR, written only in reset
//! mode, while the host may be writing the frame.
//!
//! Both RAMs also hold the copies of ACR0..3/AMR0..3 (`READBACK_FILTER` + 0..7) and BTR0, BTR1, OCR
//! (`READBACK_CONFIGURATION` + 0..2): the host reads those registers from there and the filter reads
//! ACR/AMR through the core port, so a copy must read what was last written, read 0 (the registers'
//! reset value) after a reset, and stay apart from the frame byte with the same low bits.

use rtl::tx_buffer::{TxBuffer, READBACK_CONFIGURATION, READBACK_FILTER};
use rust_hdl::prelude::*;
use sim::engine::rtl_step::clock_cycle;

fn buffer() -> TxBuffer {
    let mut uut = TxBuffer::default();
    uut.connect_all();
    uut.reset.next = true;
    clock_cycle(&mut uut, |b| &mut b.clock, "tx buffer");
    uut.reset.next = false;
    uut
}

/// One clock edge; with `write` = Some((index, byte)) the cycle writes that byte.
fn cycle(uut: &mut TxBuffer, write: Option<(u64, u64)>) {
    uut.write.next = write.is_some();
    if let Some((index, byte)) = write {
        uut.write_index.next = index.into();
        uut.write_data.next = byte.into();
    }
    clock_cycle(uut, |b| &mut b.clock, "tx buffer");
}

fn read_ports(uut: &TxBuffer) -> (u64, u64) {
    (
        uut.host_data.val().index() as u64,
        uut.core_data.val().index() as u64,
    )
}

#[test]
fn a_read_in_the_cycle_that_writes_its_byte_gives_0_then_the_byte() {
    let mut uut = buffer();
    uut.host_index.next = 3.into();
    uut.core_index.next = 3.into();
    cycle(&mut uut, Some((3, 0x5A)));
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut), (0x5A, 0x5A), "byte 3 written");
    cycle(&mut uut, Some((3, 0xA5)));
    assert_eq!(
        read_ports(&uut),
        (0, 0),
        "read in the cycle that writes byte 3 again"
    );
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut), (0xA5, 0xA5), "read the cycle after");
}

#[test]
fn a_read_in_a_cycle_that_writes_another_byte_gives_0_too() {
    let mut uut = buffer();
    uut.host_index.next = 4.into();
    uut.core_index.next = 4.into();
    cycle(&mut uut, Some((4, 0x11)));
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut), (0x11, 0x11), "byte 4 written");
    cycle(&mut uut, Some((7, 0x22)));
    assert_eq!(read_ports(&uut), (0, 0), "a write cycle of byte 7");
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut), (0x11, 0x11), "byte 4 again");
}

#[test]
fn a_write_outside_the_13_bytes_is_no_write_cycle() {
    let mut uut = buffer();
    uut.host_index.next = 2.into();
    uut.core_index.next = 2.into();
    cycle(&mut uut, Some((2, 0x33)));
    cycle(&mut uut, Some((13, 0x44)));
    assert_eq!(read_ports(&uut), (0x33, 0x33), "index 13 is ignored");
}

#[test]
fn a_read_back_copy_reads_what_was_written_and_0_after_a_reset() {
    let ocr = READBACK_CONFIGURATION as u64 + 2;
    let amr3 = READBACK_FILTER as u64 + 7;
    let mut uut = buffer();
    for (index, byte) in [(ocr, 0xDA), (amr3, 0x3C)] {
        uut.host_index.next = index.into();
        cycle(&mut uut, None);
        assert_eq!(read_ports(&uut).0, 0, "copy {index} before any write");
        cycle(&mut uut, Some((index, byte)));
        cycle(&mut uut, None);
        assert_eq!(read_ports(&uut).0, byte, "copy {index} written");
    }
    uut.reset.next = true;
    cycle(&mut uut, None);
    uut.reset.next = false;
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut).0, 0, "copy of AMR3 after a reset");
}

#[test]
fn a_register_copy_and_the_frame_byte_with_its_low_bits_stay_apart() {
    let mut uut = buffer();
    uut.core_index.next = 0.into();
    cycle(&mut uut, Some((0, 0x88)));
    cycle(&mut uut, None);
    // Index 16 and 0 share their low four bits.
    uut.host_index.next = (READBACK_FILTER as u64).into();
    cycle(&mut uut, Some((READBACK_FILTER as u64, 0x77)));
    assert_eq!(
        read_ports(&uut).1,
        0x88,
        "the engine reads frame byte 0 in the copy's write cycle"
    );
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut), (0x77, 0x88), "copy 16 and frame byte 0");
    assert_eq!(uut.info.val().index(), 0x88, "the frame information");
    uut.core_index.next = (READBACK_FILTER as u64).into();
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut).1, 0x77, "the core port reads copy 16");
}

#[test]
fn the_core_port_reads_a_copy_while_the_frame_is_written() {
    let acr2 = READBACK_FILTER as u64 + 2;
    let mut uut = buffer();
    cycle(&mut uut, Some((acr2, 0xC3)));
    uut.core_index.next = acr2.into();
    cycle(&mut uut, Some((5, 0x12)));
    assert_eq!(
        read_ports(&uut).1,
        0xC3,
        "ACR2 in a frame byte's write cycle"
    );
    cycle(&mut uut, Some((READBACK_FILTER as u64 + 5, 0x34)));
    assert_eq!(read_ports(&uut).1, 0, "ACR2 in a copy's write cycle");
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut).1, 0xC3, "ACR2 the cycle after");
    uut.reset.next = true;
    cycle(&mut uut, None);
    uut.reset.next = false;
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut).1, 0, "ACR2 after a reset");
}

#[test]
fn indices_past_the_read_back_copies_are_ignored() {
    let mut uut = buffer();
    let past = READBACK_CONFIGURATION as u64 + 3;
    uut.host_index.next = past.into();
    cycle(&mut uut, Some((past, 0x99)));
    cycle(&mut uut, None);
    assert_eq!(read_ports(&uut).0, 0, "index {past} is no register");
}
