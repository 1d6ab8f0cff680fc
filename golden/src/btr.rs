//! SJA1000 bit-timing registers (BTR0/BTR1) and a bit-timing calculator.
//!
//! # Register layout (SJA1000 data sheet)
//!
//! * `BTR0 = SJW(7..6) BRP(5..0)`
//! * `BTR1 = SAM(7) TSEG2(6..4) TSEG1(3..0)`
//!
//! Every field holds "length − 1": the time quantum is `tq = 2·(BRP+1)·t_CLK`, the synchronisation
//! segment is 1 tq, TSEG1 is `TSEG1+1` tq, TSEG2 is `TSEG2+1` tq and the resynchronisation jump
//! width is `SJW+1` tq. The sample point lies at the end of TSEG1; with `SAM = 1` the bus is sampled
//! three times and a majority vote is taken.
//!
//! # Calculator
//!
//! [`calc_bittiming`] chooses a register pair for a requested bit rate with the search method used by
//! the Linux SocketCAN `can_calc_bittiming` helper (re-implemented here from its description), applied
//! to this chip's constants: CAN clock = controller clock / 2, TSEG1 1..=16 tq, TSEG2 1..=8 tq,
//! SJW ≤ 4 tq, prescaler 1..=64 in steps of 1, sync segment 1 tq.
#![warn(missing_docs)]

use std::fmt;

/// Length of the synchronisation segment in time quanta.
const SYNC_SEG_TQ: u32 = 1;
/// Shortest TSEG1 in tq.
const TSEG1_MIN: u32 = 1;
/// Longest TSEG1 in tq.
const TSEG1_MAX: u32 = 16;
/// Shortest TSEG2 in tq.
const TSEG2_MIN: u32 = 1;
/// Longest TSEG2 in tq.
const TSEG2_MAX: u32 = 8;
/// Longest SJW in tq.
const SJW_MAX: u32 = 4;
/// Smallest prescaler (BTR0.BRP + 1).
const BRP_MIN: u64 = 1;
/// Largest prescaler (BTR0.BRP + 1).
const BRP_MAX: u64 = 64;
/// Prescaler step.
const BRP_INC: u64 = 1;

/// A bit-timing field of the SJA1000, used to name the culprit in a [`BitTimingError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BtrField {
    /// Baud-rate prescaler, BTR0 bits 5..0.
    Brp,
    /// Synchronisation jump width, BTR0 bits 7..6.
    Sjw,
    /// Time segment 1, BTR1 bits 3..0.
    Tseg1,
    /// Time segment 2, BTR1 bits 6..4.
    Tseg2,
}

impl BtrField {
    /// Largest value the register field can hold.
    pub fn field_max(self) -> u32 {
        match self {
            BtrField::Brp => 63,
            BtrField::Sjw => 3,
            BtrField::Tseg1 => 15,
            BtrField::Tseg2 => 7,
        }
    }
}

impl fmt::Display for BtrField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BtrField::Brp => "BRP",
            BtrField::Sjw => "SJW",
            BtrField::Tseg1 => "TSEG1",
            BtrField::Tseg2 => "TSEG2",
        })
    }
}

/// Errors of the register constructors and of the calculator.
#[derive(Clone, Debug, PartialEq)]
pub enum BitTimingError {
    /// The controller clock is 0 Hz.
    ZeroClock,
    /// The requested bit rate is 0 bit/s.
    ZeroBitrate,
    /// The requested sample point (a fraction) is not strictly between 0 and 1, or does not round to
    /// a value between 0.1 % and 99.9 %.
    SamplePointOutOfRange(f64),
    /// The requested SJW is not 1..=4 tq.
    SjwOutOfRange(u32),
    /// The requested SJW is longer than the TSEG2 the calculator chose.
    SjwExceedsTseg2 {
        /// Requested SJW in tq.
        sjw_tq: u32,
        /// TSEG2 of the chosen timing in tq.
        tseg2_tq: u32,
    },
    /// A raw register field value is larger than the field can hold (fields are `0..=max`).
    FieldOutOfRange {
        /// The field.
        field: BtrField,
        /// The rejected value.
        value: u32,
    },
    /// A segment length in tq (or the prescaler field for [`Btr::from_quanta`]) is outside what
    /// the chip can be programmed to.
    LengthOutOfRange {
        /// The field.
        field: BtrField,
        /// The rejected length in tq.
        tq: u32,
        /// Shortest allowed length in tq.
        min: u32,
        /// Longest allowed length in tq.
        max: u32,
    },
    /// No register setting comes within 5 % of the requested bit rate.
    Impossible {
        /// Controller clock in Hz.
        clock_hz: u32,
        /// Requested bit rate in bit/s.
        bitrate: u32,
        /// The achievable bit rate nearest to the request, in bit/s.
        closest_bitrate: f64,
    },
}

/// Formats a bit rate: integral rates without decimals, others with three.
fn fmt_rate(rate: f64) -> String {
    if (rate - rate.round()).abs() < 1e-6 {
        format!("{:.0}", rate)
    } else {
        format!("{:.3}", rate)
    }
}

impl fmt::Display for BitTimingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BitTimingError::ZeroClock => write!(f, "the controller clock must not be 0 Hz"),
            BitTimingError::ZeroBitrate => write!(f, "the bit rate must not be 0 bit/s"),
            BitTimingError::SamplePointOutOfRange(sp) => write!(
                f,
                "sample point {sp} is out of range: it must be a fraction strictly between 0 and 1 \
                 (0.001..=0.999, e.g. 0.875 for 87.5 %)"
            ),
            BitTimingError::SjwOutOfRange(sjw) => {
                write!(
                    f,
                    "SJW {sjw} tq is out of range: the SJA1000 allows 1..=4 tq"
                )
            }
            BitTimingError::SjwExceedsTseg2 { sjw_tq, tseg2_tq } => write!(
                f,
                "SJW {sjw_tq} tq is longer than TSEG2 ({tseg2_tq} tq) of the chosen timing"
            ),
            BitTimingError::FieldOutOfRange { field, value } => write!(
                f,
                "{field} field value {value} is out of range: the register field holds 0..={}",
                field.field_max()
            ),
            BitTimingError::LengthOutOfRange {
                field,
                tq,
                min,
                max,
            } => {
                if *field == BtrField::Brp {
                    write!(
                        f,
                        "BRP field value {tq} is out of range: allowed {min}..={max}"
                    )
                } else {
                    write!(
                        f,
                        "{field} length {tq} tq is out of range: allowed {min}..={max} tq"
                    )
                }
            }
            BitTimingError::Impossible {
                clock_hz,
                bitrate,
                closest_bitrate,
            } => {
                let err = (closest_bitrate - *bitrate as f64) / *bitrate as f64 * 100.0;
                write!(
                    f,
                    "bitrate {bitrate} is impossible with a {clock_hz} Hz clock (closest: {} bit/s, \
                     {err:+.2} %; at most 5 % error is accepted)",
                    fmt_rate(*closest_bitrate)
                )
            }
        }
    }
}

