//! `decode`: frames from a capture, printed decoded.
//!
//! The input is hex text (whitespace, newlines, `0x`-prefixed bytes such as `0x1` or
//! `0x01`, commas and `#` comments allowed) or the raw bytes of a TCP stream. It is run through the same decoder a
//! connection uses, so what is reported here (garbage before a sync sequence, oversize
//! frames, a truncated last frame) is exactly how x30ctl would see that stream from a
//! robot. A header whose reserved bytes are not zero is read like any other, as x30ctl and
//! the panel read answers, and reported before its frame: the robot refuses such a request.
//! Each event carries its byte offset in the input.

use std::io::Read;

use serde::Serialize;
use x30_panel::proto::codes::MessageType;
use x30_panel::proto::frame::{FrameError, HEADER_LEN, Header, HeaderError, SYNC};
use x30_panel::proto::message::{Request, Response};
use x30_panel::proto::xml::{Envelope, StructureError, read_document};

use crate::Ctx;
use crate::cli::{DecodeArgs, InputFormat};
use crate::conn::{self, MAX_FRAME_LEN};
use crate::error::Error;
use crate::render::{self, AnswerJson, RequestJson, emit};

/// Longest body a frame may have to be handed out whole.
const MAX_BODY: usize = MAX_FRAME_LEN - HEADER_LEN;

/// Something found in the input.
#[derive(Debug, PartialEq, Eq)]
enum Event {
    /// A whole frame.
    Frame {
        offset: usize,
        message_id: u16,
        asdu: Vec<u8>,
    },
    /// Bytes without a sync sequence.
    Garbage { offset: usize, len: usize },
    /// A header whose reserved bytes are not zero, read as if they were; its frame (or
    /// oversize report) follows.
    Reserved { offset: usize, message_id: u16 },
    /// A frame longer than the decoder accepts; skipped.
    Oversize {
        offset: usize,
        message_id: u16,
        asdu_len: u16,
        /// Whether the input ended before the frame did.
        cut: bool,
    },
    /// A frame that ended before its declared length: the next frame's sync sequence came
    /// first. Skipped.
    CutShort {
        offset: usize,
        message_id: u16,
        asdu_len: u16,
        /// Bytes of its body that came.
        received: u16,
    },
    /// The input ended inside a frame.
    Truncated {
        offset: usize,
        /// The declared body length, if the header is complete.
        asdu_len: Option<u16>,
        /// Bytes of the frame present.
        present: usize,
    },
}

/// Runs `decode`.
pub fn run(ctx: &Ctx, args: &DecodeArgs) -> Result<(), Error> {
    let input = read_input(args)?;
    let bytes = match args.format {
        InputFormat::Raw => input,
        InputFormat::Hex => parse_hex(&input).map_err(Error::Usage)?,
        InputFormat::Auto if looks_like_hex(&input) => parse_hex(&input).map_err(Error::Usage)?,
        InputFormat::Auto => input,
    };
    let events = scan(&bytes);
    let mut frames = 0;
    for event in &events {
        if matches!(event, Event::Frame { .. }) {
            frames += 1;
        }
        if ctx.json {
            emit(&event_json(event, frames, args.xml));
        } else {
            emit(&event_text(event, frames, args.xml));
        }
    }
    if !ctx.json {
        emit(&summary(&events, bytes.len()));
    }
    Ok(())
}

fn read_input(args: &DecodeArgs) -> Result<Vec<u8>, Error> {
    let mut input = Vec::new();
    match &args.file {
        Some(path) if path.as_os_str() != "-" => {
            input = std::fs::read(path).map_err(|e| {
                Error::Usage(format!(
                    "decode: cannot read {}: {}",
                    path.display(),
                    crate::error::io_text(&e)
                ))
            })?;
        }
        _ => {
            std::io::stdin().read_to_end(&mut input).map_err(|e| {
                Error::Usage(format!(
                    "decode: cannot read standard input: {}",
                    crate::error::io_text(&e)
                ))
            })?;
        }
    }
    Ok(input)
}

/// The input without `#` comments (to the end of their line).
fn strip_comments(text: &str) -> impl Iterator<Item = &str> {
    text.lines()
        .map(|line| line.split_once('#').map_or(line, |(code, _)| code))
}

