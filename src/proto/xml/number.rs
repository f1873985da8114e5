//! Number text of the protocol: decimal integers and C `float`s, without `core::fmt`.
//!
//! The robot writes `float` fields with up to 9 significant digits (`-0.00023393621`) and reads
//! whatever decimal we send. core's float parser (`str::parse::<f32>`, ~18 KiB of flash for its
//! tables) and core's float formatting (`{}` on `f32`, ~14 KiB) are far too big for the panel, so
//! this module does both by hand, in integer arithmetic only: the Cortex-M4F has no
//! double-precision FPU, and software `f64` alone would cost ~4 KiB. 64×64→128-bit products
//! compile to a few `UMULL`/`UMLAL`, and no 64-bit division is used anywhere (it would pull in
//! a ~1 KiB library routine).
//!
//! # Approximation, then exactness where it matters
//!
//! Both directions first compute with `Approx`, a 64-bit significand and binary exponent, and
//! `10^e` as one product of two table entries, `5^(16q)` and `5^r` (`e = 16q + r`): relative
//! error below `2^-62`.
//! Rounding to `f32` only changes at the *midpoints* between adjacent floats, and shortest
//! decimal output only at the ends of a float's rounding interval and at ties between two
//! candidates; when the approximation is too close to one of those for its error bound, the
//! question is settled exactly by comparing `n·10^e` with `k·2^e2` as integers of at most 192
//! bits (`compare`). That happens for about one input in 2^30, and for exact ties.
//!
//! # Parsing
//!
//! The text is reduced to `n·10^e` with up to 19 significant digits in `n: u64`; digits past the
//! 19th only set a sticky bit. `n·10^e` is approximated, rounded to `f32` with round-half-even,
//! and refined exactly when it lies near a midpoint.
//!
//! # Formatting
//!
//! `write_f32` prints the shortest decimal that reads back as the same `f32` (ties between two
//! equally short, equally close candidates go to the larger magnitude), without exponent, exactly
//! as `format!("{}", x)` does. With `s` chosen so that `y = x·10^s` lies in `[10^8, 10^9)`, every
//! shortest candidate is an integer number of `y`-units, because the float's rounding interval is
//! at least ~2.9 units wide: the interval is reduced to the integers `low..=high` it contains,
//! and the answer is the one with the most trailing zeros, nearest to `y`. `y` and the interval
//! are held in 32.32 fixed point; for `10^-6 <= x < 10^9` (all values the panel sends in
//! practice) they are exact there, so no approximation is involved at all. The chosen digits
//! (at most nine) are made at once, eight of them in one word's lanes, and the text, zeros
//! included, is written with 8-byte stores.
//!
//! Neither direction allocates, uses `unsafe`, or can panic; all buffers are fixed-size arrays.

use core::cmp::Ordering;

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
    // Accumulate towards the negative side: i64::MIN has no positive counterpart.
    let mut value: i64 = 0;
    let mut overflow = false;
    for &c in body.get(..digits).unwrap_or_default() {
        match value
            .checked_mul(10)
            .and_then(|v| v.checked_sub(i64::from(c - b'0')))
        {
            Some(v) => value = v,
            None => overflow = true,
        }
    }
    let value = match (overflow, negative) {
        (true, _) => Err(NumberError::OutOfRange),
        (false, true) => Ok(value),
        (false, false) => value.checked_neg().ok_or(NumberError::OutOfRange),
    };
    (value, used)
}

/// Parses like parse_i64 and converts into a narrower integer type, OutOfRange if it does not fit.
pub fn parse_int<T: TryFrom<i64>>(text: &[u8]) -> Result<T, NumberError> {
    T::try_from(parse_i64(text)?).map_err(|_| NumberError::OutOfRange)
}

