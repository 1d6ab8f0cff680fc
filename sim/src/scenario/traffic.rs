//! What the nodes send and when: single frames at given times (from the scenario or a replayed
//! log) and periodic messages. A [`Schedule`] releases them in time order; the runner hands a
//! released frame to the node's driver as soon as the driver takes one (one frame in flight at a
//! time, as the kernel's queue does).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::engine::rng::Rng;
use golden::frame::Frame;

/// How a periodic message's payload changes from one message to the next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pattern {
    /// Always the template's data.
    Fixed,
    /// The template's data with the first byte replaced by the message number (0, 1, 2, …,
    /// wrapping at 256).
    Counter,
    /// As many random bytes as the template has (seeded by the scenario's seed).
    Random,
}

/// One frame handed to a node's driver at a given time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Once {
    /// Index of the sending node.
    pub node: usize,
    /// When the frame is released.
    pub at_fs: u64,
    /// The frame.
    pub frame: Frame,
}

/// A message sent every `period_fs` from `first_fs` on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Periodic {
    /// Index of the sending node.
    pub node: usize,
    /// Identifier, DLC and (for [`Pattern::Fixed`] and [`Pattern::Counter`]) data.
    pub template: Frame,
    /// Release time of the first message.
    pub first_fs: u64,
    /// Time between two releases (> 0).
    pub period_fs: u64,
    /// Number of messages; `None`: until the run ends.
    pub count: Option<u64>,
    /// How the payload changes.
    pub pattern: Pattern,
}

impl Periodic {
    /// Release time of message `k` (0-based).
    pub fn time(&self, k: u64) -> u64 {
        self.first_fs + k * self.period_fs
    }

    /// Message `k` (0-based); `stream` and `seed` choose the random payloads.
    pub fn frame(&self, k: u64, stream: u64, seed: u64) -> Frame {
        let mut data = self.template.data_bytes().to_vec();
        match self.pattern {
            Pattern::Fixed => return self.template,
            Pattern::Counter => data[0] = k as u8,
            Pattern::Random => {
                let mut rng = Rng::for_case(seed ^ stream.rotate_left(32), k);
                data.iter_mut().for_each(|b| *b = rng.next_u64() as u8);
            }
        }
        Frame::data_with_dlc(self.template.id(), self.template.dlc(), &data)
            .expect("same identifier, DLC and length as the template")
    }
}

/// Everything the nodes send.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    /// Single frames (scenario frames and replayed log lines).
    pub once: Vec<Once>,
    /// Periodic messages.
    pub periodic: Vec<Periodic>,
}

/// Where a release comes from: a single frame, or message `k` of a periodic one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Source {
    Once(usize),
    Periodic { index: usize, k: u64 },
}

/// The releases still to come, earliest first (ties in file order: single frames, then periodic
/// messages).
pub struct Schedule<'t> {
    traffic: &'t Traffic,
    seed: u64,
    pending: BinaryHeap<Reverse<(u64, Source)>>,
}

