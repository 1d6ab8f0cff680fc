//! Interrupts: the interrupt enable register (PeliCAN IER, BasicCAN CR.4..1), the interrupt register
//! IR, the captures ALC and ECC, the error status SR.ES and the BasicCAN receive interrupt latch.
//!
//! Ports in: the host bus `host` (`addr`, `we`, `wdata`) and `re` (IER/CR writes; IR, ALC and ECC reads, whose
//! side effects act at the edge that ends the read cycle), the map state `pelican` and `reset_mode`,
//! `enables` (the interrupt enables in force, from the read side), `entering_reset`, `wake_up`,
//! `cmd_release` (RRB), the core's events and counters (`tx_done`, `arbitration_lost` with `alc_in`,
//! `bus_error` with `ecc_in`, `tec`, `rec`, `error_passive`, `bus_off`), the FIFO's
//! `message_count` and `overrun`, and `ewlr`. Out, from flip-flops only (so any input may come from
//! the controller's logic: docs/VERILOG.md): `registers` (IER, IR without RI, which the read side
//! adds, ALC, ECC, ES, the RI latch) and `bus_off_before`. Acts on the rising edge of `clock`; `reset`
//! is synchronous, active high.
//!
//! Rules (SJA1000 data sheet, IR and SR): an event sets its IR bit when enabled; reading IR clears
//! every bit but RI (a level); entering reset mode clears all but EI. ALC and ECC capture the first
//! arbitration loss / bus error and hold it until read. ES follows the counters against the warning
//! limit (EWLR in PeliCAN, 96 in BasicCAN) outside reset mode: a counter written in reset mode
//! changes ES and EPI only when reset mode is left; EI reports ES changes and bus-off entry and end,
//! EPI error-passive changes outside bus-off. BasicCAN's RI is a latch set when a message becomes
//! available (RBS rises, or RRB leaves another one) and cleared by reading IR.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::register_map::{HostWrite, InterruptRegisters};
use crate::registers::{pelican, DEFAULT_EWLR};

