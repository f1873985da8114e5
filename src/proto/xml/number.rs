//! Number text of the protocol: decimal integers and C `float`s, without `core::fmt`.
//!
//! The robot writes `float` fields with up to 9 significant digits (`-0.00023393621`) and reads
//! whatever decimal we send. core's float parser (`str::parse::<f32>`, ~18 KiB of flash for its
//! tables) and core's float formatting (`{}` on `f32`, ~14 KiB) are far too big for the panel, so
//! this module does both by hand with a fast path in plain `f64`/`u64` arithmetic and a small
//! exact fallback.
//!
//! # Parsing
//!
//! The text is reduced to `n·10^e` with up to 19 significant digits in `n: u64`. An `f64`
//! approximation of `n·10^e` takes at most four rounding steps, so it is within `2^-51` (relative)
//! of the true value: unless it lies within that error of a *midpoint* between two adjacent
//! `f32`s, rounding it to `f32` gives the correctly rounded result. Only inputs that close to a
//! midpoint (exact ties such as `"2097152.25"`, or 2^-45-close ones) go to the exact check,
//! which compares `n·10^e` with the midpoint `k·2^e2` as integers in a 192-bit [`Big`].
//!
//! # Formatting
//!
//! `write_f32` prints the shortest decimal that reads back as the same `f32` (ties between two
//! equally short, equally close candidates go to the larger magnitude), without exponent, exactly
//! as `format!("{}", x)` does. With `s` chosen so that `y = x·10^s` lies in `[10^8, 10^9)`, every
//! shortest candidate is an integer `y`-unit: the float's rounding interval, whose half-width is
//! at least ~1.49 units, is reduced to the integers `[low, high]` it contains, and the answer is
//! the one among them with the most trailing zeros, nearest to `y`. For `10^-6 <= x < 10^9` (all
//! values the robot sends in practice) `y` and the interval are exact in 32.32 fixed point in a
//! `u64`. Elsewhere they come from `f64` arithmetic accurate to `2^-19` units, and only an
//! interval end or a tie within `2^-16` of an integer is settled with the exact comparison.
//!
//! Neither direction allocates, uses `unsafe`, or can panic; all buffers are fixed-size arrays.

use core::cmp::Ordering;

/// Why a number's text was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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

/// Longest text `write_i64` can produce.
pub const I64_TEXT_MAX: usize = 20;

// ---------------------------------------------------------------------------------------------
// Integers
// ---------------------------------------------------------------------------------------------

/// Parses an optionally signed decimal integer (no exponent, no '.', leading '+' allowed) as i64; overflow -> OutOfRange.
pub fn parse_i64(text: &[u8]) -> Result<i64, NumberError> {
    let (negative, digits) = split_sign(text)?;
    if digits.is_empty() {
        return Err(NumberError::Invalid);
    }
    // Accumulate towards the negative side: i64::MIN has no positive counterpart.
    let mut value: i64 = 0;
    let mut overflow = false;
    for &c in digits {
        let d = digit(c).ok_or(NumberError::Invalid)?;
        match value
            .checked_mul(10)
            .and_then(|v| v.checked_sub(i64::from(d)))
        {
            Some(v) => value = v,
            // Keep scanning: a malformed tail is reported as Invalid, not OutOfRange.
            None => overflow = true,
        }
    }
    if overflow {
        return Err(NumberError::OutOfRange);
    }
    if negative {
        Ok(value)
    } else {
        value.checked_neg().ok_or(NumberError::OutOfRange)
    }
}

/// Parses like parse_i64 and converts into a narrower integer type, OutOfRange if it does not fit.
pub fn parse_int<T: TryFrom<i64>>(text: &[u8]) -> Result<T, NumberError> {
    T::try_from(parse_i64(text)?).map_err(|_| NumberError::OutOfRange)
}

