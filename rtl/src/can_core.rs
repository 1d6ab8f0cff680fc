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
use crate::bsp::core_ports::{CounterLoad, NodeStatus, TransmitRequest};
use crate::bsp::protocol::Protocol;
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
    /// Bus output (to the transceiver), registered.
    pub tx: Signal<Out, Bit>,
    /// The frame is valid for receivers (one clock).
    pub rx_valid: Signal<Out, Bit>,
    // The protocol engine's port groups, linked through unchanged (`crate::bsp::core_ports`,
    // `crate::bsp::received_frame`).
    /// Transmit request in, its end out.
    #[interface]
    pub transmit: TransmitRequest,
    /// TXERR/RXERR writes.
    #[interface]
    pub counters: CounterLoad,
    /// Header, then data bytes.
    #[interface]
    pub rx_frame: ReceivedFrame,
    /// Captures, counters, states.
    #[interface]
    pub status: NodeStatus,
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
        TransmitRequest::link(&mut self.transmit, &mut self.protocol.transmit);
        CounterLoad::link(&mut self.counters, &mut self.protocol.counters);
        self.tx.next = self.protocol.tx.val();
        ReceivedFrame::link(&mut self.rx_frame, &mut self.protocol.rx_frame);
        self.rx_valid.next = self.protocol.rx_valid.val();
        NodeStatus::link(&mut self.status, &mut self.protocol.status);
        self.sample_point.next = self.bit_timing.sample_point.val();
        self.segment.next = self.bit_timing.segment.val();
    }
}
