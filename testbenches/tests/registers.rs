//! SJA1000 register behaviour of the complete controller, observed only through its host port.
//!
//! The contract is `docs/SJA1000.md`; the design decisions stated in the module doc of
//! `rtl::can_controller` are tested as stated. One group of tests per rule: reset values, access
//! permissions, commands, interrupts, ALC/ECC capture, counter writes and fault confinement as seen
//! through registers, and the BasicCAN map. Every address and bit comes from `rtl::registers`.

use golden::frame::{encode, EncodedFrame, Field, Frame, Id, DOMINANT, RECESSIVE};
use rtl::registers::{
    basic, clock_divider, command, control, interrupt, mode, pelican, status, DEFAULT_EWLR,
};
use sim::engine::bus::Drive;
use sim::host::frame_buffer::{buffer_len, encode_buffer};
use sim::host::sja1000::{
    drain_rx, read_rx_message, transmit, BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ,
};
use sim::host::Host;
use sim::nodes::controller_node::ControllerNode;
use testbenches::controller_bench::{
    bench_bit_fs, configure_pelican, configure_pelican_for, ControllerBench, INTEGRATION_BITS,
};
use testbenches::ecc::{self, ecc};

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

fn std_frame(id: u16, data: &[u8]) -> Frame {
    Frame::data(Id::standard(id).unwrap(), data).unwrap()
}

fn ext_frame(id: u32, data: &[u8]) -> Frame {
    Frame::data(Id::extended(id).unwrap(), data).unwrap()
}

fn std_remote(id: u16, dlc: u8) -> Frame {
    Frame::remote(Id::standard(id).unwrap(), dlc).unwrap()
}

fn ext_remote(id: u32, dlc: u8) -> Frame {
    Frame::remote(Id::extended(id).unwrap(), dlc).unwrap()
}

/// Bytes a message occupies in the RX FIFO (frame information, identifier, stored data).
fn fifo_len(frame: &Frame) -> u8 {
    buffer_len(encode_buffer(frame)[0]) as u8
}

/// Reads every register of `expected` (name, address, value) in order and compares all at once.
fn check_registers(host: &mut Host, expected: &[(&str, u8, u8)], what: &str) {
    let got: Vec<(&str, u8)> = expected
        .iter()
        .map(|&(name, addr, _)| (name, host.read(addr)))
        .collect();
    let want: Vec<(&str, u8)> = expected.iter().map(|&(name, _, v)| (name, v)).collect();
    assert_eq!(got, want, "{what}");
}

/// `count` controllers after a hardware reset, each set up by [`configure_pelican`] (PeliCAN,
/// bench timing, open filter, IER 0xFF) and left in reset mode.
fn pelican_in_reset_mode(count: usize) -> ControllerBench {
    let mut bench = ControllerBench::new(count);
    for n in 0..count {
        configure_pelican(&mut bench.host(n));
    }
    bench
}

/// Node `n` leaves reset mode (MOD = `mod_bits`, RM clear) and the bus runs until it has integrated.
fn leave_reset_mode(bench: &mut ControllerBench, n: usize, mod_bits: u8) {
    bench.host(n).write(pelican::MOD, mod_bits & !mode::RM);
    bench.run_bits(INTEGRATION_BITS);
}

/// Runs bit by bit until `SR & mask == value` on node `n`; returns the bits waited. Panics after
/// `max_bits`.
fn run_until_status(
    bench: &mut ControllerBench,
    n: usize,
    mask: u8,
    value: u8,
    max_bits: u64,
) -> u64 {
    for bits in 0..=max_bits {
        if bench.host(n).read(pelican::SR) & mask == value {
            return bits;
        }
        bench.run_bits(1);
    }
    panic!("node {n}: SR & {mask:#04x} never became {value:#04x} within {max_bits} bits");
}

/// Runs until node `n` has a free transmit buffer again (its request ended).
fn run_until_tx_done(bench: &mut ControllerBench, n: usize, max_bits: u64) {
    run_until_status(bench, n, status::TBS, status::TBS, max_bits);
}

/// Node `from` sends `frame` with `cmd` and the bus runs until the request has ended.
fn send(bench: &mut ControllerBench, from: usize, frame: &Frame, cmd: u8) {
    transmit(&mut bench.host(from), frame, cmd);
    run_until_tx_done(bench, from, 400);
}

/// The first non-stuff wire bit of `field` that is sent with `level`.
fn bit_in_field(encoded: &EncodedFrame, field: Field, level: bool) -> usize {
    (0..encoded.len())
        .find(|&i| {
            encoded.tags[i].field == field && !encoded.tags[i].stuff && encoded.bits[i] == level
        })
        .unwrap_or_else(|| panic!("no {field} bit at level {level}"))
}

/// Node `n` transmits `frame` with `cmd`; the node sees the wire bit `bit` of it as `level`.
/// Runs until the request ends.
fn transmit_with_seen_bit(
    bench: &mut ControllerBench,
    n: usize,
    frame: &Frame,
    cmd: u8,
    bit: usize,
    level: bool,
) {
    transmit(&mut bench.host(n), frame, cmd);
    let sof = bench.run_until_sof(n, 20);
    bench.force_seen_bit(n, sof, bit, level);
    run_until_tx_done(bench, n, 400);
}

/// The BasicCAN setup of node `n` (after a hardware reset): bench timing, `acr`/`amr`, then CR =
/// `cr` (RR clear: operating mode), and the bus runs until it has integrated.
fn configure_basic(bench: &mut ControllerBench, n: usize, acr: u8, amr: u8, cr: u8) {
    let mut host = bench.host(n);
    host.write(basic::CR, control::RR);
    host.write(basic::BTR0, BTR0_500K_AT_16MHZ);
    host.write(basic::BTR1, BTR1_500K_AT_16MHZ);
    host.write(basic::ACR, acr);
    host.write(basic::AMR, amr);
    host.write(basic::CR, cr & !control::RR);
    bench.run_bits(INTEGRATION_BITS);
}

/// Writes a standard frame into the BasicCAN transmit buffer (10..19) and the command `cmd`.
fn basic_transmit(host: &mut Host, frame: &Frame, cmd: u8) {
    let Id::Standard(id) = frame.id() else {
        panic!("BasicCAN sends standard frames only");
    };
    host.write(basic::TX, (id >> 3) as u8);
    host.write(
        basic::TX + 1,
        ((id & 7) as u8) << 5 | (frame.is_remote() as u8) << 4 | frame.dlc(),
    );
    for (i, b) in frame.data_bytes().iter().enumerate() {
        host.write(basic::TX + 2 + i as u8, *b);
    }
    host.write(basic::CMR, cmd);
}

/// The BasicCAN RX buffer bytes 20.. of a standard frame as a host expects them.
fn basic_rx_bytes(frame: &Frame) -> Vec<u8> {
    let Id::Standard(id) = frame.id() else {
        panic!("standard frames only");
    };
    let mut bytes = vec![
        (id >> 3) as u8,
        ((id & 7) as u8) << 5 | (frame.is_remote() as u8) << 4 | frame.dlc(),
    ];
    bytes.extend_from_slice(frame.data_bytes());
    bytes
}

/// Reads `len` bytes from `first` on.
fn read_bytes(host: &mut Host, first: u8, len: usize) -> Vec<u8> {
    (0..len).map(|i| host.read(first + i as u8)).collect()
}

/// Addresses of the PeliCAN map that are reserved (no register), below the RAM windows and above.
fn pelican_reserved_addresses() -> Vec<u8> {
    let mut addrs = vec![5, 9, 10];
    addrs.extend(pelican::TX_RAM_LAST + 1..=255);
    addrs
}

#[test]
fn a_frame_sent_through_registers_is_stored_by_the_other_controller() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x123, &[1, 2, 3, 4]);
    transmit(&mut bench.host(0), &frame, command::TR);
    assert!(bench.run_until_irq(1, 200), "receiver raises RI");
    let ir = bench.host(1).read(pelican::IR);
    assert_eq!(ir & interrupt::RI, interrupt::RI);
    assert_eq!(bench.host(1).read(pelican::RMC), 1);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);
    assert!(bench.run_until_irq(0, 50), "transmitter raises TI");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::TI);
    let sr = bench.host(0).read(pelican::SR);
    assert_eq!(sr & (status::TBS | status::TCS), status::TBS | status::TCS);
}

// ---------------------------------------------------------------------------------------------
// Rule 1: reset values
// ---------------------------------------------------------------------------------------------

/// The BasicCAN map right after a hardware reset (reset mode).
fn basic_hardware_reset_values() -> Vec<(&'static str, u8, u8)> {
    vec![
        ("CR", basic::CR, control::RR | control::ALWAYS_ONE),
        ("CMR", basic::CMR, 0xFF),
        ("SR", basic::SR, 0x3C),
        ("IR", basic::IR, 0xE0),
        ("ACR", basic::ACR, 0),
        ("AMR", basic::AMR, 0),
        ("BTR0", basic::BTR0, 0),
        ("BTR1", basic::BTR1, 0),
        ("OCR", basic::OCR, 0),
        ("reserved 9", 9, 0),
        ("reserved 30", 30, 0),
        ("CDR", basic::CDR, 0),
    ]
}

/// The PeliCAN map right after a hardware reset and the write CDR = PeliCAN (reset mode).
fn pelican_hardware_reset_values() -> Vec<(&'static str, u8, u8)> {
    let mut regs = vec![
        ("MOD", pelican::MOD, mode::RM),
        ("CMR", pelican::CMR, 0),
        ("SR", pelican::SR, 0x3C),
        ("IR", pelican::IR, 0),
        ("IER", pelican::IER, 0),
        ("BTR0", pelican::BTR0, 0),
        ("BTR1", pelican::BTR1, 0),
        ("OCR", pelican::OCR, 0),
        ("ALC", pelican::ALC, 0),
        ("ECC", pelican::ECC, 0),
        ("EWLR", pelican::EWLR, DEFAULT_EWLR),
        ("RXERR", pelican::RXERR, 0),
        ("TXERR", pelican::TXERR, 0),
        ("ACR0", pelican::ACR0, 0),
        ("ACR1", pelican::ACR0 + 1, 0),
        ("ACR2", pelican::ACR0 + 2, 0),
        ("ACR3", pelican::ACR0 + 3, 0),
        ("AMR0", pelican::AMR0, 0),
        ("AMR1", pelican::AMR0 + 1, 0),
        ("AMR2", pelican::AMR0 + 2, 0),
        ("AMR3", pelican::AMR3, 0),
        ("RMC", pelican::RMC, 0),
        ("RBSA", pelican::RBSA, 0),
        ("CDR", pelican::CDR, clock_divider::PELICAN),
    ];
    regs.extend([
        ("reserved 5", 5, 0),
        ("reserved 9", 9, 0),
        ("reserved 10", 10, 0),
    ]);
    regs
}

#[test]
fn hardware_reset_values_of_the_basic_can_map() {
    let mut bench = ControllerBench::new(1);
    check_registers(
        &mut bench.host(0),
        &basic_hardware_reset_values(),
        "BasicCAN map after a hardware reset",
    );
    assert!(!bench.node(0).irq(), "irq_n high after a hardware reset");
}

#[test]
fn hardware_reset_values_of_the_pelican_map() {
    let mut bench = ControllerBench::new(1);
    bench.host(0).write(pelican::CDR, clock_divider::PELICAN);
    check_registers(
        &mut bench.host(0),
        &pelican_hardware_reset_values(),
        "PeliCAN map after a hardware reset",
    );
}

#[test]
fn ts_and_rs_stay_set_until_the_node_has_seen_11_recessive_bits() {
    let mut bench = pelican_in_reset_mode(1);
    assert_eq!(bench.host(0).read(pelican::SR), 0x3C, "in reset mode");
    bench.host(0).write(pelican::MOD, 0);
    bench.run_bits(9);
    assert_eq!(
        bench.host(0).read(pelican::SR),
        0x3C,
        "9 bits after leaving reset mode: still waiting for the bus"
    );
    bench.run_bits(4);
    assert_eq!(
        bench.host(0).read(pelican::SR),
        status::TBS | status::TCS,
        "13 bits after: integrated, idle"
    );
}

