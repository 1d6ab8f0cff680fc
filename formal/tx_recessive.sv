// The controller keeps `tx` recessive in reset mode and in listen-only mode, whatever the bus does.
//
// Rules (SJA1000 data sheet 6.4.3 MOD): reset mode (MOD.RM = 1) takes the controller off the bus: it
// sends nothing. Listen-only mode (MOD.LOM = 1, PeliCAN only) gives no acknowledge and no error flags,
// and transmits nothing: the output stays recessive even on errors and on frames it receives.
// `tx` is registered: the rule holds from the clock after the mode is in force, i.e. `tx` is 1 in every
// cycle that follows a cycle in reset mode, in listen-only mode (MOD.LOM with CDR.7 PeliCAN) or in
// `reset`. (Entering the mode takes one clock; `tx` may still carry the last bus bit in that clock.)
//
// The whole controller, every input free (`rx` too: the bit timing and the protocol engine may do
// anything) but for the port contract at the top of fpga/rtl/can_controller.v: `reset` in the first
// cycle, `we` and `re` never together.
//
//! read: can_controller.v
//! connect: reset_mode = ctl.modes.rm$q
//! connect: lom = ctl.modes.lom$q
//! connect: cdr = ctl.modes.cdr_reg$q
//! bmc: 12
//! prove: pdr
//! mutation: reset-mode-not-silent | sender$silent = faults$bus_off | (enable == 1'b0); => sender$silent = faults$bus_off;
//! mutation: listen-only-wrong-bit | listen_only_reg$d = lom$d & cdr_reg$d[32'h7]; => listen_only_reg$d = lom$d & cdr_reg$d[32'h6];
//! mutation: reset-mode-enables | enable_reg$d = (rm$d == 1'b0) & (sm$d == 1'b0); => enable_reg$d = (sm$d == 1'b0);
module tx_recessive (
`include "controller_ports.vh"
);
`include "controller.vh"

  // Inside the controller (see the `connect` lines): MOD.RM, MOD.LOM, CDR.
  wire reset_mode, lom;
  wire [7:0] cdr;

  // The port contract.
  reg started = 1'b0;
  always @(posedge clock) started <= 1'b1;
  always @(*) begin
    if (!started) assume (reset);
    assume (!(we && re));
  end

  reg past_valid = 1'b0;
  reg past_quiet;
  always @(posedge clock) begin
    past_valid <= started;
    past_quiet <= reset || reset_mode || (lom && cdr[7]);
  end

  always @(*) if (past_valid && past_quiet) assert (tx);
endmodule
