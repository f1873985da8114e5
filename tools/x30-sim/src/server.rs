//! The TCP side: the listener, the tick thread, and one reader thread per connection.
//!
//! Threads and what they own:
//! - the listener accepts connections and starts a reader and an outbox for each;
//! - the tick thread moves the robot on at 50 Hz and sends the answers of tasks that ended;
//! - a connection's reader decodes frames, logs them, asks the robot, and queues answers
//!   (it also answers bytes without a sync sequence that no frame follows, see
//!   [`crate::unsynced`]);
//! - a connection's outbox ([`crate::outbox`]) writes them.
//!
//! All of them share one [`Shared`]. No thread holds two of its locks at once, so they
//! cannot deadlock; every blocking call has a timeout so that shutdown is prompt.

use std::collections::HashMap;
use std::io::{self, ErrorKind, Read};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Sender};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use x30_panel::proto::codes::RequestErrorCode;
use x30_panel::proto::frame::{FrameDecoder, FrameError, HEADER_LEN};
use x30_panel::proto::message::{MAX_REQUEST_LEN, MotionCommand, Request, RequestError, Response};
use x30_panel::proto::xml::{StructureError, read_document};

use crate::faults::Faults;
use crate::log::{LogEntry, RequestLog};
use crate::outbox::{self, Outgoing};
use crate::robot::{self, ConnId, EndedTask, Reply, Requester, Robot};
use crate::unsynced::{Event, Unsynced};

/// How often the robot is moved on when nobody asks it anything.
pub const TICK: Duration = Duration::from_millis(20);

/// How often an idle listener looks for a connection (it polls so it can stop).
const ACCEPT_POLL: Duration = Duration::from_millis(5);

/// Longest a reader blocks in `read` before looking whether the simulator is shutting down.
const READ_POLL: Duration = Duration::from_millis(100);

/// Shortest read timeout (zero would mean none at all).
const MIN_READ_WAIT: Duration = Duration::from_millis(1);

/// Size of each connection's frame decoder: room for the longest valid request.
const DECODER_LEN: usize = HEADER_LEN + MAX_REQUEST_LEN;

/// The frame decoder of each connection.
type Decoder = FrameDecoder<DECODER_LEN>;

/// Locks a mutex, carrying on with the data if another thread panicked while holding it
/// (the simulator's state stays usable; nothing here leaves it half-changed).
pub(crate) fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// An open connection, as other threads see it.
#[derive(Debug)]
struct ConnHandle {
    /// Its outbox.
    outbox: Sender<Outgoing>,
    /// A handle to close it with.
    stream: TcpStream,
}

/// State shared by every thread of one simulator.
#[derive(Debug)]
pub(crate) struct Shared {
    /// When the simulator started: the origin of the robot's time and of log times.
    pub start: Instant,
    /// The one robot every connection talks to.
    pub robot: Mutex<Robot>,
    faults: Mutex<Faults>,
    /// Every frame received.
    pub log: RequestLog,
    conns: Mutex<HashMap<ConnId, ConnHandle>>,
    next_conn: AtomicU64,
    shutdown: AtomicBool,
    /// Connection threads, joined on shutdown.
    threads: Mutex<Vec<JoinHandle<()>>>,
}

impl Shared {
    /// State for a simulator whose robot, faults and log are given.
    pub fn new(robot: Robot, faults: Faults, log: RequestLog) -> Self {
        Self {
            start: Instant::now(),
            robot: Mutex::new(robot),
            faults: Mutex::new(faults),
            log,
            conns: Mutex::new(HashMap::new()),
            next_conn: AtomicU64::new(1),
            shutdown: AtomicBool::new(false),
            threads: Mutex::new(Vec::new()),
        }
    }

    /// Real time since the simulator started.
    pub fn now(&self) -> Duration {
        self.start.elapsed()
    }

    /// The faults in force.
    pub fn faults(&self) -> Faults {
        lock(&self.faults).clone()
    }

