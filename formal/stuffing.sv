// Bit stuffing: while the node transmits a frame, the bits it sends from SOF to the end of the CRC
// sequence never hold six equal values in a row.
//
// Rule (Bosch CAN 2.0 part B section 6 "Coding"; ISO 11898-1 "bit stuffing"): the frame
// segments SOF, arbitration field, control field, data field and CRC sequence are coded by bit
// stuffing: whenever a transmitter detects five consecutive bits of identical value in the bit stream
// to be transmitted, it inserts a complementary bit in the actual transmitted bit stream. Error and
// overload flags, delimiters, ACK and EOF are of fixed form and not stuffed.
//
// Checked on the bit stream processor (top$core$protocol) with every input free (bus level, host
// requests, transmit-buffer bytes, enable) except two contracts of the controller around it: the order
// of the bit-timing triggers, which formal/bit_timing.sv proves (a process point and a transmit point
// never share a clock; between two process points there is a transmit point), and the modes
// listen-only and self-test changing only while the engine is disabled (reset mode: the SJA1000
// takes MOD.LOM and MOD.STM only in reset mode, data sheet 6.4.3). The harness reads `tx` at each
// process point (the bit the node sends in that bit time) and counts the run of equal bits while
// the node is the transmitter in SOF .. CRC sequence.
//
//! read: can_controller.v
//! connect: field = protocol.field$q
//! connect: field_next = protocol.field$d
//! connect: transmitter = protocol.transmitter$q
//! bmc: 40
//! prove: pdr
//! mutation: sixth-bit-unstuffed | four_equal = active$q & (run_length$q == 32'h4); => four_equal = active$q & (run_length$q == 32'h5);
`include "encodings.vh"

module stuffing (
`include "protocol_ports.vh"
);
  localparam [3:0] IDLE = `ProtocolState_Idle, ARBITRATION = `ProtocolState_Arbitration;
  localparam [3:0] CONTROL = `ProtocolState_Control, DATA = `ProtocolState_Data, CRC = `ProtocolState_Crc;
  localparam [3:0] INTERMISSION = `ProtocolState_Intermission, SUSPEND = `ProtocolState_Suspend;

  wire [3:0] field, field_next;
  wire transmitter;

`include "protocol_engine.vh"

  reg started = 1'b0;
  always @(posedge clock) started <= 1'b1;
  always @(*) if (!started) assume (reset);

  // The bit-timing contract (proved in formal/bit_timing.sv).
  reg transmitted_since_process = 1'b1;
  always @(posedge clock)
    if (process_point) transmitted_since_process <= 1'b0;
    else if (transmit_point) transmitted_since_process <= 1'b1;
  always @(*) assume (!(process_point && transmit_point));
  always @(*) if (process_point) assume (transmitted_since_process);

  // Modes change only in reset mode (enable low).
  reg listen_only_was, self_test_was, enable_was = 1'b0;
  always @(posedge clock) {listen_only_was, self_test_was, enable_was} <= {listen_only, self_test, enable};
  always @(*) if (started && enable && enable_was) assume ({listen_only, self_test} == {listen_only_was, self_test_was});

  // SOF: the bit that takes the engine from idle, suspend or intermission into arbitration.
  wire sof = (field == IDLE || field == SUSPEND || field == INTERMISSION) && field_next == ARBITRATION;
  wire stuffed_field = field == ARBITRATION || field == CONTROL || field == DATA || field == CRC;
  wire sending = enable && transmitter && (sof || stuffed_field);

  // The run of equal bits the node has sent so far in this frame's stuffed region.
  reg [2:0] run = 3'd0;
  reg run_level = 1'b1;
  always @(posedge clock) begin
    if (reset) run <= 3'd0;
    else if (process_point) begin
      if (!sending || sof) begin
        // SOF is dominant on the bus even when another node sent it (a node with a frame pending
        // takes a dominant third intermission bit as SOF and sends its identifier from the next bit).
        run <= sending ? 3'd1 : 3'd0;
        run_level <= 1'b0;
      end else if (tx == run_level && run != 3'd0) run <= run + 3'd1;
      else begin
        run <= 3'd1;
        run_level <= tx;
      end
    end
  end

  always @(*) if (started && !reset && process_point && sending && !sof && run != 3'd0) assert (!(run == 3'd5 && tx == run_level));
  always @(*) assert (run <= 3'd5);
endmodule
