//! Does our bus decoder ([`sim::decode::bus_decoder`]) agree with sigrok's CAN decoder on a VCD? Both decode
//! the file; their frames are matched by the time of their SOF.
//!
//! sigrok's decoder (libsigrokdecode 0.5.3) checks nothing: no CRC, no stuff or form errors, no error
//! or overload frames; it starts a decode at any dominant level while idle, resynchronises fully on
//! every falling edge and reads a whole frame's worth of bits. The rule is therefore:
//!
//! * Every frame our decoder accepts, and every frame that an error interrupts only after its CRC (an
//!   ACK error, a form error in a delimiter or the EOF), sigrok decodes at the same SOF with the same
//!   identifier, kind and data (or, for the interrupted ones, decodes as no frame at all: with a
//!   dominant CRC delimiter it sometimes does). Exceptions ([`Exclusion`]): the frames sigrok cannot read (remote
//!   frames with DLC > 0, DLC above 8, a recessive reserved bit, which it reads as CAN FD's FDF), the
//!   frames in which our decoder noted an edge it did not synchronise on fully (sigrok does), and the
//!   frames sigrok misses because it is still reading a decode that is out of step.
//! * A sigrok decode is out of step unless it read one of our frames right. A decode that starts
//!   where our decoder saw no frame is allowed only on a glitch our decoder saw on the idle bus, inside
//!   our error and overload frames, or within [`RESTART_BITS`] of the end of an out-of-step decode
//!   (sigrok then waits for the next dominant level, which is inside whatever is on the bus).
//! * Anything else is a disagreement: a different frame, a frame one decoder has and the other lacks
//!   while sigrok is in step, a sigrok decode on a bus our decoder saw idle.
//!
//! The report counts the exclusions per reason and can list each.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use golden::frame::{Frame, MAX_DATA_LEN};
use sim::decode::bus_decoder::{BusEvent, BusEventKind, ErrorCause, RemarkKind};
use sim::decode::vcd_reader::{decode_vcd, DecodeOptions, VcdDecode};
use sim::engine::bus_timing::BusTiming;
use sim::engine::time::{FS_PER_S, FS_PER_US};

use crate::sigrok::{self, SigrokFrame};

/// Bits after the end of an out-of-step sigrok decode within which its next decode may start
/// anywhere on a busy bus: the longest run without a falling edge inside frames and flags (10 bits of
/// stuffing, or an error delimiter and intermission) plus one.
pub const RESTART_BITS: u64 = 12;
/// Largest SOF time difference of one frame in the two decoders, as a fraction of a bit.
const SOF_TOLERANCE: f64 = 0.25;

/// Why a frame or a decode was left out of the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Exclusion {
    /// A remote frame with DLC > 0: sigrok reads data bytes after its control field.
    RemoteWithDlc,
    /// A data frame with DLC 9..15: sigrok maps the DLC to a CAN FD length.
    DlcAbove8,
    /// A frame with a recessive reserved bit: sigrok reads r0 of a standard frame and r1 of an
    /// extended one as CAN FD's FDF bit.
    ReservedBitRecessive,
    /// A frame with an edge our decoder did not synchronise on fully (after a dominant sample, a
    /// second edge in a bit, a phase error beyond its SJW): sigrok resynchronises fully on each.
    UnusualEdge,
    /// A frame our decoder rejected before its CRC was complete (stuff, CRC or form error); sigrok
    /// reads on through the error flag.
    Rejected,
    /// A frame whose CRC our decoder received complete and right, interrupted at its CRC delimiter
    /// or later, of which sigrok decodes no frame (seen when the CRC delimiter is dominant: forced
    /// so, or an error flag starting there); neither decoder delivers it.
    UndecodedAfterCrc,
    /// The input ends inside the frame.
    Incomplete,
    /// A sigrok decode that starts on a glitch our decoder saw end before the sample point.
    GlitchReadAsFrame,
    /// A sigrok decode that starts on an error or overload flag.
    FlagReadAsFrame,
    /// A sigrok decode that starts right after an out-of-step decode.
    OutOfStep,
    /// A frame of ours that sigrok missed while reading an out-of-step decode.
    MissedWhileOutOfStep,
}

