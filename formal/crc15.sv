// CRC-15: the CRC block's register is the remainder of the polynomial division that defines the CRC
// sequence, over every bit fed since the last clear.
//
// Rule (Bosch CAN 2.0 part B 3.2.1 "CRC field"; ISO 11898-1 "CRC field"): the bits from SOF to the
// end of the data field, as coefficients of a polynomial, multiplied by x^15 and divided by
// g(x) = x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1; the remainder is the CRC sequence.
// The reference below keeps that remainder directly: feeding bit b takes the message M(x) to
// M(x)*x + b, so the remainder R(x) of M(x)*x^15 becomes (R(x)*x + b*x^15) mod g(x), computed on the
// 16-bit polynomial with g's x^15 term written out. Second rule, the receiver's check: feeding a
// message followed by its own 15 CRC bits leaves remainder 0 (M*x^15 + R is divisible by g).
//
//! read: can_controller.v
//! bmc: 24
//! prove: pdr
//! mutation: polynomial | localparam  polynomial = 15'b100010110011001; => localparam  polynomial = 15'b100010110011011;
//! mutation: feedback-tap | if (level ^ register$q[32'he]) begin => if (level ^ register$q[32'hd]) begin
module crc15 (
    input clock,
    input clear,
    input feed,
    input level,
    input check
);
  localparam [15:0] GENERATOR = 16'b1100010110011001;  // x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1

  wire [14:0] value;
  \top$core$protocol$crc crc (
      .clock(clock),
      .clear(clear),
      .feed(feed),
      .level(level),
      .value(value)
  );

  // The remainder of M(x) * x^15 mod g(x), M the bits fed since the last clear.
  reg [14:0] remainder;
  reg started = 1'b0;
  wire [15:0] shifted = {remainder, 1'b0} ^ {level, 15'b0};  // R*x + b*x^15
  wire [15:0] reduced = shifted[15] ? shifted ^ GENERATOR : shifted;
  always @(posedge clock) begin
    started <= 1'b1;
    if (clear) remainder <= 15'b0;
    else if (feed) remainder <= reduced[14:0];
  end

  // The register's first value is not defined before a clear: the proof starts with one.
  always @(*) if (!started) assume (clear);
  always @(*) if (started) assert (value == remainder);

  // The receiver's check: from a free `check` strobe on, the harness feeds back the register's top bit
  // (the CRC sequence goes out most significant bit first) 15 times; the register is then 0.
  reg [4:0] echoed = 5'd0;
  wire echoing = echoed != 5'd0 && echoed != 5'd16;
  always @(posedge clock) begin
    if (clear || echoed == 5'd16) echoed <= 5'd0;
    else if (echoed == 5'd0 && check) echoed <= 5'd1;
    else if (echoing && feed) echoed <= echoed + 5'd1;
  end
  always @(*) if (echoing && feed) assume (level == value[14]);
  // After j bits fed back the j low bits are 0 (the register only shifts); after 15 all are.
  wire [14:0] fed_back_zeros = ~(15'h7fff << (echoed - 5'd1));
  always @(*) if (started && echoed != 5'd0) assert ((value & fed_back_zeros) == 15'b0);
  always @(*) if (started && echoed == 5'd16) assert (value == 15'b0);
endmodule
