//! `nav`: one navigation task (Type 1003), awaited for as long as it takes.
//!
//! The robot answers a 1003 request only when the task has ended, and stops the task if
//! the requesting connection drops (ErrorStatus 41802). So the task gets its own
//! connection, kept open until the answer arrives, and nothing else is sent on it (the
//! document warns that a 1007 sent on the same connection can mix up answers).
//!
//! Ctrl-C (or `--nav-timeout`) cancels the task with a 1004 request on a separate
//! connection; the robot then sends the cancelled 1003 answer (ErrorCode 2, ErrorStatus
//! 8962) on the task connection and the 1004 answer on the other. Both are reported. A
//! second Ctrl-C gives up at once. [`await_task`] is that wait, which `route run` shares.

use std::sync::mpsc;
use std::thread;
use std::time::Duration;

use x30_panel::proto::codes::{MessageType, NavOutcome};
use x30_panel::proto::message::{NavResult, NavTask, Request, Response};

use crate::cli::NavArgs;
use crate::conn::{Answer, Check, Connection, Deadline};
use crate::error::Error;
use crate::render::{self, note};
use crate::{Ctx, Interrupts};

/// Why the task is being cancelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reason {
    /// Ctrl-C.
    Interrupted,
    /// `--nav-timeout` expired.
    TimedOut(Duration),
}

/// A 1004 request running on its own thread and connection, so the task connection keeps
/// being read while it runs.
struct Cancel {
    reason: Reason,
    rx: mpsc::Receiver<Result<Answer, Error>>,
    result: Option<Result<Answer, Error>>,
    /// How long to go on waiting for the cancelled 1003 answer.
    deadline: Deadline,
    /// Bound on the 1004 exchange itself (connect, send, answer).
    exchange: Duration,
}

impl Cancel {
    fn start(ctx: &Ctx, reason: Reason) -> Self {
        if !ctx.json {
            note(&match reason {
                Reason::Interrupted => "x30ctl: Ctrl-C: cancelling the navigation task (Type 1004); Ctrl-C again to give up at once".to_owned(),
                Reason::TimedOut(after) => format!(
                    "x30ctl: the navigation task did not finish within {} s: cancelling it (Type 1004)",
                    after.as_secs_f64()
                ),
            });
        }
        let (tx, rx) = mpsc::channel();
        let cancel_ctx = ctx.clone();
        thread::spawn(move || {
            let result = cancel_ctx
                .connect()
                .and_then(|mut conn| conn.request(&Request::CancelNav));
            let _ = tx.send(result);
        });
        let exchange = ctx.connect_timeout + ctx.timeout;
        Self {
            reason,
            rx,
            result: None,
            // The robot sends the 1003 answer before the 1004 answer, so once the 1004
            // exchange is over the 1003 answer is due; one more answer timeout is margin.
            deadline: Deadline::after(exchange + ctx.timeout),
            exchange,
        }
    }

    /// The 1004 result, if it has arrived.
    fn poll(&mut self) -> Option<&Result<Answer, Error>> {
        if self.result.is_none() {
            self.result = self.rx.try_recv().ok();
        }
        self.result.as_ref()
    }

    /// The 1004 result, waiting for it as long as the exchange may take.
    fn finish(mut self) -> Result<Answer, Error> {
        if let Some(result) = self.result.take() {
            return result;
        }
        self.rx
            .recv_timeout(self.exchange + Duration::from_millis(500))
            .unwrap_or_else(|_| {
                Err(Error::Timeout {
                    waited: self.exchange,
                    message_type: MessageType::CancelNav.raw(),
                })
            })
    }
}

/// How waiting for a 1003 answer ended: the answer, and the cancel if one was sent.
#[derive(Debug)]
pub struct TaskEnd {
    /// The 1003 answer.
    pub answer: Answer,
    /// Its items.
    pub result: NavResult,
    /// Why the task was cancelled and the 1004 answer (or why there is none), if Ctrl-C or
    /// the nav timeout cancelled it.
    pub cancel: Option<(Reason, Result<Answer, Error>)>,
}

