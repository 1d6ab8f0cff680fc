//! The 64-byte receive FIFO of the controller, observed only through the host port: messages of
//! every length stored circularly (straddling byte 63 → 0), RMC, RBSA after each release, data
//! overrun (DOS, DOI once until CDO, the dropped message entirely absent), the RAM windows
//! (32..95 = FIFO bytes 0..63, 96..108 = TX buffer; readable always, writable in reset mode) and
//! the RX window 16..28 on the head message.
//!
//! Bench: controller 0 sends, controller 1 (the one under test) receives and acknowledges.

use std::collections::VecDeque;

use golden::frame::{Frame, Id};
use rtl::registers::{command, interrupt, mode, pelican, status};
use sim::host::frame_buffer::buffer_len;
use sim::host::sja1000::{drain_rx, read_rx_message, transmit};
use sim::host::Host;
use testbenches::controller_bench::{
    bench_bit_fs, rx_buffer_bytes, ControllerBench, INTEGRATION_BITS,
};

const SENDER: usize = 0;
const RECEIVER: usize = 1;
const FIFO_BYTES: usize = 64;
/// Longest a frame (and its retransmission after one error) may take, in bit times.
const MAX_FRAME_BITS: u64 = 400;

fn std_data(id: u16, data: &[u8]) -> Frame {
    Frame::data(Id::standard(id).unwrap(), data).unwrap()
}

fn std_remote(id: u16, dlc: u8) -> Frame {
    Frame::remote(Id::standard(id).unwrap(), dlc).unwrap()
}

fn ext_data(id: u32, data: &[u8]) -> Frame {
    Frame::data(Id::extended(id).unwrap(), data).unwrap()
}

fn ext_remote(id: u32, dlc: u8) -> Frame {
    Frame::remote(Id::extended(id).unwrap(), dlc).unwrap()
}

/// FIFO bytes `frame` occupies.
fn fifo_len(frame: &Frame) -> usize {
    rx_buffer_bytes(frame).len()
}

/// The sender transmits `frame` (TR); returns once its request ended, after checking it succeeded
/// (TCS = 1) and clearing its TI.
fn send(bench: &mut ControllerBench, frame: &Frame) {
    transmit(&mut bench.host(SENDER), frame, command::TR);
    assert!(
        bench.run_until_tx_buffer_free(SENDER, MAX_FRAME_BITS),
        "the sender's request for {frame} never ended"
    );
    let sr = bench.host(SENDER).read(pelican::SR);
    assert_eq!(
        sr & status::TCS,
        status::TCS,
        "{frame} was sent (SR {sr:#04x})"
    );
    let ir = bench.host(SENDER).read(pelican::IR);
    assert_eq!(ir, interrupt::TI, "sender IR after {frame}");
}

/// The receiver's FIFO RAM byte `addr` (0..63) through the RAM window.
fn ram(bench: &mut ControllerBench, addr: usize) -> u8 {
    bench
        .host(RECEIVER)
        .read(pelican::RX_RAM + (addr % FIFO_BYTES) as u8)
}

/// `len` RAM bytes from FIFO address `from`, circularly.
fn ram_bytes(bench: &mut ControllerBench, from: usize, len: usize) -> Vec<u8> {
    (0..len).map(|k| ram(bench, from + k)).collect()
}

fn rmc(bench: &mut ControllerBench) -> usize {
    bench.host(RECEIVER).read(pelican::RMC) as usize
}

fn rbsa(bench: &mut ControllerBench) -> usize {
    bench.host(RECEIVER).read(pelican::RBSA) as usize
}

fn receiver_sr(bench: &mut ControllerBench) -> u8 {
    bench.host(RECEIVER).read(pelican::SR)
}

fn receiver_ir(bench: &mut ControllerBench) -> u8 {
    bench.host(RECEIVER).read(pelican::IR)
}

fn release(bench: &mut ControllerBench) {
    bench.host(RECEIVER).write(pelican::CMR, command::RRB);
}

/// Puts the receiver in reset mode, runs `f` on it, and brings it back into operation (integrated).
fn in_reset_mode<F: FnOnce(&mut ControllerBench)>(bench: &mut ControllerBench, f: F) {
    bench.host(RECEIVER).write(pelican::MOD, mode::RM);
    assert_eq!(bench.host(RECEIVER).read(pelican::MOD) & mode::RM, mode::RM);
    f(bench);
    bench.host(RECEIVER).write(pelican::MOD, 0);
    bench.run_bits(INTEGRATION_BITS);
}

