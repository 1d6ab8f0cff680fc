//! The demo of `cansim demo` (and of a bare `cargo run --release`): the scenario
//! `examples/demo.toml`, built into the binary so that the demo runs from any directory. Four
//! complete controllers, each driven only through its registers by the Linux SJA1000 driver
//! model: arbitration, a node whose acceptance filter rejects some identifiers, an injected error,
//! a node pushed to error passive and back, and a node taken to bus-off and restarted by its
//! driver. The file's comments tell the story.

use std::path::Path;

use crate::scenario::{parse, Scenario, ScenarioError};

/// The demo scenario as shipped.
pub const DEMO_TOML: &str = include_str!("../../../examples/demo.toml");
/// Where the demo scenario lives in the repository (named in messages).
pub const DEMO_PATH: &str = "examples/demo.toml";
/// Where `cansim demo` writes the VCD.
pub const DEMO_VCD: &str = "waves/demo.vcd";
/// Where `cansim demo` writes the bus log.
pub const DEMO_LOG: &str = "waves/demo.log";

/// The demo scenario.
pub fn demo_scenario() -> Result<Scenario, ScenarioError> {
    parse(DEMO_TOML, Path::new(DEMO_PATH))
}
