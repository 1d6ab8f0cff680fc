//! Quiet cycles of the compiled controller and of the bare core, which the engine's edge skipping
//! jumps over: between the bit timing's events (a segment's end, the sample, process and transmit
//! points) a design whose inputs hold, whose other blocks are settled and whose bus input has
//! passed the synchroniser only counts: the prescaler, the quanta left in the segment, the quanta
//! since Sync and (the controller) the CLKOUT divider. Those stretches are jumped in one step by
//! writing the counters' values after them (`rtl/src/bit_timing.rs` and `rtl/src/clock_divider.rs`
//! say how they count).
//!
//! What makes a jump exact: the next edge changes no flip-flop but the counters (`settled`, from
//! the model), the bit timing's outputs to the rest of the design (sample, process and transmit
//! points, `rx_bit`, the segment, the synchronisation pulses) stay what they are until the jump's
//! end (computed here), and the inputs hold (the caller's word). The engine's checked mode steps a
//! copy cycle by cycle beside every jump and compares the whole state (`CompiledController::skip`).

use rtl::bit_timing::Segment;

use super::{core_model, model};

/// The nets of the controller read or written here (flattened names of the generated Verilog),
/// each with whether it is one of the counters a skipped cycle may change; the bit timing's in the
/// order of the bare core's ([`CORE_STATE`]), then the CLKOUT divider's.
pub(crate) const CONTROLLER_STATE: [(&str, bool); 14] = [
    ("core.bit_timing.clocks.q", true),
    ("core.bit_timing.remaining.q", true),
    ("core.bit_timing.elapsed.q", true),
    ("core.bit_timing.segment_state.q", false),
    ("core.bit_timing.process_pending.q", false),
    ("core.bit_timing.transmit_deferred.q", false),
    ("core.bit_timing.sampling.metastable.q", false),
    ("core.bit_timing.sampling.stable.q", false),
    ("core.bit_timing.sampling.previous.q", false),
    ("core.bit_timing.sampling.quantum_samples.q", false),
    ("configuration.btr0.q", false),
    ("modes.divider.count.q", true),
    ("modes.divider.level.q", true),
    ("modes.cdr_reg.q", false),
];

/// The same nets of the bare core (whose prescaler field is an input).
pub(crate) const CORE_STATE: [(&str, bool); 11] = [
    ("bit_timing.clocks.q", true),
    ("bit_timing.remaining.q", true),
    ("bit_timing.elapsed.q", true),
    ("bit_timing.segment_state.q", false),
    ("bit_timing.process_pending.q", false),
    ("bit_timing.transmit_deferred.q", false),
    ("bit_timing.sampling.metastable.q", false),
    ("bit_timing.sampling.stable.q", false),
    ("bit_timing.sampling.previous.q", false),
    ("bit_timing.sampling.quantum_samples.q", false),
    ("brp", false),
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

/// A generated model with one of the state lists above.
pub(crate) trait Counters {
    /// Whether the design has the CLKOUT divider (the controller's last three nets).
    const DIVIDER: bool;
    /// The value of state net `i`.
    fn state(&self, i: usize) -> u64;
    /// Writes free-running state net `i`.
    fn set_state(&mut self, i: usize, value: u64);
    /// Evaluates the groups whose inputs changed.
    fn evaluate(&mut self);
}

/// `Counters` for a generated model, whose methods of the same names it calls.
macro_rules! counters {
    ($model:ty, divider: $divider:literal) => {
        impl Counters for $model {
            const DIVIDER: bool = $divider;
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

counters!(model::Model, divider: true);
counters!(core_model::Model, divider: false);

/// BTR0.5..0 (the BRP input of the core has only these): the prescaler.
const BRP_MASK: u64 = 0x3F;
/// CDR.2..0: the CLKOUT divider code; CDR.3: clock off.
pub(crate) const CDR_CODE_MASK: u64 = 0x7;
pub(crate) const CDR_CLOCK_OFF: u64 = 1 << 3;
/// The CDR code that passes the controller clock through (no divided level on the pin).
pub(crate) const CDR_CODE_FOSC: u64 = 7;
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

/// How many cycles from the next one on change nothing but the counters, given that the inputs
/// stay those of the last cycle with the bus input at `rx`, and that the whole model is settled
/// (`Model::settled`, checked by the caller). With `clkout_seen` the CLKOUT pin must hold too.
pub(crate) fn quiet_cycles<M: Counters>(model: &M, rx: bool, clkout_seen: bool) -> u64 {
    // The CLKOUT pin first: while traced it usually toggles every few clocks, and then nothing
    // else needs a look.
    let clkout = if M::DIVIDER && clkout_seen {
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
    let stable = model.state(STABLE);
    let sampling_settled = model.state(METASTABLE) == u64::from(rx)
        && stable == u64::from(rx)
        && model.state(PREVIOUS) == stable
        && model.state(QUANTUM_SAMPLES) == stable * 0b11;
    let idle_triggers = model.state(PROCESS_PENDING) == 0 && model.state(TRANSMIT_DEFERRED) == 0;
    if !sampling_settled || !idle_triggers || model.state(ELAPSED) > ELAPSED_SATURATED {
        return 0;
    }
    let last_clock = 2 * (model.state(BRP_SOURCE) & BRP_MASK) + 1;
    let clocks = model.state(CLOCKS);
    // The segment ends in the cycle of its last quantum's end.
    let segment_end = last_clock.saturating_sub(clocks) + model.state(REMAINING) * (last_clock + 1);
    let segment = model.state(SEGMENT);
    let bit_timing = if segment == Segment::Sync as u64 {
        // The first clock of Sync is a transmit point.
        if clocks == 0 {
            return 0;
        }
        segment_end
    } else if segment == Segment::Tseg1 as u64 {
        // The sample point is the cycle of TSEG1's end itself.
        match segment_end.checked_sub(1) {
            Some(cycles) => cycles,
            None => return 0,
        }
    } else if segment == Segment::Tseg2 as u64 {
        segment_end
    } else {
        return 0;
    };
    bit_timing.min(clkout)
}

/// Writes the counters' values `cycles` cycles on (at most [`quiet_cycles`] gave) and evaluates.
pub(crate) fn advance<M: Counters>(model: &mut M, cycles: u64) {
    let last_clock = 2 * (model.state(BRP_SOURCE) & BRP_MASK) + 1;
    let (clocks, quantum_ends) = count_cycles(model.state(CLOCKS), last_clock, cycles);
    model.set_state(CLOCKS, clocks);
    let remaining = model.state(REMAINING) - quantum_ends;
    model.set_state(REMAINING, remaining);
    let elapsed = (model.state(ELAPSED) + quantum_ends).min(ELAPSED_SATURATED);
    model.set_state(ELAPSED, elapsed);
    if M::DIVIDER {
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
