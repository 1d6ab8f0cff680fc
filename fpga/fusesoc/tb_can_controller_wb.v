// A self-checking Icarus bench of can_controller_wb for the FuseSoC `sim` target: Wishbone classic
// cycles (hold stb until ack) check the SJA1000 reset value of the BasicCAN control register (21h),
// switch to PeliCAN (CDR 80h: MOD reads 01h in reset mode), and write the four acceptance code
// registers with one 32-bit write (byte layout: registers 16..19 are the lanes of word 4) and read
// each back with its byte select. Prints PASS or stops with $fatal.
module tb_can_controller_wb;
    reg clock = 1'b0, reset = 1'b1;
    reg cyc = 1'b0, stb = 1'b0, we = 1'b0;
    reg [7:0] adr = 8'h00;
    reg [3:0] sel = 4'h0;
    reg [31:0] dat_w = 32'h0;
    wire [31:0] dat_r;
    wire ack, stall, tx, irq, clkout;
    reg [31:0] word;
    integer k;

    always #5 clock = ~clock;

    can_controller_wb dut (
        .clock(clock), .reset(reset), .wb_cyc(cyc), .wb_stb(stb), .wb_we(we), .wb_adr(adr),
        .wb_sel(sel), .wb_dat_w(dat_w), .wb_dat_r(dat_r), .wb_ack(ack), .wb_stall(stall),
        .rx(tx), .tx(tx), .irq(irq), .clkout(clkout));

    task access(input write, input [7:0] word_address, input [3:0] lanes, input [31:0] data);
        begin
            @(negedge clock);
            {cyc, stb, we, adr, sel, dat_w} = {1'b1, 1'b1, write, word_address, lanes, data};
            @(posedge clock);
            while (!ack) @(posedge clock);
            word = dat_r;
            @(negedge clock);
            {cyc, stb, we} = 3'b000;
        end
    endtask

    task expect_byte(input [7:0] register, input [7:0] value);
        begin
            access(1'b0, register >> 2, 4'b0001 << register[1:0], 32'h0);
            if (((word >> (8 * register[1:0])) & 8'hFF) !== value)
                $fatal(1, "register %0d: %h, expected %h", register, word, value);
        end
    endtask

    initial begin
        repeat (4) @(posedge clock);
        reset = 1'b0;
        expect_byte(8'd0, 8'h21);
        access(1'b1, 8'd31 >> 2, 4'b1000, 32'h8000_0000);
        expect_byte(8'd0, 8'h01);
        access(1'b1, 8'd16 >> 2, 4'b1111, 32'h4433_2211);
        for (k = 0; k < 4; k = k + 1) expect_byte(8'd16 + k, 8'h11 * (k + 1));
        $display("PASS");
        $finish;
    end
endmodule
