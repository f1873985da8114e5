//! The simulated robot: one state machine that every connection talks to.
//!
//! Nothing here does I/O or reads a clock. Every call that needs time takes `now`, the real
//! time since the simulator started, so the robot can be driven step by step in unit tests.
//! The robot multiplies elapsed real time by its time scale for everything physical
//! (walking, navigation, battery, temperatures, lying down, standing up). Only the
//! manual-motion watchdog ([`MOTION_TIMEOUT`]) runs in real time, because it watches how
//! often the client sends, which does not speed up with the simulation.
//!
//! Requests go in through [`Robot::handle`], which answers at once or, for a navigation task,
//! later. A task that ends for reasons other than a cancel (arrival, a failure while it
//! runs, a soft emergency stop) leaves its answer in an outbox that the server empties with
//! [`Robot::take_ended`]. What tasks do on the way (each waypoint set out for, how they end)
//! collects for the log the same way ([`Robot::take_task_events`]).

mod access;
mod motion;
mod motors;
mod nav;
mod power;

use std::time::Duration;

use x30_panel::proto::codes::{
    ChargeState, CommandResult, ControlMode, ErrorStatus, GaitState, LightEffect,
    LocalizationResult, Location, MotionGait, MotionState, MotorState, NavOutcome, NavTaskStatus,
    ObsMode, ObsState, OnDockState, PointInfo,
};
use x30_panel::proto::message::{
    Battery, CommandAck, Direction, Light, MapImage, MotionAck, MotionCommand, MotionValue,
    MotorTemperatures, NavPoint, NavResult, NavTask, NavTaskState, Perception, Relocalize,
    RelocalizeAck, Request, Response, RobotStatus, ValidationError,
};

pub use access::{Snapshot, TaskInfo};
pub use motion::{FORCE_CONTROL_TIME, LIE_DOWN_TIME, MOTION_TIMEOUT, ManualMotion, STAND_UP_TIME};
pub use motors::OVER_TEMPERATURE;
pub use nav::{TaskEvent, TaskProgress, nav_speed};
pub use power::{CHARGE_RATE, IDLE_DRAIN, LYING_DRAIN, Load, MOVING_DRAIN, NOMINAL_CAPACITY};

use motion::{Transition, wrap_angle};
use motors::Motors;
use nav::Task;
use power::Power;

/// Number of a client connection, counted from 1 in the order they were accepted.
pub type ConnId = u64;

/// The map image the robot reports in 1002: 5 cm pixels, bottom-left corner at
/// (−10 m, −10 m), 400 px high.
pub const MAP: MapImage = MapImage {
    res: 0.05,
    x0: -10.0,
    y0: -10.0,
    h: 400,
};

/// At or below this charge (the reported, rounded %), navigation tasks fail with 41730.
pub const LOW_BATTERY: i32 = 10;

/// Simulated seconds an obstacle may hold up a task walking with obstacle stop on
/// (`ObsMode` 0) before it fails with 41803.
pub const OBSTACLE_STOP_LIMIT: f64 = 30.0;

/// Total odometry of the simulated robot when it starts, m.
const INITIAL_SUM_ODOMETRY: f64 = 123_400.0;

/// Where a request came from, so that an answer sent later finds its way back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Requester {
    /// The connection it arrived on.
    pub conn: ConnId,
    /// Its message ID, which the answer echoes.
    pub message_id: u16,
}

/// What the robot does with a request.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// Answer now, on the request's connection.
    Now(Response),
    /// A navigation task was accepted: its answer comes when it ends.
    Later,
    /// A cancel (1004) ended a running task: first send the task's answer on the task's
    /// connection, then at once `answer` on the cancel's connection (one write when it is
    /// the same connection).
    AfterTask {
        /// The cancelled task and its answer (ErrorCode 2, ErrorStatus 8962).
        task: EndedTask,
        /// The 1004 answer.
        answer: Response,
    },
}

