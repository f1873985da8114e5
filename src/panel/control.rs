//! The control state machine: debounced button events in, robot commands out.
//!
//! [`Control`] turns presses and releases into the requests of the command connection,
//! which the application pulls with [`Control::next_command`] and writes at once, without
//! waiting for earlier answers, and into navigation tasks for the navigation connection
//! ([`Control::take_task`]). It never blocks and never sends anything itself.
//!
//! The rules:
//!
//! - **Stops first.** What goes out next is, in this order: a due e-stop (Type 2 Command 13),
//!   zero velocity (Command 6), a cancel (1004), the held motion button's command, then
//!   one-shot commands. Stops are flags, not queue entries, so they are never dropped for
//!   lack of room.
//! - **E-stop latch.** `estop` latches: Command 13 goes out at once and again every
//!   [`ESTOP_REPEAT`] until a status (1002) reports soft emergency stop (MotionState 6),
//!   across timeouts, refusals and reconnects; a press during an outage goes out first when
//!   the command connection is back. Motion and `dock` stay locked out until the button is
//!   released, the robot has confirmed, and then reports a state other than 6.
//! - **Motion.** A motion button sends its command at once and every repeat period while
//!   held (the robot needs 3–5 Hz), and zero velocity when released; with several held the
//!   latest press drives. Motion is not written while the robot's answers are overdue
//!   (`motion_allowed`), so no backlog of repeats reaches a robot that wakes up. If the
//!   command connection drops while motion is commanded, or before the robot answered the
//!   last zero velocity (a robot that stopped reading it never got it), zero velocity goes
//!   out first when it is back (once, not on every connection to a robot that never
//!   answers), and a held button needs a new press.
//! - **Nothing stale.** A one-shot press (stop stepping, lie down, gait, light, cancel,
//!   dock) that has not gone out within [`STALE_PRESS`] is dropped and the fault LED
//!   blinks; it is never sent later. A navigation task cancelled or overridden before its
//!   1003 went out is not sent.
//! - **Navigation.** `stop` ends a running task with a 1004 as well as zero velocity (the
//!   robot refuses motion during a task); a motion press cancels it first, and so does the
//!   e-stop, after its Command 13; `dock` without a configured charging point does nothing
//!   but blink the fault LED.
//! - **Patrol.** `patrol` walks the saved route: a 1003 per point, the next one as soon as
//!   the robot reports the previous reached. Every stop rule holds: a motion press, `stop`
//!   or `cancel` ends it with a 1004, an e-stop ends it (with a 1004 after the e-stop, though
//!   the robot fails the running point itself), a failed, cancelled or lost point ends it
//!   with a fault blink, and it never resumes by itself after an outage. Without a route it
//!   only blinks the fault LED.
//! - **Gait** cycles from the robot's reported `GaitState`, not from a local counter.
//! - **The robot's light** (setting `robot-light`, off by default) turns steady red
//!   ([`ESTOP_LIGHT`]) once the robot has confirmed the panel's e-stop, and back to the
//!   `light` button's preset when the latch is released. It is the last thing written, and
//!   only with no stop due, no motion held and no press waiting, so it never goes ahead of
//!   any of them; a robot that refuses it, leaves it unanswered, or drops the connection
//!   before answering it is not sent another until settings are saved again.

use embassy_time::{Duration, Instant};
use heapless::{Deque, Vec};

use super::ConnectionState;
use super::buttons::{Button, ButtonEvent};
use super::next_after;
use crate::client::{ClientError, Health};
use crate::config::{Config, LightPresets, MotionSpeeds, Route};
use crate::proto::codes::{
    GaitState, LightEffect, LocalizationResult, MotionGait, MotionState, NavOutcome,
};
use crate::proto::message::{
    Light, MotionCommand, NavPoint, NavResult, NavTask, Request, Response,
};

/// How long a press stays fresh: one not acted on by then is dropped, never sent late.
pub const STALE_PRESS: Duration = Duration::from_millis(300);

/// How often a latched e-stop is sent again until the robot confirms it.
pub const ESTOP_REPEAT: Duration = Duration::from_millis(250);

