//! Everything that is not hardware: the simulation engine that steps several controllers on one
//! wired-AND bus, the lower tester, the golden CAN frame codec, the VCD tracer, the bit-timing
//! calculator and the pieces of the `cansim` command line tool.
#![warn(missing_docs)]

pub mod acceptance;
pub mod bench;
pub mod btl_node;
pub mod btr;
pub mod bus;
pub mod bus_decoder;
pub mod campaign;
pub mod can_node;
pub mod controller_node;
pub mod crc15;
pub mod demo;
pub mod driver;
pub mod engine;
pub mod frame;
pub mod frame_buffer;
pub mod host;
pub mod lower_tester;
pub mod reference;
pub mod rta;
pub mod rtl_step;
pub mod scenario;
pub mod sync_demo;
pub mod time;
pub mod trace;
pub mod vcd_reader;
pub mod verilog;
pub mod worst_case;
