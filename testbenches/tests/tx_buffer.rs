//! The TX buffer block alone (`rtl::tx_buffer`): what its two read ports give around a write.
//!
//! The block's contract (its doc comment): each read port gives the byte that was at its index
//! before the clock edge, and 0 when that cycle wrote the buffer, so that the emitted RAMs need no
//! read-during-write logic (`no_rw_check`, docs/VERILOG.md). The host side never sees the 0: the
//! SJA1000 port contract has `we` and `re` never high in the same cycle (docs/FPGA.md), and the
//! engine only reads while TBS is 0, when host writes to the buffer are dropped (registers.rs,
//! "writes while TBS = 0 are lost").

use rtl::tx_buffer::TxBuffer;
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