/// What the robot's light shows while the panel's e-stop is confirmed (`robot-light`).
pub const ESTOP_LIGHT: Light = Light {
    red: 255,
    green: 0,
    blue: 0,
    effect: LightEffect::Steady,
    brightness: 100,
};

/// How many one-shot presses may wait to go out; one beyond is dropped (and shown).
pub const ONE_SHOT_QUEUE: usize = 4;

/// Motion buttons that can be held at once.
const MOTION_BUTTONS: usize = 6;

/// Whether an answer reports success: `ErrorCode` 0 of a command, a navigation task that
/// succeeded or was cancelled, a relocalisation that localised, or any state answer; a
/// Type 0 request error is a failure.
pub fn succeeded(response: &Response) -> bool {
    match response {
        Response::Motion(_, ack) => ack.result.is_success(),
        Response::CancelNav(ack) | Response::Light(ack) => ack.result.is_success(),
        Response::NavResult(result) => {
            matches!(
                result.outcome,
                NavOutcome::Succeeded | NavOutcome::Cancelled
            )
        }
        Response::Relocalize(ack) => ack.result == LocalizationResult::Localized,
        Response::RequestError(_) => false,
        Response::Status(_)
        | Response::NavStatus(_)
        | Response::MotorTemperatures(_)
        | Response::Battery(_)
        | Response::Perception(_) => true,
    }
}

/// How a navigation task (one 1003) ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TaskEnd {
    /// The robot reached the point.
    Reached,
    /// The robot reports the task cancelled (by this panel or another client).
    Cancelled,
    /// The task failed, or its answer was lost with its connection.
    Failed,
}

impl TaskEnd {
    /// How the task ended by its answer, or its loss.
    pub fn of(end: Result<&NavResult, &ClientError>) -> Self {
        match end.map(|result| result.outcome) {
            Ok(NavOutcome::Succeeded) => Self::Reached,
            Ok(NavOutcome::Cancelled) => Self::Cancelled,
            Ok(_) | Err(_) => Self::Failed,
        }
    }
}

/// How a command or a navigation task ended, as far as the panel is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Outcome {
    /// The robot reported success (a cancelled task counts).
    Succeeded,
    /// The robot refused it, answered with an error, or did not answer.
    Failed,
}

impl Outcome {
    /// The outcome of an answer ([`succeeded`]), or of none.
    pub fn of(answer: Result<&Response, &ClientError>) -> Self {
        if answer.is_ok_and(succeeded) {
            Self::Succeeded
        } else {
            Self::Failed
        }
    }
}

/// A navigation task a press ordered, for the navigation connection.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TaskOrder {
    /// Tells this order from later ones: ask [`Control::task_wanted`] with it just before
    /// the 1003 goes out.
    pub id: u32,
    /// The task.
    pub task: NavTask,
}

/// A command a single press sends once.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum OneShot {
    /// A Type 2 command: stop stepping, lie down, switch gait.
    Command(MotionCommand),
    /// A light preset (1101).
    Light(Light),
}

/// Where the panel's navigation task stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Task {
    /// None.
    Idle,
    /// Pressed at `at`; its 1003 has not gone out.
    Ordered {
        /// The order's ID.
        id: u32,
        /// When `dock` was pressed.
        at: Instant,
    },
    /// Its 1003 went out; the robot answers when it ends.
    Running {
        /// The order's ID.
        id: u32,
    },
}

/// Where zero velocity stands: due (and why), or written and waiting for its answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum ZeroVelocity {
    /// Not due, and none waits for its answer.
    No,
    /// Due: a release or `stop` asks for it.
    Asked,
    /// Due once more after an outage: motion was commanded, or the one asked for unanswered.
    Again,
    /// The one asked for was written at `at` and is unanswered, and no navigation task has
    /// started since (a zero velocity would take the robot out of it): an outage makes it
    /// due again. Only its own answer settles it, not that of one written before it.
    Unanswered { at: Instant },
}

