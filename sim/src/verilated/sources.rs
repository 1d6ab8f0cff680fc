//! The sources Verilator compiles besides the generated controller: a Verilog wrapper around
//! `can_controller` and a C++ shim with a C interface, plus the layout of the words that carry the
//! inputs and outputs of one clock cycle across that interface.
//!
//! The wrapper does two things:
//! - it holds the controller's inputs in registers that the shim loads on each edge of an extra
//!   input, `load`, with the clock still. Verilator re-evaluates the logic that depends on a
//!   top-level input at every `eval()` (its "input combinational" region), and nearly all of the
//!   controller depends on `reset`, the host port or `rx`; fed from registers, that logic runs
//!   only after a clock edge or after the inputs really changed (measured: twice as fast);
//! - it brings the few internal signals the traces and diagnostics need ([`INTERNAL_SIGNALS`]) out
//!   as ports, by hierarchical reference, so nothing else of the design has to be public;
//! - it tells the shim whether CLKOUT shows the controller clock itself (CDR code 7, clock on),
//!   the only case in which an output changes on the clock's falling edge; otherwise the shim
//!   does not evaluate that edge;
//! - for skipping quiet edges (docs/ENGINES.md) it brings out the bit timing's and the CLKOUT
//!   divider's state ([`CONTROLLER_STATE`]) and whether every other flip-flop and memory is
//!   settled (its next value is its value), and it loads the free-running counters among them on
//!   each edge of an extra input, `skip`, with the clock still.
//!
//! [`INTERNAL_SIGNALS`] and [`CONTROLLER_STATE`] are the only places that name signals inside the
//! generated Verilog; the flip-flops and memories `settled` compares are found in it
//! ([`StateElements`]).
//!
//! [`CONTROLLER_STATE`]: crate::compiled::quiet::CONTROLLER_STATE

use std::fmt::Write as _;

use crate::compiled::quiet::{CDR, CDR_CLOCK_OFF, CDR_CODE_FOSC, CDR_CODE_MASK};
use crate::verilated::quiet_word::{QuietField, StateElements};
use crate::verilated::verilog::TOP_MODULE;

/// Top module of the wrapper (and the prefix of Verilator's generated classes).
pub(crate) const WRAPPER_MODULE: &str = "can_controller_sim";
/// File name of the wrapper.
pub(crate) const WRAPPER_FILE: &str = "can_controller_sim.v";
/// File name of the generated controller.
pub(crate) const CONTROLLER_FILE: &str = "can_controller.v";
/// File name of the C++ shim.
pub(crate) const SHIM_FILE: &str = "shim.cpp";
/// Defined in the instrumented build of a profile-guided build: the shim then exports
/// `cc_profile_dump`, which writes the training run's profile.
pub(crate) const PROFILE_GENERATE_MACRO: &str = "CC_PROFILE_GENERATE";
/// Version of the C interface; the library reports it and the loader checks it.
pub(crate) const ABI_VERSION: u32 = 2;

/// An internal signal of the controller that the wrapper brings out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct InternalSignal {
    /// Name of the wrapper port (`p_<name>`) and of the trace probe.
    pub name: &'static str,
    /// The wire of the top module of the generated Verilog that carries it.
    pub wire: &'static str,
    /// Bits in the output word: at least the width of the wire (a wider port zero-extends it).
    pub width: u32,
}

/// The internal signals, in the order of the core probes of the trace ([`crate::nodes::can_node`]), then
/// the ones only diagnostics read.
pub(crate) const INTERNAL_SIGNALS: [InternalSignal; 6] = [
    InternalSignal {
        name: "sample_point",
        wire: "core$sample_point",
        width: 1,
    },
    InternalSignal {
        name: "segment",
        wire: "core$segment",
        width: 2,
    },
    InternalSignal {
        name: "state",
        wire: "core$status$state",
        width: 5,
    },
    InternalSignal {
        name: "tec",
        wire: "core$status$tec",
        width: 8,
    },
    InternalSignal {
        name: "rec",
        wire: "core$status$rec",
        width: 8,
    },
    InternalSignal {
        name: "transmitting",
        wire: "core$status$transmitting",
        width: 1,
    },
];

