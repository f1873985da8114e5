//! `move`: a translation or rotation held for a while, then zero velocity.
//!
//! The robot keeps moving only while the command is repeated at 3-5 Hz, so it is sent
//! every 250 ms. Send times are computed from the start on a monotonic clock
//! (`start + k x 250 ms`), not by sleeping 250 ms after each answer, so answer latency
//! does not make the rate drift; ticks missed behind a slow answer are skipped, never
//! sent in a burst. Whatever happens (the duration ends, Ctrl-C, an error), zero velocity
//! (Command 6) is sent before exiting, on a fresh connection if the old one failed.

use std::thread;
use std::time::{Duration, Instant};

use x30_panel::proto::codes::MotionCommandCode;
use x30_panel::proto::message::{MotionCommand, Request};

use crate::cli::MoveArgs;
use crate::conn::Connection;
use crate::error::Error;
use crate::render::{self, emit, note};
use crate::{Ctx, Interrupts};

/// Time between repeats: 4 Hz, inside the document's 3-5 Hz.
pub const PERIOD: Duration = Duration::from_millis(250);

/// Longest sleep between Ctrl-C checks.
const SLEEP_SLICE: Duration = Duration::from_millis(20);

/// How one `move` ended before zero velocity was sent.
enum Ended {
    /// The duration passed.
    Done,
    /// An error; zero velocity must still be sent.
    Failed(Error),
    /// Ctrl-C.
    Interrupted,
}

/// Runs `move`.
pub fn run(ctx: &Ctx, args: &MoveArgs, interrupts: &Interrupts) -> Result<(), Error> {
    let command = args.command();
    let request = Request::Motion(command);
    if let (Some(max), Some(speed)) = (command.speed_limit(), args.speed)
        && request.validate().is_err()
    {
        let unit = match command.code() {
            MotionCommandCode::TurnLeft | MotionCommandCode::TurnRight => "rad/s",
            _ => "m/s",
        };
        return Err(Error::Usage(format!(
            "move {}: speed {speed} {unit} out of range: -1 (the robot's default) or 0..={max} {unit} allowed; nothing sent",
            command.code().description()
        )));
    }
    crate::validate(&request, &format!("move {}", command.code().description()))?;
    let duration = Duration::try_from_secs_f64(args.duration)
        .ok()
        .filter(|d| !d.is_zero())
        .ok_or_else(|| {
            Error::Usage(format!(
                "move: --duration {} is not a positive number of seconds; nothing sent",
                args.duration
            ))
        })?;

    // Only an absurd duration (centuries) overflows the clock; refuse it rather than panic.
    if duration
        .checked_mul(2)
        .and_then(|d| Instant::now().checked_add(d))
        .is_none()
    {
        return Err(Error::Usage(format!(
            "move: --duration {} is too long; nothing sent",
            args.duration
        )));
    }

    let mut conn = Some(ctx.connect()?);
    let start = Instant::now();
    let end = start.checked_add(duration).unwrap_or(start);
    let mut acknowledged = 0u32;
    let mut tick = 0u32;
    let ended = loop {
        let Some(due) = PERIOD.checked_mul(tick).and_then(|t| start.checked_add(t)) else {
            break Ended::Done;
        };
        if due >= end {
            // Let the last command run out its period before stopping.
            if !sleep_until(end, interrupts) {
                break Ended::Interrupted;
            }
            break Ended::Done;
        }
        if !sleep_until(due, interrupts) {
            break Ended::Interrupted;
        }
        let Some(c) = conn.as_mut() else {
            break Ended::Done;
        };
        // Ctrl-C must not wait for a slow answer: zero velocity is what matters then.
        match c.request_unless(&request, || interrupts.count() > 0) {
            Ok(None) => break Ended::Interrupted,
            Ok(Some(answer)) => {
                if ctx.json {
                    emit(&answer.json());
                }
                if let Some(message) = render::failure("move", &answer.response) {
                    break Ended::Failed(Error::Failed(message));
                }
                acknowledged += 1;
            }
            Err(e) => {
                if !e.keeps_connection() {
                    conn = None;
                }
                break Ended::Failed(e);
            }
        }
        // The next tick on the fixed grid that is still ahead, skipping any missed.
        let elapsed = start.elapsed().as_nanos();
        let next = u32::try_from(elapsed / PERIOD.as_nanos() + 1).unwrap_or(u32::MAX);
        tick = next.max(tick + 1);
    };

    let stopped = zero_velocity(ctx, conn);
    if !ctx.json {
        emit(&summary(&command, duration, acknowledged, &stopped));
    }
    let stop_error = stopped.err();
    match ended {
        Ended::Done => stop_error.map_or(Ok(()), Err),
        Ended::Interrupted => Err(Error::Interrupted(format!(
            "move interrupted by Ctrl-C after {acknowledged} command(s); zero velocity {}",
            if stop_error.is_none() {
                "sent"
            } else {
                "could NOT be sent"
            }
        ))),
        Ended::Failed(e) => {
            if let Some(stop_error) = stop_error {
                note(&format!(
                    "x30ctl: zero velocity could not be sent: {stop_error}"
                ));
            }
            Err(e)
        }
    }
}

/// Sends zero velocity, on `conn` if it is still usable, else (or if that fails) on a
/// new connection.
fn zero_velocity(ctx: &Ctx, conn: Option<Connection>) -> Result<(), Error> {
    let request = Request::Motion(MotionCommand::ZeroVelocity);
    let on = |conn: &mut Connection| {
        let answer = conn.request(&request)?;
        if ctx.json {
            emit(&answer.json());
        }
        match render::failure("zero velocity", &answer.response) {
            Some(message) => Err(Error::Failed(message)),
            None => Ok(()),
        }
    };
    if let Some(mut conn) = conn {
        match on(&mut conn) {
            Ok(()) => return Ok(()),
            Err(e @ Error::Failed(_)) => return Err(e),
            Err(e) => note(&format!(
                "x30ctl: zero velocity: {e}; retrying on a new connection"
            )),
        }
    }
    on(&mut ctx.connect()?)
}

/// The human summary of a `move`.
fn summary(
    command: &MotionCommand,
    duration: Duration,
    acknowledged: u32,
    stopped: &Result<(), Error>,
) -> String {
    let value = match command.value() {
        x30_panel::proto::message::MotionValue::Float(v) if v != -1.0 => format!("{v}"),
        _ => "the robot's default".to_owned(),
    };
    format!(
        "{} (Type 2 Command {}) at {value} speed for {} s: {acknowledged} command(s) acknowledged; zero velocity (Command 6) {}",
        command.code().description(),
        command.code().raw(),
        duration.as_secs_f64(),
        match stopped {
            Ok(()) => "acknowledged",
            Err(_) => "FAILED",
        }
    )
}

/// Sleeps until `when`, waking every few ms to look for Ctrl-C; false if it was pressed.
pub fn sleep_until(when: Instant, interrupts: &Interrupts) -> bool {
    loop {
        if interrupts.count() > 0 {
            return false;
        }
        let left = when.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return true;
        }
        thread::sleep(left.min(SLEEP_SLICE));
    }
}
