//! Malformed input gets Type 0 answers (docs/protocol.md, "Type 0: request error"), and the
//! connection keeps working.

mod common;

use common::*;
use x30_panel::proto::codes::RequestErrorCode;
use x30_panel::proto::frame::{HEADER_LEN, SYNC};
use x30_panel::proto::message::{MAX_REQUEST_LEN, Request, Response};
use x30_panel::proto::time::Timestamp;

/// Expects a Type 0 answer with `code` and message ID `id`, then that the connection still
/// answers a good request.
fn assert_request_error_then_working(client: &mut Client, code: RequestErrorCode, id: u16) {
    let answer = client.recv();
    assert_eq!(answer.id, id, "{answer:?}");
    assert_eq!(answer.time, Timestamp::ZERO);
    match answer.response {
        Response::RequestError(e) => assert_eq!(e.code, code),
        other => panic!("expected Type 0, got {other:?}"),
    }
    client.send_with_id(500, &Request::Status);
    let next = client.recv();
    assert_eq!(
        next.id, 500,
        "the next good request is answered next: {next:?}"
    );
    assert!(matches!(next.response, Response::Status(_)));
}

/// A header with chosen fields.
fn header(len: u16, id: u16, reserved: [u8; 8]) -> Vec<u8> {
    let mut h = SYNC.to_vec();
    h.extend_from_slice(&len.to_le_bytes());
    h.extend_from_slice(&id.to_le_bytes());
    h.extend_from_slice(&reserved);
    assert_eq!(h.len(), HEADER_LEN);
    h
}

const BODY: &str = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>\n  <Type>1002</Type>\n  <Command>1</Command>\n  <Time>2023-01-01 00:00:00</Time>\n  <Items/>\n</PatrolDevice>\n";

#[test]
fn bytes_without_a_header_get_error_code_1() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let mut bytes = b"hello robot \xEB\x90 not a frame".to_vec();
    bytes.extend(frame_bytes(7, &Request::Battery));
    client.send_raw(&bytes);
    assert_request_error_then_working_after(&mut client, RequestErrorCode::HeaderMissing, 0, 7);
}

/// Like [`assert_request_error_then_working`], when a good frame (`good_id`) already followed
/// the bad bytes.
fn assert_request_error_then_working_after(
    client: &mut Client,
    code: RequestErrorCode,
    id: u16,
    good_id: u16,
) {
    let answer = client.recv();
    assert_eq!((answer.id, answer.time), (id, Timestamp::ZERO));
    assert!(
        matches!(answer.response, Response::RequestError(e) if e.code == code),
        "{answer:?}"
    );
    let next = client.recv();
    assert_eq!(next.id, good_id);
    assert!(!matches!(next.response, Response::RequestError(_)));
}

#[test]
fn a_wrong_header_gets_error_code_2() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let mut bytes = header(BODY.len() as u16, 77, [0, 0, 0, 1, 0, 0, 0, 0]);
    bytes.extend_from_slice(BODY.as_bytes());
    client.send_raw(&bytes);
    // The rest of the bad frame is part of its error, not another one.
    assert_request_error_then_working(&mut client, RequestErrorCode::HeaderWrong, 77);
}

#[test]
fn an_oversized_frame_gets_error_code_3() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let len = MAX_REQUEST_LEN + 1;
    let mut bytes = header(len as u16, 78, [0; 8]);
    bytes.extend(std::iter::repeat_n(b' ', len));
    client.send_raw(&bytes);
    assert_request_error_then_working(&mut client, RequestErrorCode::LengthAbnormal, 78);
}

#[test]
fn the_longest_valid_request_is_accepted() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    // A valid body padded with whitespace to exactly the longest length accepted.
    let mut body = BODY.as_bytes().to_vec();
    body.resize(MAX_REQUEST_LEN, b' ');
    client.send_raw(&raw_frame(79, &body));
    let answer = client.recv();
    assert_eq!(answer.id, 79);
    assert!(matches!(answer.response, Response::Status(_)));
}

#[test]
fn unparseable_xml_gets_error_code_4() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    client.send_raw(&raw_frame(80, b"<PatrolDevice><Type>1002</Type><Command>1"));
    assert_request_error_then_working(&mut client, RequestErrorCode::ParseFailed, 80);
    // A required item missing is a parse failure too.
    let missing = BODY.replace("<Type>1002</Type>", "<Type>2</Type>");
    client.send_raw(&raw_frame(81, missing.as_bytes()));
    assert_request_error_then_working(&mut client, RequestErrorCode::ParseFailed, 81);
}

