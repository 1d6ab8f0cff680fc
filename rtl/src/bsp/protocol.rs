//! The frame sequencer: one state per field with a field bit counter, bit monitoring, arbitration,
//! ACK, the five error kinds, error and overload frames, intermission, suspend, bus integration and
//! bus-off recovery. The top block of the bit stream processor: its children track stuffing
//! (`stuffing`), the CRC (`crc15`), the error counters (`fault_confinement`), assemble the received
//! frame (`rx_assembler`), stream the frame to send from the transmit buffer and choose and drive
//! the bit to send (`bit_transmitter`), and capture ECC and ALC (`error_capture`).
//!
//! Ports in: the bit timing triggers (`process_point`, `transmit_point`) and `rx_bit`; `enable` (low =
//! SJA1000 reset mode: tx recessive at once, the node waits for bus integration afterwards); the
//! transmit request (`tx_request`, `tx_single_shot`, `tx_abort`), the frame to send as the SJA1000 TX buffer
//! (`tx_info` = frame information byte, and `tx_data` = the byte at `tx_addr`).
//! Out: `tx`, `sync_mode`/`tx_dominant` for the bit timing logic, the received frame (`rx_frame`:
//! the header, then every data byte; `rx_valid` at the receiver's validity point, EOF bit 6), `tx_done`/`tx_success`, captures
//! (`bus_error` + `ecc`, `arbitration_lost` + `alc`), counters and states.
//!
//! Timing: everything acts at `process_point` (the clock after the sample point) on `rx_bit`: the bit
//! is classified (stuff bit or field bit), checked (bit, stuff, CRC, form, ACK errors), the state
//! advances, and the bit transmitter prepares the next bit to send; at `transmit_point` it only sends
//! that bit, so the extra transmit point of a hard synchronisation sends the same bit again.
//!
//! Conventions (see the conformance catalog): an error detected at bit e gives a flag from e+1; the
//! error flag is active if the node was error active before the error's counter change; a receiver
//! takes a frame at EOF bit 6 and decrements REC when its ACK went out; a transmitter succeeds at EOF
//! bit 7. The ECC segment of an error on a stuff bit is that of the field bit after it (the engine has
//! moved on). Identifiers, data and the TX buffer use the SJA1000 frame-buffer layout: byte 1.. of
//! `tx_data` are the ID bytes, data starts at byte 3 (standard) or 5 (extended).

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};

use crate::bit_timing::SyncMode;
use crate::bsp::bit_transmitter::BitTransmitter;
use crate::bsp::crc15::Crc15;
use crate::bsp::error_capture::ErrorCapture;
use crate::bsp::fault_confinement::FaultConfinement;
use crate::bsp::received_frame::ReceivedFrame;
use crate::bsp::rx_assembler::RxAssembler;
use crate::bsp::stuffing::BitStuffing;
use crate::bsp::{
    ecc_type, CRC_BITS, DELIMITER_BITS, DLC_BITS, EOF_BITS, EXT_RTR_POSITION, FLAG_BITS,
    IDE_POSITION, IDLE_RUN_BITS, INTERMISSION_BITS, PENALTY_DOMINANT_BITS, SRR_RTR_POSITION,
    SUSPEND_BITS,
};

/// States of the frame sequencer, one per field.
#[derive(Copy, Clone, Debug, PartialEq, Eq, LogicState)]
pub enum ProtocolState {
    /// Waiting for 11 recessive bits before taking part in traffic.
    Integrating,
    /// Bus idle.
    Idle,
    /// ID, SRR/RTR, IDE (and extended ID, RTR): arbitration bit positions 0..31 (SJA1000 ALC coding).
    Arbitration,
    /// r1 (extended), r0, DLC.
    Control,
    /// Data bytes.
    Data,
    /// CRC sequence.
    Crc,
    /// CRC delimiter.
    CrcDelimiter,
    /// ACK slot.
    AckSlot,
    /// ACK delimiter.
    AckDelimiter,
    /// End of frame.
    EndOfFrame,
    /// Intermission.
    Intermission,
    /// Suspend transmission (error-passive former transmitter).
    Suspend,
    /// Active or passive error flag.
    ErrorFlag,
    /// Overload flag.
    OverloadFlag,
    /// Error or overload delimiter (count 0: waiting for the first recessive bit).
    Delimiter,
    /// Bus-off.
    BusOff,
}