#[test]
fn hardware_reset_pulse_mid_operation_restores_every_reset_value() {
    let mut bench = pelican_in_reset_mode(2);
    // Node 0: every writable register away from its reset value.
    {
        let mut h = bench.host(0);
        h.write(pelican::OCR, 0x1A);
        h.write(pelican::EWLR, 50);
        h.write(pelican::TXERR, 10);
        h.write(pelican::RXERR, 20);
        h.write(pelican::ACR0 + 1, 0x5A);
        h.write(pelican::RBSA, 7);
        h.write(
            pelican::CDR,
            clock_divider::PELICAN | clock_divider::CBP | clock_divider::CLOCK_OFF | 3,
        );
        h.write(pelican::BTR1, BTR1_500K_AT_16MHZ);
        h.write(pelican::MOD, mode::AFM);
    }
    leave_reset_mode(&mut bench, 1, 0);
    bench.run_bits(INTEGRATION_BITS);
    send(&mut bench, 1, &std_frame(0x321, &[9, 8, 7]), command::TR);
    assert_eq!(
        bench.host(0).read(pelican::RMC),
        1,
        "node 0 holds a message"
    );
    assert!(bench.node(0).irq(), "RI pending before the reset");
    // A transmission request of node 0 under way when the reset comes.
    transmit(&mut bench.host(0), &std_frame(0x10, &[1]), command::TR);
    bench.run_bits(5);

    bench.pulse_hardware_reset(0);

    assert!(!bench.node(0).irq(), "irq_n released by the reset");
    check_registers(
        &mut bench.host(0),
        &basic_hardware_reset_values(),
        "BasicCAN map after a reset pulse in operation",
    );
    bench.host(0).write(pelican::CDR, clock_divider::PELICAN);
    check_registers(
        &mut bench.host(0),
        &pelican_hardware_reset_values(),
        "PeliCAN map after a reset pulse in operation",
    );
}

#[test]
fn software_reset_pelican_cancels_tx_empties_fifo_clears_ir_but_ei_and_keeps_the_rest() {
    let mut bench = pelican_in_reset_mode(2);
    {
        let mut h = bench.host(0);
        h.write(pelican::OCR, 0x1A);
        h.write(pelican::EWLR, 90);
        // TXERR 100 >= EWLR: ES rises when reset mode is left, giving an EI that stays pending
        // (node 0 sends nothing successfully, so TXERR stays).
        h.write(pelican::TXERR, 100);
        h.write(pelican::RXERR, 30);
        h.write(pelican::ACR0 + 1, 0x5A);
        h.write(pelican::AMR0 + 2, 0xF7);
        h.write(pelican::CDR, clock_divider::PELICAN | 2);
    }
    bench.host(0).write(pelican::MOD, mode::AFM);
    leave_reset_mode(&mut bench, 1, 0);
    // Six messages of 11 bytes: five fit in the 64-byte FIFO, the sixth overruns.
    for k in 0..6u8 {
        send(
            &mut bench,
            1,
            &std_frame(0x100 + k as u16, &[k; 8]),
            command::TR,
        );
    }
    bench.host(0).write(pelican::CMR, command::RRB);
    // A request of node 0 that waits while node 1 sends.
    transmit(
        &mut bench.host(1),
        &std_frame(0x001, &[0xEE; 8]),
        command::TR,
    );
    bench.run_bits(3);
    transmit(&mut bench.host(0), &std_frame(0x7F0, &[1]), command::TR);
    check_registers(
        &mut bench.host(0),
        &[
            ("MOD", pelican::MOD, mode::AFM),
            ("RMC", pelican::RMC, 4),
            ("RBSA", pelican::RBSA, 11),
        ],
        "before the software reset",
    );
    // Each message received lowered RXERR by one.
    let rxerr = bench.host(0).read(pelican::RXERR);
    assert_eq!(rxerr, 30 - 6);
    let sr = bench.host(0).read(pelican::SR);
    assert_eq!(
        sr & (status::ES | status::TBS | status::DOS | status::RBS),
        status::ES | status::DOS | status::RBS,
        "before: ES, DOS, RBS, request pending (SR {sr:#04x})"
    );

    bench.host(0).write(pelican::MOD, mode::RM);
    bench.host(0).idle(2);

    assert!(bench.node(0).irq(), "EI still pending");
    check_registers(
        &mut bench.host(0),
        &[
            ("MOD", pelican::MOD, mode::RM | mode::AFM),
            ("CMR", pelican::CMR, 0),
            (
                "SR",
                pelican::SR,
                status::ES | status::TS | status::RS | status::TBS,
            ),
            ("IR", pelican::IR, interrupt::EI),
            ("IER", pelican::IER, 0xFF),
            ("BTR0", pelican::BTR0, BTR0_500K_AT_16MHZ),
            ("BTR1", pelican::BTR1, BTR1_500K_AT_16MHZ),
            ("OCR", pelican::OCR, 0x1A),
            ("EWLR", pelican::EWLR, 90),
            ("RXERR", pelican::RXERR, rxerr),
            ("TXERR", pelican::TXERR, 100),
            ("ACR0", pelican::ACR0, 0),
            ("ACR1", pelican::ACR0 + 1, 0x5A),
            ("AMR2", pelican::AMR0 + 2, 0xF7),
            ("AMR3", pelican::AMR3, 0xFF),
            ("RMC", pelican::RMC, 0),
            ("RBSA", pelican::RBSA, 11),
            ("CDR", pelican::CDR, clock_divider::PELICAN | 2),
        ],
        "after MOD.RM: TX cancelled, FIFO empty, IR = EI, configuration and RBSA kept",
    );
    // The cancelled request never gives TI, and is not sent after reset mode is left.
    bench.host(0).write(pelican::MOD, mode::AFM);
    bench.run_bits(200);
    assert_eq!(bench.host(0).read(pelican::IR) & interrupt::TI, 0, "no TI");
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        status::TBS,
        "buffer free, never completed"
    );
}

#[test]
fn entering_reset_mode_clears_sm() {
    let mut bench = ControllerBench::operating(1);
    bench.host(0).write(pelican::IER, 0);
    bench.host(0).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(0).read(pelican::MOD), mode::SM, "asleep");
    bench.host(0).write(pelican::MOD, mode::RM | mode::SM);
    assert_eq!(
        bench.host(0).read(pelican::MOD),
        mode::RM,
        "reset mode, SM cleared"
    );
}

#[test]
fn software_reset_basic_can_keeps_cr_enables_and_configuration() {
    let mut bench = ControllerBench::new(2);
    let cr = control::RIE | control::TIE | control::EIE | control::OIE | 0x40;
    configure_basic(&mut bench, 0, 0x24, 0x0F, cr);
    configure_pelican(&mut bench.host(1));
    leave_reset_mode(&mut bench, 1, 0);
    bench.host(0).write(basic::OCR, 0x55); // ignored in operating mode
    send(&mut bench, 1, &std_frame(0x120, &[1, 2]), command::TR);
    assert_eq!(bench.host(0).read(basic::SR) & status::RBS, status::RBS);
    assert!(bench.node(0).irq(), "RI pending before the reset");

    bench.host(0).write(basic::CR, cr | control::RR);
    // The FIFO and the core follow RR one clock later (the SJA1000 acts on its next internal
    // clock, fosc/2, too).
    bench.host(0).idle(2);

    assert!(!bench.node(0).irq(), "RI gone with the FIFO");
    check_registers(
        &mut bench.host(0),
        &[
            ("CR", basic::CR, cr | control::RR | control::ALWAYS_ONE),
            (
                "SR",
                basic::SR,
                status::TS | status::RS | status::TBS | status::TCS,
            ),
            ("IR", basic::IR, 0xE0),
            ("ACR", basic::ACR, 0x24),
            ("AMR", basic::AMR, 0x0F),
            ("BTR0", basic::BTR0, BTR0_500K_AT_16MHZ),
            ("BTR1", basic::BTR1, BTR1_500K_AT_16MHZ),
            ("OCR", basic::OCR, 0),
            ("CDR", basic::CDR, 0),
        ],
        "BasicCAN after CR.RR in operating mode",
    );
}

// ---------------------------------------------------------------------------------------------
// Rule 2: access permissions
// ---------------------------------------------------------------------------------------------

/// The PeliCAN registers that only reset mode may write, with a test value each.
fn reset_mode_only_registers() -> Vec<(&'static str, u8, u8)> {
    vec![
        ("BTR0", pelican::BTR0, 0x43),
        ("BTR1", pelican::BTR1, 0xA5),
        ("OCR", pelican::OCR, 0xDA),
        ("EWLR", pelican::EWLR, 0x33),
        ("RXERR", pelican::RXERR, 0x11),
        ("TXERR", pelican::TXERR, 0x22),
        ("ACR0", pelican::ACR0, 0xA0),
        ("ACR1", pelican::ACR0 + 1, 0xA1),
        ("ACR2", pelican::ACR0 + 2, 0xA2),
        ("ACR3", pelican::ACR0 + 3, 0xA3),
        ("AMR0", pelican::AMR0, 0xB0),
        ("AMR1", pelican::AMR0 + 1, 0xB1),
        ("AMR2", pelican::AMR0 + 2, 0xB2),
        ("AMR3", pelican::AMR3, 0xB3),
        ("RBSA", pelican::RBSA, 0x25),
    ]
}

#[test]
fn pelican_configuration_registers_are_written_in_reset_mode() {
    let mut bench = pelican_in_reset_mode(1);
    let regs = reset_mode_only_registers();
    for &(_, addr, value) in &regs {
        bench.host(0).write(addr, value);
    }
    check_registers(&mut bench.host(0), &regs, "written in reset mode");
}

#[test]
fn pelican_configuration_registers_ignore_writes_in_operating_mode() {
    let mut bench = ControllerBench::operating(1);
    let regs = reset_mode_only_registers();
    let before: Vec<(&str, u8, u8)> = {
        let mut h = bench.host(0);
        h.write(pelican::MOD, mode::RM);
        let before = regs
            .iter()
            .map(|&(name, addr, _)| (name, addr, h.read(addr)))
            .collect();
        h.write(pelican::MOD, 0);
        before
    };
    bench.run_bits(INTEGRATION_BITS);
    for &(_, addr, value) in &regs {
        bench.host(0).write(addr, value);
    }
    // Counters and bus timing are readable in operating mode too.
    check_registers(
        &mut bench.host(0),
        &before[..6],
        "BTR, OCR, EWLR, counters after writes in operating mode",
    );
    bench.host(0).write(pelican::MOD, mode::RM);
    check_registers(
        &mut bench.host(0),
        &before,
        "every reset-mode-only register after writes in operating mode",
    );
}

#[test]
fn frame_window_is_acceptance_filter_in_reset_mode_and_tx_rx_buffer_in_operating_mode() {
    let mut bench = ControllerBench::operating(2);
    // Operating mode: 16..28 written = TX buffer (seen at 96..108), read = RX head message.
    let frame = std_frame(0x2A5, &[0x11, 0x22, 0x33, 0x44, 0x55]);
    send(&mut bench, 1, &frame, command::TR);
    let written: Vec<u8> = (0..13).map(|i| 0xC0 + i).collect();
    for (i, b) in written.iter().enumerate() {
        bench.host(0).write(pelican::FRAME + i as u8, *b);
    }
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::TX_RAM, 13),
        written,
        "TX buffer holds the bytes written at 16..28"
    );
    let buf = encode_buffer(&frame);
    let len = buffer_len(buf[0]);
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::FRAME, len),
        buf[..len].to_vec(),
        "16.. read the received message"
    );
    // Reset mode: 16..23 are ACR0..3/AMR0..3; TX buffer untouched (also at 24..28).
    bench.host(0).write(pelican::MOD, mode::RM);
    for i in 0..13u8 {
        bench.host(0).write(pelican::FRAME + i, 0x30 + i);
    }
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::ACR0, 8),
        (0x30..0x38).collect::<Vec<u8>>(),
        "ACR0..3, AMR0..3 at 16..23"
    );
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::TX_RAM, 13),
        written,
        "frame-window writes in reset mode do not reach the TX buffer"
    );
}

