//! The web page's library side: the `/api/status` JSON, the `/` page, the `/settings` page
//! and what a POST of its form does, saved by a real console over a simulated flash.

// The store's tests use the whole simulated chip; these only a blank one.
#[allow(dead_code)]
#[path = "common/sim_flash.rs"]
mod sim_flash;
#[path = "common/steady.rs"]
mod steady;
// The console's tests read the screen; these only need a terminal.
#[allow(dead_code)]
#[path = "common/terminal.rs"]
mod terminal;

use embassy_time::{Duration, Instant};
use serde_json::Value;
use sim_flash::{PAGE, SimFlash};
use steady::steady;
use terminal::{Keyboard, Screen};
use x30_panel::app::{Shared, Snapshot};
use x30_panel::config::{Cidr, Config, RobotAddress};
use x30_panel::console;
use x30_panel::panel::indicators::{Faults, LinkState};
use x30_panel::panel::monitor::{RobotView, STALE_AFTER_POLLS, Stamped};
use x30_panel::panel::{Busy, Button, ButtonEvent, Indicators, Led};
use x30_panel::proto::codes::{
    ChargeState, ControlMode, GaitState, Location, MotionState, MotorState, NavTaskStatus,
    ObsState, OnDockState, ProtectedState,
};
use x30_panel::proto::message::{
    Battery, MotorTemperatures, NavTaskState, Perception, Response, RobotStatus,
};
use x30_panel::settings::desk::Desk;
use x30_panel::settings::route::RoutePoint;
use x30_panel::settings::store::{BUF_LEN, Store};
use x30_panel::settings::{Key, MAX_VALUE, Settings};
use x30_panel::web::{
    self, FORM_MAX, INDEX_HTML, Posted, SETTINGS_PAGE_MAX, STATUS_MAX, json::WORD_MAX,
};

/// When the test snapshots' answers arrived.
const T0: Instant = Instant::from_secs(1000);

/// The twelve motor items, in the document's order.
const MOTORS: [&str; 12] = [
    "LeftFrontSway",
    "LeftFrontHip",
    "LeftFrontKnee",
    "RightFrontSway",
    "RightFrontHip",
    "RightFrontKnee",
    "LeftBackSway",
    "LeftBackHip",
    "LeftBackKnee",
    "RightBackSway",
    "RightBackHip",
    "RightBackKnee",
];

/// A robot stepping at (1.5, -2, 0.1) in the slope gait, 87 % charged.
fn status() -> RobotStatus {
    RobotStatus {
        motion_state: MotionState::Stepping,
        pos_x: 1.5,
        pos_y: -2.0,
        pos_z: 0.1,
        yaw: 0.5,
        speed: 0.25,
        electricity: Some(87),
        gait_state: Some(GaitState::Slope),
        ..RobotStatus::UNAVAILABLE
    }
}

/// A battery at 76 %, 31.5 °C.
fn battery() -> Battery {
    Battery {
        voltage: Some(52),
        current: Some(-150),
        remaining_capacity: Some(3100),
        nominal_capacity: Some(4000),
        cycles: Some(12),
        protected_state: Some(ProtectedState::Normal),
        battery_level: Some(76),
        battery_temperature: Some(31.5),
    }
}

/// Motors at 30 °C, 31 °C, … in the document's order.
fn motors() -> MotorTemperatures {
    let t = |i: u8| 30.0 + f32::from(i);
    MotorTemperatures {
        left_front_sway: t(0),
        left_front_hip: t(1),
        left_front_knee: t(2),
        right_front_sway: t(3),
        right_front_hip: t(4),
        right_front_knee: t(5),
        left_back_sway: t(6),
        left_back_hip: t(7),
        left_back_knee: t(8),
        right_back_sway: t(9),
        right_back_hip: t(10),
        right_back_knee: t(11),
    }
}

/// A connected panel whose every answer arrived at [`T0`], running a task to point 7.
fn snapshot() -> Snapshot {
    Snapshot {
        link: LinkState::Connected,
        robot: Config::default().robot,
        status: Some(Stamped::new(status(), T0)),
        battery: Some(Stamped::new(battery(), T0)),
        perception: Some(Stamped::new(
            Perception {
                obs_state: ObsState::ObstacleAhead,
            },
            T0,
        )),
        motors: Some(Stamped::new(motors(), T0)),
        nav: Some(Stamped::new(
            NavTaskState {
                value: 7,
                status: NavTaskStatus::Running,
                error_code: NavTaskStatus::Running,
            },
            T0,
        )),
        polls: Config::default().polls,
        faults: Faults::default(),
        leds: Indicators {
            link: Led::On,
            activity: Led::Off,
            fault: Led::Blink,
        },
        command_failed: false,
        busy: Some(Busy::TaskRunning),
        board_address: Some(Cidr {
            address: [10, 0, 2, 15],
            prefix_len: 24,
        }),
        at: T0,
    }
}

/// The JSON text of `snapshot` at `now`.
fn json_text(snapshot: Option<&Snapshot>, now: Instant) -> String {
    let mut text = String::new();
    web::write_status(snapshot, now, &mut text).unwrap();
    text
}

/// The JSON of `snapshot` at `now`, parsed.
fn json(snapshot: Option<&Snapshot>, now: Instant) -> Value {
    let text = json_text(snapshot, now);
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// The keys of a JSON object, sorted.
fn keys(value: &Value) -> Vec<&str> {
    let mut keys: Vec<&str> = value
        .as_object()
        .unwrap_or_else(|| panic!("not an object: {value}"))
        .keys()
        .map(String::as_str)
        .collect();
    keys.sort_unstable();
    keys
}

/// `names` and the keys every answer's object has, sorted.
fn answer_keys<'a>(names: &[&'a str]) -> Vec<&'a str> {
    let mut all = names.to_vec();
    all.extend(["age_ms", "stale", "text"]);
    all.sort_unstable();
    all
}

