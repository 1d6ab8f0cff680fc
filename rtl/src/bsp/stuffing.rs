//! Bit stuffing: tracks the run of equal bus bits from SOF to the end of the CRC field (and the stuff
//! bit that may follow the last CRC bit).
//!
//! Ports: `consume` (the protocol engine processes `level` now), `start` (that bit is a SOF), `stop`
//! (leave the stuffed region after it) in; out, from registers only: `stuff_bit` (the bit now being
//! processed is a stuff bit: the five before it were equal), `run_level` and `four_equal` (the last four
//! bits were equal and not a stuff position). The protocol engine derives stuff errors (a stuff bit
//! equal to `run_level`) and "the next bit is a stuff bit" (`four_equal` and this bit equal to
//! `run_level`). Registered-only outputs keep the parent's logic free of combinational loops through
//! this block. Acts on the rising edge of `clock` when `consume` is high, i.e. at the process point;
//! transmitters and receivers share it: a transmitter sends what it reads, so its stuff bit is the
//! complement of the bus level.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock};

/// Stuff-run tracker of the bit stream processor.
#[derive(ActivityBlock, Default)]
pub struct BitStuffing {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// The protocol engine processes `level` in this clock.
    pub consume: Signal<In, Bit>,
    /// The bus bit being processed.
    pub level: Signal<In, Bit>,
    /// The processed bit is a start of frame: a run of one begins.
    pub start: Signal<In, Bit>,
    /// Leave the stuffed region after this bit.
    pub stop: Signal<In, Bit>,
    /// The bit being processed is a stuff bit.
    pub stuff_bit: Signal<Out, Bit>,
    /// Level of the current run.
    pub run_level: Signal<Out, Bit>,
    /// Four equal bits in the stuffed region: a fifth makes the next bit a stuff bit.
    pub four_equal: Signal<Out, Bit>,
    active: DFF<Bit>,
    run_level_reg: DFF<Bit>,
    run_length: DFF<Bits<3>>,
}

impl Logic for BitStuffing {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, active, run_level_reg, run_length);
        self.stuff_bit.next = self.active.q.val() & (self.run_length.q.val() == 5);
        self.four_equal.next = self.active.q.val() & (self.run_length.q.val() == 4);
        self.run_level.next = self.run_level_reg.q.val();
        if self.consume.val() {
            if (self.run_length.q.val() == 5) | (self.level.val() != self.run_level_reg.q.val()) {
                self.run_level_reg.d.next = self.level.val();
                self.run_length.d.next = 1.into();
            } else {
                self.run_length.d.next = self.run_length.q.val() + 1;
            }
            if self.start.val() {
                self.active.d.next = true;
                self.run_level_reg.d.next = self.level.val();
                self.run_length.d.next = 1.into();
            }
            if self.stop.val() {
                self.active.d.next = false;
            }
        }
        if self.reset.val() {
            self.active.d.next = false;
            self.run_length.d.next = 0.into();
        }
    }
}
