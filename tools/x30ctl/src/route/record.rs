//! `route record`: a route written from where the robot stands, one point per Enter.
//!
//! Commands come from standard input, one per line, so that a script (or a test) can drive
//! it through a pipe: an empty line records the robot's pose (asked with 1002 at that
//! moment) as the next point, `q` finishes, and so does the end of the input. The file is
//! rewritten after every point (to a `.part` file, then renamed over it), so an
//! interrupted recording keeps every point it had. On a terminal the robot's pose is shown
//! live, polled every half second.

use std::io::{BufRead, IsTerminal};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::thread;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use x30_panel::proto::codes::Location;
use x30_panel::proto::message::{NavPoint, NavTask, Request, Response, RobotStatus};

use super::{PointJson, file};
use crate::Ctx;
use crate::cli::RouteRecordArgs;
use crate::conn::Connection;
use crate::error::{Error, io_text};
use crate::render::{self, code_text, emit, note, warn};

/// How often the live pose is refreshed on a terminal.
const LIVE_POLL: Duration = Duration::from_millis(500);

/// Runs `route record`.
pub fn run(ctx: &Ctx, args: &RouteRecordArgs) -> Result<(), Error> {
    let shown = args.file.display().to_string();
    let template = args.style.point(1, args.map_id, 0.0, 0.0, 0.0, 0.0);
    crate::validate(
        &Request::NavTask(NavTask::to_point(template)),
        "route record",
    )?;
    if args.file.exists() && !args.force {
        return Err(Error::Usage(format!(
            "route record: {shown} exists; --force overwrites it; nothing recorded"
        )));
    }
    // Found out now, not after the robot was walked to the first point.
    let folder = args
        .file
        .parent()
        .filter(|folder| !folder.as_os_str().is_empty());
    if let Some(folder) = folder.filter(|folder| !folder.is_dir()) {
        return Err(Error::Usage(format!(
            "route record: no folder {}; nothing recorded",
            folder.display()
        )));
    }
    let lines = stdin_lines();
    let live = Live::new(ctx);
    if !ctx.json {
        note(&format!(
            "x30ctl: recording a route into {shown}: Enter records the robot's pose as the next point, q + Enter finishes"
        ));
    }
    let mut conn: Option<Connection> = None;
    let mut points: Vec<NavPoint> = Vec::new();
    loop {
        let line = match &live {
            Some(live) => match lines.recv_timeout(LIVE_POLL) {
                Ok(line) => line,
                Err(RecvTimeoutError::Timeout) => {
                    live.refresh(ctx, &mut conn, points.len() + 1);
                    continue;
                }
                Err(RecvTimeoutError::Disconnected) => break,
            },
            None => match lines.recv() {
                Ok(line) => line,
                Err(_) => break,
            },
        };
        match line.trim() {
            "" => {}
            "q" | "quit" => break,
            other => {
                warn(&format!(
                    "{other:?} ignored: Enter records a point, q + Enter finishes"
                ));
                continue;
            }
        }
        let status = match pose(ctx, &mut conn) {
            Ok(status) => status,
            Err(why) => {
                warn(&format!("point {} not recorded: {why}", points.len() + 1));
                continue;
            }
        };
        let value = i32::try_from(points.len() + 1).unwrap_or(i32::MAX);
        let point = args.style.point(
            value,
            args.map_id,
            status.pos_x,
            status.pos_y,
            status.pos_z,
            status.yaw,
        );
        points.push(point);
        write(&args.file, &points)?;
        let line = if ctx.json {
            render::json_line(&PointJson::new(points.len(), &point))
        } else {
            format!(
                "point {} (Value {value}): x {} m, y {} m, z {} m, yaw {} rad; {shown} has {} point(s)",
                points.len(),
                point.pos_x,
                point.pos_y,
                point.pos_z,
                point.angle_yaw,
                points.len()
            )
        };
        match &live {
            Some(live) => live.bar.println(line),
            None => emit(&line),
        }
    }
    if let Some(live) = &live {
        live.bar.finish_and_clear();
    }
    if points.is_empty() {
        return Err(Error::Usage(format!(
            "route record: no point recorded; {shown} not written"
        )));
    }
    if ctx.json {
        #[derive(Serialize)]
        struct Written<'a> {
            kind: &'static str,
            file: &'a str,
            points: usize,
        }
        emit(&render::json_line(&Written {
            kind: "route_written",
            file: &shown,
            points: points.len(),
        }));
    } else {
        emit(&format!(
            "route {shown}: {} point(s) recorded",
            points.len()
        ));
    }
    Ok(())
}

