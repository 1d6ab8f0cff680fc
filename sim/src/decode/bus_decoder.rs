//! Streaming CAN bus decoder: turns the level changes of one bus signal into frames, error frames and
//! overload frames, as a receiving node sees them.
//!
//! Bit timing works in continuous time, like a node's bit timing logic with an infinitely fine time
//! quantum: a hard synchronisation on the recessive-to-dominant edge that starts a frame (bus idle or the
//! third intermission bit), a resynchronisation on every other recessive-to-dominant edge that follows a
//! recessive sample (at most one per bit, limited to [`SJW_FRACTION`] of a bit), and one sample per bit
//! at the sample point.
//!
//! The sampled bits go through a receiver that destuffs, checks the CRC and the fixed-form bits and
//! parses every field, then through the error, overload and intermission states that bring it back to
//! bus idle. An error is reported where this receiver detects it, which on a real bus is where the
//! other nodes' error flags make it visible: a stuff error on the sixth equal bit, a form error on a
//! dominant fixed recessive bit, a CRC error after the ACK delimiter. A frame counts as received, as for
//! a receiver, when its first six EOF bits are recessive; a dominant last EOF bit is an overload flag.
//!
//! Beside the events the decoder notes [`Remark`]s: what other decoders may read differently although
//! it is no error (edges it did not follow fully, idle-bus glitches, recessive reserved bits).

use std::fmt;

use crate::engine::bus_timing::BusTiming;
use crate::engine::time::{seconds_micros, FS_PER_NS};
use golden::crc15::Crc15;
use golden::frame::{
    data_len_for_dlc, Field, Frame, Id, Run, DELIMITER_BITS, DOMINANT, EOF_BITS, INTERMISSION_BITS,
    MAX_DATA_LEN, RECESSIVE,
};

/// Interface name printed in the candump-style lines.
pub const INTERFACE: &str = "can0";
/// Resynchronisation jump width as a fraction of the bit time.
pub const SJW_FRACTION: f64 = 0.25;
/// Intermission bits after which a dominant bit is a start of frame (in the last intermission bit)
/// rather than an overload flag.
const SOF_AFTER_INTERMISSION_BITS: u64 = INTERMISSION_BITS as u64 - 1;
/// Bits in a data byte.
const BYTE_BITS: u16 = 8;

/// A place on the bus a decoder event refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BitPlace {
    /// Bit `index` (0-based, MSB first, stuff bits not counted) of a frame field.
    Frame {
        /// The field.
        field: Field,
        /// Bit index inside the field.
        index: u16,
    },
    /// Bit `n` (0-based) of an error delimiter.
    ErrorDelimiter(u8),
    /// Bit `n` (0-based) of an overload delimiter.
    OverloadDelimiter(u8),
    /// Bit `n` (0-based) of the intermission.
    Intermission(u8),
}

impl BitPlace {
    fn frame(field: Field, index: u16) -> BitPlace {
        BitPlace::Frame { field, index }
    }
}

/// Fields longer than one bit, whose places name the bit index.
fn is_multi_bit(field: Field) -> bool {
    matches!(
        field,
        Field::BaseId | Field::ExtId | Field::Dlc | Field::Data | Field::Crc | Field::Eof
    )
}

impl fmt::Display for BitPlace {
    /// `data bit 12`, `CRC delimiter`, `error delimiter bit 7`, `intermission bit 0`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            BitPlace::Frame { field, index } if is_multi_bit(field) => {
                write!(f, "{field} bit {index}")
            }
            BitPlace::Frame { field, .. } => write!(f, "{field}"),
            BitPlace::ErrorDelimiter(n) => write!(f, "error delimiter bit {n}"),
            BitPlace::OverloadDelimiter(n) => write!(f, "overload delimiter bit {n}"),
            BitPlace::Intermission(n) => write!(f, "intermission bit {n}"),
        }
    }
}

/// Why the decoder saw an error frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorCause {
    /// Six equal bits in the stuffed region (SOF to CRC); the place is the last bit before the one
    /// that should have been a stuff bit.
    Stuff,
    /// The received CRC differs from the computed one; seen after the ACK delimiter, the place is the
    /// ACK delimiter.
    Crc,
    /// A dominant bit where the format requires recessive (CRC delimiter, ACK delimiter, EOF, error or
    /// overload delimiter); the place is that bit.
    Form,
    /// A dominant ACK delimiter after a recessive ACK slot: the error flag of a transmitter that saw
    /// no acknowledgement; the place is the ACK delimiter.
    Ack,
}

impl fmt::Display for ErrorCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ErrorCause::Stuff => "stuff error",
            ErrorCause::Crc => "CRC error",
            ErrorCause::Form => "form error",
            ErrorCause::Ack => "ACK error",
        })
    }
}

impl ErrorCause {
    /// Whether the place is the bit before the error (stuff, CRC) rather than the erroneous bit.
    fn place_precedes_error(self) -> bool {
        matches!(self, ErrorCause::Stuff | ErrorCause::Crc)
    }
}

/// What the decoder saw.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BusEventKind {
    /// A valid frame: CRC right, fixed-form bits right through the sixth EOF bit.
    Frame {
        /// The frame.
        frame: Frame,
        /// Whether the ACK slot was dominant.
        acked: bool,
    },
    /// An error flag and its delimiter.
    ErrorFrame {
        /// Why.
        cause: ErrorCause,
        /// Where the decoder detected it.
        at: BitPlace,
        /// The identifier of the interrupted frame, once it was complete.
        id: Option<Id>,
        /// The interrupted frame, when every bit through the CRC was received and the CRC was right
        /// (the error came in the CRC delimiter, ACK field or EOF).
        frame: Option<Frame>,
        /// Start of the interrupted frame's SOF bit (none for an error in a delimiter).
        sof_fs: Option<u64>,
    },
    /// An overload flag and its delimiter.
    OverloadFrame {
        /// The bit on which the overload flag started.
        at: BitPlace,
    },
    /// The input ended inside a frame.
    Incomplete {
        /// The first bit that was not received.
        at: BitPlace,
        /// The identifier, if it was complete.
        id: Option<Id>,
    },
}

/// One decoded event with its time span on the bus.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BusEvent {
    /// Start: the SOF bit of a frame, the first flag bit of an error or overload frame (for an error
    /// found on a recessive bit or after the ACK delimiter: the bit where it was found, or the next).
    pub start_fs: u64,
    /// End: the end of the last EOF bit or delimiter bit, or the end of the input.
    pub end_fs: u64,
    /// What it is.
    pub kind: BusEventKind,
}

