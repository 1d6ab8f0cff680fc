//! Bench for register-level tests: complete RTL controllers ([`ControllerNode`]) on one bus, each
//! reached only through its host port ([`Host`]), optionally with a lower tester. 16 MHz clock,
//! 500 kbit/s (BTR0 = 0x00, BTR1 = 0x1C: 16 tq, sample point 87.5 %), PeliCAN mode and an open
//! filter unless a test says otherwise.

use golden::btr::Btr;
use golden::frame::Frame;
use rtl::registers::{pelican, status};
use sim::engine::time::ClockSpec;
use sim::engine::{DeviceId, Engine};
use sim::host::frame_buffer::{buffer_len, encode_buffer};
use sim::host::sja1000::{set_up_pelican, PelicanSetup, BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ};
use sim::host::{Host, RegisterPort};
use sim::nodes::controller_node::{ControllerNode, ModelEngine};
use sim::nodes::lower_tester::LowerTester;

use crate::{bench_engine, CLOCK_HZ};

/// Bits after which a node that left reset mode has integrated (11 recessive bits and margin).
pub const INTEGRATION_BITS: u64 = 13;

/// The bit timing of the bench.
pub fn bench_btr() -> Btr {
    Btr::from_registers(BTR0_500K_AT_16MHZ, BTR1_500K_AT_16MHZ)
}

/// Controllers (and at most one lower tester) on one bus.
pub struct ControllerBench {
    /// The engine.
    pub engine: Engine,
    nodes: Vec<DeviceId>,
    lt: Option<DeviceId>,
}

impl ControllerBench {
    /// `count` controllers, each after a hardware reset (reset mode, BasicCAN), stepped by the
    /// engine `CAN_ENGINE` chooses.
    pub fn new(count: usize) -> ControllerBench {
        ControllerBench::with_nodes(count, ControllerNode::new)
    }

    /// As [`ControllerBench::new`], stepped by `engine` whatever `CAN_ENGINE` says.
    pub fn with_engine(count: usize, engine: ModelEngine) -> ControllerBench {
        ControllerBench::with_nodes(count, |name, clock| {
            ControllerNode::with_engine(name, clock, engine).unwrap_or_else(|e| panic!("{e}"))
        })
    }

    fn with_nodes(
        count: usize,
        node: impl Fn(&str, ClockSpec) -> ControllerNode,
    ) -> ControllerBench {
        let clock = ClockSpec::from_hz(CLOCK_HZ);
        let mut engine = bench_engine(&bench_btr(), clock);
        engine.keep_history();
        let nodes = (0..count)
            .map(|i| engine.add(node(&format!("n{i}"), clock), 0))
            .collect();
        ControllerBench {
            engine,
            nodes,
            lt: None,
        }
    }

    /// One controller and a lower tester in the bench's bit timing.
    pub fn with_lower_tester() -> ControllerBench {
        let mut bench = ControllerBench::new(1);
        let lt = LowerTester::new("lt", ClockSpec::from_hz(CLOCK_HZ), bench_btr());
        bench.lt = Some(bench.engine.add(lt, 0));
        bench
    }

    /// `count` controllers set up by [`configure_pelican`] and integrated.
    pub fn operating(count: usize) -> ControllerBench {
        let mut bench = ControllerBench::new(count);
        for n in 0..count {
            configure_pelican(&mut bench.host(n));
            bench.host(n).write(pelican::MOD, 0);
        }
        bench.run_bits(INTEGRATION_BITS);
        bench
    }

    /// The host of controller `n`.
    pub fn host(&mut self, n: usize) -> Host<'_> {
        Host::new(&mut self.engine, self.nodes[n])
    }

    /// Controller `n`.
    pub fn node(&self, n: usize) -> &ControllerNode {
        self.engine.device(self.nodes[n])
    }

    /// Controller `n`'s device id.
    pub fn id(&self, n: usize) -> DeviceId {
        self.nodes[n]
    }

    /// The lower tester.
    pub fn lt(&mut self) -> &mut LowerTester {
        let lt = self.lt.expect("a bench with a lower tester");
        self.engine.device_mut(lt)
    }

    /// Runs the bus for `bits` bit times.
    pub fn run_bits(&mut self, bits: u64) {
        let end = self.engine.now() + bits * bench_bit_fs();
        self.engine.run_until(end).expect("simulation");
    }

    /// Runs until controller `n`'s interrupt output is asserted or `max_bits` have passed; returns
    /// whether it was.
    pub fn run_until_irq(&mut self, n: usize, max_bits: u64) -> bool {
        let id = self.nodes[n];
        let limit = self.engine.now() + max_bits * bench_bit_fs();
        self.engine
            .run_while(limit, |e| e.device::<ControllerNode>(id).irq())
            .expect("simulation")
    }
}

