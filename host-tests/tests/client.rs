//! The client against a scripted peer on loopback: message-ID matching, Type 0 answers,
//! unsolicited frames, timeouts, closed connections, the learned clock.

mod common;
#[path = "common/peer.rs"]
mod peer;

use common::TokioTransport;
use embassy_time::{Duration, Instant};
use peer::{answer, read_request};
use std::io::{Read as _, Write as _};
use std::net::{TcpListener, TcpStream};
use std::thread;
use x30_panel::client::{
    ANSWER_OVERDUE, Backoff, ClientError, Connection, Health, MAX_DOUBLINGS, PROMPT_ANSWERS,
    REQUEST_TIMEOUT, SILENT_AFTER, STABLE_AFTER, Sent,
};
use x30_panel::config::RobotAddress;
use x30_panel::proto::codes::*;
use x30_panel::proto::frame::{self, FrameDecoder};
use x30_panel::proto::message::*;

const TIMEOUT: Duration = Duration::from_millis(2000);

fn backoff() -> Backoff {
    Backoff::new(Duration::from_millis(10), Duration::from_millis(100))
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

/// A half-open robot: accepts one connection, reads everything and answers nothing.
fn half_open() -> std::net::SocketAddr {
    peer(|mut s| {
        let mut d = FrameDecoder::new();
        while read_request(&mut s, &mut d).is_some() {}
    })
}

fn perception() -> Response {
    Response::Perception(Perception {
        obs_state: ObsState::ObstacleAhead,
    })
}

async fn connected(addr: std::net::SocketAddr) -> Connection<TokioTransport> {
    let mut link = Connection::new(TokioTransport::new(addr), backoff());
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

/// An empty frame carrying the request's message ID (a keep-alive that happens to share it)
/// is passed over, and the answer after it is the request's.
#[tokio::test]
async fn an_empty_frame_is_no_answer_whatever_its_message_id() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (id, _) = read_request(&mut s, &mut d).unwrap();
        let mut bytes = vec![0u8; frame::HEADER_LEN];
        frame::encode(&mut bytes, id, &[]).unwrap();
        s.write_all(&bytes).unwrap();
        thread::sleep(std::time::Duration::from_millis(50));
        s.write_all(&answer(id, &perception())).unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    let p = link
        .perception(TIMEOUT)
        .await
        .expect("the answer after the empty frame is read");
    assert_eq!(p.obs_state, ObsState::ObstacleAhead);
    let anomalies = link.anomalies();
    assert_eq!((anomalies.empty_frames, anomalies.unsolicited), (1, 0));
}

/// A frame that carries the request's message ID but not its Type is no answer to it: a
/// navigation task's wait must not end on a robot's own report that reuses the ID. The
/// answer after it is the request's.
#[tokio::test]
async fn a_frame_of_another_type_with_the_requests_id_is_no_answer() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (perception_id, _) = read_request(&mut s, &mut d).unwrap();
        let mut bytes = answer(
            perception_id,
            &Response::NavStatus(NavTaskState {
                value: 1,
                status: NavTaskStatus::Running,
                error_code: NavTaskStatus::Running,
            }),
        );
        bytes.extend(answer(perception_id, &perception()));
        s.write_all(&bytes).unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    let perception_id = link.send(&Request::Perception).await.unwrap();
    let first = link.receive().await.unwrap();
    assert_eq!(first.message_id, perception_id);
    assert_eq!(first.result, Ok(perception()));
    assert_eq!(link.anomalies().unsolicited, 1);
}

/// A motion answer with the request's message ID that names another Command (a robot that
/// fills its answers in from one template) is its answer all the same, as the robot wrote
/// it, and counted; the request is no longer outstanding.
#[tokio::test]
async fn a_motion_answer_naming_another_command_is_its_answer_all_the_same() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (stop_id, _) = read_request(&mut s, &mut d).unwrap();
        s.write_all(&answer(
            stop_id,
            &ack(MotionCommand::Move(Direction::Forward, Speed::Default)),
        ))
        .unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    let stop_id = link
        .send(&Request::Motion(MotionCommand::ZeroVelocity))
        .await
        .unwrap();
    let answer = link.receive().await.unwrap();
    assert_eq!(answer.message_id, stop_id);
    assert_eq!(
        answer.result,
        Ok(ack(MotionCommand::Move(Direction::Forward, Speed::Default)))
    );
    let anomalies = link.anomalies();
    assert_eq!((anomalies.other_command, anomalies.unsolicited), (1, 0));
    assert!(link.waiting_since().is_none(), "nothing outstanding");
}

