//! The console's commands: what each line does, and the answer a person reads.

use core::fmt::Write as _;

use embassy_time::{Duration, Instant};

use super::Answer;
use crate::app::Snapshot;
use crate::panel::indicators::LinkState;
use crate::proto::codes::NOT_REPORTED;
use crate::proto::xml::number::{F32_TEXT_MAX, parse_f32};
use crate::settings::route::{DEFAULT_POINT_INFO, MAX_ROUTE, RoutePoint, parse_point_info};
use crate::settings::text::NONE;
use crate::settings::{Key, LoadProblem, MAX_VALUE, Settings, write_f32};

/// How old the robot's status may be for `dock here` to take its pose.
pub const POSE_MAX_AGE: Duration = Duration::from_secs(2);

/// What the console must do after a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Nothing more: the answer is written.
    Answered,
    /// Save the edited settings, if they may be saved now.
    Save,
    /// Restart the board.
    Reboot,
}

/// The commands and what they do, for `help`.
const HELP: &str = "\
help [KEY]               this list, or what KEY allows
show [KEY]               every setting (or one), its value, and whether it is the default
set KEY VALUE            change a setting (checked; `save` keeps it)
unset KEY                back to the default (`save` keeps it)
save                     keep the changes in flash and use them (not while moving)
status                   connection, robot, battery, motion state, last fault
dock here [MAP [POINT]]  the robot's pose now is the dock point, saved at once
route show               the patrol route, point by point
route add here [TYPE]    the robot's pose now as the route's next point
route add X Y Z YAW [TYPE]  a point at that pose (m, rad); TYPE: transition, task
                         (default), standing, charging
route clear              no route (`save` keeps any route change)
reboot                   restart the panel (network and button settings apply then)
";

/// Runs one command line, writing its answer to `answer`.
pub fn execute(
    line: &str,
    settings: &mut Settings,
    snapshot: Option<&Snapshot>,
    now: Instant,
    answer: &mut Answer,
) -> Action {
    let line = line.trim();
    let (command, rest) = line.split_once(' ').unwrap_or((line, ""));
    let rest = rest.trim();
    match command {
        "" => Action::Answered,
        "help" | "?" => help(rest, answer),
        "show" => show(rest, settings, answer),
        "set" => set(rest, settings, answer),
        "unset" => unset(rest, settings, answer),
        // Checked and done by the console, right before the flash work.
        "save" if rest.is_empty() => Action::Save,
        "status" if rest.is_empty() => status(settings, snapshot, now, answer),
        "dock" => dock(rest, settings, snapshot, now, answer),
        "route" => route(rest, settings, snapshot, now, answer),
        "reboot" if rest.is_empty() => {
            if !settings.unsaved_changes().is_empty() {
                let _ = writeln!(answer, "changes not saved are dropped");
            }
            let _ = writeln!(answer, "rebooting");
            Action::Reboot
        }
        _ => {
            let _ = writeln!(
                answer,
                "unknown command `{line}`; `help` lists the commands"
            );
            Action::Answered
        }
    }
}

/// Tells what went wrong loading the saved settings.
pub fn tell_load_problem(problem: LoadProblem, answer: &mut Answer) {
    let _ = match problem {
        LoadProblem::Unreadable => writeln!(
            answer,
            "the settings store in flash is damaged or not this panel's: every setting has \
             its default (the fault LED blinks); `save` writes a new store"
        ),
        LoadProblem::NotSettings => writeln!(
            answer,
            "the saved settings are not this firmware's: every setting has its default (the \
             fault LED blinks); `save` writes new ones"
        ),
        LoadProblem::InvalidValues(keys) => {
            let _ = write!(answer, "saved values not valid any more, defaults used: ");
            let _ = write!(answer, "{keys}");
            writeln!(answer)
        }
        LoadProblem::InvalidRoute => writeln!(
            answer,
            "the saved route is not valid any more: the route is empty (the fault LED blinks)"
        ),
        LoadProblem::UnknownKeys(count) => writeln!(
            answer,
            "{count} saved settings are unknown to this firmware (a newer one saved them); \
             they are ignored"
        ),
    };
}

