//! Quiet cycles of the compiled controller and of the bare core, which the engine's edge skipping
//! jumps over: between the bit timing's events (the sample, process and transmit points) a design
//! whose inputs hold, whose other blocks are settled and whose bus input has passed the
//! synchroniser only counts: the prescaler, the quanta left in the segment, the quanta since Sync,
//! the segment itself at the ends of Sync and TSEG2, the samples of the triple sampling taken at
//! the quanta's ends and (the controller) the CLKOUT divider. Those stretches are jumped in one
//! step by writing the counters' values after them (`rtl/src/bit_timing.rs` and
//! `rtl/src/clock_divider.rs` say how they count).
//!
//! What makes a jump exact: the next edge changes no flip-flop but the counters (`settled`, from
//! the model), the bit timing's outputs to the rest of the design (sample, process and transmit
//! points, `rx_bit`, the synchronisation pulses) stay what they are until the jump's end
//! (computed here), and the inputs hold (the caller's word). The segment and the sample point are
//! read by nothing but the trace: a traced design's jumps end at the segment's end (and before
//! the clock of the sample point), an untraced one's run on through the ends of Sync and TSEG2
//! and into the clock of the sample point. The engine's checked mode steps a copy cycle by cycle
//! beside every jump and compares the whole state (`CompiledController::skip`).

use rtl::bit_timing::Segment;

use super::{core_model, model};

/// The nets of the controller read or written here (flattened names of the generated Verilog),
/// each with whether it is one of the counters a skipped cycle may change; the bit timing's in the
/// order of the bare core's ([`CORE_STATE`]), then the CLKOUT divider's, then BTR1 (TSEG1).
pub(crate) const CONTROLLER_STATE: [(&str, bool); 15] = [
    ("core.bit_timing.clocks.q", true),
    ("core.bit_timing.remaining.q", true),
    ("core.bit_timing.elapsed.q", true),
    ("core.bit_timing.segment_state.q", true),
    ("core.bit_timing.process_pending.q", false),
    ("core.bit_timing.transmit_deferred.q", false),
    ("core.bit_timing.sampling.metastable.q", false),
    ("core.bit_timing.sampling.stable.q", false),
    ("core.bit_timing.sampling.previous.q", false),
    ("core.bit_timing.sampling.quantum_samples.q", true),
    ("configuration.btr0.q", false),
    ("modes.divider.count.q", true),
    ("modes.divider.level.q", true),
    ("modes.cdr_reg.q", false),
    ("configuration.btr1.q", false),
];

/// The same nets of the bare core (whose bit timing fields are inputs).
pub(crate) const CORE_STATE: [(&str, bool); 12] = [
    ("bit_timing.clocks.q", true),
    ("bit_timing.remaining.q", true),
    ("bit_timing.elapsed.q", true),
    ("bit_timing.segment_state.q", true),
    ("bit_timing.process_pending.q", false),
    ("bit_timing.transmit_deferred.q", false),
    ("bit_timing.sampling.metastable.q", false),
    ("bit_timing.sampling.stable.q", false),
    ("bit_timing.sampling.previous.q", false),
    ("bit_timing.sampling.quantum_samples.q", true),
    ("brp", false),
    ("tseg1", false),
];

const CLOCKS: usize = 0;
const REMAINING: usize = 1;
const ELAPSED: usize = 2;
const SEGMENT: usize = 3;
const PROCESS_PENDING: usize = 4;
const TRANSMIT_DEFERRED: usize = 5;
const METASTABLE: usize = 6;
const STABLE: usize = 7;
const PREVIOUS: usize = 8;
const QUANTUM_SAMPLES: usize = 9;
/// BTR0 (the controller) or the BRP input (the core).
const BRP_SOURCE: usize = 10;
const DIVIDER_COUNT: usize = 11;
const DIVIDER_LEVEL: usize = 12;
/// The CDR register's index in [`CONTROLLER_STATE`].
pub(crate) const CDR: usize = 13;
/// BTR1 in [`CONTROLLER_STATE`].
const BTR1: usize = 14;
/// The TSEG1 input in [`CORE_STATE`].
const CORE_TSEG1: usize = 11;

/// A generated model with one of the state lists above.
pub(crate) trait Counters {
    /// Whether the design is the controller (with the CLKOUT divider and the BTR registers:
    /// [`CONTROLLER_STATE`]) rather than the bare core ([`CORE_STATE`]).
    const CONTROLLER: bool;
    /// The value of state net `i`.
    fn state(&self, i: usize) -> u64;
    /// Writes free-running state net `i`.
    fn set_state(&mut self, i: usize, value: u64);
    /// Evaluates the groups whose inputs changed.
    fn evaluate(&mut self);
}

/// `Counters` for a generated model, whose methods of the same names it calls.
macro_rules! counters {
    ($model:ty, controller: $controller:literal) => {
        impl Counters for $model {
            const CONTROLLER: bool = $controller;
            fn state(&self, i: usize) -> u64 {
                <$model>::state(self, i)
            }
            fn set_state(&mut self, i: usize, value: u64) {
                <$model>::set_state(self, i, value);
            }
            fn evaluate(&mut self) {
                self.eval(false);
            }
        }
    };
}

