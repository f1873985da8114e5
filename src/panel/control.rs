//! The control state machine: debounced button events in, robot commands out.
//!
//! [`Control`] turns presses and releases into [`Action`]s, which the application pulls with
//! [`Control::next_action`] and sends. It never blocks and never sends anything itself, so it
//! holds only what is still to be sent: a short queue of commands from presses, and the held
//! motion button whose command repeats every 250 ms.
//!
//! The rules, from DESIGN.md "Panel behaviour":
//!
//! - A motion button sends its Type 2 command at once when pressed, then every repeat period
//!   while held (the robot needs 3–5 Hz), and Command 6 (zero velocity) when released. With
//!   several held, the latest press drives; releasing it falls back to the latest of the others.
//! - `stop` sends Command 6 and ends the held motion (a new press is needed), so that it also
//!   stops a robot whose motion button is stuck.
//! - `estop` sends Command 13 ahead of everything and drops everything still queued. Motion
//!   (the six motion buttons and `dock`) stays locked out until the button is released **and**
//!   the robot reports a motion state other than soft emergency stop (6), seen after the
//!   Command 13 went out.
//! - A motion press while a navigation task runs cancels the task (1004) first; a `dock` not
//!   yet sent is simply dropped instead.
//! - Nothing is queued while the robot is not connected: presses are dropped, never replayed,
//!   and a motion button held across an outage needs a new press.

use embassy_time::{Duration, Instant};
use heapless::{Deque, Vec};

use super::buttons::Button;
use super::next_after;
use crate::config::{Config, LightPresets, MotionSpeeds};
use crate::proto::codes::{LocalizationResult, MotionGait, MotionState, NavOutcome};
use crate::proto::message::{Light, MotionCommand, NavPoint, NavTask, Request, Response};

/// How many commands may wait to be sent; a press beyond this is dropped (and logged).
pub const QUEUE_CAPACITY: usize = 8;

/// Motion buttons that can be held at once.
const MOTION_BUTTONS: usize = 6;

/// Something the application should do for the panel, in the order received.
// The navigation task holds its points inline (no heap); an action exists only between
// `next_action` and the send, so the size is paid on the stack, briefly.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Action {
    /// Send this request on the control connection.
    Send(Request),
    /// Start this navigation task (1003) on the navigation connection, which must stay open
    /// until the task's answer (the robot stops a task whose client disconnects).
    Navigate(NavTask),
    /// Cancel the navigation task: send 1004 on the control connection. The robot answers the
    /// running task's 1003 first (ErrorCode 2, on the navigation connection), then the 1004.
    CancelNavigation,
}

impl Action {
    /// The request to send for this action.
    pub fn request(&self) -> Request {
        match self {
            Self::Send(request) => request.clone(),
            Self::Navigate(task) => Request::NavTask(task.clone()),
            Self::CancelNavigation => Request::CancelNav,
        }
    }

    /// Whether this is a command (it changes the robot or its light) rather than a poll of
    /// the robot's state; only commands flash the activity LED and count as failed.
    pub fn is_command(&self) -> bool {
        !matches!(
            self,
            Self::Send(
                Request::Status
                    | Request::NavStatus
                    | Request::MotorTemperatures
                    | Request::Battery
                    | Request::Perception
            )
        )
    }
}

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

/// A command waiting in the queue, small until it is turned into an [`Action`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Entry {
    /// What the held motion buttons ask for now (a motion command or zero velocity); a newer
    /// one replaces it, because only the latest motion matters.
    Motion(MotionCommand),
    /// A one-off Type 2 command: e-stop, stop stepping, lie down, gait.
    Command(MotionCommand),
    /// A light preset (1101).
    Light(Light),
    /// The navigation task to the dock (1003).
    Dock,
    /// Cancel the navigation task (1004).
    Cancel,
}