impl std::error::Error for BitTimingError {}

/// An advisory finding of [`Btr::validate`]: the chip accepts the setting, but it is outside what
/// CAN 2.0 / ISO 11898-1 recommends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BtrWarning {
    /// SJW is longer than TSEG1 or TSEG2; a resynchronisation can then never use all of it.
    SjwExceedsSegment {
        /// SJW in tq.
        sjw_tq: u32,
        /// TSEG1 in tq.
        tseg1_tq: u32,
        /// TSEG2 in tq.
        tseg2_tq: u32,
    },
    /// TSEG2 is shorter than the 2 tq information processing time of CAN 2.0.
    Tseg2BelowIpt {
        /// TSEG2 in tq.
        tseg2_tq: u32,
    },
    /// TSEG1 is shorter than 2 tq, so it cannot hold both a propagation and a phase segment.
    Tseg1TooShort {
        /// TSEG1 in tq.
        tseg1_tq: u32,
    },
    /// The bit has fewer than 8 or more than 25 time quanta (CAN 2.0 range).
    QuantaOutOfRange {
        /// Quanta per bit.
        quanta: u32,
    },
}

impl fmt::Display for BtrWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BtrWarning::SjwExceedsSegment {
                sjw_tq,
                tseg1_tq,
                tseg2_tq,
            } => write!(
                f,
                "SJW {sjw_tq} tq exceeds min(TSEG1 {tseg1_tq} tq, TSEG2 {tseg2_tq} tq)"
            ),
            BtrWarning::Tseg2BelowIpt { tseg2_tq } => write!(
                f,
                "TSEG2 {tseg2_tq} tq is shorter than the 2 tq information processing time"
            ),
            BtrWarning::Tseg1TooShort { tseg1_tq } => write!(
                f,
                "TSEG1 {tseg1_tq} tq leaves no room for both propagation and phase segment 1"
            ),
            BtrWarning::QuantaOutOfRange { quanta } => {
                write!(f, "{quanta} tq per bit is outside the CAN 2.0 range 8..=25")
            }
        }
    }
}

/// SJA1000 bit timing: BTR0 = SJW(7..6) BRP(5..0); BTR1 = SAM(7) TSEG2(6..4) TSEG1(3..0).
///
/// The fields hold the raw register values ("length − 1"). They are public; a value wider than its
/// register field is truncated to the field width (as the register would) by [`Btr::btr0`],
/// [`Btr::btr1`] and all derived quantities, so a `Btr` always behaves like
/// `Btr::from_registers(b.btr0(), b.btr1())`. Use [`Btr::new`] or [`Btr::from_quanta`] for checked
/// construction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Btr {
    /// Baud-rate prescaler field, 0..=63 (prescaler = `brp + 1`).
    pub brp: u8,
    /// Synchronisation jump width field, 0..=3 (SJW = `sjw + 1` tq).
    pub sjw: u8,
    /// Time segment 1 field, 0..=15 (TSEG1 = `tseg1 + 1` tq).
    pub tseg1: u8,
    /// Time segment 2 field, 0..=7 (TSEG2 = `tseg2 + 1` tq).
    pub tseg2: u8,
    /// Triple sampling (BTR1 bit 7).
    pub sam: bool,
}

impl Btr {
    /// Decodes a register pair. Every pair is valid.
    pub fn from_registers(btr0: u8, btr1: u8) -> Btr {
        Btr {
            brp: btr0 & 0x3F,
            sjw: btr0 >> 6,
            tseg1: btr1 & 0x0F,
            tseg2: (btr1 >> 4) & 0x07,
            sam: btr1 & 0x80 != 0,
        }
    }

    /// Builds a timing from raw FIELD values (BRP 0..=63, TSEG1 0..=15, TSEG2 0..=7, SJW 0..=3).
    ///
    /// Out-of-range values give [`BitTimingError::FieldOutOfRange`] naming the field and value.
    pub fn new(brp: u8, tseg1: u8, tseg2: u8, sjw: u8, sam: bool) -> Result<Btr, BitTimingError> {
        for (field, value) in [
            (BtrField::Brp, brp),
            (BtrField::Tseg1, tseg1),
            (BtrField::Tseg2, tseg2),
            (BtrField::Sjw, sjw),
        ] {
            if u32::from(value) > field.field_max() {
                return Err(BitTimingError::FieldOutOfRange {
                    field,
                    value: value.into(),
                });
            }
        }
        Ok(Btr {
            brp,
            sjw,
            tseg1,
            tseg2,
            sam,
        })
    }

    /// Builds a timing from the BRP field (0..=63) and segment lengths in time quanta
    /// (TSEG1 1..=16, TSEG2 1..=8, SJW 1..=4).
    ///
    /// SJW longer than TSEG1 or TSEG2 is accepted, as the chip accepts it; [`Btr::validate`]
    /// reports it.
    pub fn from_quanta(
        brp_field: u8,
        tseg1_tq: u32,
        tseg2_tq: u32,
        sjw_tq: u32,
        sam: bool,
    ) -> Result<Btr, BitTimingError> {
        if u32::from(brp_field) > BtrField::Brp.field_max() {
            return Err(BitTimingError::LengthOutOfRange {
                field: BtrField::Brp,
                tq: brp_field.into(),
                min: 0,
                max: BtrField::Brp.field_max(),
            });
        }
        for (field, tq, max) in [
            (BtrField::Tseg1, tseg1_tq, TSEG1_MAX),
            (BtrField::Tseg2, tseg2_tq, TSEG2_MAX),
            (BtrField::Sjw, sjw_tq, SJW_MAX),
        ] {
            if !(1..=max).contains(&tq) {
                return Err(BitTimingError::LengthOutOfRange {
                    field,
                    tq,
                    min: 1,
                    max,
                });
            }
        }
        // The lengths are checked to be 1..=16 and fit a u8 after subtracting 1.
        Ok(Btr {
            brp: brp_field,
            sjw: (sjw_tq - 1) as u8,
            tseg1: (tseg1_tq - 1) as u8,
            tseg2: (tseg2_tq - 1) as u8,
            sam,
        })
    }