/// A robot that wrote only part of the status answer, then the e-stop's answer: the e-stop's
/// answer is not swallowed as the rest of the broken frame, and the broken one is counted.
#[tokio::test]
async fn an_answer_cut_short_does_not_swallow_the_estops_answer() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (status_id, _) = read_request(&mut s, &mut d).unwrap();
        let (estop_id, _) = read_request(&mut s, &mut d).unwrap();
        let mut bytes = answer(status_id, &Response::Status(RobotStatus::UNAVAILABLE));
        bytes.truncate(frame::HEADER_LEN + 100);
        bytes.extend(answer(estop_id, &ack(MotionCommand::SoftEmergencyStop)));
        s.write_all(&bytes).unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    link.send(&Request::Status).await.unwrap();
    let estop_id = link
        .send(&Request::Motion(MotionCommand::SoftEmergencyStop))
        .await
        .unwrap();
    let answer = link.receive().await.unwrap();
    assert_eq!(answer.message_id, estop_id);
    assert_eq!(answer.result, Ok(ack(MotionCommand::SoftEmergencyStop)));
    assert_eq!(link.anomalies().stream_errors, 1);
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

/// A peer that answers the first request, a status poll, with the body `body`.
fn answering_a_status_with(body: Vec<u8>) -> std::net::SocketAddr {
    peer(move |mut s| {
        let mut d = FrameDecoder::new();
        let (id, request) = read_request(&mut s, &mut d).unwrap();
        assert_eq!(request, Request::Status);
        let mut out = vec![0u8; body.len() + frame::HEADER_LEN];
        let n = frame::encode(&mut out, id, &body).unwrap();
        s.write_all(&out[..n]).unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    })
}

/// A robot_server that reports many more items than the document lists, deeply indented:
/// its 3.5 KiB status still fits the answer buffer and is read.
#[tokio::test]
async fn a_status_three_times_the_usual_size_is_read() {
    let extra: String = (0..70)
        .map(|i| format!("\t\t\t\t<VendorReading{i:02}>-1234.56789</VendorReading{i:02}>\r\n"))
        .collect();
    let body = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\r\n<PatrolDevice>\r\n\t\t<Type>1002</Type>\r\n\
         \t\t<Command>1</Command>\r\n\t\t<Time>2024-06-01 12:00:00</Time>\r\n\t\t<Items>\r\n\
         {extra}\t\t\t\t<MotionState>6</MotionState>\r\n\t\t\t\t<Electricity>87</Electricity>\r\n\
         \t\t</Items>\r\n</PatrolDevice>\r\n"
    );
    assert!(body.len() > 3500, "{} bytes", body.len());
    let mut link = connected(answering_a_status_with(body.into_bytes())).await;
    let status = link
        .status(TIMEOUT)
        .await
        .expect("the large status is read");
    assert_eq!(
        (status.motion_state, status.electricity),
        (MotionState::SoftEmergencyStop, Some(87))
    );
    assert_eq!(link.anomalies().stream_errors, 0);
}

