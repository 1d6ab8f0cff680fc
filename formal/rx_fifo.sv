// Receive FIFO: RMC counts exactly the stored messages, a message is kept only if it fits in the 64
// bytes, and a message that does not fit is dropped with DOS set, without touching the stored ones.
//
// Rules (SJA1000 data sheet 6.4.14 "receive buffer" and 6.4.16 "RX message counter"; 6.4.5 SR bit 1
// DOS; 6.3.x for BasicCAN):
//   - RMC is the number of messages in the RXFIFO: +1 for each received message that is stored, -1 for
//     each release (CMR.RRB) of the head message; reset mode empties the FIFO.
//   - The RXFIFO holds 64 bytes; a message takes its frame information, 2 or 4 identifier bytes and its
//     data bytes (none for RTR, at most 8), written as they arrive after the stored messages.
//   - A message with a byte that finds no room is lost: the store sets DOS and leaves RMC unchanged, and
//     no byte of the stored messages, [RBSA, RBSA + used) circularly, is ever written outside reset
//     mode (where the FIFO is emptied anyway).
// (RBS = RMC > 0, SR bit 0, is proven on the whole controller in formal/register_port.sv.)
//
// The block: `top$fifo` (rtl/src/rx_fifo.rs). Its inputs are free but for this contract, which the
// protocol engine and the host port guarantee (rtl/src/bsp/received_frame.rs, can_controller.rs):
//   - `header` starts a frame; id/ide/rtr/dlc then stay put until its `store` (or a new `header`); the
//     header bytes are written in the 3 or 5 cycles after `header`, and data bytes come later (a data
//     bit takes many clocks), in order: `strobe` with `index` 0, 1, ... below the data length;
//   - `store` comes at most once per frame, after all of its bytes (the validity point, end of frame);
//     reset mode (`clear`) stops the engine: no `header` then, and a frame in progress is not stored;
//   - `release_head` (CMR.RRB) only in operating mode (`clear` low: the decoder ignores CMR in reset
//     mode) and never with `host_read` (a write and a read of the host port never come together).
// Without the store-after-all-bytes part a store could count a message whose last bytes were never
// checked for room.
//
// Bounded: the rules hold for the first 20 clocks from reset (15 s; 30 before the block found room
// by comparing its write position with the head instead of adding the bytes used and the byte's
// offset, the harness's own arithmetic: the solver now relates the two at every step, and 22 clocks
// take 120 s, 23 take 400 s; pdr does not close in 600 s). That is too short to fill the 64 bytes
// (about 70 clocks of back-to-back frames), so the overrun rules are not reached: they are asserted
// at every step, but no trace within the bound makes a store find no room.
// formal/rx_fifo_overrun.sv runs this harness with the largest frames back to back, where the fifth
// overruns, and proves the overrun rules there; simulation covers other mixes
// (testbenches/tests/rx_fifo.rs: the 22nd smallest message overruns; rx_fifo_ram.rs: exactly 64
// bytes, and a lost message's bytes after a release). The assertions
// are written as induction lemmas (the harness's view of the frame being received against the
// block's registers and the bytes it stores, `used`: the pointers' distance, 64 when `full`; the
// write position is the tail plus the bytes of the frame written so far).
// The block's byte count is its pointers' distance; the harness counts the bytes itself (`counted`:
// + each message stored whole, - the length the block releases, which it takes from the frame
// information of the head message). That length is not chained through the RAM here, so the rules
// are claimed up to a release longer than the bytes counted (`overdrawn`); formal/rx_fifo_overrun.sv
// asserts that this never happens with the largest frames, for every depth. (Without that premise a
// bounded proof has to chain every release through the RAM: bmc3 reached 19 clocks in 40 s.)
//
// Harness state: `stored` counts the stores of messages that fit minus the releases (mod 32, as RMC's
// five bits); `lost` marks a frame with a byte that found no room; `counted` and `overdrawn` above.
//
//! read: can_controller.v
//! connect: tail = dut.tail$q
//! connect: write_at = dut.write_at$q
//! connect: full = dut.full$q
//! connect: incomplete = dut.incomplete$q
//! connect: info = dut.new_info
//! connect: writing_header = dut.writing_header$q
//! connect: header_step = dut.header_step$q
//! connect: ram_write_enable = dut.ram$write_enable
//! connect: ram_write_address = dut.ram$write_address
//! connect: release_length = dut.head_length
//! bmc: 20
//! mutation: release-length | head$d = next_head; => head$d = head$q + 6'h3;
//! mutation: release-not-counted | count_after_release = count$q - 32'h1; => count_after_release = count$q;
//! mutation: tail-at-store | tail$d = write_at$q; => tail$d = write_at$q + 6'h1;
module rx_fifo #(
    // 1: the received frames fixed to the largest message, back to back (formal/rx_fifo_overrun.sv).
    parameter LARGEST_BACK_TO_BACK = 0
) (
`include "rx_fifo_ports.vh"
);
  wire [7:0] read_data, head_info;
  wire [4:0] message_count;
  wire [5:0] start;
  wire overrun;
  \top$fifo dut (
      .clock(clock),
      .reset(reset),
      .clear(clear),
      .load_start(load_start),
      .start_address(start_address),
      .\rx_frame$header (header),
      .\rx_frame$id (id),
      .\rx_frame$ide (ide),
      .\rx_frame$rtr (rtr),
      .\rx_frame$dlc (dlc),
      .\rx_frame$strobe (strobe),
      .\rx_frame$data (data),
      .\rx_frame$index (index),
      .store(store),
      .release_head(release_head),
      .clear_overrun(clear_overrun),
      .host_read(host_read),
      .host_address(host_address),
      .host_write(host_write),
      .host_data(host_data),
      .read_data(read_data),
      .message_count(message_count),
      .start(start),
      .overrun(overrun),
      .head_info(head_info)
  );

  // Inside the block (see the `connect` lines).
  wire [5:0] tail;  // the end of the stored messages
  wire [5:0] write_at;  // where the next byte of the frame being received goes
  wire [5:0] distance = tail - start;
  wire full;  // the pointers meet with a message stored
  wire [6:0] used = full ? 7'd64 : {1'b0, distance};  // the bytes stored
  wire incomplete, writing_header;
  wire [7:0] info;
  wire [2:0] header_step;
  wire ram_write_enable;
  wire [5:0] ram_write_address;
  wire [3:0] release_length;

  // ---- The frame being received, as the engine sends it.
  reg started = 1'b0;
  reg receiving;  // from `header` to `store`
  reg header_writing;  // the 3 or 5 cycles after `header`
  reg [2:0] header_done;  // header bytes written
  reg [3:0] next_index;  // data bytes sent
  reg held_ide, held_rtr;
  reg [3:0] held_dlc;
  reg [28:0] held_id;
  reg lost;  // a byte of this frame found no room
  wire [7:0] frame_info = {ide, rtr, 2'b00, dlc};
  wire [3:0] frame_header_bytes = ide ? 4'd5 : 4'd3;
  wire [3:0] frame_data_bytes = rtr ? 4'd0 : (dlc[3] ? 4'd8 : dlc);
  wire [3:0] frame_bytes = frame_header_bytes + frame_data_bytes;
  // Bytes written so far (in order): the header bytes, then the data bytes.
  wire [3:0] reach = next_index != 0 ? frame_header_bytes + next_index : {1'b0, header_done};
  // The byte written this cycle, at this offset in the message.
  wire attempt = header_writing | strobe;
  wire [3:0] attempt_offset = strobe ? frame_header_bytes + {1'b0, index} : {1'b0, header_done};
  wire no_room = used + attempt_offset >= 7'd64;

  always @(posedge clock) begin
    started <= 1'b1;
    if (header_writing) begin
      header_done <= header_done + 3'd1;
      if ({1'b0, header_done} == frame_header_bytes - 4'd1) header_writing <= 1'b0;
    end
    if (strobe) next_index <= next_index + 4'd1;
    if (attempt && no_room) lost <= 1'b1;
    if (header) begin
      receiving <= 1'b1;
      header_writing <= 1'b1;
      header_done <= 3'd0;
      next_index <= 4'd0;
      lost <= 1'b0;
      {held_id, held_ide, held_rtr, held_dlc} <= {id, ide, rtr, dlc};
    end
    if (store) receiving <= 1'b0;
    if (reset || clear) begin
      receiving <= 1'b0;
      header_writing <= 1'b0;
    end
  end

  // ---- The contract.
  always @(*) begin
    if (!started) assume (reset);
    if (receiving && !header) assume ({id, ide, rtr, dlc} == {held_id, held_ide, held_rtr, held_dlc});
    if (header) assume (!clear && !header_writing && !strobe && !store);
    if (strobe) assume (receiving && !header_writing && index == next_index[2:0] && next_index < frame_data_bytes);
    if (store) assume (receiving && !header_writing && next_index == frame_data_bytes);
    if (release_head) assume (!clear && !host_read);
    if (LARGEST_BACK_TO_BACK) begin
      // Extended, 8 data bytes (13 bytes), every byte at once, the next frame the clock after the
      // store; no reset mode, host RAM access or CDO after reset. Only the releases stay free.
      if (started) assume (!reset && !clear && !load_start && !host_read && !host_write && !clear_overrun);
      assume ({id, ide, rtr, dlc} == {29'd0, 1'b1, 1'b0, 4'd8} && data == 8'd0);
      if (started) begin
        assume (header == !receiving);
        assume (strobe == (receiving && !header_writing && !header && next_index < 4'd8));
        assume (store == (receiving && !header_writing && !header && next_index == 4'd8));
      end
    end
  end

  // ---- The reference count: messages stored whole, minus releases of a stored one.
  reg [4:0] stored;
  wire accepted = store && !lost;
  wire released = release_head && stored != 0;
  always @(posedge clock)
    if (reset || clear) stored <= 5'd0;
    else stored <= stored - released + accepted;

  // The bytes stored as a count of their own: + the length of each message stored whole, - the
  // length the block releases (that of the frame information it holds for the head message, which
  // this harness does not chain through the RAM). After a release longer than the bytes counted
  // (`overdrawn`, until reset mode) the rules below make no claim; formal/rx_fifo_overrun.sv proves
  // for every depth that no release is overdrawn with the largest frames.
  reg [6:0] counted;
  reg overdrawn;
  always @(posedge clock)
    if (reset || clear) begin
      counted <= 7'd0;
      overdrawn <= 1'b0;
    end else begin
      counted <= counted - (released ? {3'd0, release_length} : 7'd0) + (accepted ? {3'd0, frame_bytes} : 7'd0);
      if (released && {3'd0, release_length} > counted) overdrawn <= 1'b1;
    end

  // A RAM write lands in the stored messages' bytes, [RBSA, RBSA + used) circularly.
  wire [5:0] write_distance = ram_write_address - start;
  wire write_in_stored = ram_write_enable && {1'b0, write_distance} < used;

  reg past_valid = 1'b0;
  reg past_store, past_lost, past_clear, past_reset, past_clear_overrun, past_release;
  reg [4:0] past_count;
  always @(posedge clock) begin
    past_valid <= started;
    {past_store, past_lost, past_clear, past_reset, past_clear_overrun} <= {store, lost, clear, reset, clear_overrun};
    past_release <= release_head && message_count != 0;
    past_count <= message_count;
  end

  always @(*)
    if (started) begin
      // The rules.
      assert (message_count == stored);
      if (!clear && !overdrawn) assert (!write_in_stored);
      if (receiving && !lost && !overdrawn) assert (used + reach <= 7'd64);
      if (past_valid && past_store && past_lost && !past_clear && !past_reset && !past_clear_overrun) begin
        assert (overrun);
        assert (message_count == past_count - past_release);
      end

      // Lemmas: the bookkeeping, and the frame being received as the block sees it.
      if (!overdrawn) assert (used == counted && (!full || distance == 0));
      // With the largest frames the head message is always 13 bytes long: never overdrawn.
      if (LARGEST_BACK_TO_BACK) assert (!overdrawn);
      assert (writing_header == header_writing);
      if (header_writing) assert (header_step == header_done && receiving);
      if (receiving && !header) begin
        assert (info == frame_info);
        assert (incomplete == lost);
        if (!lost) assert (write_at == tail + {2'b00, reach});
        assert (reach <= frame_bytes);
        if (!header_writing) assert (header_done == frame_header_bytes[2:0]);
        if (next_index != 0) assert (!header_writing);
      end
    end
endmodule
