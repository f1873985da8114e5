//! Number text of the protocol: decimal integers and C `float`s, without `core::fmt`.
//!
//! The robot writes `float` fields with up to 9 significant digits (`-0.00023393621`) and reads
//! whatever decimal we send. core's float parser (`str::parse::<f32>`, ~18 KiB of flash for its
//! tables) and core's float formatting (`{}` on `f32`, ~14 KiB) are far too big for the panel, so
//! this module does both by hand, in integer arithmetic only: the Cortex-M4F has no
//! double-precision FPU, and software `f64` alone would cost ~4 KiB. No 64-bit division is
//! used anywhere (it would pull in a ~1 KiB library routine).
//!
//! # Exactly, and fast where it is safe
//!
//! Both directions are exact conversions in big-integer arithmetic (module `exact`):
//!
//! - Reading: the text is reduced to `n·10^e`, `n` its first 120 significant digits (any
//!   beyond lie below the last digit of every midpoint between floats, so whether they are
//!   zero only breaks a tie), and `n·10^e` is divided out to 27 bits and rounded to `f32`,
//!   half to even.
//! - Writing: `write_f32` prints the shortest decimal that reads back as the same `f32`, and
//!   of those the nearest (between two equally near, the larger magnitude), without exponent,
//!   exactly as `format!("{}", x)` does. Its digits come one at a time from the float and the
//!   ends of its rounding interval, scaled to integers, until the decimal cut off there, or
//!   one unit above it, falls inside the interval.
//!
//! The exact reader keeps a text's first nine significant digits in a word; a big integer
//! takes them at a tenth. A `compact` build reads the usual text (digits that fit a word, at
//! most 13 of them after the point) by the same long division in machine words, and
//! everything else as above. The default build first tries approximations that settle
//! almost every number in a few multiplications, and are exact wherever they answer (module
//! `fast`); the rest goes the exact way. The chosen digits (at most nine) are made at once,
//! eight of them in one word's lanes, and the text, zeros included, is written with 8-byte
//! stores.
//!
//! Neither direction allocates, uses `unsafe`, or can panic; all buffers are fixed-size arrays.

mod big;
mod exact;
#[cfg(not(feature = "compact"))]
mod fast;
mod plain;

use big::Big;
#[cfg(not(feature = "compact"))]
pub use fast::short_int_prefix;
#[cfg(not(feature = "compact"))]
pub use fast::write_i32;
#[cfg(feature = "compact")]
pub use plain::write_i32;

/// Why a number's text was rejected.
///
/// (Its `defmt::Format` impl is in `proto::display`: the build script includes this file,
/// and has no defmt.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum NumberError {
    /// The text is empty.
    Empty,
    /// The text is not a decimal number (names the problem by being this variant).
    Invalid,
    /// The number is well formed but does not fit the target type.
    OutOfRange,
    /// The value is NaN or infinite and has no text form in the protocol.
    NotFinite,
}

/// Longest text `write_f32` can produce (sign, "0." and 45 fraction digits, for `-1e-45`).
///
/// The longest integer form is 39 digits (`f32::MAX`); the last digit of any shortest form is at
/// or above `10^-45`, because the rounding interval of every `f32` is at least `1.4e-45` wide.
pub const F32_TEXT_MAX: usize = 48;

/// Longest text `write_i32` can produce (`-2147483648`).
pub const I32_TEXT_MAX: usize = 11;

// ---------------------------------------------------------------------------------------------
// Integers
// ---------------------------------------------------------------------------------------------

/// Parses an optionally signed decimal integer (no exponent, no '.', leading '+' allowed) as i64; overflow -> OutOfRange.
pub fn parse_i64(text: &[u8]) -> Result<i64, NumberError> {
    let (value, used) = scan_i64(text);
    match value {
        Err(NumberError::Empty) => Err(NumberError::Empty),
        // Anything after the digits makes the text Invalid, even if they overflowed.
        _ if used != text.len() => Err(NumberError::Invalid),
        value => value,
    }
}

/// The integer at the start of `text` and the length of its text, if it is one that
/// [`parse_int`] accepts: `parse_int(&text[..n])` gives the same value. For reading a
/// number and finding where its text ends in one pass.
pub fn parse_int_prefix<T: TryFrom<i64>>(text: &[u8]) -> Option<(T, usize)> {
    let (value, used) = scan_i64(text);
    Some((T::try_from(value.ok()?).ok()?, used))
}