    /// BTR0 register value: `SJW << 6 | BRP`.
    pub fn btr0(&self) -> u8 {
        ((self.sjw & 0x03) << 6) | (self.brp & 0x3F)
    }

    /// BTR1 register value: `SAM << 7 | TSEG2 << 4 | TSEG1`.
    pub fn btr1(&self) -> u8 {
        (u8::from(self.sam) << 7) | ((self.tseg2 & 0x07) << 4) | (self.tseg1 & 0x0F)
    }

    /// Controller clock periods per time quantum: `2·(BRP+1)`.
    pub fn clocks_per_tq(&self) -> u32 {
        2 * (u32::from(self.brp & 0x3F) + 1)
    }

    /// Length of TSEG1 in tq (field + 1).
    pub fn tseg1_tq(&self) -> u32 {
        u32::from(self.tseg1 & 0x0F) + 1
    }

    /// Length of TSEG2 in tq (field + 1).
    pub fn tseg2_tq(&self) -> u32 {
        u32::from(self.tseg2 & 0x07) + 1
    }

    /// Resynchronisation jump width in tq (field + 1).
    pub fn sjw_tq(&self) -> u32 {
        u32::from(self.sjw & 0x03) + 1
    }

    /// Time quanta per bit: `1 (sync) + TSEG1 + TSEG2`.
    pub fn quanta_per_bit(&self) -> u32 {
        SYNC_SEG_TQ + self.tseg1_tq() + self.tseg2_tq()
    }

    /// Controller clock periods per nominal bit.
    pub fn clocks_per_bit(&self) -> u32 {
        self.clocks_per_tq() * self.quanta_per_bit()
    }

    /// Time quanta from the start of the bit to the sample point: `1 + TSEG1`.
    pub fn sample_point_tq(&self) -> u32 {
        SYNC_SEG_TQ + self.tseg1_tq()
    }

    /// Nominal bit rate in bit/s for a controller clock of `clock_hz`.
    pub fn bitrate(&self, clock_hz: f64) -> f64 {
        clock_hz / f64::from(self.clocks_per_bit())
    }

    /// Sample point as a fraction of the bit (0..1).
    pub fn sample_point(&self) -> f64 {
        f64::from(self.sample_point_tq()) / f64::from(self.quanta_per_bit())
    }

    /// Propagation segment assumed by [`Btr::oscillator_tolerance`]: `max(1, TSEG1 − TSEG2)` tq.
    ///
    /// The SJA1000 has a single TSEG1 = Prop_Seg + Phase_Seg1. ISO 11898-1 (CAN 2.0) requires
    /// Prop_Seg ≥ 1 tq and Phase_Seg2 = max(Phase_Seg1, IPT), i.e. Phase_Seg1 ≤ Phase_Seg2. The
    /// split used here gives Phase_Seg1 the largest length those rules allow and the rest of TSEG1 to
    /// propagation: Phase_Seg1 = min(TSEG1 − 1, TSEG2), Prop_Seg = TSEG1 − Phase_Seg1.
    pub fn prop_seg_tq(&self) -> u32 {
        self.tseg1_tq() - self.phase_seg1_tq()
    }

    /// Phase segment 1 assumed by [`Btr::oscillator_tolerance`]: `min(TSEG1 − 1, TSEG2)` tq
    /// (see [`Btr::prop_seg_tq`] for the rule).
    pub fn phase_seg1_tq(&self) -> u32 {
        (self.tseg1_tq() - 1).min(self.tseg2_tq())
    }

    /// Oscillator tolerance `df` of ISO 11898-1 (a fraction; 0.003125 = 0.3125 %), for the default
    /// split of TSEG1 into Prop_Seg + Phase_Seg1 (see [`Btr::prop_seg_tq`]).
    ///
    /// `df = min(SJW' / (20·NBT), min(Phase_Seg1, Phase_Seg2) / (2·(13·NBT − Phase_Seg2)))` with
    /// NBT = quanta per bit, Phase_Seg2 = TSEG2, Phase_Seg1 = min(TSEG1 − 1, TSEG2) and
    /// SJW' = min(SJW, Phase_Seg1, Phase_Seg2): the jump the chip's resynchronisation can really
    /// make (an SJW longer than a phase segment cannot be used in full). Because Phase_Seg1 is as
    /// long as the standard allows, this is the best case: it assumes the bus's propagation delay
    /// fits in the remaining Prop_Seg. Use [`Btr::oscillator_tolerance_for_prop`] for a longer
    /// propagation segment. Triple sampling (SAM) does not enter the formula. A TSEG1 of 1 tq
    /// leaves no Phase_Seg1 and gives 0.
    pub fn oscillator_tolerance(&self) -> f64 {
        self.oscillator_tolerance_for_prop(self.prop_seg_tq())
    }

    /// Oscillator tolerance (as [`Btr::oscillator_tolerance`]) when `prop_tq` quanta of TSEG1 are
    /// reserved for the propagation delay; Phase_Seg1 = TSEG1 − `prop_tq` (0 if `prop_tq` ≥ TSEG1).
    pub fn oscillator_tolerance_for_prop(&self, prop_tq: u32) -> f64 {
        let nbt = f64::from(self.quanta_per_bit());
        let phase1 = self.tseg1_tq().saturating_sub(prop_tq);
        let phase2 = self.tseg2_tq();
        let min_phase = phase1.min(phase2);
        let sjw = self.sjw_tq().min(min_phase);
        let df_resync = f64::from(sjw) / (20.0 * nbt);
        let df_error_flag = f64::from(min_phase) / (2.0 * (13.0 * nbt - f64::from(phase2)));
        df_resync.min(df_error_flag)
    }

    /// Advisory checks against CAN 2.0 / ISO 11898-1 recommendations; empty when none apply.
    ///
    /// Reports SJW > min(TSEG1, TSEG2), TSEG2 < 2 tq (information processing time), TSEG1 < 2 tq
    /// and quanta per bit outside 8..=25. The chip accepts all of these settings.
    pub fn validate(&self) -> Vec<BtrWarning> {
        let mut warnings = Vec::new();
        let (tseg1_tq, tseg2_tq, sjw_tq) = (self.tseg1_tq(), self.tseg2_tq(), self.sjw_tq());
        if sjw_tq > tseg1_tq.min(tseg2_tq) {
            warnings.push(BtrWarning::SjwExceedsSegment {
                sjw_tq,
                tseg1_tq,
                tseg2_tq,
            });
        }
        if tseg2_tq < 2 {
            warnings.push(BtrWarning::Tseg2BelowIpt { tseg2_tq });
        }
        if tseg1_tq < 2 {
            warnings.push(BtrWarning::Tseg1TooShort { tseg1_tq });
        }
        let quanta = self.quanta_per_bit();
        if !(8..=25).contains(&quanta) {
            warnings.push(BtrWarning::QuantaOutOfRange { quanta });
        }
        warnings
    }
}

