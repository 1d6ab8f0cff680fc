//! Activity-driven simulation of the controller's blocks (not hardware: nothing here reaches the
//! Verilog).
//!
//! rust-hdl's own `LogicBlock` derive re-runs every kernel and re-latches every signal on each
//! `update_all` pass, and a value moves one hierarchy level per pass, so a controller clock cycle
//! cost about six passes over all 779 signals. The blocks of this crate derive
//! [`ActivityBlock`](rtl_derive::ActivityBlock) instead. Its `update_all`:
//!
//! 1. latches the block's inputs first, so a value written by the parent reaches the child's kernel
//!    in the same pass;
//! 2. runs the kernel only when something it reads may have changed: an input, a register (`q`,
//!    or a `d` it reads back), an output of a child; and on the first pass;
//! 3. on a rising edge of `clock`, after the kernel, loads every `DFF` itself (`q` from `d`), so the
//!    whole design loads in the one pass in which the clock is high, from values settled before
//!    the edge, as the Verilog's `always @(posedge clock)` does;
//! 4. visits a child only when the kernel ran (it may have written the child's inputs), the clock
//!    moved, or the child changed at its last visit, and latches the child's inputs only in the
//!    first case.
//!
//! What the kernels read: in rust-hdl 0.46 `val()` of an `Out` or `Local` signal returns `next`
//! (what was just written), while `val()` of an `In` returns the value latched at the owner's
//! visit. So a kernel sees its own locals and outputs, and its children's outputs, at once; a
//! register's `d`, its own inputs and its children's inputs only after a latch. Skipping a kernel
//! whose inputs, registers and children's outputs did not change cannot change what it writes, so
//! the settled values are those of rust-hdl's exhaustive evaluation, under three rules the kernels
//! of this crate follow (`rtl/tests/kernel_rules.rs` checks the first two):
//!
//! - a kernel never reads a child's input (that value moves at the child's visit, after the kernel
//!   ran; keep it in a `Local` instead);
//! - the clock is only passed on (`clock!`, `dff_setup!`), never read as data (the one block that
//!   does, `ClockOutput`, keeps rust-hdl's derive and is visited whenever the clock moves);
//! - inputs and the clock do not change in the same settle (`sim::rtl_step` settles the inputs
//!   first, then holds the clock high for exactly one pass).
//!
//! [`Child::set_exhaustive`] turns the skipping off for a whole design (every kernel on every pass,
//! every child visited: rust-hdl's own evaluation); the `rust-hdl-exhaustive` engine uses it, and
//! `testbenches/tests/engines.rs` compares it with the skipping on every example scenario.

use rust_hdl::prelude::*;

pub use rtl_derive::{ActivityBlock, BlockDefault};

/// The bookkeeping of an [`ActivityBlock`]: what happened at its last visit.
#[derive(Clone, Debug, Default)]
pub struct Activity {
    /// The kernel ran at least once.
    pub(crate) started: bool,
    /// A register changed at the last visit (`q` loaded, or a `d` the kernel may read back): the
    /// kernel runs again.
    pub(crate) rerun: bool,
    /// An output changed at the last visit: the parent's kernel runs again.
    pub(crate) outputs_changed: bool,
    /// Anything in the block or below it changed at the last visit (`has_changed`).
    pub(crate) changed: bool,
    /// Run every kernel and visit every child on every pass (rust-hdl's own behaviour).
    pub(crate) exhaustive: bool,
}

/// A block as its parent's activity-driven `update_all` sees it.
pub trait Child: Block {
    /// One `update_all` pass over the block; `inputs_written` is false when the parent's kernel did
    /// not run since the last visit, so no input can have changed.
    fn visit(&mut self, inputs_written: bool);
    /// Drives the block's clock input(s) with the parent's clock level.
    fn drive_clock(&mut self, level: Clock);
    /// Nothing in the block changed at its last visit: visiting it again changes nothing unless
    /// the parent wrote one of its inputs or the clock moved.
    fn settled(&self) -> bool;
    /// An output of the block changed at its last visit.
    fn outputs_changed(&self) -> bool;
    /// With `true`, every kernel below runs on every pass (for comparisons with the skipping).
    fn set_exhaustive(&mut self, exhaustive: bool);
}

/// `Child` for a block that keeps rust-hdl's own derive: it is visited whenever the clock moves or
/// it changed (its own `update_all` latches everything), and it sees a rising edge one pass after
/// its clock inputs latched it.
macro_rules! derived_child {
    (impl [$($generics:tt)*] $block:ty, clocks: [$($clock:ident),+], output: $output:ident) => {
        impl<$($generics)*> $crate::activity::Child for $block {
            fn visit(&mut self, _inputs_written: bool) {
                ::rust_hdl::core::block::Block::update_all(self);
            }

            fn drive_clock(&mut self, level: ::rust_hdl::core::clock::Clock) {
                $(self.$clock.next = level;)+
            }

            fn settled(&self) -> bool {
                !::rust_hdl::core::block::Block::has_changed(self)
            }

            fn outputs_changed(&self) -> bool {
                self.$output.changed
            }

            fn set_exhaustive(&mut self, _exhaustive: bool) {}
        }
    };
}
pub(crate) use derived_child;

// rust-hdl's RAM reads the inputs latched at the pass of its clock edge, which are from before the
// edge.
derived_child!(impl [D: Synth, const N: usize] RAM<D, N>, clocks: [read_clock, write_clock], output: read_data);
