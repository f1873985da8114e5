//! The default build's fast paths: approximations that settle almost every number in a few
//! multiplications, and hand the rest to the exact conversions (`exact`). A `compact` build
//! leaves this module out.
//!
//! # Reading
//!
//! The usual text (digits and at most one point, 19 bytes at most) is read by
//! [`Decimal::scan_short`], eight digits at a time, as `n·10^e` with `-18 <= e <= 0`. That is
//! then approximated with an [`Approx`], a 64-bit significand and binary exponent, `10^e`
//! being one entry of a table of negative powers: relative error below `2^-62`. Rounding to
//! `f32` only changes at the *midpoints* between adjacent floats; a decimal too close to one
//! for that error bound (about one in 2^30, and exact ties) is read exactly, as is any other
//! text (an exponent, more than 19 bytes, a syntax error).
//!
//! # Writing
//!
//! With `s` chosen so that `y = x·10^s` lies in `[10^8, 10^9)`, every shortest candidate is
//! an integer number of `y`-units, because the float's rounding interval is at least ~2.9
//! units wide: the interval is reduced to the integers `low..=high` it contains, and the
//! answer is the one with the most trailing zeros, nearest to `y`. For `10^-6 <= x < 10^9`
//! (all values the panel sends in practice) `y` and the interval are exact in 32.32 fixed
//! point ([`Window`]); any other float is written exactly.
//!
//! # Text
//!
//! Digits are made eight at a time in one word's lanes ([`eight_ascii`]), and the text,
//! zeros included, is written with 8-byte stores.

use super::{
    Binary, Decimal, F32_TEXT_MAX, I32_TEXT_MAX, ZERO_DIGITS, float_bits, split_lanes, split_sign,
    two_digit_lanes,
};

/// `floor(k·log2(5))` for `-64 <= k < 64` (in 12.20 fixed point; checked for each such `k`).
fn log2_pow5(k: i32) -> i32 {
    (k * 2_434_718) >> 20
}

/// A positive number `m·2^e` with `2^63 <= m < 2^64`, approximating some exact value.
#[derive(Clone, Copy)]
struct Approx {
    m: u64,
    e: i32,
}

/// `10^-k` for `k = 0..=18` (the usual text's fraction lengths) as the significand of an
/// [`Approx`] (`e` is `-k + log2_pow5(-k) - 63`), rounded to nearest.
const POW10_NEGATIVE: [u64; 19] = [
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
];

