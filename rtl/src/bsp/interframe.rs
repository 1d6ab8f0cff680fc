//! Between frames and after errors: bus integration, idle, intermission, suspend transmission, the
//! error and overload flags and their delimiter, bus-off recovery; and the outcome of every bit,
//! which merges the frame fields' decisions (`frame_fields.rs`) with these and starts error flags
//! (ISO 11898-1 error and overload frames, interframe space, fault confinement rules 1 to 6).
//!
//! Ports in: the sequencer's `field`, `count`, `transmitter` and `in_frame`, the process point
//! with `rx_bit`, `stuff_bit` and the level sent `sender_tx`, the request (`tx_request`,
//! `tx_single_shot`, `abort_pending`, `done_pending`), the modes and states (`enable`,
//! `listen_only`, `error_passive`, `bus_off`), and the frame fields' decisions (`frame_*`,
//! `set_ack_penalty`). Out, combinational: the bit's `next_field`, `next_count`,
//! `next_transmitter`, `start_frame` (a SOF), `may_start`, the `error` with its `error_type` and
//! `receiver_error`, `flag_restarts` (a bit error in our active flag), `stop_stuffing`, the counter
//! events `tec_plus_8`, `rec_plus_8`, `rec_plus_1`, `recovery_tick`, `done` (a request ends
//! unsent), and `flag_is_passive`; registered: `flag_passive`. Every input comes straight from a
//! port, a flip-flop or another block's output (docs/VERILOG.md). Registers (the flag's kind and
//! level, what came before the delimiter, rule 6's dominant bits, rule 3a's pending ACK error) load
//! at process points on the rising edge of `clock`; `reset` is synchronous.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::protocol::ProtocolState;
use crate::bsp::{
    ecc_type, DELIMITER_BITS, FLAG_BITS, IDLE_RUN_BITS, INTERMISSION_BITS, PENALTY_DOMINANT_BITS,
    SUSPEND_BITS,
};

