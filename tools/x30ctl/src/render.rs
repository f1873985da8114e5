//! Human-readable and JSON output of answers and requests, and readable text for the core's
//! error enums.
//!
//! The JSON is the core's own serialisation (its `serde` feature): every message's items,
//! codes as `{"code", "name", "description"}` objects, times as text. This module only puts
//! the envelope in front (`kind`, `type`, `command`, and for answers the message ID and
//! time) and adds what the core computes but does not store: whether a status is
//! unavailable, the robot's map pixel, and the hottest motor.
//!
//! Floats are printed with Rust's shortest round-trip form (`{}` and serde_json), never
//! with a fixed number of digits: existing clients lose position precision by printing
//! six significant digits (docs/protocol.md, "Mistakes of existing clients").
//!
//! Nothing here panics when stdout or stderr is closed: `println!` would, so every write
//! goes through [`emit`] and [`note`], which drop write errors.

use std::fmt::{self, Write as _};
use std::io::{self, Write as _};

use serde::Serialize;
use x30_panel::proto::codes::*;
use x30_panel::proto::message::{
    Battery, CommandAck, Light, MotionAck, MotionCommand, MotionValue, MotorTemperatures, NavPoint,
    NavResult, NavTaskState, Perception, Relocalize, RelocalizeAck, Request, RequestError,
    Response, RobotStatus, ValidationError,
};
use x30_panel::proto::time::{TIME_TEXT_LEN, Timestamp};

/// Writes one line to stdout; a closed stdout is not worth a panic.
pub fn emit(line: &str) {
    let mut out = io::stdout().lock();
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}

/// Writes one line to stderr (errors, warnings, progress).
pub fn note(line: &str) {
    let _ = writeln!(io::stderr().lock(), "{line}");
}

/// Writes a warning to stderr, prefixed so it is not mistaken for an answer.
pub fn warn(line: &str) {
    note(&format!("x30ctl: warning: {line}"));
}

/// JSON text of a value; serialising these plain values cannot fail, but a failure would
/// still produce valid JSON rather than a panic.
pub fn json_line<T: Serialize>(value: &T) -> String {
    serde_json::to_string(value).unwrap_or_else(|e| format!("{{\"error\":{:?}}}", e.to_string()))
}

/// `YYYY-MM-DD HH:MM:SS`.
pub fn time_text(time: &Timestamp) -> String {
    let mut text = [0u8; TIME_TEXT_LEN];
    time.encode(&mut text);
    String::from_utf8_lossy(&text).into_owned()
}

/// `meaning (code)`, the human form of a code.
pub fn code_text<T: Code>(value: T) -> String {
    format!("{} ({})", value.description(), value.raw())
}

/// An item the robot may leave out: its `text`, or [`NOT_REPORTED`].
fn reported<T>(value: Option<T>, text: impl FnOnce(T) -> String) -> String {
    value.map_or_else(|| NOT_REPORTED.to_owned(), text)
}

/// A coded item the robot may leave out: [`code_text`], or [`NOT_REPORTED`].
pub fn reported_code_text<T: Code>(value: Option<T>) -> String {
    reported(value, code_text)
}

/// An integer item the robot may leave out, with its unit, or [`NOT_REPORTED`].
pub fn reported_int(value: Option<i32>, unit: &str) -> String {
    reported(value, |v| format!("{v}{unit}"))
}

// ---------------------------------------------------------------------------------------
// Answers
// ---------------------------------------------------------------------------------------

/// A short stable name for each kind of answer (the `kind` field of the JSON).
pub fn response_kind(response: &Response) -> &'static str {
    match response {
        Response::Status(_) => "status",
        Response::NavResult(_) => "nav_result",
        Response::CancelNav(_) => "cancel_nav",
        Response::NavStatus(_) => "nav_status",
        Response::MotorTemperatures(_) => "motor_temperatures",
        Response::Light(_) => "light",
        Response::Motion(..) => "motion",
        Response::Battery(_) => "battery",
        Response::Perception(_) => "perception",
        Response::Relocalize(_) => "relocalize",
        Response::RequestError(_) => "request_error",
    }
}