impl ZeroVelocity {
    /// Whether it must go out.
    fn due(self) -> bool {
        matches!(self, Self::Asked | Self::Again)
    }
}

/// The e-stop latch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct Estop {
    /// Whether the button is down.
    held: bool,
    /// Whether motion is locked out by an e-stop press.
    latched: bool,
    /// Whether a status has reported soft emergency stop since the press.
    confirmed: bool,
    /// Whether a status has reported another state since the confirmation.
    left: bool,
    /// When Command 13 is due again, while latched and unconfirmed.
    due: Instant,
}

impl Estop {
    /// Whether Command 13 must still go out.
    fn unconfirmed(&self) -> bool {
        self.latched && !self.confirmed
    }
}

/// The robot's light as `robot-light` drives it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct RobotLight {
    /// Whether the setting is on.
    on: bool,
    /// Whether [`ESTOP_LIGHT`] was the last light written (the robot shows it, as far as
    /// the panel knows).
    estop_shown: bool,
    /// Whether a light written for the setting waits for its answer.
    unanswered: bool,
    /// Whether the robot refused one, left it unanswered, or the connection dropped before
    /// its answer: no more until settings are saved again.
    given_up: bool,
}

/// The control state machine; see the module docs for its rules.
#[derive(Debug, Clone)]
pub struct Control {
    /// Speed per motion button.
    speeds: MotionSpeeds,
    /// Presets of the `light` button.
    lights: LightPresets,
    /// The dock's charging point, if one is configured.
    dock: Option<NavPoint>,
    /// The saved patrol route.
    route: Route,
    /// The route point the patrol is at (ordered or walking to), while a patrol runs.
    patrol: Option<usize>,
    /// Repeat period of a held motion button.
    repeat: Duration,
    /// Motion buttons held since a press that was accepted, oldest first; the last one drives.
    held: Vec<Button, MOTION_BUTTONS>,
    /// When the driving motion button's command is due (at once after a press).
    next_repeat: Option<Instant>,
    /// Whether the command connection is open.
    connected: bool,
    /// The e-stop latch.
    estop: Estop,
    /// Whether zero velocity must go out, or waits for its answer.
    zero_velocity: ZeroVelocity,
    /// A 1004 to send, with the press that asked for it.
    cancel: Option<Instant>,
    /// One-shot commands with their presses, oldest first.
    one_shots: Deque<(OneShot, Instant), ONE_SHOT_QUEUE>,
    /// The navigation task.
    task: Task,
    /// The last task order's ID.
    task_ids: u32,
    /// Index of the light preset last sent (the first preset, "off", at start).
    light: usize,
    /// The robot's light as `robot-light` drives it.
    robot_light: RobotLight,
    /// When the last command went out.
    last_sent: Option<Instant>,
    /// Whether the last command failed or a press was dropped.
    last_failed: bool,
}

impl Control {
    /// Takes the speeds, light presets, dock point and repeat period of `config`; a held
    /// button repeats at the new speed from its next repeat.
    pub fn reconfigure(&mut self, config: &Config) {
        self.speeds = config.speeds;
        self.lights = config.lights.clone();
        self.dock = config.dock;
        // A save is refused while a task runs, so no patrol walks the old route.
        self.route = config.route.clone();
        self.repeat = config.motion_repeat;
        // A save tries a light the robot refused again.
        self.robot_light.on = config.robot_light;
        self.robot_light.given_up = false;
    }

    /// A control state machine with the configured speeds, light presets, dock point and
    /// repeat period; disconnected, nothing held.
    pub fn new(config: &Config) -> Self {
        Self {
            speeds: config.speeds,
            lights: config.lights.clone(),
            dock: config.dock,
            route: config.route.clone(),
            patrol: None,
            repeat: config.motion_repeat,
            held: Vec::new(),
            next_repeat: None,
            connected: false,
            estop: Estop {
                held: false,
                latched: false,
                confirmed: false,
                left: false,
                due: Instant::MIN,
            },
            zero_velocity: ZeroVelocity::No,
            cancel: None,
            one_shots: Deque::new(),
            task: Task::Idle,
            task_ids: 0,
            light: 0,
            robot_light: RobotLight {
                on: config.robot_light,
                estop_shown: false,
                unanswered: false,
                given_up: false,
            },
            last_sent: None,
            last_failed: false,
        }
    }