/// IER, IR, the ALC/ECC captures, ES and the BasicCAN RI latch.
#[derive(ActivityBlock, BlockDefault)]
pub struct Interrupts {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// The host bus: address, write strobe, write data.
    #[interface]
    pub host: HostWrite,
    /// Read strobe.
    pub re: Signal<In, Bit>,
    /// The PeliCAN map (CDR.7).
    pub pelican: Signal<In, Bit>,
    /// Reset mode.
    pub reset_mode: Signal<In, Bit>,
    /// The interrupt enables in force (IER, or BasicCAN's CR bits with WUI).
    pub enables: Signal<In, Bits<8>>,
    /// Reset mode begins at this edge.
    pub entering_reset: Signal<In, Bit>,
    /// The wake-up event.
    pub wake_up: Signal<In, Bit>,
    /// CMR.RRB.
    pub cmd_release: Signal<In, Bit>,
    /// A transmission ended.
    pub tx_done: Signal<In, Bit>,
    /// Arbitration lost, with its bit position `alc_in`.
    pub arbitration_lost: Signal<In, Bit>,
    /// The ALC value of `arbitration_lost`.
    pub alc_in: Signal<In, Bits<5>>,
    /// A bus error, with its code `ecc_in`.
    pub bus_error: Signal<In, Bit>,
    /// The ECC value of `bus_error`.
    pub ecc_in: Signal<In, Bits<8>>,
    /// Transmit error counter.
    pub tec: Signal<In, Bits<8>>,
    /// Receive error counter.
    pub rec: Signal<In, Bits<8>>,
    /// Error passive.
    pub error_passive: Signal<In, Bit>,
    /// Bus-off.
    pub bus_off: Signal<In, Bit>,
    /// Messages in the RX FIFO.
    pub message_count: Signal<In, Bits<5>>,
    /// The RX FIFO overran.
    pub overrun: Signal<In, Bit>,
    /// The error warning limit register.
    pub ewlr: Signal<In, Bits<8>>,
    /// IER, IR, ALC, ECC, ES and the RI latch, from flip-flops.
    #[interface]
    pub registers: InterruptRegisters,
    /// `bus_off` one clock earlier.
    pub bus_off_before: Signal<Out, Bit>,
    ier_reg: DFF<Bits<8>>,
    ir_reg: DFF<Bits<8>>,
    alc_reg: DFF<Bits<5>>,
    alc_armed: DFF<Bit>,
    ecc_reg: DFF<Bits<8>>,
    ecc_armed: DFF<Bit>,
    es_reg: DFF<Bit>,
    bus_off_reg: DFF<Bit>,
    passive_before: DFF<Bit>,
    overrun_before: DFF<Bit>,
    rbs_before: DFF<Bit>,
    basic_ri_reg: DFF<Bit>,
    read_ir: Signal<Local, Bit>,
    rbs: Signal<Local, Bit>,
    /// The error warning limit in force: EWLR in PeliCAN mode, its reset value in BasicCAN mode.
    warning_limit: Signal<Local, Bits<8>>,
    es_next: Signal<Local, Bit>,
    events: Signal<Local, Bits<8>>,
    ir_kept: Signal<Local, Bits<8>>,
    ev_error: Signal<Local, Bit>,
    ev_overrun: Signal<Local, Bit>,
    ev_passive: Signal<Local, Bit>,
    ev_arbitration: Signal<Local, Bit>,
    ev_bus_error: Signal<Local, Bit>,
    basic_receive: Signal<Local, Bit>,
    #[constant(u64::from(pelican::MOD))]
    cr_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::IR))]
    ir_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::IER))]
    ier_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::ALC))]
    alc_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::ECC))]
    ecc_address: Constant<Bits<8>>,
    #[constant(u64::from(DEFAULT_EWLR))]
    default_ewlr: Constant<Bits<8>>,
    #[constant(0u64)]
    zero_byte: Constant<Bits<8>>,
}