/// Index of the sample point in [`INTERNAL_SIGNALS`].
const SAMPLE_POINT: usize = 0;
/// Index of the segment in [`INTERNAL_SIGNALS`].
const SEGMENT: usize = 1;
/// Index of the protocol state in [`INTERNAL_SIGNALS`].
pub(crate) const STATE: usize = 2;
/// Index of the "transmitting" flag in [`INTERNAL_SIGNALS`].
pub(crate) const TRANSMITTING: usize = 5;

// ---- the input word -----------------------------------------------------------------------------

/// Bit position of `wdata` (8 bits) in the input word.
pub(crate) const IN_WDATA: u32 = 0;
/// Bit position of `addr` (8 bits).
pub(crate) const IN_ADDR: u32 = 8;
/// Bit position of `we`.
pub(crate) const IN_WE: u32 = 16;
/// Bit position of `re`.
pub(crate) const IN_RE: u32 = 17;
/// Bit position of `rx`.
pub(crate) const IN_RX: u32 = 18;
/// Bit position of `reset`.
pub(crate) const IN_RESET: u32 = 19;

// ---- the output word ----------------------------------------------------------------------------

/// Bit position of `rdata` (8 bits) in the output word.
pub(crate) const OUT_RDATA: u32 = 0;
/// Bit position of `tx`.
pub(crate) const OUT_TX: u32 = 8;
/// Bit position of `irq_n`.
pub(crate) const OUT_IRQ_N: u32 = 9;
/// Bit position of `clkout`.
pub(crate) const OUT_CLKOUT: u32 = 10;
/// Bit position of the first internal signal; the others follow in table order.
const OUT_FIRST_INTERNAL: u32 = 11;

/// The outputs only a trace shows, which a skip of quiet edges in an untraced run may change on
/// the way (`crate::compiled::quiet`): CLKOUT, the sample point and the segment.
pub(crate) const UNTRACED_OUTPUTS: u64 = 1 << OUT_CLKOUT
    | ((1 << INTERNAL_SIGNALS[SAMPLE_POINT].width) - 1) << INTERNAL_SHIFTS[SAMPLE_POINT]
    | ((1 << INTERNAL_SIGNALS[SEGMENT].width) - 1) << INTERNAL_SHIFTS[SEGMENT];

/// Bit position of each internal signal in the output word.
pub(crate) const INTERNAL_SHIFTS: [u32; INTERNAL_SIGNALS.len()] = internal_shifts();

const fn internal_shifts() -> [u32; INTERNAL_SIGNALS.len()] {
    let mut shifts = [0; INTERNAL_SIGNALS.len()];
    let mut at = OUT_FIRST_INTERNAL;
    let mut i = 0;
    while i < INTERNAL_SIGNALS.len() {
        shifts[i] = at;
        at += INTERNAL_SIGNALS[i].width;
        i += 1;
    }
    assert!(at <= 64, "the output word holds 64 bits");
    shifts
}

// ---- quiet edges --------------------------------------------------------------------------------

/// Verilog's hierarchical name of `path.net` below the wrapper's instance.
fn below_dut(path: &str, net: &str) -> String {
    format!("dut.{path}.{net}")
}

/// The wrapper's expression that is 1 when no flip-flop but the counters and no memory changes at
/// the next edge.
fn settled_expression(elements: &StateElements, layout: &[QuietField]) -> String {
    let counters: Vec<&str> = layout
        .iter()
        .filter(|f| f.counter)
        .map(|f| f.path.as_str())
        .collect();
    let mut terms: Vec<String> = elements
        .flip_flops
        .iter()
        .filter(|(path, _)| !counters.contains(&path.as_str()))
        .map(|(path, _)| format!("({} == {})", below_dut(path, "d"), below_dut(path, "q")))
        .collect();
    for ram in &elements.memories {
        terms.push(format!(
            "!{} && ({} == {}[{}])",
            below_dut(ram, "write_enable"),
            below_dut(ram, "read_data"),
            below_dut(ram, "mem"),
            below_dut(ram, "read_address")
        ));
    }
    terms.join("\n        && ")
}

