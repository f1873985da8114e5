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
//!   message and `Time` again.
//!
//! Build and run with `scripts/fuzz.sh`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use x30_panel::proto::message::{Request, Response};
use x30_panel::proto::xml::{StructureError, read_document, read_document_general};

/// Re-encoding buffer: larger than any message the codec can write.
const ENCODE_BUF: usize = 16 * 1024;

fuzz_target!(|body: &[u8]| {
    assert_eq!(items_of(body, true), items_of(body, false), "read_document");

    // Debug text throughout, so that a NaN would compare equal to itself.
    let request = Request::decode(body);
    assert_eq!(
        format!("{request:?}"),
        format!("{:?}", Request::decode_general(body)),
        "Request::decode"
    );
    let response = Response::decode(body);
    assert_eq!(
        format!("{response:?}"),
        format!("{:?}", Response::decode_general(body)),
        "Response::decode"
    );

    let mut out = vec![0u8; ENCODE_BUF];
    if let Ok(decoded) = request {
        let n = decoded
            .message
            .encode(&decoded.time, &mut out)
            .expect("a decoded request encodes");
        assert_eq!(
            format!("{:?}", Request::decode(&out[..n])),
            format!("{:?}", Ok::<_, ()>(decoded)),
            "request round trip"
        );
    }
    if let Ok(decoded) = response {
        let n = decoded
            .message
            .encode(&decoded.time, &mut out)
            .expect("a decoded response encodes");
        assert_eq!(
            format!("{:?}", Response::decode(&out[..n])),
            format!("{:?}", Ok::<_, ()>(decoded)),
            "response round trip"
        );
    }
});

/// Everything the reader hands out: each block's items (name and text), then the envelope
/// and block count, or the error.
fn items_of(body: &[u8], shortcut: bool) -> String {
    let mut trace = String::new();
    let mut on_items = |envelope: &_, items: &mut x30_panel::proto::xml::Items<'_>| {
        trace.push_str(&format!("block {envelope:?}:"));
        for item in items {
            match item {
                Ok(item) => trace.push_str(&format!(" {:?}={:?}", item.name, item.text)),
                Err(e) => {
                    trace.push_str(&format!(" error {e:?}"));
                    return Err(StructureError::Xml(e));
                }
            }
        }
        trace.push('\n');
        Ok::<_, StructureError>(())
    };
    let result = if shortcut {
        read_document(body, &mut on_items)
    } else {
        read_document_general(body, &mut on_items)
    };
    format!("{trace}{result:?}")
}
