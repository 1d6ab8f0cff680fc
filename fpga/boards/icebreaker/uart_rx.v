// The bridge's UART receiver (fpga/boards/icebreaker/icebreaker_can.v).
// 8N1 receiver: samples each bit in its middle, after a start bit that is still low there. A byte
// stays `valid` until the user `take`s it (the next byte takes a whole frame time to arrive).
module uart_rx #(parameter CLOCKS_PER_BIT = 104) (
    input  wire       clock,
    input  wire       reset,
    input  wire       rx,
    input  wire       take,
    output reg  [7:0] data,
    output reg        valid
);
    reg [1:0] sync = 2'b11;
    reg [7:0] count = 8'd0;
    reg [3:0] bit_index = 4'd0;
    reg busy = 1'b0;
    initial valid = 1'b0;
    always @(posedge clock) begin
        sync <= {sync[0], rx};
        if (take) valid <= 1'b0;
        if (!busy) begin
            if (!sync[1]) begin
                busy <= 1'b1;
                count <= CLOCKS_PER_BIT / 2;
                bit_index <= 4'd0;
            end
        end else if (count != 8'd0) begin
            count <= count - 8'd1;
        end else begin
            count <= CLOCKS_PER_BIT - 1;
            bit_index <= bit_index + 4'd1;
            if (bit_index == 4'd0) begin
                if (sync[1]) busy <= 1'b0;  // a glitch, not a start bit
            end else if (bit_index == 4'd9) begin
                busy <= 1'b0;
                if (sync[1]) valid <= 1'b1;  // stop bit high: a byte
            end else begin
                data <= {sync[1], data[7:1]};
            end
        end
        if (reset) begin
            busy <= 1'b0;
            valid <= 1'b0;
        end
    end
endmodule
