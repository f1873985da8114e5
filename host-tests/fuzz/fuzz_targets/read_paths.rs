//! libFuzzer target: the layout shortcuts of the document reader against the general
//! reader, and decode(encode(x)) == x.
//!
//! The input is one body (an ASDU). Invariants (a panic is a finding):
//!
//! - `read_document` and `read_document_general` (the same reader with every shortcut
//!   declining) return the same envelope, block count and error, and hand out the same
//!   items, in the same order, with the same texts;
//! - `Request::decode` and `Response::decode` return exactly what their `decode_general`
//!   twins return (message, `Time` or error);
//! - every message a decoder accepts encodes, and decoding that encoding gives the same
//!   message and `Time` again;
//! - an answer encodes to the same bytes through `Response::encode` (each item by code of
//!   its own) and `Response::encode_general` (through the item tables);
//! - the number text agrees with Rust's own: `parse_f32` reads each text between the
//!   body's tags as `str::parse` does, and the float of the body's first four bytes is
//!   written as `{}` writes it. The fast paths and the exact conversions they leave the
//!   rest to must both agree with it.
//!
//! Build and run with `scripts/fuzz.sh`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::fmt::Debug;
use x30_panel::proto::message::{Decoded, Request, Response};
use x30_panel::proto::time::Timestamp;
use x30_panel::proto::xml::number::{F32_TEXT_MAX, parse_f32, write_f32};

#[path = "../../tests/common/reader_trace.rs"]
mod reader_trace;

/// Re-encoding buffer: larger than any message the codec can write.
const ENCODE_BUF: usize = 16 * 1024;

fuzz_target!(|body: &[u8]| {
    check_number_text(body);
    assert_eq!(
        reader_trace::reader_trace(body, true),
        reader_trace::reader_trace(body, false),
        "read_document"
    );
    check_direction(
        "request",
        body,
        Request::decode,
        Request::decode_general,
        Request::encode,
    );
    check_direction(
        "response",
        body,
        Response::decode,
        Response::decode_general,
        Response::encode,
    );
    if let Ok(decoded) = Response::decode(body) {
        let (mut straight, mut general) = (vec![0u8; ENCODE_BUF], vec![0u8; ENCODE_BUF]);
        let written = decoded.message.encode(&decoded.time, &mut straight);
        assert_eq!(
            written,
            decoded.message.encode_general(&decoded.time, &mut general),
            "response: encode against encode_general"
        );
        if let Ok(n) = written {
            assert_eq!(
                straight[..n],
                general[..n],
                "response: encode against encode_general"
            );
        }
    }
});

/// The invariants for one direction: `decode` gives what `decode_general` gives (compared
/// as Debug text, so that a NaN equals itself), and what it accepts encodes to a body that
/// decodes to the same message and `Time`.
fn check_direction<M: Debug, E: Debug, W: Debug>(
    what: &str,
    body: &[u8],
    decode: fn(&[u8]) -> Result<Decoded<M>, E>,
    decode_general: fn(&[u8]) -> Result<Decoded<M>, E>,
    encode: fn(&M, &Timestamp, &mut [u8]) -> Result<usize, W>,
) {
    let decoded = decode(body);
    assert_eq!(
        format!("{decoded:?}"),
        format!("{:?}", decode_general(body)),
        "{what}: decode against decode_general"
    );
    if let Ok(decoded) = decoded {
        let mut out = vec![0u8; ENCODE_BUF];
        let n = encode(&decoded.message, &decoded.time, &mut out)
            .unwrap_or_else(|e| panic!("a decoded {what} does not encode: {e:?}"));
        // The message and `Time` only: items that could not be read are written as left
        // out, so the second reading has none to name.
        assert_eq!(
            format!("{:?}", decode(&out[..n]).map(|d| (d.time, d.message))),
            format!("{:?}", Ok::<_, ()>((decoded.time, decoded.message))),
            "{what}: round trip"
        );
    }
}

/// `parse_f32` of each text between the body's tags (the items' numbers of a seed) against
/// `str::parse::<f32>`, and `write_f32` of the float of its first four bytes against `{}`.
fn check_number_text(body: &[u8]) {
    for text in body.split(|&b| b == b'<' || b == b'>') {
        let Ok(text) = std::str::from_utf8(text) else {
            continue;
        };
        let ours = parse_f32(text.as_bytes()).map(f32::to_bits);
        // `str::parse` also reads the words for NaN and infinity, which the protocol's
        // numbers never are; a number beyond the range is infinite there, out of range here.
        let word = text
            .bytes()
            .any(|b| b.is_ascii_alphabetic() && !b.eq_ignore_ascii_case(&b'e'));
        match text.parse::<f32>() {
            Ok(_) if word => assert!(ours.is_err(), "parse_f32({text:?}) read a word: {ours:?}"),
            Ok(v) if v.is_infinite() => assert!(ours.is_err(), "parse_f32({text:?}): {ours:?}"),
            Ok(v) => assert_eq!(ours, Ok(v.to_bits()), "parse_f32({text:?})"),
            Err(_) => assert!(ours.is_err(), "parse_f32({text:?}) read {ours:?}"),
        }
    }
    if let Some(bits) = body.first_chunk::<4>() {
        let value = f32::from_le_bytes(*bits);
        let mut out = [0u8; F32_TEXT_MAX];
        match write_f32(value, &mut out) {
            Ok(n) => assert_eq!(
                out.get(..n),
                Some(format!("{value}").as_bytes()),
                "write_f32({value:?})"
            ),
            Err(_) => assert!(!value.is_finite(), "write_f32({value:?}) refused"),
        }
    }
}
