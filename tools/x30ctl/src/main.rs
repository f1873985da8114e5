//! `x30ctl`: a command-line client for the DEEP Robotics Jueying X30 robot_server
//! (TCP port 30000, protocol V1.0.12).
//!
//! Every request of the protocol has a subcommand; answers are printed human-readable or,
//! with `--json`, as one JSON object per answer. All encoding and decoding is done by the
//! `x30-panel` protocol core; this crate adds the sockets, the command line and the output.
//! Exit statuses are listed in `--help` and in [`error`].

mod cli;
mod conn;
mod decode_cmd;
mod error;
mod estop_cmd;
mod move_cmd;
mod nav_cmd;
mod render;
mod route;
mod watch_cmd;

use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use clap::Parser;
use x30_panel::proto::message::{Light, MotionCommand, Relocalize, Request};

use cli::{Cli, Command};
use conn::{Answer, Connection};
use error::Error;
use render::{emit, note};

/// What every command needs: where the robot is, the timeouts, and the output format.
#[derive(Debug, Clone)]
pub struct Ctx {
    /// `HOST:PORT` as given.
    pub robot: String,
    /// TCP connect timeout.
    pub connect_timeout: Duration,
    /// Wait for each answer.
    pub timeout: Duration,
    /// JSON output.
    pub json: bool,
}

impl Ctx {
    /// A new connection to the robot.
    pub fn connect(&self) -> Result<Connection, Error> {
        Connection::connect(&self.robot, self.connect_timeout, self.timeout)
    }

    /// A new connection to the robot, unless Ctrl-C was pressed by the time it is made: a
    /// connect may take up to `--connect-timeout-ms`, and what the caller writes on it must
    /// not go out after the operator asked to stop. `what` names what is then not sent.
    pub fn connect_unless_interrupted(
        &self,
        interrupts: &Interrupts,
        what: &str,
    ) -> Result<Connection, Error> {
        let conn = self.connect()?;
        if interrupts.count() > 0 {
            return Err(Error::Interrupted(format!(
                "interrupted by Ctrl-C while connecting: {what} not sent"
            )));
        }
        Ok(conn)
    }

    /// The connection in `conn`, unless there is none or the robot has closed it (a robot
    /// that hangs up after each answer): then a new one, which takes its place.
    pub fn reuse<'c>(&self, conn: &'c mut Option<Connection>) -> Result<&'c mut Connection, Error> {
        let kept = conn
            .take()
            .and_then(|mut c| (!c.closed_by_robot()).then_some(c));
        match kept {
            Some(c) => Ok(conn.insert(c)),
            None => Ok(conn.insert(self.connect()?)),
        }
    }

    /// Asks `request` on `conn`, connecting first if needed. A connection that had
    /// answered before and is found closed before this answer (a robot that hangs up after
    /// each answer, whose close may come just after the check [`Ctx::reuse`] makes, or one
    /// that restarted meanwhile) is replaced by a new one, and the request asked once more
    /// there: for queries, which change nothing on the robot.
    pub fn ask(&self, conn: &mut Option<Connection>, request: &Request) -> Result<Answer, Error> {
        if let Some(c) = conn.as_mut() {
            match c.request(request) {
                Err(Error::Closed { .. }) => {}
                answered => return answered,
            }
        }
        conn.insert(self.connect()?).request(request)
    }

    /// Prints an answer in the chosen format.
    pub fn print(&self, answer: &Answer) {
        if self.json {
            emit(&answer.json());
        } else {
            emit(&render::response_text(&answer.response));
        }
    }
}

/// Counts Ctrl-C presses; commands that must clean up (nav, move, route run) poll it.
#[derive(Debug, Clone, Default)]
pub struct Interrupts(Arc<AtomicUsize>);

impl Interrupts {
    /// Installs the Ctrl-C handler. Until this is called, Ctrl-C ends the process at once,
    /// which is right for commands with nothing to clean up.
    fn install() -> Result<Self, Error> {
        let interrupts = Self::default();
        let counter = Arc::clone(&interrupts.0);
        ctrlc::set_handler(move || {
            counter.fetch_add(1, Ordering::SeqCst);
        })
        .map_err(|e| Error::Usage(format!("cannot install the Ctrl-C handler: {e}")))?;
        Ok(interrupts)
    }

    /// How many times Ctrl-C was pressed.
    pub fn count(&self) -> usize {
        self.0.load(Ordering::SeqCst)
    }

