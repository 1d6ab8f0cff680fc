//! Modes: the mode register (PeliCAN MOD, BasicCAN CR.RR and CR.6), the clock divider register
//! (CDR: the map selection CDR.7 and CLKOUT), sleep and wake-up, and the core's mode inputs.
//!
//! Ports in: the host bus `host` (`addr`, `we`, `wdata`: MOD/CR and CDR writes, decoded here), the command
//! strobes `command` and `cmd_sleep` of the host decoder (BasicCAN GTS), `irq_pending` (sleep needs
//! no pending interrupt), and from the core `bus_off`, `state`, `sample_point`, with `bus_off_before`
//! (bus-off one clock earlier, from the interrupt block) and the bus pin `rx` (a dominant bit
//! wakes the controller). Every input comes straight from a port, a flip-flop or another block's
//! output, so the controller may use this block's combinational outputs `entering_reset` (reset
//! mode begins at this edge, by a write or by bus-off), `wake_up` (the wake-up interrupt event) and
//! `clkout` without a Verilator loop (docs/VERILOG.md). The other outputs are flip-flops: the
//! mode bits, `pelican`, `cdr`, `cr6`, and `core_enable`, `core_listen_only`, `core_self_test`.
//! Acts on the rising edge of `clock`; `reset` is synchronous, active high (RM set, all else 0).
//!
//! Rules (SJA1000 data sheet, MOD and CDR): the old RM decides what a MOD write changes (LOM, STM
//! and AFM only in reset mode, SM only outside it); bus-off sets RM; entering reset mode ends sleep;
//! sleep needs an idle bus and no pending interrupt, or the attempt wakes at once (WUI); a dominant
//! bus bit or clearing SM wakes. CDR is written whole in reset mode (bit 4 reads 0), only its
//! divider bits 2..0 outside it. In sleep, CLKOUT runs on for at least 15 bit times (for a host
//! clocked by it), then stays low.

use rust_hdl::prelude::*;

use crate::activity::{Activity, ActivityBlock, BlockDefault};
use crate::bsp::protocol::ProtocolState;
use crate::clock_divider::ClockDivider;
use crate::register_map::HostWrite;
use crate::registers::pelican;

/// Sample points CLKOUT runs on in sleep: 16, the first of which may end a partial bit.
const SLEEP_CLOCK_BITS: u64 = 16;

/// The mode and clock-divider registers, sleep and the core's mode inputs.
#[derive(ActivityBlock, BlockDefault)]
pub struct Modes {
    /// Simulation bookkeeping (see `crate::activity`); not hardware.
    activity: Activity,
    /// Controller clock.
    pub clock: Signal<In, Clock>,
    /// Synchronous reset, active high.
    pub reset: Signal<In, Bit>,
    /// The host bus: address, write strobe, write data.
    #[interface]
    pub host: HostWrite,
    /// A CMR write outside reset mode (host decoder).
    pub command: Signal<In, Bit>,
    /// CMR.GTS of a BasicCAN command (host decoder).
    pub cmd_sleep: Signal<In, Bit>,
    /// An interrupt is pending (IR & enables != 0).
    pub irq_pending: Signal<In, Bit>,
    /// The core is bus-off.
    pub bus_off: Signal<In, Bit>,
    /// `bus_off` one clock earlier.
    pub bus_off_before: Signal<In, Bit>,
    /// The core's state (sleep needs an idle bus).
    pub state: Signal<In, ProtocolState>,
    /// The core's sample point.
    pub sample_point: Signal<In, Bit>,
    /// Bus input.
    pub rx: Signal<In, Bit>,
    /// MOD.RM / CR.RR: reset mode.
    pub reset_mode: Signal<Out, Bit>,
    /// MOD.LOM.
    pub listen_only: Signal<Out, Bit>,
    /// MOD.STM.
    pub self_test: Signal<Out, Bit>,
    /// MOD.AFM.
    pub single_filter: Signal<Out, Bit>,
    /// MOD.SM.
    pub sleep: Signal<Out, Bit>,
    /// CR bit 6 (BasicCAN, plain storage).
    pub cr6: Signal<Out, Bit>,
    /// CDR.
    pub cdr: Signal<Out, Bits<8>>,
    /// CDR.7: the PeliCAN map.
    pub pelican: Signal<Out, Bit>,
    /// The core runs (neither reset mode nor sleep).
    pub core_enable: Signal<Out, Bit>,
    /// The core listens only (LOM in PeliCAN).
    pub core_listen_only: Signal<Out, Bit>,
    /// The core acknowledges its own frames (STM in PeliCAN).
    pub core_self_test: Signal<Out, Bit>,
    /// Reset mode begins at this edge.
    pub entering_reset: Signal<Out, Bit>,
    /// The wake-up interrupt event.
    pub wake_up: Signal<Out, Bit>,
    /// Clock output.
    pub clkout: Signal<Out, Bit>,
    divider: ClockDivider,
    rm: DFF<Bit>,
    lom: DFF<Bit>,
    stm: DFF<Bit>,
    afm: DFF<Bit>,
    sm: DFF<Bit>,
    cr6_reg: DFF<Bit>,
    cdr_reg: DFF<Bits<8>>,
    sleep_bits: DFF<Bits<5>>,
    // Registered from the values the mode flip-flops load (so equal to what they were computed
    // from in every cycle): they start the engine's longest paths.
    enable_reg: DFF<Bit>,
    listen_only_reg: DFF<Bit>,
    self_test_reg: DFF<Bit>,
    write_mod: Signal<Local, Bit>,
    sleep_request: Signal<Local, Bit>,
    wake_request: Signal<Local, Bit>,
    #[constant(u64::from(pelican::MOD))]
    mod_address: Constant<Bits<8>>,
    #[constant(u64::from(pelican::CDR))]
    cdr_address: Constant<Bits<8>>,
    #[constant(SLEEP_CLOCK_BITS)]
    sleep_clock_bits: Constant<Bits<5>>,
}

