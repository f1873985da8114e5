//! One connection to the robot: framing, message IDs, timeouts, reconnection.

use embassy_time::{Duration, Instant, with_timeout};
use embedded_io_async::{Error as _, ErrorKind, Read, Write};

use super::{Backoff, ClientError, RobotClock};
use crate::proto::codes::MessageType;
use crate::proto::frame::{self, FrameDecoder, FrameError, MessageIds};
use crate::proto::message::{
    Battery, CommandAck, Light, MotionAck, MotionCommand, MotorTemperatures, NavResult, NavTask,
    NavTaskState, Perception, Relocalize, RelocalizeAck, Request, Response, RobotStatus,
};

/// Frame buffer for answers: the largest, a real robot's 1002 answer with its extra items,
/// is about 1.2 KiB.
pub const RX_BUF: usize = 2048;
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
}

/// What went by on a connection that was not an answer to the request in hand.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Anomalies {
    /// Frames whose message ID matched no pending request (late or unsolicited answers).
    pub unsolicited: u32,
    /// Stream errors the frame decoder skipped past: garbage, bad headers, oversized frames.
    pub stream_errors: u32,
}

/// A request/response connection to the robot: sends one request at a time and waits for
/// the answer with the same message ID.
///
/// Errors say whether the connection survived ([`ClientError::connection_usable`]); when it
/// did not, the link closes the transport and [`Link::connect`] must succeed before the
/// next request.
pub struct Link<T: Transport> {
    transport: T,
    connected: bool,
    rx: FrameDecoder<RX_BUF>,
    tx: [u8; TX_BUF],
    ids: MessageIds,
    clock: RobotClock,
    backoff: Backoff,
    anomalies: Anomalies,
}

impl<T: Transport> Link<T> {
    /// A link over `transport`, not yet connected, retrying with `backoff`.
    pub fn new(transport: T, backoff: Backoff) -> Self {
        Self {
            transport,
            connected: false,
            rx: FrameDecoder::new(),
            tx: [0; TX_BUF],
            ids: MessageIds::new(),
            clock: RobotClock::new(),
            backoff,
            anomalies: Anomalies::default(),
        }
    }

    /// Whether the connection is open.
    pub fn is_connected(&self) -> bool {
        self.connected
    }

    /// The robot's clock as learned from this link's answers.
    pub fn clock(&self) -> RobotClock {
        self.clock
    }

    /// Adopts a clock learned elsewhere (the navigation link learns little by itself).
    pub fn set_clock(&mut self, clock: RobotClock) {
        self.clock = clock;
    }

    /// What went by that was not an answer, since the link was made.
    pub fn anomalies(&self) -> Anomalies {
        self.anomalies
    }

    /// Makes one attempt to open the connection. On failure returns how long to wait
    /// before the next attempt, growing exponentially up to the backoff's maximum.
    pub async fn connect(&mut self) -> Result<(), Duration> {
        self.disconnect().await;
        match self.transport.connect().await {
            Ok(()) => {
                self.connected = true;
                self.backoff.reset();
                info!("connected to the robot");
                Ok(())
            }
            Err(kind) => {
                let retry_in = self.backoff.next_delay();
                warn!(
                    "connection failed ({:?}); retrying in {} ms",
                    kind,
                    retry_in.as_millis()
                );
                Err(retry_in)
            }
        }
    }

    /// Closes the connection and forgets any partial answer.
    pub async fn disconnect(&mut self) {
        if self.connected {
            self.transport.close().await;
            self.connected = false;
        }
        self.rx.clear();
    }

    /// Sends `request` and waits up to `timeout` for its answer; `None` waits as long as
    /// the connection lasts (a 1003 is answered only when the task ends).
    pub async fn request(
        &mut self,
        request: &Request,
        timeout: Option<Duration>,
    ) -> Result<Response, ClientError> {
        if !self.connected {
            return Err(ClientError::NotConnected);
        }
        let id = self.send(request).await?;
        let answer = match timeout {
            Some(limit) => with_timeout(limit, self.answer(id))
                .await
                .unwrap_or(Err(ClientError::Timeout)),
            None => self.answer(id).await,
        };
        if let Err(e) = &answer
            && !e.connection_usable()
        {
            self.disconnect().await;
        }
        let answer = answer?;
        let expected = request.message_type();
        match answer {
            Response::RequestError(error) => Err(ClientError::RequestError(error.code)),
            _ if answer.message_type() != expected => Err(ClientError::UnexpectedAnswer {
                expected,
                got: answer.message_type(),
            }),
            _ => Ok(answer),
        }
    }

    /// Encodes and writes one request; returns its message ID.
    async fn send(&mut self, request: &Request) -> Result<u16, ClientError> {
        let id = self.ids.next_id();
        let time = self.clock.at(Instant::now());
        let len = frame::encode_with(&mut self.tx, id, |body| {
            request.encode(&time, body).map_err(ClientError::Encode)
        })?;
        let bytes = self.tx.get(..len).unwrap_or_default();
        let written = match self.transport.write_all(bytes).await {
            Ok(()) => self.transport.flush().await,
            Err(e) => Err(e),
        };
        if let Err(e) = written {
            self.disconnect().await;
            return Err(ClientError::Io(e.kind()));
        }
        debug!(
            "sent Type {} Command {} as message {}",
            request.message_type().raw(),
            request.command(),
            id
        );
        Ok(id)
    }

    /// Reads frames until the one answering message `id`; other frames are counted and
    /// skipped, so the connection never falls out of step.
    async fn answer(&mut self, id: u16) -> Result<Response, ClientError> {
        loop {
            while let Some(item) = self.rx.decode() {
                match item {
                    Ok(frame) if frame.message_id == id => {
                        let decoded = Response::decode(frame.asdu).map_err(|e| match e {
                            crate::proto::message::DecodeError::UnknownType(t) => {
                                ClientError::UnknownType(t)
                            }
                            other => ClientError::Decode(other),
                        })?;
                        self.clock.learn(decoded.time, Instant::now());
                        return Ok(decoded.message);
                    }
                    Ok(frame) => {
                        self.anomalies.unsolicited = self.anomalies.unsolicited.saturating_add(1);
                        warn!("skipped a frame for message {}", frame.message_id);
                    }
                    Err(e) => {
                        self.anomalies.stream_errors =
                            self.anomalies.stream_errors.saturating_add(1);
                        log_stream_error(e);
                    }
                }
            }
            let spare = self.rx.spare();
            let n = self
                .transport
                .read(spare)
                .await
                .map_err(|e| ClientError::Io(e.kind()))?;
            if n == 0 {
                return Err(ClientError::Closed);
            }
            self.rx.commit(n);
        }
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
    /// one waiting for a 1003 answer (SPEC §4.4).
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
    /// as long as the connection lasts. Use a link of its own: the robot answers only when
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

fn log_stream_error(e: FrameError) {
    warn!("skipped bytes on the connection: {:?}", e);
}
