//! `estop`: soft emergency stop (Type 2 Command 13), sent until the robot confirms it.
//!
//! As the panel's e-stop button does: the command goes out at once and again every 250 ms,
//! whatever answers are still due, until a status (1002) reports soft emergency stop
//! (MotionState 6). A status is asked with the first command and again each time the last
//! one is answered. Refusals (ErrorCode 1), late answers and lost connections change only
//! the report: a robot silent for [`SILENT`] gets a new connection, with twice the wait (up
//! to [`MAX_DOUBLINGS`] times, as the panel's connections), and a connection that fails is
//! tried again at the next repeat. A robot that hangs up after each answer gets each
//! command on a new connection, and the status it hung up on after answering every
//! Command 13 is asked again at once on another. The confirmation (exit 0), `--timeout-ms`
//! without it (exit 3) or Ctrl-C (exit 130) end the repeats.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use x30_panel::client::{MAX_DOUBLINGS, SILENT_AFTER};
use x30_panel::panel::control::ESTOP_REPEAT;
use x30_panel::proto::codes::{MessageType, MotionState};
use x30_panel::proto::message::{MotionCommand, Request, Response};

use crate::conn::{Answer, Connection};
use crate::error::Error;
use crate::move_cmd::sleep_until;
use crate::render::{emit, warn};
use crate::{Ctx, Interrupts};

/// How often Command 13 goes out until it is confirmed: the panel's rate.
const REPEAT: Duration = Duration::from_millis(ESTOP_REPEAT.as_millis());

/// An answer this late, at first, means the connection is given up and a new one opened:
/// the panel's rule.
const SILENT: Duration = Duration::from_millis(SILENT_AFTER.as_millis());

/// Runs `estop`.
pub fn run(ctx: &Ctx, interrupts: &Interrupts) -> Result<(), Error> {
    let estop = Request::Motion(MotionCommand::SoftEmergencyStop);
    let start = Instant::now();
    let mut link = Link::default();
    let mut sent = 0u32;
    let mut repeat = 0u32;
    loop {
        if interrupts.count() > 0 {
            return Err(Error::Interrupted(format!(
                "estop interrupted by Ctrl-C: Command 13 was sent {sent} time(s), not confirmed"
            )));
        }
        if start.elapsed() >= ctx.timeout {
            return Err(Error::EstopUnconfirmed {
                waited: ctx.timeout,
                sent,
            });
        }
        if link.send(ctx, &estop) {
            sent += 1;
        }
        repeat = repeat.saturating_add(1);
        let next = REPEAT
            .checked_mul(repeat)
            .and_then(|after| start.checked_add(after))
            .unwrap_or_else(Instant::now);
        if let Some(state) = link.take_answers(ctx, next, interrupts) {
            if !ctx.json {
                emit(&format!(
                    "confirmed: the robot reports {} (MotionState {}) after {sent} command(s)",
                    state.description(),
                    state.raw()
                ));
            }
            return Ok(());
        }
    }
}

/// The connection the e-stop goes on, and the requests waiting for answers on it (none
/// without a connection).
#[derive(Default)]
struct Link {
    conn: Option<Connection>,
    /// Command 13s awaiting their answers, oldest first: message ID and when it was sent.
    estops: VecDeque<(u16, Instant)>,
    /// The status request awaiting its answer, and when it was sent.
    status: Option<(u16, Instant)>,
    /// How often the wait for an answer was doubled from [`SILENT`], as the panel's
    /// connections do; kept across connections. A robot that answers every request late (a
    /// slow link) then still has a status read, and confirms the e-stop, instead of losing
    /// each answer with the connection it was due on. With the longest wait, at most 33
    /// requests are outstanding on a connection (a Command 13 per repeat and one status),
    /// fewer than it keeps track of.
    doublings: u8,
}

impl Link {
    /// Sends Command 13, and a status request if none is due, connecting first if needed;
    /// whether the command went out. A failure is reported and drops the connection.
    fn send(&mut self, ctx: &Ctx, estop: &Request) -> bool {
        if let Some(conn) = self.conn.as_mut()
            && conn.closed_by_robot()
        {
            // The robot hung up: what it answered before is shown, and the command goes
            // on a new connection, where it is not lost.
            self.take_estop_answers(ctx);
            self.drop_connection();
        }
        let Some(conn) = self.connection(ctx) else {
            return false;
        };
        let message_id = match conn.send(estop) {
            Ok(message_id) => message_id,
            Err(e) => {
                self.lose(&e);
                return false;
            }
        };
        self.estops.push_back((message_id, Instant::now()));
        if self.status.is_none() {
            self.ask_status(ctx);
        }
        true
    }

