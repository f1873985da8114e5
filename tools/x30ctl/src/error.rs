//! Every way a command can fail, with the exit status and the message each one gets.

use std::fmt;
use std::io;
use std::time::Duration;

use x30_panel::proto::codes::RequestErrorCode;

/// Exit status: the robot reported a failure.
pub const EXIT_ROBOT_FAILURE: u8 = 1;
/// Exit status: usage or validation error; nothing was sent.
pub const EXIT_USAGE: u8 = 2;
/// Exit status: connection, timeout or protocol error.
pub const EXIT_CONNECTION: u8 = 3;
/// Exit status: interrupted by Ctrl-C (after cleaning up).
pub const EXIT_INTERRUPTED: u8 = 130;

/// Why a command failed. `Display` gives the one-line message printed on stderr.
#[derive(Debug)]
pub enum Error {
    /// Bad options or values; nothing was sent.
    Usage(String),
    /// The robot's address does not resolve.
    Resolve {
        /// The address as given.
        addr: String,
        /// Why.
        source: io::Error,
    },
    /// The TCP connection could not be established.
    Connect {
        /// The address as given.
        addr: String,
        /// Why.
        source: io::Error,
        /// The connect timeout, named when it expired.
        timeout: Duration,
    },
    /// No answer within the allowed time.
    Timeout {
        /// How long was waited.
        waited: Duration,
        /// The Type of the request.
        message_type: i32,
    },
    /// The robot closed (or reset) the connection while an answer was awaited.
    Closed {
        /// The Type of the request.
        message_type: i32,
        /// The reset error, when it was not an orderly close.
        source: Option<io::Error>,
    },
    /// Sending or receiving failed otherwise.
    Io {
        /// What was being done.
        context: String,
        /// Why.
        source: io::Error,
    },
    /// The robot answered Type 0: it could not read the request.
    TypeZero {
        /// The robot's ErrorCode.
        code: RequestErrorCode,
        /// The Type of the request it refused.
        message_type: i32,
    },
    /// The answer (matched by message ID) could not be decoded, or was too long to read.
    BadAnswer {
        /// The Type of the request.
        message_type: i32,
        /// The answer's message ID.
        message_id: u16,
        /// What was wrong.
        detail: String,
    },
    /// The robot answered and reported a failure.
    Failed(String),
    /// No status confirmed the soft emergency stop in time, though it was sent again and
    /// again.
    EstopUnconfirmed {
        /// How long it was sent for.
        waited: Duration,
        /// How many times Command 13 went out.
        sent: u32,
    },
    /// Ctrl-C, after the command cleaned up.
    Interrupted(String),
    /// A route stopped before its end.
    RouteStopped {
        /// Where: which point of which loop.
        at: String,
        /// Why; its exit status is the route's.
        cause: Box<Error>,
        /// The command that carries on from there, if anything is left to walk.
        resume: Option<String>,
    },
}

impl Error {
    /// The process exit status for this error.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Usage(_) => EXIT_USAGE,
            Self::Failed(_) => EXIT_ROBOT_FAILURE,
            Self::Interrupted(_) => EXIT_INTERRUPTED,
            Self::RouteStopped { cause, .. } => cause.exit_code(),
            Self::Resolve { .. }
            | Self::Connect { .. }
            | Self::Timeout { .. }
            | Self::EstopUnconfirmed { .. }
            | Self::Closed { .. }
            | Self::Io { .. }
            | Self::TypeZero { .. }
            | Self::BadAnswer { .. } => EXIT_CONNECTION,
        }
    }

    /// Whether the connection this error came from is still usable for another request.
    ///
    /// After a timeout the late answer may still arrive; it would be skipped by its
    /// message ID, but a fresh connection is simpler to reason about, so only errors that
    /// consumed a whole, well-formed answer keep the connection.
    pub fn keeps_connection(&self) -> bool {
        matches!(self, Self::Failed(_) | Self::Usage(_))
    }
}

/// An I/O error's text without the ` (os error N)` suffix, which says nothing to a user.
pub fn io_text(e: &io::Error) -> String {
    let text = e.to_string();
    match text.find(" (os error").and_then(|at| text.get(..at)) {
        Some(short) => short.to_owned(),
        None => text,
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Usage(message) | Self::Failed(message) | Self::Interrupted(message) => {
                f.write_str(message)
            }
            Self::Resolve { addr, source } => {
                write!(
                    f,
                    "cannot resolve robot address {addr}: {}",
                    io_text(source)
                )
            }
            Self::Connect {
                addr,
                source,
                timeout,
            } => {
                if matches!(
                    source.kind(),
                    io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                ) {
                    write!(
                        f,
                        "connection to {addr} failed: timed out after {} ms",
                        timeout.as_millis()
                    )
                } else {
                    write!(f, "connection to {addr} failed: {}", io_text(source))
                }
            }
            Self::EstopUnconfirmed { waited, sent } => write!(
                f,
                "no status confirmed soft emergency stop (MotionState 6) within {} ms; \
                 Command 13 was sent {sent} time(s)",
                waited.as_millis()
            ),
            Self::Timeout {
                waited,
                message_type,
            } => write!(
                f,
                "timed out after {} ms waiting for the answer to Type {message_type}",
                waited.as_millis()
            ),
            Self::Closed {
                message_type,
                source: None,
            } => write!(
                f,
                "connection closed by the robot before answering Type {message_type}"
            ),
            Self::Closed {
                message_type,
                source: Some(source),
            } => write!(
                f,
                "connection closed by the robot before answering Type {message_type} ({})",
                io_text(source)
            ),
            Self::Io { context, source } => write!(f, "{context}: {}", io_text(source)),
            Self::TypeZero { code, .. } => write!(
                f,
                "robot answered Type 0: ErrorCode {} ({})",
                code.raw(),
                code.description()
            ),
            Self::BadAnswer {
                message_type,
                message_id,
                detail,
            } => write!(
                f,
                "bad answer to Type {message_type} (message ID {message_id}): {detail}"
            ),
            Self::RouteStopped { at, cause, resume } => {
                write!(f, "route stopped at {at}: {cause}")?;
                match resume {
                    Some(command) => write!(f, "; to resume: {command}"),
                    None => Ok(()),
                }
            }
        }
    }
}

impl std::error::Error for Error {}