/// The protocol engine.
#[derive(ActivityBlock, BlockDefault)]
pub struct Protocol {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Operating mode (low: SJA1000 reset mode).
    pub enable: Signal<In, Bit>,
    /// Process point of the bit timing logic.
    pub process_point: Signal<In, Bit>,
    /// Transmit point of the bit timing logic.
    pub transmit_point: Signal<In, Bit>,
    /// The sampled bit, valid at `process_point`.
    pub rx_bit: Signal<In, Bit>,
    /// Listen-only mode: never a dominant bit (no ACK, passive error flags, no transmission), error
    /// counters frozen.
    pub listen_only: Signal<In, Bit>,
    /// Self-test mode: a transmission succeeds without an ACK.
    pub self_test: Signal<In, Bit>,
    /// A frame waits in the transmit buffer.
    pub tx_request: Signal<In, Bit>,
    /// One attempt only (no retransmission after an error or lost arbitration).
    pub tx_single_shot: Signal<In, Bit>,
    /// Abort the request (one clock): a request not under transmission ends at the next process
    /// point (`tx_done` without success); an attempt under way finishes as a single shot.
    pub tx_abort: Signal<In, Bit>,
    /// Frame information byte of the frame to send: FF (7), RTR (6), DLC (3..0).
    pub tx_info: Signal<In, Bits<8>>,
    /// The transmit-buffer byte at `tx_addr`, at the latest from the clock after `tx_addr`
    /// changed (a registered RAM read): it is used at process points only, and `tx_addr` changes
    /// at a process point or between frames.
    pub tx_data: Signal<In, Bits<8>>,
    /// Load `counter_value` into TEC.
    pub load_tec: Signal<In, Bit>,
    /// Load `counter_value` into REC.
    pub load_rec: Signal<In, Bit>,
    /// Value for `load_tec` / `load_rec`.
    pub counter_value: Signal<In, Bits<8>>,
    /// Bus output, registered.
    pub tx: Signal<Out, Bit>,
    /// Synchronisation allowed for the current bit.
    pub sync_mode: Signal<Out, SyncMode>,
    /// The node sends a dominant bit.
    pub tx_dominant: Signal<Out, Bit>,
    /// Transmit-buffer byte wanted (1..12).
    pub tx_addr: Signal<Out, Bits<4>>,
    /// One clock at the end of a transmission attempt that ends the request (success, or a failed
    /// single shot).
    pub tx_done: Signal<Out, Bit>,
    /// With `tx_done`: the frame was sent.
    pub tx_success: Signal<Out, Bit>,
    /// The received frame: the header, then every data byte (`crate::bsp::received_frame`).
    #[interface]
    pub rx_frame: ReceivedFrame,
    /// One clock when the frame on the bus is valid for receivers (EOF bit 6).
    pub rx_valid: Signal<Out, Bit>,
    /// One clock per detected bus error, with `ecc`.
    pub bus_error: Signal<Out, Bit>,
    /// SJA1000 error code capture: type (7..6), direction (5, 1 = receiving), segment (4..0).
    pub ecc: Signal<Out, Bits<8>>,
    /// One clock when arbitration is lost, with `alc`.
    pub arbitration_lost: Signal<Out, Bit>,
    /// Arbitration bit position of the loss (SJA1000 ALC coding).
    pub alc: Signal<Out, Bits<5>>,
    /// Transmit error counter.
    pub tec: Signal<Out, Bits<8>>,
    /// Receive error counter.
    pub rec: Signal<Out, Bits<8>>,
    /// Error passive.
    pub error_passive: Signal<Out, Bit>,
    /// Bus-off.
    pub bus_off: Signal<Out, Bit>,
    /// Transmitting a frame of its own (SJA1000 SR.TS).
    pub transmitting: Signal<Out, Bit>,
    /// Receiving a frame (SJA1000 SR.RS).
    pub receiving: Signal<Out, Bit>,
    /// Current state (for waves and tests).
    pub state: Signal<Out, ProtocolState>,
    stuffing: BitStuffing,
    crc: Crc15,
    faults: FaultConfinement,
    assembler: RxAssembler,
    sender: BitTransmitter,
    capture: ErrorCapture,
    field: DFF<ProtocolState>,
    count: DFF<Bits<7>>,
    /// The node transmits the frame on the bus (or its error/overload frame after it).
    transmitter: DFF<Bit>,
    valid_pulse: DFF<Bit>,
    done_pulse: DFF<Bit>,
    done_success: DFF<Bit>,
    abort_pending: DFF<Bit>,
    crc_error: DFF<Bit>,
    /// The error flag being sent is passive, and the level of its run of equal bits.
    flag_passive: DFF<Bit>,
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
    /// In a data or remote frame (arbitration to end of frame), registered.
    in_frame: DFF<Bit>,
    // Decisions of this process point.
    next_field: Signal<Local, ProtocolState>,
    next_count: Signal<Local, Bits<7>>,
    next_transmitter: Signal<Local, Bit>,
    count_plus_1: Signal<Local, Bits<7>>,
    /// A transmitter reads back another level than it sends (the bit monitoring of every field).
    bit_error: Signal<Local, Bit>,
    error_now: Signal<Local, Bit>,
    error_type: Signal<Local, Bits<2>>,
    error_counts: Signal<Local, Bit>,
    lost: Signal<Local, Bit>,
    /// The received bit goes into the CRC register this cycle (the kernel reads its own copy:
    /// see `crate::activity` on reading a child's input).
    feed_crc: Signal<Local, Bit>,
    /// Stuffing stops after this bit (an error or the end of the stuffed fields); reset mode
    /// also stops it, below, where it no longer matters for the next bit.
    stop_stuffing: Signal<Local, Bit>,
    start_frame: Signal<Local, Bit>,
    /// In the arbitration field: an identifier bit (not SRR/RTR, IDE or the extended RTR).
    id_bit: Signal<Local, Bit>,
    /// In the control field: the last DLC bit; and with it, no data field follows (remote frame
    /// or DLC 0: the DLC so far with this bit shifted in is 0).
    control_last: Signal<Local, Bit>,
    no_data: Signal<Local, Bit>,
    /// In the data field: the last bit of the last data byte.
    data_last: Signal<Local, Bit>,
    may_start: Signal<Local, Bit>,
    single_shot: Signal<Local, Bit>,
    consume_stream: Signal<Local, Bit>,
    receiver_error: Signal<Local, Bit>,
    send_ack: Signal<Local, Bit>,
    /// Reset mode (and not bus-off): the node takes no part in traffic.
    disabled: Signal<Local, Bit>,
    flag_is_passive: Signal<Local, Bit>,
    /// A bit error in our active error flag restarts it.
    flag_restarts: Signal<Local, Bit>,
    /// The error flag's sixth bit (passive: sixth equal bit) is on the bus.
    flag_complete: Signal<Local, Bit>,
    #[constant(ecc_type::BIT)]
    bit_error_type: Constant<Bits<2>>,
    #[constant(ecc_type::FORM)]
    form_error_type: Constant<Bits<2>>,
    #[constant(ecc_type::STUFF)]
    stuff_error_type: Constant<Bits<2>>,
    #[constant(ecc_type::OTHER)]
    other_error_type: Constant<Bits<2>>,
    // Last positions of the fields (count = position in the field, from 0).
    #[constant(IDLE_RUN_BITS - 1)]
    last_idle_run_bit: Constant<Bits<7>>,
    #[constant(SRR_RTR_POSITION)]
    srr_rtr_position: Constant<Bits<7>>,
    #[constant(IDE_POSITION)]
    ide_position: Constant<Bits<7>>,
    /// The last DLC bit of a standard and of an extended frame.
    #[constant(DLC_BITS)]
    last_standard_dlc_bit: Constant<Bits<7>>,
    #[constant(DLC_BITS + 1)]
    last_extended_dlc_bit: Constant<Bits<7>>,
    /// The last bit of a data byte.
    #[constant(7)]
    last_byte_bit: Constant<Bits<3>>,
    #[constant(EXT_RTR_POSITION)]
    ext_rtr_position: Constant<Bits<7>>,
    #[constant(CRC_BITS - 1)]
    last_crc_bit: Constant<Bits<7>>,
    /// EOF bit 6 (the last but one): a receiver takes the frame here.
    #[constant(EOF_BITS - 2)]
    validity_eof_bit: Constant<Bits<7>>,
    #[constant(EOF_BITS - 1)]
    last_eof_bit: Constant<Bits<7>>,
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

impl Logic for Protocol {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            field,
            in_frame,
            count,
            transmitter,
            valid_pulse,
            done_pulse,
            done_success,
            abort_pending,
            crc_error,
            flag_passive,
            flag_level,
            after_error_flag,
            first_after_flag,
            dominant_after_flag,
            ack_penalty
        );
        clock!(self, clock, stuffing, crc, faults, assembler, sender, capture);

