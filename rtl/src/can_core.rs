//! A CAN node without host registers: the bit timing logic and the bit stream processor wired together.
//!
//! Ports: the bus pins `rx`/`tx`, the BTR fields, `enable` (low = reset mode), the transmit request with
//! its frame in the SJA1000 TX-buffer layout (`tx_info`, `tx_data` at `tx_addr`), and out the received
//! frame (header, data-byte stream, validity strobe), transmission results, error and arbitration
//! captures, counters and states: the boundary the SJA1000 register block uses. Everything acts on the
//! rising edge of `clock`.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock};

use crate::bit_timing::{BitTiming, Segment};
use crate::bsp::protocol::{Protocol, ProtocolState};
use crate::bsp::received_frame::ReceivedFrame;

/// Bit timing logic + bit stream processor.
#[derive(ActivityBlock, Default)]
pub struct CanCore {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Bus input (from the transceiver).
    pub rx: Signal<In, Bit>,
    /// Operating mode (low: SJA1000 reset mode).
    pub enable: Signal<In, Bit>,
    /// Baud rate prescaler field (BTR0.5..0).
    pub brp: Signal<In, Bits<6>>,
    /// TSEG1 field (BTR1.3..0).
    pub tseg1: Signal<In, Bits<4>>,
    /// TSEG2 field (BTR1.6..4).
    pub tseg2: Signal<In, Bits<3>>,
    /// SJW field (BTR0.7..6).
    pub sjw: Signal<In, Bits<2>>,
    /// Triple sampling (BTR1.7).
    pub sam: Signal<In, Bit>,
    /// Listen-only mode (SJA1000 MOD.LOM).
    pub listen_only: Signal<In, Bit>,
    /// Self-test mode (SJA1000 MOD.STM).
    pub self_test: Signal<In, Bit>,
    /// A frame waits in the transmit buffer.
    pub tx_request: Signal<In, Bit>,
    /// One transmission attempt only.
    pub tx_single_shot: Signal<In, Bit>,
    /// Abort the transmission request (one clock, see `Protocol`).
    pub tx_abort: Signal<In, Bit>,
    /// Frame information byte of the frame to send.
    pub tx_info: Signal<In, Bits<8>>,
    /// The transmit-buffer byte at `tx_addr`; it may come one clock after `tx_addr` (see
    /// `Protocol`).
    pub tx_data: Signal<In, Bits<8>>,
    /// Load `counter_value` into TEC.
    pub load_tec: Signal<In, Bit>,
    /// Load `counter_value` into REC.
    pub load_rec: Signal<In, Bit>,
    /// Value for `load_tec` / `load_rec`.
    pub counter_value: Signal<In, Bits<8>>,
    /// Bus output (to the transceiver), registered.
    pub tx: Signal<Out, Bit>,
    /// Transmit-buffer byte wanted.
    pub tx_addr: Signal<Out, Bits<4>>,
    /// End of a transmission request (see `Protocol`).
    pub tx_done: Signal<Out, Bit>,
    /// With `tx_done`: the frame was sent.
    pub tx_success: Signal<Out, Bit>,
    /// The received frame: header, then data bytes (`crate::bsp::received_frame`).
    #[interface]
    pub rx_frame: ReceivedFrame,
    /// The frame is valid for receivers (one clock).
    pub rx_valid: Signal<Out, Bit>,
    /// A bus error was detected (one clock).
    pub bus_error: Signal<Out, Bit>,
    /// SJA1000 error code capture value of that error.
    pub ecc: Signal<Out, Bits<8>>,
    /// Arbitration lost (one clock).
    pub arbitration_lost: Signal<Out, Bit>,
    /// SJA1000 arbitration lost capture value.
    pub alc: Signal<Out, Bits<5>>,
    /// Transmit error counter.
    pub tec: Signal<Out, Bits<8>>,
    /// Receive error counter.
    pub rec: Signal<Out, Bits<8>>,
    /// Error passive.
    pub error_passive: Signal<Out, Bit>,
    /// Bus-off.
    pub bus_off: Signal<Out, Bit>,
    /// Transmitting a frame of its own.
    pub transmitting: Signal<Out, Bit>,
    /// Receiving a frame.
    pub receiving: Signal<Out, Bit>,
    /// Protocol state.
    pub state: Signal<Out, ProtocolState>,
    /// Sample point trigger (for waves).
    pub sample_point: Signal<Out, Bit>,
    /// Bit timing segment (for waves).
    pub segment: Signal<Out, Segment>,
    bit_timing: BitTiming,
    protocol: Protocol,
}

impl Logic for CanCore {
    #[hdl_gen]
    fn update(&mut self) {
        clock!(self, clock, bit_timing, protocol);
        self.bit_timing.reset.next = self.reset.val();
        self.protocol.reset.next = self.reset.val();
        self.bit_timing.brp.next = self.brp.val();
        self.bit_timing.tseg1.next = self.tseg1.val();
        self.bit_timing.tseg2.next = self.tseg2.val();
        self.bit_timing.sjw.next = self.sjw.val();
        self.bit_timing.sam.next = self.sam.val();
        self.bit_timing.rx.next = self.rx.val();
        self.bit_timing.sync_mode.next = self.protocol.sync_mode.val();
        self.bit_timing.tx_dominant.next = self.protocol.tx_dominant.val();
        self.protocol.process_point.next = self.bit_timing.process_point.val();
        self.protocol.transmit_point.next = self.bit_timing.transmit_point.val();
        self.protocol.rx_bit.next = self.bit_timing.rx_bit.val();
        self.protocol.enable.next = self.enable.val();
        self.protocol.listen_only.next = self.listen_only.val();
        self.protocol.self_test.next = self.self_test.val();
        self.protocol.tx_request.next = self.tx_request.val();
        self.protocol.tx_single_shot.next = self.tx_single_shot.val();
        self.protocol.tx_abort.next = self.tx_abort.val();
        self.protocol.tx_info.next = self.tx_info.val();
        self.protocol.tx_data.next = self.tx_data.val();
        self.protocol.load_tec.next = self.load_tec.val();
        self.protocol.load_rec.next = self.load_rec.val();
        self.protocol.counter_value.next = self.counter_value.val();
        self.tx.next = self.protocol.tx.val();
        self.tx_addr.next = self.protocol.tx_addr.val();
        self.tx_done.next = self.protocol.tx_done.val();
        self.tx_success.next = self.protocol.tx_success.val();
        ReceivedFrame::link(&mut self.rx_frame, &mut self.protocol.rx_frame);
        self.rx_valid.next = self.protocol.rx_valid.val();
        self.bus_error.next = self.protocol.bus_error.val();
        self.ecc.next = self.protocol.ecc.val();
        self.arbitration_lost.next = self.protocol.arbitration_lost.val();
        self.alc.next = self.protocol.alc.val();
        self.tec.next = self.protocol.tec.val();
        self.rec.next = self.protocol.rec.val();
        self.error_passive.next = self.protocol.error_passive.val();
        self.bus_off.next = self.protocol.bus_off.val();
        self.transmitting.next = self.protocol.transmitting.val();
        self.receiving.next = self.protocol.receiving.val();
        self.state.next = self.protocol.state.val();
        self.sample_point.next = self.bit_timing.sample_point.val();
        self.segment.next = self.bit_timing.segment.val();
    }
}