impl fmt::Display for Btr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "BTR0=0x{:02X} BTR1=0x{:02X} (BRP {}, TSEG1 {} tq, TSEG2 {} tq, SJW {} tq, SAM {})",
            self.btr0(),
            self.btr1(),
            self.brp & 0x3F,
            self.tseg1_tq(),
            self.tseg2_tq(),
            self.sjw_tq(),
            u8::from(self.sam)
        )
    }
}

/// Result of [`calc_bittiming`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calculation {
    /// The chosen register setting (SAM = 0).
    pub btr: Btr,
    /// Exact nominal bit rate of `btr` in bit/s.
    pub bitrate: f64,
    /// Relative, signed bit-rate error: `(bitrate − requested) / requested`.
    pub bitrate_error: f64,
    /// Sample point as a fraction of the bit.
    pub sample_point: f64,
    /// Time quanta per bit (sync + TSEG1 + TSEG2).
    pub quanta_per_bit: u32,
    /// Length of one time quantum in nanoseconds.
    pub tq_ns: f64,
}

/// Bit rates listed by [`format_table`].
pub const COMMON_BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// A TSEG1/TSEG2 split for a given number of quanta after the sync segment.
#[derive(Clone, Copy, Debug)]
struct SplitCandidate {
    tseg1: u32,
    tseg2: u32,
    /// Sample-point error against the nominal one, in tenths of a percent.
    error: u32,
}

/// Splits `tseg` (= TSEG1 + TSEG2 in tq) so that the sample point comes as close as possible to
/// `sp_nominal` (tenths of a percent) without passing it. Tries the TSEG2 that puts the sample point
/// at or just after the nominal one and the next longer TSEG2; splits giving TSEG1 < 1 are skipped.
fn split_tseg(sp_nominal: u32, tseg: u32) -> Option<SplitCandidate> {
    let total = i64::from(tseg + SYNC_SEG_TQ);
    let mut best: Option<SplitCandidate> = None;
    for longer in 0..=1i64 {
        let raw_tseg2 = total - i64::from(sp_nominal) * total / 1000 - longer;
        let mut tseg2 = raw_tseg2.clamp(i64::from(TSEG2_MIN), i64::from(TSEG2_MAX));
        let mut tseg1 = i64::from(tseg) - tseg2;
        if tseg1 > i64::from(TSEG1_MAX) {
            tseg1 = i64::from(TSEG1_MAX);
            tseg2 = i64::from(tseg) - tseg1;
        }
        if tseg1 < i64::from(TSEG1_MIN) {
            continue;
        }
        let sample_point = 1000 * (total - tseg2) / total;
        let error = (i64::from(sp_nominal) - sample_point).unsigned_abs() as u32;
        if sample_point <= i64::from(sp_nominal) && best.is_none_or(|b| error < b.error) {
            best = Some(SplitCandidate {
                tseg1: tseg1 as u32,
                tseg2: tseg2 as u32,
                error,
            });
        }
    }
    best
}

/// The achievable bit rate nearest to `bitrate` over all prescalers and segment totals.
fn closest_bitrate(clock_hz: u32, bitrate: u32) -> f64 {
    let mut best = f64::NAN;
    for brp in BRP_MIN..=BRP_MAX {
        for tsegall in (SYNC_SEG_TQ + TSEG1_MIN + TSEG2_MIN)..=(SYNC_SEG_TQ + TSEG1_MAX + TSEG2_MAX)
        {
            let rate = f64::from(clock_hz) / (2.0 * brp as f64 * f64::from(tsegall));
            if best.is_nan()
                || (rate - f64::from(bitrate)).abs() < (best - f64::from(bitrate)).abs()
            {
                best = rate;
            }
        }
    }
    best
}

