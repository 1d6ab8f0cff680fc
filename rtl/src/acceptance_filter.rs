//! The acceptance filter of the SJA1000: decides whether a received frame is stored in the RX FIFO.
//!
//! The block owns the acceptance code and mask registers and their host access: PeliCAN ACR0..3 and
//! AMR0..3 at addresses 16..23, written and read in reset mode (in operating mode those addresses are
//! the frame buffers); BasicCAN ACR and AMR at 4 and 5 (ACR0 and AMR0 here), written in reset mode
//! (the controller makes them read 0xFF in operating mode). `host_selected`/`host_index` are
//! combinational from `addr` and the map: the controller writes the same value into the register's
//! read-back copy in the TX buffer's RAM, which the host reads (`crate::tx_buffer`), so the block has
//! no read multiplexer of its eight registers.
//!
//! Ports in: the host bus (`host`: `addr`, `we`, `wdata`; and `reset_mode`), the filter configuration
//! (`pelican`: PeliCAN mode, 0 = BasicCAN; `single_filter`: MOD.AFM) and the received-frame stream
//! of the protocol engine `rx_frame`: `header` (one-clock strobe when the header is complete) with
//! `id` (ID.28..18 in bits 28..18 in both formats, `crate::bsp::received_frame`), `ide` and `rtr`,
//! held until the frame's last strobe, then one `strobe` per data byte with `data` and `index` (0 =
//! data byte 1). Out: `accept`, valid from the clock after the last strobe of a frame (its header or its
//! last data byte) until the next `header`; it is combinational from the
//! registers and the two mode inputs. Acts on the rising edge of `clock`; `reset` is synchronous,
//! active high, and leaves `accept` low in every mode (no frame seen).
//!
//! The filter is evaluated incrementally, so no byte of the frame is stored: at `header` the
//! identifier/RTR part of every filter (single, dual filter 1, dual filter 2, BasicCAN) is compared
//! and the data flags are set to "match" (a missing data byte, e.g. of a remote frame or DLC < 2,
//! matches); data bytes 1 and 2 of a standard frame then update the data flags. A bit matches when it
//! equals its ACR bit or its AMR bit is 1 (don't care). Bit mapping (ID.28 is the first identifier bit
//! on the bus, i.e. bit 10 of a standard identifier):
//!
//! - BasicCAN: ACR0/AMR0 against ID.28..21 only. For an extended frame this is its ID.28..21 too; the
//!   parent drops extended frames in BasicCAN mode whatever `accept` says.
//! - Single filter, standard frame: ACR0 = ID.28..21, ACR1 bits 7..5 = ID.20..18, bit 4 = RTR, bits
//!   3..0 unused; ACR2 = data byte 1; ACR3 = data byte 2.
//! - Single filter, extended frame: ACR0..ACR2 = ID.28..5, ACR3 bits 7..3 = ID.4..0, bit 2 = RTR,
//!   bits 1..0 unused.
//! - Dual filter, standard frame: filter 1 = ACR0 (ID.28..21), ACR1 bits 7..5 (ID.20..18), bit 4
//!   (RTR), ACR1 bits 3..0 (data byte 1 bits 7..4) and ACR3 bits 3..0 (data byte 1 bits 3..0);
//!   filter 2 = ACR2 (ID.28..21), ACR3 bits 7..5 (ID.20..18), bit 4 (RTR). Accept if either matches.
//! - Dual filter, extended frame: filter 1 = ACR0, ACR1 against ID.28..13; filter 2 = ACR2, ACR3
//!   against ID.28..13.
//!
//! The comparisons run only in the clocks of a strobe (their temporaries are 0 otherwise), which keeps
//! the per-cycle cost of the simulation low.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::received_frame::ReceivedFrameIn;
use crate::register_map::HostWrite;
use crate::registers::{basic, pelican};

// The PeliCAN ACR0..AMR3 block is eight aligned addresses: `addr >> 3` selects it, `addr & 7` is
// the register.
const _: () = assert!(pelican::ACR0.is_multiple_of(8) && pelican::AMR0 == pelican::ACR0 + 4);
const _: () = assert!(pelican::AMR3 == pelican::ACR0 + 7);

