//! A blocking connection to robot_server: connect, send requests, wait for their answers.
//!
//! This is where the mistakes of existing clients (SPEC §6) are avoided:
//! - bytes go through a [`FrameDecoder`], so split frames, several frames in one read and
//!   garbage before a sync sequence are all handled, and the stream resynchronises;
//! - answers are matched by message ID (from a [`MessageIds`] counter); frames with other
//!   IDs are reported on stderr and skipped, never taken for the answer;
//! - an answer of a Type this protocol version does not know is an error naming the Type,
//!   not a stall;
//! - every read has a timeout, so nothing waits forever unless the caller asks for it
//!   (the 1003 answer), and even then the caller is polled so Ctrl-C is seen.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use x30_panel::proto::codes::MessageType;
use x30_panel::proto::frame::{
    self, EncodeError, FrameDecoder, FrameError, HEADER_LEN, MessageIds,
};
use x30_panel::proto::message::{MAX_REQUEST_LEN, Request, Response};
use x30_panel::proto::time::Timestamp;
use x30_panel::proto::xml::writer::WriteError;

use crate::error::Error;
use crate::render::{self, warn};

/// The robot_server port.
pub const DEFAULT_PORT: u16 = 30000;

/// Largest frame (header and body) accepted. Answers are at most a couple of KiB (a real
/// 1002 answer with extra items is about 1 KiB); longer frames are skipped and reported
/// rather than buffered.
pub const MAX_FRAME_LEN: usize = 16 * 1024;

/// The frame decoder used for every connection and for `decode`.
pub type Decoder = FrameDecoder<MAX_FRAME_LEN>;

/// How long one read may block, so the caller's check (Ctrl-C, a moving deadline) runs
/// often enough even when no deadline is near.
const POLL: Duration = Duration::from_millis(100);

/// An answer matched to its request.
#[derive(Debug, Clone, Copy)]
pub struct Answer {
    /// The message ID the request and answer share.
    pub message_id: u16,
    /// The robot's `Time`.
    pub time: Timestamp,
    /// The answer.
    pub response: Response,
}

impl Answer {
    /// The answer as a JSON line.
    pub fn json(&self) -> String {
        render::json_line(&render::answer_json(
            self.message_id,
            &self.time,
            &self.response,
        ))
    }
}

/// A wait limit: give up at `at`, reporting that `after` has passed.
#[derive(Debug, Clone, Copy)]
pub struct Deadline {
    /// When to give up.
    pub at: Instant,
    /// The wait it stands for, for the error message.
    pub after: Duration,
}

impl Deadline {
    /// A deadline `after` from now (capped at a year, far beyond any timeout the
    /// command line allows, so the clock arithmetic cannot overflow).
    pub fn after(after: Duration) -> Self {
        let now = Instant::now();
        let year = Duration::from_secs(365 * 24 * 3600);
        Self {
            at: now
                .checked_add(after)
                .or_else(|| now.checked_add(year))
                .unwrap_or(now),
            after,
        }
    }
}

/// What a caller of [`Connection::wait`] wants after each read.
#[derive(Debug)]
pub enum Check {
    /// Go on waiting, until the deadline if there is one.
    Wait(Option<Deadline>),
    /// Stop waiting with this error.
    Abort(Error),
}

/// A connection to robot_server.
#[derive(Debug)]
pub struct Connection {
    stream: TcpStream,
    ids: MessageIds,
    decoder: Box<Decoder>,
    timeout: Duration,
    frame_buf: Vec<u8>,
    /// Message IDs of requests given up on: their late answers are expected, so they are
    /// skipped without a warning.
    abandoned: Vec<u16>,
}

/// Resolves `HOST:PORT` (or `HOST`, meaning port 30000).
pub fn resolve(robot: &str) -> Result<Vec<SocketAddr>, Error> {
    let resolved = match robot.to_socket_addrs() {
        Ok(addrs) => Ok(addrs),
        // "HOST" alone (no port): try the protocol's port. A bare IPv6 address has colons
        // and never gets here with a port missing, so it must be written [addr]:port.
        Err(_) if !robot.contains(':') => (robot, DEFAULT_PORT).to_socket_addrs(),
        Err(e) => Err(e),
    };
    let addrs: Vec<SocketAddr> = resolved
        .map_err(|source| Error::Resolve {
            addr: robot.to_owned(),
            source,
        })?
        .collect();
    if addrs.is_empty() {
        return Err(Error::Resolve {
            addr: robot.to_owned(),
            source: io::Error::new(io::ErrorKind::NotFound, "no address found"),
        });
    }
    Ok(addrs)
}

/// Frame encoding fails either in the header or in the XML body.
enum EncodeFailure {
    Frame(EncodeError),
    Body(WriteError),
}

impl From<EncodeError> for EncodeFailure {
    fn from(e: EncodeError) -> Self {
        Self::Frame(e)
    }
}