/// Computes SJA1000 bit timing for `bitrate` bit/s with a controller clock of `clock_hz`.
///
/// `sample_point` is the wanted sample point as a fraction (e.g. 0.875); `None` selects 75 % above
/// 800 kbit/s, 80 % above 500 kbit/s and 87.5 % otherwise. The chosen sample point never lies after
/// the nominal one. `sjw_tq` is the wanted SJW in tq (1..=4, and at most TSEG2); `None` selects
/// `max(1, min(Phase_Seg1, Phase_Seg2 / 2))` capped at 4 tq and TSEG2, with Prop_Seg = TSEG1 / 2.
///
/// The search walks every segment total from the longest down, trying for each the prescaler
/// that gives the nearest bit rate at or above the target and the next one; it keeps the setting
/// with the smallest bit-rate error and, among equal ones, the smallest sample-point error (longer
/// bits win ties). A result more than 5 % off gives [`BitTimingError::Impossible`].
pub fn calc_bittiming(
    clock_hz: u32,
    bitrate: u32,
    sample_point: Option<f64>,
    sjw_tq: Option<u32>,
) -> Result<Calculation, BitTimingError> {
    if clock_hz == 0 {
        return Err(BitTimingError::ZeroClock);
    }
    if bitrate == 0 {
        return Err(BitTimingError::ZeroBitrate);
    }
    let sp_nominal: u32 = match sample_point {
        None if bitrate > 800_000 => 750,
        None if bitrate > 500_000 => 800,
        None => 875,
        Some(sp) => {
            if !(sp > 0.0 && sp < 1.0) {
                return Err(BitTimingError::SamplePointOutOfRange(sp));
            }
            let tenths = (sp * 1000.0).round() as u32;
            if !(1..=999).contains(&tenths) {
                return Err(BitTimingError::SamplePointOutOfRange(sp));
            }
            tenths
        }
    };
    if let Some(sjw) = sjw_tq {
        if !(1..=SJW_MAX).contains(&sjw) {
            return Err(BitTimingError::SjwOutOfRange(sjw));
        }
    }

    let can_clock = u64::from(clock_hz) / 2;
    let target = u64::from(bitrate);
    // (rate error, prescaler, split) of the best setting so far.
    let mut best: Option<(u64, u64, SplitCandidate)> = None;
    let mut best_rate_error = u64::MAX;
    let mut best_sp_error = u32::MAX;
    let t_max = 2 * (TSEG1_MAX + TSEG2_MAX) + 1;
    let t_min = 2 * (TSEG1_MIN + TSEG2_MIN);
    for t in (t_min..=t_max).rev() {
        let tseg = t / 2;
        let tsegall = u64::from(SYNC_SEG_TQ + tseg);
        // Even t: the prescaler giving the rate at or above the target; odd t: the next one.
        let brp = (can_clock / (tsegall * target) + u64::from(t % 2)) / BRP_INC * BRP_INC;
        if !(BRP_MIN..=BRP_MAX).contains(&brp) {
            continue;
        }
        let rate = can_clock / (brp * tsegall);
        let rate_error = target.abs_diff(rate);
        if rate_error > best_rate_error {
            continue;
        }
        if rate_error < best_rate_error {
            best_sp_error = u32::MAX;
        }
        let Some(split) = split_tseg(sp_nominal, tseg) else {
            continue;
        };
        if split.error >= best_sp_error {
            continue;
        }
        best_rate_error = rate_error;
        best_sp_error = split.error;
        best = Some((rate_error, brp, split));
        if rate_error == 0 && split.error == 0 {
            break;
        }
    }

    let impossible = || BitTimingError::Impossible {
        clock_hz,
        bitrate,
        closest_bitrate: closest_bitrate(clock_hz, bitrate),
    };
    let Some((rate_error, brp, split)) = best else {
        return Err(impossible());
    };
    if rate_error * 20 > target {
        return Err(impossible());
    }

    let sjw = match sjw_tq {
        Some(sjw) => {
            if sjw > split.tseg2 {
                return Err(BitTimingError::SjwExceedsTseg2 {
                    sjw_tq: sjw,
                    tseg2_tq: split.tseg2,
                });
            }
            sjw
        }
        None => {
            let phase_seg1 = split.tseg1 - split.tseg1 / 2;
            let phase_seg2 = split.tseg2;
            // TSEG2 ≥ 1, so the upper bound is never below 1.
            phase_seg1
                .min(phase_seg2 / 2)
                .clamp(1, SJW_MAX.min(split.tseg2))
        }
    };

    // brp is 1..=64 and the split is within the chip's ranges.
    let btr = Btr::from_quanta((brp - 1) as u8, split.tseg1, split.tseg2, sjw, false)?;
    let actual = btr.bitrate(f64::from(clock_hz));
    Ok(Calculation {
        btr,
        bitrate: actual,
        bitrate_error: (actual - f64::from(bitrate)) / f64::from(bitrate),
        sample_point: btr.sample_point(),
        quanta_per_bit: btr.quanta_per_bit(),
        tq_ns: 1e9 * f64::from(btr.clocks_per_tq()) / f64::from(clock_hz),
    })
}

/// A sample point given in percent (87.5) or as a fraction (0.875), as a fraction; `None` when it
/// is neither (not strictly between 0 and 100, or exactly 1).
pub fn sample_point_fraction(value: f64) -> Option<f64> {
    match value {
        v if v > 0.0 && v < 1.0 => Some(v),
        v if v > 1.0 && v < 100.0 => Some(v / 100.0),
        _ => None,
    }
}

/// Multi-line, human-readable description of a calculation for a controller clock of `clock_hz`.
pub fn format_calculation(clock_hz: u32, c: &Calculation) -> String {
    let b = &c.btr;
    let mut s = String::new();
    s.push_str(&format!("clock        {} Hz\n", clock_hz));
    s.push_str(&format!(
        "BTR0         0x{:02X}  (SJW field {}, BRP field {} -> prescaler {})\n",
        b.btr0(),
        b.sjw & 0x03,
        b.brp & 0x3F,
        u32::from(b.brp & 0x3F) + 1
    ));
    s.push_str(&format!(
        "BTR1         0x{:02X}  (SAM {}, TSEG2 field {}, TSEG1 field {})\n",
        b.btr1(),
        u8::from(b.sam),
        b.tseg2 & 0x07,
        b.tseg1 & 0x0F
    ));
    s.push_str(&format!(
        "tq           {:.3} ns ({} clocks)\n",
        c.tq_ns,
        b.clocks_per_tq()
    ));
    s.push_str(&format!(
        "quanta/bit   {} (sync 1 + tseg1 {} + tseg2 {})\n",
        c.quanta_per_bit,
        b.tseg1_tq(),
        b.tseg2_tq()
    ));
    s.push_str(&format!(
        "sample point {:.1} % ({} tq)\n",
        c.sample_point * 100.0,
        b.sample_point_tq()
    ));
    s.push_str(&format!(
        "bitrate      {} bit/s (error {:+.3} %)\n",
        fmt_rate(c.bitrate),
        c.bitrate_error * 100.0
    ));
    s.push_str(&format!("SJW          {} tq\n", b.sjw_tq()));
    s.push_str(&format!(
        "osc. tol.    {:.4} %\n",
        b.oscillator_tolerance() * 100.0
    ));
    s
}

