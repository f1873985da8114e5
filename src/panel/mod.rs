//! The panel's logic, board-agnostic: plain state machines fed with events and time.
//!
//! From the buttons upward:
//!
//! - [`buttons`]: the fifteen [`Button`]s and a [`Debouncer`] that turns raw pin levels into
//!   one press and one release per push.
//! - [`control`]: [`Control`] turns presses and releases into commands and navigation
//!   tasks, with stops first, the e-stop latch, motion repeats and nothing sent late.
//! - [`monitor`]: [`Monitor`] schedules the polls of the robot's state, and [`RobotView`]
//!   keeps the latest answers with their age.
//! - [`indicators`]: the three [`Led`]s, as pure functions of the above.
//! - [`virtual_panel`]: the QEMU board's buttons, as text lines (`+forward`, `-forward`).
//!
//! [`Panel`] puts them together for the application. Nothing here does I/O, reads a clock or
//! allocates: every input carries its time (`now`), and every output is pulled, so host tests
//! drive the whole panel with simulated time and no network.

pub mod buttons;
pub mod control;
pub mod indicators;
pub mod monitor;
pub mod virtual_panel;

pub use buttons::{Button, ButtonDebouncers, ButtonEvent, Debouncer};
pub use control::{Control, Outcome, STALE_PRESS, TaskEnd, TaskOrder, succeeded};
pub use indicators::{Fault, Indicators, Led, LinkState, Navigation};
pub use monitor::{Monitor, RobotView, Stamped};

use embassy_time::{Duration, Instant};

use crate::client::{ANSWER_OVERDUE, ClientError, Health};
use crate::config::Config;
use crate::proto::codes::{MessageType, MotionCommandCode};
use crate::proto::message::{NavResult, Request, Response};

/// The next deadline of a periodic job that ran at `now` for the deadline `due`: one period
/// after `due`, so late wake-ups do not slow the rate down, but never at or before `now`, so
/// a loop that stalled does not send a burst to catch up.
pub(crate) fn next_after(due: Instant, period: Duration, now: Instant) -> Instant {
    let next = due.saturating_add(period);
    if next > now {
        next
    } else {
        now.saturating_add(period)
    }
}

/// Whether the board has a network: a link and an address.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NetworkState {
    /// No link, or no address yet.
    Down,
    /// A link and an address.
    Up,
}

/// The panel's connections to the robot, each with one job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConnectionRole {
    /// Commands, written without waiting for earlier answers.
    Commands,
    /// Polls of the robot's state, one at a time.
    Polls,
    /// The navigation task's 1003, held open until its answer.
    Navigation,
}

/// How one connection to the robot is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConnectionState {
    /// Not open: connecting, or waiting to try again.
    Connecting,
    /// Open, and the robot answers.
    Open,
    /// Open, but the robot's answers are overdue.
    NotAnswering,
}

/// The whole panel: control, monitor, robot view and indicators, kept in step.
///
/// The application feeds it button events, connection changes and answers as they come;
/// writes what [`Panel::next_command`] returns on the command connection and what
/// [`Panel::next_poll`] returns on the poll connection; runs the tasks of
/// [`Panel::take_task`]; and sets the LEDs from [`Panel::indicators`].
#[derive(Debug, Clone)]
pub struct Panel {
    /// Commands from buttons.
    control: Control,
    /// Poll schedule.
    monitor: Monitor,
    /// The robot's latest answers.
    view: RobotView,
    /// Whether the board has a network.
    network: NetworkState,
    /// The command connection.
    commands: ConnectionState,
    /// The poll connection.
    polls: ConnectionState,
    /// Since when the command connection has waited for an answer, if it does.
    commands_waiting_since: Option<Instant>,
    /// Whether the saved settings could not be read, so the defaults are in use.
    settings_lost: bool,
}

/// Why the panel is not quiet enough to save settings: a flash erase stalls the board, and
/// nothing a person is doing may wait for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Busy {
    /// An e-stop, zero velocity or cancel waits to go out, or an e-stop is not confirmed.
    StopPending,
    /// A motion button is held.
    MotionHeld,
    /// A navigation task runs.
    TaskRunning,
}

impl Busy {
    /// What the panel is doing, in words.
    pub const fn description(self) -> &'static str {
        match self {
            Self::StopPending => "a stop is going out or an e-stop is not yet confirmed",
            Self::MotionHeld => "a motion button is held",
            Self::TaskRunning => "a navigation task runs",
        }
    }
}