impl Approx {
    /// The integer `v`, exactly (`v > 0`).
    fn new(v: u64) -> Self {
        let shift = v.leading_zeros();
        Approx {
            m: v.checked_shl(shift).unwrap_or(0),
            e: -(shift as i32),
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

    /// `10^e` for `-18 <= e <= 0` (a fraction's digits), one entry of [`POW10_NEGATIVE`],
    /// within `2^-64` (relative); `None` for any other `e`.
    fn pow10(e: i32) -> Option<Self> {
        let m = *POW10_NEGATIVE.get(usize::try_from(-e).ok()?)?;
        Some(Approx {
            m,
            e: e + log2_pow5(e) - 63,
        })
    }
}

/// log2 of the distance to a midpoint, in units of the approximation's last bit, within which
/// the rounding is settled exactly. The approximation of `n·10^e` is within `3·2^-64`
/// (relative: [`Approx::pow10`], and the product's truncation); with the significand below
/// 2^64 that is under 3 units, and 2^7 leaves a wide margin.
const MIDPOINT_MARGIN_BITS: u32 = 7;

/// [`super::parse_f32`] for the usual text (see [`Decimal::scan_short`]), if its
/// approximation settles it ([`Decimal::approximate`]); `None` for any other text, and for
/// the rare decimal too near a midpoint between floats, which are read exactly (syntax
/// errors included).
pub(super) fn parse_f32(text: &[u8]) -> Option<f32> {
    let (negative, body) = split_sign(text).ok()?;
    let decimal = Decimal::scan_short(negative, body)?;
    let magnitude = if decimal.mantissa == 0 {
        0.0
    } else {
        f32::from_bits(decimal.approximate()?)
    };
    Some(if decimal.negative {
        -magnitude
    } else {
        magnitude
    })
}

impl Decimal<u64> {
    /// The bits of the float nearest to the decimal, if its approximation settles it;
    /// `None` if the decimal lies too near a midpoint between two floats for the
    /// approximation's error. The decimal is one [`Decimal::scan_short`] read, with a
    /// nonzero mantissa: it lies in `[10^-18, 10^19)`, so its float is normal and finite.
    fn approximate(&self) -> Option<u32> {
        let v = Approx::new(self.mantissa).mul(Approx::pow10(self.exponent)?);
        // The float keeps 24 bits from the leading one. `rest`, the bits below them
        // left-aligned, is exactly 2^63 at the midpoint.
        const DROPPED: u32 = 64 - 24;
        let (kept, rest) = (v.m >> DROPPED, v.m << (64 - DROPPED));
        const HALF: u64 = 1 << 63;
        if rest.abs_diff(HALF) <= 1 << (64 - DROPPED + MIDPOINT_MARGIN_BITS) {
            return None;
        }
        Some(float_bits(v.e + DROPPED as i32, kept as u32, rest > HALF))
    }

    /// The usual text of a float, digits with at most one '.' and no exponent, short enough
    /// (19 bytes) that every digit fits the mantissa, read in two tight loops, one each side
    /// of the point: the exponent is then `-18..=0`. `None` for anything else, which the
    /// exact reader reads or refuses.
    fn scan_short(negative: bool, body: &[u8]) -> Option<Self> {
        if body.len() > 19 {
            return None;
        }
        let mut mantissa = 0u64;
        // The whole part's digits, summed in the pass that finds their end.
        let mut whole = 0;
        while let Some(d) = body
            .get(whole)
            .map(|c| c.wrapping_sub(b'0'))
            .filter(|&d| d <= 9)
        {
            mantissa = mantissa * 10 + u64::from(d);
            whole += 1;
        }
        let rest = body.get(whole..).unwrap_or_default();
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
        })
    }
}

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
    Some(lanes_value(word & LOW_NIBBLES))
}

/// [`super::parse_int_prefix`] for the usual integer text, one to seven digits without a
/// sign, with more bytes after it: its value and length, read as one word. `None` for any
/// other text, which `parse_int_prefix` reads.
pub fn short_int_prefix(text: &[u8]) -> Option<(u32, usize)> {
    const ONES: u64 = u64::from_le_bytes([1; 8]);
    let word = u64::from_le_bytes(*text.first_chunk::<8>()?);
    let lanes = word ^ (ONES * u64::from(b'0'));
    // A lane is a digit exactly when it is below 10: adding 0x76 sets the high bit of a lane
    // of 10 to 0x7f, and only a lane at or above 0x8a carries into the next (above the
    // first that is not a digit, which is all that counts).
    let others = (lanes.wrapping_add(ONES * 0x76) | lanes) & (ONES << 7);
    let len = (others.trailing_zeros() / 8) as usize;
    if !(1..8).contains(&len) {
        return None;
    }
    // The digits moved to the top lanes, zeros below: leading zeros add nothing.
    Some((lanes_value(lanes << (64 - 8 * len)) as u32, len))
}

/// The number that eight lanes of one digit each make, the first digit in the lowest lane.
#[inline(always)]
fn lanes_value(lanes: u64) -> u64 {
    // Each step multiplies the lower group by its weight and adds the upper one in the same
    // lane.
    let pairs = lanes.wrapping_mul(10 << 8 | 1) >> 8;
    let fours = (pairs & 0x00ff_00ff_00ff_00ff).wrapping_mul(100 << 16 | 1) >> 16;
    (fours & 0x0000_ffff_0000_ffff).wrapping_mul(10_000 << 32 | 1) >> 32
}

/// The integers `low..=high` (in units of `10^-scale`) that read back as a float, and `y`,
/// the float in those units, in 32.32 fixed point, all exact.
pub(super) struct Window {
    scale: i32,
    y: u64,
    low: u32,
    high: u32,
}

