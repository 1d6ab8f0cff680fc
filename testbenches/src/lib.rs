//! Shared helpers of the integration testbenches: the bit-timing configurations of the conformance
//! catalog and a bench of one lower tester plus nodes under test, with queries in script positions
//! (bits and quanta of the lower tester's script) rather than raw times.
#![warn(missing_docs)]

use std::cell::RefCell;
use std::path::PathBuf;

use golden::btr::Btr;
use rtl::bit_timing::SyncMode;
use sim::engine::bus_timing::BusTiming;
use sim::engine::time::ClockSpec;
use sim::engine::{DeviceId, Engine};
use sim::nodes::btl_node::{BitTimingNode, SyncPolicy};
use sim::nodes::lower_tester::LowerTester;

/// Controller clock of the testbenches.
pub const CLOCK_HZ: f64 = 16e6;
/// Idle bits the lower tester plays before its first frame.
pub const LEAD_IN_BITS: usize = 4;
/// Prescaler field of the "BRP > 0" configurations (tq = 6 clocks).
pub const BRP_ABOVE_ZERO: u8 = 2;

/// Environment variable that makes every bench write the VCD of its run: `1` into the workspace's
/// `waves/`, any other value but `0` into the directory it names.
pub const WAVES_ENV: &str = "CANSIM_WAVES";

/// The engine of a bench whose bus runs with bit timing `btr` on `clock`. With [`WAVES_ENV`] set it
/// writes its VCD, the bus timing recorded in the header, to `<waves>/<test binary>.<test name>.vcd`
/// (the test name being the test's path in its binary; the second and later engines of one test add
/// `.2`, `.3`, …). Tracing starts at the first step, so devices can be added until then, and the file
/// is finished when the engine is dropped, also when the test fails.
pub fn bench_engine(btr: &Btr, clock: ClockSpec) -> Engine {
    let mut engine = Engine::new();
    if let Some(mode) = skipping::edge_skipping() {
        engine.set_edge_skipping(mode);
    }
    if let Some(path) = waves_path() {
        engine.trace_vcd_from_first_step(&path, BusTiming::from_btr(btr, clock));
    }
    engine
}

/// Where the next engine of this test writes its VCD, or `None` without [`WAVES_ENV`] and during a
/// skipping check (its runs repeat the `on_core::` and `on_registers::` tests' scenarios: their
/// waves would be copies).
fn waves_path() -> Option<PathBuf> {
    if skipping::engine().is_some() {
        return None;
    }
    let setting = std::env::var(WAVES_ENV)
        .ok()
        .filter(|v| !v.is_empty() && v != "0")?;
    let dir = if setting == "1" {
        PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../waves"))
    } else {
        PathBuf::from(setting)
    };
    std::fs::create_dir_all(&dir)
        .unwrap_or_else(|e| panic!("{WAVES_ENV}: cannot create {}: {e}", dir.display()));
    Some(dir.join(format!("{}.vcd", next_trace_name())))
}

thread_local! {
    /// The test running on this thread and how many engines it traced so far.
    static TRACED: RefCell<(String, usize)> = const { RefCell::new((String::new(), 0)) };
}

