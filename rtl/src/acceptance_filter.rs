//! The acceptance filter of the SJA1000: decides whether a received frame is stored in the RX FIFO.
//!
//! The block decodes the host addresses of the acceptance code and mask registers: PeliCAN ACR0..3
//! and AMR0..3 at addresses 16..23, written and read in reset mode (in operating mode those addresses
//! are the frame buffers); BasicCAN ACR and AMR at 4 and 5 (ACR0 and AMR0 here), written in reset
//! mode (the controller makes them read 0xFF in operating mode). `host_selected`/`host_index` are
//! combinational from `addr` and the map: on an accepted write the controller stores the value at
//! the register's index in the TX buffer's RAMs (`crate::tx_buffer`), where the host reads it back
//! and this block compares with it, so the block has neither the registers nor their multiplexers.
//!
//! Ports in: `addr` and `reset_mode` (the host side), the filter configuration (`pelican`: PeliCAN
//! mode, 0 = BasicCAN; `single_filter`: MOD.AFM), the register reads (`copy_granted`, `copy_data`)
//! and the received-frame stream of the protocol engine `rx_frame`: `header` (one-clock strobe when
//! the header is complete) with `id` (ID.28..18 in bits 28..18 in both formats,
//! `crate::bsp::received_frame`), `ide` and `rtr`, valid from then until the next frame's header,
//! then one `strobe` per data byte with `data` and `index` (0 = data byte 1). Out: `accept`, final
//! [`COMPARE_READS`] granted clocks after the last strobe of a frame that starts a comparison (its
//! header or data byte 1 or 2 of a standard frame) until the next `header`, combinational from
//! flip-flops and the two mode inputs; `copy_wanted`/`copy_index` (flip-flops: the register the
//! filter reads next). Acts on the rising edge of `clock`; `reset` is synchronous, active high, and
//! leaves `accept` low in every mode (no frame seen).
//!
//! The filter keeps no copy of ACR/AMR: the controller writes them, with their read-back copies, into
//! the TX buffer's RAMs (`crate::tx_buffer`), and the filter reads them from the protocol engine's
//! RAM through `copy_index` → `copy_data` (registered: the byte arrives the clock after the read),
//! in the clocks the controller grants (`copy_granted`: any clock but a sample point, whose read is
//! the engine's). After `header`, and after data bytes 1 and 2 of a standard frame (the byte is
//! latched: the stream's byte register shifts on), the filter reads the eight registers in the order
//! ACR0, AMR0, ACR1, AMR1, .. AMR3 and compares one frame byte with each ACR/AMR pair as its AMR
//! arrives, with one comparator: the pair's frame byte is the one the mode in force maps to it. A
//! bit matches when it equals its ACR bit or its AMR bit is 1 (don't care). Match flags gather the
//! results (a missing data byte, e.g. of a remote frame or DLC < 2, matches). The eight reads take
//! eight granted clocks; the stream's strobes are a byte (at least 8 bit times) apart and the frame
//! is stored at its validity point, more than 20 bit times after its last strobe, so `accept` is
//! final long before it is used. The mode (`pelican`, `single_filter`) changes only in reset mode,
//! where no frame is stored. Bit mapping (ID.28 is the first identifier bit on the bus, i.e. bit 10
//! of a standard identifier):
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

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::received_frame::ReceivedFrameIn;
use crate::registers::{basic, pelican};

// The PeliCAN ACR0..AMR3 block is eight aligned addresses: `addr >> 3` selects it, `addr & 7` is
// the register.
const _: () = assert!(pelican::ACR0.is_multiple_of(8) && pelican::AMR0 == pelican::ACR0 + 4);
const _: () = assert!(pelican::AMR3 == pelican::ACR0 + 7);