/// `help [KEY]`.
fn help(rest: &str, answer: &mut Answer) -> Action {
    if rest.is_empty() {
        let _ = answer.push_str(HELP);
        let _ = writeln!(answer, "keys (`show` lists their values):");
        for (i, key) in Key::ALL.iter().enumerate() {
            let gap = if i % 4 == 0 { "  " } else { ", " };
            let end = if i % 4 == 3 { "\n" } else { "" };
            let _ = write!(answer, "{gap}{}{end}", key.name());
        }
        let _ = writeln!(answer);
    } else if let Some(key) = key(rest, answer) {
        let _ = writeln!(
            answer,
            "{}: {} (build-time variable {})",
            key.name(),
            key.allowed(),
            key.variable()
        );
    }
    Action::Answered
}

/// `show [KEY]`.
fn show(rest: &str, settings: &Settings, answer: &mut Answer) -> Action {
    if rest.is_empty() {
        for &key in Key::ALL {
            show_key(key, settings, answer);
        }
    } else if let Some(key) = key(rest, answer) {
        show_key(key, settings, answer);
    }
    Action::Answered
}

/// One line of `show`: `name = value  [default]`.
fn show_key(key: Key, settings: &Settings, answer: &mut Answer) {
    let _ = write!(answer, "{:<18} = ", key.name());
    write_shown(key, settings, answer);
    let origin = if settings.is_overridden(key) {
        "set"
    } else {
        "default"
    };
    let unsaved = if settings.unsaved().contains(key) {
        ", not saved"
    } else {
        ""
    };
    let _ = writeln!(answer, "  [{origin}{unsaved}]");
}

/// `set KEY VALUE`.
fn set(rest: &str, settings: &mut Settings, answer: &mut Answer) -> Action {
    let (name, value) = rest.split_once(' ').unwrap_or((rest, ""));
    let Some(key) = key(name, answer) else {
        return Action::Answered;
    };
    let value = value.trim();
    if value.is_empty() {
        let _ = writeln!(answer, "set {} VALUE: {}", key.name(), key.allowed());
        return Action::Answered;
    }
    match settings.set(key, value) {
        Ok(()) => changed(key, settings, answer),
        Err(_) => {
            let _ = writeln!(
                answer,
                "{}: `{value}` is not valid: expected {}; nothing changed",
                key.name(),
                key.allowed()
            );
        }
    }
    Action::Answered
}

/// `unset KEY`.
fn unset(rest: &str, settings: &mut Settings, answer: &mut Answer) -> Action {
    if let Some(key) = key(rest, answer) {
        settings.unset(key);
        changed(key, settings, answer);
    }
    Action::Answered
}

/// Writes `key`'s edited value as the console shows it: a PIN as `****`.
fn write_shown(key: Key, settings: &Settings, answer: &mut Answer) {
    let config = settings.edited();
    if key == Key::WebPin && config.web_pin.is_some() {
        // The PIN guards the web page; whoever reads the console needs no copy of it (nor
        // of the build's, which `unset web-pin` puts back).
        let _ = answer.push_str("****");
    } else {
        let _ = key.write(config, answer);
    }
}

/// The answer to a change: the new value, and that it is not saved yet.
fn changed(key: Key, settings: &Settings, answer: &mut Answer) {
    let _ = write!(answer, "{} = ", key.name());
    write_shown(key, settings, answer);
    let note = if settings.unsaved().contains(key) {
        " (not saved: `save` keeps it)"
    } else {
        " (as saved)"
    };
    let _ = writeln!(answer, "{note}");
}