/// A deterministic generator of frames of every shape: standard and extended, data and remote,
/// DLC 0..11 (9..11: eight data bytes stored).
struct FrameGen(u64);

impl FrameGen {
    fn next_u32(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) as u32
    }

    fn frame(&mut self) -> Frame {
        let extended = self.next_u32().is_multiple_of(2);
        let id = if extended {
            Id::extended(self.next_u32() & 0x1FFF_FFFF).unwrap()
        } else {
            Id::standard((self.next_u32() & 0x7FF) as u16).unwrap()
        };
        let dlc = (self.next_u32() % 12) as u8;
        if self.next_u32().is_multiple_of(5) {
            return Frame::remote(id, dlc).unwrap();
        }
        let data: Vec<u8> = (0..dlc.min(8)).map(|_| self.next_u32() as u8).collect();
        Frame::data_with_dlc(id, dlc, &data).unwrap()
    }
}

/// The expected FIFO: head address (RBSA), bytes in use, the stored messages in order.
struct FifoModel {
    head: usize,
    used: usize,
    messages: VecDeque<Frame>,
}

impl FifoModel {
    fn fits(&self, frame: &Frame) -> bool {
        self.used + fifo_len(frame) <= FIFO_BYTES
    }

    fn tail(&self) -> usize {
        (self.head + self.used) % FIFO_BYTES
    }
}

#[test]
fn messages_of_mixed_lengths_wrap_around_the_fifo_and_read_back_in_order() {
    let mut bench = ControllerBench::operating(2);
    let mut gen = FrameGen(0x5EED_CAFE);
    let mut model = FifoModel {
        head: 0,
        used: 0,
        messages: VecDeque::new(),
    };
    assert_eq!(rbsa(&mut bench), 0, "RBSA after a hardware reset");
    let mut next = gen.frame();
    let mut straddling = 0;
    let mut wraps = 0;
    for round in 0..10 {
        // Fill: send until the next frame would not fit.
        while model.fits(&next) {
            let at = model.tail();
            let expected = rx_buffer_bytes(&next);
            send(&mut bench, &next);
            model.used += expected.len();
            model.messages.push_back(next);
            assert_eq!(
                ram_bytes(&mut bench, at, expected.len()),
                expected,
                "round {round}: {next} stored at FIFO address {at}"
            );
            if at + expected.len() > FIFO_BYTES {
                straddling += 1;
            }
            assert_eq!(rmc(&mut bench), model.messages.len(), "round {round}: RMC");
            assert_eq!(receiver_sr(&mut bench) & status::DOS, 0, "no overrun");
            next = gen.frame();
        }
        // Release a part (the last round: everything), checking each message and RBSA.
        let keep = if round == 9 {
            0
        } else {
            (gen.next_u32() as usize) % model.messages.len()
        };
        while model.messages.len() > keep {
            let frame = model.messages.pop_front().unwrap();
            assert_eq!(
                rbsa(&mut bench),
                model.head,
                "round {round}: RBSA of {frame}"
            );
            assert_eq!(
                read_rx_message(&mut bench.host(RECEIVER)),
                frame,
                "round {round}"
            );
            release(&mut bench);
            let len = fifo_len(&frame);
            if model.head + len >= FIFO_BYTES {
                wraps += 1;
            }
            model.head = (model.head + len) % FIFO_BYTES;
            model.used -= len;
            assert_eq!(
                rbsa(&mut bench),
                model.head,
                "round {round}: RBSA after RRB"
            );
            assert_eq!(
                rmc(&mut bench),
                model.messages.len(),
                "round {round}: RMC after RRB"
            );
        }
    }
    assert_eq!(receiver_sr(&mut bench) & status::RBS, 0, "all released");
    assert!(
        straddling >= 3,
        "{straddling} messages straddled byte 63 -> 0 (want at least 3)"
    );
    assert!(wraps >= 3, "RBSA wrapped {wraps} times (want at least 3)");
    assert_eq!(bench.host(RECEIVER).read(pelican::RXERR), 0);
}