/// A navigation task that has ended, with the 1003 answer to send to whoever asked for it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EndedTask {
    /// The 1003 request's connection and message ID.
    pub owner: Requester,
    /// The answer.
    pub result: NavResult,
}

/// How the last navigation task ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskRecord {
    /// The number its answer carried: the last waypoint's when all were reached, else the
    /// one it stopped on the way to.
    pub value: i32,
    /// Succeeded, failed or cancelled.
    pub outcome: NavOutcome,
    /// Why (for example 8960 completed, 41802 client connection dropped).
    pub status: ErrorStatus,
    /// The connection that asked for it.
    pub conn: ConnId,
}

/// Position and heading in the map frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// m.
    pub x: f64,
    /// m.
    pub y: f64,
    /// m.
    pub z: f64,
    /// rad, in (−π, π], counter-clockwise from the map's x axis.
    pub yaw: f64,
}

/// The simulated robot.
///
/// It starts standing in force-control stand (3), battery 90 %, localised at the origin
/// facing along x, gait walk, manual control, the navigation program running.
///
/// # Motion states (docs/protocol.md, "Type 1002: real-time status") and Type 2 commands
///
/// | Command | from | effect |
/// |---|---|---|
/// | 1, 2, 3, 4, 11, 12 | 2, 3, 4 | stepping (4), moving at the speed asked (−1: 0.5 m/s, 0.35 rad/s, 0.1 m/s) until [`MOTION_TIMEOUT`] (400 ms, real time) after the last one |
/// | 6 zero velocity | any | stops manual motion, keeps stepping; never fails |
/// | 13 soft e-stop | any | 6; stops motion; a running task fails with 41766 |
/// | 14 stop stepping | 4 (2, 3: no change) | 3 |
/// | 15 lie down | 1, 2, 3, 4 | 5, then 0 after [`LIE_DOWN_TIME`] s simulated |
/// | 15 lie down | 6, 7 | 0 at once (the way out of soft e-stop and fallen) |
/// | 20 switch gait | all but 6, 7 | Value 0/1/2/4 → GaitState 0/1/2/6; other values fail |
/// | 16 stand up¹ | 0 | 1, then 2 after [`STAND_UP_TIME`] s, then 3 after [`FORCE_CONTROL_TIME`] s |
/// | 17 force control¹ | 2 | 3 |
/// | 18 start stepping¹ | 2, 3 | 4 |
/// | 19 body height¹, 21, 22¹ | any | recorded / accepted, nothing else |
///
/// ¹ Beyond protocol V1.0.12. Translations, rotations, 14, 15, 20 and the extensions fail
/// (ErrorCode 1) while a navigation task runs, and so does any speed outside the document's
/// range. A command from a state not listed fails and changes nothing.
///
/// # Navigation
///
/// A task walks its waypoints (one per `<Items>` block) in order, in straight lines at each
/// point's speed (normal 0.5, low 0.25, high 1.0 m/s), and is answered once, when it ends.
/// It is refused at once (ErrorCode 1) when the navigation program is not running (41745),
/// a task already runs (41793), a point breaks the document's rules (ErrorStatus 0: the
/// document has no code for it), or the robot's state forbids it: soft e-stop or fallen
/// (41729), battery ≤ 10 % (41730), a motor over 80 °C (41731), a charger connected
/// (41732), localisation lost (41747). The same conditions end a running task, and so does
/// setting out for a waypoint made unreachable ([`Robot::set_unreachable_points`]: 41804,
/// global path planning failed). On arrival at the last waypoint: transition point → keeps
/// stepping; task or standing point → force-control stand; charging point → lying on the
/// dock, charging.
///
/// The answer's `Value` is the last waypoint's when the task succeeded; when it failed or
/// was cancelled, it is the waypoint the robot was walking to (a refused task: the first),
/// so that the client learns where the route stopped. 1007 reports the waypoint being walked
/// to while the task runs.
#[derive(Debug, Clone)]
pub struct Robot {
    time_scale: f64,
    real_now: Duration,
    sim_time: f64,
    state: MotionState,
    transition: Option<Transition>,
    pose: Pose,
    manual: Option<ManualMotion>,
    speed: f64,
    odometry: f64,
    gait: GaitState,
    control_mode: ControlMode,
    localized: bool,
    localization_broken: bool,
    navigation_running: bool,
    obstacle: bool,
    on_dock: bool,
    charger_connected: bool,
    power: Power,
    motors: Motors,
    light: Option<Light>,
    body_height: Option<f32>,
    task: Option<Task>,
    last_task: Option<TaskRecord>,
    ended: Vec<EndedTask>,
    task_events: Vec<TaskProgress>,
    /// `Value`s of waypoints no task can reach.
    unreachable: Vec<i32>,
}

