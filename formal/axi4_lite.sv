// AXI4-Lite slave: can_controller_axil answers every request once, holds its responses until the
// master takes them, and no READY waits for a VALID.
//
// Rules (AMBA AXI and ACE Protocol Specification, ARM IHI 0022, AXI4-Lite is chapter B1):
//   A3.1.2 Reset: the slave drives BVALID and RVALID low during reset (here, with the synchronous
//     active-high `reset`: low in the cycle after a reset cycle).
//   A3.2.1 Handshake process: once a source asserts VALID it holds VALID, and its information stays
//     stable, until the handshake (VALID and READY high at a rising edge): BVALID with BRESP until
//     BREADY, RVALID with RDATA and RRESP until RREADY.
//   A3.3 Relationships between the channels: the slave gives the write response only after both the
//     AW and the W handshake of the write, and the read data only after the AR handshake; one
//     response per transaction (AXI4-Lite: every transaction has burst length 1). Counted here: a
//     response never goes out without an answered-for request, and each AW+W pair and each AR gets
//     one register-port access (docs/FPGA.md) and one response.
//   A3.3.1 Dependencies between channel handshake signals: the slave can wait for AWVALID, WVALID
//     or ARVALID before asserting the READY, but must not have to: here every READY is the output of
//     a flip-flop (docs/FPGA.md "every ready comes from a flip-flop"), proven as READY(t) == the
//     flip-flop's next-state value at t-1, so no VALID of cycle t can reach a READY of cycle t.
//   B1.1 (AXI4-Lite): BRESP and RRESP are OKAY (0); this slave has no error response.
//   Liveness, bounded: from the first cycle in which the slave holds both the AW and the W of a
//     write, at most 21 cycles pass before its BVALID (10 when no read goes first: 8 clocks of the
//     register port, docs/FPGA.md, plus 2), not counting cycles in which the master holds off the
//     read response (RVALID without RREADY); the same for a held AR and its RVALID. 21 = a read that
//     went first (10 cycles, then 1 for its response handshake) plus the write's own 10. Reads and
//     writes take turns, so neither starves the other.
//
// Assumptions: only that `reset` is high in the first cycle. The properties hold whatever the
// master does (the master's obligations of A3.2.1, VALID held with stable payload until READY, and of
// A3.1.2, no VALID during reset, are not needed) and whatever the controller answers: can_controller
// is replaced by the black box at the end of this file, its outputs free in every cycle. Both register layouts are proven: word_stride 0 (instance
// stride0) and 1 (stride1), driven by the same bus.
//
// Internal names (//! connect:): the next-state inputs of the three READY flip-flops (aw_full,
// w_full, ar_full: READY is their inverse), the register port's start/write strobes (counted), and
// the wrapper's and the port's state, for the helper invariants that let the proof close.
//
//! read: can_controller_axil.v
//! connect: stride0.aw_full_d = stride0.dut.aw_full.d
//! connect: stride0.w_full_d = stride0.dut.w_full.d
//! connect: stride0.ar_full_d = stride0.dut.ar_full.d
//! connect: stride0.port_start = stride0.dut.port.start
//! connect: stride0.port_write = stride0.dut.port.write
//! connect: stride0.state = stride0.dut.state.q
//! connect: stride0.last_write = stride0.dut.last_write.q
//! connect: stride0.port_state = stride0.dut.port.state.q
//! connect: stride0.port_lane = stride0.dut.port.lane.q
//! connect: stride0.port_done = stride0.dut.port.done
//! connect: stride1.aw_full_d = stride1.dut.aw_full.d
//! connect: stride1.w_full_d = stride1.dut.w_full.d
//! connect: stride1.ar_full_d = stride1.dut.ar_full.d
//! connect: stride1.port_start = stride1.dut.port.start
//! connect: stride1.port_write = stride1.dut.port.write
//! connect: stride1.state = stride1.dut.state.q
//! connect: stride1.last_write = stride1.dut.last_write.q
//! connect: stride1.port_state = stride1.dut.port.state.q
//! connect: stride1.port_lane = stride1.dut.port.lane.q
//! connect: stride1.port_done = stride1.dut.port.done
//! bmc: 30
//! prove: pdr
//! mutation: awready-combinational | s_axil_awready = aw_full$q == 1'b0; => s_axil_awready = (aw_full$q == 1'b0) & s_axil_awvalid;
//! mutation: bvalid-not-held | if (s_axil_bready) begin => if (s_axil_bready | s_axil_rready) begin
//! mutation: write-without-w | if (aw_full$q & w_full$q) begin => if (aw_full$q) begin
//! mutation: rdata-not-held | rdata = data_in$q; => rdata = {24'h0, can$rdata};
//! mutation: bresp-slverr | s_axil_bresp = 32'h0; => s_axil_bresp = 32'h2;
//! mutation: read-starves-write | if (ar_full$q & (last_write$q | (begin_write == 1'b0))) begin => if (ar_full$q) begin
`include "encodings.vh"

module axi4_lite (
    input        clock,
    input        reset,
    input        awvalid,
    input  [9:0] awaddr,
    input        wvalid,
    input [31:0] wdata,
    input  [3:0] wstrb,
    input        bready,
    input        arvalid,
    input  [9:0] araddr,
    input        rready,
    input        rx
);
  axi4_lite_slave #(.WORD_STRIDE(1'b0)) stride0 (.*);
  axi4_lite_slave #(.WORD_STRIDE(1'b1)) stride1 (.*);
endmodule

// One wrapper instance and its rules.
module axi4_lite_slave #(
    parameter [0:0] WORD_STRIDE = 1'b0
) (
    input        clock,
    input        reset,
    input        awvalid,
    input  [9:0] awaddr,
    input        wvalid,
    input [31:0] wdata,
    input  [3:0] wstrb,
    input        bready,
    input        arvalid,
    input  [9:0] araddr,
    input        rready,
    input        rx
);
  wire awready, wready, bvalid, arready, rvalid;
  wire [1:0] bresp, rresp;
  wire [31:0] rdata;
  can_controller_axil #(.word_stride(WORD_STRIDE)) dut (
      .clock(clock),
      .reset(reset),
      .s_axil_awvalid(awvalid),
      .s_axil_awready(awready),
      .s_axil_awaddr(awaddr),
      .s_axil_wvalid(wvalid),
      .s_axil_wready(wready),
      .s_axil_wdata(wdata),
      .s_axil_wstrb(wstrb),
      .s_axil_bvalid(bvalid),
      .s_axil_bready(bready),
      .s_axil_bresp(bresp),
      .s_axil_arvalid(arvalid),
      .s_axil_arready(arready),
      .s_axil_araddr(araddr),
      .s_axil_rvalid(rvalid),
      .s_axil_rready(rready),
      .s_axil_rdata(rdata),
      .s_axil_rresp(rresp),
      .rx(rx),
      .tx(),
      .irq(),
      .clkout()
  );

  // Driven from inside the design (//! connect: lines above).
  wire aw_full_d, w_full_d, ar_full_d;  // next state of the flip-flops whose inverse is each READY
  wire port_start, port_write;  // the register port starts an access (a write when port_write)
  wire [2:0] state;  // the wrapper's state
  wire last_write;  // the last access was a write (a waiting read goes first)
  wire [1:0] port_state, port_lane;  // the register port's state and byte lane
  wire port_done;  // the register port's access ends

  localparam IDLE = `AxiState_Idle, WRITE = `AxiState_Write, READ = `AxiState_Read;
  localparam WRITE_RESPONSE = `AxiState_WriteResponse, READ_RESPONSE = `AxiState_ReadResponse;
  localparam PORT_IDLE = `PortState_Idle, PORT_CAPTURE = `PortState_Capture;
  localparam LIMIT = 5'd21;  // bound on the owed cycles before a response (header)

  reg started = 1'b0;
  always @(posedge clock) started <= 1'b1;
  always @(*) if (!started) assume (reset);

  wire aw_taken = awvalid && awready;
  wire w_taken = wvalid && wready;
  wire ar_taken = arvalid && arready;
  wire b_taken = bvalid && bready;
  wire r_taken = rvalid && rready;

  // Requests taken and not yet answered by a response handshake, register-port accesses started and
  // not yet answered, and the owed cycles of the oldest unanswered write and read.
  reg [1:0] aw_open, w_open, ar_open;
  reg w_access, r_access;
  reg [4:0] b_wait, r_wait;
  wire write_owed = aw_open != 2'd0 && w_open != 2'd0 && !bvalid;
  wire read_owed = ar_open != 2'd0 && !rvalid;
  always @(posedge clock) begin
    if (reset) begin
      aw_open <= 2'd0;
      w_open <= 2'd0;
      ar_open <= 2'd0;
      w_access <= 1'b0;
      r_access <= 1'b0;
    end else begin
      aw_open <= aw_open + aw_taken - b_taken;
      w_open <= w_open + w_taken - b_taken;
      ar_open <= ar_open + ar_taken - r_taken;
      w_access <= w_access + (port_start && port_write) - b_taken;
      r_access <= r_access + (port_start && !port_write) - r_taken;
    end
    if (reset || !write_owed) b_wait <= 5'd0;
    else if (!(rvalid && !rready)) b_wait <= b_wait + 5'd1;
    if (reset || !read_owed) r_wait <= 5'd0;
    else if (!(bvalid && !bready)) r_wait <= r_wait + 5'd1;
  end

  // A3.3: no response without its request; one register access and one response per request; at
  // most one transaction in the register port.
  always @(*)
    if (started) begin
      assert (aw_open <= 2'd2 && w_open <= 2'd2 && ar_open <= 2'd2);
      if (bvalid) assert (aw_open != 2'd0 && w_open != 2'd0 && w_access);
      if (rvalid) assert (ar_open != 2'd0 && r_access);
      if (w_access) assert (aw_open != 2'd0 && w_open != 2'd0);
      if (r_access) assert (ar_open != 2'd0);
      assert (!(w_access && r_access));
      assert (!port_start || (!w_access && !r_access));
    end

  // B1.1: OKAY responses.
  always @(*) if (bvalid) assert (bresp == 2'b00);
  always @(*) if (rvalid) assert (rresp == 2'b00);

  // A3.1.2 and A3.2.1: no response after reset; a response waits, unchanged, for its READY.
  always @(posedge clock)
    if (started) begin
      if ($past(reset)) assert (!bvalid && !rvalid);
      if ($past(bvalid && !bready && !reset)) assert (bvalid && bresp == $past(bresp));
      if ($past(rvalid && !rready && !reset))
        assert (rvalid && rdata == $past(rdata) && rresp == $past(rresp));
    end

  // A3.3.1: every READY is the registered value computed the cycle before.
  always @(posedge clock)
    if (started) begin
      assert (awready == !$past(aw_full_d));
      assert (wready == !$past(w_full_d));
      assert (arready == !$past(ar_full_d));
    end

  // Bounded response time.
  always @(*) if (started) assert (b_wait <= LIMIT && r_wait <= LIMIT);

  // Helper invariants (not rules): the counters above against the wrapper's and the port's state.
  wire [3:0] port_step = port_done ? 4'd9 :
      port_state == PORT_IDLE ? 4'd0 : {1'b0, port_lane, 1'b0} + (port_state == PORT_CAPTURE) + 4'd1;
  always @(*)
    if (started) begin
      assert (state <= READ_RESPONSE && port_state <= PORT_CAPTURE);
      assert (aw_open == !awready + (state == WRITE_RESPONSE));
      assert (w_open == !wready + (state == WRITE_RESPONSE));
      assert (ar_open == !arready + (state == READ_RESPONSE));
      assert (w_access == (state == WRITE || state == WRITE_RESPONSE));
      assert (r_access == (state == READ || state == READ_RESPONSE));
      if (state == WRITE) assert (!awready && !wready && last_write);
      if (state == WRITE_RESPONSE) assert (last_write);
      if (state == READ) assert (!arready && !last_write);
      if (state == READ_RESPONSE) assert (!last_write);
      if (state == WRITE || state == READ) assert (port_step != 4'd0);
      else assert (port_step == 4'd0);
      if (state == IDLE) assert (b_wait <= 5'd11 && r_wait <= 5'd11);
      if (state == IDLE && b_wait != 5'd0) assert (!last_write);
      if (state == IDLE && r_wait != 5'd0) assert (last_write);
      if (state == WRITE) assert (b_wait <= port_step + 5'd11 && r_wait <= port_step);
      if (state == READ) assert (r_wait <= port_step + 5'd11 && b_wait <= port_step);
      if (state == WRITE_RESPONSE) assert (r_wait <= 5'd10);
      if (state == READ_RESPONSE) assert (b_wait <= 5'd10);
    end
endmodule

`include "controller_stub.vh"