/// Register reads of one comparison run: ACR0, AMR0, .. ACR3, AMR3.
pub const COMPARE_READS: usize = 8;
// The run's read number: bit 0 picks AMR over ACR, bits 2..1 the pair (the kernel's literals).
const _: () = assert!(COMPARE_READS == 8);

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
    /// The host's register address.
    pub addr: Signal<In, Bits<8>>,
    /// The received-frame stream (`crate::bsp::received_frame`; the DLC is not filtered).
    #[interface]
    pub rx_frame: ReceivedFrameIn,
    /// The read of `copy_index` asked for in this clock takes place (the register arrives in
    /// `copy_data` in the next clock).
    pub copy_granted: Signal<In, Bit>,
    /// The register read in the clock before (its copy in the TX buffer: 0 until written after
    /// a reset, the registers' reset value).
    pub copy_data: Signal<In, Bits<8>>,
    /// The frame passes the filter of the current mode.
    pub accept: Signal<Out, Bit>,
    /// `addr` is one of this block's registers in the current mode (PeliCAN ACR0..AMR3 in reset
    /// mode, BasicCAN ACR and AMR).
    pub host_selected: Signal<Out, Bit>,
    /// The register at `addr`, with `host_selected`: 0..3 ACR0..3, 4..7 AMR0..3.
    pub host_index: Signal<Out, Bits<3>>,
    /// The filter asks to read the register at `copy_index`.
    pub copy_wanted: Signal<Out, Bit>,
    /// The register to read: 0..3 ACR0..3, 4..7 AMR0..3 (as `host_index`).
    pub copy_index: Signal<Out, Bits<3>>,
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
    /// A comparison run is under way: reads are asked for.
    running: DFF<Bit>,
    /// The run's next read (bit 0: AMR, bits 2..1: the pair).
    read_number: DFF<Bits<3>>,
    /// A read was granted in the clock before: `copy_data` holds register `arrived_number`.
    arrived: DFF<Bit>,
    arrived_number: DFF<Bits<3>>,
    /// The ACR of the pair being compared, until its AMR arrives.
    code: DFF<Bits<8>>,
    /// The run compares a data byte (`data_byte`), not the header.
    data_run: DFF<Bit>,
    /// With `data_run`: data byte 2, else data byte 1.
    second_byte: DFF<Bit>,
    /// The data byte compared (the stream's byte register shifts on after its strobe).
    data_byte: DFF<Bits<8>>,
    /// Identifier and RTR match: the single filter, dual filter 1, or BasicCAN.
    filter1_id_match: DFF<Bit>,
    /// Dual filter 2: identifier (and RTR) match.
    filter2_id_match: DFF<Bit>,
    /// Data byte 1 matches (single: ACR2; dual filter 1: ACR1[3:0], ACR3[3:0]) or is missing.
    data1_match: DFF<Bit>,
    /// Single filter: data byte 2 matches ACR3 or is missing.
    data2_match: DFF<Bit>,
    /// PeliCAN single filter, and PeliCAN dual filter.
    single: Signal<Local, Bit>,
    dual: Signal<Local, Bit>,
    /// The pair (0..3) of the register that arrived.
    pair: Signal<Local, Bits<2>>,
    /// 0xFF: `amr ^ ones` is the "care" mask of a register.
    #[constant(0xFFu64)]
    ones: Constant<Bits<8>>,
    /// 0xF0: the compared bits of ACR1/ACR3 for a standard identifier (ID.20..18, RTR).
    #[constant(0xF0u64)]
    standard_id_care: Constant<Bits<8>>,
    /// 0xFC: the compared bits of ACR3 in single filter mode for an extended identifier.
    #[constant(0xFCu64)]
    extended_rtr_care: Constant<Bits<8>>,
    /// 0x0F: the compared bits of ACR1 and ACR3 against a data byte's nibble (dual filter 1).
    #[constant(0x0Fu64)]
    nibble_care: Constant<Bits<8>>,
    /// Identifier bytes in the frame-buffer layout: ID.28..21; ID.20..13 (standard: ID.20..18,
    /// RTR, 0000); ID.12..5; ID.4..0, RTR, 00.
    id_byte1: Signal<Local, Bits<8>>,
    id_byte3: Signal<Local, Bits<8>>,
    /// The compared bits of `id_byte1` (standard or extended).
    byte1_care: Signal<Local, Bits<8>>,
    /// The frame byte compared with the pair that arrived, and its compared bits.
    operand: Signal<Local, Bits<8>>,
    care: Signal<Local, Bits<8>>,
    /// Mismatching cared-for bits of `operand` against the pair.
    mismatch: Signal<Local, Bits<8>>,
    matched: Signal<Local, Bit>,
}

