//! Bit timing logic: time quanta, the Sync / TSEG1 (Prop+Phase1) / TSEG2 (Phase2) segments, hard
//! synchronisation, resynchronisation limited by SJW, and the sample, process and transmit triggers.
//!
//! Ports in: `rx` (bus input), the SJA1000 BTR fields `brp`, `tseg1`, `tseg2`, `sjw`, `sam`, and from the
//! protocol side `sync_mode` (which synchronisation the current bit allows) and `tx_dominant` (the node
//! sends a dominant bit). Out: one-clock triggers `sample_point`, `process_point`, `transmit_point`, the
//! bit value `rx_bit` taken at the last sample point, the current `segment`, and `hard_synced` /
//! `resynced` pulses in the clock that synchronised.
//!
//! Timing (every flop acts on the rising edge of `clock`):
//! - tq = 2·(BRP+1) clocks; a bit is Sync (1 tq) + TSEG1 (TSEG1+1 tq) + TSEG2 (TSEG2+1 tq).
//! - `transmit_point` is high in the first clock of Sync (the protocol engine loads its registered `tx`
//!   there); if that clock is also a `process_point` (a restart right after the sample point) it comes one
//!   clock later so the protocol engine has decided the bit.
//! - `sample_point` is high in the last clock of TSEG1; `rx_bit` holds that bit from the next clock on.
//! - `process_point` is high in the clock after `sample_point`.
//! - An edge is a recessive → dominant change of the synchronised input, taken only if the bit sampled at
//!   the last sample point was recessive and no synchronisation happened since that sample point.
//!   - Hard synchronisation (`sync_mode` = Hard): the clock that sees the edge becomes the first clock of
//!     a new Sync segment (with a transmit point).
//!   - Resynchronisation, edge in TSEG1 (phase error e > 0, e = quanta since the end of Sync): if e ≤ SJW
//!     the clock that sees the edge restarts the bit as in a hard sync but without a transmit point (the
//!     sample point moves by e); otherwise TSEG1 is lengthened by SJW quanta. Not done while the node
//!     sends a dominant bit (`tx_dominant`).
//!   - Resynchronisation, edge in TSEG2 (e < 0, |e| = quanta left in TSEG2): if |e| ≤ SJW a new bit
//!     starts at once (Sync, with a transmit point); otherwise TSEG2 is shortened by SJW quanta.
//!   - An edge in Sync is a phase error of 0: no change, but it counts as the synchronisation of that bit.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};

use crate::bus_sampling::BusSampling;

/// Where `elapsed` stops counting: the largest SJW (BTR0.7..6 = 3) is 4 quanta, and an edge that
/// many quanta into TSEG1 is past every SJW.
const ELAPSED_OVER_SJW: u64 = 4;

/// The segment of the bit time the bit timing logic is in.
#[derive(Copy, Clone, Debug, PartialEq, Eq, LogicState)]
pub enum Segment {
    /// Synchronisation segment (1 tq): edges are expected here.
    Sync,
    /// TSEG1 = propagation segment + phase segment 1; the sample point is at its end.
    Tseg1,
    /// TSEG2 = phase segment 2.
    Tseg2,
}

/// Which synchronisation the protocol engine allows for the current bit.
#[derive(Copy, Clone, Debug, PartialEq, Eq, LogicState)]
pub enum SyncMode {
    /// Hard synchronisation: bus idle, intermission, start of frame.
    Hard,
    /// Resynchronisation: inside a frame.
    Resync,
}