/// The control state machine; see the module docs for its rules.
#[derive(Debug, Clone)]
pub struct Control {
    /// Speed per motion button.
    speeds: MotionSpeeds,
    /// Presets of the `light` button.
    lights: LightPresets,
    /// The dock's charging point.
    dock: NavPoint,
    /// Repeat period of a held motion button.
    repeat: Duration,
    /// Commands from presses, oldest first.
    queue: Deque<Entry, QUEUE_CAPACITY>,
    /// Motion buttons held since a press that was accepted, oldest first; the last one drives.
    held: Vec<Button, MOTION_BUTTONS>,
    /// When the driving motion button's command is due again.
    next_repeat: Option<Instant>,
    /// Whether the control connection to the robot is up.
    connected: bool,
    /// Whether a navigation task runs (or is about to start).
    navigating: bool,
    /// Whether the e-stop button is down.
    estop_held: bool,
    /// Whether motion is locked out by an e-stop until the robot leaves soft emergency stop.
    estop_latched: bool,
    /// The robot's motion state last reported since the latest e-stop went out.
    robot_state: Option<MotionState>,
    /// The gait last sent (the robot starts in walk).
    gait: MotionGait,
    /// Index of the light preset last sent (the first preset, "off", at start).
    light: usize,
    /// When the last command was sent.
    last_sent: Option<Instant>,
    /// Whether the last command failed.
    last_failed: bool,
    /// Whether motion was being commanded when the link dropped, so that zero velocity goes
    /// out first when it is back.
    stop_on_reconnect: bool,
}

impl Control {
    /// A control state machine with the configured speeds, light presets, dock point and
    /// repeat period; disconnected, nothing held.
    pub fn new(config: &Config) -> Self {
        Self {
            speeds: config.speeds,
            lights: config.lights.clone(),
            dock: config.dock,
            repeat: config.motion_repeat,
            queue: Deque::new(),
            held: Vec::new(),
            next_repeat: None,
            connected: false,
            navigating: false,
            estop_held: false,
            estop_latched: false,
            robot_state: None,
            gait: MotionGait::Walk,
            light: 0,
            last_sent: None,
            last_failed: false,
            stop_on_reconnect: false,
        }
    }

    /// A debounced press (`pressed`) or release of `button` at `now`.
    pub fn button(&mut self, button: Button, pressed: bool, now: Instant) {
        if button == Button::Estop {
            // The lock-out follows the physical button even while disconnected.
            self.estop_held = pressed;
            if pressed {
                self.estop();
            } else {
                self.check_unlock();
            }
            return;
        }
        if !pressed {
            if button.is_motion() {
                self.release(button, now);
            }
            return;
        }
        if !self.connected {
            debug!("{} dropped: robot not connected", button.name());
            return;
        }
        match button {
            Button::Stop => {
                self.end_motion();
                self.push_motion(MotionCommand::ZeroVelocity);
            }
            Button::StopStepping => self.push(Entry::Command(MotionCommand::StopStepping)),
            Button::LieDown => self.push(Entry::Command(MotionCommand::LieDown)),
            Button::Gait => {
                self.gait = next_gait(self.gait);
                self.push(Entry::Command(MotionCommand::SwitchGait(self.gait)));
            }
            Button::Light => self.next_light(),
            Button::Dock => self.dock(),
            Button::Cancel => {
                // A task not yet sent needs no 1004, but one may run that this panel does not
                // know of, and cancelling when none runs is harmless (the robot answers success).
                self.queue.retain(|e| *e != Entry::Dock);
                self.navigating = false;
                self.push(Entry::Cancel);
            }
            Button::Forward
            | Button::Backward
            | Button::TurnLeft
            | Button::TurnRight
            | Button::StrafeLeft
            | Button::StrafeRight => self.press_motion(button, now),
            // Handled above, whether connected or not.
            Button::Estop => {}
        }
    }

    /// The control connection to the robot went up or down.
    pub fn link(&mut self, connected: bool) {
        if connected != self.connected {
            info!(
                "control: robot {}",
                if connected { "connected" } else { "lost" }
            );
        }
        let was_connected = self.connected;
        self.connected = connected;
        if was_connected && !connected {
            // The release that should stop the robot may be lost with the link. Zero
            // velocity after the outage is no replayed press: stopping is always safe.
            self.stop_on_reconnect |= self.next_repeat.is_some()
                || self.queue.iter().any(|e| matches!(e, Entry::Motion(_)));
            // Nothing is replayed after an outage, and held buttons need a new press.
            self.queue.clear();
            self.end_motion();
        }
        if connected && core::mem::take(&mut self.stop_on_reconnect) {
            self.push_motion(MotionCommand::ZeroVelocity);
        }
    }

