//! The compiled engine's model (`sim/src/compiled/model.rs`) is the one Yosys and the generator
//! make from the Verilog of `rtl/` now: a change of `rtl/` without `make compiled-model` fails here
//! (and the engine refuses to start). That the model computes what the rust-hdl model computes is
//! checked by `engines.rs` (every example, a register session) and `verilog_equivalence.rs` (per
//! cycle).

use std::path::Path;

#[test]
fn the_checked_in_model_is_generated_from_the_current_verilog() {
    let generated = sim::compiled::generate_model_source().unwrap_or_else(|e| panic!("{e}"));
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(sim::compiled::MODEL_PATH);
    let checked_in = std::fs::read_to_string(&path).unwrap();
    assert!(
        generated == checked_in,
        "{} is not what `make compiled-model` generates from rtl/ now: run `make compiled-model` \
         and commit the file",
        path.display()
    );
}