#[test]
fn twenty_one_smallest_messages_fill_the_fifo_and_the_twenty_second_overruns() {
    let mut bench = ControllerBench::operating(2);
    let frames: Vec<Frame> = (0..22).map(|i| std_remote(0x100 + i, 0)).collect();
    for (i, frame) in frames[..21].iter().enumerate() {
        send(&mut bench, frame);
        assert_eq!(rmc(&mut bench), i + 1, "RMC after message {}", i + 1);
    }
    assert_eq!(
        receiver_sr(&mut bench) & status::DOS,
        0,
        "63 bytes: no overrun"
    );
    assert_eq!(receiver_ir(&mut bench), interrupt::RI);
    send(&mut bench, &frames[21]);
    assert_eq!(rmc(&mut bench), 21, "the 22nd (bytes 63..65) is dropped");
    assert_eq!(receiver_sr(&mut bench) & status::DOS, status::DOS);
    assert_eq!(receiver_ir(&mut bench), interrupt::RI | interrupt::DOI);
    assert_eq!(rbsa(&mut bench), 0);
    assert_eq!(drain_rx(&mut bench.host(RECEIVER)), frames[..21].to_vec());
    assert_eq!(rmc(&mut bench), 0);
}

#[test]
fn overrun_drops_the_whole_message_and_raises_doi_once_until_cdo() {
    let mut bench = ControllerBench::operating(2);
    // 4 × 13 + 11 = 63 bytes: one byte left.
    let mut stored: Vec<Frame> = (0..4u8)
        .map(|i| ext_data(0x1000_0000 + i as u32, &[i; 8]))
        .collect();
    stored.push(std_data(0x555, &[0xA5; 8]));
    for frame in &stored {
        send(&mut bench, frame);
    }
    assert_eq!(rmc(&mut bench), 5);
    assert_eq!(receiver_ir(&mut bench), interrupt::RI);

    // First overrun: DOS, DOI at once, RMC unchanged.
    send(&mut bench, &std_remote(0x7F0, 0));
    assert_eq!(rmc(&mut bench), 5, "the dropped message is not counted");
    assert_eq!(receiver_sr(&mut bench) & status::DOS, status::DOS);
    assert_eq!(receiver_ir(&mut bench), interrupt::RI | interrupt::DOI);
    assert_eq!(
        receiver_ir(&mut bench),
        interrupt::RI,
        "reading IR cleared DOI"
    );

    // Second overrun while DOS = 1: no DOI.
    send(&mut bench, &std_data(0x7F1, &[1, 2]));
    assert_eq!(rmc(&mut bench), 5);
    assert_eq!(receiver_sr(&mut bench) & status::DOS, status::DOS);
    assert_eq!(
        receiver_ir(&mut bench),
        interrupt::RI,
        "no new DOI while DOS = 1"
    );

    // CDO clears DOS (no interrupt); the next overrun gives DOI again.
    bench.host(RECEIVER).write(pelican::CMR, command::CDO);
    assert_eq!(receiver_sr(&mut bench) & status::DOS, 0, "CDO clears DOS");
    assert_eq!(receiver_ir(&mut bench), interrupt::RI);
    send(&mut bench, &ext_remote(0x1555_5555, 2));
    assert_eq!(rmc(&mut bench), 5);
    assert_eq!(receiver_sr(&mut bench) & status::DOS, status::DOS);
    assert_eq!(receiver_ir(&mut bench), interrupt::RI | interrupt::DOI);

    // CDO and RRB together: 13 bytes free; an 11-byte message is stored again.
    bench
        .host(RECEIVER)
        .write(pelican::CMR, command::CDO | command::RRB);
    let first = stored.remove(0);
    assert_eq!(receiver_sr(&mut bench) & status::DOS, 0);
    assert_eq!(rmc(&mut bench), 4);
    assert_eq!(rbsa(&mut bench), fifo_len(&first));
    let last = std_data(0x0AA, &[0xC3; 8]);
    send(&mut bench, &last);
    stored.push(last);
    assert_eq!(rmc(&mut bench), 5);
    assert_eq!(
        receiver_sr(&mut bench) & status::DOS,
        0,
        "stored: no overrun"
    );
    assert_eq!(receiver_ir(&mut bench), interrupt::RI);
    // The new message went where the released one was (63 → 0 → 10): no byte of a dropped one.
    assert_eq!(ram_bytes(&mut bench, 63, 11), rx_buffer_bytes(&last));

    assert_eq!(
        drain_rx(&mut bench.host(RECEIVER)),
        stored,
        "earlier messages intact, no dropped message anywhere"
    );
    assert_eq!(receiver_sr(&mut bench) & (status::DOS | status::RBS), 0);
}

