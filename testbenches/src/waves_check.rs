//! The comparison behind `waves-check` and `make waves-compare`: our bus decoder against sigrok's CAN
//! decoder on every VCD under the given files and directories, in parallel; prints one line per file
//! with the exclusions it applied (verbose: each one, with its time and frame) and every
//! disagreement, then the totals. See `crate::agreement` for the rule.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crate::agreement::{check_vcd, Agreement};

/// The VCD files under `paths` (a file as given, a directory's `*.vcd`), sorted.
fn vcd_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let mut files = Vec::new();
    for path in paths {
        if path.is_dir() {
            let entries =
                std::fs::read_dir(path).map_err(|e| format!("{}: {e}", path.display()))?;
            for entry in entries {
                let file = entry
                    .map_err(|e| format!("{}: {e}", path.display()))?
                    .path();
                if file.extension().is_some_and(|x| x == "vcd") {
                    files.push(file);
                }
            }
        } else if path.exists() {
            files.push(path.clone());
        } else {
            return Err(format!("{}: no such file or directory", path.display()));
        }
    }
    files.sort();
    Ok(files)
}

/// Checks every VCD under `paths` (a file as given, a directory's `*.vcd`); `Ok(true)` when every
/// file agrees, `Ok(false)` on a disagreement or an unreadable file, `Err` when sigrok-cli is
/// missing or there is no file.
pub fn check_paths(paths: &[PathBuf], verbose: bool) -> Result<bool, String> {
    Command::new("sigrok-cli")
        .arg("--version")
        .output()
        .map_err(|e| format!("cannot run sigrok-cli ({e}): install it with `make tools`"))?;
    let files = vcd_files(paths)?;
    if files.is_empty() {
        return Err(format!(
            "no VCD files in {} (write them with CANSIM_WAVES=1 cargo test)",
            paths
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let started = Instant::now();
    let results = check_all(&files);
    let mut agreed = 0;
    let mut failed = 0;
    for (file, result) in files.iter().zip(&results) {
        match result {
            Ok(agreement) => {
                println!("{agreement}");
                if verbose {
                    print!("{}", agreement.details());
                }
                agreed += agreement.agreed;
                failed += usize::from(!agreement.agrees());
            }
            Err(message) => {
                println!("{}: ERROR {message}", file.display());
                failed += 1;
            }
        }
    }
    println!(
        "{} files, {agreed} frames agree, {failed} files with disagreements or errors ({:.1} s)",
        files.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(failed == 0)
}

/// Checks every file on every core; results in the order of `files`.
fn check_all(files: &[PathBuf]) -> Vec<Result<Agreement, String>> {
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<Agreement, String>>>> =
        Mutex::new(files.iter().map(|_| None).collect());
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| loop {
                let index = next.fetch_add(1, Ordering::Relaxed);
                let Some(file) = files.get(index) else { break };
                let result = check_one(file);
                results.lock().expect("results lock")[index] = Some(result);
            });
        }
    });
    results
        .into_inner()
        .expect("results lock")
        .into_iter()
        .map(|r| r.expect("every file checked"))
        .collect()
}

/// One file; a panic of the sigrok runner (sigrok-cli failing on the file) becomes an error.
fn check_one(file: &Path) -> Result<Agreement, String> {
    std::panic::catch_unwind(|| check_vcd(file)).unwrap_or_else(|panic| {
        let message = panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "sigrok check panicked".into());
        Err(message)
    })
}
