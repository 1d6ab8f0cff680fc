//! Building the model library and keeping it under `target/verilator/`, keyed by a hash of
//! everything that goes into it: the generated Verilog, the wrapper, the shim, the build flags and
//! the Verilator version. A changed design builds a new library; an unchanged one is loaded as is.
//!
//! A build happens in a directory of its own and its library is renamed into place when complete,
//! so two processes that build at once both end with a whole library (the last rename wins) and a
//! failed or interrupted build leaves nothing that looks finished.
//!
//! The build is profile-guided: an instrumented library runs a training (`training.rs`) and the
//! compiler builds the kept library from that profile (branch layout and inlining where the
//! stepped edges go: the reference workload with skipping on about 9 % faster, 2 and 8 nodes).
//! Where that fails (another compiler, no profiling runtime) the library is built without a
//! profile, as the message says.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use super::quiet_word::{quiet_layout, QuietField, StateElements};
use super::sources::{
    self, shim_cpp, wrapper_verilog, CONTROLLER_FILE, SHIM_FILE, WRAPPER_FILE, WRAPPER_MODULE,
};
use super::{training, EngineError};
use crate::verilated::verilog::controller_verilog;

/// The Verilator executable.
const VERILATOR: &str = "verilator";
/// Sub-directory of the target directory holding the built libraries.
const CACHE_SUBDIR: &str = "verilator";
/// File name of the library inside a build directory.
const LIBRARY_NAME: &str = "libcan_controller_sim.so";
/// Build time on a two-core machine (the two compilations and the training), for the progress
/// line.
const TYPICAL_BUILD_SECONDS: u32 = 20;
/// Lines of the tool's output quoted in a build error.
const ERROR_TAIL_LINES: usize = 40;

/// How Verilator translates and compiles the model. `-O3` and fast X handling (the design resets
/// every register it reads); C++ at `-O2` (as fast as `-O3` here, quicker to build; Verilator's
/// default `-Os` is a third slower), position independent for the shared library, with only the
/// shim's functions exported. [`ProfileStage`] adds its flags.
const BUILD_FLAGS: &[&str] = &[
    "--cc",
    "--exe",
    "--build",
    "-O3",
    "--x-assign",
    "fast",
    "--x-initial",
    "fast",
    "--noassert",
    "-Wno-fatal",
    "-Wno-lint",
    "-Wno-style",
    "-CFLAGS",
    "-fPIC -fvisibility=hidden -fno-semantic-interposition",
    "-LDFLAGS",
    "-shared",
    "-MAKEFLAGS",
    "OPT_FAST=-O2 OPT_GLOBAL=-O2 OPT_SLOW=-O1",
];

/// The compilations of a profile-guided build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ProfileStage {
    /// Instrumented: counts branches and calls, and exports the shim's `cc_profile_dump`.
    Generate,
    /// Laid out by the profile the training wrote beside the objects (functions it never ran
    /// are optimised as without a profile).
    Use,
    /// No profile (the fallback).
    Without,
}

impl ProfileStage {
    /// Verilator options added to [`BUILD_FLAGS`].
    fn flags(self) -> Vec<String> {
        let cflags = match self {
            ProfileStage::Generate => format!(
                "-fprofile-generate -fprofile-update=single -D{}",
                sources::PROFILE_GENERATE_MACRO
            ),
            ProfileStage::Use => {
                "-fprofile-use -fprofile-partial-training -Wno-missing-profile".into()
            }
            ProfileStage::Without => return Vec::new(),
        };
        let mut flags = vec!["-CFLAGS".to_string(), cflags];
        if self == ProfileStage::Generate {
            flags.extend(["-LDFLAGS".to_string(), "-fprofile-generate".to_string()]);
        }
        flags
    }
}

