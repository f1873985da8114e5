//! The panel's logic, board-agnostic: plain state machines fed with events and time.
//!
//! From the buttons upward:
//!
//! - [`buttons`]: the fourteen [`Button`]s and a [`Debouncer`] that turns raw pin levels into
//!   one press and one release per push.
//! - [`control`]: [`Control`] turns presses and releases into [`Action`]s (commands to send),
//!   with motion repeats, e-stop priority and lock-out, and navigation cancelling.
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
pub use control::{Action, Control, succeeded};
pub use indicators::{Fault, Indicators, Led, LinkState};
pub use monitor::{Monitor, RobotView, Stamped};

use embassy_time::{Duration, Instant};

use crate::config::Config;
use crate::proto::message::Response;

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

/// The whole panel: control, monitor, robot view and indicators, kept in step.
///
/// The application's loop: feed it button events, link changes and answers as they come;
/// send what [`Panel::next_action`] returns until it returns `None` (commands come before
/// polls), reporting each outcome with [`Panel::sent`]; set the LEDs from
/// [`Panel::indicators`]; then wait for the next event or [`Panel::next_deadline`].
#[derive(Debug, Clone)]
pub struct Panel {
    /// Commands from buttons.
    control: Control,
    /// Poll schedule.
    monitor: Monitor,
    /// The robot's latest answers.
    view: RobotView,
    /// How far the connection to the robot is.
    link: LinkState,
}

impl Panel {
    /// A panel with `config`, not yet connected.
    pub fn new(config: &Config) -> Self {
        Self {
            control: Control::new(config),
            monitor: Monitor::new(config),
            view: RobotView::new(config),
            link: LinkState::NoNetwork,
        }
    }

    /// A debounced press or release.
    pub fn button(&mut self, button: Button, pressed: bool, now: Instant) {
        self.control.button(button, pressed, now);
    }

    /// The connection to the robot changed.
    pub fn link(&mut self, link: LinkState, now: Instant) {
        let connected = link == LinkState::Connected;
        self.link = link;
        self.control.link(connected);
        self.monitor.link(connected, now);
    }

    /// A navigation task started (its 1003 went out) or ended (its answer came, or its
    /// connection failed).
    pub fn navigation(&mut self, running: bool, now: Instant) {
        self.control.navigation(running);
        self.monitor.navigation(running, now);
    }

    /// The next thing to send at `now`: a command if one is waiting, else a due poll.
    pub fn next_action(&mut self, now: Instant) -> Option<Action> {
        if let Some(action) = self.control.next_action(now) {
            // A dock or cancel changes whether a task runs; the 1007 polls follow.
            self.monitor.navigation(self.control.navigating(), now);
            return Some(action);
        }
        self.monitor.next_poll(now).map(Action::Send)
    }

    /// Reports an action's outcome (see [`Control::sent`]).
    pub fn sent(&mut self, action: &Action, ok: bool, now: Instant) {
        self.control.sent(action, ok, now);
    }

    /// An answer from the robot arrived at `now`.
    pub fn response(&mut self, response: &Response, now: Instant) {
        self.view.update(response, now);
        match response {
            // An all-zero status says nothing about the motion state.
            Response::Status(status) if !status.is_unavailable() => {
                self.control.robot_motion_state(status.motion_state);
            }
            Response::NavResult(result) => {
                info!("navigation task ended: {}", result.outcome.description());
                self.navigation(false, now);
            }
            _ => {}
        }
    }

    /// The LEDs at `now`.
    pub fn indicators(&self, now: Instant) -> Indicators {
        Indicators::derive(&self.indicator_inputs(), now)
    }

    /// When the panel next has something to do without a new event: an action or poll due,
    /// or an LED about to change. A time at or before `now` means at once.
    pub fn next_deadline(&self, now: Instant) -> Option<Instant> {
        [
            self.control.next_deadline(),
            self.monitor.next_deadline(),
            Indicators::next_change(&self.indicator_inputs(), now),
        ]
        .into_iter()
        .flatten()
        .min()
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

    /// How far the connection to the robot is.
    pub fn link_state(&self) -> LinkState {
        self.link
    }

    /// What the LEDs depend on.
    fn indicator_inputs(&self) -> indicators::Inputs<'_> {
        indicators::Inputs {
            link: self.link,
            view: &self.view,
            navigating: self.control.navigating(),
            last_sent: self.control.last_sent(),
            last_command_failed: self.control.last_failed(),
        }
    }
}