#[test]
fn mod_lom_stm_afm_change_only_in_reset_mode_and_the_old_rm_decides() {
    let mut bench = pelican_in_reset_mode(1);
    let mut h = bench.host(0);
    // One write from reset mode sets LOM and clears RM.
    h.write(pelican::MOD, mode::LOM);
    assert_eq!(h.read(pelican::MOD), mode::LOM, "LOM set, RM cleared");
    // Operating mode: STM/AFM cannot be set, LOM cannot be cleared.
    h.write(pelican::MOD, mode::STM | mode::AFM);
    assert_eq!(
        h.read(pelican::MOD),
        mode::LOM,
        "op-mode write keeps LOM/STM/AFM"
    );
    // Entering reset mode: the old RM (0) decides, the mode bits stay.
    h.write(pelican::MOD, mode::RM | mode::STM);
    assert_eq!(
        h.read(pelican::MOD),
        mode::RM | mode::LOM,
        "RM set, LOM kept, STM not set"
    );
    // In reset mode they change (and RM may stay).
    h.write(pelican::MOD, mode::RM | mode::STM | mode::AFM);
    assert_eq!(h.read(pelican::MOD), mode::RM | mode::STM | mode::AFM);
    // One write from reset mode: AFM only, RM cleared.
    h.write(pelican::MOD, mode::AFM);
    assert_eq!(h.read(pelican::MOD), mode::AFM);
}

#[test]
fn ier_is_writable_in_both_modes() {
    let mut bench = pelican_in_reset_mode(1);
    let mut h = bench.host(0);
    h.write(pelican::IER, 0x5A);
    assert_eq!(h.read(pelican::IER), 0x5A, "reset mode");
    h.write(pelican::MOD, 0);
    h.write(pelican::IER, 0xA5);
    assert_eq!(h.read(pelican::IER), 0xA5, "operating mode");
}

#[test]
fn cdr_bits_7_and_3_change_in_reset_mode_only_bits_2_to_0_always() {
    let mut bench = pelican_in_reset_mode(1);
    let mut h = bench.host(0);
    h.write(
        pelican::CDR,
        clock_divider::PELICAN | clock_divider::CLOCK_OFF | 5,
    );
    assert_eq!(
        h.read(pelican::CDR),
        clock_divider::PELICAN | clock_divider::CLOCK_OFF | 5,
        "reset mode: every bit"
    );
    h.write(pelican::MOD, 0);
    // Operating mode: try to leave PeliCAN and switch the clock on; only the divider changes.
    h.write(pelican::CDR, 2);
    assert_eq!(
        h.read(pelican::CDR),
        clock_divider::PELICAN | clock_divider::CLOCK_OFF | 2,
        "operating mode: bits 2..0 only"
    );
    assert_eq!(h.read(pelican::MOD), 0, "still the PeliCAN map");
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::CDR, 7);
    assert_eq!(
        h.read(basic::CDR),
        7,
        "reset mode: back to BasicCAN, clock on"
    );
    assert_eq!(
        h.read(basic::CR) & (control::RR | control::ALWAYS_ONE),
        control::RR | control::ALWAYS_ONE,
        "the BasicCAN map is selected (CR at 0)"
    );
}

#[test]
fn tx_buffer_is_written_in_operating_mode_only_while_tbs_is_set() {
    let mut bench = ControllerBench::operating(2);
    let first = std_frame(0x155, &[1, 2, 3, 4, 5, 6, 7, 8]);
    let second = std_frame(0x0AA, &[0xF0, 0x0F]);
    transmit(&mut bench.host(0), &first, command::TR);
    bench.run_bits(5);
    assert_eq!(
        bench.host(0).read(pelican::SR) & status::TBS,
        0,
        "buffer locked"
    );
    let buf2 = encode_buffer(&second);
    for (i, b) in buf2.iter().enumerate() {
        bench.host(0).write(pelican::FRAME + i as u8, *b);
    }
    run_until_tx_done(&mut bench, 0, 200);
    let buf1 = encode_buffer(&first);
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::TX_RAM, 13),
        buf1.to_vec(),
        "writes while TBS = 0 are lost"
    );
    assert_eq!(
        drain_rx(&mut bench.host(1)),
        vec![first],
        "first frame sent unchanged"
    );
    for (i, b) in buf2.iter().enumerate() {
        bench.host(0).write(pelican::FRAME + i as u8, *b);
    }
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::TX_RAM, 13),
        buf2.to_vec(),
        "writes with TBS = 1 land"
    );
}

#[test]
fn ram_windows_are_writable_in_reset_mode_only() {
    let mut bench = pelican_in_reset_mode(1);
    let rx_pattern: Vec<u8> = (0..64).map(|i| 0x80 ^ (i as u8 * 3)).collect();
    let tx_pattern: Vec<u8> = (0..13).map(|i| 0x40 + i as u8).collect();
    for (i, b) in rx_pattern.iter().enumerate() {
        bench.host(0).write(pelican::RX_RAM + i as u8, *b);
    }
    for (i, b) in tx_pattern.iter().enumerate() {
        bench.host(0).write(pelican::TX_RAM + i as u8, *b);
    }
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::RX_RAM, 64),
        rx_pattern
    );
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::TX_RAM, 13),
        tx_pattern
    );
    leave_reset_mode(&mut bench, 0, 0);
    for i in 0..64u8 {
        bench.host(0).write(pelican::RX_RAM + i, 0x00);
    }
    for i in 0..13u8 {
        bench.host(0).write(pelican::TX_RAM + i, 0x00);
    }
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::RX_RAM, 64),
        rx_pattern,
        "RX RAM not written in operating mode"
    );
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::TX_RAM, 13),
        tx_pattern,
        "TX RAM window not written in operating mode"
    );
}

#[test]
fn rbsa_written_in_reset_mode_places_the_next_message() {
    let mut bench = pelican_in_reset_mode(2);
    bench.host(0).write(pelican::RBSA, 40);
    leave_reset_mode(&mut bench, 0, 0);
    leave_reset_mode(&mut bench, 1, 0);
    bench.host(0).write(pelican::RBSA, 3); // operating mode: ignored
    let frame = std_frame(0x3C3, &[0xAB, 0xCD]);
    send(&mut bench, 1, &frame, command::TR);
    assert_eq!(bench.host(0).read(pelican::RBSA), 40);
    let buf = encode_buffer(&frame);
    assert_eq!(
        read_bytes(&mut bench.host(0), pelican::RX_RAM + 40, 5),
        buf[..5].to_vec(),
        "message stored from FIFO byte 40"
    );
    assert_eq!(read_rx_message(&mut bench.host(0)), frame);
}

#[test]
fn reserved_addresses_read_0_in_both_modes() {
    let mut bench = pelican_in_reset_mode(1);
    let addrs = pelican_reserved_addresses();
    for &a in &addrs {
        bench.host(0).write(a, 0xFF);
    }
    let reads: Vec<(u8, u8)> = addrs.iter().map(|&a| (a, bench.host(0).read(a))).collect();
    assert!(reads.iter().all(|&(_, v)| v == 0), "reset mode: {reads:?}");
    leave_reset_mode(&mut bench, 0, 0);
    for &a in &addrs {
        bench.host(0).write(a, 0xFF);
    }
    let reads: Vec<(u8, u8)> = addrs.iter().map(|&a| (a, bench.host(0).read(a))).collect();
    assert!(
        reads.iter().all(|&(_, v)| v == 0),
        "operating mode: {reads:?}"
    );
}

#[test]
fn cmr_reads_0_in_pelican_and_ff_in_basic_can_in_both_modes() {
    let mut bench = pelican_in_reset_mode(1);
    assert_eq!(
        bench.host(0).read(pelican::CMR),
        0x00,
        "PeliCAN, reset mode"
    );
    bench.host(0).write(pelican::MOD, 0);
    assert_eq!(
        bench.host(0).read(pelican::CMR),
        0x00,
        "PeliCAN, operating mode"
    );
    bench.host(0).write(pelican::MOD, mode::RM);
    bench.host(0).write(pelican::CDR, 0);
    assert_eq!(bench.host(0).read(basic::CMR), 0xFF, "BasicCAN, reset mode");
    bench.host(0).write(basic::CR, 0);
    assert_eq!(
        bench.host(0).read(basic::CMR),
        0xFF,
        "BasicCAN, operating mode"
    );
}

// ---------------------------------------------------------------------------------------------
// Rule 3: commands
// ---------------------------------------------------------------------------------------------

#[test]
fn tr_clears_tbs_and_tcs_sets_ts_during_the_frame_then_tbs_tcs_and_ti() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x456, &[0xDE, 0xAD]);
    assert_eq!(
        bench.host(0).read(pelican::SR),
        status::TBS | status::TCS,
        "idle"
    );
    transmit(&mut bench.host(0), &frame, command::TR);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        0,
        "TR clears TBS and TCS"
    );
    bench.run_bits(5);
    let sr = bench.host(0).read(pelican::SR);
    assert_eq!(
        sr & (status::TS | status::TBS | status::TCS),
        status::TS,
        "transmitting (SR {sr:#04x})"
    );
    let sr1 = bench.host(1).read(pelican::SR);
    assert_eq!(
        sr1 & (status::TS | status::RS),
        status::RS,
        "the receiver: RS, not TS (SR {sr1:#04x})"
    );
    assert_eq!(bench.host(0).read(pelican::IR), 0, "no TI while sending");
    assert!(bench.run_until_irq(0, 100), "TI at the end");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::TI);
    assert_eq!(
        bench.host(0).read(pelican::SR),
        status::TBS | status::TCS,
        "done: TBS, TCS, not TS"
    );
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);
}

#[test]
fn a_receiver_shows_rs_but_never_ts_even_while_it_drives_ack_or_an_error_flag() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x2D2, &[0x12, 0x34]);
    let enc = encode(&frame);
    transmit(&mut bench.host(0), &frame, command::TR);
    let sof = bench.run_until_sof(0, 20);
    // The receiver sees a dominant CRC delimiter: form error, error flag; then the retransmission
    // is acknowledged.
    let crc_delim = enc.position(Field::CrcDelim, 0).unwrap();
    bench.force_seen_bit(1, sof, crc_delim, DOMINANT);
    let mut seen = 0u8;
    let mut ack_or_flag = false;
    let end = sof + 2 * (enc.len() as u64 + 30) * bench_bit_fs();
    while bench.engine.now() < end {
        bench.host(1).idle(7);
        seen |= bench.host(1).read(pelican::SR);
        ack_or_flag |= !bench.node(1).tx();
    }
    assert!(ack_or_flag, "the receiver drove dominant bits");
    assert_eq!(
        bench.host(1).read(pelican::ECC),
        ecc(ecc::FORM, true, ecc::SEG_CRC_DELIM)
    );
    assert_eq!(
        seen & (status::RS | status::TS),
        status::RS,
        "RS seen, TS never"
    );
    assert_eq!(
        drain_rx(&mut bench.host(1)),
        vec![frame],
        "the retransmission arrived"
    );
}

#[test]
fn at_before_the_frame_starts_cancels_the_request_tcs_0_tbs_1_ti() {
    let mut bench = ControllerBench::operating(2);
    // Node 1's frame keeps the bus busy while node 0's request waits.
    transmit(
        &mut bench.host(1),
        &std_frame(0x001, &[0x77; 4]),
        command::TR,
    );
    bench.run_bits(3);
    transmit(&mut bench.host(0), &std_frame(0x7F0, &[1, 2]), command::TR);
    assert_eq!(
        bench.host(0).read(pelican::SR) & status::TBS,
        0,
        "request pending"
    );
    bench.run_bits(2);
    bench.host(0).write(pelican::CMR, command::AT);
    bench.run_bits(1);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS | status::TS),
        status::TBS,
        "aborted: TBS = 1, TCS = 0, not transmitting"
    );
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::TI,
        "TI for the release"
    );
    run_until_tx_done(&mut bench, 1, 200);
    bench.run_bits(100);
    assert_eq!(
        bench.host(1).read(pelican::RMC),
        0,
        "the aborted frame never went on the bus"
    );
    assert_eq!(
        bench.host(0).read(pelican::RMC),
        1,
        "node 0 received node 1's frame"
    );
}

