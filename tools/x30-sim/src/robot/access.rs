//! Reading and changing the simulated state from outside the protocol: what tests and
//! tools use to look at the robot and to put it into situations (low battery, fallen, a
//! broken navigation program) that clients must cope with.

use std::time::Duration;

use x30_panel::proto::codes::{ControlMode, GaitState, MotionState};
use x30_panel::proto::message::Light;

use super::motion::wrap_angle;
use super::{ManualMotion, Pose, Requester, Robot, TaskRecord};

/// A navigation task under way, as seen from outside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskInfo {
    /// The 1003 request's connection and message ID.
    pub owner: Requester,
    /// Number of the waypoint being walked to (what 1007 reports as `Value`).
    pub target: i32,
    /// Number of the last waypoint (what the 1003 answer will carry).
    pub value: i32,
    /// Waypoints in the task.
    pub waypoints: usize,
    /// Waypoints reached so far.
    pub reached: usize,
}

/// Everything about the simulated robot at one moment, for tests and tools.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Real time since the simulator started, as of the last update.
    pub real_time: Duration,
    /// Simulated time since the simulator started, s.
    pub sim_time: f64,
    /// Motion state.
    pub motion_state: MotionState,
    /// Position and heading.
    pub pose: Pose,
    /// Forward speed as 1002 reports it, m/s.
    pub speed: f64,
    /// Manual motion in progress, if any.
    pub manual: Option<ManualMotion>,
    /// Gait.
    pub gait: GaitState,
    /// Manual or automatic control.
    pub control_mode: ControlMode,
    /// Battery charge, 0.0..=100.0 %.
    pub battery: f64,
    /// Whether the battery is charging (on the dock or a charger).
    pub charging: bool,
    /// Whether the robot lies on its dock.
    pub on_dock: bool,
    /// Whether a charger cable is connected (tasks fail with 41732).
    pub charger_connected: bool,
    /// Whether the robot is localised.
    pub localized: bool,
    /// Whether relocalisation (2101) fails.
    pub localization_broken: bool,
    /// Whether the navigation program runs (if not: 1002 all zeros, 1007 −1, 1003 41745).
    pub navigation_running: bool,
    /// Whether an obstacle is on the path within 2 m (2002).
    pub obstacle: bool,
    /// Motor temperatures, °C, in the document's order.
    pub motor_temperatures: [f64; 12],
    /// The last indicator light request accepted (1101), if any.
    pub light: Option<Light>,
    /// The last body height requested (Command 19, beyond V1.0.12), if any.
    pub body_height: Option<f32>,
    /// Odometry since start, m.
    pub odometry: f64,
    /// The navigation task under way, if any.
    pub task: Option<TaskInfo>,
    /// How the last navigation task ended, if one has.
    pub last_task: Option<TaskRecord>,
}

impl Robot {
    /// Everything about the robot now.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            real_time: self.real_now,
            sim_time: self.sim_time,
            motion_state: self.state,
            pose: self.pose,
            speed: self.speed,
            manual: self.manual,
            gait: self.gait,
            control_mode: self.control_mode,
            battery: self.power.level(),
            charging: self.is_charging(),
            on_dock: self.on_dock,
            charger_connected: self.charger_connected,
            localized: self.localized,
            localization_broken: self.localization_broken,
            navigation_running: self.navigation_running,
            obstacle: self.obstacle,
            motor_temperatures: self.motors.temperatures(),
            light: self.light,
            body_height: self.body_height,
            odometry: self.odometry,
            task: self.task.as_ref().map(|task| TaskInfo {
                owner: task.owner,
                target: task.current().map_or(task.value(), |p| p.value),
                value: task.value(),
                waypoints: task.len(),
                reached: task.reached(),
            }),
            last_task: self.last_task,
        }
    }

    /// Motion state.
    pub fn motion_state(&self) -> MotionState {
        self.state
    }

    /// Position and heading.
    pub fn pose(&self) -> Pose {
        self.pose
    }

    /// The last indicator light request accepted, if any.
    pub fn light(&self) -> Option<Light> {
        self.light
    }

    /// Battery charge, 0.0..=100.0 %.
    pub fn battery_level(&self) -> f64 {
        self.power.level()
    }

    /// Sets the battery charge, % (clamped to 0..=100). At or below 10 % navigation tasks fail.
    pub fn set_battery(&mut self, percent: f64) {
        self.power.set_level(percent);
    }

    /// Puts an obstacle on the path or clears it (2002). A task walking with obstacle stop
    /// on waits while it is there, and fails after [`OBSTACLE_STOP_LIMIT`](super::OBSTACLE_STOP_LIMIT).
    pub fn set_obstacle(&mut self, obstacle: bool) {
        self.obstacle = obstacle;
    }

    /// Makes the robot localised or lost (1002 `Location`); 2101 localises it again.
    pub fn set_localized(&mut self, localized: bool) {
        self.localized = localized;
    }

    /// Makes relocalisation (2101) fail, answering 1 and leaving the robot lost.
    pub fn set_localization_broken(&mut self, broken: bool) {
        self.localization_broken = broken;
    }

    /// Starts or stops the navigation program. Stopped: 1002 answers all zeros, 1007
    /// answers −1, and tasks fail with 41745.
    pub fn set_navigation_running(&mut self, running: bool) {
        self.navigation_running = running;
    }

    /// Connects or disconnects a charger cable: the battery charges and tasks fail with 41732.
    pub fn set_charger_connected(&mut self, connected: bool) {
        self.charger_connected = connected;
    }

    /// Sets every motor's temperature, °C; above [`OVER_TEMPERATURE`](super::OVER_TEMPERATURE) the motors report
    /// over-temperature and tasks fail with 41731. They cool down from there at rest.
    pub fn set_motor_temperatures(&mut self, celsius: f64) {
        for i in 0..12 {
            self.motors.set(i, celsius);
        }
    }

    /// Sets one motor's temperature, °C (index in the document's order, left front sway = 0).
    pub fn set_motor_temperature(&mut self, motor: usize, celsius: f64) {
        self.motors.set(motor, celsius);
    }

    /// Forces the motion state, for example [`MotionState::Fallen`]; manual motion stops
    /// unless the state is stepping. A running task fails at the next update if the state
    /// is soft emergency stop or fallen (41729).
    pub fn set_motion_state(&mut self, state: MotionState) {
        if state != MotionState::Stepping {
            self.stop_manual();
        }
        self.set_state(state);
    }

    /// Moves the robot (yaw wrapped into (−π, π]).
    pub fn set_pose(&mut self, pose: Pose) {
        self.pose = Pose {
            yaw: wrap_angle(pose.yaw),
            ..pose
        };
    }

    /// Makes waypoints with these `Value`s unreachable: a task fails with 41804 (global
    /// path planning failed) when it sets out for one, as a real robot does when no path
    /// leads there. An empty list makes every waypoint reachable again.
    pub fn set_unreachable_points(&mut self, values: &[i32]) {
        self.unreachable = values.to_vec();
    }

    /// Sets the gait (1002 `GaitState`).
    pub fn set_gait(&mut self, gait: GaitState) {
        self.gait = gait;
    }

    /// Puts the robot lying on its dock (charging) or takes it off.
    pub fn set_on_dock(&mut self, on_dock: bool) {
        self.on_dock = on_dock;
        if on_dock {
            self.stop_manual();
            self.set_state(MotionState::LyingDown);
        }
    }
}
