//! The generated Verilog of the complete controller against the rust-hdl model: the same per-cycle
//! stimulus on two controllers on one bus, run by rust-hdl, by Icarus, by the simulator's
//! Verilator engine and by its compiled engine (with its skipping of unchanged groups of cells and
//! without), and the outputs of all (`tx`, `rdata`, `irq_n`, `clkout` after every rising edge)
//! compared cycle by cycle.
//!
//! Needs `iverilog`/`vvp` and `verilator` (`make tools` installs them); a developer without Icarus
//! may skip these tests with `CANSIM_SKIP_ICARUS=1`.

use std::path::PathBuf;
use std::time::Instant;

use golden::frame::{Frame, Id};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use rtl::registers::{basic, clock_divider, command, interrupt, mode, pelican, status};
use sim::host::frame_buffer::{buffer_len, encode_buffer};
use testbenches::equivalence::controller_verilog;
use testbenches::equivalence::{
    first_difference, first_mismatch, icarus_skipped, read_results, run_compiled, run_rust,
    run_verilated, verilated_skips_agree, without_initial_blocks, Simulator, Stimulus,
    StimulusBuilder, Trace, VerilogBench, CLOCKS_PER_BIT,
};

// ---- helpers ----------------------------------------------------------------------------------

fn std_frame(id: u16, data: &[u8]) -> Frame {
    Frame::data(Id::standard(id).unwrap(), data).unwrap()
}

fn ext_frame(id: u32, data: &[u8]) -> Frame {
    Frame::data(Id::extended(id).unwrap(), data).unwrap()
}

/// A fresh scratch directory for one test.
fn scratch_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("verilog_equivalence_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn skip_without_icarus(test: &str) -> bool {
    icarus_skipped(test)
}

