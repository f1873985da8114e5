//! What the panel knows of the robot: the poll schedule and the latest answers.
//!
//! [`Monitor`] decides when to ask the robot for its state: status (1002) and perception
//! (2002) every 500 ms, battery (2001) every 5 s, motor temperatures (1008) every 10 s, and
//! the navigation-task status (1007) every second while a task runs (docs/design.md,
//! "Monitor").
//! The polls have a connection of their own, so that a robot slow to answer them never
//! holds a command back.
//!
//! [`RobotView`] keeps the latest answer of each kind with the time it arrived. An answer
//! older than four poll periods is stale and reads as absent, so the indicators never show a
//! state the robot may have left long ago.

use embassy_time::{Duration, Instant};

use super::{ConnectionState, next_after};
use crate::config::{Config, PollPeriods};
use crate::proto::codes::MessageType;
use crate::proto::message::{
    Battery, MotorTemperatures, NavResult, NavTaskState, Perception, Request, Response, RobotStatus,
};

/// How many poll periods an answer stays fresh: at the default 500 ms, a status 2 s old or
/// older counts as unavailable.
pub const STALE_AFTER_POLLS: u32 = 4;

/// The longest a poll other than the status is put back after failing again and again
/// ([`Monitor::poll_failed`]), unless its own period is longer.
pub const MAX_BACKOFF: Duration = Duration::from_secs(60);

/// One periodic poll.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct Schedule {
    /// What to ask.
    kind: Poll,
    /// How often.
    period: Duration,
    /// When next, kept while disconnected; `None` while this poll is off.
    due: Option<Instant>,
    /// Whether it goes before every other poll: its connection was lost before its answer.
    first: bool,
    /// How many times in a row it failed (no answer in time, or none that could be read).
    failures: u8,
}

impl Schedule {
    /// Counts a failure at `now` and puts the poll back by its period doubled for each
    /// failure in a row, up to [`MAX_BACKOFF`] (or its period, if longer).
    fn fail(&mut self, now: Instant) {
        self.failures = self.failures.saturating_add(1);
        // Sixteen doublings of any period a setting allows still fit the 64-bit ticks.
        let doubled = self.period.as_ticks() << self.failures.min(16);
        let limit = MAX_BACKOFF.max(self.period).as_ticks();
        self.due = Some(now.saturating_add(Duration::from_ticks(doubled.min(limit))));
    }
}

/// The kinds of poll, in the order they go out when due together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Poll {
    /// 1002.
    Status,
    /// 2002.
    Perception,
    /// 2001.
    Battery,
    /// 1008.
    MotorTemperatures,
    /// 1007, only while a navigation task runs.
    NavStatus,
}

impl Poll {
    /// The Type of this poll's request and of its answer: what requests and answers are
    /// matched to polls by (comparing whole requests would link a comparison of every
    /// request, navigation tasks included).
    fn message_type(self) -> MessageType {
        self.request().message_type()
    }

    /// The request that asks for this state.
    fn request(self) -> Request {
        match self {
            Self::Status => Request::Status,
            Self::Perception => Request::Perception,
            Self::Battery => Request::Battery,
            Self::MotorTemperatures => Request::MotorTemperatures,
            Self::NavStatus => Request::NavStatus,
        }
    }
}

/// The poll schedule.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Monitor {
    /// One schedule per kind of poll, in [`Poll`] order.
    schedules: [Schedule; 5],
    /// Whether the control connection is up.
    connected: bool,
    /// Whether a navigation task runs.
    navigating: bool,
    /// Whether the status yields its turn to one other poll due: its latest answer came
    /// after the next status was already due, so the status alone would fill the connection.
    status_yields: bool,
}

impl Monitor {
    /// Takes the poll periods of `config`; polls already scheduled keep their time.
    pub fn reconfigure(&mut self, config: &Config) {
        let fresh = Self::new(config);
        for (schedule, new) in self.schedules.iter_mut().zip(fresh.schedules) {
            schedule.period = new.period;
        }
    }