impl Panel {
    /// A panel with `config`, without a network yet.
    pub fn new(config: &Config) -> Self {
        Self {
            control: Control::new(config),
            monitor: Monitor::new(config),
            view: RobotView::new(config),
            network: NetworkState::Down,
            commands: ConnectionState::Connecting,
            polls: ConnectionState::Connecting,
            commands_waiting_since: None,
            settings_lost: false,
        }
    }

    /// Takes new settings in, keeping every state: what is held stays held, a latched
    /// e-stop stays latched, a running task runs on.
    pub fn reconfigure(&mut self, config: &Config) {
        self.control.reconfigure(config);
        self.monitor.reconfigure(config);
        self.view.reconfigure(config);
    }

    /// Whether the saved settings could not be read (the fault LED blinks while so).
    pub fn settings_lost(&mut self, lost: bool) {
        self.settings_lost = lost;
    }

    /// Why settings must not be saved now, if they must not.
    pub fn busy(&self) -> Option<Busy> {
        let control = &self.control;
        if control.stop_pending() || control.estop_unconfirmed() {
            Some(Busy::StopPending)
        } else if control.active_motion().is_some() {
            Some(Busy::MotionHeld)
        } else if control.navigating() {
            Some(Busy::TaskRunning)
        } else {
            None
        }
    }

    /// A debounced press or release.
    pub fn button(&mut self, event: ButtonEvent) {
        let gait = self.view.status(event.at).and_then(|s| s.gait_state);
        self.control.button(event, gait);
        self.follow_navigation(event.at);
    }

    /// The board's network came up or went down.
    pub fn network(&mut self, state: NetworkState) {
        self.network = state;
    }

    /// A poll's connection was lost before its answer (see [`Monitor::poll_lost`]).
    pub fn poll_lost(&mut self, poll: MessageType, now: Instant) {
        self.monitor.poll_lost(poll, now);
    }

    /// The poll of Type `poll` failed, its connection still open (see [`Monitor::poll_failed`]).
    pub fn poll_failed(&mut self, poll: MessageType, now: Instant) {
        self.monitor.poll_failed(poll, now);
    }

    /// The robot's address changed (see [`Monitor::robot_moved`]).
    pub fn robot_moved(&mut self) {
        self.monitor.robot_moved();
    }

    /// A connection to the robot is in `state`; whether that is a change.
    pub fn connection(
        &mut self,
        connection: ConnectionRole,
        state: ConnectionState,
        now: Instant,
    ) -> bool {
        let was = match connection {
            ConnectionRole::Commands => {
                self.control.connection(state);
                core::mem::replace(&mut self.commands, state)
            }
            ConnectionRole::Polls => {
                self.monitor.connection(state, now);
                core::mem::replace(&mut self.polls, state)
            }
            // Its loss ends the task, which the application reports with `task_ended`.
            ConnectionRole::Navigation => state,
        };
        was != state
    }

    /// Since when the command connection has waited for an answer (`None`: it does not),
    /// counting connections closed before their answers came.
    pub fn commands_waiting(&mut self, since: Option<Instant>) {
        self.commands_waiting_since = since;
    }

    /// Whether the command connection is open.
    pub fn commands_connected(&self) -> bool {
        self.commands != ConnectionState::Connecting
    }

    /// Whether a stop still waits on the command connection.
    pub fn stop_unanswered(&self) -> bool {
        self.stop_waiting_since().is_some()
    }

    /// Whether the robot served a poll written at `sent` ahead of a stop that has waited
    /// on the command connection since [`ANSWER_OVERDUE`] before it: a robot that serves
    /// one connection at a time (or fewer than the panel opens), serving the polls'. The
    /// poll connection then gives way. A robot merely slow answers in the order it was
    /// asked, the stop first.
    pub fn stop_passed_over_by(&self, sent: Instant) -> bool {
        self.stop_waiting_since()
            .is_some_and(|since| since.saturating_add(ANSWER_OVERDUE) <= sent)
    }

    /// Since when a stop has waited on the command connection, if one does.
    fn stop_waiting_since(&self) -> Option<Instant> {
        self.commands_waiting_since
            .filter(|_| self.control.stop_pending())
    }

    /// The next request for the command connection (see [`Control::next_command`]).
    pub fn next_command(&mut self, now: Instant, health: Health) -> Option<Request> {
        let request = self.control.next_command(now, health);
        // A stop or motion press may have ended the navigation task.
        self.follow_navigation(now);
        request
    }