#[test]
fn overrun_with_doi_disabled_sets_dos_only() {
    let mut bench = ControllerBench::operating(2);
    bench.host(RECEIVER).write(pelican::IER, !interrupt::DOI);
    for i in 0..21 {
        send(&mut bench, &std_remote(0x200 + i, 1));
    }
    send(&mut bench, &std_remote(0x300, 1));
    assert_eq!(rmc(&mut bench), 21);
    assert_eq!(receiver_sr(&mut bench) & status::DOS, status::DOS);
    assert_eq!(
        receiver_ir(&mut bench),
        interrupt::RI,
        "DOI is not set while DOIE = 0"
    );
    // Enabling DOIE later does not raise DOI for the overrun already reported in DOS.
    bench.host(RECEIVER).write(pelican::IER, 0xFF);
    bench.run_bits(2);
    assert_eq!(receiver_ir(&mut bench), interrupt::RI);
}

#[test]
fn an_overrunning_frame_destroyed_by_an_error_sets_dos_only_when_its_retransmission_is_valid() {
    let mut bench = ControllerBench::operating(2);
    for i in 0..21 {
        send(&mut bench, &std_remote(0x400 + i, 0));
    }
    assert_eq!(receiver_sr(&mut bench) & status::DOS, 0);
    // The 22nd frame does not fit; the receiver sees seven dominant bits in its data field (a
    // stuff error), so the first attempt is destroyed and retransmitted.
    let frame = std_data(0x6B5, &[0xF0, 0x0F, 0x55, 0xAA]);
    transmit(&mut bench.host(SENDER), &frame, command::TR);
    let sof = bench.run_until_sof(SENDER, 50);
    let receiver = bench.id(RECEIVER);
    bench.engine.disturb_rx(
        receiver,
        sof + 22 * bench_bit_fs(),
        sof + 29 * bench_bit_fs(),
        false,
    );
    bench.run_bits(38);
    // 22 + 6 dominant bits, the error flag, the delimiter: before the retransmission's end.
    assert_eq!(
        receiver_sr(&mut bench) & status::DOS,
        0,
        "a dropped message that turns out erroneous is no overrun"
    );
    assert_eq!(receiver_ir(&mut bench) & interrupt::DOI, 0);
    assert_ne!(
        bench.host(RECEIVER).read(pelican::RXERR),
        0,
        "the stuff error was seen"
    );
    assert!(bench.run_until_tx_buffer_free(SENDER, MAX_FRAME_BITS));
    assert_eq!(
        bench.host(SENDER).read(pelican::SR) & status::TCS,
        status::TCS
    );
    assert_eq!(receiver_sr(&mut bench) & status::DOS, status::DOS);
    assert_eq!(receiver_ir(&mut bench), interrupt::RI | interrupt::DOI);
    assert_eq!(rmc(&mut bench), 21);
    let expected: Vec<Frame> = (0..21).map(|i| std_remote(0x400 + i, 0)).collect();
    assert_eq!(drain_rx(&mut bench.host(RECEIVER)), expected);
}

#[test]
fn a_frame_destroyed_by_an_error_leaves_no_trace_and_its_retransmission_is_stored_once() {
    let mut bench = ControllerBench::operating(2);
    let first = std_data(0x011, &[0x11]);
    send(&mut bench, &first);
    let frame = ext_data(0x0ABC_DEF1, &[9, 8, 7, 6, 5, 4, 3, 2]);
    transmit(&mut bench.host(SENDER), &frame, command::TR);
    let sof = bench.run_until_sof(SENDER, 50);
    let receiver = bench.id(RECEIVER);
    bench.engine.disturb_rx(
        receiver,
        sof + 70 * bench_bit_fs(),
        sof + 77 * bench_bit_fs(),
        false,
    );
    assert!(bench.run_until_tx_buffer_free(SENDER, MAX_FRAME_BITS));
    assert_ne!(
        bench.host(SENDER).read(pelican::TXERR),
        0,
        "the first attempt failed"
    );
    assert_eq!(rmc(&mut bench), 2);
    assert_eq!(rbsa(&mut bench), 0);
    assert_eq!(
        ram_bytes(&mut bench, 4, 13),
        rx_buffer_bytes(&frame),
        "the retransmission is stored right after the first message"
    );
    assert_eq!(drain_rx(&mut bench.host(RECEIVER)), vec![first, frame]);
    assert_eq!(rbsa(&mut bench), 17);
}

