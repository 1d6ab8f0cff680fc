//! The SJA1000-compatible CAN controller: the top block with the host port contract of the project's
//! `docs/SJA1000.md`, and the register map (PeliCAN and BasicCAN, selected by CDR.7) that ties the
//! protocol core, the transmit buffer, the acceptance filter, the receive FIFO and the CLKOUT divider
//! together.
//!
//! Ports: `clock`; `reset` (synchronous, active high: afterwards as after a hardware reset); the host
//! bus `addr`, `wdata`, `we`, `re` (one-cycle strobes, never together) and `rdata` (registered: valid
//! from the edge after the `re` cycle until the next read); the bus pins `rx`, `tx` (registered);
//! `irq_n` (low while IR & IER != 0) and `clkout`. Everything acts on the rising edge of `clock`:
//! writes and read side effects (IR clear, ALC/ECC re-arm) take effect at the edge that ends the
//! strobe cycle.
//!
//! Register behaviour follows the data sheet as summarised in `docs/SJA1000.md`: writes per mode
//! (old MOD.RM decides), commands (TR, AT, RRB, CDO, SRR, single shot), status bits, interrupt set
//! and clear conditions, capture-until-read of ALC and ECC, counter writes, reset mode, listen-only,
//! self-test, sleep and wake-up.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};

use crate::acceptance_filter::AcceptanceFilter;
use crate::bsp::protocol::ProtocolState;
use crate::can_core::CanCore;
use crate::clock_divider::ClockDivider;
use crate::registers::{basic, pelican, DEFAULT_EWLR};
use crate::rx_fifo::RxFifo;
use crate::tx_buffer::TxBuffer;

