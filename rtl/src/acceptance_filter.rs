//! The acceptance filter of the SJA1000: decides whether a received frame is stored in the RX FIFO.
//!
//! Ports in: the filter configuration (`pelican`: PeliCAN mode, 0 = BasicCAN; `single_filter`: MOD.AFM;
//! `acr0`..`acr3`, `amr0`..`amr3`: the acceptance code and mask registers; in BasicCAN mode ACR/AMR are
//! `acr0`/`amr0`) and the received-frame stream of the protocol engine: `rx_header` (one-clock strobe
//! when the header is complete) with `rx_id` (11-bit standard or 29-bit extended identifier,
//! right-aligned), `rx_ide` and `rx_rtr`, then one `rx_byte_strobe` per data byte with `rx_byte` and
//! `rx_byte_index` (0 = data byte 1). Out: `accept`, valid from the clock after the last strobe of a
//! frame (its header or its last data byte) until the next `rx_header`; it is combinational from the
//! registers and the two mode inputs. Acts on the rising edge of `clock`; `reset` is synchronous,
//! active high, and leaves `accept` low in every mode (no frame seen).
//!
//! The filter is evaluated incrementally, so no byte of the frame is stored: at `rx_header` the
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

use crate::activity::{Activity, ActivityBlock};

/// The SJA1000 acceptance filter (BasicCAN, PeliCAN single and dual filter).
#[derive(ActivityBlock)]
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
    /// Acceptance code register 0 (the BasicCAN ACR).
    pub acr0: Signal<In, Bits<8>>,
    /// Acceptance code register 1.
    pub acr1: Signal<In, Bits<8>>,
    /// Acceptance code register 2.
    pub acr2: Signal<In, Bits<8>>,
    /// Acceptance code register 3.
    pub acr3: Signal<In, Bits<8>>,
    /// Acceptance mask register 0 (the BasicCAN AMR); a 1 bit is "don't care".
    pub amr0: Signal<In, Bits<8>>,
    /// Acceptance mask register 1.
    pub amr1: Signal<In, Bits<8>>,
    /// Acceptance mask register 2.
    pub amr2: Signal<In, Bits<8>>,
    /// Acceptance mask register 3.
    pub amr3: Signal<In, Bits<8>>,
    /// One-clock strobe: the header of a received frame is complete (`rx_id`, `rx_ide`, `rx_rtr` valid).
    pub rx_header: Signal<In, Bit>,
    /// Received identifier, right-aligned: 11 bits (standard) or 29 bits (extended).
    pub rx_id: Signal<In, Bits<29>>,
    /// Received frame is extended (IDE recessive).
    pub rx_ide: Signal<In, Bit>,
    /// Received frame is a remote frame.
    pub rx_rtr: Signal<In, Bit>,
    /// One-clock strobe: a data byte was received (`rx_byte`, `rx_byte_index` valid).
    pub rx_byte_strobe: Signal<In, Bit>,
    /// The received data byte.
    pub rx_byte: Signal<In, Bits<8>>,
    /// Index of the received data byte (0 = data byte 1).
    pub rx_byte_index: Signal<In, Bits<3>>,
    /// The frame passes the filter of the current mode.
    pub accept: Signal<Out, Bit>,
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
    /// The current frame is extended (data bytes are not filtered).
    extended_frame: DFF<Bit>,
    /// 0xFF: `amr ^ ones` is the "care" mask of a register.
    ones: Constant<Bits<8>>,
    /// 0xF0: the compared bits of ACR1/ACR3 for a standard identifier (ID.20..18, RTR).
    standard_id_care: Constant<Bits<8>>,
    /// 0xFC: the compared bits of ACR3 in single filter mode for an extended identifier.
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

