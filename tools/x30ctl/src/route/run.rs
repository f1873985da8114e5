//! `route run`: a route walked point by point.
//!
//! Each point is one navigation task (1003) on a connection of its own, sent when the
//! previous one's answer has come, and that answer comes only when the robot has reached
//! the point or given up (docs/protocol.md, "Type 1003"). The wait is `nav`'s
//! ([`nav_cmd::await_task`]): Ctrl-C cancels the running point with 1004 on another
//! connection. With `--single-request` the points go in one 1003 with one `<Items>` block
//! each, as the vendor SDK sends them; the robot then answers once, for the whole route, so
//! a second connection asks 1007 which point it is walking to.
//!
//! Whenever the route stops early (Ctrl-C, a failed point, a lost connection) the error
//! names the point and carries the command that resumes there. Connecting is retried with
//! backoff, since nothing is pending then; a 1003 whose connection is lost cannot be
//! retried, because its answer is lost with it and the robot stops the task (41802), so
//! the route stops at that point.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use x30_panel::proto::codes::{NavOutcome, NavTaskStatus};
use x30_panel::proto::message::{
    MAX_NAV_POINTS, NavPoint, NavTask, NavTaskState, Request, Response,
};

use super::{file, show};
use crate::cli::RouteRunArgs;
use crate::conn::{Answer, Connection};
use crate::error::Error;
use crate::move_cmd::sleep_until;
use crate::nav_cmd::{self, TaskEnd};
use crate::render::{self, AnswerJson, emit, note};
use crate::{Ctx, Interrupts};

/// Waits before the retries of a connection for the next point; after the last one the
/// route stops.
const BACKOFF: [Duration; 4] = [
    Duration::from_millis(250),
    Duration::from_millis(500),
    Duration::from_secs(1),
    Duration::from_secs(2),
];

/// How often `--single-request` asks 1007 which point the robot is walking to.
const STATUS_POLL: Duration = Duration::from_millis(200);

/// Where a route is: a loop (from 1) and a point (index from 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Place {
    round: u64,
    index: usize,
}

/// Why a route stopped, and the point it resumes at (which may be one past the last).
#[derive(Debug)]
struct Stop {
    at: Place,
    cause: Error,
}

/// Runs `route run`.
pub fn run(ctx: &Ctx, args: &RouteRunArgs, interrupts: &Interrupts) -> Result<(), Error> {
    let points = file::load(&args.file)?;
    let first = usize::try_from(args.from)
        .ok()
        .filter(|&from| from <= points.len())
        .ok_or_else(|| {
            Error::Usage(format!(
                "route run: --from {} is out of range: {} has points 1 to {}; nothing sent",
                args.from,
                args.file.display(),
                points.len()
            ))
        })?
        - 1;
    if args.single_request {
        // Later loops send the whole route.
        let most = if args.loops == 1 {
            points.len() - first
        } else {
            points.len()
        };
        if most > MAX_NAV_POINTS {
            return Err(Error::Usage(format!(
                "route run --single-request: {most} points do not fit one request, which carries at most {MAX_NAV_POINTS}; leave out --single-request to send one request per point; nothing sent"
            )));
        }
    }
    if args.dry_run {
        show(ctx, &points);
        dry_run_summary(ctx, args, points.len(), first);
        return Ok(());
    }
    let mut runner = Runner {
        ctx,
        args,
        points: &points,
        interrupts,
        out: Output::new(ctx, points.len(), args.loops),
        started: Instant::now(),
    };
    let result = runner.walk(first);
    runner.out.finish();
    result
}

/// What `--dry-run` would have sent, after the table.
fn dry_run_summary(ctx: &Ctx, args: &RouteRunArgs, len: usize, first: usize) {
    let requests = if args.single_request { 1 } else { len - first };
    if ctx.json {
        #[derive(Serialize)]
        struct DryRun {
            kind: &'static str,
            from: usize,
            to: usize,
            requests: usize,
            loops: u64,
            single_request: bool,
        }
        emit(&render::json_line(&DryRun {
            kind: "dry_run",
            from: first + 1,
            to: len,
            requests,
            loops: args.loops,
            single_request: args.single_request,
        }));
    } else {
        emit(&format!(
            "dry run: points {} to {len} would go in {requests} navigation request(s) (Type 1003), {}; nothing sent",
            first + 1,
            loops_text(args.loops)
        ));
    }
}