/// The SJA1000 acceptance filter (BasicCAN, PeliCAN single and dual filter).
#[derive(ActivityBlock, BlockDefault)]
pub struct AcceptanceFilter {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// PeliCAN mode (CDR.7); 0 = BasicCAN.
    pub pelican: Signal<In, Bit>,
    /// Single acceptance filter (MOD.AFM); 0 = dual filter. Ignored in BasicCAN mode.
    pub single_filter: Signal<In, Bit>,
    /// Reset mode (MOD.RM / CR.RR): ACR and AMR are written only then.
    pub reset_mode: Signal<In, Bit>,
    /// The host bus: address, write strobe, write data.
    #[interface]
    pub host: HostWrite,
    /// The received-frame stream (`crate::bsp::received_frame`; the DLC is not filtered).
    #[interface]
    pub rx_frame: ReceivedFrameIn,
    /// The frame passes the filter of the current mode.
    pub accept: Signal<Out, Bit>,
    /// `addr` is one of this block's registers in the current mode (PeliCAN ACR0..AMR3 in reset
    /// mode, BasicCAN ACR and AMR).
    pub host_selected: Signal<Out, Bit>,
    /// The register at `addr`, with `host_selected`: 0..3 ACR0..3, 4..7 AMR0..3.
    pub host_index: Signal<Out, Bits<3>>,
    /// Acceptance code registers (ACR0 is the BasicCAN ACR).
    acr0: DFF<Bits<8>>,
    acr1: DFF<Bits<8>>,
    acr2: DFF<Bits<8>>,
    acr3: DFF<Bits<8>>,
    /// Acceptance mask registers (AMR0 is the BasicCAN AMR); a 1 bit is "don't care".
    amr0: DFF<Bits<8>>,
    amr1: DFF<Bits<8>>,
    amr2: DFF<Bits<8>>,
    amr3: DFF<Bits<8>>,
    /// `addr` in the PeliCAN block ACR0..AMR3, and the register's index there (0..3 ACR, 4..7 AMR).
    in_pelican_block: Signal<Local, Bit>,
    index: Signal<Local, Bits<3>>,
    /// The eight addresses of the PeliCAN block, as `addr >> 3`.
    #[constant(u64::from(pelican::ACR0 >> 3))]
    pelican_block: Constant<Bits<5>>,
    #[constant(u64::from(basic::ACR))]
    basic_acr: Constant<Bits<8>>,
    #[constant(u64::from(basic::AMR))]
    basic_amr: Constant<Bits<8>>,
    /// Single filter: identifier and RTR match.
    single_id_match: DFF<Bit>,
    /// Single filter: data byte 1 matches ACR2 (or is missing).
    single_data1_match: DFF<Bit>,
    /// Single filter: data byte 2 matches ACR3 (or is missing).
    single_data2_match: DFF<Bit>,
    /// Dual filter 1: identifier and RTR match.
    dual1_id_match: DFF<Bit>,
    /// Dual filter 1: data byte 1 matches ACR1[3:0]/ACR3[3:0] (or is missing).
    dual1_data_match: DFF<Bit>,
    /// Dual filter 2: identifier (and RTR) match.
    dual2_id_match: DFF<Bit>,
    /// BasicCAN: ID.28..21 match.
    basic_id_match: DFF<Bit>,
    /// 0xFF: `amr ^ ones` is the "care" mask of a register.
    #[constant(0xFFu64)]
    ones: Constant<Bits<8>>,
    /// 0xF0: the compared bits of ACR1/ACR3 for a standard identifier (ID.20..18, RTR).
    #[constant(0xF0u64)]
    standard_id_care: Constant<Bits<8>>,
    /// 0xFC: the compared bits of ACR3 in single filter mode for an extended identifier.
    #[constant(0xFCu64)]
    extended_rtr_care: Constant<Bits<8>>,
    /// The frame's bits compared with ACR0 (ID.28..21).
    frame_byte0: Signal<Local, Bits<8>>,
    /// The frame's bits compared with ACR1 (standard: ID.20..18, RTR, 0000; extended: ID.20..13).
    frame_byte1: Signal<Local, Bits<8>>,
    /// The frame's bits compared with ACR2 in single filter mode, extended frame (ID.12..5).
    frame_byte2: Signal<Local, Bits<8>>,
    /// The frame's bits compared with ACR3 in single filter mode, extended frame (ID.4..0, RTR, 00).
    frame_byte3: Signal<Local, Bits<8>>,
    /// The compared bits of `frame_byte1` (standard or extended).
    byte1_care: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits: `frame_byte0` against ACR0.
    mismatch0: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits: `frame_byte1` against ACR1.
    mismatch1: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits: `frame_byte2` against ACR2.
    mismatch2: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits: `frame_byte3` against ACR3.
    mismatch3: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits: `frame_byte0` against ACR2 (dual filter 2).
    mismatch0_filter2: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits: `frame_byte1` against ACR3 (dual filter 2).
    mismatch1_filter2: Signal<Local, Bits<8>>,
    /// Dual filter 1 data code: ACR1[3:0] (data bits 7..4), ACR3[3:0] (data bits 3..0).
    dual_data_code: Signal<Local, Bits<8>>,
    /// Dual filter 1 data mask: AMR1[3:0], AMR3[3:0].
    dual_data_mask: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits of the received data byte, single filter.
    data_mismatch_single: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits of the received data byte, dual filter 1.
    data_mismatch_dual: Signal<Local, Bits<8>>,
}

