// The inputs of the bit stream processor (top$core$protocol), free in every cycle but for what the
// including harness assumes; the port list of the harnesses on it, with formal/protocol_engine.vh.
    input clock,
    input reset,
    input enable,
    input process_point,
    input transmit_point,
    input rx_bit,
    input listen_only,
    input self_test,
    input tx_request,
    input tx_single_shot,
    input tx_abort,
    input [7:0] tx_info,
    input [7:0] tx_data,
    input load_tec,
    input load_rec,
    input [7:0] load_value