#[test]
fn at_without_a_pending_request_does_nothing() {
    let mut bench = ControllerBench::operating(1);
    bench.host(0).write(pelican::CMR, command::AT);
    bench.run_bits(3);
    assert_eq!(bench.host(0).read(pelican::IR), 0, "no TI");
    assert_eq!(bench.host(0).read(pelican::SR), status::TBS | status::TCS);
}

#[test]
fn at_during_the_own_frame_lets_it_finish_and_a_success_sets_tcs() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x321, &[1, 2, 3]);
    transmit(&mut bench.host(0), &frame, command::TR);
    run_until_status(&mut bench, 0, status::TS, status::TS, 5);
    bench.host(0).write(pelican::CMR, command::AT);
    assert_eq!(
        bench.host(0).read(pelican::SR) & status::TS,
        status::TS,
        "still sending"
    );
    run_until_tx_done(&mut bench, 0, 200);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        status::TBS | status::TCS,
        "the frame on the bus finished successfully"
    );
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::TI);
    bench.run_bits(100);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame], "sent once");
}

#[test]
fn at_during_the_own_frame_that_fails_gives_no_retransmission() {
    // A lone node: no ACK, so every attempt fails with an ACK error (TEC + 8).
    let mut bench = ControllerBench::operating(1);
    transmit(&mut bench.host(0), &std_frame(0x321, &[1]), command::TR);
    run_until_status(&mut bench, 0, status::TS, status::TS, 5);
    bench.host(0).write(pelican::CMR, command::AT);
    bench.run_bits(300);
    assert_eq!(bench.host(0).read(pelican::TXERR), 8, "one attempt only");
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS | status::TS),
        status::TBS,
        "released, not completed, bus left alone"
    );
    assert_eq!(
        bench.host(0).read(pelican::IR) & interrupt::TI,
        interrupt::TI
    );
}

#[test]
fn tr_at_single_shot_without_ack_fails_once_with_the_ack_error_captured() {
    let mut bench = ControllerBench::operating(1);
    transmit(
        &mut bench.host(0),
        &std_frame(0x0F0, &[0x5A]),
        command::TR | command::AT,
    );
    run_until_tx_done(&mut bench, 0, 200);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        status::TBS,
        "TBS = 1, TCS = 0"
    );
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::TI | interrupt::BEI,
        "TI and the bus error"
    );
    assert_eq!(
        bench.host(0).read(pelican::ECC),
        ecc(ecc::OTHER, false, ecc::SEG_ACK_SLOT),
        "ACK error while transmitting, in the ACK slot"
    );
    assert_eq!(bench.host(0).read(pelican::TXERR), 8);
    bench.run_bits(300);
    assert_eq!(bench.host(0).read(pelican::TXERR), 8, "no second attempt");
}

#[test]
fn tr_at_single_shot_with_ack_succeeds() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x0F0, &[0x5A, 0xA5]);
    send(&mut bench, 0, &frame, command::TR | command::AT);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        status::TBS | status::TCS
    );
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::TI);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);
    assert_eq!(bench.host(0).read(pelican::RMC), 0, "no self-reception");
}

#[test]
fn srr_sends_and_stores_the_own_frame_when_another_node_acks() {
    let mut bench = ControllerBench::operating(2);
    let frame = ext_frame(0x0ABC_DEF1, &[1, 2, 3, 4, 5]);
    send(&mut bench, 0, &frame, command::SRR);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS | status::RBS),
        status::TBS | status::TCS | status::RBS
    );
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::TI | interrupt::RI
    );
    assert_eq!(
        drain_rx(&mut bench.host(0)),
        vec![frame],
        "own frame stored"
    );
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame], "and sent");
}

#[test]
fn srr_at_single_shot_stores_the_own_frame_on_success() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x1F1, &[7]);
    send(&mut bench, 0, &frame, command::SRR | command::AT);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        status::TBS | status::TCS
    );
    assert_eq!(drain_rx(&mut bench.host(0)), vec![frame]);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);
}

#[test]
fn srr_at_single_shot_without_ack_fails_once_and_stores_nothing() {
    let mut bench = ControllerBench::operating(1);
    transmit(
        &mut bench.host(0),
        &std_frame(0x1F1, &[7]),
        command::SRR | command::AT,
    );
    run_until_tx_done(&mut bench, 0, 200);
    bench.run_bits(200);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS | status::RBS),
        status::TBS,
        "failed, nothing stored"
    );
    assert_eq!(bench.host(0).read(pelican::TXERR), 8, "one attempt");
    assert_eq!(
        bench.host(0).read(pelican::IR) & interrupt::TI,
        interrupt::TI
    );
}

#[test]
fn srr_stores_the_own_frame_only_if_the_acceptance_filter_passes_it() {
    let mut bench = pelican_in_reset_mode(2);
    // Node 0, single filter: ID.28..21 must be 0x24, the rest is don't care.
    bench.host(0).write(pelican::ACR0, 0x24);
    bench.host(0).write(pelican::AMR0, 0x00);
    leave_reset_mode(&mut bench, 0, mode::AFM);
    leave_reset_mode(&mut bench, 1, 0);
    let rejected = std_frame(0x300, &[1]);
    let accepted = std_frame(0x125, &[2]);
    send(&mut bench, 0, &rejected, command::SRR);
    send(&mut bench, 0, &accepted, command::SRR);
    assert_eq!(drain_rx(&mut bench.host(0)), vec![accepted]);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![rejected, accepted]);
}

/// The acceptance filter compares the data bytes after they arrive, reading ACR/AMR from the TX
/// buffer in the clocks the protocol engine leaves it; at the fastest bit timing that carries frames
/// between two controllers on this bench (BTR0 = 0x00, BTR1 = 0x02: 5 quanta of 2 clocks, 10 clocks
/// a bit, data sheet 6.5.1/6.5.2; a TSEG1 of 1 or 2 quanta carries none) its reads still end before
/// the next byte and the frame's end. Data sheet 6.4.15, single filter, standard frame: ACR2 is
/// data byte 1, ACR3 data byte 2 (identifier and RTR don't care here).
#[test]
fn the_filter_compares_data_bytes_at_the_fastest_bit_timing() {
    let fastest = golden::btr::Btr::from_registers(0x00, 0x02);
    let mut bench = ControllerBench::new(2);
    for n in 0..2 {
        configure_pelican_for(&mut bench.host(n), fastest);
    }
    let receiver = 1;
    // ACR0..3 at ACR0 + k, AMR0..3 at AMR0 + k.
    for (register, value) in [
        (pelican::ACR0 + 2, 0xA5),
        (pelican::ACR0 + 3, 0x3C),
        (pelican::AMR0, 0xFF),
        (pelican::AMR0 + 1, 0xFF),
        (pelican::AMR0 + 2, 0x00),
        (pelican::AMR3, 0x00),
    ] {
        bench.host(receiver).write(register, value);
    }
    leave_reset_mode(&mut bench, 0, 0);
    leave_reset_mode(&mut bench, receiver, mode::AFM);
    let frames = [
        std_frame(0x101, &[0xA5, 0x3C, 1, 2, 3, 4, 5, 6]),
        std_frame(0x102, &[0xA5, 0x3D]),
        std_frame(0x103, &[0xA4, 0x3C]),
        std_frame(0x104, &[0xA5]),
        std_frame(0x105, &[0xA5, 0x3C]),
    ];
    for frame in &frames {
        send(&mut bench, 0, frame, command::TR);
    }
    assert_eq!(
        drain_rx(&mut bench.host(receiver)),
        vec![frames[0], frames[3], frames[4]],
        "frames whose data bytes 1 and 2 (those present) equal ACR2 and ACR3"
    );
}

#[test]
fn tr_with_srr_is_a_plain_tr() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x222, &[2, 2]);
    send(&mut bench, 0, &frame, command::TR | command::SRR);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TCS | status::RBS),
        status::TCS,
        "sent, not received by itself"
    );
    assert_eq!(bench.host(0).read(pelican::RMC), 0);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);
}

#[test]
fn tr_srr_at_is_a_single_shot_without_self_reception() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x246, &[6]);
    send(
        &mut bench,
        0,
        &frame,
        command::TR | command::SRR | command::AT,
    );
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TCS | status::RBS),
        status::TCS,
        "sent, not received by itself"
    );
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);
    // Single shot: with nobody acknowledging, one attempt only.
    bench.host(1).write(pelican::MOD, mode::RM);
    transmit(
        &mut bench.host(0),
        &frame,
        command::TR | command::SRR | command::AT,
    );
    run_until_tx_done(&mut bench, 0, 200);
    bench.run_bits(200);
    assert_eq!(bench.host(0).read(pelican::TXERR), 8, "one attempt");
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TCS | status::RBS),
        0
    );
}

#[test]
fn rrb_releases_the_head_moves_rbsa_by_its_length_and_re_evaluates_rbs_and_ri() {
    let mut bench = ControllerBench::operating(2);
    bench.host(0).write(pelican::IER, interrupt::RI);
    let frames = [
        std_frame(0x101, &[1, 2]),
        ext_frame(0x0123_4567, &[3, 4, 5]),
        std_remote(0x202, 4),
    ];
    for f in &frames {
        send(&mut bench, 1, f, command::TR);
    }
    bench.run_bits(5);
    assert_eq!(bench.host(0).read(pelican::RMC), 3);
    assert_eq!(bench.host(0).read(pelican::RBSA), 0);
    let mut rbsa = 0;
    for (k, f) in frames.iter().enumerate() {
        assert_eq!(read_rx_message(&mut bench.host(0)), *f, "head message {k}");
        assert!(bench.node(0).irq(), "RI while a message is stored");
        bench.host(0).write(pelican::CMR, command::RRB);
        rbsa += fifo_len(f);
        let left = (frames.len() - k - 1) as u8;
        check_registers(
            &mut bench.host(0),
            &[
                ("RMC", pelican::RMC, left),
                ("RBSA", pelican::RBSA, rbsa),
                (
                    "SR.RBS",
                    pelican::SR,
                    (left > 0) as u8 | status::TBS | status::TCS,
                ),
                ("IR", pelican::IR, (left > 0) as u8),
            ],
            &format!("after RRB {k}"),
        );
    }
    assert!(!bench.node(0).irq(), "RI gone with the last message");
    bench.host(0).write(pelican::CMR, command::RRB);
    assert_eq!(
        (
            bench.host(0).read(pelican::RMC),
            bench.host(0).read(pelican::RBSA)
        ),
        (0, rbsa),
        "RRB on an empty FIFO changes nothing"
    );
}

#[test]
fn cdo_clears_dos_and_keeps_the_stored_messages() {
    let mut bench = ControllerBench::operating(2);
    let frames: Vec<Frame> = (0..6u8)
        .map(|k| std_frame(0x300 + k as u16, &[k; 8]))
        .collect();
    for f in &frames {
        send(&mut bench, 1, f, command::TR);
    }
    bench.run_bits(5);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::DOS | status::RBS),
        status::DOS | status::RBS,
        "the sixth message overran"
    );
    assert_eq!(bench.host(0).read(pelican::RMC), 5);
    bench.host(0).write(pelican::CMR, command::CDO);
    assert_eq!(
        bench.host(0).read(pelican::SR) & status::DOS,
        0,
        "CDO clears DOS"
    );
    assert_eq!(drain_rx(&mut bench.host(0)), frames[..5].to_vec());
}

