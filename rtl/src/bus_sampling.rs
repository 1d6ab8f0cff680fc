//! Bus sampling: the input stage of the bit timing logic.
//!
//! Ports: `rx` (asynchronous bus input), `sam` (triple sampling on), `quantum_end` (the bit timing logic's
//! last clock of a time quantum) in; `level` (synchronised bus level), `falling_edge` (recessive → dominant
//! seen in this clock) and `vote` (the bit value if this clock is the sample point) out.
//!
//! Timing: every flop acts on the rising edge of `clock`. `rx` passes a 2-flop synchroniser, so `level`
//! shows the bus as it was two clocks earlier. With `sam` set, `vote` is the majority of the levels at the
//! last clock of the two previous quanta and `level` now, i.e. one sample per quantum for the last three
//! quanta before the sample point; without `sam` it is `level`.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock};

/// 2-flop synchroniser, edge detector and single/triple sampler of the bus input.
#[derive(ActivityBlock, Default)]
pub struct BusSampling {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Bus input (asynchronous to `clock`).
    pub rx: Signal<In, Bit>,
    /// Triple sampling (SJA1000 BTR1.SAM).
    pub sam: Signal<In, Bit>,
    /// High in the last clock of every time quantum: records one sample for the majority vote.
    pub quantum_end: Signal<In, Bit>,
    /// Synchronised bus level.
    pub level: Signal<Out, Bit>,
    /// High in the clock in which `level` turned from recessive to dominant.
    pub falling_edge: Signal<Out, Bit>,
    /// Bit value to take if this clock is the sample point.
    pub vote: Signal<Out, Bit>,
    metastable: DFF<Bit>,
    stable: DFF<Bit>,
    previous: DFF<Bit>,
    quantum_samples: DFF<Bits<2>>,
}

impl Logic for BusSampling {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, metastable, stable, previous, quantum_samples);
        self.metastable.d.next = self.rx.val();
        self.stable.d.next = self.metastable.q.val();
        self.previous.d.next = self.stable.q.val();
        self.level.next = self.stable.q.val();
        self.falling_edge.next = self.previous.q.val() & !self.stable.q.val();
        self.vote.next = self.stable.q.val();
        if self.sam.val() {
            self.vote.next = (self.quantum_samples.q.val().get_bit(1)
                & self.quantum_samples.q.val().get_bit(0))
                | (self.quantum_samples.q.val().get_bit(1) & self.stable.q.val())
                | (self.quantum_samples.q.val().get_bit(0) & self.stable.q.val());
        }
        if self.quantum_end.val() {
            self.quantum_samples.d.next = self
                .quantum_samples
                .q
                .val()
                .replace_bit(1, self.quantum_samples.q.val().get_bit(0))
                .replace_bit(0, self.stable.q.val());
        }
        // The idle bus is recessive (1).
        if self.reset.val() {
            self.metastable.d.next = true;
            self.stable.d.next = true;
            self.previous.d.next = true;
            self.quantum_samples.d.next = 3.into();
        }
    }
}