    /// The robot's motion state, from a readable status (not from an all-zero one, whose
    /// "lying down" means nothing).
    pub fn robot_motion_state(&mut self, state: MotionState) {
        self.robot_state = Some(state);
        self.check_unlock();
    }

    /// Whether a navigation task runs: set when the application starts one, cleared when
    /// its answer arrives or its connection fails.
    pub fn navigation(&mut self, running: bool) {
        self.navigating = running;
    }

    /// The next action to carry out at `now`, if any: queued commands first (an e-stop is
    /// always at the front), then the held motion button's repeat once it is due.
    pub fn next_action(&mut self, now: Instant) -> Option<Action> {
        if let Some(entry) = self.queue.pop_front() {
            return Some(self.action(entry));
        }
        let due = self.next_repeat.filter(|&due| due <= now)?;
        let command = self.held.last().and_then(|b| b.motion(&self.speeds))?;
        self.next_repeat = Some(next_after(due, self.repeat, now));
        trace!("repeat {:?}", command);
        Some(Action::Send(Request::Motion(command)))
    }

    /// When [`Control::next_action`] next has something: a time in the past (at once) while
    /// commands are queued, else the next repeat; `None` when idle.
    pub fn next_deadline(&self) -> Option<Instant> {
        if self.queue.is_empty() {
            self.next_repeat
        } else {
            Some(Instant::MIN)
        }
    }

    /// Reports the outcome of an action: `ok` when the robot answered success (see
    /// [`succeeded`]), `false` on a failure answer, a timeout or a lost connection. Polls
    /// are ignored; for a navigation task report its start, and its end again if it failed.
    pub fn sent(&mut self, action: &Action, ok: bool, now: Instant) {
        if !action.is_command() {
            return;
        }
        if !ok {
            warn!("command failed: {:?}", action);
        }
        self.last_sent = Some(now);
        self.last_failed = !ok;
    }

    /// When the last command was sent.
    pub fn last_sent(&self) -> Option<Instant> {
        self.last_sent
    }

    /// Whether the last command failed.
    pub fn last_failed(&self) -> bool {
        self.last_failed
    }

    /// Whether a navigation task runs, as far as the panel knows.
    pub fn navigating(&self) -> bool {
        self.navigating
    }

    /// Whether motion is locked out by the e-stop.
    pub fn motion_locked(&self) -> bool {
        self.estop_held || self.estop_latched
    }

    /// The motion button that drives the robot now, if any.
    pub fn active_motion(&self) -> Option<Button> {
        self.held.last().copied()
    }

    /// Whether the robot is connected, as last reported.
    pub fn connected(&self) -> bool {
        self.connected
    }

    /// E-stop pressed: Command 13 before anything else, and nothing else that was waiting.
    fn estop(&mut self) {
        if !self.connected {
            warn!("estop dropped: robot not connected");
            return;
        }
        info!("estop: motion locked out");
        self.queue.clear();
        self.end_motion();
        self.estop_latched = true;
        self.robot_state = None;
        // The queue was just emptied, so this cannot fail.
        let _ = self
            .queue
            .push_front(Entry::Command(MotionCommand::SoftEmergencyStop));
    }

    /// Releases the e-stop lock-out once both conditions hold.
    fn check_unlock(&mut self) {
        let left_estop = self
            .robot_state
            .is_some_and(|s| s != MotionState::SoftEmergencyStop);
        if self.estop_latched && !self.estop_held && left_estop {
            info!("estop released: motion allowed");
            self.estop_latched = false;
        }
    }

