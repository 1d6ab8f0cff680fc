// Receive FIFO overrun: a message that finds no room is dropped with DOS set and RMC unchanged, and no
// byte of the stored messages is written.
//
// Rules (SJA1000 data sheet 6.4.14 "receive buffer", 6.4.16 "RX message counter", 6.4.5 SR bit 1
// DOS): as in formal/rx_fifo.sv, whose harness this one reuses with the received frames fixed to
// the largest message (extended, 8 data bytes: 13 bytes), sent back to back at the fastest rate the
// engine's contract allows (header bytes in the 5 cycles after `header`, a data byte every cycle,
// `store` at once, the next `header` the cycle after). The host's release of the head message
// (CMR.RRB) stays free in every cycle; reset mode, RAM access by the host and CDO stay off. The
// fifth message needs bytes 53..65 of 64: it overruns unless releases made room, so every
// interleaving of releases with a FIFO that fills, overruns and drains is covered, for every depth
// (pdr; the first overrun comes about 75 clocks after reset). The general harness cannot get that
// deep (formal/rx_fifo.sv: free frames, bmc3 reached 52 clocks). Here every release also frees
// exactly the bytes of the head message: the harness's byte count is never overdrawn, so the
// general harness's premise holds for these frames at every depth.
//
//! read: can_controller.v
//! connect: harness.tail = harness.dut.tail$q
//! connect: harness.write_at = harness.dut.write_at$q
//! connect: harness.full = harness.dut.full$q
//! connect: harness.incomplete = harness.dut.incomplete$q
//! connect: harness.info = harness.dut.new_info
//! connect: harness.writing_header = harness.dut.writing_header$q
//! connect: harness.header_step = harness.dut.header_step$q
//! connect: harness.ram_write_enable = harness.dut.ram$write_enable
//! connect: harness.ram_write_address = harness.dut.ram$write_address
//! connect: harness.release_length = harness.dut.head_length
//! bmc: 90
//! prove: pdr
//! start: first
//! mutation: room-check | if (no_room) begin => if (no_room & 1'b0) begin
//! mutation: no-dos | overrun_state$d = 1'b1; => overrun_state$d = overrun_state$q;
//! mutation: release-length | head$d = next_head; => head$d = head$q + 6'h3;
//! mutation: release-not-counted | count_after_release = count$q - 32'h1; => count_after_release = count$q;

// The harness of formal/rx_fifo.sv, with its frames fixed.
`include "rx_fifo.sv"

module rx_fifo_overrun (
`include "rx_fifo_ports.vh"
);
  rx_fifo #(
      .LARGEST_BACK_TO_BACK(1)
  ) harness (.*);
endmodule