/// A status whose floats the robot wrote with a decimal comma is read, those items left
/// out, and counted among the connection's anomalies.
#[tokio::test]
async fn a_status_with_unreadable_items_is_read_and_counted() {
    let body = b"<PatrolDevice><Type>1002</Type><Command>1</Command><Time>2024-06-01 12:00:00</Time>\
        <Items><MotionState>4</MotionState><PosX>1,5</PosX><Electricity>87</Electricity></Items></PatrolDevice>";
    let mut link = connected(answering_a_status_with(body.to_vec())).await;
    let status = link.status(TIMEOUT).await.expect("the status is read");
    assert!(status.pos_x.is_nan());
    assert_eq!(status.electricity, Some(87));
    assert_eq!(link.anomalies().unreadable_items, 1);
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
    let mut link = Connection::new(TokioTransport::new(addr), backoff());
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

fn ack(command: MotionCommand) -> Response {
    Response::Motion(
        command.code(),
        MotionAck {
            value: Some(-1.0),
            result: CommandResult::Success,
        },
    )
}

#[tokio::test]
async fn requests_go_out_without_waiting_and_answers_match_in_any_order() {
    let (tx, rx) = std::sync::mpsc::channel();
    let addr = peer(move |mut s| {
        let mut d = FrameDecoder::new();
        // Both requests arrive before either is answered; the answers come in reverse.
        let first = read_request(&mut s, &mut d).unwrap();
        let second = read_request(&mut s, &mut d).unwrap();
        tx.send((first.1.clone(), second.1.clone())).unwrap();
        let mut bytes = answer(second.0, &ack(MotionCommand::ZeroVelocity));
        bytes.extend(answer(first.0, &ack(MotionCommand::SoftEmergencyStop)));
        s.write_all(&bytes).unwrap();
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    let estop = Request::Motion(MotionCommand::SoftEmergencyStop);
    let zero = Request::Motion(MotionCommand::ZeroVelocity);
    let first = link.send(&estop).await.unwrap();
    let second = link.send(&zero).await.unwrap();
    assert_eq!(link.outstanding(), 2);
    let (got_first, got_second) = rx
        .recv_timeout(std::time::Duration::from_secs(5))
        .expect("the peer read both requests before answering");
    assert_eq!((got_first, got_second), (estop, zero));
    let a = link.receive().await.unwrap();
    let b = link.receive().await.unwrap();
    assert_eq!((a.message_id, a.request.command), (second, 6));
    assert_eq!((b.message_id, b.request.command), (first, 13));
    assert!(matches!(
        a.result,
        Ok(Response::Motion(MotionCommandCode::ZeroVelocity, _))
    ));
    assert_eq!(link.outstanding(), 0);
}

#[tokio::test]
async fn type_0_with_an_unknown_message_id_answers_the_oldest_outstanding_request() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let first = read_request(&mut s, &mut d).unwrap();
        let second = read_request(&mut s, &mut d).unwrap();
        // The robot could not read a header: its Type 0 carries an ID it made up (0xBEEF).
        let error = Response::RequestError(RequestError {
            code: RequestErrorCode::HeaderMissing,
        });
        let mut bytes = answer(0xBEEF, &error);
        bytes.extend(answer(second.0, &ack(MotionCommand::ZeroVelocity)));
        s.write_all(&bytes).unwrap();
        drop(first);
        thread::sleep(std::time::Duration::from_millis(200));
    });
    let mut link = connected(addr).await;
    let first = link
        .send(&Request::Motion(MotionCommand::SoftEmergencyStop))
        .await
        .unwrap();
    let second = link
        .send(&Request::Motion(MotionCommand::ZeroVelocity))
        .await
        .unwrap();
    let a = link.receive().await.unwrap();
    assert_eq!(a.message_id, first, "Type 0 answers the oldest");
    assert_eq!(
        a.result,
        Err(ClientError::RequestError(RequestErrorCode::HeaderMissing))
    );
    let b = link.receive().await.unwrap();
    assert_eq!(b.message_id, second);
    assert!(b.result.is_ok());
    assert_eq!(link.anomalies().unsolicited, 0);
}

#[tokio::test]
async fn a_write_the_robot_never_takes_drops_the_connection_within_its_bound() {
    // The peer accepts but never reads: once both kernels' buffers are full, a write cannot
    // complete. The link must give up after WRITE_TIMEOUT and close, not hang.
    let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
    let addr = peer(move |s| {
        let _ = done_rx.recv_timeout(std::time::Duration::from_secs(20));
        drop(s);
    });
    let mut link = connected(addr).await;
    let mut outcome = Ok(0);
    // A bounded number of writes: loopback buffers hold a few MiB at most.
    for _ in 0..200_000 {
        outcome = link
            .send(&Request::Motion(MotionCommand::ZeroVelocity))
            .await;
        if outcome.is_err() {
            break;
        }
    }
    done_tx.send(()).ok();
    assert_eq!(outcome, Err(ClientError::WriteTimeout));
    assert!(!link.is_connected(), "the stalled connection is dropped");
}