/// Waits on `conn` for the answer to the 1003 request `message_id`, for as long as the task
/// takes. The first Ctrl-C, or `nav_timeout` passing, cancels the task (1004 on another
/// connection) and waits for the cancelled answer; a second Ctrl-C, or a cancel that fails,
/// gives up at once (closing the connection then stops the task). `tick` runs after every
/// read, at least every 100 ms, with the time waited so far.
pub fn await_task(
    ctx: &Ctx,
    conn: &mut Connection,
    message_id: u16,
    interrupts: &Interrupts,
    nav_timeout: Option<Duration>,
    mut tick: impl FnMut(Duration),
) -> Result<TaskEnd, Error> {
    let mut cancel: Option<Cancel> = None;
    let result = conn.wait(message_id, MessageType::NavTask, |waited| {
        tick(waited);
        let presses = interrupts.count();
        if presses >= 2 {
            return Check::Abort(Error::Interrupted(
                "interrupted twice: gave up waiting; closing the task connection, which makes the robot stop the task (ErrorStatus 41802)".to_owned(),
            ));
        }
        if cancel.is_none() {
            let reason = if presses == 1 {
                Some(Reason::Interrupted)
            } else {
                nav_timeout
                    .filter(|&limit| waited >= limit)
                    .map(Reason::TimedOut)
            };
            cancel = reason.map(|reason| Cancel::start(ctx, reason));
        }
        let Some(cancel) = &mut cancel else {
            // The documented unbounded wait: a task may take many minutes.
            return Check::Wait(None);
        };
        let deadline = cancel.deadline;
        match cancel.poll() {
            Some(Err(e)) => Check::Abort(Error::Interrupted(format!(
                "cancelling the navigation task failed ({e}); closing the task connection, which makes the robot stop the task (ErrorStatus 41802)"
            ))),
            Some(Ok(answer)) => match render::failure("cancel", &answer.response) {
                Some(message) => Check::Abort(Error::Failed(format!(
                    "{message}; the navigation task may still be running"
                ))),
                None => Check::Wait(Some(deadline)),
            },
            None => Check::Wait(Some(deadline)),
        }
    });

    let answer = match result {
        Ok(answer) => answer,
        Err(e) => {
            if let Some(mut cancel) = cancel {
                // Report the 1004 answer if it is in, but do not wait for it: a second
                // Ctrl-C means "give up at once".
                if let Some(Ok(cancel_answer)) = cancel.poll() {
                    ctx.print(cancel_answer);
                }
                if matches!(e, Error::Timeout { .. }) {
                    note("x30ctl: the robot did not send the cancelled Type 1003 answer");
                }
            }
            return Err(e);
        }
    };
    let Response::NavResult(result) = answer.response else {
        // conn.wait only returns answers of the request's Type.
        return Err(Error::BadAnswer {
            message_type: MessageType::NavTask.raw(),
            message_id: answer.message_id,
            detail: "not a navigation result".to_owned(),
        });
    };
    Ok(TaskEnd {
        answer,
        result,
        cancel: cancel.map(|cancel| (cancel.reason, cancel.finish())),
    })
}

/// Runs `nav`.
pub fn run(ctx: &Ctx, args: &NavArgs, interrupts: &Interrupts) -> Result<(), Error> {
    let point = args.point();
    let request = Request::NavTask(NavTask::to_point(point));
    crate::validate(&request, "nav")?;
    let nav_timeout = match args.nav_timeout {
        None => None,
        Some(seconds) => Some(crate::seconds_arg("nav", "--nav-timeout", seconds)?),
    };

    let mut conn = ctx.connect_unless_interrupted(interrupts, "the navigation task")?;
    let message_id = conn.send(&request)?;
    if !ctx.json {
        note(&format!(
            "x30ctl: navigation task sent ({}); waiting until the robot has finished it (Ctrl-C cancels)",
            render::nav_point_text(&point)
        ));
    }

    let end = await_task(ctx, &mut conn, message_id, interrupts, nav_timeout, |_| {})?;
    ctx.print(&end.answer);
    if let Some((reason, cancel_answer)) = end.cancel {
        match cancel_answer {
            Ok(cancel_answer) => ctx.print(&cancel_answer),
            Err(e) => note(&format!("x30ctl: cancel (Type 1004): {e}")),
        }
        if end.result.outcome == NavOutcome::Cancelled {
            return Err(match reason {
                Reason::Interrupted => Error::Interrupted(format!(
                    "navigation task cancelled by Ctrl-C: ErrorStatus {}, \"{}\"",
                    end.result.status.raw(),
                    end.result.status.description()
                )),
                Reason::TimedOut(after) => {
                    note(&format!(
                        "x30ctl: navigation task cancelled after --nav-timeout: ErrorStatus {}, \"{}\"",
                        end.result.status.raw(),
                        end.result.status.description()
                    ));
                    Error::Timeout {
                        waited: after,
                        message_type: MessageType::NavTask.raw(),
                    }
                }
            });
        }
    }
    match render::failure("nav", &end.answer.response) {
        Some(message) => Err(Error::Failed(message)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::{Cli, Command};
    use clap::Parser;
    use std::io::Read;
    use std::net::TcpListener;

    /// Ctrl-C pressed by the time the connection is made (a connect may take up to the
    /// connect timeout): no task goes out, and `nav` ends as interrupted.
    #[test]
    fn a_ctrl_c_while_connecting_sends_no_task() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("addr").to_string();
        let robot = thread::spawn(move || {
            let (mut stream, _) = listener.accept().expect("the client connects");
            let _ = stream.set_read_timeout(Some(Duration::from_secs(2)));
            let mut written = Vec::new();
            // Until the client closes (or the bound): what it wrote.
            let _ = stream.read_to_end(&mut written);
            written
        });
        let args = [
            "x30ctl", "--robot", &addr, "nav", "--map-id", "1", "--x", "1", "--y", "0",
        ];
        let Command::Nav(nav) = Cli::try_parse_from(args).expect("valid arguments").command else {
            panic!("parsed as another command");
        };
        let ctx = Ctx {
            robot: addr,
            connect_timeout: Duration::from_secs(2),
            timeout: Duration::from_secs(2),
            json: false,
        };
        let result = run(&ctx, &nav, &Interrupts::pressed(1));
        assert!(matches!(result, Err(Error::Interrupted(_))), "{result:?}");
        let written = robot.join().expect("the robot's thread");
        assert!(written.is_empty(), "{} bytes written", written.len());
    }
}
