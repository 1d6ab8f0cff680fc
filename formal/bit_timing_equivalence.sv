// Bit timing: the restructured block behaves exactly as the one before it (issue 23).
//
// Rule: no behaviour change. Issue 23 shortens the design's longest path, through the bit timing's
// resynchronisation (Bosch CAN 2.0 B 9: phase error, SJW, lengthening Phase1 / shortening Phase2), by
// counting the quanta left in a segment down instead of up to its last quantum. Every output
// (sample, process and transmit points, the sampled bit, the segment, the hard-sync and resync
// pulses) equals, in every clock, that of the block as emitted before the change
// (formal/reference/bit_timing_448f1d3.v), for every bus input, every synchronisation mode and
// tx_dominant, and every BTR value.
//
// Assumption, from the controller around the block: a BTR field changes only in reset mode (SJA1000
// data sheet 6.5.1, 6.5.2), where the protocol engine asks for hard synchronisation; the host
// needs a clock to leave reset mode after its last BTR write, so the clock of a change and the next
// ask for hard synchronisation.
//
//! read: can_controller.v
//! reference: bit_timing_448f1d3.v
//! bmc: 16
//! prove: pdr
//! start: first
//! mutation: early-restart-bound | if (remaining$q <= sjw_field) begin => if (remaining$q < sjw_field) begin
//! mutation: shortened-end | segment_end = quantum_end & (remaining$q == sjw_quanta$q); => segment_end = quantum_end & (remaining$q == sjw_field);
//! mutation: elapsed-not-saturated | if (elapsed$q != elapsed_over_sjw) begin => if (1'b1) begin
//! mutation: lengthen-step | remaining_step = sjw_field; => remaining_step = sjw_quanta$q;
`include "encodings.vh"
module bit_timing_equivalence (
`include "bit_timing_ports.vh"
);
  wire sample_now, process_now, transmit_now, rx_bit_now, hard_synced_now, resynced_now;
  wire [1:0] segment_now;
  wire sample_before, process_before, transmit_before, rx_bit_before, hard_synced_before, resynced_before;
  wire [1:0] segment_before;

  \top$core$bit_timing now (
      .clock(clock), .reset(reset), .rx(rx), .brp(brp), .tseg1(tseg1), .tseg2(tseg2), .sjw(sjw),
      .sam(sam), .sync_mode(sync_mode), .tx_dominant(tx_dominant),
      .sample_point(sample_now), .process_point(process_now), .transmit_point(transmit_now),
      .rx_bit(rx_bit_now), .segment(segment_now), .hard_synced(hard_synced_now),
      .resynced(resynced_now)
  );
  \before$bit_timing before (
      .clock(clock), .reset(reset), .rx(rx), .brp(brp), .tseg1(tseg1), .tseg2(tseg2), .sjw(sjw),
      .sam(sam), .sync_mode(sync_mode), .tx_dominant(tx_dominant),
      .sample_point(sample_before), .process_point(process_before),
      .transmit_point(transmit_before), .rx_bit(rx_bit_before), .segment(segment_before),
      .hard_synced(hard_synced_before), .resynced(resynced_before)
  );

  reg started = 1'b0;
  reg [15:0] btr_0;
  reg btr_changed_0 = 1'b0;
  wire [15:0] btr = {brp, tseg1, tseg2, sjw, sam};
  wire btr_changed = started && btr != btr_0;
  always @(posedge clock) begin
    started <= 1'b1;
    btr_0 <= btr;
    btr_changed_0 <= btr_changed;
  end
  always @(*) if (!started) assume (reset);
  always @(*) if (btr_changed || btr_changed_0) assume (sync_mode == `SyncMode_Hard);

  always @(*) if (started) begin
    assert (sample_now == sample_before);
    assert (process_now == process_before);
    assert (transmit_now == transmit_before);
    assert (rx_bit_now == rx_bit_before);
    assert (segment_now == segment_before);
    assert (hard_synced_now == hard_synced_before);
    assert (resynced_now == resynced_before);
  end
endmodule
