//! The bus timing a VCD was written with: nominal bit time and sample point, and the header comment
//! that records them in every VCD the tracer writes, so a reader decodes the file without being
//! told the bit rate. Shared by the writer (`engine::trace`) and the readers (`decode`).

use std::fmt;

use golden::btr::Btr;

use crate::engine::time::{ClockSpec, FS_PER_S};

/// The nominal bit timing a decoder samples with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BusTiming {
    /// Nominal bit time in femtoseconds.
    pub bit_time_fs: u64,
    /// Sample point as a fraction of the bit, strictly between 0 and 1.
    pub sample_point: f64,
}

impl BusTiming {
    /// A checked timing: a positive bit time and a sample point strictly inside the bit.
    pub fn new(bit_time_fs: u64, sample_point: f64) -> Result<BusTiming, String> {
        if bit_time_fs == 0 {
            return Err("the bit time must be positive".into());
        }
        if !(sample_point > 0.0 && sample_point < 1.0) {
            return Err(format!(
                "sample point {sample_point} is not strictly between 0 and 1"
            ));
        }
        Ok(BusTiming {
            bit_time_fs,
            sample_point,
        })
    }

    /// The timing of `bitrate` bit/s (the bit time rounded to the femtosecond).
    pub fn from_bitrate(bitrate: f64, sample_point: f64) -> Result<BusTiming, String> {
        if !(bitrate.is_finite() && bitrate >= 1.0) {
            return Err(format!(
                "bit rate {bitrate} is not a rate of at least 1 bit/s"
            ));
        }
        BusTiming::new((FS_PER_S as f64 / bitrate).round() as u64, sample_point)
    }

    /// The timing of a controller with bit timing `btr` on `clock`.
    pub fn from_btr(btr: &Btr, clock: ClockSpec) -> BusTiming {
        BusTiming {
            bit_time_fs: u64::from(btr.clocks_per_bit()) * clock.period_fs(),
            sample_point: btr.sample_point(),
        }
    }

    /// The bit rate in bit/s.
    pub fn bitrate(&self) -> f64 {
        FS_PER_S as f64 / self.bit_time_fs as f64
    }
}

impl fmt::Display for BusTiming {
    /// `500000 bit/s, sample point 87.5 %`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} bit/s, sample point {} %",
            round_to_thousandths(self.bitrate()),
            round_to_thousandths(self.sample_point * 100.0)
        )
    }
}

/// `x` rounded to three decimals, printed without trailing zeros (166666.667, 500000, 87.5).
fn round_to_thousandths(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

/// Start of the header comment that records a VCD's bus timing.
pub const TIMING_COMMENT_PREFIX: &str = "cansim bus timing:";

/// The header comment recording `timing`:
/// `cansim bus timing: bit_time_fs=2000000000 sample_point=0.875 (500000 bit/s, sample point 87.5 %)`.
pub fn timing_comment(timing: &BusTiming) -> String {
    format!(
        "{TIMING_COMMENT_PREFIX} bit_time_fs={} sample_point={} ({timing})",
        timing.bit_time_fs, timing.sample_point
    )
}

/// The timing recorded by a [`timing_comment`], `None` for any other comment.
pub(crate) fn parse_timing_comment(text: &str) -> Option<Result<BusTiming, String>> {
    let fields = text.trim().strip_prefix(TIMING_COMMENT_PREFIX)?;
    let value = |key: &str| {
        fields
            .split_whitespace()
            .find_map(|word| word.strip_prefix(key)?.strip_prefix('='))
            .ok_or_else(|| format!("the bus timing comment has no {key}"))
    };
    let parsed = || -> Result<BusTiming, String> {
        let bit_time = value("bit_time_fs")?;
        let bit_time_fs = bit_time
            .parse()
            .map_err(|_| format!("bit_time_fs={bit_time} is not a whole number"))?;
        let sample_point = value("sample_point")?;
        let sample_point = sample_point
            .parse()
            .map_err(|_| format!("sample_point={sample_point} is not a number"))?;
        BusTiming::new(bit_time_fs, sample_point)
    };
    Some(parsed().map_err(|e| format!("bad bus timing comment: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_comment_round_trips() {
        let timing = BusTiming::from_bitrate(166_666.667, 0.8).unwrap();
        let text = timing_comment(&timing);
        assert_eq!(
            text,
            "cansim bus timing: bit_time_fs=5999999988 sample_point=0.8 (166666.667 bit/s, sample point 80 %)"
        );
        assert_eq!(parse_timing_comment(&text), Some(Ok(timing)));
        assert_eq!(parse_timing_comment("written by cansim"), None);
        assert_eq!(
            parse_timing_comment(&format!("{TIMING_COMMENT_PREFIX} bit_time_fs=12")),
            Some(Err(
                "bad bus timing comment: the bus timing comment has no sample_point".into()
            ))
        );
    }
}