impl Default for Robot {
    fn default() -> Self {
        Self::new(1.0)
    }
}

impl Robot {
    /// A robot in its starting state whose simulated time runs `time_scale` times as fast as
    /// real time (a scale that is not a positive finite number counts as 1).
    pub fn new(time_scale: f64) -> Self {
        Self {
            time_scale: if time_scale.is_finite() && time_scale > 0.0 {
                time_scale
            } else {
                1.0
            },
            real_now: Duration::ZERO,
            sim_time: 0.0,
            state: MotionState::ForceControlStand,
            transition: None,
            pose: Pose::default(),
            manual: None,
            speed: 0.0,
            odometry: 0.0,
            gait: GaitState::Walk,
            control_mode: ControlMode::Manual,
            localized: true,
            localization_broken: false,
            navigation_running: true,
            obstacle: false,
            on_dock: false,
            charger_connected: false,
            power: Power::new(90.0),
            motors: Motors::default(),
            light: None,
            body_height: None,
            task: None,
            last_task: None,
            ended: Vec::new(),
            task_events: Vec::new(),
            unreachable: Vec::new(),
        }
    }

    /// How many times faster than real time the simulated time runs.
    pub fn time_scale(&self) -> f64 {
        self.time_scale
    }

    // ---------------------------------------------------------------------------------
    // Time
    // ---------------------------------------------------------------------------------

    /// Brings the robot up to `now` (real time since the simulator started): motion,
    /// navigation, timed state changes, battery and temperatures. Times earlier than the
    /// last one are ignored.
    pub fn advance(&mut self, now: Duration) {
        let Some(elapsed) = now.checked_sub(self.real_now).filter(|d| !d.is_zero()) else {
            return;
        };
        let mut moved = 0.0;
        let mut walking = false;
        if let Some(manual) = self.manual {
            // Manual motion runs until its watchdog expires, even if nobody looked in between.
            let deadline = manual.last_command.saturating_add(MOTION_TIMEOUT);
            let active = deadline.min(now).saturating_sub(self.real_now);
            let dt = active.as_secs_f64() * self.time_scale;
            if dt > 0.0 {
                moved += self.pose.drive(manual.drive, manual.speed, dt);
                walking = true;
            }
            if now >= deadline {
                self.stop_manual();
            }
        }
        self.real_now = now;
        let dt = elapsed.as_secs_f64() * self.time_scale;
        self.sim_time += dt;
        self.run_transitions();
        if self.task.is_some() {
            let covered = self.run_task(dt);
            moved += covered;
            walking |= covered > 0.0;
        }
        self.odometry += moved;
        let load = if walking {
            Load::Moving
        } else if self.is_upright() {
            Load::Standing
        } else {
            Load::Lying
        };
        self.power.advance(dt, load, self.is_charging());
        self.motors.advance(dt, walking);
    }

    /// Carries out the timed state changes that are due.
    fn run_transitions(&mut self) {
        while let Some(t) = self.transition.filter(|t| self.sim_time >= t.at) {
            self.state = t.to;
            // A stand-up ends in force-control stand shortly after the initial stand.
            self.transition = (t.to == MotionState::InitialStand).then_some(Transition {
                at: t.at + FORCE_CONTROL_TIME,
                to: MotionState::ForceControlStand,
            });
        }
    }

