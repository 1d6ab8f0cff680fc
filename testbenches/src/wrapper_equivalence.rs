//! Per-cycle equivalence of the bus wrappers (`rtl::bus`): a bus master model drives each wrapped
//! controller of a bench, closed loop, on the rust-hdl model (two controllers on one CAN bus, `rx` of
//! each the wired-AND of every `tx` of the cycle before); the inputs it applied are then replayed on
//! the emitted Verilog (`can_controller.v` plus the wrapper's file) in Icarus or Verilator, whose
//! outputs must equal the model's in every cycle.

use std::fmt::Write as _;
use std::path::Path;

use rust_hdl::prelude::*;

use rtl::bus::apb::CanControllerApb;
use rtl::bus::axi4_lite::CanControllerAxiLite;
use rtl::bus::wishbone::CanControllerWishbone;
use sim::engine::rtl_step::clock_cycle_with;
use sim::verilated::verilog::{controller_verilog, wrapper_verilog, Bus, WORD_STRIDE_PARAMETER};

use crate::equivalence::Simulator;

/// A port of a wrapper's top module.
#[derive(Clone, Copy, Debug)]
pub struct PortSpec {
    /// Its name in the Verilog.
    pub name: &'static str,
    /// Its width in bits.
    pub width: u32,
}

const fn port(name: &'static str, width: u32) -> PortSpec {
    PortSpec { name, width }
}

/// A wrapper top as the bench drives it: every input but `clock` and `rx`, every output.
pub trait Wrapped: Block + Sized {
    /// The bus.
    const BUS: Bus;
    /// Inputs in stimulus order (`clock` and `rx` are the bench's).
    const INPUTS: &'static [PortSpec];
    /// Outputs compared in every cycle (`tx` among them).
    const OUTPUTS: &'static [PortSpec];
    /// The wrapper with this register layout.
    fn with_word_stride(word_stride: bool) -> Self;
    /// Puts `values` (in [`Wrapped::INPUTS`] order) and `rx` on the inputs.
    fn apply(&mut self, values: &[u64], rx: bool);
    /// The outputs, in [`Wrapped::OUTPUTS`] order.
    fn sample(&self) -> Vec<u64>;
    /// `tx`.
    fn tx(&self) -> bool;
    /// The clock input.
    fn clock_input(&mut self) -> &mut Signal<In, Clock>;
}

fn bits<const N: usize>(value: u64) -> Bits<N> {
    value.to_bits()
}

impl Wrapped for CanControllerWishbone {
    const BUS: Bus = Bus::Wishbone;
    const INPUTS: &'static [PortSpec] = &[
        port("reset", 1),
        port("wb_cyc", 1),
        port("wb_stb", 1),
        port("wb_we", 1),
        port("wb_adr", 8),
        port("wb_sel", 4),
        port("wb_dat_w", 32),
    ];
    const OUTPUTS: &'static [PortSpec] = &[
        port("wb_dat_r", 32),
        port("wb_ack", 1),
        port("wb_stall", 1),
        port("tx", 1),
        port("irq", 1),
        port("clkout", 1),
    ];
    fn with_word_stride(word_stride: bool) -> Self {
        CanControllerWishbone::with_word_stride(word_stride)
    }
    fn apply(&mut self, v: &[u64], rx: bool) {
        self.reset.next = v[0] != 0;
        self.wb_cyc.next = v[1] != 0;
        self.wb_stb.next = v[2] != 0;
        self.wb_we.next = v[3] != 0;
        self.wb_adr.next = bits(v[4]);
        self.wb_sel.next = bits(v[5]);
        self.wb_dat_w.next = bits(v[6]);
        self.rx.next = rx;
    }
    fn sample(&self) -> Vec<u64> {
        vec![
            self.wb_dat_r.val().to_u64(),
            u64::from(self.wb_ack.val()),
            u64::from(self.wb_stall.val()),
            u64::from(self.tx.val()),
            u64::from(self.irq.val()),
            u64::from(self.clkout.val()),
        ]
    }
    fn tx(&self) -> bool {
        self.tx.val()
    }
    fn clock_input(&mut self) -> &mut Signal<In, Clock> {
        &mut self.clock
    }
}

