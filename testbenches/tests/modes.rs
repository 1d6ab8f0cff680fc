//! Operating modes of the controller, observed through the host port and the pins: listen-only,
//! self test, self reception, reset mode entered mid-frame, bus integration after reset mode,
//! sleep and wake-up, and the CLKOUT divider (every CDR code, clock off, CLKOUT in sleep).

use golden::frame::{encode, Frame, Id};
use rtl::registers::{clock_divider, command, interrupt, mode, pelican, status};
use sim::host::sja1000::{drain_rx, read_rx_message, transmit};
use sim::nodes::controller_node::ControllerNode;
use testbenches::controller_bench::{
    bench_bit_fs, bench_btr, configure_pelican, ControllerBench, INTEGRATION_BITS,
};
use testbenches::ecc::{self, ecc};

/// Longest a frame may take, in bit times.
const MAX_FRAME_BITS: u64 = 300;

fn std_frame(id: u16, data: &[u8]) -> Frame {
    Frame::data(Id::standard(id).unwrap(), data).unwrap()
}

fn clocks_per_bit() -> u64 {
    bench_btr().clocks_per_bit() as u64
}

/// Controller `n` leaves operation and comes back with MOD = `value` (LOM, STM written in reset
/// mode, RM cleared by the same write), then integrates.
fn reconfigure(bench: &mut ControllerBench, n: usize, value: u8) {
    bench.host(n).write(pelican::MOD, mode::RM);
    bench.host(n).write(pelican::MOD, value);
    assert_eq!(bench.host(n).read(pelican::MOD), value, "MOD of node {n}");
    bench.run_bits(INTEGRATION_BITS);
}

/// Runs until controller `n`'s `tx` pin turns dominant (a falling edge) at or after `not_before`
/// (fs); returns whether it did within `max_bits`.
fn run_until_tx_falls(
    bench: &mut ControllerBench,
    n: usize,
    not_before: u64,
    max_bits: u64,
) -> bool {
    let id = bench.id(n);
    let limit = bench.engine.now() + max_bits * bench_bit_fs();
    let mut before = bench.node(n).tx();
    bench
        .engine
        .run_while(limit, |e| {
            let now = e.device::<ControllerNode>(id).tx();
            let fell = before && !now;
            before = now;
            fell && e.now() >= not_before
        })
        .unwrap()
}

/// Controller `n`'s `clkout` sampled once right after each of its next `clocks` clock edges.
fn sample_clkout(bench: &mut ControllerBench, n: usize, clocks: u64) -> Vec<bool> {
    let id = bench.id(n);
    let start = bench.node(n).edges();
    let mut last = start;
    let mut samples = Vec::with_capacity(clocks as usize);
    bench
        .engine
        .run_while(u64::MAX, |e| {
            let node = e.device::<ControllerNode>(id);
            if node.edges() != last {
                last = node.edges();
                samples.push(node.clkout());
            }
            node.edges() >= start + clocks
        })
        .unwrap();
    samples
}

/// Lengths of the complete runs of equal levels (the first and the last run, possibly cut by the
/// sampling window, left out).
fn inner_runs(samples: &[bool]) -> Vec<usize> {
    let mut runs = Vec::new();
    let mut len = 1;
    for w in samples.windows(2) {
        if w[0] == w[1] {
            len += 1;
        } else {
            runs.push(len);
            len = 1;
        }
    }
    runs.remove(0);
    runs
}

fn rising_edges(samples: &[bool]) -> usize {
    samples.windows(2).filter(|w| !w[0] && w[1]).count()
}

// ---------------------------------------------------------------- listen-only

