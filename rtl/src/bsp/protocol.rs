//! The frame sequencer: one state per field with a field bit counter and the node's role, committed
//! at every process point, with the request's end, the receiver's validity point, bus-off, reset mode
//! and the synchronisation mode. The top block of the bit stream processor: its children decide
//! what a bit means (`frame_fields`: the fields of a data or remote frame, stuff bits, bit
//! monitoring, arbitration, ACK, the error kinds they detect; `interframe`: integration, idle,
//! intermission, suspend, error and overload flags and delimiters, bus-off recovery, and the
//! outcome of the bit), track stuffing (`stuffing`), the CRC (`crc15`), the error counters
//! (`fault_confinement`), assemble the received frame (`rx_assembler`), stream the frame to send
//! from the transmit buffer and choose and drive the bit to send (`bit_transmitter`), and capture
//! ECC and ALC (`error_capture`).
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
use crate::bsp::core_ports::{CounterLoad, NodeStatus, TransmitRequest};
use crate::bsp::crc15::Crc15;
use crate::bsp::error_capture::ErrorCapture;
use crate::bsp::fault_confinement::FaultConfinement;
use crate::bsp::frame_fields::FrameFields;
use crate::bsp::interframe::Interframe;
use crate::bsp::received_frame::ReceivedFrame;
use crate::bsp::rx_assembler::RxAssembler;
use crate::bsp::stuffing::BitStuffing;
use crate::bsp::INTERMISSION_BITS;

