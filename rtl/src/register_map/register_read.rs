//! The host's read side: SR and IR as the host sees them, the read multiplexer of both maps, the
//! registered read data, the FIFO's host address and the interrupt line.
//!
//! Ports in: the host bus `addr`, `re`; the host decoder's windows and indices; the registers and
//! states it shows (mode bits, CDR and CR.6 from the mode block; IER, IR, ALC, ECC, ES and the
//! BasicCAN RI latch from the interrupt block; EWLR; `readback_selected`, the configuration and
//! acceptance filter registers read from their copies in the TX buffer's RAM; TBS/TCS; the core's
//! counters and states; the FIFO's count, start, overrun, head message information and RAM read
//! data; the TX buffer's read data). Every input
//! comes straight from a port, a flip-flop or another block's output, so the controller may use the
//! combinational outputs `enables`, `irq_pending`, `fifo_address` and `fifo_read` without a
//! Verilator loop (docs/VERILOG.md). `rdata` is registered: valid from the edge after the `re`
//! cycle until the next read; RAM and TX buffer reads come out of their read registers that cycle
//! and are held in `rdata_reg` from the next. Acts on the rising edge of `clock`.
//!
//! Rules (SJA1000 data sheet, register tables): in PeliCAN the frame window reads the head message
//! of the RX FIFO in operating mode (ACR/AMR in reset mode, from the filter); in BasicCAN CMR reads
//! 0xFF, IR bits 7..5 read 1, CR bit 5 reads 1, ACR, AMR, BTR0, BTR1 and OCR read 0xFF in operating
//! mode, and RX buffer byte 21 adds the DLC to ID.2..0 and RTR. RI is the level RBS & RIE in PeliCAN
//! and the RI latch & RBS & RIE in BasicCAN.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::protocol::ProtocolState;
use crate::register_map::InterruptRegistersIn;
use crate::registers::{basic, pelican};

/// The read multiplexer, SR, IR and the interrupt line.
#[derive(ActivityBlock, BlockDefault)]
pub struct RegisterRead {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Register address.
    pub addr: Signal<In, Bits<8>>,
    /// Read strobe.
    pub re: Signal<In, Bit>,
    /// Host decoder: PeliCAN frame window.
    pub in_frame_window: Signal<In, Bit>,
    /// Host decoder: PeliCAN RX RAM window.
    pub in_rx_ram: Signal<In, Bit>,
    /// Host decoder: PeliCAN TX RAM window.
    pub in_tx_ram: Signal<In, Bit>,
    /// Host decoder: BasicCAN TX buffer.
    pub in_basic_tx: Signal<In, Bit>,
    /// Host decoder: BasicCAN RX buffer.
    pub in_basic_rx: Signal<In, Bit>,
    /// Host decoder: BasicCAN ACR..OCR.
    pub in_basic_config: Signal<In, Bit>,
    /// Host decoder: index in the frame window.
    pub frame_index: Signal<In, Bits<4>>,
    /// Host decoder: index in the BasicCAN RX buffer (as a FIFO message byte).
    pub basic_rx_index: Signal<In, Bits<4>>,
    /// Host decoder: index in the RX RAM window.
    pub rx_ram_index: Signal<In, Bits<6>>,
    /// The PeliCAN map.
    pub pelican: Signal<In, Bit>,
    /// MOD.RM.
    pub reset_mode: Signal<In, Bit>,
    /// MOD.LOM.
    pub listen_only: Signal<In, Bit>,
    /// MOD.STM.
    pub self_test: Signal<In, Bit>,
    /// MOD.AFM.
    pub single_filter: Signal<In, Bit>,
    /// MOD.SM.
    pub sleep: Signal<In, Bit>,
    /// CR bit 6.
    pub cr6: Signal<In, Bit>,
    /// CDR.
    pub cdr: Signal<In, Bits<8>>,
    /// The interrupt block's registers.
    #[interface]
    pub interrupts: InterruptRegistersIn,
    /// SR.TBS.
    pub tbs: Signal<In, Bit>,
    /// SR.TCS.
    pub tcs: Signal<In, Bit>,
    /// Transmit error counter.
    pub tec: Signal<In, Bits<8>>,
    /// Receive error counter.
    pub rec: Signal<In, Bits<8>>,
    /// Bus-off.
    pub bus_off: Signal<In, Bit>,
    /// The core receives a frame.
    pub receiving: Signal<In, Bit>,
    /// The core transmits a frame.
    pub transmitting: Signal<In, Bit>,
    /// The core's state.
    pub state: Signal<In, ProtocolState>,
    /// Messages in the RX FIFO.
    pub message_count: Signal<In, Bits<5>>,
    /// The RX FIFO overran.
    pub overrun: Signal<In, Bit>,
    /// RBSA: the head message's start address.
    pub start: Signal<In, Bits<6>>,
    /// The head message's frame information byte.
    pub head_info: Signal<In, Bits<8>>,
    /// The FIFO RAM's read data.
    pub fifo_data: Signal<In, Bits<8>>,
    /// The TX buffer's read data.
    pub tx_data: Signal<In, Bits<8>>,
    /// EWLR.
    pub ewlr: Signal<In, Bits<8>>,
    /// `addr` is a register read from its copy in the TX buffer's RAM (ACR/AMR, BTR0, BTR1, OCR;
    /// the controller points the TX buffer's host index at it).
    pub readback_selected: Signal<In, Bit>,
    /// Read data.
    pub rdata: Signal<Out, Bits<8>>,
    /// The interrupt enables in force: IER; CR.4..1 and WUI in BasicCAN.
    pub enables: Signal<Out, Bits<8>>,
    /// IR & enables != 0.
    pub irq_pending: Signal<Out, Bit>,
    /// The FIFO RAM address of this access.
    pub fifo_address: Signal<Out, Bits<6>>,
    /// An access at `addr` reads the FIFO RAM (with `re`).
    pub fifo_read: Signal<Out, Bit>,
    rdata_reg: DFF<Bits<8>>,
    rdata_from_ram: DFF<Bit>,
    rdata_from_tx: DFF<Bit>,
    rdata_ram_or: DFF<Bits<8>>,
    tx_read: Signal<Local, Bit>,
    rbs: Signal<Local, Bit>,
    waiting_for_bus: Signal<Local, Bit>,
    status: Signal<Local, Bits<8>>,
    ir_value: Signal<Local, Bits<8>>,
    read_value: Signal<Local, Bits<8>>,
    ram_or: Signal<Local, Bits<8>>,
    ram_read_index: Signal<Local, Bits<4>>,
    ram_data: Signal<Local, Bits<8>>,
    #[constant(u64::from(pelican::MOD))]
    mod_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::CMR))]
    cmr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::SR))]
    sr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::IR))]
    ir_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::IER))]
    ier_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::ALC))]
    alc_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::ECC))]
    ecc_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::EWLR))]
    ewlr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::RXERR))]
    rxerr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::TXERR))]
    txerr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::RMC))]
    rmc_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::RBSA))]
    rbsa_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::CDR))]
    cdr_address: Constant<Bits<8>>,
    #[constant(u64::from(basic::RX_ID_DLC))]
    rx_id_dlc_address: Constant<Bits<8>>,
    #[constant(0u64)]
    zero_byte: Constant<Bits<8>>,
    #[constant(0xFFu64)]
    all_ones: Constant<Bits<8>>,
}