#[test]
fn commands_are_ignored_in_reset_mode() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x135, &[1, 3, 5]);
    let buf = encode_buffer(&frame);
    for (i, b) in buf.iter().take(buffer_len(buf[0])).enumerate() {
        bench.host(0).write(pelican::FRAME + i as u8, *b);
    }
    bench.host(0).write(pelican::MOD, mode::RM);
    for cmd in [
        command::TR,
        command::SRR,
        command::TR | command::AT,
        command::SRR | command::AT,
    ] {
        bench.host(0).write(pelican::CMR, cmd);
        assert_eq!(
            bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
            status::TBS | status::TCS,
            "CMR {cmd:#04x} in reset mode: no request"
        );
    }
    leave_reset_mode(&mut bench, 0, 0);
    bench.run_bits(150);
    assert_eq!(bench.host(1).read(pelican::RMC), 0, "nothing was sent");
    assert_eq!(bench.host(0).read(pelican::IR), 0, "no TI");
    assert_eq!(
        bench.host(0).read(pelican::SR),
        status::TBS | status::TCS,
        "still idle"
    );
}

// ---------------------------------------------------------------------------------------------
// Rule 4: interrupts
// ---------------------------------------------------------------------------------------------

#[test]
fn reading_ir_clears_every_bit_but_ri() {
    let mut bench = ControllerBench::operating(2);
    send(&mut bench, 0, &std_frame(0x111, &[1]), command::SRR);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::TI | interrupt::RI
    );
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::RI, "RI stays");
    assert!(bench.node(0).irq(), "RI still asserts irq_n");
}

#[test]
fn ri_is_rbs_and_rie_as_a_level_and_irq_n_follows_it() {
    let mut bench = ControllerBench::operating(2);
    bench.host(0).write(pelican::IER, 0);
    send(&mut bench, 1, &std_frame(0x111, &[1]), command::TR);
    bench.run_bits(5);
    assert_eq!(bench.host(0).read(pelican::SR) & status::RBS, status::RBS);
    assert_eq!(bench.host(0).read(pelican::IR), 0, "RIE = 0: no RI");
    assert!(!bench.node(0).irq());
    bench.host(0).write(pelican::IER, interrupt::RI);
    assert!(bench.node(0).irq(), "RIE set: RI = RBS, irq_n low");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::RI);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::RI,
        "a read does not clear RI"
    );
    bench.host(0).write(pelican::IER, 0);
    assert!(!bench.node(0).irq(), "RIE cleared: irq_n rises");
    assert_eq!(bench.host(0).read(pelican::IR), 0, "and RI reads 0");
    bench.host(0).write(pelican::IER, interrupt::RI);
    assert!(bench.node(0).irq(), "RI back with RIE");
    bench.host(0).write(pelican::CMR, command::RRB);
    bench.host(0).idle(1);
    assert!(!bench.node(0).irq(), "FIFO empty: RI drops");
    assert_eq!(bench.host(0).read(pelican::IR), 0);
}

#[test]
fn ti_is_set_only_when_tie_is_set() {
    let mut bench = ControllerBench::operating(2);
    bench.host(0).write(pelican::IER, 0);
    send(&mut bench, 0, &std_frame(0x111, &[1]), command::TR);
    bench.host(0).write(pelican::IER, interrupt::TI);
    assert_eq!(bench.host(0).read(pelican::IR), 0, "TIE was 0 at TBS 0->1");
    assert!(!bench.node(0).irq());
    transmit(&mut bench.host(0), &std_frame(0x111, &[2]), command::TR);
    assert!(bench.run_until_irq(0, 200), "TI with TIE");
    assert_eq!(bench.host(0).read(pelican::SR) & status::TBS, status::TBS);
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::TI);
    assert!(!bench.node(0).irq(), "read cleared TI");
}

#[test]
fn irq_n_is_low_exactly_while_ir_and_ier_overlap() {
    let mut bench = ControllerBench::operating(2);
    bench.host(0).write(pelican::IER, interrupt::TI);
    assert!(!bench.node(0).irq(), "nothing pending");
    transmit(&mut bench.host(0), &std_frame(0x111, &[1]), command::TR);
    // irq_n follows the IR & IER at every clock until TI.
    let id = bench.id(0);
    let limit = bench.engine.now() + 200 * bench_bit_fs();
    bench
        .engine
        .run_while(limit, |e| e.device::<ControllerNode>(id).irq())
        .unwrap();
    assert_eq!(
        bench.host(0).read(pelican::SR) & status::TBS,
        status::TBS,
        "irq_n low at TI"
    );
    bench.host(0).write(pelican::IER, interrupt::RI);
    assert!(!bench.node(0).irq(), "TI pending but disabled: irq_n high");
    bench
        .host(0)
        .write(pelican::IER, interrupt::RI | interrupt::TI);
    let ir = bench.host(0).read(pelican::IR);
    assert_eq!(ir & interrupt::RI, 0);
    assert!(!bench.node(0).irq(), "after the IR read nothing is pending");
}

#[test]
fn ei_is_set_on_each_es_change_only_when_eie_is_set() {
    let mut bench = pelican_in_reset_mode(1);
    let mut h = bench.host(0);
    h.write(pelican::IER, 0);
    h.write(pelican::RXERR, 100);
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(h.read(pelican::SR) & status::ES, status::ES, "ES set");
    assert_eq!(h.read(pelican::IR), 0, "EIE = 0: no EI");
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::IER, interrupt::EI);
    h.write(pelican::RXERR, 0);
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(h.read(pelican::SR) & status::ES, 0, "ES cleared");
    assert!(h.node().irq());
    assert_eq!(h.read(pelican::IR), interrupt::EI, "EI on ES 1 -> 0");
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::TXERR, DEFAULT_EWLR);
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(
        h.read(pelican::SR) & status::ES,
        status::ES,
        "TXERR = EWLR: ES"
    );
    assert_eq!(h.read(pelican::IR), interrupt::EI, "EI on ES 0 -> 1");
}

#[test]
fn epi_is_set_on_both_passive_changes_only_when_epie_is_set() {
    let mut bench = pelican_in_reset_mode(1);
    let mut h = bench.host(0);
    h.write(pelican::IER, 0);
    h.write(pelican::RXERR, 128);
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(
        h.read(pelican::IR),
        0,
        "EPIE = 0: no EPI when becoming passive"
    );
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::IER, interrupt::EPI);
    h.write(pelican::RXERR, 127);
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(h.read(pelican::IR), interrupt::EPI, "passive -> active");
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::TXERR, 128);
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(h.read(pelican::IR), interrupt::EPI, "active -> passive");
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::TXERR, 200);
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(h.read(pelican::IR), 0, "passive -> passive: no EPI");
}

#[test]
fn doi_is_set_once_per_overrun_only_when_doie_is_set_until_cdo() {
    let mut bench = ControllerBench::operating(2);
    bench.host(0).write(pelican::IER, 0);
    let frame = |k: u16| std_frame(0x300 + k, &[k as u8; 8]);
    for k in 0..6 {
        send(&mut bench, 1, &frame(k), command::TR);
    }
    bench.run_bits(5);
    assert_eq!(bench.host(0).read(pelican::SR) & status::DOS, status::DOS);
    assert_eq!(bench.host(0).read(pelican::IR), 0, "DOIE = 0: no DOI");
    bench.host(0).write(pelican::CMR, command::CDO);
    bench.host(0).write(pelican::IER, interrupt::DOI);
    send(&mut bench, 1, &frame(6), command::TR);
    bench.run_bits(5);
    assert_eq!(bench.host(0).read(pelican::SR) & status::DOS, status::DOS);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::DOI,
        "overrun with DOIE"
    );
    send(&mut bench, 1, &frame(7), command::TR);
    bench.run_bits(5);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        0,
        "no further DOI while DOS = 1"
    );
    bench.host(0).write(pelican::CMR, command::CDO);
    send(&mut bench, 1, &frame(8), command::TR);
    bench.run_bits(5);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::DOI,
        "again after CDO"
    );
    assert_eq!(bench.host(0).read(pelican::RMC), 5);
}

#[test]
fn wui_on_wake_up_by_bus_activity_and_the_waking_frame_is_not_received() {
    // Node 2 acknowledges, so node 1's frame goes out once.
    let mut bench = ControllerBench::operating(3);
    bench.host(0).write(pelican::IER, interrupt::WUI);
    bench.host(0).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(0).read(pelican::MOD), mode::SM, "asleep");
    transmit(&mut bench.host(1), &std_frame(0x0AB, &[1, 2]), command::TR);
    assert!(bench.run_until_irq(0, 20), "WUI");
    assert_eq!(bench.host(0).read(pelican::MOD), 0, "awake");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::WUI);
    run_until_tx_done(&mut bench, 1, 200);
    bench.run_bits(5);
    assert_eq!(
        bench.host(0).read(pelican::RMC),
        0,
        "the waking frame is lost"
    );
}

#[test]
fn wui_is_set_only_when_wuie_is_set() {
    let mut bench = ControllerBench::operating(1);
    bench.host(0).write(pelican::IER, 0);
    bench.host(0).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(0).read(pelican::MOD), mode::SM);
    bench.host(0).write(pelican::MOD, 0);
    assert_eq!(bench.host(0).read(pelican::MOD), 0, "woken by the host");
    assert_eq!(bench.host(0).read(pelican::IR), 0, "WUIE = 0: no WUI");
    // After sleep the node integrates again; only then may it sleep (bus idle).
    bench.run_bits(INTEGRATION_BITS);
    bench.host(0).write(pelican::IER, interrupt::WUI);
    bench.host(0).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(0).read(pelican::MOD), mode::SM);
    bench.host(0).write(pelican::MOD, 0);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::WUI,
        "WUI with WUIE"
    );
}

#[test]
fn sm_with_an_interrupt_pending_gives_wui_at_once_and_no_sleep() {
    let mut bench = ControllerBench::operating(2);
    bench
        .host(0)
        .write(pelican::IER, interrupt::TI | interrupt::WUI);
    send(&mut bench, 0, &std_frame(0x0AB, &[1]), command::TR);
    assert!(bench.node(0).irq(), "TI pending");
    bench.host(0).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(0).read(pelican::MOD), 0, "not asleep");
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::TI | interrupt::WUI
    );
}

#[test]
fn sm_while_the_bus_is_active_gives_wui_at_once_and_no_sleep() {
    let mut bench = ControllerBench::operating(2);
    bench.host(0).write(pelican::IER, interrupt::WUI);
    transmit(
        &mut bench.host(1),
        &std_frame(0x0AB, &[1, 2, 3]),
        command::TR,
    );
    bench.run_bits(10);
    bench.host(0).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(0).read(pelican::MOD), 0, "not asleep");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::WUI);
    run_until_tx_done(&mut bench, 1, 200);
    bench.run_bits(5);
    assert_eq!(
        bench.host(0).read(pelican::RMC),
        1,
        "the frame was received"
    );
}

// ---------------------------------------------------------------------------------------------
// Rule 5: ALC and ECC capture until read
// ---------------------------------------------------------------------------------------------

/// Bits of the intermission after a frame on the LT script.
const INTERMISSION: usize = 3;

/// One controller (IER = `ier`, integrated) transmitting `mine` against a lower tester that plays
/// each of `lt_frames` from one of its attempts' SOF on (script bit 0 = the controller's first SOF),
/// with an intermission after each; with `ack_after`, the controller's next attempt after them is
/// acknowledged.
fn arbitration_bench(
    ier: u8,
    mine: &Frame,
    lt_frames: &[Frame],
    ack_after: bool,
) -> ControllerBench {
    let mut bench = ControllerBench::with_lower_tester();
    // Before the first clock edge: the LT waits for the controller's SOF.
    bench.lt().start_on_dominant();
    configure_pelican(&mut bench.host(0));
    bench.host(0).write(pelican::IER, ier);
    for f in lt_frames {
        bench
            .lt()
            .send_bits(encode(f).bits.iter().by_vals())
            .release(INTERMISSION);
    }
    if ack_after {
        let enc = encode(mine);
        let sof = bench.lt().script_len();
        bench.lt().release(enc.len() + 2);
        let ack = sof + enc.position(Field::AckSlot, 0).unwrap();
        bench.lt().set_bit(ack, Drive::Dominant);
    }
    leave_reset_mode(&mut bench, 0, 0);
    transmit(&mut bench.host(0), mine, command::TR);
    bench
}

