//! The receive assembler: collects the frame on the bus (identifier, IDE, RTR, DLC and data bytes)
//! as the sequencer walks its fields.
//!
//! Ports in: `field_bit` (a process point whose bit is not a stuff bit) with `rx_bit`, the
//! sequencer's `field` and `count`, the kind of an arbitration-field bit (`id_bit`, `srr_rtr_bit`,
//! `ide_bit`, `ext_rtr_bit`) and `header_done` (the last DLC bit), and `start_frame` (the bit is a SOF: identifier and
//! DLC start empty). Out, from registers only (the sequencer reads them back, and Verilator must see
//! no loop through this block): the received-frame stream `frame` (`crate::bsp::received_frame`:
//! the header one clock after the last DLC bit, then each data byte); `last_data_byte`, the index
//! of the last data byte the DLC announces. Acts on the rising edge of `clock`.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::protocol::ProtocolState;
use crate::bsp::received_frame::{ReceivedFrame, STANDARD_ID_SHIFT};
use crate::bsp::{BASE_ID_BITS, EXT_RTR_POSITION, IDE_POSITION, SRR_RTR_POSITION};

// The kernel writes these as literals (Rust constants are not Verilog): `id_extension` holds the
// 18 bits below the base identifier, and `base_id_bit` decodes positions 0..10 (base) from 13..30
// (extension), with SRR/RTR at 11 and IDE at 12 between them.
const _: () = assert!(STANDARD_ID_SHIFT == 18 && BASE_ID_BITS + STANDARD_ID_SHIFT as u64 == 29);
const _: () = assert!(
    BASE_ID_BITS == 11 && SRR_RTR_POSITION == 11 && IDE_POSITION == 12 && EXT_RTR_POSITION == 31
);

/// Received-frame assembler of the bit stream processor.
#[derive(ActivityBlock, BlockDefault)]
pub struct RxAssembler {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// A process point whose bit is a field bit (not a stuff bit).
    pub field_bit: Signal<In, Bit>,
    /// The sampled bit.
    pub rx_bit: Signal<In, Bit>,
    /// The field of the bit being processed.
    pub field: Signal<In, ProtocolState>,
    /// The bit's position in its field.
    pub count: Signal<In, Bits<7>>,
    /// The bit is a SOF.
    pub start_frame: Signal<In, Bit>,
    /// In the arbitration field: the bit is an identifier bit.
    pub id_bit: Signal<In, Bit>,
    /// In the arbitration field: the SRR (extended) or RTR (standard) bit.
    pub srr_rtr_bit: Signal<In, Bit>,
    /// In the arbitration field: the IDE bit.
    pub ide_bit: Signal<In, Bit>,
    /// In the arbitration field: the RTR bit of an extended frame.
    pub ext_rtr_bit: Signal<In, Bit>,
    /// The bit is the last DLC bit: the header is complete.
    pub header_done: Signal<In, Bit>,
    /// The received frame (header, then data bytes), from registers.
    #[interface]
    pub frame: ReceivedFrame,
    /// Index of the last data byte (DLC 9..15 count as 8; meaningless without data).
    pub last_data_byte: Signal<Out, Bits<4>>,
    /// ID.28..18, in every frame.
    id_base: DFF<Bits<11>>,
    /// ID.17..0 of an extended frame (0 in a standard frame).
    id_extension: DFF<Bits<18>>,
    ide_reg: DFF<Bit>,
    rtr_reg: DFF<Bit>,
    dlc_reg: DFF<Bits<4>>,
    byte_reg: DFF<Bits<8>>,
    header_pulse: DFF<Bit>,
    byte_pulse: DFF<Bit>,
    byte_index: DFF<Bits<3>>,
    /// Registered: DLC and RTR are settled a bit before the data field.
    last_data_byte_reg: DFF<Bits<4>>,
    data_bytes: Signal<Local, Bits<4>>,
    /// The DLC with this bit shifted in.
    dlc_after: Signal<Local, Bits<4>>,

    /// The bit is a DLC bit (after r0, and r1 in an extended frame).
    dlc_bit: Signal<Local, Bit>,
    /// The identifier bit is one of ID.28..18 (arbitration-field bits 0..10; the extension's are
    /// 13..30).
    base_id_bit: Signal<Local, Bit>,
}