    /// Changes the faults in force; refusing connections from now on closes the open ones.
    pub fn set_faults(&self, faults: Faults) {
        let refusing = faults.refuses_connections(Instant::now());
        *lock(&self.faults) = faults;
        if refusing {
            self.drop_connections();
        }
    }

    /// Uses up one of [`Faults::refuse_estops`]; false if none is left.
    pub fn take_estop_refusal(&self) -> bool {
        let mut faults = lock(&self.faults);
        let refuse = faults.refuse_estops > 0;
        faults.refuse_estops = faults.refuse_estops.saturating_sub(1);
        refuse
    }

    /// Whether new connections wait in the backlog: [`Faults::one_at_a_time`], and one is
    /// open. Reads the one field, not a copy of every fault: the listener asks this every
    /// [`ACCEPT_POLL`].
    fn holds_new_connections(&self) -> bool {
        self.connection_count() > 0 && lock(&self.faults).one_at_a_time
    }

    /// Whether a connection opened at `opened` is hung now ([`Faults::hang_at`]). Reads the
    /// one field, not a copy of every fault: each connection asks this before each read.
    fn hangs(&self, opened: Instant) -> bool {
        lock(&self.faults).hangs(opened, Instant::now())
    }

    /// Whether the simulator is shutting down.
    pub fn is_shutting_down(&self) -> bool {
        self.shutdown.load(Ordering::SeqCst)
    }

    /// Tells every thread to stop and closes every connection.
    pub fn begin_shutdown(&self) {
        self.shutdown.store(true, Ordering::SeqCst);
        self.drop_connections();
    }

    /// Brings the robot up to now, runs `f` on it, and sends the answers of any tasks that
    /// ended meanwhile and logs what tasks did (after letting go of the robot).
    pub fn with_robot<R>(&self, f: impl FnOnce(&mut Robot, Duration) -> R) -> R {
        let now = self.now();
        let (result, ended, events) = {
            let mut robot = lock(&self.robot);
            robot.advance(now);
            let result = f(&mut robot, now);
            (result, robot.take_ended(), robot.take_task_events())
        };
        for event in events {
            self.log.record_task(event.into());
        }
        self.deliver(ended);
        result
    }

    /// Queues ended tasks' answers on their connections (gone connections are skipped).
    fn deliver(&self, ended: Vec<EndedTask>) {
        for task in ended {
            self.send_to(task.owner.conn, task_answer(&task));
        }
    }

    /// Queues an answer on a connection. If the connection is gone the answer is dropped,
    /// which still queues its follow-up ([`outbox::FollowUp`]).
    fn send_to(&self, conn: ConnId, outgoing: Outgoing) {
        let outbox = lock(&self.conns).get(&conn).map(|c| c.outbox.clone());
        if let Some(outbox) = outbox {
            let _ = outbox.send(outgoing);
        }
    }

    /// Closes every open connection now; their readers notice and clean up.
    pub fn drop_connections(&self) {
        for handle in lock(&self.conns).values() {
            let _ = handle.stream.shutdown(Shutdown::Both);
        }
    }

    /// Number of open connections.
    pub fn connection_count(&self) -> usize {
        lock(&self.conns).len()
    }

    /// Starts a named thread that is joined on shutdown.
    fn spawn(&self, name: &str, f: impl FnOnce() + Send + 'static) -> io::Result<()> {
        let handle = thread::Builder::new().name(name.into()).spawn(f)?;
        let mut threads = lock(&self.threads);
        // Forget threads that have ended, so a long run does not collect handles.
        threads.retain(|t| !t.is_finished());
        threads.push(handle);
        Ok(())
    }

    /// Waits until `deadline` at most for the connection threads to end.
    pub fn join_connection_threads(&self, deadline: Instant) {
        let threads = std::mem::take(&mut *lock(&self.threads));
        for handle in threads {
            join_until(handle, deadline);
        }
    }
}

