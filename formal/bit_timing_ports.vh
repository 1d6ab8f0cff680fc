// The inputs of the bit timing logic (top$core$bit_timing), free in every cycle but for what the
// including harness assumes; the port list of the harnesses on it.
    input clock,
    input reset,
    input rx,
    input [5:0] brp,
    input [3:0] tseg1,
    input [2:0] tseg2,
    input [1:0] sjw,
    input sam,
    input sync_mode,
    input tx_dominant
