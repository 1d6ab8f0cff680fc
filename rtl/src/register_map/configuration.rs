//! Configuration registers: the bus timing registers BTR0 and BTR1, the output control register OCR
//! and the error warning limit EWLR (PeliCAN), with their host access.
//!
//! Ports in: the host bus `host` (`addr`, `we`, `wdata`: `crate::register_map::HostWrite`) and the map state `pelican`, `reset_mode`, straight
//! from the controller's ports and the mode flip-flops. Out: the bit timing fields the core runs on
//! (`brp`, `sjw`, `tseg1`, `tseg2`, `sam`), `ewlr` (which the read side also reads), and
//! `host_selected`/`host_index` (BTR0, BTR1 or OCR at `addr`, combinational from `addr` and the
//! map): the controller writes the same value into the register's read-back copy in the TX
//! buffer's RAM, which the host reads (`crate::tx_buffer`). OCR has no flip-flops here: nothing
//! runs on it (the output driver is outside the core), so it is only that copy. Acts on the rising
//! edge of `clock`; `reset` is synchronous, active high (all 0, EWLR 96).
//!
//! Rules (SJA1000 data sheet): all four are written in reset mode only; EWLR exists in PeliCAN only.
//! BTR0 = SJW (7..6) and BRP (5..0); BTR1 = SAM (7), TSEG2 (6..4), TSEG1 (3..0).

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::register_map::HostWrite;
use crate::registers::{basic, pelican, DEFAULT_EWLR};

// Address bits 3 and 0 tell BTR0, BTR1 and OCR apart (00, 01, 10): the kernel's `host_index`.
const _: () = assert!(
    pelican::BTR0 & 0b1001 == 0b0000
        && pelican::BTR1 & 0b1001 == 0b0001
        && pelican::OCR & 0b1001 == 0b1000
        && pelican::BTR0 == basic::BTR0
        && pelican::BTR1 == basic::BTR1
        && pelican::OCR == basic::OCR
);

/// BTR0, BTR1, OCR and EWLR.
#[derive(ActivityBlock, BlockDefault)]
pub struct Configuration {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// The host bus: address, write strobe, write data.
    #[interface]
    pub host: HostWrite,
    /// The PeliCAN map (CDR.7).
    pub pelican: Signal<In, Bit>,
    /// Reset mode.
    pub reset_mode: Signal<In, Bit>,
    /// BTR0.5..0: baud rate prescaler.
    pub brp: Signal<Out, Bits<6>>,
    /// BTR0.7..6: synchronisation jump width.
    pub sjw: Signal<Out, Bits<2>>,
    /// BTR1.3..0: time segment 1.
    pub tseg1: Signal<Out, Bits<4>>,
    /// BTR1.6..4: time segment 2.
    pub tseg2: Signal<Out, Bits<3>>,
    /// BTR1.7: triple sampling.
    pub sam: Signal<Out, Bit>,
    /// EWLR.
    pub ewlr: Signal<Out, Bits<8>>,
    /// `addr` is BTR0, BTR1 or OCR (the registers read back from their copies).
    pub host_selected: Signal<Out, Bit>,
    /// The register at `addr`, with `host_selected`: 0 BTR0, 1 BTR1, 2 OCR.
    pub host_index: Signal<Out, Bits<2>>,
    btr0: DFF<Bits<8>>,
    btr1: DFF<Bits<8>>,
    // SJW and TSEG2 are kept apart too: slicing them out of BTR0/BTR1 on every simulated cycle is
    // costly in rust-hdl, and a registered SJW keeps the resynchronisation path short.
    sjw_reg: DFF<Bits<2>>,
    tseg2_reg: DFF<Bits<3>>,
    ewlr_reg: DFF<Bits<8>>,
    #[constant(u64::from(pelican::BTR0))]
    btr0_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::BTR1))]
    btr1_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::OCR))]
    ocr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::EWLR))]
    ewlr_address: Constant<Bits<8>>,
    #[constant(u64::from(DEFAULT_EWLR))]
    default_ewlr: Constant<Bits<8>>,
    #[constant(0u64)]
    zero_index: Constant<Bits<2>>,
}

impl Logic for Configuration {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(self, clock, btr0, btr1, sjw_reg, tseg2_reg, ewlr_reg);
        self.brp.next = bit_cast::<6, 8>(self.btr0.q.val());
        self.sjw.next = self.sjw_reg.q.val();
        self.tseg1.next = bit_cast::<4, 8>(self.btr1.q.val());
        self.tseg2.next = self.tseg2_reg.q.val();
        self.sam.next = self.btr1.q.val().get_bit(7);
        self.ewlr.next = self.ewlr_reg.q.val();

        if self.host.we.val() & self.reset_mode.val() {
            if self.host.addr.val() == self.btr0_address.val() {
                self.btr0.d.next = self.host.wdata.val();
                self.sjw_reg.d.next = self.host.wdata.val().get_bits::<2>(6);
            }
            if self.host.addr.val() == self.btr1_address.val() {
                self.btr1.d.next = self.host.wdata.val();
                self.tseg2_reg.d.next = self.host.wdata.val().get_bits::<3>(4);
            }
            if self.pelican.val() & (self.host.addr.val() == self.ewlr_address.val()) {
                self.ewlr_reg.d.next = self.host.wdata.val();
            }
        }

        self.host_selected.next = (self.host.addr.val() == self.btr0_address.val())
            | (self.host.addr.val() == self.btr1_address.val())
            | (self.host.addr.val() == self.ocr_address.val());
        // One assignment: the controller reads this output back (docs/VERILOG.md).
        self.host_index.next = self
            .zero_index
            .val()
            .replace_bit(1, self.host.addr.val().get_bit(3))
            .replace_bit(0, self.host.addr.val().get_bit(0));

        if self.reset.val() {
            self.btr0.d.next = 0.into();
            self.btr1.d.next = 0.into();
            self.sjw_reg.d.next = 0.into();
            self.tseg2_reg.d.next = 0.into();
            self.ewlr_reg.d.next = self.default_ewlr.val();
        }
    }
}
