//! The lower tester (LT): the test driver that owns the bus.
//!
//! It plays a script of bits at time-quantum resolution on its own clock: golden bit lists from the frame
//! codec, idle time, and modifications of any bit or quantum (flip a bit, force a range of quanta
//! dominant or recessive, lengthen or shorten a bit). Recessive script bits *release* the bus, so nodes
//! under test can drive it; [`Drive::ForceRecessive`] overrides them. While it plays, the LT records the
//! bus level at the end of every quantum; [`crate::engine::Engine::keep_history`] gives what each node
//! drove at any time, and [`LowerTester::quantum_time`] maps script positions to times.
//!
//! Script positions: bit `i` of the script starts at quantum [`LowerTester::bit_start_quantum`]`(i)`;
//! quantum 0 starts when the LT starts (its first clock edge, or the edge of the first dominant bit on
//! the bus with [`LowerTester::start_on_dominant`]).

use std::any::Any;

use crate::engine::bus::Drive;
use crate::engine::time::ClockSpec;
use crate::engine::Device;
use golden::btr::Btr;
use golden::frame::{DOMINANT, RECESSIVE};

#[derive(Clone, Copy, Debug)]
struct ScriptBit {
    drive: Drive,
    quanta: u32,
}

#[derive(Clone, Copy, Debug)]
struct Force {
    bit: usize,
    from_tq: u32,
    quanta: u32,
    drive: Drive,
}

/// The lower tester device.
pub struct LowerTester {
    name: String,
    clock: ClockSpec,
    clocks_per_tq: u32,
    quanta_per_bit: u32,
    script: Vec<ScriptBit>,
    forces: Vec<Force>,
    start_on_dominant: bool,
    program: Vec<Drive>,
    compiled: bool,
    script_quanta: usize,
    started_at: Option<u64>,
    quantum: usize,
    clock_in_quantum: u32,
    observed: Vec<bool>,
}

impl LowerTester {
    /// A lower tester on `clock` whose quanta and nominal bit length follow `btr`.
    pub fn new(name: &str, clock: ClockSpec, btr: Btr) -> LowerTester {
        LowerTester {
            name: name.to_string(),
            clock,
            clocks_per_tq: btr.clocks_per_tq(),
            quanta_per_bit: btr.quanta_per_bit(),
            script: Vec::new(),
            forces: Vec::new(),
            start_on_dominant: false,
            program: Vec::new(),
            compiled: false,
            script_quanta: 0,
            started_at: None,
            quantum: 0,
            clock_in_quantum: 0,
            observed: Vec::new(),
        }
    }

    /// Start the script at the first dominant edge on the bus (quantum 0 begins at that edge) instead of
    /// at the LT's first clock edge: for tests where a node under test transmits.
    pub fn start_on_dominant(&mut self) -> &mut Self {
        self.start_on_dominant = true;
        self
    }

    /// Appends `levels` as nominal-length bits (dominant drives, recessive releases the bus).
    pub fn send_bits<I: IntoIterator<Item = bool>>(&mut self, levels: I) -> &mut Self {
        for level in levels {
            self.push_bit(Drive::from_level(level));
        }
        self
    }

    /// Appends `bits` nominal bits that release the bus (idle, or room for a node to transmit).
    pub fn release(&mut self, bits: usize) -> &mut Self {
        for _ in 0..bits {
            self.push_bit(Drive::Recessive);
        }
        self
    }

    /// Appends one nominal bit with `drive`.
    pub fn push_bit(&mut self, drive: Drive) -> &mut Self {
        self.script.push(ScriptBit {
            drive,
            quanta: self.quanta_per_bit,
        });
        self.compiled = false;
        self
    }

    /// Quanta in a nominal bit.
    pub fn quanta_per_bit(&self) -> u32 {
        self.quanta_per_bit
    }

    /// Number of bits in the script.
    pub fn script_len(&self) -> usize {
        self.script.len()
    }

    /// Inverts script bit `bit` (dominant ↔ released).
    pub fn flip_bit(&mut self, bit: usize) -> &mut Self {
        let b = &mut self.script[bit];
        b.drive = match b.drive {
            Drive::Dominant => Drive::Recessive,
            Drive::Recessive | Drive::ForceRecessive => Drive::Dominant,
        };
        self.compiled = false;
        self
    }

