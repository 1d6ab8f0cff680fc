// The inputs of can_controller, free in every cycle but for the port contract the including harness
// assumes; the port list of the harnesses on the whole controller, with formal/controller.vh.
    input clock,
    input reset,
    input [7:0] addr,
    input [7:0] wdata,
    input we,
    input re,
    input rx