/// Runs `stim` on the rust-hdl model, on the simulator's Verilator engine (the library) and in the
/// Verilog simulators, prints the timings, and panics on the first difference with the accesses
/// before it.
///
/// With `EQUIVALENCE_READS` set in the environment, every read and its rust-hdl value is printed
/// (to see what a scenario does).
fn compare(name: &str, stim: &Stimulus) -> Trace {
    let t = Instant::now();
    let rust = run_rust(stim);
    let rust_s = t.elapsed().as_secs_f64();
    if std::env::var_os("EQUIVALENCE_READS").is_some() {
        for r in read_results(stim, &rust) {
            eprintln!(
                "read {:7} n{} [{:3}] = {}",
                r.cycle, r.node, r.addr, r.value
            );
        }
    }
    eprintln!(
        "{name}: {} cycles × {} nodes; rust-hdl {rust_s:.2} s ({:.0} cycles/s)",
        stim.len(),
        stim.nodes,
        stim.len() as f64 / rust_s
    );
    let t = Instant::now();
    let library = run_verilated(stim).unwrap_or_else(|e| panic!("{name}: {e}"));
    let library_s = t.elapsed().as_secs_f64();
    eprintln!(
        "{name}: Verilator engine {library_s:.2} s ({:.0} cycles/s, model build or load included)",
        stim.len() as f64 / library_s
    );
    if let Some(m) = first_mismatch(&rust, &library) {
        let (k, _) = first_difference(&rust, &library).unwrap_or_default();
        panic!(
            "{name}: {m}\naccesses before it:\n{}",
            stim.describe(k.saturating_sub(40)..k + 1)
        );
    }
    for every_group in [false, true] {
        let t = Instant::now();
        let compiled = run_compiled(stim, every_group).unwrap_or_else(|e| panic!("{name}: {e}"));
        eprintln!(
            "{name}: compiled engine (every group: {every_group}) {:.2} s",
            t.elapsed().as_secs_f64()
        );
        if let Some(m) = first_mismatch(&rust, &compiled) {
            let (k, _) = first_difference(&rust, &compiled).unwrap_or_default();
            panic!(
                "{name}: {m}\naccesses before it:\n{}",
                stim.describe(k.saturating_sub(40)..k + 1)
            );
        }
    }
    for simulator in simulators() {
        let dir = scratch_dir(&format!("{name}_{}", simulator.name()));
        let t = Instant::now();
        let bench = VerilogBench::new(simulator, stim.nodes, stim.len(), &dir)
            .unwrap_or_else(|e| panic!("{} compile: {e}", simulator.name()));
        let compile_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let verilog = bench
            .run(stim)
            .unwrap_or_else(|e| panic!("{} run: {e}", simulator.name()));
        let run_s = t.elapsed().as_secs_f64();
        eprintln!(
            "{name}: {} compile {compile_s:.2} s, run {run_s:.2} s ({:.0} cycles/s)",
            simulator.name(),
            stim.len() as f64 / run_s
        );
        if let Some(m) = first_mismatch(&rust, &verilog) {
            let (k, _) = first_difference(&rust, &verilog).unwrap_or_default();
            panic!(
                "{name}: {m}\naccesses before it:\n{}(Verilog, testbench and stimulus kept in {})",
                stim.describe(k.saturating_sub(40)..k + 1),
                dir.display()
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    rust
}

/// Icarus always, Verilator too when it is installed.
fn simulators() -> Vec<Simulator> {
    let mut list = vec![Simulator::Icarus];
    if Simulator::Verilator.available() {
        list.push(Simulator::Verilator);
    } else {
        eprintln!("verilator not on PATH: comparing with Icarus only");
    }
    list
}

// ---- the harness itself -------------------------------------------------------------------------

/// A short stimulus: reset, configuration of both nodes, operating mode, IER and SR reads.
fn short_stimulus() -> Stimulus {
    let mut b = StimulusBuilder::new(2);
    b.reset(2).configure_pelican(0).configure_pelican(1);
    b.write_all(pelican::MOD, 0).idle(20);
    b.reads(0, [pelican::IER, pelican::SR, pelican::CDR]);
    b.reads(1, [pelican::IER, pelican::SR, pelican::CDR]);
    b.idle(5);
    b.build()
}

#[test]
fn harness_reports_a_deliberately_broken_verilog() {
    if skip_without_icarus("harness_reports_a_deliberately_broken_verilog") {
        return;
    }
    // IER moved from address 4 to 5 on the read side of the Verilog only (the write still lands
    // in IER): the IER read-back must differ.
    let good = testbenches::equivalence::controller_verilog();
    let read_side = good.find("module top$read(").expect("the read-side module");
    let target = "localparam  ier_address = 8'h4;";
    let at = read_side
        + good[read_side..]
            .find(target)
            .expect("patch target in top$read");
    let broken = format!(
        "{}localparam  ier_address = 8'h5;{}",
        &good[..at],
        &good[at + target.len()..]
    );
    let stim = short_stimulus();
    let rust = run_rust(&stim);
    let dir = scratch_dir("broken");
    let good_trace = VerilogBench::new(Simulator::Icarus, 2, stim.len(), &dir)
        .and_then(|b| b.run(&stim))
        .expect("Icarus");
    assert_eq!(first_mismatch(&rust, &good_trace), None);
    let broken_trace = VerilogBench::with_verilog(Simulator::Icarus, 2, stim.len(), &dir, &broken)
        .and_then(|b| b.run(&stim))
        .expect("Icarus");
    let ier_read = stim.cycles.iter().position(|c| c.nodes[0].re).unwrap();
    let m = first_mismatch(&rust, &broken_trace).expect("a mismatch");
    assert!(
        m.contains(&format!("cycle {ier_read}")) && m.contains("node 0") && m.contains("rdata"),
        "{m}"
    );
    assert!(m.contains("rust-hdl 0xff, Icarus 0x00"), "{m}");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- reset without initial blocks -----------------------------------------------------------

/// Cycles before the hardware reset and of the reset in [`after_reset_stimulus`].
const POWER_UP_CYCLES: usize = 3;
/// The registers that show a node's error state after counter writes: SR, IR, TXERR, RXERR, MOD.
const ERROR_STATE_REGISTERS: [u8; 5] = [
    pelican::SR,
    pelican::IR,
    pelican::TXERR,
    pelican::RXERR,
    pelican::MOD,
];
const RESET_CYCLES: usize = 4;

/// Power-up, a hardware reset, then configuration, an arbitration, reads of every register but the
/// RX FIFO RAM windows, the received frames read only as far as they were written (the rest of the
/// RAM is undefined after power-up, as on the SJA1000), an error burst and reset mode.
fn after_reset_stimulus() -> Stimulus {
    let f0 = std_frame(0x120, &[0x11, 0x22]);
    let f1 = ext_frame(0x121 << 18, &[0x33]);
    let mut b = StimulusBuilder::new(2);
    b.idle(POWER_UP_CYCLES).reset(RESET_CYCLES);
    // BasicCAN after reset: every register but the RX window (RAM).
    for n in 0..2 {
        b.reads(
            n,
            (0..=31).filter(|a| !(basic::RX..=basic::RX_LAST).contains(a)),
        );
    }
    b.configure_pelican(0).configure_pelican(1);
    b.reads(
        0,
        (0..=31).filter(|a| !(pelican::FRAME..=pelican::FRAME_LAST).contains(a)),
    );
    b.write_all(pelican::MOD, 0).idle_bits(14);
    let t = b.now();
    b.transmit(0, &f0, command::TR);
    b.seek(t).transmit(1, &f1, command::TR);
    b.idle_bits(260);
    b.read_status(0).read_status(1);
    b.reads(
        1,
        pelican::FRAME..pelican::FRAME + buffer_len(encode_buffer(&f0)[0]) as u8,
    );
    b.reads(
        0,
        pelican::FRAME..pelican::FRAME + buffer_len(encode_buffer(&f1)[0]) as u8,
    );
    b.release_rx_buffer(0).release_rx_buffer(1);
    b.transmit(0, &f0, command::TR).idle_bits(3);
    b.force_dominant(0, 20 * CLOCKS_PER_BIT).idle_bits(60);
    b.read_status(0).read_status(1);
    b.write_all(pelican::MOD, mode::RM).idle(4);
    b.read_status(0).read_status(1);
    b.build()
}

/// The generated Verilog does not rely on its `initial` blocks: without them every register starts
/// unknown in Icarus, and after the hardware reset the outputs are defined and equal to the rust-hdl
/// model's in every cycle.
#[test]
fn behaviour_after_reset_does_not_depend_on_initial_blocks() {
    if skip_without_icarus("behaviour_after_reset_does_not_depend_on_initial_blocks") {
        return;
    }
    let verilog = without_initial_blocks(&controller_verilog());
    assert!(!verilog.contains("initial"), "an initial block is left");
    let stim = after_reset_stimulus();
    let rust = run_rust(&stim);
    let dir = scratch_dir("no_initial");
    let icarus = VerilogBench::with_verilog(Simulator::Icarus, 2, stim.len(), &dir, &verilog)
        .and_then(|b| b.run(&stim))
        .expect("Icarus");
    assert_ne!(
        icarus.at(0, 0).unknown,
        0,
        "outputs before the reset should be unknown without initial blocks"
    );
    let after_reset = POWER_UP_CYCLES + RESET_CYCLES;
    if let Some(m) = first_mismatch(
        &rust.from_cycle(after_reset),
        &icarus.from_cycle(after_reset),
    ) {
        panic!("{m} (cycles counted from the end of the reset)");
    }
    assert!(rust.dominant_cycles() > 100, "traffic on the bus");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- the scripted scenario ---------------------------------------------------------------------

/// Where the scenario reads something it checks on the rust-hdl trace (so the scenario is known to
/// do what it says).
#[derive(Default)]
struct Checkpoints {
    /// Node 1's ALC read after losing arbitration.
    alc_1: usize,
    /// The frame information byte read from each node's RX window after the arbitration.
    fi: [usize; 2],
    /// Node 1's SR after TXERR = 255.
    sr_bus_off: usize,
    /// Node 0's ECC after the error burst.
    ecc_0: usize,
    /// Node 0's IR after waking up by bus activity.
    ir_wake: usize,
}

/// Reset, configuration, an arbitration between both nodes, RX window and RAM reads with release,
/// status and capture reads, an injected error burst, counter writes in reset mode, every CLKOUT
/// divider code and clock-off, sleep with wake-up by the bus and by the host; then more
/// traffic (extended, remote, self-reception, single shot, abort), a FIFO overrun, listen-only and
/// self-test, and a bus-off recovery by 128 × 11 recessive bits.
fn scripted() -> (Stimulus, Checkpoints) {
    let mut cp = Checkpoints::default();
    let mut b = StimulusBuilder::new(2);
    // Power-up: a few idle cycles (DFF initial values), then a hardware reset.
    b.idle(3).reset(4);
    // BasicCAN after reset: CR, SR, IR, CDR, and the 0xFF reads.
    for n in 0..2 {
        b.reads(n, [0, 1, 2, 3, 4, 5, 6, 7, 8, 31]);
    }
    b.concurrently(&mut [
        &mut |b: &mut StimulusBuilder| {
            b.configure_pelican(0);
        },
        &mut |b: &mut StimulusBuilder| {
            b.configure_pelican(1);
        },
    ]);
    // Reset-mode reads: the whole map including the filter and RAM windows.
    b.reads(0, 0..=31);
    b.write(1, pelican::EWLR, 100).write(1, pelican::RBSA, 0);
    b.reads(
        1,
        [pelican::EWLR, pelican::RBSA, pelican::BTR0, pelican::BTR1],
    );
    b.write_all(pelican::MOD, 0);
    b.idle_bits(14);

    // ---- Arbitration: both request in the same cycle; 0x120 beats 0x121 at ID.18 (ALC 10).
    let f0 = std_frame(0x120, &[0x11, 0x22]);
    let f1 = std_frame(0x121, &[0xA5, 0x5A, 0xFF]);
    b.concurrently(&mut [
        &mut |b: &mut StimulusBuilder| {
            b.transmit(0, &f0, command::TR);
        },
        &mut |b: &mut StimulusBuilder| {
            b.idle(2).transmit(1, &f1, command::TR);
        },
    ]);
    b.reads(0, [pelican::SR, pelican::SR]);
    b.idle_bits(60);
    cp.alc_1 = b.now() + 3;
    b.reads(1, [pelican::IR, pelican::SR, pelican::ALC, pelican::ALC]);
    b.idle_bits(90);
    // Both received the other's frame: IR, SR, the RX window, the RAM window, release.
    let t = b.now();
    cp.fi = [t + 2, t + 2];
    b.concurrently(&mut [
        &mut |b: &mut StimulusBuilder| {
            b.reads(0, [pelican::IR, pelican::SR]);
            b.read_rx_buffer(0).read_rx_ram(0).release_rx_buffer(0);
            b.read_status(0);
        },
        &mut |b: &mut StimulusBuilder| {
            b.reads(1, [pelican::IR, pelican::SR]);
            b.read_rx_buffer(1).read_rx_ram(1).release_rx_buffer(1);
            b.read_status(1);
        },
    ]);

    // ---- Error burst: node 1 sees 8 dominant bits in the middle of node 0's frame.
    let f2 = std_frame(0x555, &[1, 2, 3, 4, 5, 6, 7, 8]);
    b.transmit(0, &f2, command::TR);
    b.idle_bits(25).force_dominant(1, 8 * CLOCKS_PER_BIT);
    b.idle_bits(40);
    cp.ecc_0 = b.now() + 3;
    b.read_status(0).read_status(1);
    b.reads(0, [pelican::ECC, pelican::ECC]);
    b.idle_frame(&f2);
    b.read_status(0).read_status(1);
    b.read_and_release(1);
    b.reads(1, [pelican::SR, pelican::IR]);

    // ---- Counter writes in reset mode on node 1: TXERR 255 (bus-off), then 0; RXERR; EWLR.
    b.write(1, pelican::MOD, mode::RM);
    b.write(1, pelican::TXERR, 255);
    b.idle(3);
    cp.sr_bus_off = b.now();
    b.reads(1, ERROR_STATE_REGISTERS);
    b.write(1, pelican::RXERR, 10);
    b.write(1, pelican::TXERR, 0);
    b.idle(3);
    b.reads(1, ERROR_STATE_REGISTERS);
    b.write(1, pelican::RXERR, 130)
        .write(1, pelican::TXERR, 100);
    b.write(1, pelican::EWLR, 90);
    b.reads(1, [pelican::SR, pelican::TXERR, pelican::RXERR]);
    b.leave_reset_mode(1, 0);
    b.idle(4);
    b.reads(1, [pelican::SR, pelican::IR]);
    b.write(1, pelican::MOD, mode::RM);
    b.write(1, pelican::TXERR, 0).write(1, pelican::RXERR, 0);
    b.write(1, pelican::EWLR, 96);
    b.leave_reset_mode(1, 0);
    b.reads(1, [pelican::SR, pelican::IR]);
    b.idle_bits(14);

    // ---- CLKOUT: every divider code in operating mode, then clock-off (reset mode only).
    for code in 0..8 {
        b.write(0, pelican::CDR, clock_divider::PELICAN | code);
        b.read(0, pelican::CDR);
        b.idle(37);
    }
    b.write(0, pelican::MOD, mode::RM);
    b.write(
        0,
        pelican::CDR,
        clock_divider::PELICAN | clock_divider::CLOCK_OFF | 5,
    );
    b.idle(30);
    b.write(0, pelican::CDR, clock_divider::PELICAN | 7);
    b.idle(20);
    b.write(0, pelican::CDR, clock_divider::PELICAN | 2);
    b.leave_reset_mode(0, 0);
    b.idle_bits(14);

    // ---- Sleep: node 0 sleeps (IR read first: no pending interrupt), CLKOUT stops after 15
    // bits; node 1's frame wakes it (WUI) without being received by it.
    b.reads(0, [pelican::IR, pelican::SR]);
    b.write(0, pelican::MOD, mode::SM);
    b.read(0, pelican::MOD);
    b.idle_bits(20);
    b.read(0, pelican::MOD);
    b.transmit(1, &std_frame(0x7F0, &[0xC3]), command::TR);
    b.idle_bits(80);
    cp.ir_wake = b.now() + 1;
    b.reads(0, [pelican::MOD, pelican::IR, pelican::SR, pelican::RMC]);
    b.reads(1, [pelican::IR, pelican::SR]);
    // Sleep requested while an interrupt is pending: WUI at once; then sleep and a host wake-up.
    b.write(1, pelican::MOD, mode::SM);
    b.reads(1, [pelican::MOD, pelican::IR, pelican::IR]);
    b.write(1, pelican::MOD, mode::SM);
    b.idle_bits(18);
    b.write(1, pelican::MOD, 0);
    b.reads(1, [pelican::MOD, pelican::IR]);
    b.idle_bits(14);

    more_traffic(&mut b);
    bus_off_and_traffic(&mut b);
    b.idle_bits(2);
    (b.build(), cp)
}

/// Frame kinds and modes: extended, remote, DLC > 8, self-reception, single shot, standard against
/// extended arbitration, abort, listen-only, self-test, a closed acceptance filter.
fn more_traffic(b: &mut StimulusBuilder) {
    // Extended and remote frames, self-reception, single shot, abort.
    let frames = [
        ext_frame(0x1234_5678, &[0xDE, 0xAD, 0xBE, 0xEF]),
        Frame::remote(Id::standard(0x3FF).unwrap(), 4).unwrap(),
        Frame::remote(Id::extended(0x0ABC_DEF0).unwrap(), 8).unwrap(),
        Frame::data_with_dlc(Id::standard(0x001).unwrap(), 12, &[9; 8]).unwrap(),
        std_frame(0x000, &[]),
    ];
    for (i, f) in frames.iter().enumerate() {
        let node = i % 2;
        b.transmit(node, f, command::TR).idle_frame(f);
        b.read_status(node);
        b.read_and_release(1 - node).read_status(1 - node);
    }
    // Self-reception (node 0 receives its own frame too) and single shot without a partner
    // (node 1 in reset mode: no ACK, so the single shot fails).
    let f = std_frame(0x2AA, &[0x55; 8]);
    b.transmit(0, &f, command::SRR).idle_frame(&f);
    b.read_and_release(0)
        .read_and_release(0)
        .read_and_release(1);
    b.read_status(0).read_status(1);
    b.write(1, pelican::MOD, mode::RM);
    b.transmit(0, &std_frame(0x100, &[1]), command::TR | command::AT);
    b.idle_bits(80);
    b.read_status(0);
    b.leave_reset_mode(1, 0);
    b.idle_bits(14);
    // Arbitration between a standard frame and an extended one with the same base ID (the
    // standard data frame wins at SRR/RTR), and an abort of a request that lost.
    let t = b.now();
    b.transmit(0, &std_frame(0x4C1, &[0x77]), command::TR);
    b.seek(t)
        .transmit(1, &ext_frame(0x4C1 << 18, &[0x88]), command::TR);
    b.idle_bits(30);
    b.write(1, pelican::CMR, command::AT);
    b.idle_bits(50);
    b.read_status(0).read_status(1);
    b.read_and_release(0).read_and_release(1);

    // Listen-only node 1, self-test node 0: node 0's frame needs no ACK with STM.
    b.write_all(pelican::MOD, mode::RM);
    b.write(1, pelican::MOD, mode::LOM);
    b.write(0, pelican::MOD, mode::STM);
    b.idle_bits(14);
    let f = std_frame(0x0F0, &[0xF0, 0x0F]);
    b.transmit(0, &f, command::TR).idle_frame(&f);
    b.read_status(0).read_status(1).read_and_release(1);
    b.write_all(pelican::MOD, mode::RM);
    b.write_all(pelican::MOD, 0);
    b.idle_bits(14);

    // Acceptance filter closed on node 1 (single filter, exact 0x123), filter writes read back.
    b.write(1, pelican::MOD, mode::RM);
    b.write(1, pelican::MOD, mode::RM | mode::AFM);
    for (i, v) in [0x24u8, 0x60, 0, 0, 0, 0x0F, 0xFF, 0xFF].iter().enumerate() {
        b.write(1, pelican::ACR0 + i as u8, *v);
    }
    b.reads(1, pelican::ACR0..=pelican::AMR3);
    b.leave_reset_mode(1, mode::AFM);
    b.idle_bits(14);
    for id in [0x123u16, 0x124] {
        let f = std_frame(id, &[0xAB]);
        b.transmit(0, &f, command::TR).idle_frame(&f);
        b.read_status(1).read_and_release(1);
    }
    b.write(1, pelican::MOD, mode::RM);
    for i in 0..4 {
        b.write(1, pelican::ACR0 + i, 0)
            .write(1, pelican::AMR0 + i, 0xFF);
    }
    b.leave_reset_mode(1, 0);
    b.idle_bits(14);
}

/// The traffic after the first part: a FIFO overrun, bus-off by error bursts and recovery by
/// 128 × 11 recessive bits, then alternating traffic up to 200 000 cycles.
fn bus_off_and_traffic(b: &mut StimulusBuilder) {
    // FIFO overrun on node 1: six 8-byte frames (13 bytes each) into 64 bytes, then CDO.
    for i in 0..6u8 {
        b.transmit(0, &std_frame(0x300 + u16::from(i), &[i; 8]), command::TR);
        b.idle_bits(140);
        b.read_status(0);
    }
    b.read_status(1);
    b.read_rx_ram(1);
    for _ in 0..5 {
        b.read_and_release(1);
    }
    b.write(1, pelican::CMR, command::CDO);
    b.read_status(1);

    // Bus-off by error bursts on node 0's rx while it transmits, recovery by 128 × 11 recessive
    // bits (about 45 000 cycles), and a frame afterwards.
    b.transmit(0, &std_frame(0x0AA, &[0; 8]), command::TR);
    for _ in 0..40 {
        b.idle_bits(3).force_dominant(0, 20 * CLOCKS_PER_BIT);
        b.idle_bits(20);
    }
    b.read_status(0).read_status(1);
    b.leave_reset_mode(0, 0);
    b.idle_bits(128 * 11 + 40);
    b.read_status(0);
    b.read_status(1);
    b.release_rx_buffer(1);
    b.transmit(0, &std_frame(0x0AB, &[1, 2]), command::TR);
    b.idle_bits(100);
    b.read_status(0).read_status(1).read_and_release(1);
    // Alternating traffic with varied frames and simultaneous requests.
    let mut i = 0u32;
    while b.now() < 200_000 {
        let id = (i * 0x2F1 + 7) & 0x7FF;
        let data: Vec<u8> = (0..(i % 9) as u8)
            .map(|k| k.wrapping_mul(37) ^ i as u8)
            .collect();
        let f = if i % 3 == 2 {
            ext_frame(id << 18 | i, &data)
        } else {
            std_frame(id as u16, &data)
        };
        let node = (i % 2) as usize;
        let t = b.now();
        b.transmit(node, &f, command::TR);
        if i % 4 == 3 {
            b.seek(t).transmit(
                1 - node,
                &std_frame((id ^ 1) as u16, &[i as u8]),
                command::TR,
            );
        }
        b.idle_bits(if i % 4 == 3 { 300 } else { 150 });
        b.read_status(0).read_status(1);
        b.concurrently(&mut [
            &mut |b: &mut StimulusBuilder| {
                b.read_and_release(0);
            },
            &mut |b: &mut StimulusBuilder| {
                b.read_and_release(1);
            },
        ]);
        i += 1;
    }
}

/// Checks on the rust-hdl trace that the scenario exercises what it claims.
fn check_scenario(trace: &Trace, cp: &Checkpoints) {
    assert!(trace.dominant_cycles() > 1000, "traffic on the bus");
    assert!(
        trace.irq_cycles(0) > 0 && trace.irq_cycles(1) > 0,
        "interrupts"
    );
    assert_eq!(trace.at(cp.alc_1, 1).rdata, 10, "node 1 lost at ID.18");
    // Node 0 received 0x121 with 3 bytes, node 1 0x120 with 2 bytes.
    assert_eq!(trace.at(cp.fi[0], 0).rdata, 0x03, "FI at node 0");
    assert_eq!(trace.at(cp.fi[1], 1).rdata, 0x02, "FI at node 1");
    assert_ne!(trace.at(cp.sr_bus_off, 1).rdata & status::BS, 0, "bus-off");
    assert_ne!(trace.at(cp.ecc_0, 0).rdata, 0, "ECC after the burst");
    assert_ne!(
        trace.at(cp.ir_wake, 0).rdata & interrupt::WUI,
        0,
        "wake-up interrupt"
    );
}

/// At least 200 000 cycles: both nodes, register writes and reads (FIFO window included), traffic
/// with arbitration, injected errors, error passive, bus-off and recovery, sleep and wake-up.
#[test]
fn scripted_scenario_rust_hdl_equals_verilog() {
    if skip_without_icarus("scripted_scenario_rust_hdl_equals_verilog") {
        return;
    }
    let (stim, cp) = scripted();
    assert!(stim.len() >= 200_000, "{} cycles", stim.len());
    let trace = compare("scripted", &stim);
    check_scenario(&trace, &cp);
}

/// The Verilator engine's skips of quiet edges (docs/ENGINES.md, "Skipping quiet edges") along the
/// scripted scenario: after every skip the skipping model is in the state, and shows the outputs,
/// that stepping each edge gave. As for traced nodes (CLKOUT, segment and sample point must hold),
/// then as for untraced ones, whose skips run on through the ends of Sync and TSEG2 and past
/// CLKOUT's toggles (the wrapper loads the segment, the triple sampling's samples and the divider
/// too).
#[test]
fn scripted_scenario_verilator_skips_reach_what_stepping_does() {
    let (stim, _) = scripted();
    let traced = verilated_skips_agree(&stim, true).unwrap_or_else(|e| panic!("traced: {e}"));
    let untraced = verilated_skips_agree(&stim, false).unwrap_or_else(|e| panic!("untraced: {e}"));
    let edges = (stim.len() * stim.nodes) as u64;
    eprintln!("skipped {traced} (traced) and {untraced} (untraced) of {edges} edges");
    // CLKOUT runs at fosc/2 in parts of the scenario, and is watched: no quiet edges there.
    assert!(traced * 8 > edges, "only {traced} of {edges} edges skipped");
    assert!(
        untraced > traced,
        "untraced {untraced} edges skipped, traced {traced}"
    );
}

// ---- random register traffic ------------------------------------------------------------------

/// Cycles of one random case.
const RANDOM_CYCLES: usize = 3_000;

/// One step of a random host program.
#[derive(Clone, Debug)]
enum Op {
    Write(u8, u8),
    Read(u8),
    Transmit(Frame, u8),
    ReadAndRelease,
    /// Reset mode, then operating mode with these MOD bits.
    ModeChange(u8),
    Idle(usize),
    ForceDominant(usize),
}

/// Bit timings fast enough for traffic in 3 000 cycles (BTR0, BTR1): 6 to 10 tq of 2 clocks.
const FAST_TIMINGS: [(u8, u8); 3] = [(0x00, 0x12), (0x40, 0x23), (0x80, 0x25)];

fn arb_frame() -> impl Strategy<Value = Frame> {
    let id = prop_oneof![
        3 => (0..=0x7FF_u16).prop_map(Id::Standard),
        1 => (0..=0x1FFF_FFFF_u32).prop_map(Id::Extended),
    ];
    (id, 0..=15_u8, prop::bool::weighted(0.2), any::<[u8; 8]>()).prop_map(
        |(id, dlc, remote, bytes)| {
            if remote {
                Frame::remote(id, dlc).unwrap()
            } else {
                Frame::data_with_dlc(id, dlc, &bytes[..usize::from(dlc.min(8))]).unwrap()
            }
        },
    )
}

/// Registers a driver writes in operating mode (and a few reset-mode ones that are then ignored).
const USUAL_WRITES: [u8; 8] = [
    pelican::IER,
    pelican::CMR,
    pelican::CDR,
    pelican::EWLR,
    pelican::TXERR,
    pelican::RXERR,
    pelican::FRAME,
    pelican::FRAME + 3,
];

fn arb_op() -> impl Strategy<Value = Op> {
    let cmd = prop_oneof![
        4 => Just(command::TR),
        1 => Just(command::SRR),
        1 => Just(command::TR | command::AT),
        1 => Just(command::AT),
        1 => Just(command::CDO),
    ];
    prop_oneof![
        1 => (0..=127_u8, any::<u8>()).prop_map(|(a, v)| Op::Write(a, v)),
        2 => (prop::sample::select(&USUAL_WRITES[..]), any::<u8>()).prop_map(|(a, v)| Op::Write(a, v)),
        3 => (0..=127_u8).prop_map(Op::Read),
        3 => (arb_frame(), cmd).prop_map(|(f, c)| Op::Transmit(f, c)),
        1 => Just(Op::ReadAndRelease),
        1 => arb_mode().prop_map(Op::ModeChange),
        3 => (1..400_usize).prop_map(Op::Idle),
        1 => (1..80_usize).prop_map(Op::ForceDominant),
    ]
}

/// MOD bits for operating mode: mostly none.
fn arb_mode() -> impl Strategy<Value = u8> {
    prop_oneof![
        6 => Just(0_u8),
        1 => Just(mode::LOM),
        1 => Just(mode::STM),
        1 => Just(mode::AFM),
        1 => Just(mode::SM),
    ]
}

/// A random case: a common bit timing, per node a random IER and mode write, then random host
/// programs on both nodes.
#[derive(Clone, Debug)]
struct RandomCase {
    timing: (u8, u8),
    ier: [u8; 2],
    modes: [u8; 2],
    programs: [Vec<Op>; 2],
}

fn arb_case() -> impl Strategy<Value = RandomCase> {
    (
        prop::sample::select(&FAST_TIMINGS[..]),
        any::<[u8; 2]>(),
        [arb_mode(), arb_mode()],
        [
            prop::collection::vec(arb_op(), 5..40),
            prop::collection::vec(arb_op(), 5..40),
        ],
    )
        .prop_map(|(timing, ier, modes, programs)| RandomCase {
            timing,
            ier,
            modes,
            programs,
        })
}

fn random_stimulus(case: &RandomCase) -> Stimulus {
    let mut b = StimulusBuilder::new(2);
    b.reset(2);
    let start = b.now();
    let mut end = start;
    for n in 0..2 {
        b.seek(start);
        b.configure_pelican_with(n, case.timing.0, case.timing.1);
        b.write(n, pelican::IER, case.ier[n]);
        b.write(n, pelican::MOD, mode::RM | case.modes[n]);
        b.leave_reset_mode(n, case.modes[n]);
        for op in &case.programs[n] {
            if b.now() >= RANDOM_CYCLES {
                break;
            }
            match op {
                Op::Write(a, v) => {
                    b.write(n, *a, *v);
                }
                Op::Read(a) => {
                    b.read(n, *a);
                }
                Op::Transmit(f, c) => {
                    b.transmit(n, f, *c);
                }
                Op::ReadAndRelease => {
                    b.read_and_release(n);
                }
                Op::ModeChange(m) => {
                    b.write(n, pelican::MOD, mode::RM);
                    b.write(n, pelican::MOD, mode::RM | m);
                    b.leave_reset_mode(n, *m);
                }
                Op::Idle(c) => {
                    b.idle(*c);
                }
                Op::ForceDominant(c) => {
                    b.force_dominant(n, *c);
                }
            }
        }
        end = end.max(b.now());
    }
    b.seek(end.max(RANDOM_CYCLES));
    let mut stim = b.build();
    stim.cycles.truncate(RANDOM_CYCLES);
    stim
}

#[test]
fn random_register_traffic_rust_hdl_equals_icarus() {
    if skip_without_icarus("random_register_traffic_rust_hdl_equals_icarus") {
        return;
    }
    let dir = scratch_dir("random");
    let t = Instant::now();
    let bench =
        VerilogBench::new(Simulator::Icarus, 2, RANDOM_CYCLES, &dir).expect("Icarus compile");
    eprintln!("random: Icarus compile {:.2} s", t.elapsed().as_secs_f64());
    let mut runner = TestRunner::new(Config {
        // PROPTEST_CASES overrides the few cases of a normal run (each takes ~2 s of Icarus).
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(6),
        max_shrink_iters: 64,
        failure_persistence: None,
        ..Config::default()
    });
    let dominant = std::cell::Cell::new(0);
    let result = runner.run(&arb_case(), |case| {
        let stim = random_stimulus(&case);
        let t = Instant::now();
        let rust = run_rust(&stim);
        let rust_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let icarus = bench
            .run(&stim)
            .map_err(|e| TestCaseError::fail(format!("Icarus: {e}")))?;
        let icarus_s = t.elapsed().as_secs_f64();
        eprintln!(
            "random case: {} cycles; rust-hdl {rust_s:.2} s, Icarus {icarus_s:.2} s, bus dominant \
             {} cycles",
            stim.len(),
            rust.dominant_cycles()
        );
        dominant.set(dominant.get() + rust.dominant_cycles());
        let library = run_verilated(&stim).map_err(|e| TestCaseError::fail(e.to_string()))?;
        for other in [&icarus, &library] {
            if let Some(m) = first_mismatch(&rust, other) {
                let (k, _) = first_difference(&rust, other).unwrap_or_default();
                return Err(TestCaseError::fail(format!(
                    "{m}\naccesses before it:\n{}",
                    stim.describe(k.saturating_sub(40)..k + 1)
                )));
            }
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    assert!(dominant.get() > 0, "no traffic in any random case");
    let _ = std::fs::remove_dir_all(&dir);
}
