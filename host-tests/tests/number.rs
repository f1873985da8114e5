//! Number text: `write_f32`/`parse_f32` against std's `{}` and `str::parse` as oracles, and the
//! integer codec.

use proptest::prelude::*;
use x30_panel::proto::xml::number::{
    F32_TEXT_MAX, I32_TEXT_MAX, NumberError, parse_f32, parse_i64, parse_int, parse_int_prefix,
    parse_non_finite, write_f32, write_i32, write_reading,
};

/// Our text for a finite float.
fn ours(x: f32) -> String {
    let mut out = [0u8; F32_TEXT_MAX];
    let len = write_f32(x, &mut out).expect("finite values are written");
    String::from_utf8(out[..len].to_vec()).expect("ASCII output")
}

/// Asserts both directions against std for one finite float.
fn check_float(x: f32) {
    let expected = format!("{x}");
    assert_eq!(ours(x), expected, "write_f32 of bits {:#010x}", x.to_bits());
    let back = parse_f32(expected.as_bytes());
    assert_eq!(
        back.map(f32::to_bits),
        Ok(x.to_bits()),
        "parse_f32({expected:?})"
    );
}

/// Asserts `parse_f32` agrees with std on `text` (std's infinity is our `OutOfRange`).
fn check_parse(text: &str) {
    let expected = match text.parse::<f32>() {
        Ok(v) if v.is_infinite() => Err(NumberError::OutOfRange),
        Ok(v) => Ok(v.to_bits()),
        Err(e) => panic!("oracle rejected {text:?}: {e}"),
    };
    assert_eq!(
        parse_f32(text.as_bytes()).map(f32::to_bits),
        expected,
        "parse_f32({text:?})"
    );
}

/// The next float away from zero and towards zero, for positive finite `x`.
fn neighbours(x: f32) -> [f32; 2] {
    [
        f32::from_bits(x.to_bits() + 1),
        f32::from_bits(x.to_bits().saturating_sub(1)),
    ]
}

#[test]
fn special_values_match_std() {
    for x in [
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        12.5,
        0.35,
        1000.0,
        -0.000_233_936_21,
        f32::MAX,
        -f32::MAX,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        -f32::from_bits(1),
        f32::from_bits(0x007f_ffff),
        f32::EPSILON,
        16_777_216.0,
        16_777_217.0,
        // 2097152.25 and .75 (exact; a literal would trip clippy::excessive_precision).
        2_097_152.0 + 0.25,
        2_097_152.0 + 0.75,
        1e30,
        0.1,
        0.2,
        0.3,
        1e-6,
        1e-5,
        1e-4,
        1e8,
        1e9,
        1e10,
    ] {
        check_float(x);
    }
    assert_eq!(ours(-0.0), "-0");
    assert_eq!(ours(0.0), "0");
    assert_eq!(ours(1.0), "1");
    assert_eq!(ours(-0.000_233_936_21), "-0.00023393621");
    assert_eq!(
        ours(2_097_152.0 + 0.25),
        "2097152.3",
        "ties between equally short go up"
    );
}

#[test]
fn longest_text_is_f32_text_max() {
    // "-0." followed by 44 zeros and "1".
    assert_eq!(ours(-f32::from_bits(1)).len(), F32_TEXT_MAX);
    assert_eq!(ours(-f32::MAX).len(), 40);
}

#[test]
fn powers_of_two_match_std() {
    let mut x = f32::from_bits(1);
    while x.is_finite() {
        for v in [x, -x] {
            check_float(v);
        }
        for v in neighbours(x) {
            check_float(v);
        }
        x *= 2.0;
    }
}

#[test]
fn powers_of_ten_match_std() {
    for e in -45..=38 {
        let x: f32 = format!("1e{e}").parse().unwrap();
        check_float(x);
        check_float(-x);
        for v in neighbours(x) {
            check_float(v);
        }
        check_parse(&format!("1e{e}"));
        check_parse(&format!("-1E{e}"));
    }
}

#[test]
fn subnormals_match_std() {
    for bits in (1..2000).chain((2000..0x0080_0000).step_by(997)) {
        check_float(f32::from_bits(bits));
    }
    check_float(f32::from_bits(0x007f_ffff));
}

