//! A tiny robot_server client for the tests, built on the protocol core, and helpers.
//!
//! Every read has a timeout and every loop a bound, so a broken simulator fails a test
//! instead of hanging it.
#![allow(dead_code)]

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use x30_panel::proto::codes::{NavOutcome, PointInfo};
use x30_panel::proto::frame::{self, FrameDecoder, FrameError, MessageIds};
use x30_panel::proto::message::{
    MotionAck, MotionCommand, NavPoint, NavResult, NavTask, NavTaskState, Request, Response,
    RobotStatus,
};
use x30_panel::proto::outstanding::Outstanding;
use x30_panel::proto::time::Timestamp;
use x30_sim::{Config, Simulator};

/// Longest a test waits for any one answer.
pub const TIMEOUT: Duration = Duration::from_secs(10);

/// A simulator on a free loopback port.
pub fn start(time_scale: f64) -> Simulator {
    start_with(Config {
        listen: "127.0.0.1:0".parse().unwrap(),
        time_scale,
        ..Config::default()
    })
}

/// A simulator with a custom configuration.
pub fn start_with(config: Config) -> Simulator {
    Simulator::start(config).expect("simulator starts")
}

/// One answer frame, decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct Answer {
    /// The frame's message ID.
    pub id: u16,
    /// The request it answers, by the core's answer matcher: the one with `id`, or the
    /// oldest for a Type 0 whose ID matches none; `None` if it answers none.
    pub answers: Option<u16>,
    pub time: Timestamp,
    pub response: Response,
}

/// Encodes a request into a whole frame.
pub fn frame_bytes(id: u16, request: &Request) -> Vec<u8> {
    let mut body = [0u8; 8192];
    let n = request
        .encode(&Timestamp::DOCUMENT_EPOCH, &mut body)
        .unwrap();
    raw_frame(id, &body[..n])
}

/// A frame around any body.
pub fn raw_frame(id: u16, body: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; body.len() + frame::HEADER_LEN];
    let n = frame::encode(&mut out, id, body).unwrap();
    out.truncate(n);
    out
}

/// A client connection.
pub struct Client {
    pub stream: TcpStream,
    decoder: Box<FrameDecoder<16384>>,
    ids: MessageIds,
    /// Requests sent with [`Client::send`] and not answered yet.
    outstanding: Outstanding<(), 64>,
    /// Stream errors the decoder reported while reading answers (garbage before frames).
    pub stream_errors: Vec<FrameError>,
}

impl Client {
    pub fn connect(addr: SocketAddr) -> Self {
        let stream = TcpStream::connect(addr).expect("connects");
        stream.set_nodelay(true).unwrap();
        Self {
            stream,
            decoder: Box::new(FrameDecoder::new()),
            ids: MessageIds::new(),
            outstanding: Outstanding::new(),
            stream_errors: Vec::new(),
        }
    }

    /// Sends a request with the next message ID; returns the ID.
    pub fn send(&mut self, request: &Request) -> u16 {
        let id = self.ids.next_id();
        self.send_with_id(id, request);
        self.outstanding.push(id, ());
        id
    }

    pub fn send_with_id(&mut self, id: u16, request: &Request) {
        self.send_raw(&frame_bytes(id, request));
    }

    pub fn send_raw(&mut self, bytes: &[u8]) {
        self.stream.write_all(bytes).unwrap();
        self.stream.flush().unwrap();
    }

    /// The next whole frame's message ID and body; `None` on timeout or when the connection
    /// closes.
    pub fn recv_frame_within(&mut self, timeout: Duration) -> Option<(u16, Vec<u8>)> {
        let deadline = Instant::now() + timeout;
        loop {
            while let Some(event) = self.decoder.decode() {
                match event {
                    Ok(frame) => return Some((frame.message_id, frame.asdu.to_vec())),
                    Err(e) => self.stream_errors.push(e),
                }
            }
            let left = deadline.checked_duration_since(Instant::now())?;
            self.stream
                .set_read_timeout(Some(left.max(Duration::from_millis(1))))
                .unwrap();
            match self.stream.read(self.decoder.spare()) {
                Ok(0) => return None,
                Ok(n) => self.decoder.commit(n),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return None;
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => return None,
            }
        }
    }

