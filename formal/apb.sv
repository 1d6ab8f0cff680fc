// APB slave: can_controller_apb completes every transfer exactly once, in its access phase, with
// no error.
//
// Rules (AMBA APB Protocol Specification, ARM IHI 0024C, APB4):
//   2.1 Write transfers / 2.2 Read transfers and 4.1 Operating states (master obligations,
//     assumed): a transfer is one SETUP cycle (PSEL, not PENABLE) followed by ACCESS cycles (PSEL and
//     PENABLE) until PREADY; PENABLE is only high in the ACCESS phase, which follows a SETUP cycle
//     or an ACCESS cycle without PREADY; after reset the bus starts IDLE or in SETUP.
//   3.1 / 3.3 PREADY: the slave extends the ACCESS phase with PREADY low; PREADY high in an ACCESS
//     cycle completes the transfer. Proven: PREADY only in the ACCESS phase (PSEL and PENABLE), so
//     every completion ends a SETUP + ACCESS transfer; each transfer completes, within 10 cycles of
//     ACCESS (the 11th ACCESS cycle at the latest; docs/FPGA.md: 8 clocks of the register port,
//     then PREADY from a flip-flop), hence exactly once; and each transfer makes exactly one
//     register-port access, in its ACCESS phase (a read of the controller has side effects).
//   3.4 Error response: PSLVERR is 0 (docs/FPGA.md: this slave has no error), proven in every
//     cycle.
//
// Assumptions: `reset` high in the first cycle; the master's sequencing above (PSEL, PENABLE).
// PADDR, PWRITE, PWDATA and PSTRB are free in every cycle (their stability is not needed), and the
// controller behind the register port is the black box at the end of this file. Both register
// layouts: word_stride 0 (instance stride0) and 1 (stride1), on the same bus.
//
// Internal names (//! connect:): the wrapper's and the register port's state (helper invariants for
// the proof) and the port's start strobe (the access count).
//
//! read: can_controller_apb.v
//! connect: stride0.state = stride0.dut.state.q
//! connect: stride0.port_start = stride0.dut.port.start
//! connect: stride0.port_state = stride0.dut.port.state.q
//! connect: stride0.port_lane = stride0.dut.port.lane.q
//! connect: stride0.port_done = stride0.dut.port.done
//! connect: stride1.state = stride1.dut.state.q
//! connect: stride1.port_start = stride1.dut.port.start
//! connect: stride1.port_state = stride1.dut.port.state.q
//! connect: stride1.port_lane = stride1.dut.port.lane.q
//! connect: stride1.port_done = stride1.dut.port.done
//! bmc: 30
//! prove: pdr
//! mutation: pready-two-cycles | pready = state$q == ApbState$Ready; => pready = (state$q == ApbState$Ready) | ((state$q == ApbState$Busy) & port$done);
//! mutation: start-in-setup | if (psel & penable) begin => if (psel) begin
//! mutation: pready-before-access | if (port$done) begin => if (1'b1) begin
//! mutation: pslverr-on-write | pslverr = 1'b0; => pslverr = (state$q == ApbState$Ready) & pwrite;
`include "encodings.vh"

module apb (
    input        clock,
    input        reset,
    input        psel,
    input        penable,
    input        pwrite,
    input  [9:0] paddr,
    input [31:0] pwdata,
    input  [3:0] pstrb,
    input        rx
);
  apb_slave #(.WORD_STRIDE(1'b0)) stride0 (.*);
  apb_slave #(.WORD_STRIDE(1'b1)) stride1 (.*);
endmodule

// One wrapper instance, its master's obligations and its rules.
module apb_slave #(
    parameter [0:0] WORD_STRIDE = 1'b0
) (
    input        clock,
    input        reset,
    input        psel,
    input        penable,
    input        pwrite,
    input  [9:0] paddr,
    input [31:0] pwdata,
    input  [3:0] pstrb,
    input        rx
);
  wire [31:0] prdata;
  wire pready, pslverr;
  can_controller_apb #(.word_stride(WORD_STRIDE)) dut (
      .clock(clock),
      .reset(reset),
      .psel(psel),
      .penable(penable),
      .pwrite(pwrite),
      .paddr(paddr),
      .pwdata(pwdata),
      .pstrb(pstrb),
      .prdata(prdata),
      .pready(pready),
      .pslverr(pslverr),
      .rx(rx),
      .tx(),
      .irq(),
      .clkout()
  );

  // Driven from inside the design (//! connect: lines above).
  wire [1:0] state;  // the wrapper's state
  wire port_start;  // start strobe into the register port
  wire [1:0] port_state, port_lane;  // the register port's state and byte lane
  wire port_done;  // the register port's access ends

  localparam IDLE = `ApbState_Idle, BUSY = `ApbState_Busy, READY = `ApbState_Ready;
  localparam PORT_IDLE = `PortState_Idle, PORT_CAPTURE = `PortState_Capture;

  reg started = 1'b0;
  always @(posedge clock) started <= 1'b1;
  always @(*) if (!started) assume (reset);

  wire setup = psel && !penable;
  wire access_phase = psel && penable;
  wire completed = access_phase && pready;

  // The master's sequencing (2.1, 2.2, 4.1): SETUP is followed by ACCESS, ACCESS lasts until
  // PREADY, and PENABLE rises only after SETUP.
  reg was_setup, was_waiting;  // last cycle (not in reset): SETUP; ACCESS without PREADY
  always @(posedge clock) begin
    was_setup <= setup && !reset;
    was_waiting <= access_phase && !pready && !reset;
  end
  always @(*) begin
    if (penable) assume (psel);
    if (started && (was_setup || was_waiting)) assume (access_phase);
    if (started && penable) assume (was_setup || was_waiting);
  end

  // A register-port access begins (the port takes `start` only when idle and not in reset).
  wire access = port_start && port_state == PORT_IDLE && !reset;

  // In the current transfer's ACCESS phase: `age` its cycles before this one, `accesses` the
  // register accesses begun before this one.
  reg [3:0] age;
  reg [1:0] accesses;
  always @(posedge clock)
    if (reset || !access_phase || pready) begin
      age <= 4'd0;
      accesses <= 2'd0;
    end else begin
      age <= age + 4'd1;
      accesses <= accesses + access;
    end

  always @(*)
    if (started) begin
      // 3.1: PREADY only in the ACCESS phase; PSLVERR never.
      assert (!pready || access_phase);
      assert (!pslverr);
      // Every transfer completes in time; one register access per transfer, in its ACCESS phase.
      assert (age <= 4'd10);
      assert (!access || access_phase);
      assert (accesses + access <= 2'd1);
      assert (!completed || accesses == 2'd1);
    end

  // Helper invariants (not rules): the counters against the wrapper's and the port's state.
  wire [3:0] port_step = port_done ? 4'd9 :
      port_state == PORT_IDLE ? 4'd0 : {1'b0, port_lane, 1'b0} + (port_state == PORT_CAPTURE) + 4'd1;
  always @(*)
    if (started) begin
      assert (state <= READY && port_state <= PORT_CAPTURE);
      if (state != IDLE) assert (access_phase && accesses == 2'd1);
      if (state == BUSY) assert (port_step != 4'd0 && age == port_step);
      else assert (port_step == 4'd0);
      if (state == READY) assert (age == 4'd10);
      if (state == IDLE) assert (age == 4'd0 && accesses == 2'd0);
    end
endmodule

`include "controller_stub.vh"