impl Logic for AcceptanceFilter {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            running,
            read_number,
            arrived,
            arrived_number,
            code,
            data_run,
            second_byte,
            data_byte,
            filter1_id_match,
            filter2_id_match,
            data1_match,
            data2_match
        );

        // ---- Host access: the register at `addr` (the controller writes it into the TX buffer).
        self.index.next = bit_cast::<3, 8>(self.addr.val());
        self.in_pelican_block.next = self.addr.val().get_bits::<5>(3) == self.pelican_block.val();
        self.host_selected.next =
            self.pelican.val() & self.reset_mode.val() & self.in_pelican_block.val();
        if self.pelican.val() == false {
            // BasicCAN ACR and AMR are ACR0 and AMR0.
            self.index.next = 0.into();
            if self.addr.val() == self.basic_amr.val() {
                self.index.next = 4.into();
            }
            self.host_selected.next = (self.addr.val() == self.basic_acr.val())
                | (self.addr.val() == self.basic_amr.val());
        }
        self.host_index.next = self.index.val();

        // ---- The result of the current mode.
        self.single.next = self.pelican.val() & self.single_filter.val();
        self.dual.next = self.pelican.val() & (self.single_filter.val() == false);
        self.accept.next = self.filter1_id_match.q.val();
        if self.single.val() {
            self.accept.next =
                self.filter1_id_match.q.val() & self.data1_match.q.val() & self.data2_match.q.val();
        }
        if self.dual.val() {
            self.accept.next = (self.filter1_id_match.q.val() & self.data1_match.q.val())
                | self.filter2_id_match.q.val();
        }

        // ---- Reads: ACR k is read number 2k (index k), AMR k number 2k + 1 (index 4 + k).
        self.copy_wanted.next = self.running.q.val();
        self.copy_index.next =
            (self.read_number.q.val() >> 1).replace_bit(2, self.read_number.q.val().get_bit(0));
        self.arrived.d.next = false;
        if self.running.q.val() & self.copy_granted.val() {
            self.read_number.d.next = self.read_number.q.val() + 1;
            self.arrived.d.next = true;
            self.arrived_number.d.next = self.read_number.q.val();
            if self.read_number.q.val() == 7 {
                self.running.d.next = false;
            }
        }

        // ---- The frame byte of the pair that arrived, in the mode in force.
        self.pair.next = self.arrived_number.q.val().get_bits::<2>(1);
        self.id_byte1.next = self.rx_frame.id.val().get_bits::<8>(13);
        self.byte1_care.next = self.ones.val();
        if self.rx_frame.ide.val() == false {
            self.id_byte1.next = self
                .rx_frame
                .id
                .val()
                .get_bits::<8>(13)
                .replace_bit(4, self.rx_frame.rtr.val());
            self.byte1_care.next = self.standard_id_care.val();
        }
        self.id_byte3.next = (bit_cast::<8, 5>(self.rx_frame.id.val().get_bits::<5>(0)) << 3)
            | (bit_cast::<8, 1>(self.rx_frame.rtr.val().into()) << 2);
        // Header: pairs 0 and 1 take ID.28..21 and byte 1 in every mode; pairs 2 and 3 take
        // ID.12..5 and byte 3 in single filter mode, and the same two as pairs 0 and 1 in dual
        // filter mode (filter 2).
        self.operand.next = self.rx_frame.id.val().get_bits::<8>(21);
        self.care.next = self.ones.val();
        if self.pair.val().get_bit(0) {
            self.operand.next = self.id_byte1.val();
            self.care.next = self.byte1_care.val();
            if self.pair.val().get_bit(1) & self.single.val() {
                self.operand.next = self.id_byte3.val();
                self.care.next = self.extended_rtr_care.val();
            }
        } else if self.pair.val().get_bit(1) & self.single.val() {
            self.operand.next = self.rx_frame.id.val().get_bits::<8>(5);
        }
        // Data byte 1 in dual filter mode: bits 7..4 against ACR1[3:0], bits 3..0 against
        // ACR3[3:0].
        if self.data_run.q.val() {
            self.operand.next = self.data_byte.q.val();
            self.care.next = self.ones.val();
            if self.dual.val() {
                self.care.next = self.nibble_care.val();
                if self.pair.val() == 1 {
                    self.operand.next = self.data_byte.q.val() >> 4;
                }
            }
        }
        self.mismatch.next = (self.operand.val() ^ self.code.q.val())
            & (self.copy_data.val() ^ self.ones.val())
            & self.care.val();
        self.matched.next = self.mismatch.val() == 0;

        // ---- An ACR arrives: keep it; an AMR arrives: compare, and gather the result.
        if self.arrived.q.val() & (self.arrived_number.q.val().get_bit(0) == false) {
            self.code.d.next = self.copy_data.val();
        }
        if self.arrived.q.val() & self.arrived_number.q.val().get_bit(0) {
            if self.data_run.q.val() {
                if self.single.val() {
                    if (self.pair.val() == 2) & (self.second_byte.q.val() == false) {
                        self.data1_match.d.next = self.matched.val();
                    }
                    if (self.pair.val() == 3) & self.second_byte.q.val() {
                        self.data2_match.d.next = self.matched.val();
                    }
                } else if self.second_byte.q.val() == false {
                    if self.pair.val() == 1 {
                        self.data1_match.d.next = self.matched.val();
                    }
                    if self.pair.val() == 3 {
                        self.data1_match.d.next = self.data1_match.q.val() & self.matched.val();
                    }
                }
            } else if self.pair.val() == 0 {
                self.filter1_id_match.d.next = self.matched.val();
            } else if self.pair.val() == 1 {
                if self.pelican.val() {
                    self.filter1_id_match.d.next =
                        self.filter1_id_match.q.val() & self.matched.val();
                }
            } else if self.single.val() {
                // Pairs 2 and 3 of a single filter: only an extended identifier reaches them.
                if self.rx_frame.ide.val() {
                    self.filter1_id_match.d.next =
                        self.filter1_id_match.q.val() & self.matched.val();
                }
            } else if self.pair.val() == 2 {
                self.filter2_id_match.d.next = self.matched.val();
            } else {
                self.filter2_id_match.d.next = self.filter2_id_match.q.val() & self.matched.val();
            }
        }

        // ---- A run starts at the header (missing data bytes match) and at data bytes 1 and 2 of a
        // standard frame; it restarts whatever ran before.
        if self.rx_frame.header.val()
            | (self.rx_frame.strobe.val()
                & (self.rx_frame.ide.val() == false)
                & (self.rx_frame.index.val().get_bits::<2>(1) == 0))
        {
            self.running.d.next = true;
            self.read_number.d.next = 0.into();
            self.arrived.d.next = false;
            self.data_run.d.next = self.rx_frame.header.val() == false;
            self.second_byte.d.next = self.rx_frame.index.val().get_bit(0);
            self.data_byte.d.next = self.rx_frame.data.val();
        }
        if self.rx_frame.header.val() {
            self.data1_match.d.next = true;
            self.data2_match.d.next = true;
        }

        if self.reset.val() {
            self.running.d.next = false;
            self.read_number.d.next = 0.into();
            self.arrived.d.next = false;
            self.filter1_id_match.d.next = false;
            self.filter2_id_match.d.next = false;
            self.data1_match.d.next = true;
            self.data2_match.d.next = true;
        }
    }
}