        // ---- Outputs, from registers and children.
        self.tx.next = self.sender.tx.val();
        self.tx_dominant.next = self.sender.tx.val() == false;
        self.tx_addr.next = self.sender.tx_addr.val();
        ReceivedFrame::link(&mut self.rx_frame, &mut self.assembler.frame);
        self.rx_valid.next = self.valid_pulse.q.val();
        self.tx_done.next = self.done_pulse.q.val();
        self.tx_success.next = self.done_success.q.val();
        self.bus_error.next = self.capture.bus_error.val();
        self.ecc.next = self.capture.ecc.val();
        self.arbitration_lost.next = self.capture.arbitration_lost.val();
        self.alc.next = self.capture.alc.val();
        self.tec.next = self.faults.tec.val();
        self.rec.next = self.faults.rec.val();
        self.error_passive.next = self.faults.error_passive.val();
        self.bus_off.next = self.faults.bus_off.val();
        self.state.next = self.field.q.val();
        self.transmitting.next = self.transmitter.q.val() & self.in_frame.q.val();
        self.receiving.next = !self.transmitter.q.val() & self.in_frame.q.val();
        self.faults.load_tec.next = self.load_tec.val();
        self.faults.load_rec.next = self.load_rec.val();
        self.faults.load_value.next = self.counter_value.val();
        self.faults.reset.next = self.reset.val();
        self.stuffing.reset.next = self.reset.val();
        self.assembler.reset.next = self.reset.val();
        self.sender.reset.next = self.reset.val();
        self.capture.reset.next = self.reset.val();