/// Interframe fields, error and overload frames, and a bit's outcome.
#[derive(ActivityBlock, BlockDefault)]
pub struct Interframe {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Process point of the bit timing logic.
    pub process_point: Signal<In, Bit>,
    /// The sampled bit.
    pub rx_bit: Signal<In, Bit>,
    /// The field of the bit.
    pub field: Signal<In, ProtocolState>,
    /// The bit's position in its field.
    pub count: Signal<In, Bits<7>>,
    /// The node transmits the frame.
    pub transmitter: Signal<In, Bit>,
    /// In a data or remote frame.
    pub in_frame: Signal<In, Bit>,
    /// The bit is a stuff bit.
    pub stuff_bit: Signal<In, Bit>,
    /// The level the node sends.
    pub sender_tx: Signal<In, Bit>,
    /// A frame waits to be sent.
    pub tx_request: Signal<In, Bit>,
    /// One attempt only.
    pub tx_single_shot: Signal<In, Bit>,
    /// The request is being aborted.
    pub abort_pending: Signal<In, Bit>,
    /// A request end is being reported this clock.
    pub done_pending: Signal<In, Bit>,
    /// Operating mode.
    pub enable: Signal<In, Bit>,
    /// Listen-only mode.
    pub listen_only: Signal<In, Bit>,
    /// Error passive.
    pub error_passive: Signal<In, Bit>,
    /// Bus-off.
    pub bus_off: Signal<In, Bit>,
    /// The frame fields' next field.
    pub frame_next_field: Signal<In, ProtocolState>,
    /// The frame fields' next count (the count + 1 outside the frame fields).
    pub frame_next_count: Signal<In, Bits<7>>,
    /// The frame fields found an error.
    pub frame_error: Signal<In, Bit>,
    /// Its ECC type.
    pub frame_error_type: Signal<In, Bits<2>>,
    /// It changes the counters.
    pub frame_counts: Signal<In, Bit>,
    /// Arbitration is lost.
    pub frame_lost: Signal<In, Bit>,
    /// Stuffing stops after this bit (end of the stuffed fields).
    pub frame_stop_stuffing: Signal<In, Bit>,
    /// An error-passive transmitter's ACK error (rule 3 exception a).
    pub set_ack_penalty: Signal<In, Bit>,
    /// The field after this bit.
    pub next_field: Signal<Out, ProtocolState>,
    /// The count after this bit.
    pub next_count: Signal<Out, Bits<7>>,
    /// The node's role after this bit.
    pub next_transmitter: Signal<Out, Bit>,
    /// The bit is a SOF.
    pub start_frame: Signal<Out, Bit>,
    /// A frame of our own may start.
    pub may_start: Signal<Out, Bit>,
    /// An error is detected at this bit: the flag starts with the next one.
    pub error: Signal<Out, Bit>,
    /// Its ECC type.
    pub error_type: Signal<Out, Bits<2>>,
    /// The node is a receiver of the erroneous frame.
    pub receiver_error: Signal<Out, Bit>,
    /// A bit error in our active flag restarts it.
    pub flag_restarts: Signal<Out, Bit>,
    /// Stuffing stops after this bit.
    pub stop_stuffing: Signal<Out, Bit>,
    /// TEC + 8.
    pub tec_plus_8: Signal<Out, Bit>,
    /// REC + 8.
    pub rec_plus_8: Signal<Out, Bit>,
    /// REC + 1.
    pub rec_plus_1: Signal<Out, Bit>,
    /// 11 recessive bits while bus-off.
    pub recovery_tick: Signal<Out, Bit>,
    /// The request ends unsent (a failed single shot, or an abort).
    pub done: Signal<Out, Bit>,
    /// A flag of this node would be passive (error passive or listen-only).
    pub flag_is_passive: Signal<Out, Bit>,
    /// The error flag being sent is passive.
    pub flag_passive: Signal<Out, Bit>,
    flag_passive_reg: DFF<Bit>,
    /// The level of the passive flag's run of equal bits.
    flag_level: DFF<Bit>,
    /// The flag before the delimiter was an error flag (not an overload flag).
    after_error_flag: DFF<Bit>,
    /// The first bit after the flag (fault confinement rule 2).
    first_after_flag: DFF<Bit>,
    /// Dominant bits after the flag, modulo 8 (rule 6).
    dominant_after_flag: DFF<Bits<3>>,
    /// An error-passive transmitter's ACK error, counted only if a dominant bit follows in its
    /// passive flag (rule 3 exception a).
    ack_penalty: DFF<Bit>,
    counts: Signal<Local, Bit>,
    /// The error flag's sixth bit (passive: sixth equal bit) is on the bus.
    flag_complete: Signal<Local, Bit>,
    #[constant(ecc_type::FORM)]
    form_error_type: Constant<Bits<2>>,
    #[constant(IDLE_RUN_BITS - 1)]
    last_idle_run_bit: Constant<Bits<7>>,
    #[constant(INTERMISSION_BITS - 1)]
    last_intermission_bit: Constant<Bits<7>>,
    #[constant(SUSPEND_BITS - 1)]
    last_suspend_bit: Constant<Bits<7>>,
    #[constant(FLAG_BITS - 1)]
    last_flag_bit: Constant<Bits<7>>,
    #[constant(DELIMITER_BITS - 1)]
    last_delimiter_bit: Constant<Bits<7>>,
    /// The eighth dominant bit after a flag (rule 6), counted modulo 8.
    #[constant(PENALTY_DOMINANT_BITS - 1)]
    eighth_dominant_bit: Constant<Bits<3>>,
}

