// Two SJA1000-compatible CAN controllers on an iCEBreaker (iCE40UP5K-SG48), driven from a host
// over the board's USB serial port (115200 baud, 8N1) through a register bridge:
//
//   write: 3 bytes  {1'b1, 6'b0, node}, register, value      (no answer)
//   read:  2 bytes  {1'b0, 6'b0, node}, register             (answer: the register's value)
//
// Each controller's TXD/RXD go to PMOD 1A for an external transceiver (e.g. a TJA1051 module):
// node 0 TXD on P1A1, RXD on P1A2; node 1 TXD on P1A3, RXD on P1A4. The controllers run on the
// board's 12 MHz clock (their fosc: 500 kbit/s is BTR0 00h, BTR1 27h: 12 tq of 2 clocks). The red
// LED is on while either controller is bus-off (the bridge reads SR when the host is quiet; SR
// reads have no side effects), the green one while either has an interrupt pending. BTN_N resets.
// Written by hand (not generated); tb_icebreaker_can.v beside it tests it in Icarus.
// CLOCKS_PER_BIT: 104 is 115200 baud at 12 MHz (0.2 % off); the bench makes it faster.
module icebreaker_can #(parameter CLOCKS_PER_BIT = 104) (
    input  wire CLK,      // 12 MHz
    input  wire BTN_N,    // reset, active low
    input  wire RX,       // from the host (FTDI TXD)
    output wire TX,       // to the host
    output wire LEDR_N,
    output wire LEDG_N,
    output wire P1A1,     // node 0 TXD
    input  wire P1A2,     // node 0 RXD
    output wire P1A3,     // node 1 TXD
    input  wire P1A4      // node 1 RXD
);

    localparam SR = 8'd2;
    localparam SR_BUS_OFF = 7;

    // ---- Reset: held for 16 clocks after configuration and while BTN_N is pressed.
    reg [4:0] por = 5'd0;
    reg [1:0] button = 2'b00;
    wire reset = ~por[4] | ~button[1];
    always @(posedge CLK) begin
        button <= {button[0], BTN_N};
        if (!por[4]) por <= por + 5'd1;
    end

    // ---- The bridge's states (its logic is below).
    localparam IDLE = 3'd0, REGISTER = 3'd1, VALUE = 3'd2, READ = 3'd3, ANSWER = 3'd4,
               POLL = 3'd5, POLLED = 3'd6;
    reg [2:0] state = IDLE;

    // ---- UART receiver and transmitter.
    wire [7:0] rx_byte;
    wire rx_valid;
    reg [7:0] tx_byte = 8'h00;
    reg tx_start = 1'b0;
    wire tx_busy;
    // A byte waits in the receiver while the bridge polls or answers.
    wire take = rx_valid & (state == IDLE || state == REGISTER || state == VALUE);
    uart_rx #(.CLOCKS_PER_BIT(CLOCKS_PER_BIT)) uart_in (
        .clock(CLK), .reset(reset), .rx(RX), .take(take), .data(rx_byte), .valid(rx_valid));
    uart_tx #(.CLOCKS_PER_BIT(CLOCKS_PER_BIT)) uart_out (
        .clock(CLK), .reset(reset), .start(tx_start), .data(tx_byte), .tx(TX), .busy(tx_busy));

    // ---- The controllers.
    reg [7:0] addr = 8'h00, wdata = 8'h00;
    reg [1:0] we = 2'b00, re = 2'b00;
    wire [7:0] rdata0, rdata1;
    wire [1:0] irq_n;
    // CLKOUT is not used on this board.
    /* verilator lint_off PINCONNECTEMPTY */
    can_controller node0 (
        .clock(CLK), .reset(reset), .addr(addr), .wdata(wdata), .we(we[0]), .re(re[0]),
        .rdata(rdata0), .rx(P1A2), .tx(P1A1), .irq_n(irq_n[0]), .clkout());
    can_controller node1 (
        .clock(CLK), .reset(reset), .addr(addr), .wdata(wdata), .we(we[1]), .re(re[1]),
        .rdata(rdata1), .rx(P1A4), .tx(P1A3), .irq_n(irq_n[1]), .clkout());
    /* verilator lint_on PINCONNECTEMPTY */

    // ---- The bridge: command, register, value; between commands it polls SR of both nodes.
    reg write = 1'b0, node = 1'b0, poll_node = 1'b0;
    reg [1:0] bus_off = 2'b00;
    reg [15:0] quiet = 16'd0;
    wire [7:0] rdata = node ? rdata1 : rdata0;

    always @(posedge CLK) begin
        we <= 2'b00;
        re <= 2'b00;
        tx_start <= 1'b0;
        quiet <= quiet + 16'd1;
        case (state)
            IDLE:
                if (rx_valid) begin
                    write <= rx_byte[7];
                    node <= rx_byte[0];
                    state <= REGISTER;
                end else if (quiet == 16'hFFFF) begin
                    node <= poll_node;
                    addr <= SR;
                    re <= poll_node ? 2'b10 : 2'b01;
                    state <= POLL;
                end
            REGISTER:
                if (rx_valid) begin
                    addr <= rx_byte;
                    if (write) begin
                        state <= VALUE;
                    end else begin
                        re <= node ? 2'b10 : 2'b01;
                        state <= READ;
                    end
                end
            VALUE:
                if (rx_valid) begin
                    wdata <= rx_byte;
                    we <= node ? 2'b10 : 2'b01;
                    quiet <= 16'd0;
                    state <= IDLE;
                end
            READ:  // rdata is valid the cycle after the read strobe
                state <= ANSWER;
            ANSWER:
                if (!tx_busy) begin
                    tx_byte <= rdata;
                    tx_start <= 1'b1;
                    quiet <= 16'd0;
                    state <= IDLE;
                end
            POLL:
                state <= POLLED;
            POLLED: begin
                bus_off[poll_node] <= rdata[SR_BUS_OFF];
                poll_node <= ~poll_node;
                state <= IDLE;
            end
            default:
                state <= IDLE;
        endcase
        if (reset) begin
            state <= IDLE;
            bus_off <= 2'b00;
            quiet <= 16'd0;
        end
    end

    assign LEDR_N = ~(|bus_off);
    assign LEDG_N = &irq_n;
endmodule
