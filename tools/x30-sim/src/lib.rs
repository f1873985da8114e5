//! `x30-sim`: a simulator of the DEEP Robotics Jueying X30's `robot_server` (TCP, protocol
//! V1.0.12), for testing clients such as the x30-panel firmware and `x30ctl` without a robot.
//!
//! One simulated [`Robot`] answers every Type of the protocol to any number of concurrent
//! connections: motion control with the robot's motion states, navigation tasks that answer
//! only when the walk ends, cancelling, task status, battery, perception, light, motor
//! temperatures and relocalisation. Malformed input gets the robot's Type 0 answers, and
//! [`Faults`] make answers slow, split, merged, garbled, unexpected or missing, refuse
//! connections or emergency stops, as real robots and networks do. Every frame received is
//! logged ([`LogEntry`]).
//!
//! All encoding and decoding is the protocol core's (`x30_panel::proto`): the simulator
//! decodes requests and encodes answers with the same code the panel uses the other way
//! round. Faults only alter the bytes the core produced.
//!
//! # Example
//!
//! ```
//! use std::io::{Read, Write};
//! use std::net::TcpStream;
//! use std::time::Duration;
//! use x30_panel::proto::frame::{self, FrameDecoder};
//! use x30_panel::proto::message::{Request, Response};
//! use x30_panel::proto::time::Timestamp;
//!
//! let sim = x30_sim::Simulator::start(x30_sim::Config {
//!     listen: "127.0.0.1:0".parse()?,
//!     time_scale: 10.0,
//!     ..Default::default()
//! })?;
//! // Read and change the simulated state.
//! sim.robot(|r| {
//!     r.set_battery(42.0);
//!     r.set_obstacle(true);
//! });
//! assert_eq!(sim.snapshot().motion_state.raw(), 3);
//!
//! // Ask for the status as a client does: frame a 1002 request, read the answer.
//! let mut body = [0; 512];
//! // (The core's error types are no_std enums without `std::error::Error`, hence `expect`.)
//! let n = Request::Status.encode(&Timestamp::DOCUMENT_EPOCH, &mut body).expect("fits");
//! let mut out = [0; 528];
//! let n = frame::encode(&mut out, 1, &body[..n]).expect("fits");
//! let mut stream = TcpStream::connect(sim.addr())?;
//! stream.set_read_timeout(Some(Duration::from_secs(5)))?;
//! stream.write_all(&out[..n])?;
//! let mut decoder = FrameDecoder::<4096>::new();
//! let answer = loop {
//!     let n = stream.read(decoder.spare())?;
//!     assert!(n > 0, "connection closed");
//!     decoder.commit(n);
//!     if let Some(Ok(frame)) = decoder.decode() {
//!         break Response::decode(frame.asdu).expect("a valid answer").message;
//!     }
//! };
//! assert!(matches!(answer, Response::Status(s) if s.electricity == Some(42)));
//!
//! // Make answers slow from now on, and see what clients sent.
//! sim.set_faults(x30_sim::Faults {
//!     delay: Duration::from_millis(200),
//!     ..Default::default()
//! });
//! let log: Vec<x30_sim::LogEntry> = sim.requests();
//! assert_eq!(log[0].message_type, Some(1002));
//!
//! sim.drop_connections(); // close every client connection now
//! drop(sim); // stops the listener and every thread
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Behaviour in brief
//!
//! - Time: the robot's time runs at real time × [`Config::time_scale`] for everything
//!   physical (walking, navigation, battery, temperatures, lying down). The manual-motion
//!   watchdog ([`robot::MOTION_TIMEOUT`], 400 ms) runs in real time: it watches the
//!   client's sending rate.
//! - Motion (Type 2): see [`Robot`] for the motion states; translations and rotations
//!   continue while repeated and stop when a gap between repeats exceeds 400 ms (the
//!   protocol asks for at least 3 Hz) or on Command 6.
//! - Navigation (1003): the waypoints of a request (one per `<Items>` block) are walked in
//!   order; answered once, when the walk ends (distance / speed), or at once when refused,
//!   with the last waypoint's `Value` on success and the one the robot was walking to on
//!   failure or cancel. 1007 reports the waypoint being walked to; the log records each
//!   waypoint set out for ([`TaskEntry`]). 1004 sends the task's answer (ErrorCode 2, 8962)
//!   on the task's connection, then at once its own answer: both frames in one write when
//!   the task and the cancel came on the same connection. A dropped task connection stops
//!   the task (41802).
//! - Battery (2001): `Current` is positive while discharging, negative while charging.
//! - Malformed input: Type 0 with ErrorCode 1 (bytes without a sync sequence), 2 (reserved
//!   bytes not zero), 3 (longer than the longest valid request) or 4 (body not a valid
//!   request, unknown Type included), the frame's message ID when its header was read (0
//!   for bytes without a header) and the time `0000-00-00 00:00:00`; the connection stays
//!   usable. A run of bytes without a sync sequence is answered once, when the next sync
//!   sequence arrives or after [`NO_SYNC_QUIET`] without a byte, whichever is first, so a
//!   client that writes a bare XML document gets its answer.
//! - Every answer is written with its own `write` call (unless a fault says otherwise, or
//!   it is a cancel's pair of answers), because existing clients read one frame per read.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod clock;
pub mod faults;
mod log;
mod outbox;
pub mod robot;
mod server;
mod unsynced;

