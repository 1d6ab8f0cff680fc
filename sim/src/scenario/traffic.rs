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

    /// Every release due at or before `now`, in order: (node, frame).
    pub fn release(&mut self, now: u64) -> Vec<(usize, Frame)> {
        let mut released = Vec::new();
        while let Some(&Reverse((t, source))) = self.pending.peek() {
            if t > now {
                break;
            }
            self.pending.pop();
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
        released
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
        let text = |r: Vec<(usize, Frame)>| -> Vec<String> {
            r.iter().map(|(n, f)| format!("{n}:{f}")).collect()
        };
        assert_eq!(text(schedule.release(99)), Vec::<String>::new());
        assert_eq!(text(schedule.release(100)), ["0:011#", "2:020#00BB"]);
        assert_eq!(
            text(schedule.release(300)),
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
}