        // Pulses last one clock.
        self.valid_pulse.d.next = false;
        self.done_pulse.d.next = false;

        // ---- Frame-level helpers.
        self.count_plus_1.next = self.count.q.val() + 1;
        self.bit_error.next =
            self.transmitter.q.val() & (self.sender.tx.val() != self.rx_bit.val());
        // A new frame of our own may start: a request, and no suspend owed (error-passive former
        // transmitter) unless the suspend is over.
        self.single_shot.next = self.tx_single_shot.val() | self.abort_pending.q.val();
        self.may_start.next = self.tx_request.val()
            & !self.listen_only.val()
            & !self.abort_pending.q.val()
            & self.enable.val()
            & !self.faults.bus_off.val()
            & !self.done_pulse.q.val();
        // A SOF: a dominant bit where a frame may start (idle, suspend, intermission bit 3). One
        // statement of registers and inputs only: the receive assembler's combinational outputs
        // read back below do not depend on it, and Verilator sees no loop (docs/VERILOG.md).
        self.start_frame.next = self.process_point.val()
            & !self.stuffing.stuff_bit.val()
            & (self.rx_bit.val() == false)
            & ((self.field.q.val() == ProtocolState::Idle)
                | (self.field.q.val() == ProtocolState::Suspend)
                | ((self.field.q.val() == ProtocolState::Intermission)
                    & (self.count.q.val() == self.last_intermission_bit.val())));
        // Where the fields of a frame end, from registers (the count stays below 32 in the
        // arbitration field: equalities, not comparisons, which are carry chains on FPGAs).
        self.id_bit.next = (self.count.q.val() != self.srr_rtr_position.val())
            & (self.count.q.val() != self.ide_position.val())
            & (self.count.q.val() != self.ext_rtr_position.val());
        self.control_last.next = (self.count.q.val() == self.last_extended_dlc_bit.val())
            | ((self.count.q.val() == self.last_standard_dlc_bit.val())
                & (self.rx_frame.ide.val() == false));
        self.no_data.next = self.rx_frame.rtr.val()
            | ((bit_cast::<3, 4>(self.rx_frame.dlc.val()) == 0) & (self.rx_bit.val() == false));
        self.data_last.next = (self.count.q.val().get_bits::<3>(0) == self.last_byte_bit.val())
            & (self.count.q.val().get_bits::<4>(3) == self.assembler.last_data_byte.val());
        self.disabled.next = (self.enable.val() == false) & (self.faults.bus_off.val() == false);
        // A listening node's error flags are passive: it never drives a dominant bit.
        self.flag_is_passive.next = self.faults.error_passive.val() | self.listen_only.val();
        self.flag_restarts.next = false;
        self.flag_complete.next = false;

        // ---- Sub-block defaults.
        self.stuffing.consume.next = false;
        self.stuffing.level.next = self.rx_bit.val();
        self.stuffing.start.next = false;
        self.stop_stuffing.next = false;
        self.crc.clear.next = false;
        self.feed_crc.next = false;
        self.crc.level.next = self.rx_bit.val();
        self.faults.rec_plus_1.next = false;
        self.faults.rec_plus_8.next = false;
        self.faults.tec_plus_8.next = false;
        self.faults.tec_minus_1.next = false;
        self.faults.rec_success.next = false;
        self.faults.recovery_tick.next = false;

        // ---- Decisions of this bit (meaningful at the process point).
        self.next_field.next = self.field.q.val();
        self.next_count.next = self.count_plus_1.val();
        self.next_transmitter.next = self.transmitter.q.val();
        self.error_now.next = false;
        self.error_type.next = self.bit_error_type.val();
        self.error_counts.next = true;
        self.lost.next = false;
        self.consume_stream.next = false;
        self.send_ack.next = false;
        self.receiver_error.next = false;