#[test]
fn listen_only_node_stores_frames_but_never_drives_the_bus() {
    const LOM: usize = 2;
    let mut bench = ControllerBench::operating(3);
    reconfigure(&mut bench, LOM, mode::LOM);

    // With a normal receiver that acknowledges: the frame is stored by the listen-only node.
    let frame = std_frame(0x2A1, &[1, 2, 3, 4]);
    transmit(&mut bench.host(0), &frame, command::TR);
    let dominant = bench.run_bits_counting_dominant_tx(LOM, 120);
    assert_eq!(dominant, 0, "the listen-only node drove dominant (an ACK?)");
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        status::TBS | status::TCS,
        "acknowledged by node 1"
    );
    assert_eq!(bench.host(LOM).read(pelican::IR), interrupt::RI);
    assert_eq!(drain_rx(&mut bench.host(LOM)), vec![frame]);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);

    // The listen-only node alone with the sender: no ACK, so the sender gets ACK errors.
    bench.host(1).write(pelican::MOD, mode::RM);
    bench.host(0).read(pelican::ECC);
    bench.host(0).read(pelican::IR);
    let lonely = std_frame(0x0F0, &[0x5A]);
    transmit(&mut bench.host(0), &lonely, command::TR);
    let mut dominant = bench.run_bits_counting_dominant_tx(LOM, 100);
    assert_eq!(
        bench.host(0).read(pelican::ECC),
        ecc(ecc::OTHER, false, ecc::SEG_ACK_SLOT),
        "the sender's ECC"
    );
    assert!(
        bench.host(0).read(pelican::TXERR) >= 8,
        "the sender counts ACK errors"
    );
    assert_eq!(
        bench.host(LOM).read(pelican::RMC),
        0,
        "the sender's active error flag destroys the frame"
    );
    // Once the sender is error passive its flag is recessive: the listen-only node then receives
    // the frame validly and stores it.
    let mut chunks = 0;
    while bench.host(LOM).read(pelican::RMC) == 0 {
        chunks += 1;
        assert!(chunks < 300, "the listen-only node never stored the frame");
        dominant += bench.run_bits_counting_dominant_tx(LOM, 10);
    }
    assert_eq!(
        bench.host(0).read(pelican::TXERR),
        128,
        "sender error passive"
    );
    bench.host(0).write(pelican::MOD, mode::RM);
    assert_eq!(
        dominant, 0,
        "the listen-only node drove dominant (ACK or error flag)"
    );
    assert_eq!(read_rx_message(&mut bench.host(LOM)), lonely);
    assert_eq!(bench.host(LOM).read(pelican::RXERR), 0, "counters frozen");
    assert_eq!(bench.host(LOM).read(pelican::TXERR), 0, "counters frozen");
    assert_eq!(bench.host(LOM).read(pelican::SR) & status::ES, 0);
}

#[test]
fn listen_only_node_does_not_transmit() {
    let mut bench = ControllerBench::operating(2);
    reconfigure(&mut bench, 1, mode::LOM);
    transmit(&mut bench.host(1), &std_frame(0x100, &[1]), command::TR);
    let dominant = bench.run_bits_counting_dominant_tx(1, 200);
    assert_eq!(
        dominant, 0,
        "a transmission request in listen-only mode sends nothing"
    );
    assert_eq!(bench.host(0).read(pelican::RMC), 0);
    assert_eq!(bench.host(1).read(pelican::TXERR), 0);
}

#[test]
fn sleep_cannot_be_entered_in_reset_mode() {
    let mut bench = ControllerBench::operating(1);
    bench.host(0).write(pelican::MOD, mode::RM);
    bench.host(0).write(pelican::MOD, mode::RM | mode::SM);
    assert_eq!(
        bench.host(0).read(pelican::MOD),
        mode::RM,
        "SM ignored in reset mode"
    );
    assert_eq!(bench.host(0).read(pelican::IR), 0);
}