#[test]
fn the_json_holds_every_answer_under_its_protocol_names() {
    let now = T0 + Duration::from_millis(120);
    let j = json(Some(&snapshot()), now);
    assert_eq!(
        keys(&j),
        [
            "battery",
            "busy",
            "connection",
            "faults",
            "leds",
            "motors",
            "nav",
            "obstacle",
            "status"
        ]
    );
    assert_eq!(
        j["connection"],
        serde_json::json!({
            "state": "connected",
            "robot": "192.168.1.106:30000",
            "board": "10.0.2.15",
        })
    );

    let s = &j["status"];
    let mut status_names = answer_keys(&[
        "MotionState",
        "PosX",
        "PosY",
        "PosZ",
        "Roll",
        "Pitch",
        "Yaw",
        "Speed",
        "CurOdom",
        "SumOdom",
        "Res",
        "X0",
        "Y0",
        "H",
        "Electricity",
        "Location",
        "GaitState",
        "MotorState",
        "ChargeState",
        "ControlMode",
        "OnDockState",
    ]);
    status_names.push("unavailable");
    status_names.sort_unstable();
    assert_eq!(keys(s), status_names);
    assert_eq!(s["MotionState"], 4);
    assert_eq!(s["GaitState"], 2);
    assert_eq!(s["Electricity"], 87);
    assert_eq!(s["PosX"], 1.5);
    assert_eq!(s["PosY"], -2.0);
    assert_eq!(s["age_ms"], 120);
    assert_eq!(s["stale"], false);
    assert_eq!(s["unavailable"], false);
    assert_eq!(s["text"]["MotionState"], "stepping");
    assert_eq!(s["text"]["GaitState"], "slope/anti-slip");
    assert_eq!(s["text"]["Location"], "localised");
    // Floats in their shortest exact form, as the protocol writes them.
    let text = json_text(Some(&snapshot()), now);
    assert!(text.contains("\"PosZ\":0.1,"), "{text}");

    let b = &j["battery"];
    assert_eq!(
        keys(b),
        answer_keys(&[
            "Voltage",
            "Current",
            "RemainingCapacity",
            "NominalCapacity",
            "Cycles",
            "ProtectedState",
            "BatteryLevel",
            "BatteryTemperature",
        ])
    );
    assert_eq!(b["BatteryLevel"], 76);
    assert_eq!(b["Current"], -150);
    assert_eq!(b["BatteryTemperature"], 31.5);
    assert_eq!(b["text"]["ProtectedState"], "normal");

    let m = &j["motors"];
    assert_eq!(keys(m), answer_keys(&MOTORS));
    for (i, name) in MOTORS.iter().enumerate() {
        assert_eq!(m[name], 30.0 + i as f64, "{name}");
    }

    assert_eq!(j["obstacle"]["ObsState"], 1);
    assert_eq!(
        j["obstacle"]["text"]["ObsState"],
        "obstacle on the planned path within 2 m"
    );
    let n = &j["nav"];
    assert_eq!(keys(n), answer_keys(&["Value", "Status", "ErrorCode"]));
    assert_eq!((&n["Value"], &n["Status"]), (&7.into(), &1.into()));
    assert_eq!(n["text"]["Status"], "running");

    assert_eq!(
        j["leds"],
        serde_json::json!({"link": "on", "activity": "off", "fault": "blink"})
    );
    assert_eq!(j["faults"], serde_json::json!([]));
    assert_eq!(j["busy"], "a navigation task runs");
}

#[test]
fn answers_not_received_and_items_not_sent_are_null() {
    let snapshot = Snapshot {
        link: LinkState::Connecting,
        battery: Some(Stamped::new(
            Battery {
                battery_temperature: None,
                voltage: None,
                protected_state: None,
                ..battery()
            },
            T0,
        )),
        status: None,
        perception: None,
        motors: None,
        nav: None,
        board_address: None,
        busy: None,
        ..snapshot()
    };
    let j = json(Some(&snapshot), T0);
    assert_eq!(j["connection"]["state"], "connecting");
    assert_eq!(j["connection"]["board"], Value::Null);
    for answer in ["status", "motors", "obstacle", "nav"] {
        assert_eq!(j[answer], Value::Null, "{answer}");
    }
    assert_eq!(j["battery"]["BatteryTemperature"], Value::Null);
    assert_eq!(j["battery"]["Voltage"], Value::Null);
    assert_eq!(j["battery"]["ProtectedState"], Value::Null);
    assert_eq!(j["battery"]["text"]["ProtectedState"], "not reported");
    assert_eq!(j["battery"]["BatteryLevel"], 76);
    assert_eq!(j["busy"], Value::Null);
}

#[test]
fn each_answer_goes_stale_after_its_own_poll_periods() {
    let polls = Config::default().polls;
    let limit = |period: Duration| period * STALE_AFTER_POLLS;
    let s = snapshot();
    for (answer, period) in [
        ("status", polls.status),
        ("obstacle", polls.status),
        ("battery", polls.battery),
        ("motors", polls.motor_temperatures),
        ("nav", polls.nav_status),
    ] {
        let just_fresh = T0 + limit(period) - Duration::from_millis(1);
        let j = json(Some(&s), just_fresh);
        assert_eq!(j[answer]["stale"], false, "{answer}");
        assert_eq!(
            j[answer]["age_ms"],
            limit(period).as_millis() - 1,
            "{answer}"
        );
        // As the panel counts it: as old as the limit is too old.
        let j = json(Some(&s), T0 + limit(period));
        assert_eq!(j[answer]["stale"], true, "{answer}");
    }
    // The limits differ: at the status's limit the battery is still fresh.
    let j = json(Some(&s), T0 + limit(polls.status));
    assert_eq!(j["status"]["stale"], true);
    assert_eq!(j["battery"]["stale"], false);
    // An answer stamped after `now` (a snapshot taken meanwhile) is new, not negative.
    assert_eq!(
        json(Some(&s), T0 - Duration::from_millis(5))["status"]["age_ms"],
        0
    );
}

