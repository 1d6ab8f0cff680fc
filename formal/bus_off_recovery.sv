// Bus-off recovery: a bus-off node becomes error active again only after 128 occurrences of 11
// consecutive recessive bits.
//
// Rule (Bosch CAN 2.0 part B section 8, rule 12: a bus-off node becomes error active with both
// counters 0 after 128 occurrences of 11 consecutive recessive bits; ISO 11898-1 fault confinement;
// SJA1000 data sheet 6.3.3 note 4(b) and 6.4.12: after the host clears the reset request the
// controller waits for 128 occurrences of bus-free before bus-on, counting them down in TXERR from
// 127). Stated on the ports of the bit stream processor: a bit counts when it is sampled recessive
// (`rx_bit` high) at a process point with `enable` high (the host has cleared reset mode); a bit
// sampled dominant, or at a process point with `enable` low, breaks the run; an occurrence is a run
// of 11 such bits, the next run starts after it. The harness counts occurrences from the clock
// bus-off begins; `status$bus_off` falls exactly at the process point that completes the 128th.
// Reset mode in the middle of the recovery (enable low) breaks the run under way but keeps the
// occurrences already counted (the RTL keeps them in TEC; the data sheet does not say otherwise).
//
// Checked on the bit stream processor (top$core$protocol) with its inputs free but for:
//  - reset in the first clock only;
//  - no host write of TXERR (`counters$load_tec` low): a write of 0..254 ends bus-off at once
//    (SJA1000 6.4.12, and formal/fault_confinement.sv proves it);
//  - no process points in two consecutive clocks: the bit-timing logic puts a transmit point
//    between two process points (formal/bit_timing.sv); the engine enters the BusOff field the clock
//    after bus-off begins, and a process point in that clock would be decided by the field before.
// Lemmas: while bus-off TEC = 127 - occurrences, and in the BusOff field the engine's bit count is
// the harness's run.
//
// Found by this proof and fixed: the sequencer entered the BusOff field without clearing its bit
// count. When bus-off began at a dominant bit of a passive error flag (an error-passive transmitter's
// ACK error, fault confinement rule 3 exception a, with TEC >= 248) the count was 1 there, so the
// first occurrence needed only 10 recessive bits (1407 instead of 1408). Only the bare core showed it:
// on the complete controller bus-off sets MOD.RM, and the count stays 0 until the host clears it.
// The mutation `count-kept-on-entry` puts the bug back.
//
//! read: can_controller.v
//! connect: field = protocol.field$q
//! connect: count = protocol.count$q
//! bmc: 40
//! prove: pdr
//! mutation-long: recovery-127 | if (tec_count$q == 32'h0) begin => if (tec_count$q == 32'h1) begin
//! mutation-long: count-kept-on-entry | if (field$q != ProtocolState$BusOff) begin => if (1'b0) begin
//! mutation: enable-ignored | if ((rx_bit & enable) == 1'b0) begin => if (rx_bit == 1'b0) begin
`include "encodings.vh"

module bus_off_recovery (
`include "protocol_ports.vh"
);
  localparam [3:0] BUS_OFF = `ProtocolState_BusOff;

`include "protocol_engine.vh"
  wire [3:0] field;
  wire [6:0] count;

  reg started = 1'b0;
  reg p_pp = 1'b0;
  always @(posedge clock) begin
    started <= 1'b1;
    p_pp <= process_point;
  end
  always @(*) assume (reset == !started);
  always @(*) assume (!load_tec);
  always @(*) if (p_pp) assume (!process_point);

  // Occurrences of 11 recessive bits and the run under way, since bus-off began.
  reg [7:0] occurrences = 8'd0;
  reg [3:0] run = 4'd0;
  reg p_bus_off = 1'b0;
  always @(posedge clock) begin
    p_bus_off <= bus_off;
    if (!bus_off) begin
      occurrences <= 8'd0;
      run <= 4'd0;
    end else if (field != BUS_OFF) run <= 4'd0;
    else if (process_point) begin
      if (!(rx_bit && enable)) run <= 4'd0;
      else if (run == 4'd10) begin
        run <= 4'd0;
        occurrences <= occurrences + 8'd1;
      end else run <= run + 4'd1;
    end
  end

  always @(*)
    if (started) begin
      // The rule: bus-off ends at the 128th occurrence, not before, not after.
      if (p_bus_off && !bus_off) assert (occurrences == 8'd128);
      if (bus_off) assert (occurrences <= 8'd127);
      // Lemmas.
      if (bus_off) assert (tec == 8'd127 - occurrences);
      if (bus_off && field == BUS_OFF) assert ({3'd0, run} == count);
      if (bus_off && field != BUS_OFF) assert (!p_bus_off && run == 4'd0 && occurrences == 8'd0);
    end
endmodule