/// Runs until the lower tester's script bit `bit` starts (first until the LT starts).
fn run_to_lt_bit(bench: &mut ControllerBench, bit: usize) {
    for _ in 0..100 {
        if bench.lt().started_at().is_some() {
            break;
        }
        bench.run_bits(1);
    }
    let at = bench.lt().bit_time(bit).expect("LT started");
    bench.engine.run_until(at).expect("simulation");
}

/// (frame of the controller, frame of the LT that wins, expected ALC).
fn arbitration_cases() -> Vec<(Frame, Frame, u8)> {
    let mut cases = Vec::new();
    let all_ones_std = std_frame(0x7FF, &[0x11]);
    for k in 0..=10u8 {
        let theirs = std_frame(0x7FF & !(1 << (10 - k)), &[0x22]);
        cases.push((all_ones_std, theirs, k));
    }
    // 11: RTR of a standard frame, and SRR of an extended one against a standard data frame.
    cases.push((std_remote(0x7FF, 1), std_frame(0x7FF, &[0x22]), 11));
    let all_ones_ext = ext_frame(0x1FFF_FFFF, &[0x11]);
    cases.push((all_ones_ext, std_frame(0x7FF, &[0x22]), 11));
    // 12: IDE (a standard remote frame has SRR = RTR recessive too).
    cases.push((all_ones_ext, std_remote(0x7FF, 0), 12));
    for j in 0..18u8 {
        let theirs = ext_frame(0x1FFF_FFFF & !(1 << (17 - j)), &[0x22]);
        cases.push((all_ones_ext, theirs, 13 + j));
    }
    // 31: RTR of an extended frame.
    cases.push((
        ext_remote(0x1FFF_FFFF, 1),
        ext_frame(0x1FFF_FFFF, &[0x22]),
        31,
    ));
    cases
}

#[test]
fn alc_is_the_position_of_the_first_differing_arbitration_bit() {
    for (mine, theirs, alc) in arbitration_cases() {
        let mut bench = arbitration_bench(interrupt::ALI, &mine, &[theirs], false);
        assert!(bench.run_until_irq(0, 80), "{mine} vs {theirs}: ALI");
        assert_eq!(
            bench.host(0).read(pelican::ALC),
            alc,
            "{mine} loses to {theirs}"
        );
        assert_eq!(bench.host(0).read(pelican::IR), interrupt::ALI);
    }
}

#[test]
fn ar_09_alc_keeps_the_first_loss_until_read() {
    let mine = ext_frame(0x1FFF_FFFF, &[0x11]);
    // Loss 1 at ID.12 (extended bit 5): ALC 18. Loss 2 at SRR: ALC 11. Loss 3 at ID.25: ALC 3.
    let first = ext_frame(0x1FFF_FFFF & !(1 << 12), &[0x22]);
    let second = std_frame(0x7FF, &[0x33, 0x44]);
    let third = ext_frame(0x1FFF_FFFF & !(1 << 25), &[0x55]);
    let sof_2 = encode(&first).len() + INTERMISSION;
    let sof_3 = sof_2 + encode(&second).len() + INTERMISSION;
    let mut bench = arbitration_bench(
        interrupt::ALI | interrupt::TI,
        &mine,
        &[first, second, third],
        true,
    );
    assert!(bench.run_until_irq(0, 60), "ALI at the first loss");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::ALI);
    // Past the second loss (the second LT frame is over) without reading ALC.
    run_to_lt_bit(&mut bench, sof_3 - 1);
    assert!(!bench.node(0).irq(), "no ALI for the second loss");
    assert_eq!(bench.host(0).read(pelican::IR), 0);
    assert_eq!(
        bench.host(0).read(pelican::ALC),
        18,
        "the first loss is kept"
    );
    assert_eq!(
        bench.host(0).read(pelican::ALC),
        18,
        "reading does not clear ALC"
    );
    // ALC read: the third loss is captured with a new ALI.
    assert!(bench.run_until_irq(0, 60), "ALI at the third loss");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::ALI);
    assert_eq!(bench.host(0).read(pelican::ALC), 3, "the third loss");
    assert!(bench.run_until_irq(0, 200), "TI");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::TI);
    assert_eq!(
        bench.host(0).read(pelican::SR) & status::TCS,
        status::TCS,
        "the fourth attempt succeeded"
    );
    assert_eq!(
        drain_rx(&mut bench.host(0)),
        vec![first, second, third],
        "the three winners were received"
    );
}

#[test]
fn ali_needs_alie_but_alc_captures_anyway() {
    let mine = std_frame(0x7FF, &[1]);
    let first = std_frame(0x3FF, &[2]); // loss at ID.28: ALC 0
    let second = std_frame(0x7EF, &[3]); // loss at ID.22: ALC 6
    let sof_2 = encode(&first).len() + INTERMISSION;
    let mut bench = arbitration_bench(0, &mine, &[first, second], false);
    run_to_lt_bit(&mut bench, sof_2 - 1);
    assert_eq!(bench.host(0).read(pelican::IR), 0, "ALIE = 0: no ALI");
    bench.host(0).write(pelican::IER, interrupt::ALI);
    assert_eq!(bench.host(0).read(pelican::ALC), 0, "captured without ALIE");
    assert!(bench.run_until_irq(0, 60), "ALI with ALIE");
    assert_eq!(bench.host(0).read(pelican::ALC), 6);
}

#[test]
fn ecc_keeps_the_first_bus_error_until_read_and_bei_fires_once_per_capture() {
    let mut bench = ControllerBench::operating(2);
    bench.host(0).write(pelican::IER, interrupt::BEI);
    let frame = std_frame(0x3A5, &[0xA5, 0x5A]);
    let enc = encode(&frame);
    let single_shot = command::TR | command::AT;
    // 1: bit error in the data field.
    let data = bit_in_field(&enc, Field::Data, RECESSIVE);
    transmit_with_seen_bit(&mut bench, 0, &frame, single_shot, data, DOMINANT);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::BEI,
        "first error: BEI"
    );
    // 2: bit error in the DLC, ECC not read: no capture, no BEI.
    bench.run_bits(20);
    let dlc = bit_in_field(&enc, Field::Dlc, RECESSIVE);
    transmit_with_seen_bit(&mut bench, 0, &frame, single_shot, dlc, DOMINANT);
    assert_eq!(
        bench.host(0).read(pelican::TXERR),
        16,
        "two errors happened"
    );
    assert_eq!(bench.host(0).read(pelican::IR), 0, "second error: no BEI");
    let first = ecc(ecc::BIT, false, ecc::SEG_DATA);
    assert_eq!(
        bench.host(0).read(pelican::ECC),
        first,
        "the first error is kept"
    );
    assert_eq!(
        bench.host(0).read(pelican::ECC),
        first,
        "reading does not clear ECC"
    );
    // 3: after the read, the next error is captured with a new BEI.
    bench.run_bits(20);
    let crc = bit_in_field(&enc, Field::Crc, RECESSIVE);
    transmit_with_seen_bit(&mut bench, 0, &frame, single_shot, crc, DOMINANT);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::BEI,
        "third error: BEI"
    );
    assert_eq!(
        bench.host(0).read(pelican::ECC),
        ecc(ecc::BIT, false, ecc::SEG_CRC)
    );
}

#[test]
fn bei_needs_beie_but_ecc_captures_anyway() {
    let mut bench = ControllerBench::operating(1);
    bench.host(0).write(pelican::IER, 0);
    send(
        &mut bench,
        0,
        &std_frame(0x100, &[1]),
        command::TR | command::AT,
    );
    assert_eq!(bench.host(0).read(pelican::IR), 0, "BEIE = 0: no BEI");
    let ack_error = ecc(ecc::OTHER, false, ecc::SEG_ACK_SLOT);
    assert_eq!(
        bench.host(0).read(pelican::ECC),
        ack_error,
        "captured without BEIE"
    );
    bench.host(0).write(pelican::IER, interrupt::BEI);
    bench.run_bits(20);
    send(
        &mut bench,
        0,
        &std_frame(0x100, &[1]),
        command::TR | command::AT,
    );
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::BEI,
        "BEI with BEIE"
    );
    assert_eq!(bench.host(0).read(pelican::ECC), ack_error);
}

/// Node 0 sends `frame` once (TR+AT) to node 1; node `victim` sees wire bit `bit` as `level`.
/// Returns the victim's ECC.
fn ecc_after_disturbance(frame: &Frame, victim: usize, bit: usize, level: bool) -> u8 {
    let mut bench = ControllerBench::operating(2);
    transmit(&mut bench.host(0), frame, command::TR | command::AT);
    let sof = bench.run_until_sof(0, 20);
    bench.force_seen_bit(victim, sof, bit, level);
    run_until_tx_done(&mut bench, 0, 300);
    bench.host(victim).read(pelican::ECC)
}

#[test]
fn ecc_decodes_error_type_direction_and_segment() {
    let frame = std_frame(0x000, &[0xA5, 0x5A]);
    let enc = encode(&frame);
    let stuff = enc.tags.iter().position(|t| t.stuff).unwrap();
    let cases = [
        (
            "transmitter, bit error in the data field",
            0,
            bit_in_field(&enc, Field::Data, RECESSIVE),
            DOMINANT,
            ecc(ecc::BIT, false, ecc::SEG_DATA),
        ),
        (
            "transmitter, bit error in the DLC",
            0,
            bit_in_field(&enc, Field::Dlc, RECESSIVE),
            DOMINANT,
            ecc(ecc::BIT, false, ecc::SEG_DLC),
        ),
        (
            "transmitter, bit error in the CRC sequence",
            0,
            bit_in_field(&enc, Field::Crc, RECESSIVE),
            DOMINANT,
            ecc(ecc::BIT, false, ecc::SEG_CRC),
        ),
        (
            "transmitter, ACK error",
            0,
            enc.position(Field::AckSlot, 0).unwrap(),
            RECESSIVE,
            ecc(ecc::OTHER, false, ecc::SEG_ACK_SLOT),
        ),
        (
            "receiver, form error in the CRC delimiter",
            1,
            enc.position(Field::CrcDelim, 0).unwrap(),
            DOMINANT,
            ecc(ecc::FORM, true, ecc::SEG_CRC_DELIM),
        ),
        (
            "receiver, stuff error in ID.28..21",
            1,
            stuff,
            enc.bits[stuff - 1],
            ecc(ecc::STUFF, true, ecc::SEG_ID_28_21),
        ),
        (
            "receiver, bit error on its own ACK",
            1,
            enc.position(Field::AckSlot, 0).unwrap(),
            RECESSIVE,
            ecc(ecc::BIT, true, ecc::SEG_ACK_SLOT),
        ),
        (
            "receiver, form error in the ACK delimiter",
            1,
            enc.position(Field::AckDelim, 0).unwrap(),
            DOMINANT,
            ecc(ecc::FORM, true, ecc::SEG_ACK_DELIM),
        ),
        (
            "receiver, form error in the EOF",
            1,
            enc.position(Field::Eof, 2).unwrap(),
            DOMINANT,
            ecc(ecc::FORM, true, ecc::SEG_EOF),
        ),
    ];
    let got: Vec<(&str, u8)> = cases
        .iter()
        .map(|&(what, victim, bit, level, _)| {
            (what, ecc_after_disturbance(&frame, victim, bit, level))
        })
        .collect();
    let want: Vec<(&str, u8)> = cases.iter().map(|&(what, _, _, _, e)| (what, e)).collect();
    assert_eq!(got, want);
}