counters!(model::Model, controller: true);
counters!(core_model::Model, controller: false);

/// BTR0.5..0 (the BRP input of the core has only these): the prescaler.
const BRP_MASK: u64 = 0x3F;
/// BTR1.3..0: TSEG1 (the core's TSEG1 input).
const TSEG1_MASK: u64 = 0xF;
/// CDR.2..0: the CLKOUT divider code; CDR.3: clock off.
pub(crate) const CDR_CODE_MASK: u64 = 0x7;
pub(crate) const CDR_CLOCK_OFF: u64 = 1 << 3;
/// The CDR code that passes the controller clock through (no divided level on the pin).
pub(crate) const CDR_CODE_FOSC: u64 = 7;
/// The triple sampling keeps the levels of the last two quanta's ends.
const QUANTUM_SAMPLES_KEPT: u64 = 2;
const QUANTUM_SAMPLES_MASK: u64 = 0b11;
/// Where `elapsed` stops counting (`ELAPSED_OVER_SJW` of the bit timing).
const ELAPSED_SATURATED: u64 = 4;

/// A counter that counts up by one per cycle and restarts at 0 in the cycle after it reached
/// `last` (the bit timing's prescaler, the CLKOUT divider): its value after `cycles` cycles from
/// `count`, and how many restarts those cycles made.
fn count_cycles(count: u64, last: u64, cycles: u64) -> (u64, u64) {
    let first = last.saturating_sub(count);
    if cycles <= first {
        return (count + cycles, 0);
    }
    let after_first = cycles - 1 - first;
    (after_first % (last + 1), 1 + after_first / (last + 1))
}

/// The bit timing's counters and segment: where the next edges take them.
struct Timing {
    /// The prescaler's last count (2·BRP + 1).
    last_clock: u64,
    /// The quanta of TSEG1 after its first (the BTR1 field).
    tseg1: u64,
    segment: u64,
    clocks: u64,
    remaining: u64,
    elapsed: u64,
    /// The synchronised bus level, and the last two of it taken at quanta's ends.
    stable: u64,
    quantum_samples: u64,
}

impl Timing {
    fn of<M: Counters>(model: &M) -> Timing {
        let tseg1 = if M::CONTROLLER {
            model.state(BTR1) & TSEG1_MASK
        } else {
            model.state(CORE_TSEG1)
        };
        Timing {
            last_clock: 2 * (model.state(BRP_SOURCE) & BRP_MASK) + 1,
            tseg1,
            segment: model.state(SEGMENT),
            clocks: model.state(CLOCKS),
            remaining: model.state(REMAINING),
            elapsed: model.state(ELAPSED),
            stable: model.state(STABLE),
            quantum_samples: model.state(QUANTUM_SAMPLES),
        }
    }

    /// At each of `quantum_ends` the triple sampling shifts the synchronised level in.
    fn take_samples(&mut self, quantum_ends: u64) {
        for _ in 0..quantum_ends.min(QUANTUM_SAMPLES_KEPT) {
            self.quantum_samples = (self.quantum_samples << 1 | self.stable) & QUANTUM_SAMPLES_MASK;
        }
    }

    /// Edges before the one that ends the segment (which comes in its last quantum's last clock).
    fn edges_before_segment_end(&self) -> u64 {
        self.last_clock.saturating_sub(self.clocks) + self.remaining * (self.last_clock + 1)
    }

    /// The edges of a whole segment of `remaining` + 1 quanta before the one that ends it.
    fn segment_edges(&self, remaining: u64) -> u64 {
        self.last_clock + remaining * (self.last_clock + 1)
    }

    /// `cycles` edges on, none of them a resynchronisation (at most [`quiet_cycles`]).
    fn advance(&mut self, mut cycles: u64) {
        loop {
            let within = self.edges_before_segment_end();
            if cycles <= within {
                let (clocks, quantum_ends) = count_cycles(self.clocks, self.last_clock, cycles);
                self.clocks = clocks;
                self.remaining -= quantum_ends;
                self.elapsed = (self.elapsed + quantum_ends).min(ELAPSED_SATURATED);
                self.take_samples(quantum_ends);
                return;
            }
            // The segment's end: the next one starts with its first clock. It is Sync's or
            // TSEG2's: a skip ends before TSEG1's (the sample point).
            cycles -= within + 1;
            self.take_samples(self.remaining + 1);
            (self.segment, self.remaining) = if self.segment == Segment::Sync as u64 {
                (Segment::Tseg1 as u64, self.tseg1)
            } else {
                (Segment::Sync as u64, 0)
            };
            self.clocks = 0;
            self.elapsed = 0;
        }
    }
}