/// One line per entry of [`COMMON_BITRATES`] for a controller clock of `clock_hz`; a bit rate that
/// cannot be reached gets the reason instead of register values.
pub fn format_table(clock_hz: u32) -> String {
    let mut s = format!("SJA1000 bit timing, {} Hz clock\n", clock_hz);
    for &rate in COMMON_BITRATES.iter() {
        match calc_bittiming(clock_hz, rate, None, None) {
            Ok(c) => s.push_str(&format!(
                "{:>8} bit/s: BTR0=0x{:02X} BTR1=0x{:02X}  brp {:>2}  {:>2} tq = 1+{}+{}  SP {:>4.1} %  SJW {}  err {:+.3} %\n",
                rate,
                c.btr.btr0(),
                c.btr.btr1(),
                u32::from(c.btr.brp & 0x3F) + 1,
                c.quanta_per_bit,
                c.btr.tseg1_tq(),
                c.btr.tseg2_tq(),
                c.sample_point * 100.0,
                c.btr.sjw_tq(),
                c.bitrate_error * 100.0
            )),
            Err(e) => s.push_str(&format!("{:>8} bit/s: {}\n", rate, e)),
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn calc(clock: u32, rate: u32) -> Calculation {
        calc_bittiming(clock, rate, None, None).unwrap()
    }

    fn regs(c: &Calculation) -> (u8, u8) {
        (c.btr.btr0(), c.btr.btr1())
    }

    #[test]
    fn btr_register_round_trip_all_pairs() {
        for btr0 in 0..=255u8 {
            for btr1 in 0..=255u8 {
                let b = Btr::from_registers(btr0, btr1);
                assert_eq!((b.btr0(), b.btr1()), (btr0, btr1));
                let rebuilt = Btr::new(b.brp, b.tseg1, b.tseg2, b.sjw, b.sam).unwrap();
                assert_eq!(rebuilt, b);
                let q = Btr::from_quanta(b.brp, b.tseg1_tq(), b.tseg2_tq(), b.sjw_tq(), b.sam);
                assert_eq!(q.unwrap(), b);
            }
        }
    }

    #[test]
    fn btr_field_decoding_and_derived_quantities() {
        // BTR0 = SJW 2 (field), BRP 5; BTR1 = SAM, TSEG2 3, TSEG1 10.
        let b = Btr::from_registers(0x85, 0xBA);
        assert_eq!((b.sjw, b.brp, b.sam, b.tseg2, b.tseg1), (2, 5, true, 3, 10));
        assert_eq!(b.clocks_per_tq(), 12);
        assert_eq!((b.tseg1_tq(), b.tseg2_tq(), b.sjw_tq()), (11, 4, 3));
        assert_eq!(b.quanta_per_bit(), 16);
        assert_eq!(b.clocks_per_bit(), 192);
        assert_eq!(b.sample_point_tq(), 12);
        assert!((b.bitrate(16e6) - 16e6 / 192.0).abs() < 1e-9);
        assert!((b.sample_point() - 0.75).abs() < 1e-12);
        // Out-of-width public fields are truncated like the register would.
        let wide = Btr {
            brp: 0xFF,
            sjw: 0xFF,
            tseg1: 0xFF,
            tseg2: 0xFF,
            sam: false,
        };
        assert_eq!((wide.btr0(), wide.btr1()), (0xFF, 0x7F));
        assert_eq!(wide.clocks_per_tq(), 128);
        assert_eq!(wide.quanta_per_bit(), 25);
    }

    #[test]
    fn btr_new_rejects_out_of_range_fields() {
        let cases = [
            (Btr::new(64, 0, 0, 0, false), BtrField::Brp, 64),
            (Btr::new(0, 16, 0, 0, false), BtrField::Tseg1, 16),
            (Btr::new(0, 0, 8, 0, false), BtrField::Tseg2, 8),
            (Btr::new(0, 0, 0, 4, false), BtrField::Sjw, 4),
        ];
        for (result, field, value) in cases {
            let err = result.unwrap_err();
            assert_eq!(err, BitTimingError::FieldOutOfRange { field, value });
            let msg = err.to_string();
            assert!(msg.contains(&field.to_string()), "{msg}");
            assert!(msg.contains(&value.to_string()), "{msg}");
            assert!(msg.contains(&format!("0..={}", field.field_max())), "{msg}");
        }
        assert!(Btr::new(63, 15, 7, 3, true).is_ok());
    }

    #[test]
    fn btr_from_quanta_ranges() {
        let ok = Btr::from_quanta(0, 13, 2, 1, false).unwrap();
        assert_eq!((ok.btr0(), ok.btr1()), (0x00, 0x1C));
        // SJW longer than TSEG2 is accepted by the chip, only flagged by validate().
        let long_sjw = Btr::from_quanta(0, 13, 2, 4, false).unwrap();
        assert!(long_sjw
            .validate()
            .iter()
            .any(|w| matches!(w, BtrWarning::SjwExceedsSegment { sjw_tq: 4, .. })));
        let bad = [
            (
                Btr::from_quanta(64, 13, 2, 1, false),
                BtrField::Brp,
                64,
                0,
                63,
            ),
            (
                Btr::from_quanta(0, 0, 2, 1, false),
                BtrField::Tseg1,
                0,
                1,
                16,
            ),
            (
                Btr::from_quanta(0, 17, 2, 1, false),
                BtrField::Tseg1,
                17,
                1,
                16,
            ),
            (
                Btr::from_quanta(0, 13, 0, 1, false),
                BtrField::Tseg2,
                0,
                1,
                8,
            ),
            (
                Btr::from_quanta(0, 13, 9, 1, false),
                BtrField::Tseg2,
                9,
                1,
                8,
            ),
            (Btr::from_quanta(0, 13, 2, 0, false), BtrField::Sjw, 0, 1, 4),
            (Btr::from_quanta(0, 13, 2, 5, false), BtrField::Sjw, 5, 1, 4),
        ];
        for (result, field, tq, min, max) in bad {
            let err = result.unwrap_err();
            assert_eq!(
                err,
                BitTimingError::LengthOutOfRange {
                    field,
                    tq,
                    min,
                    max
                }
            );
            let msg = err.to_string();
            assert!(msg.contains(&format!("{field}")) && msg.contains(&format!("{min}..={max}")));
        }
        assert_eq!(
            Btr::from_quanta(0, 17, 2, 1, false)
                .unwrap_err()
                .to_string(),
            "TSEG1 length 17 tq is out of range: allowed 1..=16 tq"
        );
    }

    #[test]
    fn btr_validate_warnings() {
        assert!(Btr::from_registers(0x00, 0x1C).validate().is_empty());
        // TSEG1 1 tq, TSEG2 1 tq, SJW 2 tq: 3 tq per bit.
        let w = Btr::from_quanta(0, 1, 1, 2, false).unwrap().validate();
        assert_eq!(w.len(), 4, "{w:?}");
        for warning in &w {
            assert!(!warning.to_string().is_empty());
        }
    }

    #[test]
    fn btr_display() {
        let b = Btr::from_registers(0x00, 0x1C);
        assert_eq!(
            b.to_string(),
            "BTR0=0x00 BTR1=0x1C (BRP 0, TSEG1 13 tq, TSEG2 2 tq, SJW 1 tq, SAM 0)"
        );
        let b = Btr::from_registers(0xC5, 0xBA);
        assert_eq!(
            b.to_string(),
            "BTR0=0xC5 BTR1=0xBA (BRP 5, TSEG1 11 tq, TSEG2 4 tq, SJW 4 tq, SAM 1)"
        );
    }

    #[test]
    fn btr_oscillator_tolerance_500k_16mhz() {
        // BTR0=0x00 BTR1=0x1C: NBT 16 tq, TSEG1 13, TSEG2 2, SJW 1.
        // Split: Phase_Seg1 = min(13 − 1, 2) = 2, Prop_Seg = 11, Phase_Seg2 = 2.
        // Condition 1: SJW / (20·NBT) = 1 / 320 = 0.003125.
        // Condition 2: min(2, 2) / (2·(13·16 − 2)) = 2 / 412 = 0.004854.
        // df = min = 0.003125 (0.3125 %): the 1 tq SJW limits it.
        let b = Btr::from_registers(0x00, 0x1C);
        assert_eq!((b.prop_seg_tq(), b.phase_seg1_tq()), (11, 2));
        let df = b.oscillator_tolerance();
        println!(
            "oscillator tolerance of {b}: {:.6} ({:.4} %)",
            df,
            df * 100.0
        );
        assert!((df - 1.0 / 320.0).abs() < 1e-12);
        // With all of TSEG1 but 1 tq used for propagation nothing changes (Phase_Seg1 = 12 > 2);
        // with 12 tq of propagation Phase_Seg1 is 1 tq: cond. 2 = 1/412 = 0.002427 limits.
        assert!((b.oscillator_tolerance_for_prop(1) - 1.0 / 320.0).abs() < 1e-12);
        assert!((b.oscillator_tolerance_for_prop(12) - 1.0 / 412.0).abs() < 1e-12);
        assert_eq!(b.oscillator_tolerance_for_prop(13), 0.0);
    }

    #[test]
    fn btr_oscillator_tolerance_tseg1_11_tseg2_4_sjw_2() {
        // NBT 16, Phase_Seg1 = min(10, 4) = 4, Prop_Seg 7, Phase_Seg2 4, SJW 2.
        // Condition 1: 2 / 320 = 0.00625; condition 2: 4 / (2·(208 − 4)) = 4 / 408 = 0.009804.
        let b = Btr::from_quanta(0, 11, 4, 2, false).unwrap();
        assert_eq!(b.quanta_per_bit(), 16);
        assert_eq!((b.prop_seg_tq(), b.phase_seg1_tq()), (7, 4));
        let df = b.oscillator_tolerance();
        println!(
            "oscillator tolerance of {b}: {:.6} ({:.4} %)",
            df,
            df * 100.0
        );
        assert!((df - 2.0 / 320.0).abs() < 1e-12);
        // SJW 4: condition 1 = 4/320 = 0.0125 > condition 2, which then limits.
        let b4 = Btr::from_quanta(0, 11, 4, 4, false).unwrap();
        assert!((b4.oscillator_tolerance() - 4.0 / 408.0).abs() < 1e-12);
        // An SJW longer than the phase segments only counts as far as they reach.
        let b_long = Btr::from_quanta(0, 13, 2, 4, false).unwrap();
        assert!((b_long.oscillator_tolerance() - 2.0 / 412.0).abs() < 1e-12);
        // TSEG1 = 1 tq leaves no phase segment 1.
        assert_eq!(
            Btr::from_quanta(0, 1, 4, 1, false)
                .unwrap()
                .oscillator_tolerance(),
            0.0
        );
    }

    #[test]
    fn btr_calc_16mhz_500k_required_example() {
        let c = calc(16_000_000, 500_000);
        assert_eq!(regs(&c), (0x00, 0x1C));
        assert_eq!(c.btr.brp + 1, 1);
        assert_eq!(
            (c.btr.tseg1_tq(), c.btr.tseg2_tq(), c.btr.sjw_tq()),
            (13, 2, 1)
        );
        assert_eq!(c.quanta_per_bit, 16);
        assert_eq!(c.sample_point, 0.875);
        assert_eq!(c.bitrate, 500_000.0);
        assert_eq!(c.bitrate_error, 0.0);
        assert!((c.tq_ns - 125.0).abs() < 1e-9);
        println!("{}", format_calculation(16_000_000, &c));
    }

    #[test]
    fn btr_calc_16mhz_125k_250k_1m() {
        // 8 MHz CAN clock. 125 k: 64 CAN clocks per bit; the first exact total from the top is
        // 16 tq (no total 17..=25 divides 64): prescaler 4, 13 + 2 tq, 87.5 %.
        let c = calc(16_000_000, 125_000);
        assert_eq!(regs(&c), (0x03, 0x1C));
        assert_eq!(c.sample_point, 0.875);
        // 250 k: 32 CAN clocks per bit: 16 tq, prescaler 2.
        let c = calc(16_000_000, 250_000);
        assert_eq!(regs(&c), (0x01, 0x1C));
        // 1 M: 8 CAN clocks per bit: 8 tq, prescaler 1; nominal SP 75 %: TSEG2 = 8 − 6 = 2,
        // TSEG1 = 5, SP = 6/8 = 75 %; SJW = max(1, min(5 − 2, 2 / 2)) = 1.
        let c = calc(16_000_000, 1_000_000);
        assert_eq!(regs(&c), (0x00, 0x14));
        assert_eq!(
            (c.btr.tseg1_tq(), c.btr.tseg2_tq(), c.btr.sjw_tq()),
            (5, 2, 1)
        );
        assert_eq!(c.sample_point, 0.75);
        // 800 k: 10 CAN clocks per bit, 10 tq, nominal 80 %: TSEG2 = 10 − 8 = 2, TSEG1 7.
        let c = calc(16_000_000, 800_000);
        assert_eq!(regs(&c), (0x00, 0x16));
        assert_eq!(c.sample_point, 0.8);
    }

    #[test]
    fn btr_calc_8mhz_500k() {
        // 4 MHz CAN clock, 8 CAN clocks per bit: 8 tq, prescaler 1. Nominal 87.5 %:
        // TSEG2 = 8 − 7 = 1, TSEG1 = 6, SP = 7/8 = 87.5 %, SJW 1. BTR1 = 0 << 4 | 5.
        let c = calc(8_000_000, 500_000);
        assert_eq!(regs(&c), (0x00, 0x05));
        assert_eq!(
            (c.btr.tseg1_tq(), c.btr.tseg2_tq(), c.btr.sjw_tq()),
            (6, 1, 1)
        );
        assert_eq!(c.sample_point, 0.875);
        assert_eq!(c.bitrate_error, 0.0);
        assert!((c.tq_ns - 250.0).abs() < 1e-9);
    }

    #[test]
    fn btr_calc_24mhz_1m() {
        // 12 MHz CAN clock, 12 CAN clocks per bit: 12 tq, prescaler 1. Nominal 75 %:
        // TSEG2 = 12 − 9 = 3, TSEG1 = 8, SP = 9/12 = 75 %; SJW = max(1, min(4, 3/2)) = 1.
        let c = calc(24_000_000, 1_000_000);
        assert_eq!(regs(&c), (0x00, 0x27));
        assert_eq!(
            (c.btr.tseg1_tq(), c.btr.tseg2_tq(), c.btr.sjw_tq()),
            (8, 3, 1)
        );
        assert_eq!(c.sample_point, 0.75);
        assert_eq!(c.bitrate, 1_000_000.0);
    }

    #[test]
    fn btr_calc_impossible_requests() {
        // 3 Mbit/s at 16 MHz: the shortest bit (3 tq at prescaler 1) gives 2.667 Mbit/s, −11 %.
        let err = calc_bittiming(16_000_000, 3_000_000, None, None).unwrap_err();
        match err {
            BitTimingError::Impossible {
                clock_hz,
                bitrate,
                closest_bitrate,
            } => {
                assert_eq!((clock_hz, bitrate), (16_000_000, 3_000_000));
                assert!((closest_bitrate - 8e6 / 3.0).abs() < 1e-6);
            }
            other => panic!("unexpected {other:?}"),
        }
        let msg = err.to_string();
        println!("{msg}");
        assert!(msg.starts_with("bitrate 3000000 is impossible with a 16000000 Hz clock (closest:"));
        // 1 kbit/s at 16 MHz needs 8000 CAN clocks per bit > 64 · 25: the slowest is 5 kbit/s.
        let err = calc_bittiming(16_000_000, 1_000, None, None).unwrap_err();
        assert_eq!(
            err,
            BitTimingError::Impossible {
                clock_hz: 16_000_000,
                bitrate: 1_000,
                closest_bitrate: 5_000.0
            }
        );
        println!("{err}");
        assert!(err.to_string().contains("closest: 5000 bit/s, +400.00 %"));
        // Tiny clock.
        assert!(matches!(
            calc_bittiming(1, 1, None, None),
            Err(BitTimingError::Impossible { .. })
        ));
    }

    #[test]
    fn btr_calc_bad_arguments() {
        assert_eq!(
            calc_bittiming(0, 500_000, None, None),
            Err(BitTimingError::ZeroClock)
        );
        assert_eq!(
            calc_bittiming(16_000_000, 0, None, None),
            Err(BitTimingError::ZeroBitrate)
        );
        for sp in [0.0, 1.0, -0.5, 1.5, f64::NAN, 0.0001, 0.9999] {
            let err = calc_bittiming(16_000_000, 500_000, Some(sp), None).unwrap_err();
            assert!(
                matches!(err, BitTimingError::SamplePointOutOfRange(_)),
                "{sp}"
            );
            assert!(err.to_string().contains("sample point"));
        }
        for sjw in [0, 5] {
            let err = calc_bittiming(16_000_000, 500_000, None, Some(sjw)).unwrap_err();
            assert_eq!(err, BitTimingError::SjwOutOfRange(sjw));
            assert!(err.to_string().contains("1..=4"));
        }
        // 500 k at 16 MHz has TSEG2 = 2 tq: SJW 3 is rejected, SJW 2 accepted.
        let err = calc_bittiming(16_000_000, 500_000, None, Some(3)).unwrap_err();
        assert_eq!(
            err,
            BitTimingError::SjwExceedsTseg2 {
                sjw_tq: 3,
                tseg2_tq: 2
            }
        );
        assert!(!err.to_string().is_empty());
        assert_eq!(
            BitTimingError::ZeroClock.to_string(),
            "the controller clock must not be 0 Hz"
        );
        assert_eq!(
            BitTimingError::ZeroBitrate.to_string(),
            "the bit rate must not be 0 bit/s"
        );
    }

    #[test]
    fn btr_calc_requested_sjw_and_sample_point() {
        let c = calc_bittiming(16_000_000, 500_000, None, Some(2)).unwrap();
        assert_eq!(regs(&c), (0x40, 0x1C));
        // 75 % at 500 k / 16 MHz: 16 tq, TSEG2 = 16 − 12 = 4, TSEG1 = 11; default SJW = 2.
        let c = calc_bittiming(16_000_000, 500_000, Some(0.75), None).unwrap();
        assert_eq!(
            (c.btr.tseg1_tq(), c.btr.tseg2_tq(), c.btr.sjw_tq()),
            (11, 4, 2)
        );
        assert_eq!(regs(&c), (0x40, 0x3A));
        assert_eq!(c.sample_point, 0.75);
    }

    #[test]
    fn btr_calc_results_respect_limits() {
        // Sweep clocks, rates and sample points: a result is within the chip's ranges, within 5 %
        // of the request, and never samples after the nominal sample point.
        let clocks = [
            8_000_000u32,
            11_059_200,
            12_000_000,
            16_000_000,
            20_000_000,
            24_000_000,
            33_333_333,
        ];
        let mut ok = 0;
        for &clock in &clocks {
            for rate in (5_000u32..=1_200_000).step_by(7_919) {
                for sp in [None, Some(0.5), Some(0.6), Some(0.7), Some(0.9)] {
                    let Ok(c) = calc_bittiming(clock, rate, sp, None) else {
                        continue;
                    };
                    ok += 1;
                    let nominal = match sp {
                        Some(f) => f,
                        None if rate > 800_000 => 0.75,
                        None if rate > 500_000 => 0.8,
                        None => 0.875,
                    };
                    assert!(
                        c.sample_point <= nominal + 1e-9,
                        "{clock} {rate} {sp:?} {c:?}"
                    );
                    assert!(c.bitrate_error.abs() <= 0.05 + 1e-9);
                    assert!(c.btr.sjw_tq() <= c.btr.tseg2_tq());
                    assert_eq!(Btr::from_registers(c.btr.btr0(), c.btr.btr1()), c.btr);
                }
            }
        }
        assert!(ok > 1000, "{ok}");
    }

    #[test]
    fn btr_format_table_16mhz() {
        let table = format_table(16_000_000);
        println!("{table}");
        assert_eq!(table.lines().count(), 1 + COMMON_BITRATES.len());
        assert!(table.contains("500000 bit/s: BTR0=0x00 BTR1=0x1C"));
        assert!(table.contains("125000 bit/s: BTR0=0x03 BTR1=0x1C"));
        // 10 kbit/s needs 800 CAN clocks per bit: 16 tq · prescaler 50 hits 87.5 % exactly.
        assert!(table.contains("10000 bit/s: BTR0=0x31 BTR1=0x1C"));
        // An impossible rate is reported in its line, not aborted.
        let slow = format_table(100_000_000);
        assert!(
            slow.contains("10000 bit/s: bitrate 10000 is impossible"),
            "{slow}"
        );
        let c = calc(16_000_000, 500_000);
        let text = format_calculation(16_000_000, &c);
        for needle in [
            "0x00",
            "0x1C",
            "125.000 ns",
            "16 (sync 1 + tseg1 13 + tseg2 2)",
            "87.5 %",
        ] {
            assert!(text.contains(needle), "{needle} missing in\n{text}");
        }
    }
}
