//! Fault confinement: the transmit and receive error counters, error-active / error-passive / bus-off
//! and bus-off recovery. (The error warning limit is a register of the controller, which compares the
//! counters with it.)
//!
//! Ports in: counter events from the protocol engine (one-clock strobes at the process point:
//! `rec_plus_1`, `rec_plus_8`, `tec_plus_8`, `tec_minus_1`, `rec_success`), `recovery_tick` (11
//! consecutive recessive bits seen while bus-off and recovery allowed), `frozen` (listen-only or
//! reset mode: the events but recovery are ignored), host writes (`load_tec`/`load_rec` with
//! `load_value`). Out:
//! `tec`, `rec`, `error_passive`, `bus_off`. Acts on the rising edge of `clock`.
//!
//! Rules (catalog group EC): REC saturates at 255 and never causes bus-off; a successful reception
//! takes REC from above 127 to 127, otherwise down by one; TEC above 255 is bus-off, entered with
//! TEC = 127 and REC = 0 as on the SJA1000; while bus-off the counters are frozen but for recovery,
//! where each `recovery_tick` counts TEC down and the 128th ends bus-off with both counters 0. A host
//! write of 255 into TEC enters bus-off the same way; a write of 0..254 while bus-off ends it at once
//! (TEC = the value written, REC = 0); REC writes are ignored while bus-off.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock};

/// TEC/REC and the fault confinement state.
#[derive(ActivityBlock, Default)]
pub struct FaultConfinement {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Receiver error (rule 1).
    pub rec_plus_1: Signal<In, Bit>,
    /// Receiver error worth 8 (rules 2, 5, 6).
    pub rec_plus_8: Signal<In, Bit>,
    /// Transmitter error (rules 3, 4, 6).
    pub tec_plus_8: Signal<In, Bit>,
    /// Successful transmission (rule 7).
    pub tec_minus_1: Signal<In, Bit>,
    /// Successful reception (rule 8).
    pub rec_success: Signal<In, Bit>,
    /// One more sequence of 11 recessive bits during bus-off recovery.
    pub recovery_tick: Signal<In, Bit>,
    /// Counters frozen (listen-only mode, reset mode): the events above but `recovery_tick` are
    /// ignored.
    pub frozen: Signal<In, Bit>,
    /// Load `load_value` into TEC (host write, SJA1000 TXERR in reset mode).
    pub load_tec: Signal<In, Bit>,
    /// Load `load_value` into REC (host write, SJA1000 RXERR in reset mode).
    pub load_rec: Signal<In, Bit>,
    /// Value for `load_tec` / `load_rec`.
    pub load_value: Signal<In, Bits<8>>,
    /// Transmit error counter.
    pub tec: Signal<Out, Bits<8>>,
    /// Receive error counter.
    pub rec: Signal<Out, Bits<8>>,
    /// Error passive: a counter at 128 or more, not bus-off.
    pub error_passive: Signal<Out, Bit>,
    /// Bus-off.
    pub bus_off: Signal<Out, Bit>,
    tec_count: DFF<Bits<8>>,
    rec_count: DFF<Bits<8>>,
    bus_off_state: DFF<Bit>,
    /// `error_passive`, registered from the values the counters load (it starts long paths of the
    /// protocol engine).
    passive_state: DFF<Bit>,
}

impl Logic for FaultConfinement {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            tec_count,
            rec_count,
            bus_off_state,
            passive_state
        );
        self.tec.next = self.tec_count.q.val();
        self.rec.next = self.rec_count.q.val();
        self.bus_off.next = self.bus_off_state.q.val();
        self.error_passive.next = self.passive_state.q.val();

        if self.bus_off_state.q.val() {
            if self.recovery_tick.val() {
                if self.tec_count.q.val() == 0 {
                    self.bus_off_state.d.next = false;
                    self.rec_count.d.next = 0.into();
                } else {
                    self.tec_count.d.next = self.tec_count.q.val() - 1;
                }
            }
        } else if self.frozen.val() == false {
            // +8 passes 255 exactly from 248 on (bits 7..3 all set): no 9-bit sum needed.
            if self.tec_plus_8.val() {
                if self.tec_count.q.val().get_bits::<5>(3) == 31 {
                    self.bus_off_state.d.next = true;
                    self.tec_count.d.next = 127.into();
                    self.rec_count.d.next = 0.into();
                } else {
                    self.tec_count.d.next = self.tec_count.q.val() + 8;
                }
            }
            if self.tec_minus_1.val() & (self.tec_count.q.val() != 0) {
                self.tec_count.d.next = self.tec_count.q.val() - 1;
            }
            if self.rec_plus_1.val() & (self.rec_count.q.val() != 255) {
                self.rec_count.d.next = self.rec_count.q.val() + 1;
            }
            if self.rec_plus_8.val() {
                self.rec_count.d.next = self.rec_count.q.val() + 8;
                if self.rec_count.q.val().get_bits::<5>(3) == 31 {
                    self.rec_count.d.next = 255.into();
                }
            }
            if self.rec_success.val() {
                if self.rec_count.q.val().get_bit(7) {
                    self.rec_count.d.next = 127.into();
                } else if self.rec_count.q.val() != 0 {
                    self.rec_count.d.next = self.rec_count.q.val() - 1;
                }
            }
        }
        // Host writes (SJA1000 TXERR/RXERR): 255 into TEC forces bus-off; any other TEC value ends
        // bus-off at once; REC cannot be written while bus-off.
        if self.load_tec.val() {
            self.tec_count.d.next = self.load_value.val();
            if self.load_value.val() == 255 {
                self.bus_off_state.d.next = true;
                self.tec_count.d.next = 127.into();
                self.rec_count.d.next = 0.into();
            } else if self.bus_off_state.q.val() {
                self.bus_off_state.d.next = false;
                self.rec_count.d.next = 0.into();
            }
        }
        if self.load_rec.val() & (self.bus_off_state.q.val() == false) {
            self.rec_count.d.next = self.load_value.val();
        }
        if self.reset.val() {
            self.tec_count.d.next = 0.into();
            self.rec_count.d.next = 0.into();
            self.bus_off_state.d.next = false;
        }
        self.passive_state.d.next = !self.bus_off_state.d.val()
            & (self.tec_count.d.val().get_bit(7) | self.rec_count.d.val().get_bit(7));
    }
}