    /// A debounced press or release. `robot_gait` is the robot's gait from a fresh status
    /// that reports one: `gait` steps on from it, and is refused without it.
    pub fn button(&mut self, event: ButtonEvent, robot_gait: Option<GaitState>) {
        let ButtonEvent {
            button,
            pressed,
            at,
        } = event;
        if button == Button::Estop {
            if pressed {
                self.press_estop(at);
            } else {
                self.estop.held = false;
                self.check_unlock();
            }
            return;
        }
        if !pressed {
            if button.is_motion() {
                self.release(button, at);
            }
            return;
        }
        match button {
            Button::Stop => {
                self.end_motion();
                self.zero_velocity = ZeroVelocity::Asked;
                self.end_task(at);
            }
            Button::Cancel => {
                // A task not yet sent needs no 1004, but one may run that this panel does not
                // know of, and cancelling when none runs is harmless (the robot answers success).
                self.task = Task::Idle;
                self.patrol = None;
                self.cancel = Some(at);
            }
            Button::StopStepping => {
                self.push(OneShot::Command(MotionCommand::StopStepping), at);
            }
            Button::LieDown => {
                self.push(OneShot::Command(MotionCommand::LieDown), at);
            }
            Button::Gait => match robot_gait {
                Some(state) => {
                    // A gait with no Command 20 value (accumulated frame) steps back to walk.
                    let next = state
                        .motion_gait()
                        .map_or(MotionGait::Walk, MotionGait::next);
                    self.push(OneShot::Command(MotionCommand::SwitchGait(next)), at);
                }
                None => self.refuse(button, "the robot's gait is not known"),
            },
            Button::Light => self.next_light(at),
            Button::Dock | Button::Patrol => self.press_navigation(button, at),
            Button::Forward
            | Button::Backward
            | Button::TurnLeft
            | Button::TurnRight
            | Button::StrafeLeft
            | Button::StrafeRight => self.press_motion(button, at),
            // Handled above.
            Button::Estop => {}
        }
    }

    /// The command connection is in `state` (open unless connecting).
    pub fn connection(&mut self, state: ConnectionState) {
        let open = state != ConnectionState::Connecting;
        if open == self.connected {
            return;
        }
        info!("control: robot {}", if open { "connected" } else { "lost" });
        self.connected = open;
        if open {
            // A latched e-stop goes before anything else on the new connection.
            self.estop.due = Instant::MIN;
        } else {
            if self.robot_light.unanswered {
                // The robot may have hung up on the light (a Type it does not serve):
                // another would cost the command connection again.
                warn!("robot light: connection lost before its answer; no more sent");
                self.robot_light.unanswered = false;
                self.robot_light.given_up = true;
            }
            // The release that should stop the robot may be lost with the connection: never
            // written while motion was commanded, or written to a robot that stopped reading
            // (unanswered). Zero velocity after the outage is no replayed press: stopping is
            // always safe. It goes once: a robot that never answers is not sent one on every
            // connection.
            let unanswered = matches!(self.zero_velocity, ZeroVelocity::Unanswered { .. });
            if self.next_repeat.is_some() || unanswered {
                self.zero_velocity = ZeroVelocity::Again;
                self.end_motion();
            }
        }
    }

    /// The robot's motion state from a readable status (not an all-zero one).
    pub fn robot_motion_state(&mut self, state: MotionState) {
        if !self.estop.latched {
            return;
        }
        if state == MotionState::SoftEmergencyStop {
            if !self.estop.confirmed {
                info!("estop confirmed by the robot");
            }
            self.estop.confirmed = true;
        } else if self.estop.confirmed {
            self.estop.left = true;
        }
        self.check_unlock();
    }

