//! The frame sequencer: one state per field with a field bit counter, bit monitoring, arbitration,
//! ACK, the five error kinds, error and overload frames, intermission, suspend, bus integration and
//! bus-off recovery. The top block of the bit stream processor.
//!
//! Ports in: the bit timing triggers (`process_point`, `transmit_point`) and `rx_bit`; `enable` (low =
//! SJA1000 reset mode: tx recessive at once, the node waits for bus integration afterwards); the
//! transmit request (`tx_request`, `tx_single_shot`, `tx_abort`), the frame to send as the SJA1000 TX buffer
//! (`tx_info` = frame information byte, and `tx_data` = the byte at `tx_addr`).
//! Out: `tx`, `sync_mode`/`tx_dominant` for the bit timing logic, the received frame (`rx_id`,
//! `rx_ide`, `rx_rtr`, `rx_dlc` valid at `rx_header`, then every data byte with `rx_byte_strobe`, and
//! `rx_valid` at the receiver's validity point, EOF bit 6), `tx_done`/`tx_success`, captures
//! (`bus_error` + `ecc`, `arbitration_lost` + `alc`), counters and states.
//!
//! Timing: everything acts at `process_point` (the clock after the sample point) on `rx_bit`: the bit
//! is classified (stuff bit or field bit), checked (bit, stuff, CRC, form, ACK errors), the state
//! advances, and the next bit to send is prepared in `tx_next`; `transmit_point` only copies `tx_next`
//! to `tx`, so the extra transmit point of a hard synchronisation sends the same bit again.
//!
//! Conventions (see the conformance catalog): an error detected at bit e gives a flag from e+1; the
//! error flag is active if the node was error active before the error's counter change; a receiver
//! takes a frame at EOF bit 6 and decrements REC when its ACK went out; a transmitter succeeds at EOF
//! bit 7. The ECC segment of an error on a stuff bit is that of the field bit after it (the engine has
//! moved on). Identifiers, data and the TX buffer use the SJA1000 frame-buffer layout: byte 1.. of
//! `tx_data` are the ID bytes, data starts at byte 3 (standard) or 5 (extended).

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock};