/// The start of a log line: `(seconds.micros) can0 `.
fn log_prefix(f: &mut fmt::Formatter<'_>, t_fs: u64) -> fmt::Result {
    write!(f, "({}) {INTERFACE} ", seconds_micros(t_fs))
}

impl fmt::Display for BusEvent {
    /// candump log style with the start time: `(0.000120) can0 123#DEADBEEF`, with annotations:
    /// `… 123#DEADBEEF (no ACK)`, `… ERROR FRAME after data bit 5 of 555 (stuff error)`,
    /// `… OVERLOAD FRAME in intermission bit 0`, `… INCOMPLETE FRAME, input ends in CRC bit 3 of 123`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        log_prefix(f, self.start_fs)?;
        match &self.kind {
            BusEventKind::Frame { frame, acked } => {
                write!(f, "{frame}")?;
                if !acked {
                    f.write_str(" (no ACK)")?;
                }
                Ok(())
            }
            BusEventKind::ErrorFrame {
                cause,
                at,
                id,
                frame,
                ..
            } => {
                let preposition = if cause.place_precedes_error() {
                    "after"
                } else {
                    "in"
                };
                write!(f, "ERROR FRAME {preposition} {at}")?;
                match (frame, id) {
                    (Some(frame), _) => write!(f, " of {frame}")?,
                    (None, Some(id)) => write!(f, " of {id}")?,
                    (None, None) => {}
                }
                write!(f, " ({cause})")
            }
            BusEventKind::OverloadFrame { at } => write!(f, "OVERLOAD FRAME in {at}"),
            BusEventKind::Incomplete { at, id } => {
                write!(f, "INCOMPLETE FRAME, input ends in {at}")?;
                match id {
                    Some(id) => write!(f, " of {id}"),
                    None => Ok(()),
                }
            }
        }
    }
}

/// How many events of each kind a decode found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EventCounts {
    /// Valid frames.
    pub frames: usize,
    /// Error frames.
    pub error_frames: usize,
    /// Overload frames.
    pub overload_frames: usize,
    /// Frames cut off by the end of the input.
    pub incomplete: usize,
}

impl EventCounts {
    /// Counts `events` by kind.
    pub fn of(events: &[BusEvent]) -> EventCounts {
        let mut counts = EventCounts::default();
        for event in events {
            let count = match event.kind {
                BusEventKind::Frame { .. } => &mut counts.frames,
                BusEventKind::ErrorFrame { .. } => &mut counts.error_frames,
                BusEventKind::OverloadFrame { .. } => &mut counts.overload_frames,
                BusEventKind::Incomplete { .. } => &mut counts.incomplete,
            };
            *count += 1;
        }
        counts
    }
}

impl fmt::Display for EventCounts {
    /// `12 frames, 3 error frames, 1 overload frame`, and `, 1 incomplete frame` when there is one.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let plural = |n: usize| if n == 1 { "" } else { "s" };
        write!(
            f,
            "{} frame{}, {} error frame{}, {} overload frame{}",
            self.frames,
            plural(self.frames),
            self.error_frames,
            plural(self.error_frames),
            self.overload_frames,
            plural(self.overload_frames)
        )?;
        if self.incomplete > 0 {
            write!(
                f,
                ", {} incomplete frame{}",
                self.incomplete,
                plural(self.incomplete)
            )?;
        }
        Ok(())
    }
}

/// Something on the bus that decoders may read differently although it is no error: the decoder
/// notes it beside its events.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Remark {
    /// When: the edge, or the start of the bit.
    pub t_fs: u64,
    /// What.
    pub kind: RemarkKind,
}

/// The kinds of [`Remark`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RemarkKind {
    /// A recessive-to-dominant edge inside a frame that the decoder did not synchronise on: the last
    /// sample was dominant (the edge ends a recessive glitch), or it already synchronised in this bit.
    IgnoredEdge,
    /// A synchronisation edge further from the bit start than the SJW: the decoder moved its bit
    /// timing by the SJW only.
    PhaseErrorBeyondSjw {
        /// The edge's distance from the bit start (negative: before it).
        phase_error_fs: i64,
    },
    /// A dominant level on the idle bus that was recessive again at the sample point: no SOF.
    SofGlitch,
    /// A reserved bit (r0, or r1 of an extended frame) received recessive; receivers accept it, but
    /// CAN FD decoders read that bit as FDF.
    ReservedBitRecessive(Field),
}

impl fmt::Display for Remark {
    /// `(0.000037) can0 remark: edge 0.47 bit late, beyond the SJW`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        log_prefix(f, self.t_fs)?;
        f.write_str("remark: ")?;
        match self.kind {
            RemarkKind::IgnoredEdge => f.write_str("edge not used for synchronisation"),
            RemarkKind::PhaseErrorBeyondSjw { phase_error_fs } => {
                let side = if phase_error_fs < 0 { "early" } else { "late" };
                write!(
                    f,
                    "edge {:.0} ns {side}, beyond the SJW",
                    phase_error_fs.unsigned_abs() as f64 / FS_PER_NS as f64
                )
            }
            RemarkKind::SofGlitch => f.write_str("glitch on the idle bus, no start of frame"),
            RemarkKind::ReservedBitRecessive(field) => write!(f, "{field} received recessive"),
        }
    }
}

/// How a received bit ended (or did not end) the frame.
enum RxOutcome {
    Continue,
    /// The frame is valid; `overload` when the last EOF bit was dominant.
    Done {
        frame: Frame,
        acked: bool,
        overload: bool,
    },
    Error {
        cause: ErrorCause,
        at: BitPlace,
        frame: Option<Frame>,
    },
}

/// The receiver of one frame, fed one sampled bit at a time from SOF on.
struct Receiver {
    start_fs: u64,
    run: Run,
    /// The next bit is a stuff bit.
    stuff_next: bool,
    crc: Crc15,
    /// The field and bit index the next (non-stuff) bit belongs to.
    field: Field,
    index: u16,
    /// The bits of the current field so far (every field but the data field).
    value: u32,
    /// Place of the last non-stuff bit of the stuffed region.
    last: BitPlace,
    base_id: u32,
    /// The bit after the base identifier: RTR of a standard frame, SRR of an extended one.
    rtr_or_srr: bool,
    ide_seen: bool,
    id: Option<Id>,
    remote: bool,
    dlc: u8,
    data: [u8; MAX_DATA_LEN],
    crc_ok: bool,
    acked: bool,
    /// A remark about the last bit, for the decoder to take.
    remark: Option<RemarkKind>,
}