/// `status`.
fn status(
    settings: &Settings,
    snapshot: Option<&Snapshot>,
    now: Instant,
    answer: &mut Answer,
) -> Action {
    let _ = write!(answer, "robot      ");
    let _ = Key::Robot.write(settings.config(), answer);
    let Some(s) = snapshot else {
        let _ = writeln!(answer, ", the panel is starting");
        return Action::Answered;
    };
    let link = match s.link {
        LinkState::NoNetwork => "no network (no Ethernet link or no address)",
        LinkState::Connecting => "connecting",
        LinkState::NotAnswering => "connected, not answering",
        LinkState::Connected => "connected and answering",
    };
    let _ = writeln!(answer, ", {link}");
    let _ = write!(answer, "board      ");
    match s.board_address {
        Some(cidr) => {
            let [a, b, c, d] = cidr.address;
            let _ = writeln!(answer, "{a}.{b}.{c}.{d}/{}", cidr.prefix_len);
        }
        None => {
            let _ = writeln!(answer, "no address yet");
        }
    }
    let age = |at: Instant| now.saturating_duration_since(at).as_millis();
    match (&s.status, &s.battery) {
        (Some(status), battery) if !status.value.is_unavailable() => {
            // The battery answer's level, else the status's; a robot may report neither.
            let level = battery
                .and_then(|b| b.value.battery_level)
                .or(status.value.electricity);
            let _ = match level {
                Some(level) => writeln!(answer, "battery    {level} %"),
                None => writeln!(answer, "battery    {NOT_REPORTED}"),
            };
            let _ = writeln!(
                answer,
                "motion     {} ({} ms ago)",
                status.value.motion_state,
                age(status.at)
            );
        }
        _ => {
            let _ = writeln!(
                answer,
                "battery    unknown\nmotion     unknown (no status yet)"
            );
        }
    }
    let _ = write!(answer, "fault      ");
    let _ = match (s.faults.iter().next(), s.command_failed) {
        (Some(fault), _) => writeln!(answer, "{}", fault.description()),
        (None, true) => writeln!(answer, "the last command failed"),
        (None, false) => writeln!(answer, "none"),
    };
    let unsaved = settings.unsaved_changes();
    if !unsaved.is_empty() {
        let _ = write!(answer, "unsaved    ");
        let _ = write!(answer, "{unsaved}");
        let _ = writeln!(answer);
    }
    Action::Answered
}

/// `dock here [MAP [POINT]]`: the robot's pose as the dock point, saved at once.
fn dock(
    rest: &str,
    settings: &mut Settings,
    snapshot: Option<&Snapshot>,
    now: Instant,
    answer: &mut Answer,
) -> Action {
    let mut words = rest.split_ascii_whitespace();
    if words.next() != Some("here") {
        let _ = writeln!(answer, "usage: dock here [MAP [POINT]]");
        return Action::Answered;
    }
    let current = settings.edited().dock;
    let mut number = |default: i32| match words.next() {
        None => Some(default),
        Some(word) => word.parse::<i32>().ok(),
    };
    let map = number(current.map_or(1, |p| p.map_id));
    let point = number(current.map_or(1, |p| p.value));
    let (Some(map), Some(point), None) = (map, point, words.next()) else {
        let _ = writeln!(answer, "usage: dock here [MAP [POINT]] (whole numbers)");
        return Action::Answered;
    };
    let Some(pose) = robot_pose(snapshot, now, answer) else {
        return Action::Answered;
    };
    // As long as any dock value: a pose far out or very small takes 48 characters a number.
    let mut text = heapless::String::<MAX_VALUE>::new();
    let _ = write!(text, "{point},{map}");
    for value in pose {
        let _ = text.push(',');
        let _ = write_f32(&mut text, value);
    }
    if settings.set(Key::Dock, &text).is_err() {
        let _ = writeln!(
            answer,
            "the robot's pose `{text}` is not a valid dock point"
        );
        return Action::Answered;
    }
    let _ = writeln!(answer, "dock = {text} (the robot's pose now)");
    Action::Save
}

/// The pose (PosX, PosY, PosZ, Yaw) of a readable status at most [`POSE_MAX_AGE`] old, or
/// an answer saying there is none. A robot that is not localised reports `nan`, which is no
/// place to send it back to.
fn robot_pose(snapshot: Option<&Snapshot>, now: Instant, answer: &mut Answer) -> Option<[f32; 4]> {
    let status = snapshot
        .and_then(|s| s.status)
        .filter(|s| now.saturating_duration_since(s.at) <= POSE_MAX_AGE)
        .filter(|s| !s.value.is_unavailable());
    let Some(status) = status else {
        let _ = writeln!(
            answer,
            "no fresh status from the robot (none within {} s): is it connected?",
            POSE_MAX_AGE.as_secs()
        );
        return None;
    };
    let s = status.value;
    let pose = [s.pos_x, s.pos_y, s.pos_z, s.yaw];
    if !pose.iter().all(|v| v.is_finite()) {
        let _ = writeln!(
            answer,
            "the robot does not know its pose (it reports nan or inf): is it localised?"
        );
        return None;
    }
    Some(pose)
}