use std::io;
use std::net::{SocketAddr, TcpListener};
use std::path::PathBuf;
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

pub use faults::{Declaration, Faults};
pub use log::{LogEntry, MEMORY_LIMIT, TaskEntry};
pub use outbox::{SPLIT_GAP, encode_frame};
pub use robot::{Pose, Robot, Snapshot, TaskEvent};
pub use server::TICK;
pub use unsynced::NO_SYNC_QUIET;

use log::RequestLog;
use server::Shared;

/// The address the simulator listens on unless told otherwise: the robot's port, on
/// loopback only.
pub const DEFAULT_LISTEN: SocketAddr =
    SocketAddr::new(std::net::IpAddr::V4(std::net::Ipv4Addr::LOCALHOST), 30000);

/// Longest [`Simulator`]'s drop waits for its threads; a thread still busy then (a client
/// that stopped reading) ends by itself shortly after.
pub const SHUTDOWN_LIMIT: Duration = Duration::from_secs(2);

/// How to start a simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Address to listen on; port 0 picks a free one ([`Simulator::addr`] tells which).
    pub listen: SocketAddr,
    /// How many times faster than real time the robot's time runs (10: a 10 s walk takes
    /// 1 s). Must be positive and finite.
    pub time_scale: f64,
    /// Faults from the start; change them later with [`Simulator::set_faults`].
    pub faults: Faults,
    /// Also write the request log to this file, as JSON lines (created or truncated).
    pub log_file: Option<PathBuf>,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            listen: DEFAULT_LISTEN,
            time_scale: 1.0,
            faults: Faults::default(),
            log_file: None,
        }
    }
}

/// A running simulator: a listening socket, the simulated robot, and the threads that serve
/// it. Dropping it closes every connection and stops every thread.
#[derive(Debug)]
pub struct Simulator {
    shared: Arc<Shared>,
    addr: SocketAddr,
    listener: Option<JoinHandle<()>>,
    ticker: Option<JoinHandle<()>>,
}