/// Whether the input is hex text: UTF-8 holding only hex digits, whitespace, `0x`
/// prefixes, commas and comments. A raw capture starts with the sync byte 0xEB, which is
/// not ASCII, so it is never taken for hex.
fn looks_like_hex(input: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(input) else {
        return false;
    };
    let mut any = false;
    for c in strip_comments(text).flat_map(str::chars) {
        if c.is_ascii_hexdigit() {
            any = true;
        } else if !(c.is_whitespace() || c == 'x' || c == 'X' || c == ',') {
            return false;
        }
    }
    any
}

/// Parses hex text into bytes.
fn parse_hex(input: &[u8]) -> Result<Vec<u8>, String> {
    let text =
        std::str::from_utf8(input).map_err(|_| "decode: the hex input is not text".to_owned())?;
    let mut digits = Vec::new();
    for (number, line) in strip_comments(text).enumerate() {
        for token in line.split(|c: char| c.is_whitespace() || c == ',') {
            let prefixed = token
                .strip_prefix("0x")
                .or_else(|| token.strip_prefix("0X"));
            // A `0x` token is one byte, and may be written with one digit (`0x1`, as
            // Python's `hex` writes it): padded, not run into the next token's digits.
            match prefixed.map(str::len) {
                Some(1) => digits.push(0),
                Some(2) => {}
                Some(_) => {
                    return Err(format!(
                        "decode: line {}: {token:?} is not one byte (0x and one or two hex digits)",
                        number + 1
                    ));
                }
                None => {}
            }
            for c in prefixed.unwrap_or(token).chars() {
                let digit = c.to_digit(16).ok_or_else(|| {
                    format!("decode: line {}: {c:?} is not a hex digit", number + 1)
                })?;
                // to_digit(16) is below 16, so it fits a byte.
                digits.push(u8::try_from(digit).unwrap_or(0));
            }
        }
    }
    if digits.len() % 2 != 0 {
        return Err(format!(
            "decode: odd number of hex digits ({}): the last byte is incomplete",
            digits.len()
        ));
    }
    Ok(digits
        .chunks_exact(2)
        .map(|pair| match pair {
            [high, low] => high << 4 | low,
            _ => 0,
        })
        .collect())
}

/// Runs the bytes through a frame decoder, tracking where each event starts.
fn scan(bytes: &[u8]) -> Vec<Event> {
    let mut decoder = conn::decoder();
    let mut events = Vec::new();
    // The decoder reports every byte it consumes exactly once (in a frame, a garbage run or
    // a skipped oversize frame), in order, so adding them up gives each event's offset in
    // the input.
    let mut cursor = 0usize;
    let mut fed = 0usize;
    loop {
        while let Some(item) = decoder.decode() {
            let offset = cursor;
            let header = bytes
                .get(offset..)
                .and_then(|b| b.first_chunk::<HEADER_LEN>());
            let starts_here = match &item {
                Ok(_) | Err(FrameError::TooLong { .. }) => true,
                // An oversized frame cut short was reported (and its header looked at) before.
                Err(FrameError::CutShort { asdu_len, .. }) => usize::from(*asdu_len) <= MAX_BODY,
                Err(_) => false,
            };
            if let Some(header) = header.filter(|_| starts_here)
                && Header::decode(header) == Err(HeaderError::BadReserved)
            {
                let message_id = u16::from_le_bytes([header[6], header[7]]);
                events.push(Event::Reserved { offset, message_id });
            }
            match item {
                Ok(frame) => {
                    cursor += HEADER_LEN + frame.asdu.len();
                    events.push(Event::Frame {
                        offset,
                        message_id: frame.message_id,
                        asdu: frame.asdu.to_vec(),
                    });
                }
                Err(FrameError::Garbage { skipped }) => {
                    cursor += skipped;
                    events.push(Event::Garbage {
                        offset,
                        len: skipped,
                    });
                }
                Err(FrameError::TooLong {
                    message_id,
                    asdu_len,
                }) => {
                    cursor += HEADER_LEN + usize::from(asdu_len);
                    events.push(Event::Oversize {
                        offset,
                        message_id,
                        asdu_len,
                        cut: cursor > bytes.len(),
                    });
                }
                Err(FrameError::CutShort {
                    message_id,
                    asdu_len,
                    received,
                }) => {
                    // An oversized frame was counted whole when it was reported: it starts
                    // where that report does, and the input did not end inside it.
                    let offset = match events.last_mut() {
                        Some(Event::Oversize {
                            offset: start, cut, ..
                        }) if usize::from(asdu_len) > MAX_BODY => {
                            *cut = false;
                            *start
                        }
                        _ => offset,
                    };
                    cursor = offset + HEADER_LEN + usize::from(received);
                    events.push(Event::CutShort {
                        offset,
                        message_id,
                        asdu_len,
                        received,
                    });
                }
                Err(_) => {}
            }
        }
        let rest = bytes.get(fed..).unwrap_or_default();
        if rest.is_empty() {
            break;
        }
        let taken = decoder.feed(rest);
        if taken == 0 {
            break;
        }
        fed += taken;
    }
    // What the decoder still holds: garbage it has not reported yet, and/or the start of
    // a frame that never completed.
    if let Some(rest) = bytes.get(cursor..).filter(|rest| !rest.is_empty()) {
        let sync_at = rest.windows(SYNC.len()).position(|w| w == SYNC);
        let garbage = sync_at.unwrap_or(rest.len());
        if garbage > 0 {
            events.push(Event::Garbage {
                offset: cursor,
                len: garbage,
            });
        }
        if let Some(at) = sync_at {
            let frame = rest.get(at..).unwrap_or_default();
            let asdu_len = match frame {
                [_, _, _, _, low, high, ..] if frame.len() >= HEADER_LEN => {
                    Some(u16::from_le_bytes([*low, *high]))
                }
                _ => None,
            };
            events.push(Event::Truncated {
                offset: cursor + at,
                asdu_len,
                present: frame.len(),
            });
        }
    }
    events
}