/// One answer as JSON: the envelope, then the answer's items, in one object.
#[derive(Debug, Serialize)]
pub struct AnswerJson<'a> {
    /// See [`response_kind`].
    pub kind: &'static str,
    /// The message Type.
    #[serde(rename = "type")]
    pub message_type: i32,
    /// The `Command`.
    pub command: i32,
    /// The frame's message ID.
    pub message_id: u16,
    /// The robot's `Time`, as its text.
    pub time: Timestamp,
    /// The items.
    #[serde(flatten)]
    pub items: AnswerItemsJson<'a>,
}

/// The items of an answer: the core's serialisation, with x30ctl's additions to the status
/// and the motor temperatures.
#[derive(Debug, Serialize)]
#[serde(untagged)]
pub enum AnswerItemsJson<'a> {
    /// Type 1002.
    Status {
        /// True when every item is 0: status unavailable, not a robot at the origin.
        unavailable: bool,
        /// The items.
        #[serde(flatten)]
        status: &'a RobotStatus,
        /// The position in map-image pixels, when `res` allows the conversion.
        map_pixel: Option<PixelJson>,
    },
    /// Type 1008, °C.
    Motors {
        /// The items.
        #[serde(flatten)]
        temperatures: &'a MotorTemperatures,
        /// The hottest of those reported (null if none is).
        max: f32,
    },
    /// Every other answer, as the core serialises it.
    Other(&'a Response),
}

/// A map-image pixel.
#[derive(Debug, Serialize)]
pub struct PixelJson {
    /// Column.
    pub x: i32,
    /// Row, from the top.
    pub y: i32,
}

/// The JSON object of an answer.
pub fn answer_json<'a>(
    message_id: u16,
    time: &Timestamp,
    response: &'a Response,
) -> AnswerJson<'a> {
    let items = match response {
        Response::Status(s) => AnswerItemsJson::Status {
            unavailable: s.is_unavailable(),
            status: s,
            map_pixel: map_pixel(s).map(|(x, y)| PixelJson { x, y }),
        },
        Response::MotorTemperatures(m) => AnswerItemsJson::Motors {
            temperatures: m,
            max: m.max(),
        },
        other => AnswerItemsJson::Other(other),
    };
    AnswerJson {
        kind: response_kind(response),
        message_type: response.message_type().raw(),
        command: response.command(),
        message_id,
        time: *time,
        items,
    }
}

/// The robot's position in map-image pixels, if the status is available and `Res` usable.
fn map_pixel(s: &RobotStatus) -> Option<(i32, i32)> {
    if s.is_unavailable() {
        return None;
    }
    s.map_image()?.to_pixel(s.pos_x, s.pos_y)
}

/// A reading the robot reports, with its unit: C's `nan` or `inf`, which a robot prints for
/// a reading it does not have (an unknown pose), reads "unknown".
pub fn reading(value: f32, unit: &str) -> String {
    match (value.is_finite(), unit) {
        (false, _) => "unknown".to_owned(),
        (true, "") => value.to_string(),
        (true, unit) => format!("{value} {unit}"),
    }
}

/// The line printed for an unavailable status.
pub const STATUS_UNAVAILABLE: &str = "status unavailable (all items 0): the robot could not read its status, or its navigation program is not running";

/// Aligned `label  value` lines.
struct Table {
    text: String,
}

impl Table {
    fn new() -> Self {
        Self {
            text: String::new(),
        }
    }

    fn row(&mut self, label: &str, value: impl fmt::Display) -> &mut Self {
        if !self.text.is_empty() {
            self.text.push('\n');
        }
        let _ = write!(self.text, "{label:<14} {value}");
        self
    }

