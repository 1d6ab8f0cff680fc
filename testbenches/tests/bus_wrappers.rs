//! The bus wrappers (`rtl::bus`: Wishbone, AXI4-Lite, APB) on both register layouts: two wrapped
//! controllers on one CAN bus, each driven by a bus master model through the Linux driver's start
//! sequence (SJA1000 data sheet 6.4 and the PeliCAN map, section 6.5), then one sends a standard
//! frame and the other an extended one. What the reads give is checked against the data sheet,
//! and the emitted Verilog (`can_controller.v` plus the wrapper's file, the layout chosen by the
//! `word_stride` parameter) must give the same outputs as the rust-hdl model in every cycle, on
//! Icarus (and Verilator for the byte layout).

use std::path::PathBuf;

use rtl::bus::apb::CanControllerApb;
use rtl::bus::axi4_lite::CanControllerAxiLite;
use rtl::bus::wishbone::CanControllerWishbone;
use testbenches::bus_masters::{ApbMaster, AxiLiteMaster, BusOp, Layout, WishboneMaster};
use testbenches::equivalence::{icarus_skipped, Simulator};
use testbenches::wrapper_equivalence::{first_mismatch, run_rust, run_verilog, Master, Wrapped};

/// PeliCAN registers (data sheet Table 3 and 6.5).
const MOD: u8 = 0;
const CMR: u8 = 1;
const SR: u8 = 2;
const IR: u8 = 3;
const IER: u8 = 4;
const BTR0: u8 = 6;
const BTR1: u8 = 7;
const RX_FRAME: u8 = 16;
const AMR0: u8 = 20;
const RMC: u8 = 29;
const CDR: u8 = 31;
/// BasicCAN control register after a hardware reset: reset request set, bit 5 reads 1 (6.3.1).
const BASIC_CR_AFTER_RESET: u8 = 0x21;
/// BTR1 0x14: TSEG1 5 tq, TSEG2 2 tq, with BTR0 0 (tq = 2 clocks): 16 clocks per bit.
const FAST_BTR1: u8 = 0x14;
/// Names of the reads of the RX buffer's bytes.
const RX_NAMES: [&str; 8] = [
    "rx 0", "rx 1", "rx 2", "rx 3", "rx 4", "rx 5", "rx 6", "rx 7",
];
/// Clocks for a frame of up to 160 bits and its interrupt.
const FRAME_CYCLES: usize = 160 * 16 + 200;

/// A script of bus operations with the reads whose values the test checks, by name.
struct Script {
    layout: Layout,
    ops: Vec<BusOp>,
    named: Vec<(&'static str, u8, usize)>,
    reads: usize,
}

impl Script {
    fn new(word_stride: bool) -> Script {
        Script {
            layout: Layout { word_stride },
            ops: vec![BusOp::Reset(3)],
            named: Vec::new(),
            reads: 0,
        }
    }

    fn write(&mut self, reg: u8, value: u8) -> &mut Self {
        self.ops.push(self.layout.write(reg, value));
        self
    }

    fn read(&mut self, name: &'static str, reg: u8) -> &mut Self {
        self.ops.push(self.layout.read(reg));
        self.named.push((name, reg, self.reads));
        self.reads += 1;
        self
    }

    fn idle(&mut self, cycles: usize) -> &mut Self {
        self.ops.push(BusOp::Idle(cycles));
        self
    }

    /// Four registers from `first` (a multiple of 4) in one 32-bit write with every lane enabled
    /// in the byte layout; one write each in the word layout.
    fn write4(&mut self, first: u8, values: [u8; 4]) -> &mut Self {
        if self.layout.word_stride {
            for (k, v) in values.into_iter().enumerate() {
                self.write(first + k as u8, v);
            }
        } else {
            self.ops.push(BusOp::Write {
                addr: u32::from(first),
                data: u32::from_le_bytes(values),
                strobe: 0xF,
            });
        }
        self
    }