    /// A schedule with the configured periods; nothing is due until the robot is connected.
    pub fn new(config: &Config) -> Self {
        let p = &config.polls;
        let schedule = |kind, period| Schedule {
            kind,
            period,
            due: None,
            first: false,
            failures: 0,
        };
        Self {
            schedules: [
                schedule(Poll::Status, p.status),
                schedule(Poll::Perception, p.status),
                schedule(Poll::Battery, p.battery),
                schedule(Poll::MotorTemperatures, p.motor_temperatures),
                schedule(Poll::NavStatus, p.nav_status),
            ],
            connected: false,
            navigating: false,
            status_yields: false,
        }
    }

    /// The poll connection is in `state`: open (every poll that fell due meanwhile at once,
    /// in [`Monitor::next_poll`]'s order; on the first connection, all of them, to fill the
    /// view) or connecting (no polls until it is back).
    ///
    /// Polls keep their times across a reconnection. Were they all made due afresh, a robot
    /// that answers one request and hangs up would only ever be asked the first of them.
    pub fn connection(&mut self, state: ConnectionState, now: Instant) {
        let connected = state != ConnectionState::Connecting;
        if connected == self.connected {
            return;
        }
        self.connected = connected;
        if connected {
            for s in &mut self.schedules {
                s.due.get_or_insert(now);
            }
        }
        // The 1007 poll has its own rule.
        self.schedule_nav(now);
    }

    /// The poll of Type `poll` went unanswered because its connection was lost: it goes first
    /// on the next connection. Otherwise a robot that hangs up after each answer would lose
    /// the same poll, the one after the status, every time.
    ///
    /// Lost again before any answer, a poll other than the status counts as failing
    /// ([`Monitor::poll_failed`]) instead: a robot that hangs up on a Type it does not know
    /// would otherwise be asked nothing else, each connection spent on that poll.
    pub fn poll_lost(&mut self, poll: MessageType, now: Instant) {
        if let Some(s) = self.scheduled(poll) {
            if s.failures == 0 || s.kind == Poll::Status {
                s.failures = s.failures.saturating_add(1);
                s.due = Some(now);
                s.first = true;
            } else {
                s.fail(now);
            }
        }
    }

    /// The poll of Type `poll` failed at `now` on a connection that stays open: no answer in
    /// time, or one that could not be read. A poll other than the status is then put back
    /// by twice its period, doubled again for each failure in a row, up to
    /// [`MAX_BACKOFF`]: a robot that does not answer a Type (an older
    /// `robot_server` without 1008, say) would otherwise hold the status back for the
    /// whole wait, again and again. The status keeps its period: it is what the LEDs and
    /// the e-stop's confirmation wait on.
    pub fn poll_failed(&mut self, poll: MessageType, now: Instant) {
        if let Some(s) = self.scheduled(poll).filter(|s| s.kind != Poll::Status) {
            s.fail(now);
        }
    }

    /// The schedule of the poll of Type `message_type`, if it is one and on.
    fn scheduled(&mut self, message_type: MessageType) -> Option<&mut Schedule> {
        self.schedules
            .iter_mut()
            .find(|s| s.kind.message_type() == message_type && s.due.is_some())
    }

    /// A poll's answer arrived at `now`: its kind is asked at its own period again. A status
    /// answer that comes when the next status is already due (a robot slower to answer it
    /// than its period) lets one other poll due go first, so that the others are still asked.
    pub fn poll_answered(&mut self, response: &Response, now: Instant) {
        let message_type = response.message_type();
        for s in &mut self.schedules {
            if s.kind.message_type() == message_type {
                s.failures = 0;
                if s.kind == Poll::Status {
                    self.status_yields = s.due.is_some_and(|due| due <= now);
                }
            }
        }
    }

