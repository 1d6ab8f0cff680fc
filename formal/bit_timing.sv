// Bit timing: the order of the triggers the bit stream processor relies on.
//
// Rule (ISO 11898-1 / Bosch CAN 2.0 part B section 9 "Bit timing requirements": a bit time is
// Sync, Prop+Phase1 and Phase2; the bit is sampled at the end of Phase1 and the next bit is sent from
// the start of Sync; hard synchronisation and resynchronisation restart or stretch the bit): one
// sample point per bit, its processing in the clock after it, and the next bit's transmission
// (transmit point) after that processing and before the next sample point. Stated as the contract
// formal/stuffing.sv and the engine assume: a process point follows each sample point by one clock;
// a process point and a transmit point never share a clock; between two process points there is at
// least one transmit point.
//
// Checked on the bit timing logic (top$core$bit_timing) with `rx` (the bus), `tx_dominant` and the
// synchronisation mode free. The BTR fields are free but hold still after reset: the SJA1000 lets
// the host change BTR0/BTR1 only in reset mode (data sheet 6.5.1, 6.5.2), and the controller
// resets its bit timing when it leaves reset mode.
//
//! read: can_controller.v
//! bmc: 40
//! prove: pdr
//! mutation: no-deferred-transmit | transmit_point = (transmit_now & ~process_pending$q & ~reset) | transmit_deferred$q; => transmit_point = (transmit_now & ~reset) | transmit_deferred$q;
module bit_timing (
`include "bit_timing_ports.vh"
);
  wire sample_point, process_point, transmit_point;

  \top$core$bit_timing timing (
      .clock(clock),
      .reset(reset),
      .rx(rx),
      .brp(brp),
      .tseg1(tseg1),
      .tseg2(tseg2),
      .sjw(sjw),
      .sam(sam),
      .sync_mode(sync_mode),
      .tx_dominant(tx_dominant),
      .sample_point(sample_point),
      .process_point(process_point),
      .transmit_point(transmit_point)
  );

  reg started = 1'b0;
  reg [5:0] brp_0;
  reg [3:0] tseg1_0;
  reg [2:0] tseg2_0;
  reg [1:0] sjw_0;
  reg sam_0;
  always @(posedge clock) begin
    started <= 1'b1;
    if (reset) {brp_0, tseg1_0, tseg2_0, sjw_0, sam_0} <= {brp, tseg1, tseg2, sjw, sam};
  end
  always @(*) if (!started) assume (reset);
  always @(*) if (started) assume ({brp, tseg1, tseg2, sjw, sam} == {brp_0, tseg1_0, tseg2_0, sjw_0, sam_0});
  always @(*) if (started) assume (!reset);

  reg sampled = 1'b0;
  reg transmitted_since_process = 1'b1;
  always @(posedge clock) begin
    sampled <= sample_point;
    if (process_point) transmitted_since_process <= 1'b0;
    else if (transmit_point) transmitted_since_process <= 1'b1;
  end

  always @(*) if (started) begin
    assert (process_point == sampled);
    assert (!(process_point && transmit_point));
    if (process_point) assert (transmitted_since_process);
  end
endmodule
