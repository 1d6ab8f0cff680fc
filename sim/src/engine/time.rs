//! Simulated time and clocks. Time is counted in femtoseconds (`u64`: about 5 hours of simulated time),
//! fine enough for clock periods with ppm offsets.

/// Femtoseconds per nanosecond.
pub const FS_PER_NS: u64 = 1_000_000;
/// Femtoseconds per microsecond.
pub const FS_PER_US: u64 = 1_000_000_000;
/// Femtoseconds per millisecond.
pub const FS_PER_MS: u64 = 1_000_000_000_000;
/// Femtoseconds per second.
pub const FS_PER_S: u64 = 1_000_000_000_000_000;

/// A time as candump and socketcand write it: `SECONDS.MICROS` (`12.000345`).
pub fn seconds_micros(t_fs: u64) -> String {
    format!("{}.{:06}", t_fs / FS_PER_S, t_fs % FS_PER_S / FS_PER_US)
}

/// A free-running clock: rising edges at `phase + n·period` for n = 0, 1, 2, …
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClockSpec {
    period_fs: u64,
    phase_fs: u64,
}

impl ClockSpec {
    /// A clock of `hz` hertz, first rising edge at time 0.
    pub fn from_hz(hz: f64) -> ClockSpec {
        ClockSpec::with_ppm(hz, 0.0)
    }

    /// A clock of nominal frequency `hz` that runs `ppm` parts per million fast (negative: slow).
    pub fn with_ppm(hz: f64, ppm: f64) -> ClockSpec {
        assert!(
            hz > 0.0 && hz.is_finite(),
            "clock frequency must be positive, got {hz}"
        );
        let actual = hz * (1.0 + ppm * 1e-6);
        assert!(actual > 0.0, "clock offset {ppm} ppm stops the clock");
        ClockSpec {
            period_fs: (FS_PER_S as f64 / actual).round() as u64,
            phase_fs: 0,
        }
    }

    /// The same clock with its first rising edge at `phase_fs`.
    pub fn with_phase(self, phase_fs: u64) -> ClockSpec {
        ClockSpec { phase_fs, ..self }
    }

    /// Clock period in femtoseconds.
    pub fn period_fs(&self) -> u64 {
        self.period_fs
    }

    /// Frequency in hertz.
    pub fn hz(&self) -> f64 {
        FS_PER_S as f64 / self.period_fs as f64
    }

    /// Time of rising edge number `n`.
    pub fn edge(&self, n: u64) -> u64 {
        self.phase_fs + n * self.period_fs
    }
}