/// The value of the sign and digits at the start of `text`, and their length; reading
/// stops at the first byte that cannot continue them.
fn scan_i64(text: &[u8]) -> (Result<i64, NumberError>, usize) {
    let (negative, body) = match split_sign(text) {
        Ok(split) => split,
        Err(e) => return (Err(e), 0),
    };
    let digits = body.iter().take_while(|c| c.is_ascii_digit()).count();
    let used = text.len() - body.len() + digits;
    if digits == 0 {
        return (Err(NumberError::Invalid), used);
    }
    let digits = body.get(..digits).unwrap_or_default();
    let mut magnitude = 0u64;
    for &c in digits {
        magnitude = magnitude.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
    }
    // Any 19 digits fit a u64, and more than 19 past leading zeros never fit an i64; the
    // magnitude may have wrapped only then.
    let too_long = digits.len() > 19
        && digits
            .iter()
            .position(|&c| c != b'0')
            .is_some_and(|first| digits.len() - first > 19);
    // i64::MIN's magnitude is one more than i64::MAX's.
    let limit = i64::MAX as u64 + u64::from(negative);
    let value = if too_long || magnitude > limit {
        Err(NumberError::OutOfRange)
    } else if negative {
        Ok(0i64.wrapping_sub_unsigned(magnitude))
    } else {
        Ok(magnitude as i64)
    };
    (value, used)
}

/// Parses like parse_i64 and converts into a narrower integer type, OutOfRange if it does not fit.
pub fn parse_int<T: TryFrom<i64>>(text: &[u8]) -> Result<T, NumberError> {
    T::try_from(parse_i64(text)?).map_err(|_| NumberError::OutOfRange)
}

/// Splits off one leading '+' or '-'; `Empty` for empty text. Out of line in a `compact`
/// build, whose three readers of numbers share it.
#[cfg_attr(feature = "compact", inline(never))]
fn split_sign(text: &[u8]) -> Result<(bool, &[u8]), NumberError> {
    match text.split_first() {
        None => Err(NumberError::Empty),
        Some((b'-', rest)) => Ok((true, rest)),
        Some((b'+', rest)) => Ok((false, rest)),
        Some(_) => Ok((false, text)),
    }
}

/// The value of an ASCII decimal digit.
fn digit(c: u8) -> Option<u8> {
    let d = c.wrapping_sub(b'0');
    (d < 10).then_some(d)
}

// ---------------------------------------------------------------------------------------------
// Floats as integers
// ---------------------------------------------------------------------------------------------

/// Bit pattern of +infinity; as a [`Binary`] it decodes to 2^128, the value just above `f32::MAX`.
const INF_BITS: u32 = 0x7f80_0000;

/// A non-negative `f32` (or the infinity pattern, as 2^128) as `m·2^e` with `m < 2^24`.
#[derive(Clone, Copy)]
struct Binary {
    m: u32,
    e: i32,
}

impl Binary {
    /// Splits the bits of a non-negative `f32` into significand and exponent.
    fn decode(bits: u32) -> Self {
        let biased = (bits >> 23) & 0xff;
        let fraction = bits & 0x007f_ffff;
        match biased {
            0 => Binary {
                m: fraction,
                e: -149,
            },
            _ => Self::decode_normal(bits),
        }
    }

    /// [`Binary::decode`] for the bits of a normal float.
    fn decode_normal(bits: u32) -> Self {
        Binary {
            m: bits & 0x007f_ffff | 1 << 23,
            // At most 255: the conversion is lossless.
            e: (bits >> 23 & 0xff) as i32 - 150,
        }
    }

    /// Whether the gap to the next smaller float is half the gap to the next larger one
    /// (a power of two above the smallest normal).
    fn narrow_below(self) -> bool {
        self.m == 1 << 23 && self.e > -149
    }
}

/// The bits of a float rounded to the last place `2^lsb` (`lsb >= -149`), where `kept` is
/// its significand there and `up` says whether it rounds up; [`INF_BITS`] on overflow.
fn float_bits(lsb: i32, kept: u32, up: bool) -> u32 {
    // `lsb + 149` is the biased exponent less one for a normal float (whose `kept` holds the
    // leading one), 0 for a subnormal; a carry out of the significand steps the exponent, as
    // it should, and reaches INF_BITS on overflow.
    let exponent = ((lsb + 149) as u32).min(255);
    ((exponent << 23) + kept + u32::from(up)).min(INF_BITS)
}

// ---------------------------------------------------------------------------------------------
// Parsing floats
// ---------------------------------------------------------------------------------------------