    /// The next request for the command connection at `now`, if any; see the module docs
    /// for the order. Motion is written only while the robot is [`Health::Answering`]:
    /// motion due while its answers are overdue is skipped, not sent late.
    pub fn next_command(&mut self, now: Instant, health: Health) -> Option<Request> {
        let motion_allowed = health == Health::Answering;
        if !self.connected {
            return None;
        }
        let request = self.next_stop(now).or_else(|| {
            self.next_motion(now, motion_allowed)
                .or_else(|| self.next_one_shot(now))
                .or_else(|| self.next_robot_light())
        })?;
        self.last_sent = Some(now);
        Some(request)
    }

    /// A due stop: e-stop, zero velocity, or a fresh cancel.
    fn next_stop(&mut self, now: Instant) -> Option<Request> {
        if self.estop.unconfirmed() && self.estop.due <= now {
            self.estop.due = now.saturating_add(ESTOP_REPEAT);
            return Some(Request::Motion(MotionCommand::SoftEmergencyStop));
        }
        if self.zero_velocity.due() {
            // Only the one asked for waits for its answer, not one sent again.
            self.zero_velocity = if self.zero_velocity == ZeroVelocity::Asked {
                ZeroVelocity::Unanswered { at: now }
            } else {
                ZeroVelocity::No
            };
            return Some(Request::Motion(MotionCommand::ZeroVelocity));
        }
        let pressed = self.cancel.take()?;
        if self.fresh(pressed, now, "cancel") {
            Some(Request::CancelNav)
        } else {
            None
        }
    }

    /// The held motion button's command, if due and allowed.
    fn next_motion(&mut self, now: Instant, motion_allowed: bool) -> Option<Request> {
        let due = self.next_repeat.filter(|&due| due <= now)?;
        self.next_repeat = Some(next_after(due, self.repeat, now));
        if !motion_allowed || self.motion_locked() {
            debug!("motion held back: the robot's answers are overdue");
            return None;
        }
        let command = self.held.last().and_then(|b| b.motion(&self.speeds))?;
        Some(Request::Motion(command))
    }

    /// The oldest fresh one-shot command; stale ones are dropped on the way.
    fn next_one_shot(&mut self, now: Instant) -> Option<Request> {
        while let Some((command, pressed)) = self.one_shots.pop_front() {
            if self.fresh(pressed, now, "a press") {
                return Some(match command {
                    OneShot::Command(command) => Request::Motion(command),
                    OneShot::Light(light) => Request::Light(light),
                });
            }
        }
        None
    }

    /// The light `robot-light` wants written, if it differs from what the robot was last
    /// sent: [`ESTOP_LIGHT`] or the `light` button's preset. Only with nothing else due and
    /// no motion held, one at a time, and never again once given up.
    fn robot_light_due(&self) -> Option<Light> {
        let light = self.robot_light;
        let estop = light.on && self.estop.latched && self.estop.confirmed;
        let idle = !self.stop_pending() && self.next_repeat.is_none() && self.one_shots.is_empty();
        if light.given_up || estop == light.estop_shown || light.unanswered || !idle {
            return None;
        }
        if estop {
            Some(ESTOP_LIGHT)
        } else {
            self.lights.get(self.light).copied()
        }
    }

    /// The light due for `robot-light` ([`Control::robot_light_due`]).
    fn next_robot_light(&mut self) -> Option<Request> {
        let light = self.robot_light_due()?;
        self.robot_light.estop_shown = light == ESTOP_LIGHT;
        self.robot_light.unanswered = true;
        Some(Request::Light(light))
    }

    /// The answer to a light (1101), or none: one written for `robot-light` that failed
    /// ends them.
    pub fn light_answered(&mut self, outcome: Outcome) {
        if !self.robot_light.unanswered {
            return;
        }
        self.robot_light.unanswered = false;
        if outcome == Outcome::Failed {
            warn!("robot light: refused by the robot; no more sent");
            self.robot_light.given_up = true;
        }
    }

