//! One connection to the robot: framing, message IDs, timeouts, reconnection.

use embassy_time::{Duration, Instant, with_timeout};
use embedded_io_async::{Error as _, ErrorKind, Read, Write};

use super::{Backoff, ClientError, RobotClock};
use crate::config::RobotAddress;
use crate::proto::codes::MessageType;
use crate::proto::frame::{self, FrameDecoder, MessageIds, Reserved};
use crate::proto::message::{
    Battery, CommandAck, DecodeError, Decoded, Light, MotionAck, MotionCommand, MotorTemperatures,
    NavResult, NavTask, NavTaskState, Perception, Relocalize, RelocalizeAck, Request, Response,
    RobotStatus,
};
use crate::proto::outstanding::Outstanding;

/// Frame buffer for answers. The largest known, a real robot's 1002 answer with its extra
/// items, is about 1.2 KiB; a frame that does not fit is skipped, and a status skipped every
/// time would leave an e-stop unconfirmed, so there is room for a robot_server that adds
/// as many items again, and more, or indents more deeply.
pub const RX_BUF: usize = 4096;
/// Frame buffer for requests: a one-point 1003 request, the largest the panel sends, is
/// about 0.6 KiB.
pub const TX_BUF: usize = 1024;

/// A byte stream to the robot that can be opened again after it failed.
///
/// On the board this wraps an embassy-net `TcpSocket`; on the host, a tokio `TcpStream`.
#[allow(async_fn_in_trait)] // Used in one executor at a time; no Send bound is wanted.
pub trait Transport: Read + Write {
    /// Opens the connection, closing a previous one first.
    async fn connect(&mut self) -> Result<(), ErrorKind>;
    /// Closes the connection, so that the robot sees it gone.
    async fn close(&mut self);
    /// Where the next `connect` goes: the robot's address was changed in the settings.
    fn set_robot(&mut self, robot: RobotAddress);
}

/// What went by on a connection that was not an answer to a request outstanding on it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Anomalies {
    /// Frames that answered no outstanding request: late or unsolicited answers, and
    /// frames with a request's message ID but not its Type.
    pub unsolicited: u32,
    /// Motion answers that named another Command than their request's: taken as its
    /// answer all the same (the message ID pairs them).
    pub other_command: u32,
    /// Stream errors the frame decoder skipped past: garbage, bad headers, oversized frames,
    /// frames cut short.
    pub stream_errors: u32,
    /// Answers with optional items the robot wrote in a form that cannot be read, each
    /// read as left out.
    pub unreadable_items: u32,
    /// Frames with an empty body (a keep-alive, whatever its message ID), passed over.
    pub empty_frames: u32,
}

impl Anomalies {
    /// Counts, and logs now and then, an answer to `request` that named Command `named`:
    /// rare, so kept out of the receive loop's way.
    #[cold]
    fn count_other_command(&mut self, request: &Sent, named: i32) {
        if let Some(count) = count_one(&mut self.other_command) {
            warn!(
                "the robot answered Type {} Command {} naming Command {}: taken as its answer \
                 ({} so far)",
                request.message_type.raw(),
                request.command,
                named,
                count
            );
        }
    }
}

/// How many requests may wait for their answers on one connection. A stop path writes
/// without waiting, at most every 250 ms, and a request is given up on after about a
/// second, so a handful is in flight at most; beyond this the oldest is given up on.
pub const MAX_OUTSTANDING: usize = 16;

/// A write that has not gone into the transport after this long means the robot takes no
/// more bytes (its receive window is closed): the connection is dropped rather than let a
/// stop wait behind it.
pub const WRITE_TIMEOUT: Duration = Duration::from_millis(200);

/// An answer not here after this long is overdue: the robot is slow or not answering, and
/// motion is no longer written to the connection (stops still are). A motion command given
/// up on unanswered keeps it so until the robot answers again: giving the request up does
/// not make the robot answer. Only a request written after the last one answered can be
/// overdue: one the robot passed over, answering later ones (a Type it ignores), says
/// nothing about whether it answers now.
pub const ANSWER_OVERDUE: Duration = Duration::from_millis(500);

