//! The controller behind the buses SoCs use: Wishbone B4 ([`wishbone`]), AXI4-Lite
//! ([`axi4_lite`]) and APB3/APB4 ([`apb`]), 32 bits wide: each a top block with its bus protocol
//! around [`register_port`], the [`CanController`](crate::can_controller::CanController) behind a
//! byte-lane sequencer that all three share. `cansim verilog --bus …` emits them as `can_controller_wb`,
//! `can_controller_axil` and `can_controller_apb`, each instantiating `can_controller`.
//!
//! The register layout is the wrappers' `word_stride` (a Verilog parameter of the emitted top):
//! 0, byte registers at byte addresses, for Linux's `sja1000_platform` with `reg-io-width = 1`;
//! 1, register n in byte lane 0 of word n (byte address 4n), for `reg-io-width = 4`.

pub mod apb;
pub mod axi4_lite;
pub mod register_port;
pub mod wishbone;