#[tokio::test]
async fn a_robot_that_stops_answering_is_overdue_then_silent() {
    let addr = half_open();
    let mut link = connected(addr).await;
    let start = Instant::now();
    assert_eq!(link.health(start), Health::Answering);
    link.send(&Request::Status).await.unwrap();
    let sent = Instant::now();
    assert_eq!(link.health(sent), Health::Answering);
    assert_eq!(
        link.health(sent + ANSWER_OVERDUE),
        Health::Overdue,
        "an answer older than ANSWER_OVERDUE is overdue"
    );
    let overdue = sent + ANSWER_OVERDUE;
    assert!(
        link.health_deadline(overdue).is_some_and(|d| d > overdue),
        "once overdue, the next change is silence, not a deadline already passed (a loop \
         sleeping until it would spin)"
    );
    assert_eq!(
        link.health(sent + SILENT_AFTER),
        Health::Silent,
        "nothing received for SILENT_AFTER with a request outstanding"
    );
    // Two requests given up on in a row make it silent too, whatever the clock says.
    let later = sent + Duration::from_millis(600);
    assert!(link.expire(later, Duration::from_millis(500)).is_some());
    link.send(&Request::Status).await.unwrap();
    assert!(
        link.expire(
            Instant::now() + Duration::from_secs(1),
            Duration::from_millis(500)
        )
        .is_some()
    );
    assert_eq!(link.health(Instant::now()), Health::Silent);
}

/// Whether `sent` is an e-stop.
fn is_estop(sent: &Sent) -> bool {
    sent.message_type == MessageType::Motion && sent.command == 13
}

/// A robot answers a motion repeat after the e-stop written just behind it has reached it,
/// then hangs: the e-stop's repeat, written after that answer, is the one it never read,
/// and the e-stop before it (with an answer after it) does not hide it.
#[tokio::test]
async fn a_stop_written_after_the_last_answer_is_unread_whatever_came_before_it() {
    let (tx, rx) = std::sync::mpsc::channel();
    let addr = peer(move |mut s| {
        let mut d = FrameDecoder::new();
        let repeat = read_request(&mut s, &mut d).unwrap();
        let _estop = read_request(&mut s, &mut d).unwrap();
        let forward = MotionCommand::Move(Direction::Forward, Speed::Default);
        s.write_all(&answer(repeat.0, &ack(forward))).unwrap();
        // Hung: reads what comes (the repeat of the e-stop), answers nothing.
        let again = read_request(&mut s, &mut d);
        tx.send(again.map(|(_, request)| request)).unwrap();
        thread::sleep(std::time::Duration::from_millis(500));
    });
    let mut link = connected(addr).await;
    let forward = Request::Motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    let estop = Request::Motion(MotionCommand::SoftEmergencyStop);
    link.send(&forward).await.unwrap();
    link.send(&estop).await.unwrap();
    let answered = link.receive().await.unwrap();
    assert_eq!(answered.request.command, 1, "the repeat's answer");
    assert_eq!(
        link.unread_since(is_estop),
        None,
        "the robot sent something after the first e-stop was written"
    );
    let before = Instant::now();
    link.send(&estop).await.unwrap();
    let after = Instant::now();
    let unread = link.unread_since(is_estop);
    assert!(
        unread.is_some_and(|at| before <= at && at <= after),
        "the e-stop's repeat is unread since it was written: {unread:?}"
    );
    assert_eq!(
        rx.recv_timeout(std::time::Duration::from_secs(5)).unwrap(),
        Some(estop)
    );
}

#[tokio::test]
async fn a_request_given_up_on_still_counts_towards_silence() {
    let addr = half_open();
    let mut link = connected(addr).await;
    let before = Instant::now();
    link.send(&Request::Status).await.unwrap();
    let sent = Instant::now();
    let given_up = sent + Duration::from_millis(1500);
    assert!(link.expire(given_up, Duration::from_millis(1500)).is_some());
    assert_eq!(link.outstanding(), 0);
    assert_eq!(
        link.health(given_up),
        Health::Answering,
        "nothing outstanding to be overdue, a status says nothing of motion, and one give-up \
         is not two"
    );
    let deadline = link.health_deadline(given_up);
    assert!(
        deadline.is_some_and(|d| (before + SILENT_AFTER..=sent + SILENT_AFTER).contains(&d)),
        "the silence clock keeps running from the send after the give-up: {deadline:?}"
    );
    assert_eq!(link.health(sent + SILENT_AFTER), Health::Silent);
}