    /// Whether a press at `pressed` may still go out at `now`; if not, it is dropped and
    /// shown as failed.
    fn fresh(&mut self, pressed: Instant, now: Instant, what: &str) -> bool {
        let fresh = now.saturating_duration_since(pressed) <= STALE_PRESS;
        if !fresh {
            warn!(
                "{} dropped: not sent within {} ms",
                what,
                STALE_PRESS.as_millis()
            );
            self.last_failed = true;
        }
        fresh
    }

    /// When [`Control::next_command`] next has something: a time at or before `now` while
    /// something waits, else the next repeat or e-stop; `None` when idle or disconnected.
    pub fn next_deadline(&self) -> Option<Instant> {
        if !self.connected {
            return None;
        }
        if self.zero_velocity.due()
            || self.cancel.is_some()
            || !self.one_shots.is_empty()
            || self.robot_light_due().is_some()
        {
            return Some(Instant::MIN);
        }
        let estop = self.estop.unconfirmed().then_some(self.estop.due);
        [estop, self.next_repeat].into_iter().flatten().min()
    }

    /// A command's answer came, or never did.
    pub fn command_answered(&mut self, outcome: Outcome) {
        self.last_failed = outcome == Outcome::Failed;
    }

    /// The robot answered a zero velocity written at `written` (whether it succeeded or
    /// not, it read it): if that is the one waiting for its answer, or one written after
    /// it, a lost connection need not send it again. The answer to one written before it
    /// says nothing of whether the robot read the latest.
    pub fn zero_velocity_answered(&mut self, written: Instant) {
        if let ZeroVelocity::Unanswered { at } = self.zero_velocity
            && written >= at
        {
            self.zero_velocity = ZeroVelocity::No;
        }
    }

    /// A navigation task started: it drives the robot now, and a zero velocity would take
    /// the robot out of it. One waiting for its answer need no longer go again after an
    /// outage, nor one due again after an outage that is not yet written (the command
    /// connection came back after the navigation connection wrote the task).
    fn settle_zero_velocity(&mut self) {
        if matches!(
            self.zero_velocity,
            ZeroVelocity::Unanswered { .. } | ZeroVelocity::Again
        ) {
            self.zero_velocity = ZeroVelocity::No;
        }
    }

    /// The ordered navigation task, for the navigation connection to send; `None` without
    /// one, or when its press went stale (then dropped and shown as failed).
    pub fn take_task(&mut self, now: Instant) -> Option<TaskOrder> {
        let Task::Ordered { id, .. } = self.task else {
            return None;
        };
        if !self.task_wanted(id, now) {
            return None;
        }
        let point = match self.patrol {
            Some(index) => self.route.get(index)?.nav_point(),
            None => self.dock?,
        };
        Some(TaskOrder {
            id,
            task: NavTask::to_point(point),
        })
    }

    /// Whether order `id` may still go out at `now`: not cancelled, overridden or stale.
    /// Ask just before writing its 1003.
    pub fn task_wanted(&mut self, id: u32, now: Instant) -> bool {
        match self.task {
            Task::Ordered { id: ordered, at } if ordered == id => {
                let what = if self.patrol.is_some() {
                    "patrol"
                } else {
                    "dock"
                };
                // A patrol's next point follows the robot's answer, not a press: it is never
                // stale (the press that started the patrol was checked).
                let continuing = self.patrol.is_some_and(|index| index > 0);
                if continuing || self.fresh(at, now, what) {
                    true
                } else {
                    self.task = Task::Idle;
                    self.patrol = None;
                    false
                }
            }
            _ => false,
        }
    }

    /// Order `id`'s 1003 went out at `now`: the task runs until its answer. If a press
    /// withdrew the order while the 1003 was being written, the task is cancelled at once.
    pub fn task_started(&mut self, id: u32, now: Instant) {
        if self.ordered(id) {
            self.task = Task::Running { id };
            self.settle_zero_velocity();
        } else {
            warn!("navigation task withdrawn while its 1003 went out: cancelling it");
            self.cancel = Some(now);
        }
    }

