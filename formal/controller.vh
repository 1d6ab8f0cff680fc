// The whole controller as `ctl`, driven by the inputs of formal/controller_ports.vh; its outputs as
// wires the harness reads.
  wire [7:0] rdata;
  wire tx, irq_n, clkout;
  can_controller ctl (
      .clock(clock),
      .reset(reset),
      .addr(addr),
      .wdata(wdata),
      .we(we),
      .re(re),
      .rdata(rdata),
      .rx(rx),
      .tx(tx),
      .irq_n(irq_n),
      .clkout(clkout)
  );