#[test]
fn floats_json_cannot_hold_are_null() {
    let mut s = snapshot();
    let status = RobotStatus {
        pos_x: f32::NAN,
        pos_y: f32::INFINITY,
        pos_z: f32::NEG_INFINITY,
        ..status()
    };
    s.status = Some(Stamped::new(status, T0));
    s.motors = Some(Stamped::new(
        MotorTemperatures {
            left_front_hip: f32::NAN,
            ..motors()
        },
        T0,
    ));
    let j = json(Some(&s), T0);
    for item in ["PosX", "PosY", "PosZ"] {
        assert_eq!(j["status"][item], Value::Null, "{item}");
    }
    assert_eq!(j["status"]["Yaw"], 0.5);
    assert_eq!(j["motors"]["LeftFrontHip"], Value::Null);
    assert_eq!(j["motors"]["LeftFrontSway"], 30.0);
}

#[test]
fn a_starting_panel_answers_with_nulls() {
    let j = json(None, T0);
    assert_eq!(
        j,
        serde_json::json!({
            "connection": {"state": "starting", "robot": null, "board": null},
            "status": null,
            "battery": null,
            "motors": null,
            "obstacle": null,
            "nav": null,
            "leds": null,
            "faults": [],
            "busy": null,
        })
    );
}

#[test]
fn faults_the_all_zero_status_and_a_failed_command_are_told() {
    let mut view = RobotView::new(&Config::default());
    let faulty = RobotStatus {
        motion_state: MotionState::Fallen,
        electricity: Some(10),
        ..status()
    };
    view.update(&Response::Status(faulty), T0);
    let s = Snapshot {
        faults: Faults::of(&view, T0),
        command_failed: true,
        status: Some(Stamped::new(RobotStatus::UNAVAILABLE, T0)),
        ..snapshot()
    };
    let j = json(Some(&s), T0);
    assert_eq!(
        j["faults"],
        serde_json::json!(["fallen", "battery low", "the last command failed"])
    );
    assert_eq!(j["status"]["unavailable"], true);
}

/// The longest float text: `-0.` and 45 digits.
fn longest_float() -> f32 {
    -f32::from_bits(1)
}

/// A snapshot with every value at its longest: the floats' longest text, the integers'
/// `i32::MIN`, every coded item `code`, every fault, the longest addresses and ages.
fn largest(code: i32) -> Snapshot {
    let f = longest_float();
    let status = RobotStatus {
        motion_state: MotionState::from_raw(code),
        pos_x: f,
        pos_y: f,
        pos_z: f,
        roll: f,
        pitch: f,
        yaw: f,
        speed: f,
        cur_odom: f,
        sum_odom: f,
        res: f,
        x0: f,
        y0: f,
        h: Some(i32::MIN),
        electricity: Some(i32::MIN),
        location: Some(Location::from_raw(code)),
        gait_state: Some(GaitState::from_raw(code)),
        motor_state: Some(MotorState::from_raw(code)),
        charge_state: Some(ChargeState::from_raw(code)),
        control_mode: Some(ControlMode::from_raw(code)),
        on_dock_state: Some(OnDockState::from_raw(code)),
    };
    let battery = Battery {
        voltage: Some(i32::MIN),
        current: Some(i32::MIN),
        remaining_capacity: Some(i32::MIN),
        nominal_capacity: Some(i32::MIN),
        cycles: Some(i32::MIN),
        protected_state: Some(ProtectedState::from_raw(code)),
        battery_level: Some(i32::MIN),
        battery_temperature: Some(f),
    };
    let motors = MotorTemperatures {
        left_front_sway: f,
        left_front_hip: f,
        left_front_knee: f,
        right_front_sway: f,
        right_front_hip: f,
        right_front_knee: f,
        left_back_sway: f,
        left_back_hip: f,
        left_back_knee: f,
        right_back_sway: f,
        right_back_hip: f,
        right_back_knee: f,
    };
    // Every fault a status and a battery answer can report at once.
    let mut view = RobotView::new(&Config::default());
    let faulty = RobotStatus {
        motion_state: MotionState::Fallen,
        motor_state: Some(MotorState::OverTemperature),
        location: Some(Location::Lost),
        electricity: Some(0),
        ..self::status()
    };
    view.update(&Response::Status(faulty), T0);
    let protected = Battery {
        protected_state: Some(ProtectedState::Triggered),
        ..self::battery()
    };
    view.update(&Response::Battery(protected), T0);
    Snapshot {
        link: LinkState::NotAnswering,
        robot: RobotAddress {
            ip: [255; 4],
            port: u16::MAX,
        },
        status: Some(Stamped::new(status, Instant::MIN)),
        battery: Some(Stamped::new(battery, Instant::MIN)),
        perception: Some(Stamped::new(
            Perception {
                obs_state: ObsState::from_raw(code),
            },
            Instant::MIN,
        )),
        motors: Some(Stamped::new(motors, Instant::MIN)),
        nav: Some(Stamped::new(
            NavTaskState {
                value: i32::MIN,
                status: NavTaskStatus::from_raw(code),
                error_code: NavTaskStatus::from_raw(i32::MIN),
            },
            Instant::MIN,
        )),
        polls: Config::default().polls,
        faults: Faults::of(&view, T0),
        leds: Indicators {
            link: Led::BlinkFast,
            activity: Led::BlinkFast,
            fault: Led::BlinkFast,
        },
        command_failed: true,
        busy: Some(Busy::StopPending),
        board_address: Some(Cidr {
            address: [255; 4],
            prefix_len: 32,
        }),
        at: T0,
    }
}

