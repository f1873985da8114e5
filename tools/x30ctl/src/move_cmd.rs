//! `move`: a translation or rotation held for a while, then zero velocity.
//!
//! The robot keeps moving only while the command is repeated at 3-5 Hz, so it is sent
//! every 250 ms. Send times are computed from the start on a monotonic clock
//! (`start + k x 250 ms`), and no command waits for the previous one's answer: answers are
//! taken in between, so a slow one delays nothing. Like the panel, `move` sends no motion
//! while an answer is overdue (500 ms), rather than drive a robot that may not hear it,
//! and gives up once one is `--timeout-ms` late; ticks missed are skipped, never sent in a
//! burst. Whatever happens (the duration ends, Ctrl-C, an error), zero velocity (Command 6)
//! is sent at once, whatever answers are still due, on a fresh connection if the old one
//! failed or the robot closed it. A robot that hangs up after each answer gets each
//! command on a new connection.

use std::collections::VecDeque;
use std::thread;
use std::time::{Duration, Instant};

use x30_panel::client::ANSWER_OVERDUE;
use x30_panel::proto::codes::{MessageType, MotionCommandCode};
use x30_panel::proto::message::{MotionCommand, Request};

use crate::cli::MoveArgs;
use crate::conn::Connection;
use crate::error::Error;
use crate::render::{self, emit, note, warn};
use crate::{Ctx, Interrupts};

/// Time between repeats: 4 Hz, inside the document's 3-5 Hz.
pub const PERIOD: Duration = Duration::from_millis(250);

/// An answer not in after this long is overdue, and no motion is sent until it is: the
/// panel's rule.
const OVERDUE: Duration = Duration::from_millis(ANSWER_OVERDUE.as_millis());

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
    let duration = crate::seconds_arg("move", "--duration", args.duration)?;

    // Only an absurd duration (centuries) overflows the clock; refuse it rather than panic.
    if duration
        .checked_mul(2)
        .and_then(|d| Instant::now().checked_add(d))
        .is_none()
    {
        return Err(Error::Usage(format!(
            "move: --duration {} is too long; nothing sent",
            crate::shown_seconds(args.duration)
        )));
    }

    let mut conn = Some(ctx.connect()?);
    let start = Instant::now();
    let end = start.checked_add(duration).unwrap_or(start);
    let mut sent = Sent::default();
    let mut tick = 0u32;
    let ended = loop {
        let Some(due) = PERIOD.checked_mul(tick).and_then(|t| start.checked_add(t)) else {
            break Ended::Done;
        };
        let Some(c) = conn.as_mut() else {
            break Ended::Done;
        };
        // Answers are taken while the next command (or the end) is not due yet: a slow
        // answer delays neither, and the last command runs out its period before stopping.
        if let Err(e) = sent.take_answers(ctx, c, due.min(end), interrupts) {
            break failed(&mut conn, e);
        }
        if interrupts.count() > 0 {
            break Ended::Interrupted;
        }
        if due >= end {
            break Ended::Done;
        }
        match sent.oldest_wait() {
            // A robot that answers nothing is not driven for the whole duration.
            Some(waited) if waited >= ctx.timeout => {
                break Ended::Failed(Error::Timeout {
                    waited: ctx.timeout,
                    message_type: request.message_type().raw(),
                });
            }
            // Nor blind: like the panel, no motion while an answer is overdue.
            Some(waited) if waited >= OVERDUE => sent.hold(),
            _ => {
                // With every answer in, a connection the robot closed (a robot that hangs
                // up after each answer) is replaced first: the command would be lost on it.
                let open = if sent.pending.is_empty() {
                    ctx.reuse(&mut conn)
                } else {
                    Ok(c)
                };
                let c = match open {
                    Ok(c) => c,
                    Err(e) => break failed(&mut conn, e),
                };
                // A new connection may have taken up to the connect timeout: a Ctrl-C or the
                // end of the duration meanwhile sends no more motion.
                if interrupts.count() > 0 {
                    break Ended::Interrupted;
                }
                if Instant::now() >= end {
                    break Ended::Done;
                }
                match c.send(&request) {
                    Ok(message_id) => sent.pending.push_back((message_id, Instant::now())),
                    Err(e) => break failed(&mut conn, e),
                }
            }
        }
        // The next tick on the fixed grid that is still ahead, skipping any missed.
        let elapsed = start.elapsed().as_nanos();
        let next = u32::try_from(elapsed / PERIOD.as_nanos() + 1).unwrap_or(u32::MAX);
        tick = next.max(tick + 1);
    };

    // At once, whatever answers are still to come: they are counted after it.
    let stopped = zero_velocity(ctx, &mut conn, interrupts);
    if let Some(c) = conn.as_mut() {
        // A late refusal changes nothing now that the robot is stopped.
        let _ = sent.take_answers(ctx, c, Instant::now(), interrupts);
    }
    let acknowledged = sent.acknowledged;
    if !ctx.json {
        emit(&summary(&command, duration, acknowledged, &stopped));
    }
    let stop_error = stopped.err();
    // Ctrl-C during the move, or during the wait for zero velocity's answer.
    let interrupted =
        matches!(ended, Ended::Interrupted) || matches!(stop_error, Some(Error::Interrupted(_)));
    match ended {
        Ended::Interrupted | Ended::Done if interrupted => Err(Error::Interrupted(format!(
            "move interrupted by Ctrl-C after {acknowledged} command(s); zero velocity {}",
            match stop_error {
                None => "sent",
                Some(Error::Interrupted(_)) => STOP_NOT_AWAITED,
                Some(_) => "NOT acknowledged",
            }
        ))),
        Ended::Interrupted | Ended::Done => stop_error.map_or(Ok(()), Err),
        // The move's own error is the one reported, a Ctrl-C during the stop's wait aside.
        Ended::Failed(e) => {
            match stop_error {
                Some(Error::Interrupted(_)) => {
                    note(&format!(
                        "x30ctl: zero velocity {STOP_NOT_AWAITED} (Ctrl-C)"
                    ));
                }
                Some(stop_error) => note(&format!(
                    "x30ctl: zero velocity was not acknowledged: {stop_error}"
                )),
                None => {}
            }
            Err(e)
        }
    }
}