impl Logic for Interrupts {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            ier_reg,
            ir_reg,
            alc_reg,
            alc_armed,
            ecc_reg,
            ecc_armed,
            es_reg,
            bus_off_reg,
            passive_before,
            overrun_before,
            rbs_before,
            basic_ri_reg
        );
        self.registers.ier.next = self.ier_reg.q.val();
        self.registers.ir.next = self.ir_reg.q.val();
        self.registers.alc.next = self.alc_reg.q.val();
        self.registers.ecc.next = self.ecc_reg.q.val();
        self.registers.es.next = self.es_reg.q.val();
        self.registers.basic_ri.next = self.basic_ri_reg.q.val();
        self.bus_off_before.next = self.bus_off_reg.q.val();
        self.read_ir.next = self.re.val() & (self.host.addr.val() == self.ir_address.val());
        self.rbs.next = self.message_count.val() != 0;

        // ---- Enables: IER in PeliCAN; CR.4..1 (RIE, TIE, EIE, OIE) in BasicCAN.
        if self.host.we.val() {
            if self.pelican.val() & (self.host.addr.val() == self.ier_address.val()) {
                self.ier_reg.d.next = self.host.wdata.val();
            }
            if (self.pelican.val() == false) & (self.host.addr.val() == self.cr_address.val()) {
                self.ier_reg.d.next = bit_cast::<8, 4>(self.host.wdata.val().get_bits::<4>(1))
                    .replace_bit(4, self.ier_reg.q.val().get_bit(4))
                    .replace_bit(5, self.ier_reg.q.val().get_bit(5))
                    .replace_bit(6, self.ier_reg.q.val().get_bit(6))
                    .replace_bit(7, self.ier_reg.q.val().get_bit(7));
            }
        }

        // ---- Captures: ALC and ECC hold their value until read.
        self.ev_arbitration.next = false;
        self.ev_bus_error.next = false;
        if self.arbitration_lost.val() & self.alc_armed.q.val() {
            self.alc_reg.d.next = self.alc_in.val();
            self.alc_armed.d.next = false;
            self.ev_arbitration.next = true;
        }
        if self.bus_error.val() & self.ecc_armed.q.val() {
            self.ecc_reg.d.next = self.ecc_in.val();
            self.ecc_armed.d.next = false;
            self.ev_bus_error.next = true;
        }
        if self.re.val() & self.pelican.val() {
            if self.host.addr.val() == self.alc_address.val() {
                self.alc_armed.d.next = true;
            }
            if self.host.addr.val() == self.ecc_address.val() {
                self.ecc_armed.d.next = true;
            }
        }

        // ---- Error status, bus-off and error passive changes.
        self.warning_limit.next = self.ewlr.val();
        if self.pelican.val() == false {
            self.warning_limit.next = self.default_ewlr.val();
        }
        self.es_next.next = self.es_reg.q.val();
        if self.reset_mode.val() == false {
            self.es_next.next = (self.tec.val() >= self.warning_limit.val())
                | (self.rec.val() >= self.warning_limit.val())
                | self.bus_off.val();
        }
        self.es_reg.d.next = self.es_next.val();
        self.bus_off_reg.d.next = self.bus_off.val();
        self.ev_error.next = (self.es_next.val() != self.es_reg.q.val())
            | (self.bus_off.val() != self.bus_off_reg.q.val());
        self.ev_passive.next = false;
        if self.bus_off.val() {
            self.passive_before.d.next = false;
        } else if self.reset_mode.val() == false {
            self.passive_before.d.next = self.error_passive.val();
            self.ev_passive.next = self.error_passive.val() != self.passive_before.q.val();
        }
        self.overrun_before.d.next = self.overrun.val();
        self.ev_overrun.next = self.overrun.val() & (self.overrun_before.q.val() == false);

        // ---- BasicCAN RI latch.
        self.rbs_before.d.next = self.rbs.val();
        self.basic_receive.next = (self.rbs.val() & (self.rbs_before.q.val() == false))
            | (self.cmd_release.val()
                & (self.message_count.val() != 0)
                & (self.message_count.val() != 1));
        if self.read_ir.val() {
            self.basic_ri_reg.d.next = false;
        }
        if self.basic_receive.val() {
            self.basic_ri_reg.d.next = true;
        }

        // ---- IR: events set enabled bits; a read clears them, entering reset mode all but EI.
        self.events.next = self
            .zero_byte
            .val()
            .replace_bit(1, self.tx_done.val())
            .replace_bit(2, self.ev_error.val())
            .replace_bit(3, self.ev_overrun.val())
            .replace_bit(4, self.wake_up.val())
            .replace_bit(5, self.ev_passive.val())
            .replace_bit(6, self.ev_arbitration.val())
            .replace_bit(7, self.ev_bus_error.val());
        self.ir_kept.next = self.ir_reg.q.val();
        if self.read_ir.val() {
            self.ir_kept.next = 0.into();
        }
        if self.entering_reset.val() {
            self.ir_kept.next = self
                .zero_byte
                .val()
                .replace_bit(2, self.ir_kept.val().get_bit(2));
        }
        self.ir_reg.d.next = self.ir_kept.val() | (self.events.val() & self.enables.val());

        if self.reset.val() {
            self.ier_reg.d.next = 0.into();
            self.ir_reg.d.next = 0.into();
            self.alc_reg.d.next = 0.into();
            self.alc_armed.d.next = true;
            self.ecc_reg.d.next = 0.into();
            self.ecc_armed.d.next = true;
            self.es_reg.d.next = false;
            self.bus_off_reg.d.next = false;
            self.passive_before.d.next = false;
            self.overrun_before.d.next = false;
            self.rbs_before.d.next = false;
            self.basic_ri_reg.d.next = false;
        }
    }
}
