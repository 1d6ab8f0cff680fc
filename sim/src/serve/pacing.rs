//! How far the simulated bus of `cansim serve` may run: in real time, no further than the wall
//! clock since the start; otherwise as fast as it can, but no more than a slice of simulated time
//! ahead of the wall clock or of the last thing a client did, whichever is later. So a simulation
//! slower than real time never waits, a faster one does not race ahead of clients that only
//! listen (nor spin while nobody is connected), and what a client sends gets a slice of bus time
//! at once.

use std::time::{Duration, Instant};

use crate::engine::time::FS_PER_S;

/// How far behind the wall clock the bus may fall before the server says it cannot keep up.
pub const BEHIND_LIMIT: Duration = Duration::from_millis(100);

/// The pacing of one run.
pub struct Pace {
    realtime: bool,
    slice_fs: u64,
    /// Wall clock and simulated time at the start.
    started: Instant,
    start_fs: u64,
    /// Simulated time of the last client activity.
    active_fs: u64,
    /// Whether the bus fell behind the wall clock (said once).
    behind: bool,
}

impl Pace {
    /// Pacing from now, at simulated time `now_fs`.
    pub fn new(realtime: bool, slice_fs: u64, now_fs: u64) -> Pace {
        Pace {
            realtime,
            slice_fs,
            started: Instant::now(),
            start_fs: now_fs,
            active_fs: now_fs,
            behind: false,
        }
    }

    /// A client did something at simulated time `now_fs`.
    pub fn activity(&mut self, now_fs: u64) {
        self.active_fs = self.active_fs.max(now_fs);
    }

    /// The simulated time the bus may run to now: in real time, the wall clock's; otherwise a
    /// slice past the later of the wall clock's and the last client activity.
    pub fn allowed(&self) -> u64 {
        let wall_fs = self.start_fs + duration_fs(self.started.elapsed());
        if self.realtime {
            wall_fs
        } else {
            wall_fs.max(self.active_fs).saturating_add(self.slice_fs)
        }
    }

    /// In real time, at `now_fs`: the first time the bus is more than [`BEHIND_LIMIT`] behind the
    /// wall clock, a message saying so.
    pub fn check_behind(&mut self, now_fs: u64) -> Option<String> {
        if !self.realtime || self.behind {
            return None;
        }
        let wall_fs = duration_fs(self.started.elapsed());
        if self.start_fs + wall_fs < now_fs + duration_fs(BEHIND_LIMIT) {
            return None;
        }
        self.behind = true;
        Some(format!(
            "the simulation cannot keep up with real time (now at {:.3}x); it runs as fast as it \
             can",
            self.factor(now_fs)
        ))
    }

    /// Simulated time per wall-clock time since the start, at `now_fs`.
    pub fn factor(&self, now_fs: u64) -> f64 {
        let wall = self.started.elapsed().as_secs_f64().max(1e-9);
        (now_fs - self.start_fs) as f64 / FS_PER_S as f64 / wall
    }
}

/// A wall-clock duration in femtoseconds.
fn duration_fs(d: Duration) -> u64 {
    (d.as_nanos() * u128::from(FS_PER_S / 1_000_000_000)).min(u128::from(u64::MAX)) as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::time::FS_PER_MS;

    #[test]
    fn without_real_time_the_bus_runs_a_slice_past_the_wall_clock_or_the_last_activity() {
        let mut pace = Pace::new(false, 10 * FS_PER_MS, 5 * FS_PER_MS);
        let near =
            |allowed: u64, ms: u64| (ms * FS_PER_MS..(ms + 5) * FS_PER_MS).contains(&allowed);
        assert!(near(pace.allowed(), 15), "{}", pace.allowed());
        pace.activity(100 * FS_PER_MS);
        assert!(near(pace.allowed(), 110), "{}", pace.allowed());
        pace.activity(3 * FS_PER_MS);
        assert!(near(pace.allowed(), 110), "activity never moves it back");
        assert_eq!(pace.check_behind(0), None);
        std::thread::sleep(Duration::from_millis(120));
        assert!(
            pace.allowed() >= 130 * FS_PER_MS,
            "the wall clock moves it on"
        );
    }

    #[test]
    fn in_real_time_the_bus_follows_the_wall_clock_and_says_once_when_it_falls_behind() {
        let mut pace = Pace::new(true, 10 * FS_PER_MS, 0);
        let early = pace.allowed();
        assert!(early < 50 * FS_PER_MS, "{early}");
        std::thread::sleep(BEHIND_LIMIT + Duration::from_millis(20));
        assert!(pace.allowed() >= 120 * FS_PER_MS);
        assert!(pace.check_behind(0).unwrap().contains("cannot keep up"));
        assert_eq!(pace.check_behind(0), None, "said once");
    }
}