#[test]
fn lom_and_stm_change_only_in_reset_mode() {
    let mut bench = ControllerBench::operating(1);
    bench
        .host(0)
        .write(pelican::MOD, mode::LOM | mode::STM | mode::AFM);
    assert_eq!(
        bench.host(0).read(pelican::MOD),
        0,
        "ignored in operating mode"
    );
    bench.host(0).write(pelican::MOD, mode::RM);
    bench
        .host(0)
        .write(pelican::MOD, mode::LOM | mode::STM | mode::AFM);
    assert_eq!(
        bench.host(0).read(pelican::MOD),
        mode::LOM | mode::STM | mode::AFM,
        "set by a write in reset mode that also clears RM"
    );
}

// ---------------------------------------------------------------- self test and self reception

#[test]
fn self_test_transmission_succeeds_without_ack() {
    let mut bench = ControllerBench::new(1);
    configure_pelican(&mut bench.host(0));
    bench.host(0).write(pelican::MOD, mode::STM);
    bench.run_bits(INTEGRATION_BITS);
    let frame = std_frame(0x3C5, &[0xDE, 0xAD]);
    transmit(&mut bench.host(0), &frame, command::TR);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        status::TBS | status::TCS
    );
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::TI);
    assert_eq!(bench.host(0).read(pelican::TXERR), 0, "no ACK error");
    assert_eq!(bench.host(0).read(pelican::RMC), 0, "TR: no self reception");

    // SRR: the own frame is stored too.
    let own = Frame::data(Id::extended(0x1555_AAAA).unwrap(), &[1, 2, 3]).unwrap();
    transmit(&mut bench.host(0), &own, command::SRR);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(
        bench.host(0).read(pelican::SR) & (status::TBS | status::TCS),
        status::TBS | status::TCS
    );
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::TI | interrupt::RI
    );
    assert_eq!(drain_rx(&mut bench.host(0)), vec![own]);
    assert_eq!(bench.host(0).read(pelican::TXERR), 0);
}

#[test]
fn self_reception_in_normal_mode_stores_the_own_frame() {
    let mut bench = ControllerBench::operating(2);
    let frame = std_frame(0x555, &[0x55, 0xAA, 0x0F]);
    transmit(&mut bench.host(0), &frame, command::SRR);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(bench.host(0).read(pelican::SR) & status::TCS, status::TCS);
    assert_eq!(
        bench.host(0).read(pelican::IR),
        interrupt::TI | interrupt::RI
    );
    assert_eq!(drain_rx(&mut bench.host(0)), vec![frame]);
    assert_eq!(drain_rx(&mut bench.host(1)), vec![frame]);

    // A plain TR afterwards does not store the own frame.
    transmit(&mut bench.host(0), &frame, command::TR);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(bench.host(0).read(pelican::RMC), 0);
    assert_eq!(bench.host(1).read(pelican::RMC), 1);
}

// ---------------------------------------------------------------- reset mode and integration

