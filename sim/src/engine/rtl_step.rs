//! One clock cycle of a rust-hdl design, stepped directly (no threads), with as few settle passes
//! as the design allows.
//!
//! rust-hdl propagates a change one hierarchy level per `update_all` pass, so a plain "clock low,
//! settle; clock high, settle" costs two full settles per cycle although nothing acts on the falling
//! edge. Here the inputs settle with the clock low, then the clock is high for exactly one pass at the
//! top and low again: the one-pass pulse travels down the hierarchy, every flop sees its rising edge in
//! exactly one pass (as it would with a long high phase), and the rest of the settle carries the new
//! register values up to the outputs. The outputs read afterwards are those after the rising edge.

use rust_hdl::prelude::*;

/// Settle passes allowed before a design is declared non-converging (a combinational loop).
const SETTLE_LIMIT: usize = 200;

/// Settles `uut` after its inputs changed; panics naming `what` if it does not converge.
pub fn settle<B: Block>(uut: &mut B, what: &str) {
    assert!(simulate(uut, SETTLE_LIMIT), "{what} did not settle");
}

/// One rising edge of `clock` with the inputs already applied: settles the inputs, pulses the
/// clock and settles the result.
pub fn clock_cycle<B: Block>(uut: &mut B, clock: fn(&mut B) -> &mut Signal<In, Clock>, what: &str) {
    clock_cycle_with(uut, clock, what, true);
}

/// [`clock_cycle`] for a caller that knows whether any input changed since the last cycle: with
/// `inputs_changed` false the design is still settled and the input settle is skipped.
pub fn clock_cycle_with<B: Block>(
    uut: &mut B,
    clock: fn(&mut B) -> &mut Signal<In, Clock>,
    what: &str,
    inputs_changed: bool,
) {
    if inputs_changed {
        settle(uut, what);
    }
    // The clock is high for exactly one pass: the blocks pass it down within the pass and load
    // their registers at once (see `rtl::activity`); the rest of the settle, with the clock low,
    // carries the new register values to the outputs.
    clock(uut).next = true.into();
    uut.update_all();
    clock(uut).next = false.into();
    settle(uut, what);
}
