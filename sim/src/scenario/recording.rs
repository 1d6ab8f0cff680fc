//! A recorded bus on the simulated one (`[bus] recording`, `cansim replay`): the level changes of
//! one signal of a capture drive a line of the wired-AND bus, so the scenario's controllers
//! receive, and may answer, what was recorded.
//!
//! Captures are VCD files (any timescale, the signal by full or trailing name, as `cansim decode`)
//! or sigrok session files (`.sr`, turned into VCD by `sigrok-cli -O vcd`). The file is read as the
//! run goes, a little ahead of it, so a capture of any length takes no more memory than its header.
//! Long recessive stretches may be shortened (`idle_keep_fs`): a controller that has seen the bus
//! idle for that long behaves the same whatever comes after, and simulating the rest would only
//! cost time. [`RecordingFeed::recorded_time`] maps simulated times back to the capture's.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::decode::vcd_reader::SignalReader;
use crate::engine::bus::Drive;
use crate::engine::Engine;
use golden::frame::RECESSIVE;

use super::ScenarioError;

/// A capture that drives the bus.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// The capture file (`.vcd` or `.sr`).
    pub path: PathBuf,
    /// The bus signal in it.
    pub signal: String,
    /// Recessive stretches longer than this are shortened to it; `None`: played as recorded.
    pub idle_keep_fs: Option<u64>,
    /// The run ends this long after the capture's last change; `None`: at the scenario's end.
    pub end_after_fs: Option<u64>,
}

/// A capture as a VCD file: the file itself, or a sigrok session converted by `sigrok-cli -O vcd`
/// into a temporary VCD, removed when this is dropped.
pub struct CaptureVcd {
    path: PathBuf,
    temporary: bool,
}

impl CaptureVcd {
    /// The VCD of the capture at `path` (`.sr`: a sigrok session).
    pub fn new(path: &Path) -> Result<CaptureVcd, String> {
        let is_session = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("sr"));
        if !is_session {
            return Ok(CaptureVcd {
                path: path.to_path_buf(),
                temporary: false,
            });
        }
        let vcd = std::env::temp_dir().join(format!(
            "cansim-capture-{}-{}.vcd",
            std::process::id(),
            path.file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("session")
        ));
        let converted = Command::new("sigrok-cli")
            .arg("-i")
            .arg(path)
            .args(["-O", "vcd", "-o"])
            .arg(&vcd)
            .output()
            .map_err(|e| {
                format!(
                    "{}: reading a sigrok session needs sigrok-cli (Debian: apt-get install \
                     sigrok-cli): {e}",
                    path.display()
                )
            })?;
        let capture = CaptureVcd {
            path: vcd,
            temporary: true,
        };
        if !converted.status.success() {
            return Err(format!(
                "{}: sigrok-cli could not read it: {}",
                path.display(),
                String::from_utf8_lossy(&converted.stderr).trim()
            ));
        }
        Ok(capture)
    }

    /// The VCD file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for CaptureVcd {
    fn drop(&mut self) {
        if self.temporary {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Opens `path` at `signal`: a VCD directly, a sigrok session through `sigrok-cli -O vcd`.
pub fn open_capture(path: &Path, signal: &str) -> Result<SignalReader, String> {
    let vcd = CaptureVcd::new(path)?;
    // An open reader keeps a temporary file's contents after its name is gone.
    SignalReader::open(vcd.path(), signal).map_err(|e| e.to_string())
}

/// Feeds a capture to a recorded line of the engine, ahead of the run.
pub struct RecordingFeed {
    reader: SignalReader,
    line: usize,
    idle_keep_fs: Option<u64>,
    /// The level last given to the line.
    level: bool,
    /// The next change, in capture time, read but not given yet.
    next: Option<(u64, bool)>,
    /// Capture and simulated time of the last change given.
    last_change: (u64, u64),
    /// Simulated minus capture time, from each simulated time on: later when the capture begins
    /// before the controllers are up, earlier at every shortened idle stretch.
    shifts: Vec<(u64, i64)>,
    /// The capture has no more changes.
    exhausted: bool,
}

impl RecordingFeed {
    /// Feeds `recording` to a new line of `engine`.
    pub fn new(recording: &Recording, engine: &mut Engine) -> Result<RecordingFeed, ScenarioError> {
        let reader =
            open_capture(&recording.path, &recording.signal).map_err(ScenarioError::new)?;
        Ok(RecordingFeed {
            reader,
            line: engine.add_recorded_line(0),
            idle_keep_fs: recording.idle_keep_fs,
            level: RECESSIVE,
            next: None,
            last_change: (0, 0),
            shifts: vec![(0, 0)],
            exhausted: false,
        })
    }

    fn shift(&self) -> i64 {
        self.shifts.last().map_or(0, |&(_, shift)| shift)
    }

    /// Gives the engine every change of the capture before simulated time `until_fs`.
    pub fn feed(&mut self, engine: &mut Engine, until_fs: u64) -> Result<(), ScenarioError> {
        loop {
            let Some((t_capture, level)) = self.peek()? else {
                return Ok(());
            };
            if level == self.level {
                self.next = None;
                continue;
            }
            let (last_capture, last_sim) = self.last_change;
            let mut t_sim = t_capture.saturating_add_signed(self.shift());
            let keep = self
                .idle_keep_fs
                .filter(|&keep| self.level == RECESSIVE && t_capture - last_capture > keep);
            if let Some(keep) = keep {
                t_sim = t_sim.min(last_sim + keep);
            }
            // Never into what was already simulated (the controllers come up after time 0).
            t_sim = t_sim.max(engine.now() + 1);
            if t_sim >= until_fs {
                return Ok(());
            }
            let shift = t_sim as i64 - t_capture as i64;
            if shift != self.shift() {
                self.shifts.push((t_sim, shift));
            }
            engine.record_drive(self.line, t_sim, Drive::from_level(level));
            (self.level, self.last_change, self.next) = (level, (t_capture, t_sim), None);
        }
    }

    /// The next change of the capture (read once, kept until given).
    fn peek(&mut self) -> Result<Option<(u64, bool)>, ScenarioError> {
        if self.next.is_none() && !self.exhausted {
            self.next = self
                .reader
                .next_value()
                .map_err(|e| ScenarioError::new(e.to_string()))?;
            self.exhausted = self.next.is_none();
        }
        Ok(self.next)
    }

    /// Once the capture is exhausted: the simulated time of its last change.
    pub fn ended_at(&self) -> Option<u64> {
        self.exhausted.then_some(self.last_change.1)
    }

    /// Simulated minus capture time, from each simulated time on.
    pub fn shifts(&self) -> &[(u64, i64)] {
        &self.shifts
    }

    /// The signal's full name in the capture.
    pub fn signal(&self) -> &str {
        &self.reader.name
    }

    /// `x` and `z` values in the capture (taken as recessive).
    pub fn undefined_values(&self) -> u64 {
        self.reader.undefined_values
    }
}
