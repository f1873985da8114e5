//! The exact conversions between decimals and `f32`, in big-integer arithmetic ([`Big`]):
//! every result is decided by comparing and dividing integers, so it is right by
//! construction, whatever the input. A `compact` build converts every number here, the
//! usual text of a float in machine words where its digits fit one; the default build only
//! what its approximations cannot settle (`fast`).

use super::big::Big;
use super::{Binary, float_bits};
use core::cmp::Ordering;

/// The float nearest to `n·10^e`, plus a tiny amount if `sticky` (digits were dropped past
/// `n`'s last), ties to the even one: its bits, [`super::INF_BITS`] when it rounds above
/// `f32::MAX`, 0 when it is below half the smallest subnormal.
///
/// The callers keep `0 < n < 10^120`, `e >= -165` and `n·10^e < 10^58`, the bounds within
/// which every number here fits a [`Big`] (see each step). With `sticky`, `n` must hold
/// enough digits that every midpoint between floats near the decimal is a multiple of
/// `10^e` (see [`super::EXACT_DIGITS`]): then the dropped digits only ever break a tie.
pub(super) fn to_f32(n: Big, e: i32, sticky: bool) -> u32 {
    // The usual text of a float, in a `compact` build: digits that fit a word, at most 13
    // of them after the point, every digit kept.
    #[cfg(feature = "compact")]
    let (quotient, b, fraction) = match (n.to_u32(), e, sticky) {
        (Some(word), -13..=0, false) => divide_short(word, e.unsigned_abs()),
        _ => None,
    }
    .unwrap_or_else(|| divide(n, e, sticky));
    #[cfg(not(feature = "compact"))]
    let (quotient, b, fraction) = divide(n, e, sticky);
    round(quotient, b, fraction)
}

/// The quotient `q` of [`round`] for `n·10^e` (plus a tiny amount if `sticky`), the power
/// of two `b` it counts, and whether the fraction below it is nonzero, in big integers:
/// for any decimal within [`to_f32`]'s bounds.
fn divide(n: Big, e: i32, sticky: bool) -> (u32, i32, bool) {
    // n·10^e = (n·5^e)·2^e, or (n / 5^-e)·2^e: the power of five goes where it multiplies.
    // `n·5^e < 10^58 < 2^193`; `5^-e <= 5^165 < 2^384`.
    let (mut num, mut den) = (n, Big::from_u64(1));
    if e >= 0 {
        num.mul_pow5(e.unsigned_abs());
    } else {
        den.mul_pow5(e.unsigned_abs());
    }
    // One of the two is shifted so that their quotient lies in (2^25, 2^27): 24 bits of the
    // float, one to round with, and one or two more. `num` then has `den`'s bits and 26
    // more (at most 410), or `den` has `num`'s bits less 26.
    let shift = den.bit_len() as i32 - num.bit_len() as i32 + 26;
    if shift >= 0 {
        num.shl(shift.unsigned_abs());
    } else {
        den.shl(shift.unsigned_abs());
    }
    // Long division, one bit of the quotient a step: the remainder, doubled each step, is
    // compared with the divisor at the quotient's top bit. It stays below twice that
    // divisor, at most 411 bits.
    den.shl(26);
    let mut quotient = 0;
    for _ in 0..27 {
        quotient <<= 1;
        if num >= den {
            num.sub(&den);
            quotient |= 1;
        }
        // Doubled by a multiplication, which takes half the instructions of a shift by any
        // amount.
        num.mul_add(2, 0);
    }
    // The decimal is (quotient + fraction)·2^(e - shift).
    (quotient, e - shift, sticky || !num.is_zero())
}

/// [`divide`] for `n·10^-k` with `0 < n < 2^32` and `k <= 13` (nine significant digits
/// fit), in machine words instead of thirteen limbs. `None` when the value's integer part
/// has more bits than the quotient, which `divide` takes.
#[cfg(feature = "compact")]
fn divide_short(n: u32, k: u32) -> Option<(u32, i32, bool)> {
    // n·10^-k = (n / 5^k)·2^-k, with 5^k below 2^31: the remainder, below it, doubled and
    // given a bit, still fits a word.
    let den = (0..k).fold(1u32, |power, _| power * 5);
    // As in `divide`, the quotient of `n·2^shift` by `den` lies in (2^25, 2^27).
    let shift = n.leading_zeros() as i32 - den.leading_zeros() as i32 + 26;
    if shift < 0 {
        return None;
    }
    // Long division of `n·2^shift`, which has `den`'s bits and 26 more, one bit of it a
    // step, from the top: the remainder, below `den`, takes the next bit of `n` (or a zero
    // past its last), and gives the quotient a bit.
    let mut bits = n << n.leading_zeros();
    let (mut rest, mut quotient) = (0, 0);
    for _ in 0..32 - den.leading_zeros() + 26 {
        rest = 2 * rest + (bits >> 31);
        bits <<= 1;
        quotient <<= 1;
        if rest >= den {
            rest -= den;
            quotient |= 1;
        }
    }
    Some((quotient, -(k as i32) - shift, rest != 0))
}