/// States of the frame sequencer, one per field.
///
/// The declaration order is the encoding in the Verilog (0..15), chosen for the decoding it saves:
/// 0..3 the states that wait for the bus, where a start of frame is hard-synchronised
/// (`Integrating` first: the power-up value), 4..7 the flags, delimiter and intermission between
/// frames, 8..15 the frame's fields in bus order, so that "in a frame" is bit 3. Measured with
/// `make synth` against the order before (fields in bus order from 2): 19 SB_LUT4 fewer on iCE40,
/// docs/FPGA.md. `waves/state.filter` and the engines' state table follow this order (tests check
/// both).
#[derive(Copy, Clone, Debug, PartialEq, Eq, LogicState)]
pub enum ProtocolState {
    /// Waiting for 11 recessive bits before taking part in traffic.
    Integrating,
    /// Bus idle.
    Idle,
    /// Suspend transmission (error-passive former transmitter).
    Suspend,
    /// Bus-off.
    BusOff,
    /// Active or passive error flag.
    ErrorFlag,
    /// Overload flag.
    OverloadFlag,
    /// Error or overload delimiter (count 0: waiting for the first recessive bit).
    Delimiter,
    /// Intermission.
    Intermission,
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
    /// The transmit request, its frame and its end (`crate::bsp::core_ports`).
    #[interface]
    pub transmit: TransmitRequest,
    /// Host writes of the error counters.
    #[interface]
    pub counters: CounterLoad,
    /// Bus output, registered.
    pub tx: Signal<Out, Bit>,
    /// Synchronisation allowed for the current bit.
    pub sync_mode: Signal<Out, SyncMode>,
    /// The node sends a dominant bit.
    pub tx_dominant: Signal<Out, Bit>,
    /// The received frame: the header, then every data byte (`crate::bsp::received_frame`).
    #[interface]
    pub rx_frame: ReceivedFrame,
    /// One clock when the frame on the bus is valid for receivers (EOF bit 6).
    pub rx_valid: Signal<Out, Bit>,
    /// Captures, counters and states (`crate::bsp::core_ports`).
    #[interface]
    pub status: NodeStatus,
    stuffing: BitStuffing,
    crc: Crc15,
    faults: FaultConfinement,
    assembler: RxAssembler,
    sender: BitTransmitter,
    capture: ErrorCapture,
    frame: FrameFields,
    interframe: Interframe,
    field: DFF<ProtocolState>,
    count: DFF<Bits<7>>,
    /// The node transmits the frame on the bus (or its error/overload frame after it).
    transmitter: DFF<Bit>,
    valid_pulse: DFF<Bit>,
    done_pulse: DFF<Bit>,
    done_success: DFF<Bit>,
    abort_pending: DFF<Bit>,
    crc_error: DFF<Bit>,
    /// In a data or remote frame (arbitration to end of frame), registered.
    in_frame: DFF<Bit>,
    /// Reset mode (and not bus-off): the node takes no part in traffic.
    disabled: Signal<Local, Bit>,
    #[constant(INTERMISSION_BITS - 1)]
    last_intermission_bit: Constant<Bits<7>>,
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
            crc_error
        );
        clock!(self, clock, stuffing, crc, faults, assembler, sender, capture, interframe);

        // ---- Outputs, from registers and children.
        self.tx.next = self.sender.tx.val();
        self.tx_dominant.next = self.sender.tx.val() == false;
        self.transmit.addr.next = self.sender.tx_addr.val();
        ReceivedFrame::link(&mut self.rx_frame, &mut self.assembler.frame);
        self.rx_valid.next = self.valid_pulse.q.val();
        self.transmit.done.next = self.done_pulse.q.val();
        self.transmit.success.next = self.done_success.q.val();
        self.status.bus_error.next = self.capture.bus_error.val();
        self.status.ecc.next = self.capture.ecc.val();
        self.status.arbitration_lost.next = self.capture.arbitration_lost.val();
        self.status.alc.next = self.capture.alc.val();
        self.status.tec.next = self.faults.tec.val();
        self.status.rec.next = self.faults.rec.val();
        self.status.error_passive.next = self.faults.error_passive.val();
        self.status.bus_off.next = self.faults.bus_off.val();
        self.status.state.next = self.field.q.val();
        self.status.transmitting.next = self.transmitter.q.val() & self.in_frame.q.val();
        self.status.receiving.next = !self.transmitter.q.val() & self.in_frame.q.val();
        self.disabled.next = (self.enable.val() == false) & (self.faults.bus_off.val() == false);

        // ---- The decisions of a bit: frame fields, then the rest and the outcome. Their inputs
        // come straight from ports, registers and children (docs/VERILOG.md).
        self.frame.process_point.next = self.process_point.val();
        self.frame.field.next = self.field.q.val();
        self.frame.count.next = self.count.q.val();
        self.frame.transmitter.next = self.transmitter.q.val();
        self.frame.rx_bit.next = self.rx_bit.val();
        self.frame.sender_tx.next = self.sender.tx.val();
        self.frame.stuff_bit.next = self.stuffing.stuff_bit.val();
        self.frame.run_level.next = self.stuffing.run_level.val();
        self.frame.ide.next = self.rx_frame.ide.val();
        self.frame.rtr.next = self.rx_frame.rtr.val();
        self.frame.dlc.next = self.rx_frame.dlc.val();
        self.frame.last_data_byte.next = self.assembler.last_data_byte.val();
        self.frame.crc.next = self.crc.value.val();
        self.frame.crc_error.next = self.crc_error.q.val();
        self.frame.enable.next = self.enable.val();
        self.frame.listen_only.next = self.listen_only.val();
        self.frame.self_test.next = self.self_test.val();
        self.frame.error_passive.next = self.faults.error_passive.val();
        self.frame.tx_single_shot.next = self.transmit.single_shot.val();
        self.frame.abort_pending.next = self.abort_pending.q.val();

        self.interframe.reset.next = self.reset.val();
        self.interframe.process_point.next = self.process_point.val();
        self.interframe.rx_bit.next = self.rx_bit.val();
        self.interframe.field.next = self.field.q.val();
        self.interframe.count.next = self.count.q.val();
        self.interframe.transmitter.next = self.transmitter.q.val();
        self.interframe.in_frame.next = self.in_frame.q.val();
        self.interframe.stuff_bit.next = self.stuffing.stuff_bit.val();
        self.interframe.sender_tx.next = self.sender.tx.val();
        self.interframe.tx_request.next = self.transmit.request.val();
        self.interframe.tx_single_shot.next = self.transmit.single_shot.val();
        self.interframe.abort_pending.next = self.abort_pending.q.val();
        self.interframe.done_pending.next = self.done_pulse.q.val();
        self.interframe.enable.next = self.enable.val();
        self.interframe.listen_only.next = self.listen_only.val();
        self.interframe.error_passive.next = self.faults.error_passive.val();
        self.interframe.bus_off.next = self.faults.bus_off.val();
        self.interframe.frame_next_field.next = self.frame.next_field.val();
        self.interframe.frame_next_count.next = self.frame.next_count.val();
        self.interframe.frame_error.next = self.frame.error.val();
        self.interframe.frame_error_type.next = self.frame.error_type.val();
        self.interframe.frame_counts.next = self.frame.counts.val();
        self.interframe.frame_lost.next = self.frame.lost.val();
        self.interframe.frame_stop_stuffing.next = self.frame.stop_stuffing.val();
        self.interframe.set_ack_penalty.next = self.frame.set_ack_penalty.val();

        // ---- What the bit changes here: the result pulses, the CRC error, the abort.
        self.valid_pulse.d.next = self.frame.valid.val();
        self.done_pulse.d.next = false;
        if self.frame.done.val() {
            self.done_pulse.d.next = true;
            self.done_success.d.next = self.frame.done_success.val();
        }
        if self.interframe.done.val() {
            self.done_pulse.d.next = true;
            self.done_success.d.next = false;
        }
        if self.frame.set_crc_error.val() {
            self.crc_error.d.next = true;
        }
        if self.interframe.start_frame.val() {
            self.crc_error.d.next = false;
        }
        // An abort lasts until the request ends.
        if self.transmit.abort.val() {
            self.abort_pending.d.next = true;
        }
        if self.done_pulse.q.val() | (self.transmit.request.val() == false) {
            self.abort_pending.d.next = false;
        }

        // ---- The children's inputs from this bit's decisions.
        self.stuffing.consume.next = self.process_point.val();
        self.stuffing.level.next = self.rx_bit.val();
        self.stuffing.start.next = self.interframe.start_frame.val();
        self.stuffing.stop.next = self.interframe.stop_stuffing.val() | self.disabled.val();
        self.crc.clear.next = self.interframe.start_frame.val();
        self.crc.feed.next = self.frame.feed_crc.val();
        self.crc.level.next = self.rx_bit.val();
        self.faults.rec_plus_1.next = self.interframe.rec_plus_1.val();
        self.faults.rec_plus_8.next = self.interframe.rec_plus_8.val();
        self.faults.tec_plus_8.next = self.interframe.tec_plus_8.val();
        self.faults.tec_minus_1.next = self.frame.tec_minus_1.val();
        self.faults.rec_success.next = self.frame.rec_success.val();
        self.faults.recovery_tick.next = self.interframe.recovery_tick.val();
        // Listen-only mode freezes the counters; so does reset mode, even in the rest of a frame
        // the node was in when it was disabled.
        self.faults.frozen.next = self.listen_only.val() | self.disabled.val();
        self.faults.load_tec.next = self.counters.load_tec.val();
        self.faults.load_rec.next = self.counters.load_rec.val();
        self.faults.load_value.next = self.counters.value.val();
        self.faults.reset.next = self.reset.val();
        self.stuffing.reset.next = self.reset.val();
        self.assembler.reset.next = self.reset.val();
        self.assembler.field_bit.next = self.process_point.val() & !self.stuffing.stuff_bit.val();
        self.assembler.rx_bit.next = self.rx_bit.val();
        self.assembler.field.next = self.field.q.val();
        self.assembler.count.next = self.count.q.val();
        self.assembler.start_frame.next = self.interframe.start_frame.val();
        self.assembler.id_bit.next = self.frame.id_bit.val();
        self.assembler.srr_rtr_bit.next = self.frame.srr_rtr_bit.val();
        self.assembler.ide_bit.next = self.frame.ide_bit.val();
        self.assembler.ext_rtr_bit.next = self.frame.ext_rtr_bit.val();
        self.assembler.header_done.next =
            (self.field.q.val() == ProtocolState::Control) & self.frame.control_last.val();
        self.sender.reset.next = self.reset.val();
        self.sender.tx_data.next = self.transmit.data.val();
        self.sender.consume.next = self.frame.consume.val() & !self.interframe.error.val();
        // From the arbitration field's end and the SOF themselves, not from the next field: the
        // same condition (no error comes with either) without the sequencer's whole decision on
        // the way to the stream's enables.
        self.sender.to_data.next = self.frame.arbitration_end.val() & !self.frame.error.val();
        self.sender.extended.next = self.frame.ext_rtr_bit.val();
        // Between frames the stream waits at the first identifier byte.
        self.sender.rewind.next = !self.in_frame.q.val() & !self.interframe.start_frame.val();
        self.sender.process_point.next = self.process_point.val();
        self.sender.transmit_point.next = self.transmit_point.val();
        self.sender.rx_bit.next = self.rx_bit.val();
        self.sender.field.next = self.field.q.val();
        self.sender.count.next = self.count.q.val();
        self.sender.stuff_bit.next = self.stuffing.stuff_bit.val();
        self.sender.start_frame.next = self.interframe.start_frame.val();
        self.sender.next_field.next = self.interframe.next_field.val();
        self.sender.next_transmitter.next = self.interframe.next_transmitter.val();
        self.sender.may_start.next = self.interframe.may_start.val();
        self.sender.tx_info.next = self.transmit.info.val();
        self.sender.crc_msb.next = self.crc.value.val().get_bit(14);
        self.sender.crc_next_msb.next = self.crc.value.val().get_bit(13);
        self.sender.feed_crc.next = self.frame.feed_crc.val();
        self.sender.send_ack.next = self.frame.send_ack.val();
        self.sender.flag_is_passive.next = self.interframe.flag_is_passive.val();
        self.sender.flag_passive.next = self.interframe.flag_passive.val();
        self.sender.flag_restarts.next = self.interframe.flag_restarts.val();
        self.sender.listen_only.next = self.listen_only.val();
        self.sender.four_equal.next = self.stuffing.four_equal.val();
        self.sender.run_level.next = self.stuffing.run_level.val();
        self.sender.stop_stuffing.next = self.interframe.stop_stuffing.val();
        self.sender.error.next = self.interframe.error.val();
        self.sender.silent.next = self.faults.bus_off.val() | (self.enable.val() == false);
        self.capture.reset.next = self.reset.val();
        self.capture.field.next = self.field.q.val();
        self.capture.count.next = self.count.q.val();
        self.capture.ide.next = self.rx_frame.ide.val();
        self.capture.flag_passive.next = self.interframe.flag_passive.val();
        self.capture.error.next = self.interframe.error.val() | self.interframe.flag_restarts.val();
        self.capture.error_type.next = self.interframe.error_type.val();
        self.capture.receiving.next = self.interframe.receiver_error.val();
        self.capture.lost.next = self.frame.lost.val();
        self.capture.discard.next = self.disabled.val();

        // ---- Commit at the process point; bus-off, reset mode and reset override everything.
        if self.process_point.val() {
            self.field.d.next = self.interframe.next_field.val();
            self.count.d.next = self.interframe.next_count.val();
            self.transmitter.d.next = self.interframe.next_transmitter.val();
        }
        if self.faults.bus_off.val() {
            self.field.d.next = ProtocolState::BusOff;
            self.transmitter.d.next = false;
            // Recovery counts recessive bits from here: a flag bit counted before bus-off (a
            // passive flag's dominant bit ends rule 3's exception a) must not shorten the first
            // of the 128 occurrences (formal/bus_off_recovery.sv found it).
            if self.field.q.val() != ProtocolState::BusOff {
                self.count.d.next = 0.into();
            }
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
            self.valid_pulse.d.next = false;
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
            self.done_pulse.d.next = false;
            self.abort_pending.d.next = false;
            // Only for a defined start without power-up values (FPGA flows that drop `initial`
            // blocks, X in four-state simulators); not read before being loaded.
            self.valid_pulse.d.next = false;
            self.done_success.d.next = false;
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