/// A robot that ignores the light's Type (as an older `robot_server` does) and answers
/// everything else.
fn ignoring_the_light() -> std::net::SocketAddr {
    peer(|mut s| {
        let mut d = FrameDecoder::new();
        while let Some((id, request)) = read_request(&mut s, &mut d) {
            if !matches!(request, Request::Light(_)) {
                s.write_all(&answer(id, &perception())).unwrap();
            }
        }
    })
}

/// The light's request: steady red.
fn red_light() -> Request {
    Request::Light(Light {
        red: 255,
        green: 0,
        blue: 0,
        effect: LightEffect::Steady,
        brightness: 50,
    })
}

#[tokio::test]
async fn a_request_the_robot_passes_over_is_not_overdue_once_a_later_one_is_answered() {
    let mut link = connected(ignoring_the_light()).await;
    let light = red_light();
    link.send(&light).await.unwrap();
    let light_sent = Instant::now();
    assert_eq!(
        link.health(light_sent + ANSWER_OVERDUE),
        Health::Overdue,
        "nothing answered since the light's request: overdue"
    );
    link.send(&Request::Perception).await.unwrap();
    let later = link.receive().await.unwrap();
    assert!(later.result.is_ok());
    assert_eq!(
        link.health(light_sent + ANSWER_OVERDUE),
        Health::Answering,
        "a request written after it was answered: the robot answers"
    );
    // A request written after that one and not answered is overdue again.
    link.send(&light).await.unwrap();
    let again = Instant::now();
    assert_eq!(link.health(again), Health::Answering);
    assert_eq!(link.health(again + ANSWER_OVERDUE), Health::Overdue);
}

/// A robot that answers everything but motion commands, and sends a keep-alive (a frame
/// with no body) every 50 ms.
fn ignoring_motion() -> std::net::SocketAddr {
    peer(|mut s| {
        let mut d = FrameDecoder::new();
        let mut keep_alive = vec![0u8; frame::HEADER_LEN];
        frame::encode(&mut keep_alive, 0, &[]).unwrap();
        let mut w = s.try_clone().unwrap();
        thread::spawn(move || {
            for _ in 0..100 {
                if w.write_all(&keep_alive).is_err() {
                    return;
                }
                thread::sleep(std::time::Duration::from_millis(50));
            }
        });
        while let Some((id, request)) = read_request(&mut s, &mut d) {
            if !matches!(request, Request::Motion(_)) {
                s.write_all(&answer(id, &perception())).unwrap();
            }
        }
    })
}

/// Reads for `ms` milliseconds whatever comes (keep-alives), answering nothing.
async fn listen(link: &mut Connection<TokioTransport>, ms: u64) {
    let _ = tokio::time::timeout(std::time::Duration::from_millis(ms), link.receive()).await;
}

#[tokio::test]
async fn a_motion_command_given_up_on_keeps_motion_held_back_until_the_robot_answers_again() {
    let mut link = connected(ignoring_motion()).await;
    link.send(&Request::Motion(MotionCommand::ZeroVelocity))
        .await
        .unwrap();
    let given_up = Instant::now() + Duration::from_millis(1500);
    assert!(link.expire(given_up, Duration::from_millis(1500)).is_some());
    assert_eq!(link.outstanding(), 0);
    assert_eq!(
        link.health(given_up),
        Health::Overdue,
        "nothing answered since the motion command given up on"
    );
    // Keep-alives are no answer: they do not hold the silence off.
    let silent_at = link.health_deadline(given_up);
    listen(&mut link, 300).await;
    assert!(link.anomalies().empty_frames > 0, "keep-alives came");
    assert_eq!(link.health_deadline(given_up), silent_at);
    link.send(&Request::Perception).await.unwrap();
    assert!(link.receive().await.unwrap().result.is_ok());
    assert_eq!(
        link.health(Instant::now()),
        Health::Answering,
        "the robot answered again"
    );
}