impl Receiver {
    fn new(start_fs: u64) -> Receiver {
        Receiver {
            start_fs,
            run: Run::new(),
            stuff_next: false,
            crc: Crc15::new(),
            field: Field::Sof,
            index: 0,
            value: 0,
            last: BitPlace::frame(Field::Sof, 0),
            base_id: 0,
            rtr_or_srr: false,
            ide_seen: false,
            id: None,
            remote: false,
            dlc: 0,
            data: [0; MAX_DATA_LEN],
            crc_ok: false,
            acked: false,
            remark: None,
        }
    }

    fn place(&self) -> BitPlace {
        BitPlace::frame(self.field, self.index)
    }

    fn data_len(&self) -> usize {
        if self.remote {
            0
        } else {
            data_len_for_dlc(self.dlc)
        }
    }

    fn width(&self, field: Field) -> u16 {
        match field {
            Field::BaseId => 11,
            Field::ExtId => 18,
            Field::Dlc => 4,
            // At most 8 bytes, so the cast is lossless.
            Field::Data => BYTE_BITS * self.data_len() as u16,
            Field::Crc => 15,
            Field::Eof => EOF_BITS,
            _ => 1,
        }
    }

    /// The received frame; call only once the CRC is in.
    fn frame(&self) -> Frame {
        let id = self.id.expect("identifier complete before the CRC");
        let frame = if self.remote {
            Frame::remote(id, self.dlc)
        } else {
            Frame::data_with_dlc(id, self.dlc, &self.data[..self.data_len()])
        };
        frame.expect("received fields are always in range")
    }

    fn error(&self, cause: ErrorCause, at: BitPlace) -> RxOutcome {
        let frame = self.crc_ok.then(|| self.frame());
        RxOutcome::Error { cause, at, frame }
    }

    /// One sampled bit.
    fn push(&mut self, bit: bool) -> RxOutcome {
        if self.stuff_next {
            self.stuff_next = false;
            if bit == self.run.value {
                return self.error(ErrorCause::Stuff, self.last);
            }
            self.run.push(bit);
            return RxOutcome::Continue;
        }
        let at = self.place();
        match self.field {
            Field::AckDelim if bit == DOMINANT && !self.acked => {
                return self.error(ErrorCause::Ack, at);
            }
            Field::CrcDelim | Field::AckDelim if bit == DOMINANT => {
                return self.error(ErrorCause::Form, at);
            }
            Field::AckDelim if !self.crc_ok => return self.error(ErrorCause::Crc, at),
            Field::CrcDelim | Field::AckDelim => {}
            Field::AckSlot => self.acked = bit == DOMINANT,
            Field::Eof => return self.end_of_frame_bit(bit),
            _ => {
                self.stuff_next = self.run.push(bit);
                if self.field != Field::Crc {
                    self.crc.push(bit);
                }
                self.last = at;
            }
        }
        if self.field == Field::Data {
            let byte = usize::from(self.index / BYTE_BITS);
            self.data[byte] |= u8::from(bit) << (BYTE_BITS - 1 - self.index % BYTE_BITS);
        } else {
            self.value = self.value << 1 | u32::from(bit);
        }
        self.index += 1;
        while self.index == self.width(self.field) {
            self.field = self.field_done();
            (self.index, self.value) = (0, 0);
        }
        RxOutcome::Continue
    }

    fn end_of_frame_bit(&mut self, bit: bool) -> RxOutcome {
        let last = self.index == EOF_BITS - 1;
        if bit == DOMINANT && !last {
            return self.error(ErrorCause::Form, self.place());
        }
        self.index += 1;
        if !last {
            return RxOutcome::Continue;
        }
        RxOutcome::Done {
            frame: self.frame(),
            acked: self.acked,
            overload: bit == DOMINANT,
        }
    }

    fn note_reserved(&mut self, field: Field, recessive: bool) {
        if recessive {
            self.remark = Some(RemarkKind::ReservedBitRecessive(field));
        }
    }

    /// Takes in the completed current field and returns the next one (an empty data field is complete
    /// at once, hence the caller's loop).
    fn field_done(&mut self) -> Field {
        let set = self.value == 1;
        match self.field {
            Field::Sof => Field::BaseId,
            Field::BaseId => {
                self.base_id = self.value;
                Field::Rtr
            }
            Field::Rtr if !self.ide_seen => {
                self.rtr_or_srr = set;
                Field::Ide
            }
            Field::Ide => {
                self.ide_seen = true;
                if set {
                    Field::ExtId
                } else {
                    // 11-bit value, always in range.
                    self.id = Some(Id::Standard(self.base_id as u16));
                    self.remote = self.rtr_or_srr;
                    Field::R0
                }
            }
            Field::ExtId => {
                self.id = Some(Id::Extended(self.base_id << 18 | self.value));
                Field::Rtr
            }
            Field::Rtr => {
                self.remote = set;
                Field::R1
            }
            Field::R1 => {
                self.note_reserved(Field::R1, set);
                Field::R0
            }
            Field::R0 => {
                self.note_reserved(Field::R0, set);
                Field::Dlc
            }
            Field::Dlc => {
                // 4-bit value.
                self.dlc = self.value as u8;
                Field::Data
            }
            Field::Data => Field::Crc,
            Field::Crc => {
                self.crc_ok = self.value == u32::from(self.crc.value());
                Field::CrcDelim
            }
            Field::CrcDelim => Field::AckSlot,
            Field::AckSlot => Field::AckDelim,
            // The bit after the base identifier is read as RTR, so SRR is never the current field.
            Field::AckDelim | Field::Srr | Field::Eof => Field::Eof,
        }
    }
}

/// Error or overload: the two flags share their structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Flag {
    Error,
    Overload,
}

enum State {
    /// Bus idle: a dominant bit is a start of frame.
    Idle,
    /// Receiving a frame.
    Frame(Box<Receiver>),
    /// An error or overload flag: dominant bits (any number, flags overlap) until the first recessive.
    Flag(Flag),
    /// The delimiter after a flag: `recessive` recessive bits so far.
    Delimiter { flag: Flag, recessive: u8 },
    /// The intermission: `recessive` recessive bits so far.
    Intermission { recessive: u8 },
}