    /// The Linux driver's start: PeliCAN, open filter, fast bit timing, interrupts, operating mode.
    fn start(&mut self, ier: u8) -> &mut Self {
        self.read("CR after reset", MOD)
            .write(CDR, 0x80)
            .read("MOD in reset mode", MOD)
            .write(BTR0, 0x00)
            .write(BTR1, FAST_BTR1)
            .write4(AMR0, [0xFF; 4])
            .write(IER, ier)
            .write(MOD, 0x00)
            .read("MOD operating", MOD)
            .idle(12 * 16)
    }

    /// Transmit `bytes` (frame information, identifier, data) through the TX buffer.
    fn transmit(&mut self, bytes: &[u8]) -> &mut Self {
        for (k, b) in bytes.iter().enumerate() {
            self.write(RX_FRAME + k as u8, *b);
        }
        self.write(CMR, 0x01)
    }

    /// The received frame's `count` bytes and the release.
    fn receive(&mut self, count: u8) -> &mut Self {
        for k in 0..count {
            self.read(RX_NAMES[usize::from(k)], RX_FRAME + k);
        }
        self.read("RMC before release", RMC)
            .write(CMR, 0x04)
            .read("RMC after release", RMC)
    }

    fn value(&self, reads: &[u32], name: &str) -> u8 {
        let &(_, reg, k) = self
            .named
            .iter()
            .find(|(n, ..)| *n == name)
            .unwrap_or_else(|| panic!("no read {name}"));
        self.layout.byte_of(reg, reads[k])
    }
}

/// Standard frame 123h, DLC 2 (frame information 02h, ID 24h 60h, data ABh CDh) from node 0;
/// extended frame 1ABCDE5h, DLC 1 from node 1 (frame information 81h, ID 35h 79h BCh A8h).
const STANDARD: [u8; 5] = [0x02, 0x24, 0x60, 0xAB, 0xCD];
const EXTENDED: [u8; 6] = [0x81, 0x35, 0x79, 0xBC, 0xA8, 0x5A];

fn scripts(word_stride: bool) -> [Script; 2] {
    let mut sender = Script::new(word_stride);
    sender
        .start(0x03)
        .transmit(&STANDARD)
        .idle(FRAME_CYCLES)
        .read("IR after sending", IR)
        .read("SR after sending", SR)
        .idle(2 * FRAME_CYCLES)
        .read("IR after receiving", IR)
        .receive(6)
        .ops
        .push(BusOp::Reset(2));
    sender.read("CR after a reset", MOD);
    let mut receiver = Script::new(word_stride);
    receiver
        .start(0x01)
        .idle(FRAME_CYCLES / 2)
        .read("IR after receiving", IR)
        .receive(5)
        .idle(FRAME_CYCLES)
        .transmit(&EXTENDED)
        .idle(FRAME_CYCLES)
        .read("SR after sending", SR);
    [sender, receiver]
}

fn workdir(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("cansim-wrapper-{name}-{}", std::process::id()))
}

