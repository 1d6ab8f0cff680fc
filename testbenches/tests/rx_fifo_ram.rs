//! The RX FIFO block alone (`rtl::rx_fifo`): where the bytes of a received message go, when the
//! FIFO has room for them, and what the host's RAM read gives in the clock the receiver writes.
//!
//! Rules (SJA1000 data sheet 6.4.14 "receive buffer", 6.4.16 "RX message counter", 6.4.5 SR.1
//! DOS): the 64-byte RXFIFO keeps each message as its frame information, 2 or 4 identifier bytes and
//! its data bytes (none for RTR), one after the other; a message that does not fit is lost (DOS) and
//! RMC does not count it. The FIFO is exactly full at 64 bytes, which the pointers alone cannot tell
//! from empty.
//!
//! The RAM reads before it writes: a host read of the byte that the receiver writes in that same
//! clock gives the byte it held, the read a clock later the byte written (the emitted Verilog keeps
//! this on block RAM, whose collision behaviour is undefined, with Yosys's read-during-write logic:
//! docs/VERILOG.md).

use rtl::rx_fifo::RxFifo;
use rust_hdl::prelude::*;
use sim::engine::rtl_step::clock_cycle;

/// Bytes of an extended frame's header in the FIFO (frame information, 4 identifier bytes).
const EXTENDED_HEADER: usize = 5;
/// Bytes of a standard frame's header in the FIFO (frame information, 2 identifier bytes).
const STANDARD_HEADER: usize = 3;

fn fifo() -> RxFifo {
    let mut uut = RxFifo::default();
    uut.connect_all();
    uut.reset.next = true;
    cycle(&mut uut);
    uut.reset.next = false;
    uut
}

fn cycle(uut: &mut RxFifo) {
    clock_cycle(uut, |b| &mut b.clock, "rx fifo");
}

/// The header strobe of a message as the protocol engine sends it (identifier 0x12345678, so
/// ID.28..21 = 0x91; the fields are held from then on). The block writes the header bytes in the
/// clocks after it.
fn header(uut: &mut RxFifo, ide: bool, rtr: bool, dlc: usize) {
    uut.rx_frame.id.next = 0x1234_5678.into();
    uut.rx_frame.ide.next = ide;
    uut.rx_frame.rtr.next = rtr;
    uut.rx_frame.dlc.next = (dlc as u64).into();
    uut.rx_frame.header.next = true;
    cycle(uut);
    uut.rx_frame.header.next = false;
}

/// The header strobe and the clocks that write the header bytes.
fn header_written(uut: &mut RxFifo, ide: bool, rtr: bool, dlc: usize) {
    header(uut, ide, rtr, dlc);
    for _ in 0..EXTENDED_HEADER + 1 {
        cycle(uut);
    }
}

/// Data bytes in order, a few clocks apart (a data bit takes many clocks).
fn data_bytes(uut: &mut RxFifo, data: &[u8]) {
    for (index, byte) in data.iter().enumerate() {
        uut.rx_frame.data.next = (*byte as u64).into();
        uut.rx_frame.index.next = (index as u64).into();
        uut.rx_frame.strobe.next = true;
        cycle(uut);
        uut.rx_frame.strobe.next = false;
        cycle(uut);
    }
}

/// The validity point: keep the frame received.
fn store(uut: &mut RxFifo) {
    uut.store.next = true;
    cycle(uut);
    uut.store.next = false;
    cycle(uut);
}

/// A whole message: header, data bytes, store. Returns the message's length in the FIFO.
fn receive(uut: &mut RxFifo, ide: bool, rtr: bool, data: &[u8]) -> usize {
    header_written(uut, ide, rtr, data.len());
    data_bytes(uut, data);
    store(uut);
    let header = if ide {
        EXTENDED_HEADER
    } else {
        STANDARD_HEADER
    };
    header + if rtr { 0 } else { data.len() }
}

fn release(uut: &mut RxFifo) {
    uut.release_head.next = true;
    cycle(uut);
    uut.release_head.next = false;
    cycle(uut);
}

/// The RAM byte at `address`, read through the host port.
fn read(uut: &mut RxFifo, address: u64) -> u64 {
    uut.host_address.next = address.into();
    uut.host_read.next = true;
    cycle(uut);
    uut.host_read.next = false;
    uut.read_data.val().index() as u64
}

fn rmc(uut: &RxFifo) -> u64 {
    uut.message_count.val().index() as u64
}