/// The complete controller.
#[derive(ActivityBlock, BlockDefault)]
pub struct CanController {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock (the SJA1000 fosc).
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// Register address.
    pub addr: Signal<In, Bits<8>>,
    /// Write data.
    pub wdata: Signal<In, Bits<8>>,
    /// Write strobe.
    pub we: Signal<In, Bit>,
    /// Read strobe.
    pub re: Signal<In, Bit>,
    /// Read data.
    pub rdata: Signal<Out, Bits<8>>,
    /// Bus input (from the transceiver).
    pub rx: Signal<In, Bit>,
    /// Bus output (to the transceiver), registered.
    pub tx: Signal<Out, Bit>,
    /// Interrupt, active low.
    pub irq_n: Signal<Out, Bit>,
    /// Clock output.
    pub clkout: Signal<Out, Bit>,
    /// The protocol core (bit timing logic and bit stream processor).
    pub core: CanCore,
    /// The receive FIFO.
    pub fifo: RxFifo,
    tx_buffer: TxBuffer,
    filter: AcceptanceFilter,
    divider: ClockDivider,
    // ---- Registers.
    mode_rm: DFF<Bit>,
    mode_lom: DFF<Bit>,
    mode_stm: DFF<Bit>,
    mode_afm: DFF<Bit>,
    mode_sm: DFF<Bit>,
    ier: DFF<Bits<8>>,
    ir: DFF<Bits<8>>,
    btr0: DFF<Bits<8>>,
    btr1: DFF<Bits<8>>,
    sjw: DFF<Bits<2>>,
    tseg2: DFF<Bits<3>>,
    ocr: DFF<Bits<8>>,
    ewlr: DFF<Bits<8>>,
    cdr: DFF<Bits<8>>,
    alc: DFF<Bits<5>>,
    alc_armed: DFF<Bit>,
    ecc: DFF<Bits<8>>,
    ecc_armed: DFF<Bit>,
    // ---- Transmission and status state.
    tx_pending: DFF<Bit>,
    tx_single_shot: DFF<Bit>,
    self_reception: DFF<Bit>,
    tcs: DFF<Bit>,
    tbs: DFF<Bit>,
    es: DFF<Bit>,
    bus_off_before: DFF<Bit>,
    passive_before: DFF<Bit>,
    overrun_before: DFF<Bit>,
    rbs_before: DFF<Bit>,
    basic_ri: DFF<Bit>,
    basic_cr6: DFF<Bit>,
    sleep_bits: DFF<Bits<5>>,
    // ---- The core's mode inputs, registered from the values the mode flip-flops load (so equal to
    // what they were computed from in every cycle): they start the engine's longest paths.
    core_enable: DFF<Bit>,
    core_listen_only: DFF<Bit>,
    core_self_test: DFF<Bit>,
    // ---- Read data path.
    rdata_reg: DFF<Bits<8>>,
    rdata_from_ram: DFF<Bit>,
    rdata_from_tx: DFF<Bit>,
    rdata_ram_or: DFF<Bits<8>>,
    // ---- Addresses (from `crate::registers`).
    #[constant(u64::from(pelican::MOD))]
    pc_mod: Constant<Bits<8>>,
    #[constant(u64::from(pelican::CMR))]
    pc_cmr: Constant<Bits<8>>,
    #[constant(u64::from(pelican::SR))]
    pc_sr: Constant<Bits<8>>,
    #[constant(u64::from(pelican::IR))]
    pc_ir: Constant<Bits<8>>,
    #[constant(u64::from(pelican::IER))]
    pc_ier: Constant<Bits<8>>,
    #[constant(u64::from(pelican::BTR0))]
    pc_btr0: Constant<Bits<8>>,
    #[constant(u64::from(pelican::BTR1))]
    pc_btr1: Constant<Bits<8>>,
    #[constant(u64::from(pelican::OCR))]
    pc_ocr: Constant<Bits<8>>,
    #[constant(u64::from(pelican::ALC))]
    pc_alc: Constant<Bits<8>>,
    #[constant(u64::from(pelican::ECC))]
    pc_ecc: Constant<Bits<8>>,
    #[constant(u64::from(pelican::EWLR))]
    pc_ewlr: Constant<Bits<8>>,
    #[constant(u64::from(pelican::RXERR))]
    pc_rxerr: Constant<Bits<8>>,
    #[constant(u64::from(pelican::TXERR))]
    pc_txerr: Constant<Bits<8>>,
    #[constant(u64::from(pelican::RMC))]
    pc_rmc: Constant<Bits<8>>,
    #[constant(u64::from(pelican::RBSA))]
    pc_rbsa: Constant<Bits<8>>,
    #[constant(u64::from(pelican::CDR))]
    pc_cdr: Constant<Bits<8>>,
    #[constant(u64::from(basic::CR))]
    bc_cr: Constant<Bits<8>>,
    #[constant(u64::from(basic::RX_ID_DLC))]
    bc_rx_id_dlc: Constant<Bits<8>>,
    // ---- Address windows, as bit maps indexed by the address (`>=`/`<=` pairs would become
    // carry chains on FPGAs), and the low address bits of their first bytes.
    #[constant(window(pelican::FRAME, pelican::FRAME_LAST))]
    frame_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(pelican::RX_RAM, pelican::RX_RAM_LAST))]
    rx_ram_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(pelican::TX_RAM, pelican::TX_RAM_LAST))]
    tx_ram_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(basic::TX, basic::TX_LAST))]
    basic_tx_window: Constant<Bits<ADDRESSES>>,
    #[constant(window(basic::RX, basic::RX_LAST))]
    basic_rx_window: Constant<Bits<ADDRESSES>>,
    /// ACR, AMR, BTR0, BTR1, OCR: read 0xFF in operating mode.
    #[constant(window(basic::ACR, basic::OCR))]
    basic_config_window: Constant<Bits<ADDRESSES>>,
    #[constant(low_bits(pelican::FRAME))]
    frame_base: Constant<Bits<4>>,
    #[constant(low_bits(pelican::TX_RAM))]
    tx_ram_base: Constant<Bits<4>>,
    // The byte before each BasicCAN buffer: buffer byte 1 is the first identifier byte.
    #[constant(low_bits(basic::TX - 1))]
    basic_tx_base: Constant<Bits<4>>,
    #[constant(low_bits(basic::RX - 1))]
    basic_rx_base: Constant<Bits<4>>,
    #[constant(low_bits(pelican::RX_RAM))]
    rx_ram_base: Constant<Bits<6>>,
    #[constant(u64::from(DEFAULT_EWLR))]
    default_ewlr: Constant<Bits<8>>,
    #[constant(0u64)]
    zero_byte: Constant<Bits<8>>,
    // ---- Decoded access of this cycle.
    pelican_mode: Signal<Local, Bit>,
    reset_mode: Signal<Local, Bit>,
    // Byte indices inside the windows, computed at the width they need: the low bits of a
    // difference depend only on the low bits of its operands.
    addr_low4: Signal<Local, Bits<4>>,
    addr_low6: Signal<Local, Bits<6>>,
    frame_index: Signal<Local, Bits<4>>,
    tx_ram_index: Signal<Local, Bits<4>>,
    basic_tx_index: Signal<Local, Bits<4>>,
    basic_rx_index: Signal<Local, Bits<4>>,
    rx_ram_index: Signal<Local, Bits<6>>,
    in_frame_window: Signal<Local, Bit>,
    in_rx_ram: Signal<Local, Bit>,
    in_tx_ram: Signal<Local, Bit>,
    in_basic_tx: Signal<Local, Bit>,
    in_basic_rx: Signal<Local, Bit>,
    in_basic_config: Signal<Local, Bit>,
    ram_read_index: Signal<Local, Bits<4>>,
    command: Signal<Local, Bit>,
    cmd_transmit: Signal<Local, Bit>,
    cmd_abort: Signal<Local, Bit>,
    cmd_release: Signal<Local, Bit>,
    cmd_clear_overrun: Signal<Local, Bit>,
    cmd_self_reception: Signal<Local, Bit>,
    cmd_sleep: Signal<Local, Bit>,
    sleep_request: Signal<Local, Bit>,
    wake_request: Signal<Local, Bit>,
    entering_reset: Signal<Local, Bit>,
    read_value: Signal<Local, Bits<8>>,
    read_from_ram: Signal<Local, Bit>,
    read_from_tx: Signal<Local, Bit>,
    ram_or: Signal<Local, Bits<8>>,
    // ---- Status and interrupts of this cycle.
    enables: Signal<Local, Bits<8>>,
    rbs: Signal<Local, Bit>,
    ir_value: Signal<Local, Bits<8>>,
    ir_active: Signal<Local, Bits<8>>,
    irq_pending: Signal<Local, Bit>,
    status: Signal<Local, Bits<8>>,
    waiting_for_bus: Signal<Local, Bit>,
    /// The error warning limit in force: EWLR in PeliCAN mode, its reset value in BasicCAN mode.
    warning_limit: Signal<Local, Bits<8>>,
    /// A counter at or above `warning_limit` (SR.ES before the reset-mode freeze).
    error_warning: Signal<Local, Bit>,
    es_next: Signal<Local, Bit>,
    events: Signal<Local, Bits<8>>,
    ir_kept: Signal<Local, Bits<8>>,
    ev_transmit: Signal<Local, Bit>,
    ev_error: Signal<Local, Bit>,
    ev_overrun: Signal<Local, Bit>,
    ev_wake_up: Signal<Local, Bit>,
    ev_passive: Signal<Local, Bit>,
    ev_arbitration: Signal<Local, Bit>,
    ev_bus_error: Signal<Local, Bit>,
    own_frame_received: Signal<Local, Bit>,
    basic_receive: Signal<Local, Bit>,
}