/// An older `robot_server` ignores the light's Type: giving that request up says nothing of
/// whether the robot acts on motion.
#[tokio::test]
async fn a_light_given_up_on_does_not_hold_motion_back() {
    let mut link = connected(ignoring_the_light()).await;
    link.send(&red_light()).await.unwrap();
    let given_up = Instant::now() + Duration::from_millis(1500);
    assert!(link.expire(given_up, Duration::from_millis(1500)).is_some());
    assert_eq!(link.health(given_up), Health::Answering);
}

#[tokio::test]
async fn giving_up_on_a_request_the_robot_passed_over_says_nothing_of_silence() {
    let mut link = connected(ignoring_the_light()).await;
    let light = red_light();
    // Two ignored requests, then one answered: neither give-up counts, though two in a
    // row that did would make the robot silent.
    link.send(&light).await.unwrap();
    link.send(&light).await.unwrap();
    link.send(&Request::Perception).await.unwrap();
    assert!(link.receive().await.unwrap().result.is_ok());
    let late = Instant::now() + Duration::from_millis(1500);
    while link.expire(late, Duration::from_millis(1500)).is_some() {}
    assert_eq!(link.outstanding(), 0);
    assert_eq!(
        link.health_deadline(late),
        None,
        "nothing outstanding, nothing to time"
    );
    assert_eq!(
        link.health(late + SILENT_AFTER),
        Health::Answering,
        "the robot answered what came after the requests it passed over"
    );
}

#[tokio::test]
async fn an_answer_clears_the_overdue_state() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        while let Some((id, _)) = read_request(&mut s, &mut d) {
            s.write_all(&answer(id, &perception())).unwrap();
        }
    });
    let mut link = connected(addr).await;
    link.send(&Request::Perception).await.unwrap();
    let answer = link.receive().await.unwrap();
    assert!(answer.result.is_ok());
    assert_eq!(
        link.health(Instant::now() + SILENT_AFTER * 2),
        Health::Answering,
        "nothing outstanding, nothing overdue"
    );
}

#[tokio::test]
async fn a_robot_that_drops_every_connection_at_once_is_retried_with_backoff() {
    // Accepts and closes at once, a few times over; no answer ever.
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    thread::spawn(move || {
        for stream in listener.incoming().take(4) {
            drop(stream);
        }
    });
    let mut link = Connection::new(TokioTransport::new(addr), backoff());
    let mut delays = Vec::new();
    for _ in 0..3 {
        link.connect().await.expect("the peer accepts");
        assert!(link.receive().await.is_err(), "the peer hangs up");
        delays.push(link.reconnect_delay(STABLE_AFTER).as_millis());
    }
    assert_eq!(
        delays,
        [10, 20, 40],
        "growing delays while nothing is answered"
    );
}

#[tokio::test]
async fn a_connection_that_answered_is_reopened_at_once_when_lost() {
    let addr = peer(|mut s| {
        let mut d = FrameDecoder::new();
        let (id, _) = read_request(&mut s, &mut d).unwrap();
        s.write_all(&answer(id, &perception())).unwrap();
        // Then hang up.
    });
    let mut link = connected(addr).await;
    link.perception(TIMEOUT).await.unwrap();
    assert!(link.receive().await.is_err(), "the peer hangs up");
    assert_eq!(
        link.reconnect_delay(Duration::from_ticks(0)).as_millis(),
        0,
        "a blip: no wait"
    );
}

#[tokio::test]
async fn a_robot_that_hangs_up_after_each_answer_waits_out_the_backoff_unless_asked_not_to() {
    // Answers the first request on each connection and hangs up: at once, except on the
    // fourth connection, which it keeps open a little longer than STABLE_AFTER.
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    thread::spawn(move || {
        for (i, stream) in listener.incoming().take(6).enumerate() {
            let Ok(mut s) = stream else { return };
            let mut d = FrameDecoder::new();
            if let Some((id, _)) = read_request(&mut s, &mut d) {
                let _ = s.write_all(&answer(id, &perception()));
            }
            if i == 3 {
                thread::sleep(std::time::Duration::from_millis(1100));
            }
        }
    });
    let mut link = Connection::new(TokioTransport::new(addr), backoff());
    let mut delays = Vec::new();
    let at_once = Duration::from_ticks(0);
    for stable in [
        STABLE_AFTER,
        STABLE_AFTER,
        STABLE_AFTER,
        STABLE_AFTER,
        STABLE_AFTER,
        at_once,
    ] {
        link.connect().await.expect("the peer accepts");
        link.perception(TIMEOUT).await.expect("answered");
        assert!(link.receive().await.is_err(), "the peer hangs up");
        delays.push(link.reconnect_delay(stable).as_millis());
    }
    assert_eq!(
        delays,
        [10, 20, 40, 0, 10, 0],
        "short connections wait out a growing backoff; a healthy one is reopened at once \
         and starts the backoff again; the command connection's rule reopens any at once"
    );
}