#[test]
fn reset_mode_mid_frame_releases_the_bus_at_once_and_cancels_the_request() {
    let mut bench = ControllerBench::operating(2);
    // Node 0 has stored messages and an overrun (21 + 1 remote frames of 3 bytes).
    for i in 0..22 {
        transmit(
            &mut bench.host(1),
            &Frame::remote(Id::standard(0x600 + i).unwrap(), 0).unwrap(),
            command::TR,
        );
        assert!(bench.run_until_tx_buffer_free(1, MAX_FRAME_BITS));
    }
    assert_eq!(bench.host(0).read(pelican::RMC), 21);
    assert_eq!(bench.host(0).read(pelican::SR) & status::DOS, status::DOS);
    let rbsa = bench.host(0).read(pelican::RBSA);

    // Node 0 transmits; 20 bits into its frame, at the start of a dominant bit, RM is set.
    transmit(&mut bench.host(0), &std_frame(0x7E5, &[0; 8]), command::TR);
    assert!(run_until_tx_falls(&mut bench, 0, 0, 50), "SOF");
    let sof = bench.engine.now();
    assert!(run_until_tx_falls(
        &mut bench,
        0,
        sof + 20 * bench_bit_fs(),
        30
    ));
    bench.host(0).write(pelican::MOD, mode::RM);
    let written_at = bench.node(0).edges();
    let id = bench.id(0);
    bench
        .engine
        .run_while(u64::MAX, |e| e.device::<ControllerNode>(id).tx())
        .unwrap();
    let clocks = bench.node(0).edges() - written_at;
    assert!(
        clocks <= 2,
        "tx recessive {clocks} clocks after the MOD write (at most 2)"
    );

    let sr = bench.host(0).read(pelican::SR);
    assert_eq!(
        sr & status::TBS,
        status::TBS,
        "request cancelled: TBS = 1 (SR {sr:#04x})"
    );
    assert_eq!(sr & status::TCS, 0, "not completed (SR {sr:#04x})");
    assert_eq!(
        sr & (status::RBS | status::DOS),
        0,
        "FIFO emptied (SR {sr:#04x})"
    );
    assert_eq!(bench.host(0).read(pelican::RMC), 0);
    assert_eq!(bench.host(0).read(pelican::RBSA), rbsa, "RBSA kept");
    assert_eq!(bench.host(0).read(pelican::IR), 0, "no TI; RI, DOI cleared");

    // Back in operation, nothing is retransmitted; node 1 stored nothing of the broken frame.
    bench.run_bits(30);
    bench.host(0).write(pelican::MOD, 0);
    let dominant = bench.run_bits_counting_dominant_tx(0, 200);
    assert_eq!(dominant, 0, "the cancelled frame was sent after all");
    assert_eq!(
        bench.host(0).read(pelican::IR) & interrupt::TI,
        0,
        "no TI later either"
    );
    assert_eq!(bench.host(1).read(pelican::RMC), 0);
}

#[test]
fn a_node_entering_reset_mode_mid_frame_takes_no_further_part_in_the_frame() {
    // A receiver (node 2) enters reset mode 20 bits into a correct frame from node 0 to node 1.
    let mut bench = ControllerBench::operating(3);
    assert_eq!(bench.host(2).read(pelican::ECC), 0);
    transmit(
        &mut bench.host(0),
        &std_frame(0x123, &[1, 2, 3]),
        command::TR,
    );
    assert!(run_until_tx_falls(&mut bench, 0, 0, 50), "SOF");
    bench.run_bits(20);
    bench.host(2).write(pelican::MOD, mode::RM);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    bench.run_bits(20);
    assert_eq!(
        bench.host(1).read(pelican::RMC),
        1,
        "the frame itself was fine"
    );
    let (rxerr, ecc, ir) = (
        bench.host(2).read(pelican::RXERR),
        bench.host(2).read(pelican::ECC),
        bench.host(2).read(pelican::IR),
    );
    assert_eq!(
        (rxerr, ecc, ir),
        (0, 0, 0),
        "receiver in reset mode: (RXERR, ECC, IR) changed, so it detected an error"
    );

    // The transmitter (node 0) enters reset mode mid-frame; the receivers' error flag follows.
    let mut bench = ControllerBench::operating(2);
    transmit(&mut bench.host(0), &std_frame(0x7E5, &[0; 8]), command::TR);
    assert!(run_until_tx_falls(&mut bench, 0, 0, 50), "SOF");
    bench.run_bits(20);
    bench.host(0).write(pelican::MOD, mode::RM);
    bench.run_bits(40);
    assert_ne!(
        bench.host(1).read(pelican::RXERR),
        0,
        "node 1 saw the broken frame"
    );
    let (txerr, rxerr, ecc, ir) = (
        bench.host(0).read(pelican::TXERR),
        bench.host(0).read(pelican::RXERR),
        bench.host(0).read(pelican::ECC),
        bench.host(0).read(pelican::IR),
    );
    assert_eq!(
        (txerr, rxerr, ecc, ir),
        (0, 0, 0, 0),
        "transmitter in reset mode: (TXERR, RXERR, ECC, IR) changed"
    );
}