/// Writes an integer in decimal; returns bytes written.
pub fn write_i64(value: i64, out: &mut [u8; I64_TEXT_MAX]) -> usize {
    let negative = value < 0;
    let mut magnitude = value.unsigned_abs();
    let len = usize::from(negative) + decimal_len(magnitude);
    // Digits are produced least significant first, so fill the text from its end.
    for slot in out.iter_mut().take(len).skip(usize::from(negative)).rev() {
        *slot = ascii_digit(magnitude % 10);
        magnitude /= 10;
    }
    if negative && let Some(first) = out.first_mut() {
        *first = b'-';
    }
    len
}

/// Splits off one leading '+' or '-'; `Empty` for empty text.
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

/// The ASCII character of `d % 10`.
fn ascii_digit(d: u64) -> u8 {
    // `d % 10 < 10`, so the narrowing keeps the value.
    b'0' + (d % 10) as u8
}

/// Number of decimal digits of `n` (1 for zero); multiplications only, no 64-bit division.
fn decimal_len(n: u64) -> usize {
    let mut len = 1;
    let mut bound: u64 = 10;
    while len < 20 && n >= bound {
        len += 1;
        bound = bound.saturating_mul(10);
    }
    len
}

// ---------------------------------------------------------------------------------------------
// Shared float machinery
// ---------------------------------------------------------------------------------------------

/// Bit pattern of +infinity; as a [`Binary`] it decodes to 2^128, the value just above `f32::MAX`.
const INF_BITS: u32 = 0x7f80_0000;

/// 2^128: every decimal at least this large rounds to infinity.
const TWO_POW_128: f64 = 340_282_366_920_938_463_463_374_607_431_768_211_456.0;

/// Exact `f64` powers of ten (10^22 is the last one an `f64` holds exactly).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Powers of five; 5^13 is the largest that fits a `u32` limb multiplier.
const POW5: [u64; 15] = [
    1,
    5,
    25,
    125,
    625,
    3_125,
    15_625,
    78_125,
    390_625,
    1_953_125,
    9_765_625,
    48_828_125,
    244_140_625,
    1_220_703_125,
    6_103_515_625,
];

/// A non-negative `f32` (or the infinity pattern, as 2^128) written as `m·2^e` with `m < 2^24`.
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
        // `biased <= 255`, so the conversion to i32 is lossless.
        match biased {
            0 => Binary {
                m: fraction,
                e: -149,
            },
            _ => Binary {
                m: fraction | 1 << 23,
                e: biased as i32 - 150,
            },
        }
    }

    /// Whether the gap to the next smaller float is half the gap to the next larger one
    /// (a power of two above the smallest normal).
    fn narrow_below(self) -> bool {
        self.m == 1 << 23 && self.e > -149
    }
}

/// `v·10^e` in at most three rounding steps (for `|e| <= 66`), each with relative error `2^-53`.
fn scale(mut v: f64, mut e: i32) -> f64 {
    while e > 22 {
        v *= 1e22;
        e -= 22;
    }
    while e < -22 {
        v /= 1e22;
        e += 22;
    }
    let p = POW10.get(e.unsigned_abs() as usize).copied().unwrap_or(1.0);
    if e >= 0 { v * p } else { v / p }
}

/// 2^e as an `f64`, for `-1022 <= e <= 1023`.
fn pow2(e: i32) -> f64 {
    let biased = (e + 1023).clamp(1, 2046) as u64;
    f64::from_bits(biased << 52)
}

/// Where the decimal `n·10^e10` (plus a tiny amount if `sticky`) rounds, relative to the
/// non-negative float `bits`: `Less` below it, `Equal` to it, `Greater` above it.
///
/// Round-half-even: a decimal exactly between two floats goes to the one with even `m`.
fn round_check(n: u64, e10: i32, sticky: bool, bits: u32) -> Ordering {
    let x = Binary::decode(bits);
    let odd = x.m % 2 == 1;
    let against = |k: u32, e2: i32| {
        compare(n, e10, k, e2).then(if sticky {
            Ordering::Greater
        } else {
            Ordering::Equal
        })
    };
    // Midpoint to the next float up: (2m+1)·2^(e-1).
    match against(2 * x.m + 1, x.e - 1) {
        Ordering::Greater => return Ordering::Greater,
        Ordering::Equal if odd => return Ordering::Greater,
        _ => {}
    }
    if bits == 0 {
        return Ordering::Equal;
    }
    // Midpoint to the next float down, a quarter step away at a power of two.
    let below = if x.narrow_below() {
        against(4 * x.m - 1, x.e - 2)
    } else {
        against(2 * x.m - 1, x.e - 1)
    };
    match below {
        Ordering::Less => Ordering::Less,
        Ordering::Equal if odd => Ordering::Less,
        _ => Ordering::Equal,
    }
}