/// Writes an integer in decimal; returns bytes written. The bytes after the text may be
/// overwritten too (its last eight digits are stored as one word).
pub fn write_i32(value: i32, out: &mut [u8; I32_TEXT_MAX]) -> usize {
    // Most items are codes and counts of one digit.
    if let Ok(digit @ 0..=9) = u8::try_from(value) {
        out[0] = b'0' + digit;
        return 1;
    }
    let negative = value < 0;
    let mut at = usize::from(negative);
    if negative {
        out[0] = b'-';
    }
    // At most ten digits: up to two above the last eight, then those eight made all at
    // once and stored as a word, the text's digits at its top.
    let magnitude = value.unsigned_abs();
    let (high, low) = (magnitude / 100_000_000, magnitude % 100_000_000);
    let low_len = if high == 0 {
        decimal_len(low)
    } else {
        if high >= 10 {
            put(out, at, b'0' + (high / 10) as u8);
            at += 1;
        }
        put(out, at, b'0' + (high % 10) as u8);
        at += 1;
        8
    };
    store8(out, at, eight_ascii(low) >> (8 * (8 - low_len)));
    at + low_len
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

/// Number of decimal digits of `n < 10^8` (1 for zero), counted up from one: integers are
/// mostly short.
fn decimal_len(n: u32) -> usize {
    let mut len = 1;
    let mut bound = 10;
    while len < 8 && n >= bound {
        len += 1;
        bound *= 10;
    }
    len
}

// ---------------------------------------------------------------------------------------------
// Floats as integers
// ---------------------------------------------------------------------------------------------

/// Bit pattern of +infinity; as a [`Binary`] it decodes to 2^128, the value just above `f32::MAX`.
const INF_BITS: u32 = 0x7f80_0000;

/// `floor(k·log2(5))` for `-64 <= k < 64` (in 12.20 fixed point; checked for each such `k`).
fn log2_pow5(k: i32) -> i32 {
    (k * 2_434_718) >> 20
}

/// An entry of a table of significands (`2^63`, i.e. one, past its end).
fn table(entries: &[u64], i: usize) -> u64 {
    entries.get(i).copied().unwrap_or(1 << 63)
}

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

/// Where the decimal `n·10^e10` (plus a tiny amount if `sticky`) rounds, relative to the
/// non-negative float `bits`: `Less` below it, `Equal` to it, `Greater` above it.
///
/// Round-half-even: a decimal exactly between two floats goes to the one with even `m`.
/// With `sticky`, `n` must hold enough digits that every midpoint near the decimal is a
/// multiple of `10^e10` ([`EXACT_DIGITS`]): then `n·10^e10` below a midpoint leaves the
/// decimal below it too, whatever the dropped digits were.
fn round_check(n: Big, e10: i32, sticky: bool, bits: u32) -> Ordering {
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
/// `k < 2^26` and either `n < 2^64` with `-64 <= e10 <= 38`, or `n < 10^120` (see
/// [`EXACT_DIGITS`]) with `e10 >= -165` and `n·10^e10 < 10^57` (a decimal the parser
/// scaled). So neither side exceeds `max(2^64·5^38, 10^120, 2^26·5^165) < 2^410` before the
/// shift, and [`Big::compare_shifted`] never grows a number past the larger of the two: 416
/// bits suffice.
fn compare(n: Big, e10: i32, k: u32, e2: i32) -> Ordering {
    let mut decimal = n;
    let mut binary = Big::from_u64(u64::from(k));
    if e10 >= 0 {
        decimal.mul_pow5(e10.unsigned_abs());
    } else {
        binary.mul_pow5(e10.unsigned_abs());
    }
    decimal.compare_shifted(binary, e10 - e2)
}

/// Number of 32-bit limbs of [`Big`]; see [`compare`] for why 416 bits are enough.
const LIMBS: usize = 13;

/// A fixed-size unsigned integer, least significant limb first, with only what [`compare`] needs.
#[derive(Clone, Copy)]
struct Big([u32; LIMBS]);

impl Big {
    /// The value `v`.
    fn from_u64(v: u64) -> Self {
        let mut big = Big([0; LIMBS]);
        let [low, high, ..] = &mut big.0;
        (*low, *high) = (v as u32, (v >> 32) as u32);
        big
    }

    /// `self = self·factor + addend` (the caller guarantees the result fits).
    fn mul_add(&mut self, factor: u32, addend: u32) {
        let mut carry = u64::from(addend);
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
            // 5^13 is the largest power of five below 2^32.
            let step = e.min(13);
            self.mul_add(5u32.pow(step), 0);
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

/// A positive number `m·2^e` with `2^63 <= m < 2^64`, approximating some exact value.
#[derive(Clone, Copy)]
struct Approx {
    m: u64,
    e: i32,
}

/// `5^(16q)` for `q = -4..=3` as the significand `m` of an [`Approx`] (`e` is
/// `log2_pow5(16q) - 63`), rounded to nearest; exact for `q = 0, 1`.
const POW5_COARSE: [u64; 8] = [
    0xa87f_ea27_a539_e9a5, // 5^-64
    0xbb12_7c53_b17e_c159, // 5^-48
    0xcfb1_1ead_4539_94ba, // 5^-32
    0xe695_94be_c44d_e15b, // 5^-16
    0x8000_0000_0000_0000, // 5^0
    0x8e1b_c9bf_0400_0000, // 5^16
    0x9dc5_ada8_2b70_b59e, // 5^32
    0xaf29_8d05_0e43_95d7, // 5^48
];

/// `10^-k` for `k = 0..20` as the significand of an [`Approx`] (`e` is
/// `-k + log2_pow5(-k) - 63`), rounded to nearest.
const POW10_NEGATIVE: [u64; 20] = [
    0x8000_0000_0000_0000,
    0xcccc_cccc_cccc_cccd,
    0xa3d7_0a3d_70a3_d70a,
    0x8312_6e97_8d4f_df3b,
    0xd1b7_1758_e219_652c,
    0xa7c5_ac47_1b47_8423,
    0x8637_bd05_af6c_69b6,
    0xd6bf_94d5_e57a_42bc,
    0xabcc_7711_8461_cefd,
    0x8970_5f41_36b4_a597,
    0xdbe6_fece_bded_d5bf,
    0xafeb_ff0b_cb24_aaff,
    0x8cbc_cc09_6f50_88cc,
    0xe12e_1342_4bb4_0e13,
    0xb424_dc35_095c_d80f,
    0x901d_7cf7_3ab0_acd9,
    0xe695_94be_c44d_e15b,
    0xb877_aa32_36a4_b449,
    0x9392_ee8e_921d_5d07,
    0xec1e_4a7d_b695_61a5,
];

impl Approx {
    /// `v·2^e`, exactly (`v > 0`).
    fn new(v: u64, e: i32) -> Self {
        let shift = v.leading_zeros();
        Approx {
            m: v.checked_shl(shift).unwrap_or(0),
            e: e - shift as i32,
        }
    }

    /// The product, truncated to 64 bits: adds a relative error below `2^-63`.
    fn mul(self, other: Approx) -> Self {
        // Both significands are in [2^63, 2^64), so the product is in [2^126, 2^128).
        let product = u128::from(self.m) * u128::from(other.m);
        let top = (product >> 127) as u32;
        Approx {
            m: (product >> (63 + top)) as u64,
            e: self.e + other.e + 63 + top as i32,
        }
    }

    /// `10^e` for `-64 <= e < 64`, as `2^e·5^(16q)·5^r` with `0 <= r < 16`: one product of
    /// a table entry and `5^r` (exact: `5^15 < 2^35`), the first within `2^-64` (relative),
    /// truncated
    /// (below `2^-63` more), so within `3·2^-64`; exact for `0 <= e < 28`. The exponents
    /// of usual float text, `-19 <= e <= 0` (a fraction's digits), are one entry of
    /// [`POW10_NEGATIVE`] instead, within `2^-64`, which saves the product.
    fn pow10(e: i32) -> Self {
        // A `compact` build takes every power from the two tables below.
        if !cfg!(feature = "compact")
            && let Some(&m) = usize::try_from(-e).ok().and_then(|k| POW10_NEGATIVE.get(k))
        {
            return Approx {
                m,
                e: e + log2_pow5(e) - 63,
            };
        }
        let (q, r) = (e >> 4, e & 15);
        let coarse = Approx {
            m: table(&POW5_COARSE, (q + 4) as usize),
            e: log2_pow5(16 * q) - 63,
        };
        // `0 <= r < 16`: the conversion is lossless.
        let fine = Approx::new(5u64.pow(r as u32), e);
        coarse.mul(fine)
    }

    /// The value times 2^32, truncated (for values below 2^31).
    fn fixed32(self) -> u64 {
        let shift = (-(self.e + 32)).clamp(0, 64) as u32;
        self.m.checked_shr(shift).unwrap_or(0)
    }
}

// ---------------------------------------------------------------------------------------------
// Parsing floats
// ---------------------------------------------------------------------------------------------

/// Parses a decimal float: optional sign, digits with optional '.', optional exponent (e/E, sign, digits).
///
/// No surrounding whitespace, no "inf"/"nan" (answers read those with
/// [`parse_non_finite`]), no hex; ".5" and "5." are accepted (C `strtod` does). The result
/// is correctly rounded (round-half-even) to `f32` for any number of digits: 19 significant
/// ones are read at once, and only a text that lies near the midpoint between two floats
/// after them is read again, with up to 120. Values that round above `f32::MAX`
/// are [`NumberError::OutOfRange`]; values too small for the smallest subnormal become ±0.
pub fn parse_f32(text: &[u8]) -> Result<f32, NumberError> {
    let decimal = Decimal::scan(text)?;
    let magnitude = decimal.magnitude(text)?;
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

/// A mantissa at or above this takes no more digits: 19 significant digits are kept, and any
/// 19 fit a `u64`.
const MANTISSA_FULL: u64 = 1_000_000_000_000_000_000;

/// Cap on an exponent's digits: far beyond any float, yet adding text-derived offsets to it
/// cannot overflow (additions saturate in any case).
const EXPONENT_CAP: i32 = 1 << 30;

/// log2 of the distance to a midpoint, in units of the approximation's last bit, within which
/// the rounding is settled exactly. The approximation of `n·10^e` is within `5·2^-64`
/// (relative: [`Approx::pow10`] and one more product), plus `10^-18` for dropped digits; with
/// the significand below 2^64 that is under 24 units, and 2^7 leaves a safety factor of five.
const MIDPOINT_MARGIN_BITS: u32 = 7;

/// A decimal `mantissa·10^exponent`, plus `sticky` if non-zero digits were dropped.
struct Decimal {
    negative: bool,
    mantissa: u64,
    exponent: i32,
    sticky: bool,
    /// Where in the text the first dropped digit is (0 if none is).
    dropped_at: usize,
}

impl Decimal {
    /// Reads the syntax of a float: sign, digits and '.', optional exponent.
    fn scan(text: &[u8]) -> Result<Self, NumberError> {
        let (negative, body) = split_sign(text)?;
        // The shortcut reads the usual text faster; a `compact` build leaves it out.
        if !cfg!(feature = "compact")
            && let Some(decimal) = Self::scan_short(negative, body)
        {
            return Ok(decimal);
        }
        let mut decimal = Decimal {
            negative,
            mantissa: 0,
            exponent: 0,
            sticky: false,
            dropped_at: 0,
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
            // Leading zeros are taken too, and leave the mantissa zero.
            if decimal.mantissa < MANTISSA_FULL {
                decimal.mantissa = decimal.mantissa * 10 + u64::from(d);
                if after_point {
                    decimal.exponent = decimal.exponent.saturating_sub(1);
                }
            } else {
                // No digit is dropped at the text's start: 0 means none yet.
                if decimal.dropped_at == 0 {
                    decimal.dropped_at = text.len() - body.len() + i;
                }
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

    /// [`Decimal::scan`] for the usual text, digits with at most one '.' and no exponent,
    /// short enough (19 bytes) that no digit needs dropping: two tight loops, one each side
    /// of the point. `None` for anything else, which the general scan reads or refuses.
    fn scan_short(negative: bool, body: &[u8]) -> Option<Self> {
        if body.len() > 19 {
            return None;
        }
        let mut mantissa = 0u64;
        let whole = body.iter().take_while(|c| c.is_ascii_digit()).count();
        let (digits, rest) = body.split_at_checked(whole)?;
        for &c in digits {
            mantissa = mantissa * 10 + u64::from(c - b'0');
        }
        let fraction = match rest.split_first() {
            None => &[][..],
            Some((b'.', fraction)) => fraction,
            Some(_) => return None,
        };
        // A float's fraction usually has 7 to 11 digits: eight at a time, then one by one.
        let (eights, tail) = fraction.as_chunks::<8>();
        for &chunk in eights {
            mantissa = mantissa * 100_000_000 + eight_digits(chunk)?;
        }
        for &c in tail {
            let d = c.wrapping_sub(b'0');
            if d > 9 {
                return None;
            }
            mantissa = mantissa * 10 + u64::from(d);
        }
        (whole + fraction.len() > 0).then_some(Decimal {
            negative,
            mantissa,
            exponent: -(fraction.len() as i32),
            sticky: false,
            dropped_at: 0,
        })
    }

    /// The correctly rounded magnitude; `text` is what [`Decimal::scan`] read, for the rare
    /// decimal whose dropped digits decide it.
    fn magnitude(&self, text: &[u8]) -> Result<f32, NumberError> {
        if self.mantissa == 0 {
            return Ok(0.0);
        }
        // The value lies in [10^exponent, 10^(19+exponent)].
        if self.exponent > 38 {
            // At least 10^39 > f32::MAX.
            return Err(NumberError::OutOfRange);
        }
        if self.exponent < -64 {
            // At most 10^-46, less than half the smallest subnormal 2^-149.
            return Ok(0.0);
        }
        // Now -64 <= exponent <= 38, the range `compare` is sized for.
        let approx = Approx::new(self.mantissa, 0).mul(Approx::pow10(self.exponent));
        let (guess, near_midpoint) = round_to_f32(approx);
        let bits = if near_midpoint {
            self.refine(guess, text)
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
    fn refine(&self, mut bits: u32, text: &[u8]) -> u32 {
        let (digits, exponent, sticky) = self.exact(text);
        for _ in 0..4 {
            match round_check(digits, exponent, sticky, bits) {
                Ordering::Greater if bits < INF_BITS => bits += 1,
                Ordering::Less if bits > 0 => bits -= 1,
                _ => break,
            }
        }
        bits
    }

    /// The decimal with enough digits for [`round_check`]: with digits dropped, a midpoint
    /// may lie between the 19 kept and the whole text, and the text's later digits decide.
    /// Each is appended in turn (the point is passed over), up to [`EXACT_DIGITS`]; `text`
    /// is what [`Decimal::scan`] read.
    fn exact(&self, text: &[u8]) -> (Big, i32, bool) {
        let mut digits = Big::from_u64(self.mantissa);
        let (mut exponent, mut sticky) = (self.exponent, false);
        if !self.sticky {
            return (digits, exponent, sticky);
        }
        // `exponent` is the 19 kept digits' (each dropped digit before the point raised
        // it), so each digit appended lowers it.
        let dropped = text.get(self.dropped_at..).unwrap_or_default();
        let mut room = EXACT_DIGITS - 19;
        for &c in dropped.iter().take_while(|&&c| c | 0x20 != b'e') {
            let Some(d) = digit(c) else {
                continue;
            };
            if room > 0 {
                digits.mul_add(10, u32::from(d));
                exponent = exponent.saturating_sub(1);
                room -= 1;
            } else {
                sticky |= d != 0;
            }
        }
        (digits, exponent, sticky)
    }
}

/// Significant digits read exactly when the 19 kept do not settle the rounding. Every
/// midpoint between floats, `k·2^e2` with `k < 2^26` and `e2 >= -151`, has its last
/// significant digit at or above 10^-151, and its first within one place of the decimal's
/// first when the two are near; so 120 digits from the decimal's first reach below every
/// such midpoint's last, and a midpoint near the decimal is a multiple of the last kept
/// digit's place (as [`round_check`] needs). 10^120 fits [`Big`].
const EXACT_DIGITS: u32 = 120;

/// The value of eight ASCII digits, read as one little-endian word, or `None` if any byte is
/// not a digit: three multiplications, each combining neighbouring groups (digits, then
/// pairs, then fours), instead of eight dependent steps.
fn eight_digits(chunk: [u8; 8]) -> Option<u64> {
    const LOW_NIBBLES: u64 = 0x0f0f_0f0f_0f0f_0f0f;
    let word = u64::from_le_bytes(chunk);
    // A byte is a digit exactly when its high nibble is 3 and adding 6 keeps it 3.
    let high = word & !LOW_NIBBLES;
    let high_plus_six = word.wrapping_add(0x0606_0606_0606_0606) & !LOW_NIBBLES;
    if high | high_plus_six >> 4 != 0x3333_3333_3333_3333 {
        return None;
    }
    // The first digit is the lowest byte: each step multiplies the lower group by its
    // weight and adds the upper one in the same lane.
    let pairs = (word & LOW_NIBBLES).wrapping_mul(10 << 8 | 1) >> 8;
    let fours = (pairs & 0x00ff_00ff_00ff_00ff).wrapping_mul(100 << 16 | 1) >> 16;
    Some((fours & 0x0000_ffff_0000_ffff).wrapping_mul(10_000 << 32 | 1) >> 32)
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

/// Rounds `v` to the bits of an `f32` (`INF_BITS` on overflow), round-half-even, and tells
/// whether `v` is within [`MIDPOINT_MARGIN_BITS`] of a midpoint, where its error could matter.
fn round_to_f32(v: Approx) -> (u32, bool) {
    // Keep 24 bits below the leading one, or fewer where subnormals have a fixed last bit.
    let lsb = (v.e + 63 - 23).max(-149);
    let drop = lsb - v.e; // at least 40
    if drop > 64 {
        // Below half the smallest subnormal, but perhaps by less than the error: let the exact
        // check decide.
        return (0, true);
    }
    // `rest`: the dropped bits, left-aligned; exactly 2^63 is the midpoint.
    let (kept, rest) = match v.m.checked_shr(drop as u32) {
        Some(kept) => (kept, v.m << (64 - drop)),
        None => (0, v.m),
    };
    const HALF: u64 = 1 << 63;
    let margin = 1u64 << (64 - drop + MIDPOINT_MARGIN_BITS as i32);
    let near = rest.abs_diff(HALF) <= margin;
    let round_up = rest > HALF || (rest == HALF && kept % 2 == 1);
    // lsb + 149 is the biased exponent minus one for normals, 0 for subnormals; a carry out of
    // the significand steps the exponent as it should (and reaches INF_BITS on overflow).
    let exponent = ((lsb + 149) as u32).min(255);
    let bits = (exponent << 23) + kept as u32 + u32::from(round_up);
    (bits.min(INF_BITS), near)
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
/// The usual float's window is exact ([`exact_fixed`]); its digits are chosen and written
/// here without a call, which would make the compiler save and restore more registers.
/// Zero and any other float go to [`write_inexact`], so the code that chooses and writes
/// the digits is here twice (524 bytes of flash for 5 % of the 1002 answer's encode, against
/// a cold path that returns only the digits).
#[inline(never)]
pub(crate) fn write_finite(value: f32, out: &mut [u8; F32_TEXT_MAX]) -> usize {
    // A `compact` build keeps one copy: every float goes the general way.
    if cfg!(feature = "compact") {
        return write_inexact(value, out);
    }
    let bits = value.to_bits() & !(1 << 31);
    // Zero's window is not exact either (its scale is out of range), so zero goes to
    // `write_inexact` too.
    match Window::new(bits, true) {
        Some(window) => {
            let (digits, exponent, len) = window.pick();
            render(value.is_sign_negative(), digits, exponent, len, out)
        }
        _ => write_inexact(value, out),
    }
}

/// [`write_finite`] for zero and for a float whose window is not exact (for every float in a
/// `compact` build).
#[cold]
#[inline(never)]
fn write_inexact(value: f32, out: &mut [u8; F32_TEXT_MAX]) -> usize {
    let bits = value.to_bits() & !(1 << 31);
    let window = if bits == 0 {
        None
    } else {
        Window::new(bits, false)
    };
    let (digits, exponent, len) = window.map_or((0, 0, 1), |window| window.pick());
    render(value.is_sign_negative(), digits, exponent, len, out)
}

/// Writes a NaN or an infinity as C's `printf` does (`nan`, `-nan`, `inf`, `-inf`), for
/// answers that report a reading the robot does not have; returns the length. A finite
/// `value` writes nothing (0).
// Out of line: one copy for both places a number item is written, off their usual path.
#[inline(never)]
pub fn write_non_finite(value: f32, out: &mut [u8; F32_TEXT_MAX]) -> usize {
    let word: &[u8] = match (
        value.is_nan(),
        value.is_infinite(),
        value.is_sign_negative(),
    ) {
        (true, _, false) => b"nan",
        (true, _, true) => b"-nan",
        (_, true, false) => b"inf",
        (_, true, true) => b"-inf",
        _ => b"",
    };
    for (slot, &c) in out.iter_mut().zip(word) {
        *slot = c;
    }
    word.len()
}

/// How close (in 32.32 units: `2^-16`) an approximate position may come to an integer or a tie
/// before it is checked exactly. `y` is within `5·2^-64` (relative: [`Approx::pow10`] and one
/// product) of the truth plus one unit of truncation, i.e. below 2^62 by less than 3 units, and
/// the interval ends within 2^6 units (after `×10`).
const TIE_MARGIN: u64 = 1 << 16;

/// The integers `low..=high` (in units of `10^-scale`) that read back as the float `bits`, and
/// `y`, the float in those units, in 32.32 fixed point.
struct Window {
    bits: u32,
    x: Binary,
    scale: i32,
    y: u64,
    /// Whether `y` and the interval ends are exact (else within 2^6 units).
    exact: bool,
    low: u32,
    high: u32,
}

impl Window {
    /// The window of the positive float `bits`, with `y` in `[10^8, 10^9)`; `None` if it
    /// would not be exact and `exact_only` asks for no other. Inlined, so that with
    /// `exact_only` set the approximate path is not there at all.
    #[inline(always)]
    fn new(bits: u32, exact_only: bool) -> Option<Self> {
        // An exact window's float is normal. Zero and subnormals read as normal come out with
        // a scale far above 14, so they are not exact either way.
        let x = if exact_only {
            Binary::decode_normal(bits)
        } else {
            Binary::decode(bits)
        };
        // floor(log2 x) + 1, and the floor of that times log10(2) (exact for |v| < 1650 with
        // this constant): the decimal exponent of x is `estimate` or one less.
        // A normal float's significand has 24 bits, so the exact-only path takes 24 instead
        // of counting them: the count sat on the chain the writer waits on (5 % of a 1002
        // encode). Zero and subnormals have fewer, but with 24 their scale still comes out
        // far above 14, so they are not exact either way.
        let significand_bits = if exact_only {
            24
        } else {
            32 - x.m.leading_zeros()
        };
        let bit_top = x.e + significand_bits as i32;
        let estimate = (bit_top * 78_913) >> 18;
        let mut scale = 8 - estimate;
        // `above`: the half-step to the next float up, in the same units as `y`.
        // A `compact` build scales every float the approximate way, checked where it matters.
        let exact_window = if cfg!(feature = "compact") {
            None
        } else {
            exact_fixed(x, scale)
        };
        let (mut y, mut above, exact) = match exact_window {
            Some((y, above)) => (y, above, true),
            None if exact_only => return None,
            None => {
                let power = Approx::pow10(scale);
                let y = Approx::new(u64::from(x.m), x.e).mul(power);
                let above = Approx::new(1, x.e - 1).mul(power);
                (y.fixed32(), above.fixed32(), false)
            }
        };
        if y < 100_000_000 << 32 {
            // The estimate was one too high; y < 10^8·2^32 < 2^59, so nothing overflows.
            y *= 10;
            above *= 10;
            scale += 1;
        }
        // `above` is even when exact (a power of two of at least 2 times 5^scale). A normal
        // float is narrow below when its significand is a power of two.
        let narrow_below = if exact_only {
            x.m == 1 << 23
        } else {
            x.narrow_below()
        };
        let below = if narrow_below { above / 2 } else { above };
        let mut window = Window {
            bits,
            x,
            scale,
            y,
            exact,
            low: 0,
            high: 0,
        };
        if exact {
            // Exact ends belong to the interval when m is even (the reader rounds ties to
            // even): an odd m moves each end one 2^-32 unit inwards, and then both are
            // inclusive, so the integers inside follow by rounding up and down.
            let odd = u64::from(x.m % 2);
            window.low = ((y - below + odd + 0xffff_ffff) >> 32) as u32;
            window.high = ((y + above - odd) >> 32) as u32;
        } else {
            window.low = window.end(y - below, true);
            window.high = window.end(y + above, false);
        }
        Some(window)
    }

    /// The first (`lower`) or last integer inside the interval that ends near `end`, for an
    /// approximate window.
    fn end(&self, end: u64, lower: bool) -> u32 {
        let floor = (end >> 32) as u32;
        let fraction = end as u32;
        let margin = TIE_MARGIN as u32;
        if fraction > margin && fraction.wrapping_neg() > margin {
            // Clearly between two integers.
            return if lower {
                floor.saturating_add(1)
            } else {
                floor
            };
        }
        let nearest = if fraction <= margin {
            floor
        } else {
            floor.saturating_add(1)
        };
        match (lower, self.reads_back(nearest)) {
            (_, true) => nearest,
            (true, false) => nearest.saturating_add(1),
            (false, false) => nearest.saturating_sub(1),
        }
    }

    /// Whether `candidate·10^-scale` parses back to the float.
    fn reads_back(&self, candidate: u32) -> bool {
        let candidate = Big::from_u64(u64::from(candidate));
        round_check(candidate, -self.scale, false, self.bits) == Ordering::Equal
    }

    /// The shortest integer in the window, nearest to `y`, ties to the larger one; returned as
    /// digits, decimal exponent and number of digits. Inlined, like [`render`], so that the
    /// float writer's usual path makes no call.
    #[inline(always)]
    fn pick(&self) -> (u32, i32, usize) {
        // The largest power of ten with a multiple inside the window: the window holds a
        // multiple of 10^k exactly when high/10^k > (low-1)/10^k, and then one of 10^(k-1)
        // too. So powers are tried two digits a round, then one more digit: a round number
        // (0.05 drops eight) takes half the rounds, each of which waits on the one before.
        // Dividing by a constant compiles to a multiplication; a division by a variable
        // power would not, so y's quotient is divided along. `high < 2^32` ends the loop
        // within four rounds, so `step` stays at most 10^9 and its product needs no
        // overflow check.
        let (mut below, mut high) = (self.low.saturating_sub(1), self.high);
        let mut quotient = (self.y >> 32) as u32;
        let mut step = 1u32;
        let mut zeros = 0;
        while high / 100 > below / 100 {
            high /= 100;
            below /= 100;
            quotient /= 100;
            step = step.wrapping_mul(100);
            zeros += 2;
        }
        if high / 10 > below / 10 {
            quotient /= 10;
            step = step.wrapping_mul(10);
            zeros += 1;
        }
        // The nearest multiple of `step` is one of the two around y.
        let down = quotient * step;
        let up = down.saturating_add(step);
        let inside = |c: u32| (self.low..=self.high).contains(&c);
        let chosen = match (inside(down), inside(up)) {
            (true, true) if self.up_is_nearer(down, step) => quotient + 1,
            (true, _) => quotient,
            _ => quotient + 1,
        };
        // `y` has nine digits, and so do the window's integers below 10^9; one of them with
        // `zeros` trailing zeros has `9 - zeros` more. 10^9 is a multiple of every step, so
        // with it inside the search ends at `zeros = 9`, choosing 1.
        (
            chosen,
            zeros - self.scale,
            9usize.saturating_sub(zeros as usize).max(1),
        )
    }

    /// Whether `y >= down + step/2`.
    fn up_is_nearer(&self, down: u32, step: u32) -> bool {
        // Both below 2^32, so twice their midpoint is below 2^33.
        let twice_mid = 2 * u64::from(down) + u64::from(step);
        let mid = twice_mid << 31;
        if self.exact || self.y.abs_diff(mid) > TIE_MARGIN {
            return self.y >= mid;
        }
        // mid·10^-scale = twice_mid·5·10^(-scale-1).
        let twice_mid = Big::from_u64(twice_mid * 5);
        compare(twice_mid, -self.scale - 1, self.x.m, self.x.e) != Ordering::Greater
    }
}

/// `5^k` for `k = 0..=14`, exactly: the exact window's scales. The float writer waits on
/// this: a table saves it the multiplications (2 % of a 1002 encode).
const POW5_EXACT: [u64; 15] = [
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

/// `y = x·10^s` and the half-step above it, times 2^32, if those are integers: for
/// `0 <= s <= 14` and a quarter-step `5^s·2^(e+s-2)` of at least `2^-32`, i.e. roughly
/// `10^-6 <= x < 10^9`.
///
/// `s` must keep `x·10^s` below 10^9, as [`Window::new`]'s estimate does. Then `y < 2^62`:
/// neither shift loses a bit or reaches 64, so they need no check (which cost 3.5 % of the
/// writer's instructions).
fn exact_fixed(x: Binary, s: i32) -> Option<(u64, u64)> {
    let s = u32::try_from(s).ok()?;
    let p5 = *POW5_EXACT.get(s as usize)?;
    let quarter = u32::try_from(x.e + s as i32 + 30).ok()?;
    let y = (u64::from(x.m) * p5).wrapping_shl(quarter + 2);
    let above = p5.wrapping_shl(quarter + 1);
    Some((y, above))
}

/// Writes `[-]digits·10^exponent` the way `{}` does, never with an exponent, for `digits`
/// of `len` (at most nine) digits.
///
/// The digits are made all at once ([`eight_ascii`]) and the text is written with 8-byte
/// stores, runs of zeros included; bytes stored past the text's end are left for the
/// caller to ignore. No store reaches past `out`'s end: the text's last byte is at most at
/// 47, and stores that would pass 48 are moved back over bytes that are zeros anyway.
#[inline(always)]
fn render(
    negative: bool,
    digits: u32,
    exponent: i32,
    len: usize,
    out: &mut [u8; F32_TEXT_MAX],
) -> usize {
    let start = usize::from(negative);
    // Overwritten by what follows unless the number is negative.
    put(out, 0, b'-');
    // Where the point goes, in digits from the first: at or past the last for an integer,
    // at or before the first for a number below one.
    let point = len as i32 + exponent;
    let at = if point > 0 {
        start
    } else {
        // "0." and the zeros before the digits.
        let digits_at = start + 2 + point.unsigned_abs() as usize;
        fill_zeros(out, start, digits_at);
        put(out, start + 1, b'.');
        digits_at
    };
    // The first of nine (zero-padded) digits alone, the others in one word, of which the
    // last `in_word` are the number's.
    let first = digits / 100_000_000;
    put(out, at, b'0' + first as u8);
    let padded = eight_ascii(digits - first * 100_000_000);
    let in_word = len.min(8);
    let word_at = at + len - in_word;
    let word = padded >> (8 * (8 - in_word));
    if word_at + 8 <= F32_TEXT_MAX {
        store8(out, word_at, word);
    } else {
        // Only after at least 38 zeros: the padding lands on zeros.
        store8(out, word_at + in_word - 8, padded);
    }
    let end = at + len;
    match usize::try_from(point) {
        Ok(whole) if whole >= len => {
            let end_zeros = end + (whole - len);
            fill_zeros(out, end, end_zeros);
            end_zeros
        }
        Ok(whole) if whole > 0 => {
            // The fraction again, one place further on, then the point before it.
            store8(out, at + whole + 1, word >> (8 * (whole - (len - in_word))));
            put(out, at + whole, b'.');
            end + 1
        }
        _ => end,
    }
}

/// Writes ASCII zeros at `from..to` (`to <= F32_TEXT_MAX`), and possibly after `to` or from
/// byte 40 on, eight at a time.
fn fill_zeros(out: &mut [u8; F32_TEXT_MAX], from: usize, to: usize) {
    let mut at = from;
    while at < to {
        store8(out, at.min(F32_TEXT_MAX - 8), ZERO_DIGITS);
        at += 8;
    }
}

/// Eight ASCII zeros in a word.
const ZERO_DIGITS: u64 = u64::from_le_bytes([b'0'; 8]);

/// The eight decimal digits of `v < 10^8`, zero-padded, as ASCII in a word's bytes (the
/// first digit in the lowest byte). The digits are split into halves, quarters and single
/// digits in all lanes at once, by multiplications that divide exactly in the lanes'
/// ranges. Inlined into both number writers: a call made the float writer save and restore
/// registers around it, 3 % of the 1002 answer's encode, which is worth the 164 bytes of
/// flash of the second copy; a `compact` build keeps one.
#[cfg_attr(not(feature = "compact"), inline(always))]
#[cfg_attr(feature = "compact", inline(never))]
fn eight_ascii(v: u32) -> u64 {
    // Two lanes of 32 bits: the top and bottom four digits.
    let x = u64::from(v / 10_000) | u64::from(v % 10_000) << 32;
    // x / 100 in each lane: exact for lanes below 43699.
    let high = ((x * 5243) >> 19) & 0x0000_007f_0000_007f;
    let x = high | (x - high * 100) << 16;
    two_digit_lanes(x)
}

/// The ASCII digits of four numbers below 100, one in each 16-bit lane of `x`: the tens in
/// the lane's low byte, the ones in its high byte. Dividing by ten is a multiplication, exact
/// in every lane below 179.
pub(crate) fn two_digit_lanes(x: u64) -> u64 {
    let tens = ((x * 103) >> 10) & 0x000f_000f_000f_000f;
    tens | (x - tens * 10) << 8 | ZERO_DIGITS
}

/// Stores the word's eight bytes, lowest first, at `at` in `out` (nothing if they do not
/// fit, which the callers' bounds rule out).
fn store8<const N: usize>(out: &mut [u8; N], at: usize, word: u64) {
    if let Some(slot) = out.get_mut(at..).and_then(|o| o.first_chunk_mut::<8>()) {
        *slot = word.to_le_bytes();
    }
}

/// Stores one byte at `at` in `out` (nothing past its end, which the callers rule out).
fn put<const N: usize>(out: &mut [u8; N], at: usize, byte: u8) {
    if let Some(slot) = out.get_mut(at) {
        *slot = byte;
    }
}