impl fmt::Display for Exclusion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Exclusion::RemoteWithDlc => "remote frames with DLC > 0 (sigrok limit)",
            Exclusion::DlcAbove8 => "frames with DLC > 8 (sigrok limit)",
            Exclusion::ReservedBitRecessive => {
                "frames with a recessive reserved bit (sigrok reads it as CAN FD's FDF)"
            }
            Exclusion::UnusualEdge => {
                "frames with an edge we follow partly or not (sigrok resynchronises fully)"
            }
            Exclusion::Rejected => "frames we rejected before their CRC ended (sigrok reads on)",
            Exclusion::UndecodedAfterCrc => {
                "frames interrupted after their CRC that sigrok decodes as no frame"
            }
            Exclusion::Incomplete => "frames cut by the end of the file",
            Exclusion::GlitchReadAsFrame => "sigrok decodes starting on an idle-bus glitch",
            Exclusion::FlagReadAsFrame => "sigrok decodes starting on an error or overload flag",
            Exclusion::OutOfStep => "sigrok decodes out of step after such a decode",
            Exclusion::MissedWhileOutOfStep => "frames sigrok missed while out of step",
        })
    }
}

/// One exclusion applied: why, when, and the frame or decode it concerns.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Excluded {
    /// Why.
    pub why: Exclusion,
    /// The SOF of the frame or decode.
    pub t_fs: u64,
    /// The frame (candump notation) or a description.
    pub what: String,
}

/// The comparison of one file.
#[derive(Clone, Debug, PartialEq)]
pub struct Agreement {
    /// The file.
    pub path: PathBuf,
    /// The bus timing both decoders used.
    pub timing: BusTiming,
    /// Frames both decoders decoded identically at the same SOF.
    pub agreed: usize,
    /// Every exclusion applied, in time order.
    pub exclusions: Vec<Excluded>,
    /// Every disagreement, described.
    pub disagreements: Vec<String>,
}

impl Agreement {
    /// Whether the decoders agree on the file.
    pub fn agrees(&self) -> bool {
        self.disagreements.is_empty()
    }

    /// How many times each exclusion was applied.
    pub fn counts(&self) -> BTreeMap<Exclusion, usize> {
        let mut counts = BTreeMap::new();
        for e in &self.exclusions {
            *counts.entry(e.why).or_default() += 1;
        }
        counts
    }

    /// How many times `exclusion` was applied.
    pub fn excluded(&self, exclusion: Exclusion) -> usize {
        self.exclusions
            .iter()
            .filter(|e| e.why == exclusion)
            .count()
    }

    /// One line per exclusion: `  0.000207 s 00000000#RB: remote frames with DLC > 0 (sigrok limit)`.
    pub fn details(&self) -> String {
        self.exclusions
            .iter()
            .map(|e| format!("  {} {}: {}\n", at(e.t_fs), e.what, e.why))
            .collect()
    }
}

impl fmt::Display for Agreement {
    /// `waves/x.vcd (500000 bit/s, sample point 87.5 %): 12 frames agree; excluded: 2 …; 1 …`, then
    /// one line per disagreement.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} ({}): {} frames agree",
            self.path.display(),
            self.timing,
            self.agreed
        )?;
        let excluded: Vec<String> = self
            .counts()
            .iter()
            .map(|(why, n)| format!("{n} {why}"))
            .collect();
        if !excluded.is_empty() {
            write!(f, "; excluded: {}", excluded.join("; "))?;
        }
        for disagreement in &self.disagreements {
            write!(f, "\n  DISAGREEMENT: {disagreement}")?;
        }
        Ok(())
    }
}