    fn finish(&mut self) -> String {
        std::mem::take(&mut self.text)
    }
}

/// The human-readable form of an answer: one line for acknowledgements, a table for
/// status-like answers.
pub fn response_text(response: &Response) -> String {
    match response {
        Response::Status(s) => status_text(s),
        Response::NavResult(r) => nav_result_text(r),
        Response::CancelNav(a) => format!(
            "cancel navigation task: {} (ErrorCode {})",
            a.result.description(),
            a.result.raw()
        ),
        Response::NavStatus(s) => nav_status_text(s),
        Response::MotorTemperatures(m) => motors_text(m),
        Response::Light(a) => format!(
            "indicator light: {} (ErrorCode {})",
            a.result.description(),
            a.result.raw()
        ),
        Response::Motion(code, ack) => motion_ack_text(*code, ack),
        Response::Battery(b) => battery_text(b),
        Response::Perception(p) => perception_text(p),
        Response::Relocalize(a) => relocalize_text(a),
        Response::RequestError(e) => request_error_text(e),
    }
}

fn status_text(s: &RobotStatus) -> String {
    if s.is_unavailable() {
        return STATUS_UNAVAILABLE.to_owned();
    }
    let pixel = match map_pixel(s) {
        Some((x, y)) => format!(" (map pixel {x}, {y})"),
        None => String::new(),
    };
    Table::new()
        .row("motion state", code_text(s.motion_state))
        .row(
            "position",
            format_args!(
                "x {}, y {}, z {}{pixel}",
                reading(s.pos_x, "m"),
                reading(s.pos_y, "m"),
                reading(s.pos_z, "m")
            ),
        )
        .row(
            "attitude",
            format_args!(
                "roll {}, pitch {}, yaw {}",
                reading(s.roll, "rad"),
                reading(s.pitch, "rad"),
                reading(s.yaw, "rad")
            ),
        )
        .row("speed", reading(s.speed, "m/s"))
        .row(
            "odometry",
            format_args!(
                "{} since power-on, {} total",
                reading(s.cur_odom, "km"),
                reading(s.sum_odom, "km")
            ),
        )
        .row("battery", reported_int(s.electricity, " %"))
        .row("gait", reported_code_text(s.gait_state))
        .row("localisation", reported_code_text(s.location))
        .row("motors", reported_code_text(s.motor_state))
        .row("charging", reported_code_text(s.charge_state))
        .row("dock", reported_code_text(s.on_dock_state))
        .row("control mode", reported_code_text(s.control_mode))
        .row(
            "map image",
            format_args!(
                "{}, bottom-left corner at x {}, y {}, {} high",
                reading(s.res, "m/px"),
                reading(s.x0, "m"),
                reading(s.y0, "m"),
                reported_int(s.h, " px")
            ),
        )
        .finish()
}

/// One line describing how a navigation task ended.
pub fn nav_result_text(r: &NavResult) -> String {
    format!(
        "navigation to point {}: {} (ErrorCode {}), {} (ErrorStatus {})",
        r.value,
        r.outcome.description(),
        r.outcome.raw(),
        r.status.description(),
        r.status.raw()
    )
}

fn nav_status_text(s: &NavTaskState) -> String {
    let mut text = format!(
        "navigation task status: point {}, {} (Status {})",
        s.value,
        s.status.description(),
        s.status.raw()
    );
    if s.error_code != s.status {
        let _ = write!(text, ", ErrorCode {}", s.error_code.raw());
    }
    text
}

