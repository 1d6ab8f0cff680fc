//! CRC-15 of CAN (x^15+x^14+x^10+x^8+x^7+x^4+x^3+1) over the bus bits of a frame.
//!
//! Ports: `clear` and `feed` strobes with the `level` to feed in; `value` (the register, the only
//! output, so the parent has no combinational path through this block) out. Acts on the rising edge of
//! `clock`: `clear` empties the register, otherwise `feed` shifts `level` in. The protocol engine feeds
//! every non-stuff bit from SOF to the last CRC bit, the received CRC bits included: the register then
//! ends at 0 exactly when the CRC was right. Feeding the right CRC bit only shifts the register, so a
//! transmitter's next CRC bit after feeding bit b is `value[13] ^ value[14] ^ b`.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::CRC15_POLYNOMIAL;

/// The CRC-15 shift register.
#[derive(ActivityBlock, BlockDefault)]
pub struct Crc15 {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Empties the register (start of frame).
    pub clear: Signal<In, Bit>,
    /// Shifts `level` in.
    pub feed: Signal<In, Bit>,
    /// The bus bit to feed.
    pub level: Signal<In, Bit>,
    /// The register.
    pub value: Signal<Out, Bits<15>>,
    register: DFF<Bits<15>>,
    #[constant(CRC15_POLYNOMIAL)]
    polynomial: Constant<Bits<15>>,
}

impl Logic for Crc15 {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, register);
        self.value.next = self.register.q.val();
        // A shift (wiring), not `x + x` (an adder); only when fed, where its cost in the
        // simulation is rare.
        if self.feed.val() {
            self.register.d.next = self.register.q.val() << 1;
            if self.level.val() ^ self.register.q.val().get_bit(14) {
                self.register.d.next = (self.register.q.val() << 1) ^ self.polynomial.val();
            }
        }
        if self.clear.val() {
            self.register.d.next = 0.into();
        }
    }
}