impl Window {
    /// The window of the positive float `bits`, with `y` in `[10^8, 10^9)`; `None` if it is
    /// not exact in 32.32 fixed point (zero, subnormals, and floats far from 1).
    #[inline(always)]
    pub(super) fn new(bits: u32) -> Option<Self> {
        // An exact window's float is normal. Zero and subnormals read as normal come out with
        // a scale far above 14, so they are not exact either way.
        let x = Binary::decode_normal(bits);
        // floor(log2 x) + 1, and the floor of that times log10(2) (exact for |v| < 1650 with
        // this constant): the decimal exponent of x is `estimate` or one less. A normal
        // float's significand has 24 bits, taken as a constant: a count sat on the chain the
        // writer waits on (5 % of a 1002 encode).
        let bit_top = x.e + 24;
        let estimate = (bit_top * 78_913) >> 18;
        let mut scale = 8 - estimate;
        // `above`: the half-step to the next float up, in the same units as `y`.
        let (mut y, mut above) = exact_fixed(x, scale)?;
        if y < 100_000_000 << 32 {
            // The estimate was one too high; y < 10^8·2^32 < 2^59, so nothing overflows.
            y *= 10;
            above *= 10;
            scale += 1;
        }
        // `above` is even (a power of two of at least 2 times 5^scale). A normal float is
        // narrow below when its significand is a power of two.
        let below = if x.m == 1 << 23 { above / 2 } else { above };
        // Exact ends belong to the interval when m is even (the reader rounds ties to
        // even): an odd m moves each end one 2^-32 unit inwards, and then both are
        // inclusive, so the integers inside follow by rounding up and down.
        let odd = u64::from(x.m % 2);
        Some(Window {
            scale,
            y,
            low: ((y - below + odd + 0xffff_ffff) >> 32) as u32,
            high: ((y + above - odd) >> 32) as u32,
        })
    }

    /// The shortest integer in the window, nearest to `y`, ties to the larger one; returned as
    /// digits, decimal exponent and number of digits. Inlined, as the compiler inlines
    /// [`render`] by itself, so that the float writer's usual path makes no call.
    #[inline(always)]
    pub(super) fn pick(&self) -> (u32, i32, usize) {
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
        // The nearest multiple of `step` is one of the two around y; `y >= down + step/2`
        // (both below 2^32, so twice their midpoint is below 2^33) says it is the upper.
        let down = quotient * step;
        let up = down.saturating_add(step);
        let inside = |c: u32| (self.low..=self.high).contains(&c);
        let up_is_nearer = || self.y >= (2 * u64::from(down) + u64::from(step)) << 31;
        let chosen = match (inside(down), inside(up)) {
            (true, true) if up_is_nearer() => quotient + 1,
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

/// Writes `[-]digits·10^exponent` the way `{}` does, never with an exponent, for `digits`
/// of `len` (at most nine) digits.
///
/// The digits are made all at once ([`eight_ascii`]) and the text is written with 8-byte
/// stores, runs of zeros included; bytes stored past the text's end are left for the
/// caller to ignore. No store reaches past `out`'s end: the text's last byte is at most at
/// 47, and stores that would pass 48 are moved back over bytes that are zeros anyway.
pub(super) fn render(
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
    // A ninth digit alone, the others in one word, of which the last `in_word` are the
    // number's. Nine digits are rare (1.5 % of the floats from 10^-6 to 10^9); the other
    // texts skip the division by 10^8, which the word's digits would wait on (5 % of a 1002
    // encode).
    let low8 = if len > 8 {
        let first = digits / 100_000_000;
        put(out, at, b'0' + first as u8);
        digits - first * 100_000_000
    } else {
        digits
    };
    let padded = eight_ascii(low8);
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

/// The eight decimal digits of `v < 10^8`, zero-padded, as ASCII in a word's bytes (the
/// first digit in the lowest byte). The digits are split into halves, quarters and single
/// digits in all lanes at once, by multiplications that divide exactly in the lanes'
/// ranges. Inlined into both number writers: a call made the float writer save and restore
/// registers around it, 3 % of the 1002 answer's encode, which is worth the 164 bytes of
/// flash of the second copy.
#[inline(always)]
fn eight_ascii(v: u32) -> u64 {
    // Two lanes of 32 bits: the top and bottom four digits.
    let x = split_lanes(v.into(), (v / 10_000).into(), 10_000, 32);
    // x / 100 in each lane: exact for lanes below 43699.
    let high = ((x * 5243) >> 19) & 0x0000_007f_0000_007f;
    two_digit_lanes(split_lanes(x, high, 100, 16))
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
