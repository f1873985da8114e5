//! Each connection's outbox: one thread that writes the connection's answers.
//!
//! Answers reach a connection from several threads: its own reader, another connection's
//! reader (a cancel, a soft emergency stop) and the tick thread (a task that arrived). They
//! all queue an [`Outgoing`] here, so frames never interleave and nobody but this thread
//! waits for delays or slow clients. Every answer is encoded with the protocol core, then
//! altered and written as the faults in force at that moment say.
//!
//! Answers wait in arrival order until their delay ([`Faults::delay_for`]) has expired, and
//! the connection's [`Faults::warm_up`]; of those due, the earliest queued is written
//! first. So without per-Type delays answers go out in the order they were queued, and with
//! them a slow Type holds up no other.

use std::io::{self, Write};
use std::net::{Shutdown, TcpStream};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant};

use x30_panel::proto::frame::{self, HEADER_LEN};
use x30_panel::proto::message::Response;
use x30_panel::proto::time::Timestamp;

use crate::clock;
use crate::faults::{self, Faults, MERGED_ID_OFFSET};
use crate::server::{Shared, lock};

/// Gap between the chunks of a split answer.
pub const SPLIT_GAP: Duration = Duration::from_millis(1);

/// How often a waiting outbox looks whether the simulator is shutting down.
const POLL: Duration = Duration::from_millis(50);

/// Room for one encoded answer body; the longest (1002 with every float at its longest) is
/// well under 2 KiB.
const BODY_CAPACITY: usize = 8192;

/// Answers to put on the wire together, in one write.
#[derive(Debug)]
pub struct Outgoing {
    /// Message ID and answer of each frame, in the order they are written.
    pub frames: Vec<(u16, Response)>,
    /// When the request arrived (or the task ended); the delays count from here.
    pub since: Instant,
    /// Queued on another connection once these answers are written or given up; held for
    /// its `Drop`, which does the queueing.
    _follow_up: Option<FollowUp>,
}

impl Outgoing {
    /// An answer to send as soon as the faults allow.
    pub fn new(message_id: u16, response: Response) -> Self {
        Self {
            frames: vec![(message_id, response)],
            since: Instant::now(),
            _follow_up: None,
        }
    }

    /// The same write with one more answer after the others.
    pub fn and(mut self, message_id: u16, response: Response) -> Self {
        self.frames.push((message_id, response));
        self
    }

    /// The same write, followed by `next` on another connection's outbox.
    pub fn then(self, outbox: Sender<Outgoing>, next: Outgoing) -> Self {
        Self {
            _follow_up: Some(FollowUp {
                outbox,
                next: Some(Box::new(next)),
            }),
            ..self
        }
    }

    /// When the faults let it be written: the longest delay of its answers' Types.
    fn due(&self, faults: &Faults) -> Instant {
        let delay = self
            .frames
            .iter()
            .map(|(_, r)| faults.delay_for(r.message_type().raw()))
            .max()
            .unwrap_or(faults.delay);
        faults::after(self.since, delay)
    }
}

/// An answer that must leave right after another connection's: a cancel's 1004 answer
/// after the cancelled task's 1003 answer.
///
/// It is queued when dropped, that is once the answer carrying it has been written, or
/// discarded, or its connection has gone; so the later answer is never lost and never
/// waits longer than the earlier one's write.
#[derive(Debug)]
pub struct FollowUp {
    outbox: Sender<Outgoing>,
    next: Option<Box<Outgoing>>,
}

impl Drop for FollowUp {
    fn drop(&mut self) {
        if let Some(next) = self.next.take() {
            // The other connection may have closed meanwhile: then nobody waits for it.
            let _ = self.outbox.send(*next);
        }
    }
}

/// Writes the answers queued for one connection until the queue has closed (its reader
/// has ended) and nothing is left, a write fails, or the simulator shuts down.
pub(crate) fn run(shared: Arc<Shared>, mut stream: TcpStream, queue: Receiver<Outgoing>) {
    let opened = Instant::now();
    // What each write of a flood puts on the wire, made once for the connection.
    let flood = faults::flood_bytes();
    let mut waiting: Vec<Outgoing> = Vec::new();
    let mut open = true;
    while (open || !waiting.is_empty()) && !shared.is_shutting_down() {
        let faults = shared.faults();
        let now = Instant::now();
        let warmed_up = faults::after(opened, faults.warm_up);
        let due = |o: &Outgoing| o.due(&faults).max(warmed_up);
        if let Some(i) = waiting.iter().position(|o| due(o) <= now) {
            let outgoing = waiting.remove(i);
            if !faults.mute && send(&shared, &mut stream, &outgoing, &faults).is_err() {
                return;
            }
            if faults.hang_up_after_answer {
                // The reader sees the connection end too, and stops.
                let _ = stream.shutdown(Shutdown::Both);
                return;
            }
            continue;
        }
        let next_due = waiting.iter().map(due).min();
        let mut wait = next_due.map_or(POLL, |due| due.saturating_duration_since(now).min(POLL));
        if faults.flood {
            // Blocks while the client's window is full: as fast as it reads, no faster.
            if write(&shared, &mut stream, &flood, None).is_err() {
                return;
            }
            wait = Duration::ZERO;
        }
        if !open {
            std::thread::sleep(wait);
            continue;
        }
        match queue.recv_timeout(wait) {
            Ok(outgoing) => waiting.push(outgoing),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => open = false,
        }
    }
}

/// Encodes and writes one [`Outgoing`].
fn send(
    shared: &Shared,
    stream: &mut TcpStream,
    outgoing: &Outgoing,
    faults: &Faults,
) -> io::Result<()> {
    let bytes = wire_bytes(shared, outgoing, faults);
    write(shared, stream, &bytes, faults.split)
}

/// Everything one write puts on the wire.
fn wire_bytes(shared: &Shared, outgoing: &Outgoing, faults: &Faults) -> Vec<u8> {
    let mut frames = Vec::with_capacity(2 * outgoing.frames.len());
    for (id, response) in &outgoing.frames {
        frames.extend(encode_frame(*id, response, faults));
        if faults.merge {
            let status = lock(&shared.robot).status();
            let id = id.wrapping_add(MERGED_ID_OFFSET);
            frames.extend(encode_frame(id, &Response::Status(status), faults));
        }
    }
    faults::wire_bytes(&frames, faults)
}

/// Encodes one answer frame with the protocol core, then alters its body and header as the
/// faults say.
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
    faults::alter_header(&mut frame, faults);
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