/// How long the poll connection must have been open, with the robot answering on it, to be
/// reopened at once when it is lost ([`Connection::reconnect_delay`]). A robot that answers
/// a request and hangs up at the next would otherwise be reconnected to and polled as fast
/// as the link allows.
pub const STABLE_AFTER: Duration = Duration::from_secs(1);

/// The robot is silent, and the connection given up on, when nothing is received for this long
/// after a request it has not answered: one still outstanding, or one given up on (a robot
/// that ignored it has said nothing since) unless the robot answered a request written after
/// it. Once a request was given up on, only an answer counts as received, not keep-alives
/// or unsolicited frames. Doubled for a slow robot ([`MAX_DOUBLINGS`]).
pub const SILENT_AFTER: Duration = Duration::from_secs(2);

/// This many requests given up on in a row also make the robot silent.
pub const SILENT_TIMEOUTS: u8 = 2;

/// How long a command or poll waits for its answer before it is given up on (and counts as
/// failed), while the robot answers within it; [`Connection::request_timeout`] is this
/// lengthened for a slow robot.
pub const REQUEST_TIMEOUT: Duration = Duration::from_millis(1500);

/// How many times a connection's waits for answers ([`REQUEST_TIMEOUT`] and
/// [`SILENT_AFTER`]) may double: each time the robot is given up on as silent, they double
/// for the next connection, so that a robot which answers, but later than
/// [`REQUEST_TIMEOUT`], is read after all; [`PROMPT_ANSWERS`] halve them again. Twice: a
/// robot that takes more than 6 s for each answer is not worth waiting for, and a hung one is
/// still left after 8 s. [`ANSWER_OVERDUE`] never grows: motion is not written to a robot
/// that lags, whatever its reason.
pub const MAX_DOUBLINGS: u8 = 2;

/// This many answers in a row, each within half the wait, halve the waits again
/// ([`MAX_DOUBLINGS`]). Several, not one: a robot slow to answer its status answers the
/// other polls promptly in between, and one of those halving the wait would have the next
/// status given up on, and the connection with it.
pub const PROMPT_ANSWERS: u8 = 8;

/// A request written on a connection, as remembered until its answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sent {
    /// The request's Type.
    pub message_type: MessageType,
    /// The request's Command.
    pub command: i32,
    /// When it was written.
    pub at: Instant,
}

/// An answer received, with the request it answers.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Answer {
    /// The request's message ID.
    pub message_id: u16,
    /// The request it answers.
    pub request: Sent,
    /// The answer, or why it is no usable answer (Type 0, an unknown Type, undecodable);
    /// the connection stays usable either way.
    pub result: Result<Response, ClientError>,
}

/// Whether the robot answers on a connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Health {
    /// Nothing is overdue.
    Answering,
    /// An answer has waited longer than [`ANSWER_OVERDUE`], or a motion command was given
    /// up on unanswered, and nothing written after that request was answered: write no
    /// motion.
    Overdue,
    /// Nothing received for [`SILENT_AFTER`] (doubled for a slow robot) since a request was
    /// written and not answered (still outstanding, or given up on with nothing written after
    /// it answered), or [`SILENT_TIMEOUTS`] such requests in a row given up on: close and
    /// reconnect.
    Silent,
}