/// Compares `n·10^e10` with `k·2^e2` exactly.
///
/// Both sides are brought to integers by moving the power of five to the side where it
/// multiplies: `n·5^e10` vs `k` (for `e10 >= 0`) or `n` vs `k·5^-e10`. Callers keep
/// `-64 <= e10 <= 38`, `n < 2^64` and `k < 2^26`, so neither side exceeds
/// `max(2^64·5^38, 2^26·5^64) < 2^175` bits before the shift, and
/// [`Big::compare_shifted`] never grows a number past the larger of the two: 192 bits suffice.
fn compare(n: u64, e10: i32, k: u32, e2: i32) -> Ordering {
    let mut decimal = Big::from_u64(n);
    let mut binary = Big::from_u64(u64::from(k));
    if e10 >= 0 {
        decimal.mul_pow5(e10.unsigned_abs());
    } else {
        binary.mul_pow5(e10.unsigned_abs());
    }
    decimal.compare_shifted(binary, e10 - e2)
}

/// Number of 32-bit limbs of [`Big`]; see [`compare`] for why 192 bits are enough.
const LIMBS: usize = 6;

/// A fixed-size unsigned integer, least significant limb first, with only what [`compare`] needs.
#[derive(Clone, Copy)]
struct Big([u32; LIMBS]);

impl Big {
    /// The value `v`.
    fn from_u64(v: u64) -> Self {
        Big([v as u32, (v >> 32) as u32, 0, 0, 0, 0])
    }

    /// `self *= factor` (the caller guarantees the product fits).
    fn mul_small(&mut self, factor: u32) {
        let mut carry = 0u64;
        for limb in &mut self.0 {
            // (2^32-1)^2 + (2^32-1) < 2^64: no overflow.
            let product = u64::from(*limb) * u64::from(factor) + carry;
            *limb = product as u32;
            carry = product >> 32;
        }
    }

    /// `self *= 5^e`.
    fn mul_pow5(&mut self, mut e: u32) {
        while e > 0 {
            let step = e.min(13);
            let factor = POW5.get(step as usize).copied().unwrap_or(1);
            self.mul_small(factor as u32);
            e -= step;
        }
    }

    /// Number of significant bits (0 for zero).
    fn bit_len(&self) -> i32 {
        for (i, &limb) in self.0.iter().enumerate().rev() {
            if limb != 0 {
                return (i as i32 + 1) * 32 - limb.leading_zeros() as i32;
            }
        }
        0
    }

    /// `self <<= n` (the caller guarantees the result fits).
    fn shl(&mut self, n: u32) {
        let words = (n / 32) as usize;
        let bits = n % 32;
        let old = self.0;
        let limb = |i: usize, back: usize| {
            i.checked_sub(back)
                .and_then(|j| old.get(j))
                .copied()
                .unwrap_or(0)
        };
        for (i, slot) in self.0.iter_mut().enumerate() {
            let high = limb(i, words);
            *slot = match bits {
                0 => high,
                _ => high << bits | limb(i, words + 1) >> (32 - bits),
            };
        }
    }

