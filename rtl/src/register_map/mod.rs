//! The SJA1000 register map's blocks: each owns its registers and their host access, and the
//! controller (`crate::can_controller`) wires them to the host port, the core, the transmit buffer,
//! the acceptance filter and the receive FIFO.
//!
//! - `host_decode`: which window an access hits, byte indices, the CMR strobes (combinational);
//! - `modes`: MOD / CR.RR, CDR, sleep and wake-up, CLKOUT, the core's mode inputs;
//! - `configuration`: BTR0, BTR1, OCR, EWLR;
//! - `interrupts`: IER, IR, the ALC and ECC captures, SR.ES, the BasicCAN RI latch;
//! - `register_read`: SR, the IR value, the read multiplexer, `rdata` and the interrupt line.

// rust-hdl's `LogicInterface` derive writes methods without doc comments; every item written here
// has one.
#![allow(missing_docs)]

use rust_hdl::prelude::*;

pub mod configuration;
pub mod host_decode;
pub mod interrupts;
pub mod modes;
pub mod register_read;

/// The host's write side as each register block takes it straight from the controller's ports:
/// the address (also decoded for reads), the write strobe and the write data. Declared once; the
/// controller drives every block's copy from its `addr`, `we` and `wdata` ports.
#[derive(LogicInterface, Default)]
pub struct HostWrite {
    /// Register address.
    pub addr: Signal<In, Bits<8>>,
    /// Write strobe (one clock), with `wdata`.
    pub we: Signal<In, Bit>,
    /// Write data.
    pub wdata: Signal<In, Bits<8>>,
}

/// The interrupt block's registers as the read side shows them: IER, IR (RI excluded), ALC, ECC,
/// SR.ES and the BasicCAN RI latch, all flip-flop outputs.
#[derive(LogicInterface, Default)]
pub struct InterruptRegisters {
    /// IER (BasicCAN: CR.4..1 in bits 3..0).
    pub ier: Signal<Out, Bits<8>>,
    /// IR, RI excluded.
    pub ir: Signal<Out, Bits<8>>,
    /// ALC.
    pub alc: Signal<Out, Bits<5>>,
    /// ECC.
    pub ecc: Signal<Out, Bits<8>>,
    /// SR.ES.
    pub es: Signal<Out, Bit>,
    /// The BasicCAN RI latch.
    pub basic_ri: Signal<Out, Bit>,
}

/// The mirror of [`InterruptRegisters`] at the read side.
#[derive(LogicInterface, Default)]
pub struct InterruptRegistersIn {
    /// IER.
    pub ier: Signal<In, Bits<8>>,
    /// IR without RI.
    pub ir: Signal<In, Bits<8>>,
    /// ALC.
    pub alc: Signal<In, Bits<5>>,
    /// ECC.
    pub ecc: Signal<In, Bits<8>>,
    /// SR.ES.
    pub es: Signal<In, Bit>,
    /// The RI latch.
    pub basic_ri: Signal<In, Bit>,
}