/// A frame's body, decoded every way that works.
struct Body {
    envelope: Result<Envelope, StructureError>,
    request: Option<Request>,
    response: Option<(x30_panel::proto::time::Timestamp, Response)>,
    /// Why neither decoding worked.
    error: Option<String>,
}

fn decode_body(asdu: &[u8]) -> Body {
    // How many items the document holds, to tell an itemless request from an answer; an
    // item whose XML is wrong is the document's error.
    let mut items = 0usize;
    let envelope = read_document(asdu, |_, block| {
        for item in block {
            item?;
            items += 1;
        }
        Ok::<(), StructureError>(())
    })
    .map(|(e, _)| e);
    let request = Request::decode(asdu);
    let response = Response::decode(asdu);
    // A request without items (1002, 2001, ...) also "decodes" from its answer, whose
    // items it ignores; showing it would suggest the frame was sent by a client.
    let itemless = |r: &Request| {
        matches!(
            r,
            Request::Status
                | Request::CancelNav
                | Request::NavStatus
                | Request::MotorTemperatures
                | Request::Battery
                | Request::Perception
        )
    };
    let error = match (&request, &response) {
        (Err(req), Err(resp)) => {
            let req = req.to_string();
            let resp = resp.to_string();
            Some(if req == resp {
                req
            } else {
                format!("not a valid request ({req}), nor a valid response ({resp})")
            })
        }
        _ => None,
    };
    // An itemless request also reads from its answer, and an answer whose items are all
    // optional (1008) from its request, every item left out: the items decide which the
    // frame is.
    let (request, response) = match (
        request.ok().map(|d| d.message),
        response.ok().map(|d| (d.time, d.message)),
    ) {
        (Some(request), Some(_)) if itemless(&request) && items == 0 => (Some(request), None),
        (Some(request), Some(response)) if itemless(&request) => (None, Some(response)),
        both => both,
    };
    Body {
        envelope,
        request,
        response,
        error,
    }
}

fn xml_text(asdu: &[u8]) -> String {
    String::from_utf8_lossy(asdu).into_owned()
}

fn indent(text: &str, by: &str) -> String {
    text.lines()
        .map(|line| format!("{by}{line}"))
        .collect::<Vec<_>>()
        .join("\n")
}