/// The current local time, for the `Time` element of requests.
pub fn local_time() -> Timestamp {
    use chrono::{Datelike, Timelike};
    let now = chrono::Local::now();
    let narrow = |v: u32| u8::try_from(v).unwrap_or(0);
    Timestamp {
        year: u16::try_from(now.year().clamp(0, 9999)).unwrap_or(0),
        month: narrow(now.month()),
        day: narrow(now.day()),
        hour: narrow(now.hour()),
        minute: narrow(now.minute()),
        // A leap second shows as 60 in chrono; the protocol's seconds stop at 59.
        second: narrow(now.second().min(59)),
    }
}

/// Encodes a whole frame (header and XML body) for a request.
pub fn encode_request(request: &Request, message_id: u16, out: &mut Vec<u8>) -> Result<(), Error> {
    out.clear();
    out.resize(HEADER_LEN + MAX_REQUEST_LEN, 0);
    let time = local_time();
    let len = frame::encode_with(out, message_id, |body| {
        request.encode(&time, body).map_err(EncodeFailure::Body)
    })
    .map_err(|e| {
        let why = match e {
            EncodeFailure::Frame(e) => format!("{e:?}"),
            EncodeFailure::Body(WriteError::NotFinite { item }) => {
                format!("{item} is not a finite number")
            }
            EncodeFailure::Body(e) => format!("{e:?}"),
        };
        Error::Usage(format!(
            "cannot encode the Type {} request: {why}",
            request.message_type().raw()
        ))
    })?;
    out.truncate(len);
    Ok(())
}

impl Connection {
    /// Connects to the robot, trying each resolved address in turn.
    ///
    /// `timeout` is the default wait for answers ([`Connection::request`]).
    pub fn connect(
        robot: &str,
        connect_timeout: Duration,
        timeout: Duration,
    ) -> Result<Self, Error> {
        let mut last = None;
        for addr in resolve(robot)? {
            match TcpStream::connect_timeout(&addr, connect_timeout) {
                Ok(stream) => {
                    // Requests are small and answered one at a time: send each at once.
                    let _ = stream.set_nodelay(true);
                    return Ok(Self {
                        stream,
                        ids: MessageIds::new(),
                        decoder: Box::default(),
                        timeout,
                        frame_buf: Vec::new(),
                        abandoned: Vec::new(),
                    });
                }
                Err(e) => last = Some(e),
            }
        }
        Err(Error::Connect {
            addr: robot.to_owned(),
            source: last.unwrap_or_else(|| io::Error::other("no address to connect to")),
            timeout: connect_timeout,
        })
    }

    /// Sends a request and waits up to the connection's timeout for its answer.
    ///
    /// A failed `ErrorCode` is still an answer (`Ok`); a Type 0 answer is an error.
    pub fn request(&mut self, request: &Request) -> Result<Answer, Error> {
        let message_id = self.send(request)?;
        let deadline = Deadline::after(self.timeout);
        self.wait(message_id, request.message_type(), |_| {
            Check::Wait(Some(deadline))
        })
    }

    /// Sends a request and waits for its answer like [`Connection::request`], but gives up
    /// with `Ok(None)` as soon as `stop` returns true (checked at least every 100 ms). The
    /// answer may still arrive later; it is then skipped quietly.
    pub fn request_unless(
        &mut self,
        request: &Request,
        stop: impl Fn() -> bool,
    ) -> Result<Option<Answer>, Error> {
        let message_id = self.send(request)?;
        let deadline = Deadline::after(self.timeout);
        let mut stopped = false;
        let result = self.wait(message_id, request.message_type(), |_| {
            if stop() {
                stopped = true;
                // Abort needs an error; it is replaced by `Ok(None)` below.
                Check::Abort(Error::Interrupted(String::new()))
            } else {
                Check::Wait(Some(deadline))
            }
        });
        match result {
            Err(_) if stopped => {
                self.abandoned.push(message_id);
                Ok(None)
            }
            other => other.map(Some),
        }
    }

    /// Sends a request without waiting; returns its message ID.
    pub fn send(&mut self, request: &Request) -> Result<u16, Error> {
        let message_id = self.ids.next_id();
        let mut buf = std::mem::take(&mut self.frame_buf);
        let result = encode_request(request, message_id, &mut buf).and_then(|()| {
            // A robot that stops reading must not block us forever either.
            let _ = self.stream.set_write_timeout(Some(self.timeout));
            self.stream.write_all(&buf).map_err(|source| {
                let message_type = request.message_type().raw();
                if is_disconnect(&source) {
                    Error::Closed {
                        message_type,
                        source: Some(source),
                    }
                } else {
                    Error::Io {
                        context: format!("sending the Type {message_type} request"),
                        source,
                    }
                }
            })
        });
        self.frame_buf = buf;
        result.map(|()| message_id)
    }

