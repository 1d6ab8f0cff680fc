//! The wired-AND CAN bus: every device drives one line through its own propagation delay; dominant (0)
//! wins over recessive (1), and a lower tester may force the bus recessive to model a disturbance.
//!
//! A fault on the bus itself ([`BusFault`]: forced to a level, or inverted, for a time window) changes
//! the level every device sees, wherever it sits, as a disturbance on the wires would.
//!
//! Each line keeps the history of its drive changes for as long as the longest delay needs it (or
//! for the whole run when [`Bus::keep_history`] is on), so the level seen at any time is exact: a change
//! made at time t is visible strictly after t, which makes simultaneous clock edges order-independent.

use std::collections::VecDeque;

use golden::frame::{DOMINANT, RECESSIVE};

/// What a device puts on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Drive {
    /// Released: the line is recessive unless someone drives it dominant.
    Recessive,
    /// Driven dominant.
    Dominant,
    /// Forced recessive whatever the others drive (a disturbance injected by the lower tester).
    ForceRecessive,
}

impl Drive {
    /// The drive of a transmitter output at `level` (dominant = false).
    pub fn from_level(level: bool) -> Drive {
        if level == DOMINANT {
            Drive::Dominant
        } else {
            Drive::Recessive
        }
    }

    /// The level this drive would put on an otherwise idle bus.
    pub fn level(self) -> bool {
        match self {
            Drive::Dominant => DOMINANT,
            Drive::Recessive | Drive::ForceRecessive => RECESSIVE,
        }
    }
}

/// A disturbance of the bus itself, seen by every device through its own delay.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusFault {
    /// The bus is at this level whatever the devices drive (`false` = dominant).
    Force(bool),
    /// The bus is at the inverse of the wired-AND of the drives.
    Invert,
}

/// A [`BusFault`] that holds for levels just before `t` with `from_fs < t <= to_fs`: it begins to be
/// seen strictly after `from_fs`, like a drive change.
#[derive(Clone, Copy, Debug)]
struct FaultWindow {
    from_fs: u64,
    to_fs: u64,
    fault: BusFault,
}

struct Line {
    delay_fs: u64,
    /// Drive before the first retained change.
    initial: Drive,
    /// (time, new drive), oldest first.
    changes: VecDeque<(u64, Drive)>,
}

impl Line {
    fn drive_before(&self, t: u64) -> Drive {
        self.changes
            .iter()
            .rev()
            .find(|(at, _)| *at < t)
            .map_or(self.initial, |(_, drive)| *drive)
    }

    fn current(&self) -> Drive {
        self.changes
            .back()
            .map_or(self.initial, |(_, drive)| *drive)
    }
}

/// The bus: one line per device.
#[derive(Default)]
pub struct Bus {
    lines: Vec<Line>,
    max_delay_fs: u64,
    keep_history: bool,
    faults: Vec<FaultWindow>,
    /// Lines whose latest drive is dominant, and forced recessive.
    dominant_lines: usize,
    forcing_lines: usize,
    /// The time of the latest drive change of any line.
    last_change_fs: Option<u64>,
}

impl Bus {
    /// An empty bus.
    pub fn new() -> Bus {
        Bus::default()
    }

    /// Adds a line whose drive reaches the bus `delay_fs` after it changes, and whose device sees the
    /// bus `delay_fs` late. Returns the line number.
    pub fn add_line(&mut self, delay_fs: u64) -> usize {
        self.lines.push(Line {
            delay_fs,
            initial: Drive::Recessive,
            changes: VecDeque::new(),
        });
        self.max_delay_fs = self.max_delay_fs.max(delay_fs);
        self.lines.len() - 1
    }

    /// Keep every change (for queries about the past, e.g. what a node sent in a given bit).
    pub fn keep_history(&mut self, keep: bool) {
        self.keep_history = keep;
    }

    /// Number of lines.
    pub fn lines(&self) -> usize {
        self.lines.len()
    }

    /// Propagation delay of `line`.
    pub fn delay_fs(&self, line: usize) -> u64 {
        self.lines[line].delay_fs
    }