/// How many cycles from the next one on change nothing but the counters, given that the inputs
/// stay those of the last cycle with the bus input at `rx`, and that the whole model is settled
/// (`Model::settled`, checked by the caller). With `traced` the CLKOUT pin, the segment and the
/// sample point must hold too.
pub(crate) fn quiet_cycles<M: Counters>(model: &M, rx: bool, traced: bool) -> u64 {
    // The CLKOUT pin first: while traced it usually toggles every few clocks, and then nothing
    // else needs a look.
    let clkout = if M::CONTROLLER && traced {
        let cdr = model.state(CDR);
        let code = cdr & CDR_CODE_MASK;
        let pin_toggles = cdr & CDR_CLOCK_OFF == 0 && code != CDR_CODE_FOSC;
        // The level toggles at the edge after the cycle in which the count reaches the code.
        if pin_toggles {
            code.saturating_sub(model.state(DIVIDER_COUNT))
        } else {
            u64::MAX
        }
    } else {
        u64::MAX
    };
    if clkout == 0 {
        return 0;
    }
    // The synchroniser has passed `rx` on, and seen no edge (the triple sampling's samples count).
    let stable = model.state(STABLE);
    let sampling_settled = model.state(METASTABLE) == u64::from(rx)
        && stable == u64::from(rx)
        && model.state(PREVIOUS) == stable;
    let idle_triggers = model.state(PROCESS_PENDING) == 0 && model.state(TRANSMIT_DEFERRED) == 0;
    if !sampling_settled || !idle_triggers || model.state(ELAPSED) > ELAPSED_SATURATED {
        return 0;
    }
    let timing = Timing::of(model);
    let within = timing.edges_before_segment_end();
    let segment = timing.segment;
    let bit_timing = if segment == Segment::Sync as u64 {
        // The first clock of Sync is a transmit point.
        if timing.clocks == 0 {
            return 0;
        }
        if traced {
            within
        } else {
            // Through Sync's end and TSEG1 into the clock of the sample point.
            within + 1 + timing.segment_edges(timing.tseg1)
        }
    } else if segment == Segment::Tseg1 as u64 {
        if traced {
            // The sample point is high in the clock of TSEG1's end, which the trace shows.
            match within.checked_sub(1) {
                Some(cycles) => cycles,
                None => return 0,
            }
        } else {
            within
        }
    } else if segment == Segment::Tseg2 as u64 {
        if traced {
            within
        } else {
            // Through TSEG2's end into Sync's first clock, the transmit point.
            within + 1
        }
    } else {
        return 0;
    };
    bit_timing.min(clkout)
}

/// Writes the counters' values `cycles` cycles on (at most [`quiet_cycles`] gave) and evaluates.
pub(crate) fn advance<M: Counters>(model: &mut M, cycles: u64) {
    let mut timing = Timing::of(model);
    timing.advance(cycles);
    model.set_state(CLOCKS, timing.clocks);
    model.set_state(REMAINING, timing.remaining);
    model.set_state(ELAPSED, timing.elapsed);
    model.set_state(SEGMENT, timing.segment);
    model.set_state(QUANTUM_SAMPLES, timing.quantum_samples);
    if M::CONTROLLER {
        let code = model.state(CDR) & CDR_CODE_MASK;
        let (count, toggles) = count_cycles(model.state(DIVIDER_COUNT), code, cycles);
        model.set_state(DIVIDER_COUNT, count);
        model.set_state(DIVIDER_LEVEL, model.state(DIVIDER_LEVEL) ^ (toggles & 1));
    }
    model.evaluate();
}

/// The checked mode's test of a skip of `cycles` cycles: panics unless every one of them, stepped
/// by `step` (which gives the outputs seen after it), leaves the outputs at `before`.
pub(crate) fn assert_stepping_agrees<W: PartialEq + std::fmt::LowerHex>(
    design: &str,
    cycles: u64,
    before: W,
    mut step: impl FnMut() -> W,
) {
    for cycle in 0..cycles {
        let after = step();
        assert!(
            after == before,
            "{design}: cycle {cycle} of {cycles} skipped ones changed the outputs \
             ({before:#x} -> {after:#x})"
        );
    }
}

/// Panics unless the skip and the stepping ended in the same state (`differences` empty).
pub(crate) fn assert_same_state(design: &str, cycles: u64, differences: Vec<&'static str>) {
    assert!(
        differences.is_empty(),
        "{design}: skipping {cycles} cycles left another state than stepping them: \
         {differences:?}"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counter stepped cycle by cycle, as the RTL counts.
    fn stepped(mut count: u64, last: u64, cycles: u64) -> (u64, u64) {
        let mut restarts = 0;
        for _ in 0..cycles {
            if count >= last {
                count = 0;
                restarts += 1;
            } else {
                count += 1;
            }
        }
        (count, restarts)
    }

    #[test]
    fn counting_many_cycles_at_once_gives_what_counting_one_by_one_does() {
        for last in 0..10 {
            for count in 0..12 {
                for cycles in 0..40 {
                    assert_eq!(
                        count_cycles(count, last, cycles),
                        stepped(count, last, cycles),
                        "count {count}, last {last}, {cycles} cycles"
                    );
                }
            }
        }
    }
}