#[test]
fn ecc_of_a_form_error_in_the_error_delimiter() {
    // A lone transmitter: ACK error at the ACK slot, active flag, then the error delimiter.
    let mut bench = ControllerBench::operating(1);
    let frame = std_frame(0x0F0, &[0x5A]);
    let enc = encode(&frame);
    let ack = enc.position(Field::AckSlot, 0).unwrap();
    transmit(&mut bench.host(0), &frame, command::TR | command::AT);
    let sof = bench.run_until_sof(0, 20);
    // Flag ack+1..=ack+6, delimiter from ack+7: its fourth bit read dominant.
    bench.force_seen_bit(0, sof, ack + 10, DOMINANT);
    bench
        .engine
        .run_until(sof + (ack as u64 + 3) * bench_bit_fs())
        .unwrap();
    assert_eq!(
        bench.host(0).read(pelican::ECC),
        ecc(ecc::OTHER, false, ecc::SEG_ACK_SLOT),
        "the ACK error, read to re-arm"
    );
    run_until_tx_done(&mut bench, 0, 100);
    bench.run_bits(20);
    assert_eq!(
        bench.host(0).read(pelican::ECC),
        ecc(ecc::FORM, false, ecc::SEG_ERROR_DELIM)
    );
}

// ---------------------------------------------------------------------------------------------
// Rule 6: error counters, ES/EI, EPI, bus-off
// ---------------------------------------------------------------------------------------------

#[test]
fn rxerr_and_txerr_are_written_in_reset_mode_only() {
    let mut bench = ControllerBench::operating(1);
    let mut h = bench.host(0);
    h.write(pelican::RXERR, 5);
    h.write(pelican::TXERR, 255);
    assert_eq!(
        (h.read(pelican::RXERR), h.read(pelican::TXERR)),
        (0, 0),
        "operating mode: ignored"
    );
    assert_eq!(
        h.read(pelican::SR) & status::BS,
        0,
        "no bus-off from an op-mode write"
    );
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::RXERR, 5);
    h.write(pelican::TXERR, 7);
    assert_eq!(
        (h.read(pelican::RXERR), h.read(pelican::TXERR)),
        (5, 7),
        "reset mode"
    );
}

#[test]
fn txerr_255_in_reset_mode_forces_bus_off_with_bs_txerr_127_rxerr_0_and_ei() {
    let mut bench = pelican_in_reset_mode(1);
    let mut h = bench.host(0);
    h.write(pelican::IER, interrupt::EI);
    h.write(pelican::RXERR, 33);
    h.write(pelican::TXERR, 255);
    h.idle(1);
    assert!(h.node().irq(), "EI");
    check_registers(
        &mut h,
        &[
            ("MOD", pelican::MOD, mode::RM),
            ("TXERR", pelican::TXERR, 127),
            ("RXERR", pelican::RXERR, 0),
            ("IR", pelican::IR, interrupt::EI),
        ],
        "forced bus-off",
    );
    assert_eq!(h.read(pelican::SR) & status::BS, status::BS, "BS");
}

#[test]
fn rxerr_writes_are_ignored_while_bus_off() {
    let mut bench = pelican_in_reset_mode(1);
    let mut h = bench.host(0);
    h.write(pelican::TXERR, 255);
    h.write(pelican::RXERR, 9);
    assert_eq!(h.read(pelican::RXERR), 0);
    assert_eq!(
        h.read(pelican::SR) & status::BS,
        status::BS,
        "still bus-off"
    );
}

#[test]
fn txerr_write_below_255_ends_bus_off_at_once_with_ei() {
    let mut bench = pelican_in_reset_mode(1);
    let mut h = bench.host(0);
    h.write(pelican::IER, interrupt::EI);
    h.write(pelican::TXERR, 255);
    // IR follows the counter write one clock later (the status a clock after the write).
    h.idle(1);
    assert_eq!(h.read(pelican::IR), interrupt::EI, "EI at bus-off entry");
    h.write(pelican::TXERR, 0);
    h.idle(1);
    assert!(h.node().irq(), "EI at bus-off end");
    check_registers(
        &mut h,
        &[
            ("IR", pelican::IR, interrupt::EI),
            ("TXERR", pelican::TXERR, 0),
            ("RXERR", pelican::RXERR, 0),
            ("MOD", pelican::MOD, mode::RM),
        ],
        "bus-off ended by TXERR = 0",
    );
    assert_eq!(h.read(pelican::SR) & status::BS, 0, "BS cleared at once");
    // The node is an ordinary error-active node after reset mode.
    h.write(pelican::MOD, 0);
    bench.run_bits(INTEGRATION_BITS);
    assert_eq!(
        bench.host(0).read(pelican::SR),
        status::TBS | status::TCS,
        "integrated after 11 recessive bits, error active"
    );
}

#[test]
fn es_and_ei_follow_txerr_crossing_a_low_ewlr() {
    let mut bench = pelican_in_reset_mode(2);
    bench.host(0).write(pelican::EWLR, 16);
    bench.host(0).write(pelican::IER, interrupt::EI);
    leave_reset_mode(&mut bench, 0, 0);
    // Node 1 stays in reset mode: no ACK, every attempt of node 0 costs TEC + 8.
    transmit(&mut bench.host(0), &std_frame(0x050, &[5]), command::TR);
    assert!(bench.run_until_irq(0, 300), "EI when TXERR reaches EWLR");
    assert_eq!(bench.host(0).read(pelican::TXERR), 16, "second ACK error");
    assert_eq!(bench.host(0).read(pelican::SR) & status::ES, status::ES);
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::EI);
    bench.host(0).write(pelican::CMR, command::AT);
    run_until_tx_done(&mut bench, 0, 100);
    assert_eq!(bench.host(0).read(pelican::TXERR), 16, "no further attempt");
    // An acknowledged frame: TXERR 15 < EWLR.
    leave_reset_mode(&mut bench, 1, 0);
    transmit(&mut bench.host(0), &std_frame(0x050, &[5]), command::TR);
    assert!(
        bench.run_until_irq(0, 200),
        "EI when TXERR drops below EWLR"
    );
    assert_eq!(bench.host(0).read(pelican::TXERR), 15);
    assert_eq!(bench.host(0).read(pelican::SR) & status::ES, 0);
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::EI);
}

#[test]
fn es_and_epi_are_frozen_in_reset_mode_and_re_evaluated_when_it_is_left() {
    let mut bench = ControllerBench::operating(1);
    let mut h = bench.host(0);
    h.write(pelican::IER, interrupt::EI | interrupt::EPI);
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::RXERR, 200);
    h.idle(5);
    assert_eq!(
        h.read(pelican::SR) & status::ES,
        0,
        "ES frozen in reset mode"
    );
    assert_eq!(h.read(pelican::IR), 0, "no EI/EPI in reset mode");
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(
        h.read(pelican::SR) & status::ES,
        status::ES,
        "ES when reset mode is left"
    );
    assert_eq!(h.read(pelican::IR), interrupt::EI | interrupt::EPI);
    h.write(pelican::MOD, mode::RM);
    h.write(pelican::RXERR, 0);
    h.idle(5);
    assert_eq!(h.read(pelican::SR) & status::ES, status::ES, "still frozen");
    assert_eq!(h.read(pelican::IR), 0);
    h.write(pelican::MOD, 0);
    h.idle(2);
    assert_eq!(h.read(pelican::SR) & status::ES, 0);
    assert_eq!(h.read(pelican::IR), interrupt::EI | interrupt::EPI);
}

#[test]
fn error_passive_entry_and_return_give_epi_each_time() {
    let mut bench = pelican_in_reset_mode(2);
    bench.host(0).write(pelican::IER, interrupt::EPI);
    leave_reset_mode(&mut bench, 0, 0);
    // Alone on the bus (node 1 in reset mode): TEC + 8 per attempt up to 128.
    transmit(&mut bench.host(0), &std_frame(0x050, &[]), command::TR);
    assert!(
        bench.run_until_irq(0, 2000),
        "EPI on becoming error passive"
    );
    assert_eq!(bench.host(0).read(pelican::TXERR), 128);
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::EPI);
    assert_eq!(bench.host(0).read(pelican::SR) & status::ES, status::ES);
    bench.run_bits(200);
    assert_eq!(
        bench.host(0).read(pelican::TXERR),
        128,
        "ACK errors of a passive transmitter do not count"
    );
    assert_eq!(bench.host(0).read(pelican::IR), 0);
    leave_reset_mode(&mut bench, 1, 0);
    assert!(
        bench.run_until_irq(0, 300),
        "EPI on becoming error active again"
    );
    assert_eq!(bench.host(0).read(pelican::TXERR), 127, "one success");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::EPI);
}

#[test]
fn bus_off_by_bit_errors_and_recovery_after_128_times_11_recessive_bits() {
    let mut bench = ControllerBench::operating(1);
    bench
        .host(0)
        .write(pelican::IER, interrupt::EI | interrupt::EPI);
    let frame = std_frame(0x555, &[0x55; 8]);
    let enc = encode(&frame);
    transmit(&mut bench.host(0), &frame, command::TR);
    let sof = bench.run_until_sof(0, 20);
    // From the data field on, the node sees a dominant bus: a bit error, then every 8 dominant
    // bits after its error flag cost TEC + 8 until bus-off.
    let from = sof + bit_in_field(&enc, Field::Data, RECESSIVE) as u64 * bench_bit_fs();
    let id = bench.id(0);
    bench
        .engine
        .disturb_rx(id, from, from + 400 * bench_bit_fs(), DOMINANT);
    let bits = run_until_status(&mut bench, 0, status::BS, status::BS, 400);
    assert!(bits > 100, "bus-off after {bits} bits");
    bench.host(0).idle(2);
    assert!(bench.node(0).irq(), "EI at bus-off");
    check_registers(
        &mut bench.host(0),
        &[
            ("MOD", pelican::MOD, mode::RM),
            (
                "SR",
                pelican::SR,
                status::BS | status::ES | status::TS | status::RS | status::TBS,
            ),
            ("IR", pelican::IR, interrupt::EI),
            ("TXERR", pelican::TXERR, 127),
            ("RXERR", pelican::RXERR, 0),
        ],
        "bus-off entry: RM, BS, request cancelled, IR = EI only, TXERR 127, RXERR 0",
    );
    // Recovery starts when reset mode is left, after the disturbance is over.
    bench.run_bits(400);
    bench.host(0).write(pelican::IER, interrupt::EI);
    bench.host(0).write(pelican::MOD, 0);
    let start = bench.engine.now();
    bench.run_bits(64 * 11 + 5);
    let tec = bench.host(0).read(pelican::TXERR);
    assert!(
        (62..=64).contains(&tec),
        "TXERR counts down once per 11 recessive bits: {tec} after 64 sequences"
    );
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::BS | status::TS | status::RS),
        status::BS | status::TS | status::RS,
        "still bus-off, waiting for the bus"
    );
    assert!(
        bench.run_until_irq(0, 64 * 11 + 10),
        "EI at the end of recovery"
    );
    // The write lands somewhere in a bit: the 1408th recessive sample comes 1407..1408 bits later.
    let took = (bench.engine.now() - start) as f64 / bench_bit_fs() as f64;
    assert!(
        (128.0 * 11.0 - 1.0..128.0 * 11.0 + 1.0).contains(&took),
        "recovery took {took} bits"
    );
    check_registers(
        &mut bench.host(0),
        &[
            ("MOD", pelican::MOD, 0),
            ("SR", pelican::SR, status::TBS),
            ("IR", pelican::IR, interrupt::EI),
            ("TXERR", pelican::TXERR, 0),
            ("RXERR", pelican::RXERR, 0),
        ],
        "after recovery: error active, BS = ES = 0, EI",
    );
}

#[test]
fn forced_bus_off_recovers_after_reset_mode_is_left_and_128_times_11_recessive_bits() {
    let mut bench = pelican_in_reset_mode(1);
    bench.host(0).write(pelican::TXERR, 255);
    bench.host(0).write(pelican::IER, interrupt::EI);
    bench.host(0).write(pelican::MOD, 0);
    bench.run_bits(100);
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::BS | status::ES | status::TS | status::RS),
        status::BS | status::ES | status::TS | status::RS,
        "bus-off, waiting for the bus"
    );
    let tec = bench.host(0).read(pelican::TXERR);
    assert!(
        (117..=119).contains(&tec),
        "TXERR counts down: {tec} after 100 bits"
    );
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::EI,
        "ES re-evaluated on leaving"
    );
    assert!(
        bench.run_until_irq(0, 128 * 11),
        "EI at the end of recovery"
    );
    assert_eq!(bench.host(0).read(pelican::SR), status::TBS | status::TCS);
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::EI);
    assert_eq!(bench.host(0).read(pelican::TXERR), 0);
}