#[test]
fn a_frame_under_way_when_reset_mode_is_left_is_not_received_but_the_next_is() {
    const LATE: usize = 1;
    let mut bench = ControllerBench::operating(3);
    bench.host(LATE).write(pelican::MOD, mode::RM);
    let first = std_frame(0x0A0, &[0xFF, 0x00, 0xFF]);
    let second = std_frame(0x0A1, &[0x12]);
    transmit(&mut bench.host(0), &first, command::TR);
    assert!(run_until_tx_falls(&mut bench, 0, 0, 50), "SOF");
    bench.run_bits(10);
    bench.host(LATE).write(pelican::MOD, 0);
    let sr = bench.host(LATE).read(pelican::SR);
    assert_eq!(
        sr & (status::TS | status::RS),
        status::TS | status::RS,
        "waiting for 11 recessive bits (SR {sr:#04x})"
    );
    // Watched up to the EOF of the frame (it must not acknowledge it either).
    let rest = encode(&first).len() as u64 - 16;
    let dominant = bench.run_bits_counting_dominant_tx(LATE, rest);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(dominant, 0);
    assert_eq!(
        bench.host(LATE).read(pelican::RMC),
        0,
        "the frame under way is not received"
    );
    // The next frame, requested as soon as the first one ended, is received.
    transmit(&mut bench.host(0), &second, command::TR);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(drain_rx(&mut bench.host(LATE)), vec![second]);
    assert_eq!(drain_rx(&mut bench.host(2)), vec![first, second]);
    assert_eq!(bench.host(LATE).read(pelican::RXERR), 0);
}

// ---------------------------------------------------------------- sleep and wake-up

#[test]
fn sleep_is_left_by_writing_sm_0_with_wui() {
    let mut bench = ControllerBench::operating(1);
    assert_eq!(bench.host(0).read(pelican::IR), 0);
    bench.host(0).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(0).read(pelican::MOD), mode::SM, "asleep");
    bench.run_bits(40);
    assert_eq!(bench.host(0).read(pelican::MOD), mode::SM, "still asleep");
    assert_eq!(bench.host(0).read(pelican::IR), 0);
    bench.host(0).write(pelican::MOD, 0);
    assert_eq!(bench.host(0).read(pelican::MOD), 0, "awake");
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::WUI);
}

#[test]
fn a_node_woken_by_the_bus_does_not_store_the_waking_frame_but_the_next() {
    const SLEEPER: usize = 1;
    let mut bench = ControllerBench::operating(3);
    bench.host(SLEEPER).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(SLEEPER).read(pelican::MOD), mode::SM);
    let waking = std_frame(0x011, &[0xAA, 0x55]);
    let next = std_frame(0x012, &[0x01]);
    transmit(&mut bench.host(0), &waking, command::TR);
    assert!(run_until_tx_falls(&mut bench, 0, 0, 50), "SOF");
    let mut dominant = bench.run_bits_counting_dominant_tx(SLEEPER, 5);
    assert_eq!(
        bench.host(SLEEPER).read(pelican::MOD),
        0,
        "woken by the SOF"
    );
    assert_eq!(bench.host(SLEEPER).read(pelican::IR), interrupt::WUI);
    dominant += bench.run_bits_counting_dominant_tx(SLEEPER, encode(&waking).len() as u64 - 10);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(dominant, 0);
    assert_eq!(
        bench.host(SLEEPER).read(pelican::RMC),
        0,
        "the waking frame is lost"
    );
    transmit(&mut bench.host(0), &next, command::TR);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(drain_rx(&mut bench.host(SLEEPER)), vec![next]);
    assert_eq!(bench.host(SLEEPER).read(pelican::RXERR), 0);
    assert_eq!(drain_rx(&mut bench.host(2)), vec![waking, next]);
}