        if self.process_point.val() {
            self.stuffing.consume.next = true;
            if self.stuffing.stuff_bit.val() {
                // A stuff bit: no field advance.
                self.next_count.next = self.count.q.val();
                if self.bit_error.val() {
                    self.error_now.next = true;
                    // Rule 3 exception b: a recessive stuff bit of the arbitration field read dominant
                    // is a stuff error (ISO 11898-1) that does not count.
                    if (self.field.q.val() == ProtocolState::Arbitration) & self.sender.tx.val() {
                        self.error_type.next = self.stuff_error_type.val();
                        self.error_counts.next = false;
                    }
                } else if self.rx_bit.val() == self.stuffing.run_level.val() {
                    self.error_now.next = true;
                    self.error_type.next = self.stuff_error_type.val();
                }
            } else {
                match self.field.q.val() {
                    ProtocolState::Integrating => {
                        self.next_count.next = 0.into();
                        if self.rx_bit.val() {
                            self.next_count.next = self.count_plus_1.val();
                            if self.count.q.val() == self.last_idle_run_bit.val() {
                                self.next_field.next = ProtocolState::Idle;
                            }
                        }
                    }
                    ProtocolState::Idle => {
                        if self.rx_bit.val() == false {
                            self.next_transmitter.next = self.sender.tx.val() == false;
                        } else if self.sender.tx.val() == false {
                            // Our SOF read recessive.
                            self.error_now.next = true;
                            self.error_type.next = self.bit_error_type.val();
                            self.next_transmitter.next = true;
                        }
                    }
                    ProtocolState::Suspend => {
                        // We send nothing while suspended: a dominant bit is another node's SOF.
                        if self.rx_bit.val() == false {
                            self.next_transmitter.next = false;
                        } else if self.count.q.val() == self.last_suspend_bit.val() {
                            self.next_field.next = ProtocolState::Idle;
                            self.next_transmitter.next = false;
                        }
                    }
                    ProtocolState::Arbitration => {
                        self.feed_crc.next = true;
                        if self.id_bit.val() {
                            self.consume_stream.next = self.transmitter.q.val();
                        }
                        // A dominant IDE ends a standard arbitration field.
                        if (self.count.q.val() == self.ide_position.val())
                            & (self.rx_bit.val() == false)
                        {
                            self.next_field.next = ProtocolState::Control;
                            self.next_count.next = 0.into();
                        }
                        if self.count.q.val() == self.ext_rtr_position.val() {
                            self.next_field.next = ProtocolState::Control;
                            self.next_count.next = 0.into();
                        }
                        if self.bit_error.val() {
                            if self.sender.tx.val() {
                                // Sent recessive, read dominant: arbitration lost.
                                self.next_transmitter.next = false;
                                self.consume_stream.next = false;
                                self.lost.next = true;
                                if self.single_shot.val() {
                                    self.done_pulse.d.next = true;
                                    self.done_success.d.next = false;
                                }
                            } else {
                                self.error_now.next = true;
                                self.error_type.next = self.bit_error_type.val();
                            }
                        }
                    }
                    ProtocolState::Control => {
                        self.feed_crc.next = true;
                        if self.control_last.val() {
                            self.next_count.next = 0.into();
                            self.next_field.next = ProtocolState::Data;
                            if self.no_data.val() {
                                self.next_field.next = ProtocolState::Crc;
                            }
                        }
                        if self.bit_error.val() {
                            self.error_now.next = true;
                            self.error_type.next = self.bit_error_type.val();
                        }
                    }
                    ProtocolState::Data => {
                        self.feed_crc.next = true;
                        self.consume_stream.next = self.transmitter.q.val();
                        if self.data_last.val() {
                            self.next_field.next = ProtocolState::Crc;
                            self.next_count.next = 0.into();
                        }
                        if self.bit_error.val() {
                            self.error_now.next = true;
                            self.error_type.next = self.bit_error_type.val();
                        }
                    }
                    ProtocolState::Crc => {
                        self.feed_crc.next = true;
                        if self.count.q.val() == self.last_crc_bit.val() {
                            self.next_field.next = ProtocolState::CrcDelimiter;
                        }
                        if self.bit_error.val() {
                            self.error_now.next = true;
                            self.error_type.next = self.bit_error_type.val();
                        }
                    }
                    ProtocolState::CrcDelimiter => {
                        self.stop_stuffing.next = true;
                        self.next_field.next = ProtocolState::AckSlot;
                        if self.rx_bit.val() == false {
                            self.error_now.next = true;
                            self.error_type.next = self.form_error_type.val();
                        } else if self.transmitter.q.val() == false {
                            if self.crc.value.val() == 0 {
                                self.send_ack.next =
                                    self.enable.val() & (self.listen_only.val() == false);
                            } else {
                                self.crc_error.d.next = true;
                            }
                        }
                    }
                    ProtocolState::AckSlot => {
                        self.next_field.next = ProtocolState::AckDelimiter;
                        if self.transmitter.q.val() {
                            if self.rx_bit.val() & (self.self_test.val() == false) {
                                self.error_now.next = true;
                                self.error_type.next = self.other_error_type.val();
                                // Rule 3 exception a is decided during the passive flag.
                                if self.faults.error_passive.val() {
                                    self.error_counts.next = false;
                                    self.ack_penalty.d.next = true;
                                }
                            }
                        } else if self.sender.tx.val() == false {
                            if self.rx_bit.val() {
                                self.error_now.next = true;
                                self.error_type.next = self.bit_error_type.val();
                            } else {
                                self.faults.rec_success.next = true;
                            }
                        }
                    }
                    ProtocolState::AckDelimiter => {
                        self.next_field.next = ProtocolState::EndOfFrame;
                        self.next_count.next = 0.into();
                        if self.rx_bit.val() == false {
                            self.error_now.next = true;
                            self.error_type.next = self.form_error_type.val();
                        } else if self.crc_error.q.val() {
                            self.error_now.next = true;
                            self.error_type.next = self.other_error_type.val();
                        }
                    }
                    ProtocolState::EndOfFrame => {
                        if self.count.q.val() == self.last_eof_bit.val() {
                            self.next_field.next = ProtocolState::Intermission;
                            self.next_count.next = 0.into();
                        }
                        if self.rx_bit.val() == false {
                            if (self.count.q.val() == self.last_eof_bit.val())
                                & (self.transmitter.q.val() == false)
                            {
                                self.next_field.next = ProtocolState::OverloadFlag;
                            } else {
                                self.error_now.next = true;
                                self.error_type.next = self.form_error_type.val();
                            }
                        } else {
                            if (self.count.q.val() == self.validity_eof_bit.val())
                                & (self.transmitter.q.val() == false)
                            {
                                self.valid_pulse.d.next = true;
                            }
                            if (self.count.q.val() == self.last_eof_bit.val())
                                & self.transmitter.q.val()
                            {
                                self.done_pulse.d.next = true;
                                self.done_success.d.next = true;
                                self.faults.tec_minus_1.next = true;
                            }
                        }
                    }
                    ProtocolState::Intermission => {
                        if self.rx_bit.val() == false {
                            if self.count.q.val() == self.last_intermission_bit.val() {
                                self.next_transmitter.next = self.may_start.val()
                                    & !(self.transmitter.q.val() & self.faults.error_passive.val());
                            } else {
                                self.next_field.next = ProtocolState::OverloadFlag;
                                self.next_count.next = 0.into();
                            }
                        } else if self.count.q.val() == self.last_intermission_bit.val() {
                            self.next_field.next = ProtocolState::Idle;
                            self.next_transmitter.next = false;
                            if self.transmitter.q.val() & self.faults.error_passive.val() {
                                self.next_field.next = ProtocolState::Suspend;
                                self.next_count.next = 0.into();
                                self.next_transmitter.next = true;
                            }
                        }
                    }
                    ProtocolState::ErrorFlag => {
                        // Complete at its sixth bit unless it restarts below (from the count
                        // itself, not from `next_count`: no adder on the way to the next field).
                        self.flag_complete.next = self.count.q.val() == self.last_flag_bit.val();
                        if self.flag_passive.q.val() {
                            // Complete after 6 equal bits in a row.
                            self.flag_level.d.next = self.rx_bit.val();
                            if (self.count.q.val() != 0)
                                & (self.rx_bit.val() != self.flag_level.q.val())
                            {
                                self.next_count.next = 1.into();
                                self.flag_complete.next = false;
                            }
                            // Rule 3 exception a ends: a dominant bit during the passive flag.
                            if (self.rx_bit.val() == false) & self.ack_penalty.q.val() {
                                self.faults.tec_plus_8.next = true;
                                self.ack_penalty.d.next = false;
                            }
                        } else if self.rx_bit.val() {
                            // Bit error in our active flag (rules 4 and 5): +8, the flag restarts,
                            // active or passive by the state at this detection (ISO 16845-1 7.5.7,
                            // 8.5.15).
                            self.flag_passive.d.next = self.flag_is_passive.val();
                            self.flag_restarts.next = true;
                            self.faults.tec_plus_8.next = self.transmitter.q.val();
                            self.faults.rec_plus_8.next = self.transmitter.q.val() == false;
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
                            self.error_now.next = true;
                            self.error_type.next = self.bit_error_type.val();
                        } else if self.count.q.val() == self.last_flag_bit.val() {
                            self.next_field.next = ProtocolState::Delimiter;
                            self.next_count.next = 0.into();
                            self.after_error_flag.d.next = false;
                            self.first_after_flag.d.next = true;
                            self.dominant_after_flag.d.next = 0.into();
                        }
                    }
                    ProtocolState::Delimiter => {
                        if self.count.q.val() == 0 {
                            self.first_after_flag.d.next = false;
                            if self.rx_bit.val() == false {
                                self.next_count.next = 0.into();
                                self.dominant_after_flag.d.next =
                                    self.dominant_after_flag.q.val() + 1;
                                // Rule 2: first bit after our error flag dominant.
                                if self.first_after_flag.q.val()
                                    & self.after_error_flag.q.val()
                                    & (self.transmitter.q.val() == false)
                                {
                                    self.faults.rec_plus_8.next = true;
                                }
                                // Rule 6: every 8 dominant bits after the flag.
                                if self.dominant_after_flag.q.val()
                                    == self.eighth_dominant_bit.val()
                                {
                                    self.faults.tec_plus_8.next = self.transmitter.q.val();
                                    self.faults.rec_plus_8.next = self.transmitter.q.val() == false;
                                }
                            }
                        } else if self.rx_bit.val() == false {
                            if self.count.q.val() == self.last_delimiter_bit.val() {
                                self.next_field.next = ProtocolState::OverloadFlag;
                                self.next_count.next = 0.into();
                            } else {
                                self.error_now.next = true;
                                self.error_type.next = self.form_error_type.val();
                            }
                        } else if self.count.q.val() == self.last_delimiter_bit.val() {
                            self.next_field.next = ProtocolState::Intermission;
                            self.next_count.next = 0.into();
                        }
                    }
                    ProtocolState::BusOff => {
                        self.next_count.next = 0.into();
                        if self.rx_bit.val() & self.enable.val() {
                            self.next_count.next = self.count_plus_1.val();
                            if self.count.q.val() == self.last_idle_run_bit.val() {
                                self.faults.recovery_tick.next = true;
                                self.next_count.next = 0.into();
                            }
                        }
                    }
                }
            }

            // A frame starts with this bit (SOF): the stream, CRC and stuffing begin.
            if self.start_frame.val() {
                self.next_field.next = ProtocolState::Arbitration;
                self.next_count.next = 0.into();
                self.stuffing.start.next = true;
                self.crc.clear.next = true;
                self.crc_error.d.next = false;
            }

            // Error: the flag starts with the next bit. The role is decided above (our own SOF read
            // recessive makes us the transmitter), so it is read only after every assignment.
            self.receiver_error.next = self.next_transmitter.val() == false;
            if self.error_now.val() {
                self.next_field.next = ProtocolState::ErrorFlag;
                self.next_count.next = 0.into();
                self.stop_stuffing.next = true;
                self.consume_stream.next = false;
                self.flag_passive.d.next = self.flag_is_passive.val();
                self.after_error_flag.d.next = true;
                if self.error_counts.val() {
                    self.faults.tec_plus_8.next = self.next_transmitter.val();
                    self.faults.rec_plus_1.next = self.receiver_error.val();
                    if (self.field.q.val() == ProtocolState::OverloadFlag)
                        & self.receiver_error.val()
                    {
                        self.faults.rec_plus_1.next = false;
                        self.faults.rec_plus_8.next = true;
                    }
                }
                if self.next_transmitter.val() & self.single_shot.val() & self.in_frame.q.val() {
                    self.done_pulse.d.next = true;
                    self.done_success.d.next = false;
                }
            }

            // An aborted request with no attempt under way ends here.
            if self.abort_pending.q.val() & (self.next_transmitter.val() == false) {
                self.done_pulse.d.next = true;
                self.done_success.d.next = false;
            }
        }

