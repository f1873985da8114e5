//! The client against a scripted peer on loopback: message-ID matching, Type 0 answers,
//! unsolicited frames, timeouts, closed connections, the learned clock.

mod common;

use common::TokioTransport;
use embassy_time::{Duration, Instant};
use std::io::{Read as _, Write as _};
use std::net::{TcpListener, TcpStream};
use std::thread;
use x30_panel::client::{Backoff, ClientError, Link};
use x30_panel::proto::codes::*;
use x30_panel::proto::frame::{self, FrameDecoder};
use x30_panel::proto::message::*;
use x30_panel::proto::time::Timestamp;

const TIMEOUT: Duration = Duration::from_millis(2000);
const ROBOT_TIME: Timestamp = Timestamp {
    year: 2024,
    month: 6,
    day: 1,
    hour: 12,
    minute: 0,
    second: 0,
};

fn backoff() -> Backoff {
    Backoff::new(Duration::from_millis(10), Duration::from_millis(100))
}

/// A frame holding `response` for message `id`.
fn answer(id: u16, response: &Response) -> Vec<u8> {
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

/// Reads one request frame from a peer socket: its ID and decoded request.
fn read_request(
    stream: &mut TcpStream,
    decoder: &mut FrameDecoder<8192>,
) -> Option<(u16, Request)> {
    stream
        .set_read_timeout(Some(std::time::Duration::from_secs(5)))
        .ok()?;
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

/// A peer that accepts one connection and runs `script` on it.
fn peer(script: impl FnOnce(TcpStream) + Send + 'static) -> std::net::SocketAddr {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    thread::spawn(move || {
        if let Ok((stream, _)) = listener.accept() {
            script(stream);
        }
    });
    addr
}

fn perception() -> Response {
    Response::Perception(Perception {
        obs_state: ObsState::ObstacleAhead,
    })
}

async fn connected(addr: std::net::SocketAddr) -> Link<TokioTransport> {
    let mut link = Link::new(TokioTransport::new(addr), backoff());
    link.connect().await.expect("the peer accepts");
    link
}

#[tokio::test]
async fn answer_is_matched_by_message_id_and_other_frames_are_skipped() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (id, request) = read_request(&mut s, &mut d).unwrap();
        assert_eq!(request, Request::Perception);
        // A late answer to an older message, garbage, then the answer, all in one write.
        let mut bytes = answer(id.wrapping_sub(1), &perception());
        bytes.extend_from_slice(b"junk");
        bytes.extend(answer(id, &perception()));
        s.write_all(&bytes).unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    let p = link.perception(TIMEOUT).await.unwrap();
    assert_eq!(p.obs_state, ObsState::ObstacleAhead);
    let anomalies = link.anomalies();
    assert_eq!(anomalies.unsolicited, 1);
    assert_eq!(anomalies.stream_errors, 1);
}

#[tokio::test]
async fn message_ids_count_up_per_request() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        for expected in 0..3u16 {
            let (id, _) = read_request(&mut s, &mut d).unwrap();
            assert_eq!(id, expected);
            s.write_all(&answer(id, &perception())).unwrap();
        }
    });
    let mut link = connected(addr).await;
    for _ in 0..3 {
        link.perception(TIMEOUT).await.unwrap();
    }
}

#[tokio::test]
async fn type_0_answer_is_an_error_and_the_connection_stays_usable() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (id, _) = read_request(&mut s, &mut d).unwrap();
        let error = Response::RequestError(RequestError {
            code: RequestErrorCode::ParseFailed,
        });
        s.write_all(&answer(id, &error)).unwrap();
        let (id, _) = read_request(&mut s, &mut d).unwrap();
        s.write_all(&answer(id, &perception())).unwrap();
    });
    let mut link = connected(addr).await;
    let err = link.perception(TIMEOUT).await.unwrap_err();
    assert_eq!(
        err,
        ClientError::RequestError(RequestErrorCode::ParseFailed)
    );
    assert!(err.connection_usable());
    assert!(link.is_connected());
    assert!(link.perception(TIMEOUT).await.is_ok());
}

