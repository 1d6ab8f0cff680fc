//! The SJA1000-compatible CAN controller: the top block with the host port contract of the project's
//! `docs/SJA1000.md`. It wires the register map's blocks (`crate::register_map`: host decoding,
//! modes, configuration, interrupts, the read side) to the protocol core, the transmit buffer, the
//! acceptance filter and the receive FIFO, and owns the transmission request and SR.TBS/TCS.
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
//! self-test, sleep and wake-up. Here: the commands TR, AT, SRR (a request, its abort and its end,
//! TBS/TCS), RRB and CDO (to the FIFO), the TX buffer's write window (operating mode while TBS, its
//! RAM window in reset mode) and the register copies it keeps (ACR/AMR, BTR0, BTR1, OCR), its core
//! read port (the protocol engine's byte at a sample point, the acceptance filter's ACR/AMR in any
//! other clock), the TXERR/RXERR and RBSA writes (reset mode, PeliCAN) and which received frames
//! are stored.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};

use crate::acceptance_filter::AcceptanceFilter;
use crate::bsp::received_frame::ReceivedFrame;
use crate::can_core::CanCore;
use crate::register_map::configuration::Configuration;
use crate::register_map::host_decode::HostDecode;
use crate::register_map::interrupts::Interrupts;
use crate::register_map::modes::Modes;
use crate::register_map::register_read::RegisterRead;
use crate::registers::pelican;
use crate::rx_fifo::RxFifo;
use crate::tx_buffer::{TxBuffer, READBACK_CONFIGURATION, READBACK_FILTER};

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
    decode: HostDecode,
    modes: Modes,
    configuration: Configuration,
    interrupts: Interrupts,
    read: RegisterRead,
    // ---- The transmission request and SR.TBS/TCS.
    tx_pending: DFF<Bit>,
    tx_single_shot: DFF<Bit>,
    self_reception: DFF<Bit>,
    tcs: DFF<Bit>,
    tbs: DFF<Bit>,
    #[constant(u64::from(pelican::RXERR))]
    rxerr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::TXERR))]
    txerr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::RBSA))]
    rbsa_address: Constant<Bits<8>>,
    /// Index of ACR0's copy in the TX buffer (ACR1..AMR3 by their low bits).
    #[constant(READBACK_FILTER as u64)]
    readback_filter: Constant<Bits<5>>,
    /// Index of BTR0's read-back copy in the TX buffer (BTR1, OCR by their low bits).
    #[constant(READBACK_CONFIGURATION as u64)]
    readback_configuration: Constant<Bits<5>>,
    /// `addr` is a register read back from its copy in the TX buffer, at `readback_index`.
    readback_selected: Signal<Local, Bit>,
    readback_index: Signal<Local, Bits<5>>,
    /// The TX buffer's write and host read port, before they go to the buffer.
    tx_write: Signal<Local, Bit>,
    tx_write_index: Signal<Local, Bits<5>>,
    tx_host_index: Signal<Local, Bits<5>>,
    /// The acceptance filter reads an ACR/AMR copy through the TX buffer's core port, which is at
    /// `tx_core_index`.
    filter_read: Signal<Local, Bit>,
    tx_core_index: Signal<Local, Bits<5>>,
    pelican_mode: Signal<Local, Bit>,
    reset_mode: Signal<Local, Bit>,
    /// A PeliCAN write in reset mode (counters, RBSA).
    reset_mode_write: Signal<Local, Bit>,
    request: Signal<Local, Bit>,
    own_frame_received: Signal<Local, Bit>,
}