/// A connection to the robot: writes requests, matches answers to them by message ID.
///
/// Requests may be written without waiting for earlier answers ([`Connection::send`], then
/// [`Connection::receive`]), which is how stops overtake anything pending; [`Connection::request`] and
/// the typed calls send one request and wait for its answer.
///
/// Errors say whether the connection survived ([`ClientError::connection_usable`]); when it
/// did not, the connection closes the transport and [`Connection::connect`] must succeed before the
/// next request.
pub struct Connection<T: Transport> {
    transport: T,
    connected: bool,
    rx: FrameDecoder<RX_BUF>,
    tx: [u8; TX_BUF],
    ids: MessageIds,
    clock: RobotClock,
    backoff: Backoff,
    anomalies: Anomalies,
    /// Requests written and not answered yet.
    outstanding: Outstanding<Sent, MAX_OUTSTANDING>,
    /// Since when requests have waited with nothing received; `None` once every request
    /// written has been answered or passed over. Giving up on any other request leaves it
    /// running: see [`SILENT_AFTER`].
    waiting_since: Option<Instant>,
    /// Requests given up on since the last answer, those passed over aside.
    timeouts_in_a_row: u8,
    /// Whether a motion command was given up on unanswered and nothing was answered since:
    /// the robot does not answer motion now, and giving the request up changed nothing.
    /// (Another Type given up on says less: an older `robot_server` ignores some Types and
    /// answers the rest.)
    motion_unanswered: bool,
    /// When the latest-written request answered on this connection was written.
    answered_up_to: Option<Instant>,
    /// Whether the robot has answered on this connection since it opened: only then does
    /// the backoff start again from its minimum, so that a robot that accepts connections
    /// and drops them at once is not hammered.
    answered: bool,
    /// How many times the waits for answers are doubled ([`MAX_DOUBLINGS`]); kept across
    /// reconnections, which is where a slow robot is learned.
    doublings: u8,
    /// Answers in a row within half the wait, towards [`PROMPT_ANSWERS`].
    prompt_in_a_row: u8,
    /// When this connection opened.
    opened_at: Instant,
    /// When the latest attempt to open it began.
    attempted_at: Instant,
}

impl<T: Transport> Connection<T> {
    /// A connection over `transport`, not yet open, retrying with `backoff`.
    pub fn new(transport: T, backoff: Backoff) -> Self {
        Self {
            transport,
            connected: false,
            // A robot whose software fills the header's reserved bytes is still read.
            rx: FrameDecoder::new().reserved(Reserved::Ignore),
            tx: [0; TX_BUF],
            ids: MessageIds::new(),
            clock: RobotClock::new(),
            backoff,
            anomalies: Anomalies::default(),
            outstanding: Outstanding::new(),
            waiting_since: None,
            timeouts_in_a_row: 0,
            motion_unanswered: false,
            answered_up_to: None,
            answered: false,
            doublings: 0,
            prompt_in_a_row: 0,
            opened_at: Instant::from_ticks(0),
            attempted_at: Instant::from_ticks(0),
        }
    }

    /// Whether the connection is open.
    pub fn is_connected(&self) -> bool {
        self.connected
    }

    /// Since when the connection has waited for an answer, if it does: the oldest request's
    /// writing, or the last answer while others are due.
    pub fn waiting_since(&self) -> Option<Instant> {
        self.waiting_since
    }

    /// Whether the robot has answered on this connection since it opened.
    pub fn answered(&self) -> bool {
        self.answered
    }

    /// The robot's clock as learned from this connection's answers.
    pub fn clock(&self) -> RobotClock {
        self.clock
    }

    /// Adopts a clock learned elsewhere (a connection that sends little learns little by itself).
    pub fn set_clock(&mut self, clock: RobotClock) {
        self.clock = clock;
    }

    /// What went by that was not an answer, since the connection was made.
    pub fn anomalies(&self) -> Anomalies {
        self.anomalies
    }

    /// Makes one attempt to open the connection. On failure logs why and returns how long to
    /// wait before the next attempt, growing exponentially up to the backoff's maximum. The
    /// caller, which may wait less (a stop pending), logs the wait it keeps.
    pub async fn connect(&mut self) -> Result<(), Duration> {
        self.disconnect().await;
        self.attempted_at = Instant::now();
        match self.transport.connect().await {
            Ok(()) => {
                self.connected = true;
                self.answered = false;
                self.opened_at = Instant::now();
                info!("connected to the robot");
                Ok(())
            }
            Err(kind) => {
                warn!("connection failed ({:?})", kind);
                Err(self.backoff.next_delay())
            }
        }
    }

    /// When the latest attempt to open the connection began (boot time before the first).
    pub fn last_attempt(&self) -> Instant {
        self.attempted_at
    }

