//! The controller clock as a plain bit signal, for CLKOUT's fosc setting (CDR.2..0 = 7).
//!
//! Ports: `clock` in, `level` out (equal to `clock`, combinationally). rust-hdl kernels cannot read a
//! clock as data, so this block writes its Verilog by hand: one combinational assignment.

use rust_hdl::prelude::*;

/// A clock-to-bit buffer.
#[derive(LogicBlock, Default)]
pub struct ClockOutput {
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// The clock level.
    pub level: Signal<Out, Bit>,
}

impl Logic for ClockOutput {
    fn update(&mut self) {
        self.level.next = self.clock.val().clk;
    }

    fn connect(&mut self) {
        self.level.connect();
    }

    fn hdl(&self) -> Verilog {
        Verilog::Custom("always @(*) level = clock;".into())
    }
}

// The clock is data here: rust-hdl's derive re-runs the kernel, and the parent visits the block,
// whenever the clock moves.
crate::activity::derived_child!(impl [] ClockOutput, clocks: [clock], output: level);