#[test]
fn strided_bit_patterns_match_std() {
    // About a million patterns spread over every exponent.
    for bits in (0..0x7f80_0000u32).step_by(2039) {
        check_float(f32::from_bits(bits));
        check_float(-f32::from_bits(bits));
    }
}

#[test]
fn whole_numbers_match_std() {
    // A `compact` build writes a whole number below 2^24 as an integer (a stop's -1). Every
    // one below 2^16, then a stride up to 2^24, then the whole floats from there to 2^31,
    // which must not take that way: above 2^24 a shorter decimal may read back as the same
    // float (67108872 is written 67108870).
    let below = (1..1 << 16).chain((1 << 16..=1 << 24).step_by(97));
    let above = (1u32 << 24..1 << 31).step_by(4099).map(|i| i & !7);
    for i in below
        .chain(above)
        .chain([(1 << 24) - 1, 1 << 24, (1 << 24) + 2, 67_108_872])
    {
        check_float(i as f32);
        check_float(-(i as f32));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(50_000))]

    #[test]
    fn any_bit_pattern_matches_std(bits in any::<u32>()) {
        let x = f32::from_bits(bits);
        prop_assume!(x.is_finite());
        check_float(x);
    }

    #[test]
    fn typical_robot_values_match_std(x in -1e6f32..1e6) {
        check_float(x);
        check_float(x / 1000.0);
    }
}

/// Builds decimal text from its parts: sign, leading zeros, `digits` significant digits with
/// an optional point, and an optional exponent in one of several spellings.
fn decimal_text(digits: std::ops::RangeInclusive<usize>) -> impl Strategy<Value = String> {
    (
        0..3usize,
        0..4usize,
        prop::collection::vec(0..10u8, digits),
        any::<prop::sample::Index>(),
        any::<bool>(),
        prop::option::of((-75..60i32, 0..4usize)),
    )
        .prop_map(|(sign, zeros, digits, point, has_point, exponent)| {
            let mut text = String::from(["", "+", "-"][sign]);
            text.push_str(&"0".repeat(zeros));
            let digits: String = digits.iter().map(|d| char::from(b'0' + d)).collect();
            if has_point {
                let at = point.index(digits.len() + 1);
                text.push_str(&digits[..at]);
                text.push('.');
                text.push_str(&digits[at..]);
            } else {
                text.push_str(&digits);
            }
            if let Some((e, spelling)) = exponent {
                let e = match spelling {
                    0 => format!("e{e}"),
                    1 => format!("E{e}"),
                    2 if e >= 0 => format!("e+{e}"),
                    2 => format!("E{e}"),
                    _ => format!("e{:03}", e), // zero-padded exponent
                };
                text.push_str(&e);
            }
            text
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(50_000))]

    #[test]
    fn parse_matches_std(text in decimal_text(1..=19)) {
        check_parse(&text);
    }

    /// Past 19 significant digits too (where the digits after the 19th are read again when
    /// they decide).
    #[test]
    fn long_texts_match_std(text in decimal_text(20..=130)) {
        check_parse(&text);
    }

    /// A text without exponent reads the same with zeros appended to its fraction: past 19
    /// bytes that takes the exact reader instead of the short scan, so the two agree.
    #[test]
    fn short_and_long_scans_agree(text in decimal_text(1..=19)) {
        if !text.contains(['e', 'E']) {
            let point = if text.contains('.') { "" } else { "." };
            let long = format!("{text}{point}{}", "0".repeat(20));
            prop_assert_eq!(parse_f32(text.as_bytes()), parse_f32(long.as_bytes()), "{}", long);
        }
    }

    /// A fraction with one byte that is not a digit is refused, wherever the byte is: the
    /// short scan checks every byte it takes as a digit.
    #[test]
    fn a_stray_byte_in_a_fraction_is_refused(
        whole in "[0-9]{1,3}",
        fraction in "[0-9]{8,15}",
        at in any::<prop::sample::Index>(),
        stray in any::<u8>().prop_filter("not a digit or exponent", |b| {
            !b.is_ascii_digit() && !b"eE".contains(b)
        }),
    ) {
        let mut text = format!("{whole}.{fraction}").into_bytes();
        let i = whole.len() + 1 + at.index(fraction.len());
        text[i] = stray;
        prop_assert!(parse_f32(&text).is_err(), "{:?}", String::from_utf8_lossy(&text));
    }

    #[test]
    fn nine_digit_values_match_std(
        mantissa in 1u32..1_000_000_000,
        exponent in -55..=38i32,
        negative in any::<bool>(),
    ) {
        let sign = if negative { "-" } else { "" };
        check_parse(&format!("{sign}{mantissa}e{exponent}"));
        check_parse(&format!("{sign}0.{mantissa:09}e{exponent}"));
    }

    /// The exact midpoint between adjacent floats, however many digits it takes (up to
    /// 112), rounds to the even neighbour; a digit past its last, up or down, decides;
    /// 19-digit decimals just below and above it round down and up.
    #[test]
    fn midpoints_round_to_even(bits in 1u32..0x7f7f_ffff) {
        let low = f32::from_bits(bits);
        let Midpoint { value: mid, text: exact, high, even } = midpoint_above(low);
        prop_assert_eq!(parse_f32(exact.as_bytes()), Ok(even), "{}", exact);
        check_parse(&exact);
        // A non-zero digit far past the midpoint's last breaks the tie upwards.
        let point = if exact.contains('.') { "" } else { "." };
        let nudged = format!("{exact}{point}{}1", "0".repeat(20));
        prop_assert_eq!(parse_f32(nudged.as_bytes()), Ok(high), "{}", nudged);
        check_parse(&nudged);
        // Its last digit one lower, then nines: just below the midpoint.
        let (head, last) = exact.split_at(exact.len() - 1);
        let last = last.parse::<u8>().unwrap();
        if last > 0 {
            let below = format!("{head}{}{point}{}", last - 1, "9".repeat(30));
            prop_assert_eq!(parse_f32(below.as_bytes()), Ok(low), "{}", below);
            check_parse(&below);
        }
        // 19 significant digits just below and just above the midpoint.
        let (below, above) = bracket_19(mid);
        prop_assert_eq!(parse_f32(below.as_bytes()), Ok(low), "{}", below);
        prop_assert_eq!(parse_f32(above.as_bytes()), Ok(high), "{}", above);
        check_parse(&below);
        check_parse(&above);
    }
}

