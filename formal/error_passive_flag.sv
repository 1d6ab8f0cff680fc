// Passive error flags: an error-passive node never drives a dominant error flag, and a listen-only
// node never drives a dominant bit at all.
//
// Rule (Bosch CAN 2.0 part B 7.2 "Error signalling" and section 8 "Fault confinement": an
// error-passive node that detects an error transmits a passive error flag, six recessive bits;
// ISO 11898-1 error frame; ISO 16845-1 7.5.7 / 8.5.15: the kind of the flag is decided by the node's
// state at the error detection, before that error's counter change). Listen-only mode (SJA1000 data
// sheet 6.4.3, MOD.LOM) sends no dominant bit: its flags are passive too.
//  - When the node starts an error flag (the sequencer's `field` goes to ErrorFlag with bit count 0,
//    a new flag or an active flag restarted by a bit error in it) while it is error passive
//    (`status$error_passive`, the state before this error's counter change) or listen-only, `tx` is
//    recessive from the first transmit point of the flag until the field leaves ErrorFlag. (Before
//    that transmit point `tx` still holds the bit in which the error was detected.)
//  - In every clock after one with `listen_only` high, `tx` is recessive.
//
// Checked on the bit stream processor (top$core$protocol) with every input free: any bit stream, any
// timing of the process and transmit points, any request, mode change or host counter write; reset
// in the first clock.
//
//! read: can_controller.v
//! connect: field_next = protocol.field$d
//! connect: count_next = protocol.count$d
//! connect: field = protocol.field$q
//! bmc: 30
//! prove: pdr
//! mutation: flag-ignores-passive | flag_is_passive = error_passive | listen_only; => flag_is_passive = listen_only;
//! mutation: flag-kind-dropped | next_bit = flag_passive; => next_bit = 1'b0;
//! mutation: listen-only-drives | if (listen_only) begin => if (1'b0) begin
`include "encodings.vh"

module error_passive_flag (
`include "protocol_ports.vh"
);
  localparam [3:0] ERROR_FLAG = `ProtocolState_ErrorFlag;

`include "protocol_engine.vh"

  // The sequencer's field and count: this clock's, and what the edge loads.
  wire [3:0] field, field_next;
  wire [6:0] count_next;

  reg started = 1'b0;
  always @(posedge clock) started <= 1'b1;
  always @(*) if (!started) assume (reset);

  // A flag starts at this edge: the next field is ErrorFlag at its bit 0 (a new flag, or an active
  // flag restarted by a bit error in it; a passive flag's count never goes back to 0).
  wire flag_starts = field_next == ERROR_FLAG && count_next == 7'd0 && process_point;
  reg passive_flag = 1'b0;  // the flag under way started while error passive or listen-only
  reg flag_sent = 1'b0;  // a transmit point since it started: `tx` carries the flag
  reg after_listen_only = 1'b0;
  always @(posedge clock) begin
    after_listen_only <= listen_only;
    if (flag_starts) begin
      passive_flag <= error_passive || listen_only;
      flag_sent <= 1'b0;
    end else if (transmit_point && field == ERROR_FLAG) flag_sent <= 1'b1;
  end

  always @(*)
    if (started) begin
      if (field == ERROR_FLAG && passive_flag && flag_sent) assert (tx);
      if (after_listen_only) assert (tx);
    end
endmodule
