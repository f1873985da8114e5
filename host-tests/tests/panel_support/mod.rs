//! Shared helpers of the panel tests: simulated time, a status answer, and a loop that pulls
//! actions the way the application does.

// Each test file uses some of these helpers.
#![allow(dead_code)]

use embassy_time::Instant;
use x30_panel::config::Config;
use x30_panel::panel::{Action, Control};
use x30_panel::proto::codes::*;
use x30_panel::proto::message::{Battery, MotionCommand, Request, RobotStatus};

/// The instant `ms` milliseconds after boot.
pub fn at(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

/// A control state machine with the default configuration, connected.
pub fn connected() -> Control {
    connected_with(&Config::default())
}

/// A control state machine with `config`, connected.
pub fn connected_with(config: &Config) -> Control {
    let mut control = Control::new(config);
    control.link(true);
    control
}

/// The motion command an action sends, if it sends one.
pub fn motion(action: &Action) -> Option<MotionCommand> {
    match action {
        Action::Send(Request::Motion(command)) => Some(*command),
        _ => None,
    }
}

/// Every action due at `now`.
pub fn drain(control: &mut Control, now: Instant) -> Vec<Action> {
    std::iter::from_fn(|| control.next_action(now)).collect()
}

/// Runs the control state machine from `from` to `to` inclusive as the application does:
/// pull everything due, then wake up at the next deadline. Returns each action with the time
/// it was pulled.
pub fn run(control: &mut Control, from: Instant, to: Instant) -> Vec<(Instant, Action)> {
    let mut out = Vec::new();
    let mut now = from;
    loop {
        out.extend(drain(control, now).into_iter().map(|a| (now, a)));
        match control.next_deadline() {
            Some(next) if next <= to => now = next.max(now),
            _ => return out,
        }
    }
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
        h: 400,
        electricity: 80,
        location: Location::Localized,
        gait_state: GaitState::Walk,
        motor_state: MotorState::Normal,
        charge_state: ChargeState::NotCharging,
        control_mode: ControlMode::Manual,
        on_dock_state: OnDockState::OffDock,
    }
}

/// A healthy battery answer.
pub fn battery() -> Battery {
    Battery {
        voltage: 54,
        current: -150,
        remaining_capacity: 2400,
        nominal_capacity: 3000,
        cycles: 42,
        protected_state: ProtectedState::Normal,
        battery_level: 80,
        battery_temperature: Some(31.5),
    }
}