impl Logic for AcceptanceFilter {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            single_id_match,
            single_data1_match,
            single_data2_match,
            dual1_id_match,
            dual1_data_match,
            dual2_id_match,
            basic_id_match,
            acr0,
            acr1,
            acr2,
            acr3,
            amr0,
            amr1,
            amr2,
            amr3
        );

        // ---- Host access: the register at `addr`, and writes in reset mode.
        self.index.next = bit_cast::<3, 8>(self.host.addr.val());
        self.in_pelican_block.next =
            self.host.addr.val().get_bits::<5>(3) == self.pelican_block.val();
        self.host_selected.next =
            self.pelican.val() & self.reset_mode.val() & self.in_pelican_block.val();
        if self.pelican.val() == false {
            // BasicCAN ACR and AMR are ACR0 and AMR0.
            self.index.next = 0.into();
            if self.host.addr.val() == self.basic_amr.val() {
                self.index.next = 4.into();
            }
            self.host_selected.next = (self.host.addr.val() == self.basic_acr.val())
                | (self.host.addr.val() == self.basic_amr.val());
        }
        self.host_index.next = self.index.val();
        if self.host.we.val() & self.reset_mode.val() & self.host_selected.val() {
            if self.index.val() == 0 {
                self.acr0.d.next = self.host.wdata.val();
            }
            if self.index.val() == 1 {
                self.acr1.d.next = self.host.wdata.val();
            }
            if self.index.val() == 2 {
                self.acr2.d.next = self.host.wdata.val();
            }
            if self.index.val() == 3 {
                self.acr3.d.next = self.host.wdata.val();
            }
            if self.index.val() == 4 {
                self.amr0.d.next = self.host.wdata.val();
            }
            if self.index.val() == 5 {
                self.amr1.d.next = self.host.wdata.val();
            }
            if self.index.val() == 6 {
                self.amr2.d.next = self.host.wdata.val();
            }
            if self.index.val() == 7 {
                self.amr3.d.next = self.host.wdata.val();
            }
        }
        self.frame_byte0.next = 0.into();
        self.frame_byte1.next = 0.into();
        self.frame_byte2.next = 0.into();
        self.frame_byte3.next = 0.into();
        self.byte1_care.next = 0.into();
        self.mismatch0.next = 0.into();
        self.mismatch1.next = 0.into();
        self.mismatch2.next = 0.into();
        self.mismatch3.next = 0.into();
        self.mismatch0_filter2.next = 0.into();
        self.mismatch1_filter2.next = 0.into();
        self.dual_data_code.next = 0.into();
        self.dual_data_mask.next = 0.into();
        self.data_mismatch_single.next = 0.into();
        self.data_mismatch_dual.next = 0.into();

        // The result of the current mode.
        self.accept.next = self.basic_id_match.q.val();
        if self.pelican.val() {
            if self.single_filter.val() {
                self.accept.next = self.single_id_match.q.val()
                    & self.single_data1_match.q.val()
                    & self.single_data2_match.q.val();
            } else {
                self.accept.next = (self.dual1_id_match.q.val() & self.dual1_data_match.q.val())
                    | self.dual2_id_match.q.val();
            }
        }

        // Header: compare identifier and RTR with every filter; missing data bytes match.
        if self.rx_frame.header.val() {
            // ID.28..13 are id bits 28..13 in both formats (a standard frame's are ID.28..18,
            // then 0); a standard frame's RTR takes bit 4 of byte 1, whose bits 3..0 are not
            // compared.
            self.frame_byte0.next = self.rx_frame.id.val().get_bits::<8>(21);
            self.frame_byte1.next = self.rx_frame.id.val().get_bits::<8>(13);
            self.byte1_care.next = self.ones.val();
            if self.rx_frame.ide.val() == false {
                self.frame_byte1.next = self
                    .rx_frame
                    .id
                    .val()
                    .get_bits::<8>(13)
                    .replace_bit(4, self.rx_frame.rtr.val());
                self.byte1_care.next = self.standard_id_care.val();
            }
            self.frame_byte2.next = self.rx_frame.id.val().get_bits::<8>(5);
            self.frame_byte3.next = (bit_cast::<8, 5>(self.rx_frame.id.val().get_bits::<5>(0))
                << 3)
                | (bit_cast::<8, 1>(self.rx_frame.rtr.val().into()) << 2);
            self.mismatch0.next = (self.frame_byte0.val() ^ self.acr0.q.val())
                & (self.amr0.q.val() ^ self.ones.val());
            self.mismatch1.next = (self.frame_byte1.val() ^ self.acr1.q.val())
                & (self.amr1.q.val() ^ self.ones.val())
                & self.byte1_care.val();
            self.mismatch2.next = (self.frame_byte2.val() ^ self.acr2.q.val())
                & (self.amr2.q.val() ^ self.ones.val());
            self.mismatch3.next = (self.frame_byte3.val() ^ self.acr3.q.val())
                & (self.amr3.q.val() ^ self.ones.val())
                & self.extended_rtr_care.val();
            self.mismatch0_filter2.next = (self.frame_byte0.val() ^ self.acr2.q.val())
                & (self.amr2.q.val() ^ self.ones.val());
            self.mismatch1_filter2.next = (self.frame_byte1.val() ^ self.acr3.q.val())
                & (self.amr3.q.val() ^ self.ones.val())
                & self.byte1_care.val();

            self.basic_id_match.d.next = self.mismatch0.val() == 0;
            self.dual1_id_match.d.next = (self.mismatch0.val() == 0) & (self.mismatch1.val() == 0);
            self.dual2_id_match.d.next =
                (self.mismatch0_filter2.val() == 0) & (self.mismatch1_filter2.val() == 0);
            self.single_id_match.d.next = (self.mismatch0.val() == 0)
                & (self.mismatch1.val() == 0)
                & ((self.rx_frame.ide.val() == false)
                    | ((self.mismatch2.val() == 0) & (self.mismatch3.val() == 0)));
            self.single_data1_match.d.next = true;
            self.single_data2_match.d.next = true;
            self.dual1_data_match.d.next = true;
        }

        // Data bytes 1 and 2 of a standard frame (`ide` is held from the header on).
        if self.rx_frame.strobe.val() & (self.rx_frame.ide.val() == false) {
            if self.rx_frame.index.val() == 0 {
                self.data_mismatch_single.next = (self.rx_frame.data.val() ^ self.acr2.q.val())
                    & (self.amr2.q.val() ^ self.ones.val());
                self.dual_data_code.next = (bit_cast::<8, 4>(self.acr1.q.val().get_bits::<4>(0))
                    << 4)
                    | bit_cast::<8, 4>(self.acr3.q.val().get_bits::<4>(0));
                self.dual_data_mask.next = (bit_cast::<8, 4>(self.amr1.q.val().get_bits::<4>(0))
                    << 4)
                    | bit_cast::<8, 4>(self.amr3.q.val().get_bits::<4>(0));
                self.data_mismatch_dual.next = (self.rx_frame.data.val()
                    ^ self.dual_data_code.val())
                    & (self.dual_data_mask.val() ^ self.ones.val());
                self.single_data1_match.d.next = self.data_mismatch_single.val() == 0;
                self.dual1_data_match.d.next = self.data_mismatch_dual.val() == 0;
            }
            if self.rx_frame.index.val() == 1 {
                self.data_mismatch_single.next = (self.rx_frame.data.val() ^ self.acr3.q.val())
                    & (self.amr3.q.val() ^ self.ones.val());
                self.single_data2_match.d.next = self.data_mismatch_single.val() == 0;
            }
        }

        if self.reset.val() {
            self.single_id_match.d.next = false;
            self.single_data1_match.d.next = true;
            self.single_data2_match.d.next = true;
            self.dual1_id_match.d.next = false;
            self.dual1_data_match.d.next = true;
            self.dual2_id_match.d.next = false;
            self.basic_id_match.d.next = false;
            self.acr0.d.next = 0.into();
            self.acr1.d.next = 0.into();
            self.acr2.d.next = 0.into();
            self.acr3.d.next = 0.into();
            self.amr0.d.next = 0.into();
            self.amr1.d.next = 0.into();
            self.amr2.d.next = 0.into();
            self.amr3.d.next = 0.into();
        }
    }
}