/// Joins a thread if it ends before `deadline`; otherwise leaves it to end by itself.
pub(crate) fn join_until(handle: JoinHandle<()>, deadline: Instant) {
    while !handle.is_finished() && Instant::now() < deadline {
        thread::sleep(Duration::from_millis(2));
    }
    if handle.is_finished() {
        let _ = handle.join();
    }
}

/// Accepts connections until shutdown. The listener must be non-blocking.
pub(crate) fn listen(shared: Arc<Shared>, listener: TcpListener) {
    while !shared.is_shutting_down() {
        if shared.holds_new_connections() {
            // Left in the backlog until the open connection closes.
            thread::sleep(ACCEPT_POLL);
            continue;
        }
        match listener.accept() {
            Ok((stream, _)) => {
                // A connection that cannot be set up is dropped; the next one may work.
                let _ = open_connection(&shared, stream);
            }
            // Nothing waiting, or a transient failure (out of descriptors): try again soon.
            Err(_) => thread::sleep(ACCEPT_POLL),
        }
    }
}

/// Moves the robot on every [`TICK`] until shutdown.
pub(crate) fn tick(shared: Arc<Shared>) {
    while !shared.is_shutting_down() {
        thread::sleep(TICK);
        shared.with_robot(|_, _| ());
    }
}

/// The answer to send for a navigation task that has ended.
fn task_answer(task: &EndedTask) -> Outgoing {
    Outgoing::new(task.owner.message_id, Response::NavResult(task.result))
}

/// Registers a new connection and starts its outbox and reader, unless connections are
/// refused: then it is closed without a byte read.
fn open_connection(shared: &Arc<Shared>, stream: TcpStream) -> io::Result<()> {
    // Accepted sockets may inherit the listener's non-blocking mode on some platforms.
    stream.set_nonblocking(false)?;
    // Each answer (or chunk) must leave as written, not coalesced with the next.
    stream.set_nodelay(true)?;
    let conn = shared.next_conn.fetch_add(1, Ordering::SeqCst);
    let (outbox, queue) = mpsc::channel();
    let writer = stream.try_clone()?;
    let handle = ConnHandle {
        outbox: outbox.clone(),
        stream: stream.try_clone()?,
    };
    lock(&shared.conns).insert(conn, handle);
    // Looked at once registered: a refusal starting meanwhile either finds this connection
    // to close, or is seen here. Returning drops (closes) every handle to the socket. (The
    // listener opens one connection at a time, so the count is this one's and those before.)
    let faults = shared.faults();
    let over_limit = faults
        .max_connections
        .is_some_and(|max| shared.connection_count() > max);
    if faults.refuses_connections(Instant::now()) || over_limit {
        lock(&shared.conns).remove(&conn);
        return Ok(());
    }
    if faults.newest_only {
        for (_, handle) in lock(&shared.conns).iter().filter(|(id, _)| **id != conn) {
            let _ = handle.stream.shutdown(Shutdown::Both);
        }
    }
    let started = {
        let shared_w = Arc::clone(shared);
        let shared_r = Arc::clone(shared);
        shared
            .spawn(&format!("x30-sim-out-{conn}"), move || {
                outbox::run(shared_w, writer, queue)
            })
            .and_then(|()| {
                shared.spawn(&format!("x30-sim-conn-{conn}"), move || {
                    Connection::new(shared_r, stream, conn, outbox).serve()
                })
            })
    };
    if started.is_err() {
        lock(&shared.conns).remove(&conn);
    }
    started
}

/// A frame as the robot understood it.
enum Received {
    /// A request to answer (boxed: a 1003 request with its waypoints is large).
    Request { id: u16, request: Box<Request> },
    /// Something to answer with Type 0 and this code.
    Invalid { id: u16, code: RequestErrorCode },
}

/// Whether a connection goes on after an event.
#[derive(Debug, PartialEq, Eq)]
enum Flow {
    Continue,
    Close,
}