/// A robot that answers every request on its i-th connection `delays_ms[i]` after reading
/// it, one request at a time (the last delay on later connections), and takes at most
/// `connections` connections.
fn answering_after(delays_ms: &'static [u64], connections: usize) -> std::net::SocketAddr {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    thread::spawn(move || {
        let mut delays = delays_ms
            .iter()
            .chain(std::iter::repeat(delays_ms.last().unwrap()));
        for stream in listener.incoming().take(connections) {
            let Ok(mut s) = stream else { return };
            let mut d = FrameDecoder::new();
            let delay = std::time::Duration::from_millis(*delays.next().unwrap());
            while let Some((id, _)) = read_request(&mut s, &mut d) {
                thread::sleep(delay);
                if s.write_all(&answer(id, &perception())).is_err() {
                    break;
                }
            }
        }
    });
    addr
}

#[tokio::test]
async fn a_robot_given_up_on_as_silent_gets_twice_the_wait_until_it_answers_promptly() {
    // The first connection's answer comes after 2.5 s, past the 1.5 s wait; then a robot that
    // takes 2.5 s for every answer is read within the doubled wait, and PROMPT_ANSWERS
    // prompt answers in a row halve it again.
    let addr = answering_after(&[2500, 2500, 10], 3);
    let mut link = connected(addr).await;
    assert_eq!(link.request_timeout(), REQUEST_TIMEOUT);
    assert!(matches!(
        link.perception(link.request_timeout()).await,
        Err(ClientError::Timeout)
    ));
    assert_eq!(link.health(Instant::now() + SILENT_AFTER), Health::Silent);
    link.give_up().await;
    assert_eq!(
        link.request_timeout(),
        REQUEST_TIMEOUT * 2,
        "given up on as silent: the next connection waits twice as long"
    );

    link.connect().await.expect("the peer accepts");
    link.send(&Request::Perception).await.unwrap();
    let sent = Instant::now();
    assert_eq!(
        link.health(sent + SILENT_AFTER),
        Health::Overdue,
        "not silent at SILENT_AFTER any more (but overdue: motion stays held back)"
    );
    assert_eq!(link.health(sent + SILENT_AFTER * 2), Health::Silent);
    let late = link.receive().await.expect("the late answer");
    assert_eq!(late.result, Ok(perception()));
    assert_eq!(
        link.request_timeout(),
        REQUEST_TIMEOUT * 2,
        "an answer that needed the longer wait keeps it"
    );

    link.connect().await.expect("the peer accepts");
    for _ in 1..PROMPT_ANSWERS {
        link.perception(link.request_timeout())
            .await
            .expect("a prompt answer");
    }
    assert_eq!(
        link.request_timeout(),
        REQUEST_TIMEOUT * 2,
        "one prompt answer short of PROMPT_ANSWERS"
    );
    link.perception(link.request_timeout())
        .await
        .expect("a prompt answer");
    assert_eq!(
        link.request_timeout(),
        REQUEST_TIMEOUT,
        "PROMPT_ANSWERS answers in a row within half the wait halve it"
    );
}

#[tokio::test]
async fn the_waits_double_at_most_max_doublings_times_and_start_afresh_for_another_robot() {
    let addr = half_open();
    let mut link = connected(addr).await;
    for _ in 0..=MAX_DOUBLINGS {
        link.give_up().await;
    }
    assert_eq!(
        link.request_timeout(),
        REQUEST_TIMEOUT * (1 << MAX_DOUBLINGS)
    );
    // Another robot has not been found slow.
    link.retarget(RobotAddress {
        ip: [127, 0, 0, 1],
        port: addr.port(),
    })
    .await;
    assert_eq!(link.request_timeout(), REQUEST_TIMEOUT);
}