    // ---------------------------------------------------------------------------------
    // Requests
    // ---------------------------------------------------------------------------------

    /// Handles one decoded request from `from`, at real time `now`.
    pub fn handle(&mut self, request: &Request, from: Requester, now: Duration) -> Reply {
        self.advance(now);
        let answer = match request {
            Request::Status => Response::Status(self.status()),
            Request::NavTask(task) => return self.start_task(task, from),
            Request::CancelNav => return self.cancel_task(),
            Request::NavStatus => Response::NavStatus(self.nav_status()),
            Request::MotorTemperatures => Response::MotorTemperatures(self.motor_temperatures()),
            Request::Light(light) => Response::Light(CommandAck {
                result: result(self.set_light(light)),
            }),
            Request::Motion(command) => {
                let ok = self.motion(command);
                motion_answer(command, ok)
            }
            Request::Battery => Response::Battery(self.battery()),
            Request::Perception => Response::Perception(self.perception()),
            Request::Relocalize(pose) => Response::Relocalize(self.relocalize(pose)),
        };
        Reply::Now(answer)
    }

    /// One answer of each kind the robot gives, for what they can hold: every Type's, as it
    /// would answer now, and a completed navigation task's.
    pub fn sample_answers(&mut self) -> Vec<Response> {
        let from = Requester {
            conn: 0,
            message_id: 0,
        };
        let light = Light {
            red: 0,
            green: 0,
            blue: 0,
            effect: LightEffect::Steady,
            brightness: 0,
        };
        let pose = Relocalize {
            pos_x: 0.0,
            pos_y: 0.0,
            pos_z: 0.0,
            yaw: 0.0,
        };
        let requests = [
            Request::Status,
            Request::Battery,
            Request::Perception,
            Request::MotorTemperatures,
            Request::NavStatus,
            Request::CancelNav,
            Request::Motion(MotionCommand::ZeroVelocity),
            Request::Light(light),
            Request::Relocalize(pose),
        ];
        let mut answers: Vec<Response> = requests
            .iter()
            .filter_map(|request| match self.handle(request, from, self.real_now) {
                Reply::Now(answer) => Some(answer),
                _ => None,
            })
            .collect();
        answers.push(Response::NavResult(NavResult {
            value: 1,
            outcome: NavOutcome::Succeeded,
            status: ErrorStatus::TaskCompleted,
        }));
        answers
    }

    /// Tells the robot that a connection has closed: a task it asked for stops with 41802
    /// (its answer cannot be sent any more).
    pub fn connection_closed(&mut self, conn: ConnId, now: Duration) {
        self.advance(now);
        if self.task.as_ref().is_some_and(|t| t.owner.conn == conn) {
            self.end_task(NavOutcome::Failed, ErrorStatus::ClientDisconnected);
        }
    }

    /// Takes the answers of tasks that have ended by themselves since the last call.
    pub fn take_ended(&mut self) -> Vec<EndedTask> {
        std::mem::take(&mut self.ended)
    }

    /// Takes what tasks did since the last call (waypoints set out for, ends), oldest first.
    pub fn take_task_events(&mut self) -> Vec<TaskProgress> {
        std::mem::take(&mut self.task_events)
    }

    /// Notes a task event at the current time.
    fn task_event(&mut self, owner: Requester, event: TaskEvent) {
        self.task_events.push(TaskProgress {
            owner,
            at: self.real_now,
            event,
        });
    }

    // ---------------------------------------------------------------------------------
    // Motion control (Type 2)
    // ---------------------------------------------------------------------------------