#[test]
fn sleep_requested_with_an_interrupt_pending_or_a_busy_bus_gives_wui_at_once() {
    let mut bench = ControllerBench::operating(2);
    // An interrupt pending (RI).
    transmit(&mut bench.host(0), &std_frame(0x020, &[2]), command::TR);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    bench.host(1).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(1).read(pelican::MOD), 0, "SM stays 0");
    assert_eq!(
        bench.host(1).read(pelican::IR),
        interrupt::RI | interrupt::WUI
    );
    drain_rx(&mut bench.host(1));
    assert_eq!(bench.host(1).read(pelican::IR), 0);

    // The bus busy with a frame.
    transmit(&mut bench.host(0), &std_frame(0x021, &[3; 8]), command::TR);
    assert!(run_until_tx_falls(&mut bench, 0, 0, 50), "SOF");
    bench.run_bits(10);
    bench.host(1).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(1).read(pelican::MOD), 0, "SM stays 0");
    assert_eq!(bench.host(1).read(pelican::IR), interrupt::WUI);
    assert!(bench.run_until_tx_buffer_free(0, MAX_FRAME_BITS));
    assert_eq!(
        bench.host(1).read(pelican::RMC),
        1,
        "still receiving normally"
    );

    // With WUIE = 0 the refused request raises nothing.
    bench
        .host(1)
        .write(pelican::IER, !(interrupt::WUI | interrupt::RI));
    bench.host(1).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(1).read(pelican::MOD), 0);
    assert_eq!(bench.host(1).read(pelican::IR), 0);
}

// ---------------------------------------------------------------- CLKOUT

#[test]
fn clkout_divides_fosc_by_every_cdr_code() {
    // The sampling sees clkout once per controller clock (right after the rising edge), so a
    // divided clock shows as runs of equal samples: code c gives runs of c + 1 clocks.
    let mut bench = ControllerBench::new(1);
    let cdr = bench.host(0).read(pelican::CDR);
    assert_eq!(cdr & clock_divider::PELICAN, 0, "hardware reset: BasicCAN");
    if cdr & clock_divider::CLOCK_OFF == 0 && cdr & clock_divider::DIVIDER != 7 {
        let half = (cdr & clock_divider::DIVIDER) as usize + 1;
        let samples = sample_clkout(&mut bench, 0, 100);
        assert!(
            inner_runs(&samples).iter().all(|&r| r == half),
            "after reset CLKOUT follows the CDR read ({cdr:#04x})"
        );
    }
    for code in 0..7u8 {
        bench
            .host(0)
            .write(pelican::CDR, clock_divider::PELICAN | code);
        sample_clkout(&mut bench, 0, 20);
        let samples = sample_clkout(&mut bench, 0, 840);
        let half = code as usize + 1;
        let runs = inner_runs(&samples);
        assert!(
            runs.iter().all(|&r| r == half),
            "code {code}: fosc/{} wants runs of {half} clocks, got {runs:?}",
            2 * half
        );
        let edges = rising_edges(&samples);
        let want = 840 / (2 * half);
        assert!(
            edges.abs_diff(want) <= 1,
            "code {code}: {edges} rising edges in 840 clocks, want {want}"
        );
    }
    // Code 7 passes fosc through. Sampled once per clock at a fixed phase it aliases to a
    // constant level: its frequency cannot be seen by this bench, only that it is not divided.
    // Every engine hands over the outputs of a cycle with the clock low again (docs/ENGINES.md),
    // so that level is low; on Verilator this is the one cycle whose falling edge is evaluated.
    bench
        .host(0)
        .write(pelican::CDR, clock_divider::PELICAN | 7);
    sample_clkout(&mut bench, 0, 20);
    let samples = sample_clkout(&mut bench, 0, 200);
    assert!(
        samples.iter().all(|&s| !s),
        "code 7 (fosc) sampled once per clock, with the clock low, reads low"
    );
}