/// The midpoint between a positive float and the next one up.
struct Midpoint {
    /// Its value, exact: adjacent floats have 24-bit significands one binade apart at most.
    value: f64,
    /// Its exact decimal text.
    text: String,
    /// The float above it.
    high: f32,
    /// The one of the two floats a reader rounds it to: the one with the even significand.
    even: f32,
}

/// The [`Midpoint`] between the positive finite float `low` and the next float up.
fn midpoint_above(low: f32) -> Midpoint {
    let high = f32::from_bits(low.to_bits() + 1);
    let value = (f64::from(low) + f64::from(high)) / 2.0;
    Midpoint {
        value,
        text: exact_decimal(value),
        high,
        even: if low.to_bits().is_multiple_of(2) {
            low
        } else {
            high
        },
    }
}

/// The exact decimal expansion of a positive `f64` (std prints exact digits when asked for
/// enough of them).
fn exact_decimal(v: f64) -> String {
    let text = format!("{v:.1100}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The 19-significant-digit decimals just below and just above `v` (which has more digits).
fn bracket_19(v: f64) -> (String, String) {
    // `{:.18e}` rounds to 19 digits; step the last digit to land on each side of `v`.
    let text = format!("{v:.18e}");
    let (mantissa, exponent) = text.split_once('e').unwrap();
    let exponent: i32 = exponent.parse().unwrap();
    let digits: u64 = mantissa.replace('.', "").parse().unwrap();
    let as_text = |d: u64| format!("{d}e{}", exponent - 18);
    let value = |d: u64| exact_value_cmp(d, exponent - 18, v);
    let (mut low, mut high) = (digits, digits);
    while value(low) != std::cmp::Ordering::Less {
        low -= 1;
    }
    while value(high) != std::cmp::Ordering::Greater {
        high += 1;
    }
    (as_text(low), as_text(high))
}

/// Compares `d·10^e` with `v` exactly, using std's exact decimal expansion of `v`.
fn exact_value_cmp(d: u64, e: i32, v: f64) -> std::cmp::Ordering {
    // Both as (digits, exponent of the first digit) compared digit by digit.
    let normalise = |s: String, point: i64| -> (i64, Vec<u8>) {
        let digits: Vec<u8> = s.bytes().collect();
        let first = digits
            .iter()
            .position(|&c| c != b'0')
            .unwrap_or(digits.len());
        let mut significant = digits[first..].to_vec();
        while significant.last() == Some(&b'0') {
            significant.pop();
        }
        (point - first as i64, significant)
    };
    let d_text = d.to_string();
    let left = normalise(d_text.clone(), d_text.len() as i64 + i64::from(e));
    let exact = exact_decimal(v);
    let (int, frac) = exact.split_once('.').unwrap_or((&exact, ""));
    let right = normalise(format!("{int}{frac}"), int.len() as i64);
    left.0.cmp(&right.0).then_with(|| left.1.cmp(&right.1))
}

#[test]
fn parse_forms_match_std() {
    for text in [
        ".5",
        "5.",
        "-.5",
        "+5.",
        "1e5",
        "1E5",
        "1.5E+3",
        "1.5e-3",
        "-0.00023393621",
        "0",
        "-0",
        "+0",
        "0.0",
        "00000.00000",
        "0e99999",
        "1e-99999",
        "-1e-99999",
        "1e-46",
        "7e-46",
        "7.1e-46",
        "1.4e-45",
        "3.4028235e38",
        "3.40282356e38",
        "340282356779733661637539395458142568447",
        "0.000000000000000000000000000000000000000000001",
        "2097152.25",
        "2097152.75",
        "16777217",
        "16777219",
        "9999999999999999999",
        "12345678901234567890123456789",
        "1234567890123456789e-19",
        "0.1",
        "0.2",
        "0.3",
        "00123.4500e2",
        "123456789e-50",
        "1e00000000000000000000000000000000000001",
    ] {
        check_parse(text);
    }
    assert_eq!(parse_f32(b"-0").map(f32::to_bits), Ok((-0.0f32).to_bits()));
    assert_eq!(
        parse_f32(b"-1e-99999").map(f32::to_bits),
        Ok((-0.0f32).to_bits())
    );
    assert_eq!(parse_f32(b"0e99999"), Ok(0.0));
}

/// Digits past the 19th are read exactly where they decide the rounding: ties written out
/// in full, and the largest float's upper midpoint, which is beyond the range.
#[test]
fn more_than_19_digits_round_correctly() {
    for tie in [
        "1.000000178813934326171875",
        "0.1000000052154064178466796875",
        "0.0010000001057051122188568115234375",
        "1.0000000596046447753906251",
        "1.0000000596046447753906249999999999999",
    ] {
        check_parse(tie);
    }
    // Half a step above f32::MAX rounds to infinity, which is out of range; a digit less is
    // f32::MAX.
    assert_eq!(
        parse_f32(b"340282356779733661637539395458142568448"),
        Err(NumberError::OutOfRange)
    );
    assert_eq!(
        parse_f32(b"340282356779733661637539395458142568447.9999999999999999999999"),
        Ok(f32::MAX)
    );
    // The tie above the smallest subnormal, all 105 significant digits of it.
    let subnormal_tie = exact_decimal(f64::from(f32::from_bits(1)) * 1.5);
    assert_eq!(parse_f32(subnormal_tie.as_bytes()), Ok(f32::from_bits(2)));
    check_parse(&subnormal_tie);
    check_parse("0.10000000000000000000000000000000001");
    check_parse("3.14159265358979323846264338327950288");
    check_parse("100000000000000000000000000000000000000");
    check_parse(&format!("1{}e-60", "0".repeat(50)));
    check_parse(&format!("0.{}1", "0".repeat(200)));
    check_parse(&format!("{}1e-200", "0".repeat(300)));
    // 16777217 is the midpoint of 16777216 and 16777218: ties go to even, anything above up.
    assert_eq!(parse_f32(b"16777217"), Ok(16_777_216.0));
    assert_eq!(parse_f32(b"16777217.0000000000001"), Ok(16_777_218.0));
    assert_eq!(parse_f32(b"16777216.9999999999999"), Ok(16_777_216.0));
    check_parse("16777217.0000000000001");
    check_parse("16777217.000000000000000000000000000000000000000001");
}

#[test]
fn power_table_seams_match_std() {
    // The usual text's 10^e is one table entry for each length of its fraction, 0 to 18:
    // mantissas of 1, 9 and 19 digits with each (past 19 bytes the exact reader takes them,
    // which must agree), and the floats written with those scales.
    for fraction in 0..=18 {
        for mantissa in [
            "1",
            "7",
            "123456789",
            "9999999999999999999",
            "1000000000000000001",
        ] {
            let text = match mantissa.len().checked_sub(fraction) {
                Some(whole) if whole > 0 => {
                    format!("{}.{}", &mantissa[..whole], &mantissa[whole..])
                }
                _ => format!("0.{}{mantissa}", "0".repeat(fraction - mantissa.len())),
            };
            check_parse(&text);
            check_parse(&format!("-{text}"));
        }
    }
    // The longest fraction the short scan takes, 18 digits, has no digit before the point.
    for text in [
        ".123456789012345678",
        "-.999999999999999999",
        ".000000000000000001",
    ] {
        check_parse(text);
    }
    // Texts with an exponent, over the whole range of floats and past it.
    for e in -64..=38 {
        for mantissa in ["1", "7", "123456789", "9999999999999999999"] {
            check_parse(&format!("{mantissa}e{e}"));
            check_parse(&format!("-{mantissa}E{e}"));
        }
    }
    for e in -45..=38 {
        for x in [format!("1.5e{e}"), format!("9.87654321e{e}")] {
            let x: f32 = x.parse().unwrap();
            if x.is_finite() {
                check_float(x);
            }
        }
    }
}

#[test]
fn nineteen_digit_mantissa_edge() {
    // Texts of 19 bytes and just past them: the short scan takes 19 bytes at most, the
    // exact reader the rest.
    for text in [
        "1000000000000000000",
        "9999999999999999999",
        "99999999999999999999",
        "0.00000000009999999999999999999",
        "0.000000000099999999999999999999",
        "1999999999999999999.5",
        "16777216.9999999999",
        "16777216.99999999999",
        "16777217.00000000000",
        "000000000000000000000016777217.0000000000000001",
    ] {
        check_parse(text);
    }
}

/// `n` with a point before its last `k` digits (zeros in front as needed).
fn with_point(n: u64, k: usize) -> String {
    let digits = format!("{n:0>width$}", width = k + 1);
    let (whole, fraction) = digits.split_at(digits.len() - k);
    if k == 0 {
        whole.to_string()
    } else {
        format!("{whole}.{fraction}")
    }
}

#[test]
fn word_sized_decimals_match_std() {
    // A `compact` build reads a decimal whose digits fit a `u32`, with at most 13 after the
    // point, by long division in machine words; the rest, and the integer parts too wide for
    // a float's quotient, in big integers. Its edges: every power of two and its neighbours
    // as digits (up to the widest word and past it), and for each point position the digits
    // where the division's quotient gains a bit (the power of five it divides by, shifted by
    // 26 and 27). Nine and ten digits (999999999, 1000000000 and the powers of two from
    // 2^30) are also the exact reader's edge in every build: the first nine significant
    // digits are kept in a word, and the tenth moves them to a big integer.
    let mut digits = vec![1, 9, 10, 999_999_999, 1_000_000_000];
    for p in 1..33 {
        digits.extend([(1 << p) - 1, 1 << p, (1 << p) + 1]);
    }
    for k in 0..=14 {
        for bits in [26, 27] {
            let edge = 5u64.pow(k) << bits;
            digits.extend([edge - 1, edge, edge + 1]);
        }
    }
    for k in 0..=14 {
        for &n in &digits {
            let text = with_point(n, k);
            check_parse(&text);
            check_parse(&format!("-{text}"));
        }
    }
    // Midpoints between floats that are short decimals: between integers from 2^24 up (odd
    // ones, and twice odd from 2^25), and with one or two binary places below 2^24. Each
    // rounds to the even neighbour.
    for places in -8i32..=2 {
        let binade = 23 - places;
        for step in [0u32, 1, 2, 3, 1 << 22, (1 << 23) - 2, (1 << 23) - 1] {
            let mid = midpoint_above(f32::from_bits((((binade + 127) as u32) << 23) + step));
            assert_eq!(parse_f32(mid.text.as_bytes()), Ok(mid.even), "{}", mid.text);
            check_parse(&mid.text);
        }
    }
}

#[test]
fn parse_rejections() {
    assert_eq!(parse_f32(b""), Err(NumberError::Empty));
    for bad in [
        "-", "+", ".", "-.", "e5", ".e5", "1e", "1e+", "1e-", "1.2.3", "1,5", " 1", "1 ", "inf",
        "-inf", "nan", "NaN", "infinity", "0x10", "--1", "+-1", "1e5.0", "1e5e5", "1d5", "١",
        "1_000",
    ] {
        assert_eq!(
            parse_f32(bad.as_bytes()),
            Err(NumberError::Invalid),
            "{bad:?}"
        );
    }
    for big in [
        "1e39",
        "3.5e38",
        "-3.5e38",
        "1e99999",
        "3.40282357e38",
        "99e99",
    ] {
        assert_eq!(
            parse_f32(big.as_bytes()),
            Err(NumberError::OutOfRange),
            "{big:?}"
        );
    }
}

#[test]
fn write_rejects_non_finite() {
    let mut out = [0u8; F32_TEXT_MAX];
    for x in [f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(write_f32(x, &mut out), Err(NumberError::NotFinite));
    }
}

/// C's words for NaN and infinity (answers only; `parse_f32` refuses them, above) read
/// back as what they name, and `write_reading` writes what glibc's `printf` writes for
/// them, and a finite reading as `write_f32` does.
#[test]
fn non_finite_words_as_c_writes_them() {
    let bits = |x: Option<f32>| x.map(f32::to_bits);
    for (text, value) in [
        ("nan", f32::NAN),
        ("NaN", f32::NAN),
        ("+nan", f32::NAN),
        ("-nan", -f32::NAN),
        ("-NAN", -f32::NAN),
        ("inf", f32::INFINITY),
        ("INF", f32::INFINITY),
        ("Infinity", f32::INFINITY),
        ("-inf", f32::NEG_INFINITY),
        ("-infinity", f32::NEG_INFINITY),
    ] {
        assert_eq!(
            bits(parse_non_finite(text.as_bytes())),
            Some(value.to_bits()),
            "{text}"
        );
    }
    for text in [
        "",
        "-",
        "na",
        "nan0",
        "nan(1)",
        "in",
        "infinit",
        "infinityy",
        "--inf",
        "1",
        "0.5",
    ] {
        assert_eq!(parse_non_finite(text.as_bytes()), None, "{text:?}");
    }
    let mut out = [0u8; F32_TEXT_MAX];
    for (value, text) in [
        (f32::NAN, "nan"),
        (-f32::NAN, "-nan"),
        (f32::INFINITY, "inf"),
        (f32::NEG_INFINITY, "-inf"),
        (1.5, "1.5"),
        (-0.0, "-0"),
        (f32::MAX, "340282350000000000000000000000000000000"),
    ] {
        let n = write_reading(value, &mut out);
        assert_eq!(&out[..n], text.as_bytes(), "{value}");
    }
}

/// Our text for an integer.
fn int_text(v: i32) -> String {
    let mut out = [0u8; I32_TEXT_MAX];
    let len = write_i32(v, &mut out);
    String::from_utf8(out[..len].to_vec()).unwrap()
}

#[test]
fn integer_edges() {
    for v in [
        i32::MIN,
        i32::MIN + 1,
        i32::MAX,
        0,
        -1,
        1,
        9,
        10,
        -10,
        99,
        100,
    ] {
        assert_eq!(int_text(v), v.to_string());
        assert_eq!(parse_i64(v.to_string().as_bytes()), Ok(v.into()));
    }
    assert_eq!(int_text(i32::MIN).len(), I32_TEXT_MAX);
    for v in [i64::MIN, i64::MAX] {
        assert_eq!(parse_i64(v.to_string().as_bytes()), Ok(v));
    }
    assert_eq!(parse_i64(b"+5"), Ok(5));
    assert_eq!(parse_i64(b"-0"), Ok(0));
    assert_eq!(parse_i64(b"007"), Ok(7));
    assert_eq!(
        parse_i64(b"9223372036854775808"),
        Err(NumberError::OutOfRange)
    );
    assert_eq!(
        parse_i64(b"-9223372036854775809"),
        Err(NumberError::OutOfRange)
    );
    assert_eq!(
        parse_i64(b"99999999999999999999999"),
        Err(NumberError::OutOfRange)
    );
    assert_eq!(
        parse_i64(b"99999999999999999999999x"),
        Err(NumberError::Invalid)
    );
    // Twenty digits whose value is 2^64, which a 64-bit accumulator would read as zero; and
    // leading zeros, which count for nothing.
    assert_eq!(
        parse_i64(b"18446744073709551616"),
        Err(NumberError::OutOfRange)
    );
    assert_eq!(
        parse_i64(b"-00000000000000000000009223372036854775808"),
        Ok(i64::MIN)
    );
    assert_eq!(parse_i64(b""), Err(NumberError::Empty));
    for bad in [
        "-", "+", "5.0", "1e3", " 5", "5 ", "--5", "+-5", "0x1", "five",
    ] {
        assert_eq!(
            parse_i64(bad.as_bytes()),
            Err(NumberError::Invalid),
            "{bad:?}"
        );
    }
    assert_eq!(parse_int::<u8>(b"255"), Ok(255));
    assert_eq!(parse_int::<u8>(b"256"), Err(NumberError::OutOfRange));
    assert_eq!(parse_int::<u8>(b"-1"), Err(NumberError::OutOfRange));
    assert_eq!(parse_int::<i8>(b"-128"), Ok(-128));
    assert_eq!(parse_int::<i8>(b"+5"), Ok(5));
    assert_eq!(parse_int::<u32>(b"5.0"), Err(NumberError::Invalid));
    assert_eq!(parse_int::<u16>(b""), Err(NumberError::Empty));
    assert_eq!(parse_int::<u16>(b"-"), Err(NumberError::Invalid));
    assert_eq!(
        parse_int::<u64>(b"9223372036854775807"),
        Ok(i64::MAX as u64)
    );
}

/// Every integer of up to six digits, and every power of ten and its neighbours, is written
/// as std writes it: the lengths where the text's layout changes.
#[test]
fn integers_print_as_std_at_every_length() {
    let mut edges = vec![i32::MIN, i32::MIN + 1, i32::MAX];
    for power in (0..10).map(|k| 10i32.pow(k)) {
        for v in [power - 1, power, power + 1] {
            edges.extend([v, -v]);
        }
    }
    for v in (-1_000_000..=1_000_000).chain(edges) {
        assert_eq!(int_text(v), v.to_string());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn integers_round_trip(v in any::<i32>()) {
        let text = int_text(v);
        prop_assert_eq!(&text, &v.to_string());
        prop_assert_eq!(parse_i64(text.as_bytes()), Ok(v.into()));
        prop_assert_eq!(parse_int::<i32>(text.as_bytes()), Ok(v));
    }

    #[test]
    fn integer_parse_matches_std(text in "[+-]?[0-9]{1,22}") {
        let expected = text.parse::<i64>().map_err(|_| NumberError::OutOfRange);
        prop_assert_eq!(parse_i64(text.as_bytes()), expected);
    }

    /// What `parse_int_prefix` reads at the start of a text is what `parse_int` reads from
    /// that part alone, and it stops exactly where the integer's text ends.
    #[test]
    fn integer_prefix_is_parse_of_the_prefix(text in "[+-]?[0-9]{0,12}[<&a .e+-]?[0-9<]{0,3}") {
        let bytes = text.as_bytes();
        match parse_int_prefix::<i32>(bytes) {
            Some((value, n)) => {
                prop_assert_eq!(parse_int::<i32>(&bytes[..n]), Ok(value));
                prop_assert!(!bytes.get(n).is_some_and(u8::is_ascii_digit));
            }
            None => {
                let digits = text.trim_start_matches(['+', '-']);
                let end = text.len() - digits.len()
                    + digits.bytes().take_while(u8::is_ascii_digit).count();
                prop_assert!(parse_int::<i32>(&bytes[..end]).is_err(), "{text:?}");
            }
        }
    }
}

/// Every one of the 2^32 bit patterns against std, on all cores. About 2·10^9 finite values per
/// sign; run by hand, in each build: `cargo test --release --test number -- --ignored`, and
/// the same with `--features compact`.
#[test]
#[ignore = "checks all 2^32 floats: 45 minutes on two cores in release mode, 95 in the compact build"]
fn exhaustive_f32_round_trip() {
    use std::fmt::Write;
    use std::sync::atomic::{AtomicU64, Ordering};

    let threads = std::thread::available_parallelism().map_or(4, |n| n.get()) as u64;
    let failures = AtomicU64::new(0);
    let longest = AtomicU64::new(0);
    const TOTAL: u64 = 1 << 32;
    std::thread::scope(|scope| {
        for t in 0..threads {
            let (failures, longest) = (&failures, &longest);
            scope.spawn(move || {
                let mut expected = String::with_capacity(64);
                let mut out = [0u8; F32_TEXT_MAX];
                let mut local_longest = 0;
                for bits in (TOTAL * t / threads)..(TOTAL * (t + 1) / threads) {
                    let x = f32::from_bits(bits as u32);
                    if !x.is_finite() {
                        continue;
                    }
                    expected.clear();
                    write!(expected, "{x}").unwrap();
                    let len = write_f32(x, &mut out).unwrap();
                    local_longest = local_longest.max(len);
                    let parsed = parse_f32(expected.as_bytes());
                    let wrong = &out[..len] != expected.as_bytes()
                        || parsed.map(f32::to_bits) != Ok(bits as u32);
                    if wrong && failures.fetch_add(1, Ordering::Relaxed) < 20 {
                        eprintln!(
                            "{bits:#010x}: std {expected:?}, ours {:?}, parsed {parsed:?}",
                            String::from_utf8_lossy(&out[..len])
                        );
                    }
                }
                longest.fetch_max(local_longest as u64, Ordering::Relaxed);
            });
        }
    });
    assert_eq!(failures.load(Ordering::Relaxed), 0);
    assert_eq!(longest.load(Ordering::Relaxed), F32_TEXT_MAX as u64);
}

/// The default build's shortcuts for an item line's number, against the readers they stand
/// in for.
#[cfg(not(feature = "compact"))]
mod shortcuts {
    use proptest::prelude::*;
    use x30_panel::proto::xml::number::{parse_int_prefix, short_int_prefix};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]

        /// `short_int_prefix` reads one to seven digits without a sign, followed by
        /// something other than a digit within the eight bytes it reads at once, as
        /// `parse_int_prefix` reads them, and declines every other text.
        #[test]
        fn short_integers_read_as_the_prefix_reader_reads_them(
            text in "[+-]?[0-9]{0,10}[<&a .e+-]?[0-9<]{0,8}|[\\x00-\\xff]{0,10}",
        ) {
            let bytes = text.as_bytes();
            let digits = bytes.iter().take_while(|b| b.is_ascii_digit()).count();
            let expected = match (bytes.len() >= 8, digits) {
                (true, 1..=7) => parse_int_prefix::<i32>(bytes).map(|(v, n)| (v as u32, n)),
                _ => None,
            };
            prop_assert_eq!(short_int_prefix(bytes), expected, "{:?}", text);
        }
    }
}