impl<'t> Schedule<'t> {
    /// The schedule of `traffic`; `seed` for random payloads.
    pub fn new(traffic: &'t Traffic, seed: u64) -> Schedule<'t> {
        let mut pending = BinaryHeap::new();
        for (i, once) in traffic.once.iter().enumerate() {
            pending.push(Reverse((once.at_fs, Source::Once(i))));
        }
        for (index, periodic) in traffic.periodic.iter().enumerate() {
            if periodic.count != Some(0) {
                pending.push(Reverse((
                    periodic.first_fs,
                    Source::Periodic { index, k: 0 },
                )));
            }
        }
        Schedule {
            traffic,
            seed,
            pending,
        }
    }

    /// When the next release is due.
    pub fn next_time(&self) -> Option<u64> {
        self.pending.peek().map(|Reverse((t, _))| *t)
    }

    /// Every release due at or before `now` whose node `has_room` (asked once per frame), in
    /// order: (node, frame). A release whose node has no room waits, and its periodic message's
    /// later releases behind it, as a sender blocked on a full transmit queue.
    pub fn release(
        &mut self,
        now: u64,
        mut has_room: impl FnMut(usize) -> bool,
    ) -> Vec<(usize, Frame)> {
        let mut released = Vec::new();
        let mut waiting = Vec::new();
        while let Some(&Reverse((t, source))) = self.pending.peek() {
            if t > now {
                break;
            }
            self.pending.pop();
            if !has_room(self.node_of(source)) {
                waiting.push(Reverse((t, source)));
                continue;
            }
            match source {
                Source::Once(i) => {
                    let once = &self.traffic.once[i];
                    released.push((once.node, once.frame));
                }
                Source::Periodic { index, k } => {
                    let periodic = &self.traffic.periodic[index];
                    released.push((periodic.node, periodic.frame(k, index as u64, self.seed)));
                    if periodic.count.is_none_or(|n| k + 1 < n) {
                        let next = Source::Periodic { index, k: k + 1 };
                        self.pending.push(Reverse((periodic.time(k + 1), next)));
                    }
                }
            }
        }
        self.pending.extend(waiting);
        released
    }

    fn node_of(&self, source: Source) -> usize {
        match source {
            Source::Once(i) => self.traffic.once[i].node,
            Source::Periodic { index, .. } => self.traffic.periodic[index].node,
        }
    }

    /// When the next release is due after `now` (releases already due wait for room).
    pub fn next_time_after(&self, now: u64) -> Option<u64> {
        self.pending
            .iter()
            .map(|Reverse((t, _))| *t)
            .filter(|&t| t > now)
            .min()
    }

    /// Per node (of `nodes`), the releases due at or before `end` that were never handed out.
    pub fn overdue(&self, end: u64, nodes: usize) -> Vec<u64> {
        let mut counts = vec![0; nodes];
        for &Reverse((t, source)) in &self.pending {
            if t > end {
                continue;
            }
            match source {
                Source::Once(i) => counts[self.traffic.once[i].node] += 1,
                Source::Periodic { index, k } => {
                    let periodic = &self.traffic.periodic[index];
                    let due = (end - periodic.first_fs) / periodic.period_fs + 1;
                    let due = periodic.count.map_or(due, |n| due.min(n));
                    counts[periodic.node] += due.saturating_sub(k);
                }
            }
        }
        counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use golden::frame::Id;

    fn frame(id: u16, data: &[u8]) -> Frame {
        Frame::data(Id::standard(id).unwrap(), data).unwrap()
    }

    #[test]
    fn releases_come_in_time_order_and_periodic_ones_stop_at_their_count() {
        let traffic = Traffic {
            once: vec![
                Once {
                    node: 1,
                    at_fs: 250,
                    frame: frame(0x10, &[1]),
                },
                Once {
                    node: 0,
                    at_fs: 100,
                    frame: frame(0x11, &[]),
                },
            ],
            periodic: vec![Periodic {
                node: 2,
                template: frame(0x20, &[0xAA, 0xBB]),
                first_fs: 100,
                period_fs: 100,
                count: Some(3),
                pattern: Pattern::Counter,
            }],
        };
        let mut schedule = Schedule::new(&traffic, 1);
        assert_eq!(schedule.next_time(), Some(100));
        let all = |_| true;
        let text = |r: Vec<(usize, Frame)>| -> Vec<String> {
            r.iter().map(|(n, f)| format!("{n}:{f}")).collect()
        };
        assert_eq!(text(schedule.release(99, all)), Vec::<String>::new());
        assert_eq!(text(schedule.release(100, all)), ["0:011#", "2:020#00BB"]);
        assert_eq!(
            text(schedule.release(300, all)),
            ["2:020#01BB", "1:010#01", "2:020#02BB"]
        );
        assert_eq!(schedule.next_time(), None);
    }

    #[test]
    fn random_payloads_keep_the_length_and_differ_between_messages() {
        let periodic = Periodic {
            node: 0,
            template: frame(0x30, &[0; 8]),
            first_fs: 0,
            period_fs: 1,
            count: None,
            pattern: Pattern::Random,
        };
        let (a, b) = (periodic.frame(0, 0, 7), periodic.frame(1, 0, 7));
        assert_eq!((a.dlc(), b.dlc()), (8, 8));
        assert_ne!(a, b);
        assert_eq!(a, periodic.frame(0, 0, 7), "the seed decides");
        assert_ne!(a, periodic.frame(0, 0, 8));
    }

    #[test]
    fn a_release_without_room_waits_and_what_never_went_out_is_overdue() {
        let traffic = Traffic {
            once: vec![Once {
                node: 0,
                at_fs: 50,
                frame: frame(0x11, &[]),
            }],
            periodic: vec![Periodic {
                node: 1,
                template: frame(0x20, &[0]),
                first_fs: 0,
                period_fs: 100,
                count: Some(10),
                pattern: Pattern::Counter,
            }],
        };
        let mut schedule = Schedule::new(&traffic, 1);
        let text = |r: Vec<(usize, Frame)>| -> Vec<String> {
            r.iter().map(|(n, f)| format!("{n}:{f}")).collect()
        };
        // Node 1 has room for one frame: message 0 goes, message 1 (due at 100) waits.
        let mut room = 1;
        let released = schedule.release(150, |n| n == 0 || std::mem::replace(&mut room, 0) > 0);
        assert_eq!(text(released), ["1:020#00", "0:011#"]);
        assert_eq!(
            schedule.next_time_after(150),
            None,
            "message 1 waits: nothing later is due"
        );
        // By 450, messages 1 to 4 were due and never handed out.
        assert_eq!(schedule.overdue(450, 2), [0, 4]);
        // With room again, the waiting message goes first, in order.
        assert_eq!(
            text(schedule.release(250, |_| true)),
            ["1:020#01", "1:020#02"]
        );
        assert_eq!(schedule.next_time_after(250), Some(300));
    }
}