#[test]
fn the_largest_answer_fits_status_max() {
    let mut text = String::new();
    web::write_status(Some(&snapshot()), T0, &mut text).unwrap();
    let typical = text.len();
    let mut longest = 0;
    // Every code the protocol defines for these items lies in -1..=8; and one it does not.
    for code in (-1..=8).chain([i32::MIN]) {
        let text = json_text(Some(&largest(code)), Instant::MAX);
        assert!(text.len() <= STATUS_MAX, "{} > {STATUS_MAX}", text.len());
        longest = longest.max(text.len());
        let j: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(j["faults"].as_array().unwrap().len(), 6, "{}", j["faults"]);
        assert!(j["status"]["PosX"].as_f64().unwrap() < 0.0);
        for answer in ["status", "battery", "obstacle", "nav"] {
            for (item, word) in j[answer]["text"].as_object().unwrap() {
                let word = word.as_str().unwrap();
                assert!(word.len() <= WORD_MAX, "{item}: {word}");
            }
        }
    }
    // The bound is not wildly loose either.
    assert!(longest > STATUS_MAX * 3 / 4, "{longest} of {STATUS_MAX}");
    println!("status JSON: typical {typical} bytes, longest {longest}, bound {STATUS_MAX}");
}

#[test]
fn a_buffer_too_small_fails_rather_than_cutting_the_json() {
    let mut small = heapless::String::<256>::new();
    assert!(web::write_status(Some(&snapshot()), T0, &mut small).is_err());
    let mut enough = heapless::String::<STATUS_MAX>::new();
    web::write_status(Some(&largest(-1)), Instant::MAX, &mut enough).unwrap();
}

#[test]
fn the_status_page_is_small_self_contained_and_refreshes_from_the_json() {
    assert!(INDEX_HTML.len() <= 6 * 1024, "{} bytes", INDEX_HTML.len());
    assert!(INDEX_HTML.is_ascii());
    assert!(INDEX_HTML.contains("name=viewport"));
    assert!(INDEX_HTML.contains("fetch('/api/status'"));
    assert!(INDEX_HTML.contains("setTimeout(tick,500)"));
    assert!(!INDEX_HTML.contains("location.reload"));
    assert!(INDEX_HTML.contains("href=\"/settings\""));
    for id in [
        "connection",
        "connection-state",
        "robot-address",
        "board-address",
        "battery",
        "battery-level",
        "robot",
        "motion-state",
        "gait",
        "location",
        "obstacle",
        "obstacle-state",
        "nav",
        "nav-state",
        "faults",
        "fault-list",
        "leds",
        "motors",
        "motor-table",
    ] {
        assert!(INDEX_HTML.contains(&format!(" id={id}>")), "{id}");
    }
    // Nothing from elsewhere: no addresses, no loaded scripts, styles or images.
    for external in ["http", "src=", "@import", "url("] {
        assert!(!INDEX_HTML.contains(external), "{external}");
    }
}

/// Settings whose saved PIN is `2468`.
fn with_pin() -> Settings {
    let mut settings = Settings::new(Config::default());
    settings.set(Key::WebPin, "2468").unwrap();
    settings.commit();
    settings
}

/// The settings page for `settings` and `posted`.
fn page(settings: Option<&Settings>, posted: Option<&Posted>) -> String {
    page_after(settings, posted, b"")
}

/// The settings page for `settings` and `posted`, which posted `posted_form`.
fn page_after(settings: Option<&Settings>, posted: Option<&Posted>, posted_form: &[u8]) -> String {
    let mut text = String::new();
    web::write_settings_page(settings, posted, posted_form, &mut text).unwrap();
    text
}

/// The value of the field `name` among `fields` (see [`inputs`]).
fn field<'f>(fields: &'f [(String, String)], name: &str) -> &'f str {
    fields
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, value)| value.as_str())
        .unwrap_or_else(|| panic!("no field {name} among {fields:?}"))
}

/// The form's fields as the page fills them in: `(name, value)`.
fn inputs(page: &str) -> Vec<(String, String)> {
    let attribute = |tag: &str, name: &str| {
        let start = tag.find(&format!("{name}=\""))? + name.len() + 2;
        let end = start + tag[start..].find('"')?;
        Some(
            tag[start..end]
                .replace("&quot;", "\"")
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&#39;", "'")
                .replace("&amp;", "&"),
        )
    };
    page.split("<input ")
        .skip(1)
        .map(|rest| &rest[..rest.find('>').unwrap()])
        .filter_map(|tag| Some((attribute(tag, "name")?, attribute(tag, "value")?)))
        .collect()
}

