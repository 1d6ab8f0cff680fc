// Two AXI4-Lite-wrapped CAN controllers on one CAN bus (wired-AND of their tx), for the cocotb
// tests of fpga/cocotb/test_can_wrappers.py. Each node's bus is named n<k>_s_axil_* for
// cocotbext-axi's AxiLiteBus.from_prefix.
module tb_axil #(parameter WORD_STRIDE = 1'b0) (
    input  wire        clock,
    input  wire        reset,
    input  wire        n0_s_axil_awvalid, n0_s_axil_wvalid, n0_s_axil_bready,
    input  wire        n0_s_axil_arvalid, n0_s_axil_rready,
    input  wire [9:0]  n0_s_axil_awaddr, n0_s_axil_araddr,
    input  wire [31:0] n0_s_axil_wdata,
    input  wire [3:0]  n0_s_axil_wstrb,
    output wire        n0_s_axil_awready, n0_s_axil_wready, n0_s_axil_bvalid,
    output wire        n0_s_axil_arready, n0_s_axil_rvalid,
    output wire [1:0]  n0_s_axil_bresp, n0_s_axil_rresp,
    output wire [31:0] n0_s_axil_rdata,
    input  wire        n1_s_axil_awvalid, n1_s_axil_wvalid, n1_s_axil_bready,
    input  wire        n1_s_axil_arvalid, n1_s_axil_rready,
    input  wire [9:0]  n1_s_axil_awaddr, n1_s_axil_araddr,
    input  wire [31:0] n1_s_axil_wdata,
    input  wire [3:0]  n1_s_axil_wstrb,
    output wire        n1_s_axil_awready, n1_s_axil_wready, n1_s_axil_bvalid,
    output wire        n1_s_axil_arready, n1_s_axil_rvalid,
    output wire [1:0]  n1_s_axil_bresp, n1_s_axil_rresp,
    output wire [31:0] n1_s_axil_rdata,
    output wire        n0_irq, n1_irq,
    output wire        can_bus
);
    wire tx0, tx1;
    assign can_bus = tx0 & tx1;
    can_controller_axil #(.word_stride(WORD_STRIDE)) n0 (
        .clock(clock), .reset(reset),
        .s_axil_awvalid(n0_s_axil_awvalid), .s_axil_awready(n0_s_axil_awready),
        .s_axil_awaddr(n0_s_axil_awaddr), .s_axil_wvalid(n0_s_axil_wvalid),
        .s_axil_wready(n0_s_axil_wready), .s_axil_wdata(n0_s_axil_wdata),
        .s_axil_wstrb(n0_s_axil_wstrb), .s_axil_bvalid(n0_s_axil_bvalid),
        .s_axil_bready(n0_s_axil_bready), .s_axil_bresp(n0_s_axil_bresp),
        .s_axil_arvalid(n0_s_axil_arvalid), .s_axil_arready(n0_s_axil_arready),
        .s_axil_araddr(n0_s_axil_araddr), .s_axil_rvalid(n0_s_axil_rvalid),
        .s_axil_rready(n0_s_axil_rready), .s_axil_rdata(n0_s_axil_rdata),
        .s_axil_rresp(n0_s_axil_rresp), .rx(can_bus), .tx(tx0), .irq(n0_irq), .clkout());
    can_controller_axil #(.word_stride(WORD_STRIDE)) n1 (
        .clock(clock), .reset(reset),
        .s_axil_awvalid(n1_s_axil_awvalid), .s_axil_awready(n1_s_axil_awready),
        .s_axil_awaddr(n1_s_axil_awaddr), .s_axil_wvalid(n1_s_axil_wvalid),
        .s_axil_wready(n1_s_axil_wready), .s_axil_wdata(n1_s_axil_wdata),
        .s_axil_wstrb(n1_s_axil_wstrb), .s_axil_bvalid(n1_s_axil_bvalid),
        .s_axil_bready(n1_s_axil_bready), .s_axil_bresp(n1_s_axil_bresp),
        .s_axil_arvalid(n1_s_axil_arvalid), .s_axil_arready(n1_s_axil_arready),
        .s_axil_araddr(n1_s_axil_araddr), .s_axil_rvalid(n1_s_axil_rvalid),
        .s_axil_rready(n1_s_axil_rready), .s_axil_rdata(n1_s_axil_rdata),
        .s_axil_rresp(n1_s_axil_rresp), .rx(can_bus), .tx(tx1), .irq(n1_irq), .clkout());
endmodule