fn motors_text(m: &MotorTemperatures) -> String {
    // A temperature the robot did not report reads "unknown", as any other reading does.
    let leg = |sway: f32, hip: f32, knee: f32| {
        format!(
            "sway {}, hip {}, knee {}",
            reading(sway, "°C"),
            reading(hip, "°C"),
            reading(knee, "°C")
        )
    };
    Table::new()
        .row(
            "left front",
            leg(m.left_front_sway, m.left_front_hip, m.left_front_knee),
        )
        .row(
            "right front",
            leg(m.right_front_sway, m.right_front_hip, m.right_front_knee),
        )
        .row(
            "left back",
            leg(m.left_back_sway, m.left_back_hip, m.left_back_knee),
        )
        .row(
            "right back",
            leg(m.right_back_sway, m.right_back_hip, m.right_back_knee),
        )
        .row("hottest", reading(m.max(), "°C"))
        .finish()
}

/// A Type 2 `Value` as the user thinks of it.
fn motion_value_text(code: MotionCommandCode, value: f32) -> String {
    match code {
        MotionCommandCode::SwitchGait => {
            let gait = MotionGait::from_raw(value as i32);
            format!("gait {}", code_text(gait))
        }
        MotionCommandCode::Forward
        | MotionCommandCode::Backward
        | MotionCommandCode::StrafeLeft
        | MotionCommandCode::StrafeRight => speed_text(value, "m/s"),
        MotionCommandCode::TurnLeft | MotionCommandCode::TurnRight => speed_text(value, "rad/s"),
        _ => format!("Value {value}"),
    }
}

fn speed_text(value: f32, unit: &str) -> String {
    if value == -1.0 {
        "the robot's default speed".to_owned()
    } else {
        format!("{value} {unit}")
    }
}

fn motion_ack_text(code: MotionCommandCode, ack: &MotionAck) -> String {
    format!(
        "{} (Type 2 Command {}, {}): {} (ErrorCode {})",
        code.description(),
        code.raw(),
        ack.value.map_or("no Value echoed".to_owned(), |value| {
            motion_value_text(code, value)
        }),
        ack.result.description(),
        ack.result.raw()
    )
}

fn battery_text(b: &Battery) -> String {
    // Amperes and ampere-hours from the robot's units of 10 mA and 10 mAh.
    let hundredths = |value: i32, unit: &str| format!("{} {unit}", f64::from(value) / 100.0);
    let capacity = |value: Option<i32>| reported(value, |v| hundredths(v, "Ah"));
    Table::new()
        .row("level", reported_int(b.battery_level, " %"))
        .row("voltage", reported_int(b.voltage, " V"))
        .row(
            "current",
            reported(b.current, |c| {
                format!("{} ({c} x 10 mA)", hundredths(c, "A"))
            }),
        )
        .row(
            "capacity",
            format_args!(
                "remaining {}, nominal {}",
                capacity(b.remaining_capacity),
                capacity(b.nominal_capacity)
            ),
        )
        .row("cycles", reported_int(b.cycles, ""))
        .row("protection", reported_code_text(b.protected_state))
        .row(
            "temperature",
            reported(b.battery_temperature, |t| format!("{t} °C")),
        )
        .finish()
}

fn perception_text(p: &Perception) -> String {
    format!(
        "obstacle: {} (ObsState {})",
        p.obs_state.description(),
        p.obs_state.raw()
    )
}

fn relocalize_text(a: &RelocalizeAck) -> String {
    format!(
        "initialise localisation: {} (ErrorCode {})",
        a.result.description(),
        a.result.raw()
    )
}

fn request_error_text(e: &RequestError) -> String {
    format!(
        "request error (Type 0): ErrorCode {} ({})",
        e.code.raw(),
        e.code.description()
    )
}