impl Simulator {
    /// Binds the listening socket and starts serving.
    ///
    /// Fails if the address cannot be bound, the log file cannot be created, or the time
    /// scale is not a positive finite number.
    pub fn start(config: Config) -> io::Result<Self> {
        if !(config.time_scale.is_finite() && config.time_scale > 0.0) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "time scale must be positive and finite, not {}",
                    config.time_scale
                ),
            ));
        }
        let log = RequestLog::open(config.log_file.as_deref())?;
        let listener = TcpListener::bind(config.listen)?;
        let addr = listener.local_addr()?;
        // The listener polls so that it can notice a shutdown.
        listener.set_nonblocking(true)?;
        let robot = Robot::new(config.time_scale);
        let mut sim = Self {
            shared: Arc::new(Shared::new(robot, config.faults, log)),
            addr,
            listener: None,
            ticker: None,
        };
        // On failure `sim` is dropped, which stops whatever did start.
        let shared = Arc::clone(&sim.shared);
        sim.listener = Some(
            thread::Builder::new()
                .name("x30-sim-listen".into())
                .spawn(move || server::listen(shared, listener))?,
        );
        let shared = Arc::clone(&sim.shared);
        sim.ticker = Some(
            thread::Builder::new()
                .name("x30-sim-tick".into())
                .spawn(move || server::tick(shared))?,
        );
        Ok(sim)
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Runs `f` on the robot, brought up to now, and returns what it returns. Use it to read
    /// or change the simulated state; answers of tasks that `f` made end are sent at once.
    pub fn robot<R>(&self, f: impl FnOnce(&mut Robot) -> R) -> R {
        self.shared.with_robot(|robot, _| f(robot))
    }

    /// The robot's state now.
    pub fn snapshot(&self) -> Snapshot {
        self.robot(|r| r.snapshot())
    }

    /// The faults in force.
    pub fn faults(&self) -> Faults {
        self.shared.faults()
    }

    /// Replaces the faults; answers written from now on follow them.
    pub fn set_faults(&self, faults: Faults) {
        self.shared.set_faults(faults);
    }

    /// Changes some of the faults.
    pub fn update_faults(&self, f: impl FnOnce(&mut Faults)) {
        let mut faults = self.faults();
        f(&mut faults);
        self.set_faults(faults);
    }

    /// Closes every open connection and refuses new ones for `duration` from now
    /// ([`Faults::refuse_connections_until`]).
    pub fn refuse_connections(&self, duration: Duration) {
        let until = faults::after(Instant::now(), duration);
        self.update_faults(|f| f.refuse_connections_until = Some(until));
    }

    /// Stops reading every open connection, leaving them open, as a `robot_server` whose
    /// client handlers hung ([`Faults::hang_at`]); connections opened later are served.
    pub fn hang_open_connections(&self) {
        self.update_faults(|f| f.hang_at = Some(Instant::now()));
    }

    /// Every frame clients have sent (the last [`MEMORY_LIMIT`]), oldest first.
    pub fn requests(&self) -> Vec<LogEntry> {
        self.shared.log.entries()
    }

    /// The first frame of the connection that carried the first frame `which` accepts: what
    /// a client sent first on, say, the connection it opened after an outage.
    pub fn first_on_connection_of(&self, which: impl Fn(&LogEntry) -> bool) -> Option<LogEntry> {
        let log = self.requests();
        let conn = log.iter().find(|e| which(e))?.conn;
        log.into_iter().find(|e| e.conn == conn)
    }

    /// What navigation tasks did (the last [`MEMORY_LIMIT`]), oldest first: each waypoint
    /// set out for and how each task ended. The log file has these lines too.
    pub fn task_log(&self) -> Vec<TaskEntry> {
        self.shared.log.task_entries()
    }

    /// Forgets the frames and task progress logged in memory so far (the log file keeps
    /// them).
    pub fn clear_requests(&self) {
        self.shared.log.clear();
    }

    /// Number of client connections open now.
    pub fn connections(&self) -> usize {
        self.shared.connection_count()
    }

    /// Closes every open client connection now. A running navigation task whose connection
    /// is among them stops (41802). New connections are accepted as before.
    pub fn drop_connections(&self) {
        self.shared.drop_connections();
    }

    /// Real time since the simulator started (the `t` of log entries).
    pub fn elapsed(&self) -> Duration {
        self.shared.now()
    }
}

impl Drop for Simulator {
    fn drop(&mut self) {
        self.shared.begin_shutdown();
        let deadline = Instant::now() + SHUTDOWN_LIMIT;
        for handle in [self.listener.take(), self.ticker.take()]
            .into_iter()
            .flatten()
        {
            server::join_until(handle, deadline);
        }
        // After the listener has stopped, no new connection threads can appear.
        self.shared.drop_connections();
        self.shared.join_connection_threads(deadline);
    }
}