        // An abort lasts until the request ends.
        if self.tx_abort.val() {
            self.abort_pending.d.next = true;
        }
        if self.done_pulse.q.val() | (self.tx_request.val() == false) {
            self.abort_pending.d.next = false;
        }

        // ---- The children's inputs from this bit's decisions.
        self.crc.feed.next = self.feed_crc.val();
        self.stuffing.stop.next = self.stop_stuffing.val() | self.disabled.val();
        self.assembler.field_bit.next = self.process_point.val() & !self.stuffing.stuff_bit.val();
        self.assembler.rx_bit.next = self.rx_bit.val();
        self.assembler.field.next = self.field.q.val();
        self.assembler.count.next = self.count.q.val();
        self.assembler.start_frame.next = self.start_frame.val();
        self.assembler.id_bit.next = self.id_bit.val();
        self.assembler.header_done.next =
            (self.field.q.val() == ProtocolState::Control) & self.control_last.val();
        self.sender.tx_data.next = self.tx_data.val();
        self.sender.consume.next = self.consume_stream.val();
        self.sender.to_data.next = self.process_point.val()
            & (self.field.q.val() == ProtocolState::Arbitration)
            & (self.next_field.val() == ProtocolState::Control);
        self.sender.extended.next = self.count.q.val() == self.ext_rtr_position.val();
        // Between frames the stream waits at the first identifier byte.
        self.sender.rewind.next =
            !self.in_frame.q.val() & (self.next_field.val() != ProtocolState::Arbitration);
        self.capture.field.next = self.field.q.val();
        self.capture.count.next = self.count.q.val();
        self.capture.ide.next = self.rx_frame.ide.val();
        self.capture.flag_passive.next = self.flag_passive.q.val();
        self.capture.error.next = self.error_now.val() | self.flag_restarts.val();
        self.capture.error_type.next = self.error_type.val();
        self.capture.receiving.next = self.receiver_error.val();
        self.capture.lost.next = self.lost.val();
        self.capture.discard.next = self.disabled.val();
        self.sender.process_point.next = self.process_point.val();
        self.sender.transmit_point.next = self.transmit_point.val();
        self.sender.rx_bit.next = self.rx_bit.val();
        self.sender.field.next = self.field.q.val();
        self.sender.count.next = self.count.q.val();
        self.sender.stuff_bit.next = self.stuffing.stuff_bit.val();
        self.sender.start_frame.next = self.start_frame.val();
        self.sender.next_field.next = self.next_field.val();
        self.sender.next_transmitter.next = self.next_transmitter.val();
        self.sender.may_start.next = self.may_start.val();
        self.sender.tx_info.next = self.tx_info.val();
        self.sender.crc_msb.next = self.crc.value.val().get_bit(14);
        self.sender.crc_next_msb.next = self.crc.value.val().get_bit(13);
        self.sender.feed_crc.next = self.feed_crc.val();
        self.sender.send_ack.next = self.send_ack.val();
        self.sender.flag_is_passive.next = self.flag_is_passive.val();
        self.sender.flag_passive.next = self.flag_passive.q.val();
        self.sender.flag_restarts.next = self.flag_restarts.val();
        self.sender.listen_only.next = self.listen_only.val();
        self.sender.four_equal.next = self.stuffing.four_equal.val();
        self.sender.run_level.next = self.stuffing.run_level.val();
        self.sender.stop_stuffing.next = self.stop_stuffing.val();
        self.sender.error.next = self.error_now.val();
        self.sender.silent.next = self.faults.bus_off.val() | (self.enable.val() == false);