/// Fills the receiver with 5 × 11 + 4 = 59 bytes (5 bytes free), then the sender transmits an
/// 11-byte message and the receiver's host releases the head message (11 bytes) `release_after`
/// bit times after its SOF. Returns the bench, the stored messages and the arriving one.
fn release_during_reception(release_after: u64) -> (ControllerBench, Vec<Frame>, Frame) {
    let mut bench = ControllerBench::operating(2);
    let mut stored: Vec<Frame> = (0..5u8)
        .map(|i| std_data(0x700 + i as u16, &[i; 8]))
        .collect();
    stored.push(std_data(0x70F, &[0xFF]));
    for frame in &stored {
        send(&mut bench, frame);
    }
    let arriving = std_data(0x0C3, &[0x31, 0x32, 0x33, 0x34, 0x35, 0x36, 0x37, 0x38]);
    transmit(&mut bench.host(SENDER), &arriving, command::TR);
    bench.run_until_sof(SENDER, 50);
    bench.run_bits(release_after);
    release(&mut bench);
    stored.remove(0);
    assert!(bench.run_until_tx_buffer_free(SENDER, MAX_FRAME_BITS));
    (bench, stored, arriving)
}

#[test]
fn a_release_before_the_bytes_arrive_makes_room_for_the_arriving_message() {
    // Released 10 bits after the SOF (in the identifier): every byte finds room.
    let (mut bench, mut stored, arriving) = release_during_reception(10);
    assert_eq!(receiver_sr(&mut bench) & status::DOS, 0, "no overrun");
    assert_eq!(rmc(&mut bench), 6);
    assert_eq!(rbsa(&mut bench), 11);
    assert_eq!(ram_bytes(&mut bench, 59, 11), rx_buffer_bytes(&arriving));
    stored.push(arriving);
    assert_eq!(drain_rx(&mut bench.host(RECEIVER)), stored);
}

#[test]
fn a_release_after_a_byte_found_no_room_does_not_save_the_arriving_message() {
    // Released 70 bits after the SOF: data byte 3 (FIFO byte 64) was already lost.
    let (mut bench, stored, _) = release_during_reception(70);
    assert_eq!(receiver_sr(&mut bench) & status::DOS, status::DOS);
    assert_eq!(receiver_ir(&mut bench), interrupt::RI | interrupt::DOI);
    assert_eq!(rmc(&mut bench), 5);
    assert_eq!(drain_rx(&mut bench.host(RECEIVER)), stored);
}