/// Where built libraries are kept: `verilator/` in the Cargo target directory of the running
/// executable (found by the `CACHEDIR.TAG` Cargo puts there), else in the temporary directory.
pub(crate) fn cache_dir() -> PathBuf {
    std::env::current_exe()
        .ok()
        .and_then(|exe| {
            exe.ancestors()
                .skip(1)
                .find(|dir| dir.join("CACHEDIR.TAG").is_file())
                .map(|dir| dir.join(CACHE_SUBDIR))
        })
        .unwrap_or_else(|| std::env::temp_dir().join("cansim-verilator"))
}

/// The first line of `verilator --version`; [`EngineError::VerilatorMissing`] if it cannot run.
fn verilator_version() -> Result<String, EngineError> {
    let output = Command::new(VERILATOR)
        .arg("--version")
        .output()
        .map_err(|e| EngineError::VerilatorMissing(e.to_string()))?;
    if !output.status.success() {
        return Err(EngineError::VerilatorMissing(format!(
            "`{VERILATOR} --version` failed ({})",
            output.status
        )));
    }
    Ok(String::from_utf8_lossy(&output.stdout)
        .lines()
        .next()
        .unwrap_or_default()
        .to_string())
}

/// 64-bit FNV-1a of `parts`, each followed by a separator byte (stable across Rust versions, unlike
/// the standard hasher).
pub(crate) fn fnv1a(parts: &[&str]) -> u64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut hash = OFFSET;
    for part in parts {
        for byte in part.bytes().chain([0xff]) {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(PRIME);
        }
    }
    hash
}

/// The files of one build.
struct Sources {
    controller: String,
    /// Where the wrapper's quiet word holds each state net.
    layout: Vec<QuietField>,
    wrapper: String,
    shim: String,
}

impl Sources {
    fn new() -> Sources {
        let controller = controller_verilog();
        let elements = StateElements::of(&controller);
        let layout = quiet_layout(&elements);
        Sources {
            wrapper: wrapper_verilog(&elements, &layout),
            controller,
            layout,
            shim: shim_cpp(),
        }
    }

    /// The cache key: the sources, the flags, the tools.
    fn key(&self, verilator: &str) -> u64 {
        let cxx = std::env::var("CXX").unwrap_or_default();
        let profile: Vec<String> = [ProfileStage::Generate, ProfileStage::Use]
            .iter()
            .flat_map(|stage| stage.flags())
            .collect();
        let mut parts = vec![
            verilator,
            cxx.as_str(),
            &self.controller,
            &self.wrapper,
            &self.shim,
        ];
        parts.extend(BUILD_FLAGS);
        parts.extend(profile.iter().map(String::as_str));
        fnv1a(&parts)
    }

    fn write(&self, dir: &Path) -> Result<(), EngineError> {
        for (name, text) in [
            (CONTROLLER_FILE, &self.controller),
            (WRAPPER_FILE, &self.wrapper),
            (SHIM_FILE, &self.shim),
        ] {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|e| EngineError::io(&path, e))?;
        }
        Ok(())
    }
}

/// The library of the current design (built first if the cache does not hold it) and where its
/// quiet word holds each state net.
pub(crate) fn library() -> Result<(PathBuf, Vec<QuietField>), EngineError> {
    let version = verilator_version()?;
    let sources = Sources::new();
    let dir = cache_dir();
    let path = dir.join(format!(
        "{WRAPPER_MODULE}-{:016x}.so",
        sources.key(&version)
    ));
    if !path.is_file() {
        build(&sources, &dir, &path)?;
    }
    Ok((path, sources.layout))
}

/// Builds the library in a fresh directory under `dir` and renames it to `target`.
fn build(sources: &Sources, dir: &Path, target: &Path) -> Result<(), EngineError> {
    eprintln!("building the Verilator model (about {TYPICAL_BUILD_SECONDS} s)…");
    let start = Instant::now();
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let work = dir.join(format!("build-{}-{nanos}", std::process::id()));
    std::fs::create_dir_all(&work).map_err(|e| EngineError::io(&work, e))?;
    let result = compile(sources, &work).and_then(|library| {
        std::fs::rename(&library, target).map_err(|e| EngineError::io(target, e))
    });
    let _ = std::fs::remove_dir_all(&work);
    result?;
    eprintln!(
        "built the Verilator model in {:.1} s: {}",
        start.elapsed().as_secs_f64(),
        target.display()
    );
    Ok(())
}

