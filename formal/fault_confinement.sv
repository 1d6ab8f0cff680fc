// Fault confinement: the transmit and receive error counters (TEC, REC) move only by the amounts of
// the fault confinement rules, only at a bit boundary, and the error states follow from them.
//
// Rules (Bosch CAN 2.0 part B section 8 "Fault confinement", rules 1 to 12; ISO 11898-1 fault
// confinement; SJA1000 data sheet 6.4.11 RXERR, 6.4.12 TXERR):
//  - in one clock TEC changes only by +8 (rules 3, 4, 6), by -1 (rule 7), to 127 on entering bus-off
//    (SJA1000 6.4.12: bus-off initialises TXERR to 127), by -1 during bus-off recovery (one step per
//    128th of the recovery), to 0 at reset, or to a value the host writes (TXERR; 255 gives 127 and
//    bus-off);
//  - REC changes only by +1 (rule 1), +8 (rules 2, 5, 6) saturating at 255, -1 (rule 8), to 127 from
//    above 127 on a successful reception (rule 8), to 0 on entering or leaving bus-off and at reset,
//    or to a value the host writes (RXERR, not while bus-off);
//  - the counters change only in a clock with `process_point` (the bit boundary where the engine
//    decides a bit) unless reset or a host write; listen-only and reset mode freeze them (SJA1000
//    6.3.3, 6.4.11) but for bus-off recovery;
//  - error passive (`status$error_passive`) iff TEC >= 128 or REC >= 128 (rules 9, 10), and not
//    bus-off; bus-off is entered exactly when TEC would pass 255 (rule 11: +8 from 248 or more) or
//    the host writes 255 into TXERR; it ends only by recovery (rule 12) with both counters 0, by a
//    host write of 0..254 into TXERR, or by reset.
// Two statements of these rules are checked: the first (`step_ok`) sees only the ports of the bit
// stream processor; the second is a reference model of the counters written from the rules and driven
// by the engine's counter events (the strobes into the fault confinement block), which also checks
// that the events come one per counter and only at a process point.
//
// The bit stream processor's inputs are free (any bit stream, any timing of the process and transmit
// points, any request, any mode change), but for reset in the first clock and the register block's
// contract for host writes: one counter per clock, only in reset mode (`enable` low; SJA1000 6.4.11,
// 6.4.12: TXERR and RXERR are writable in reset mode only).
//
//! read: can_controller.v
//! connect: ev_tec_plus_8 = protocol.faults.tec_plus_8
//! connect: ev_tec_minus_1 = protocol.faults.tec_minus_1
//! connect: ev_rec_plus_1 = protocol.faults.rec_plus_1
//! connect: ev_rec_plus_8 = protocol.faults.rec_plus_8
//! connect: ev_rec_success = protocol.faults.rec_success
//! connect: ev_recovery_tick = protocol.faults.recovery_tick
//! bmc: 20
//! prove: pdr
//! mutation: bus-off-threshold | if (tec_count$q[(32'h3)+:(5)] == 32'h1f) begin => if (tec_count$q[(32'h3)+:(5)] >= 32'h1e) begin
//! mutation: tec-step | tec_count$d = tec_count$q + 32'h8; => tec_count$d = tec_count$q + 32'h9;
//! mutation: rec-success | rec_count$d = 32'h7f; => rec_count$d = 32'h77;
//! mutation: rec-saturation | if (rec_plus_1 & (rec_count$q != 32'hff)) begin => if (rec_plus_1) begin
//! mutation: passive-from-old | passive_state$d = ~bus_off_state$d & (tec_count$d[32'h7] | rec_count$d[32'h7]); => passive_state$d = ~bus_off_state$q & (tec_count$q[32'h7] | rec_count$q[32'h7]);
//! mutation: listen-only-counts | faults$frozen = listen_only | disabled; => faults$frozen = disabled;
//! mutation: tick-off-bit-boundary | faults$recovery_tick = interframe$recovery_tick; => faults$recovery_tick = interframe$recovery_tick | (rx_bit & ~process_point);
module fault_confinement (
`include "protocol_ports.vh"
);
`include "protocol_engine.vh"

  reg started = 1'b0;
  always @(posedge clock) started <= 1'b1;
  always @(*) if (!started) assume (reset);
  always @(*) assume (!(load_tec && load_rec));
  always @(*) if (load_tec || load_rec) assume (!enable);

  // ---- The previous clock, as the ports showed it.
  reg p_reset, p_pp, p_frozen, p_load_tec, p_load_rec, p_bus_off;
  reg [7:0] p_value, p_tec, p_rec;
  always @(posedge clock) begin
    p_reset <= reset;
    p_pp <= process_point;
    p_frozen <= listen_only || !enable;
    p_load_tec <= load_tec;
    p_load_rec <= load_rec;
    p_value <= load_value;
    p_tec <= tec;
    p_rec <= rec;
    p_bus_off <= bus_off;
  end

  // ---- First statement: the allowed steps of one clock, from the ports only.
  wire bit_step = p_pp && !p_bus_off && !p_frozen;  // an error-active/passive node's bit
  wire entering_bus_off = !p_bus_off && bus_off;
  wire leaving_bus_off = p_bus_off && !bus_off;
  reg tec_ok, rec_ok, bus_off_ok;
  always @(*) begin
    if (p_reset) begin
      tec_ok = tec == 8'd0;
      rec_ok = rec == 8'd0;
      bus_off_ok = !bus_off;
    end else if (p_load_tec) begin
      tec_ok = tec == (p_value == 8'd255 ? 8'd127 : p_value);
      rec_ok = (p_value == 8'd255 || p_bus_off) ? rec == 8'd0 : rec == p_rec;
      bus_off_ok = bus_off == (p_value == 8'd255);
    end else if (p_load_rec && !p_bus_off) begin
      tec_ok = tec == p_tec;
      rec_ok = rec == p_value;
      bus_off_ok = !bus_off;
    end else begin
      tec_ok = tec == p_tec
          || bit_step && p_tec < 8'd248 && tec == p_tec + 8'd8
          || bit_step && p_tec != 8'd0 && tec == p_tec - 8'd1
          || bit_step && p_tec >= 8'd248 && entering_bus_off && tec == 8'd127
          || p_pp && p_bus_off && bus_off && p_tec != 8'd0 && tec == p_tec - 8'd1;
      rec_ok = rec == p_rec && !entering_bus_off && !leaving_bus_off
          || bit_step && p_rec != 8'd255 && rec == p_rec + 8'd1
          || bit_step && rec == (p_rec >= 8'd248 ? 8'd255 : p_rec + 8'd8)
          || bit_step && p_rec != 8'd0 && p_rec <= 8'd127 && rec == p_rec - 8'd1
          || bit_step && p_rec >= 8'd128 && rec == 8'd127
          || (entering_bus_off || leaving_bus_off) && rec == 8'd0;
      // Bus-off: entered by +8 from 248 or more, left by recovery with TEC 0 (rule 12).
      bus_off_ok = bus_off == p_bus_off
          || entering_bus_off && bit_step && p_tec >= 8'd248
          || leaving_bus_off && p_pp && p_tec == 8'd0 && tec == 8'd0;
    end
  end

  always @(*)
    if (started) begin
      assert (tec_ok);
      assert (rec_ok);
      assert (bus_off_ok);
      assert (error_passive == (!bus_off && (tec >= 8'd128 || rec >= 8'd128)));
    end

  // ---- Second statement: a reference model of the counters driven by the engine's events.
  wire ev_tec_plus_8, ev_tec_minus_1, ev_rec_plus_1, ev_rec_plus_8, ev_rec_success, ev_recovery_tick;
  // Read through a gate, not as aliases: `connect` cuts a connected wire from its aliases.
  wire tec_plus_8 = ev_tec_plus_8 & started, tec_minus_1 = ev_tec_minus_1 & started;
  wire rec_plus_1 = ev_rec_plus_1 & started, rec_plus_8 = ev_rec_plus_8 & started;
  wire rec_success = ev_rec_success & started, recovery_tick = ev_recovery_tick & started;
  wire tec_event = tec_plus_8 || tec_minus_1;
  wire rec_event = rec_plus_1 || rec_plus_8 || rec_success;
  // A bit is one thing: at most one event per counter, only at a process point.
  always @(*)
    if (started && !reset) begin
      assert (!(tec_plus_8 && tec_minus_1));
      assert (rec_plus_1 + rec_plus_8 + rec_success <= 2'd1);
      assert (!(tec_event || rec_event || recovery_tick) || process_point);
    end

  reg [7:0] ref_tec, ref_rec;
  reg ref_bus_off;
  always @(posedge clock) begin
    if (reset) begin
      ref_tec <= 8'd0;
      ref_rec <= 8'd0;
      ref_bus_off <= 1'b0;
    end else if (load_tec && load_value == 8'd255) begin  // TXERR := 255: bus-off
      ref_tec <= 8'd127;
      ref_rec <= 8'd0;
      ref_bus_off <= 1'b1;
    end else if (load_tec) begin  // TXERR := 0..254, ends bus-off
      ref_tec <= load_value;
      if (ref_bus_off) ref_rec <= 8'd0;
      ref_bus_off <= 1'b0;
    end else if (ref_bus_off) begin
      if (recovery_tick) begin  // rule 12: the 128th step ends bus-off
        if (ref_tec == 8'd0) begin
          ref_bus_off <= 1'b0;
          ref_rec <= 8'd0;
        end else ref_tec <= ref_tec - 8'd1;
      end
    end else if (load_rec) ref_rec <= load_value;  // RXERR := value, not while bus-off
    else if (!(listen_only || !enable)) begin  // listen-only and reset mode freeze the counters
      if (tec_plus_8 && ref_tec >= 8'd248) begin  // rule 11: TEC above 255
        ref_bus_off <= 1'b1;
        ref_tec <= 8'd127;
        ref_rec <= 8'd0;
      end else begin
        if (tec_plus_8) ref_tec <= ref_tec + 8'd8;
        if (tec_minus_1 && ref_tec != 8'd0) ref_tec <= ref_tec - 8'd1;
        if (rec_plus_1 && ref_rec != 8'd255) ref_rec <= ref_rec + 8'd1;
        if (rec_plus_8) ref_rec <= ref_rec >= 8'd248 ? 8'd255 : ref_rec + 8'd8;
        if (rec_success && ref_rec >= 8'd128) ref_rec <= 8'd127;
        if (rec_success && ref_rec != 8'd0 && ref_rec <= 8'd127) ref_rec <= ref_rec - 8'd1;
      end
    end
  end

  always @(*)
    if (started) begin
      assert (tec == ref_tec);
      assert (rec == ref_rec);
      assert (bus_off == ref_bus_off);
    end
endmodule