    /// The robot's address changed: the next connection goes to another robot, whose
    /// answers are all asked at once, as on the first connection. Called while the poll
    /// connection is closed.
    pub fn robot_moved(&mut self) {
        for s in &mut self.schedules {
            s.due = None;
            s.first = false;
            s.failures = 0;
        }
    }

    /// A navigation task started or ended: 1007 polls run only in between.
    pub fn navigation(&mut self, running: bool, now: Instant) {
        if running != self.navigating {
            self.navigating = running;
            self.schedule_nav(now);
        }
    }

    /// The poll to send at `now`, if one is due: one lost with its connection first, then
    /// the status (unless it yields, [`Monitor::poll_answered`]), then the most overdue,
    /// ties in the order perception, battery, motor temperatures, navigation status.
    pub fn next_poll(&mut self, now: Instant) -> Option<Request> {
        if !self.connected {
            return None;
        }
        let status_first = !core::mem::take(&mut self.status_yields);
        let s = self
            .schedules
            .iter_mut()
            .filter(|s| s.due.is_some_and(|due| due <= now))
            // `min_by_key` keeps the first of equal keys, which gives the tie order.
            .min_by_key(|s| (!s.first, !(status_first && s.kind == Poll::Status), s.due))?;
        s.due = s.due.map(|due| next_after(due, s.period, now));
        s.first = false;
        Some(s.kind.request())
    }

    /// When the next poll is due; `None` while disconnected.
    pub fn next_deadline(&self) -> Option<Instant> {
        if !self.connected {
            return None;
        }
        self.schedules.iter().filter_map(|s| s.due).min()
    }

    /// Turns the 1007 poll on one period from `now` while connected and navigating, else off.
    fn schedule_nav(&mut self, now: Instant) {
        let on = self.connected && self.navigating;
        for s in &mut self.schedules {
            if s.kind == Poll::NavStatus {
                // Not at once: just after the 1003 the robot may still report the last task.
                s.due = on.then(|| now.saturating_add(s.period));
            }
        }
    }
}

/// An answer and when it arrived.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stamped<T> {
    /// The answer.
    pub value: T,
    /// When it arrived.
    pub at: Instant,
}

impl<T> Stamped<T> {
    /// An answer that arrived at `at`.
    pub fn new(value: T, at: Instant) -> Self {
        Self { value, at }
    }
}

/// The latest answers of the robot: everything the indicators and the log show.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RobotView {
    /// Latest status (1002), even an all-zero one.
    status: Option<Stamped<RobotStatus>>,
    /// Latest battery answer (2001).
    battery: Option<Stamped<Battery>>,
    /// Latest perception answer (2002).
    perception: Option<Stamped<Perception>>,
    /// Latest motor temperatures (1008).
    motor_temperatures: Option<Stamped<MotorTemperatures>>,
    /// Latest navigation-task status (1007).
    nav_state: Option<Stamped<NavTaskState>>,
    /// How the last navigation task ended (1003 answer); never stale.
    nav_result: Option<Stamped<NavResult>>,
    /// Poll periods, from which the age limits follow.
    polls: PollPeriods,
}

impl RobotView {
    /// An empty view whose answers go stale after [`STALE_AFTER_POLLS`] configured periods.
    pub fn new(config: &Config) -> Self {
        Self {
            status: None,
            battery: None,
            perception: None,
            motor_temperatures: None,
            nav_state: None,
            nav_result: None,
            polls: config.polls,
        }
    }

    /// Takes the poll periods of `config`, from which the answers' age limits follow.
    pub fn reconfigure(&mut self, config: &Config) {
        self.polls = config.polls;
    }

    /// Takes in an answer that arrived at `now`; answers to commands are not kept.
    pub fn update(&mut self, response: &Response, now: Instant) {
        match *response {
            Response::Status(s) => self.status = Some(Stamped::new(s, now)),
            Response::Battery(b) => self.battery = Some(Stamped::new(b, now)),
            Response::Perception(p) => self.perception = Some(Stamped::new(p, now)),
            Response::MotorTemperatures(t) => {
                self.motor_temperatures = Some(Stamped::new(t, now));
            }
            Response::NavStatus(n) => self.nav_state = Some(Stamped::new(n, now)),
            Response::NavResult(r) => self.nav_result = Some(Stamped::new(r, now)),
            _ => {}
        }
    }

