//! The compiled engine's models (the controller's `sim/src/compiled/model.rs`, the bare core's
//! `core_model.rs`, its lane model `lane_model.rs`) are the ones Yosys and the generator make from the Verilog of `rtl/` now: a
//! change of `rtl/` without `make compiled-model` fails here (and the engine refuses to start). That the model computes what the rust-hdl model computes is
//! checked by `engines.rs` (every example, a register session) and `verilog_equivalence.rs` (per
//! cycle).

use std::path::Path;

use sim::compiled::Design;

#[test]
fn the_checked_in_controller_model_is_generated_from_the_current_verilog() {
    check(Design::Controller);
}

#[test]
fn the_checked_in_core_model_is_generated_from_the_current_verilog() {
    check(Design::Core);
}

#[test]
fn the_checked_in_lane_model_is_generated_from_the_current_verilog() {
    let generated = sim::compiled::generate_lane_model_source().unwrap_or_else(|e| panic!("{e}"));
    compare(&generated, sim::compiled::LANE_MODEL_PATH);
}

fn check(design: Design) {
    let generated = sim::compiled::generate_model_source(design).unwrap_or_else(|e| panic!("{e}"));
    compare(&generated, design.model_path());
}

fn compare(generated: &str, model_path: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(model_path);
    let checked_in = std::fs::read_to_string(&path).unwrap();
    assert!(
        generated == checked_in,
        "{} is not what `make compiled-model` generates from rtl/ now: run `make compiled-model` \
         and commit the file",
        path.display()
    );
}