/// Decodes `path` with both decoders (the timing the file records, else the defaults) and compares
/// them; an error if our decoder cannot read the file. Panics if sigrok-cli fails on it.
pub fn check_vcd(path: &Path) -> Result<Agreement, String> {
    let ours = decode_vcd(path, &DecodeOptions::default()).map_err(|e| e.to_string())?;
    let signal = ours.signal.rsplit('.').next().unwrap_or(&ours.signal);
    let timing = ours.timing;
    let decodes = sigrok::decode_frames(
        path,
        signal,
        timing.bitrate().round() as u32,
        timing.sample_point * 100.0,
    );
    Ok(compare(path, &ours, &decodes))
}

/// Compares our decode of `path` with sigrok's decodes of it (sample numbers in the VCD's time unit,
/// counted from time 0).
pub fn compare(path: &Path, ours: &VcdDecode, decodes: &[SigrokFrame]) -> Agreement {
    let mut comparison = Comparison::new(ours, decodes);
    comparison.run();
    comparison.exclusions.sort_by_key(|e| e.t_fs);
    Agreement {
        path: path.to_path_buf(),
        timing: ours.timing,
        agreed: comparison.agreed,
        exclusions: comparison.exclusions,
        disagreements: comparison.disagreements,
    }
}

/// What our decoder saw start at an SOF.
#[derive(Clone, Copy, Debug)]
enum OurFrame<'a> {
    /// A valid frame.
    Valid(&'a Frame),
    /// A frame an error interrupted; with its content when the error came after the CRC.
    Interrupted(ErrorCause, Option<&'a Frame>),
    /// A frame the input cut.
    Incomplete,
}

/// One of our frames: SOF time, end time (of the error frame, for an interrupted one), what it is.
#[derive(Clone, Copy, Debug)]
struct Ours<'a> {
    sof_fs: u64,
    end_fs: u64,
    frame: OurFrame<'a>,
}

impl<'a> Ours<'a> {
    /// The frame's content, or the exclusion for a frame without one.
    fn content(&self) -> Result<(&'a Frame, Option<ErrorCause>), (Exclusion, String)> {
        match self.frame {
            OurFrame::Valid(f) => Ok((f, None)),
            OurFrame::Interrupted(cause, Some(f)) => Ok((f, Some(cause))),
            OurFrame::Interrupted(cause, None) => {
                Err((Exclusion::Rejected, format!("a frame with a {cause}")))
            }
            OurFrame::Incomplete => Err((Exclusion::Incomplete, "a cut frame".into())),
        }
    }
}

/// Our frames, valid or not, in bus order.
fn our_frames(events: &[BusEvent]) -> Vec<Ours<'_>> {
    events
        .iter()
        .filter_map(|e| {
            let (sof_fs, frame) = match &e.kind {
                BusEventKind::Frame { frame, .. } => (e.start_fs, OurFrame::Valid(frame)),
                BusEventKind::ErrorFrame {
                    cause,
                    frame,
                    sof_fs: Some(sof),
                    ..
                } => (*sof, OurFrame::Interrupted(*cause, frame.as_ref())),
                BusEventKind::Incomplete { .. } => (e.start_fs, OurFrame::Incomplete),
                _ => return None,
            };
            Some(Ours {
                sof_fs,
                end_fs: e.end_fs,
                frame,
            })
        })
        .collect()
}

/// The sigrok limit that makes it misread `frame`, if any.
fn sigrok_limit(frame: &Frame) -> Option<Exclusion> {
    if frame.is_remote() && frame.dlc() > 0 {
        Some(Exclusion::RemoteWithDlc)
    } else if usize::from(frame.dlc()) > MAX_DATA_LEN {
        Some(Exclusion::DlcAbove8)
    } else {
        None
    }
}

/// Seconds with microseconds, as in the decoders' logs.
fn at(t_fs: u64) -> String {
    format!("{}.{:06} s", t_fs / FS_PER_S, t_fs % FS_PER_S / FS_PER_US)
}

/// A sigrok decode in femtoseconds.
#[derive(Clone, Copy, Debug)]
struct Decode<'a> {
    start: u64,
    end: Option<u64>,
    frame: Option<&'a str>,
}

