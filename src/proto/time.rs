//! The `Time` element: the sender's local wall-clock time, `YYYY-MM-DD HH:MM:SS`.
//!
//! The robot does not act on it, but sends it and expects it. A panel has no battery-backed
//! clock, so it learns the robot's time from answers and counts on from there.

use crate::proto::xml::number::two_digit_lanes;

/// Length of the text form `YYYY-MM-DD HH:MM:SS`.
pub const TIME_TEXT_LEN: usize = 19;

/// A calendar date and time of day, as carried in the `Time` element.
///
/// Type 0 answers carry the all-zero `0000-00-00 00:00:00`, so fields are not range-checked
/// beyond their digit count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Timestamp {
    /// Year, 0..=9999.
    pub year: u16,
    /// Month, 1..=12 (0 in Type 0 answers).
    pub month: u8,
    /// Day of the month, 1..=31 (0 in Type 0 answers).
    pub day: u8,
    /// Hour, 0..=23.
    pub hour: u8,
    /// Minute, 0..=59.
    pub minute: u8,
    /// Second, 0..=59.
    pub second: u8,
}

/// The `Time` text is not `YYYY-MM-DD HH:MM:SS`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BadTimestamp;

const SECONDS_PER_DAY: u64 = 86_400;

impl Timestamp {
    /// The all-zero time that Type 0 answers carry.
    pub const ZERO: Self = Self {
        year: 0,
        month: 0,
        day: 0,
        hour: 0,
        minute: 0,
        second: 0,
    };

    /// The time the protocol document uses in its samples, a fixed epoch for a panel that
    /// has not heard the robot's clock yet.
    pub const DOCUMENT_EPOCH: Self = Self {
        year: 2023,
        month: 1,
        day: 1,
        hour: 0,
        minute: 0,
        second: 0,
    };

    /// Writes the text form into `out`. A field too large for its place (the year has four
    /// digits, the others two) is written with its last digits.
    pub fn encode(&self, out: &mut [u8; TIME_TEXT_LEN]) {
        // The last two digits of each field in a 16-bit lane, made into ASCII all at once.
        let lanes = |a: u16, b: u16, c: u16, d: u16| {
            let lane = |v: u16, at: u32| u64::from(v % 100) << at;
            lane(a, 0) | lane(b, 16) | lane(c, 32) | lane(d, 48)
        };
        let (month, day) = (self.month.into(), self.day.into());
        let (hour, minute, second) = (self.hour.into(), self.minute.into(), self.second.into());
        // `YYYYMMDD` and `hhmmss`, first character in the lowest byte.
        let date = two_digit_lanes(lanes(self.year / 100, self.year, month, day));
        let clock = two_digit_lanes(lanes(hour, minute, second, 0));
        let pair = |word: u64, at: u32| word >> at & 0xffff;
        let byte = |b: u8, at: u32| u64::from(b) << at;
        // `YYYY-MM-`, then `DD hh:mm`, then `:ss`.
        let first = pair(date, 0) | pair(date, 16) << 16 | byte(b'-', 32);
        let first = first | pair(date, 32) << 40 | byte(b'-', 56);
        let second = pair(date, 48) | byte(b' ', 16) | pair(clock, 0) << 24;
        let second = second | byte(b':', 40) | pair(clock, 16) << 48;
        let [s0, s1, ..] = pair(clock, 32).to_le_bytes();
        let [a, b, c, d, e, f, g, h] = first.to_le_bytes();
        let [i, j, k, l, m, n, o, p] = second.to_le_bytes();
        *out = [a, b, c, d, e, f, g, h, i, j, k, l, m, n, o, p, b':', s0, s1];
    }

    /// Parses `YYYY-MM-DD HH:MM:SS`.
    pub fn decode(text: &[u8]) -> Result<Self, BadTimestamp> {
        let text: &[u8; TIME_TEXT_LEN] = text.try_into().map_err(|_| BadTimestamp)?;
        // Every byte has its fixed place: the separators, and seven pairs of digits (the
        // year is two), each checked and read there.
        const SEPARATORS: [(u8, u8); 5] =
            [(4, b'-'), (7, b'-'), (10, b' '), (13, b':'), (16, b':')];
        const PAIRS: [u8; 7] = [0, 2, 5, 8, 11, 14, 17];
        if SEPARATORS
            .iter()
            .any(|&(at, c)| text.get(usize::from(at)) != Some(&c))
        {
            return Err(BadTimestamp);
        }
        let digit = |at: usize| {
            text.get(at)
                .map(|c| c.wrapping_sub(b'0'))
                .filter(|&d| d <= 9)
        };
        let mut pairs = [0u8; PAIRS.len()];
        for (pair, &at) in pairs.iter_mut().zip(&PAIRS) {
            let at = usize::from(at);
            let (Some(tens), Some(ones)) = (digit(at), digit(at + 1)) else {
                return Err(BadTimestamp);
            };
            *pair = tens * 10 + ones;
        }
        let [century, year, month, day, hour, minute, second] = pairs;
        Ok(Self {
            year: u16::from(century) * 100 + u16::from(year),
            month,
            day,
            hour,
            minute,
            second,
        })
    }

    /// The time `seconds` later, carrying into minutes, hours, days, months and years.
    ///
    /// Used to count on from the last time the robot told us; a zero or invalid date
    /// counts on from the document's epoch instead.
    pub fn plus_seconds(&self, seconds: u64) -> Self {
        let base = if self.month == 0 || self.day == 0 {
            Self::DOCUMENT_EPOCH
        } else {
            *self
        };
        let total = base.seconds_of_day() + seconds;
        let days = total / SECONDS_PER_DAY;
        let rest = total % SECONDS_PER_DAY;
        let (year, month, day) = add_days(base.year, base.month, base.day, days);
        Self {
            year,
            month,
            day,
            hour: (rest / 3600) as u8,
            minute: (rest / 60 % 60) as u8,
            second: (rest % 60) as u8,
        }
    }

    fn seconds_of_day(&self) -> u64 {
        u64::from(self.hour) * 3600 + u64::from(self.minute) * 60 + u64::from(self.second)
    }
}

fn is_leap(year: u16) -> bool {
    (year.is_multiple_of(4) && !year.is_multiple_of(100)) || year.is_multiple_of(400)
}

fn days_in_month(year: u16, month: u8) -> u8 {
    match month {
        2 if is_leap(year) => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

/// Adds whole days to a date; years saturate at 9999 (the text has four digits).
fn add_days(mut year: u16, mut month: u8, mut day: u8, mut days: u64) -> (u16, u8, u8) {
    while days > 0 && year < 9999 {
        let left_in_month =
            u64::from(days_in_month(year, month) - day.min(days_in_month(year, month)));
        if days <= left_in_month {
            day += days as u8;
            days = 0;
        } else {
            days -= left_in_month + 1;
            day = 1;
            month += 1;
            if month > 12 {
                month = 1;
                year += 1;
            }
        }
    }
    (year, month, day)
}
