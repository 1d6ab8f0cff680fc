// Icarus bench of the iCEBreaker design (icebreaker_can.v): a host on the serial port configures
// both controllers through the register bridge (PeliCAN, 500 kbit/s at 12 MHz: BTR0 00h, BTR1 27h,
// open filter, operating mode), node 0 sends standard frame 123h [ABh CDh] on a CAN bus that joins
// the two PMOD transceiver pins (wired-AND), and the host reads node 1's IR and RX buffer back.
// The UART runs at 12 MHz / 8 here to keep the bench short. Prints PASS or stops with $fatal.
module tb_icebreaker_can;
    localparam CPB = 8;
    reg clock = 1'b0, button_n = 1'b1, host_tx = 1'b1;
    wire host_rx, ledr_n, ledg_n, tx0, tx1;
    wire bus = tx0 & tx1;
    reg [7:0] answer;
    integer k;

    always #41 clock = ~clock;  // about 12 MHz

    icebreaker_can #(.CLOCKS_PER_BIT(CPB)) dut (
        .CLK(clock), .BTN_N(button_n), .RX(host_tx), .TX(host_rx), .LEDR_N(ledr_n),
        .LEDG_N(ledg_n), .P1A1(tx0), .P1A2(bus), .P1A3(tx1), .P1A4(bus));

    task send_byte(input [7:0] b);
        integer i;
        begin
            host_tx = 1'b0;
            repeat (CPB) @(posedge clock);
            for (i = 0; i < 8; i = i + 1) begin
                host_tx = b[i];
                repeat (CPB) @(posedge clock);
            end
            host_tx = 1'b1;
            repeat (2 * CPB) @(posedge clock);
        end
    endtask

    task receive_byte;
        integer i;
        begin
            @(negedge host_rx);
            repeat (CPB + CPB / 2) @(posedge clock);
            for (i = 0; i < 8; i = i + 1) begin
                answer[i] = host_rx;
                repeat (CPB) @(posedge clock);
            end
        end
    endtask

    task write_reg(input node, input [7:0] register, input [7:0] value);
        begin
            send_byte({1'b1, 6'b0, node});
            send_byte(register);
            send_byte(value);
        end
    endtask

    task expect_reg(input node, input [7:0] register, input [7:0] value);
        begin
            fork
                begin
                    send_byte({1'b0, 6'b0, node});
                    send_byte(register);
                end
                receive_byte;
            join
            if (answer !== value)
                $fatal(1, "node %0d register %0d: %h, expected %h", node, register, answer, value);
        end
    endtask

    task start_node(input node);
        begin
            expect_reg(node, 8'd0, 8'h21);       // BasicCAN CR after reset
            write_reg(node, 8'd31, 8'h80);       // CDR: PeliCAN
            write_reg(node, 8'd6, 8'h00);        // BTR0
            write_reg(node, 8'd7, 8'h27);        // BTR1: 12 tq of 2 clocks, 500 kbit/s
            for (k = 20; k < 24; k = k + 1) write_reg(node, k, 8'hFF);  // AMR0..3: accept all
            write_reg(node, 8'd4, 8'h01);        // IER: RIE
            write_reg(node, 8'd0, 8'h00);        // MOD: operating mode
        end
    endtask

    initial begin
        repeat (40) @(posedge clock);
        start_node(1'b0);
        start_node(1'b1);
        repeat (12 * 24) @(posedge clock);   // both integrate: 11 recessive bits
        write_reg(1'b0, 8'd16, 8'h02);       // frame information: standard, DLC 2
        write_reg(1'b0, 8'd17, 8'h24);       // identifier 123h
        write_reg(1'b0, 8'd18, 8'h60);
        write_reg(1'b0, 8'd19, 8'hAB);
        write_reg(1'b0, 8'd20, 8'hCD);
        write_reg(1'b0, 8'd1, 8'h01);        // CMR: transmission request
        repeat (130 * 24) @(posedge clock);  // the frame
        if (ledg_n !== 1'b0) $fatal(1, "green LED: node 1's receive interrupt");
        expect_reg(1'b1, 8'd3, 8'h01);       // IR: RI
        expect_reg(1'b1, 8'd16, 8'h02);
        expect_reg(1'b1, 8'd17, 8'h24);
        expect_reg(1'b1, 8'd18, 8'h60);
        expect_reg(1'b1, 8'd19, 8'hAB);
        expect_reg(1'b1, 8'd20, 8'hCD);
        if (ledr_n !== 1'b1) $fatal(1, "red LED: no node is bus-off");
        $display("PASS");
        $finish;
    end
endmodule
