//! A bus node made of the RTL bit timing logic ([`rtl::bit_timing::BitTiming`]) and a minimal bit-level
//! stand-in for the protocol engine, for testing synchronisation before the bit stream processor exists.
//!
//! The stand-in follows frames only as far as synchronisation needs: hard synchronisation while the bus
//! is idle, resynchronisation from a dominant sampled bit (start of frame) until 10 recessive bits were
//! sampled in a row (ACK delimiter, EOF and intermission of an acknowledged frame), and, when it has a bit
//! list to send, it starts while idle. Like the real protocol engine it *prepares* the next bit at the
//! process point and only *loads* it at a transmit point, so the extra transmit point of a hard
//! synchronisation (the transmitter's own SOF edge restarts the bit) sends the same bit again. A test
//! may instead pin the synchronisation mode.
//!
//! Stepping (see the project's RUST_HDL notes): inputs are applied with the clock low and settled, then
//! the rising edge is settled; the stand-in acts like flops clocked by the same edge, on the triggers of
//! the clock cycle that ended there. Every trigger is recorded as a [`BtlEvent`].

use std::any::Any;
use std::collections::VecDeque;

use rtl::bit_timing::{BitTiming, Segment, SyncMode};
use rust_hdl::prelude::*;

use crate::engine::bus::Drive;
use crate::engine::rtl_step::{clock_cycle, settle};
use crate::engine::time::ClockSpec;
use crate::engine::trace::Probe;
use crate::engine::Device;
use golden::btr::Btr;
use golden::frame::{DOMINANT, RECESSIVE};

/// Recessive bits in a row after which the stand-in takes the bus as idle again.
const IDLE_AFTER_RECESSIVE_BITS: u32 = 10;

/// What the bit timing logic did, and when.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BtlEventKind {
    /// A sample point; `at_fs` is the time before which the node took the bus level (its input
    /// synchroniser captured it at that clock edge), and the bit value it took.
    Sample(bool),
    /// A transmit point; `at_fs` is when the node's `tx` output takes the new bit.
    Transmit,
    /// A hard synchronisation; `at_fs` is the clock edge that starts the new Sync segment.
    HardSync,
    /// A resynchronisation; `at_fs` is the clock edge of the clock cycle that saw the edge.
    Resync,
}

/// One recorded event of a [`BitTimingNode`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BtlEvent {
    /// Time, in femtoseconds; see [`BtlEventKind`] for what it marks.
    pub at_fs: u64,
    /// What happened.
    pub kind: BtlEventKind,
}

/// How the stand-in chooses the synchronisation mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SyncPolicy {
    /// Follow frames: hard sync while idle, resync inside a frame.
    FollowFrames,
    /// Always this mode.
    Fixed(SyncMode),
}

#[derive(Clone, Copy, Default)]
struct Triggers {
    sample_point: bool,
    process_point: bool,
    transmit_point: bool,
    hard_synced: bool,
    resynced: bool,
    rx_bit: bool,
    segment: u64,
}

/// The RTL bit timing logic plus a bit-level protocol stand-in, as a bus [`Device`].
pub struct BitTimingNode {
    name: String,
    clock: ClockSpec,
    uut: BitTiming,
    policy: SyncPolicy,
    in_frame: bool,
    recessive_run: u32,
    to_send: VecDeque<bool>,
    sending: bool,
    prepared: bool,
    tx: bool,
    sync_mode: SyncMode,
    last: Triggers,
    events: Vec<BtlEvent>,
}

impl BitTimingNode {
    /// A node on `clock` with bit timing `btr`, held in reset for one clock, then idle.
    pub fn new(name: &str, clock: ClockSpec, btr: Btr) -> BitTimingNode {
        let mut uut = BitTiming::default();
        uut.connect_all();
        uut.brp.next = (btr.brp as u64).to_bits();
        uut.tseg1.next = (btr.tseg1 as u64).to_bits();
        uut.tseg2.next = (btr.tseg2 as u64).to_bits();
        uut.sjw.next = (btr.sjw as u64).to_bits();
        uut.sam.next = btr.sam;
        uut.rx.next = RECESSIVE;
        uut.sync_mode.next = SyncMode::Hard;
        uut.tx_dominant.next = false;
        uut.reset.next = true;
        let mut node = BitTimingNode {
            name: name.to_string(),
            clock,
            uut,
            policy: SyncPolicy::FollowFrames,
            in_frame: false,
            recessive_run: 0,
            to_send: VecDeque::new(),
            sending: false,
            prepared: RECESSIVE,
            tx: RECESSIVE,
            sync_mode: SyncMode::Hard,
            last: Triggers::default(),
            events: Vec::new(),
        };
        node.clock_edge();
        node.uut.reset.next = false;
        node
    }

    /// Pins the synchronisation mode (or lets the stand-in follow frames again).
    pub fn set_sync_policy(&mut self, policy: SyncPolicy) {
        self.policy = policy;
        self.update_sync_mode();
        self.apply_stand_in_outputs();
    }

    /// Queues `bits` to send as one frame (the first should be a dominant SOF); sending starts at the
    /// next transmit point while the bus is idle.
    pub fn transmit<I: IntoIterator<Item = bool>>(&mut self, bits: I) {
        self.to_send.extend(bits);
    }

    /// Whether the node still has bits to send.
    pub fn transmitting(&self) -> bool {
        self.sending || !self.to_send.is_empty()
    }