    /// The drive of `line` changes to `drive` at time `t` (times never decrease per line).
    pub fn set_drive(&mut self, line: usize, t: u64, drive: Drive) {
        let l = &mut self.lines[line];
        let old = l.current();
        if old == drive {
            return;
        }
        l.changes.push_back((t, drive));
        if let Some(lines) = self.lines_driving(old) {
            *lines -= 1;
        }
        if let Some(lines) = self.lines_driving(drive) {
            *lines += 1;
        }
        self.last_change_fs = self.last_change_fs.max(Some(t));
    }

    /// The count of lines whose latest drive is `drive` (none kept for recessive).
    fn lines_driving(&mut self, drive: Drive) -> Option<&mut usize> {
        match drive {
            Drive::Dominant => Some(&mut self.dominant_lines),
            Drive::ForceRecessive => Some(&mut self.forcing_lines),
            Drive::Recessive => None,
        }
    }

    /// Every retained change of `line`'s drive, as (time, new drive), oldest first (all of them
    /// with [`Bus::keep_history`]).
    pub fn drive_changes(&self, line: usize) -> impl Iterator<Item = (u64, Drive)> + '_ {
        self.lines[line].changes.iter().copied()
    }

    /// What `line` drove just before `t` (at the device, before the delay).
    pub fn drive_before(&self, line: usize, t: u64) -> Drive {
        self.lines[line].drive_before(t)
    }

    /// Adds a fault of the bus from `from_fs` to `to_fs` (the first window that covers a time wins).
    pub fn add_fault(&mut self, from_fs: u64, to_fs: u64, fault: BusFault) {
        self.faults.push(FaultWindow {
            from_fs,
            to_fs,
            fault,
        });
    }

    /// The bus level just before `t`, at the point where all delays are counted from.
    pub fn level_before(&self, t: u64) -> bool {
        let natural = self.driven_level_before(t);
        match self
            .faults
            .iter()
            .find(|w| w.from_fs < t && t <= w.to_fs)
            .map(|w| w.fault)
        {
            Some(BusFault::Force(level)) => level,
            Some(BusFault::Invert) => !natural,
            None => natural,
        }
    }

    /// The wired-AND of the drives just before `t`, without bus faults.
    fn driven_level_before(&self, t: u64) -> bool {
        // Without delays, once every change is older than `t` the latest drives decide: counted
        // as they change instead of looking at every line (the engine asks at every clock edge).
        if self.max_delay_fs == 0 && self.last_change_fs.is_none_or(|at| at < t) {
            return if self.forcing_lines == 0 && self.dominant_lines > 0 {
                DOMINANT
            } else {
                RECESSIVE
            };
        }
        let mut dominant = false;
        for l in &self.lines {
            match l.drive_before(t.saturating_sub(l.delay_fs)) {
                Drive::ForceRecessive => return RECESSIVE,
                Drive::Dominant => dominant = true,
                Drive::Recessive => {}
            }
        }
        if dominant {
            DOMINANT
        } else {
            RECESSIVE
        }
    }

    /// The time from which every line sees the level the drives of now give (every change has
    /// passed both delays): later levels change only with a later drive change or a fault.
    pub fn settled_from(&self) -> u64 {
        self.last_change_fs
            .map_or(0, |at| at.saturating_add(2 * self.max_delay_fs + 1))
    }

    /// The first start or end of a fault window after `t` (`u64::MAX` if none).
    pub fn next_fault_boundary(&self, t: u64) -> u64 {
        self.faults
            .iter()
            .flat_map(|w| [w.from_fs, w.to_fs])
            .filter(|&b| b > t)
            .min()
            .unwrap_or(u64::MAX)
    }

    /// The level the device on `line` sees just before `t`.
    pub fn level_seen_by(&self, line: usize, t: u64) -> bool {
        self.level_before(t.saturating_sub(self.lines[line].delay_fs))
    }

    /// Forgets changes that no query at time ≥ `now` can need any more.
    pub fn prune(&mut self, now: u64) {
        if self.keep_history {
            return;
        }
        let horizon = now.saturating_sub(2 * self.max_delay_fs + 1);
        self.faults.retain(|w| w.to_fs >= horizon);
        for l in &mut self.lines {
            // Queries at or after the horizon need only the last change before it.
            while let Some(&(at, drive)) = l.changes.front() {
                if at >= horizon {
                    break;
                }
                l.initial = drive;
                l.changes.pop_front();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dominant_wins_and_force_recessive_overrides() {
        let mut bus = Bus::new();
        let a = bus.add_line(0);
        let b = bus.add_line(0);
        assert_eq!(bus.level_before(10), RECESSIVE);
        bus.set_drive(a, 10, Drive::Dominant);
        assert_eq!(
            bus.level_before(10),
            RECESSIVE,
            "a change is visible strictly after its time"
        );
        assert_eq!(bus.level_before(11), DOMINANT);
        bus.set_drive(b, 20, Drive::ForceRecessive);
        assert_eq!(bus.level_before(21), RECESSIVE);
    }

    #[test]
    fn a_bus_fault_forces_or_inverts_the_level_in_its_window_only() {
        let mut bus = Bus::new();
        let a = bus.add_line(0);
        bus.set_drive(a, 100, Drive::Dominant);
        bus.add_fault(200, 300, BusFault::Force(RECESSIVE));
        bus.add_fault(400, 500, BusFault::Invert);
        bus.add_fault(600, 700, BusFault::Force(DOMINANT));
        bus.set_drive(a, 550, Drive::Recessive);
        let levels: Vec<bool> = [150, 200, 201, 300, 301, 401, 500, 501, 601, 701]
            .iter()
            .map(|&t| bus.level_before(t))
            .collect();
        assert_eq!(
            levels,
            [
                DOMINANT, DOMINANT, RECESSIVE, RECESSIVE, DOMINANT, RECESSIVE, RECESSIVE, DOMINANT,
                DOMINANT, RECESSIVE
            ]
        );
    }

    /// Without delays the level comes from counts of the latest drives once every change is in
    /// the past, and from the history before that: both give the scan's answer.
    #[test]
    fn the_counted_level_without_delays_is_the_level_of_the_history() {
        let mut bus = Bus::new();
        let lines: Vec<usize> = (0..4).map(|_| bus.add_line(0)).collect();
        let mut seed = 7u64;
        for step in 0..2_000u64 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let t = step / 3 * 10;
            let drive = match seed >> 40 & 7 {
                0 => Drive::ForceRecessive,
                1..=3 => Drive::Dominant,
                _ => Drive::Recessive,
            };
            bus.set_drive(lines[(seed >> 50) as usize % 4], t, drive);
            for query in [t, t + 1] {
                let scanned = {
                    let mut dominant = false;
                    let mut forced = false;
                    for l in &bus.lines {
                        match l.drive_before(query) {
                            Drive::ForceRecessive => forced = true,
                            Drive::Dominant => dominant = true,
                            Drive::Recessive => {}
                        }
                    }
                    dominant && !forced
                };
                assert_eq!(bus.level_before(query) == DOMINANT, scanned, "step {step}");
            }
        }
    }

    #[test]
    fn delays_apply_on_the_way_out_and_in() {
        let mut bus = Bus::new();
        let a = bus.add_line(100);
        let b = bus.add_line(50);
        bus.set_drive(a, 1000, Drive::Dominant);
        assert_eq!(bus.level_before(1100), RECESSIVE);
        assert_eq!(bus.level_before(1101), DOMINANT);
        assert_eq!(bus.level_seen_by(b, 1150), RECESSIVE);
        assert_eq!(bus.level_seen_by(b, 1151), DOMINANT);
        assert_eq!(bus.level_seen_by(a, 1201), DOMINANT);
    }

    #[test]
    fn pruning_keeps_what_delayed_queries_need() {
        let mut bus = Bus::new();
        let a = bus.add_line(100);
        for i in 0..100u64 {
            let drive = if i % 2 == 0 {
                Drive::Dominant
            } else {
                Drive::Recessive
            };
            bus.set_drive(a, i * 10, drive);
        }
        bus.prune(990);
        assert_eq!(
            bus.level_seen_by(a, 1081),
            DOMINANT,
            "the change at 880 is still known"
        );
        assert_eq!(bus.level_seen_by(a, 1091), RECESSIVE);
        assert!(bus.lines[a].changes.len() < 30);
    }
}