/// The wrapper module around [`TOP_MODULE`], whose flip-flops and memories are `elements` and
/// whose quiet word is laid out as `layout` (both found in its Verilog).
pub(crate) fn wrapper_verilog(elements: &StateElements, layout: &[QuietField]) -> String {
    let mut ports = String::new();
    let mut decls = String::new();
    let mut assigns = String::new();
    for s in &INTERNAL_SIGNALS {
        write!(ports, ", p_{}", s.name).unwrap();
        let range = match s.width {
            1 => String::new(),
            w => format!("[{}:0] ", w - 1),
        };
        writeln!(decls, "    output wire {range}p_{};", s.name).unwrap();
        writeln!(assigns, "    assign p_{} = dut.{};", s.name, s.wire).unwrap();
    }
    let mut quiet_fields = String::new();
    let mut skip_loads = String::new();
    for f in layout {
        let range = format!("{}:{}", f.shift + f.width - 1, f.shift);
        let q = below_dut(&f.path, "q");
        writeln!(quiet_fields, "    assign p_quiet[{range}] = {q};").unwrap();
        if f.counter {
            writeln!(skip_loads, "        {q} <= skip_state[{range}];").unwrap();
        }
    }
    let cdr = below_dut(&layout[CDR].path, "q");
    let cdr_width = layout[CDR].width;
    let used = layout.last().map_or(0, |f| f.shift + f.width);
    let settled = settled_expression(elements, layout);
    format!(
        "\
// Generated by sim::verilated: {TOP_MODULE} with registered inputs, a few internal signals as
// ports and the state of the quiet-edge skipping, for the Verilator engine of the simulator. Not
// part of the hardware.
module {WRAPPER_MODULE}(clock, load, reset, addr, wdata, we, re, rx, rdata, tx, irq_n, clkout{ports},
    p_clock_shown, p_quiet, probe, p_settled, skip, skip_state);
    input wire clock;
    input wire load;
    input wire reset;
    input wire [7:0] addr;
    input wire [7:0] wdata;
    input wire we;
    input wire re;
    input wire rx;
    output wire [7:0] rdata;
    output wire tx;
    output wire irq_n;
    output wire clkout;
{decls}    output wire p_clock_shown;
    output wire [{last_field}:0] p_quiet;
    input wire probe;
    output reg p_settled = 1'b0;
    input wire skip;
    input wire [63:0] skip_state;

    // The controller's inputs, loaded on either edge of `load` (never together with a clock edge).
    reg reset_q = 1'b0;
    reg [7:0] addr_q = 8'h0;
    reg [7:0] wdata_q = 8'h0;
    reg we_q = 1'b0;
    reg re_q = 1'b0;
    reg rx_q = 1'b1;
    always @(posedge load or negedge load) begin
        reset_q <= reset;
        addr_q <= addr;
        wdata_q <= wdata;
        we_q <= we;
        re_q <= re;
        rx_q <= rx;
    end

    {TOP_MODULE} dut(.clock(clock), .reset(reset_q), .addr(addr_q), .wdata(wdata_q), .we(we_q),
        .re(re_q), .rdata(rdata), .rx(rx_q), .tx(tx), .irq_n(irq_n), .clkout(clkout));

{assigns}
    // CLKOUT shows the controller clock itself: the one output that the falling edge changes.
    assign p_clock_shown = ({cdr} & {cdr_width}'d{shown_mask}) == {cdr_width}'d{CDR_CODE_FOSC};

    // Quiet edges: the bit timing's and the CLKOUT divider's state; whether everything else is
    // settled, taken on either edge of `probe` (so the comparisons cost nothing in the cycles that
    // do not ask); the free-running counters loaded on either edge of `skip` with their values
    // after the skipped edges (neither edge ever together with a clock edge).
{quiet_fields}    always @(posedge probe or negedge probe) begin
        p_settled <= {settled};
    end
    /* verilator lint_off MULTIDRIVEN */
    always @(posedge skip or negedge skip) begin
{skip_loads}    end
    /* verilator lint_on MULTIDRIVEN */
endmodule
",
        last_field = used - 1,
        shown_mask = CDR_CODE_MASK | CDR_CLOCK_OFF,
    )
}

/// The C++ shim: `cc_abi_version`, `cc_create`, `cc_destroy`, `cc_cycle` (one clock cycle: the
/// input word in, the output word out), `cc_quiet` (the quiet word without its settled bit),
/// `cc_settled` (evaluates and gives that bit) and `cc_skip` (loads the counters from a quiet
/// word, gives the output word).
pub(crate) fn shim_cpp() -> String {
    let mut pack = String::new();
    for (s, shift) in INTERNAL_SIGNALS.iter().zip(INTERNAL_SHIFTS) {
        writeln!(
            pack,
            "    out |= static_cast<uint64_t>(t.p_{}) << {shift};",
            s.name
        )
        .unwrap();
    }
    let class = format!("V{WRAPPER_MODULE}");
    format!(
        "\
// Generated by sim::verilated: the Verilated {WRAPPER_MODULE} behind a C interface, one call per
// clock cycle, for the Rust simulation engine.
#include <cstdint>
#include <new>
#include \"verilated.h\"
#include \"{class}.h\"
#if __has_include(\"{class}___024root.h\")
#include \"{class}___024root.h\"
#endif

#define CC_EXPORT extern \"C\" __attribute__((visibility(\"default\")))

namespace {{
struct Model {{
    VerilatedContext context;
    {class} top;
    // The input word the wrapper's input registers hold; `loaded` is false until the first load.
    uint32_t inputs = 0;
    bool loaded = false;
    // The first evaluation runs the `initial` blocks and takes the clock, `load`, `probe` and
    // `skip` as they are (low) without seeing an edge; from then on their changes are edges.
    Model() : context(), top(&context, \"{WRAPPER_MODULE}\") {{ top.eval(); }}
}};

// The clock's falling edge without an evaluation: Verilator's next eval() finds the rising edge
// by comparing the clock with the level it recorded at the last one, so that record is set low.
// Where the generated model has no such member (another Verilator version) this returns false
// and the caller evaluates the edge.
template <class Root>
auto clock_fell(Root* root, int) -> decltype(root->__Vtrigrprev__TOP__clock = 0, bool()) {{
    root->__Vtrigrprev__TOP__clock = 0;
    return true;
}}
template <class Root>
bool clock_fell(Root*, long) {{ return false; }}

uint64_t outputs({class}& t) {{
    uint64_t out = static_cast<uint64_t>(t.rdata) << {OUT_RDATA};
    out |= static_cast<uint64_t>(t.tx) << {OUT_TX};
    out |= static_cast<uint64_t>(t.irq_n) << {OUT_IRQ_N};
    out |= static_cast<uint64_t>(t.clkout) << {OUT_CLKOUT};
{pack}    return out;
}}
}}

CC_EXPORT uint32_t cc_abi_version() {{ return {ABI_VERSION}; }}

CC_EXPORT void* cc_create() {{ return new (std::nothrow) Model(); }}

CC_EXPORT void cc_destroy(void* model) {{ delete static_cast<Model*>(model); }}

CC_EXPORT uint64_t cc_cycle(void* model, uint32_t inputs) {{
    Model& m = *static_cast<Model*>(model);
    {class}& t = m.top;
    if (!m.loaded || inputs != m.inputs) {{
        t.wdata = (inputs >> {IN_WDATA}) & 0xff;
        t.addr = (inputs >> {IN_ADDR}) & 0xff;
        t.we = (inputs >> {IN_WE}) & 1;
        t.re = (inputs >> {IN_RE}) & 1;
        t.rx = (inputs >> {IN_RX}) & 1;
        t.reset = (inputs >> {IN_RESET}) & 1;
        t.load = !t.load;
        t.eval();
        m.inputs = inputs;
        m.loaded = true;
    }}
    // The rising edge, then the clock low again: outputs are read as after the rust-hdl model's
    // cycle (a CLKOUT that passes the clock through reads low). Nothing but such a CLKOUT
    // changes on the falling edge, so only then is it evaluated (otherwise 7 % fewer instructions
    // per cycle; tests/modes.rs and the scripted equivalence fail if the check misses it).
    t.clock = 1;
    t.eval();
    t.clock = 0;
    if (t.p_clock_shown || !clock_fell(t.rootp, 0)) {{
        t.eval();
    }}
    return outputs(t);
}}

CC_EXPORT uint64_t cc_quiet(void* model) {{ return static_cast<Model*>(model)->top.p_quiet; }}

CC_EXPORT uint32_t cc_settled(void* model) {{
    {class}& t = static_cast<Model*>(model)->top;
    t.probe = !t.probe;
    t.eval();
    return t.p_settled;
}}

CC_EXPORT uint64_t cc_skip(void* model, uint64_t state) {{
    {class}& t = static_cast<Model*>(model)->top;
    t.skip_state = state;
    t.skip = !t.skip;
    t.eval();
    return outputs(t);
}}

#ifdef {PROFILE_GENERATE_MACRO}
// The instrumented build of a profile-guided one writes its profile when the training ends.
extern \"C\" void __gcov_dump(void);
CC_EXPORT void cc_profile_dump() {{ __gcov_dump(); }}
#endif
"
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nodes::can_node::{core_probes, CORE_PROBES, CORE_PROBE_BITS};
    use crate::verilated::quiet_word::quiet_layout;
    use crate::verilated::verilog::controller_verilog;

    #[test]
    fn internal_signals_start_with_the_core_probes_in_their_order_and_width() {
        for (probe, signal) in core_probes().iter().zip(&INTERNAL_SIGNALS[..CORE_PROBES]) {
            assert_eq!(probe.name, signal.name);
            assert_eq!(probe.width, signal.width, "{}", signal.name);
        }
        assert_eq!(INTERNAL_SIGNALS[STATE].name, "state");
        assert_eq!(INTERNAL_SIGNALS[TRANSMITTING].name, "transmitting");
        let widths: u32 = core_probes().iter().map(|p| p.width).sum();
        assert_eq!(widths, CORE_PROBE_BITS);
    }

    /// The wires the wrapper reads must exist in the generated Verilog, at most as wide as the
    /// port: a renamed or widened signal in `rtl/` fails here with its name.
    #[test]
    fn every_internal_signal_is_a_wire_of_the_top_module_that_fits_its_port() {
        let verilog = controller_verilog();
        let top_end = verilog
            .find("endmodule")
            .expect("the top module ends somewhere");
        let top = &verilog[..top_end];
        for s in &INTERNAL_SIGNALS {
            let decl = top
                .lines()
                .map(str::trim)
                .find(|l| l.starts_with("wire") && l.ends_with(&format!(" {};", s.wire)))
                .unwrap_or_else(|| {
                    panic!(
                        "the Verilator engine reads `{}` ({}), which the top module of the \
                         generated Verilog no longer declares: update INTERNAL_SIGNALS in \
                         sim/src/verilated/sources.rs",
                        s.wire, s.name
                    )
                });
            let width = match decl.find('[') {
                Some(open) => {
                    let msb: u32 = decl[open + 1..decl.find(':').unwrap()].parse().unwrap();
                    msb + 1
                }
                None => 1,
            };
            assert!(
                width <= s.width,
                "`{}` is {width} bits wide, the port {}: widen it in INTERNAL_SIGNALS",
                s.wire,
                s.width
            );
        }
    }

    /// The wrapper loads exactly the free-running counters on `skip`, brings out every net of the
    /// quiet state, and calls the design settled only if every other flip-flop and every memory
    /// is.
    #[test]
    fn the_wrapper_loads_the_counters_and_compares_every_other_flip_flop_and_memory() {
        let elements = StateElements::of(&controller_verilog());
        let layout = quiet_layout(&elements);
        let wrapper = wrapper_verilog(&elements, &layout);
        for field in &layout {
            let q = below_dut(&field.path, "q");
            let range = format!("[{}:{}]", field.shift + field.width - 1, field.shift);
            assert!(
                wrapper.contains(&format!("assign p_quiet{range} = {q};")),
                "{q}"
            );
            let load = format!("{q} <= skip_state{range};");
            assert_eq!(wrapper.contains(&load), field.counter, "{load}");
        }
        for (path, _) in &elements.flip_flops {
            let compared = format!("({} == {})", below_dut(path, "d"), below_dut(path, "q"));
            let counter = layout.iter().any(|f| f.counter && &f.path == path);
            assert_eq!(wrapper.contains(&compared), !counter, "{path}");
        }
        for ram in &elements.memories {
            let unchanged = format!(
                "!{} && ({} == {}[{}])",
                below_dut(ram, "write_enable"),
                below_dut(ram, "read_data"),
                below_dut(ram, "mem"),
                below_dut(ram, "read_address")
            );
            assert!(wrapper.contains(&unchanged), "{ram}");
        }
    }

    #[test]
    fn the_shim_packs_every_internal_signal_at_its_shift() {
        let shim = shim_cpp();
        for (s, shift) in INTERNAL_SIGNALS.iter().zip(INTERNAL_SHIFTS) {
            assert!(
                shim.contains(&format!("t.p_{}) << {shift};", s.name)),
                "{}",
                s.name
            );
        }
        assert_eq!(INTERNAL_SHIFTS[0], OUT_FIRST_INTERNAL);
    }
}
