//! `waves-check [-v] [PATH…]`: compares our bus decoder with sigrok's CAN decoder on every VCD under
//! the given files and directories (default `waves/`), in parallel; prints one line per file with the
//! exclusions it applied (`-v`: each one, with its time and frame) and every disagreement, then the
//! totals. Exits non-zero on a disagreement, an unreadable file or when sigrok-cli is missing. See
//! `testbenches::agreement` for the rule.

use std::path::PathBuf;
use std::process::ExitCode;

use testbenches::waves_check::check_paths;

/// The directory checked when no path is given.
const DEFAULT_DIR: &str = "waves";

fn main() -> ExitCode {
    match run() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(message) => {
            eprintln!("waves-check: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<bool, String> {
    let mut verbose = false;
    let mut paths = Vec::new();
    for arg in std::env::args_os().skip(1) {
        match arg.to_str() {
            Some("-v" | "--verbose") => verbose = true,
            Some(flag) if flag.starts_with('-') => {
                return Err(format!(
                    "unknown option {flag}; usage: waves-check [-v] [PATH...]"
                ))
            }
            _ => paths.push(PathBuf::from(arg)),
        }
    }
    if paths.is_empty() {
        paths.push(PathBuf::from(DEFAULT_DIR));
    }
    check_paths(&paths, verbose)
}