#[test]
fn rbsa_moves_by_each_released_message_and_survives_reset_mode() {
    let mut bench = ControllerBench::operating(2);
    let frames = [
        std_remote(0x001, 0),           // 3 bytes
        std_data(0x002, &[1, 2]),       // 5
        ext_data(0x0000_0003, &[3; 8]), // 13
        ext_remote(0x0000_0004, 7),     // 5
        std_data(0x005, &[5; 8]),       // 11
        Frame::data_with_dlc(Id::standard(0x006).unwrap(), 15, &[6; 8]).unwrap(), // 11
    ];
    for frame in &frames {
        send(&mut bench, frame);
    }
    let mut expected = 0;
    for frame in &frames {
        assert_eq!(rbsa(&mut bench), expected, "RBSA of {frame}");
        assert_eq!(read_rx_message(&mut bench.host(RECEIVER)), *frame);
        release(&mut bench);
        expected += fifo_len(frame);
    }
    assert_eq!(expected, 48);
    assert_eq!(rbsa(&mut bench), 48, "after the last release");
    assert_eq!(receiver_sr(&mut bench) & status::RBS, 0);
    // A release with the FIFO empty changes nothing.
    release(&mut bench);
    assert_eq!(rbsa(&mut bench), 48);
    assert_eq!(rmc(&mut bench), 0);

    // Reset mode empties the FIFO (RMC 0, RBS 0, DOS 0) but keeps RBSA.
    send(&mut bench, &std_data(0x010, &[0x10]));
    send(&mut bench, &std_data(0x011, &[0x11]));
    assert_eq!(rmc(&mut bench), 2);
    in_reset_mode(&mut bench, |bench| {
        assert_eq!(rmc(bench), 0);
        assert_eq!(receiver_sr(bench) & (status::RBS | status::DOS), 0);
        assert_eq!(rbsa(bench), 48, "RBSA kept in reset mode");
    });
    assert_eq!(rbsa(&mut bench), 48);
    let after_reset = std_remote(0x012, 3);
    send(&mut bench, &after_reset);
    assert_eq!(rmc(&mut bench), 1);
    assert_eq!(
        ram_bytes(&mut bench, 48, 3),
        rx_buffer_bytes(&after_reset),
        "the next message is stored at RBSA"
    );
    assert_eq!(read_rx_message(&mut bench.host(RECEIVER)), after_reset);

    // RBSA written in reset mode: the next message is stored there, straddling 63 → 0.
    in_reset_mode(&mut bench, |bench| {
        bench.host(RECEIVER).write(pelican::RBSA, 60);
        assert_eq!(rbsa(bench), 60);
    });
    let straddling = ext_data(0x1234_5678, &[0xDE, 0xAD, 0xBE, 0xEF]);
    send(&mut bench, &straddling);
    assert_eq!(rbsa(&mut bench), 60);
    assert_eq!(ram_bytes(&mut bench, 60, 9), rx_buffer_bytes(&straddling));
    assert_eq!(read_rx_message(&mut bench.host(RECEIVER)), straddling);
    release(&mut bench);
    assert_eq!(rbsa(&mut bench), 5, "60 + 9 wraps to 5");
    // RBSA is read-only in operating mode.
    bench.host(RECEIVER).write(pelican::RBSA, 20);
    assert_eq!(rbsa(&mut bench), 5);
}

#[test]
fn ram_window_shows_the_raw_fifo_bytes_at_their_addresses() {
    let mut bench = ControllerBench::operating(2);
    send(&mut bench, &std_data(0x123, &[0xAA, 0x55]));
    send(&mut bench, &ext_remote(0x1ABC_DEF0, 3));
    send(&mut bench, &std_remote(0x7FF, 9));
    send(&mut bench, &ext_data(0x0000_0001, &[0x80]));
    #[rustfmt::skip]
    let expected: [u8; 19] = [
        0x02, 0x24, 0x60, 0xAA, 0x55,       // FI (DLC 2), ID.10..3, ID.2..0 | RTR 0, data
        0xC3, 0xD5, 0xE6, 0xF7, 0x84,       // FF | RTR | DLC 3, ID.28..5, ID.4..0 | RTR copy
        0x49, 0xFF, 0xF0,                   // RTR | DLC 9, ID.10..3, ID.2..0 | RTR copy
        0x81, 0x00, 0x00, 0x00, 0x08, 0x80, // FF | DLC 1, ID (= 1), data
    ];
    for (i, &byte) in expected.iter().enumerate() {
        assert_eq!(
            bench.host(RECEIVER).read(pelican::RX_RAM + i as u8),
            byte,
            "RAM address {} (FIFO byte {i})",
            pelican::RX_RAM as usize + i
        );
    }
    // The window is readable in reset mode too, and entering reset mode does not change the RAM.
    in_reset_mode(&mut bench, |bench| {
        assert_eq!(ram_bytes(bench, 0, expected.len()), expected.to_vec());
    });
}

/// The byte the RAM-window test writes at FIFO address `i`.
fn ram_pattern(i: usize) -> u8 {
    (i as u8).wrapping_mul(37) ^ 0x5A
}

/// Reads both RAM windows back: the RX RAM holds [`ram_pattern`], the TX RAM `0xE0 | index`.
fn assert_ram_windows_hold_the_pattern(host: &mut Host) {
    for i in 0..FIFO_BYTES {
        assert_eq!(
            host.read(pelican::RX_RAM + i as u8),
            ram_pattern(i),
            "RX RAM {i}"
        );
    }
    for i in 0..13 {
        assert_eq!(host.read(pelican::TX_RAM + i), 0xE0 | i, "TX RAM {i}");
    }
}