impl Logic for CanController {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            tx_pending,
            tx_single_shot,
            self_reception,
            tcs,
            tbs
        );
        clock!(
            self,
            clock,
            core,
            fifo,
            tx_buffer,
            filter,
            modes,
            configuration,
            interrupts,
            read
        );
        self.pelican_mode.next = self.modes.pelican.val();
        self.reset_mode.next = self.modes.reset_mode.val();

        // ---- Host port: each block decodes the registers it owns. Inputs of blocks whose
        // combinational outputs are read here come straight from ports and other blocks' outputs
        // (docs/VERILOG.md).
        self.decode.host.addr.next = self.addr.val();
        self.decode.host.we.next = self.we.val();
        self.decode.host.wdata.next = self.wdata.val();
        self.decode.pelican.next = self.modes.pelican.val();
        self.decode.reset_mode.next = self.modes.reset_mode.val();

        self.modes.reset.next = self.reset.val();
        self.modes.host.addr.next = self.addr.val();
        self.modes.host.we.next = self.we.val();
        self.modes.host.wdata.next = self.wdata.val();
        self.modes.command.next = self.decode.command.val();
        self.modes.cmd_sleep.next = self.decode.cmd_sleep.val();
        self.modes.irq_pending.next = self.read.irq_pending.val();
        self.modes.bus_off.next = self.core.status.bus_off.val();
        self.modes.bus_off_before.next = self.interrupts.bus_off_before.val();
        self.modes.state.next = self.core.status.state.val();
        self.modes.sample_point.next = self.core.sample_point.val();
        self.modes.rx.next = self.rx.val();
        self.clkout.next = self.modes.clkout.val();

        self.configuration.reset.next = self.reset.val();
        self.configuration.host.addr.next = self.addr.val();
        self.configuration.host.we.next = self.we.val();
        self.configuration.host.wdata.next = self.wdata.val();
        self.configuration.pelican.next = self.modes.pelican.val();
        self.configuration.reset_mode.next = self.modes.reset_mode.val();

        self.interrupts.reset.next = self.reset.val();
        self.interrupts.host.addr.next = self.addr.val();
        self.interrupts.host.we.next = self.we.val();
        self.interrupts.re.next = self.re.val();
        self.interrupts.host.wdata.next = self.wdata.val();
        self.interrupts.pelican.next = self.modes.pelican.val();
        self.interrupts.reset_mode.next = self.modes.reset_mode.val();
        self.interrupts.enables.next = self.read.enables.val();
        self.interrupts.entering_reset.next = self.modes.entering_reset.val();
        self.interrupts.wake_up.next = self.modes.wake_up.val();
        self.interrupts.cmd_release.next = self.decode.cmd_release.val();
        self.interrupts.tx_done.next = self.core.transmit.done.val();
        self.interrupts.arbitration_lost.next = self.core.status.arbitration_lost.val();
        self.interrupts.alc_in.next = self.core.status.alc.val();
        self.interrupts.bus_error.next = self.core.status.bus_error.val();
        self.interrupts.ecc_in.next = self.core.status.ecc.val();
        self.interrupts.tec.next = self.core.status.tec.val();
        self.interrupts.rec.next = self.core.status.rec.val();
        self.interrupts.error_passive.next = self.core.status.error_passive.val();
        self.interrupts.bus_off.next = self.core.status.bus_off.val();
        self.interrupts.message_count.next = self.fifo.message_count.val();
        self.interrupts.overrun.next = self.fifo.overrun.val();
        self.interrupts.ewlr.next = self.configuration.ewlr.val();

        self.read.reset.next = self.reset.val();
        self.read.addr.next = self.addr.val();
        self.read.re.next = self.re.val();
        self.read.in_frame_window.next = self.decode.in_frame_window.val();
        self.read.in_rx_ram.next = self.decode.in_rx_ram.val();
        self.read.in_tx_ram.next = self.decode.in_tx_ram.val();
        self.read.in_basic_tx.next = self.decode.in_basic_tx.val();
        self.read.in_basic_rx.next = self.decode.in_basic_rx.val();
        self.read.in_basic_config.next = self.decode.in_basic_config.val();
        self.read.frame_index.next = self.decode.frame_index.val();
        self.read.basic_rx_index.next = self.decode.basic_rx_index.val();
        self.read.rx_ram_index.next = self.decode.rx_ram_index.val();
        self.read.pelican.next = self.modes.pelican.val();
        self.read.reset_mode.next = self.modes.reset_mode.val();
        self.read.listen_only.next = self.modes.listen_only.val();
        self.read.self_test.next = self.modes.self_test.val();
        self.read.single_filter.next = self.modes.single_filter.val();
        self.read.sleep.next = self.modes.sleep.val();
        self.read.cr6.next = self.modes.cr6.val();
        self.read.cdr.next = self.modes.cdr.val();
        // Written here rather than with `InterruptRegisters::join`: the same connections, but the
        // join's separate always blocks mapped to 44 more Xilinx LUTs (docs/RUST_HDL.md).
        self.read.interrupts.ier.next = self.interrupts.registers.ier.val();
        self.read.interrupts.ir.next = self.interrupts.registers.ir.val();
        self.read.interrupts.alc.next = self.interrupts.registers.alc.val();
        self.read.interrupts.ecc.next = self.interrupts.registers.ecc.val();
        self.read.interrupts.es.next = self.interrupts.registers.es.val();
        self.read.interrupts.basic_ri.next = self.interrupts.registers.basic_ri.val();
        self.read.tbs.next = self.tbs.q.val();
        self.read.tcs.next = self.tcs.q.val();
        self.read.tec.next = self.core.status.tec.val();
        self.read.rec.next = self.core.status.rec.val();
        self.read.bus_off.next = self.core.status.bus_off.val();
        self.read.receiving.next = self.core.status.receiving.val();
        self.read.transmitting.next = self.core.status.transmitting.val();
        self.read.state.next = self.core.status.state.val();
        self.read.message_count.next = self.fifo.message_count.val();
        self.read.overrun.next = self.fifo.overrun.val();
        self.read.start.next = self.fifo.start.val();
        self.read.head_info.next = self.fifo.head_info.val();
        self.read.fifo_data.next = self.fifo.read_data.val();
        self.read.tx_data.next = self.tx_buffer.host_data.val();
        // The read-back copies of ACR/AMR, BTR0, BTR1 and OCR: written with the register (the
        // filter and the configuration accept writes in reset mode), read by the host from
        // the TX buffer.
        self.readback_selected.next =
            self.filter.host_selected.val() | self.configuration.host_selected.val();
        self.readback_index.next =
            self.readback_filter.val() | bit_cast::<5, 3>(self.filter.host_index.val());
        if self.configuration.host_selected.val() {
            self.readback_index.next = self.readback_configuration.val()
                | bit_cast::<5, 2>(self.configuration.host_index.val());
        }
        self.read.ewlr.next = self.configuration.ewlr.val();
        self.read.readback_selected.next = self.readback_selected.val();
        self.rdata.next = self.read.rdata.val();
        self.irq_n.next = self.read.irq_pending.val() == false;

        // ---- Counter writes (the core applies the TXERR/RXERR rules) and RBSA (the FIFO is
        // empty in reset mode): PeliCAN, reset mode.
        self.reset_mode_write.next =
            self.we.val() & self.reset_mode.val() & self.pelican_mode.val();
        self.core.counters.value.next = self.wdata.val();
        self.core.counters.load_tec.next =
            self.reset_mode_write.val() & (self.addr.val() == self.txerr_address.val());
        self.core.counters.load_rec.next =
            self.reset_mode_write.val() & (self.addr.val() == self.rxerr_address.val());
        self.fifo.load_start.next =
            self.reset_mode_write.val() & (self.addr.val() == self.rbsa_address.val());
        self.fifo.start_address.next = bit_cast::<6, 8>(self.wdata.val());

        // ---- Transmit buffer: written in operating mode while it is free (TBS), its RAM window in
        // reset mode. Child inputs that feed combinational outputs read back here come straight
        // from flip-flops (docs/VERILOG.md).
        self.tx_buffer.reset.next = self.reset.val();
        self.tx_buffer.basic_layout.next = self.modes.pelican.val() == false;
        self.tx_write.next = self.we.val()
            & (self.reset_mode.val() == false)
            & self.tbs.q.val()
            & (self.decode.in_frame_window.val() | self.decode.in_basic_tx.val());
        self.tx_write_index.next = bit_cast::<5, 4>(self.decode.frame_index.val());
        if self.we.val() & self.reset_mode.val() & self.decode.in_tx_ram.val() {
            self.tx_write.next = true;
            self.tx_write_index.next = bit_cast::<5, 4>(self.decode.tx_ram_index.val());
        }
        self.tx_host_index.next = bit_cast::<5, 4>(self.decode.tx_ram_index.val());
        if self.pelican_mode.val() == false {
            // BasicCAN byte 10 is buffer byte 1 (identifier bits 10..3).
            self.tx_write_index.next = bit_cast::<5, 4>(self.decode.basic_tx_index.val());
            self.tx_host_index.next = bit_cast::<5, 4>(self.decode.basic_tx_index.val());
        }
        if self.readback_selected.val() {
            self.tx_host_index.next = self.readback_index.val();
            if self.we.val() & self.reset_mode.val() {
                self.tx_write.next = true;
                self.tx_write_index.next = self.readback_index.val();
            }
        }
        // Each input of the TX buffer written once, from its final value: the buffer's outputs come
        // back into this kernel, and in Icarus an input written twice in one pass re-runs the
        // buffer, whose outputs then change twice too and re-run this kernel, without end
        // (docs/VERILOG.md).
        self.tx_buffer.write.next = self.tx_write.val();
        self.tx_buffer.write_index.next = self.tx_write_index.val();
        self.tx_buffer.host_index.next = self.tx_host_index.val();
        self.tx_buffer.write_data.next = self.wdata.val();
        // The core port: the protocol engine's frame byte, read in the sample-point clock for the
        // process point after it (the only clocks the engine uses it, docs/ARCHITECTURE.md), and
        // the filter's ACR/AMR in any other clock it asks for.
        self.filter_read.next = self.filter.copy_wanted.val() & !self.core.sample_point.val();
        self.tx_core_index.next = bit_cast::<5, 4>(self.core.transmit.addr.val());
        if self.filter_read.val() {
            self.tx_core_index.next =
                self.readback_filter.val() | bit_cast::<5, 3>(self.filter.copy_index.val());
        }
        self.tx_buffer.core_index.next = self.tx_core_index.val();
        self.filter.copy_granted.next = self.filter_read.val();
        self.filter.copy_data.next = self.tx_buffer.core_data.val();

        // ---- Transmission requests and their end. TR together with SRR is a plain TR, AT with
        // either a single shot (data sheet).
        self.core.transmit.abort.next = self.decode.cmd_abort.val()
            & (self.decode.cmd_transmit.val() == false)
            & (self.decode.cmd_self_reception.val() == false)
            & self.tx_pending.q.val();
        if self.core.transmit.done.val() {
            self.tx_pending.d.next = false;
            self.tbs.d.next = true;
            self.tcs.d.next = self.core.transmit.success.val();
        }
        self.request.next = self.decode.cmd_transmit.val() | self.decode.cmd_self_reception.val();
        if self.request.val() & self.tbs.q.val() & (self.tx_pending.q.val() == false) {
            self.tx_pending.d.next = true;
            self.tbs.d.next = false;
            self.tcs.d.next = false;
            self.tx_single_shot.d.next = self.decode.cmd_abort.val();
            self.self_reception.d.next = self.decode.cmd_self_reception.val();
        }
        // Entering reset mode cancels the request (TBS without TI).
        if self.modes.entering_reset.val() {
            self.tx_pending.d.next = false;
            self.tbs.d.next = true;
        }

        // ---- Receive FIFO: store valid accepted frames (own ones with self-reception); BasicCAN
        // stores standard frames only. The FIFO stays empty in reset mode.
        self.own_frame_received.next = self.core.transmit.done.val()
            & self.core.transmit.success.val()
            & self.self_reception.q.val();
        self.fifo.reset.next = self.reset.val();
        self.fifo.store.next = (self.core.rx_valid.val() | self.own_frame_received.val())
            & self.filter.accept.val()
            & (self.pelican_mode.val() | (self.core.rx_frame.ide.val() == false));
        self.fifo.release_head.next = self.decode.cmd_release.val();
        self.fifo.clear_overrun.next = self.decode.cmd_clear_overrun.val();
        self.fifo.clear.next = self.reset_mode.val();
        ReceivedFrame::join(&mut self.core.rx_frame, &mut self.fifo.rx_frame);
        self.fifo.host_read.next = self.re.val() & self.read.fifo_read.val();
        self.fifo.host_write.next =
            self.we.val() & self.reset_mode.val() & self.decode.in_rx_ram.val();
        self.fifo.host_data.next = self.wdata.val();
        self.fifo.host_address.next = self.read.fifo_address.val();

        // ---- Acceptance filter (owns ACR/AMR and their host access).
        self.filter.reset.next = self.reset.val();
        self.filter.pelican.next = self.modes.pelican.val();
        self.filter.single_filter.next = self.modes.single_filter.val();
        self.filter.reset_mode.next = self.modes.reset_mode.val();
        self.filter.addr.next = self.addr.val();
        ReceivedFrame::join(&mut self.core.rx_frame, &mut self.filter.rx_frame);

        // ---- The core.
        self.core.reset.next = self.reset.val();
        self.core.rx.next = self.rx.val();
        self.core.enable.next = self.modes.core_enable.val();
        self.core.listen_only.next = self.modes.core_listen_only.val();
        self.core.self_test.next = self.modes.core_self_test.val();
        self.core.brp.next = self.configuration.brp.val();
        self.core.sjw.next = self.configuration.sjw.val();
        self.core.tseg1.next = self.configuration.tseg1.val();
        self.core.tseg2.next = self.configuration.tseg2.val();
        self.core.sam.next = self.configuration.sam.val();
        self.core.transmit.request.next = self.tx_pending.q.val();
        self.core.transmit.single_shot.next = self.tx_single_shot.q.val();
        self.core.transmit.info.next = self.tx_buffer.info.val();
        self.core.transmit.data.next = self.tx_buffer.core_data.val();
        self.tx.next = self.core.tx.val();

        if self.reset.val() {
            self.tx_pending.d.next = false;
            self.tx_single_shot.d.next = false;
            self.self_reception.d.next = false;
            self.tcs.d.next = true;
            self.tbs.d.next = true;
        }
    }
}