    /// Replaces the drive of script bit `bit`.
    pub fn set_bit(&mut self, bit: usize, drive: Drive) -> &mut Self {
        self.script[bit].drive = drive;
        self.compiled = false;
        self
    }

    /// Lengthens (`delta_tq` > 0) or shortens (< 0) script bit `bit`; every later bit moves with it.
    pub fn lengthen_bit(&mut self, bit: usize, delta_tq: i32) -> &mut Self {
        let b = &mut self.script[bit];
        let quanta = b.quanta as i64 + delta_tq as i64;
        assert!(quanta >= 1, "bit {bit} cannot be shorter than one quantum");
        b.quanta = quanta as u32;
        self.compiled = false;
        self
    }

    /// Drives `drive` during `quanta` quanta starting `from_tq` quanta after the start of script bit
    /// `bit` (the window may run into later bits); it overrides the script there.
    pub fn force(&mut self, bit: usize, from_tq: u32, quanta: u32, drive: Drive) -> &mut Self {
        self.forces.push(Force {
            bit,
            from_tq,
            quanta,
            drive,
        });
        self.compiled = false;
        self
    }

    /// Quantum at which script bit `bit` starts. Bits past the end of the script are nominal
    /// released bits (the LT keeps counting bits after it has played its script).
    pub fn bit_start_quantum(&self, bit: usize) -> usize {
        let played = bit.min(self.script.len());
        let script: usize = self.script[..played]
            .iter()
            .map(|b| b.quanta as usize)
            .sum();
        script + (bit - played) * self.quanta_per_bit as usize
    }

    /// Time at which quantum `q` of the script starts, once the LT has started.
    pub fn quantum_time(&self, q: usize) -> Option<u64> {
        let per_tq = self.clocks_per_tq as u64 * self.clock.period_fs();
        self.started_at.map(|t0| t0 + q as u64 * per_tq)
    }

    /// Time at which script bit `bit` starts, once the LT has started.
    pub fn bit_time(&self, bit: usize) -> Option<u64> {
        self.quantum_time(self.bit_start_quantum(bit))
    }

    /// Length of one time quantum in femtoseconds.
    pub fn tq_fs(&self) -> u64 {
        self.clocks_per_tq as u64 * self.clock.period_fs()
    }

    /// When the script started.
    pub fn started_at(&self) -> Option<u64> {
        self.started_at
    }

    /// Whether the whole script has been played.
    pub fn finished(&self) -> bool {
        // A script changed since the last edge is compiled (and so not finished) at the next edge.
        self.started_at.is_some() && self.compiled && self.quantum >= self.script_quanta
    }

    /// The bus level seen in the last clock of every quantum played so far.
    pub fn observed_quanta(&self) -> &[bool] {
        &self.observed
    }

    /// The bus level seen at the end of quantum `tq` of script bit `bit` (e.g. `tq` = the sample point
    /// in quanta minus one for what a node sampling at the nominal sample point saw).
    pub fn observed(&self, bit: usize, tq: u32) -> Option<bool> {
        self.observed
            .get(self.bit_start_quantum(bit) + tq as usize)
            .copied()
    }

    fn compile(&mut self) {
        self.script_quanta = self.bit_start_quantum(self.script.len());
        let mut program = Vec::with_capacity(self.script_quanta);
        for b in &self.script {
            program.extend(std::iter::repeat_n(b.drive, b.quanta as usize));
        }
        for f in &self.forces {
            let start = self.bit_start_quantum(f.bit) + f.from_tq as usize;
            let end = start + f.quanta as usize;
            if program.len() < end {
                program.resize(end, Drive::Recessive);
            }
            program[start..end].fill(f.drive);
        }
        self.program = program;
        self.compiled = true;
    }

    fn drive_now(&self) -> Drive {
        self.program
            .get(self.quantum)
            .copied()
            .unwrap_or(Drive::Recessive)
    }
}