#[tokio::test]
async fn unknown_type_is_reported_without_desynchronising() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (id, _) = read_request(&mut s, &mut d).unwrap();
        let body = b"<PatrolDevice><Type>2102</Type><Command>1</Command><Time>2024-06-01 12:00:00</Time><Items><Lat>1</Lat></Items></PatrolDevice>";
        let mut out = vec![0u8; 512];
        let n = frame::encode(&mut out, id, body).unwrap();
        s.write_all(&out[..n]).unwrap();
        let (id, _) = read_request(&mut s, &mut d).unwrap();
        s.write_all(&answer(id, &perception())).unwrap();
    });
    let mut link = connected(addr).await;
    assert_eq!(
        link.perception(TIMEOUT).await,
        Err(ClientError::UnknownType(2102))
    );
    assert!(link.perception(TIMEOUT).await.is_ok());
}

#[tokio::test]
async fn timeout_keeps_the_connection_and_the_late_answer_is_skipped() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (first, _) = read_request(&mut s, &mut d).unwrap();
        let (second, _) = read_request(&mut s, &mut d).unwrap();
        // The first answer comes too late, right before the second.
        s.write_all(&answer(first, &perception())).unwrap();
        s.write_all(&answer(
            second,
            &Response::Perception(Perception {
                obs_state: ObsState::Clear,
            }),
        ))
        .unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    let err = link
        .perception(Duration::from_millis(100))
        .await
        .unwrap_err();
    assert_eq!(err, ClientError::Timeout);
    assert!(link.is_connected());
    let p = link.perception(TIMEOUT).await.unwrap();
    assert_eq!(
        p.obs_state,
        ObsState::Clear,
        "the late answer to the first request is not taken for the second"
    );
    assert_eq!(link.anomalies().unsolicited, 1);
}

#[tokio::test]
async fn closed_connection_is_reported_and_the_link_reconnects() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    thread::spawn(move || {
        // First connection: read the request and hang up without answering.
        let (mut s, _) = listener.accept().unwrap();
        let mut d = FrameDecoder::new();
        read_request(&mut s, &mut d).unwrap();
        drop(s);
        // Second connection: answer.
        let (mut s, _) = listener.accept().unwrap();
        let mut d = FrameDecoder::new();
        let (id, _) = read_request(&mut s, &mut d).unwrap();
        s.write_all(&answer(id, &perception())).unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    let err = link.perception(TIMEOUT).await.unwrap_err();
    assert!(
        matches!(err, ClientError::Closed | ClientError::Io(_)),
        "{err:?}"
    );
    assert!(!err.connection_usable());
    assert!(!link.is_connected());
    assert_eq!(
        link.perception(TIMEOUT).await,
        Err(ClientError::NotConnected)
    );
    link.connect().await.unwrap();
    assert!(link.perception(TIMEOUT).await.is_ok());
}

#[tokio::test]
async fn failed_connects_back_off_exponentially_within_bounds() {
    // A port that was just free: connections are refused.
    let addr = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let mut link = Link::new(TokioTransport::new(addr), backoff());
    let mut delays = Vec::new();
    for _ in 0..6 {
        delays.push(link.connect().await.unwrap_err().as_millis());
    }
    assert_eq!(delays, vec![10, 20, 40, 80, 100, 100]);
}

#[tokio::test]
async fn time_field_is_learned_from_answers() {
    let (tx, rx) = std::sync::mpsc::channel();
    let addr = peer(move |mut s| {
        let mut d = FrameDecoder::<8192>::new();
        let mut times = Vec::new();
        for _ in 0..2 {
            // Decode again to see the Time the client wrote.
            s.set_read_timeout(Some(std::time::Duration::from_secs(5)))
                .unwrap();
            let (id, time) = loop {
                if let Some(Ok(f)) = d.decode() {
                    let decoded = Request::decode(f.asdu).unwrap();
                    break (f.message_id, decoded.time);
                }
                let mut buf = [0u8; 1024];
                let n = s.read(&mut buf).unwrap();
                d.feed(&buf[..n]);
            };
            times.push(time);
            s.write_all(&answer(id, &perception())).unwrap();
        }
        tx.send(times).unwrap();
    });
    let mut link = connected(addr).await;
    let before = link.clock().at(Instant::now());
    link.perception(TIMEOUT).await.unwrap();
    link.perception(TIMEOUT).await.unwrap();
    let times = rx.recv().unwrap();
    assert_eq!(
        times[0], before,
        "before any answer: the document's epoch plus uptime"
    );
    assert_eq!(times[0].year, 2023);
    assert_eq!(
        (times[1].year, times[1].month, times[1].day),
        (2024, 6, 1),
        "after an answer: the robot's time"
    );
    assert!(link.clock().is_learned());
}