    /// The connection, connecting first if there is none; a failure to connect is
    /// reported, and tried again at the next repeat.
    fn connection(&mut self, ctx: &Ctx) -> Option<&mut Connection> {
        if self.conn.is_none() {
            match ctx.connect() {
                Ok(conn) => self.conn = Some(conn),
                Err(e) => warn(&format!("{e}; trying again")),
            }
        }
        self.conn.as_mut()
    }

    /// Asks for the status, connecting first if needed.
    fn ask_status(&mut self, ctx: &Ctx) {
        let Some(conn) = self.connection(ctx) else {
            return;
        };
        match conn.send(&Request::Status) {
            Ok(message_id) => self.status = Some((message_id, Instant::now())),
            Err(e) => self.lose(&e),
        }
    }

    /// Takes the answers that come until `until` (or Ctrl-C): the motion state of a status
    /// that confirms the e-stop, if one does. Command 13's answers are printed (refusals
    /// too, which change nothing); a connection that fails or falls silent is dropped.
    fn take_answers(
        &mut self,
        ctx: &Ctx,
        until: Instant,
        interrupts: &Interrupts,
    ) -> Option<MotionState> {
        let mut status = self.take_status(until, interrupts);
        // In the order they came: Command 13's answers before the status.
        self.take_estop_answers(ctx);
        // Unless reading Command 13's answers dropped the connection already.
        if let Err(e) = &status
            && self.conn.is_some()
        {
            if matches!(e, Error::Closed { .. }) && self.estops.is_empty() {
                // The robot hung up after answering every Command 13 on the connection (a
                // robot that serves one request a connection): the status it left is
                // asked again at once, on a new connection.
                self.drop_connection();
                self.ask_status(ctx);
                status = self.take_status(until, interrupts);
            }
            if let Err(e) = &status
                && self.conn.is_some()
            {
                self.lose(e);
            }
        }
        let confirmed = status.ok().flatten();
        if let Some((_, answer)) = &confirmed
            && ctx.json
        {
            emit(&answer.json());
        }
        let confirmed = confirmed.map(|(state, _)| state);
        if confirmed.is_none() {
            // A status that did not confirm: the next is asked with the next command.
            sleep_until(until, interrupts);
        }
        let wait = self.silent_after();
        let silent = |sent: Option<Instant>| sent.is_some_and(|at| at.elapsed() >= wait);
        if confirmed.is_none()
            && (silent(self.estops.front().map(|&(_, at)| at))
                || silent(self.status.map(|(_, at)| at)))
        {
            self.doublings = (self.doublings + 1).min(MAX_DOUBLINGS);
            warn(&format!(
                "the robot has not answered for {} ms: reconnecting (waiting {} ms for an answer there)",
                wait.as_millis(),
                self.silent_after().as_millis()
            ));
            self.drop_connection();
        }
        confirmed
    }

    /// Waits until `until` (or Ctrl-C) for the status asked for, if one is: its motion
    /// state and the answer, if it confirms the e-stop. An error leaves the connection to
    /// the caller.
    fn take_status(
        &mut self,
        until: Instant,
        interrupts: &Interrupts,
    ) -> Result<Option<(MotionState, Answer)>, Error> {
        let (Some(conn), Some((message_id, _))) = (self.conn.as_mut(), self.status) else {
            return Ok(None);
        };
        let answer = conn.poll(message_id, MessageType::Status, until, || {
            interrupts.count() > 0
        })?;
        let Some(answer) = answer else {
            return Ok(None);
        };
        self.status = None;
        let Response::Status(status) = answer.response else {
            return Ok(None);
        };
        Ok(status
            .motion_state
            .is_soft_emergency_stop()
            .then_some((status.motion_state, answer)))
    }

    /// Prints the answers to Command 13 that are in already, waiting for none.
    fn take_estop_answers(&mut self, ctx: &Ctx) {
        while let (Some(conn), Some(&(message_id, _))) = (self.conn.as_mut(), self.estops.front()) {
            match conn.poll(message_id, MessageType::Motion, Instant::now(), || false) {
                Ok(Some(answer)) => {
                    self.estops.pop_front();
                    // A refusal is printed like any answer; the command goes again anyway.
                    ctx.print(&answer);
                }
                Ok(None) => break,
                Err(e) => {
                    self.lose(&e);
                    break;
                }
            }
        }
    }

    /// Drops the connection after `e`, unless it is still usable.
    fn lose(&mut self, e: &Error) {
        if !e.keeps_connection() {
            warn(&format!("{e}; reconnecting"));
            self.drop_connection();
        }
    }

    /// How long the robot may leave a request unanswered before the connection is given up.
    fn silent_after(&self) -> Duration {
        SILENT * (1u32 << self.doublings)
    }

    /// Drops the connection, and with it the requests that waited for answers on it.
    fn drop_connection(&mut self) {
        *self = Self {
            doublings: self.doublings,
            ..Self::default()
        };
    }
}