    /// Closes the connection and opens the next one to `robot`, with a fresh backoff:
    /// another robot has not refused anything yet.
    pub async fn retarget(&mut self, robot: RobotAddress) {
        self.disconnect().await;
        self.transport.set_robot(robot);
        self.backoff.reset();
        self.doublings = 0;
        self.prompt_in_a_row = 0;
    }

    /// Closes the connection and forgets any partial answer and every outstanding request.
    pub async fn disconnect(&mut self) {
        if self.connected {
            self.transport.close().await;
            self.connected = false;
        }
        self.rx.clear();
        self.outstanding.clear();
        self.timeouts_in_a_row = 0;
        self.motion_unanswered = false;
        self.waiting_since = None;
        self.answered_up_to = None;
    }

    /// Gives up on a connection whose robot went silent; the next attempt waits for the
    /// backoff, so a robot that accepts connections but never answers is not hammered, and
    /// the next connection waits twice as long for answers ([`MAX_DOUBLINGS`]).
    ///
    /// What was written last (the stops due, written just before) is flushed first, for at
    /// most [`WRITE_TIMEOUT`]: the reset that closes the connection would drop it unsent, and
    /// a robot that reads but does not answer may still act on it.
    pub async fn give_up(&mut self) -> Duration {
        if self.connected {
            let _ = with_timeout(WRITE_TIMEOUT, self.transport.flush()).await;
        }
        self.disconnect().await;
        if core::mem::take(&mut self.answered) {
            self.backoff.reset();
        }
        self.prompt_in_a_row = 0;
        if self.doublings < MAX_DOUBLINGS {
            self.doublings += 1;
            info!(
                "waiting {} ms for answers from now on",
                self.request_timeout().as_millis()
            );
        }
        self.backoff.next_delay()
    }

    /// How long a request waits for its answer on this connection: [`REQUEST_TIMEOUT`],
    /// doubled for a robot found slow ([`MAX_DOUBLINGS`]).
    pub fn request_timeout(&self) -> Duration {
        self.patient(REQUEST_TIMEOUT)
    }

    /// `wait` doubled as many times as the robot has been found slow.
    fn patient(&self, wait: Duration) -> Duration {
        wait * (1 << self.doublings)
    }

    /// How long to wait before reconnecting after the connection was lost: not at all if
    /// the robot had answered on it and it had been open for `stable` (a blip; the backoff
    /// starts again from its minimum), else the backoff's next delay. The poll connection
    /// gives [`STABLE_AFTER`]; the command connection, whose stops must not wait, less.
    pub fn reconnect_delay(&mut self, stable: Duration) -> Duration {
        let up = Instant::now().saturating_duration_since(self.opened_at);
        if core::mem::take(&mut self.answered) && up >= stable {
            self.backoff.reset();
            Duration::from_ticks(0)
        } else {
            self.backoff.next_delay()
        }
    }

    /// Whether the robot answers on this connection at `now`.
    pub fn health(&self, now: Instant) -> Health {
        let waited = |since: Instant| now.saturating_duration_since(since);
        if self.timeouts_in_a_row >= SILENT_TIMEOUTS
            || self
                .waiting_since
                .is_some_and(|w| waited(w) >= self.patient(SILENT_AFTER))
        {
            Health::Silent
        } else if self.motion_unanswered
            || self
                .oldest_not_passed_over()
                .is_some_and(|oldest| waited(oldest.at) >= ANSWER_OVERDUE)
        {
            Health::Overdue
        } else {
            Health::Answering
        }
    }

    /// When [`Connection::health`] may next change, after `now`, without anything received.
    /// A deadline already passed is left out: a loop that sleeps until it would spin.
    pub fn health_deadline(&self, now: Instant) -> Option<Instant> {
        let overdue = self
            .oldest_not_passed_over()
            .map(|oldest| oldest.at.saturating_add(ANSWER_OVERDUE))
            .filter(|&at| at > now);
        let silent = self
            .waiting_since
            .map(|w| w.saturating_add(self.patient(SILENT_AFTER)));
        overdue.into_iter().chain(silent).min()
    }

