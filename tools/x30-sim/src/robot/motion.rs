//! Manual motion (Type 2 translation and rotation commands) and timed motion-state changes.

use std::f64::consts::{PI, TAU};
use std::time::Duration;

use x30_panel::proto::message::{Direction, MotionCommand, Speed};

use super::Pose;
use x30_panel::proto::codes::MotionState;

/// How long manual motion continues after the last translation or rotation command: the
/// motion watchdog.
///
/// The robot expects those commands repeated at 3–5 Hz (docs/protocol.md, "Type 2: motion
/// control"), that is at most 333 ms
/// apart, and stops (as on Command 6) when they come slower. 400 ms allows a 3 Hz client
/// some jitter while a gap longer than that, a client below the protocol's rate, stops the
/// robot, so a client that repeats too slowly sees it stutter here rather than on a real
/// robot. This is real time, not scaled by the time scale: it watches the client's sending
/// rate, which does not speed up with the simulation.
pub const MOTION_TIMEOUT: Duration = Duration::from_millis(400);

/// Simulated seconds from Command 15 (lie down) to lying down (state 5 → 0).
pub const LIE_DOWN_TIME: f64 = 1.0;
/// Simulated seconds a stand-up takes (state 1 → 2).
pub const STAND_UP_TIME: f64 = 1.0;
/// Simulated seconds from initial stand to force-control stand after a stand-up (2 → 3).
pub const FORCE_CONTROL_TIME: f64 = 0.5;

/// The direction and requested speed of a translation or rotation command; `None` for
/// every other command.
pub fn drive_of(command: &MotionCommand) -> Option<(Direction, Speed)> {
    match *command {
        MotionCommand::Move(direction, speed) => Some((direction, speed)),
        _ => None,
    }
}

/// The forward speed the 1002 `Speed` item reports while driving in `direction` at `speed`.
pub fn forward_speed(direction: Direction, speed: f64) -> f64 {
    match direction {
        Direction::Forward => speed,
        Direction::Backward => -speed,
        _ => 0.0,
    }
}

/// Manual motion in progress: what was last commanded and when (real time).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManualMotion {
    /// The direction.
    pub drive: Direction,
    /// The speed, m/s or rad/s.
    pub speed: f64,
    /// Real time since the simulator started at which the last command arrived.
    pub last_command: Duration,
}

/// A motion-state change that happens by itself after a while (lying down, standing up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    /// Simulated time at which it happens, s.
    pub at: f64,
    /// The state it leads to.
    pub to: MotionState,
}

impl Pose {
    /// Moves the pose by `drive` at `speed` for `dt` simulated seconds; returns the distance
    /// translated, m (0 for turns).
    pub fn drive(&mut self, drive: Direction, speed: f64, dt: f64) -> f64 {
        let step = speed * dt;
        let (sin, cos) = self.yaw.sin_cos();
        let (dx, dy) = match drive {
            Direction::Forward => (step * cos, step * sin),
            Direction::Backward => (-step * cos, -step * sin),
            // Left of the heading is the heading turned by +90°: (−sin, cos).
            Direction::StrafeLeft => (-step * sin, step * cos),
            Direction::StrafeRight => (step * sin, -step * cos),
            Direction::TurnLeft => {
                self.yaw = wrap_angle(self.yaw + step);
                return 0.0;
            }
            Direction::TurnRight => {
                self.yaw = wrap_angle(self.yaw - step);
                return 0.0;
            }
        };
        self.x += dx;
        self.y += dy;
        step.abs()
    }
}

/// An angle brought into (−π, π], as the robot reports its yaw.
pub fn wrap_angle(angle: f64) -> f64 {
    let a = angle % TAU;
    if a > PI {
        a - TAU
    } else if a <= -PI {
        a + TAU
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn driving_moves_relative_to_the_heading() {
        let mut pose = Pose {
            yaw: PI / 2.0,
            ..Pose::default()
        };
        assert_eq!(pose.drive(Direction::Forward, 0.5, 2.0), 1.0);
        assert!((pose.y - 1.0).abs() < 1e-9 && pose.x.abs() < 1e-9);
        pose.drive(Direction::StrafeLeft, 0.1, 10.0);
        assert!((pose.x + 1.0).abs() < 1e-9, "{pose:?}");
        assert_eq!(pose.drive(Direction::TurnRight, 0.35, 1.0), 0.0);
        assert!((pose.yaw - (PI / 2.0 - 0.35)).abs() < 1e-9);
    }

    #[test]
    fn angles_wrap_into_the_reported_range() {
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-9);
        assert!((wrap_angle(-3.0 * PI / 2.0) - PI / 2.0).abs() < 1e-9);
        assert_eq!(wrap_angle(PI), PI);
        assert!(wrap_angle(f64::NAN).is_nan());
    }
}