#[test]
fn messages_of_exactly_64_bytes_fill_the_fifo_and_the_next_one_is_lost() {
    let mut uut = fifo();
    let mut used = 0;
    // Four extended frames with 8 data bytes (13 bytes each) and one with 7 (12): 64 bytes.
    for k in 0..4u8 {
        used += receive(&mut uut, true, false, &[k; 8]);
    }
    used += receive(&mut uut, true, false, &[0xEE; 7]);
    assert_eq!(used, 64);
    assert_eq!(rmc(&uut), 5, "five messages stored in 64 bytes");
    assert!(!uut.overrun.val(), "no overrun yet");
    assert_eq!(
        read(&mut uut, 63),
        0xEE,
        "the last byte of the fifth message"
    );

    // The smallest message (a standard remote frame, 3 bytes) finds no room: lost, DOS.
    receive(&mut uut, false, true, &[]);
    assert_eq!(rmc(&uut), 5, "RMC does not count the lost message");
    assert!(uut.overrun.val(), "DOS");
    assert_eq!(
        read(&mut uut, 0),
        0x88,
        "the head message's frame information is intact"
    );
    assert_eq!(
        read(&mut uut, 1),
        0x91,
        "and its first identifier byte (ID.28..21)"
    );

    // Releasing the head message frees its 13 bytes: a message of 13 fits again, where it was.
    release(&mut uut);
    assert_eq!(uut.start.val().index(), 13, "RBSA after the release");
    receive(&mut uut, true, false, &[0x5A; 8]);
    assert_eq!(rmc(&uut), 5, "the message after the release is stored");
    assert_eq!(read(&mut uut, 0), 0x88, "its frame information at byte 0");
    assert_eq!(read(&mut uut, 12), 0x5A, "its last data byte at byte 12");
}

#[test]
fn a_message_one_byte_too_long_for_the_room_left_is_lost() {
    let mut uut = fifo();
    for k in 0..4u8 {
        receive(&mut uut, true, false, &[k; 8]);
    }
    // 52 bytes used, 12 left: an extended frame with 8 data bytes needs 13.
    receive(&mut uut, true, false, &[0xEE; 8]);
    assert_eq!(rmc(&uut), 4, "the 13-byte message is lost");
    assert!(uut.overrun.val(), "DOS");
    // 12 bytes still fit once DOS is cleared (CMR.CDO).
    uut.clear_overrun.next = true;
    cycle(&mut uut);
    uut.clear_overrun.next = false;
    receive(&mut uut, true, false, &[0xEE; 7]);
    assert_eq!(rmc(&uut), 5, "the 12-byte message fits");
    assert!(!uut.overrun.val(), "no new overrun");
}

#[test]
fn a_host_read_of_the_byte_written_in_that_clock_gives_the_byte_it_held() {
    let mut uut = fifo();
    // Reset mode: the host fills bytes 0 and 1 of the RAM.
    uut.clear.next = true;
    for (address, byte) in [(0u64, 0x77u64), (1, 0x66)] {
        uut.host_address.next = address.into();
        uut.host_data.next = byte.into();
        uut.host_write.next = true;
        cycle(&mut uut);
    }
    uut.host_write.next = false;
    uut.clear.next = false;
    cycle(&mut uut);
    assert_eq!(read(&mut uut, 0), 0x77);

    // A standard frame: its header strobe, then the block writes the frame information at byte 0
    // in the first clock after it, identifier bytes at 1 and 2 in the next two.
    header(&mut uut, false, false, 1);
    assert_eq!(
        read(&mut uut, 0),
        0x77,
        "byte 0 read in the clock it is written: the byte the host wrote"
    );
    assert_eq!(
        read(&mut uut, 0),
        0x01,
        "byte 0 the clock after: the frame information"
    );
    // Byte 1 was written while byte 0 was read again; byte 2 is written now, byte 1 read.
    assert_eq!(
        read(&mut uut, 1),
        0x91,
        "byte 1, written the clock before: ID.28..21"
    );
}

#[test]
fn a_lost_message_writes_no_byte_after_its_first_without_room_even_when_a_release_makes_room() {
    let mut uut = fifo();
    // 60 bytes: four extended frames with 8 data bytes (13 each), one with 3 (8).
    for k in 0..4u8 {
        receive(&mut uut, true, false, &[k; 8]);
    }
    receive(&mut uut, true, false, &[0x44; 3]);
    let head_bytes: Vec<u64> = (1..9).map(|a| read(&mut uut, a)).collect();

    // A 13-byte message: 4 header bytes fit at 60..63, the fifth would land on the head message.
    header_written(&mut uut, true, false, 8);
    // The head message is released before the data bytes arrive: bytes 0..12 are free again,
    // where the lost message's data bytes would go (1..8).
    release(&mut uut);
    data_bytes(&mut uut, &[0xAB; 8]);
    store(&mut uut);
    assert_eq!(
        rmc(&uut),
        4,
        "five stored, one released, the lost one not counted"
    );
    assert!(uut.overrun.val(), "DOS");
    let after: Vec<u64> = (1..9).map(|a| read(&mut uut, a)).collect();
    assert_eq!(
        after, head_bytes,
        "bytes 1..8 keep the released message's bytes: no byte of the lost message is written"
    );
}