    /// Compares `self·2^shift` with `other`.
    fn compare_shifted(mut self, mut other: Big, shift: i32) -> Ordering {
        let (len, other_len) = (self.bit_len(), other.bit_len());
        if len == 0 || other_len == 0 {
            return len.cmp(&other_len);
        }
        // Different bit lengths decide at once; equal ones mean the shift only aligns the
        // shorter number with the longer, so nothing outgrows the wider of the two.
        match (len + shift).cmp(&other_len) {
            Ordering::Equal => {}
            decided => return decided,
        }
        if shift >= 0 {
            self.shl(shift.unsigned_abs());
        } else {
            other.shl(shift.unsigned_abs());
        }
        self.0.iter().rev().cmp(other.0.iter().rev())
    }
}

// ---------------------------------------------------------------------------------------------
// Parsing floats
// ---------------------------------------------------------------------------------------------

/// Parses a decimal float: optional sign, digits with optional '.', optional exponent (e/E, sign, digits).
///
/// No surrounding whitespace, no "inf"/"nan", no hex; ".5" and "5." are accepted (C `strtod`
/// does). The result is correctly rounded (round-half-even) to `f32` for inputs of up to 19
/// significant digits. Digits beyond the 19th only set a sticky bit ("something non-zero
/// follows"), so a longer input that lies within `10^-18` (relative) of the midpoint between two
/// floats may round to the wrong neighbour: an error of at most one unit in the last place, for
/// inputs no `float` printer produces. Values that round above `f32::MAX` are
/// [`NumberError::OutOfRange`]; values too small for the smallest subnormal become ±0.
pub fn parse_f32(text: &[u8]) -> Result<f32, NumberError> {
    let decimal = Decimal::scan(text)?;
    let magnitude = decimal.magnitude()?;
    Ok(if decimal.negative {
        -magnitude
    } else {
        magnitude
    })
}

/// Significant digits kept; 10^19 - 1 is the largest all-nines number a `u64` holds.
const MAX_DIGITS: u32 = 19;

/// Cap on an exponent's digits: far beyond any float, yet adding text-derived offsets to it
/// cannot overflow (additions saturate in any case).
const EXPONENT_CAP: i32 = 1 << 30;

/// Relative distance to a midpoint below which the `f64` estimate is not trusted. The estimate
/// is within `4·2^-53` of the input; `2^-45` leaves a wide safety factor.
const MIDPOINT_MARGIN: f64 = 1.0 / 35_184_372_088_832.0; // 2^-45

/// A decimal `mantissa·10^exponent`, plus `sticky` if non-zero digits were dropped.
struct Decimal {
    negative: bool,
    mantissa: u64,
    exponent: i32,
    sticky: bool,
}