        // ---- Commit at the process point.
        if self.process_point.val() {
            self.field.d.next = self.next_field.val();
            self.count.d.next = self.next_count.val();
            self.transmitter.d.next = self.next_transmitter.val();
        }

        // ---- Listen-only mode: counters frozen.
        if self.listen_only.val() {
            self.faults.rec_plus_1.next = false;
            self.faults.rec_plus_8.next = false;
            self.faults.tec_plus_8.next = false;
            self.faults.tec_minus_1.next = false;
            self.faults.rec_success.next = false;
        }

        // ---- Bus-off, reset mode and reset override everything.
        if self.faults.bus_off.val() {
            self.field.d.next = ProtocolState::BusOff;
            self.transmitter.d.next = false;
        }
        // Recovery complete: error active with both counters 0.
        if (self.field.q.val() == ProtocolState::BusOff) & (self.faults.bus_off.val() == false) {
            self.field.d.next = ProtocolState::Idle;
            self.count.d.next = 0.into();
        }
        if self.disabled.val() {
            self.field.d.next = ProtocolState::Integrating;
            self.count.d.next = 0.into();
            self.transmitter.d.next = false;
            // A node in reset mode takes no part in traffic: nothing it sees counts, even in the
            // rest of a frame it was in when it was disabled.
            self.valid_pulse.d.next = false;
            self.faults.rec_plus_1.next = false;
            self.faults.rec_plus_8.next = false;
            self.faults.tec_plus_8.next = false;
            self.faults.tec_minus_1.next = false;
            self.faults.rec_success.next = false;
        }
        // Hard synchronisation where a SOF may come: idle, suspend, intermission bit 3, integration.
        self.sync_mode.next = SyncMode::Resync;
        if (self.field.q.val() == ProtocolState::Idle)
            | (self.field.q.val() == ProtocolState::Suspend)
            | (self.field.q.val() == ProtocolState::Integrating)
            | (self.field.q.val() == ProtocolState::BusOff)
            | ((self.field.q.val() == ProtocolState::Intermission)
                & (self.count.q.val() == self.last_intermission_bit.val()))
        {
            self.sync_mode.next = SyncMode::Hard;
        }
        if self.reset.val() {
            self.field.d.next = ProtocolState::Integrating;
            self.count.d.next = 0.into();
            self.transmitter.d.next = false;
            self.crc_error.d.next = false;
            self.ack_penalty.d.next = false;
            self.done_pulse.d.next = false;
            self.abort_pending.d.next = false;
            // The rest only for a defined start without power-up values (FPGA flows that drop
            // `initial` blocks, X in four-state simulators); none of it is read before being loaded.
            self.valid_pulse.d.next = false;
            self.done_success.d.next = false;
            self.flag_passive.d.next = false;
            self.flag_level.d.next = false;
            self.after_error_flag.d.next = false;
            self.first_after_flag.d.next = false;
            self.dominant_after_flag.d.next = 0.into();
        }
        // Registered, from the state this edge loads, so `in_frame.q` always describes `field.q`:
        // outputs made of flip-flop outputs only keep the Verilog free of combinational loops
        // through the parent (see docs/RUST_HDL.md).
        self.in_frame.d.next = (self.field.d.val() == ProtocolState::Arbitration)
            | (self.field.d.val() == ProtocolState::Control)
            | (self.field.d.val() == ProtocolState::Data)
            | (self.field.d.val() == ProtocolState::Crc)
            | (self.field.d.val() == ProtocolState::CrcDelimiter)
            | (self.field.d.val() == ProtocolState::AckSlot)
            | (self.field.d.val() == ProtocolState::AckDelimiter)
            | (self.field.d.val() == ProtocolState::EndOfFrame);
    }
}