/// Whether an answer reports that the request failed, and the message for stderr.
///
/// `what` names the command for the message (`light`, `cancel`, ...).
pub fn failure(what: &str, response: &Response) -> Option<String> {
    let ack_failed = |a: &CommandAck| {
        (!a.result.is_success()).then(|| {
            format!(
                "{what} failed: ErrorCode {}, \"{}\"",
                a.result.raw(),
                a.result.description()
            )
        })
    };
    match response {
        Response::NavResult(r) if !r.outcome.is_success() => Some(format!(
            "{what} {}: ErrorStatus {}, \"{}\"",
            match r.outcome {
                NavOutcome::Cancelled => "cancelled",
                _ => "failed",
            },
            r.status.raw(),
            r.status.description()
        )),
        Response::CancelNav(a) | Response::Light(a) => ack_failed(a),
        Response::Motion(code, ack) if !ack.result.is_success() => Some(format!(
            "{what} failed: the robot refused {} (Type 2 Command {}): ErrorCode {}, \"{}\"",
            code.description(),
            code.raw(),
            ack.result.raw(),
            ack.result.description()
        )),
        Response::Relocalize(a) if a.result != LocalizationResult::Localized => Some(format!(
            "{what} failed: ErrorCode {}, \"{}\"",
            a.result.raw(),
            a.result.description()
        )),
        _ => None,
    }
}

// ---------------------------------------------------------------------------------------
// Requests (for `decode`)
// ---------------------------------------------------------------------------------------

/// A request as JSON, for `decode`: the envelope, then the core's serialisation of the
/// request's items (nothing for a request without items).
#[derive(Debug, Serialize)]
pub struct RequestJson<'a> {
    /// A short stable name: status, nav_task, cancel_nav, nav_status, motor_temperatures,
    /// light, motion, battery, perception, relocalize.
    pub kind: &'static str,
    /// The message Type.
    #[serde(rename = "type")]
    pub message_type: i32,
    /// The `Command`.
    pub command: i32,
    /// The items.
    #[serde(flatten)]
    pub items: &'a Request,
}

fn request_kind(request: &Request) -> &'static str {
    match request {
        Request::Status => "status",
        Request::NavTask(_) => "nav_task",
        Request::CancelNav => "cancel_nav",
        Request::NavStatus => "nav_status",
        Request::MotorTemperatures => "motor_temperatures",
        Request::Light(_) => "light",
        Request::Motion(_) => "motion",
        Request::Battery => "battery",
        Request::Perception => "perception",
        Request::Relocalize(_) => "relocalize",
    }
}

/// The JSON object of a request.
pub fn request_json(request: &Request) -> RequestJson<'_> {
    RequestJson {
        kind: request_kind(request),
        message_type: request.message_type().raw(),
        command: request.command(),
        items: request,
    }
}

/// One line describing a 1003 point.
pub fn nav_point_text(p: &NavPoint) -> String {
    format!(
        "point {} on map {} at x {} m, y {} m, z {} m, yaw {} rad; {}; gait {}; speed {}; {}; {}; {}; {}; {}",
        p.value,
        p.map_id,
        p.pos_x,
        p.pos_y,
        p.pos_z,
        p.angle_yaw,
        code_text(p.point_info),
        code_text(p.gait),
        code_text(p.speed),
        code_text(p.manner),
        code_text(p.obs_mode),
        code_text(p.nav_mode),
        code_text(p.terrain),
        code_text(p.posture),
    )
}

fn light_text(l: &Light) -> String {
    format!(
        "indicator light: red {}, green {}, blue {}, {}, brightness {} %",
        l.red,
        l.green,
        l.blue,
        code_text(l.effect),
        l.brightness
    )
}

fn relocalize_request_text(r: &Relocalize) -> String {
    format!(
        "initialise localisation at x {} m, y {} m, z {} m, yaw {} rad",
        r.pos_x, r.pos_y, r.pos_z, r.yaw
    )
}

fn motion_request_text(m: &MotionCommand) -> String {
    let value = match m.value() {
        MotionValue::Float(v) => motion_value_text(m.code(), v),
        MotionValue::Int(v) => format!("gait {}", code_text(MotionGait::from_raw(v))),
    };
    format!(
        "motion: {} (Command {}), {value}",
        m.code().description(),
        m.code().raw()
    )
}