    /// Waits for the answer with `message_id` to a request of Type `message_type`.
    ///
    /// `check` runs after every read (at least every 100 ms) with the time waited so far,
    /// and says how long to go on. Frames with other message IDs and stream errors
    /// (garbage, bad headers, oversize frames) are reported on stderr and skipped.
    pub fn wait(
        &mut self,
        message_id: u16,
        message_type: MessageType,
        mut check: impl FnMut(Duration) -> Check,
    ) -> Result<Answer, Error> {
        let started = Instant::now();
        let ty = message_type.raw();
        loop {
            if let Some(answer) = self.next_answer(message_id, message_type)? {
                return Ok(answer);
            }
            let deadline = match check(started.elapsed()) {
                Check::Abort(e) => return Err(e),
                Check::Wait(deadline) => deadline,
            };
            let mut slice = POLL;
            if let Some(deadline) = deadline {
                let left = deadline.at.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    return Err(Error::Timeout {
                        waited: deadline.after,
                        message_type: ty,
                    });
                }
                slice = slice.min(left);
            }
            // A zero read timeout is an error; a millisecond is the shortest useful one.
            let _ = self
                .stream
                .set_read_timeout(Some(slice.max(Duration::from_millis(1))));
            let spare = self.decoder.spare();
            if spare.is_empty() {
                // Cannot happen (the decoder skips frames that would not fit), but an
                // empty read buffer would look like a closed connection.
                self.decoder.clear();
                continue;
            }
            match self.stream.read(spare) {
                Ok(0) => {
                    return Err(Error::Closed {
                        message_type: ty,
                        source: None,
                    });
                }
                Ok(n) => self.decoder.commit(n),
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock
                            | io::ErrorKind::TimedOut
                            | io::ErrorKind::Interrupted
                    ) => {}
                Err(e) if is_disconnect(&e) => {
                    return Err(Error::Closed {
                        message_type: ty,
                        source: Some(e),
                    });
                }
                Err(source) => {
                    return Err(Error::Io {
                        context: format!("reading the answer to Type {ty}"),
                        source,
                    });
                }
            }
        }
    }

    /// Takes frames out of the decoder until the awaited answer turns up or more bytes
    /// are needed.
    fn next_answer(
        &mut self,
        message_id: u16,
        message_type: MessageType,
    ) -> Result<Option<Answer>, Error> {
        let ty = message_type.raw();
        while let Some(item) = self.decoder.decode() {
            let frame = match item {
                Ok(frame) => frame,
                Err(FrameError::TooLong {
                    message_id: id,
                    asdu_len,
                }) if id == message_id => {
                    return Err(Error::BadAnswer {
                        message_type: ty,
                        message_id: id,
                        detail: format!(
                            "{asdu_len}-byte body, longer than the {}-byte limit; skipped",
                            MAX_FRAME_LEN - HEADER_LEN
                        ),
                    });
                }
                Err(e) => {
                    warn(&stream_error_text(&e));
                    continue;
                }
            };
            let id = frame.message_id;
            if let Some(at) = self.abandoned.iter().position(|&a| a == id) {
                // The late answer to a request given up on: expected, not news.
                self.abandoned.swap_remove(at);
                continue;
            }
            let decoded = Response::decode(frame.asdu);
            match decoded {
                // Type 0 is the robot saying it could not read a request. It cannot always
                // know the request's message ID (ErrorCode 1: header missing), and only one
                // request is outstanding on a connection, so it is this request's answer
                // whatever its ID.
                Ok(d) => {
                    if let Response::RequestError(e) = d.message {
                        if id != message_id {
                            warn(&format!(
                                "the Type 0 answer carries message ID {id}, not the request's {message_id}"
                            ));
                        }
                        return Err(Error::TypeZero {
                            code: e.code,
                            message_type: ty,
                        });
                    }
                    let got = d.message.message_type();
                    if id != message_id {
                        warn(&format!(
                            "ignored an unsolicited Type {} frame with message ID {id} (waiting for the answer to Type {ty}, message ID {message_id})",
                            got.raw()
                        ));
                        continue;
                    }
                    if got != message_type {
                        return Err(Error::BadAnswer {
                            message_type: ty,
                            message_id: id,
                            detail: format!("the answer has Type {}", got.raw()),
                        });
                    }
                    return Ok(Some(Answer {
                        message_id: id,
                        time: d.time,
                        response: d.message,
                    }));
                }
                Err(e) if id == message_id => {
                    return Err(Error::BadAnswer {
                        message_type: ty,
                        message_id: id,
                        detail: e.to_string(),
                    });
                }
                Err(e) => warn(&format!(
                    "ignored an undecodable frame with message ID {id} (waiting for the answer to Type {ty}, message ID {message_id}): {e}"
                )),
            }
        }
        Ok(None)
    }
}

/// Whether an I/O error means the peer went away.
fn is_disconnect(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::BrokenPipe
            | io::ErrorKind::UnexpectedEof
    )
}

/// A stream error of the frame decoder, as text.
pub fn stream_error_text(e: &FrameError) -> String {
    match e {
        FrameError::Garbage { skipped } => format!(
            "skipped {skipped} byte{} of garbage before a sync sequence",
            if *skipped == 1 { "" } else { "s" }
        ),
        FrameError::BadReserved { message_id } => {
            format!("skipped a frame header with non-zero reserved bytes (message ID {message_id})")
        }
        FrameError::TooLong {
            message_id,
            asdu_len,
        } => format!(
            "skipped an oversize frame (message ID {message_id}, {asdu_len}-byte body, limit {})",
            MAX_FRAME_LEN - HEADER_LEN
        ),
        other => format!("stream error: {other:?}"),
    }
}
