// The bridge's UART transmitter (fpga/boards/icebreaker/icebreaker_can.v).
// 8N1 transmitter.
module uart_tx #(parameter CLOCKS_PER_BIT = 104) (
    input  wire       clock,
    input  wire       reset,
    input  wire       start,
    input  wire [7:0] data,
    output wire       tx,
    output wire       busy
);
    reg [9:0] shift = 10'h3FF;
    reg [3:0] bits_left = 4'd0;
    reg [7:0] count = 8'd0;
    assign tx = shift[0];
    assign busy = bits_left != 4'd0;
    always @(posedge clock) begin
        if (!busy) begin
            if (start) begin
                shift <= {1'b1, data, 1'b0};
                bits_left <= 4'd10;
                count <= CLOCKS_PER_BIT - 1;
            end
        end else if (count != 8'd0) begin
            count <= count - 8'd1;
        end else begin
            count <= CLOCKS_PER_BIT - 1;
            shift <= {1'b1, shift[9:1]};
            bits_left <= bits_left - 4'd1;
        end
        if (reset) begin
            shift <= 10'h3FF;
            bits_left <= 4'd0;
        end
    end
endmodule