    /// A count as if Ctrl-C had been pressed `times` times, for tests.
    #[cfg(test)]
    pub fn pressed(times: usize) -> Self {
        Self(Arc::new(AtomicUsize::new(times)))
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // clap prints help and version to stdout with status 0, usage errors to
            // stderr with status 2.
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(error::EXIT_USAGE));
        }
    };
    let ctx = Ctx {
        robot: cli.robot.clone(),
        connect_timeout: Duration::from_millis(cli.connect_timeout_ms),
        timeout: Duration::from_millis(cli.timeout_ms),
        json: cli.json,
    };
    match run(&ctx, &cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            note(&format!("x30ctl: {e}"));
            ExitCode::from(e.exit_code())
        }
    }
}

/// Runs one subcommand.
fn run(ctx: &Ctx, command: &Command) -> Result<(), Error> {
    match command {
        Command::Status => simple(ctx, &Request::Status, "status"),
        Command::Battery => simple(ctx, &Request::Battery, "battery"),
        Command::Obstacle => simple(ctx, &Request::Perception, "obstacle"),
        Command::Motors => simple(ctx, &Request::MotorTemperatures, "motors"),
        Command::NavStatus => simple(ctx, &Request::NavStatus, "nav-status"),
        Command::Cancel => simple(ctx, &Request::CancelNav, "cancel"),
        Command::Stop => motion(ctx, MotionCommand::ZeroVelocity, "stop"),
        Command::Estop => estop_cmd::run(ctx, &Interrupts::install()?),
        Command::StopStepping => motion(ctx, MotionCommand::StopStepping, "stop-stepping"),
        Command::LieDown => motion(ctx, MotionCommand::LieDown, "lie-down"),
        Command::Gait { gait } => motion(ctx, MotionCommand::SwitchGait((*gait).into()), "gait"),
        Command::Light(args) => {
            let light = Light {
                red: args.red,
                green: args.green,
                blue: args.blue,
                effect: args.effect.into(),
                brightness: args.brightness,
            };
            simple(ctx, &Request::Light(light), "light")
        }
        Command::Relocalize(args) => {
            let pose = Relocalize {
                pos_x: args.x,
                pos_y: args.y,
                pos_z: args.z,
                yaw: args.yaw,
            };
            simple(ctx, &Request::Relocalize(pose), "relocalize")
        }
        Command::Nav(args) => nav_cmd::run(ctx, args, &Interrupts::install()?),
        Command::Move(args) => move_cmd::run(ctx, args, &Interrupts::install()?),
        Command::Watch(args) => watch_cmd::run(ctx, args),
        Command::Decode(args) => decode_cmd::run(ctx, args),
        Command::Route(args) => route::run(ctx, args),
    }
}

/// Validates a request, sends it on a new connection, prints the answer, and turns a
/// failed `ErrorCode` into an error named after `what`.
fn simple(ctx: &Ctx, request: &Request, what: &str) -> Result<(), Error> {
    validate(request, what)?;
    let answer = ctx.connect()?.request(request)?;
    ctx.print(&answer);
    match render::failure(what, &answer.response) {
        Some(message) => Err(Error::Failed(message)),
        None => Ok(()),
    }
}

/// A one-shot Type 2 command.
fn motion(ctx: &Ctx, command: MotionCommand, what: &str) -> Result<(), Error> {
    simple(ctx, &Request::Motion(command), what)
}

/// A number of seconds given on the command line (`option` of command `what`) as a duration;
/// zero, negative, not a number, under a nanosecond or past what a `Duration` holds is a
/// usage error that says which.
pub fn seconds_arg(what: &str, option: &str, seconds: f64) -> Result<Duration, Error> {
    let problem = match Duration::try_from_secs_f64(seconds) {
        _ if seconds.is_nan() || seconds <= 0.0 => "is not a positive number of seconds",
        Ok(duration) if duration.is_zero() => "is under a nanosecond",
        Ok(duration) => return Ok(duration),
        Err(_) => "is too long",
    };
    Err(Error::Usage(format!(
        "{what}: {option} {} {problem}; nothing sent",
        shown_seconds(seconds)
    )))
}

/// A number of seconds as a usage error shows it: huge ones in exponent form (1e300, not its
/// 301 digits).
pub fn shown_seconds(seconds: f64) -> String {
    if seconds.abs() >= 1e15 {
        format!("{seconds:e}")
    } else {
        seconds.to_string()
    }
}

/// Checks a request against the document's rules before anything is sent.
pub fn validate(request: &Request, what: &str) -> Result<(), Error> {
    request.validate().map_err(|e| {
        Error::Usage(format!(
            "{what}: {}; nothing sent",
            render::validation_error_text(&e)
        ))
    })
}