#[test]
fn the_settings_page_lists_every_key_and_never_the_pin() {
    let mut settings = with_pin();
    settings.set(Key::Repeat, "300").unwrap();
    settings.commit();
    let text = page(Some(&settings), None);
    assert!(
        text.contains("<form method=post action=\"/settings\">"),
        "{text}"
    );
    assert!(text.contains("name=pin type=password"));
    assert!(text.contains("<button type=submit>"));
    let fields = inputs(&text);
    let names: Vec<&str> = fields.iter().map(|(n, _)| n.as_str()).collect();
    let mut all: Vec<&str> = Key::ALL.iter().map(|k| k.name()).collect();
    all.push("saved");
    assert_eq!(
        names, all,
        "one field per key, in table order, then the saved stamp"
    );
    assert_eq!(field(&fields, "saved"), settings.saved_stamp().to_string());
    let value = |name: &str| field(&fields, name);
    assert_eq!(value("robot"), "192.168.1.106:30000");
    assert_eq!(value("repeat-ms"), "300");
    assert_eq!(value("web-pin"), "****");
    assert!(!text.contains("2468"), "the PIN is never shown");
    for key in Key::ALL {
        assert!(text.contains(key.name()), "{key:?}");
    }
    assert!(text.contains("robot</label> <small>[default]</small>"));
    assert!(text.contains("repeat-ms</label> <small>[set]</small>"));
    assert!(text.contains("milliseconds from 200 to 333"), "the hint");
    assert!(!text.contains("id=read-only"));
}

#[test]
fn without_a_pin_the_page_is_read_only_and_says_how_to_set_one() {
    let settings = Settings::new(Config::default());
    let text = page(Some(&settings), None);
    assert!(
        !text.contains("<form") && !text.contains("<input"),
        "{text}"
    );
    assert!(text.contains("id=read-only"));
    assert!(text.contains("<code>set web-pin 1234</code>, then <code>save</code>"));
    assert!(text.contains("<code id=\"k-speed-forward\">default</code>"));
    assert!(text.contains("<code id=\"k-web-pin\">none</code>"));
}

#[test]
fn the_page_shows_what_is_saved_and_names_changes_typed_on_the_console() {
    let mut settings = with_pin();
    settings.set(Key::SpeedForward, "0.9").unwrap();
    settings.set(Key::Repeat, "300").unwrap();
    let text = page(Some(&settings), None);
    let fields = inputs(&text);
    let value = |name: &str| field(&fields, name);
    assert_eq!(value("speed-forward"), "default");
    assert_eq!(value("repeat-ms"), "250");
    assert!(
        text.contains("Changed on the console and not saved: speed-forward, repeat-ms."),
        "{text}"
    );
    // Route points added on the console are such changes too.
    let mut routed = with_pin();
    routed
        .add_route_point(RoutePoint::parse("1,1,2,0,0,0,task").unwrap())
        .unwrap();
    let text = page(Some(&routed), None);
    assert!(
        text.contains("Changed on the console and not saved: route."),
        "{text}"
    );
    let starting = page(None, None);
    assert!(starting.contains("not available yet"), "{starting}");
    assert!(!starting.contains("<form"));
}

#[test]
fn the_page_escapes_what_people_wrote() {
    let posted = Posted {
        status: 400,
        message: "no setting `<script>alert(\"x\")</script>` & co"
            .try_into()
            .unwrap(),
    };
    let text = page(Some(&with_pin()), Some(&posted));
    assert!(!text.contains("<script"), "{text}");
    assert!(
        text.contains(
            "<p id=posted class=err>no setting `&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;` &amp; co</p>"
        ),
        "{text}"
    );
    let saved = Posted {
        status: 200,
        message: "saved robot".try_into().unwrap(),
    };
    assert!(page(None, Some(&saved)).contains("<p id=posted class=ok>saved robot</p>"));
}

#[test]
fn the_largest_settings_page_fits_settings_page_max() {
    let mut settings = with_pin();
    let lights = ["FFFFFF:100:breathing"; 8].join(",");
    let f = "-0.000000000000000000000000000000000000000000001";
    let dock = format!("{},{},{f},{f},{f},{f}", i32::MIN, i32::MIN);
    settings.set(Key::Lights, &lights).unwrap();
    settings.set(Key::Dock, &dock).unwrap();
    settings.set(Key::Ip, "255.255.255.255/32").unwrap();
    settings.set(Key::Gateway, "255.255.255.255").unwrap();
    settings.set(Key::Robot, "255.255.255.255:65535").unwrap();
    settings.commit();
    for &key in Key::ALL {
        settings.unset(key);
    }
    let posted = Posted {
        status: 400,
        message: "\"".repeat(256).as_str().try_into().unwrap(),
    };
    // A refused form as long as allowed, its values all quotes (unencoded, each escapes
    // to six bytes), as long as a value may be.
    let mut typed = String::from("pin=2468");
    for &key in Key::ALL.iter().filter(|&&k| k != Key::WebPin) {
        let room = FORM_MAX.saturating_sub(typed.len() + key.name().len() + 2);
        if room == 0 {
            break;
        }
        let quotes = "\"".repeat(room.min(MAX_VALUE));
        typed += &format!("&{}={quotes}", key.name());
    }
    assert!(typed.len() <= FORM_MAX && typed.len() > FORM_MAX - 64);
    let text = page_after(Some(&settings), Some(&posted), typed.as_bytes());
    assert!(text.contains("FFFFFF:100:breathing,FFFFFF"), "{text}");
    assert!(
        text.len() <= SETTINGS_PAGE_MAX,
        "{} > {SETTINGS_PAGE_MAX}",
        text.len()
    );
    println!(
        "settings page: default {} bytes, longest {}, bound {SETTINGS_PAGE_MAX}",
        page(Some(&with_pin()), None).len(),
        text.len()
    );
}

/// `fields` as an `application/x-www-form-urlencoded` body.
fn form(fields: &[(&str, &str)]) -> Vec<u8> {
    let encode = |text: &str| {
        text.bytes()
            .map(|b| match b {
                b' ' => "+".to_owned(),
                b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'.' | b'*' => {
                    char::from(b).to_string()
                }
                b => format!("%{b:02X}"),
            })
            .collect::<String>()
    };
    fields
        .iter()
        .map(|(name, value)| format!("{}={}", encode(name), encode(value)))
        .collect::<Vec<_>>()
        .join("&")
        .into_bytes()
}

