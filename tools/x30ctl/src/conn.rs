//! A blocking connection to robot_server: connect, send requests, wait for their answers.
//!
//! This is where the mistakes of existing clients (docs/protocol.md, "Mistakes of existing
//! clients") are avoided:
//! - bytes go through a [`FrameDecoder`], so split frames, several frames in one read and
//!   garbage before a sync sequence are all handled, and the stream resynchronises; an
//!   answer whose header's reserved bytes are not zero is read all the same;
//! - answers are matched to requests by the protocol core's [`Outstanding`]: by message ID
//!   (from a [`MessageIds`] counter), and a Type 0 answer whose ID matches no outstanding
//!   request answers the oldest one; frames that answer no request are reported on stderr
//!   and skipped, never taken for the answer (late answers to requests given up on are
//!   skipped quietly);
//! - an answer of a Type this protocol version does not know is an error naming the Type,
//!   not a stall;
//! - every read has a timeout, so nothing waits forever unless the caller asks for it
//!   (the 1003 answer), and even then the caller is polled so Ctrl-C is seen.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use x30_panel::proto::codes::{MessageType, MotionCommandCode};
use x30_panel::proto::frame::{
    self, EncodeError, FrameDecoder, FrameError, HEADER_LEN, MessageIds, Reserved,
};
use x30_panel::proto::message::{
    DecodeError, Decoded, MAX_REQUEST_LEN, Request, Response, Unreadable,
};
use x30_panel::proto::outstanding::Outstanding;
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

/// A decoder as every connection reads answers: reserved header bytes are ignored, as the
/// panel ignores them, so a robot whose software fills them is still understood.
pub fn decoder() -> Box<Decoder> {
    Box::new(Decoder::new().reserved(Reserved::Ignore))
}

/// Requests one connection may have written and not seen answered; beyond this the oldest
/// is given up on. Only `move` and `estop` send before the last answer is in: `move` stops
/// while an answer is overdue (two or three requests at 4 Hz), and `estop` reconnects
/// after at most 8 s of silence (33 requests: a Command 13 every 250 ms and one status),
/// so this is ample.
const MAX_OUTSTANDING: usize = 40;