fn event_text(event: &Event, index: usize, xml: bool) -> String {
    match event {
        Event::Frame {
            offset,
            message_id,
            asdu,
        } => {
            let body = decode_body(asdu);
            let mut text = format!(
                "frame {index} at byte {offset}: message ID {message_id}, {}-byte body",
                asdu.len()
            );
            match &body.envelope {
                Ok(e) => {
                    let ty = MessageType::from_raw(e.message_type);
                    text.push_str(&format!(
                        "\n  Type {} ({}), Command {}, Time {}",
                        e.message_type,
                        if ty.is_known() {
                            ty.description()
                        } else {
                            "not a Type of protocol V1.0.12"
                        },
                        e.command,
                        render::time_text(&e.time)
                    ));
                }
                Err(_) => text.push_str("\n  no readable envelope"),
            }
            if let Some(request) = &body.request {
                text.push_str(&format!(
                    "\n  as request:\n{}",
                    indent(&render::request_text(request), "    ")
                ));
            }
            if let Some((_, response)) = &body.response {
                text.push_str(&format!(
                    "\n  as response:\n{}",
                    indent(&render::response_text(response), "    ")
                ));
            }
            if let Some(error) = &body.error {
                text.push_str(&format!("\n  undecodable: {error}"));
            }
            if xml || body.error.is_some() {
                text.push_str(&format!("\n  body:\n{}", indent(&xml_text(asdu), "    | ")));
            }
            text
        }
        Event::Garbage { offset, len } => format!(
            "garbage at byte {offset}: {len} byte{} without a sync sequence, skipped",
            if *len == 1 { "" } else { "s" }
        ),
        Event::Reserved { offset, message_id } => format!(
            "header at byte {offset}: reserved bytes not zero (message ID {message_id}); read as zero, as x30ctl and the panel read answers (the robot refuses such a request: ErrorCode 2)"
        ),
        Event::Oversize {
            offset,
            message_id,
            asdu_len,
            cut,
        } => format!(
            "oversize frame at byte {offset}: message ID {message_id}, {asdu_len}-byte body, over the {MAX_BODY}-byte limit; skipped{}",
            if *cut {
                " (the input ends inside it)"
            } else {
                ""
            }
        ),
        Event::CutShort {
            offset,
            message_id,
            asdu_len,
            received,
        } => format!(
            "frame cut short at byte {offset}: message ID {message_id}, the header declares a {asdu_len}-byte body, but the next frame starts after {received} bytes of it; skipped"
        ),
        Event::Truncated {
            offset,
            asdu_len: Some(len),
            present,
        } => format!(
            "truncated frame at byte {offset}: the header declares a {len}-byte body, the input ends after {present} of {} bytes",
            HEADER_LEN + usize::from(*len)
        ),
        Event::Truncated {
            offset, present, ..
        } => format!(
            "truncated frame at byte {offset}: the input ends inside the header ({present} of {HEADER_LEN} bytes)"
        ),
    }
}

fn summary(events: &[Event], total: usize) -> String {
    let count = |f: fn(&Event) -> bool| events.iter().filter(|e| f(e)).count();
    let frames = count(|e| matches!(e, Event::Frame { .. }));
    let garbage: usize = events
        .iter()
        .map(|e| match e {
            Event::Garbage { len, .. } => *len,
            _ => 0,
        })
        .sum();
    format!(
        "{total} bytes: {frames} frame(s), {} garbage run(s) ({garbage} bytes), {} header(s) with reserved bytes set, {} oversize frame(s), {} frame(s) cut short, {} truncated frame(s)",
        count(|e| matches!(e, Event::Garbage { .. })),
        count(|e| matches!(e, Event::Reserved { .. })),
        count(|e| matches!(e, Event::Oversize { .. })),
        count(|e| matches!(e, Event::CutShort { .. })),
        count(|e| matches!(e, Event::Truncated { .. })),
    )
}

/// One event as JSON.
#[derive(Serialize)]
struct EventJson<'a> {
    event: &'static str,
    offset: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    index: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    message_id: Option<u16>,
    #[serde(skip_serializing_if = "Option::is_none")]
    asdu_len: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    len: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    present: Option<usize>,
    #[serde(rename = "type", skip_serializing_if = "Option::is_none")]
    message_type: Option<i32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    command: Option<i32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    request: Option<RequestJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    response: Option<AnswerJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    xml: Option<String>,
}