    /// The status if it is readable at `now`: fresh, and not the all-zero "unavailable" one.
    pub fn status(&self, now: Instant) -> Option<&RobotStatus> {
        fresh(&self.status, self.polls.status, now).filter(|s| !s.is_unavailable())
    }

    /// Whether a status, even an all-zero one, arrived recently enough at `now`: the robot
    /// answers its polls.
    pub fn status_fresh(&self, now: Instant) -> bool {
        fresh(&self.status, self.polls.status, now).is_some()
    }

    /// Whether the status is readable at `now` (see [`RobotView::status`]).
    pub fn status_readable(&self, now: Instant) -> bool {
        self.status(now).is_some()
    }

    /// The latest status as received, however old, with its arrival time.
    pub fn last_status(&self) -> Option<&Stamped<RobotStatus>> {
        self.status.as_ref()
    }

    /// When the status stops being fresh, if that is after `now`: the indicators change then.
    pub fn status_stale_at(&self, now: Instant) -> Option<Instant> {
        let at = self
            .status
            .as_ref()?
            .at
            .saturating_add(stale_limit(self.polls.status));
        (at > now).then_some(at)
    }

    /// The latest battery answer as received, however old, with its arrival time.
    pub fn last_battery(&self) -> Option<&Stamped<Battery>> {
        self.battery.as_ref()
    }

    /// The latest perception answer as received, however old, with its arrival time.
    pub fn last_perception(&self) -> Option<&Stamped<Perception>> {
        self.perception.as_ref()
    }

    /// The latest motor temperatures as received, however old, with their arrival time.
    pub fn last_motor_temperatures(&self) -> Option<&Stamped<MotorTemperatures>> {
        self.motor_temperatures.as_ref()
    }

    /// The latest navigation-task status as received, however old, with its arrival time.
    pub fn last_nav_state(&self) -> Option<&Stamped<NavTaskState>> {
        self.nav_state.as_ref()
    }

    /// The poll periods, from which the answers' age limits follow.
    pub fn polls(&self) -> PollPeriods {
        self.polls
    }

    /// The battery answer if it is fresh at `now`.
    pub fn battery(&self, now: Instant) -> Option<&Battery> {
        fresh(&self.battery, self.polls.battery, now)
    }

    /// The perception answer if it is fresh at `now`.
    pub fn perception(&self, now: Instant) -> Option<&Perception> {
        fresh(&self.perception, self.polls.status, now)
    }

    /// The motor temperatures if they are fresh at `now`.
    pub fn motor_temperatures(&self, now: Instant) -> Option<&MotorTemperatures> {
        fresh(&self.motor_temperatures, self.polls.motor_temperatures, now)
    }

    /// The navigation-task status if it is fresh at `now`.
    pub fn nav_state(&self, now: Instant) -> Option<&NavTaskState> {
        fresh(&self.nav_state, self.polls.nav_status, now)
    }

    /// How the last navigation task ended, and when the answer came.
    pub fn nav_result(&self) -> Option<&Stamped<NavResult>> {
        self.nav_result.as_ref()
    }
}

/// How old an answer polled every `period` may be and still count.
pub(crate) fn stale_limit(period: Duration) -> Duration {
    period
        .checked_mul(STALE_AFTER_POLLS)
        .unwrap_or(Duration::MAX)
}

/// The answer if it is younger than [`stale_limit`] of its poll `period` at `now`.
fn fresh<T>(answer: &Option<Stamped<T>>, period: Duration, now: Instant) -> Option<&T> {
    answer
        .as_ref()
        .filter(|a| now.saturating_duration_since(a.at) < stale_limit(period))
        .map(|a| &a.value)
}