    /// Carries out a motion command; returns whether it succeeded.
    fn motion(&mut self, command: &MotionCommand) -> bool {
        match command {
            // Stopping is always possible and never touches a navigation task.
            MotionCommand::ZeroVelocity => {
                self.stop_manual();
                return true;
            }
            MotionCommand::SoftEmergencyStop => {
                self.soft_emergency_stop();
                return true;
            }
            _ => {}
        }
        // The robot carries out the commands beyond V1.0.12 whether or not this build may
        // send them.
        let invalid = command
            .validate()
            .is_err_and(|e| e != ValidationError::VendorExtension);
        if invalid || self.task.is_some() {
            return false;
        }
        if let Some((drive, speed)) = motion::drive_of(command) {
            let speed = match speed {
                x30_panel::proto::message::Speed::Default => drive.default_speed(),
                x30_panel::proto::message::Speed::Value(v) => f64::from(v),
            };
            return self.start_manual(drive, speed);
        }
        use MotionState as S;
        match *command {
            MotionCommand::StopStepping => match self.state {
                S::Stepping => {
                    self.stop_manual();
                    self.state = S::ForceControlStand;
                    true
                }
                S::InitialStand | S::ForceControlStand => true,
                _ => false,
            },
            MotionCommand::LieDown => self.lie_down(),
            MotionCommand::SwitchGait(gait) => self.switch_gait(gait),
            MotionCommand::StandUp => self.stand_up(),
            MotionCommand::ForceControl => match self.state {
                S::InitialStand => {
                    self.set_state(S::ForceControlStand);
                    true
                }
                S::ForceControlStand | S::Stepping => true,
                _ => false,
            },
            MotionCommand::StartStepping => match self.state {
                S::InitialStand | S::ForceControlStand => {
                    self.set_state(S::Stepping);
                    true
                }
                S::Stepping => true,
                _ => false,
            },
            MotionCommand::BodyHeight(height) => {
                self.body_height = Some(height);
                true
            }
            MotionCommand::GoCharging | MotionCommand::LeaveCharger => true,
            _ => false,
        }
    }

    /// Starts or continues manual motion, from a standing state only.
    fn start_manual(&mut self, drive: Direction, speed: f64) -> bool {
        use MotionState as S;
        if !matches!(
            self.state,
            S::InitialStand | S::ForceControlStand | S::Stepping
        ) {
            return false;
        }
        self.set_state(S::Stepping);
        self.control_mode = ControlMode::Manual;
        self.manual = Some(ManualMotion {
            drive,
            speed,
            last_command: self.real_now,
        });
        self.speed = motion::forward_speed(drive, speed);
        true
    }

    /// Ends manual motion; the robot keeps stepping in place.
    fn stop_manual(&mut self) {
        if self.manual.take().is_some() {
            self.speed = 0.0;
        }
    }

    /// Sets the motion state, cancelling any timed change.
    fn set_state(&mut self, state: MotionState) {
        self.state = state;
        self.transition = None;
    }

    fn soft_emergency_stop(&mut self) {
        self.stop_manual();
        self.set_state(MotionState::SoftEmergencyStop);
        if self.task.is_some() {
            self.fail_task(ErrorStatus::SoftEmergencyStopped);
        }
        self.speed = 0.0;
    }

    fn lie_down(&mut self) -> bool {
        use MotionState as S;
        match self.state {
            S::StandingUp | S::InitialStand | S::ForceControlStand | S::Stepping => {
                self.stop_manual();
                self.state = S::LyingDownInProgress;
                self.transition = Some(Transition {
                    at: self.sim_time + LIE_DOWN_TIME,
                    to: S::LyingDown,
                });
                true
            }
            // The way out of soft emergency stop and fallen (docs/protocol.md, "Type 1002:
            // real-time status"): already on the ground.
            S::SoftEmergencyStop | S::Fallen | S::Unknown(_) => {
                self.set_state(S::LyingDown);
                true
            }
            S::LyingDown | S::LyingDownInProgress => true,
        }
    }

