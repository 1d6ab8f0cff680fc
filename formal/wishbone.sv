// Wishbone B4 slave: can_controller_wb acknowledges every request exactly once, with a one-cycle
// ACK inside the bus cycle, for classic and for pipelined masters.
//
// Rules (Wishbone B4, OpenCores 2010):
//   3.1.2 Transfer cycle initiation, RULE 3.25: CYC_O is asserted for the whole bus cycle, no later
//     than STB_O (master obligation, assumed: STB only with CYC; a pipelined master keeps CYC while
//     it waits for an ACK); RULE 3.30: a slave does not respond while CYC_I is negated.
//   3.1.3 Handshaking protocol, RULE 3.35: ACK_O is generated in response to CYC_I and STB_I.
//     Classic: STB_O stays asserted until the terminating ACK (master obligation, assumed), so the
//     ACK must come while CYC and STB are high, and ends the request.
//     Pipelined (B4's pipelined mode, STALL_O): a request is taken at each edge with CYC, STB and
//     no STALL; its ACK may come later, while CYC is high.
//   Proven: (a) ACK only inside CYC (classic: inside CYC and STB); (b) exactly one ACK per request:
//     no ACK without an unanswered request (pipelined: at most one outstanding), and every request
//     answered within 10 cycles (docs/FPGA.md: 8 clocks of the register port, then the ACK);
//     (c) ACK is a single-cycle pulse; (d) each request makes exactly one register-port access
//     (a read of the controller has side effects: it must not be repeated or skipped).
//
// Assumptions: `reset` high in the first cycle; STB only with CYC; classic masters (instances
// classic0/classic1) hold CYC and STB until the ACK; pipelined masters (pipelined0/pipelined1) hold
// CYC while a request is outstanding. Nothing else: addresses, data, WE and SEL are free in every
// cycle, and the controller behind the register port is the black box at the end of this file.
// Both register layouts: word_stride 0 (…0) and 1 (…1).
//
// Not covered: a master that aborts (drops CYC before the ACK, which RULE 3.25 forbids). The wrapper
// then finishes the access and still raises ACK for one cycle, outside CYC, and a request started
// before that ACK would take it as its own.
//
// Internal names (//! connect:): the wrapper's and the register port's state (helper invariants for
// the proof) and the port's start strobe (the access count).
//
//! read: can_controller_wb.v
//! connect: classic0.state = classic0.dut.state.q
//! connect: classic0.port_start = classic0.dut.port.start
//! connect: classic0.port_state = classic0.dut.port.state.q
//! connect: classic0.port_lane = classic0.dut.port.lane.q
//! connect: classic0.port_done = classic0.dut.port.done
//! connect: classic1.state = classic1.dut.state.q
//! connect: classic1.port_start = classic1.dut.port.start
//! connect: classic1.port_state = classic1.dut.port.state.q
//! connect: classic1.port_lane = classic1.dut.port.lane.q
//! connect: classic1.port_done = classic1.dut.port.done
//! connect: pipelined0.state = pipelined0.dut.state.q
//! connect: pipelined0.port_start = pipelined0.dut.port.start
//! connect: pipelined0.port_state = pipelined0.dut.port.state.q
//! connect: pipelined0.port_lane = pipelined0.dut.port.lane.q
//! connect: pipelined0.port_done = pipelined0.dut.port.done
//! connect: pipelined1.state = pipelined1.dut.state.q
//! connect: pipelined1.port_start = pipelined1.dut.port.start
//! connect: pipelined1.port_state = pipelined1.dut.port.state.q
//! connect: pipelined1.port_lane = pipelined1.dut.port.lane.q
//! connect: pipelined1.port_done = pipelined1.dut.port.done
//! bmc: 30
//! prove: pdr
//! mutation: ack-two-cycles | wb_ack = state$q == WishboneState$Ack; => wb_ack = (state$q == WishboneState$Ack) | ((state$q == WishboneState$Busy) & port$done);
//! mutation: no-stall | wb_stall = state$q != WishboneState$Idle; => wb_stall = 1'b0;
//! mutation: ack-before-access | if (port$done) begin => if (1'b1) begin
//! mutation: request-without-cyc | if (wb_cyc & wb_stb) begin => if (wb_stb | wb_we) begin
`include "encodings.vh"

module wishbone (
    input        clock,
    input        reset,
    input        cyc,
    input        stb,
    input        we,
    input  [7:0] adr,
    input  [3:0] sel,
    input [31:0] dat_w,
    input        rx
);
  wishbone_slave #(.WORD_STRIDE(1'b0), .CLASSIC(1)) classic0 (.*);
  wishbone_slave #(.WORD_STRIDE(1'b1), .CLASSIC(1)) classic1 (.*);
  wishbone_slave #(.WORD_STRIDE(1'b0), .CLASSIC(0)) pipelined0 (.*);
  wishbone_slave #(.WORD_STRIDE(1'b1), .CLASSIC(0)) pipelined1 (.*);
endmodule

// One wrapper instance, its master's obligations and its rules.
module wishbone_slave #(
    parameter [0:0] WORD_STRIDE = 1'b0,
    parameter CLASSIC = 1
) (
    input        clock,
    input        reset,
    input        cyc,
    input        stb,
    input        we,
    input  [7:0] adr,
    input  [3:0] sel,
    input [31:0] dat_w,
    input        rx
);
  wire [31:0] dat_r;
  wire ack, stall;
  can_controller_wb #(.word_stride(WORD_STRIDE)) dut (
      .clock(clock),
      .reset(reset),
      .wb_cyc(cyc),
      .wb_stb(stb),
      .wb_we(we),
      .wb_adr(adr),
      .wb_sel(sel),
      .wb_dat_w(dat_w),
      .wb_dat_r(dat_r),
      .wb_ack(ack),
      .wb_stall(stall),
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

  localparam IDLE = `WishboneState_Idle, BUSY = `WishboneState_Busy, ACK = `WishboneState_Ack;
  localparam PORT_IDLE = `PortState_Idle, PORT_CAPTURE = `PortState_Capture;

  reg started = 1'b0;
  always @(posedge clock) started <= 1'b1;
  always @(*) if (!started) assume (reset);

  // A register-port access begins (the port takes `start` only when idle and not in reset).
  wire access = port_start && port_state == PORT_IDLE && !reset;

  // The request in progress: classic, from the first cycle of CYC and STB to its ACK; pipelined,
  // from the edge that takes it (CYC, STB, no STALL) to its ACK. `age` counts its cycles before
  // this one, `accesses` the register accesses begun for it before this one.
  wire taken = CLASSIC ? cyc && stb && !pending : cyc && stb && !stall;
  reg pending;
  reg [1:0] outstanding;  // pipelined: requests taken and not yet acknowledged
  reg [3:0] age;
  reg [1:0] accesses;
  always @(posedge clock) begin
    if (reset) begin
      pending <= 1'b0;
      outstanding <= 2'd0;
      age <= 4'd0;
      accesses <= 2'd0;
    end else begin
      pending <= CLASSIC ? cyc && stb && !ack : outstanding + (cyc && stb && !stall) - ack != 2'd0;
      outstanding <= outstanding + (cyc && stb && !stall) - ack;
      age <= (ack || !(pending || taken)) ? 4'd0 : age + 4'd1;
      accesses <= (ack || !(pending || taken)) ? 2'd0 : accesses + access;
    end
  end

  // The master's obligations (RULE 3.25 and the handshaking protocol).
  always @(*) if (!cyc) assume (!stb);
  generate
    if (CLASSIC) begin : classic_master
      reg waiting;  // the last cycle had CYC and STB without ACK (and no reset)
      always @(posedge clock) waiting <= cyc && stb && !ack && !reset;
      always @(*) if (started && waiting) assume (cyc && stb);
    end else begin : pipelined_master
      always @(*) if (started && outstanding != 2'd0) assume (cyc);
    end
  endgenerate

  always @(*)
    if (started) begin
      // (a) RULE 3.35 / 3.30: ACK only in response to CYC (and STB, classic).
      assert (!ack || cyc);
      if (CLASSIC) assert (!ack || stb);
      // (b) no ACK without its request; one request at a time; every request answered in time.
      assert (!ack || pending);
      if (!CLASSIC) assert (outstanding <= 2'd1 && (!ack || outstanding == 2'd1));
      assert (age <= 4'd10);
      // (d) one register access per request: begun only for a request, once, before its ACK.
      assert (!access || taken);
      assert (accesses + access <= 2'd1);
      assert (!ack || accesses == 2'd1);
    end
  // (c) ACK lasts one cycle.
  always @(posedge clock) if (started && $past(ack && !reset)) assert (!ack);

  // Helper invariants (not rules): the counters against the wrapper's and the port's state.
  wire [3:0] port_step = port_done ? 4'd9 :
      port_state == PORT_IDLE ? 4'd0 : {1'b0, port_lane, 1'b0} + (port_state == PORT_CAPTURE) + 4'd1;
  always @(*)
    if (started) begin
      assert (state <= ACK && port_state <= PORT_CAPTURE);
      assert (pending == (state != IDLE));
      if (!CLASSIC) assert (outstanding == (state != IDLE));
      if (state == BUSY) assert (port_step != 4'd0 && age == port_step && accesses == 2'd1);
      else assert (port_step == 4'd0);
      if (state == ACK) assert (age == 4'd10 && accesses == 2'd1);
      if (state == IDLE) assert (age == 4'd0 && accesses == 2'd0);
    end
endmodule

`include "controller_stub.vh"