    /// The oldest request written after the latest one answered: the one whose answer says
    /// whether the robot still answers (see [`ANSWER_OVERDUE`]).
    fn oldest_not_passed_over(&self) -> Option<Sent> {
        self.outstanding
            .iter()
            .map(|&(_, sent)| sent)
            .find(|sent| !self.passed_over(sent))
    }

    /// Whether the robot passed `sent` over: it answered a request written after it (as an
    /// older `robot_server` does around a Type it ignores), so `sent`'s missing answer says
    /// nothing about whether it answers.
    fn passed_over(&self, sent: &Sent) -> bool {
        self.answered_up_to.is_some_and(|up_to| up_to > sent.at)
    }

    /// When the oldest outstanding request that `is` picks and that the robot has sent
    /// nothing at all on this connection since was written: as far as that request can
    /// tell, the robot may no longer read the connection (a handler that hung). The command
    /// loop asks it of the stops, which would otherwise wait the seconds of [`SILENT_AFTER`]
    /// before they went out again on a new connection; whether that is what it means is the
    /// caller's to weigh, with [`Connection::answered`]: a robot serving one connection at a
    /// time leaves a connection never answered on unread in its backlog, too.
    ///
    /// Older such requests that the robot did send something after are passed over, not
    /// taken for the answer: an e-stop written just before the answer to a motion repeat
    /// says nothing of the repeats of it written after, which a robot that hung then never
    /// reads.
    pub fn unread_since(&self, is: impl Fn(&Sent) -> bool) -> Option<Instant> {
        let since = self.waiting_since?;
        self.outstanding
            .iter()
            .map(|&(_, sent)| sent)
            .find(|sent| is(sent) && since <= sent.at)
            .map(|sent| sent.at)
    }

    /// Gives up on the oldest request if it has waited `limit` or longer at `now`, and
    /// returns it: its answer, if it comes, will be unsolicited.
    pub fn expire(&mut self, now: Instant, limit: Duration) -> Option<(u16, Sent)> {
        let &(id, oldest) = self.outstanding.oldest()?;
        if now.saturating_duration_since(oldest.at) < limit {
            return None;
        }
        self.give_up_on(id).map(|sent| (id, sent))
    }

    /// Gives up on request `id`: its answer, if it comes, will be unsolicited. Unless the
    /// robot passed it over (answered a request written after it), it counts towards
    /// [`SILENT_TIMEOUTS`] and [`SILENT_AFTER`].
    pub fn give_up_on(&mut self, id: u16) -> Option<Sent> {
        let sent = self.outstanding.remove(id)?;
        if self.passed_over(&sent) {
            if self.outstanding.is_empty() {
                self.waiting_since = None;
            }
        } else {
            self.timeouts_in_a_row = self.timeouts_in_a_row.saturating_add(1);
            self.motion_unanswered |= sent.message_type == MessageType::Motion;
        }
        Some(sent)
    }

    /// When the oldest outstanding request will have waited `limit`.
    pub fn expiry(&self, limit: Duration) -> Option<Instant> {
        self.outstanding
            .oldest()
            .map(|(_, sent)| sent.at.saturating_add(limit))
    }

    /// How many requests wait for their answers.
    pub fn outstanding(&self) -> usize {
        self.outstanding.len()
    }

    /// Sends `request` and waits up to `timeout` for its answer; `None` waits as long as
    /// the connection lasts (a 1003 is answered only when the task ends). A late answer is
    /// recognised by its message ID and skipped.
    pub async fn request(
        &mut self,
        request: &Request,
        timeout: Option<Duration>,
    ) -> Result<Response, ClientError> {
        let id = self.send(request).await?;
        let answer = match timeout {
            Some(limit) => match with_timeout(limit, self.answer_to(id)).await {
                Ok(answer) => answer,
                Err(_) => {
                    self.give_up_on(id);
                    Err(ClientError::Timeout)
                }
            },
            None => self.answer_to(id).await,
        };
        answer.and_then(|answer| answer.result)
    }