#[test]
fn an_unknown_type_gets_error_code_4() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    for ty in ["1234", "0", "2102"] {
        let body = BODY.replace("<Type>1002</Type>", &format!("<Type>{ty}</Type>"));
        client.send_raw(&raw_frame(82, body.as_bytes()));
        assert_request_error_then_working(&mut client, RequestErrorCode::ParseFailed, 82);
    }
}

#[test]
fn every_error_on_one_connection_in_a_row() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let mut bytes = b"junk".to_vec();
    bytes.extend(header(BODY.len() as u16, 2, [9; 8]));
    bytes.extend_from_slice(BODY.as_bytes());
    bytes.extend(raw_frame(3, b"not xml"));
    bytes.extend(frame_bytes(4, &Request::Perception));
    // One read may carry all of it; the answers come in order.
    client.send_raw(&bytes);
    let codes: Vec<_> = (0..3)
        .map(|_| {
            let answer = client.recv();
            match answer.response {
                Response::RequestError(e) => (answer.id, e.code),
                other => panic!("{other:?}"),
            }
        })
        .collect();
    assert_eq!(
        codes,
        [
            (0, RequestErrorCode::HeaderMissing),
            (2, RequestErrorCode::HeaderWrong),
            (3, RequestErrorCode::ParseFailed),
        ]
    );
    let answer = client.recv();
    assert_eq!(answer.id, 4);
    assert!(matches!(answer.response, Response::Perception(_)));
}

/// A bare XML document, no header at all and no frame after it: answered after a short
/// quiet time, once, and the connection goes on working.
#[test]
fn a_bare_xml_document_gets_error_code_1_without_a_frame_after_it() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    client.send_raw(BODY.as_bytes());
    // The helper's good request also shows no second Type 0 comes for the same bytes.
    assert_request_error_then_working(&mut client, RequestErrorCode::HeaderMissing, 0);
    let log = sim.requests();
    assert_eq!(log.len(), 2, "{log:?}");
    assert_eq!(log[0].id, None);
    let error = log[0].error.as_deref().unwrap_or_default();
    assert!(
        error.contains(&format!("skipped: {}", BODY.len())),
        "{error}"
    );
}

/// Random bytes (without `EB`, so without a sync sequence or a piece of one) are a chunk
/// without a header too, and a valid request after them on the same connection is answered.
#[test]
fn random_bytes_get_error_code_1_and_the_connection_stays_usable() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let mut seed: u32 = 0x2545_F491;
    let noise: Vec<u8> = (0..300)
        .map(|_| {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            match (seed >> 24) as u8 {
                0xEB => 0,
                b => b,
            }
        })
        .collect();
    client.send_raw(&noise);
    assert_request_error_then_working(&mut client, RequestErrorCode::HeaderMissing, 0);
    // Twice on the same connection: each chunk gets its own answer.
    client.send_raw(&noise[..50]);
    assert_request_error_then_working(&mut client, RequestErrorCode::HeaderMissing, 0);
}

/// Type 0 answers carry the message ID of the frame they are about whenever its header was
/// read (all 16 bits of it), and 0 for bytes without a header.
#[test]
fn type_0_answers_echo_the_offending_frames_message_id() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let mut wrong_header = header(BODY.len() as u16, 0xBEEF, [0, 0, 0, 0, 0, 0, 0, 7]);
    wrong_header.extend_from_slice(BODY.as_bytes());
    let mut oversized = header((MAX_REQUEST_LEN + 1) as u16, 0xFFFF, [0; 8]);
    oversized.extend(std::iter::repeat_n(b' ', MAX_REQUEST_LEN + 1));
    let unknown_type = BODY.replace("<Type>1002</Type>", "<Type>77</Type>");
    let cases = [
        (wrong_header, RequestErrorCode::HeaderWrong, 0xBEEF),
        (oversized, RequestErrorCode::LengthAbnormal, 0xFFFF),
        (
            raw_frame(0x8001, b"<Patrol"),
            RequestErrorCode::ParseFailed,
            0x8001,
        ),
        (
            raw_frame(0x0100, unknown_type.as_bytes()),
            RequestErrorCode::ParseFailed,
            0x0100,
        ),
        (b"no header".to_vec(), RequestErrorCode::HeaderMissing, 0),
    ];
    for (bytes, code, id) in cases {
        client.send_raw(&bytes);
        assert_request_error_then_working(&mut client, code, id);
    }
}