/// Builds the library in `work`, profile-guided (or, if that fails, without a profile); returns
/// the library built there.
fn compile(sources: &Sources, work: &Path) -> Result<PathBuf, EngineError> {
    sources.write(work)?;
    let guided = run_verilator(work, ProfileStage::Generate)
        .and_then(|instrumented| training::train(&instrumented, &sources.layout))
        .and_then(|()| remove_objects(work))
        .and_then(|()| run_verilator(work, ProfileStage::Use));
    guided.or_else(|e| {
        eprintln!("building the Verilator model without a profile ({e})");
        remove_objects(work)?;
        run_verilator(work, ProfileStage::Without)
    })
}

/// Removes the compiled objects and the library of an earlier stage, keeping the profile.
fn remove_objects(work: &Path) -> Result<(), EngineError> {
    let obj = work.join("obj");
    let entries = std::fs::read_dir(&obj).map_err(|e| EngineError::io(&obj, e))?;
    for entry in entries.flatten() {
        let path = entry.path();
        let built = matches!(
            path.extension().and_then(|e| e.to_str()),
            Some("o" | "a" | "so")
        );
        if built {
            std::fs::remove_file(&path).map_err(|e| EngineError::io(&path, e))?;
        }
    }
    Ok(())
}

/// Runs Verilator (translation and C++ build) in `work` for `stage`; returns the library built
/// there.
fn run_verilator(work: &Path, stage: ProfileStage) -> Result<PathBuf, EngineError> {
    let jobs = std::thread::available_parallelism().map_or(1, |n| n.get());
    let prefix = format!("V{WRAPPER_MODULE}");
    let mut command = Command::new(VERILATOR);
    command
        .current_dir(work)
        .args(BUILD_FLAGS)
        .args(stage.flags())
        .args(["--top-module", WRAPPER_MODULE, "--prefix", &prefix])
        .args(["--Mdir", "obj", "-o", LIBRARY_NAME])
        .args(["-j", &jobs.to_string()])
        .args([WRAPPER_FILE, CONTROLLER_FILE, SHIM_FILE])
        // A surrounding `make` (make test) must not hand its jobserver to Verilator's.
        .env_remove("MAKEFLAGS")
        .env_remove("MFLAGS")
        .env_remove("MAKELEVEL");
    let output = command
        .output()
        .map_err(|e| EngineError::VerilatorMissing(e.to_string()))?;
    let library = work.join("obj").join(LIBRARY_NAME);
    if !output.status.success() || !library.is_file() {
        let mut text = String::from_utf8_lossy(&output.stdout).into_owned();
        text.push_str(&String::from_utf8_lossy(&output.stderr));
        let lines: Vec<&str> = text.lines().collect();
        let tail = lines[lines.len().saturating_sub(ERROR_TAIL_LINES)..].join("\n");
        return Err(EngineError::Build(format!(
            "`{VERILATOR}` failed ({}) in {}:\n{tail}",
            output.status,
            work.display()
        )));
    }
    Ok(library)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_key_changes_with_any_part_and_with_how_they_are_split() {
        let base = fnv1a(&["a", "bc"]);
        assert_eq!(base, fnv1a(&["a", "bc"]));
        assert_ne!(base, fnv1a(&["ab", "c"]));
        assert_ne!(base, fnv1a(&["a", "bd"]));
        assert_ne!(base, fnv1a(&["a", "bc", ""]));
    }

    #[test]
    fn the_cache_is_in_the_target_directory_of_a_cargo_build() {
        let dir = cache_dir();
        assert!(dir.ends_with(CACHE_SUBDIR), "{}", dir.display());
        assert!(
            dir.parent().unwrap().join("CACHEDIR.TAG").is_file(),
            "{}",
            dir.display()
        );
    }
}
