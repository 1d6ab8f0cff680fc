//! Our bus decoder against sigrok's CAN decoder (an independent implementation) on every VCD the
//! testbenches wrote into `waves/` (`CANSIM_WAVES=1 cargo test`): `make waves-compare` runs this
//! ignored test after the testbenches, with the same build as `cargo test` (CI has no other). The
//! `waves-check` binary does the same from the command line (`-v` for each exclusion).

use std::path::{Path, PathBuf};

use testbenches::waves_check::check_paths;

#[test]
#[ignore = "needs the VCDs of CANSIM_WAVES=1 cargo test: make waves-compare"]
fn every_testbench_vcd_agrees_with_sigrok() {
    let waves: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../waves");
    match check_paths(&[waves], false) {
        Ok(agreed) => assert!(
            agreed,
            "a VCD disagrees with sigrok or cannot be read (above)"
        ),
        Err(message) => panic!("{message}"),
    }
}
