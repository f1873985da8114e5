//! What the client logs when a robot pushes junk: a few lines, not one per frame. In a test
//! binary of its own, because the logger it counts with is process-wide.

mod common;
#[path = "common/peer.rs"]
mod peer;

use common::TokioTransport;
use embassy_time::Duration;
use peer::{answer, read_request};
use std::io::Write as _;
use std::net::TcpListener;
use std::sync::Mutex;
use std::thread;
use x30_panel::client::{Backoff, Connection};
use x30_panel::proto::codes::ObsState;
use x30_panel::proto::frame::FrameDecoder;
use x30_panel::proto::message::{Perception, Response};

/// Every line logged at warning level or above.
static WARNINGS: Mutex<Vec<String>> = Mutex::new(Vec::new());

struct Recorder;

impl log::Log for Recorder {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::Level::Warn
    }

    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            WARNINGS.lock().unwrap().push(record.args().to_string());
        }
    }

    fn flush(&self) {}
}

static RECORDER: Recorder = Recorder;

/// How many pushed frames, and pieces of garbage, come before the answer.
const JUNK: u16 = 100;

#[tokio::test]
async fn a_robot_pushing_junk_gets_a_log_line_per_power_of_two_not_per_frame() {
    log::set_logger(&RECORDER).unwrap();
    log::set_max_level(log::LevelFilter::Warn);
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
    let warnings = WARNINGS.lock().unwrap();
    let count = |what: &str| warnings.iter().filter(|w| w.contains(what)).count();
    // The 1st, 2nd, 4th, ... 64th of each kind: 7 of 100.
    assert_eq!(count("skipped a frame"), 7, "{warnings:#?}");
    assert_eq!(count("skipped bytes"), 7, "{warnings:#?}");
    assert!(
        warnings.iter().any(|w| w.contains("(64 so far)")),
        "{warnings:#?}"
    );
}