    /// Encodes and writes one request without waiting for any answer; returns its message
    /// ID. The write is bounded by [`WRITE_TIMEOUT`]: a robot that takes no more bytes
    /// loses the connection rather than hold the caller.
    pub async fn send(&mut self, request: &Request) -> Result<u16, ClientError> {
        if !self.connected {
            return Err(ClientError::NotConnected);
        }
        request.validate().map_err(ClientError::Invalid)?;
        let id = self.ids.next_id();
        let time = self.clock.at(Instant::now());
        let len = frame::encode_with(&mut self.tx, id, |body| {
            request.encode(&time, body).map_err(ClientError::Encode)
        })?;
        let bytes = self.tx.get(..len).unwrap_or_default();
        // No flush: it would wait for the robot's acknowledgement, and the stack sends what
        // is written without it.
        let written = match with_timeout(WRITE_TIMEOUT, self.transport.write_all(bytes)).await {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => Err(ClientError::Io(e.kind())),
            Err(_) => Err(ClientError::WriteTimeout),
        };
        if let Err(e) = written {
            warn!("write failed ({:?}): closing the connection", e);
            self.disconnect().await;
            return Err(e);
        }
        let sent = Sent {
            message_type: request.message_type(),
            command: request.command(),
            at: Instant::now(),
        };
        self.waiting_since.get_or_insert(sent.at);
        if let Some((evicted, _)) = self.outstanding.push(id, sent) {
            debug!("gave up on message {}: too many outstanding", evicted);
        }
        debug!(
            "sent Type {} Command {} as message {}",
            sent.message_type.raw(),
            sent.command,
            id
        );
        Ok(id)
    }

    /// Waits for the next answer to any outstanding request. Frames that answer none are
    /// counted and skipped, so the connection never falls out of step.
    ///
    /// Cancel-safe: dropped while it waits, it loses nothing, so it can race a button in a
    /// `select`. An error means the connection is gone (and closed).
    pub async fn receive(&mut self) -> Result<Answer, ClientError> {
        loop {
            if let Some(answer) = self.next_buffered() {
                return Ok(answer);
            }
            let n = match self.transport.read(self.rx.spare()).await {
                Ok(0) => Err(ClientError::Closed),
                Ok(n) => Ok(n),
                Err(e) => Err(ClientError::Io(e.kind())),
            };
            match n {
                Ok(n) => {
                    // Any bytes show the robot alive, even the start of a large answer; but
                    // once a request was given up on unanswered, only an answer does: a
                    // robot that sends keep-alives and answers nothing is silent all the same.
                    if self.waiting_since.is_some() && self.timeouts_in_a_row == 0 {
                        self.waiting_since = Some(Instant::now());
                    }
                    self.rx.commit(n);
                }
                Err(e) => {
                    self.disconnect().await;
                    return Err(e);
                }
            }
        }
    }

    /// Waits for the answer to message `id`, written with [`Connection::send`], as long as the
    /// connection lasts; answers to other requests are dropped.
    pub async fn answer(&mut self, id: u16) -> Result<Response, ClientError> {
        self.answer_to(id).await.and_then(|answer| answer.result)
    }

    /// Waits for the answer to message `id`; answers to other requests are dropped (their
    /// callers gave up on them).
    async fn answer_to(&mut self, id: u16) -> Result<Answer, ClientError> {
        loop {
            let answer = self.receive().await?;
            if answer.message_id == id {
                return Ok(answer);
            }
        }
    }

