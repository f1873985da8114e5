//! Each connection's outbox: one thread that writes the connection's answers in order.
//!
//! Answers reach a connection from several threads: its own reader, another connection's
//! reader (a cancel, a soft emergency stop) and the tick thread (a task that arrived). They
//! all queue an [`Outgoing`] here, so frames never interleave and nobody but this thread
//! waits for delays or slow clients. Every answer is encoded with the protocol core, then
//! altered and written as the faults in force at that moment say.

use std::io::{self, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant};

use x30_panel::proto::frame::{self, HEADER_LEN};
use x30_panel::proto::message::Response;
use x30_panel::proto::time::Timestamp;

use crate::clock;
use crate::faults::{self, Faults, MERGED_ID_OFFSET};
use crate::server::{Shared, lock};

/// Gap between a cancelled task's 1003 answer and the 1004 answer that follows it.
pub const CANCEL_GAP: Duration = Duration::from_millis(50);

/// Gap between the chunks of a split answer.
pub const SPLIT_GAP: Duration = Duration::from_millis(1);

/// Longest wait for another connection to write the answer this one must follow; past it
/// the answer is written anyway rather than never.
const ORDER_WAIT_LIMIT: Duration = Duration::from_secs(2);

/// How often a waiting outbox looks whether the simulator is shutting down.
const POLL: Duration = Duration::from_millis(50);

/// Stands in for a delay too long to add to the clock.
const FOREVER: Duration = Duration::from_secs(365 * 24 * 3600);

/// Room for one encoded answer body; the longest (1002 with every float at its longest) is
/// well under 2 KiB.
const BODY_CAPACITY: usize = 8192;

/// One answer waiting to be written.
#[derive(Debug)]
pub struct Outgoing {
    /// The message ID to answer with.
    pub message_id: u16,
    /// The answer.
    pub response: Response,
    /// When the request arrived (or the task ended); [`Faults::delay`] counts from here.
    pub since: Instant,
    /// Another answer this one must follow: write only after it has been written (or its
    /// outbox has given up), and [`CANCEL_GAP`] after that.
    pub after: Option<Receiver<()>>,
    /// Told once this answer has been written.
    pub written: Option<Sender<()>>,
}

impl Outgoing {
    /// An answer to send as soon as the faults allow.
    pub fn new(message_id: u16, response: Response) -> Self {
        Self {
            message_id,
            response,
            since: Instant::now(),
            after: None,
            written: None,
        }
    }
}

/// Writes the answers queued for one connection until the queue closes (its reader has
/// ended), a write fails, or the simulator shuts down.
pub(crate) fn run(shared: Arc<Shared>, mut stream: TcpStream, queue: Receiver<Outgoing>) {
    loop {
        let outgoing = match queue.recv_timeout(POLL) {
            Ok(outgoing) => outgoing,
            Err(RecvTimeoutError::Timeout) if !shared.is_shutting_down() => continue,
            Err(_) => return,
        };
        let faults = shared.faults();
        // A delay too long for the clock waits until shutdown instead of overflowing.
        let due = outgoing
            .since
            .checked_add(faults.delay)
            .unwrap_or_else(|| Instant::now() + FOREVER);
        if !pause_until(&shared, due) {
            return;
        }
        if let Some(previous) = &outgoing.after {
            // Either a signal or a closed channel (that outbox gave up) lets this one go.
            let _ = previous.recv_timeout(ORDER_WAIT_LIMIT);
            if !pause_until(&shared, Instant::now() + CANCEL_GAP) {
                return;
            }
        }
        let bytes = wire_bytes(&shared, &outgoing, &faults);
        if write(&shared, &mut stream, &bytes, faults.split).is_err() {
            return;
        }
        if let Some(written) = outgoing.written {
            let _ = written.send(());
        }
    }
}

/// Everything one answer puts on the wire.
fn wire_bytes(shared: &Shared, outgoing: &Outgoing, faults: &Faults) -> Vec<u8> {
    let Some(answer) = encode_frame(outgoing.message_id, &outgoing.response, faults) else {
        return Vec::new();
    };
    let extra = if faults.merge {
        let status = lock(&shared.robot).status();
        let id = outgoing.message_id.wrapping_add(MERGED_ID_OFFSET);
        encode_frame(id, &Response::Status(status), faults)
    } else {
        None
    };
    faults::wire_bytes(&answer, extra.as_deref(), faults)
}

/// Encodes one answer frame with the protocol core, then alters its body as the faults say.
///
/// Type 0 answers carry the all-zero time, as the document shows; others the wall clock.
/// `None` only if the core refuses the answer, which the robot's finite values prevent.
pub fn encode_frame(message_id: u16, response: &Response, faults: &Faults) -> Option<Vec<u8>> {
    let time = match response {
        Response::RequestError(_) => Timestamp::ZERO,
        _ => clock::wall_time(),
    };
    let mut body = vec![0; BODY_CAPACITY];
    let len = response.encode(&time, &mut body).ok()?;
    body.truncate(len);
    let body = faults::alter_body(&body, faults);
    let mut frame = vec![0; HEADER_LEN + body.len()];
    let len = frame::encode(&mut frame, message_id, &body).ok()?;
    frame.truncate(len);
    Some(frame)
}

/// Writes `bytes` whole, or in chunks of `split` bytes with [`SPLIT_GAP`] between them;
/// every piece is its own write, flushed.
fn write(
    shared: &Shared,
    stream: &mut TcpStream,
    bytes: &[u8],
    split: Option<usize>,
) -> io::Result<()> {
    let chunk = split.filter(|&n| n > 0).unwrap_or(bytes.len().max(1));
    for (i, piece) in bytes.chunks(chunk).enumerate() {
        if i > 0 && !pause_until(shared, Instant::now() + SPLIT_GAP) {
            return Err(io::ErrorKind::Interrupted.into());
        }
        stream.write_all(piece)?;
        stream.flush()?;
    }
    Ok(())
}

/// Sleeps until `deadline`, waking regularly to look for a shutdown; returns false if the
/// simulator is shutting down.
fn pause_until(shared: &Shared, deadline: Instant) -> bool {
    loop {
        if shared.is_shutting_down() {
            return false;
        }
        let now = Instant::now();
        if now >= deadline {
            return true;
        }
        std::thread::sleep((deadline - now).min(POLL));
    }
}
