//! Helpers shared by the command-line tests (each test binary uses a subset of them).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `cansim` binary with `args`.
pub fn cansim(args: &[&str]) -> Output {
    cansim_with_env(args, &[])
}

/// Runs the `cansim` binary with `args` and the environment variables `env` set.
pub fn cansim_with_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_cansim"));
    command.args(args);
    for (name, value) in env {
        command.env(name, value);
    }
    command.output().expect("cansim runs")
}

/// Output bytes as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The path of `name` under the repository's `examples/`.
pub fn example(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name)
        .to_string_lossy()
        .into_owned()
}