/// The streaming decoder; see the module documentation.
pub struct BusDecoder {
    bit_fs: u64,
    sample_fs: u64,
    sjw_fs: u64,
    /// The bus level from the last call to [`BusDecoder::level`] on.
    level: bool,
    /// Start of the bit whose sample point comes next.
    bit_start: u64,
    /// A synchronisation happened since the last sample point.
    synced: bool,
    last_sample: bool,
    state: State,
    /// The error or overload frame whose delimiter is still running.
    pending: Option<BusEvent>,
    events: Vec<BusEvent>,
    remarks: Vec<Remark>,
}

impl BusDecoder {
    /// `bit_time_fs`: nominal bit time in femtoseconds; `sample_point`: fraction of the bit (e.g. 0.875).
    ///
    /// Panics if the bit time is zero or the sample point is not strictly between 0 and 1.
    pub fn new(bit_time_fs: u64, sample_point: f64) -> BusDecoder {
        if let Err(e) = BusTiming::new(bit_time_fs, sample_point) {
            panic!("{e}");
        }
        BusDecoder {
            bit_fs: bit_time_fs,
            sample_fs: (bit_time_fs as f64 * sample_point).round() as u64,
            sjw_fs: (bit_time_fs as f64 * SJW_FRACTION).round() as u64,
            level: RECESSIVE,
            bit_start: 0,
            synced: false,
            last_sample: RECESSIVE,
            state: State::Idle,
            pending: None,
            events: Vec::new(),
            remarks: Vec::new(),
        }
    }

    /// The same decoder with a synchronisation jump width of `sjw` (a fraction of the bit, as a
    /// controller's SJW in time quanta over its quanta per bit) instead of [`SJW_FRACTION`].
    pub fn with_sjw(mut self, sjw: f64) -> BusDecoder {
        self.sjw_fs = (self.bit_fs as f64 * sjw).round() as u64;
        self
    }

    /// A decoder sampling with `timing`.
    pub fn with_timing(timing: BusTiming) -> BusDecoder {
        BusDecoder::new(timing.bit_time_fs, timing.sample_point)
    }

    /// The bus level is `recessive` from `t_fs` on (calls in time order; repeats of the same level allowed).
    pub fn level(&mut self, t_fs: u64, recessive: bool) {
        self.sample_before(t_fs, false);
        if recessive == self.level {
            return;
        }
        self.level = recessive;
        if recessive == DOMINANT {
            self.synchronise(t_fs);
        }
    }

    /// End of input at `t_fs`: decodes what is pending (an unfinished frame becomes an event that says so).
    pub fn finish(&mut self, t_fs: u64) {
        self.sample_before(t_fs, true);
        if let State::Frame(rx) = &self.state {
            let kind = BusEventKind::Incomplete {
                at: rx.place(),
                id: rx.id,
            };
            let start_fs = rx.start_fs;
            self.events.push(BusEvent {
                start_fs,
                end_fs: t_fs,
                kind,
            });
        }
        self.close_pending(t_fs);
        self.state = State::Idle;
    }

    /// The events decoded so far, removed from the decoder, in bus order.
    pub fn drain(&mut self) -> Vec<BusEvent> {
        std::mem::take(&mut self.events)
    }

    /// The remarks noted so far, removed from the decoder, in time order.
    pub fn drain_remarks(&mut self) -> Vec<Remark> {
        std::mem::take(&mut self.remarks)
    }

    fn remark(&mut self, t_fs: u64, kind: RemarkKind) {
        self.remarks.push(Remark { t_fs, kind });
    }

    /// Takes every sample point before `t_fs` (`inclusive`: up to and including it).
    fn sample_before(&mut self, t_fs: u64, inclusive: bool) {
        loop {
            // An idle recessive bus has nothing to sample, unless a hard synchronisation awaits its
            // sample point: the next edge hard-synchronises. This keeps long idle stretches cheap.
            if matches!(self.state, State::Idle) && self.level == RECESSIVE && !self.synced {
                return;
            }
            let at = self.bit_start + self.sample_fs;
            if at > t_fs || (at == t_fs && !inclusive) {
                return;
            }
            self.synced = false;
            self.last_sample = self.level;
            self.bit(self.level);
            self.bit_start += self.bit_fs;
        }
    }

    fn hard_sync_allowed(&self) -> bool {
        match self.state {
            State::Idle => true,
            State::Intermission { recessive } => {
                u64::from(recessive) == SOF_AFTER_INTERMISSION_BITS
            }
            _ => false,
        }
    }

    /// A recessive-to-dominant edge at `t_fs`.
    fn synchronise(&mut self, t_fs: u64) {
        if self.hard_sync_allowed() {
            self.bit_start = t_fs;
            self.synced = true;
            return;
        }
        if self.synced || self.last_sample == DOMINANT {
            if matches!(self.state, State::Frame(_)) {
                self.remark(t_fs, RemarkKind::IgnoredEdge);
            }
            return;
        }
        self.synced = true;
        let phase_error = t_fs.abs_diff(self.bit_start);
        if phase_error > self.sjw_fs && matches!(self.state, State::Frame(_)) {
            let sign = if t_fs < self.bit_start { -1 } else { 1 };
            let phase_error_fs = sign * i64::try_from(phase_error).unwrap_or(i64::MAX);
            self.remark(t_fs, RemarkKind::PhaseErrorBeyondSjw { phase_error_fs });
        }
        if t_fs < self.bit_start {
            self.bit_start -= phase_error.min(self.sjw_fs);
        } else {
            self.bit_start += phase_error.min(self.sjw_fs);
        }
    }