/// Settings flash for the tests: two 32 KiB pages.
fn flash() -> SimFlash {
    SimFlash::new(2)
}

/// Runs a console owning `settings` over `flash` while `script` runs with its desk; what
/// the script returned.
async fn with_owner<R>(
    flash: &SimFlash,
    shared: &Shared,
    mut settings: Settings,
    script: impl AsyncFnOnce(&Desk) -> R,
) -> R {
    let mut store = Store::new(flash.clone(), 0..2 * PAGE as u32);
    let desk = Desk::new();
    // Nothing is typed; the keyboard stays open while the console runs.
    let (keyboard, _keys) = Keyboard::new();
    let console = console::run(
        keyboard,
        Screen::default(),
        &mut store,
        &mut settings,
        None,
        shared,
        &desk,
    );
    let script = async {
        for _ in 0..200 {
            if desk.settings().is_some() {
                break;
            }
            tokio::time::sleep(std::time::Duration::from_millis(5)).await;
        }
        assert!(
            desk.settings().is_some(),
            "the console published its settings"
        );
        script(&desk).await
    };
    steady(async {
        tokio::select! {
            _ = console => panic!("the console asked for a reboot"),
            result = script => result,
        }
    })
    .await
}

/// Posts `body` to a console owning `settings`; the answer, and the settings then saved on
/// the flash (`None`: the flash is untouched).
async fn post(shared: &Shared, settings: Settings, body: &[u8]) -> (Posted, Option<Settings>) {
    let flash = flash();
    let posted = with_owner(&flash, shared, settings, async |desk| {
        web::post_settings(desk, body).await
    })
    .await;
    if flash.log().is_empty() {
        assert!(flash.snapshot().iter().all(|&b| b == 0xFF));
        return (posted, None);
    }
    let mut store = Store::new(flash.clone(), 0..2 * PAGE as u32);
    let mut buf = [0u8; BUF_LEN];
    let blob = store
        .load(&mut buf)
        .await
        .unwrap()
        .expect("something saved");
    let (saved, problem) = Settings::parse(Config::default(), blob);
    assert_eq!(problem, None);
    (posted, Some(saved))
}

#[tokio::test(flavor = "current_thread")]
async fn the_form_as_the_page_fills_it_in_saves_just_what_was_changed() {
    let settings = with_pin();
    let body = form_with(
        &inputs(&page(Some(&settings), None)),
        "speed-forward",
        "0.3",
    );
    let (posted, saved) = post(&Shared::new(), settings, &body).await;
    assert_eq!(posted.status, 200, "{}", posted.message);
    assert_eq!(posted.message, "saved speed-forward");
    let saved = saved.expect("saved");
    let overridden: Vec<Key> = Key::ALL
        .iter()
        .copied()
        .filter(|&k| saved.is_overridden(k))
        .collect();
    assert_eq!(overridden, [Key::SpeedForward, Key::WebPin]);
    let mut expected = Config::default();
    Key::SpeedForward.apply(&mut expected, "0.3").unwrap();
    assert_eq!(saved.config().speeds, expected.speeds);
    assert_eq!(
        saved.config().web_pin,
        with_pin().config().web_pin,
        "PIN kept"
    );
}

/// The page's form as it was filled in (`inputs`), with `name` changed to `value`, posted
/// with the PIN.
fn form_with(inputs: &[(String, String)], name: &str, value: &str) -> Vec<u8> {
    let mut fields: Vec<(&str, &str)> = inputs
        .iter()
        .map(|(n, v)| (n.as_str(), if n == name { value } else { v.as_str() }))
        .collect();
    fields.push(("pin", "2468"));
    form(&fields)
}

/// The page loaded, then a change saved on the console: the page's form, posted with
/// another field edited, is refused rather than putting back the value the page showed,
/// and the page then shows the settings as they are now.
#[tokio::test(flavor = "current_thread")]
async fn a_form_from_before_a_save_on_the_console_is_refused_and_undoes_nothing() {
    let settings = with_pin();
    let shown = inputs(&page(Some(&settings), None));
    assert!(
        shown.iter().any(|(name, _)| name == "saved"),
        "the form carries what it showed"
    );
    let mut now = settings.clone();
    now.set(Key::Repeat, "300").unwrap();
    now.commit();
    let body = form_with(&shown, "speed-forward", "0.3");
    let (posted, saved) = post(&Shared::new(), now.clone(), &body).await;
    assert_eq!(posted.status, 409, "{}", posted.message);
    assert!(
        posted.message.contains("saved elsewhere"),
        "{}",
        posted.message
    );
    assert!(saved.is_none(), "nothing saved: repeat-ms stays 300");
    let after = inputs(&page_after(Some(&now), Some(&posted), &body));
    assert_eq!(field(&after, "repeat-ms"), "300", "as saved now");
    assert_eq!(
        field(&after, "speed-forward"),
        field(&shown, "speed-forward"),
        "as saved, not as typed on the stale page"
    );
    // The page as it is now saves.
    let fresh = inputs(&page(Some(&now), None));
    let body = form_with(&fresh, "speed-forward", "0.3");
    let (posted, saved) = post(&Shared::new(), now, &body).await;
    assert_eq!(posted.status, 200, "{}", posted.message);
    assert_eq!(posted.message, "saved speed-forward");
    assert_eq!(
        saved.expect("saved").config().motion_repeat,
        Duration::from_millis(300)
    );
}