#[test]
fn ram_windows_are_writable_in_reset_mode_only() {
    let mut bench = ControllerBench::operating(2);
    in_reset_mode(&mut bench, |bench| {
        let mut host = bench.host(RECEIVER);
        for i in 0..FIFO_BYTES {
            host.write(pelican::RX_RAM + i as u8, ram_pattern(i));
        }
        for i in 0..13 {
            host.write(pelican::TX_RAM + i, 0xE0 | i);
        }
        assert_ram_windows_hold_the_pattern(&mut host);
    });
    // Operating mode: writes to both RAM windows are ignored.
    {
        let mut host = bench.host(RECEIVER);
        for i in 0..FIFO_BYTES {
            host.write(pelican::RX_RAM + i as u8, 0);
        }
        for i in 0..13 {
            host.write(pelican::TX_RAM + i, 0);
        }
        assert_ram_windows_hold_the_pattern(&mut host);
        assert_eq!(host.read(pelican::RMC), 0, "RAM writes store no message");
    }
    // A received message overwrites only its own bytes, at RBSA (0).
    let frame = std_data(0x321, &[1, 2, 3]);
    send(&mut bench, &frame);
    let mut want: Vec<u8> = (0..FIFO_BYTES).map(ram_pattern).collect();
    want[..6].copy_from_slice(&rx_buffer_bytes(&frame));
    assert_eq!(ram_bytes(&mut bench, 0, FIFO_BYTES), want);
}

#[test]
fn tx_ram_window_is_the_transmit_buffer() {
    let mut bench = ControllerBench::operating(2);
    // Operating mode: the frame window 16..28 writes the TX buffer, visible at 96..108.
    let frame = ext_data(0x1F0F_0F0F, &[1, 2, 3, 4, 5, 6, 7, 8]);
    let bytes = sim::host::frame_buffer::encode_buffer(&frame);
    {
        let mut host = bench.host(SENDER);
        for (i, &b) in bytes.iter().enumerate() {
            host.write(pelican::FRAME + i as u8, b);
        }
        for (i, &b) in bytes.iter().enumerate() {
            assert_eq!(host.read(pelican::TX_RAM + i as u8), b, "TX RAM {i}");
        }
    }
    // Reset mode: a frame written through 96..108 is what TR sends.
    let written = std_data(0x2A5, &[0x0F, 0xF0, 0x3C]);
    let buf = sim::host::frame_buffer::encode_buffer(&written);
    bench.host(SENDER).write(pelican::MOD, mode::RM);
    for (i, &b) in buf.iter().take(buffer_len(buf[0])).enumerate() {
        bench.host(SENDER).write(pelican::TX_RAM + i as u8, b);
    }
    bench.host(SENDER).write(pelican::MOD, 0);
    bench.run_bits(INTEGRATION_BITS);
    bench.host(SENDER).write(pelican::CMR, command::TR);
    assert!(bench.run_until_tx_buffer_free(SENDER, MAX_FRAME_BITS));
    assert_eq!(drain_rx(&mut bench.host(RECEIVER)), vec![written]);
}

#[test]
fn rx_window_shows_the_head_message_wherever_it_lies() {
    let mut bench = ControllerBench::operating(2);
    in_reset_mode(&mut bench, |bench| {
        bench.host(RECEIVER).write(pelican::RBSA, 58);
    });
    let head = ext_data(
        0x0765_4321,
        &[0x10, 0x20, 0x30, 0x40, 0x50, 0x60, 0x70, 0x80],
    );
    let second = std_data(0x4C3, &[0xEE]);
    send(&mut bench, &head);
    send(&mut bench, &second);
    // The window 16..28 maps FIFO bytes RBSA..RBSA+12: the head message (here 58..63, 0..6).
    let window: Vec<u8> = (0..13)
        .map(|k| bench.host(RECEIVER).read(pelican::FRAME + k))
        .collect();
    assert_eq!(
        window,
        rx_buffer_bytes(&head),
        "head message at 58, straddling"
    );
    assert_eq!(window, ram_bytes(&mut bench, 58, 13));
    release(&mut bench);
    assert_eq!(rbsa(&mut bench), 7);
    let window: Vec<u8> = (0..13)
        .map(|k| bench.host(RECEIVER).read(pelican::FRAME + k))
        .collect();
    assert_eq!(&window[..4], rx_buffer_bytes(&second).as_slice());
    assert_eq!(
        window,
        ram_bytes(&mut bench, 7, 13),
        "past the message the window shows the RAM that follows"
    );
    // Reading the window does not release anything.
    assert_eq!(rmc(&mut bench), 1);
}
