//! What the client logs: a few lines when a robot pushes junk, not one per frame, and a
//! connection given up on told apart from one that failed to open (when the next attempt
//! comes, the application logs: `app_log.rs`). In a test binary of its own, because the
//! logger it counts with is process-wide.

mod common;
#[path = "common/peer.rs"]
mod peer;
#[path = "common/warnings.rs"]
mod warnings;

use common::TokioTransport;
use embassy_time::Duration;
use peer::{answer, read_request};
use std::io::Write as _;
use std::net::TcpListener;
use std::thread;
use warnings::{record_warnings, warnings_with};
use x30_panel::client::{Backoff, Connection};
use x30_panel::proto::codes::ObsState;
use x30_panel::proto::frame::FrameDecoder;
use x30_panel::proto::message::{Perception, Response};

/// How many pushed frames, and pieces of garbage, come before the answer.
const JUNK: u16 = 100;

#[tokio::test]
async fn a_robot_pushing_junk_gets_a_log_line_per_power_of_two_not_per_frame() {
    record_warnings();
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let perception = Response::Perception(Perception {
        obs_state: ObsState::Clear,
    });
    thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        let mut d = FrameDecoder::new();
        let (id, _) = read_request(&mut s, &mut d).unwrap();
        // Frames for messages never asked, each followed by garbage, then the answer.
        let mut bytes = Vec::new();
        for n in 1..=JUNK {
            bytes.extend(answer(id.wrapping_add(n), &perception));
            bytes.extend_from_slice(b"junk");
        }
        bytes.extend(answer(id, &perception));
        s.write_all(&bytes).unwrap();
        thread::sleep(std::time::Duration::from_millis(500));
    });
    let backoff = Backoff::new(Duration::from_millis(10), Duration::from_millis(100));
    let mut link = Connection::new(TokioTransport::new(addr), backoff);
    link.connect().await.expect("the peer accepts");
    link.perception(Duration::from_secs(2)).await.unwrap();

    let anomalies = link.anomalies();
    assert_eq!(anomalies.unsolicited, u32::from(JUNK));
    assert_eq!(anomalies.stream_errors, u32::from(JUNK));
    // The 1st, 2nd, 4th, ... 64th of each kind: 7 of 100.
    let frames = warnings_with("skipped a frame");
    assert_eq!(frames.len(), 7, "{frames:#?}");
    let bytes = warnings_with("skipped bytes");
    assert_eq!(bytes.len(), 7, "{bytes:#?}");
    assert!(
        frames.iter().any(|w| w.contains("(64 so far)")),
        "{frames:#?}"
    );
}

#[tokio::test]
async fn a_connection_given_up_on_is_not_logged_as_a_failed_connect() {
    record_warnings();
    // The kernel completes the connection; nobody answers on it.
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let backoff = Backoff::new(Duration::from_millis(10), Duration::from_millis(100));
    let mut link = Connection::new(TokioTransport::new(addr), backoff);
    link.connect()
        .await
        .expect("the listener's backlog takes the connection");
    let retry_in = link.give_up().await;
    assert_eq!(
        retry_in,
        Duration::from_millis(10),
        "the backoff's first delay"
    );
    assert_eq!(warnings_with("connection failed"), Vec::<String>::new());

    // With nothing listening, opening the next connection fails, and says why.
    drop(listener);
    let retry_in = link.connect().await.expect_err("nothing listens");
    assert_eq!(
        retry_in,
        Duration::from_millis(20),
        "the backoff's next delay"
    );
    let failed = warnings_with("connection failed");
    assert_eq!(failed.len(), 1, "{failed:#?}");
    assert!(failed[0].starts_with("connection failed ("), "{failed:#?}");
}