impl EventJson<'_> {
    fn new(event: &'static str, offset: usize) -> Self {
        Self {
            event,
            offset,
            index: None,
            message_id: None,
            asdu_len: None,
            len: None,
            present: None,
            message_type: None,
            command: None,
            request: None,
            response: None,
            error: None,
            xml: None,
        }
    }
}

/// One event as a JSON line.
fn event_json(event: &Event, index: usize, xml: bool) -> String {
    let line = |json: EventJson<'_>| render::json_line(&json);
    match event {
        Event::Frame {
            offset,
            message_id,
            asdu,
        } => {
            let body = decode_body(asdu);
            let envelope = body.envelope.ok();
            line(EventJson {
                index: Some(index),
                message_id: Some(*message_id),
                asdu_len: Some(asdu.len()),
                message_type: envelope.map(|e| e.message_type),
                command: envelope.map(|e| e.command),
                request: body.request.as_ref().map(render::request_json),
                response: body
                    .response
                    .as_ref()
                    .map(|(time, r)| render::answer_json(*message_id, time, r)),
                xml: (xml || body.error.is_some()).then(|| xml_text(asdu)),
                error: body.error,
                ..EventJson::new("frame", *offset)
            })
        }
        Event::Garbage { offset, len } => line(EventJson {
            len: Some(*len),
            ..EventJson::new("garbage", *offset)
        }),
        Event::Reserved { offset, message_id } => line(EventJson {
            message_id: Some(*message_id),
            ..EventJson::new("reserved", *offset)
        }),
        Event::Oversize {
            offset,
            message_id,
            asdu_len,
            cut,
        } => line(EventJson {
            message_id: Some(*message_id),
            asdu_len: Some(usize::from(*asdu_len)),
            error: cut.then(|| "the input ends inside the frame".to_owned()),
            ..EventJson::new("oversize", *offset)
        }),
        Event::CutShort {
            offset,
            message_id,
            asdu_len,
            received,
        } => line(EventJson {
            message_id: Some(*message_id),
            asdu_len: Some(usize::from(*asdu_len)),
            present: Some(HEADER_LEN + usize::from(*received)),
            ..EventJson::new("cut_short", *offset)
        }),
        Event::Truncated {
            offset,
            asdu_len,
            present,
        } => line(EventJson {
            asdu_len: asdu_len.map(usize::from),
            present: Some(*present),
            ..EventJson::new("truncated", *offset)
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use x30_panel::proto::frame;

    fn frame_bytes(id: u16, body: &[u8]) -> Vec<u8> {
        let mut out = vec![0; HEADER_LEN + body.len()];
        let len = frame::encode(&mut out, id, body).unwrap_or(0);
        out.truncate(len);
        out
    }

    #[test]
    fn an_itemless_frame_is_the_request_and_a_bad_item_leaves_no_envelope() {
        let document = |items: &str| {
            format!(
                "<PatrolDevice><Type>1008</Type><Command>1</Command>\
                 <Time>2024-01-01 00:00:00</Time><Items>{items}</Items></PatrolDevice>"
            )
        };
        // Every 1008 item is optional, so the request also reads as an answer.
        let poll = decode_body(document("").as_bytes());
        assert_eq!(poll.request, Some(Request::MotorTemperatures));
        assert!(poll.response.is_none());
        let answer = decode_body(document("<LeftFrontSway>30.5</LeftFrontSway>").as_bytes());
        assert!(answer.request.is_none());
        assert!(matches!(
            answer.response,
            Some((_, Response::MotorTemperatures(m))) if m.left_front_sway == 30.5
        ));
        for bad in [
            "<LeftFrontSway>30.5</Other>",
            "<LeftFrontSway>3&bogus;</LeftFrontSway>",
            "<LeftFrontSway><![CDATA[1]]></LeftFrontSway>",
            "<LeftFrontSway>30.5</LeftFrontSway><!DOCTYPE x>",
        ] {
            let broken = decode_body(document(bad).as_bytes());
            assert!(broken.envelope.is_err(), "{bad}");
            assert!(broken.error.is_some(), "{bad}");
        }
    }

    #[test]
    fn hex_is_detected_and_parsed() {
        assert!(looks_like_hex(
            b"eb 90 EB90\n0x01, 0x02 # comment with words\n"
        ));
        assert!(!looks_like_hex(&[0xEB, 0x90, 0xEB, 0x90]));
        assert!(!looks_like_hex(b"hello"));
        assert_eq!(
            parse_hex(b"eb 90 EB90\n0x01, 0x02 # c\n"),
            Ok(vec![0xEB, 0x90, 0xEB, 0x90, 1, 2])
        );
        // One digit after 0x is one byte, not half of one run into the next token's.
        assert_eq!(
            parse_hex(b"0xeb, 0x90, 0x1, 0x0, 0xA"),
            Ok(vec![0xEB, 0x90, 1, 0, 0xA])
        );
        assert!(parse_hex(b"0x").is_err(), "a prefix without its byte");
        assert!(
            parse_hex(b"0xeb90").is_err_and(|e| e.contains("is not one byte")),
            "{:?}",
            parse_hex(b"0xeb90")
        );
        assert!(parse_hex(b"abc").is_err());
    }

    #[test]
    fn scan_reports_offsets_of_every_event() {
        let body = b"<PatrolDevice><Type>1002</Type><Command>1</Command><Items/></PatrolDevice>";
        let first = frame_bytes(1, body);
        let mut input = b"junk".to_vec();
        input.extend_from_slice(&first);
        let mut oversize = frame_bytes(2, b"");
        oversize[4..6].copy_from_slice(&u16::try_from(MAX_BODY + 1).unwrap_or(0).to_le_bytes());
        oversize.resize(HEADER_LEN + MAX_BODY + 1, b'x');
        input.extend_from_slice(&oversize);
        let second_at = input.len();
        input.extend_from_slice(&frame_bytes(3, body));
        let cut_at = input.len();
        input.extend_from_slice(&frame_bytes(4, body)[..20]);
        let events = scan(&input);
        assert_eq!(events.len(), 5, "{events:?}");
        assert_eq!(events[0], Event::Garbage { offset: 0, len: 4 });
        assert!(matches!(
            events[1],
            Event::Frame {
                offset: 4,
                message_id: 1,
                ..
            }
        ));
        assert!(matches!(
            events[2],
            Event::Oversize {
                message_id: 2,
                cut: false,
                ..
            }
        ));
        assert!(
            matches!(events[3], Event::Frame { offset, message_id: 3, .. } if offset == second_at)
        );
        assert!(
            matches!(events[4], Event::Truncated { offset, present: 20, .. } if offset == cut_at)
        );
    }

    /// Frames cut short by the next one, one that fits and one too long for the limit, are
    /// reported where they start, with what came of them, and the frames after them keep
    /// their offsets.
    #[test]
    fn scan_reports_frames_cut_short() {
        let body = b"<PatrolDevice><Type>1002</Type><Command>1</Command><Items/></PatrolDevice>";
        let mut input = frame_bytes(1, body);
        input.truncate(HEADER_LEN + 30);
        let second_at = input.len();
        let mut oversize = frame_bytes(2, b"");
        let declared = u16::try_from(MAX_BODY + 100).unwrap_or(0);
        oversize[4..6].copy_from_slice(&declared.to_le_bytes());
        oversize.resize(HEADER_LEN + 50, b'x');
        input.extend_from_slice(&oversize);
        let third_at = input.len();
        input.extend_from_slice(&frame_bytes(3, body));
        let events = scan(&input);
        assert_eq!(
            events,
            [
                Event::CutShort {
                    offset: 0,
                    message_id: 1,
                    asdu_len: u16::try_from(body.len()).unwrap_or(0),
                    received: 30,
                },
                Event::Oversize {
                    offset: second_at,
                    message_id: 2,
                    asdu_len: declared,
                    cut: false,
                },
                Event::CutShort {
                    offset: second_at,
                    message_id: 2,
                    asdu_len: declared,
                    received: 50,
                },
                Event::Frame {
                    offset: third_at,
                    message_id: 3,
                    asdu: body.to_vec(),
                },
            ]
        );
    }
}
