//! The built-in runs behind `cansim`'s commands: the demo, the bit timing demo, the speed
//! benchmark's reference workload, the fault-injection campaign (and its slices for several machines) and the replay of a capture.

pub mod bench;
pub mod campaign;
pub mod campaign_slice;
pub mod demo;
pub mod replay;
pub mod sync_demo;