/// Runs the bench on `W` with `masters` made from the scripts, checks what the reads gave, and
/// compares the Verilog with the model on `simulators`.
fn bench<W: Wrapped>(
    word_stride: bool,
    master: fn(Vec<BusOp>) -> Box<dyn Master>,
    simulators: &[Simulator],
) {
    let scripts = scripts(word_stride);
    let mut masters: Vec<Box<dyn Master>> = scripts.iter().map(|s| master(s.ops.clone())).collect();
    let model = run_rust::<W>(word_stride, &mut masters, 50, 40_000);
    let what = format!("{} word_stride {}", W::BUS.name(), u8::from(word_stride));
    assert!(
        masters.iter().all(|m| m.finished()),
        "{what}: a master did not finish"
    );
    let [sender, receiver] = &scripts;
    let (s, r) = (masters[0].reads(), masters[1].reads());
    // Data sheet: CR after a hardware reset; MOD in reset mode (RM) and operating; the interrupts
    // (TI 02h, RI 01h) and SR (TBS, TCS, RBS...); the received bytes; RMC 1, then 0 after RRB.
    assert_eq!(
        sender.value(s, "CR after reset"),
        BASIC_CR_AFTER_RESET,
        "{what}"
    );
    assert_eq!(sender.value(s, "MOD in reset mode"), 0x01, "{what}");
    assert_eq!(sender.value(s, "MOD operating"), 0x00, "{what}");
    assert_eq!(sender.value(s, "IR after sending"), 0x02, "{what}: TI");
    assert_eq!(
        sender.value(s, "SR after sending") & 0x0C,
        0x0C,
        "{what}: TBS, TCS"
    );
    assert_eq!(receiver.value(r, "IR after receiving"), 0x01, "{what}: RI");
    for (k, b) in STANDARD.iter().enumerate() {
        let name = RX_NAMES[k];
        assert_eq!(receiver.value(r, name), *b, "{what}: {name}");
    }
    assert_eq!(receiver.value(r, "RMC before release"), 1, "{what}");
    assert_eq!(receiver.value(r, "RMC after release"), 0, "{what}");
    assert_eq!(sender.value(s, "IR after receiving"), 0x01, "{what}: RI");
    for (k, b) in EXTENDED.iter().enumerate() {
        let name = RX_NAMES[k];
        assert_eq!(sender.value(s, name), *b, "{what}: {name}");
    }
    assert_eq!(
        sender.value(s, "CR after a reset"),
        BASIC_CR_AFTER_RESET,
        "{what}"
    );
    for &simulator in simulators {
        let dir = workdir(&format!("{}-{}", W::BUS.name(), u8::from(word_stride)));
        let verilog = run_verilog::<W>(simulator, word_stride, &model, &dir)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        if let Some(m) = first_mismatch::<W>(&model, &verilog) {
            panic!("{what}, {}: {m}", simulator.name());
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}

fn simulators(test: &str, verilator: bool) -> Vec<Simulator> {
    let mut list = Vec::new();
    if !icarus_skipped(test) {
        list.push(Simulator::Icarus);
    }
    if verilator && Simulator::Verilator.available() {
        list.push(Simulator::Verilator);
    }
    list
}

fn wishbone_classic(ops: Vec<BusOp>) -> Box<dyn Master> {
    Box::new(WishboneMaster::new(ops, false))
}

fn wishbone_pipelined(ops: Vec<BusOp>) -> Box<dyn Master> {
    Box::new(WishboneMaster::new(ops, true))
}

fn axi_lite(ops: Vec<BusOp>) -> Box<dyn Master> {
    Box::new(AxiLiteMaster::new(ops))
}

fn apb(ops: Vec<BusOp>) -> Box<dyn Master> {
    Box::new(ApbMaster::new(ops))
}

#[test]
fn wishbone_byte_registers_equal_the_verilog() {
    let sims = simulators("wishbone_byte_registers_equal_the_verilog", true);
    bench::<CanControllerWishbone>(false, wishbone_classic, &sims);
}

#[test]
fn wishbone_pipelined_word_registers_equal_the_verilog() {
    let sims = simulators("wishbone_pipelined_word_registers_equal_the_verilog", false);
    bench::<CanControllerWishbone>(true, wishbone_pipelined, &sims);
}

#[test]
fn axi4_lite_byte_registers_equal_the_verilog() {
    let sims = simulators("axi4_lite_byte_registers_equal_the_verilog", true);
    bench::<CanControllerAxiLite>(false, axi_lite, &sims);
}

#[test]
fn axi4_lite_word_registers_equal_the_verilog() {
    let sims = simulators("axi4_lite_word_registers_equal_the_verilog", false);
    bench::<CanControllerAxiLite>(true, axi_lite, &sims);
}

#[test]
fn apb_byte_registers_equal_the_verilog() {
    let sims = simulators("apb_byte_registers_equal_the_verilog", true);
    bench::<CanControllerApb>(false, apb, &sims);
}

#[test]
fn apb_word_registers_equal_the_verilog() {
    let sims = simulators("apb_word_registers_equal_the_verilog", false);
    bench::<CanControllerApb>(true, apb, &sims);
}
