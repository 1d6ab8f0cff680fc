//! The hardware of the SJA1000-compatible CAN controller: synthesizable rust-hdl blocks only.
//!
//! One block per file, named after the block. Nothing here knows about files, threads, VCD or the CLI;
//! the simulation engine, testbenches and tools live in the `sim` crate.
#![warn(missing_docs)]
// Kernels compare bits with `== false` on purpose: `!bit` inside some expressions generates wrong
// Verilog (see docs/RUST_HDL.md of the project).
#![allow(clippy::bool_comparison)]
// `#[hdl_gen]` kernels cannot express match guards: per-state arms keep their own `if`.
#![allow(clippy::collapsible_match)]

pub mod acceptance_filter;
pub mod activity;
pub mod bit_timing;
pub mod bsp;
pub mod bus;
pub mod bus_sampling;
pub mod can_controller;
pub mod can_core;
pub mod clock_divider;
pub mod clock_output;
pub mod register_map;
pub mod registers;
pub mod rx_fifo;
pub mod tx_buffer;

/// Dominant bus level (logic 0).
pub const DOMINANT: bool = false;
/// Recessive bus level (logic 1).
pub const RECESSIVE: bool = true;