impl Logic for RegisterRead {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            rdata_reg,
            rdata_from_ram,
            rdata_from_tx,
            rdata_ram_or
        );

        // ---- Status.
        self.rbs.next = self.message_count.val() != 0;
        self.waiting_for_bus.next = (self.state.val() == ProtocolState::Integrating)
            | (self.state.val() == ProtocolState::BusOff);
        self.status.next = self
            .zero_byte
            .val()
            .replace_bit(0, self.rbs.val())
            .replace_bit(1, self.overrun.val())
            .replace_bit(2, self.tbs.val())
            .replace_bit(3, self.tcs.val())
            .replace_bit(4, self.receiving.val() | self.waiting_for_bus.val())
            .replace_bit(5, self.transmitting.val() | self.waiting_for_bus.val())
            .replace_bit(6, self.interrupts.es.val())
            .replace_bit(7, self.bus_off.val());

        // ---- Interrupts in force: RI is a level of RBS (and of the RI latch in BasicCAN).
        self.enables.next = self.interrupts.ier.val();
        self.ir_value.next = self
            .interrupts
            .ir
            .val()
            .replace_bit(0, self.rbs.val() & self.interrupts.ier.val().get_bit(0));
        if self.pelican.val() == false {
            self.enables.next =
                bit_cast::<8, 4>(bit_cast::<4, 8>(self.interrupts.ier.val())).replace_bit(4, true);
            self.ir_value.next = self.interrupts.ir.val().replace_bit(
                0,
                self.interrupts.basic_ri.val()
                    & self.rbs.val()
                    & self.interrupts.ier.val().get_bit(0),
            );
        }
        self.irq_pending.next = (self.ir_value.val() & self.enables.val()).any();

        // ---- The read multiplexer.
        self.read_value.next = 0.into();
        self.fifo_read.next = false;
        self.tx_read.next = false;
        self.ram_or.next = 0.into();
        if self.addr.val() == self.sr_address.val() {
            self.read_value.next = self.status.val();
        }
        if self.addr.val() == self.ir_address.val() {
            self.read_value.next = self.ir_value.val();
        }
        if self.addr.val() == self.cdr_address.val() {
            self.read_value.next = self.cdr.val();
        }
        if self.pelican.val() {
            if self.addr.val() == self.mod_address.val() {
                self.read_value.next = self
                    .zero_byte
                    .val()
                    .replace_bit(0, self.reset_mode.val())
                    .replace_bit(1, self.listen_only.val())
                    .replace_bit(2, self.self_test.val())
                    .replace_bit(3, self.single_filter.val())
                    .replace_bit(4, self.sleep.val());
            }
            if self.addr.val() == self.ier_address.val() {
                self.read_value.next = self.interrupts.ier.val();
            }
            if self.addr.val() == self.alc_address.val() {
                self.read_value.next = bit_cast::<8, 5>(self.interrupts.alc.val());
            }
            if self.addr.val() == self.ecc_address.val() {
                self.read_value.next = self.interrupts.ecc.val();
            }
            if self.addr.val() == self.ewlr_address.val() {
                self.read_value.next = self.ewlr.val();
            }
            if self.addr.val() == self.rxerr_address.val() {
                self.read_value.next = self.rec.val();
            }
            if self.addr.val() == self.txerr_address.val() {
                self.read_value.next = self.tec.val();
            }
            if self.addr.val() == self.rmc_address.val() {
                self.read_value.next = bit_cast::<8, 5>(self.message_count.val());
            }
            if self.addr.val() == self.rbsa_address.val() {
                self.read_value.next = bit_cast::<8, 6>(self.start.val());
            }
            // The frame window reads the head message of the RX FIFO in operating mode.
            self.fifo_read.next = (self.in_frame_window.val() & (self.reset_mode.val() == false))
                | self.in_rx_ram.val();
            self.tx_read.next = self.in_tx_ram.val() | self.readback_selected.val();
        } else {
            if self.addr.val() == self.mod_address.val() {
                self.read_value.next = self
                    .zero_byte
                    .val()
                    .replace_bit(0, self.reset_mode.val())
                    .replace_bit(1, self.interrupts.ier.val().get_bit(0))
                    .replace_bit(2, self.interrupts.ier.val().get_bit(1))
                    .replace_bit(3, self.interrupts.ier.val().get_bit(2))
                    .replace_bit(4, self.interrupts.ier.val().get_bit(3))
                    .replace_bit(5, true)
                    .replace_bit(6, self.cr6.val());
            }
            if self.addr.val() == self.cmr_address.val() {
                self.read_value.next = self.all_ones.val();
            }
            if self.addr.val() == self.ir_address.val() {
                self.read_value.next = self
                    .ir_value
                    .val()
                    .replace_bit(5, true)
                    .replace_bit(6, true)
                    .replace_bit(7, true);
            }
            if (self.reset_mode.val() == false) & self.in_basic_config.val() {
                self.read_value.next = self.all_ones.val();
            }
            // ACR, AMR, BTR0, BTR1 and OCR read 0xFF in operating mode (above).
            self.tx_read.next =
                self.in_basic_tx.val() | (self.readback_selected.val() & self.reset_mode.val());
            self.fifo_read.next = self.in_basic_rx.val();
            if self.addr.val() == self.rx_id_dlc_address.val() {
                self.ram_or.next = bit_cast::<8, 4>(bit_cast::<4, 8>(self.head_info.val()));
            }
        }

        // ---- The FIFO address: the RAM windows' 4-bit indices are whole offsets (the windows are
        // shorter than 16 bytes); one adder: BasicCAN byte 20 is FIFO message byte 1.
        self.ram_read_index.next = self.frame_index.val();
        if self.in_basic_rx.val() {
            self.ram_read_index.next = self.basic_rx_index.val();
        }
        self.fifo_address.next = self.start.val() + bit_cast::<6, 4>(self.ram_read_index.val());
        if self.in_rx_ram.val() {
            self.fifo_address.next = self.rx_ram_index.val();
        }

        // ---- Read data: RAM and TX buffer reads are copied into `rdata_reg` the cycle after, so
        // the read ports are free again and `rdata` holds until the next read.
        self.ram_data.next = self.fifo_data.val() | self.rdata_ram_or.q.val();
        self.rdata.next = self.rdata_reg.q.val();
        if self.rdata_from_ram.q.val() {
            self.rdata.next = self.ram_data.val();
            self.rdata_reg.d.next = self.ram_data.val();
            self.rdata_from_ram.d.next = false;
        }
        if self.rdata_from_tx.q.val() {
            self.rdata.next = self.tx_data.val();
            self.rdata_reg.d.next = self.tx_data.val();
            self.rdata_from_tx.d.next = false;
        }
        if self.re.val() {
            self.rdata_reg.d.next = self.read_value.val();
            self.rdata_from_ram.d.next = self.fifo_read.val();
            self.rdata_from_tx.d.next = self.tx_read.val();
            self.rdata_ram_or.d.next = self.ram_or.val();
        }

        if self.reset.val() {
            self.rdata_reg.d.next = 0.into();
            self.rdata_from_ram.d.next = false;
            self.rdata_from_tx.d.next = false;
            self.rdata_ram_or.d.next = 0.into();
        }
    }
}