    /// Every recorded event, oldest first.
    pub fn events(&self) -> &[BtlEvent] {
        &self.events
    }

    /// The recorded sample points: (time before which the bus was taken, bit value).
    pub fn samples(&self) -> impl Iterator<Item = (u64, bool)> + '_ {
        self.events.iter().filter_map(|e| match e.kind {
            BtlEventKind::Sample(bit) => Some((e.at_fs, bit)),
            _ => None,
        })
    }

    /// The recorded transmit points.
    pub fn transmit_points(&self) -> impl Iterator<Item = u64> + '_ {
        self.events.iter().filter_map(|e| match e.kind {
            BtlEventKind::Transmit => Some(e.at_fs),
            _ => None,
        })
    }

    /// Forgets the recorded events.
    pub fn clear_events(&mut self) {
        self.events.clear();
    }

    fn clock_edge(&mut self) {
        clock_cycle(&mut self.uut, |u| &mut u.clock, "bit timing logic");
    }

    fn read_triggers(&self) -> Triggers {
        Triggers {
            sample_point: self.uut.sample_point.val(),
            process_point: self.uut.process_point.val(),
            transmit_point: self.uut.transmit_point.val(),
            hard_synced: self.uut.hard_synced.val(),
            resynced: self.uut.resynced.val(),
            rx_bit: self.uut.rx_bit.val(),
            segment: match self.uut.segment.val() {
                Segment::Sync => 0,
                Segment::Tseg1 => 1,
                Segment::Tseg2 => 2,
            },
        }
    }

    /// The stand-in's flops: act on the triggers of the clock cycle that started at `cycle_start`.
    fn stand_in(&mut self, cycle_start: u64, edge: u64) {
        let period = self.clock.period_fs();
        let t = self.last;
        if t.hard_synced {
            self.record(cycle_start, BtlEventKind::HardSync);
        }
        if t.resynced {
            self.record(cycle_start, BtlEventKind::Resync);
        }
        if t.process_point {
            // The sample point was the cycle before; its value entered the synchroniser one clock earlier.
            let at = cycle_start.saturating_sub(2 * period);
            self.record(at, BtlEventKind::Sample(t.rx_bit));
            self.follow_frame(t.rx_bit);
            self.prepare_next_bit();
        }
        if t.transmit_point {
            self.tx = self.prepared;
            self.record(edge, BtlEventKind::Transmit);
        }
        self.update_sync_mode();
    }

    fn follow_frame(&mut self, bit: bool) {
        if !self.in_frame {
            self.in_frame = bit == DOMINANT;
            self.recessive_run = 0;
        } else if bit == RECESSIVE {
            self.recessive_run += 1;
            if self.recessive_run >= IDLE_AFTER_RECESSIVE_BITS && !self.sending {
                self.in_frame = false;
            }
        } else {
            self.recessive_run = 0;
        }
    }

    fn prepare_next_bit(&mut self) {
        if !self.sending && !self.in_frame && !self.to_send.is_empty() {
            self.sending = true;
        }
        self.prepared = RECESSIVE;
        if self.sending {
            match self.to_send.pop_front() {
                Some(bit) => self.prepared = bit,
                None => self.sending = false,
            }
        }
    }

    fn update_sync_mode(&mut self) {
        self.sync_mode = match self.policy {
            SyncPolicy::Fixed(mode) => mode,
            SyncPolicy::FollowFrames if self.in_frame => SyncMode::Resync,
            SyncPolicy::FollowFrames => SyncMode::Hard,
        };
    }

    /// Drives the stand-in's registered outputs into the bit timing logic and settles.
    fn apply_stand_in_outputs(&mut self) {
        self.uut.sync_mode.next = self.sync_mode;
        self.uut.tx_dominant.next = self.tx == DOMINANT;
        settle(&mut self.uut, "bit timing logic");
    }

    fn record(&mut self, at_fs: u64, kind: BtlEventKind) {
        self.events.push(BtlEvent { at_fs, kind });
    }
}

impl Device for BitTimingNode {
    fn name(&self) -> &str {
        &self.name
    }

    fn clock(&self) -> ClockSpec {
        self.clock
    }

    fn rising_edge(&mut self, t_fs: u64, rx: bool) -> Drive {
        self.uut.rx.next = rx;
        self.clock_edge();
        let cycle_start = t_fs.saturating_sub(self.clock.period_fs());
        let (mode, tx_dominant) = (self.sync_mode, self.tx == DOMINANT);
        self.stand_in(cycle_start, t_fs);
        if (self.sync_mode, self.tx == DOMINANT) != (mode, tx_dominant) {
            self.apply_stand_in_outputs();
        }
        self.last = self.read_triggers();
        Drive::from_level(self.tx)
    }

    fn probes(&self) -> Vec<Probe> {
        vec![
            Probe::bit("sample_point"),
            Probe::bit("transmit_point"),
            Probe {
                name: "segment",
                width: 2,
            },
            Probe::bit("hard_sync"),
            Probe::bit("resync"),
            Probe::bit("rx_bit"),
        ]
    }

    fn probe_values(&self, values: &mut [u64]) {
        let t = &self.last;
        values.copy_from_slice(&[
            t.sample_point as u64,
            t.transmit_point as u64,
            t.segment,
            t.hard_synced as u64,
            t.resynced as u64,
            t.rx_bit as u64,
        ]);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}