/// The bit timing logic of one CAN node (SJA1000 BTL).
#[derive(ActivityBlock, BlockDefault)]
pub struct BitTiming {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Bus input (asynchronous to `clock`).
    pub rx: Signal<In, Bit>,
    /// Baud rate prescaler field (BTR0.5..0): tq = 2·(brp+1) clocks.
    pub brp: Signal<In, Bits<6>>,
    /// TSEG1 field (BTR1.3..0): TSEG1 lasts tseg1+1 quanta.
    pub tseg1: Signal<In, Bits<4>>,
    /// TSEG2 field (BTR1.6..4): TSEG2 lasts tseg2+1 quanta.
    pub tseg2: Signal<In, Bits<3>>,
    /// Synchronisation jump width field (BTR0.7..6): SJW = sjw+1 quanta.
    pub sjw: Signal<In, Bits<2>>,
    /// Triple sampling (BTR1.7).
    pub sam: Signal<In, Bit>,
    /// Synchronisation allowed for the current bit.
    pub sync_mode: Signal<In, SyncMode>,
    /// The node is sending a dominant bit: no resynchronisation on a positive phase error.
    pub tx_dominant: Signal<In, Bit>,
    /// High in the last clock of TSEG1.
    pub sample_point: Signal<Out, Bit>,
    /// High in the clock after the sample point: the protocol engine consumes `rx_bit`.
    pub process_point: Signal<Out, Bit>,
    /// High in the clock where the protocol engine drives the next bit.
    pub transmit_point: Signal<Out, Bit>,
    /// The bit value taken at the last sample point.
    pub rx_bit: Signal<Out, Bit>,
    /// Current segment.
    pub segment: Signal<Out, Segment>,
    /// High in the clock of a hard synchronisation.
    pub hard_synced: Signal<Out, Bit>,
    /// High in the clock of a resynchronisation (any phase error, including 0).
    pub resynced: Signal<Out, Bit>,
    sampling: BusSampling,
    segment_state: DFF<Segment>,
    /// Quanta of the segment after the current one: the segment ends with the quantum in which
    /// this is 0. Counting down the rest (instead of up to a last quantum) makes every
    /// resynchronisation decision a comparison of registers with SJW, with no adder in front.
    remaining: DFF<Bits<5>>,
    /// Quanta since the end of Sync, saturating at `ELAPSED_OVER_SJW` (more than any SJW): the phase
    /// error of an edge in TSEG1 matters only in its comparison with SJW.
    elapsed: DFF<Bits<3>>,
    #[constant(ELAPSED_OVER_SJW)]
    elapsed_over_sjw: Constant<Bits<3>>,
    /// -1 in the remaining-quanta count.
    #[constant(0x1F)]
    minus_one: Constant<Bits<5>>,
    clocks: DFF<Bits<7>>,
    synced: DFF<Bit>,
    sampled: DFF<Bit>,
    process_pending: DFF<Bit>,
    transmit_deferred: DFF<Bit>,
    last_clock: Signal<Local, Bits<7>>,
    sjw_field: Signal<Local, Bits<5>>,
    sjw_field_narrow: Signal<Local, Bits<3>>,
    /// SJW in quanta (the field + 1), registered: the adder stays off the resynchronisation path.
    /// SJW changes only in reset mode, where the protocol engine asks for hard synchronisation
    /// only, so the clock of delay is never seen.
    sjw_quanta: DFF<Bits<5>>,
    /// What the remaining quanta change by in this clock: -1 at a quantum's end, +- SJW quanta.
    remaining_step: Signal<Local, Bits<5>>,
    quantum_end: Signal<Local, Bit>,
    segment_end: Signal<Local, Bit>,
    /// A recessive to dominant edge that may synchronise: the bit before was sampled recessive and
    /// no synchronisation happened since.
    sync_edge: Signal<Local, Bit>,
    hard_sync_now: Signal<Local, Bit>,
    restart_late: Signal<Local, Bit>,
    restart_early: Signal<Local, Bit>,
    lengthen: Signal<Local, Bit>,
    shorten: Signal<Local, Bit>,
    zero_phase: Signal<Local, Bit>,
    restart: Signal<Local, Bit>,
    transmit_now: Signal<Local, Bit>,
}

