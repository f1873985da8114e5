//! A fixed-size unsigned integer, with only what the exact float algorithms need.
//!
//! Its size covers every number they make: a decimal of up to [`super::EXACT_DIGITS`]
//! significant digits (below 2^399), shifted or multiplied by powers of five up to 5^165
//! (below 2^384) and by the 27 bits of a quotient; 416 bits hold them all (the algorithms
//! state their own bounds). Arithmetic past that would wrap silently, so the callers keep
//! to those bounds; nothing here can panic. Most operations are kept out of line: they serve
//! the exact conversions only, where one copy of each matters more than a call's cost. The
//! three left to the compiler (`is_zero`, `add`, `mul_pow10`) each took more flash out of
//! line (measured).

use core::cmp::Ordering;

/// Number of 32-bit limbs.
const LIMBS: usize = 13;

/// An unsigned integer of up to 416 bits, least significant limb first.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) struct Big([u32; LIMBS]);

impl Big {
    /// Zero.
    pub(super) const ZERO: Self = Big([0; LIMBS]);

    /// The value `v`.
    #[inline(never)]
    pub(super) fn from_u64(v: u64) -> Self {
        let mut big = Big([0; LIMBS]);
        let [low, high, ..] = &mut big.0;
        (*low, *high) = (v as u32, (v >> 32) as u32);
        big
    }

    /// The value, if it fits a `u32`.
    #[cfg(feature = "compact")]
    pub(super) fn to_u32(self) -> Option<u32> {
        match self.0 {
            [low, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0] => Some(low),
            _ => None,
        }
    }

    /// Whether the value is zero.
    pub(super) fn is_zero(&self) -> bool {
        self.0.iter().all(|&limb| limb == 0)
    }

    /// `self = self·factor + addend`.
    #[inline(never)]
    pub(super) fn mul_add(&mut self, factor: u32, addend: u32) {
        let mut carry = u64::from(addend);
        for limb in &mut self.0 {
            // (2^32-1)^2 + (2^32-1) < 2^64: no overflow.
            let product = u64::from(*limb) * u64::from(factor) + carry;
            *limb = product as u32;
            carry = product >> 32;
        }
    }

    /// `self *= 5^e`.
    #[inline(never)]
    pub(super) fn mul_pow5(&mut self, mut e: u32) {
        while e > 0 {
            // 5^13 is the largest power of five below 2^32.
            let step = e.min(13);
            self.mul_add(5u32.pow(step), 0);
            e -= step;
        }
    }

    /// `self *= 10^e`.
    pub(super) fn mul_pow10(&mut self, e: u32) {
        self.mul_pow5(e);
        self.shl(e);
    }

    /// `self += other`.
    pub(super) fn add(&mut self, other: &Big) {
        let mut carry = 0;
        for (limb, &add) in self.0.iter_mut().zip(&other.0) {
            let sum = u64::from(*limb) + u64::from(add) + carry;
            *limb = sum as u32;
            carry = sum >> 32;
        }
    }

    /// `self -= other`, for `other <= self`.
    #[inline(never)]
    pub(super) fn sub(&mut self, other: &Big) {
        let mut borrow = 0;
        for (limb, &sub) in self.0.iter_mut().zip(&other.0) {
            let (difference, under) = limb.overflowing_sub(sub);
            let (difference, under_again) = difference.overflowing_sub(borrow);
            *limb = difference;
            borrow = u32::from(under | under_again);
        }
    }

    /// Number of significant bits (0 for zero).
    #[inline(never)]
    pub(super) fn bit_len(&self) -> u32 {
        for (i, &limb) in self.0.iter().enumerate().rev() {
            if limb != 0 {
                return (i as u32 + 1) * 32 - limb.leading_zeros();
            }
        }
        0
    }

    /// `self <<= n`.
    #[inline(never)]
    pub(super) fn shl(&mut self, n: u32) {
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
}

impl PartialOrd for Big {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// By value: the most significant limbs decide first.
impl Ord for Big {
    #[inline(never)]
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.iter().rev().cmp(other.0.iter().rev())
    }
}