    /// One sampled bit, the bit starting at `self.bit_start`.
    fn bit(&mut self, bit: bool) {
        let (start, end) = (self.bit_start, self.bit_start + self.bit_fs);
        match &mut self.state {
            State::Idle => {
                if bit == DOMINANT {
                    self.start_frame(bit);
                } else {
                    self.remark(start, RemarkKind::SofGlitch);
                }
            }
            State::Frame(rx) => match rx.push(bit) {
                RxOutcome::Continue if rx.remark.is_some() => {
                    if let Some(kind) = rx.remark.take() {
                        self.remark(start, kind);
                    }
                }
                RxOutcome::Continue => {}
                RxOutcome::Done {
                    frame,
                    acked,
                    overload,
                } => {
                    let start_fs = rx.start_fs;
                    self.events.push(BusEvent {
                        start_fs,
                        end_fs: end,
                        kind: BusEventKind::Frame { frame, acked },
                    });
                    if overload {
                        let at = BitPlace::frame(Field::Eof, EOF_BITS - 1);
                        self.begin(start, BusEventKind::OverloadFrame { at }, Flag::Overload);
                    } else {
                        self.state = State::Intermission { recessive: 0 };
                    }
                }
                RxOutcome::Error { cause, at, frame } => {
                    let (id, sof_fs) = (rx.id, Some(rx.start_fs));
                    // A CRC error shows after the ACK delimiter: the flag starts with the next bit.
                    let flag_start = if cause == ErrorCause::Crc { end } else { start };
                    let kind = BusEventKind::ErrorFrame {
                        cause,
                        at,
                        id,
                        frame,
                        sof_fs,
                    };
                    self.begin(flag_start, kind, Flag::Error);
                }
            },
            State::Flag(flag) => {
                if bit == RECESSIVE {
                    self.state = State::Delimiter {
                        flag: *flag,
                        recessive: 1,
                    };
                }
            }
            State::Delimiter { flag, recessive } => {
                if bit == RECESSIVE {
                    *recessive += 1;
                    if *recessive == DELIMITER_BITS {
                        self.close_pending(end);
                        self.state = State::Intermission { recessive: 0 };
                    }
                    return;
                }
                let at = match flag {
                    Flag::Error => BitPlace::ErrorDelimiter(*recessive),
                    Flag::Overload => BitPlace::OverloadDelimiter(*recessive),
                };
                let last_bit = *recessive == DELIMITER_BITS - 1;
                self.close_pending(start);
                if last_bit {
                    self.begin(start, BusEventKind::OverloadFrame { at }, Flag::Overload);
                } else {
                    let kind = BusEventKind::ErrorFrame {
                        cause: ErrorCause::Form,
                        at,
                        id: None,
                        frame: None,
                        sof_fs: None,
                    };
                    self.begin(start, kind, Flag::Error);
                }
            }
            State::Intermission { recessive } => {
                if bit == RECESSIVE {
                    *recessive += 1;
                    if *recessive == INTERMISSION_BITS {
                        self.state = State::Idle;
                    }
                } else if u64::from(*recessive) < SOF_AFTER_INTERMISSION_BITS {
                    let at = BitPlace::Intermission(*recessive);
                    self.begin(start, BusEventKind::OverloadFrame { at }, Flag::Overload);
                } else {
                    self.start_frame(bit);
                }
            }
        }
    }

    /// A dominant bit out of idle or intermission: the SOF of a frame.
    fn start_frame(&mut self, sof: bool) {
        let mut rx = Receiver::new(self.bit_start);
        let outcome = rx.push(sof);
        debug_assert!(matches!(outcome, RxOutcome::Continue));
        self.state = State::Frame(Box::new(rx));
    }

    /// An error or overload flag starts at `start_fs`.
    fn begin(&mut self, start_fs: u64, kind: BusEventKind, flag: Flag) {
        self.pending = Some(BusEvent {
            start_fs,
            end_fs: start_fs,
            kind,
        });
        self.state = State::Flag(flag);
    }