/// Host addresses: the `addr` port is 8 bits wide.
const ADDRESSES: usize = 256;

/// The addresses from `first` to `last`, both included, as a bit map indexed by the address.
fn window(first: u8, last: u8) -> Bits<ADDRESSES> {
    let addresses = usize::from(first)..usize::from(last) + 1;
    addresses.fold(Bits::<ADDRESSES>::default(), |map, a| {
        map.replace_bit(a, true)
    })
}

/// The low `N` bits of an address.
fn low_bits<const N: usize>(value: u8) -> Bits<N> {
    ((value as u64) & ((1 << N) - 1)).into()
}

impl Logic for CanController {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            mode_rm,
            mode_lom,
            mode_stm,
            mode_afm,
            mode_sm,
            ier,
            ir,
            btr0,
            btr1,
            sjw,
            tseg2,
            ocr,
            ewlr,
            cdr,
            alc,
            alc_armed,
            ecc,
            ecc_armed,
            tx_pending,
            tx_single_shot,
            self_reception,
            tcs,
            tbs,
            es,
            bus_off_before,
            passive_before,
            overrun_before,
            rbs_before,
            basic_ri,
            basic_cr6,
            sleep_bits,
            core_enable,
            core_listen_only,
            core_self_test,
            rdata_reg,
            rdata_from_ram,
            rdata_from_tx,
            rdata_ram_or
        );
        clock!(self, clock, core, fifo, tx_buffer, filter, divider);
        self.pelican_mode.next = self.cdr.q.val().get_bit(7);
        self.reset_mode.next = self.mode_rm.q.val();

        // ---- Address decoding.
        self.addr_low4.next = bit_cast::<4, 8>(self.addr.val());
        self.addr_low6.next = bit_cast::<6, 8>(self.addr.val());
        self.frame_index.next = self.addr_low4.val() - self.frame_base.val();
        self.tx_ram_index.next = self.addr_low4.val() - self.tx_ram_base.val();
        self.basic_tx_index.next = self.addr_low4.val() - self.basic_tx_base.val();
        self.basic_rx_index.next = self.addr_low4.val() - self.basic_rx_base.val();
        self.rx_ram_index.next = self.addr_low6.val() - self.rx_ram_base.val();
        self.in_frame_window.next = self.frame_window.val().get_bit(self.addr.val().index());
        self.in_rx_ram.next = self.rx_ram_window.val().get_bit(self.addr.val().index());
        self.in_tx_ram.next = self.tx_ram_window.val().get_bit(self.addr.val().index());
        self.in_basic_tx.next = self.basic_tx_window.val().get_bit(self.addr.val().index());
        self.in_basic_rx.next = self.basic_rx_window.val().get_bit(self.addr.val().index());
        self.in_basic_config.next = self
            .basic_config_window
            .val()
            .get_bit(self.addr.val().index());
        if self.pelican_mode.val() == false {
            self.in_frame_window.next = false;
            self.in_rx_ram.next = false;
            self.in_tx_ram.next = false;
        } else {
            self.in_basic_tx.next = false;
            self.in_basic_rx.next = false;
        }

        // ---- Commands (CMR, the same address in both maps; ignored in reset mode).
        self.command.next = self.we.val()
            & (self.addr.val() == self.pc_cmr.val())
            & (self.reset_mode.val() == false);
        self.cmd_transmit.next = self.command.val() & self.wdata.val().get_bit(0);
        self.cmd_abort.next = self.command.val() & self.wdata.val().get_bit(1);
        self.cmd_release.next = self.command.val() & self.wdata.val().get_bit(2);
        self.cmd_clear_overrun.next = self.command.val() & self.wdata.val().get_bit(3);
        // TR together with SRR is a plain TR (data sheet).
        self.cmd_self_reception.next = self.command.val()
            & self.wdata.val().get_bit(4)
            & self.pelican_mode.val()
            & (self.cmd_transmit.val() == false);
        self.cmd_sleep.next = self.wdata.val().get_bit(4) & (self.pelican_mode.val() == false);

        // ---- Status.
        self.rbs.next = self.fifo.message_count.val() != 0;
        self.waiting_for_bus.next = (self.core.state.val() == ProtocolState::Integrating)
            | (self.core.state.val() == ProtocolState::BusOff);
        self.status.next = self
            .zero_byte
            .val()
            .replace_bit(0, self.rbs.val())
            .replace_bit(1, self.fifo.overrun.val())
            .replace_bit(2, self.tbs.q.val())
            .replace_bit(3, self.tcs.q.val())
            .replace_bit(4, self.core.receiving.val() | self.waiting_for_bus.val())
            .replace_bit(5, self.core.transmitting.val() | self.waiting_for_bus.val())
            .replace_bit(6, self.es.q.val())
            .replace_bit(7, self.core.bus_off.val());

        // ---- Interrupt enables: IER in PeliCAN; CR.4..1 (RIE, TIE, EIE, OIE) and WUI in BasicCAN.
        self.enables.next = self.ier.q.val();
        if self.pelican_mode.val() == false {
            self.enables.next =
                bit_cast::<8, 4>(bit_cast::<4, 8>(self.ier.q.val())).replace_bit(4, true);
        }
        // RI: in PeliCAN the level RBS & RIE; in BasicCAN a latch set when a message becomes
        // available (RBS rises, or RRB leaves another one) and cleared by reading IR.
        self.ir_value.next = self
            .ir
            .q
            .val()
            .replace_bit(0, self.rbs.val() & self.enables.val().get_bit(0));
        if self.pelican_mode.val() == false {
            self.ir_value.next = self.ir.q.val().replace_bit(
                0,
                self.basic_ri.q.val() & self.rbs.val() & self.enables.val().get_bit(0),
            );
        }
        self.ir_active.next = self.ir_value.val() & self.enables.val();
        self.irq_pending.next = self.ir_active.val().any();
        self.irq_n.next = self.irq_pending.val() == false;

        // ---- Mode register / control register and sleep.
        self.sleep_request.next = false;
        self.wake_request.next = false;
        self.entering_reset.next = false;
        if self.we.val() & (self.addr.val() == self.pc_mod.val()) {
            self.mode_rm.d.next = self.wdata.val().get_bit(0);
            self.entering_reset.next =
                self.wdata.val().get_bit(0) & (self.reset_mode.val() == false);
            if self.pelican_mode.val() {
                // The old RM decides: LOM, STM and AFM change only in reset mode, SM only outside it.
                if self.reset_mode.val() {
                    self.mode_lom.d.next = self.wdata.val().get_bit(1);
                    self.mode_stm.d.next = self.wdata.val().get_bit(2);
                    self.mode_afm.d.next = self.wdata.val().get_bit(3);
                } else {
                    self.sleep_request.next =
                        self.wdata.val().get_bit(4) & (self.wdata.val().get_bit(0) == false);
                    self.wake_request.next = self.wdata.val().get_bit(4) == false;
                }
            } else {
                // BasicCAN control register: RIE, TIE, EIE, OIE in bits 1..4; bit 6 is plain storage.
                self.basic_cr6.d.next = self.wdata.val().get_bit(6);
                self.ier.d.next = bit_cast::<8, 4>(self.wdata.val().get_bits::<4>(1))
                    .replace_bit(4, self.ier.q.val().get_bit(4))
                    .replace_bit(5, self.ier.q.val().get_bit(5))
                    .replace_bit(6, self.ier.q.val().get_bit(6))
                    .replace_bit(7, self.ier.q.val().get_bit(7));
            }
        }
        if self.command.val() & (self.pelican_mode.val() == false) {
            self.sleep_request.next = self.cmd_sleep.val();
            self.wake_request.next = self.cmd_sleep.val() == false;
        }
        self.ev_wake_up.next = false;
        if self.sleep_request.val() & (self.mode_sm.q.val() == false) {
            // Sleep needs an idle bus and no pending interrupt; otherwise the attempt wakes at once.
            if (self.core.state.val() == ProtocolState::Idle) & (self.irq_pending.val() == false) {
                self.mode_sm.d.next = true;
            } else {
                self.ev_wake_up.next = true;
            }
        }
        if self.mode_sm.q.val() & (self.wake_request.val() | (self.rx.val() == false)) {
            self.mode_sm.d.next = false;
            self.ev_wake_up.next = true;
        }

        // ---- Configuration registers (reset mode only, but IER and CDR.2..0).
        if self.we.val() {
            if self.pelican_mode.val() & (self.addr.val() == self.pc_ier.val()) {
                self.ier.d.next = self.wdata.val();
            }
            if self.addr.val() == self.pc_cdr.val() {
                self.cdr.d.next = bit_cast::<8, 3>(bit_cast::<3, 8>(self.wdata.val()))
                    .replace_bit(3, self.cdr.q.val().get_bit(3))
                    .replace_bit(5, self.cdr.q.val().get_bit(5))
                    .replace_bit(6, self.cdr.q.val().get_bit(6))
                    .replace_bit(7, self.cdr.q.val().get_bit(7));
                if self.reset_mode.val() {
                    self.cdr.d.next = self.wdata.val().replace_bit(4, false);
                }
            }
            if self.reset_mode.val() {
                // SJW and TSEG2 are kept apart too: slicing them out of BTR0/BTR1 on every
                // simulated cycle is costly in rust-hdl.
                if self.addr.val() == self.pc_btr0.val() {
                    self.btr0.d.next = self.wdata.val();
                    self.sjw.d.next = self.wdata.val().get_bits::<2>(6);
                }
                if self.addr.val() == self.pc_btr1.val() {
                    self.btr1.d.next = self.wdata.val();
                    self.tseg2.d.next = self.wdata.val().get_bits::<3>(4);
                }
                if self.addr.val() == self.pc_ocr.val() {
                    self.ocr.d.next = self.wdata.val();
                }
                if self.pelican_mode.val() & (self.addr.val() == self.pc_ewlr.val()) {
                    self.ewlr.d.next = self.wdata.val();
                }
            }
        }
        // Counter writes (reset mode): the core applies the TXERR/RXERR rules.
        self.core.counter_value.next = self.wdata.val();
        self.core.load_tec.next = self.we.val()
            & self.reset_mode.val()
            & self.pelican_mode.val()
            & (self.addr.val() == self.pc_txerr.val());
        self.core.load_rec.next = self.we.val()
            & self.reset_mode.val()
            & self.pelican_mode.val()
            & (self.addr.val() == self.pc_rxerr.val());
        // RBSA write (reset mode): the FIFO is empty then.
        self.fifo.load_start.next = self.we.val()
            & self.reset_mode.val()
            & self.pelican_mode.val()
            & (self.addr.val() == self.pc_rbsa.val());
        self.fifo.start_address.next = bit_cast::<6, 8>(self.wdata.val());

        // ---- Transmit buffer: written in operating mode while it is free (TBS).
        // Child inputs that feed combinational outputs read back here come straight from
        // flip-flops, not from locals such as `pelican_mode`: see docs/RUST_HDL.md (Verilator loops).
        self.tx_buffer.basic_layout.next = self.cdr.q.val().get_bit(7) == false;
        self.tx_buffer.write.next = self.we.val()
            & (self.reset_mode.val() == false)
            & self.tbs.q.val()
            & (self.in_frame_window.val() | self.in_basic_tx.val());
        self.tx_buffer.write_index.next = self.frame_index.val();
        // The TX RAM window is writable in reset mode.
        if self.we.val() & self.reset_mode.val() & self.in_tx_ram.val() {
            self.tx_buffer.write.next = true;
            self.tx_buffer.write_index.next = self.tx_ram_index.val();
        }
        self.tx_buffer.host_index.next = self.tx_ram_index.val();
        if self.pelican_mode.val() == false {
            // BasicCAN byte 10 is buffer byte 1 (identifier bits 10..3).
            self.tx_buffer.write_index.next = self.basic_tx_index.val();
            self.tx_buffer.host_index.next = self.basic_tx_index.val();
        }
        self.tx_buffer.write_data.next = self.wdata.val();
        self.tx_buffer.core_index.next = self.core.tx_addr.val();

        // ---- Transmission requests and their end.
        self.ev_transmit.next = false;
        self.core.tx_abort.next = self.cmd_abort.val()
            & (self.cmd_transmit.val() == false)
            & (self.cmd_self_reception.val() == false)
            & self.tx_pending.q.val();
        if self.core.tx_done.val() {
            self.tx_pending.d.next = false;
            self.tbs.d.next = true;
            self.tcs.d.next = self.core.tx_success.val();
            self.ev_transmit.next = true;
        }
        if (self.cmd_transmit.val() | self.cmd_self_reception.val())
            & self.tbs.q.val()
            & (self.tx_pending.q.val() == false)
        {
            self.tx_pending.d.next = true;
            self.tbs.d.next = false;
            self.tcs.d.next = false;
            self.tx_single_shot.d.next = self.cmd_abort.val();
            self.self_reception.d.next = self.cmd_self_reception.val();
        }

        // ---- Receive FIFO: store valid accepted frames (own ones with self-reception).
        self.own_frame_received.next =
            self.core.tx_done.val() & self.core.tx_success.val() & self.self_reception.q.val();
        self.fifo.store.next = (self.core.rx_valid.val() | self.own_frame_received.val())
            & self.filter.accept.val()
            & (self.pelican_mode.val() | (self.core.rx_ide.val() == false));
        self.fifo.release_head.next = self.cmd_release.val();
        self.fifo.clear_overrun.next = self.cmd_clear_overrun.val();
        self.fifo.clear.next = self.reset_mode.val();
        self.fifo.header.next = self.core.rx_header.val();
        self.fifo.id.next = self.core.rx_id.val();
        self.fifo.ide.next = self.core.rx_ide.val();
        self.fifo.rtr.next = self.core.rx_rtr.val();
        self.fifo.dlc.next = self.core.rx_dlc.val();
        self.fifo.byte_strobe.next = self.core.rx_byte_strobe.val();
        self.fifo.data_byte.next = self.core.rx_byte.val();
        self.fifo.byte_index.next = self.core.rx_byte_index.val();
        self.fifo.reset.next = self.reset.val();
        self.tx_buffer.reset.next = self.reset.val();

        // ---- Acceptance filter.
        self.filter.reset.next = self.reset.val();
        self.filter.pelican.next = self.cdr.q.val().get_bit(7);
        self.filter.single_filter.next = self.mode_afm.q.val();
        self.filter.reset_mode.next = self.mode_rm.q.val();
        self.filter.addr.next = self.addr.val();
        self.filter.we.next = self.we.val();
        self.filter.wdata.next = self.wdata.val();
        self.filter.rx_header.next = self.core.rx_header.val();
        self.filter.rx_id.next = self.core.rx_id.val();
        self.filter.rx_ide.next = self.core.rx_ide.val();
        self.filter.rx_rtr.next = self.core.rx_rtr.val();
        self.filter.rx_byte_strobe.next = self.core.rx_byte_strobe.val();
        self.filter.rx_byte.next = self.core.rx_byte.val();
        self.filter.rx_byte_index.next = self.core.rx_byte_index.val();

        // ---- Captures: ALC and ECC hold their value until read.
        self.ev_arbitration.next = false;
        self.ev_bus_error.next = false;
        if self.core.arbitration_lost.val() & self.alc_armed.q.val() {
            self.alc.d.next = self.core.alc.val();
            self.alc_armed.d.next = false;
            self.ev_arbitration.next = true;
        }
        if self.core.bus_error.val() & self.ecc_armed.q.val() {
            self.ecc.d.next = self.core.ecc.val();
            self.ecc_armed.d.next = false;
            self.ev_bus_error.next = true;
        }

        // ---- Error status, bus-off and error passive changes. A counter written in reset mode
        // changes ES and EPI only when reset mode is left (data sheet); bus-off entry and end are
        // reported by EI alone.
        self.warning_limit.next = self.ewlr.q.val();
        if self.pelican_mode.val() == false {
            self.warning_limit.next = self.default_ewlr.val();
        }
        self.error_warning.next = (self.core.tec.val() >= self.warning_limit.val())
            | (self.core.rec.val() >= self.warning_limit.val());
        self.es_next.next = self.es.q.val();
        if self.reset_mode.val() == false {
            self.es_next.next = self.error_warning.val() | self.core.bus_off.val();
        }
        self.es.d.next = self.es_next.val();
        self.bus_off_before.d.next = self.core.bus_off.val();
        self.ev_error.next = (self.es_next.val() != self.es.q.val())
            | (self.core.bus_off.val() != self.bus_off_before.q.val());
        self.ev_passive.next = false;
        if self.core.bus_off.val() {
            self.passive_before.d.next = false;
        } else if self.reset_mode.val() == false {
            self.passive_before.d.next = self.core.error_passive.val();
            self.ev_passive.next = self.core.error_passive.val() != self.passive_before.q.val();
        }
        if self.core.bus_off.val() & (self.bus_off_before.q.val() == false) {
            self.mode_rm.d.next = true;
            self.entering_reset.next = self.reset_mode.val() == false;
        }
        self.overrun_before.d.next = self.fifo.overrun.val();
        self.rbs_before.d.next = self.rbs.val();
        self.basic_receive.next = (self.rbs.val() & (self.rbs_before.q.val() == false))
            | (self.cmd_release.val()
                & (self.fifo.message_count.val() != 0)
                & (self.fifo.message_count.val() != 1));
        if self.re.val() & (self.addr.val() == self.pc_ir.val()) {
            self.basic_ri.d.next = false;
        }
        if self.basic_receive.val() {
            self.basic_ri.d.next = true;
        }
        self.ev_overrun.next = self.fifo.overrun.val() & (self.overrun_before.q.val() == false);

        // ---- Reads: registered data; IR is cleared (but RI) and ALC/ECC re-armed at the read edge.
        self.read_value.next = 0.into();
        self.read_from_ram.next = false;
        self.read_from_tx.next = false;
        self.ram_or.next = 0.into();
        // The FIFO address matters only for the windows that read or write the RAM, where the
        // 4-bit indices are the whole offsets (the windows are shorter than 16 bytes). One adder:
        // BasicCAN byte 20 is FIFO message byte 1.
        self.ram_read_index.next = self.frame_index.val();
        if self.in_basic_rx.val() {
            self.ram_read_index.next = self.basic_rx_index.val();
        }
        self.fifo.host_address.next =
            self.fifo.start.val() + bit_cast::<6, 4>(self.ram_read_index.val());
        if self.addr.val() == self.pc_sr.val() {
            self.read_value.next = self.status.val();
        }
        if self.addr.val() == self.pc_ir.val() {
            self.read_value.next = self.ir_value.val();
        }
        if self.addr.val() == self.pc_btr0.val() {
            self.read_value.next = self.btr0.q.val();
        }
        if self.addr.val() == self.pc_btr1.val() {
            self.read_value.next = self.btr1.q.val();
        }
        if self.addr.val() == self.pc_ocr.val() {
            self.read_value.next = self.ocr.q.val();
        }
        if self.addr.val() == self.pc_cdr.val() {
            self.read_value.next = self.cdr.q.val();
        }
        if self.filter.host_selected.val() {
            self.read_value.next = self.filter.host_data.val();
        }
        if self.pelican_mode.val() {
            if self.addr.val() == self.pc_mod.val() {
                self.read_value.next = self
                    .zero_byte
                    .val()
                    .replace_bit(0, self.mode_rm.q.val())
                    .replace_bit(1, self.mode_lom.q.val())
                    .replace_bit(2, self.mode_stm.q.val())
                    .replace_bit(3, self.mode_afm.q.val())
                    .replace_bit(4, self.mode_sm.q.val());
            }
            if self.addr.val() == self.pc_ier.val() {
                self.read_value.next = self.ier.q.val();
            }
            if self.addr.val() == self.pc_alc.val() {
                self.read_value.next = bit_cast::<8, 5>(self.alc.q.val());
            }
            if self.addr.val() == self.pc_ecc.val() {
                self.read_value.next = self.ecc.q.val();
            }
            if self.addr.val() == self.pc_ewlr.val() {
                self.read_value.next = self.ewlr.q.val();
            }
            if self.addr.val() == self.pc_rxerr.val() {
                self.read_value.next = self.core.rec.val();
            }
            if self.addr.val() == self.pc_txerr.val() {
                self.read_value.next = self.core.tec.val();
            }
            if self.addr.val() == self.pc_rmc.val() {
                self.read_value.next = bit_cast::<8, 5>(self.fifo.message_count.val());
            }
            if self.addr.val() == self.pc_rbsa.val() {
                self.read_value.next = bit_cast::<8, 6>(self.fifo.start.val());
            }
            if self.in_frame_window.val() & (self.reset_mode.val() == false) {
                // The head message of the RX FIFO.
                self.read_from_ram.next = true;
            }
            if self.in_rx_ram.val() {
                self.read_from_ram.next = true;
            }
            if self.in_tx_ram.val() {
                self.read_from_tx.next = true;
            }
        } else {
            if self.addr.val() == self.bc_cr.val() {
                self.read_value.next = self
                    .zero_byte
                    .val()
                    .replace_bit(0, self.mode_rm.q.val())
                    .replace_bit(1, self.ier.q.val().get_bit(0))
                    .replace_bit(2, self.ier.q.val().get_bit(1))
                    .replace_bit(3, self.ier.q.val().get_bit(2))
                    .replace_bit(4, self.ier.q.val().get_bit(3))
                    .replace_bit(5, true)
                    .replace_bit(6, self.basic_cr6.q.val());
            }
            if self.addr.val() == self.pc_cmr.val() {
                self.read_value.next = 0xFF.into();
            }
            if self.addr.val() == self.pc_ir.val() {
                // Bits 7..5 read 1.
                self.read_value.next = self
                    .ir_value
                    .val()
                    .replace_bit(5, true)
                    .replace_bit(6, true)
                    .replace_bit(7, true);
            }
            // ACR, AMR, BTR0, BTR1, OCR read 0xFF in operating mode.
            if (self.reset_mode.val() == false) & self.in_basic_config.val() {
                self.read_value.next = 0xFF.into();
            }
            if self.in_basic_tx.val() {
                self.read_from_tx.next = true;
            }
            if self.in_basic_rx.val() {
                // BasicCAN byte 21 adds the DLC to ID.2..0 and RTR.
                self.read_from_ram.next = true;
                if self.addr.val() == self.bc_rx_id_dlc.val() {
                    self.ram_or.next =
                        bit_cast::<8, 4>(bit_cast::<4, 8>(self.fifo.head_info.val()));
                }
            }
        }
        self.fifo.host_read.next = self.re.val() & self.read_from_ram.val();
        // The RAM windows are writable in reset mode.
        self.fifo.host_write.next = self.we.val() & self.reset_mode.val() & self.in_rx_ram.val();
        self.fifo.host_data.next = self.wdata.val();
        if self.in_rx_ram.val() {
            self.fifo.host_address.next = self.rx_ram_index.val();
        }
        // RAM and TX buffer reads come out of their read registers the cycle after; they are
        // copied into `rdata_reg` then, so the read ports are free again and `rdata` holds until
        // the next read.
        if self.rdata_from_ram.q.val() {
            self.rdata_reg.d.next = self.fifo.read_data.val() | self.rdata_ram_or.q.val();
            self.rdata_from_ram.d.next = false;
        }
        if self.rdata_from_tx.q.val() {
            self.rdata_reg.d.next = self.tx_buffer.host_data.val();
            self.rdata_from_tx.d.next = false;
        }
        if self.re.val() {
            self.rdata_reg.d.next = self.read_value.val();
            self.rdata_from_ram.d.next = self.read_from_ram.val();
            self.rdata_from_tx.d.next = self.read_from_tx.val();
            self.rdata_ram_or.d.next = self.ram_or.val();
            if self.pelican_mode.val() & (self.addr.val() == self.pc_alc.val()) {
                self.alc_armed.d.next = true;
            }
            if self.pelican_mode.val() & (self.addr.val() == self.pc_ecc.val()) {
                self.ecc_armed.d.next = true;
            }
        }
        self.rdata.next = self.rdata_reg.q.val();
        if self.rdata_from_ram.q.val() {
            self.rdata.next = self.fifo.read_data.val() | self.rdata_ram_or.q.val();
        }
        if self.rdata_from_tx.q.val() {
            self.rdata.next = self.tx_buffer.host_data.val();
        }

        // ---- Interrupt register: events set enabled bits; a read clears all but RI (a level).
        self.events.next = self
            .zero_byte
            .val()
            .replace_bit(1, self.ev_transmit.val())
            .replace_bit(2, self.ev_error.val())
            .replace_bit(3, self.ev_overrun.val())
            .replace_bit(4, self.ev_wake_up.val())
            .replace_bit(5, self.ev_passive.val())
            .replace_bit(6, self.ev_arbitration.val())
            .replace_bit(7, self.ev_bus_error.val());
        self.ir_kept.next = self.ir.q.val();
        if self.re.val() & (self.addr.val() == self.pc_ir.val()) {
            self.ir_kept.next = 0.into();
        }

        // ---- Reset mode: entered by RM or bus-off. The request is cancelled (TBS without TI),
        // interrupts but EI are cleared, sleep ends; the FIFO stays empty while in reset mode.
        if self.entering_reset.val() {
            self.tx_pending.d.next = false;
            self.tbs.d.next = true;
            self.mode_sm.d.next = false;
            self.ir_kept.next = self
                .zero_byte
                .val()
                .replace_bit(2, self.ir_kept.val().get_bit(2));
        }
        self.ir.d.next = self.ir_kept.val() | (self.events.val() & self.enables.val());

        // ---- The core.
        self.core.reset.next = self.reset.val();
        self.core.rx.next = self.rx.val();
        self.core.enable.next = self.core_enable.q.val();
        self.core.listen_only.next = self.core_listen_only.q.val();
        self.core.self_test.next = self.core_self_test.q.val();
        self.core.brp.next = bit_cast::<6, 8>(self.btr0.q.val());
        self.core.sjw.next = self.sjw.q.val();
        self.core.tseg1.next = bit_cast::<4, 8>(self.btr1.q.val());
        self.core.tseg2.next = self.tseg2.q.val();
        self.core.sam.next = self.btr1.q.val().get_bit(7);
        self.core.tx_request.next = self.tx_pending.q.val();
        self.core.tx_single_shot.next = self.tx_single_shot.q.val();
        self.core.tx_info.next = self.tx_buffer.info.val();
        self.core.tx_data.next = self.tx_buffer.core_data.val();
        self.tx.next = self.core.tx.val();

        // ---- CLKOUT.
        self.divider.reset.next = self.reset.val();
        self.divider.code.next = bit_cast::<3, 8>(self.cdr.q.val());
        self.divider.clock_off.next = self.cdr.q.val().get_bit(3);
        self.clkout.next = self.divider.clkout.val();
        // In sleep, CLKOUT runs on for at least 15 bit times (for a host clocked by it), then stays
        // low: 16 sample points, the first of which may end a partial bit.
        self.sleep_bits.d.next = 0.into();
        if self.mode_sm.q.val() {
            self.sleep_bits.d.next = self.sleep_bits.q.val();
            if self.core.sample_point.val() & (self.sleep_bits.q.val() != 16) {
                self.sleep_bits.d.next = self.sleep_bits.q.val() + 1;
            }
            if self.sleep_bits.q.val() == 16 {
                self.clkout.next = false;
            }
        }

        // ---- Hardware reset.
        if self.reset.val() {
            self.mode_rm.d.next = true;
            self.mode_lom.d.next = false;
            self.mode_stm.d.next = false;
            self.mode_afm.d.next = false;
            self.mode_sm.d.next = false;
            self.ier.d.next = 0.into();
            self.ir.d.next = 0.into();
            self.btr0.d.next = 0.into();
            self.btr1.d.next = 0.into();
            self.sjw.d.next = 0.into();
            self.tseg2.d.next = 0.into();
            self.ocr.d.next = 0.into();
            self.ewlr.d.next = self.default_ewlr.val();
            self.cdr.d.next = 0.into();
            self.alc.d.next = 0.into();
            self.alc_armed.d.next = true;
            self.ecc.d.next = 0.into();
            self.ecc_armed.d.next = true;
            self.tx_pending.d.next = false;
            self.tx_single_shot.d.next = false;
            self.self_reception.d.next = false;
            self.tcs.d.next = true;
            self.tbs.d.next = true;
            self.es.d.next = false;
            self.bus_off_before.d.next = false;
            self.passive_before.d.next = false;
            self.overrun_before.d.next = false;
            self.rbs_before.d.next = false;
            self.basic_ri.d.next = false;
            self.basic_cr6.d.next = false;
            self.sleep_bits.d.next = 0.into();
            self.rdata_reg.d.next = 0.into();
            self.rdata_from_ram.d.next = false;
            self.rdata_from_tx.d.next = false;
            self.rdata_ram_or.d.next = 0.into();
        }
        // After every assignment to the mode flip-flops, the reset included.
        self.core_enable.d.next = (self.mode_rm.d.val() == false) & (self.mode_sm.d.val() == false);
        self.core_listen_only.d.next = self.mode_lom.d.val() & self.cdr.d.val().get_bit(7);
        self.core_self_test.d.next = self.mode_stm.d.val() & self.cdr.d.val().get_bit(7);
    }
}