    /// Order `id` ended at `now`, as `end` says. A patrol goes on to its next point only
    /// when the robot reached this one; anything else ends it.
    pub fn task_ended(&mut self, id: u32, end: TaskEnd, now: Instant) {
        let ours = matches!(self.task, Task::Running { id: running } | Task::Ordered { id: running, .. } if running == id);
        if ours {
            self.task = Task::Idle;
        }
        // A cancelled task is not a failure: someone meant it.
        self.last_failed = end == TaskEnd::Failed;
        if !ours {
            // A task a press already ended: the press ended its patrol too, and a patrol
            // now is a newer order's, which this answer says nothing of.
            return;
        }
        let Some(index) = self.patrol.take() else {
            return;
        };
        let next = index + 1;
        if end != TaskEnd::Reached {
            info!("patrol ended at point {} of {}", next, self.route.len());
            return;
        }
        if next < self.route.len() {
            info!("patrol: point {} of {} reached", next, self.route.len());
            self.patrol = Some(next);
            self.order_task(now);
        } else {
            info!("patrol: the route is done");
        }
    }

    /// When the last command went out.
    pub fn last_sent(&self) -> Option<Instant> {
        self.last_sent
    }

    /// Whether the last command failed or a press was dropped.
    pub fn last_failed(&self) -> bool {
        self.last_failed
    }

    /// Whether a patrol runs.
    pub fn patrolling(&self) -> bool {
        self.patrol.is_some()
    }

    /// Whether a navigation task runs or is about to start, as far as the panel knows.
    pub fn navigating(&self) -> bool {
        self.task != Task::Idle
    }

    /// Whether order `id`'s task runs (its 1003 went out, and the panel still wants it).
    pub fn task_running(&self, id: u32) -> bool {
        self.task == Task::Running { id }
    }

    /// Whether motion is locked out by the e-stop.
    pub fn motion_locked(&self) -> bool {
        self.estop.held || self.estop.latched
    }

    /// Whether a stop waits to go out: an unconfirmed e-stop, zero velocity or a cancel.
    pub fn stop_pending(&self) -> bool {
        self.estop.unconfirmed() || self.zero_velocity.due() || self.cancel.is_some()
    }

    /// Whether an e-stop is latched and not yet confirmed by the robot.
    pub fn estop_unconfirmed(&self) -> bool {
        self.estop.unconfirmed()
    }

    /// The motion button that drives the robot now, if any.
    pub fn active_motion(&self) -> Option<Button> {
        self.held.last().copied()
    }

    /// Whether the command connection is open, as last reported.
    pub fn connected(&self) -> bool {
        self.connected
    }

    /// Whether order `id` waits to go out.
    fn ordered(&self, id: u32) -> bool {
        matches!(self.task, Task::Ordered { id: ordered, .. } if ordered == id)
    }

    /// E-stop pressed: latch, and drop everything that would move the robot.
    fn press_estop(&mut self, at: Instant) {
        info!("estop: latched until the robot confirms");
        self.estop = Estop {
            held: true,
            latched: true,
            confirmed: false,
            left: false,
            due: Instant::MIN,
        };
        self.end_motion();
        self.one_shots.clear();
        // The robot fails a running task in soft e-stop (ErrorStatus 41766); one that kept
        // it would drive on once the e-stop is released. So the task is ended as `stop` ends
        // it: cancelled after the e-stop, and its connection closed if it runs on. While the
        // command connection is down the 1004 would only go stale (and blink the fault LED
        // for a cancel nobody pressed): closing the task's connection stops the task then.
        if self.withdraw_task() && self.connected {
            self.cancel = Some(at);
        }
    }

    /// Releases the e-stop lock-out once the button is up and the robot confirmed the stop
    /// and then left it.
    fn check_unlock(&mut self) {
        let e = &self.estop;
        if e.latched && !e.held && e.confirmed && e.left {
            info!("estop released: motion allowed");
            self.estop.latched = false;
        }
    }

    /// A press that does nothing, shown on the fault LED.
    fn refuse(&mut self, button: Button, reason: &str) {
        warn!("{} refused: {}", button.name(), reason);
        self.last_failed = true;
    }