#[tokio::test(flavor = "current_thread")]
async fn a_saved_field_that_is_no_number_is_refused() {
    let body = form(&[("pin", "2468"), ("saved", "x1"), ("repeat-ms", "300")]);
    let (posted, saved) = post(&Shared::new(), with_pin(), &body).await;
    assert_eq!(posted.status, 400, "{}", posted.message);
    assert!(
        posted
            .message
            .starts_with("saved: the value is not a number"),
        "{}",
        posted.message
    );
    assert!(saved.is_none());
}

#[tokio::test(flavor = "current_thread")]
async fn an_empty_field_returns_a_setting_to_its_default_and_the_pin_can_change() {
    let mut settings = with_pin();
    settings.set(Key::Repeat, "300").unwrap();
    settings.commit();
    let body = form(&[
        ("pin", "2468"),
        ("repeat-ms", ""),
        ("web-pin", "97531"),
        ("dhcp", "0"),
        ("ip", "10.0.0.9/24"),
    ]);
    let (posted, saved) = post(&Shared::new(), settings, &body).await;
    assert_eq!(posted.status, 200, "{}", posted.message);
    assert_eq!(
        posted.message,
        "saved dhcp, ip, repeat-ms, web-pin; after a reboot: dhcp ip"
    );
    let saved = saved.unwrap();
    assert!(!saved.is_overridden(Key::Repeat));
    assert_eq!(
        saved.config().motion_repeat,
        Config::default().motion_repeat
    );
    assert_eq!(saved.config().web_pin.unwrap().as_str(), "97531");
}

#[tokio::test(flavor = "current_thread")]
async fn a_new_robot_is_told_to_reconnect() {
    let body = form(&[("robot", "10.0.0.2"), ("pin", "2468")]);
    let (posted, saved) = post(&Shared::new(), with_pin(), &body).await;
    assert_eq!(posted.status, 200, "{}", posted.message);
    assert_eq!(
        posted.message,
        "saved robot; the panel reconnects to the new robot"
    );
    assert_eq!(saved.unwrap().config().robot.ip, [10, 0, 0, 2]);
}

#[tokio::test(flavor = "current_thread")]
async fn a_wrong_or_missing_pin_is_refused_and_nothing_saved() {
    for body in [
        form(&[("speed-forward", "0.3"), ("pin", "2469")]),
        form(&[("speed-forward", "0.3"), ("pin", "246")]),
        form(&[("speed-forward", "0.3"), ("pin", "24680")]),
        form(&[("speed-forward", "0.3")]),
    ] {
        let (posted, saved) = post(&Shared::new(), with_pin(), &body).await;
        let body = String::from_utf8_lossy(&body);
        assert_eq!(posted.status, 403, "{body}");
        assert_eq!(posted.message, "PIN wrong; nothing saved", "{body}");
        assert!(saved.is_none(), "{body}");
    }
}

#[tokio::test(flavor = "current_thread")]
async fn without_a_pin_saved_the_form_changes_nothing() {
    let body = form(&[("speed-forward", "0.3"), ("pin", "")]);
    let (posted, saved) = post(&Shared::new(), Settings::new(Config::default()), &body).await;
    assert_eq!(posted.status, 403);
    assert!(
        posted.message.contains("read-only") && posted.message.contains("`set web-pin 1234`"),
        "{}",
        posted.message
    );
    assert!(saved.is_none());
}

#[tokio::test(flavor = "current_thread")]
async fn an_invalid_value_is_refused_naming_the_setting_and_nothing_saved() {
    let body = form(&[
        ("pin", "2468"),
        ("repeat-ms", "300"),
        ("speed-forward", "2"),
    ]);
    let (posted, saved) = post(&Shared::new(), with_pin(), &body).await;
    assert_eq!(posted.status, 400);
    assert_eq!(
        posted.message,
        "speed-forward: `2` is not valid: expected m/s from 0 to 1.5, or default (the robot's \
         0.5); nothing saved"
    );
    assert!(saved.is_none());
    // A long value is quoted by its start.
    let long = format!("{}é{}", "1".repeat(31), "2".repeat(200));
    let body = form(&[("pin", "2468"), ("dock", &long)]);
    let (posted, _) = post(&Shared::new(), with_pin(), &body).await;
    assert!(
        posted.message.starts_with(&format!(
            "dock: `{}…` is not valid: expected ",
            "1".repeat(31)
        )),
        "{}",
        posted.message
    );
}

#[tokio::test(flavor = "current_thread")]
async fn a_form_not_saved_comes_back_as_typed_but_for_a_new_pin() {
    let mut settings = with_pin();
    settings.set(Key::Repeat, "300").unwrap();
    settings.commit();
    let body = form(&[
        ("pin", "2468"),
        ("repeat-ms", "250"),
        ("speed-forward", "2"),
        ("robot", "10.0.0.9\"><b>"),
        ("web-pin", "13579"),
    ]);
    let (posted, saved) = post(&Shared::new(), settings.clone(), &body).await;
    assert_eq!(posted.status, 400, "{}", posted.message);
    assert!(saved.is_none());
    let text = page_after(Some(&settings), Some(&posted), &body);
    let fields = inputs(&text);
    let value = |name: &str| field(&fields, name);
    assert_eq!(value("repeat-ms"), "250", "as typed, not the saved 300");
    assert_eq!(value("speed-forward"), "2");
    assert_eq!(value("robot"), "10.0.0.9\"><b>");
    assert!(!text.contains("<b>"), "typed text escaped: {text}");
    assert_eq!(value("web-pin"), "****", "a new PIN is never shown");
    assert!(!text.contains("13579"), "{text}");
    let saved_fields = inputs(&page(Some(&settings), None));
    assert_eq!(
        value("lights"),
        field(&saved_fields, "lights"),
        "not typed: saved"
    );
    // Once saved, the page shows what is saved, not the form.
    let saved = Posted {
        status: 200,
        message: "saved repeat-ms".try_into().unwrap(),
    };
    let text = page_after(Some(&settings), Some(&saved), &body);
    assert!(!text.contains("value=\"2\""), "{text}");
}

