//! The TIME object (CiA 301 7.2.6): a TIME_OF_DAY in 6 bytes, the milliseconds after midnight
//! (28 bits, UNSIGNED28, the top 4 bits of the first 4 bytes reserved as 0) and the days since
//! January 1, 1984 (UNSIGNED16) (7.1.6.5). 1012h (COB-ID TIME) says on which identifier
//! (bits 10..0, default 100h) and whether the device consumes (bit 31) or produces (bit 30) it
//! (7.5.2.12).

/// Default COB-ID of TIME messages.
pub const DEFAULT_TIME_COB_ID: u16 = 0x100;
/// COB-ID TIME.
pub const COB_ID_TIME: u16 = 0x1012;
/// Bit 31 of 1012h: the device consumes TIME messages.
pub const TIME_CONSUMER: u64 = 1 << 31;
/// Bit 30 of 1012h: the device produces TIME messages.
pub const TIME_PRODUCER: u64 = 1 << 30;
/// Milliseconds in a day.
const MS_PER_DAY: u64 = 86_400_000;
/// The 28 bits of the milliseconds.
const MS_MASK: u32 = 0x0FFF_FFFF;

/// A time of day: days since 1984-01-01 and milliseconds after midnight.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct TimeOfDay {
    /// Days since January 1, 1984.
    pub days: u16,
    /// Milliseconds after midnight (below 86 400 000).
    pub ms: u32,
}

impl TimeOfDay {
    /// 2000-01-01 00:00:00.000 (5 844 days after 1984-01-01: 16 years, 4 of them leap years),
    /// the time a master's TIME producer starts from unless told otherwise.
    pub const Y2000: TimeOfDay = TimeOfDay { days: 5844, ms: 0 };

    /// The 6 bytes of a TIME message.
    pub fn encode(self) -> [u8; 6] {
        let [m0, m1, m2, m3] = (self.ms & MS_MASK).to_le_bytes();
        let [d0, d1] = self.days.to_le_bytes();
        [m0, m1, m2, m3, d0, d1]
    }

    /// The time a TIME message carries, if it has its 6 bytes.
    pub fn decode(data: &[u8]) -> Option<TimeOfDay> {
        let [m0, m1, m2, m3, d0, d1] = *data else {
            return None;
        };
        Some(TimeOfDay {
            days: u16::from_le_bytes([d0, d1]),
            ms: u32::from_le_bytes([m0, m1, m2, m3]) & MS_MASK,
        })
    }

    /// This time plus `us` microseconds (whole milliseconds count).
    pub fn plus_us(self, us: u64) -> TimeOfDay {
        let total = u64::from(self.ms) + us / 1000;
        TimeOfDay {
            days: self.days.wrapping_add((total / MS_PER_DAY) as u16),
            ms: (total % MS_PER_DAY) as u32,
        }
    }
}

impl std::fmt::Display for TimeOfDay {
    /// `2000-01-01 08:30:00.250`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (year, month, day) = civil_from_days(i64::from(self.days) + DAYS_1970_TO_1984);
        let ms = self.ms;
        let (h, m, s, milli) = (ms / 3_600_000, ms / 60_000 % 60, ms / 1000 % 60, ms % 1000);
        write!(
            f,
            "{year:04}-{month:02}-{day:02} {h:02}:{m:02}:{s:02}.{milli:03}"
        )
    }
}

/// Days from 1970-01-01 to 1984-01-01.
const DAYS_1970_TO_1984: i64 = 5113;

/// The date of `days` since 1970-01-01 (proleptic Gregorian calendar).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn six_bytes_ms_after_midnight_then_days_since_1984() {
        // 8:30:00.250 on 2000-01-01: 30 600 250 ms (01D2 EC3Ah) after midnight, day 5844 (16D4h).
        let t = TimeOfDay {
            days: 5844,
            ms: 30_600_250,
        };
        assert_eq!(30_600_250u32, 0x01D2_EC3A);
        assert_eq!(t.encode(), [0x3A, 0xEC, 0xD2, 0x01, 0xD4, 0x16]);
        assert_eq!(TimeOfDay::decode(&t.encode()), Some(t));
        assert_eq!(t.to_string(), "2000-01-01 08:30:00.250");
        assert_eq!(TimeOfDay::decode(&[0; 5]), None);
    }

    #[test]
    fn the_reserved_top_bits_are_sent_as_0_and_ignored_on_reception() {
        let mut bytes = TimeOfDay::Y2000.encode();
        bytes[3] |= 0xF0;
        assert_eq!(TimeOfDay::decode(&bytes), Some(TimeOfDay::Y2000));
    }

    #[test]
    fn adding_time_rolls_over_midnight_into_the_next_day() {
        let late = TimeOfDay {
            days: 10,
            ms: MS_PER_DAY as u32 - 1,
        };
        assert_eq!(late.plus_us(1_500), TimeOfDay { days: 11, ms: 0 });
        assert_eq!(TimeOfDay::Y2000.plus_us(999), TimeOfDay::Y2000);
    }
}
