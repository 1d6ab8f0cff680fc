//! A progress line for long runs: how much of the simulated time is done, the real time it took,
//! and the speed. The caller shows it only on a terminal (not when stderr is piped, nor with
//! `--quiet`).

use std::time::{Duration, Instant};

use crate::engine::time::FS_PER_MS;

/// Width of the bar, in characters.
const BAR_WIDTH: usize = 24;
/// Time between two redraws.
const REDRAW_INTERVAL: Duration = Duration::from_millis(200);

/// Decides when to redraw and what.
pub struct Progress {
    started: Instant,
    last_drawn: Option<Instant>,
}

impl Default for Progress {
    fn default() -> Self {
        Progress::new()
    }
}

impl Progress {
    /// A progress display starting now.
    pub fn new() -> Progress {
        Progress {
            started: Instant::now(),
            last_drawn: None,
        }
    }

    /// The line to draw for `simulated_fs` of `total_fs`, if it is time to redraw (at most every
    /// 200 ms, and not within the first 200 ms: short runs show nothing).
    pub fn update(&mut self, simulated_fs: u64, total_fs: u64) -> Option<String> {
        let now = Instant::now();
        let since = self.last_drawn.unwrap_or(self.started);
        if now.duration_since(since) < REDRAW_INTERVAL {
            return None;
        }
        self.last_drawn = Some(now);
        Some(line(
            simulated_fs,
            total_fs,
            now.duration_since(self.started),
        ))
    }

    /// Whether a line was drawn (and must be cleared at the end).
    pub fn drawn(&self) -> bool {
        self.last_drawn.is_some()
    }
}

/// `[#######-----------------]  31 %  1.550 of 5.000 ms simulated, 2.1 s real, 0.74 ms/s`.
pub fn line(simulated_fs: u64, total_fs: u64, real: Duration) -> String {
    let fraction = (simulated_fs as f64 / total_fs.max(1) as f64).clamp(0.0, 1.0);
    let filled = (fraction * BAR_WIDTH as f64).round() as usize;
    let ms = |fs: u64| fs as f64 / FS_PER_MS as f64;
    let seconds = real.as_secs_f64();
    let speed = if seconds > 0.0 {
        format!("{:.2} ms/s", ms(simulated_fs) / seconds)
    } else {
        "-".to_string()
    };
    format!(
        "[{}{}] {:3.0} %  {:.3} of {:.3} ms simulated, {seconds:.1} s real, {speed}",
        "#".repeat(filled),
        "-".repeat(BAR_WIDTH - filled),
        fraction * 100.0,
        ms(simulated_fs),
        ms(total_fs),
    )
}

/// The most memory this process has had resident so far (Linux's `VmHWM`), in bytes; `None` where
/// the system does not tell.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_shows_the_fraction_times_and_speed() {
        let text = line(
            FS_PER_MS * 5 / 4,
            FS_PER_MS * 5,
            Duration::from_millis(2500),
        );
        assert_eq!(
            text,
            "[######------------------]  25 %  1.250 of 5.000 ms simulated, 2.5 s real, 0.50 ms/s"
        );
    }

    #[test]
    fn nothing_is_drawn_in_the_first_moments() {
        let mut progress = Progress::new();
        assert_eq!(progress.update(1, 2), None);
        assert!(!progress.drawn());
    }
}