impl Wrapped for CanControllerAxiLite {
    const BUS: Bus = Bus::AxiLite;
    const INPUTS: &'static [PortSpec] = &[
        port("reset", 1),
        port("s_axil_awvalid", 1),
        port("s_axil_awaddr", 10),
        port("s_axil_wvalid", 1),
        port("s_axil_wdata", 32),
        port("s_axil_wstrb", 4),
        port("s_axil_bready", 1),
        port("s_axil_arvalid", 1),
        port("s_axil_araddr", 10),
        port("s_axil_rready", 1),
    ];
    const OUTPUTS: &'static [PortSpec] = &[
        port("s_axil_awready", 1),
        port("s_axil_wready", 1),
        port("s_axil_bvalid", 1),
        port("s_axil_bresp", 2),
        port("s_axil_arready", 1),
        port("s_axil_rvalid", 1),
        port("s_axil_rdata", 32),
        port("s_axil_rresp", 2),
        port("tx", 1),
        port("irq", 1),
        port("clkout", 1),
    ];
    fn with_word_stride(word_stride: bool) -> Self {
        CanControllerAxiLite::with_word_stride(word_stride)
    }
    fn apply(&mut self, v: &[u64], rx: bool) {
        self.reset.next = v[0] != 0;
        self.s_axil_awvalid.next = v[1] != 0;
        self.s_axil_awaddr.next = bits(v[2]);
        self.s_axil_wvalid.next = v[3] != 0;
        self.s_axil_wdata.next = bits(v[4]);
        self.s_axil_wstrb.next = bits(v[5]);
        self.s_axil_bready.next = v[6] != 0;
        self.s_axil_arvalid.next = v[7] != 0;
        self.s_axil_araddr.next = bits(v[8]);
        self.s_axil_rready.next = v[9] != 0;
        self.rx.next = rx;
    }
    fn sample(&self) -> Vec<u64> {
        vec![
            u64::from(self.s_axil_awready.val()),
            u64::from(self.s_axil_wready.val()),
            u64::from(self.s_axil_bvalid.val()),
            self.s_axil_bresp.val().to_u64(),
            u64::from(self.s_axil_arready.val()),
            u64::from(self.s_axil_rvalid.val()),
            self.s_axil_rdata.val().to_u64(),
            self.s_axil_rresp.val().to_u64(),
            u64::from(self.tx.val()),
            u64::from(self.irq.val()),
            u64::from(self.clkout.val()),
        ]
    }
    fn tx(&self) -> bool {
        self.tx.val()
    }
    fn clock_input(&mut self) -> &mut Signal<In, Clock> {
        &mut self.clock
    }
}

impl Wrapped for CanControllerApb {
    const BUS: Bus = Bus::Apb;
    const INPUTS: &'static [PortSpec] = &[
        port("reset", 1),
        port("psel", 1),
        port("penable", 1),
        port("pwrite", 1),
        port("paddr", 10),
        port("pwdata", 32),
        port("pstrb", 4),
    ];
    const OUTPUTS: &'static [PortSpec] = &[
        port("prdata", 32),
        port("pready", 1),
        port("pslverr", 1),
        port("tx", 1),
        port("irq", 1),
        port("clkout", 1),
    ];
    fn with_word_stride(word_stride: bool) -> Self {
        CanControllerApb::with_word_stride(word_stride)
    }
    fn apply(&mut self, v: &[u64], rx: bool) {
        self.reset.next = v[0] != 0;
        self.psel.next = v[1] != 0;
        self.penable.next = v[2] != 0;
        self.pwrite.next = v[3] != 0;
        self.paddr.next = bits(v[4]);
        self.pwdata.next = bits(v[5]);
        self.pstrb.next = bits(v[6]);
        self.rx.next = rx;
    }
    fn sample(&self) -> Vec<u64> {
        vec![
            self.prdata.val().to_u64(),
            u64::from(self.pready.val()),
            u64::from(self.pslverr.val()),
            u64::from(self.tx.val()),
            u64::from(self.irq.val()),
            u64::from(self.clkout.val()),
        ]
    }
    fn tx(&self) -> bool {
        self.tx.val()
    }
    fn clock_input(&mut self) -> &mut Signal<In, Clock> {
        &mut self.clock
    }
}

/// A bus master model: the inputs of the next cycle from the outputs after the last edge.
pub trait Master {
    /// The inputs (in the wrapper's [`Wrapped::INPUTS`] order) for the coming cycle, seeing
    /// `outputs` (its [`Wrapped::OUTPUTS`]).
    fn drive(&mut self, outputs: &[u64]) -> Vec<u64>;
    /// Every operation is done.
    fn finished(&self) -> bool;
    /// What each read gave, in order.
    fn reads(&self) -> &[u32];
}