    /// The answer to a command of Type `request` written at `written` (`None`: the write
    /// failed), or why there is none (timeout, connection lost, Type 0).
    pub fn command_answered(
        &mut self,
        request: MessageType,
        written: Option<Instant>,
        answer: Result<&Response, &ClientError>,
    ) {
        let outcome = Outcome::of(answer);
        match answer {
            Err(e) => warn!("command failed: {:?}", e),
            Ok(_) if outcome == Outcome::Failed => warn!("command refused by the robot"),
            Ok(_) => {}
        }
        self.control.command_answered(outcome);
        if request == MessageType::Light {
            self.control.light_answered(outcome);
        }
        if let (Ok(Response::Motion(MotionCommandCode::ZeroVelocity, _)), Some(written)) =
            (answer, written)
        {
            self.control.zero_velocity_answered(written);
        }
    }

    /// The next poll due at `now` on the poll connection.
    pub fn next_poll(&mut self, now: Instant) -> Option<Request> {
        self.monitor.next_poll(now)
    }

    /// A poll's answer arrived at `now`.
    pub fn poll_answered(&mut self, response: &Response, now: Instant) {
        self.monitor.poll_answered(response, now);
        self.view.update(response, now);
        // An all-zero status says nothing about the motion state.
        if let Response::Status(status) = response
            && !status.is_unavailable()
        {
            self.control.robot_motion_state(status.motion_state);
        }
    }

    /// The navigation task to start, if a fresh press ordered one (see [`Control::take_task`]).
    pub fn take_task(&mut self, now: Instant) -> Option<TaskOrder> {
        let order = self.control.take_task(now);
        // A stale order was dropped: its 1007 polls end with it.
        self.follow_navigation(now);
        order
    }

    /// Whether order `id` may still go out (see [`Control::task_wanted`]).
    pub fn task_wanted(&mut self, id: u32, now: Instant) -> bool {
        let wanted = self.control.task_wanted(id, now);
        self.follow_navigation(now);
        wanted
    }

    /// Order `id`'s 1003 went out at `now`.
    pub fn task_started(&mut self, id: u32, now: Instant) {
        self.control.task_started(id, now);
        self.follow_navigation(now);
    }

    /// Order `id` ended: its answer, or why there is none.
    pub fn task_ended(&mut self, id: u32, end: Result<&NavResult, &ClientError>, now: Instant) {
        match end {
            Ok(result) => {
                info!(
                    "navigation task ended: {} ({})",
                    result.outcome.description(),
                    result.status.description()
                );
                self.view.update(&Response::NavResult(*result), now);
            }
            Err(e) => warn!("navigation task lost: {:?}", e),
        }
        self.control.task_ended(id, TaskEnd::of(end), now);
        self.follow_navigation(now);
    }

    /// The LEDs at `now`.
    pub fn indicators(&self, now: Instant) -> Indicators {
        Indicators::derive(&self.indicator_inputs(), now)
    }

    /// When the LEDs may next change without a new event.
    pub fn indicators_deadline(&self, now: Instant) -> Option<Instant> {
        Indicators::next_change(&self.indicator_inputs(), now)
    }

    /// When the command connection next has something to send without a new event.
    pub fn command_deadline(&self) -> Option<Instant> {
        self.control.next_deadline()
    }

    /// When the next poll is due.
    pub fn poll_deadline(&self) -> Option<Instant> {
        self.monitor.next_deadline()
    }

    /// The control state machine.
    pub fn control(&self) -> &Control {
        &self.control
    }

    /// The poll schedule.
    pub fn monitor(&self) -> &Monitor {
        &self.monitor
    }

    /// The robot's latest answers.
    pub fn view(&self) -> &RobotView {
        &self.view
    }

    /// What the link LED shows, from the network and the command and poll connections.
    pub fn link_state(&self) -> LinkState {
        use ConnectionState::{Connecting, NotAnswering};
        if self.network == NetworkState::Down {
            LinkState::NoNetwork
        } else if self.commands == Connecting || self.polls == Connecting {
            LinkState::Connecting
        } else if self.commands == NotAnswering || self.polls == NotAnswering {
            LinkState::NotAnswering
        } else {
            LinkState::Connected
        }
    }

    /// Keeps the 1007 polls in step with the navigation task, which presses and answers
    /// start and end.
    fn follow_navigation(&mut self, now: Instant) {
        self.monitor.navigation(self.control.navigating(), now);
    }

    /// What the LEDs depend on.
    fn indicator_inputs(&self) -> indicators::Inputs<'_> {
        indicators::Inputs {
            link: self.link_state(),
            view: &self.view,
            navigation: if self.control.patrolling() {
                Navigation::Patrol
            } else if self.control.navigating() {
                Navigation::Task
            } else {
                Navigation::Idle
            },
            last_sent: self.control.last_sent(),
            panel_failure: self.control.last_failed() || self.settings_lost,
        }
    }
}
