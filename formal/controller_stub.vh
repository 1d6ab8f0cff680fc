// The controller behind a bus wrapper's register port as a black box (can_controller.v is not read):
// its outputs are free in every cycle, so the wrapper's rules cannot rest on what it answers.
module can_controller (
    input        clock,
    input        reset,
    input  [7:0] addr,
    input  [7:0] wdata,
    input        we,
    input        re,
    output [7:0] rdata,
    input        rx,
    output       tx,
    output       irq_n,
    output       clkout
);
  assign rdata = $anyseq;
  assign tx = $anyseq;
  assign irq_n = $anyseq;
  assign clkout = $anyseq;
endmodule