/// `1 loop`, `3 loops`, `loops until Ctrl-C`.
fn loops_text(loops: u64) -> String {
    match loops {
        0 => "looping until Ctrl-C".to_owned(),
        1 => "1 loop".to_owned(),
        n => format!("{n} loops"),
    }
}

/// A route being walked.
struct Runner<'a> {
    ctx: &'a Ctx,
    args: &'a RouteRunArgs,
    points: &'a [NavPoint],
    interrupts: &'a Interrupts,
    out: Output,
    started: Instant,
}

impl Runner<'_> {
    /// Walks the route from point `first` (index) of the first loop, all loops.
    fn walk(&mut self, first: usize) -> Result<(), Error> {
        self.out.route_start(self.args, first);
        let mut first = first;
        let mut round = 1;
        while self.args.loops == 0 || round <= self.args.loops {
            self.out.loop_start(round, first);
            let walked = if self.args.single_request {
                self.single(round, first)
            } else {
                (first..self.points.len()).try_for_each(|index| self.point(Place { round, index }))
            };
            if let Err(stop) = walked {
                return Err(self.stopped(stop));
            }
            first = 0;
            round += 1;
        }
        self.out.route_end(round - 1, self.started.elapsed());
        Ok(())
    }

    /// Sends one point as its own task and waits until it has been reached.
    fn point(&mut self, at: Place) -> Result<(), Stop> {
        let point = self.points[at.index];
        let mut conn = self.connect(at)?;
        let message_id = conn
            .send(&Request::NavTask(NavTask::to_point(point)))
            .map_err(|e| lost(at, e))?;
        self.out.point_start(at, &point);
        let (leg, started, out) = (Instant::now(), self.started, &mut self.out);
        let end = nav_cmd::await_task(
            self.ctx,
            &mut conn,
            message_id,
            self.interrupts,
            None,
            |_| out.tick(at, point.value, leg, started),
        )
        .map_err(|e| lost(at, e))?;
        self.finish_point(at, &end, leg)
    }

    /// Sends the points from `first` (index) in one task, following its progress with 1007.
    fn single(&mut self, round: u64, first: usize) -> Result<(), Stop> {
        let points = self.points;
        let mut at = Place {
            round,
            index: first,
        };
        let mut task = NavTask::to_point(points[first]);
        for point in &points[first + 1..] {
            // `run` has checked that the points fit.
            task.points.push(*point).map_err(|_| Stop {
                at,
                cause: Error::Usage(format!(
                    "more than {MAX_NAV_POINTS} points do not fit one request"
                )),
            })?;
        }
        let mut conn = self.connect(at)?;
        let message_id = conn
            .send(&Request::NavTask(task))
            .map_err(|e| lost(at, e))?;
        let poller = StatusPoller::start(self.ctx);
        self.out.point_start(at, &points[first]);
        let (mut leg, started, out) = (Instant::now(), self.started, &mut self.out);
        let end = nav_cmd::await_task(
            self.ctx,
            &mut conn,
            message_id,
            self.interrupts,
            None,
            |_| {
                // The robot reports the point it walks to; the ones before it are passed.
                // Values may repeat in a route, so the search starts at the current point.
                let state = poller
                    .latest()
                    .filter(|s| s.status == NavTaskStatus::Running);
                let ahead = state.and_then(|s| {
                    points[at.index..]
                        .iter()
                        .position(|p| p.value == s.value)
                        .filter(|&k| k > 0)
                });
                if let Some(ahead) = ahead {
                    let passed = points.iter().enumerate().skip(at.index).take(ahead);
                    for (index, point) in passed {
                        let place = Place { round, index };
                        out.point_end(place, point, None, leg.elapsed(), started.elapsed());
                        leg = Instant::now();
                    }
                    at.index += ahead;
                    out.point_start(at, &points[at.index]);
                }
                out.tick(at, points[at.index].value, leg, started);
            },
        );
        drop(poller);
        let end = end.map_err(|e| lost(at, e))?;
        if end.result.outcome.is_success() {
            // Every point was reached: report the ones 1007 was too slow to show.
            for index in at.index..points.len() - 1 {
                let next = Place {
                    round,
                    index: index + 1,
                };
                let (leg_time, total) = (leg.elapsed(), self.started.elapsed());
                self.out
                    .point_end(at, &points[index], None, leg_time, total);
                self.out.point_start(next, &points[next.index]);
                (at, leg) = (next, Instant::now());
            }
        } else {
            at.index = stopped_at(points, at.index, end.result.value);
        }
        self.finish_point(at, &end, leg)
    }

    /// Reports a point's answer (and a cancel's), and stops the route unless it was
    /// reached.
    fn finish_point(&mut self, at: Place, end: &TaskEnd, leg: Instant) -> Result<(), Stop> {
        let point = self.points[at.index];
        self.out.point_end(
            at,
            &point,
            Some(&end.answer),
            leg.elapsed(),
            self.started.elapsed(),
        );
        if let Some((_, cancel)) = &end.cancel {
            match cancel {
                Ok(answer) => self.out.answer(answer),
                Err(e) => self.out.note(&format!("x30ctl: cancel (Type 1004): {e}")),
            }
            if end.result.outcome == NavOutcome::Cancelled {
                return Err(Stop {
                    at,
                    cause: Error::Interrupted(format!(
                        "cancelled by Ctrl-C: ErrorStatus {}, \"{}\"",
                        end.result.status.raw(),
                        end.result.status.description()
                    )),
                });
            }
            if end.result.outcome.is_success() {
                return Err(interrupted(Place {
                    index: at.index + 1,
                    ..at
                }));
            }
        }
        match render::failure("navigation", &end.answer.response) {
            Some(message) => Err(Stop {
                at,
                cause: Error::Failed(message),
            }),
            None => Ok(()),
        }
    }

    /// A connection for the point at `at`, retried with backoff: nothing is pending while
    /// connecting, so trying again is safe.
    fn connect(&mut self, at: Place) -> Result<Connection, Stop> {
        let mut retries = BACKOFF.iter();
        loop {
            if self.interrupts.count() > 0 {
                return Err(interrupted(at));
            }
            match self
                .ctx
                .connect_unless_interrupted(self.interrupts, "the point")
            {
                Ok(conn) => return Ok(conn),
                Err(Error::Interrupted(_)) => return Err(interrupted(at)),
                Err(e @ Error::Connect { .. }) => {
                    let Some(&wait) = retries.next() else {
                        return Err(Stop { at, cause: e });
                    };
                    self.out.note(&format!(
                        "x30ctl: warning: {e}; trying again in {} s",
                        wait.as_secs_f64()
                    ));
                    // Ctrl-C ends the wait; the check above then stops the route.
                    sleep_until(Instant::now() + wait, self.interrupts);
                }
                Err(e) => return Err(Stop { at, cause: e }),
            }
        }
    }

    /// The error for a route that stopped: where, why, and how to resume.
    fn stopped(&mut self, stop: Stop) -> Error {
        let len = self.points.len();
        let mut resume = stop.at;
        if resume.index >= len {
            resume = Place {
                round: resume.round + 1,
                index: 0,
            };
        }
        let left = self.args.loops == 0 || resume.round <= self.args.loops;
        let command = left.then(|| self.resume_command(resume));
        let at = match self.points.get(stop.at.index) {
            Some(point) => format!(
                "{}point {} of {len} (Value {})",
                self.out.loop_prefix(stop.at.round),
                stop.at.index + 1,
                point.value
            ),
            None => format!("the end of {}", self.out.loop_name(stop.at.round)),
        };
        self.out.stopped(&stop, &at, command.as_deref());
        Error::RouteStopped {
            at,
            cause: Box::new(stop.cause),
            resume: command,
        }
    }

    /// The command line that walks the rest of the route from `at`.
    fn resume_command(&self, at: Place) -> String {
        let file = self.args.file.display().to_string();
        let from = (at.index + 1).to_string();
        let mut words = vec![
            "x30ctl",
            "--robot",
            &self.ctx.robot,
            "route",
            "run",
            &file,
            "--from",
            &from,
        ];
        let loops = match self.args.loops {
            0 => Some(0),
            all => Some(all - at.round + 1).filter(|&left| left != 1),
        }
        .map(|loops| loops.to_string());
        if let Some(loops) = &loops {
            words.extend(["--loop", loops]);
        }
        if self.args.single_request {
            words.push("--single-request");
        }
        if self.ctx.json {
            words.push("--json");
        }
        words
            .into_iter()
            .map(shell_word)
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// The point (index) a multi-point task that failed or was cancelled stopped at, from the
/// last point 1007 showed (`shown`) and the answer's `Value`.
///
/// 1007 is polled, so it may lag behind but is never ahead: resuming there skips nothing.
/// The answer's `Value` may name the point the robot stopped at (as x30-sim's does), or
/// always the last point (the document says no more than "as requested"); so it is
/// believed only when it is not the last point's `Value` and names a point from `shown` on.
fn stopped_at(points: &[NavPoint], shown: usize, value: i32) -> usize {
    if points.last().is_some_and(|last| last.value == value) {
        return shown;
    }
    points
        .iter()
        .skip(shown)
        .position(|p| p.value == value)
        .map_or(shown, |ahead| shown + ahead)
}

/// The stop for Ctrl-C before the point at `at` was sent.
fn interrupted(at: Place) -> Stop {
    Stop {
        at,
        cause: Error::Interrupted("interrupted by Ctrl-C before the point was sent".to_owned()),
    }
}

/// The stop for an error while a point's task was pending. A lost connection loses the
/// answer, and the robot stops a task whose connection drops: the point failed.
fn lost(at: Place, e: Error) -> Stop {
    let cause = match e {
        Error::Closed { .. } | Error::Io { .. } => Error::Failed(format!(
            "{e}; the answer is lost with the connection, and the robot stops a task whose connection drops (ErrorStatus 41802)"
        )),
        other => other,
    };
    Stop { at, cause }
}

/// A word as a POSIX shell reads it back: as it is when it has nothing special, else in
/// single quotes.
fn shell_word(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-./:@%+=,".contains(c));
    if plain {
        word.to_owned()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

/// Asks 1007 on a connection and thread of its own which point the robot is walking to,
/// every [`STATUS_POLL`], until dropped. Progress is best effort: a failed poll only means
/// a fresh connection for the next one.
struct StatusPoller {
    latest: Arc<Mutex<Option<NavTaskState>>>,
    stop: Arc<AtomicBool>,
}

impl StatusPoller {
    fn start(ctx: &Ctx) -> Self {
        let latest = Arc::new(Mutex::new(None));
        let stop = Arc::new(AtomicBool::new(false));
        let (shared, stopped, ctx) = (Arc::clone(&latest), Arc::clone(&stop), ctx.clone());
        // Not joined: it ends by itself within one poll of being told to stop, and a poll
        // that hangs must not hold the route up.
        thread::spawn(move || {
            let mut conn: Option<Connection> = None;
            while !stopped.load(Ordering::SeqCst) {
                match ctx
                    .reuse(&mut conn)
                    .and_then(|c| c.request(&Request::NavStatus))
                {
                    Ok(Answer {
                        response: Response::NavStatus(state),
                        ..
                    }) => *shared.lock().unwrap_or_else(PoisonError::into_inner) = Some(state),
                    // The next poll starts afresh: this connection may hold a late answer.
                    _ => conn = None,
                }
                thread::sleep(STATUS_POLL);
            }
        });
        Self { latest, stop }
    }

    /// The last 1007 answer, if one has come.
    fn latest(&self) -> Option<NavTaskState> {
        *self.latest.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl Drop for StatusPoller {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
    }
}

/// One line of `route run --json`.
#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum Event<'a> {
    /// The route starts.
    RouteStart {
        file: String,
        points: usize,
        from: usize,
        loops: u64,
        single_request: bool,
    },
    /// The robot sets out for a point (sent, or with `--single-request` reported by 1007).
    PointStart {
        #[serde(rename = "loop")]
        round: u64,
        index: usize,
        of: usize,
        value: i32,
    },
    /// A point's task ended (with its answer), or the robot passed it (no answer).
    PointEnd {
        #[serde(rename = "loop")]
        round: u64,
        index: usize,
        of: usize,
        value: i32,
        leg_s: f64,
        total_s: f64,
        #[serde(skip_serializing_if = "Option::is_none")]
        answer: Option<AnswerJson<'a>>,
    },
    /// Every loop is done.
    RouteEnd {
        loops: u64,
        points: usize,
        total_s: f64,
    },
    /// The route stopped early.
    RouteStopped {
        #[serde(rename = "loop")]
        round: u64,
        index: usize,
        of: usize,
        error: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        resume: Option<&'a str>,
    },
}

/// Where progress goes: JSON events, plain lines, or plain lines above a progress bar when
/// stdout is a terminal.
struct Output {
    json: bool,
    bar: Option<ProgressBar>,
    of: usize,
    loops: u64,
    /// Points reached or passed so far.
    reached: usize,
}

impl Output {
    fn new(ctx: &Ctx, of: usize, loops: u64) -> Self {
        let bar = (!ctx.json && std::io::stdout().is_terminal()).then(|| {
            let bar =
                ProgressBar::with_draw_target(u64::try_from(of).ok(), ProgressDrawTarget::stdout());
            // The template is fixed and valid; the default style stands in regardless.
            let style = ProgressStyle::with_template("{prefix}[{bar:24}] {msg}")
                .map(|s| s.progress_chars("=> "))
                .unwrap_or_else(|_| ProgressStyle::default_bar());
            bar.set_style(style);
            bar
        });
        Self {
            json: ctx.json,
            bar,
            of,
            loops,
            reached: 0,
        }
    }

    /// A line for the reader: above the bar if there is one.
    fn line(&self, text: &str) {
        match &self.bar {
            Some(bar) => bar.println(text),
            None => emit(text),
        }
    }

    /// A line on stderr, with the bar out of the way.
    fn note(&self, text: &str) {
        match &self.bar {
            Some(bar) => bar.suspend(|| note(text)),
            None => note(text),
        }
    }

    fn event(&self, event: &Event<'_>) {
        emit(&render::json_line(event));
    }

    /// `loop 2, ` when the route loops, else nothing.
    fn loop_prefix(&self, round: u64) -> String {
        if self.loops == 1 {
            String::new()
        } else {
            format!("{}, ", self.loop_name(round))
        }
    }

    /// `loop 2 of 3`, or `loop 2` when looping until Ctrl-C.
    fn loop_name(&self, round: u64) -> String {
        match self.loops {
            0 => format!("loop {round}"),
            loops => format!("loop {round} of {loops}"),
        }
    }

    fn route_start(&self, args: &RouteRunArgs, first: usize) {
        let file = args.file.display().to_string();
        if self.json {
            self.event(&Event::RouteStart {
                file,
                points: self.of,
                from: first + 1,
                loops: args.loops,
                single_request: args.single_request,
            });
        } else {
            self.line(&format!(
                "route {file}: {} points, from point {}, {}, {}",
                self.of,
                first + 1,
                loops_text(args.loops),
                if args.single_request {
                    "one request per loop"
                } else {
                    "one request per point"
                }
            ));
        }
    }

    fn loop_start(&self, round: u64, first: usize) {
        if let Some(bar) = &self.bar {
            if self.loops != 1 {
                bar.set_prefix(format!("{} ", self.loop_name(round)));
            }
            bar.set_position(u64::try_from(first).unwrap_or(0));
            bar.reset_elapsed();
        }
    }

    fn point_start(&self, at: Place, point: &NavPoint) {
        if self.json {
            self.event(&Event::PointStart {
                round: at.round,
                index: at.index + 1,
                of: self.of,
                value: point.value,
            });
        }
    }

    /// Brings the bar's message up to date: the point, time on this leg and in total.
    fn tick(&self, at: Place, value: i32, leg: Instant, started: Instant) {
        if let Some(bar) = &self.bar {
            bar.set_position(u64::try_from(at.index).unwrap_or(0));
            bar.set_message(format!(
                "point {} of {} (Value {value}): {:.1} s on this leg, {:.1} s in total",
                at.index + 1,
                self.of,
                leg.elapsed().as_secs_f64(),
                started.elapsed().as_secs_f64()
            ));
        }
    }

    fn point_end(
        &mut self,
        at: Place,
        point: &NavPoint,
        answer: Option<&Answer>,
        leg: Duration,
        total: Duration,
    ) {
        let reached = answer
            .is_none_or(|a| matches!(a.response, Response::NavResult(r) if r.outcome.is_success()));
        self.reached += usize::from(reached);
        if self.json {
            self.event(&Event::PointEnd {
                round: at.round,
                index: at.index + 1,
                of: self.of,
                value: point.value,
                leg_s: leg.as_secs_f64(),
                total_s: total.as_secs_f64(),
                answer: answer.map(|a| render::answer_json(a.message_id, &a.time, &a.response)),
            });
            return;
        }
        let what = match answer {
            Some(a) => render::response_text(&a.response),
            None => "passed".to_owned(),
        };
        self.line(&format!(
            "{}point {} of {} (Value {}): {what}; {:.1} s (total {:.1} s)",
            self.loop_prefix(at.round),
            at.index + 1,
            self.of,
            point.value,
            leg.as_secs_f64(),
            total.as_secs_f64()
        ));
        if let Some(bar) = &self.bar {
            bar.set_position(u64::try_from(at.index + 1).unwrap_or(0));
        }
    }

    /// Another answer (the cancel's), as `nav` prints it.
    fn answer(&self, answer: &Answer) {
        if self.json {
            emit(&answer.json());
        } else {
            self.line(&render::response_text(&answer.response));
        }
    }

    fn stopped(&self, stop: &Stop, at: &str, resume: Option<&str>) {
        if self.json {
            self.event(&Event::RouteStopped {
                round: stop.at.round,
                index: stop.at.index + 1,
                of: self.of,
                error: format!("route stopped at {at}: {}", stop.cause),
                resume,
            });
        }
    }

    fn route_end(&self, loops: u64, total: Duration) {
        if self.json {
            self.event(&Event::RouteEnd {
                loops,
                points: self.reached,
                total_s: total.as_secs_f64(),
            });
        } else {
            self.line(&format!(
                "route completed: {} points reached in {loops} loop(s), {:.1} s",
                self.reached,
                total.as_secs_f64()
            ));
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use x30_panel::proto::codes::PointInfo;

    #[test]
    fn a_multi_point_task_stopped_where_its_answer_says_unless_that_is_ambiguous() {
        let route: Vec<NavPoint> = [1, 2, 3, 2]
            .map(|value| NavPoint::new(value, 0, 0.0, 0.0, 0.0, 0.0, PointInfo::Task))
            .to_vec();
        // 1007 showed point 1 (index 0); the answer names point 3.
        assert_eq!(stopped_at(&route, 0, 3), 2);
        // Value 2 is also the last point's: it may mean "the task", so 1007's point stands.
        assert_eq!(stopped_at(&route, 0, 2), 0);
        // Never behind what 1007 showed, and a Value not in the route changes nothing.
        assert_eq!(stopped_at(&route, 2, 1), 2);
        assert_eq!(stopped_at(&route, 1, 99), 1);
    }

    #[test]
    fn shell_words_read_back_as_given() {
        assert_eq!(shell_word("127.0.0.1:30000"), "127.0.0.1:30000");
        assert_eq!(shell_word("routes/patrol-1.json"), "routes/patrol-1.json");
        assert_eq!(shell_word("my route.json"), "'my route.json'");
        assert_eq!(shell_word("it's.json"), r"'it'\''s.json'");
        assert_eq!(shell_word("[::1]:30000"), "'[::1]:30000'");
        assert_eq!(shell_word(""), "''");
    }
}
