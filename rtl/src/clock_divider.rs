//! The CLKOUT divider (SJA1000 CDR bits 2..0 and 3).
//!
//! Ports: `code` (CDR.2..0: fosc/2, /4, /6, /8, /10, /12, /14 for codes 0..6, fosc for 7),
//! `clock_off` (CDR.3: `clkout` held high), out `clkout`. The divided clock is a flip-flop toggled
//! on the rising edge of `clock` every `code + 1` clocks; code 7 passes the controller clock
//! through.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock};

use crate::clock_output::ClockOutput;

/// The CLKOUT divider.
#[derive(ActivityBlock, Default)]
pub struct ClockDivider {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock (fosc).
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// CDR.2..0.
    pub code: Signal<In, Bits<3>>,
    /// CDR.3: clock output off (held high).
    pub clock_off: Signal<In, Bit>,
    /// The clock output.
    pub clkout: Signal<Out, Bit>,
    fosc: ClockOutput,
    count: DFF<Bits<3>>,
    level: DFF<Bit>,
}

impl Logic for ClockDivider {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, count, level);
        self.fosc.clock.next = self.clock.val();
        self.count.d.next = self.count.q.val() + 1;
        if self.count.q.val() >= self.code.val() {
            self.count.d.next = 0.into();
            self.level.d.next = self.level.q.val() == false;
        }
        self.clkout.next = self.level.q.val();
        if self.code.val() == 7 {
            self.clkout.next = self.fosc.level.val();
        }
        if self.clock_off.val() {
            self.clkout.next = true;
        }
        if self.reset.val() {
            self.count.d.next = 0.into();
            self.level.d.next = false;
        }
    }
}