/// `<test binary>.<test path>` for this thread's test, `.N` appended from its second engine on.
fn next_trace_name() -> String {
    let binary = std::env::current_exe()
        .ok()
        .and_then(|exe| exe.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .unwrap_or_default();
    // Cargo names test binaries `<target>-<hash>`.
    let binary = binary
        .rsplit_once('-')
        .map_or(binary.as_str(), |(name, _)| name);
    let thread = std::thread::current();
    let test = thread.name().unwrap_or("main").replace("::", ".");
    let name = format!("{binary}.{test}");
    TRACED.with(|traced| {
        let mut traced = traced.borrow_mut();
        if traced.0 != name {
            *traced = (name.clone(), 0);
        }
        traced.1 += 1;
        match traced.1 {
            1 => name,
            n => format!("{name}.{n}"),
        }
    })
}

/// One bit-timing configuration of the catalog.
#[derive(Clone, Copy, Debug)]
pub struct BtConfig {
    /// Catalog name with the prescaler, e.g. "BT-A/BRP0".
    pub name: &'static str,
    /// The register values.
    pub btr: Btr,
}

/// BT-A (TSEG1 11, TSEG2 4, SJW 2), BT-B (4/3/1) and BT-C (16/8/4), each with BRP 0 and BRP > 0,
/// single sampling.
pub fn bt_configs() -> Vec<BtConfig> {
    let mut configs = Vec::new();
    for (name0, name_n, tseg1, tseg2, sjw) in [
        ("BT-A/BRP0", "BT-A/BRP2", 11, 4, 2),
        ("BT-B/BRP0", "BT-B/BRP2", 4, 3, 1),
        ("BT-C/BRP0", "BT-C/BRP2", 16, 8, 4),
    ] {
        for (name, brp) in [(name0, 0), (name_n, BRP_ABOVE_ZERO)] {
            let btr = Btr::from_quanta(brp, tseg1, tseg2, sjw, false).expect("catalog timing");
            configs.push(BtConfig { name, btr });
        }
    }
    configs
}

/// A lower tester and one node under test (IUT) on the same 16 MHz clock, zero propagation delay.
pub struct BtBench {
    /// The engine; public for tests that need more than the helpers.
    pub engine: Engine,
    lt: DeviceId,
    iut: DeviceId,
    btr: Btr,
}

impl BtBench {
    /// A bench whose IUT follows frames with its synchronisation mode (hard while idle).
    pub fn new(btr: Btr) -> BtBench {
        BtBench::with_lt_delay_clocks(btr, 0)
    }

    /// A bench whose lower tester starts `delay_clocks` clocks after the IUT, so its quanta fall at any
    /// clock offset inside the IUT's quanta.
    pub fn with_lt_delay_clocks(btr: Btr, delay_clocks: u64) -> BtBench {
        let clock = ClockSpec::from_hz(CLOCK_HZ);
        let mut engine = bench_engine(&btr, clock);
        engine.keep_history();
        let lt_clock = clock.with_phase(delay_clocks * clock.period_fs());
        let lt = engine.add(LowerTester::new("lt", lt_clock, btr), 0);
        let iut = engine.add(BitTimingNode::new("iut", clock, btr), 0);
        BtBench {
            engine,
            lt,
            iut,
            btr,
        }
    }

    /// The bit timing under test.
    pub fn btr(&self) -> Btr {
        self.btr
    }

    /// Quanta per nominal bit.
    pub fn nbt(&self) -> usize {
        self.btr.quanta_per_bit() as usize
    }

    /// Quanta from the start of a bit to its sample point.
    pub fn sp(&self) -> usize {
        self.btr.sample_point_tq() as usize
    }

    /// The lower tester, to write its script.
    pub fn lt(&mut self) -> &mut LowerTester {
        self.engine.device_mut(self.lt)
    }

    /// The lower tester, read-only.
    pub fn lt_ref(&self) -> &LowerTester {
        self.engine.device(self.lt)
    }

    /// The node under test.
    pub fn iut(&self) -> &BitTimingNode {
        self.engine.device(self.iut)
    }

    /// The node under test, mutably.
    pub fn iut_mut(&mut self) -> &mut BitTimingNode {
        self.engine.device_mut(self.iut)
    }

    /// Pins the IUT's synchronisation mode.
    pub fn pin_sync_mode(&mut self, mode: SyncMode) {
        self.iut_mut().set_sync_policy(SyncPolicy::Fixed(mode));
    }

    /// Runs until the lower tester has played its script, then two more bits.
    pub fn run(&mut self) {
        let lt = self.lt;
        let limit = 10 * sim::engine::time::FS_PER_S;
        let done = self
            .engine
            .run_while(limit, |e| e.device::<LowerTester>(lt).finished())
            .expect("simulation");
        assert!(done, "lower tester script did not finish");
        let two_bits = 2 * self.btr.clocks_per_bit() as u64;
        let end = self.engine.now() + two_bits * ClockSpec::from_hz(CLOCK_HZ).period_fs();
        self.engine.run_until(end).expect("simulation");
    }

    /// Position of a time in the lower tester's script, in quanta from the script start, if the time
    /// is on a quantum boundary.
    pub fn quantum_of(&self, t_fs: u64) -> Option<usize> {
        let lt = self.lt_ref();
        let rel = t_fs.checked_sub(lt.started_at()?)?;
        (rel % lt.tq_fs() == 0).then_some((rel / lt.tq_fs()) as usize)
    }

    /// The IUT's samples after the script start as (time, bit value), oldest first.
    pub fn samples(&self) -> Vec<(u64, bool)> {
        let t0 = self.lt_ref().started_at().expect("lower tester started");
        self.iut().samples().filter(|(at, _)| *at > t0).collect()
    }

    /// The IUT's sample taken inside script bit `bit` (after its start, up to and including the start
    /// of the next bit), as (quanta after the bit start, value). Panics if that sample is not on a
    /// quantum boundary of the lower tester.
    pub fn sample_in_bit(&self, bit: usize) -> Option<(usize, bool)> {
        let lt = self.lt_ref();
        let start = lt.quantum_time(lt.bit_start_quantum(bit))?;
        let end = lt.quantum_time(lt.bit_start_quantum(bit + 1))?;
        let (at, value) = self
            .samples()
            .into_iter()
            .find(|(at, _)| *at > start && *at <= end)?;
        let q = self
            .quantum_of(at)
            .unwrap_or_else(|| panic!("sample in bit {bit} at {at} fs is between quanta"));
        Some((q - lt.bit_start_quantum(bit), value))
    }

    /// The IUT's sample at exactly script quantum `q` (the level of the last clock of quantum q − 1).
    pub fn sample_at_quantum(&self, q: usize) -> Option<bool> {
        let at = self.lt_ref().quantum_time(q)?;
        self.samples()
            .into_iter()
            .find(|(t, _)| *t == at)
            .map(|(_, bit)| bit)
    }
}

/// Bits between frames in multi-frame exchanges: ACK delimiter, EOF and intermission length of idle.
pub const INTERFRAME_BITS: usize = 11;

/// Sends `frames` from a stand-in transmitter to a stand-in receiver whose clocks run `+ppm` and
/// `−ppm` off the nominal 16 MHz, and counts, per frame, the bits the receiver sampled wrongly (a
/// frame not found at all counts all its bits).
pub fn exchange_with_clock_offset(
    btr: Btr,
    ppm: f64,
    frames: &[golden::frame::EncodedFrame],
) -> Vec<usize> {
    let received = receive_with_clock_offset(btr, ppm, frames);
    wrong_bits_per_frame(&received, frames)
}

/// The bits a receiver at `−ppm` sampled while a transmitter at `+ppm` sent `frames` with
/// [`INTERFRAME_BITS`] of idle after each.
fn receive_with_clock_offset(
    btr: Btr,
    ppm: f64,
    frames: &[golden::frame::EncodedFrame],
) -> Vec<bool> {
    let mut engine = bench_engine(&btr, ClockSpec::from_hz(CLOCK_HZ));
    let mut tx = BitTimingNode::new("tx", ClockSpec::with_ppm(CLOCK_HZ, ppm), btr);
    for f in frames {
        tx.transmit(f.bits.iter().by_vals());
        tx.transmit(std::iter::repeat_n(
            golden::frame::RECESSIVE,
            INTERFRAME_BITS,
        ));
    }
    let tx = engine.add(tx, 0);
    let rx = engine.add(
        BitTimingNode::new("rx", ClockSpec::with_ppm(CLOCK_HZ, -ppm), btr),
        0,
    );
    engine
        .run_while(10 * sim::engine::time::FS_PER_S, |e| {
            !e.device::<BitTimingNode>(tx).transmitting()
        })
        .expect("simulation");
    let samples = engine.device::<BitTimingNode>(rx).samples();
    samples.map(|(_, bit)| bit).collect()
}

/// Finds each frame in `received` (from the next dominant bit, its SOF) and counts its wrong bits.
fn wrong_bits_per_frame(received: &[bool], frames: &[golden::frame::EncodedFrame]) -> Vec<usize> {
    use golden::frame::DOMINANT;
    let mut pos = 0;
    frames
        .iter()
        .map(|f| {
            let Some(sof) = received[pos..].iter().position(|&b| b == DOMINANT) else {
                return f.len();
            };
            let got = &received[pos + sof..];
            let wrong = (0..f.len())
                .filter(|&i| got.get(i) != Some(&f.bits[i]))
                .count();
            pos += sof + f.len().min(got.len());
            while received.get(pos) == Some(&DOMINANT) {
                pos += 1;
            }
            wrong
        })
        .collect()
}

pub mod agreement;
pub mod bus_masters;
pub mod controller_bench;
pub mod ecc;
pub mod equivalence;
pub mod iso;
pub mod lint;
pub mod protocol_bench;
pub mod register_iut;
pub mod scenario_report;
pub mod sigrok;
pub mod skipping;
pub mod waves_check;
pub mod wrapper_equivalence;

/// Defines the tests of protocol scenarios written once for both IUTs: for every function
/// `name(iut: Iut)` listed, `on_core::name` runs it on the bare RTL core and `on_registers::name` on
/// the complete controller through its registers ([`protocol_bench::Iut`]); `skipping::core::name`
/// and `skipping::registers::name` run it on the compiled engine with and without its skipping
/// and compare what the IUT did ([`skipping`]). Attributes written before a name (e.g. `#[ignore
/// = "long: …"]`) apply to every test of it.
#[macro_export]
macro_rules! on_both_iuts {
    ($($(#[$attr:meta])* $name:ident),* $(,)?) => {
        mod on_core {
            $(
                #[test]
                $(#[$attr])*
                fn $name() {
                    super::$name($crate::protocol_bench::Iut::Core)
                }
            )*
        }
        mod on_registers {
            $(
                #[test]
                $(#[$attr])*
                fn $name() {
                    super::$name($crate::protocol_bench::Iut::Registers)
                }
            )*
        }
        mod skipping {
            mod core {
                $(
                    #[test]
                    $(#[$attr])*
                    fn $name() {
                        $crate::skipping::assert_skipping_changes_nothing(
                            $crate::protocol_bench::Iut::Core,
                            super::super::$name,
                        )
                    }
                )*
            }
            mod registers {
                $(
                    #[test]
                    $(#[$attr])*
                    fn $name() {
                        $crate::skipping::assert_skipping_changes_nothing(
                            $crate::protocol_bench::Iut::Registers,
                            super::super::$name,
                        )
                    }
                )*
            }
        }
    };
}