impl Default for AcceptanceFilter {
    fn default() -> Self {
        AcceptanceFilter {
            activity: Activity::default(),
            clock: Default::default(),
            reset: Default::default(),
            pelican: Default::default(),
            single_filter: Default::default(),
            acr0: Default::default(),
            acr1: Default::default(),
            acr2: Default::default(),
            acr3: Default::default(),
            amr0: Default::default(),
            amr1: Default::default(),
            amr2: Default::default(),
            amr3: Default::default(),
            rx_header: Default::default(),
            rx_id: Default::default(),
            rx_ide: Default::default(),
            rx_rtr: Default::default(),
            rx_byte_strobe: Default::default(),
            rx_byte: Default::default(),
            rx_byte_index: Default::default(),
            accept: Default::default(),
            single_id_match: Default::default(),
            single_data1_match: Default::default(),
            single_data2_match: Default::default(),
            dual1_id_match: Default::default(),
            dual1_data_match: Default::default(),
            dual2_id_match: Default::default(),
            basic_id_match: Default::default(),
            extended_frame: Default::default(),
            ones: Constant::new(0xFF.into()),
            standard_id_care: Constant::new(0xF0.into()),
            extended_rtr_care: Constant::new(0xFC.into()),
            frame_byte0: Default::default(),
            frame_byte1: Default::default(),
            frame_byte2: Default::default(),
            frame_byte3: Default::default(),
            byte1_care: Default::default(),
            mismatch0: Default::default(),
            mismatch1: Default::default(),
            mismatch2: Default::default(),
            mismatch3: Default::default(),
            mismatch0_filter2: Default::default(),
            mismatch1_filter2: Default::default(),
            dual_data_code: Default::default(),
            dual_data_mask: Default::default(),
            data_mismatch_single: Default::default(),
            data_mismatch_dual: Default::default(),
        }
    }
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
            extended_frame
        );
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
        if self.rx_header.val() {
            self.frame_byte0.next = self.rx_id.val().get_bits::<8>(3);
            self.frame_byte1.next = (bit_cast::<8, 3>(self.rx_id.val().get_bits::<3>(0)) << 5)
                | (bit_cast::<8, 1>(self.rx_rtr.val().into()) << 4);
            self.byte1_care.next = self.standard_id_care.val();
            if self.rx_ide.val() {
                self.frame_byte0.next = self.rx_id.val().get_bits::<8>(21);
                self.frame_byte1.next = self.rx_id.val().get_bits::<8>(13);
                self.byte1_care.next = self.ones.val();
            }
            self.frame_byte2.next = self.rx_id.val().get_bits::<8>(5);
            self.frame_byte3.next = (bit_cast::<8, 5>(self.rx_id.val().get_bits::<5>(0)) << 3)
                | (bit_cast::<8, 1>(self.rx_rtr.val().into()) << 2);
            self.mismatch0.next =
                (self.frame_byte0.val() ^ self.acr0.val()) & (self.amr0.val() ^ self.ones.val());
            self.mismatch1.next = (self.frame_byte1.val() ^ self.acr1.val())
                & (self.amr1.val() ^ self.ones.val())
                & self.byte1_care.val();
            self.mismatch2.next =
                (self.frame_byte2.val() ^ self.acr2.val()) & (self.amr2.val() ^ self.ones.val());
            self.mismatch3.next = (self.frame_byte3.val() ^ self.acr3.val())
                & (self.amr3.val() ^ self.ones.val())
                & self.extended_rtr_care.val();
            self.mismatch0_filter2.next =
                (self.frame_byte0.val() ^ self.acr2.val()) & (self.amr2.val() ^ self.ones.val());
            self.mismatch1_filter2.next = (self.frame_byte1.val() ^ self.acr3.val())
                & (self.amr3.val() ^ self.ones.val())
                & self.byte1_care.val();

            self.basic_id_match.d.next = self.mismatch0.val() == 0;
            self.dual1_id_match.d.next = (self.mismatch0.val() == 0) & (self.mismatch1.val() == 0);
            self.dual2_id_match.d.next =
                (self.mismatch0_filter2.val() == 0) & (self.mismatch1_filter2.val() == 0);
            self.single_id_match.d.next = (self.mismatch0.val() == 0)
                & (self.mismatch1.val() == 0)
                & ((self.rx_ide.val() == false)
                    | ((self.mismatch2.val() == 0) & (self.mismatch3.val() == 0)));
            self.single_data1_match.d.next = true;
            self.single_data2_match.d.next = true;
            self.dual1_data_match.d.next = true;
            self.extended_frame.d.next = self.rx_ide.val();
        }

        // Data bytes 1 and 2 of a standard frame.
        if self.rx_byte_strobe.val() & (self.extended_frame.q.val() == false) {
            if self.rx_byte_index.val() == 0 {
                self.data_mismatch_single.next =
                    (self.rx_byte.val() ^ self.acr2.val()) & (self.amr2.val() ^ self.ones.val());
                self.dual_data_code.next = (bit_cast::<8, 4>(self.acr1.val().get_bits::<4>(0))
                    << 4)
                    | bit_cast::<8, 4>(self.acr3.val().get_bits::<4>(0));
                self.dual_data_mask.next = (bit_cast::<8, 4>(self.amr1.val().get_bits::<4>(0))
                    << 4)
                    | bit_cast::<8, 4>(self.amr3.val().get_bits::<4>(0));
                self.data_mismatch_dual.next = (self.rx_byte.val() ^ self.dual_data_code.val())
                    & (self.dual_data_mask.val() ^ self.ones.val());
                self.single_data1_match.d.next = self.data_mismatch_single.val() == 0;
                self.dual1_data_match.d.next = self.data_mismatch_dual.val() == 0;
            }
            if self.rx_byte_index.val() == 1 {
                self.data_mismatch_single.next =
                    (self.rx_byte.val() ^ self.acr3.val()) & (self.amr3.val() ^ self.ones.val());
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
            self.extended_frame.d.next = false;
        }
    }
}