/// What a bench run saw: per cycle and node, the inputs applied and the outputs after the edge.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    /// Nodes.
    pub nodes: usize,
    /// `inputs[cycle * nodes + node]`.
    pub inputs: Vec<Vec<u64>>,
    /// `outputs[cycle * nodes + node]` (`None`: a bit was X or Z in the Verilog).
    pub outputs: Vec<Option<Vec<u64>>>,
}

impl Recording {
    /// Cycles recorded.
    pub fn cycles(&self) -> usize {
        self.outputs.len() / self.nodes.max(1)
    }
}

/// Runs `masters` (one per node) on rust-hdl wrappers `W` with `word_stride` until every master
/// has finished and then `tail` cycles more (at most `max_cycles`); returns the recording.
pub fn run_rust<W: Wrapped>(
    word_stride: bool,
    masters: &mut [Box<dyn Master>],
    tail: usize,
    max_cycles: usize,
) -> Recording {
    let nodes = masters.len();
    let mut uuts: Vec<W> = (0..nodes)
        .map(|_| {
            let mut uut = W::with_word_stride(word_stride);
            uut.connect_all();
            uut
        })
        .collect();
    let mut outputs: Vec<Vec<u64>> = uuts.iter().map(W::sample).collect();
    let mut recording = Recording {
        nodes,
        ..Recording::default()
    };
    let mut bus = true;
    let mut after_finish = 0;
    while recording.cycles() < max_cycles && after_finish < tail {
        if masters.iter().all(|m| m.finished()) {
            after_finish += 1;
        }
        let mut next_bus = true;
        for n in 0..nodes {
            let inputs = masters[n].drive(&outputs[n]);
            uuts[n].apply(&inputs, bus);
            clock_cycle_with(&mut uuts[n], W::clock_input, "bus wrapper", true);
            outputs[n] = uuts[n].sample();
            next_bus &= uuts[n].tx();
            recording.inputs.push(inputs);
            recording.outputs.push(Some(outputs[n].clone()));
        }
        bus = next_bus;
    }
    recording
}

