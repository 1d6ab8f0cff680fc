// The bit stream processor as `protocol`, driven by the inputs of formal/protocol_ports.vh; its bus
// output and status as wires the harness reads.
  wire tx, error_passive, bus_off;
  wire [7:0] tec, rec;
  \top$core$protocol protocol (
      .clock(clock),
      .reset(reset),
      .enable(enable),
      .process_point(process_point),
      .transmit_point(transmit_point),
      .rx_bit(rx_bit),
      .listen_only(listen_only),
      .self_test(self_test),
      .\transmit$request (tx_request),
      .\transmit$single_shot (tx_single_shot),
      .\transmit$abort (tx_abort),
      .\transmit$info (tx_info),
      .\transmit$data (tx_data),
      .\counters$load_tec (load_tec),
      .\counters$load_rec (load_rec),
      .\counters$value (load_value),
      .tx(tx),
      .\status$tec (tec),
      .\status$rec (rec),
      .\status$error_passive (error_passive),
      .\status$bus_off (bus_off)
  );
