//! Shared helpers of the panel tests: simulated time, button events, a loop that pulls
//! commands the way the application does, and healthy answers of the robot.

// Each test file uses some of these helpers.
#![allow(dead_code)]

use embassy_time::Instant;
use x30_panel::client::Health;
use x30_panel::config::Config;
use x30_panel::panel::ConnectionState;
use x30_panel::panel::{Button, ButtonEvent, Control, Panel};
use x30_panel::proto::codes::*;
use x30_panel::proto::message::{Battery, Request, RobotStatus};
use x30_panel::settings::Key;

/// The instant `ms` milliseconds after boot.
pub fn at(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

/// `button` pressed (`true`) or released at `ms`.
pub fn event(button: Button, pressed: bool, ms: u64) -> ButtonEvent {
    ButtonEvent {
        button,
        pressed,
        at: at(ms),
    }
}

/// Presses and releases, for [`Control`] (which the robot's gait is not known to) and
/// [`Panel`].
pub trait Buttons {
    /// A debounced change of `button` at `ms`.
    fn change(&mut self, button: Button, pressed: bool, ms: u64);

    /// `button` pressed at `ms`.
    fn press(&mut self, button: Button, ms: u64) {
        self.change(button, true, ms);
    }

    /// `button` released at `ms`.
    fn release(&mut self, button: Button, ms: u64) {
        self.change(button, false, ms);
    }
}

impl Buttons for Control {
    fn change(&mut self, button: Button, pressed: bool, ms: u64) {
        self.button(event(button, pressed, ms), None);
    }
}

impl Buttons for Panel {
    fn change(&mut self, button: Button, pressed: bool, ms: u64) {
        self.button(event(button, pressed, ms));
    }
}

/// A configuration whose `dock` goes to charging point 5 of map 2.
pub fn with_dock() -> Config {
    let mut config = Config::default();
    Key::Dock
        .apply(&mut config, "5,2,1.5,2.5,0,1")
        .expect("a valid dock point");
    config
}

/// A control state machine with the default configuration, its command connection open.
pub fn connected() -> Control {
    connected_with(&Config::default())
}

/// A control state machine with `config`, its command connection open.
pub fn connected_with(config: &Config) -> Control {
    let mut control = Control::new(config);
    control.connection(ConnectionState::Open);
    control
}

/// Every command due at `now`, with motion allowed.
pub fn drain(control: &mut Control, now: Instant) -> Vec<Request> {
    std::iter::from_fn(|| control.next_command(now, Health::Answering)).collect()
}

/// Runs the control state machine from `from` to `to` inclusive as the application does:
/// pull everything due, then wake up at the next deadline. Returns each command with the
/// time it was pulled.
pub fn run(control: &mut Control, from: Instant, to: Instant) -> Vec<(Instant, Request)> {
    let mut out = Vec::new();
    let mut now = from;
    loop {
        out.extend(drain(control, now).into_iter().map(|r| (now, r)));
        match control.next_deadline() {
            Some(next) if next <= to => now = next.max(now),
            _ => return out,
        }
    }
}

/// The times in milliseconds at which `request` went out in a [`run`].
pub fn times_of(sent: &[(Instant, Request)], request: &Request) -> Vec<u64> {
    sent.iter()
        .filter(|(_, r)| r == request)
        .map(|(t, _)| t.as_millis())
        .collect()
}

/// A readable status of a robot stepping in the middle of its map with 80 % battery.
pub fn status() -> RobotStatus {
    RobotStatus {
        motion_state: MotionState::Stepping,
        pos_x: 1.5,
        pos_y: -2.0,
        pos_z: 0.1,
        roll: 0.0,
        pitch: 0.0,
        yaw: 0.5,
        speed: 0.3,
        cur_odom: 0.2,
        sum_odom: 12.0,
        res: 0.05,
        x0: -10.0,
        y0: -10.0,
        h: Some(400),
        electricity: Some(80),
        // Localised, walking, motors normal, not charging, manual, off the dock.
        ..RobotStatus::UNAVAILABLE
    }
}

/// [`status`] with another motion state.
pub fn status_in(motion_state: MotionState) -> RobotStatus {
    RobotStatus {
        motion_state,
        ..status()
    }
}

/// A healthy battery answer.
pub fn battery() -> Battery {
    Battery {
        voltage: Some(54),
        current: Some(-150),
        remaining_capacity: Some(2400),
        nominal_capacity: Some(3000),
        cycles: Some(42),
        protected_state: Some(ProtectedState::Normal),
        battery_level: Some(80),
        battery_temperature: Some(31.5),
    }
}