/// The bits of the float nearest to `(q + f)·2^b`, where `2^25 < q < 2^27` and `0 <= f < 1`,
/// with `f` known only as whether it is zero (`!sticky`); ties to the even float.
fn round(q: u32, b: i32, sticky: bool) -> u32 {
    // The float's last place: 24 significant bits, or 2^-149 for subnormals.
    let top = b + 32 - q.leading_zeros() as i32;
    let lsb = (top - 24).max(-149);
    // At least 2, as `q` has at least 26 bits. Past 28 all of `q` (below 2^27) is below
    // half the last place: the float is zero.
    let drop = (lsb - b).unsigned_abs();
    if drop > 28 {
        return 0;
    }
    let kept = q >> drop;
    let rest = q & ((1 << drop) - 1);
    let half = 1 << (drop - 1);
    let up = rest > half || rest == half && (sticky || kept % 2 == 1);
    float_bits(lsb, kept, up)
}

/// The shortest decimal that reads back as the positive, finite float `bits`, and of those
/// the nearest to it (between two as near, the larger): its digits (at most nine), the
/// power of ten of the last digit, and how many there are.
///
/// The digits are made one at a time from the float and the ends of its rounding interval,
/// all scaled to integers: the first place where the decimal cut off there, or the next one
/// up, falls inside the interval is the last.
pub(super) fn shortest(bits: u32) -> (u32, i32, usize) {
    let x = Binary::decode(bits);
    // The rounding interval reaches half a step each way, but only a quarter below a power
    // of two, where the step below is half as wide; its ends belong to it when the
    // significand is even (the reader rounds ties to even). The float is `mant·2^exp`, the
    // ends `mant - below` and `mant + above` of the same unit.
    let even = x.m.is_multiple_of(2);
    let (mant, below, above, exp): (u32, u32, u32, i32) = if x.narrow_below() {
        (4 * x.m, 1, 2, x.e - 2)
    } else {
        (2 * x.m, 1, 1, x.e - 1)
    };
    let (mut r, mut low, mut high) = (
        Big::from_u64(u64::from(mant)),
        Big::from_u64(u64::from(below)),
        Big::from_u64(u64::from(above)),
    );
    // The float is `r / s`; `low` and `high` are the distances to the ends, over `s` too.
    let mut s = Big::from_u64(1);
    if exp >= 0 {
        for big in [&mut r, &mut low, &mut high] {
            big.shl(exp.unsigned_abs());
        }
    } else {
        s.shl(exp.unsigned_abs());
    }
    // `k`, the place above the first digit: the least with the upper end below 10^k (or at
    // it, if the end is not in the interval). The upper end is at least 2^(top - 1), and
    // `k` starts at the power of ten at or below that (exact for |top| < 1650 with this
    // constant), at most two short.
    let top = (32 - (mant + above).leading_zeros()) as i32 + exp;
    let mut k = ((top - 1) * 78_913) >> 18;
    if k >= 0 {
        s.mul_pow10(k.unsigned_abs());
    } else {
        for big in [&mut r, &mut low, &mut high] {
            big.mul_pow10(k.unsigned_abs());
        }
    }
    while reaches(&r, &high, &s, even) {
        s.mul_add(10, 0);
        k += 1;
    }
    // Below, the float is `(digits + r/s)·10^k`, with `r < s`.
    let (mut digits, mut len) = (0u32, 0);
    loop {
        for big in [&mut r, &mut low, &mut high] {
            big.mul_add(10, 0);
        }
        k -= 1;
        let mut digit = 0;
        while r >= s {
            r.sub(&s);
            digit += 1;
        }
        digits = digits * 10 + digit;
        len += 1;
        // Whether `digits·10^k` is inside the interval, and whether one unit more is. An
        // `f32` needs at most nine digits, so one of them is by then.
        let down = is_below(&r, &low, even);
        let up = reaches(&r, &high, &s, even);
        if down || up || len == 9 {
            // Between two inside, the nearer; at equal distance (`2r = s`), the upper.
            if up && (!down || reaches(&r, &r, &s, true)) {
                digits += 1;
            }
            return (digits, k, len);
        }
    }
}

/// Whether `r + high` reaches `s`: passes it, or meets it where the interval holds its ends.
fn reaches(r: &Big, high: &Big, s: &Big, inclusive: bool) -> bool {
    let mut end = *r;
    end.add(high);
    is_below(s, &end, inclusive)
}

/// Whether `a` is below `b`, or equal to it when `inclusive`: one comparison for both.
fn is_below(a: &Big, b: &Big, inclusive: bool) -> bool {
    match a.cmp(b) {
        Ordering::Less => true,
        Ordering::Equal => inclusive,
        Ordering::Greater => false,
    }
}