/// Replays `recording`'s inputs on the emitted Verilog of `W`'s bus with `word_stride`, compiled by
/// `simulator` in `workdir`; the outputs it printed.
pub fn run_verilog<W: Wrapped>(
    simulator: Simulator,
    word_stride: bool,
    recording: &Recording,
    workdir: &Path,
) -> Result<Recording, String> {
    std::fs::create_dir_all(workdir).map_err(|e| format!("{}: {e}", workdir.display()))?;
    let write = |name: &str, text: &str| {
        std::fs::write(workdir.join(name), text).map_err(|e| format!("cannot write {name}: {e}"))
    };
    write("can_controller.v", &controller_verilog())?;
    let wrapper_file = W::BUS.file_name();
    write(&wrapper_file, &wrapper_verilog(W::BUS))?;
    write(
        "wrapper_tb.v",
        &testbench::<W>(recording.nodes, word_stride, recording.cycles()),
    )?;
    write("stim.hex", &stimulus_hex::<W>(recording))?;
    simulator.compile_files(
        workdir,
        "wrapper_tb",
        &["wrapper_tb.v", &wrapper_file, "can_controller.v"],
    )?;
    let mut run = simulator.run_command_for(workdir, "wrapper_tb");
    run.arg(format!("+cycles={}", recording.cycles()));
    let out = run
        .output()
        .map_err(|e| format!("cannot run {}: {e}", simulator.name()))?;
    if !out.status.success() {
        return Err(format!(
            "{} failed: {}",
            simulator.name(),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let text = std::fs::read_to_string(workdir.join("trace.txt")).map_err(|e| e.to_string())?;
    let mut outputs = Vec::new();
    for line in text.lines() {
        for node in line.split(" | ") {
            let values: Option<Vec<u64>> = node
                .split_whitespace()
                .map(|v| u64::from_str_radix(v, 16).ok())
                .collect();
            outputs.push(values);
        }
    }
    Ok(Recording {
        nodes: recording.nodes,
        inputs: recording.inputs.clone(),
        outputs,
    })
}

/// The first cycle where `a` and `b` differ, in words.
pub fn first_mismatch<W: Wrapped>(a: &Recording, b: &Recording) -> Option<String> {
    let common = a.outputs.len().min(b.outputs.len());
    let i = (0..common).find(|&i| a.outputs[i] != b.outputs[i]);
    match i {
        Some(i) => {
            let show = |o: &Option<Vec<u64>>| match o {
                None => "X".to_string(),
                Some(values) => W::OUTPUTS
                    .iter()
                    .zip(values)
                    .map(|(p, v)| format!("{}={v:x}", p.name))
                    .collect::<Vec<_>>()
                    .join(" "),
            };
            Some(format!(
                "cycle {}, node {}: rust-hdl {} / Verilog {}",
                i / a.nodes,
                i % a.nodes,
                show(&a.outputs[i]),
                show(&b.outputs[i])
            ))
        }
        None if a.outputs.len() != b.outputs.len() => Some(format!(
            "{} outputs against {}",
            a.outputs.len(),
            b.outputs.len()
        )),
        None => None,
    }
}

fn input_bits<W: Wrapped>() -> u32 {
    W::INPUTS.iter().map(|p| p.width).sum()
}

/// The stimulus: per cycle and node, every input packed (first input in the top bits), in hex.
fn stimulus_hex<W: Wrapped>(recording: &Recording) -> String {
    let digits = input_bits::<W>().div_ceil(4) as usize;
    let mut hex = String::new();
    for inputs in &recording.inputs {
        let mut word: u128 = 0;
        for (p, v) in W::INPUTS.iter().zip(inputs) {
            word = (word << p.width) | u128::from(*v);
        }
        writeln!(hex, "{word:0digits$x}").unwrap();
    }
    hex
}

/// A testbench of `nodes` instances of `W`'s top with `word_stride`, reading `stim.hex` and
/// writing one line per cycle to `trace.txt` (every output in hex, nodes separated by ` | `).
fn testbench<W: Wrapped>(nodes: usize, word_stride: bool, cycles: usize) -> String {
    let width = input_bits::<W>();
    let top = W::BUS.top_module();
    let mut tb = String::new();
    writeln!(
        tb,
        "// Generated by testbenches::wrapper_equivalence.\nmodule wrapper_tb;"
    )
    .unwrap();
    writeln!(
        tb,
        "    reg clock = 1'b0;\n    reg bus = 1'b1;\n    integer cycles, k, fd;"
    )
    .unwrap();
    writeln!(
        tb,
        "    reg [{}:0] stim [0:{}];",
        width - 1,
        (cycles * nodes).max(1) - 1
    )
    .unwrap();
    for n in 0..nodes {
        writeln!(tb, "    reg [{}:0] in_{n};", width - 1).unwrap();
        for p in W::OUTPUTS {
            writeln!(tb, "    wire [{}:0] {}_{n};", p.width - 1, p.name).unwrap();
        }
        let mut connections = vec![".clock(clock)".to_string(), ".rx(bus)".to_string()];
        let mut top_bit = width;
        for p in W::INPUTS {
            let (hi, lo) = (top_bit - 1, top_bit - p.width);
            connections.push(format!(".{}(in_{n}[{hi}:{lo}])", p.name));
            top_bit -= p.width;
        }
        for p in W::OUTPUTS {
            connections.push(format!(".{0}({0}_{n})", p.name));
        }
        writeln!(
            tb,
            "    {top} #(.{WORD_STRIDE_PARAMETER}(1'b{})) node_{n}({});",
            u8::from(word_stride),
            connections.join(", ")
        )
        .unwrap();
    }
    let tx_and: Vec<String> = (0..nodes).map(|n| format!("tx_{n}")).collect();
    let mut formats = Vec::new();
    let mut values = Vec::new();
    for n in 0..nodes {
        formats.push(
            W::OUTPUTS
                .iter()
                .map(|_| "%h")
                .collect::<Vec<_>>()
                .join(" "),
        );
        values.extend(W::OUTPUTS.iter().map(|p| format!("{}_{n}", p.name)));
    }
    writeln!(
        tb,
        "    initial begin\n\
         \x20       if (!$value$plusargs(\"cycles=%d\", cycles)) cycles = 0;\n\
         \x20       if (cycles > 0) $readmemh(\"stim.hex\", stim, 0, cycles * {nodes} - 1);\n\
         \x20       fd = $fopen(\"trace.txt\", \"w\");\n\
         \x20       for (k = 0; k < cycles; k = k + 1) begin"
    )
    .unwrap();
    for n in 0..nodes {
        writeln!(tb, "            in_{n} = stim[k * {nodes} + {n}];").unwrap();
    }
    writeln!(
        tb,
        "            #5 clock = 1'b1;\n\
         \x20           #1 clock = 1'b0;\n\
         \x20           #1 $fdisplay(fd, \"{}\", {});\n\
         \x20           bus = {};\n\
         \x20           #3;\n\
         \x20       end\n\
         \x20       $fclose(fd);\n\
         \x20       $finish;\n\
         \x20   end\n\
         endmodule",
        formats.join(" | "),
        values.join(", "),
        tx_and.join(" & ")
    )
    .unwrap();
    tb
}