/// Parses a decimal float: optional sign, digits with optional '.', optional exponent (e/E, sign, digits).
///
/// No surrounding whitespace, no "inf"/"nan" (answers read those with
/// [`parse_non_finite`]), no hex; ".5" and "5." are accepted (C `strtod` does). The result
/// is correctly rounded (round-half-even) to `f32` for any number of digits (up to 120
/// significant ones settle it). Values that round above `f32::MAX`
/// are [`NumberError::OutOfRange`]; values too small for the smallest subnormal become ±0.
pub fn parse_f32(text: &[u8]) -> Result<f32, NumberError> {
    // The default build reads the usual text (no exponent, 19 bytes at most) in a word and
    // settles almost every such decimal by approximation; the rest, and every decimal in a
    // `compact` build, is read exactly.
    #[cfg(not(feature = "compact"))]
    if let Some(value) = fast::parse_f32(text) {
        return Ok(value);
    }
    let decimal = Decimal::<Exact>::scan(text)?;
    let magnitude = decimal.magnitude()?;
    Ok(if decimal.negative {
        -magnitude
    } else {
        magnitude
    })
}

/// Reads the words C's `printf` writes for a float that has no numeric value: `nan`, `inf`
/// or `infinity`, optionally signed, in any ASCII case (`-nan`, `INF`).
///
/// Only answers are read with it, where a robot reports a reading it does not have (an
/// unknown pose). [`parse_f32`] refuses these words: a speed typed on the console or a
/// request's coordinate must be a number.
pub fn parse_non_finite(text: &[u8]) -> Option<f32> {
    let (negative, word) = split_sign(text).ok()?;
    let magnitude = match folded(word) {
        NAN => f32::NAN,
        INF | INFINITY => f32::INFINITY,
        _ => return None,
    };
    Some(if negative { -magnitude } else { magnitude })
}

/// A word of up to eight bytes as one number, its letters folded to lower case; 0 for a
/// longer one. Setting bit 5 turns no other byte into a letter, and no byte into zero, so
/// words of different lengths never share a number.
const fn folded(word: &[u8]) -> u64 {
    if word.len() > 8 {
        return 0;
    }
    let mut key = 0;
    let mut rest = word;
    while let [c, tail @ ..] = rest {
        key = key << 8 | (*c | 0x20) as u64;
        rest = tail;
    }
    key
}

/// [`folded`] of the words C prints for NaN and infinity.
const NAN: u64 = folded(b"nan");
const INF: u64 = folded(b"inf");
const INFINITY: u64 = folded(b"infinity");

/// Cap on an exponent's digits: far beyond any float, yet adding text-derived offsets to it
/// cannot overflow (additions saturate in any case).
const EXPONENT_CAP: i32 = 1 << 30;

/// A decimal `mantissa·10^exponent`, plus `sticky` if non-zero digits were dropped past the
/// mantissa's last, with the mantissa's digits kept as `D` keeps them.
struct Decimal<D> {
    negative: bool,
    mantissa: D,
    exponent: i32,
    sticky: bool,
}

/// The significant digits that settle any decimal's rounding: up to [`EXACT_DIGITS`] of them.
struct Exact {
    /// The digits while there are at most [`WORD_DIGITS`] of them.
    word: u32,
    /// The digits once there are more.
    digits: Big,
    /// How many significant digits were taken (leading zeros are not).
    count: u32,
}

/// Significant digits kept in a machine word before a big integer takes them (nine fit):
/// each costs a multiplication of one word instead of all the big integer's limbs. A
/// `compact` build reads every number here, most with at most nine digits, and its 1002
/// answer's decode takes 12 % fewer instructions for it (60 bytes of flash); the default
/// build reads only rare texts here, and pays 32 bytes.
const WORD_DIGITS: u32 = 9;

impl Exact {
    /// No digit yet.
    const NONE: Self = Exact {
        word: 0,
        digits: Big::ZERO,
        count: 0,
    };

    /// Takes `digit` after the digits taken, or returns `false` if there is no room for it,
    /// which drops it.
    fn push(&mut self, digit: u8) -> bool {
        let room = self.count < EXACT_DIGITS;
        if room {
            if self.count < WORD_DIGITS {
                self.word = self.word * 10 + u32::from(digit);
            } else {
                if self.count == WORD_DIGITS {
                    self.digits = self.value();
                }
                self.digits.mul_add(10, u32::from(digit));
            }
            self.count += u32::from(self.count > 0 || digit != 0);
        }
        room
    }

    /// All the digits taken, as one number.
    fn value(&self) -> Big {
        if self.count <= WORD_DIGITS {
            Big::from_u64(self.word.into())
        } else {
            self.digits
        }
    }
}

