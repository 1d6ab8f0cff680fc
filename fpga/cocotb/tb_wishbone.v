// Two Wishbone-wrapped CAN controllers on one CAN bus (wired-AND of their tx), for the cocotb tests
// of fpga/cocotb/test_can_wrappers.py. Each node's bus is named n<k>_wb_* for cocotbext-wishbone.
module tb_wishbone #(parameter WORD_STRIDE = 1'b0) (
    input  wire        clock,
    input  wire        reset,
    input  wire        n0_wb_cyc, n0_wb_stb, n0_wb_we,
    input  wire [7:0]  n0_wb_adr,
    input  wire [3:0]  n0_wb_sel,
    input  wire [31:0] n0_wb_dat_w,
    output wire [31:0] n0_wb_dat_r,
    output wire        n0_wb_ack, n0_wb_stall,
    input  wire        n1_wb_cyc, n1_wb_stb, n1_wb_we,
    input  wire [7:0]  n1_wb_adr,
    input  wire [3:0]  n1_wb_sel,
    input  wire [31:0] n1_wb_dat_w,
    output wire [31:0] n1_wb_dat_r,
    output wire        n1_wb_ack, n1_wb_stall,
    output wire        n0_irq, n1_irq,
    output wire        can_bus
);
    wire tx0, tx1;
    assign can_bus = tx0 & tx1;
    can_controller_wb #(.word_stride(WORD_STRIDE)) n0 (
        .clock(clock), .reset(reset),
        .wb_cyc(n0_wb_cyc), .wb_stb(n0_wb_stb), .wb_we(n0_wb_we), .wb_adr(n0_wb_adr),
        .wb_sel(n0_wb_sel), .wb_dat_w(n0_wb_dat_w), .wb_dat_r(n0_wb_dat_r), .wb_ack(n0_wb_ack),
        .wb_stall(n0_wb_stall), .rx(can_bus), .tx(tx0), .irq(n0_irq), .clkout());
    can_controller_wb #(.word_stride(WORD_STRIDE)) n1 (
        .clock(clock), .reset(reset),
        .wb_cyc(n1_wb_cyc), .wb_stb(n1_wb_stb), .wb_we(n1_wb_we), .wb_adr(n1_wb_adr),
        .wb_sel(n1_wb_sel), .wb_dat_w(n1_wb_dat_w), .wb_dat_r(n1_wb_dat_r), .wb_ack(n1_wb_ack),
        .wb_stall(n1_wb_stall), .rx(can_bus), .tx(tx1), .irq(n1_irq), .clkout());
endmodule
