//! A scripted robot's side of a connection: reading the panel's requests and writing
//! answers, on a plain blocking socket.

use std::io::Read as _;
use std::net::TcpStream;
use x30_panel::proto::frame::{self, FrameDecoder};
use x30_panel::proto::message::{Request, Response};
use x30_panel::proto::time::Timestamp;

/// The `Time` of every answer.
const ROBOT_TIME: Timestamp = Timestamp {
    year: 2024,
    month: 6,
    day: 1,
    hour: 12,
    minute: 0,
    second: 0,
};

/// A frame holding `response` for message `id`.
pub fn answer(id: u16, response: &Response) -> Vec<u8> {
    let mut out = vec![0u8; 4096];
    let n = frame::encode_with(&mut out, id, |body| {
        response
            .encode(&ROBOT_TIME, body)
            .map_err(|_| frame::EncodeError::BufferTooSmall)
    })
    .unwrap();
    out.truncate(n);
    out
}

/// Reads one request frame from a peer socket: its ID and decoded request; `None` when
/// none comes within 5 s.
pub fn read_request(
    stream: &mut TcpStream,
    decoder: &mut FrameDecoder<8192>,
) -> Option<(u16, Request)> {
    read_request_within(stream, decoder, std::time::Duration::from_secs(5))
}

/// [`read_request`], waiting up to `limit` for the request.
pub fn read_request_within(
    stream: &mut TcpStream,
    decoder: &mut FrameDecoder<8192>,
    limit: std::time::Duration,
) -> Option<(u16, Request)> {
    stream.set_read_timeout(Some(limit)).ok()?;
    loop {
        if let Some(Ok(f)) = decoder.decode() {
            return Some((f.message_id, Request::decode(f.asdu).ok()?.message));
        }
        let mut buf = [0u8; 1024];
        let n = stream.read(&mut buf).ok()?;
        if n == 0 {
            return None;
        }
        decoder.feed(&buf[..n]);
    }
}
