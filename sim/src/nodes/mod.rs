//! The devices on the simulated bus: nodes built from the RTL at three levels (the bit timing logic
//! alone, the protocol core, the complete controller behind its host port) and the lower tester
//! that plays golden bit scripts.

pub mod btl_node;
pub mod can_node;
pub mod controller_node;
pub mod core_engine;
pub mod lower_tester;
