//! The protocol engine's port groups towards the register block, declared once: the transmit
//! request with its frame and its end, the counter writes, and the node's status (captures,
//! counters, states). The protocol engine drives them, the CAN core passes them up with a `link`,
//! the controller reads and writes their signals.

// rust-hdl's `LogicInterface` derive writes methods without doc comments; every item written here
// has one.
#![allow(missing_docs)]

use rust_hdl::prelude::*;

use crate::bsp::protocol::ProtocolState;

/// The transmit request: the frame in the SJA1000 transmit-buffer layout, and the request's end.
#[derive(LogicInterface, Default)]
pub struct TransmitRequest {
    /// A frame waits in the transmit buffer.
    pub request: Signal<In, Bit>,
    /// One attempt only (no retransmission after an error or lost arbitration).
    pub single_shot: Signal<In, Bit>,
    /// Abort the request (one clock): a request not under transmission ends at the next process
    /// point (`done` without success); an attempt under way finishes as a single shot.
    pub abort: Signal<In, Bit>,
    /// Frame information byte of the frame to send: FF (7), RTR (6), DLC (3..0).
    pub info: Signal<In, Bits<8>>,
    /// The transmit-buffer byte at `addr`, at the latest from the clock after `addr` changed (a
    /// registered RAM read): it is used at process points only, and `addr` changes at a process
    /// point or between frames.
    pub data: Signal<In, Bits<8>>,
    /// Transmit-buffer byte wanted (1..12).
    pub addr: Signal<Out, Bits<4>>,
    /// One clock at the end of a transmission attempt that ends the request (success, or a failed
    /// single shot).
    pub done: Signal<Out, Bit>,
    /// With `done`: the frame was sent.
    pub success: Signal<Out, Bit>,
}

/// Host writes of the error counters (SJA1000 TXERR/RXERR, reset mode).
#[derive(LogicInterface, Default)]
pub struct CounterLoad {
    /// Load `value` into TEC.
    pub load_tec: Signal<In, Bit>,
    /// Load `value` into REC.
    pub load_rec: Signal<In, Bit>,
    /// The value written.
    pub value: Signal<In, Bits<8>>,
}

/// What the node reports: bus errors and arbitration losses with their captures, the error
/// counters and states, and what it is doing on the bus.
#[derive(LogicInterface, Default)]
pub struct NodeStatus {
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
}
