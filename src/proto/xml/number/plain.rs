//! Number text digit by digit, which takes the least flash: all of it in a `compact` build;
//! in the default build, the rare floats its fast path leaves to the exact writer. The
//! default build writes the same text a word at a time (`fast`).

#[cfg(feature = "compact")]
use super::I32_TEXT_MAX;

/// Writes an integer in decimal; returns bytes written.
#[cfg(feature = "compact")]
pub fn write_i32(value: i32, out: &mut [u8; I32_TEXT_MAX]) -> usize {
    let magnitude = value.unsigned_abs();
    let mut len = 1;
    let mut rest = magnitude;
    while rest >= 10 {
        rest /= 10;
        len += 1;
    }
    render(value < 0, magnitude, 0, len, out)
}

/// Writes `[-]digits·10^exponent` the way `{}` does, never with an exponent, for `digits`
/// of `len` digits; returns the length. Place by place, from the first digit (or the units,
/// for a number below one) down to the last (or the units, for an integer), with the point
/// after the units if any place follows.
pub(super) fn render(
    negative: bool,
    digits: u32,
    exponent: i32,
    len: usize,
    out: &mut [u8],
) -> usize {
    let mut at = 0;
    let mut put = |byte: u8| {
        if let Some(slot) = out.get_mut(at) {
            *slot = byte;
        }
        at += 1;
    };
    if negative {
        put(b'-');
    }
    // One past the first digit's place.
    let point = len as i32 + exponent;
    let lowest = exponent.min(0);
    // The place value of the digit written next, from the first digit's on.
    let mut power = (1..len).fold(1u32, |power, _| power.saturating_mul(10));
    let mut place = (point - 1).max(0);
    while place >= lowest {
        let digit = if (exponent..point).contains(&place) {
            let digit = digits.checked_div(power).unwrap_or(0) % 10;
            power /= 10;
            digit
        } else {
            0
        };
        put(b'0' + digit as u8);
        if place == 0 && lowest < 0 {
            put(b'.');
        }
        place -= 1;
    }
    at
}