use crate::bit_timing::SyncMode;
use crate::bsp::crc15::Crc15;
use crate::bsp::fault_confinement::FaultConfinement;
use crate::bsp::stuffing::BitStuffing;

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
#[derive(ActivityBlock, Default)]
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
    /// Received identifier (11 or 29 bits, right-aligned).
    pub rx_id: Signal<Out, Bits<29>>,
    /// Received IDE.
    pub rx_ide: Signal<Out, Bit>,
    /// Received RTR.
    pub rx_rtr: Signal<Out, Bit>,
    /// Received DLC.
    pub rx_dlc: Signal<Out, Bits<4>>,
    /// One clock when the header (`rx_id`, `rx_ide`, `rx_rtr`, `rx_dlc`) of a frame is complete.
    pub rx_header: Signal<Out, Bit>,
    /// Received data byte, valid with `rx_byte_strobe`.
    pub rx_byte: Signal<Out, Bits<8>>,
    /// Index (0..7) of `rx_byte`.
    pub rx_byte_index: Signal<Out, Bits<3>>,
    /// One clock per received data byte.
    pub rx_byte_strobe: Signal<Out, Bit>,
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
    field: DFF<ProtocolState>,
    count: DFF<Bits<7>>,
    tx_reg: DFF<Bit>,
    tx_next: DFF<Bit>,
    transmitter: DFF<Bit>,
    tx_ptr: DFF<Bits<4>>,
    tx_shift: DFF<Bits<8>>,
    tx_left: DFF<Bits<4>>,
    id_reg: DFF<Bits<29>>,
    ide_reg: DFF<Bit>,
    rtr_reg: DFF<Bit>,
    dlc_reg: DFF<Bits<4>>,
    byte_reg: DFF<Bits<8>>,
    header_pulse: DFF<Bit>,
    byte_pulse: DFF<Bit>,
    byte_index: DFF<Bits<3>>,
    valid_pulse: DFF<Bit>,
    done_pulse: DFF<Bit>,
    done_success: DFF<Bit>,
    abort_pending: DFF<Bit>,
    error_pulse: DFF<Bit>,
    ecc_reg: DFF<Bits<8>>,
    lost_pulse: DFF<Bit>,
    alc_reg: DFF<Bits<5>>,
    crc_error: DFF<Bit>,
    flag_passive: DFF<Bit>,
    flag_level: DFF<Bit>,
    after_error_flag: DFF<Bit>,
    first_after_flag: DFF<Bit>,
    dominant_after_flag: DFF<Bits<3>>,
    ack_penalty: DFF<Bit>,
    recessive_run: DFF<Bits<4>>,
    // Decisions of this process point.
    next_field: Signal<Local, ProtocolState>,
    next_count: Signal<Local, Bits<7>>,
    next_transmitter: Signal<Local, Bit>,
    count_plus_1: Signal<Local, Bits<7>>,
    error_now: Signal<Local, Bit>,
    /// The received bit goes into the CRC register this cycle (the kernel reads its own copy:
    /// see `crate::activity` on reading a child's input).
    feed_crc: Signal<Local, Bit>,
    /// Stuffing stops after this bit (an error or the end of the stuffed fields); reset mode
    /// also stops it, below, where it no longer matters for the next bit.
    stop_stuffing: Signal<Local, Bit>,
    error_type: Signal<Local, Bits<2>>,
    segment: Signal<Local, Bits<5>>,
    error_counts: Signal<Local, Bit>,
    start_frame: Signal<Local, Bit>,
    may_start: Signal<Local, Bit>,
    single_shot: Signal<Local, Bit>,
    consume_stream: Signal<Local, Bit>,
    stream_bit: Signal<Local, Bit>,
    stream_next_bit: Signal<Local, Bit>,
    data_bytes: Signal<Local, Bits<4>>,
    /// Index of the last data byte, registered: DLC and RTR are settled a bit before the data field.
    last_data_byte: DFF<Bits<4>>,
    dlc_after: Signal<Local, Bits<4>>,
    next_bit: Signal<Local, Bit>,
    dlc_position: Signal<Local, Bits<3>>,
    next_is_11: Signal<Local, Bit>,
    next_is_12: Signal<Local, Bit>,
    next_is_31: Signal<Local, Bit>,
    next_count_low: Signal<Local, Bits<3>>,
    receiver_error: Signal<Local, Bit>,
    send_ack: Signal<Local, Bit>,
    /// In a data or remote frame (arbitration to end of frame), registered.
    in_frame: DFF<Bit>,
    flag_is_passive: Signal<Local, Bit>,
    /// A bit error in our active error flag restarts it.
    flag_restarts: Signal<Local, Bit>,
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
            tx_reg,
            tx_next,
            transmitter,
            tx_ptr,
            tx_shift,
            tx_left,
            id_reg,
            ide_reg,
            rtr_reg,
            dlc_reg,
            byte_reg,
            header_pulse,
            byte_pulse,
            byte_index,
            valid_pulse,
            done_pulse,
            done_success,
            abort_pending,
            error_pulse,
            ecc_reg,
            lost_pulse,
            alc_reg,
            crc_error,
            flag_passive,
            flag_level,
            after_error_flag,
            first_after_flag,
            dominant_after_flag,
            ack_penalty,
            recessive_run,
            last_data_byte
        );
        clock!(self, clock, stuffing, crc, faults);

        // ---- Outputs from registers.
        self.tx.next = self.tx_reg.q.val();
        self.tx_dominant.next = self.tx_reg.q.val() == false;
        self.tx_addr.next = self.tx_ptr.q.val();
        self.rx_id.next = self.id_reg.q.val();
        self.rx_ide.next = self.ide_reg.q.val();
        self.rx_rtr.next = self.rtr_reg.q.val();
        self.rx_dlc.next = self.dlc_reg.q.val();
        self.rx_header.next = self.header_pulse.q.val();
        self.rx_byte.next = self.byte_reg.q.val();
        self.rx_byte_index.next = self.byte_index.q.val();
        self.rx_byte_strobe.next = self.byte_pulse.q.val();
        self.rx_valid.next = self.valid_pulse.q.val();
        self.tx_done.next = self.done_pulse.q.val();
        self.tx_success.next = self.done_success.q.val();
        self.bus_error.next = self.error_pulse.q.val();
        self.ecc.next = self.ecc_reg.q.val();
        self.arbitration_lost.next = self.lost_pulse.q.val();
        self.alc.next = self.alc_reg.q.val();
        self.tec.next = self.faults.tec.val();
        self.rec.next = self.faults.rec.val();
        self.error_passive.next = self.faults.error_passive.val();
        self.bus_off.next = self.faults.bus_off.val();
        self.state.next = self.field.q.val();
        self.faults.load_tec.next = self.load_tec.val();
        self.faults.load_rec.next = self.load_rec.val();
        self.faults.load_value.next = self.counter_value.val();
        self.faults.reset.next = self.reset.val();
        self.stuffing.reset.next = self.reset.val();

        // Pulses last one clock.
        self.header_pulse.d.next = false;
        self.byte_pulse.d.next = false;
        self.valid_pulse.d.next = false;
        self.done_pulse.d.next = false;
        self.error_pulse.d.next = false;
        self.lost_pulse.d.next = false;

        // ---- Frame-level helpers.
        self.transmitting.next = self.transmitter.q.val() & self.in_frame.q.val();
        self.receiving.next = !self.transmitter.q.val() & self.in_frame.q.val();
        self.count_plus_1.next = self.count.q.val() + 1;
        self.data_bytes.next = self.dlc_reg.q.val();
        if self.dlc_reg.q.val().get_bit(3) {
            self.data_bytes.next = 8.into();
        }
        if self.rtr_reg.q.val() {
            self.data_bytes.next = 0.into();
        }
        self.last_data_byte.d.next = self.data_bytes.val() - 1;
        // DLC shifted left with the bus bit in: wiring, where `x + x` would be an adder.
        self.dlc_after.next = self
            .dlc_reg
            .q
            .val()
            .replace_bit(3, self.dlc_reg.q.val().get_bit(2))
            .replace_bit(2, self.dlc_reg.q.val().get_bit(1))
            .replace_bit(1, self.dlc_reg.q.val().get_bit(0))
            .replace_bit(0, self.rx_bit.val());
        // A new frame of our own may start: a request, and no suspend owed (error-passive former
        // transmitter) unless the suspend is over.
        self.single_shot.next = self.tx_single_shot.val() | self.abort_pending.q.val();
        self.may_start.next = self.tx_request.val()
            & !self.listen_only.val()
            & !self.abort_pending.q.val()
            & self.enable.val()
            & !self.faults.bus_off.val()
            & !self.done_pulse.q.val();
        // The transmit-buffer stream: the bit now at its head, and after consuming it.
        self.stream_bit.next = self.tx_shift.q.val().get_bit(7);
        self.stream_next_bit.next = self.tx_shift.q.val().get_bit(6);
        if self.tx_left.q.val() == 0 {
            self.stream_bit.next = self.tx_data.val().get_bit(7);
            self.stream_next_bit.next = self.tx_data.val().get_bit(6);
        }
        if self.tx_left.q.val() == 1 {
            self.stream_next_bit.next = self.tx_data.val().get_bit(7);
        }

        // A listening node's error flags are passive: it never drives a dominant bit.
        self.flag_is_passive.next = self.faults.error_passive.val() | self.listen_only.val();
        self.flag_restarts.next = false;

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
        self.error_type.next = 0.into();
        self.segment.next = 0.into();
        self.error_counts.next = true;
        self.start_frame.next = false;
        self.consume_stream.next = false;
        self.send_ack.next = false;

        self.dlc_position.next = 0.into();
        self.receiver_error.next = false;

        // SJA1000 ECC segment of the bit being processed.
        match self.field.q.val() {
            ProtocolState::Integrating => {}
            ProtocolState::BusOff => {}
            ProtocolState::Idle => {
                self.segment.next = 0x03.into();
            }
            ProtocolState::Suspend => {
                self.segment.next = 0x03.into();
            }
            ProtocolState::Arbitration => {
                self.segment.next = 0x0C.into();
                if self.count.q.val() < 31 {
                    self.segment.next = 0x0E.into();
                }
                if self.count.q.val() < 26 {
                    self.segment.next = 0x0F.into();
                }
                if self.count.q.val() < 18 {
                    self.segment.next = 0x07.into();
                }
                if self.count.q.val() < 13 {
                    self.segment.next = 0x05.into();
                }
                if self.count.q.val() < 12 {
                    self.segment.next = 0x04.into();
                }
                if self.count.q.val() < 11 {
                    self.segment.next = 0x06.into();
                }
                if self.count.q.val() < 8 {
                    self.segment.next = 0x02.into();
                }
            }
            ProtocolState::Control => {
                self.segment.next = 0x0B.into();
                if self.ide_reg.q.val() {
                    if self.count.q.val() == 0 {
                        self.segment.next = 0x0D.into();
                    }
                    if self.count.q.val() == 1 {
                        self.segment.next = 0x09.into();
                    }
                } else if self.count.q.val() == 0 {
                    self.segment.next = 0x09.into();
                }
            }
            ProtocolState::Data => {
                self.segment.next = 0x0A.into();
            }
            ProtocolState::Crc => {
                self.segment.next = 0x08.into();
            }
            ProtocolState::CrcDelimiter => {
                self.segment.next = 0x18.into();
            }
            ProtocolState::AckSlot => {
                self.segment.next = 0x19.into();
            }
            ProtocolState::AckDelimiter => {
                self.segment.next = 0x1B.into();
            }
            ProtocolState::EndOfFrame => {
                self.segment.next = 0x1A.into();
            }
            ProtocolState::Intermission => {
                self.segment.next = 0x12.into();
            }
            ProtocolState::ErrorFlag => {
                self.segment.next = 0x11.into();
                if self.flag_passive.q.val() {
                    self.segment.next = 0x16.into();
                }
            }
            ProtocolState::OverloadFlag => {
                self.segment.next = 0x1C.into();
            }
            ProtocolState::Delimiter => {
                self.segment.next = 0x17.into();
                if self.count.q.val() == 0 {
                    self.segment.next = 0x13.into();
                }
            }
        }

        if self.process_point.val() {
            self.stuffing.consume.next = true;
            if self.stuffing.stuff_bit.val() {
                // A stuff bit: no field advance.
                self.next_count.next = self.count.q.val();
                if self.transmitter.q.val() & (self.tx_reg.q.val() != self.rx_bit.val()) {
                    self.error_now.next = true;
                    self.error_type.next = 0.into();
                    // Rule 3 exception b: a recessive stuff bit of the arbitration field read dominant
                    // is a stuff error (ISO 11898-1) that does not count.
                    if (self.field.q.val() == ProtocolState::Arbitration) & self.tx_reg.q.val() {
                        self.error_type.next = 2.into();
                        self.error_counts.next = false;
                    }
                } else if self.rx_bit.val() == self.stuffing.run_level.val() {
                    self.error_now.next = true;
                    self.error_type.next = 2.into();
                }
            } else {
                match self.field.q.val() {
                    ProtocolState::Integrating => {
                        self.next_count.next = 0.into();
                        if self.rx_bit.val() {
                            self.next_count.next = self.count_plus_1.val();
                            if self.count.q.val() == 10 {
                                self.next_field.next = ProtocolState::Idle;
                            }
                        }
                    }
                    ProtocolState::Idle => {
                        if self.rx_bit.val() == false {
                            self.start_frame.next = true;
                            self.next_transmitter.next = self.tx_reg.q.val() == false;
                        } else if self.tx_reg.q.val() == false {
                            // Our SOF read recessive.
                            self.error_now.next = true;
                            self.error_type.next = 0.into();
                            self.next_transmitter.next = true;
                        }
                    }
                    ProtocolState::Suspend => {
                        // We send nothing while suspended: a dominant bit is another node's SOF.
                        if self.rx_bit.val() == false {
                            self.start_frame.next = true;
                            self.next_transmitter.next = false;
                        } else if self.count.q.val() == 7 {
                            self.next_field.next = ProtocolState::Idle;
                            self.next_transmitter.next = false;
                        }
                    }
                    ProtocolState::Arbitration => {
                        self.feed_crc.next = true;
                        // Identifier bits: positions 0..10 and 13..30 (the count stays below 32
                        // here; equalities, not comparisons, which are carry chains on FPGAs).
                        if (self.count.q.val() != 11)
                            & (self.count.q.val() != 12)
                            & (self.count.q.val() != 31)
                        {
                            self.id_reg.d.next =
                                (self.id_reg.q.val() << 1).replace_bit(0, self.rx_bit.val());
                            self.consume_stream.next = self.transmitter.q.val();
                        }
                        if self.count.q.val() == 11 {
                            self.rtr_reg.d.next = self.rx_bit.val();
                        }
                        if self.count.q.val() == 12 {
                            self.ide_reg.d.next = self.rx_bit.val();
                            if self.rx_bit.val() == false {
                                self.next_field.next = ProtocolState::Control;
                                self.next_count.next = 0.into();
                            }
                        }
                        if self.count.q.val() == 31 {
                            self.rtr_reg.d.next = self.rx_bit.val();
                            self.next_field.next = ProtocolState::Control;
                            self.next_count.next = 0.into();
                        }
                        if self.transmitter.q.val() & (self.tx_reg.q.val() != self.rx_bit.val()) {
                            if self.tx_reg.q.val() {
                                self.next_transmitter.next = false;
                                self.consume_stream.next = false;
                                self.lost_pulse.d.next = true;
                                self.alc_reg.d.next = self.count.q.val().get_bits::<5>(0);
                                if self.single_shot.val() {
                                    self.done_pulse.d.next = true;
                                    self.done_success.d.next = false;
                                }
                            } else {
                                self.error_now.next = true;
                                self.error_type.next = 0.into();
                            }
                        }
                    }
                    ProtocolState::Control => {
                        self.feed_crc.next = true;
                        // From count 2 on, or from 1 in a standard frame (r0 is bit 0).
                        if (self.count.q.val() != 0)
                            & !((self.count.q.val() == 1) & self.ide_reg.q.val())
                        {
                            self.dlc_reg.d.next = self.dlc_after.val();
                        }
                        if (self.count.q.val() == 5)
                            | ((self.count.q.val() == 4) & (self.ide_reg.q.val() == false))
                        {
                            self.header_pulse.d.next = true;
                            self.next_count.next = 0.into();
                            self.next_field.next = ProtocolState::Data;
                            if self.rtr_reg.q.val() | (self.dlc_after.val() == 0) {
                                self.next_field.next = ProtocolState::Crc;
                            }
                        }
                        if self.transmitter.q.val() & (self.tx_reg.q.val() != self.rx_bit.val()) {
                            self.error_now.next = true;
                            self.error_type.next = 0.into();
                        }
                    }
                    ProtocolState::Data => {
                        self.feed_crc.next = true;
                        self.consume_stream.next = self.transmitter.q.val();
                        self.byte_reg.d.next =
                            (self.byte_reg.q.val() << 1).replace_bit(0, self.rx_bit.val());
                        if self.count.q.val().get_bits::<3>(0) == 7 {
                            self.byte_pulse.d.next = true;
                            self.byte_index.d.next = self.count.q.val().get_bits::<3>(3);
                            if self.count.q.val().get_bits::<4>(3) == self.last_data_byte.q.val() {
                                self.next_field.next = ProtocolState::Crc;
                                self.next_count.next = 0.into();
                            }
                        }
                        if self.transmitter.q.val() & (self.tx_reg.q.val() != self.rx_bit.val()) {
                            self.error_now.next = true;
                            self.error_type.next = 0.into();
                        }
                    }
                    ProtocolState::Crc => {
                        self.feed_crc.next = true;
                        if self.count.q.val() == 14 {
                            self.next_field.next = ProtocolState::CrcDelimiter;
                        }
                        if self.transmitter.q.val() & (self.tx_reg.q.val() != self.rx_bit.val()) {
                            self.error_now.next = true;
                            self.error_type.next = 0.into();
                        }
                    }
                    ProtocolState::CrcDelimiter => {
                        self.stop_stuffing.next = true;
                        self.next_field.next = ProtocolState::AckSlot;
                        if self.rx_bit.val() == false {
                            self.error_now.next = true;
                            self.error_type.next = 1.into();
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
                                self.error_type.next = 3.into();
                                // Rule 3 exception a is decided during the passive flag.
                                if self.faults.error_passive.val() {
                                    self.error_counts.next = false;
                                    self.ack_penalty.d.next = true;
                                }
                            }
                        } else if self.tx_reg.q.val() == false {
                            if self.rx_bit.val() {
                                self.error_now.next = true;
                                self.error_type.next = 0.into();
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
                            self.error_type.next = 1.into();
                        } else if self.crc_error.q.val() {
                            self.error_now.next = true;
                            self.error_type.next = 3.into();
                        }
                    }
                    ProtocolState::EndOfFrame => {
                        if self.count.q.val() == 6 {
                            self.next_field.next = ProtocolState::Intermission;
                            self.next_count.next = 0.into();
                        }
                        if self.rx_bit.val() == false {
                            if (self.count.q.val() == 6) & (self.transmitter.q.val() == false) {
                                self.next_field.next = ProtocolState::OverloadFlag;
                            } else {
                                self.error_now.next = true;
                                self.error_type.next = 1.into();
                            }
                        } else {
                            if (self.count.q.val() == 5) & (self.transmitter.q.val() == false) {
                                self.valid_pulse.d.next = true;
                            }
                            if (self.count.q.val() == 6) & self.transmitter.q.val() {
                                self.done_pulse.d.next = true;
                                self.done_success.d.next = true;
                                self.faults.tec_minus_1.next = true;
                            }
                        }
                    }
                    ProtocolState::Intermission => {
                        if self.rx_bit.val() == false {
                            if self.count.q.val() == 2 {
                                self.start_frame.next = true;
                                self.next_transmitter.next = self.may_start.val()
                                    & !(self.transmitter.q.val() & self.faults.error_passive.val());
                            } else {
                                self.next_field.next = ProtocolState::OverloadFlag;
                                self.next_count.next = 0.into();
                            }
                        } else if self.count.q.val() == 2 {
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
                        if self.flag_passive.q.val() {
                            // Complete after 6 equal bits in a row.
                            self.flag_level.d.next = self.rx_bit.val();
                            if (self.count.q.val() != 0)
                                & (self.rx_bit.val() != self.flag_level.q.val())
                            {
                                self.next_count.next = 1.into();
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
                            self.error_pulse.d.next = true;
                            self.ecc_reg.d.next = 0x11.into();
                            if self.transmitter.q.val() == false {
                                self.ecc_reg.d.next = 0x31.into();
                            }
                            self.faults.tec_plus_8.next = self.transmitter.q.val();
                            self.faults.rec_plus_8.next = self.transmitter.q.val() == false;
                            self.next_count.next = 0.into();
                        }
                        if self.next_count.val() == 6 {
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
                            self.error_type.next = 0.into();
                        } else if self.count.q.val() == 5 {
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
                                if self.dominant_after_flag.q.val() == 7 {
                                    self.faults.tec_plus_8.next = self.transmitter.q.val();
                                    self.faults.rec_plus_8.next = self.transmitter.q.val() == false;
                                }
                            }
                        } else if self.rx_bit.val() == false {
                            if self.count.q.val() == 7 {
                                self.next_field.next = ProtocolState::OverloadFlag;
                                self.next_count.next = 0.into();
                            } else {
                                self.error_now.next = true;
                                self.error_type.next = 1.into();
                            }
                        } else if self.count.q.val() == 7 {
                            self.next_field.next = ProtocolState::Intermission;
                            self.next_count.next = 0.into();
                        }
                    }
                    ProtocolState::BusOff => {
                        self.next_count.next = 0.into();
                        if self.rx_bit.val() & self.enable.val() {
                            self.next_count.next = self.count_plus_1.val();
                            if self.count.q.val() == 10 {
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
                self.id_reg.d.next = 0.into();
                self.dlc_reg.d.next = 0.into();
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
                self.error_pulse.d.next = true;
                self.ecc_reg.d.next = bit_cast::<8, 5>(self.segment.val())
                    .replace_bit(5, self.receiver_error.val())
                    .replace_bit(6, self.error_type.val().get_bit(0))
                    .replace_bit(7, self.error_type.val().get_bit(1));
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

        // ---- The transmit-buffer stream.
        if self.consume_stream.val() {
            if self.tx_left.q.val() == 0 {
                self.tx_shift.d.next = self.tx_data.val() << 1;
                self.tx_left.d.next = 7.into();
                self.tx_ptr.d.next = self.tx_ptr.q.val() + 1;
            } else {
                self.tx_shift.d.next = self.tx_shift.q.val() << 1;
                self.tx_left.d.next = self.tx_left.q.val() - 1;
            }
        }
        if self.process_point.val()
            & (self.field.q.val() == ProtocolState::Arbitration)
            & (self.next_field.val() == ProtocolState::Control)
        {
            self.tx_left.d.next = 0.into();
            self.tx_ptr.d.next = 3.into();
            if self.count.q.val() == 31 {
                self.tx_ptr.d.next = 5.into();
            }
        }
        // Between frames the stream waits at the first identifier byte.
        if !self.in_frame.q.val() & (self.next_field.val() != ProtocolState::Arbitration) {
            self.tx_ptr.d.next = 1.into();
            self.tx_left.d.next = 0.into();
        }

        self.crc.feed.next = self.feed_crc.val();

        // ---- The next bit to send, from the next state.
        // Where the next field is the arbitration or control field, its count comes from registers
        // rather than from `next_count`, the end of the longest path: a stuff bit holds the count, a
        // field bit advances it, a SOF starts the arbitration field at 0 (no special position) and
        // the control field starts at 0 from arbitration count 12 or 31 (positions 5 or 0: neither
        // a DLC bit).
        self.next_is_11.next = self.count.q.val() == 10;
        self.next_is_12.next = self.count.q.val() == 11;
        self.next_is_31.next = self.count.q.val() == 30;
        self.next_count_low.next = bit_cast::<3, 7>(self.count_plus_1.val());
        if self.stuffing.stuff_bit.val() {
            self.next_is_11.next = self.count.q.val() == 11;
            self.next_is_12.next = self.count.q.val() == 12;
            self.next_is_31.next = self.count.q.val() == 31;
            self.next_count_low.next = bit_cast::<3, 7>(self.count.q.val());
        }
        if self.start_frame.val() {
            self.next_is_11.next = false;
            self.next_is_12.next = false;
            self.next_is_31.next = false;
        }
        self.next_bit.next = true;
        match self.next_field.val() {
            ProtocolState::Idle => {
                self.next_bit.next = self.may_start.val() == false;
            }
            ProtocolState::Arbitration => {
                if self.next_transmitter.val() {
                    self.next_bit.next = self.stream_bit.val();
                    if self.consume_stream.val() {
                        self.next_bit.next = self.stream_next_bit.val();
                    }
                    if self.next_is_11.val() {
                        self.next_bit.next = self.tx_info.val().get_bit(6);
                        if self.tx_info.val().get_bit(7) {
                            self.next_bit.next = true;
                        }
                    }
                    if self.next_is_12.val() {
                        self.next_bit.next = self.tx_info.val().get_bit(7);
                    }
                    if self.next_is_31.val() {
                        self.next_bit.next = self.tx_info.val().get_bit(6);
                    }
                }
            }
            ProtocolState::Control => {
                if self.next_transmitter.val() {
                    // r1 (extended), r0: dominant; then DLC bits 3..0.
                    self.next_bit.next = false;
                    self.dlc_position.next = self.next_count_low.val();
                    if self.tx_info.val().get_bit(7) {
                        self.dlc_position.next = self.next_count_low.val() - 1;
                    }
                    if self.dlc_position.val() == 1 {
                        self.next_bit.next = self.tx_info.val().get_bit(3);
                    }
                    if self.dlc_position.val() == 2 {
                        self.next_bit.next = self.tx_info.val().get_bit(2);
                    }
                    if self.dlc_position.val() == 3 {
                        self.next_bit.next = self.tx_info.val().get_bit(1);
                    }
                    if self.dlc_position.val() == 4 {
                        self.next_bit.next = self.tx_info.val().get_bit(0);
                    }
                }
            }
            ProtocolState::Data => {
                if self.next_transmitter.val() {
                    self.next_bit.next = self.stream_bit.val();
                    if self.consume_stream.val() {
                        self.next_bit.next = self.stream_next_bit.val();
                    }
                }
            }
            ProtocolState::Crc => {
                if self.next_transmitter.val() {
                    // The MSB of the register after this bit (fed unless it was a stuff bit).
                    self.next_bit.next = self.crc.value.val().get_bit(14);
                    if self.feed_crc.val() {
                        self.next_bit.next = self.crc.value.val().get_bit(13)
                            ^ self.crc.value.val().get_bit(14)
                            ^ self.rx_bit.val();
                    }
                }
            }
            ProtocolState::AckSlot => {
                self.next_bit.next = self.send_ack.val() == false;
            }
            ProtocolState::ErrorFlag => {
                // A flag (a new one, or ours restarted by a bit error) starts with the state at this
                // detection; its later bits keep its kind.
                self.next_bit.next = self.flag_is_passive.val();
                if (self.field.q.val() == ProtocolState::ErrorFlag) & !self.flag_restarts.val() {
                    self.next_bit.next = self.flag_passive.q.val();
                }
            }
            ProtocolState::OverloadFlag => {
                self.next_bit.next = self.listen_only.val();
            }
            _ => {}
        }
        self.stuffing.stop.next = self.stop_stuffing.val();
        // Five equal bits with this one: the next bit is a stuff bit (complement of this level).
        if self.stuffing.four_equal.val()
            & !self.stuffing.stuff_bit.val()
            & (self.rx_bit.val() == self.stuffing.run_level.val())
            & self.next_transmitter.val()
            & !self.error_now.val()
            & !self.stop_stuffing.val()
        {
            self.next_bit.next = self.rx_bit.val() == false;
        }

        // ---- Commit at the process point.
        if self.process_point.val() {
            self.field.d.next = self.next_field.val();
            self.count.d.next = self.next_count.val();
            self.transmitter.d.next = self.next_transmitter.val();
            self.tx_next.d.next = self.next_bit.val();
        }
        if self.transmit_point.val() {
            self.tx_reg.d.next = self.tx_next.q.val();
        }

        // ---- Listen-only mode: counters frozen, the output held recessive.
        if self.listen_only.val() {
            self.faults.rec_plus_1.next = false;
            self.faults.rec_plus_8.next = false;
            self.faults.tec_plus_8.next = false;
            self.faults.tec_minus_1.next = false;
            self.faults.rec_success.next = false;
            self.tx_reg.d.next = true;
        }

        // ---- Bus-off, reset mode and reset override everything.
        if self.faults.bus_off.val() {
            self.field.d.next = ProtocolState::BusOff;
            self.tx_reg.d.next = true;
            self.tx_next.d.next = true;
            self.transmitter.d.next = false;
        }
        // Recovery complete: error active with both counters 0.
        if (self.field.q.val() == ProtocolState::BusOff) & (self.faults.bus_off.val() == false) {
            self.field.d.next = ProtocolState::Idle;
            self.count.d.next = 0.into();
        }
        if (self.enable.val() == false) & (self.faults.bus_off.val() == false) {
            self.field.d.next = ProtocolState::Integrating;
            self.count.d.next = 0.into();
            self.tx_reg.d.next = true;
            self.tx_next.d.next = true;
            self.transmitter.d.next = false;
            // A node in reset mode takes no part in traffic: nothing it sees counts, even in the
            // rest of a frame it was in when it was disabled.
            self.stuffing.stop.next = true;
            self.error_pulse.d.next = false;
            self.lost_pulse.d.next = false;
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
            | ((self.field.q.val() == ProtocolState::Intermission) & (self.count.q.val() == 2))
        {
            self.sync_mode.next = SyncMode::Hard;
        }
        if self.reset.val() {
            self.field.d.next = ProtocolState::Integrating;
            self.count.d.next = 0.into();
            self.tx_reg.d.next = true;
            self.tx_next.d.next = true;
            self.transmitter.d.next = false;
            self.crc_error.d.next = false;
            self.ack_penalty.d.next = false;
            self.done_pulse.d.next = false;
            self.abort_pending.d.next = false;
            self.error_pulse.d.next = false;
            self.lost_pulse.d.next = false;
            // The rest only for a defined start without power-up values (FPGA flows that drop
            // `initial` blocks, X in four-state simulators); none of it is read before being loaded.
            self.tx_ptr.d.next = 1.into();
            self.tx_shift.d.next = 0.into();
            self.tx_left.d.next = 0.into();
            self.id_reg.d.next = 0.into();
            self.ide_reg.d.next = false;
            self.rtr_reg.d.next = false;
            self.dlc_reg.d.next = 0.into();
            self.byte_reg.d.next = 0.into();
            self.header_pulse.d.next = false;
            self.byte_pulse.d.next = false;
            self.byte_index.d.next = 0.into();
            self.valid_pulse.d.next = false;
            self.done_success.d.next = false;
            self.ecc_reg.d.next = 0.into();
            self.alc_reg.d.next = 0.into();
            self.flag_passive.d.next = false;
            self.flag_level.d.next = false;
            self.after_error_flag.d.next = false;
            self.first_after_flag.d.next = false;
            self.dominant_after_flag.d.next = 0.into();
            self.recessive_run.d.next = 0.into();
            self.last_data_byte.d.next = 0.into();
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