    /// A motion button pressed: it drives from now on, after cancelling any navigation task.
    fn press_motion(&mut self, button: Button, now: Instant) {
        if self.motion_locked() {
            debug!("{} dropped: motion locked out by estop", button.name());
            return;
        }
        let Some(command) = button.motion(&self.speeds) else {
            return;
        };
        let dock_queued = self.queue.iter().any(|e| *e == Entry::Dock);
        if dock_queued {
            self.queue.retain(|e| *e != Entry::Dock);
        } else if self.navigating {
            info!("{} cancels the navigation task", button.name());
            self.push(Entry::Cancel);
        }
        self.navigating = false;
        self.held.retain(|b| *b != button);
        // At most six motion buttons, and this one was just removed: there is room.
        let _ = self.held.push(button);
        self.push_motion(command);
        self.next_repeat = Some(now.saturating_add(self.repeat));
    }

    /// A motion button released: fall back to the latest other held one, or stop.
    fn release(&mut self, button: Button, now: Instant) {
        let was_driving = self.held.last() == Some(&button);
        self.held.retain(|b| *b != button);
        if !was_driving {
            // Not held since an accepted press, or another button drives: nothing changes.
            return;
        }
        match self.held.last().and_then(|b| b.motion(&self.speeds)) {
            Some(command) => {
                self.push_motion(command);
                self.next_repeat = Some(now.saturating_add(self.repeat));
            }
            None => {
                self.next_repeat = None;
                self.push_motion(MotionCommand::ZeroVelocity);
            }
        }
    }

    /// Forgets the held motion buttons: they need a new press to drive again.
    fn end_motion(&mut self) {
        self.held.clear();
        self.next_repeat = None;
    }

    /// `dock` pressed: start the navigation task, unless locked out or one already runs.
    fn dock(&mut self) {
        let refused = if self.motion_locked() {
            Some("motion locked out by estop")
        } else if self.navigating || self.queue.iter().any(|e| *e == Entry::Dock) {
            Some("a navigation task already runs")
        } else {
            None
        };
        if let Some(reason) = refused {
            debug!("dock dropped: {}", reason);
            return;
        }
        // The task drives the robot now; repeats would only be refused.
        self.end_motion();
        self.queue.retain(|e| !matches!(e, Entry::Motion(_)));
        self.push(Entry::Dock);
    }

    /// `light` pressed: the next preset, wrapping round.
    fn next_light(&mut self) {
        // `checked_rem` is `None` without presets, which configuration never allows.
        let Some(index) = (self.light + 1).checked_rem(self.lights.len()) else {
            return;
        };
        if let Some(&light) = self.lights.get(index) {
            self.light = index;
            self.push(Entry::Light(light));
        }
    }

    /// Queues what the held motion buttons ask for, replacing an older motion not yet sent.
    fn push_motion(&mut self, command: MotionCommand) {
        self.queue.retain(|e| !matches!(e, Entry::Motion(_)));
        self.push(Entry::Motion(command));
    }

    /// Queues a command at the back; drops it when the queue is full.
    fn push(&mut self, entry: Entry) {
        if self.queue.push_back(entry).is_err() {
            warn!("command dropped: queue full ({:?})", entry);
        }
    }

    /// Turns a queued entry into the action to carry out, noting what sending it implies.
    fn action(&mut self, entry: Entry) -> Action {
        match entry {
            Entry::Motion(command) | Entry::Command(command) => {
                if command == MotionCommand::SoftEmergencyStop {
                    // Only states reported after Command 13 goes out can release the lock.
                    self.robot_state = None;
                }
                Action::Send(Request::Motion(command))
            }
            Entry::Light(light) => Action::Send(Request::Light(light)),
            Entry::Dock => {
                // From here the task runs, so a motion press cancels it with a 1004.
                self.navigating = true;
                Action::Navigate(NavTask::to_point(self.dock))
            }
            Entry::Cancel => Action::CancelNavigation,
        }
    }
}

/// The gait after `gait` in the cycle walk (0) → normal stairs (1) → slope (2) →
/// perception stairs (4) → walk.
fn next_gait(gait: MotionGait) -> MotionGait {
    match gait {
        MotionGait::Walk => MotionGait::NormalStairs,
        MotionGait::NormalStairs => MotionGait::Slope,
        MotionGait::Slope => MotionGait::PerceptionStairs,
        _ => MotionGait::Walk,
    }
}