impl Decimal {
    /// Reads the syntax of a float: sign, digits and '.', optional exponent.
    fn scan(text: &[u8]) -> Result<Self, NumberError> {
        let (negative, body) = split_sign(text)?;
        let mut parts = body.splitn(2, |&c| matches!(c, b'e' | b'E'));
        let significand = parts.next().unwrap_or_default();
        let written_exponent = match parts.next() {
            Some(exponent) => scan_exponent(exponent)?,
            None => 0,
        };

        let mut decimal = Decimal {
            negative,
            mantissa: 0,
            exponent: 0,
            sticky: false,
        };
        let mut kept = 0;
        let mut any_digit = false;
        let mut after_point = false;
        for &c in significand {
            if c == b'.' && !after_point {
                after_point = true;
                continue;
            }
            let d = digit(c).ok_or(NumberError::Invalid)?;
            any_digit = true;
            if decimal.mantissa == 0 && d == 0 {
                // A leading zero is not significant; after the point it still moves the scale.
                if after_point {
                    decimal.exponent = decimal.exponent.saturating_sub(1);
                }
            } else if kept < MAX_DIGITS {
                // mantissa < 10^18 here, so this stays below 10^19 < 2^64.
                decimal.mantissa = decimal.mantissa * 10 + u64::from(d);
                kept += 1;
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
        if self.mantissa == 0 {
            return Ok(0.0);
        }
        // The value lies in [10^(digits-1+exponent), 10^(digits+exponent)).
        let digits = decimal_len(self.mantissa) as i32;
        if self.exponent > 39 - digits {
            // At least 10^39 > f32::MAX.
            return Err(NumberError::OutOfRange);
        }
        if self.exponent < -45 - digits {
            // Below 10^-46, less than half the smallest subnormal 2^-149.
            return Ok(0.0);
        }
        // Now -64 <= exponent <= 38, the range `compare` is sized for.
        let approx = scale(self.mantissa as f64, self.exponent);
        if approx >= TWO_POW_128 {
            return Err(NumberError::OutOfRange);
        }
        let guess = (approx as f32).to_bits();
        let bits = if near_midpoint(approx, guess) {
            self.refine(guess)
        } else {
            guess
        };
        if bits >= INF_BITS {
            Err(NumberError::OutOfRange)
        } else {
            Ok(f32::from_bits(bits))
        }
    }

    /// Moves `bits` (a float within one step of the answer) to the exactly rounded float.
    fn refine(&self, mut bits: u32) -> u32 {
        for _ in 0..4 {
            match round_check(self.mantissa, self.exponent, self.sticky, bits) {
                Ordering::Greater if bits < INF_BITS => bits += 1,
                Ordering::Less if bits > 0 => bits -= 1,
                _ => break,
            }
        }
        bits
    }
}

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

/// Whether `approx` (an estimate of the input within `4·2^-53`) is so close to the midpoint
/// between `guess` (its rounding to `f32`) and the neighbour on its side that the estimate's
/// error could put the input on the other side.
fn near_midpoint(approx: f64, guess: u32) -> bool {
    let value = |bits: u32| match bits {
        INF_BITS => TWO_POW_128,
        _ => f64::from(f32::from_bits(bits)),
    };
    let here = value(guess);
    let neighbour = if approx > here {
        guess + 1
    } else {
        // approx > 0, so approx <= here implies guess > 0.
        guess.saturating_sub(1)
    };
    // Two adjacent floats, their sum and its half are exact in f64; so is the difference of
    // two f64s within a factor of two (Sterbenz).
    let midpoint = (here + value(neighbour)) * 0.5;
    (approx - midpoint).abs() <= approx * MIDPOINT_MARGIN
}

// ---------------------------------------------------------------------------------------------
// Formatting floats
// ---------------------------------------------------------------------------------------------

/// Writes `value` in the shortest decimal form that parses back to exactly the same f32, never in exponent notation.
///
/// The text is byte-identical to `format!("{}", value)`: `"-0"` for negative zero, integers
/// without `".0"`, trailing zeros instead of an exponent (`1e30` prints 31 digits). Returns the
/// number of bytes written to the start of `out`; NaN and infinities are
/// [`NumberError::NotFinite`].
pub fn write_f32(value: f32, out: &mut [u8; F32_TEXT_MAX]) -> Result<usize, NumberError> {
    if !value.is_finite() {
        return Err(NumberError::NotFinite);
    }
    let bits = value.to_bits() & !(1 << 31);
    let (digits, exponent) = if bits == 0 { (0, 0) } else { shortest(bits) };
    Ok(render(value.is_sign_negative(), digits, exponent, out))
}

/// Shortest digits `d` and exponent `k` with `d·10^k` reading back as the positive float `bits`.
fn shortest(bits: u32) -> (u32, i32) {
    let x = Binary::decode(bits);
    // floor(log2 x) + 1, and floor of that times log10(2) (exact for |v| < 1650 with this
    // constant): 10^estimate <= 10·x, so the decimal exponent of x is `estimate` or one less.
    let bit_top = x.e + (32 - x.m.leading_zeros()) as i32;
    let estimate = (bit_top * 78_913) >> 18;
    let s = 8 - estimate;
    let window = Window::exact(bits, x, s).unwrap_or_else(|| Window::approximate(bits, x, s));
    window.pick(x)
}

/// Half-width (in `y`-units) below which an inexact position is checked exactly; the `f64`
/// arithmetic of [`Window::approximate`] is accurate to about `2^-20` units.
const TIE_MARGIN: f64 = 1.0 / 65_536.0;

/// `y = x·10^scale`, in `[10^8, 10^9)`, either exactly in 32.32 fixed point or as an `f64`.
#[derive(Clone, Copy)]
enum Scaled {
    Exact(u64),
    Approx(f64),
}

/// The integers `low..=high` (in units of `10^-scale`) that read back as `x`, and `x` itself.
struct Window {
    low: u32,
    high: u32,
    scale: i32,
    y: Scaled,
    bits: u32,
}

impl Window {
    /// The window in 32.32 fixed point, if `y` and both interval ends are exact there: for
    /// `0 <= s <= 14` and a quarter-step `5^s·2^(e+s-2)` of at least `2^-32`, i.e. roughly
    /// `10^-6 <= x < 10^9`.
    fn exact(bits: u32, x: Binary, s: i32) -> Option<Self> {
        let p5 = POW5.get(usize::try_from(s).ok()?).copied()?;
        let quarter = u32::try_from(x.e + s + 30).ok()?;
        // m·5^s < 2^24·5^14 < 2^57; y < 10^9 keeps y·2^32 below 2^62, and `shl` checks anyway.
        let mut y = shl(u64::from(x.m) * p5, quarter + 2)?;
        let mut above = shl(p5, quarter + 1)?;
        let mut below = if x.narrow_below() {
            p5 << quarter
        } else {
            above
        };
        let mut scale = s;
        if y < 100_000_000 << 32 {
            // The estimate was one too high; y < 10^8·2^32 < 2^59 so this cannot overflow.
            y *= 10;
            above *= 10;
            below *= 10;
            scale += 1;
        }
        let (lo, hi) = (y - below, y + above);
        const FRACTION: u64 = (1 << 32) - 1;
        // Ends belong to the interval when m is even (the reader rounds ties to even).
        let (low, high) = if x.m.is_multiple_of(2) {
            ((lo + FRACTION) >> 32, hi >> 32)
        } else {
            ((lo >> 32) + 1, (hi - 1) >> 32)
        };
        Some(Window {
            low: low as u32,
            high: high as u32,
            scale,
            y: Scaled::Exact(y),
            bits,
        })
    }

    /// The window from `f64` arithmetic, with ends near an integer settled exactly.
    fn approximate(bits: u32, x: Binary, s: i32) -> Self {
        // At most 3 + 1 roundings: |error| <= 5·2^-53·2^30 < 2^-20 units.
        let mut y = scale(f64::from(f32::from_bits(bits)), s);
        let mut above = scale(pow2(x.e - 1), s);
        let mut scale_ = s;
        if y < 1e8 {
            y *= 10.0;
            above *= 10.0;
            scale_ += 1;
        }
        let below = if x.narrow_below() { above * 0.5 } else { above };
        let mut window = Window {
            low: 0,
            high: 0,
            scale: scale_,
            y: Scaled::Approx(y),
            bits,
        };
        window.low = window.end(y - below, true);
        window.high = window.end(y + above, false);
        window
    }

    /// The first (`lower`) or last integer inside the interval whose end is near `end`.
    fn end(&self, end: f64, lower: bool) -> u32 {
        let floor = end as u32;
        let fraction = end - f64::from(floor);
        if fraction > TIE_MARGIN && fraction < 1.0 - TIE_MARGIN {
            return if lower { floor + 1 } else { floor };
        }
        let nearest = if fraction <= TIE_MARGIN {
            floor
        } else {
            floor + 1
        };
        let inside = self.reads_back(nearest);
        match (lower, inside) {
            (_, true) => nearest,
            (true, false) => nearest.saturating_add(1),
            (false, false) => nearest.saturating_sub(1),
        }
    }

    /// Whether `candidate·10^-scale` parses back to the float.
    fn reads_back(&self, candidate: u32) -> bool {
        round_check(u64::from(candidate), -self.scale, false, self.bits) == Ordering::Equal
    }

    /// The shortest integer in the window, nearest to `y`, ties to the larger one; returned as
    /// digits and decimal exponent.
    fn pick(&self, x: Binary) -> (u32, i32) {
        // The largest power of ten with a multiple inside the window.
        let mut step = 1u32;
        let mut zeros = 0;
        while let Some(next) = step.checked_mul(10) {
            let top = self.high.checked_div(next).unwrap_or(0) * next;
            if top < self.low {
                break;
            }
            step = next;
            zeros += 1;
        }
        // The nearest multiple of `step` is one of the two around y.
        let floor = match self.y {
            Scaled::Exact(y) => (y >> 32) as u32,
            Scaled::Approx(y) => y as u32,
        };
        let down = floor.checked_div(step).unwrap_or(0) * step;
        let up = down.saturating_add(step);
        let inside = |c: u32| (self.low..=self.high).contains(&c);
        let chosen = match (inside(down), inside(up)) {
            (true, true) if self.up_is_nearer(down, step, x) => up,
            (true, _) => down,
            _ => up,
        };
        (chosen.checked_div(step).unwrap_or(0), zeros - self.scale)
    }

    /// Whether `y >= down + step/2`.
    fn up_is_nearer(&self, down: u32, step: u32, x: Binary) -> bool {
        // 2·down + step < 2^33: below 2^32 units each.
        let twice_mid = 2 * u64::from(down) + u64::from(step);
        match self.y {
            Scaled::Exact(y) => y >= twice_mid << 31,
            Scaled::Approx(y) => {
                let distance = y - twice_mid as f64 * 0.5;
                if distance.abs() > TIE_MARGIN {
                    return distance > 0.0;
                }
                // mid = twice_mid/2·10^-scale = twice_mid·5·10^(-scale-1).
                compare(twice_mid * 5, -self.scale - 1, x.m, x.e) != Ordering::Greater
            }
        }
    }
}

/// `v << n` if no bit is lost and the result stays below 2^63.
fn shl(v: u64, n: u32) -> Option<u64> {
    (n < v.leading_zeros()).then(|| v << n)
}

/// Writes `[-]digits·10^exponent` the way `{}` does, never with an exponent.
fn render(negative: bool, digits: u32, exponent: i32, out: &mut [u8; F32_TEXT_MAX]) -> usize {
    let mut text = Cursor { out, len: 0 };
    if negative {
        text.push(b'-');
    }
    let mut buffer = [0u8; 10];
    let digits = ascii_u32(digits, &mut buffer);
    if exponent >= 0 {
        text.extend(digits);
        for _ in 0..exponent {
            text.push(b'0');
        }
        return text.len;
    }
    let fraction = exponent.unsigned_abs() as usize;
    match digits.len().checked_sub(fraction) {
        Some(whole) if whole > 0 => {
            let (int, frac) = digits.split_at_checked(whole).unwrap_or((digits, &[]));
            text.extend(int);
            text.push(b'.');
            text.extend(frac);
        }
        _ => {
            text.extend(b"0.");
            for _ in digits.len()..fraction {
                text.push(b'0');
            }
            text.extend(digits);
        }
    }
    text.len
}

/// The decimal digits of `v`, without leading zeros ("0" for zero), inside `buffer`.
fn ascii_u32(mut v: u32, buffer: &mut [u8; 10]) -> &[u8] {
    let mut len = 0;
    for slot in buffer.iter_mut().rev() {
        *slot = b'0' + (v % 10) as u8;
        v /= 10;
        len += 1;
        if v == 0 {
            break;
        }
    }
    buffer.get(10 - len..).unwrap_or_default()
}

/// Appends bytes to the output array; positions past its end are dropped (none are reached:
/// see [`F32_TEXT_MAX`]).
struct Cursor<'a> {
    out: &'a mut [u8; F32_TEXT_MAX],
    len: usize,
}

impl Cursor<'_> {
    fn push(&mut self, c: u8) {
        if let Some(slot) = self.out.get_mut(self.len) {
            *slot = c;
            self.len += 1;
        }
    }

    fn extend(&mut self, bytes: &[u8]) {
        for &c in bytes {
            self.push(c);
        }
    }
}