impl Decimal<Exact> {
    /// Reads the syntax of a float: sign, digits and '.', optional exponent.
    fn scan(text: &[u8]) -> Result<Self, NumberError> {
        let (negative, body) = split_sign(text)?;
        let mut decimal = Decimal {
            negative,
            mantissa: Exact::NONE,
            exponent: 0,
            sticky: false,
        };
        let mut written_exponent = 0;
        let mut any_digit = false;
        let mut after_point = false;
        for (i, &c) in body.iter().enumerate() {
            let d = match c {
                b'0'..=b'9' => c - b'0',
                b'.' if !after_point => {
                    after_point = true;
                    continue;
                }
                b'e' | b'E' => {
                    written_exponent = scan_exponent(body.get(i + 1..).unwrap_or_default())?;
                    break;
                }
                _ => return Err(NumberError::Invalid),
            };
            any_digit = true;
            // A digit taken after the point lowers the exponent; one dropped before it
            // raises it.
            if decimal.mantissa.push(d) {
                if after_point {
                    decimal.exponent = decimal.exponent.saturating_sub(1);
                }
            } else {
                decimal.sticky |= d != 0;
                if !after_point {
                    decimal.exponent = decimal.exponent.saturating_add(1);
                }
            }
        }
        if !any_digit {
            return Err(NumberError::Invalid);
        }
        decimal.exponent = decimal.exponent.saturating_add(written_exponent);
        Ok(decimal)
    }

    /// The correctly rounded magnitude.
    fn magnitude(&self) -> Result<f32, NumberError> {
        let (digits, count) = (self.mantissa.value(), self.mantissa.count);
        if count == 0 {
            return Ok(0.0);
        }
        // The value lies in [10^(top-1), 10^top).
        let top = self.exponent.saturating_add(count as i32);
        if top > 39 {
            // At least 10^39 > f32::MAX.
            return Err(NumberError::OutOfRange);
        }
        if top < -45 {
            // Below 10^-46, less than half the smallest subnormal 2^-149.
            return Ok(0.0);
        }
        // Now `count <= 120` digits, `exponent >= -45 - 120` and the value below 10^39: within
        // `exact::to_f32`'s bounds.
        finite(exact::to_f32(digits, self.exponent, self.sticky))
    }
}

/// The float of `bits`, which is [`INF_BITS`] or more when the decimal rounded above
/// `f32::MAX`.
fn finite(bits: u32) -> Result<f32, NumberError> {
    if bits >= INF_BITS {
        Err(NumberError::OutOfRange)
    } else {
        Ok(f32::from_bits(bits))
    }
}

/// Significant digits read exactly when the 19 kept do not settle the rounding. Every
/// midpoint between floats, `k·2^e2` with `k < 2^26` and `e2 >= -151`, has its last
/// significant digit at or above 10^-151, and its first within one place of the decimal's
/// first when the two are near; so 120 digits from the decimal's first reach below every
/// such midpoint's last, and a midpoint near the decimal is a multiple of the last kept
/// digit's place (as [`exact::to_f32`] needs). 10^120 fits [`Big`].
const EXACT_DIGITS: u32 = 120;

/// The digits after 'e': optional sign and at least one digit, saturated at [`EXPONENT_CAP`].
fn scan_exponent(text: &[u8]) -> Result<i32, NumberError> {
    let (negative, digits) = split_sign(text).map_err(|_| NumberError::Invalid)?;
    if digits.is_empty() {
        return Err(NumberError::Invalid);
    }
    let mut value: i32 = 0;
    for &c in digits {
        let d = digit(c).ok_or(NumberError::Invalid)?;
        value = value
            .saturating_mul(10)
            .saturating_add(i32::from(d))
            .min(EXPONENT_CAP);
    }
    Ok(if negative { -value } else { value })
}
// ---------------------------------------------------------------------------------------------
// Formatting floats
// ---------------------------------------------------------------------------------------------

/// Writes `value` in the shortest decimal form that parses back to exactly the same f32, never in exponent notation.
///
/// The text is byte-identical to `format!("{}", value)`: `"-0"` for negative zero, integers
/// without `".0"`, trailing zeros instead of an exponent (`1e30` prints 31 digits). Returns the
/// length of the text at the start of `out`; the bytes after it may be overwritten too (the
/// text is stored eight bytes at a time). NaN and infinities are [`NumberError::NotFinite`].
pub fn write_f32(value: f32, out: &mut [u8; F32_TEXT_MAX]) -> Result<usize, NumberError> {
    if !value.is_finite() {
        return Err(NumberError::NotFinite);
    }
    Ok(write_finite(value, out))
}