/// How a `move` ends on `e`; a connection the error leaves unusable is dropped, so zero
/// velocity goes on a new one.
fn failed(conn: &mut Option<Connection>, e: Error) -> Ended {
    if !e.keeps_connection() {
        *conn = None;
    }
    Ended::Failed(e)
}

/// The motion commands of one `move` that went out, and what became of them.
#[derive(Default)]
struct Sent {
    /// Commands the robot confirmed.
    acknowledged: u32,
    /// Commands awaiting their answers, oldest first: message ID and when it was sent.
    pending: VecDeque<(u16, Instant)>,
    /// Whether the user was told that commands are held for a late answer.
    held: bool,
}

impl Sent {
    /// Takes the answers that come in until `until` (or Ctrl-C), waiting no longer.
    fn take_answers(
        &mut self,
        ctx: &Ctx,
        conn: &mut Connection,
        until: Instant,
        interrupts: &Interrupts,
    ) -> Result<(), Error> {
        loop {
            let Some(&(message_id, _)) = self.pending.front() else {
                sleep_until(until, interrupts);
                return Ok(());
            };
            let answer = conn.poll(message_id, MessageType::Motion, until, || {
                interrupts.count() > 0
            })?;
            let Some(answer) = answer else {
                return Ok(());
            };
            self.pending.pop_front();
            if ctx.json {
                emit(&answer.json());
            }
            if let Some(message) = render::failure("move", &answer.response) {
                return Err(Error::Failed(message));
            }
            self.acknowledged += 1;
        }
    }

    /// How long the oldest command not answered yet has waited.
    fn oldest_wait(&self) -> Option<Duration> {
        self.pending.front().map(|(_, sent)| sent.elapsed())
    }

    /// Skips a command because an answer is overdue; says so the first time.
    fn hold(&mut self) {
        if !self.held {
            self.held = true;
            warn(&format!(
                "the robot has not answered for {} ms: no motion until it does",
                OVERDUE.as_millis()
            ));
        }
    }
}

/// What a `move` says of its zero velocity when Ctrl-C ended the wait for its answer.
const STOP_NOT_AWAITED: &str = "sent, its answer not awaited";

/// Sends zero velocity, on `conn` if it is still usable, else (or if that fails) on a
/// new connection, which then replaces it. A Ctrl-C pressed after it was sent ends the
/// wait for its answer ([`Error::Interrupted`]): it is on the wire, and whoever presses
/// Ctrl-C again wants out.
fn zero_velocity(
    ctx: &Ctx,
    conn: &mut Option<Connection>,
    interrupts: &Interrupts,
) -> Result<(), Error> {
    let request = Request::Motion(MotionCommand::ZeroVelocity);
    let pressed = interrupts.count();
    let on = |conn: &mut Connection| {
        let answer = conn
            .request_unless(&request, || interrupts.count() > pressed)?
            .ok_or_else(|| Error::Interrupted(format!("zero velocity {STOP_NOT_AWAITED}")))?;
        if ctx.json {
            emit(&answer.json());
        }
        match render::failure("zero velocity", &answer.response) {
            Some(message) => Err(Error::Failed(message)),
            None => Ok(()),
        }
    };
    // One the robot has closed is passed over: the stop would fail there only after it
    // was written.
    if let Some(old) = conn.as_mut()
        && !old.closed_by_robot()
    {
        match on(old) {
            Ok(()) => return Ok(()),
            Err(e @ (Error::Failed(_) | Error::Interrupted(_))) => return Err(e),
            Err(e) => note(&format!(
                "x30ctl: zero velocity: {e}; retrying on a new connection"
            )),
        }
    }
    let fresh = conn.insert(ctx.connect()?);
    on(fresh)
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
            Err(Error::Interrupted(_)) => STOP_NOT_AWAITED,
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