    /// The pending error or overload frame ends at `end_fs`.
    fn close_pending(&mut self, end_fs: u64) {
        if let Some(mut event) = self.pending.take() {
            event.end_fs = end_fs.max(event.start_fs);
            self.events.push(event);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::time::{FS_PER_S, FS_PER_US};
    use golden::frame::hand_built::{levels, wire_from_unstuffed};
    use golden::frame::{encode, EncodedFrame, MAX_DLC};
    use proptest::prelude::*;

    /// 500 kbit/s.
    const BIT_FS: u64 = 2 * FS_PER_US;
    const SAMPLE_POINT: f64 = 0.875;
    /// Idle bits before the first frame.
    const LEAD_IN: u64 = 10;

    /// An ideal bus: wire bits of `tx_bit_fs` each, back to back, into a decoder.
    struct Wire {
        decoder: BusDecoder,
        t: u64,
        tx_bit_fs: u64,
    }

    impl Wire {
        fn new() -> Wire {
            Wire::with_timing(BIT_FS, SAMPLE_POINT, BIT_FS, LEAD_IN * BIT_FS)
        }

        fn with_timing(bit_fs: u64, sample_point: f64, tx_bit_fs: u64, start: u64) -> Wire {
            Wire {
                decoder: BusDecoder::new(bit_fs, sample_point),
                t: start,
                tx_bit_fs,
            }
        }

        fn play(&mut self, bits: impl IntoIterator<Item = bool>) {
            for bit in bits {
                self.decoder.level(self.t, bit);
                self.t += self.tx_bit_fs;
            }
        }

        fn repeat(&mut self, level: bool, n: usize) {
            self.play(std::iter::repeat_n(level, n));
        }

        /// A frame, acknowledged or not, through its last EOF bit.
        fn frame(&mut self, frame: &Frame, acked: bool) {
            self.play(wire(frame, acked).bits);
        }

        /// A frame and the intermission after it; returns the frame's (start, end).
        fn frame_and_intermission(&mut self, frame: &Frame, acked: bool) -> (u64, u64) {
            let start = self.t;
            self.frame(frame, acked);
            let end = self.t;
            self.repeat(RECESSIVE, INTERMISSION_BITS as usize);
            (start, end)
        }

        /// A flag of `flag_bits` dominant bits, its delimiter and the intermission.
        fn flag(&mut self, flag_bits: usize) {
            self.repeat(DOMINANT, flag_bits);
            self.repeat(RECESSIVE, (DELIMITER_BITS + INTERMISSION_BITS) as usize);
        }

        fn events(mut self) -> Vec<BusEvent> {
            self.decoder.finish(self.t);
            self.decoder.drain()
        }

        fn kinds(self) -> Vec<BusEventKind> {
            self.events().into_iter().map(|e| e.kind).collect()
        }
    }

    fn wire(frame: &Frame, acked: bool) -> EncodedFrame {
        let mut encoded = encode(frame);
        if acked {
            let slot = encoded.position(Field::AckSlot, 0).unwrap();
            encoded.bits.set(slot, DOMINANT);
        }
        encoded
    }

    fn std_frame(id: u16, data: &[u8]) -> Frame {
        Frame::data(Id::Standard(id), data).unwrap()
    }

    fn received(frame: Frame, acked: bool) -> BusEventKind {
        BusEventKind::Frame { frame, acked }
    }

    /// Every identifier kind, DLC 0..=15, data and remote.
    fn all_kinds() -> Vec<Frame> {
        let ids = [
            Id::Standard(0),
            Id::Standard(0x7FF),
            Id::Standard(0x555),
            Id::Standard(0x123),
            Id::Extended(0),
            Id::Extended(0x1FFF_FFFF),
            Id::Extended(0x0ABC_DEF0),
            Id::Extended(0x1555_5555),
        ];
        let mut frames = Vec::new();
        for id in ids {
            for dlc in 0..=MAX_DLC {
                let data: Vec<u8> = (0..data_len_for_dlc(dlc))
                    .map(|i| (i as u8).wrapping_mul(0x37) ^ id.raw() as u8)
                    .collect();
                frames.push(Frame::data_with_dlc(id, dlc, &data).unwrap());
                frames.push(Frame::remote(id, dlc).unwrap());
            }
        }
        frames
    }

    #[test]
    fn every_frame_kind_back_to_back() {
        let frames = all_kinds();
        let mut wire = Wire::new();
        let mut expected = Vec::new();
        for (i, frame) in frames.iter().enumerate() {
            let acked = i % 2 == 0;
            let (start_fs, end_fs) = wire.frame_and_intermission(frame, acked);
            expected.push(BusEvent {
                start_fs,
                end_fs,
                kind: received(*frame, acked),
            });
        }
        assert_eq!(wire.events(), expected);
    }

    #[test]
    fn sof_in_the_third_intermission_bit_and_after_idle() {
        let (a, b) = (std_frame(0x0F0, &[1]), std_frame(0x0F1, &[2, 3]));
        let mut wire = Wire::new();
        wire.frame(&a, true);
        wire.repeat(RECESSIVE, 2);
        wire.frame(&b, true);
        wire.repeat(RECESSIVE, 20);
        wire.frame(&a, false);
        assert_eq!(
            wire.kinds(),
            [received(a, true), received(b, true), received(a, false)]
        );
    }

    #[test]
    fn a_glitch_on_the_idle_bus_is_no_frame() {
        let mut wire = Wire::new();
        let t = wire.t;
        wire.decoder.level(t, DOMINANT);
        wire.decoder.level(t + BIT_FS / 2, RECESSIVE);
        wire.t += 20 * BIT_FS;
        let frame = std_frame(0x100, &[]);
        wire.frame(&frame, true);
        wire.decoder.finish(wire.t);
        assert_eq!(
            wire.decoder.drain_remarks(),
            [Remark {
                t_fs: t,
                kind: RemarkKind::SofGlitch
            }]
        );
        assert_eq!(wire.kinds(), [received(frame, true)]);
    }

    #[test]
    fn a_recessive_reserved_bit_is_a_remark() {
        // Standard 0x555, r0 recessive, DLC 1, data 0xAA; no stuff bit before r0 (wire bit 14).
        let header = levels("0 10101010101 0 0 1 0001 10101010");
        let mut wire = Wire::new();
        let sof = wire.t;
        wire.play(wire_from_unstuffed(&header).iter().by_vals());
        wire.decoder.finish(wire.t);
        assert_eq!(
            wire.decoder.drain_remarks(),
            [Remark {
                t_fs: sof + 14 * BIT_FS,
                kind: RemarkKind::ReservedBitRecessive(Field::R0)
            }]
        );
        assert_eq!(wire.kinds(), [received(std_frame(0x555, &[0xAA]), false)]);
    }

    #[test]
    fn edges_the_decoder_cannot_follow_fully_are_remarks() {
        let frame = std_frame(0x555, &[0xAA]);
        let encoded = wire(&frame, true);
        let (rtr, data1) = (
            encoded.position(Field::Rtr, 0).unwrap(),
            encoded.position(Field::Data, 1).unwrap(),
        );
        let mut wire = Wire::new();
        // A recessive glitch late in the dominant RTR bit, after its sample point: RTR and IDE are
        // dominant, so the edge back to dominant follows a dominant sample.
        wire.play(encoded.bits[..=rtr].iter().by_vals());
        let rtr_start = wire.t - BIT_FS;
        let glitch_end = rtr_start + 19 * BIT_FS / 20;
        wire.decoder.level(rtr_start + 9 * BIT_FS / 10, RECESSIVE);
        wire.decoder.level(glitch_end, DOMINANT);
        wire.play(encoded.bits[rtr + 1..data1].iter().by_vals());
        // Data bit 0 (recessive) lasts 0.4 bit longer: every later edge comes 0.4 bit late.
        let late = 2 * BIT_FS / 5;
        wire.t += late;
        let edge = wire.t;
        wire.play(encoded.bits[data1..].iter().by_vals());
        wire.decoder.finish(wire.t);
        assert_eq!(
            wire.decoder.drain_remarks(),
            [
                Remark {
                    t_fs: glitch_end,
                    kind: RemarkKind::IgnoredEdge
                },
                Remark {
                    t_fs: edge,
                    kind: RemarkKind::PhaseErrorBeyondSjw {
                        phase_error_fs: late as i64
                    }
                },
            ]
        );
        assert_eq!(wire.kinds(), [received(frame, true)]);
        let remark = Remark {
            t_fs: 3 * FS_PER_US,
            kind: RemarkKind::PhaseErrorBeyondSjw {
                phase_error_fs: -800 * FS_PER_NS as i64,
            },
        };
        assert_eq!(
            remark.to_string(),
            "(0.000003) can0 remark: edge 800 ns early, beyond the SJW"
        );
    }

    /// Standard 0x555, one byte 0xAA: `0 10101010101 0 0 0 0[1]0 1 10101010`. An error flag from data
    /// bit 1 on makes data bits 1..=5 dominant; the sixth dominant bit breaks the stuff rule.
    #[test]
    fn error_flag_in_the_data_field_is_a_stuff_error() {
        let frame = std_frame(0x555, &[0xAA]);
        let encoded = wire(&frame, true);
        let flag_at = encoded.position(Field::Data, 1).unwrap();
        let mut wire = Wire::new();
        let sof = wire.t;
        wire.play(encoded.bits[..flag_at].iter().by_vals());
        wire.flag(6);
        let retransmitted = wire.frame_and_intermission(&frame, true);
        let events = wire.events();
        let sixth_flag_bit = sof + (flag_at as u64 + 5) * BIT_FS;
        let error_end = sof + (flag_at as u64 + 6 + 8) * BIT_FS;
        assert_eq!(
            events[0],
            BusEvent {
                start_fs: sixth_flag_bit,
                end_fs: error_end,
                kind: BusEventKind::ErrorFrame {
                    cause: ErrorCause::Stuff,
                    at: BitPlace::frame(Field::Data, 5),
                    id: Some(Id::Standard(0x555)),
                    frame: None,
                    sof_fs: Some(sof),
                },
            }
        );
        assert_eq!(
            (events[1].start_fs, events[1].end_fs),
            retransmitted,
            "{events:?}"
        );
        assert_eq!(events[1].kind, received(frame, true));
        assert_eq!(events.len(), 2);
    }

    #[test]
    fn overlapping_flags_make_one_error_frame() {
        let frame = std_frame(0x555, &[0xAA]);
        let encoded = wire(&frame, true);
        let mut wire = Wire::new();
        wire.play(
            encoded.bits[..encoded.position(Field::Dlc, 3).unwrap()]
                .iter()
                .by_vals(),
        );
        wire.flag(12);
        wire.frame_and_intermission(&frame, true);
        let kinds = wire.kinds();
        assert_eq!(kinds.len(), 2, "{kinds:?}");
        assert!(matches!(
            kinds[0],
            BusEventKind::ErrorFrame {
                cause: ErrorCause::Stuff,
                ..
            }
        ));
    }

    #[test]
    fn flipped_data_bit_is_a_crc_error_after_the_ack_delimiter() {
        let frame = std_frame(0x555, &[0xAA]);
        let mut encoded = wire(&frame, true);
        // Data bit 3 is 0 between two 1s: setting it keeps every stuff bit where it was.
        let bit3 = encoded.position(Field::Data, 3).unwrap();
        encoded.bits.set(bit3, RECESSIVE);
        let mut wire = Wire::new();
        let sof = wire.t;
        wire.play(
            encoded.bits[..encoded.position(Field::Eof, 0).unwrap()]
                .iter()
                .by_vals(),
        );
        wire.flag(6);
        let eof = encoded.position(Field::Eof, 0).unwrap() as u64;
        let events = wire.events();
        assert_eq!(
            events,
            [BusEvent {
                start_fs: sof + eof * BIT_FS,
                end_fs: sof + (eof + 6 + 8) * BIT_FS,
                kind: BusEventKind::ErrorFrame {
                    cause: ErrorCause::Crc,
                    at: BitPlace::frame(Field::AckDelim, 0),
                    id: Some(Id::Standard(0x555)),
                    frame: None,
                    sof_fs: Some(sof),
                },
            }]
        );
    }

    #[test]
    fn a_frame_without_ack_and_the_transmitters_flag_is_an_ack_error() {
        let frame = Frame::data(Id::Extended(0x0123_4567), &[1, 2, 3]).unwrap();
        let encoded = wire(&frame, false);
        let mut wire = Wire::new();
        let sof = wire.t;
        wire.play(
            encoded.bits[..encoded.position(Field::AckDelim, 0).unwrap()]
                .iter()
                .by_vals(),
        );
        wire.flag(6);
        assert_eq!(
            wire.kinds(),
            [BusEventKind::ErrorFrame {
                cause: ErrorCause::Ack,
                at: BitPlace::frame(Field::AckDelim, 0),
                id: Some(frame.id()),
                frame: Some(frame),
                sof_fs: Some(sof),
            }]
        );
    }

    #[test]
    fn dominant_fixed_form_bits_are_form_errors() {
        let frame = Frame::remote(Id::Standard(0x321), 4).unwrap();
        let encoded = wire(&frame, true);
        for (field, index) in [
            (Field::CrcDelim, 0),
            (Field::AckDelim, 0),
            (Field::Eof, 0),
            (Field::Eof, 5),
        ] {
            let mut wire = Wire::new();
            let sof = wire.t;
            let position = encoded.position(field, index).unwrap();
            wire.play(encoded.bits[..position].iter().by_vals());
            wire.flag(6);
            let expected = BusEventKind::ErrorFrame {
                cause: ErrorCause::Form,
                at: BitPlace::frame(field, index),
                id: Some(frame.id()),
                frame: Some(frame),
                sof_fs: Some(sof),
            };
            assert_eq!(wire.kinds(), [expected], "{field} bit {index}");
        }
    }

    #[test]
    fn overload_flags_after_a_frame() {
        let frame = std_frame(0x7E0, &[0x11, 0x22]);
        let encoded = wire(&frame, true);
        let mut wire = Wire::new();
        // Dominant last EOF bit: the frame is valid for receivers, and an overload flag starts.
        wire.play(encoded.bits[..encoded.len() - 1].iter().by_vals());
        wire.flag(6);
        wire.frame(&frame, true);
        wire.flag(6);
        wire.frame(&frame, true);
        wire.repeat(RECESSIVE, 1);
        wire.flag(7);
        let overload = |at| BusEventKind::OverloadFrame { at };
        assert_eq!(
            wire.kinds(),
            [
                received(frame, true),
                overload(BitPlace::frame(Field::Eof, 6)),
                received(frame, true),
                overload(BitPlace::Intermission(0)),
                received(frame, true),
                overload(BitPlace::Intermission(1)),
            ]
        );
    }

    #[test]
    fn dominant_bits_in_a_delimiter() {
        let frame = std_frame(0x7E0, &[]);
        let mut wire = Wire::new();
        wire.frame(&frame, true);
        wire.repeat(DOMINANT, 6);
        wire.repeat(RECESSIVE, 3);
        // Overload delimiter bit 3 dominant: a form error.
        wire.repeat(DOMINANT, 6);
        wire.repeat(RECESSIVE, 7);
        // Error delimiter bit 7 (the last) dominant: an overload flag.
        wire.flag(6);
        wire.frame(&frame, true);
        assert_eq!(
            wire.kinds(),
            [
                received(frame, true),
                BusEventKind::OverloadFrame {
                    at: BitPlace::Intermission(0)
                },
                BusEventKind::ErrorFrame {
                    cause: ErrorCause::Form,
                    at: BitPlace::OverloadDelimiter(3),
                    id: None,
                    frame: None,
                    sof_fs: None,
                },
                BusEventKind::OverloadFrame {
                    at: BitPlace::ErrorDelimiter(7)
                },
                received(frame, true),
            ]
        );
    }

    #[test]
    fn input_ending_inside_a_frame_or_flag() {
        let frame = Frame::data(Id::Extended(0x1ABC_DEF0), &[0x42]).unwrap();
        let encoded = wire(&frame, true);
        let mut wire = Wire::new();
        let sof = wire.t;
        wire.play(
            encoded.bits[..encoded.position(Field::Crc, 3).unwrap()]
                .iter()
                .by_vals(),
        );
        let end = wire.t;
        assert_eq!(
            wire.events(),
            [BusEvent {
                start_fs: sof,
                end_fs: end,
                kind: BusEventKind::Incomplete {
                    at: BitPlace::frame(Field::Crc, 3),
                    id: Some(frame.id()),
                },
            }]
        );
        let mut wire = Wire::new();
        wire.play(encoded.bits[..5].iter().by_vals());
        assert_eq!(
            wire.kinds(),
            [BusEventKind::Incomplete {
                at: BitPlace::frame(Field::BaseId, 4),
                id: None,
            }]
        );
        let mut wire = Wire::new();
        wire.frame(&frame, true);
        wire.repeat(DOMINANT, 3);
        let kinds = wire.kinds();
        assert_eq!(kinds.len(), 2);
        assert!(matches!(kinds[1], BusEventKind::OverloadFrame { .. }));
    }

    #[test]
    fn log_lines() {
        let t = 3_600 * FS_PER_S + 20 * FS_PER_US;
        let line = |kind| {
            BusEvent {
                start_fs: t,
                end_fs: t,
                kind,
            }
            .to_string()
        };
        let frame = std_frame(0x123, &[0xDE, 0xAD]);
        let error = |cause, at, id, frame| BusEventKind::ErrorFrame {
            cause,
            at,
            id,
            frame,
            sof_fs: None,
        };
        let cases = [
            (received(frame, true), "(3600.000020) can0 123#DEAD"),
            (
                received(frame, false),
                "(3600.000020) can0 123#DEAD (no ACK)",
            ),
            (
                error(
                    ErrorCause::Stuff,
                    BitPlace::frame(Field::Data, 5),
                    Some(frame.id()),
                    None,
                ),
                "(3600.000020) can0 ERROR FRAME after data bit 5 of 123 (stuff error)",
            ),
            (
                error(
                    ErrorCause::Ack,
                    BitPlace::frame(Field::AckDelim, 0),
                    Some(frame.id()),
                    Some(frame),
                ),
                "(3600.000020) can0 ERROR FRAME in ACK delimiter of 123#DEAD (ACK error)",
            ),
            (
                error(ErrorCause::Form, BitPlace::ErrorDelimiter(2), None, None),
                "(3600.000020) can0 ERROR FRAME in error delimiter bit 2 (form error)",
            ),
            (
                error(
                    ErrorCause::Crc,
                    BitPlace::frame(Field::AckDelim, 0),
                    Some(frame.id()),
                    None,
                ),
                "(3600.000020) can0 ERROR FRAME after ACK delimiter of 123 (CRC error)",
            ),
            (
                BusEventKind::OverloadFrame {
                    at: BitPlace::Intermission(1),
                },
                "(3600.000020) can0 OVERLOAD FRAME in intermission bit 1",
            ),
            (
                BusEventKind::Incomplete {
                    at: BitPlace::frame(Field::Rtr, 0),
                    id: None,
                },
                "(3600.000020) can0 INCOMPLETE FRAME, input ends in RTR",
            ),
        ];
        for (kind, text) in cases {
            assert_eq!(line(kind), text);
        }
    }

    #[test]
    fn counts_by_kind() {
        let frame = std_frame(0x7E0, &[]);
        let mut wire = Wire::new();
        wire.frame(&frame, true);
        wire.flag(6);
        wire.frame(&frame, false);
        wire.repeat(RECESSIVE, 3);
        wire.play(wire_bits(&frame, true, 10));
        let counts = EventCounts::of(&wire.events());
        assert_eq!(
            counts,
            EventCounts {
                frames: 2,
                error_frames: 0,
                overload_frames: 1,
                incomplete: 1
            }
        );
        assert_eq!(
            counts.to_string(),
            "2 frames, 0 error frames, 1 overload frame, 1 incomplete frame"
        );
        let one_error = EventCounts {
            frames: 1,
            error_frames: 1,
            ..EventCounts::default()
        };
        assert_eq!(
            one_error.to_string(),
            "1 frame, 1 error frame, 0 overload frames"
        );
    }

    /// The first `n` wire bits of `frame`.
    fn wire_bits(frame: &Frame, acked: bool, n: usize) -> Vec<bool> {
        wire(frame, acked).bits[..n].iter().by_vals().collect()
    }

    #[test]
    fn an_hour_of_idle_before_a_frame() {
        let frame = Frame::remote(Id::Extended(7), 0).unwrap();
        let hour = 3_600 * FS_PER_S;
        let mut wire = Wire::with_timing(BIT_FS, SAMPLE_POINT, BIT_FS, hour);
        wire.frame(&frame, true);
        let events = wire.events();
        assert_eq!(events.len(), 1);
        assert_eq!(events[0].start_fs, hour);
        assert!(events[0]
            .to_string()
            .starts_with("(3600.000000) can0 00000007#R"));
    }

    fn arb_frame() -> impl Strategy<Value = Frame> {
        let id = prop_oneof![
            (0..=0x7FFu16).prop_map(Id::Standard),
            (0..=0x1FFF_FFFFu32).prop_map(Id::Extended),
        ];
        (id, 0..=MAX_DLC, any::<bool>(), any::<[u8; 8]>()).prop_map(|(id, dlc, remote, bytes)| {
            if remote {
                Frame::remote(id, dlc).unwrap()
            } else {
                Frame::data_with_dlc(id, dlc, &bytes[..data_len_for_dlc(dlc)]).unwrap()
            }
        })
    }

    proptest! {
        /// A transmitter up to 0.5 % off the nominal bit time, any start phase, any usual sample point:
        /// resynchronisation keeps every bit.
        #[test]
        fn frames_survive_clock_offsets(
            frames in proptest::collection::vec((arb_frame(), any::<bool>()), 1..6),
            skew_ppm in -5_000i64..=5_000,
            sample_point in 0.5f64..0.9,
            phase in 0..BIT_FS,
        ) {
            let tx_bit_fs = (BIT_FS as i64 + BIT_FS as i64 * skew_ppm / 1_000_000) as u64;
            let mut wire = Wire::with_timing(BIT_FS, sample_point, tx_bit_fs, phase);
            for (frame, acked) in &frames {
                wire.repeat(RECESSIVE, 1);
                wire.frame_and_intermission(frame, *acked);
            }
            let expected: Vec<_> = frames.iter().map(|(f, a)| received(*f, *a)).collect();
            prop_assert_eq!(wire.kinds(), expected);
        }
    }
}