/// `route show`, `route clear`, `route add here [TYPE]`, `route add X Y Z YAW [TYPE]`.
fn route(
    rest: &str,
    settings: &mut Settings,
    snapshot: Option<&Snapshot>,
    now: Instant,
    answer: &mut Answer,
) -> Action {
    let mut words = rest.split_ascii_whitespace();
    match (words.next(), words.next()) {
        (Some("show"), None) => show_route(settings, answer),
        (Some("clear"), None) => {
            settings.clear_route();
            let _ = writeln!(answer, "route cleared (not saved: `save` keeps it)");
        }
        (Some("add"), Some(first)) => {
            let (pose, kind) = if first == "here" {
                let Some(pose) = robot_pose(snapshot, now, answer) else {
                    return Action::Answered;
                };
                (pose, words.next())
            } else {
                let mut pose = [0.0; 4];
                let mut numbers = core::iter::once(first).chain(&mut words);
                for value in &mut pose {
                    match numbers.next().map(|w| parse_f32(w.as_bytes())) {
                        Some(Ok(v)) => *value = v,
                        _ => {
                            let _ = writeln!(answer, "usage: {ROUTE_ADD_USAGE}");
                            return Action::Answered;
                        }
                    }
                }
                (pose, words.next())
            };
            add_route_point(settings, pose, kind, words.next(), answer);
        }
        _ => {
            let _ = writeln!(
                answer,
                "usage: route show | route clear | route add here [TYPE] | {ROUTE_ADD_USAGE}"
            );
        }
    }
    Action::Answered
}

/// How `route add` with coordinates is typed.
const ROUTE_ADD_USAGE: &str =
    "route add X Y Z YAW [TYPE] (TYPE: transition, task, standing or charging)";

/// Adds a point at `pose` of type `kind` (default task) to the edited route, numbered after
/// the last one and on its map (the dock's map for a first point, else 1).
fn add_route_point(
    settings: &mut Settings,
    pose: [f32; 4],
    kind: Option<&str>,
    extra: Option<&str>,
    answer: &mut Answer,
) {
    let info = match kind.map(parse_point_info) {
        None => DEFAULT_POINT_INFO,
        Some(Some(info)) if extra.is_none() => info,
        Some(_) => {
            let _ = writeln!(answer, "usage: {ROUTE_ADD_USAGE}");
            return;
        }
    };
    let edited = settings.edited();
    let map = edited
        .route
        .last()
        .map(|p| p.map)
        .or(edited.dock.map(|d| d.map_id))
        .unwrap_or(1);
    let number = edited.route.len() as i32 + 1;
    let point = RoutePoint {
        point: number,
        map,
        pose,
        info,
    };
    if point.nav_point().validate().is_err() {
        let _ = writeln!(answer, "not a valid point: the numbers must be finite");
        return;
    }
    if settings.add_route_point(point).is_err() {
        let _ = writeln!(
            answer,
            "the route is full ({MAX_ROUTE} points); nothing added"
        );
        return;
    }
    let _ = write!(answer, "point {number}: ");
    let _ = point.write(answer);
    let _ = writeln!(answer, " (not saved: `save` keeps it)");
}

/// The most a point's line of `route show` takes: its number, and the point as
/// [`RoutePoint::write`] writes it, each number at its longest.
const ROUTE_LINE_MAX: usize = 4 + 2 * 11 + 1 + 4 * (1 + F32_TEXT_MAX) + 1 + 10 + 2;

/// Room `route show` leaves after its points: the note that the route is not saved, and the
/// prompt the console adds.
const AFTER_ROUTE: usize = 64;

/// `route show`: every point, unless the numbers are too long for them all to fit the
/// answer, then as many as fit and how many more there are.
fn show_route(settings: &Settings, answer: &mut Answer) {
    let route = &settings.edited().route;
    if route.is_empty() {
        let _ = writeln!(
            answer,
            "no route: `route add here` at each point, then `save`"
        );
    }
    for (shown, point) in route.iter().enumerate() {
        if answer.capacity().saturating_sub(answer.len()) < ROUTE_LINE_MAX + AFTER_ROUTE {
            let more = route.len() - shown;
            let _ = writeln!(answer, "... and {more} more points, too long to show here");
            break;
        }
        let _ = write!(answer, "{:>2}. ", point.point);
        let _ = point.write(answer);
        let _ = writeln!(answer);
    }
    if settings.route_unsaved() {
        let _ = writeln!(answer, "(not saved: `save` keeps it)");
    }
}

/// The key named `name`, or an answer saying there is none.
fn key(name: &str, answer: &mut Answer) -> Option<Key> {
    let key = Key::from_name(name);
    if key.is_none() {
        let shown = if name.is_empty() { NONE } else { name };
        let _ = writeln!(answer, "no setting `{shown}`; `show` lists them");
    }
    key
}