struct Comparison<'a> {
    ours: &'a VcdDecode,
    frames: Vec<Ours<'a>>,
    decodes: Vec<Decode<'a>>,
    tolerance_fs: u64,
    agreed: usize,
    exclusions: Vec<Excluded>,
    disagreements: Vec<String>,
}

impl<'a> Comparison<'a> {
    fn new(ours: &'a VcdDecode, decodes: &'a [SigrokFrame]) -> Comparison<'a> {
        let unit = ours.timescale_fs;
        Comparison {
            ours,
            frames: our_frames(&ours.events),
            decodes: decodes
                .iter()
                .map(|d| Decode {
                    start: d.start * unit,
                    end: d.end.map(|e| e * unit),
                    frame: d.frame.as_deref(),
                })
                .collect(),
            tolerance_fs: (ours.timing.bit_time_fs as f64 * SOF_TOLERANCE) as u64,
            agreed: 0,
            exclusions: Vec::new(),
            disagreements: Vec::new(),
        }
    }

    fn exclude(&mut self, why: Exclusion, t_fs: u64, what: impl Into<String>) {
        self.exclusions.push(Excluded {
            why,
            t_fs,
            what: what.into(),
        });
    }

    /// Our frame whose SOF is within the tolerance of `t_fs`.
    fn frame_at(&self, t_fs: u64) -> Option<Ours<'a>> {
        self.frames
            .iter()
            .copied()
            .find(|f| f.sof_fs.abs_diff(t_fs) <= self.tolerance_fs)
    }

    /// The exclusion that a remark of our decoder inside `frame` explains a sigrok misreading with.
    fn remark_in(&self, frame: &Ours<'_>) -> Option<Exclusion> {
        let inside = self
            .ours
            .remarks
            .iter()
            .filter(|r| (frame.sof_fs..=frame.end_fs).contains(&r.t_fs));
        inside
            .filter_map(|r| match r.kind {
                RemarkKind::ReservedBitRecessive(_) => Some(Exclusion::ReservedBitRecessive),
                RemarkKind::IgnoredEdge | RemarkKind::PhaseErrorBeyondSjw { .. } => {
                    Some(Exclusion::UnusualEdge)
                }
                RemarkKind::SofGlitch => None,
            })
            .min()
    }

    /// Whether our decoder saw a glitch on the idle bus at `t_fs`.
    fn glitch_at(&self, t_fs: u64) -> bool {
        self.ours
            .remarks
            .iter()
            .any(|r| r.kind == RemarkKind::SofGlitch && r.t_fs.abs_diff(t_fs) <= self.tolerance_fs)
    }

    /// Whether `t_fs` is inside an error or overload frame of ours.
    fn in_flag(&self, t_fs: u64) -> bool {
        self.ours.events.iter().any(|e| {
            matches!(
                e.kind,
                BusEventKind::ErrorFrame { .. } | BusEventKind::OverloadFrame { .. }
            ) && e.start_fs <= t_fs + self.tolerance_fs
                && t_fs <= e.end_fs
        })
    }

    fn run(&mut self) {
        let restart_fs = RESTART_BITS * self.ours.timing.bit_time_fs;
        let mut matched = Vec::new();
        let mut in_step = Vec::new();
        // The end of the previous decode, if it was out of step (`None` inside: it never ended).
        let mut out_of_step_end: Option<Option<u64>> = None;
        for index in 0..self.decodes.len() {
            let decode = self.decodes[index];
            let step = match self.frame_at(decode.start) {
                Some(frame) => {
                    matched.push(frame.sof_fs);
                    self.aligned(&decode, &frame)
                }
                None => {
                    let restarted = out_of_step_end
                        .is_some_and(|end| end.is_none_or(|e| decode.start <= e + restart_fs));
                    self.unaligned(&decode, restarted);
                    false
                }
            };
            out_of_step_end = (!step).then_some(decode.end);
            in_step.push(step);
        }
        self.unmatched(&matched, &in_step);
    }

    /// A sigrok decode at the SOF of our frame `ours`; returns whether sigrok read it right.
    fn aligned(&mut self, decode: &Decode<'_>, ours: &Ours<'a>) -> bool {
        let (content, error) = match ours.content() {
            Ok(content) => content,
            Err((why, what)) => {
                self.exclude(why, ours.sof_fs, what);
                return false;
            }
        };
        let expected = content.to_string();
        if let Some(limit) = sigrok_limit(content) {
            self.exclude(limit, ours.sof_fs, expected);
            return false;
        }
        if decode.frame == Some(expected.as_str()) {
            self.agreed += 1;
            // After an error past the CRC, sigrok's EOF runs into the flag.
            return error.is_none();
        }
        if let Some(why) = self.remark_in(ours) {
            self.exclude(why, ours.sof_fs, expected);
            return false;
        }
        if error.is_some() && decode.frame.is_none() {
            self.exclude(Exclusion::UndecodedAfterCrc, ours.sof_fs, expected);
            return false;
        }
        let then = error
            .map(|cause| format!(" (then a {cause})"))
            .unwrap_or_default();
        self.disagreements.push(format!(
            "at {} our decoder reads {expected}{then}, sigrok {}",
            at(ours.sof_fs),
            decode.frame.unwrap_or("no frame")
        ));
        false
    }

    /// A sigrok decode where our decoder saw no SOF; `restarted`: right after an out-of-step decode.
    fn unaligned(&mut self, decode: &Decode<'_>, restarted: bool) {
        let what = decode.frame.unwrap_or("a decode without frame");
        let why = if self.glitch_at(decode.start) {
            Exclusion::GlitchReadAsFrame
        } else if self.in_flag(decode.start) {
            Exclusion::FlagReadAsFrame
        } else if restarted {
            Exclusion::OutOfStep
        } else {
            self.disagreements.push(format!(
                "sigrok decodes {what} at {} where our decoder saw no frame",
                at(decode.start)
            ));
            return;
        };
        self.exclude(why, decode.start, what);
    }

    /// Our frames that no sigrok decode started at; `in_step` tells for each decode whether it was.
    fn unmatched(&mut self, matched: &[u64], in_step: &[bool]) {
        let missing: Vec<Ours<'a>> = self
            .frames
            .iter()
            .copied()
            .filter(|f| !matched.contains(&f.sof_fs))
            .collect();
        for ours in missing {
            let sof = ours.sof_fs;
            let content = match ours.content() {
                Ok((content, _)) => content,
                Err((why, what)) => {
                    self.exclude(why, sof, what);
                    continue;
                }
            };
            let busy = self
                .decodes
                .iter()
                .zip(in_step)
                .any(|(d, &step)| !step && d.start < sof && d.end.is_none_or(|end| sof < end));
            if busy {
                self.exclude(Exclusion::MissedWhileOutOfStep, sof, content.to_string());
            } else {
                self.disagreements.push(format!(
                    "sigrok misses {content} at {} (sigrok idle there)",
                    at(sof)
                ));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use golden::frame::{encode, Field, Id, DOMINANT, RECESSIVE};
    use sim::decode::bus_decoder::BusDecoder;
    use sim::engine::time::FS_PER_NS;

    /// 500 kbit/s, 2000 ns a bit.
    const BIT_NS: u64 = 2000;

    /// A bus: wire levels one bit each from 10 idle bits on, and where each frame started (ns).
    #[derive(Default)]
    struct Bus {
        levels: Vec<bool>,
        sofs: Vec<u64>,
    }

    impl Bus {
        fn new() -> Bus {
            Bus {
                levels: vec![RECESSIVE; 10],
                sofs: Vec::new(),
            }
        }

        /// `frame`, acknowledged, then 3 intermission bits and `idle` more.
        fn frame(&mut self, frame: &Frame, idle: usize) -> &mut Bus {
            self.sofs.push(self.levels.len() as u64 * BIT_NS);
            let encoded = encode(frame);
            let mut bits: Vec<bool> = encoded.bits.iter().by_vals().collect();
            bits[encoded.position(Field::AckSlot, 0).unwrap()] = DOMINANT;
            self.levels.extend(bits);
            self.levels.extend(vec![RECESSIVE; 3 + idle]);
            self
        }

        /// `frame` cut by an error flag at wire bit `at`, then the delimiter and intermission.
        fn flagged(&mut self, frame: &Frame, at: usize) -> &mut Bus {
            self.sofs.push(self.levels.len() as u64 * BIT_NS);
            self.levels
                .extend(encode(frame).bits.iter().by_vals().take(at));
            self.levels.extend([DOMINANT; 6]);
            self.levels.extend([RECESSIVE; 11]);
            self
        }

        /// Our decoder's view, as `decode_vcd` gives it for a 1 ns VCD.
        fn ours(&self) -> VcdDecode {
            let timing = BusTiming::from_bitrate(500_000.0, 0.875).unwrap();
            let mut decoder = BusDecoder::with_timing(timing);
            for (i, &level) in self.levels.iter().enumerate() {
                decoder.level(i as u64 * BIT_NS * FS_PER_NS, level);
            }
            let end_fs = self.levels.len() as u64 * BIT_NS * FS_PER_NS;
            decoder.finish(end_fs);
            VcdDecode {
                signal: "top.bus".into(),
                timing,
                file_timing: Some(timing),
                undefined_values: 0,
                timescale_fs: FS_PER_NS,
                end_fs,
                events: decoder.drain(),
                remarks: decoder.drain_remarks(),
            }
        }
    }

    fn std(id: u16, data: &[u8]) -> Frame {
        Frame::data(Id::Standard(id), data).unwrap()
    }

    /// A sigrok decode from `start` ns, `bits` long, with `frame`.
    fn decode(start: u64, bits: u64, frame: Option<&str>) -> SigrokFrame {
        SigrokFrame {
            start,
            end: Some(start + bits * BIT_NS),
            frame: frame.map(str::to_string),
        }
    }

    fn check(bus: &Bus, decodes: &[SigrokFrame]) -> Agreement {
        compare(Path::new("bus.vcd"), &bus.ours(), decodes)
    }

    #[test]
    fn same_frames_agree_and_any_difference_disagrees() {
        let (a, b) = (std(0x123, &[1, 2]), std(0x456, &[]));
        let mut bus = Bus::new();
        bus.frame(&a, 5).frame(&b, 5);
        let [sa, sb] = [bus.sofs[0], bus.sofs[1]];
        let agreement = check(
            &bus,
            &[
                decode(sa + 1, 60, Some("123#0102")),
                decode(sb, 44, Some("456#")),
            ],
        );
        assert!(agreement.agrees(), "{agreement}");
        assert_eq!((agreement.agreed, agreement.exclusions.len()), (2, 0));
        assert_eq!(
            agreement.to_string(),
            "bus.vcd (500000 bit/s, sample point 87.5 %): 2 frames agree"
        );

        let other_data = check(
            &bus,
            &[
                decode(sa, 60, Some("123#0103")),
                decode(sb, 44, Some("456#")),
            ],
        );
        assert_eq!(
            other_data.disagreements,
            ["at 0.000020 s our decoder reads 123#0102, sigrok 123#0103"]
        );
        let missed = check(&bus, &[decode(sb, 44, Some("456#"))]);
        assert_eq!(
            missed.disagreements,
            ["sigrok misses 123#0102 at 0.000020 s (sigrok idle there)"]
        );
        let extra = check(
            &bus,
            &[
                decode(2 * BIT_NS, 40, Some("7FF#")),
                decode(sa, 60, Some("123#0102")),
                decode(sb, 44, Some("456#")),
            ],
        );
        assert_eq!(
            extra.disagreements,
            ["sigrok decodes 7FF# at 0.000004 s where our decoder saw no frame"]
        );
    }

    #[test]
    fn sigrok_limits_and_out_of_step_decodes_are_excluded_and_listed() {
        // A remote frame with DLC 8: sigrok reads 64 data bits that are not there, past the next SOF,
        // restarts inside the next frame and misses it.
        let (remote, next, last) = (
            Frame::remote(Id::Standard(0x100), 8).unwrap(),
            std(0x200, &[0xAA]),
            std(0x300, &[]),
        );
        let mut bus = Bus::new();
        bus.frame(&remote, 0).frame(&next, 60).frame(&last, 0);
        let [s0, s1, s2] = [bus.sofs[0], bus.sofs[1], bus.sofs[2]];
        let agreement = check(
            &bus,
            &[
                decode(s0, 110, Some("100#R")),
                decode(s0 + 112 * BIT_NS, 40, None),
                decode(s2, 44, Some("300#")),
            ],
        );
        assert!(agreement.agrees(), "{agreement}");
        assert_eq!(agreement.agreed, 1);
        assert_eq!(agreement.excluded(Exclusion::RemoteWithDlc), 1);
        assert_eq!(agreement.excluded(Exclusion::OutOfStep), 1);
        assert_eq!(agreement.excluded(Exclusion::MissedWhileOutOfStep), 1);
        assert!(s1 < s0 + 110 * BIT_NS, "the next SOF is inside the decode");
        assert_eq!(
            agreement.details(),
            format!(
                "  0.000020 s 100#R8: remote frames with DLC > 0 (sigrok limit)\n  \
                 {} 200#AA: frames sigrok missed while out of step\n  \
                 {} a decode without frame: sigrok decodes out of step after such a decode\n",
                at(s1 * FS_PER_NS),
                at((s0 + 112 * BIT_NS) * FS_PER_NS)
            )
        );
        // Further from the out-of-step decode, on the idle bus, a decode disagrees.
        let idle = s0 + (110 + RESTART_BITS + 1) * BIT_NS;
        assert!(idle + 20 * BIT_NS < s2, "idle until the last frame");
        let late = check(
            &bus,
            &[
                decode(s0, 110, Some("100#R")),
                decode(idle, 20, None),
                decode(s2, 44, Some("300#")),
            ],
        );
        assert_eq!(
            late.disagreements,
            [format!(
                "sigrok decodes a decode without frame at {} where our decoder saw no frame",
                at(idle * FS_PER_NS)
            )]
        );
    }

    #[test]
    fn a_frame_interrupted_after_its_crc_may_be_no_frame_for_sigrok_but_not_another_frame() {
        let frame = std(0x2A5, &[0x96]);
        let mut bus = Bus::new();
        let delimiter = encode(&frame).position(Field::CrcDelim, 0).unwrap();
        bus.flagged(&frame, delimiter);
        let s0 = bus.sofs[0];
        let none = check(&bus, &[decode(s0, 40, None)]);
        assert!(none.agrees(), "{none}");
        assert_eq!(none.excluded(Exclusion::UndecodedAfterCrc), 1);
        let other = check(&bus, &[decode(s0, 40, Some("2A5#97"))]);
        assert!(!other.agrees(), "another frame is a disagreement");
    }

    #[test]
    fn error_flags_read_as_frames_are_excluded() {
        let (cut, retry) = (std(0x555, &[0xAA]), std(0x555, &[0xAA]));
        let mut bus = Bus::new();
        bus.flagged(&cut, 25).frame(&retry, 0);
        let [s0, s1] = [bus.sofs[0], bus.sofs[1]];
        // sigrok reads the cut frame on through the flag; the flag's end and delimiter make no frame.
        let agreement = check(
            &bus,
            &[
                decode(s0, 40, Some("555#00")),
                decode(s1, 60, Some("555#AA")),
            ],
        );
        assert!(agreement.agrees(), "{agreement}");
        assert_eq!(agreement.agreed, 1);
        assert_eq!(agreement.excluded(Exclusion::Rejected), 1);
        // A decode starting inside the error flag.
        let in_flag = check(
            &bus,
            &[
                decode(s0 + 32 * BIT_NS, 8, None),
                decode(s1, 60, Some("555#AA")),
            ],
        );
        assert!(in_flag.agrees(), "{in_flag}");
        assert_eq!(in_flag.excluded(Exclusion::FlagReadAsFrame), 1);
        assert_eq!(in_flag.excluded(Exclusion::Rejected), 1);
    }
}