impl Logic for BitTiming {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            segment_state,
            remaining,
            elapsed,
            clocks,
            synced,
            sampled,
            process_pending,
            transmit_deferred,
            sjw_quanta
        );
        clock!(self, clock, sampling);
        self.sampling.reset.next = self.reset.val();
        self.sampling.rx.next = self.rx.val();
        self.sampling.sam.next = self.sam.val();

        // Register fields as clock and quantum counts.
        // 2·BRP + 1: BRP shifted left with a 1 in (wiring; `brp + brp + 1` would be an adder).
        self.last_clock.next = bit_cast::<7, 6>(self.brp.val())
            .replace_bit(6, self.brp.val().get_bit(5))
            .replace_bit(5, self.brp.val().get_bit(4))
            .replace_bit(4, self.brp.val().get_bit(3))
            .replace_bit(3, self.brp.val().get_bit(2))
            .replace_bit(2, self.brp.val().get_bit(1))
            .replace_bit(1, self.brp.val().get_bit(0))
            .replace_bit(0, true);
        self.sjw_field.next = bit_cast::<5, 2>(self.sjw.val());
        self.sjw_field_narrow.next = bit_cast::<3, 2>(self.sjw.val());
        self.sjw_quanta.d.next = bit_cast::<5, 2>(self.sjw.val()) + 1;
        self.quantum_end.next = self.clocks.q.val() >= self.last_clock.val();

        // Edge qualification and the kind of synchronisation.
        self.hard_sync_now.next = false;
        self.restart_late.next = false;
        self.restart_early.next = false;
        self.lengthen.next = false;
        self.shorten.next = false;
        self.zero_phase.next = false;
        self.sync_edge.next =
            self.sampling.falling_edge.val() & self.sampled.q.val() & !self.synced.q.val();
        if self.sync_edge.val() {
            match self.sync_mode.val() {
                SyncMode::Hard => {
                    self.hard_sync_now.next = true;
                }
                SyncMode::Resync => match self.segment_state.q.val() {
                    Segment::Sync => {
                        self.zero_phase.next = true;
                    }
                    Segment::Tseg1 => {
                        if !self.tx_dominant.val() {
                            if self.elapsed.q.val() <= self.sjw_field_narrow.val() {
                                self.restart_late.next = true;
                            } else {
                                self.lengthen.next = true;
                            }
                        }
                    }
                    Segment::Tseg2 => {
                        // |e| = the current quantum and the remaining ones: |e| <= SJW quanta.
                        if self.remaining.q.val() <= self.sjw_field.val() {
                            self.restart_early.next = true;
                        } else {
                            self.shorten.next = true;
                        }
                    }
                },
            }
        }
        self.restart.next =
            self.hard_sync_now.val() | self.restart_late.val() | self.restart_early.val();
        // A lengthened TSEG1 does not end now; a shortened TSEG2 ends with this quantum exactly
        // when SJW quanta remain after it.
        self.segment_end.next =
            self.quantum_end.val() & (self.remaining.q.val() == 0) & !self.lengthen.val();
        if self.shorten.val() {
            self.segment_end.next =
                self.quantum_end.val() & (self.remaining.q.val() == self.sjw_quanta.q.val());
        }
        // One adder for the quantum's end (-1) and the adjustment (+ SJW quanta, or - SJW quanta =
        // the SJW field inverted), both at once: sjw_field = SJW quanta - 1.
        self.remaining_step.next = 0.into();
        if self.quantum_end.val() {
            self.remaining_step.next = self.minus_one.val();
        }
        if self.lengthen.val() {
            self.remaining_step.next = self.sjw_quanta.q.val();
            if self.quantum_end.val() {
                self.remaining_step.next = self.sjw_field.val();
            }
        }
        if self.shorten.val() {
            self.remaining_step.next = !self.sjw_field.val();
            if self.quantum_end.val() {
                self.remaining_step.next = !self.sjw_quanta.q.val();
            }
        }

        // Prescaler and segment sequencing.
        self.clocks.d.next = self.clocks.q.val() + 1;
        self.remaining.d.next = self.remaining.q.val() + self.remaining_step.val();
        if self.quantum_end.val() {
            self.clocks.d.next = 0.into();
            if self.elapsed.q.val() != self.elapsed_over_sjw.val() {
                self.elapsed.d.next = self.elapsed.q.val() + 1;
            }
        }
        if self.segment_end.val() {
            self.elapsed.d.next = 0.into();
            match self.segment_state.q.val() {
                Segment::Sync => {
                    self.segment_state.d.next = Segment::Tseg1;
                    self.remaining.d.next = bit_cast::<5, 4>(self.tseg1.val());
                }
                Segment::Tseg1 => {
                    self.segment_state.d.next = Segment::Tseg2;
                    self.remaining.d.next = bit_cast::<5, 3>(self.tseg2.val());
                }
                Segment::Tseg2 => {
                    self.segment_state.d.next = Segment::Sync;
                    self.remaining.d.next = 0.into();
                }
            }
        }
        // The clock that saw the edge is the first clock of the new Sync segment.
        if self.restart.val() {
            self.segment_state.d.next = Segment::Sync;
            self.elapsed.d.next = 0.into();
            self.clocks.d.next = 1.into();
            self.remaining.d.next = 0.into();
        }
        self.sampling.quantum_end.next = self.quantum_end.val() & !self.restart.val();

        // Triggers.
        // The last clock of TSEG1 unless an edge restarts or lengthens the bit: every edge taken
        // in TSEG1 does, but one ignored while sending dominant. Written flat from flip-flops and
        // the two protocol inputs (not through `segment_end` and `restart`): the sample point
        // fans out to the whole protocol engine, and this keeps it a few levels deep.
        self.sample_point.next = (self.segment_state.q.val() == Segment::Tseg1)
            & self.quantum_end.val()
            & (self.remaining.q.val() == 0)
            & !(self.sync_edge.val()
                & !((self.sync_mode.val() == SyncMode::Resync) & self.tx_dominant.val()))
            & !self.reset.val();
        self.process_pending.d.next = self.sample_point.val();
        self.process_point.next = self.process_pending.q.val();
        // Sync lasts one quantum: its first clock is the one with `clocks` 0.
        self.transmit_now.next = ((self.segment_state.q.val() == Segment::Sync)
            & (self.clocks.q.val() == 0))
            | self.hard_sync_now.val()
            | self.restart_early.val();
        self.transmit_point.next =
            (self.transmit_now.val() & !self.process_pending.q.val() & !self.reset.val())
                | self.transmit_deferred.q.val();
        self.transmit_deferred.d.next = self.transmit_now.val() & self.process_pending.q.val();

        // Sampled bit and the one-synchronisation-per-bit rule.
        self.rx_bit.next = self.sampled.q.val();
        if self.sample_point.val() {
            self.sampled.d.next = self.sampling.vote.val();
            self.synced.d.next = false;
        }
        self.resynced.next = self.restart_late.val()
            | self.restart_early.val()
            | self.lengthen.val()
            | self.shorten.val()
            | self.zero_phase.val();
        self.hard_synced.next = self.hard_sync_now.val();
        if self.hard_sync_now.val() | self.resynced.val() {
            self.synced.d.next = true;
        }
        self.segment.next = self.segment_state.q.val();
        if self.restart.val() {
            self.segment.next = Segment::Sync;
        }

        // The idle bus is recessive (1): start as after a bit sampled recessive.
        if self.reset.val() {
            self.segment_state.d.next = Segment::Sync;
            self.elapsed.d.next = 0.into();
            self.clocks.d.next = 0.into();
            self.remaining.d.next = 0.into();
            self.synced.d.next = false;
            self.sampled.d.next = true;
            self.process_pending.d.next = false;
            self.transmit_deferred.d.next = false;
            self.sjw_quanta.d.next = 1.into();
        }
    }
}