#[test]
fn clock_off_holds_clkout_high_and_is_writable_in_reset_mode_only() {
    let mut bench = ControllerBench::new(1);
    for code in 0..8u8 {
        bench.host(0).write(
            pelican::CDR,
            clock_divider::PELICAN | clock_divider::CLOCK_OFF | code,
        );
        let samples = sample_clkout(&mut bench, 0, 100);
        assert!(
            samples.iter().all(|&s| s),
            "code {code} with clock off: held high"
        );
    }
    // Operating mode: bits 2..0 change, bit 3 (clock off) does not.
    bench
        .host(0)
        .write(pelican::CDR, clock_divider::PELICAN | 1);
    configure_pelican(&mut bench.host(0));
    bench.host(0).write(pelican::MOD, 0);
    bench.run_bits(INTEGRATION_BITS);
    bench.host(0).write(
        pelican::CDR,
        clock_divider::PELICAN | clock_divider::CLOCK_OFF | 3,
    );
    assert_eq!(
        bench.host(0).read(pelican::CDR),
        clock_divider::PELICAN | 3,
        "CDR.3 kept, CDR.2..0 written"
    );
    sample_clkout(&mut bench, 0, 20);
    let samples = sample_clkout(&mut bench, 0, 160);
    assert!(inner_runs(&samples).iter().all(|&r| r == 4), "fosc/8");
}

/// Enters sleep with CLKOUT at fosc/4 and returns the clkout samples of the 40 bit times that
/// follow and the clock (counted from the MOD write) of its last change.
fn clkout_into_sleep(bench: &mut ControllerBench) -> (Vec<bool>, usize) {
    bench
        .host(0)
        .write(pelican::CDR, clock_divider::PELICAN | 1);
    bench.run_bits(1);
    bench.host(0).write(pelican::MOD, mode::SM);
    assert_eq!(bench.host(0).read(pelican::MOD), mode::SM);
    // The MOD read took one clock: sample i is taken after clock i + 2 counted from the MOD write,
    // and a change between samples i and i + 1 happened at clock i + 3.
    let samples = sample_clkout(bench, 0, 40 * clocks_per_bit());
    let last_change = samples
        .windows(2)
        .rposition(|w| w[0] != w[1])
        .expect("clkout ran on in sleep")
        + 3;
    (samples, last_change)
}

#[test]
fn clkout_stops_low_in_sleep_and_runs_again_after_wake_up() {
    let mut bench = ControllerBench::operating(1);
    let (samples, last_change) = clkout_into_sleep(&mut bench);
    let bit = clocks_per_bit() as usize;
    assert!(
        last_change <= 16 * bit,
        "clkout stopped {last_change} clocks after sleep began, want at most 16 bit times"
    );
    assert!(
        inner_runs(&samples[..last_change - 3])
            .iter()
            .all(|&r| r == 2),
        "fosc/4 up to the stop"
    );
    assert!(
        samples[last_change - 2..].iter().all(|&s| !s),
        "clkout stays low in sleep"
    );
    assert_eq!(bench.host(0).read(pelican::MOD), mode::SM);
    bench.host(0).write(pelican::MOD, 0);
    let samples = sample_clkout(&mut bench, 0, 100);
    assert!(
        inner_runs(&samples).iter().all(|&r| r == 2),
        "running again after wake-up"
    );
    assert_eq!(bench.host(0).read(pelican::IR), interrupt::WUI);
}

#[test]
fn clkout_runs_at_least_15_bit_times_into_sleep() {
    let mut bench = ControllerBench::operating(1);
    let (_, last_change) = clkout_into_sleep(&mut bench);
    let bit = clocks_per_bit() as usize;
    assert!(
        last_change >= 15 * bit,
        "clkout stopped {last_change} clocks ({:.2} bit times) after sleep began, want at least 15 bit times ({} clocks)",
        last_change as f64 / bit as f64,
        15 * bit
    );
}
