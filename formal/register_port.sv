// Configuration registers at the host port: BTR0, BTR1 and the acceptance code and mask registers
// are written only in reset mode and read back what was written; SR.0 (RBS) reads RMC > 0.
//
// Rules (SJA1000 data sheet 6.5.1 BTR0, 6.5.2 BTR1, 6.4.15 acceptance filter (PeliCAN ACR0..3 at 16..19,
// AMR0..3 at 20..23), 6.3.x BasicCAN (ACR 4, AMR 5; BTR0 6, BTR1 7 in both maps)): these registers
// "can only be accessed (written) in reset mode"; in operating mode a write to them is ignored. A
// write in reset mode to the register's address loads it; a read of that address in reset mode returns
// it. 6.4.5 SR bit 0 (RBS): 1 when the RXFIFO holds a message (RMC, 6.4.16, above 0).
// Split into (a) out of reset mode the register never changes, (b) a reset-mode write to its address
// loads `wdata`, (c) a reset-mode read of its address returns the register in `rdata` the cycle after
// the `re` cycle, (d) a read of SR returns RMC != 0 in bit 0, (e) each ACR/AMR read of the
// acceptance filter gives the register. The controller reads these registers from their copies in
// the TX buffer's RAMs (rtl/src/tx_buffer.rs), so (c) proves that each copy always equals its
// register: written together, 0 after reset, none overwriting another. ACR0..3 and AMR0..3 exist only
// as these copies: the harness holds them as the data sheet's rules define them (0 after reset, loaded
// by a reset-mode write to their address in the map in force), so (a) and (b) hold by construction
// for them and (c) and (e) check the copies against the rules; the filter reads them through the
// core port, at any clock the controller grants, while the host may write the frame (e).
//
// The whole controller, every input free (rx too) but for the port contract at the top of
// fpga/rtl/can_controller.v: `reset` in the first cycle, `we` and `re` never together. Both register
// maps are covered: the map (CDR.7) and the mode (MOD.RM) are the controller's own, read from inside;
// the host may switch either at any time the controller allows it.
//
//! read: can_controller.v
//! connect: reset_mode = ctl.modes.rm$q
//! connect: cdr = ctl.modes.cdr_reg$q
//! connect: btr0 = ctl.configuration.btr0$q
//! connect: btr1 = ctl.configuration.btr1$q
//! connect: filter_granted = ctl.filter$copy_granted
//! connect: filter_index = ctl.filter$copy_index
//! connect: filter_data = ctl.filter$copy_data
//! connect: message_count = ctl.fifo$message_count
//! bmc: 12
//! prove: pdr
//! mutation: btr-write-in-operating | if (host$we & reset_mode) begin => if (host$we) begin
//! mutation: filter-write-in-operating | if (we & reset_mode) begin => if (we) begin
//! mutation: btr1-readback | btr1$d = host$wdata; => btr1$d = host$wdata ^ 8'h01;
//! mutation: amr3-copy-kept | localparam  kept_bytes = 32'h7ff1fff; => localparam  kept_bytes = 32'h7f71fff;
//! mutation: filter-copy-index | readback_index = readback_filter | ((filter$host_index) & 5'h1f); => readback_index = readback_filter | ((filter$host_index) & 5'h1b);
//! mutation: filter-read-index | tx_core_index = readback_filter | ((filter$copy_index) & 5'h1f); => tx_core_index = readback_filter | ((filter$copy_index) & 5'h1e);
//! mutation: filter-read-in-frame-write | & ~(writing & (write_index[32'h4] == core_index[32'h4])); => & ~writing;
//! mutation: rbs-or-tbs | ((rbs) << (32'h0)) => ((rbs | tbs) << (32'h0))
module register_port (
`include "controller_ports.vh"
);
`include "controller.vh"

  // Inside the controller (see the `connect` lines).
  wire reset_mode;
  wire [7:0] cdr, btr0, btr1;
  wire [4:0] message_count;
  wire filter_granted;
  wire [2:0] filter_index;
  wire [7:0] filter_data;

  // The port contract.
  reg started = 1'b0;
  always @(posedge clock) started <= 1'b1;
  always @(*) begin
    if (!started) assume (reset);
    assume (!(we && re));
  end

  // The registers, indexed 0 BTR0, 1 BTR1, 2..5 ACR0..3, 6..9 AMR0..3, and their addresses in the map
  // in force (8'hff: none; BasicCAN has ACR0 and AMR0 only, at 4 and 5).
  // (Connected wires are only read, never renamed: `connect` would leave an alias free.)
`define REGISTERS {amr3, amr2, amr1, amr0, acr3, acr2, acr1, acr0, btr1, btr0}
`define REGISTER(r) (r == 0 ? btr0 : r == 1 ? btr1 : r == 2 ? acr0 : r == 3 ? acr1 : r == 4 ? acr2 : \
                     r == 5 ? acr3 : r == 6 ? amr0 : r == 7 ? amr1 : r == 8 ? amr2 : amr3)
  function automatic [7:0] address(input integer r, input pel);
    if (r < 2) address = 8'd6 + r;
    else if (pel) address = 8'd16 + (r - 2);
    else if (r == 2) address = 8'd4;
    else if (r == 6) address = 8'd5;
    else address = 8'hff;
  endfunction

  // ACR0..3 (registers 2..5) and AMR0..3 (6..9) by the data sheet's rules.
  wire [7:0] at_acr0 = address(2, cdr[7]), at_acr1 = address(3, cdr[7]), at_acr2 = address(4, cdr[7]),
             at_acr3 = address(5, cdr[7]), at_amr0 = address(6, cdr[7]), at_amr1 = address(7, cdr[7]),
             at_amr2 = address(8, cdr[7]), at_amr3 = address(9, cdr[7]);
`define WRITTEN(at) (reset_mode && we && at != 8'hff && addr == at)
  reg [7:0] acr0, acr1, acr2, acr3, amr0, amr1, amr2, amr3;
  always @(posedge clock)
    if (reset) {acr0, acr1, acr2, acr3, amr0, amr1, amr2, amr3} <= 64'd0;
    else begin
      if (`WRITTEN(at_acr0)) acr0 <= wdata;
      if (`WRITTEN(at_acr1)) acr1 <= wdata;
      if (`WRITTEN(at_acr2)) acr2 <= wdata;
      if (`WRITTEN(at_acr3)) acr3 <= wdata;
      if (`WRITTEN(at_amr0)) amr0 <= wdata;
      if (`WRITTEN(at_amr1)) amr1 <= wdata;
      if (`WRITTEN(at_amr2)) amr2 <= wdata;
      if (`WRITTEN(at_amr3)) amr3 <= wdata;
    end

  reg past_valid = 1'b0;
  reg past_reset, past_reset_mode, past_pelican, past_we, past_re, past_granted;
  reg [2:0] past_index;
  reg [7:0] past_addr, past_wdata;
  reg [8*10-1:0] past_value;
  reg [4:0] past_count;
  always @(posedge clock) begin
    past_valid <= started;
    {past_reset, past_reset_mode, past_pelican, past_we, past_re} <= {reset, reset_mode, cdr[7], we, re};
    {past_granted, past_index} <= {filter_granted, filter_index};
    {past_addr, past_wdata, past_value, past_count} <= {addr, wdata, `REGISTERS, message_count};
  end

  genvar r;
  generate
    for (r = 0; r < 10; r = r + 1) begin : register
      wire [7:0] at = address(r, past_pelican);
      wire hit = at != 8'hff && past_addr == at;
      always @(*)
        if (past_valid && !past_reset) begin
          // (a) Operating mode: no change.
          if (!past_reset_mode) assert (`REGISTER(r) == past_value[8*r+:8]);
          // (b) Reset mode: a write to the address loads wdata.
          if (past_reset_mode && past_we && hit) assert (`REGISTER(r) == past_wdata);
          // (c) Reset mode: a read of the address returns the register.
          if (past_reset_mode && past_re && hit) assert (rdata == past_value[8*r+:8]);
        end
    end
  endgenerate

  // (e) A granted read of the filter's register k (0..3 ACR0..3, 4..7 AMR0..3) gives the register
  // the cycle after, but when that cycle wrote a register (reset mode, no frame is filtered then).
  always @(*)
    if (past_valid && !past_reset && past_granted && !(past_we && past_reset_mode))
      assert (filter_data == past_value[8*(2 + past_index)+:8]);

  // (d) SR.0 = RBS = RMC != 0, in both maps and modes.
  always @(*) if (past_valid && !past_reset && past_re && past_addr == 8'd2) assert (rdata[0] == (past_count != 5'd0));
endmodule
`undef REGISTERS
`undef WRITTEN
`undef REGISTER