impl Logic for Interframe {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            flag_passive_reg,
            flag_level,
            after_error_flag,
            first_after_flag,
            dominant_after_flag,
            ack_penalty
        );
        self.flag_passive.next = self.flag_passive_reg.q.val();
        // A listening node's error flags are passive: it never drives a dominant bit.
        self.flag_is_passive.next = self.error_passive.val() | self.listen_only.val();
        // A new frame of our own may start: a request, and no end being reported.
        self.may_start.next = self.tx_request.val()
            & !self.listen_only.val()
            & !self.abort_pending.val()
            & self.enable.val()
            & !self.bus_off.val()
            & !self.done_pending.val();
        // A SOF: a dominant bit where a frame may start (idle, suspend, intermission bit 3).
        self.start_frame.next = self.process_point.val()
            & !self.stuff_bit.val()
            & (self.rx_bit.val() == false)
            & ((self.field.val() == ProtocolState::Idle)
                | (self.field.val() == ProtocolState::Suspend)
                | ((self.field.val() == ProtocolState::Intermission)
                    & (self.count.val() == self.last_intermission_bit.val())));

        // The frame fields' decisions stand; outside the frame fields they are "no change" (the
        // field stays, the count advances, no error), which the fields below refine.
        self.next_field.next = self.frame_next_field.val();
        self.next_count.next = self.frame_next_count.val();
        self.next_transmitter.next = self.transmitter.val() & (self.frame_lost.val() == false);
        self.error.next = self.frame_error.val();
        self.error_type.next = self.frame_error_type.val();
        self.counts.next = self.frame_counts.val();
        self.stop_stuffing.next = self.frame_stop_stuffing.val();
        self.flag_restarts.next = false;
        self.flag_complete.next = false;
        self.tec_plus_8.next = false;
        self.rec_plus_8.next = false;
        self.rec_plus_1.next = false;
        self.recovery_tick.next = false;
        self.done.next = false;
        self.receiver_error.next = false;
        if self.set_ack_penalty.val() {
            self.ack_penalty.d.next = true;
        }

        if self.process_point.val() {
            if self.stuff_bit.val() == false {
                match self.field.val() {
                    ProtocolState::Integrating => {
                        if self.rx_bit.val() == false {
                            self.next_count.next = 0.into();
                        } else if self.count.val() == self.last_idle_run_bit.val() {
                            self.next_field.next = ProtocolState::Idle;
                        }
                    }
                    ProtocolState::Idle => {
                        if self.rx_bit.val() == false {
                            self.next_transmitter.next = self.sender_tx.val() == false;
                        } else if self.sender_tx.val() == false {
                            // Our SOF read recessive.
                            self.error.next = true;
                            self.next_transmitter.next = true;
                        }
                    }
                    ProtocolState::Suspend => {
                        // We send nothing while suspended: a dominant bit is another node's SOF.
                        if self.rx_bit.val() == false {
                            self.next_transmitter.next = false;
                        } else if self.count.val() == self.last_suspend_bit.val() {
                            self.next_field.next = ProtocolState::Idle;
                            self.next_transmitter.next = false;
                        }
                    }
                    ProtocolState::Intermission => {
                        if self.rx_bit.val() == false {
                            if self.count.val() == self.last_intermission_bit.val() {
                                self.next_transmitter.next = self.may_start.val()
                                    & !(self.transmitter.val() & self.error_passive.val());
                            } else {
                                self.next_field.next = ProtocolState::OverloadFlag;
                                self.next_count.next = 0.into();
                            }
                        } else if self.count.val() == self.last_intermission_bit.val() {
                            self.next_field.next = ProtocolState::Idle;
                            self.next_transmitter.next = false;
                            if self.transmitter.val() & self.error_passive.val() {
                                self.next_field.next = ProtocolState::Suspend;
                                self.next_count.next = 0.into();
                                self.next_transmitter.next = true;
                            }
                        }
                    }
                    ProtocolState::ErrorFlag => {
                        // Complete at its sixth bit unless it restarts below (from the count
                        // itself, not from `next_count`: no adder on the way to the next field).
                        self.flag_complete.next = self.count.val() == self.last_flag_bit.val();
                        if self.flag_passive_reg.q.val() {
                            // Complete after 6 equal bits in a row.
                            self.flag_level.d.next = self.rx_bit.val();
                            if (self.count.val() != 0)
                                & (self.rx_bit.val() != self.flag_level.q.val())
                            {
                                self.next_count.next = 1.into();
                                self.flag_complete.next = false;
                            }
                            // Rule 3 exception a ends: a dominant bit during the passive flag.
                            if (self.rx_bit.val() == false) & self.ack_penalty.q.val() {
                                self.tec_plus_8.next = true;
                                self.ack_penalty.d.next = false;
                            }
                        } else if self.rx_bit.val() {
                            // Bit error in our active flag (rules 4 and 5): +8, the flag restarts,
                            // active or passive by the state at this detection (ISO 16845-1 7.5.7,
                            // 8.5.15).
                            self.flag_passive_reg.d.next = self.flag_is_passive.val();
                            self.flag_restarts.next = true;
                            self.tec_plus_8.next = self.transmitter.val();
                            self.rec_plus_8.next = self.transmitter.val() == false;
                            self.next_count.next = 0.into();
                            self.flag_complete.next = false;
                        }
                        if self.flag_complete.val() {
                            self.next_field.next = ProtocolState::Delimiter;
                            self.next_count.next = 0.into();
                            self.first_after_flag.d.next = true;
                            self.dominant_after_flag.d.next = 0.into();
                            self.ack_penalty.d.next = false;
                        }
                    }
                    ProtocolState::OverloadFlag => {
                        if self.rx_bit.val() & (self.listen_only.val() == false) {
                            // Bit error in our overload flag: an active error flag follows (+8).
                            self.error.next = true;
                        } else if self.count.val() == self.last_flag_bit.val() {
                            self.next_field.next = ProtocolState::Delimiter;
                            self.next_count.next = 0.into();
                            self.after_error_flag.d.next = false;
                            self.first_after_flag.d.next = true;
                            self.dominant_after_flag.d.next = 0.into();
                        }
                    }
                    ProtocolState::Delimiter => {
                        if self.count.val() == 0 {
                            self.first_after_flag.d.next = false;
                            if self.rx_bit.val() == false {
                                self.next_count.next = 0.into();
                                self.dominant_after_flag.d.next =
                                    self.dominant_after_flag.q.val() + 1;
                                // Rule 2: first bit after our error flag dominant.
                                if self.first_after_flag.q.val()
                                    & self.after_error_flag.q.val()
                                    & (self.transmitter.val() == false)
                                {
                                    self.rec_plus_8.next = true;
                                }
                                // Rule 6: every 8 dominant bits after the flag.
                                if self.dominant_after_flag.q.val()
                                    == self.eighth_dominant_bit.val()
                                {
                                    self.tec_plus_8.next = self.transmitter.val();
                                    self.rec_plus_8.next = self.transmitter.val() == false;
                                }
                            }
                        } else if self.rx_bit.val() == false {
                            if self.count.val() == self.last_delimiter_bit.val() {
                                self.next_field.next = ProtocolState::OverloadFlag;
                                self.next_count.next = 0.into();
                            } else {
                                self.error.next = true;
                                self.error_type.next = self.form_error_type.val();
                            }
                        } else if self.count.val() == self.last_delimiter_bit.val() {
                            self.next_field.next = ProtocolState::Intermission;
                            self.next_count.next = 0.into();
                        }
                    }
                    ProtocolState::BusOff => {
                        if (self.rx_bit.val() & self.enable.val()) == false {
                            self.next_count.next = 0.into();
                        } else if self.count.val() == self.last_idle_run_bit.val() {
                            self.recovery_tick.next = true;
                            self.next_count.next = 0.into();
                        }
                    }
                    _ => {}
                }
            }

            // A frame starts with this bit (SOF).
            if self.start_frame.val() {
                self.next_field.next = ProtocolState::Arbitration;
                self.next_count.next = 0.into();
            }

            // Error: the flag starts with the next bit. The role is decided above (our own SOF read
            // recessive makes us the transmitter), so it is read only after every assignment.
            self.receiver_error.next = self.next_transmitter.val() == false;
            if self.error.val() {
                self.next_field.next = ProtocolState::ErrorFlag;
                self.next_count.next = 0.into();
                self.stop_stuffing.next = true;
                self.flag_passive_reg.d.next = self.flag_is_passive.val();
                self.after_error_flag.d.next = true;
                if self.counts.val() {
                    self.tec_plus_8.next = self.next_transmitter.val();
                    self.rec_plus_1.next = self.next_transmitter.val() == false;
                    if (self.field.val() == ProtocolState::OverloadFlag)
                        & (self.next_transmitter.val() == false)
                    {
                        self.rec_plus_1.next = false;
                        self.rec_plus_8.next = true;
                    }
                }
                self.done.next = self.next_transmitter.val()
                    & (self.tx_single_shot.val() | self.abort_pending.val())
                    & self.in_frame.val();
            }
            // An aborted request with no attempt under way ends here.
            if self.abort_pending.val() & (self.next_transmitter.val() == false) {
                self.done.next = true;
            }
        }

        if self.reset.val() {
            self.ack_penalty.d.next = false;
            // The rest only for a defined start without power-up values (FPGA flows that drop
            // `initial` blocks, X in four-state simulators); none of it is read before being loaded.
            self.flag_passive_reg.d.next = false;
            self.flag_level.d.next = false;
            self.after_error_flag.d.next = false;
            self.first_after_flag.d.next = false;
            self.dominant_after_flag.d.next = 0.into();
        }
    }
}