/// [`write_f32`] for a value the caller has checked is finite: NaN and infinities must not
/// come here. The document writer checks first, because its items loop keeps the text's
/// length in a register then, where a `Result` would come back through memory.
///
/// In the default build, the usual float's digits are chosen by [`fast::Window`] and
/// written here without a call, which would make the compiler save and restore more
/// registers; in a `compact` build, a whole number below 2^24 is written by [`write_i32`].
/// Zero and any other float go to [`write_exact`]. The compiler keeps this function out of
/// line by itself.
pub(crate) fn write_finite(value: f32, out: &mut [u8; F32_TEXT_MAX]) -> usize {
    // A `compact` build writes a whole number below 2^24 as the integer it is: that halves
    // the encoding of a stop, whose `Value` is -1 (2495 Cortex-M instructions instead of
    // 5168, `scripts/codec-count.sh`). Floats that far up lie at most one apart, so no
    // shorter decimal reads back as the same float (above 2^24 one may: 67108872 is written
    // 67108870). Zero keeps its sign the exact way.
    #[cfg(feature = "compact")]
    {
        let whole = value as i32;
        if whole != 0
            && whole as f32 == value
            && whole.unsigned_abs() < 1 << 24
            && let Some(out) = out.first_chunk_mut()
        {
            return write_i32(whole, out);
        }
    }
    #[cfg(not(feature = "compact"))]
    if let Some(window) = fast::Window::new(value.to_bits() & !(1 << 31)) {
        let (digits, exponent, len) = window.pick();
        return fast::render(value.is_sign_negative(), digits, exponent, len, out);
    }
    write_exact(value, out)
}

/// [`write_finite`] for zero and for a float the fast path does not take (every float in a
/// `compact` build). Its text is written digit by digit (`plain`), in the default build too:
/// this path is rare there, and a second copy of the fast path's word-at-a-time writing
/// took 292 bytes more flash. Not marked cold there: that took 16 bytes more.
#[inline(never)]
fn write_exact(value: f32, out: &mut [u8; F32_TEXT_MAX]) -> usize {
    let (digits, exponent, len) = match value.to_bits() & !(1 << 31) {
        0 => (0, 0, 1),
        bits => exact::shortest(bits),
    };
    plain::render(value.is_sign_negative(), digits, exponent, len, out)
}

/// Writes a float of an answer, which may report a reading the robot does not have: a
/// finite `value` as [`write_f32`] does, a NaN or an infinity as C's `printf` does (`nan`,
/// `-nan`, `inf`, `-inf`); returns the length. The bytes after the text may be overwritten.
// Out of line: one call for every float item of an answer, the words off its usual path.
#[inline(never)]
pub fn write_reading(value: f32, out: &mut [u8; F32_TEXT_MAX]) -> usize {
    if value.is_finite() {
        return write_finite(value, out);
    }
    let word: &[u8] = match (value.is_nan(), value.is_sign_negative()) {
        (true, false) => b"nan",
        (true, true) => b"-nan",
        (false, false) => b"inf",
        (false, true) => b"-inf",
    };
    for (slot, &c) in out.iter_mut().zip(word) {
        *slot = c;
    }
    word.len()
}

/// Eight ASCII zeros in a word.
const ZERO_DIGITS: u64 = u64::from_le_bytes([b'0'; 8]);

/// The ASCII digits of four numbers below 100, one in each 16-bit lane of `x`: the tens in
/// the lane's low byte, the ones in its high byte. Dividing by ten is a multiplication, exact
/// in every lane below 179.
pub(crate) fn two_digit_lanes(x: u64) -> u64 {
    let tens = ((x * 103) >> 10) & 0x000f_000f_000f_000f;
    split_lanes(x, tens, 10, 8) | ZERO_DIGITS
}

/// Each lane of `x` split by `divisor`, given the lanes' quotients `quotient`: the quotient
/// stays in the lane's low part, the remainder goes `shift` bits up. Written as
/// `(x << shift) - quotient·((divisor << shift) - 1)`, which is that exactly, so that the
/// split is one multiplication and a subtraction after the quotient, not four steps: the
/// float writer's digits wait on it. Each lane's quotient and remainder must fit its parts.
#[inline(always)]
pub(crate) fn split_lanes(x: u64, quotient: u64, divisor: u64, shift: u32) -> u64 {
    (x << shift) - quotient * ((divisor << shift) - 1)
}