/// The human-readable form of a request.
pub fn request_text(request: &Request) -> String {
    match request {
        Request::NavTask(task) => {
            let mut text = String::from("navigation task:");
            for point in &task.points {
                let _ = write!(text, "\n  {}", nav_point_text(point));
            }
            text
        }
        Request::Motion(m) => motion_request_text(m),
        Request::Light(l) => light_text(l),
        Request::Relocalize(r) => relocalize_request_text(r),
        other => format!("{} request (no items)", other.message_type().description()),
    }
}

// ---------------------------------------------------------------------------------------
// Validation errors in the command line's own words (its flag values)
// ---------------------------------------------------------------------------------------

/// Why a request breaks the document's rules, as text.
pub fn validation_error_text(e: &ValidationError) -> String {
    match e {
        ValidationError::SpeedOutOfRange { max } => {
            format!("speed out of range: -1 (the robot's default) or 0..={max} allowed")
        }
        ValidationError::BrightnessOutOfRange => "brightness above 100 %".to_owned(),
        ValidationError::UnknownCode { item } => {
            format!("{item} holds a code protocol V1.0.12 does not define")
        }
        ValidationError::NotFinite { item } => format!("{item} is not a finite number"),
        ValidationError::GaitNotAllowedOnTerrain => {
            "terrain frame (accumulated frame) allows only the gaits frame-stairs and frame-stairs-45"
                .to_owned()
        }
        ValidationError::GaitNotAllowedWhenCrouched => {
            "posture crouched allows only the gaits walk and slope".to_owned()
        }
        ValidationError::NoPoints => "a navigation task needs a point".to_owned(),
        other => format!("{other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readings_the_robot_does_not_have_read_unknown() {
        assert_eq!(reading(-0.000_233_936_21, "m"), "-0.00023393621 m");
        assert_eq!(reading(1.5, ""), "1.5");
        for value in [f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(reading(value, "rad"), "unknown", "{value}");
        }
    }

    #[test]
    fn a_motor_temperature_the_robot_does_not_report_reads_unknown() {
        let m = MotorTemperatures {
            left_front_sway: 31.5,
            left_front_hip: f32::NAN,
            left_front_knee: 33.0,
            right_front_sway: f32::NAN,
            right_front_hip: f32::NAN,
            right_front_knee: f32::NAN,
            left_back_sway: f32::NAN,
            left_back_hip: f32::NAN,
            left_back_knee: f32::NAN,
            right_back_sway: f32::NAN,
            right_back_hip: f32::NAN,
            right_back_knee: 40.0,
        };
        let text = motors_text(&m);
        assert!(
            text.contains("sway 31.5 °C, hip unknown, knee 33 °C"),
            "{text}"
        );
        assert!(text.contains("hottest        40 °C"), "{text}");
        let none = MotorTemperatures {
            left_front_sway: f32::NAN,
            left_front_knee: f32::NAN,
            right_back_knee: f32::NAN,
            ..m
        };
        assert!(motors_text(&none).contains("hottest        unknown"));
        // In JSON, a temperature not reported, and the hottest of none, are null.
        let json = serde_json::to_string(&AnswerItemsJson::Motors {
            temperatures: &none,
            max: none.max(),
        })
        .unwrap();
        assert!(json.contains("\"left_front_sway\":null"), "{json}");
        assert!(json.contains("\"max\":null"), "{json}");
    }

    #[test]
    fn a_battery_reading_the_robot_does_not_report_reads_not_reported() {
        let b = Battery {
            voltage: None,
            current: Some(-120),
            remaining_capacity: None,
            nominal_capacity: Some(2004),
            cycles: None,
            protected_state: Some(ProtectedState::Triggered),
            battery_level: None,
            battery_temperature: None,
        };
        let text = battery_text(&b);
        for row in [
            "level          not reported",
            "voltage        not reported",
            "current        -1.2 A (-120 x 10 mA)",
            "capacity       remaining not reported, nominal 20.04 Ah",
            "cycles         not reported",
            "protection     protection triggered (1)",
        ] {
            assert!(text.contains(row), "{row:?} in\n{text}");
        }
        // In JSON, an item not reported is null.
        let json = json_line(&b);
        assert!(json.contains("\"voltage\":null"), "{json}");
        assert!(json.contains("\"battery_level\":null"), "{json}");
    }

    #[test]
    fn a_map_image_the_robot_does_not_report_reads_unknown() {
        let reported = RobotStatus {
            motion_state: MotionState::ForceControlStand,
            res: 0.05,
            x0: -25.6,
            y0: -18.35,
            ..RobotStatus::UNAVAILABLE
        };
        assert!(
            status_text(&reported)
                .contains("0.05 m/px, bottom-left corner at x -25.6 m, y -18.35 m, 0 px high"),
            "{}",
            status_text(&reported)
        );
        let left_out = RobotStatus {
            res: f32::NAN,
            x0: f32::NAN,
            y0: f32::NAN,
            ..reported
        };
        assert!(
            status_text(&left_out)
                .contains("unknown, bottom-left corner at x unknown, y unknown, 0 px high"),
            "{}",
            status_text(&left_out)
        );
    }

    #[test]
    fn codes_serialise_with_number_name_and_meaning() {
        assert_eq!(
            json_line(&ErrorStatus::BatteryTooLow),
            r#"{"code":41730,"name":"BatteryTooLow","description":"battery too low"}"#
        );
        assert_eq!(
            json_line(&ErrorStatus::from_raw(12345)),
            r#"{"code":12345,"name":"Unknown","description":"unknown code"}"#
        );
    }

    #[test]
    fn items_codes_and_times_read_back_from_their_json() {
        let battery = Battery {
            voltage: Some(58),
            current: Some(-120),
            remaining_capacity: Some(1803),
            nominal_capacity: Some(2004),
            cycles: Some(12),
            protected_state: Some(ProtectedState::from_raw(7)),
            battery_level: Some(90),
            battery_temperature: None,
        };
        let json = json_line(&battery);
        assert_eq!(serde_json::from_str::<Battery>(&json).ok(), Some(battery));
        let time = Timestamp {
            year: 2024,
            month: 2,
            day: 29,
            hour: 23,
            minute: 59,
            second: 58,
        };
        assert_eq!(json_line(&time), r#""2024-02-29 23:59:58""#);
        assert_eq!(
            serde_json::from_str::<Timestamp>(r#""2024-02-29 23:59:58""#).ok(),
            Some(time)
        );
        assert!(serde_json::from_str::<Timestamp>(r#""2024-02-29""#).is_err());
        assert_eq!(
            serde_json::from_str::<NavOutcome>(r#"{"code":2,"name":"anything"}"#).ok(),
            Some(NavOutcome::Cancelled)
        );
    }

    #[test]
    fn floats_keep_full_precision() {
        let mut status = RobotStatus {
            motion_state: MotionState::Stepping,
            pos_x: -0.000_233_936_21,
            pos_y: 123.456_79,
            res: 0.05,
            h: Some(100),
            electricity: Some(80),
            ..RobotStatus::UNAVAILABLE
        };
        let text = response_text(&Response::Status(status));
        assert!(text.contains("x -0.00023393621 m"), "{text}");
        assert!(text.contains("y 123.45679 m"), "{text}");
        let json = json_line(&answer_json(0, &Timestamp::ZERO, &Response::Status(status)));
        assert!(json.contains("\"pos_x\":-0.00023393621"), "{json}");
        status = RobotStatus {
            motion_state: MotionState::LyingDown,
            pos_x: 0.0,
            pos_y: 0.0,
            res: 0.0,
            h: Some(0),
            electricity: Some(0),
            ..status
        };
        assert_eq!(response_text(&Response::Status(status)), STATUS_UNAVAILABLE);
    }
}
