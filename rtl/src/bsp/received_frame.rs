//! The received-frame stream, declared once: the port group through which the protocol engine
//! delivers a frame while it arrives (the receive assembler drives it; the acceptance filter and the
//! receive FIFO take it in).
//!
//! `header` is one clock when the header is complete: `id`, `ide`, `rtr` and `dlc` are valid from
//! then until the next frame's header. `id` holds ID.28..18 in bits 28..18 in both formats: an
//! extended identifier as its number, a standard one shifted up by [`STANDARD_ID_SHIFT`] with 0
//! below, so the bits the SJA1000's registers place alike (frame buffer, acceptance code) come from
//! the same wires. Then each data byte comes as
//! `data` with its `index` (0 = data byte 1) and the one-clock `strobe`. All are flip-flop outputs
//! of the assembler, changing on the rising edge of `clock`.
//!
//! In a kernel, `ReceivedFrame::link(&mut self.parent_port, &mut self.child.port)` passes the group
//! up through a block, `ReceivedFrame::join(&mut self.a.port, &mut self.b.port)` connects a
//! source to a sink; both are one statement per signal in the Verilog, outside the kernel's
//! `always` block.

// rust-hdl's `LogicInterface` derive writes `join` without a doc comment; every item written here
// has one.
#![allow(missing_docs)]

use rust_hdl::prelude::*;

/// The position of ID.18 in `id`: a standard identifier is carried shifted up by this.
pub const STANDARD_ID_SHIFT: u32 = 18;

/// The received-frame stream, from its source (`Out`).
#[derive(LogicInterface, Default)]
#[join = "ReceivedFrameIn"]
pub struct ReceivedFrame {
    /// One clock when the header is complete.
    pub header: Signal<Out, Bit>,
    /// Identifier: ID.28..18 in bits 28..18 (a standard one shifted up by
    /// [`STANDARD_ID_SHIFT`]).
    pub id: Signal<Out, Bits<29>>,
    /// IDE.
    pub ide: Signal<Out, Bit>,
    /// RTR.
    pub rtr: Signal<Out, Bit>,
    /// DLC.
    pub dlc: Signal<Out, Bits<4>>,
    /// One clock per data byte.
    pub strobe: Signal<Out, Bit>,
    /// The data byte, with `strobe`.
    pub data: Signal<Out, Bits<8>>,
    /// Index (0..7) of `data`.
    pub index: Signal<Out, Bits<3>>,
}

/// The received-frame stream, at a sink (`In`): the mirror of [`ReceivedFrame`].
#[derive(LogicInterface, Default)]
pub struct ReceivedFrameIn {
    /// One clock when the header is complete.
    pub header: Signal<In, Bit>,
    /// Identifier: ID.28..18 in bits 28..18 (a standard one shifted up by
    /// [`STANDARD_ID_SHIFT`]).
    pub id: Signal<In, Bits<29>>,
    /// IDE.
    pub ide: Signal<In, Bit>,
    /// RTR.
    pub rtr: Signal<In, Bit>,
    /// DLC.
    pub dlc: Signal<In, Bits<4>>,
    /// One clock per data byte.
    pub strobe: Signal<In, Bit>,
    /// The data byte, with `strobe`.
    pub data: Signal<In, Bits<8>>,
    /// Index (0..7) of `data`.
    pub index: Signal<In, Bits<3>>,
}