/// One client connection, as its reader thread sees it.
struct Connection {
    shared: Arc<Shared>,
    stream: TcpStream,
    conn: ConnId,
    outbox: Sender<Outgoing>,
    /// When it opened, for [`Faults::hang_at`].
    opened: Instant,
    /// Frames received so far, for [`Faults::drop_after`].
    received: u64,
    /// Bytes without a sync sequence not answered yet.
    unsynced: Unsynced,
}

impl Connection {
    fn new(shared: Arc<Shared>, stream: TcpStream, conn: ConnId, outbox: Sender<Outgoing>) -> Self {
        Self {
            shared,
            stream,
            conn,
            outbox,
            opened: Instant::now(),
            received: 0,
            unsynced: Unsynced::new(Instant::now(), Decoder::MAX_ASDU),
        }
    }

    /// Reads and answers frames until the client leaves, a fault closes the connection, or
    /// the simulator shuts down; then tells the robot the connection is gone.
    fn serve(mut self) {
        let mut decoder = Box::new(Decoder::new());
        while !self.shared.is_shutting_down() {
            if self.read(&mut decoder) == Flow::Close {
                break;
            }
            if self.answer_received(&mut decoder) == Flow::Close {
                let _ = self.stream.shutdown(Shutdown::Both);
                break;
            }
        }
        let conn = self.conn;
        self.shared
            .with_robot(|robot, now| robot.connection_closed(conn, now));
        lock(&self.shared.conns).remove(&conn);
    }

    /// Reads what has arrived into the decoder, waiting no longer than until bytes without
    /// a sync sequence are due an answer; `Close` when the client has gone.
    fn read(&mut self, decoder: &mut Decoder) -> Flow {
        if self.shared.hangs(self.opened) {
            // Hung: nothing more is read here, and the connection stays open.
            std::thread::sleep(READ_POLL);
            return Flow::Continue;
        }
        let spare = decoder.spare();
        if spare.is_empty() {
            // The decoder promises room while a frame is incomplete; never spin if not.
            self.unsynced.on_cleared(DECODER_LEN);
            decoder.clear();
            return Flow::Continue;
        }
        let held = DECODER_LEN - spare.len();
        let wait = self
            .unsynced
            .wait(held, Instant::now())
            .map_or(READ_POLL, |w| w.clamp(MIN_READ_WAIT, READ_POLL));
        if self.stream.set_read_timeout(Some(wait)).is_err() {
            return Flow::Close;
        }
        match (&self.stream).read(spare) {
            Ok(0) => Flow::Close,
            // What arrived while the read waited into a hang was never read.
            Ok(_) if self.shared.hangs(self.opened) => Flow::Continue,
            Ok(n) => {
                decoder.commit(n);
                self.unsynced.on_read(n, Instant::now());
                Flow::Continue
            }
            Err(e) if is_retry(&e) => Flow::Continue,
            Err(_) => Flow::Close,
        }
    }

    /// Answers every frame the decoder has, then bytes without a sync sequence that have
    /// gone quiet; `Close` if a fault closes the connection.
    fn answer_received(&mut self, decoder: &mut Decoder) -> Flow {
        while let Some(event) = decoder.decode() {
            // Owned, so the decoder's buffer is free again while the robot is asked.
            let event = event.map(|f| (f.message_id, f.asdu.to_vec()));
            let Some(event) = self.unsynced.filter(event) else {
                continue;
            };
            if self.on_event(event) == Flow::Close {
                return Flow::Close;
            }
        }
        let held = DECODER_LEN - decoder.spare().len();
        match self.unsynced.take_due(held, Instant::now()) {
            Some(skipped) => self.on_event(Err(FrameError::Garbage { skipped })),
            None => Flow::Continue,
        }
    }