    /// Ends the panel's navigation task at a press: an order not sent is withdrawn, a running
    /// task is cancelled with a 1004.
    fn end_task(&mut self, at: Instant) {
        if self.withdraw_task() {
            self.cancel = Some(at);
        }
    }

    /// Ends the panel's navigation task and patrol: an order not sent is withdrawn. Returns
    /// whether a task was running, which the robot is then to be told of (a 1004).
    fn withdraw_task(&mut self) -> bool {
        self.patrol = None;
        match self.task {
            Task::Idle => false,
            Task::Ordered { .. } => {
                self.task = Task::Idle;
                false
            }
            Task::Running { .. } => {
                info!("cancelling the navigation task");
                self.task = Task::Idle;
                true
            }
        }
    }

    /// A motion button pressed: it drives from now on, after ending any navigation task.
    fn press_motion(&mut self, button: Button, at: Instant) {
        if !self.connected {
            debug!("{} dropped: robot not connected", button.name());
            return;
        }
        if self.motion_locked() {
            debug!("{} dropped: motion locked out by estop", button.name());
            return;
        }
        self.end_task(at);
        self.held.retain(|b| *b != button);
        // At most six motion buttons, and this one was just removed: there is room.
        let _ = self.held.push(button);
        self.next_repeat = Some(at);
    }

    /// A motion button released: fall back to the latest other held one, or stop.
    fn release(&mut self, button: Button, at: Instant) {
        let was_driving = self.held.last() == Some(&button);
        self.held.retain(|b| *b != button);
        if !was_driving {
            // Not held since an accepted press, or another button drives: nothing changes.
            return;
        }
        if self.held.is_empty() {
            self.next_repeat = None;
            self.zero_velocity = ZeroVelocity::Asked;
        } else {
            self.next_repeat = Some(at);
        }
    }

    /// Forgets the held motion buttons: they need a new press to drive again.
    fn end_motion(&mut self) {
        self.held.clear();
        self.next_repeat = None;
    }

    /// `dock` or `patrol` pressed: order the task to the charging point, or the route's
    /// first point, unless there is none, motion is locked out or a task already runs.
    fn press_navigation(&mut self, button: Button, at: Instant) {
        let patrol = button == Button::Patrol;
        if patrol && self.route.is_empty() {
            return self.refuse(button, "no route saved");
        }
        if !patrol && self.dock.is_none() {
            return self.refuse(button, "no charging point configured (the dock setting)");
        }
        if self.motion_locked() {
            return self.refuse(button, "motion locked out by estop");
        }
        if self.navigating() {
            debug!("{} dropped: a navigation task already runs", button.name());
            return;
        }
        // The task drives the robot now; repeats would only be refused.
        self.end_motion();
        self.patrol = patrol.then_some(0);
        self.order_task(at);
    }

    /// Orders the next navigation task, as of `at`.
    fn order_task(&mut self, at: Instant) {
        self.task_ids = self.task_ids.wrapping_add(1);
        self.task = Task::Ordered {
            id: self.task_ids,
            at,
        };
    }

    /// `light` pressed: the next preset, wrapping round; the preset counts as sent only
    /// once it is queued.
    fn next_light(&mut self, at: Instant) {
        // `checked_rem` is `None` without presets, which configuration never allows.
        let Some(index) = (self.light + 1).checked_rem(self.lights.len()) else {
            return;
        };
        if self.robot_light.estop_shown {
            // The robot shows the e-stop: the preset is shown when the latch is released.
            self.light = index;
            return;
        }
        if let Some(&light) = self.lights.get(index)
            && self.push(OneShot::Light(light), at)
        {
            self.light = index;
        }
    }

    /// Queues a one-shot command; drops it (shown as failed) when the queue is full.
    /// Whether it was queued.
    fn push(&mut self, command: OneShot, at: Instant) -> bool {
        let queued = self.one_shots.push_back((command, at)).is_ok();
        if !queued {
            warn!(
                "press dropped: {} one-shot commands wait already",
                ONE_SHOT_QUEUE
            );
            self.last_failed = true;
        }
        queued
    }
}
