//! `watch`: status, battery and perception (1002 + 2001 + 2002), refreshed at an interval.
//!
//! On a terminal the screen is redrawn in place; otherwise (a pipe, a log file) each
//! refresh is one plain line, or one JSON object with `--json`. A failed refresh is shown
//! and the next one reconnects, so a robot that restarts or drops the connection does not
//! end the watch (existing clients never reconnect: docs/protocol.md, "Mistakes of
//! existing clients"); a request whose connection the robot had closed after an earlier
//! answer is asked again at once on a new one, so a robot that hangs up after each answer
//! is watched too.

use std::io::IsTerminal;
use std::thread;
use std::time::{Duration, Instant};

use serde::Serialize;
use x30_panel::proto::codes::reported_description;
use x30_panel::proto::message::{Battery, Perception, Request, Response, RobotStatus};

use crate::Ctx;
use crate::cli::WatchArgs;
use crate::conn::{Answer, Connection};
use crate::error::Error;
use crate::render::{self, AnswerJson, code_text, emit, note, reading, reported_int};

/// ANSI: cursor home, clear screen.
const CLEAR: &str = "\x1b[H\x1b[2J";

/// One refresh: the three answers.
struct Snapshot {
    status: Answer,
    battery: Answer,
    perception: Answer,
}

/// One refresh as JSON.
#[derive(Serialize)]
struct SnapshotJson<'a> {
    refresh: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    status: Option<AnswerJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    battery: Option<AnswerJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    perception: Option<AnswerJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
}

/// Runs `watch`.
pub fn run(ctx: &Ctx, args: &WatchArgs) -> Result<(), Error> {
    let tty = !ctx.json && std::io::stdout().is_terminal();
    let interval = Duration::from_millis(args.interval_ms);
    let start = Instant::now();
    let mut conn: Option<Connection> = None;
    let mut last: Result<(), Error> = Ok(());
    let mut refresh = 0u64;
    while args.count.is_none_or(|count| refresh < count) {
        // Refreshes sit on a fixed grid from the start, so request time does not add up.
        if let Some(due) = interval
            .checked_mul(u32::try_from(refresh).unwrap_or(u32::MAX))
            .and_then(|offset| start.checked_add(offset))
        {
            thread::sleep(due.saturating_duration_since(Instant::now()));
        }
        refresh += 1;
        let result = snapshot(ctx, &mut conn);
        if result.is_err() {
            // Start afresh next time: the connection may hold a late answer or be dead.
            conn = None;
        }
        show(ctx, tty, refresh, &result);
        last = result.map(|_| ());
    }
    last
}

/// Takes one snapshot, connecting first if needed.
fn snapshot(ctx: &Ctx, conn: &mut Option<Connection>) -> Result<Snapshot, Error> {
    Ok(Snapshot {
        status: ctx.ask(conn, &Request::Status)?,
        battery: ctx.ask(conn, &Request::Battery)?,
        perception: ctx.ask(conn, &Request::Perception)?,
    })
}

fn show(ctx: &Ctx, tty: bool, refresh: u64, result: &Result<Snapshot, Error>) {
    fn json(a: &Answer) -> AnswerJson<'_> {
        render::answer_json(a.message_id, &a.time, &a.response)
    }
    if ctx.json {
        let line = match result {
            Ok(s) => SnapshotJson {
                refresh,
                status: Some(json(&s.status)),
                battery: Some(json(&s.battery)),
                perception: Some(json(&s.perception)),
                error: None,
            },
            Err(e) => SnapshotJson {
                refresh,
                status: None,
                battery: None,
                perception: None,
                error: Some(e.to_string()),
            },
        };
        emit(&render::json_line(&line));
        return;
    }
    match (tty, result) {
        (true, Ok(s)) => {
            emit(&format!(
                "{CLEAR}x30ctl watch {} (refresh {refresh}, robot time {}; Ctrl-C to quit)\n\n{}\n\nbattery\n{}\n\n{}",
                ctx.robot,
                render::time_text(&s.status.time),
                render::response_text(&s.status.response),
                render::response_text(&s.battery.response),
                render::response_text(&s.perception.response),
            ));
        }
        (true, Err(e)) => emit(&format!(
            "{CLEAR}x30ctl watch {} (refresh {refresh}; Ctrl-C to quit)\n\nerror: {e}\nretrying on a new connection",
            ctx.robot
        )),
        (false, Ok(s)) => emit(&line(s)),
        (false, Err(e)) => {
            note(&format!("x30ctl: refresh {refresh}: {e}"));
        }
    }
}

/// One plain line per refresh, for pipes and logs.
fn line(s: &Snapshot) -> String {
    let mut text = render::time_text(&s.status.time);
    match s.status.response {
        Response::Status(st) => text.push_str(&status_fields(&st)),
        other => text.push_str(&format!(" status: {}", render::response_text(&other))),
    }
    if let Response::Battery(b) = s.battery.response {
        text.push_str(&battery_fields(&b));
    }
    if let Response::Perception(p) = s.perception.response {
        text.push_str(&perception_fields(&p));
    }
    text
}

fn status_fields(s: &RobotStatus) -> String {
    if s.is_unavailable() {
        return " status unavailable (all items 0)".to_owned();
    }
    format!(
        " state={:?} pos=({}, {}, {}) yaw={} speed={} electricity={}% gait={:?} location={:?} charge={:?} dock={:?}",
        s.motion_state.description(),
        reading(s.pos_x, ""),
        reading(s.pos_y, ""),
        reading(s.pos_z, ""),
        reading(s.yaw, ""),
        reading(s.speed, ""),
        reported_int(s.electricity, ""),
        reported_description(s.gait_state),
        reported_description(s.location),
        reported_description(s.charge_state),
        reported_description(s.on_dock_state),
    )
}

fn battery_fields(b: &Battery) -> String {
    format!(
        " battery={} voltage={} protection={:?}",
        reported_int(b.battery_level, "%"),
        reported_int(b.voltage, "V"),
        reported_description(b.protected_state)
    )
}

fn perception_fields(p: &Perception) -> String {
    format!(" obstacle={:?}", code_text(p.obs_state))
}