    /// The next answer, decoded; `None` on timeout or close.
    pub fn recv_within(&mut self, timeout: Duration) -> Option<Answer> {
        let (id, body) = self.recv_frame_within(timeout)?;
        let decoded = Response::decode(&body)
            .unwrap_or_else(|e| panic!("{e:?} decoding {}", String::from_utf8_lossy(&body)));
        let request_error = matches!(decoded.message, Response::RequestError(_));
        let answers = self
            .outstanding
            .answer(id, request_error)
            .map(|(request, ())| request);
        Some(Answer {
            id,
            answers,
            time: decoded.time,
            response: decoded.message,
        })
    }

    /// The next answer; panics after [`TIMEOUT`].
    pub fn recv(&mut self) -> Answer {
        self.recv_within(TIMEOUT).expect("an answer in time")
    }

    /// Sends a request and returns the answer carrying its ID (answers with other IDs, such
    /// as a pending task's, are not expected here and fail the test).
    pub fn request(&mut self, request: &Request) -> Response {
        let id = self.send(request);
        let answer = self.recv();
        assert_eq!(
            answer.answers,
            Some(id),
            "answer to another request: {answer:?}"
        );
        answer.response
    }

    /// One `read` of raw bytes; empty on timeout or close.
    pub fn read_once(&mut self, timeout: Duration) -> Vec<u8> {
        self.stream.set_read_timeout(Some(timeout)).unwrap();
        let mut buf = vec![0u8; 65536];
        match self.stream.read(&mut buf) {
            Ok(n) => buf[..n].to_vec(),
            Err(_) => Vec::new(),
        }
    }

    /// Whether the simulator closed the connection within `timeout` (bytes before the close
    /// are ignored).
    pub fn closed_within(&mut self, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        let mut buf = [0u8; 4096];
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            self.stream
                .set_read_timeout(Some(left.max(Duration::from_millis(1))))
                .unwrap();
            match self.stream.read(&mut buf) {
                Ok(0) => return true,
                Ok(_) => {}
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return false;
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => return true,
            }
        }
        false
    }

    pub fn status(&mut self) -> RobotStatus {
        match self.request(&Request::Status) {
            Response::Status(s) => s,
            other => panic!("{other:?}"),
        }
    }

    pub fn motion(&mut self, command: MotionCommand) -> MotionAck {
        match self.request(&Request::Motion(command)) {
            Response::Motion(code, ack) => {
                assert_eq!(code, command.code());
                ack
            }
            other => panic!("{other:?}"),
        }
    }

    pub fn nav_status(&mut self) -> NavTaskState {
        match self.request(&Request::NavStatus) {
            Response::NavStatus(s) => s,
            other => panic!("{other:?}"),
        }
    }

    /// Sends a navigation task and returns its message ID (the answer comes later).
    pub fn start_task(&mut self, points: &[NavPoint]) -> u16 {
        self.send(&task(points))
    }

    /// Waits for the answer to a navigation task.
    pub fn task_result(&mut self, id: u16, timeout: Duration) -> NavResult {
        let answer = self
            .recv_within(timeout)
            .expect("the task's answer in time");
        assert_eq!(answer.answers, Some(id));
        match answer.response {
            Response::NavResult(r) => r,
            other => panic!("{other:?}"),
        }
    }
}

/// A navigation request through `points`, one `<Items>` block each.
pub fn task(points: &[NavPoint]) -> Request {
    let mut task = NavTask::to_point(points[0]);
    for p in &points[1..] {
        task.points.push(*p).unwrap();
    }
    Request::NavTask(task)
}

/// A point with the document's defaults (normal speed, obstacle stop on, straight line).
pub fn point(value: i32, x: f32, y: f32, info: PointInfo) -> NavPoint {
    NavPoint::new(value, 1, x, y, 0.0, 0.0, info)
}

/// Waits until `condition` holds, checking every 10 ms; false if it did not within `timeout`.
pub fn wait_until(timeout: Duration, mut condition: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + timeout;
    loop {
        if condition() {
            return true;
        }
        if Instant::now() >= deadline {
            return false;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Asserts a navigation answer's outcome and reason.
pub fn assert_nav(result: &NavResult, outcome: NavOutcome, status: i32) {
    assert_eq!(result.outcome, outcome, "{result:?}");
    assert_eq!(result.status.raw(), status, "{result:?}");
}
