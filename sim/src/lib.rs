//! Everything that is not hardware and not the golden model (that is the `golden` crate): the
//! simulation engine that steps several controllers on one wired-AND bus, the nodes and the lower
//! tester, the host and Linux driver models, the bus decoder and VCD reader, scenario files,
//! response-time analysis, the Verilator engine and the runs of the `cansim` command line tool.
//!
//! * [`engine`]: the event loop, the bus, time, VCD tracing, RTL stepping;
//! * [`nodes`]: devices on the bus (RTL nodes at three levels, the lower tester);
//! * [`host`]: the CPU side (host model, Linux SJA1000 driver, frame buffer, acceptance model);
//! * [`decode`]: the bus decoder and the VCD reader;
//! * [`scenario`], [`rta`], [`verilated`], [`workloads`]: scenario files, response-time analysis,
//!   the Verilator engine, the built-in runs;
//! * [`serve`]: a scenario's bus without end as a socketcand server (`cansim serve`).
#![warn(missing_docs)]

pub mod compiled;
pub mod decode;
pub mod engine;
pub mod host;
pub mod nodes;
pub mod rta;
pub mod scenario;
pub mod serve;
pub mod verilated;
pub mod workloads;
