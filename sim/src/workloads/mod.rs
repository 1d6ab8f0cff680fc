//! The built-in runs behind `cansim`'s commands: the demo, the bit timing demo, the speed
//! benchmark's reference workload and the fault-injection campaign.

pub mod bench;
pub mod campaign;
pub mod demo;
pub mod sync_demo;