/// One bit time of the bench in femtoseconds.
pub fn bench_bit_fs() -> u64 {
    bench_btr().clocks_per_bit() as u64 * ClockSpec::from_hz(CLOCK_HZ).period_fs()
}

/// The catalog's default setup, in reset mode: PeliCAN, the bench's bit timing, filter open
/// (ACR 0, AMR 0xFF), every interrupt enabled, EWLR 96. The caller leaves reset mode.
pub fn configure_pelican(host: &mut impl RegisterPort) {
    configure_pelican_for(host, bench_btr());
}

/// As [`configure_pelican`], with the bit timing `btr` (written to BTR0/BTR1).
pub fn configure_pelican_for(host: &mut impl RegisterPort, btr: Btr) {
    set_up_pelican(host, &PelicanSetup::open(btr.btr0(), btr.btr1()));
}

/// The bytes a host reads for `frame` from the RX buffer (and finds in the FIFO RAM): the TX layout
/// of [`encode_buffer`] plus the RTR copy (standard: byte 2 bit 4; extended: byte 4 bit 2),
/// [`buffer_len`] bytes.
pub fn rx_buffer_bytes(frame: &Frame) -> Vec<u8> {
    let mut buf = encode_buffer(frame);
    if frame.is_remote() {
        if frame.id().is_extended() {
            buf[4] |= 0x04;
        } else {
            buf[2] |= 0x10;
        }
    }
    buf[..buffer_len(buf[0])].to_vec()
}

impl ControllerBench {
    /// Polls controller `n`'s SR once per bit time until TBS is 1 (the request ended: sent,
    /// aborted or failed single shot), at most `max_bits` bit times; returns whether it was.
    pub fn run_until_tx_buffer_free(&mut self, n: usize, max_bits: u64) -> bool {
        for _ in 0..max_bits {
            if self.host(n).read(pelican::SR) & status::TBS != 0 {
                return true;
            }
            self.run_bits(1);
        }
        self.host(n).read(pelican::SR) & status::TBS != 0
    }

    /// Runs `bits` bit times and returns how many clock edges of the engine (any device) found
    /// controller `n`'s `tx` pin dominant right after them.
    pub fn run_bits_counting_dominant_tx(&mut self, n: usize, bits: u64) -> u64 {
        let id = self.nodes[n];
        let end = self.engine.now() + bits * bench_bit_fs();
        let mut dominant = 0;
        self.engine
            .run_while(end, |e| {
                if !e.device::<ControllerNode>(id).tx() {
                    dominant += 1;
                }
                false
            })
            .expect("simulation");
        dominant
    }
}

impl ControllerBench {
    /// Pulses controller `n`'s hardware `reset` input for two clocks (afterwards: as after a
    /// hardware reset, in reset mode and BasicCAN).
    pub fn pulse_hardware_reset(&mut self, n: usize) {
        let id = self.nodes[n];
        self.engine.device_mut::<ControllerNode>(id).set_reset(true);
        self.host(n).idle(2);
        self.engine
            .device_mut::<ControllerNode>(id)
            .set_reset(false);
        self.host(n).idle(1);
    }

    /// Runs until controller `n` drives a dominant bit (the SOF of its frame when it transmits
    /// from idle) and returns the time of that clock edge: the start of wire bit 0 of its frame
    /// on the bench's bit grid. Panics after `max_bits` bit times.
    pub fn run_until_sof(&mut self, n: usize, max_bits: u64) -> u64 {
        let id = self.nodes[n];
        let limit = self.engine.now() + max_bits * bench_bit_fs();
        let found = self
            .engine
            .run_while(limit, |e| !e.device::<ControllerNode>(id).tx())
            .expect("simulation");
        assert!(
            found,
            "controller {n} did not start a frame within {max_bits} bits"
        );
        self.engine.now()
    }

    /// Makes controller `n` see `level` (instead of the bus) for one bit time centred on the
    /// nominal sample point of wire bit `bit` of a frame whose SOF began at `sof` (from
    /// [`ControllerBench::run_until_sof`]), so exactly one of its samples falls inside. A window
    /// on the nominal bit itself is not enough: late in a frame a receiver's (and after the ACK
    /// also the transmitter's) sample instants lag the nominal grid by a few clocks (input
    /// synchroniser, resynchronisation), up to the very end of the nominal bit.
    pub fn force_seen_bit(&mut self, n: usize, sof: u64, bit: usize, level: bool) {
        let btr = bench_btr();
        let tq = bench_bit_fs() / btr.quanta_per_bit() as u64;
        let sample = sof + bit as u64 * bench_bit_fs() + btr.sample_point_tq() as u64 * tq;
        let half = btr.quanta_per_bit() as u64 / 2 * tq;
        let id = self.nodes[n];
        self.engine
            .disturb_rx(id, sample - half, sample + half, level);
    }
}