/// Message IDs of requests given up on that are remembered, so their late answers are
/// skipped quietly; older ones, if they ever come, are reported as unsolicited.
const MAX_ABANDONED: usize = 16;

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
    /// Requests written and not answered yet, with their Types and Commands: which request
    /// an answer answers is decided here (the protocol core's rule, Type 0 included).
    outstanding: Outstanding<(MessageType, i32), MAX_OUTSTANDING>,
    /// Answers (or the errors they amount to) that came for an outstanding request while
    /// another was being waited for, by the request's message ID.
    early: Vec<(u16, Result<Answer, Error>)>,
    /// Message IDs of requests given up on (not outstanding): their late answers are
    /// expected, so they are skipped without a warning.
    abandoned: Vec<u16>,
    /// The items last warned about as unreadable: `watch` warns again only when they
    /// change.
    unreadable: Unreadable,
    /// Whether a frame with no body has been warned about: a keep-alive comes again and
    /// again, and is told once.
    warned_empty: bool,
    /// Whether a motion answer naming another Command than its request's has been warned
    /// about: a robot that does it does it to every answer, and is told once.
    warned_other_command: bool,
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
                        decoder: decoder(),
                        timeout,
                        frame_buf: Vec::new(),
                        outstanding: Outstanding::new(),
                        early: Vec::new(),
                        abandoned: Vec::new(),
                        unreadable: Unreadable::default(),
                        warned_empty: false,
                        warned_other_command: false,
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
            // `wait` has given the request up: its late answer will be skipped quietly.
            Err(_) if stopped => Ok(None),
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
        result?;
        // The counter wrapped onto an ID given up on long ago: its answer is this one's now.
        self.abandoned.retain(|&id| id != message_id);
        self.early.retain(|(id, _)| *id != message_id);
        if let Some((oldest, _)) = self
            .outstanding
            .push(message_id, (request.message_type(), request.command()))
        {
            // Too many outstanding: the oldest was given up on to make room.
            self.abandon(oldest);
        }
        Ok(message_id)
    }

    /// Waits for the answer with `message_id` (from [`Connection::send`]) to a request of
    /// Type `message_type`.
    ///
    /// `check` runs after every read (at least every 100 ms) with the time waited so far,
    /// and says how long to go on. Answers to other outstanding requests are kept for their
    /// own `wait`; other frames and stream errors (garbage, oversize frames)
    /// are reported on stderr and skipped. If the wait ends without the answer (the
    /// deadline, [`Check::Abort`], a read error), the request is given up on: its late
    /// answer is then skipped quietly.
    pub fn wait(
        &mut self,
        message_id: u16,
        message_type: MessageType,
        mut check: impl FnMut(Duration) -> Check,
    ) -> Result<Answer, Error> {
        let started = Instant::now();
        let ty = message_type.raw();
        if let Some(settled) = self.settled(message_id, ty) {
            return settled;
        }
        let result = loop {
            if let Some(answer) = self.next_answer(message_id, message_type) {
                return answer;
            }
            let deadline = match check(started.elapsed()) {
                Check::Abort(e) => break Err(e),
                Check::Wait(deadline) => deadline,
            };
            let mut slice = POLL;
            if let Some(deadline) = deadline {
                let left = deadline.at.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    break Err(Error::Timeout {
                        waited: deadline.after,
                        message_type: ty,
                    });
                }
                slice = slice.min(left);
            }
            if let Err(e) = self.read_for(slice, ty) {
                break Err(e);
            }
        };
        self.give_up(message_id);
        result
    }

    /// Waits for the answer with `message_id` like [`Connection::wait`], but only until
    /// `until`, or until `stop` returns true (checked at least every 100 ms): then `Ok(None)`,
    /// and the request stays outstanding, its answer kept for a later call. For a caller
    /// that has other things to do on time, such as sending the next request.
    pub fn poll(
        &mut self,
        message_id: u16,
        message_type: MessageType,
        until: Instant,
        stop: impl Fn() -> bool,
    ) -> Result<Option<Answer>, Error> {
        if let Some(settled) = self.settled(message_id, message_type.raw()) {
            return settled.map(Some);
        }
        loop {
            if let Some(answer) = self.next_answer(message_id, message_type) {
                return answer.map(Some);
            }
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() || stop() {
                return Ok(None);
            }
            self.read_for(left.min(POLL), message_type.raw())?;
        }
    }

    /// Before a wait for the answer with `message_id` to a request of Type `ty`: the answer,
    /// if it came while another was waited for, or the error of a wait for a request that
    /// is not outstanding; `None` if the answer is still to come.
    fn settled(&mut self, message_id: u16, ty: i32) -> Option<Result<Answer, Error>> {
        if let Some(at) = self.early.iter().position(|(id, _)| *id == message_id) {
            return Some(self.early.remove(at).1);
        }
        if self.outstanding.contains(message_id) {
            return None;
        }
        Some(Err(Error::Io {
            context: format!("waiting for the answer to Type {ty}"),
            source: io::Error::other(format!(
                "no request with message ID {message_id} is outstanding"
            )),
        }))
    }

    /// Whether the robot has closed the connection (a robot that hangs up after each
    /// answer), found by a read that does not wait. What that read takes in is kept for the
    /// next wait. A request written on a connection the robot closed would be lost, or fail
    /// only when its answer is waited for.
    pub fn closed_by_robot(&mut self) -> bool {
        if self.stream.set_nonblocking(true).is_err() {
            return false;
        }
        let closed = match self.read_into_decoder() {
            Ok(open) => !open,
            Err(e) => is_disconnect(&e),
        };
        // Every other read and write waits, with a timeout of its own.
        let _ = self.stream.set_nonblocking(false);
        closed
    }

    /// Reads what the robot sent into the decoder, as the stream's mode and timeout allow:
    /// `Ok(false)` when the robot has closed the connection.
    fn read_into_decoder(&mut self) -> io::Result<bool> {
        let spare = self.decoder.spare();
        if spare.is_empty() {
            // Cannot happen (the decoder skips frames that would not fit), but an empty
            // read buffer would look like a closed connection.
            self.decoder.clear();
            return Ok(true);
        }
        let n = self.stream.read(spare)?;
        self.decoder.commit(n);
        Ok(n > 0)
    }

    /// Reads what the robot sent into the decoder, waiting up to `slice` for it; the error
    /// names the Type `ty` of the answer being waited for.
    fn read_for(&mut self, slice: Duration, ty: i32) -> Result<(), Error> {
        // A zero read timeout is an error; a millisecond is the shortest useful one.
        let _ = self
            .stream
            .set_read_timeout(Some(slice.max(Duration::from_millis(1))));
        match self.read_into_decoder() {
            Ok(true) => Ok(()),
            Ok(false) => Err(Error::Closed {
                message_type: ty,
                source: None,
            }),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) =>
            {
                Ok(())
            }
            Err(e) if is_disconnect(&e) => Err(Error::Closed {
                message_type: ty,
                source: Some(e),
            }),
            Err(source) => Err(Error::Io {
                context: format!("reading the answer to Type {ty}"),
                source,
            }),
        }
    }

    /// Gives up on an outstanding request: it is no longer matched, and its late answer,
    /// if one comes, is skipped without a warning.
    fn give_up(&mut self, message_id: u16) {
        if self.outstanding.remove(message_id).is_some() {
            self.abandon(message_id);
        }
    }

    /// Remembers a request given up on (no longer outstanding), so its late answer is
    /// skipped quietly.
    fn abandon(&mut self, message_id: u16) {
        if self.abandoned.len() >= MAX_ABANDONED {
            self.abandoned.remove(0);
        }
        self.abandoned.push(message_id);
    }

    /// Takes frames out of the decoder until the answer to the request with `message_id`
    /// turns up (`Some`: the answer, or the error it amounts to) or more bytes are needed.
    ///
    /// Which request a frame answers is decided by [`Outstanding::answer_if`]: the request
    /// with the frame's message ID if the frame has its Type, or, for a Type 0 answer whose
    /// ID matches none, the oldest outstanding request. Answers to other outstanding
    /// requests are kept in `early`.
    fn next_answer(
        &mut self,
        message_id: u16,
        message_type: MessageType,
    ) -> Option<Result<Answer, Error>> {
        while let Some(item) = self.decoder.decode() {
            let (answered, result) = match item {
                // A frame with no body answers nothing, whatever its message ID: a server
                // may send one to keep the connection alive, and the answer comes after it.
                Ok(frame) if frame.asdu.is_empty() => {
                    if !self.warned_empty {
                        self.warned_empty = true;
                        warn(&format!(
                            "passing over frames with no body (the first had message ID {}), \
                             which answer nothing",
                            frame.message_id
                        ));
                    }
                    continue;
                }
                Ok(frame) => {
                    let id = frame.message_id;
                    let decoded = Response::decode(frame.asdu);
                    match self.match_frame(id, decoded, (message_id, message_type)) {
                        Some(matched) => matched,
                        None => continue,
                    }
                }
                // A stream error is no answer, even with a request's message ID: a frame too
                // long or cut short may be the robot's first try at an answer it then writes
                // whole. The request goes on waiting, as the panel's does.
                Err(e) => {
                    warn(&stream_error_text(&e));
                    continue;
                }
            };
            if answered == message_id {
                return Some(result);
            }
            self.early.push((answered, result));
        }
        None
    }

    /// Matches one decoded (or undecodable) frame with message ID `id` to the outstanding
    /// request it answers, taking that request out: `(its message ID, its result)`.
    /// `None`: the frame answers no outstanding request and was skipped (quietly for the
    /// late answer to a request given up on). `awaited` (the message ID and Type of the
    /// request being waited for) is only for the warnings.
    fn match_frame(
        &mut self,
        id: u16,
        decoded: Result<Decoded<Response>, DecodeError>,
        (awaited, awaited_type): (u16, MessageType),
    ) -> Option<(u16, Result<Answer, Error>)> {
        let request_error = match &decoded {
            Ok(d) => match d.message {
                Response::RequestError(e) => Some(e.code),
                _ => None,
            },
            Err(_) => None,
        };
        // The late answer to a request given up on: expected, not news. An outstanding
        // request with the same ID (the counter wrapped) comes first.
        if !self.outstanding.contains(id)
            && let Some(at) = self.abandoned.iter().position(|&a| a == id)
        {
            self.abandoned.remove(at);
            return None;
        }
        let waiting_for = format!(
            "waiting for the answer to Type {}, message ID {awaited}",
            awaited_type.raw()
        );
        let mut d = match decoded {
            Ok(d) => d,
            Err(e) => {
                if let Some((ty, _)) = self.outstanding.remove(id) {
                    return Some((
                        id,
                        Err(Error::BadAnswer {
                            message_type: ty.raw(),
                            message_id: id,
                            detail: e.to_string(),
                        }),
                    ));
                }
                warn(&format!(
                    "ignored an undecodable frame with message ID {id} ({waiting_for}): {e}"
                ));
                return None;
            }
        };
        let got = d.message.message_type();
        // A frame with a request's message ID but not its Type is no answer to it (the
        // protocol core's rule): a robot's own report that reuses a task's ID does not end
        // its wait.
        let answers = |&(ty, _): &(MessageType, i32)| d.message.answers(ty);
        let Some((request_id, (ty, command))) =
            self.outstanding
                .answer_if(id, request_error.is_some(), answers)
        else {
            warn(&match self.outstanding.get(id) {
                Some(&(ty, command)) => format!(
                    "ignored a Type {} Command {} frame with the message ID of the Type {} \
                     Command {command} request ({waiting_for})",
                    got.raw(),
                    d.message.command(),
                    ty.raw()
                ),
                None => format!(
                    "ignored an unsolicited Type {} frame with message ID {id} ({waiting_for})",
                    got.raw()
                ),
            });
            return None;
        };
        let result = if let Some(code) = request_error {
            // Type 0 is the robot saying it could not read a request. It cannot always
            // know the request's message ID (ErrorCode 1: header missing); one whose ID
            // matches no outstanding request answers the oldest.
            if id != request_id {
                warn(&format!(
                    "the Type 0 answer carries message ID {id}, not the request's {request_id}"
                ));
            }
            Err(Error::TypeZero {
                code,
                message_type: ty.raw(),
            })
        } else {
            // The message ID pairs them: another Command named in the answer is the robot's
            // slip, told once, not a reason to wait on for an answer that will not come. The
            // answer is then shown as the request's (its ErrorCode and Value as written): a
            // `lie-down` answered "Command 1" is not shown as a forward.
            if let Response::Motion(code, ack) = d.message
                && code.raw() != command
            {
                if !self.warned_other_command {
                    self.warned_other_command = true;
                    warn(&format!(
                        "the robot answered Type {} Command {command} naming Command {} \
                         (message ID {id}); taken as its answer",
                        ty.raw(),
                        code.raw()
                    ));
                }
                d.message = Response::Motion(MotionCommandCode::from_raw(command), ack);
            }
            if d.unreadable != self.unreadable && !d.unreadable.is_empty() {
                warn(&format!(
                    "the robot wrote {} in a form that cannot be read (Type {}, message ID \
                     {id}); shown as not reported",
                    d.unreadable,
                    got.raw()
                ));
            }
            self.unreadable = d.unreadable;
            Ok(Answer {
                message_id: id,
                time: d.time,
                response: d.message,
            })
        };
        Some((request_id, result))
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

/// A stream error of the connections' decoder, as text. It reads headers whose reserved
/// bytes are set ([`decoder`]), so it never reports them.
pub fn stream_error_text(e: &FrameError) -> String {
    match e {
        FrameError::Garbage { skipped } => format!(
            "skipped {skipped} byte{} of garbage before a sync sequence",
            if *skipped == 1 { "" } else { "s" }
        ),
        FrameError::TooLong {
            message_id,
            asdu_len,
        } => format!(
            "skipped an oversize frame (message ID {message_id}, {asdu_len}-byte body, limit {})",
            MAX_FRAME_LEN - HEADER_LEN
        ),
        FrameError::CutShort {
            message_id,
            asdu_len,
            received,
        } => format!(
            "skipped a frame cut short (message ID {message_id}, {received} of its {asdu_len} \
             body bytes came before the next frame's start)"
        ),
        other => format!("stream error: {other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::TcpListener;
    use std::thread;
    use x30_panel::proto::codes::{CommandResult, MotionCommandCode, RequestErrorCode};
    use x30_panel::proto::message::{Battery, MotionAck, MotionCommand, RequestError, RobotStatus};
    use x30_sim::Faults;

    /// Bound on every wait in these tests.
    const LIMIT: Duration = Duration::from_secs(5);

    /// A one-connection fake robot on loopback: reads `requests` request frames, then
    /// writes `reply(their message IDs)` and keeps the connection open until the client
    /// leaves.
    fn fake_robot(
        requests: usize,
        reply: impl FnOnce(&[u16]) -> Vec<u8> + Send + 'static,
    ) -> String {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("addr").to_string();
        thread::spawn(move || {
            let Ok((mut stream, _)) = listener.accept() else {
                return;
            };
            let _ = stream.set_read_timeout(Some(LIMIT));
            let mut ids = Vec::new();
            for _ in 0..requests {
                let mut header = [0u8; HEADER_LEN];
                if stream.read_exact(&mut header).is_err() {
                    return;
                }
                let len = usize::from(u16::from_le_bytes([header[4], header[5]]));
                let mut body = vec![0; len];
                if stream.read_exact(&mut body).is_err() {
                    return;
                }
                ids.push(u16::from_le_bytes([header[6], header[7]]));
            }
            let _ = stream.write_all(&reply(&ids));
            let _ = stream.read(&mut [0u8; 1]);
        });
        addr
    }

    fn answer_frame(id: u16, response: &Response) -> Vec<u8> {
        x30_sim::encode_frame(id, response, &Faults::default()).expect("the answer encodes")
    }

    fn type_0(id: u16) -> Vec<u8> {
        answer_frame(
            id,
            &Response::RequestError(RequestError {
                code: RequestErrorCode::ParseFailed,
            }),
        )
    }

    fn status(id: u16) -> Vec<u8> {
        answer_frame(id, &Response::Status(RobotStatus::UNAVAILABLE))
    }

    fn battery(id: u16) -> Vec<u8> {
        answer_frame(
            id,
            &Response::Battery(Battery {
                voltage: Some(55),
                current: Some(120),
                remaining_capacity: Some(1500),
                nominal_capacity: Some(2004),
                cycles: Some(3),
                protected_state: Some(x30_panel::proto::codes::ProtectedState::Normal),
                battery_level: Some(42),
                battery_temperature: None,
            }),
        )
    }

    fn connect(addr: &str) -> Connection {
        Connection::connect(addr, LIMIT, LIMIT).expect("connect")
    }

    fn wait(conn: &mut Connection, id: u16, ty: MessageType) -> Result<Answer, Error> {
        let deadline = Deadline::after(LIMIT);
        conn.wait(id, ty, |_| Check::Wait(Some(deadline)))
    }

    /// Status then Battery outstanding; the robot answers with `reply(status ID, battery ID)`.
    fn two_outstanding(
        reply: impl FnOnce(u16, u16) -> Vec<u8> + Send + 'static,
    ) -> (Result<Answer, Error>, Result<Answer, Error>) {
        let addr = fake_robot(2, move |ids| reply(ids[0], ids[1]));
        let mut conn = connect(&addr);
        let first = conn.send(&Request::Status).expect("send");
        let second = conn.send(&Request::Battery).expect("send");
        let first = wait(&mut conn, first, MessageType::Status);
        let second = wait(&mut conn, second, MessageType::Battery);
        (first, second)
    }

    fn is_status(result: &Result<Answer, Error>) -> bool {
        matches!(
            result,
            Ok(Answer {
                response: Response::Status(_),
                ..
            })
        )
    }

    fn is_battery(result: &Result<Answer, Error>) -> bool {
        matches!(
            result,
            Ok(Answer {
                response: Response::Battery(_),
                ..
            })
        )
    }

    fn is_type_0_to(result: &Result<Answer, Error>, ty: MessageType) -> bool {
        matches!(
            result,
            Err(Error::TypeZero { code: RequestErrorCode::ParseFailed, message_type })
                if *message_type == ty.raw()
        )
    }

    #[test]
    fn answers_to_two_outstanding_requests_are_matched_in_any_order() {
        let (first, second) = two_outstanding(|a, b| [battery(b), status(a)].concat());
        assert!(is_status(&first), "{first:?}");
        assert!(
            matches!(second, Ok(Answer { response: Response::Battery(b), .. }) if b.battery_level == Some(42)),
            "{second:?}"
        );
    }

    #[test]
    fn type_0_with_the_second_requests_id_answers_the_second_not_the_first() {
        let (first, second) = two_outstanding(|a, b| [type_0(b), status(a)].concat());
        assert!(is_status(&first), "{first:?}");
        assert!(is_type_0_to(&second, MessageType::Battery), "{second:?}");
    }

    #[test]
    fn type_0_with_an_unknown_id_answers_the_oldest_outstanding_request() {
        let (first, second) = two_outstanding(|a, b| {
            [type_0(a.wrapping_add(b).wrapping_add(100)), battery(b)].concat()
        });
        assert!(is_type_0_to(&first, MessageType::Status), "{first:?}");
        assert!(is_battery(&second), "{second:?}");
    }

    #[test]
    fn late_type_0_to_a_request_given_up_on_is_skipped() {
        let addr = fake_robot(2, |ids| [type_0(ids[0]), battery(ids[1])].concat());
        let mut conn = connect(&addr);
        let given_up = conn.send(&Request::Status).expect("send");
        let stopped = conn.wait(given_up, MessageType::Status, |_| {
            Check::Abort(Error::Interrupted(String::new()))
        });
        assert!(matches!(stopped, Err(Error::Interrupted(_))), "{stopped:?}");
        let id = conn.send(&Request::Battery).expect("send");
        let answer = wait(&mut conn, id, MessageType::Battery);
        assert!(
            matches!(answer, Ok(Answer { response: Response::Battery(_), message_id, .. }) if message_id == id),
            "{answer:?}"
        );
    }

    /// The status answer cut short (its header claims more than came), then the battery's
    /// answer, then the status answer whole (a robot that wrote it again): both requests get
    /// their answers, and the battery's, which the broken frame's declared length would have
    /// swallowed, is not lost.
    #[test]
    fn an_answer_cut_short_is_skipped_and_the_answers_after_it_are_kept() {
        let (first, second) = two_outstanding(|a, b| {
            let mut cut = status(a);
            cut.truncate(HEADER_LEN + 40);
            [cut, battery(b), status(a)].concat()
        });
        assert!(is_status(&first), "{first:?}");
        assert!(is_battery(&second), "{second:?}");
    }

    /// A header with the request's message ID claiming far more than the limit, a few
    /// bytes, then the answer whole: the broken frame is skipped (too long, then cut short)
    /// and the request gets its answer.
    #[test]
    fn an_oversize_frame_cut_short_with_the_requests_id_is_no_answer() {
        let addr = fake_robot(1, |ids| {
            let mut huge = status(ids[0]);
            huge[4..6].copy_from_slice(&60_000u16.to_le_bytes());
            huge.truncate(HEADER_LEN + 7);
            [huge, status(ids[0])].concat()
        });
        let mut conn = connect(&addr);
        let id = conn.send(&Request::Status).expect("send");
        let answer = wait(&mut conn, id, MessageType::Status);
        assert!(is_status(&answer), "{answer:?}");
    }

    /// The message ID pairs a request with its answer: a motion answer naming another
    /// Command is the stop's answer, shown as the stop's with the robot's ErrorCode and
    /// Value, and the frame after it, with the same ID, answers nothing.
    #[test]
    fn a_motion_answer_naming_another_command_is_the_stops_answer() {
        let addr = fake_robot(1, |ids| {
            let ack = |code, value| {
                answer_frame(
                    ids[0],
                    &Response::Motion(
                        code,
                        MotionAck {
                            value,
                            result: CommandResult::Success,
                        },
                    ),
                )
            };
            [
                ack(MotionCommandCode::Forward, Some(0.3)),
                ack(MotionCommandCode::ZeroVelocity, None),
            ]
            .concat()
        });
        let mut conn = connect(&addr);
        let stop = conn
            .send(&Request::Motion(MotionCommand::ZeroVelocity))
            .expect("send");
        let answer = wait(&mut conn, stop, MessageType::Motion);
        assert!(
            matches!(
                answer,
                Ok(Answer {
                    response: Response::Motion(
                        MotionCommandCode::ZeroVelocity,
                        MotionAck {
                            value: Some(0.3),
                            result: CommandResult::Success
                        }
                    ),
                    ..
                })
            ),
            "{answer:?}"
        );
        assert!(conn.outstanding.is_empty(), "nothing outstanding");
    }

    #[test]
    fn waiting_for_a_request_never_sent_is_an_error_not_a_stall() {
        let addr = fake_robot(0, |_| Vec::new());
        let mut conn = connect(&addr);
        let result = wait(&mut conn, 7, MessageType::Status);
        assert!(
            matches!(&result, Err(Error::Io { source, .. }) if source.to_string().contains("no request with message ID 7")),
            "{result:?}"
        );
    }
}