// ---------------------------------------------------------------------------------------------
// Rule 7: the BasicCAN map
// ---------------------------------------------------------------------------------------------

/// Node 0 in BasicCAN (ACR/AMR/CR as given), node 1 in PeliCAN (open filter, IER 0xFF), both
/// integrated.
fn basic_and_pelican(acr: u8, amr: u8, cr: u8) -> ControllerBench {
    let mut bench = ControllerBench::new(2);
    configure_pelican(&mut bench.host(1));
    bench.host(1).write(pelican::MOD, 0);
    configure_basic(&mut bench, 0, acr, amr, cr);
    bench
}

/// Reads and releases every message of a BasicCAN node, as RX-buffer byte lists (20, 21 and the
/// stored data bytes).
fn basic_drain(host: &mut Host) -> Vec<Vec<u8>> {
    let mut messages = Vec::new();
    while host.read(basic::SR) & status::RBS != 0 {
        let dlc = (host.read(basic::RX_ID_DLC) & 0x0F).min(8) as usize;
        let rtr = host.read(basic::RX_ID_DLC) & 0x10 != 0;
        let len = 2 + if rtr { 0 } else { dlc };
        messages.push(read_bytes(host, basic::RX, len));
        host.write(basic::CMR, command::RRB);
    }
    messages
}

#[test]
fn basic_can_cr_bit5_reads_1_bit6_is_plain_storage_and_enables_read_back() {
    let mut bench = ControllerBench::new(1);
    let mut h = bench.host(0);
    let all = control::RR | control::RIE | control::TIE | control::EIE | control::OIE | 0x40;
    h.write(basic::CR, all);
    assert_eq!(h.read(basic::CR), all | control::ALWAYS_ONE);
    h.write(basic::CR, control::RR);
    assert_eq!(h.read(basic::CR), control::RR | control::ALWAYS_ONE);
    h.write(basic::CR, control::TIE | 0x40);
    assert_eq!(
        h.read(basic::CR),
        control::TIE | 0x40 | control::ALWAYS_ONE,
        "operating mode: RR cleared, TIE and bit 6 stored"
    );
}

#[test]
fn basic_can_acr_amr_btr_ocr_read_ff_and_ignore_writes_in_operating_mode() {
    let mut bench = ControllerBench::new(1);
    let regs = [
        ("ACR", basic::ACR, 0x12),
        ("AMR", basic::AMR, 0x34),
        ("BTR0", basic::BTR0, BTR0_500K_AT_16MHZ),
        ("BTR1", basic::BTR1, BTR1_500K_AT_16MHZ),
        ("OCR", basic::OCR, 0x56),
    ];
    for &(_, addr, value) in &regs {
        bench.host(0).write(addr, value);
    }
    check_registers(&mut bench.host(0), &regs, "reset mode: written and read");
    bench.host(0).write(basic::CR, 0);
    let ff: Vec<(&str, u8, u8)> = regs.iter().map(|&(n, a, _)| (n, a, 0xFF)).collect();
    check_registers(&mut bench.host(0), &ff, "operating mode: read 0xFF");
    for &(_, addr, _) in &regs {
        bench.host(0).write(addr, 0x99);
    }
    bench.host(0).write(basic::CR, control::RR);
    check_registers(
        &mut bench.host(0),
        &regs,
        "operating-mode writes were ignored",
    );
}

#[test]
fn basic_can_tx_buffer_sends_standard_frames_to_a_pelican_node_and_tie_gates_ti() {
    let mut bench = basic_and_pelican(0, 0xFF, 0);
    let data = std_frame(0x5A3, &[1, 2, 3, 4, 5, 6, 7, 8]);
    basic_transmit(&mut bench.host(0), &data, command::TR);
    run_until_tx_done(&mut bench, 0, 200);
    assert_eq!(bench.host(0).read(basic::IR), 0xE0, "TIE = 0: no TI");
    assert_eq!(bench.host(0).read(basic::SR) & status::TCS, status::TCS);
    bench.host(0).write(basic::CR, control::TIE);
    let remote = std_remote(0x0C1, 3);
    basic_transmit(&mut bench.host(0), &remote, command::TR);
    assert!(bench.run_until_irq(0, 200), "TI with TIE");
    assert_eq!(bench.host(0).read(basic::IR), 0xE0 | interrupt::TI);
    assert_eq!(bench.host(0).read(basic::IR), 0xE0, "reading IR cleared TI");
    assert_eq!(drain_rx(&mut bench.host(1)), vec![data, remote]);
}

#[test]
fn basic_can_rx_buffer_holds_received_standard_frames() {
    let mut bench = basic_and_pelican(0, 0xFF, 0);
    let frames = [std_frame(0x3C5, &[0xA1, 0xB2, 0xC3]), std_remote(0x7FE, 2)];
    for f in &frames {
        send(&mut bench, 1, f, command::TR);
    }
    bench.run_bits(5);
    let want: Vec<Vec<u8>> = frames.iter().map(basic_rx_bytes).collect();
    assert_eq!(basic_drain(&mut bench.host(0)), want);
}

#[test]
fn basic_can_ir_bits_7_to_5_read_1_and_ri_is_latched_until_ir_is_read_or_rrb() {
    let mut bench = basic_and_pelican(0, 0xFF, control::RIE);
    assert_eq!(bench.host(0).read(basic::IR), 0xE0, "nothing pending");
    send(&mut bench, 1, &std_frame(0x100, &[1]), command::TR);
    send(&mut bench, 1, &std_frame(0x101, &[2]), command::TR);
    bench.run_bits(5);
    assert!(bench.node(0).irq());
    assert_eq!(bench.host(0).read(basic::IR), 0xE0 | interrupt::RI);
    assert_eq!(bench.host(0).read(basic::IR), 0xE0, "the read cleared RI");
    assert!(!bench.node(0).irq());
    assert_eq!(
        bench.host(0).read(basic::SR) & status::RBS,
        status::RBS,
        "messages wait"
    );
    bench.host(0).write(basic::CMR, command::RRB);
    bench.host(0).idle(1);
    assert!(bench.node(0).irq(), "RRB left another message: RI");
    assert_eq!(bench.host(0).read(basic::IR), 0xE0 | interrupt::RI);
    assert_eq!(bench.host(0).read(basic::IR), 0xE0);
    bench.host(0).write(basic::CMR, command::RRB);
    bench.host(0).idle(1);
    assert!(!bench.node(0).irq(), "last message released: no RI");
    assert_eq!(bench.host(0).read(basic::IR), 0xE0);
    assert_eq!(bench.host(0).read(basic::SR) & status::RBS, 0);
}

#[test]
fn basic_can_acr_amr_filter_on_id_10_to_3() {
    // ACR 0x24, AMR 0x03: ID.10..3 in 0x24..=0x27, i.e. identifiers 0x120..=0x13F.
    let mut bench = basic_and_pelican(0x24, 0x03, 0);
    let frames = [
        std_frame(0x11F, &[1]),
        std_frame(0x120, &[2]),
        std_frame(0x13F, &[3]),
        std_frame(0x140, &[4]),
        std_frame(0x12A, &[5]),
        std_frame(0x520, &[6]),
    ];
    for f in &frames {
        send(&mut bench, 1, f, command::TR);
    }
    bench.run_bits(5);
    let want: Vec<Vec<u8>> = [&frames[1], &frames[2], &frames[4]]
        .into_iter()
        .map(basic_rx_bytes)
        .collect();
    assert_eq!(basic_drain(&mut bench.host(0)), want);
}

#[test]
fn basic_can_extended_frames_are_acknowledged_but_not_stored() {
    let mut bench = basic_and_pelican(0, 0xFF, control::RIE | control::EIE);
    // Node 0 is the only receiver: node 1 succeeds only with its ACK.
    send(
        &mut bench,
        1,
        &ext_frame(0x1234_5678, &[1, 2, 3]),
        command::TR,
    );
    assert_eq!(
        bench.host(1).read(pelican::SR) & status::TCS,
        status::TCS,
        "acknowledged"
    );
    assert_eq!(bench.host(1).read(pelican::TXERR), 0, "no error");
    bench.run_bits(5);
    assert_eq!(bench.host(0).read(basic::SR) & status::RBS, 0, "not stored");
    assert_eq!(bench.host(0).read(basic::IR), 0xE0, "no RI, no EI");
    let frame = std_frame(0x234, &[4]);
    send(&mut bench, 1, &frame, command::TR);
    bench.run_bits(5);
    assert_eq!(
        basic_drain(&mut bench.host(0)),
        vec![basic_rx_bytes(&frame)]
    );
}

#[test]
fn basic_can_wui_is_always_enabled() {
    let mut bench = basic_and_pelican(0, 0xFF, 0);
    bench.host(0).write(basic::CMR, command::GTS);
    assert_eq!(bench.host(0).read(basic::IR), 0xE0, "asleep, no WUI yet");
    bench.host(0).write(basic::CMR, 0);
    assert!(bench.node(0).irq(), "WUI asserts irq_n without any enable");
    assert_eq!(bench.host(0).read(basic::IR), 0xE0 | interrupt::WUI);
    // Woken by bus activity.
    bench.run_bits(INTEGRATION_BITS);
    bench.host(0).write(basic::CMR, command::GTS);
    assert_eq!(bench.host(0).read(basic::IR), 0xE0, "asleep again");
    transmit(&mut bench.host(1), &std_frame(0x111, &[1]), command::TR);
    assert!(bench.run_until_irq(0, 5), "woken by the SOF");
    assert_eq!(bench.host(0).read(basic::IR), 0xE0 | interrupt::WUI);
}

#[test]
fn basic_can_overrun_sets_dos_and_doi_with_oie_and_cdo_clears_dos() {
    let mut bench = basic_and_pelican(0, 0xFF, control::OIE);
    for k in 0..6u8 {
        send(
            &mut bench,
            1,
            &std_frame(0x300 + k as u16, &[k; 8]),
            command::TR,
        );
    }
    bench.run_bits(5);
    assert_eq!(
        bench.host(0).read(basic::SR) & (status::DOS | status::RBS),
        status::DOS | status::RBS
    );
    assert_eq!(bench.host(0).read(basic::IR), 0xE0 | interrupt::DOI);
    bench.host(0).write(basic::CMR, command::CDO);
    assert_eq!(
        bench.host(0).read(basic::SR) & status::DOS,
        0,
        "CDO clears DOS"
    );
    assert_eq!(
        basic_drain(&mut bench.host(0)).len(),
        5,
        "five messages kept"
    );
}

#[test]
fn basic_can_es_uses_the_fixed_limit_96() {
    let mut bench = ControllerBench::new(1);
    // Counters and EWLR are reached through the PeliCAN map in reset mode.
    let mut h = bench.host(0);
    h.write(pelican::CDR, clock_divider::PELICAN);
    h.write(pelican::EWLR, 8);
    h.write(pelican::TXERR, 95);
    h.write(pelican::CDR, 0);
    configure_basic(&mut bench, 0, 0, 0xFF, control::EIE);
    assert_eq!(
        bench.host(0).read(basic::SR) & status::ES,
        0,
        "TXERR 95 >= EWLR 8, but BasicCAN uses 96"
    );
    assert_eq!(bench.host(0).read(basic::IR), 0xE0);
    let mut h = bench.host(0);
    h.write(basic::CR, control::RR | control::EIE);
    h.write(pelican::CDR, clock_divider::PELICAN);
    h.write(pelican::TXERR, 96);
    h.write(pelican::CDR, 0);
    h.write(basic::CR, control::EIE);
    h.idle(2);
    assert_eq!(h.read(basic::SR) & status::ES, status::ES, "TXERR 96: ES");
    assert_eq!(h.read(basic::IR), 0xE0 | interrupt::EI);
}