    fn stand_up(&mut self) -> bool {
        use MotionState as S;
        match self.state {
            S::LyingDown => {
                self.on_dock = false;
                self.state = S::StandingUp;
                self.transition = Some(Transition {
                    at: self.sim_time + STAND_UP_TIME,
                    to: S::InitialStand,
                });
                true
            }
            S::StandingUp | S::InitialStand | S::ForceControlStand | S::Stepping => true,
            _ => false,
        }
    }

    fn switch_gait(&mut self, gait: MotionGait) -> bool {
        if matches!(
            self.state,
            MotionState::SoftEmergencyStop | MotionState::Fallen
        ) {
            return false;
        }
        // Command 20 numbers gaits differently from the 1002 GaitState.
        let state = match gait {
            MotionGait::Walk => GaitState::Walk,
            MotionGait::NormalStairs => GaitState::ObstacleCrossing,
            MotionGait::Slope => GaitState::Slope,
            MotionGait::PerceptionStairs => GaitState::PerceptionStairs,
            MotionGait::Unknown(_) => return false,
        };
        self.gait = state;
        true
    }

    // ---------------------------------------------------------------------------------
    // Navigation (1003, 1004, 1007)
    // ---------------------------------------------------------------------------------

    /// Accepts a navigation task, or answers at once why not.
    ///
    /// A point that breaks the document's rules (`NavPoint::validate`) fails with ErrorCode 1
    /// and ErrorStatus 0: the document has no code for it.
    fn start_task(&mut self, task: &NavTask, from: Requester) -> Reply {
        // A refused task never left its first waypoint.
        let value = task.points.first().map_or(0, |p| p.value);
        let refuse = |status| {
            Reply::Now(Response::NavResult(NavResult {
                value,
                outcome: NavOutcome::Failed,
                status,
            }))
        };
        if !self.navigation_running {
            return refuse(ErrorStatus::NavigationNotRunning);
        }
        if self.task.is_some() {
            return refuse(ErrorStatus::TaskAlreadyRunning);
        }
        if task.validate().is_err() {
            return refuse(ErrorStatus::Default);
        }
        if let Some(status) = self.task_blocker() {
            return refuse(status);
        }
        // The robot switches itself into navigation: it gets up (off the dock) and walks.
        self.stop_manual();
        self.on_dock = false;
        self.set_state(MotionState::Stepping);
        self.control_mode = ControlMode::Automatic;
        let task = Task::new(from, &task.points);
        self.speed = task.reported_speed();
        if let Some(event) = task.set_out(0) {
            self.task_event(from, event);
        }
        self.task = Some(task);
        Reply::Later
    }

    /// Cancels the running task, if any; cancelling nothing succeeds.
    fn cancel_task(&mut self) -> Reply {
        let answer = Response::CancelNav(CommandAck {
            result: CommandResult::Success,
        });
        match self.end_task(NavOutcome::Cancelled, ErrorStatus::TaskCancelled) {
            Some(task) => Reply::AfterTask { task, answer },
            None => Reply::Now(answer),
        }
    }

    /// Why a task cannot start or go on, from the robot's state, if it cannot.
    fn task_blocker(&self) -> Option<ErrorStatus> {
        Some(if !self.navigation_running {
            ErrorStatus::NavigationNotRunning
        } else if matches!(
            self.state,
            MotionState::SoftEmergencyStop | MotionState::Fallen
        ) {
            ErrorStatus::MotionStateAbnormal
        } else if self.power.percent() <= LOW_BATTERY {
            ErrorStatus::BatteryTooLow
        } else if self.motors.over_temperature() {
            ErrorStatus::MotorOverTemperature
        } else if self.charger_connected {
            ErrorStatus::ChargingOnCharger
        } else if !self.localized {
            ErrorStatus::LocalizationAbnormal
        } else {
            return None;
        })
    }