#[tokio::test(flavor = "current_thread")]
async fn malformed_forms_are_refused_naming_the_problem() {
    let long_value = "1".repeat(MAX_VALUE + 1);
    let long_name = "x".repeat(40);
    let cases: [(&[u8], &str); 9] = [
        (b"pin=2468&speed=1", "no setting `speed`"),
        (
            b"pin=2468&%3Cscript%3E=1",
            "no setting `<script>` (is the page outdated?); nothing saved",
        ),
        (b"pin=2468&robot=10.0.0.%G2", "robot: the value has a `%`"),
        (b"pin=2468&robot=10.0.0.2%4", "robot: the value has a `%`"),
        (b"pin=2468&dock=%FF%FE", "dock: the value is not UTF-8"),
        (b"pin=2468&rob%ot=1", "a field's name has a `%`"),
        (
            b"pin=2468&speed-forward=0.3&SPEED-FORWARD=0.4",
            "`speed-forward` is in the form twice",
        ),
        (
            b"pin=2468&pin=2468&repeat-ms=300",
            "`pin` is in the form twice",
        ),
        (b"pin=2468&repeat-ms=300&=1", "no setting ``"),
    ];
    for (body, words) in cases {
        let (posted, saved) = post(&Shared::new(), with_pin(), body).await;
        let body = String::from_utf8_lossy(body);
        assert_eq!(posted.status, 400, "{body}: {}", posted.message);
        assert!(posted.message.contains(words), "{body}: {}", posted.message);
        assert!(
            posted.message.ends_with("; nothing saved"),
            "{}",
            posted.message
        );
        assert!(saved.is_none(), "{body}");
    }
    for (body, words) in [
        (
            form(&[("pin", "2468"), ("dock", &long_value)]),
            "dock: the value is too long",
        ),
        (
            form(&[("pin", "2468"), (&long_name, "1")]),
            "a field's name is too long",
        ),
    ] {
        let (posted, saved) = post(&Shared::new(), with_pin(), &body).await;
        assert_eq!(posted.status, 400);
        assert!(posted.message.contains(words), "{}", posted.message);
        assert!(saved.is_none());
    }
    // Empty fields and a `+` for a space are ordinary.
    let body = b"&pin=2468&&lights=00FF00:50,+FF0000:100:breathing&";
    let (posted, saved) = post(&Shared::new(), with_pin(), body).await;
    assert_eq!(posted.status, 200, "{}", posted.message);
    assert!(saved.unwrap().is_overridden(Key::Lights));
}

#[tokio::test(flavor = "current_thread")]
async fn a_form_longer_than_form_max_is_refused_with_413() {
    let mut body = form(&[("pin", "2468"), ("repeat-ms", "300")]);
    body.resize(FORM_MAX + 1, b'&');
    let (posted, saved) = post(&Shared::new(), with_pin(), &body).await;
    assert_eq!(posted.status, 413);
    assert_eq!(
        posted.message.as_str(),
        format!("the form is longer than {FORM_MAX} bytes; nothing saved")
    );
    assert!(saved.is_none());
    // At the limit it is read.
    body.truncate(FORM_MAX);
    let (posted, _) = post(&Shared::new(), with_pin(), &body).await;
    assert_eq!(posted.status, 200, "{}", posted.message);
}

#[tokio::test(flavor = "current_thread")]
async fn a_busy_panel_refuses_with_409_and_the_flash_is_untouched() {
    let shared = Shared::new();
    shared
        .buttons
        .try_send(ButtonEvent {
            button: Button::Estop,
            pressed: true,
            at: Instant::now(),
        })
        .unwrap();
    let body = form(&[("pin", "2468"), ("repeat-ms", "300")]);
    let (posted, saved) = post(&shared, with_pin(), &body).await;
    assert_eq!(posted.status, 409);
    assert_eq!(
        posted.message,
        "not saved: a stop is going out or an e-stop is not yet confirmed; save when the panel is idle"
    );
    assert!(saved.is_none());
}

#[tokio::test(flavor = "current_thread")]
async fn nothing_changed_or_conflicting_edits_are_refused_with_409() {
    let unchanged = form(&[("pin", "2468"), ("repeat-ms", "250"), ("dock", "")]);
    let (posted, saved) = post(&Shared::new(), with_pin(), &unchanged).await;
    assert_eq!(posted.status, 409);
    assert_eq!(posted.message, "nothing changed; nothing to save");
    assert!(saved.is_none());

    let conflict = form(&[("pin", "2468"), ("dhcp", "0")]);
    let (posted, saved) = post(&Shared::new(), with_pin(), &conflict).await;
    assert_eq!(posted.status, 409);
    assert!(
        posted.message.contains("dhcp is 0 but ip is none"),
        "{}",
        posted.message
    );
    assert!(saved.is_none());
}

#[tokio::test(flavor = "current_thread")]
async fn without_an_owner_the_form_gets_503() {
    let desk = Desk::new();
    let body = form(&[("pin", "2468"), ("repeat-ms", "300")]);
    let posted = web::post_settings(&desk, &body).await;
    assert_eq!(posted.status, 503);
    assert_eq!(
        posted.message,
        "the settings are not available yet; nothing saved"
    );
}
