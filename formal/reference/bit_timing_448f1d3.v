// The bit timing logic as `cansim verilog` emitted it at commit 448f1d3, before issue 23 restructured
// it (a quantum counter and the segment's last quantum, compared through an adder), with its modules
// renamed from top$core$bit_timing to before$bit_timing. formal/bit_timing_equivalence.sv proves the
// current block equal to it; generated once, never edited.
module before$bit_timing(clock,reset,rx,brp,tseg1,tseg2,sjw,sam,sync_mode,tx_dominant,sample_point,process_point,transmit_point,rx_bit,segment,hard_synced,resynced);
    
    // Module arguments
    input wire  clock;
    input wire  reset;
    input wire  rx;
    input wire  [5:0] brp;
    input wire  [3:0] tseg1;
    input wire  [2:0] tseg2;
    input wire  [1:0] sjw;
    input wire  sam;
    input wire  sync_mode;
    input wire  tx_dominant;
    output reg  sample_point;
    output reg  process_point;
    output reg  transmit_point;
    output reg  rx_bit;
    output reg  [1:0] segment;
    output reg  hard_synced;
    output reg  resynced;
    
    // Enums
    localparam SyncMode$Hard = 0;
    localparam SyncMode$Resync = 1;
    localparam Segment$Sync = 0;
    localparam Segment$Tseg1 = 1;
    localparam Segment$Tseg2 = 2;
    
    // Stub signals
    reg  sampling$clock;
    reg  sampling$reset;
    reg  sampling$rx;
    reg  sampling$sam;
    reg  sampling$quantum_end;
    wire  sampling$level;
    wire  sampling$falling_edge;
    wire  sampling$vote;
    reg  [1:0] segment_state$d;
    wire  [1:0] segment_state$q;
    reg  segment_state$clock;
    reg  [4:0] quantum$d;
    wire  [4:0] quantum$q;
    reg  quantum$clock;
    reg  [4:0] last_quantum$d;
    wire  [4:0] last_quantum$q;
    reg  last_quantum$clock;
    reg  [6:0] clocks$d;
    wire  [6:0] clocks$q;
    reg  clocks$clock;
    reg  synced$d;
    wire  synced$q;
    reg  synced$clock;
    reg  sampled$d;
    wire  sampled$q;
    reg  sampled$clock;
    reg  process_pending$d;
    wire  process_pending$q;
    reg  process_pending$clock;
    reg  transmit_deferred$d;
    wire  transmit_deferred$q;
    reg  transmit_deferred$clock;
    reg  [4:0] sjw_quanta$d;
    wire  [4:0] sjw_quanta$q;
    reg  sjw_quanta$clock;
    
    // Local signals
    reg  [6:0] last_clock;
    reg  [4:0] sjw_field;
    reg  [4:0] quantum_plus_sjw_quanta;
    reg  [4:0] sjw_adjust;
    reg  quantum_end;
    reg  segment_end;
    reg  [4:0] last_quantum_now;
    reg  hard_sync_now;
    reg  restart_late;
    reg  restart_early;
    reg  lengthen;
    reg  shorten;
    reg  zero_phase;
    reg  restart;
    reg  transmit_now;
    
    // Sub module instances
    before$bit_timing$sampling sampling(
        .clock(sampling$clock),
        .reset(sampling$reset),
        .rx(sampling$rx),
        .sam(sampling$sam),
        .quantum_end(sampling$quantum_end),
        .level(sampling$level),
        .falling_edge(sampling$falling_edge),
        .vote(sampling$vote)
    );
    before$bit_timing$segment_state segment_state(
        .d(segment_state$d),
        .q(segment_state$q),
        .clock(segment_state$clock)
    );
    before$bit_timing$quantum quantum(
        .d(quantum$d),
        .q(quantum$q),
        .clock(quantum$clock)
    );
    before$bit_timing$last_quantum last_quantum(
        .d(last_quantum$d),
        .q(last_quantum$q),
        .clock(last_quantum$clock)
    );
    before$bit_timing$clocks clocks(
        .d(clocks$d),
        .q(clocks$q),
        .clock(clocks$clock)
    );
    before$bit_timing$synced synced(
        .d(synced$d),
        .q(synced$q),
        .clock(synced$clock)
    );
    before$bit_timing$sampled sampled(
        .d(sampled$d),
        .q(sampled$q),
        .clock(sampled$clock)
    );
    before$bit_timing$process_pending process_pending(
        .d(process_pending$d),
        .q(process_pending$q),
        .clock(process_pending$clock)
    );
    before$bit_timing$transmit_deferred transmit_deferred(
        .d(transmit_deferred$d),
        .q(transmit_deferred$q),
        .clock(transmit_deferred$clock)
    );
    before$bit_timing$sjw_quanta sjw_quanta(
        .d(sjw_quanta$d),
        .q(sjw_quanta$q),
        .clock(sjw_quanta$clock)
    );
    
    // Update code
    always @(*) begin
        segment_state$clock = clock;
        quantum$clock = clock;
        last_quantum$clock = clock;
        clocks$clock = clock;
        synced$clock = clock;
        sampled$clock = clock;
        process_pending$clock = clock;
        transmit_deferred$clock = clock;
        sjw_quanta$clock = clock;
        segment_state$d = segment_state$q;
        quantum$d = quantum$q;
        last_quantum$d = last_quantum$q;
        clocks$d = clocks$q;
        synced$d = synced$q;
        sampled$d = sampled$q;
        process_pending$d = process_pending$q;
        transmit_deferred$d = transmit_deferred$q;
        sjw_quanta$d = sjw_quanta$q;
        sampling$clock = clock;
        sampling$reset = reset;
        sampling$rx = rx;
        sampling$sam = sam;
        last_clock = (((((((((brp) & 7'h7f) & ~(1 << (32'h6)) | ((brp[32'h5]) << (32'h6))) & ~(1 << (32'h5)) | ((brp[32'h4]) << (32'h5))) & ~(1 << (32'h4)) | ((brp[32'h3]) << (32'h4))) & ~(1 << (32'h3)) | ((brp[32'h2]) << (32'h3))) & ~(1 << (32'h2)) | ((brp[32'h1]) << (32'h2))) & ~(1 << (32'h1)) | ((brp[32'h0]) << (32'h1))) & ~(1 << (32'h0)) | ((1'b1) << (32'h0)));
        sjw_field = ((sjw) & 5'h1f);
        sjw_quanta$d = ((sjw) & 5'h1f) + 32'h1;
        quantum_plus_sjw_quanta = quantum$q + sjw_quanta$q;
        quantum_end = clocks$q >= last_clock;
        hard_sync_now = 1'b0;
        restart_late = 1'b0;
        restart_early = 1'b0;
        lengthen = 1'b0;
        shorten = 1'b0;
        zero_phase = 1'b0;
        if (sampling$falling_edge & sampled$q & ~synced$q) begin
            case (sync_mode)
                SyncMode$Hard:
                    begin
                        hard_sync_now = 1'b1;
                    end
                SyncMode$Resync:
                    begin
                        case (segment_state$q)
                            Segment$Sync:
                                begin
                                    zero_phase = 1'b1;
                                end
                            Segment$Tseg1:
                                begin
                                    if (~tx_dominant) begin
                                        if (quantum$q <= sjw_field) begin
                                            restart_late = 1'b1;
                                        end
                                        else begin
                                            lengthen = 1'b1;
                                        end
                                    end
                                end
                            Segment$Tseg2:
                                begin
                                    if (last_quantum$q < quantum_plus_sjw_quanta) begin
                                        restart_early = 1'b1;
                                    end
                                    else begin
                                        shorten = 1'b1;
                                    end
                                end
                        endcase
                    end
            endcase
        end
        restart = hard_sync_now | restart_late | restart_early;
        sjw_adjust = sjw_quanta$q;
        if (shorten) begin
            sjw_adjust = ~sjw_field;
        end
        last_quantum_now = last_quantum$q;
        if (lengthen | shorten) begin
            last_quantum_now = last_quantum$q + sjw_adjust;
        end
        segment_end = quantum_end & (quantum$q == last_quantum$q) & ~lengthen;
        if (shorten) begin
            segment_end = quantum_end & (quantum_plus_sjw_quanta == last_quantum$q);
        end
        clocks$d = clocks$q + 32'h1;
        last_quantum$d = last_quantum_now;
        if (quantum_end) begin
            clocks$d = 32'h0;
            quantum$d = quantum$q + 32'h1;
        end
        if (segment_end) begin
            quantum$d = 32'h0;
            case (segment_state$q)
                Segment$Sync:
                    begin
                        segment_state$d = Segment$Tseg1;
                        last_quantum$d = ((tseg1) & 5'h1f);
                    end
                Segment$Tseg1:
                    begin
                        segment_state$d = Segment$Tseg2;
                        last_quantum$d = ((tseg2) & 5'h1f);
                    end
                Segment$Tseg2:
                    begin
                        segment_state$d = Segment$Sync;
                        last_quantum$d = 32'h0;
                    end
            endcase
        end
        if (restart) begin
            segment_state$d = Segment$Sync;
            quantum$d = 32'h0;
            clocks$d = 32'h1;
            last_quantum$d = 32'h0;
        end
        sampling$quantum_end = quantum_end & ~restart;
        sample_point = (segment_state$q == Segment$Tseg1) & segment_end & ~restart & ~reset;
        process_pending$d = sample_point;
        process_point = process_pending$q;
        transmit_now = ((segment_state$q == Segment$Sync) & (quantum$q == 32'h0) & (clocks$q == 32'h0)) | hard_sync_now | restart_early;
        transmit_point = (transmit_now & ~process_pending$q & ~reset) | transmit_deferred$q;
        transmit_deferred$d = transmit_now & process_pending$q;
        rx_bit = sampled$q;
        if (sample_point) begin
            sampled$d = sampling$vote;
            synced$d = 1'b0;
        end
        resynced = restart_late | restart_early | lengthen | shorten | zero_phase;
        hard_synced = hard_sync_now;
        if (hard_sync_now | resynced) begin
            synced$d = 1'b1;
        end
        segment = segment_state$q;
        if (restart) begin
            segment = Segment$Sync;
        end
        if (reset) begin
            segment_state$d = Segment$Sync;
            quantum$d = 32'h0;
            clocks$d = 32'h0;
            last_quantum$d = 32'h0;
            synced$d = 1'b0;
            sampled$d = 1'b1;
            process_pending$d = 1'b0;
            transmit_deferred$d = 1'b0;
            sjw_quanta$d = 32'h1;
        end
    end
    
endmodule // before$bit_timing

module before$bit_timing$clocks(d,q,clock);
    
    // Module arguments
    input wire  [6:0] d;
    output reg  [6:0] q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 7'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$clocks

module before$bit_timing$last_quantum(d,q,clock);
    
    // Module arguments
    input wire  [4:0] d;
    output reg  [4:0] q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 5'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$last_quantum

module before$bit_timing$process_pending(d,q,clock);
    
    // Module arguments
    input wire  d;
    output reg  q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 1'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$process_pending

module before$bit_timing$quantum(d,q,clock);
    
    // Module arguments
    input wire  [4:0] d;
    output reg  [4:0] q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 5'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$quantum

module before$bit_timing$sampled(d,q,clock);
    
    // Module arguments
    input wire  d;
    output reg  q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 1'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$sampled

module before$bit_timing$sampling(clock,reset,rx,sam,quantum_end,level,falling_edge,vote);
    
    // Module arguments
    input wire  clock;
    input wire  reset;
    input wire  rx;
    input wire  sam;
    input wire  quantum_end;
    output reg  level;
    output reg  falling_edge;
    output reg  vote;
    
    // Stub signals
    reg  metastable$d;
    wire  metastable$q;
    reg  metastable$clock;
    reg  stable$d;
    wire  stable$q;
    reg  stable$clock;
    reg  previous$d;
    wire  previous$q;
    reg  previous$clock;
    reg  [1:0] quantum_samples$d;
    wire  [1:0] quantum_samples$q;
    reg  quantum_samples$clock;
    
    // Sub module instances
    before$bit_timing$sampling$metastable metastable(
        .d(metastable$d),
        .q(metastable$q),
        .clock(metastable$clock)
    );
    before$bit_timing$sampling$stable stable(
        .d(stable$d),
        .q(stable$q),
        .clock(stable$clock)
    );
    before$bit_timing$sampling$previous previous(
        .d(previous$d),
        .q(previous$q),
        .clock(previous$clock)
    );
    before$bit_timing$sampling$quantum_samples quantum_samples(
        .d(quantum_samples$d),
        .q(quantum_samples$q),
        .clock(quantum_samples$clock)
    );
    
    // Update code
    always @(*) begin
        metastable$clock = clock;
        stable$clock = clock;
        previous$clock = clock;
        quantum_samples$clock = clock;
        metastable$d = metastable$q;
        stable$d = stable$q;
        previous$d = previous$q;
        quantum_samples$d = quantum_samples$q;
        metastable$d = rx;
        stable$d = metastable$q;
        previous$d = stable$q;
        level = stable$q;
        falling_edge = previous$q & ~stable$q;
        vote = stable$q;
        if (sam) begin
            vote = (quantum_samples$q[32'h1] & quantum_samples$q[32'h0]) | (quantum_samples$q[32'h1] & stable$q) | (quantum_samples$q[32'h0] & stable$q);
        end
        if (quantum_end) begin
            quantum_samples$d = ((quantum_samples$q & ~(1 << (32'h1)) | ((quantum_samples$q[32'h0]) << (32'h1))) & ~(1 << (32'h0)) | ((stable$q) << (32'h0)));
        end
        if (reset) begin
            metastable$d = 1'b1;
            stable$d = 1'b1;
            previous$d = 1'b1;
            quantum_samples$d = 32'h3;
        end
    end
    
endmodule // before$bit_timing$sampling

module before$bit_timing$sampling$metastable(d,q,clock);
    
    // Module arguments
    input wire  d;
    output reg  q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 1'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$sampling$metastable

module before$bit_timing$sampling$previous(d,q,clock);
    
    // Module arguments
    input wire  d;
    output reg  q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 1'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$sampling$previous

module before$bit_timing$sampling$quantum_samples(d,q,clock);
    
    // Module arguments
    input wire  [1:0] d;
    output reg  [1:0] q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 2'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$sampling$quantum_samples

module before$bit_timing$sampling$stable(d,q,clock);
    
    // Module arguments
    input wire  d;
    output reg  q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 1'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$sampling$stable

module before$bit_timing$segment_state(d,q,clock);
    
    // Module arguments
    input wire  [1:0] d;
    output reg  [1:0] q;
    input wire  clock;
    
    // Enums
    localparam Segment$Sync = 0;
    localparam Segment$Tseg1 = 1;
    localparam Segment$Tseg2 = 2;
    
    // Update code (custom)
    initial begin
       q = 64'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$segment_state

module before$bit_timing$sjw_quanta(d,q,clock);
    
    // Module arguments
    input wire  [4:0] d;
    output reg  [4:0] q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 5'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$sjw_quanta

module before$bit_timing$synced(d,q,clock);
    
    // Module arguments
    input wire  d;
    output reg  q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 1'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$synced

module before$bit_timing$transmit_deferred(d,q,clock);
    
    // Module arguments
    input wire  d;
    output reg  q;
    input wire  clock;
    
    // Update code (custom)
    initial begin
       q = 1'h0;
    end
    
    always @(posedge clock) begin
       q <= d;
    end
          
endmodule // before$bit_timing$transmit_deferred