    /// Moves the running task on by `dt` simulated seconds; returns the distance walked.
    ///
    /// Each waypoint set out for is noted for the log; setting out for an unreachable one
    /// fails the task.
    fn run_task(&mut self, dt: f64) -> f64 {
        if let Some(status) = self.task_blocker() {
            self.fail_task(status);
            return 0.0;
        }
        let (sim_time, obstacle) = (self.sim_time, self.obstacle);
        let Some(task) = self.task.as_mut() else {
            return 0.0;
        };
        let stopped_by_obstacle = obstacle
            && task
                .current()
                .is_some_and(|p| p.obs_mode == ObsMode::Enabled);
        if stopped_by_obstacle {
            let since = *task.obstacle_since.get_or_insert(sim_time);
            self.speed = 0.0;
            if sim_time - since >= OBSTACLE_STOP_LIMIT {
                self.fail_task(ErrorStatus::ObstacleStopTooLong);
            }
            return 0.0;
        }
        task.obstacle_since = None;
        let unreachable = &self.unreachable;
        let blocked = |p: &NavPoint| unreachable.contains(&p.value);
        let before = task.reached();
        let covered = task.walk(&mut self.pose, dt, blocked);
        self.speed = task.reported_speed();
        let (owner, after) = (task.owner, task.reached());
        let set_out: Vec<TaskEvent> = (before + 1..=after)
            .filter_map(|index| task.set_out(index))
            .collect();
        let stuck = task.current().is_some_and(blocked);
        let done = task.is_done();
        for event in set_out {
            self.task_event(owner, event);
        }
        if stuck {
            self.fail_task(ErrorStatus::GlobalPlanningFailed);
        } else if done {
            let arrival = self
                .task
                .as_ref()
                .and_then(Task::final_point)
                .map(|p| p.point_info);
            self.arrive(arrival);
            if let Some(ended) = self.end_task(NavOutcome::Succeeded, ErrorStatus::TaskCompleted) {
                self.ended.push(ended);
            }
        }
        covered
    }

    /// Takes the position the target point asks for.
    fn arrive(&mut self, point_info: Option<PointInfo>) {
        self.speed = 0.0;
        let state = match point_info {
            // A transition point keeps the robot stepping until the next task.
            Some(PointInfo::Transition) => MotionState::Stepping,
            Some(PointInfo::Charging) => {
                self.on_dock = true;
                MotionState::LyingDown
            }
            _ => MotionState::ForceControlStand,
        };
        self.set_state(state);
    }

    /// Fails the running task and leaves its answer in the outbox.
    fn fail_task(&mut self, status: ErrorStatus) {
        if let Some(ended) = self.end_task(NavOutcome::Failed, status) {
            self.ended.push(ended);
        }
    }

    /// Ends the running task, records how, and returns its answer; the robot stops where it is.
    fn end_task(&mut self, outcome: NavOutcome, status: ErrorStatus) -> Option<EndedTask> {
        let task = self.task.take()?;
        let result = NavResult {
            value: task.ended_value(),
            outcome,
            status,
        };
        self.task_event(task.owner, TaskEvent::ended(&task, &result));
        self.last_task = Some(TaskRecord {
            value: result.value,
            outcome,
            status,
            conn: task.owner.conn,
        });
        if outcome != NavOutcome::Succeeded {
            self.speed = 0.0;
            if self.state == MotionState::Stepping {
                self.set_state(MotionState::ForceControlStand);
            }
        }
        Some(EndedTask {
            owner: task.owner,
            result,
        })
    }

    /// The 1007 answer: the current waypoint (or the last task's target), and whether a task
    /// runs; −1 when the navigation program does not run.
    pub fn nav_status(&self) -> NavTaskState {
        let value = match (&self.task, &self.last_task) {
            (Some(task), _) => task.current().map_or(task.value(), |p| p.value),
            (None, Some(last)) => last.value,
            (None, None) => 0,
        };
        let status = if !self.navigation_running {
            NavTaskStatus::CannotRun
        } else if self.task.is_some() {
            NavTaskStatus::Running
        } else {
            NavTaskStatus::Finished
        };
        NavTaskState {
            value,
            status,
            error_code: status,
        }
    }

    // ---------------------------------------------------------------------------------
    // Status answers and the other requests
    // ---------------------------------------------------------------------------------

