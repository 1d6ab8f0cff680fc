// Two APB-wrapped CAN controllers on one CAN bus (wired-AND of their tx), for the cocotb tests of
// fpga/cocotb/test_can_wrappers.py. Each node's bus is named n<k>_apb_* for cocotbext-apb.
module tb_apb #(parameter WORD_STRIDE = 1'b0) (
    input  wire        clock,
    input  wire        reset,
    input  wire        n0_apb_psel, n0_apb_penable, n0_apb_pwrite,
    input  wire [9:0]  n0_apb_paddr,
    input  wire [31:0] n0_apb_pwdata,
    input  wire [3:0]  n0_apb_pstrb,
    output wire [31:0] n0_apb_prdata,
    output wire        n0_apb_pready, n0_apb_pslverr,
    input  wire        n1_apb_psel, n1_apb_penable, n1_apb_pwrite,
    input  wire [9:0]  n1_apb_paddr,
    input  wire [31:0] n1_apb_pwdata,
    input  wire [3:0]  n1_apb_pstrb,
    output wire [31:0] n1_apb_prdata,
    output wire        n1_apb_pready, n1_apb_pslverr,
    output wire        n0_irq, n1_irq,
    output wire        can_bus
);
    wire tx0, tx1;
    assign can_bus = tx0 & tx1;
    can_controller_apb #(.word_stride(WORD_STRIDE)) n0 (
        .clock(clock), .reset(reset),
        .psel(n0_apb_psel), .penable(n0_apb_penable), .pwrite(n0_apb_pwrite),
        .paddr(n0_apb_paddr), .pwdata(n0_apb_pwdata), .pstrb(n0_apb_pstrb),
        .prdata(n0_apb_prdata), .pready(n0_apb_pready), .pslverr(n0_apb_pslverr),
        .rx(can_bus), .tx(tx0), .irq(n0_irq), .clkout());
    can_controller_apb #(.word_stride(WORD_STRIDE)) n1 (
        .clock(clock), .reset(reset),
        .psel(n1_apb_psel), .penable(n1_apb_penable), .pwrite(n1_apb_pwrite),
        .paddr(n1_apb_paddr), .pwdata(n1_apb_pwdata), .pstrb(n1_apb_pstrb),
        .prdata(n1_apb_prdata), .pready(n1_apb_pready), .pslverr(n1_apb_pslverr),
        .rx(can_bus), .tx(tx1), .irq(n1_irq), .clkout());
endmodule