    /// Logs one frame or stream error, then acts on it and answers it unless muted.
    fn on_event(&mut self, event: Event) -> Flow {
        let (entry, received) = self.classify(event);
        self.shared.log.record(entry);
        self.received = self.received.saturating_add(1);
        let faults = self.shared.faults();
        let hang_up = match &received {
            Received::Request { request, .. } => {
                faults.hang_up_on.contains(&request.message_type().raw())
            }
            Received::Invalid { .. } => false,
        };
        if hang_up
            || faults
                .drop_after
                .is_some_and(|limit| self.received >= limit)
        {
            return Flow::Close;
        }
        if faults.mute {
            // A half-open robot: it hears the request but does nothing about it.
            return Flow::Continue;
        }
        match received {
            Received::Request { id, request } => self.handle(id, &request),
            Received::Invalid { id, code } => {
                self.answer(id, Response::RequestError(RequestError { code }))
            }
        }
        Flow::Continue
    }

    /// What an event amounts to, with its log entry.
    fn classify(&self, event: Event) -> (LogEntry, Received) {
        let t = self.shared.now().as_secs_f64();
        let conn = self.conn;
        let (id, asdu) = match event {
            Ok(frame) => frame,
            Err(error) => {
                let (code, id) = match error {
                    FrameError::BadReserved { message_id } => {
                        (RequestErrorCode::HeaderWrong, Some(message_id))
                    }
                    FrameError::TooLong { message_id, .. }
                    | FrameError::CutShort { message_id, .. } => {
                        (RequestErrorCode::LengthAbnormal, Some(message_id))
                    }
                    _ => (RequestErrorCode::HeaderMissing, None),
                };
                let entry = LogEntry::failure(t, conn, id, None, format!("frame: {error:?}"));
                // Bytes without a header have no message ID: answer with 0.
                let id = id.unwrap_or(0);
                return (entry, Received::Invalid { id, code });
            }
        };
        match Request::decode(&asdu) {
            Ok(decoded) => (
                LogEntry::request(t, conn, id, &decoded.message),
                Received::Request {
                    id,
                    request: Box::new(decoded.message),
                },
            ),
            Err(error) => {
                let error = format!("decode: {error:?}");
                (
                    LogEntry::failure(t, conn, Some(id), envelope(&asdu), error),
                    Received::Invalid {
                        id,
                        code: RequestErrorCode::ParseFailed,
                    },
                )
            }
        }
    }

    /// Asks the robot and queues what it says; a soft emergency stop may be refused first
    /// ([`Faults::refuse_estops`]), without the robot hearing of it.
    fn handle(&self, message_id: u16, request: &Request) {
        if let Request::Motion(command @ MotionCommand::SoftEmergencyStop) = request
            && self.shared.take_estop_refusal()
        {
            self.answer(message_id, robot::motion_answer(command, false));
            return;
        }
        let from = Requester {
            conn: self.conn,
            message_id,
        };
        match self
            .shared
            .with_robot(|robot, now| robot.handle(request, from, now))
        {
            Reply::Now(response) => self.answer(message_id, response),
            Reply::Later => {}
            Reply::AfterTask { task, answer } => self.answer_after_task(&task, message_id, answer),
        }
    }

    /// Sends a cancelled task's answer, then the cancel's: in one write when both go to
    /// this connection, as the robot does; otherwise the cancel's as soon as the task's has
    /// been written on its own connection.
    fn answer_after_task(&self, task: &EndedTask, message_id: u16, answer: Response) {
        if task.owner.conn == self.conn {
            let _ = self.outbox.send(task_answer(task).and(message_id, answer));
        } else {
            let cancel = Outgoing::new(message_id, answer);
            let first = task_answer(task).then(self.outbox.clone(), cancel);
            self.shared.send_to(task.owner.conn, first);
        }
    }

    fn answer(&self, message_id: u16, response: Response) {
        // Fails only if the outbox has ended (the connection is closing): nothing to do.
        let _ = self.outbox.send(Outgoing::new(message_id, response));
    }
}

/// Type and Command of a body that did not decode as a request, if its XML got that far.
fn envelope(asdu: &[u8]) -> Option<(i32, i32)> {
    read_document(asdu, |_, _| Ok::<(), StructureError>(()))
        .ok()
        .map(|(e, _)| (e.message_type, e.command))
}

/// Whether a read error only means "nothing yet".
fn is_retry(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
    )
}