    /// The 1002 answer; all items 0 while the navigation program does not run.
    pub fn status(&self) -> RobotStatus {
        if !self.navigation_running {
            return RobotStatus::UNAVAILABLE;
        }
        RobotStatus {
            motion_state: self.state,
            pos_x: finite(self.pose.x),
            pos_y: finite(self.pose.y),
            pos_z: finite(self.pose.z),
            roll: 0.0,
            pitch: 0.0,
            yaw: finite(self.pose.yaw),
            speed: finite(self.speed),
            cur_odom: finite(self.odometry / 1000.0),
            sum_odom: finite((INITIAL_SUM_ODOMETRY + self.odometry) / 1000.0),
            res: MAP.res,
            x0: MAP.x0,
            y0: MAP.y0,
            h: Some(MAP.h),
            electricity: Some(self.power.percent()),
            location: Some(if self.localized {
                Location::Localized
            } else {
                Location::Lost
            }),
            gait_state: Some(self.gait),
            motor_state: Some(if self.motors.over_temperature() {
                MotorState::OverTemperature
            } else {
                MotorState::Normal
            }),
            charge_state: Some(if self.is_charging() {
                ChargeState::Charging
            } else {
                ChargeState::NotCharging
            }),
            control_mode: Some(self.control_mode),
            on_dock_state: Some(if self.on_dock {
                OnDockState::OnDock
            } else {
                OnDockState::OffDock
            }),
        }
    }

    /// The 2001 answer.
    pub fn battery(&self) -> Battery {
        self.power.message()
    }

    /// The 2002 answer.
    pub fn perception(&self) -> Perception {
        Perception {
            obs_state: if self.obstacle {
                ObsState::ObstacleAhead
            } else {
                ObsState::Clear
            },
        }
    }

    /// The 1008 answer.
    pub fn motor_temperatures(&self) -> MotorTemperatures {
        self.motors.message()
    }

    fn set_light(&mut self, light: &Light) -> bool {
        let ok = light.validate().is_ok();
        if ok {
            self.light = Some(*light);
        }
        ok
    }

    fn relocalize(&mut self, pose: &Relocalize) -> RelocalizeAck {
        let valid = Request::Relocalize(*pose).validate().is_ok();
        if !valid || self.localization_broken {
            if self.localization_broken {
                self.localized = false;
            }
            return RelocalizeAck {
                result: LocalizationResult::Abnormal,
            };
        }
        self.pose = Pose {
            x: f64::from(pose.pos_x),
            y: f64::from(pose.pos_y),
            z: f64::from(pose.pos_z),
            yaw: wrap_angle(f64::from(pose.yaw)),
        };
        self.localized = true;
        RelocalizeAck {
            result: LocalizationResult::Localized,
        }
    }

    fn is_upright(&self) -> bool {
        use MotionState as S;
        matches!(
            self.state,
            S::StandingUp | S::InitialStand | S::ForceControlStand | S::Stepping
        )
    }

    fn is_charging(&self) -> bool {
        self.on_dock || self.charger_connected
    }
}

/// A value as the f32 the wire carries; 0 if it is not finite, so that every answer can be
/// encoded (the encoder refuses NaN and infinities).
fn finite(v: f64) -> f32 {
    let v = v as f32;
    if v.is_finite() { v } else { 0.0 }
}

/// The Type 2 answer to `command`: its Value echoed, and whether it succeeded.
pub fn motion_answer(command: &MotionCommand, ok: bool) -> Response {
    let value = match command.value() {
        MotionValue::Float(v) => v,
        MotionValue::Int(v) => v as f32,
    };
    Response::Motion(
        command.code(),
        MotionAck {
            value: Some(value),
            result: result(ok),
        },
    )
}

fn result(ok: bool) -> CommandResult {
    if ok {
        CommandResult::Success
    } else {
        CommandResult::Failure
    }
}

#[cfg(test)]
mod tests;
