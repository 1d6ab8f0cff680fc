// The state encodings the harnesses compare internal state registers with, as the emitted Verilog
// declares them (`localparam ProtocolState$Idle = 1;` is `ProtocolState_Idle here).
// testbenches/tests/formal.rs checks every define against fpga/rtl, so a reordered enum in the
// model cannot leave a harness comparing with the wrong state.
`define ProtocolState_Idle 4'd1
`define ProtocolState_Arbitration 4'd8
`define ProtocolState_Control 4'd9
`define ProtocolState_Data 4'd10
`define ProtocolState_Crc 4'd11
`define ProtocolState_Intermission 4'd7
`define ProtocolState_Suspend 4'd2
`define ProtocolState_ErrorFlag 4'd4
`define ProtocolState_BusOff 4'd3
`define SyncMode_Hard 1'd0
`define PortState_Idle 2'd0
`define PortState_Capture 2'd2
`define ApbState_Idle 2'd0
`define ApbState_Busy 2'd1
`define ApbState_Ready 2'd2
`define WishboneState_Idle 2'd0
`define WishboneState_Busy 2'd1
`define WishboneState_Ack 2'd2
`define AxiState_Idle 3'd0
`define AxiState_Write 3'd1
`define AxiState_Read 3'd2
`define AxiState_WriteResponse 3'd3
`define AxiState_ReadResponse 3'd4