/// Standard input's lines, read on a thread so that the live view can refresh meanwhile;
/// the channel closes at the end of the input (or on a read error).
fn stdin_lines() -> Receiver<String> {
    let (tx, rx) = mpsc::channel();
    // Not joined: it blocks reading until the input ends, which may be never.
    thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// The robot's status now, if it gives a pose worth recording; otherwise why not.
fn pose(ctx: &Ctx, conn: &mut Option<Connection>) -> Result<RobotStatus, String> {
    let answer = ctx.ask(conn, &Request::Status).map_err(|e| {
        // The next point starts afresh: this connection may hold a late answer or be dead.
        *conn = None;
        e.to_string()
    })?;
    match answer.response {
        Response::Status(s) if s.is_unavailable() => Err(render::STATUS_UNAVAILABLE.to_owned()),
        Response::Status(s) => match s.location {
            // A pose item left out reads as `nan` too.
            Some(Location::Localized)
                if ![s.pos_x, s.pos_y, s.pos_z, s.yaw]
                    .iter()
                    .all(|v| v.is_finite()) =>
            {
                Err("the robot reports no pose (PosX, PosY, PosZ or Yaw unknown)".to_owned())
            }
            Some(Location::Localized) => Ok(s),
            Some(other) => Err(format!(
                "the robot is not localised ({}), so its pose means nothing",
                code_text(other)
            )),
            None => Err(
                "the robot does not report whether it is localised, so its pose may mean nothing"
                    .to_owned(),
            ),
        },
        other => Err(format!(
            "unexpected answer: {}",
            render::response_text(&other)
        )),
    }
}

/// Writes the route so far: to a `.part` file beside it, then renamed over it, so the file
/// is always whole.
fn write(path: &Path, points: &[NavPoint]) -> Result<(), Error> {
    let mut part = path.as_os_str().to_owned();
    part.push(".part");
    let part = PathBuf::from(part);
    std::fs::write(&part, file::to_text(points))
        .and_then(|()| std::fs::rename(&part, path))
        .map_err(|e| {
            Error::Usage(format!(
                "cannot write route file {}: {}",
                path.display(),
                io_text(&e)
            ))
        })
}

/// The live pose on a terminal: a spinner line with the robot's pose.
struct Live {
    bar: ProgressBar,
}

impl Live {
    /// The live view, when stdout is a terminal and the output is not JSON.
    fn new(ctx: &Ctx) -> Option<Self> {
        if ctx.json || !std::io::stdout().is_terminal() {
            return None;
        }
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stdout());
        // The template is fixed and valid; the default style stands in regardless.
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        Some(Self { bar })
    }

    /// Asks for the pose and shows it, or why there is none.
    fn refresh(&self, ctx: &Ctx, conn: &mut Option<Connection>, next: usize) {
        let message = match pose(ctx, conn) {
            Ok(s) => format!(
                "x {} m, y {} m, z {} m, yaw {} rad; Enter records point {next}, q + Enter finishes",
                s.pos_x, s.pos_y, s.pos_z, s.yaw
            ),
            Err(why) => format!("no pose: {why}"),
        };
        self.bar.set_message(message);
        self.bar.tick();
    }
}