    /// The next answer among the frames already received, if any.
    fn next_buffered(&mut self) -> Option<Answer> {
        while let Some(item) = self.rx.decode() {
            let frame = match item {
                Ok(frame) => frame,
                Err(e) => {
                    if let Some(count) = count_one(&mut self.anomalies.stream_errors) {
                        warn!(
                            "skipped bytes on the connection: {:?} ({} so far)",
                            e, count
                        );
                    }
                    continue;
                }
            };
            // A frame with no body answers nothing: a server may send one to keep the
            // connection alive, with any message ID. Taken as an answer, it would fail the
            // request whose ID it carries, and the real answer after it would be dropped.
            if frame.asdu.is_empty() {
                if let Some(count) = count_one(&mut self.anomalies.empty_frames) {
                    warn!("skipped a frame with no body ({} so far)", count);
                }
                continue;
            }
            let decoded = Response::decode(frame.asdu);
            let request_error = matches!(
                decoded,
                Ok(Decoded {
                    message: Response::RequestError(_),
                    ..
                })
            );
            // A frame with a request's message ID but another Type is no answer to it (a
            // robot's own report that reuses the ID, say): taken for one, it would end a
            // navigation task's wait, and the task with the connection.
            // (One of a Type unknown here is that answer's error, as documented.)
            let answers = |sent: &Sent| match &decoded {
                Ok(decoded) => decoded.message.answers(sent.message_type),
                Err(_) => true,
            };
            let Some((message_id, request)) =
                self.outstanding
                    .answer_if(frame.message_id, request_error, answers)
            else {
                if let Some(count) = count_one(&mut self.anomalies.unsolicited) {
                    warn!(
                        "skipped a frame for message {} ({} so far)",
                        frame.message_id, count
                    );
                }
                continue;
            };
            // The message ID pairs them: a robot that echoes another Command (its template's
            // 1, say) has still answered, and taking it for silent would hold motion back
            // and drop the connection of a robot that answers everything.
            if !request_error
                && let Ok(decoded) = &decoded
                && decoded.message.command() != request.command
            {
                self.anomalies
                    .count_other_command(&request, decoded.message.command());
            }
            self.timeouts_in_a_row = 0;
            self.motion_unanswered = false;
            let now = Instant::now();
            self.waiting_since = (!self.outstanding.is_empty()).then_some(now);
            self.answered = true;
            // An answer within half the wait would have come within the shorter one; several
            // in a row halve it.
            if now.saturating_duration_since(request.at) < self.request_timeout() / 2 {
                self.prompt_in_a_row += 1;
                if self.prompt_in_a_row >= PROMPT_ANSWERS {
                    self.prompt_in_a_row = 0;
                    self.doublings = self.doublings.saturating_sub(1);
                }
            } else {
                self.prompt_in_a_row = 0;
            }
            self.answered_up_to = self.answered_up_to.max(Some(request.at));
            let result = match decoded {
                Ok(decoded) => {
                    if !decoded.unreadable.is_empty()
                        && let Some(count) = count_one(&mut self.anomalies.unreadable_items)
                    {
                        warn!(
                            "the robot wrote {} in a form that cannot be read, taken as \
                             not reported ({} answers so far)",
                            decoded.unreadable, count
                        );
                    }
                    self.clock.learn(decoded.time, Instant::now());
                    match decoded.message {
                        Response::RequestError(error) => Err(ClientError::RequestError(error.code)),
                        answer => Ok(answer),
                    }
                }
                Err(DecodeError::UnknownType(t)) => Err(ClientError::UnknownType(t)),
                Err(other) => Err(ClientError::Decode(other)),
            };
            return Some(Answer {
                message_id,
                request,
                result,
            });
        }
        None
    }

    /// 1002: the robot's real-time status.
    pub async fn status(&mut self, timeout: Duration) -> Result<RobotStatus, ClientError> {
        match self.request(&Request::Status, Some(timeout)).await? {
            Response::Status(status) => Ok(status),
            other => Err(unexpected(MessageType::Status, &other)),
        }
    }

    /// 2001: battery.
    pub async fn battery(&mut self, timeout: Duration) -> Result<Battery, ClientError> {
        match self.request(&Request::Battery, Some(timeout)).await? {
            Response::Battery(battery) => Ok(battery),
            other => Err(unexpected(MessageType::Battery, &other)),
        }
    }

    /// 2002: obstacle on the planned path.
    pub async fn perception(&mut self, timeout: Duration) -> Result<Perception, ClientError> {
        match self.request(&Request::Perception, Some(timeout)).await? {
            Response::Perception(perception) => Ok(perception),
            other => Err(unexpected(MessageType::Perception, &other)),
        }
    }