impl Logic for RxAssembler {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            id_base,
            id_extension,
            ide_reg,
            rtr_reg,
            dlc_reg,
            byte_reg,
            header_pulse,
            byte_pulse,
            byte_index,
            last_data_byte_reg
        );
        self.frame.id.next = (bit_cast::<29, 11>(self.id_base.q.val()) << 18)
            | bit_cast::<29, 18>(self.id_extension.q.val());
        self.frame.ide.next = self.ide_reg.q.val();
        self.frame.rtr.next = self.rtr_reg.q.val();
        self.frame.dlc.next = self.dlc_reg.q.val();
        self.frame.header.next = self.header_pulse.q.val();
        self.frame.data.next = self.byte_reg.q.val();
        self.frame.index.next = self.byte_index.q.val();
        self.frame.strobe.next = self.byte_pulse.q.val();
        self.last_data_byte.next = self.last_data_byte_reg.q.val();
        self.header_pulse.d.next = false;
        self.byte_pulse.d.next = false;

        // Data length: DLC 9..15 mean 8 bytes, a remote frame has none.
        self.data_bytes.next = self.dlc_reg.q.val();
        if self.dlc_reg.q.val().get_bit(3) {
            self.data_bytes.next = 8.into();
        }
        if self.rtr_reg.q.val() {
            self.data_bytes.next = 0.into();
        }
        self.last_data_byte_reg.d.next = self.data_bytes.val() - 1;
        // DLC shifted left with the bus bit in: wiring, where `x + x` would be an adder.
        self.dlc_after.next = self
            .dlc_reg
            .q
            .val()
            .replace_bit(3, self.dlc_reg.q.val().get_bit(2))
            .replace_bit(2, self.dlc_reg.q.val().get_bit(1))
            .replace_bit(1, self.dlc_reg.q.val().get_bit(0))
            .replace_bit(0, self.rx_bit.val());

        // DLC bits: after r0, and r1 in an extended frame.
        self.dlc_bit.next =
            (self.count.val() != 0) & !((self.count.val() == 1) & self.ide_reg.q.val());

        // Among the identifier positions (0..10, 13..30), 0..10 are those below 16 without both
        // bits 3 and 2 (12..15).
        self.base_id_bit.next = (self.count.val().get_bit(4) == false)
            & !(self.count.val().get_bit(3) & self.count.val().get_bit(2));

        if self.field_bit.val() {
            if self.field.val() == ProtocolState::Arbitration {
                if self.id_bit.val() {
                    if self.base_id_bit.val() {
                        self.id_base.d.next =
                            (self.id_base.q.val() << 1).replace_bit(0, self.rx_bit.val());
                    } else {
                        self.id_extension.d.next =
                            (self.id_extension.q.val() << 1).replace_bit(0, self.rx_bit.val());
                    }
                }
                if self.srr_rtr_bit.val() {
                    self.rtr_reg.d.next = self.rx_bit.val();
                }
                if self.ide_bit.val() {
                    self.ide_reg.d.next = self.rx_bit.val();
                }
                if self.ext_rtr_bit.val() {
                    self.rtr_reg.d.next = self.rx_bit.val();
                }
            }
            if self.field.val() == ProtocolState::Control {
                if self.dlc_bit.val() {
                    self.dlc_reg.d.next = self.dlc_after.val();
                }
                self.header_pulse.d.next = self.header_done.val();
            }
            if self.field.val() == ProtocolState::Data {
                self.byte_reg.d.next =
                    (self.byte_reg.q.val() << 1).replace_bit(0, self.rx_bit.val());
                if self.count.val().get_bits::<3>(0) == 7 {
                    self.byte_pulse.d.next = true;
                    self.byte_index.d.next = self.count.val().get_bits::<3>(3);
                }
            }
        }
        if self.start_frame.val() {
            self.id_base.d.next = 0.into();
            self.id_extension.d.next = 0.into();
            self.dlc_reg.d.next = 0.into();
        }
        if self.reset.val() {
            self.id_base.d.next = 0.into();
            self.id_extension.d.next = 0.into();
            self.ide_reg.d.next = false;
            self.rtr_reg.d.next = false;
            self.dlc_reg.d.next = 0.into();
            self.byte_reg.d.next = 0.into();
            self.header_pulse.d.next = false;
            self.byte_pulse.d.next = false;
            self.byte_index.d.next = 0.into();
            self.last_data_byte_reg.d.next = 0.into();
        }
    }
}