impl LowerTester {
    /// The edges from the next one on at which the drive stays, `finished` stays and the level
    /// seen is only recorded (as long as it is `rx`).
    fn quiet(&self, rx: bool) -> u64 {
        if !self.compiled {
            return 0;
        }
        let Some(_) = self.started_at else {
            // Waiting for a dominant bit: nothing happens while the bus is recessive.
            return if self.start_on_dominant && rx == RECESSIVE {
                u64::MAX
            } else {
                0
            };
        };
        // The edges up to the next quantum's start, then a quantum's worth per following quantum
        // with the same drive, up to the end of the script (where `finished` turns true).
        let per_tq = u64::from(self.clocks_per_tq);
        let to_next = per_tq - u64::from(self.clock_in_quantum);
        let drive = self.drive_now();
        let end = self.program.len().max(self.script_quanta);
        let mut same = 0;
        for q in self.quantum + 1.. {
            if q >= end && q > self.script_quanta && drive == Drive::Recessive {
                return u64::MAX; // recessive for good, the script played
            }
            let next = self.program.get(q).copied().unwrap_or(Drive::Recessive);
            if q == self.script_quanta || next != drive {
                break;
            }
            same += 1;
        }
        to_next + same * per_tq - 1
    }
}

impl Device for LowerTester {
    fn name(&self) -> &str {
        &self.name
    }

    fn clock(&self) -> ClockSpec {
        self.clock
    }

    fn rising_edge(&mut self, t_fs: u64, rx: bool) -> Drive {
        if !self.compiled {
            self.compile();
        }
        match self.started_at {
            Some(_) => {
                self.clock_in_quantum += 1;
                if self.clock_in_quantum == self.clocks_per_tq {
                    self.clock_in_quantum = 0;
                    self.quantum += 1;
                    self.observed.push(rx);
                }
            }
            None if !self.start_on_dominant => self.started_at = Some(t_fs),
            None if rx == DOMINANT => {
                // The bus turned dominant during the clock before this edge: that is quantum 0's start.
                self.started_at = Some(t_fs.saturating_sub(self.clock.period_fs()));
                self.clock_in_quantum = 1;
            }
            None => return Drive::from_level(RECESSIVE),
        }
        self.drive_now()
    }

    fn quiet_edges(&self, rx: bool, _traced: bool) -> u64 {
        self.quiet(rx)
    }

    fn skip_edges(&mut self, edges: u64, rx: bool, _traced: bool, _checked: bool) {
        debug_assert!(
            edges <= self.quiet(rx),
            "skipped past the lower tester's next change"
        );
        if self.started_at.is_none() {
            return;
        }
        let per_tq = u64::from(self.clocks_per_tq);
        let clocks = u64::from(self.clock_in_quantum) + edges;
        let quanta = (clocks / per_tq) as usize;
        self.clock_in_quantum = (clocks % per_tq) as u32;
        self.quantum += quanta;
        self.observed.extend(std::iter::repeat_n(rx, quanta));
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::{EdgeSkipping, Engine};

    /// The LT alone on the bus (it sees its own bits), playing a script with a lengthened bit and
    /// a forced quantum, until it has finished and a little longer.
    fn played(skipping: EdgeSkipping) -> (Vec<bool>, Vec<(u64, Drive)>, u64, u64) {
        let clock = ClockSpec::from_hz(16e6);
        let mut lt = LowerTester::new("lt", clock, Btr::from_registers(0x01, 0x1C));
        lt.send_bits([false, true, true, false, false, false, true])
            .lengthen_bit(2, 3)
            .force(4, 5, 1, Drive::Recessive);
        let mut engine = Engine::new();
        engine.set_edge_skipping(skipping);
        let id = engine.add(lt, 0);
        let limit = 50 * 64 * clock.period_fs();
        let finished = engine
            .run_while(limit, |e| e.device::<LowerTester>(id).finished())
            .unwrap();
        assert!(finished);
        let finished_at = engine.now();
        engine
            .run_until(finished_at + 100 * clock.period_fs())
            .unwrap();
        let lt = engine.device::<LowerTester>(id);
        (
            lt.observed_quanta().to_vec(),
            engine.drive_changes(id),
            finished_at,
            engine.skipped_edges(),
        )
    }

    #[test]
    fn a_script_played_with_quiet_edges_skipped_is_the_script_played_edge_by_edge() {
        let (observed, drives, finished_at, _) = played(EdgeSkipping::Off);
        let skipped = played(EdgeSkipping::On);
        assert!(skipped.3 > 0, "no edge skipped");
        assert_eq!(skipped.0, observed, "levels recorded per quantum");
        assert_eq!(skipped.1, drives, "drive changes");
        assert_eq!(skipped.2, finished_at, "the edge at which it finished");
    }
}