impl Logic for Modes {
    #[hdl_gen]
    fn update(&mut self) {
        dff_setup!(
            self,
            clock,
            rm,
            lom,
            stm,
            afm,
            sm,
            cr6_reg,
            cdr_reg,
            sleep_bits,
            enable_reg,
            listen_only_reg,
            self_test_reg
        );
        clock!(self, clock, divider);
        self.reset_mode.next = self.rm.q.val();
        self.listen_only.next = self.lom.q.val();
        self.self_test.next = self.stm.q.val();
        self.single_filter.next = self.afm.q.val();
        self.sleep.next = self.sm.q.val();
        self.cr6.next = self.cr6_reg.q.val();
        self.cdr.next = self.cdr_reg.q.val();
        self.pelican.next = self.cdr_reg.q.val().get_bit(7);
        self.core_enable.next = self.enable_reg.q.val();
        self.core_listen_only.next = self.listen_only_reg.q.val();
        self.core_self_test.next = self.self_test_reg.q.val();

        // ---- MOD (PeliCAN) / CR (BasicCAN): the same address.
        self.write_mod.next = self.host.we.val() & (self.host.addr.val() == self.mod_address.val());
        self.sleep_request.next = false;
        self.wake_request.next = false;
        self.entering_reset.next = false;
        if self.write_mod.val() {
            self.rm.d.next = self.host.wdata.val().get_bit(0);
            self.entering_reset.next =
                self.host.wdata.val().get_bit(0) & (self.rm.q.val() == false);
            if self.cdr_reg.q.val().get_bit(7) {
                if self.rm.q.val() {
                    self.lom.d.next = self.host.wdata.val().get_bit(1);
                    self.stm.d.next = self.host.wdata.val().get_bit(2);
                    self.afm.d.next = self.host.wdata.val().get_bit(3);
                } else {
                    self.sleep_request.next = self.host.wdata.val().get_bit(4)
                        & (self.host.wdata.val().get_bit(0) == false);
                    self.wake_request.next = self.host.wdata.val().get_bit(4) == false;
                }
            } else {
                self.cr6_reg.d.next = self.host.wdata.val().get_bit(6);
            }
        }
        if self.command.val() & (self.cdr_reg.q.val().get_bit(7) == false) {
            self.sleep_request.next = self.cmd_sleep.val();
            self.wake_request.next = self.cmd_sleep.val() == false;
        }

        // ---- Sleep and wake-up.
        self.wake_up.next = false;
        if self.sleep_request.val() & (self.sm.q.val() == false) {
            if (self.state.val() == ProtocolState::Idle) & (self.irq_pending.val() == false) {
                self.sm.d.next = true;
            } else {
                self.wake_up.next = true;
            }
        }
        if self.sm.q.val() & (self.wake_request.val() | (self.rx.val() == false)) {
            self.sm.d.next = false;
            self.wake_up.next = true;
        }

        // ---- Bus-off sets RM; entering reset mode ends sleep.
        if self.bus_off.val() & (self.bus_off_before.val() == false) {
            self.rm.d.next = true;
            self.entering_reset.next = self.rm.q.val() == false;
        }
        if self.entering_reset.val() {
            self.sm.d.next = false;
        }

        // ---- CDR: whole in reset mode (bit 4 reads 0), only the divider outside it.
        if self.host.we.val() & (self.host.addr.val() == self.cdr_address.val()) {
            self.cdr_reg.d.next = bit_cast::<8, 3>(bit_cast::<3, 8>(self.host.wdata.val()))
                .replace_bit(3, self.cdr_reg.q.val().get_bit(3))
                .replace_bit(5, self.cdr_reg.q.val().get_bit(5))
                .replace_bit(6, self.cdr_reg.q.val().get_bit(6))
                .replace_bit(7, self.cdr_reg.q.val().get_bit(7));
            if self.rm.q.val() {
                self.cdr_reg.d.next = self.host.wdata.val().replace_bit(4, false);
            }
        }

        // ---- CLKOUT, stopped after the sleep bits.
        self.divider.reset.next = self.reset.val();
        self.divider.code.next = bit_cast::<3, 8>(self.cdr_reg.q.val());
        self.divider.clock_off.next = self.cdr_reg.q.val().get_bit(3);
        self.clkout.next = self.divider.clkout.val();
        self.sleep_bits.d.next = 0.into();
        if self.sm.q.val() {
            self.sleep_bits.d.next = self.sleep_bits.q.val();
            if self.sample_point.val() & (self.sleep_bits.q.val() != self.sleep_clock_bits.val()) {
                self.sleep_bits.d.next = self.sleep_bits.q.val() + 1;
            }
            if self.sleep_bits.q.val() == self.sleep_clock_bits.val() {
                self.clkout.next = false;
            }
        }

        if self.reset.val() {
            self.rm.d.next = true;
            self.lom.d.next = false;
            self.stm.d.next = false;
            self.afm.d.next = false;
            self.sm.d.next = false;
            self.cr6_reg.d.next = false;
            self.cdr_reg.d.next = 0.into();
            self.sleep_bits.d.next = 0.into();
        }
        // After every assignment to the mode flip-flops, the reset included.
        self.enable_reg.d.next = (self.rm.d.val() == false) & (self.sm.d.val() == false);
        self.listen_only_reg.d.next = self.lom.d.val() & self.cdr_reg.d.val().get_bit(7);
        self.self_test_reg.d.next = self.stm.d.val() & self.cdr_reg.d.val().get_bit(7);
    }
}