    /// 1008: motor temperatures.
    pub async fn motor_temperatures(
        &mut self,
        timeout: Duration,
    ) -> Result<MotorTemperatures, ClientError> {
        match self
            .request(&Request::MotorTemperatures, Some(timeout))
            .await?
        {
            Response::MotorTemperatures(t) => Ok(t),
            other => Err(unexpected(MessageType::MotorTemperatures, &other)),
        }
    }

    /// 1007: the navigation task's state. Send it on a different connection from the
    /// one waiting for a 1003 answer (docs/protocol.md, "Type 1007: navigation task status").
    pub async fn nav_status(&mut self, timeout: Duration) -> Result<NavTaskState, ClientError> {
        match self.request(&Request::NavStatus, Some(timeout)).await? {
            Response::NavStatus(state) => Ok(state),
            other => Err(unexpected(MessageType::NavStatus, &other)),
        }
    }

    /// 2: a motion command; the answer says whether the robot carried it out.
    pub async fn motion(
        &mut self,
        command: MotionCommand,
        timeout: Duration,
    ) -> Result<MotionAck, ClientError> {
        match self
            .request(&Request::Motion(command), Some(timeout))
            .await?
        {
            Response::Motion(_, ack) => Ok(ack),
            other => Err(unexpected(MessageType::Motion, &other)),
        }
    }

    /// 1101: the robot's indicator light.
    pub async fn light(
        &mut self,
        light: Light,
        timeout: Duration,
    ) -> Result<CommandAck, ClientError> {
        match self.request(&Request::Light(light), Some(timeout)).await? {
            Response::Light(ack) => Ok(ack),
            other => Err(unexpected(MessageType::Light, &other)),
        }
    }

    /// 1004: cancels the navigation task. The cancelled task's 1003 answer arrives first,
    /// on the connection that sent the 1003.
    pub async fn cancel_navigation(
        &mut self,
        timeout: Duration,
    ) -> Result<CommandAck, ClientError> {
        match self.request(&Request::CancelNav, Some(timeout)).await? {
            Response::CancelNav(ack) => Ok(ack),
            other => Err(unexpected(MessageType::CancelNav, &other)),
        }
    }

    /// 2101: relocalises the robot at a pose.
    pub async fn relocalize(
        &mut self,
        pose: Relocalize,
        timeout: Duration,
    ) -> Result<RelocalizeAck, ClientError> {
        match self
            .request(&Request::Relocalize(pose), Some(timeout))
            .await?
        {
            Response::Relocalize(ack) => Ok(ack),
            other => Err(unexpected(MessageType::Relocalize, &other)),
        }
    }

    /// 1003: runs a navigation task and waits for its end, up to `timeout` or, with `None`,
    /// as long as the connection lasts. Use a connection of its own: the robot answers only when
    /// the task ends, and stops the task if this connection drops (ErrorStatus 41802).
    pub async fn navigate(
        &mut self,
        task: &NavTask,
        timeout: Option<Duration>,
    ) -> Result<NavResult, ClientError> {
        match self
            .request(&Request::NavTask(task.clone()), timeout)
            .await?
        {
            Response::NavResult(result) => Ok(result),
            other => Err(unexpected(MessageType::NavTask, &other)),
        }
    }
}

fn unexpected(expected: MessageType, got: &Response) -> ClientError {
    ClientError::UnexpectedAnswer {
        expected,
        got: got.message_type(),
    }
}

/// Counts one more anomaly of a kind in `counter`, and returns the new count if this one is
/// logged: the first, the second, the fourth and so on. A robot that pushes junk all the
/// time would otherwise flood the log, and on a board whose log output blocks (QEMU's
/// semihosting) take the CPU from the stop paths; the [`Anomalies`] counts keep the total.
fn count_one(counter: &mut u32) -> Option<u32> {
    *counter = counter.saturating_add(1);
    counter.is_power_of_two().then_some(*counter)
}
