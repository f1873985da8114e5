//! The robot_server client: connections, requests and their answers.
//!
//! Generic over `embedded_io_async::{Read, Write}`: the firmware runs it over an embassy-net
//! `TcpSocket`, host tests over a tokio `TcpStream` through `embedded-io-adapters`. It knows
//! connections — message IDs, timeouts, Type 0 answers, reconnection, the wall-clock `Time`
//! field — and never decides what to send; that is the panel's job.
//!
//! The panel keeps three [`Connection`]s, as the protocol document advises for requests
//! that must not wait on each other: one for commands, written without waiting for earlier
//! answers (so a stop never waits), one for the state queries, and one that carries a 1003
//! and stays open until its answer, because the robot stops a task whose connection drops
//! (ErrorStatus 41802).

mod backoff;
mod clock;
mod connection;

pub use backoff::Backoff;
pub use clock::RobotClock;
pub use connection::{
    ANSWER_OVERDUE, Anomalies, Answer, Connection, Health, MAX_DOUBLINGS, MAX_OUTSTANDING,
    PROMPT_ANSWERS, REQUEST_TIMEOUT, RX_BUF, SILENT_AFTER, SILENT_TIMEOUTS, STABLE_AFTER, Sent,
    TX_BUF, Transport, WRITE_TIMEOUT,
};
pub use embedded_io_async::ErrorKind;

use crate::proto::codes::{MessageType, RequestErrorCode};
use crate::proto::message::{DecodeError, ValidationError};
use crate::proto::xml::writer::WriteError;

/// Why a request got no usable answer. [`ClientError::connection_usable`] says whether the
/// connection is still open for the next request.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ClientError {
    /// The connection is not open; nothing was sent.
    NotConnected,
    /// The transport failed; the connection is closed.
    Io(ErrorKind),
    /// The robot closed the connection before answering; the connection is closed.
    Closed,
    /// The robot took no more bytes within [`WRITE_TIMEOUT`] (its receive window stayed
    /// closed); the connection is closed, so that a stop never waits behind it.
    WriteTimeout,
    /// No answer in time. The connection stays open: a late answer is recognised by its
    /// message ID and skipped.
    Timeout,
    /// The request could not be encoded; nothing was sent. The connection stays open.
    Encode(WriteError),
    /// The request breaks the protocol document's rules, or is a command beyond V1.0.12
    /// without the `vendor-extensions` feature; nothing was sent. The connection stays open.
    Invalid(ValidationError),
    /// The robot answered with Type 0: it could not read the request. The connection
    /// stays open.
    RequestError(RequestErrorCode),
    /// The answer carried a Type this protocol version does not define. The connection
    /// stays open.
    UnknownType(i32),
    /// The answer's body could not be decoded. The connection stays open.
    Decode(DecodeError),
    /// The answer is of another Type than the request. [`Connection`] passes such frames
    /// over as no answer, so only a caller holding an answer it did not expect makes this.
    /// The connection stays open.
    UnexpectedAnswer {
        /// The request's Type.
        expected: MessageType,
        /// The answer's Type.
        got: MessageType,
    },
}

impl ClientError {
    /// Whether the connection is still open after this error.
    pub fn connection_usable(&self) -> bool {
        !matches!(
            self,
            Self::NotConnected | Self::Io(_) | Self::Closed | Self::WriteTimeout
        )
    }
}

/// A frame that does not fit the connection's send buffer is a request too large to encode.
impl From<crate::proto::frame::EncodeError> for ClientError {
    fn from(_: crate::proto::frame::EncodeError) -> Self {
        Self::Encode(WriteError::BufferFull)
    }
}
