//! The application: the panel's logic driving three connections to the robot.
//! Board-agnostic.
//!
//! The board hands over three [`Connection`]s ([`Connections`]) and a [`Shared`] with the button events
//! it produces and the LED states it shows; [`run`] does the rest, forever, in five loops
//! joined in one task (so they share the [`Panel`] through a `RefCell`, without locks):
//!
//! - the **button** loop hands each debounced event to the panel the moment it arrives;
//! - the **command** loop writes what the panel asks for on the command connection without
//!   waiting for earlier answers, so a stop goes on the wire at once whatever is pending;
//!   it matches the answers as they come, gives up on requests after
//!   [`REQUEST_TIMEOUT`](crate::client::REQUEST_TIMEOUT) (longer for a slow robot), holds
//!   motion back while answers are overdue, and reconnects when the robot falls silent;
//! - the **poll** loop asks for the robot's state on a connection of its own, one request
//!   at a time, so a robot slow to answer polls never holds a command back. A robot that
//!   serves a single client (one at a time, serving the command connection; closing the
//!   others; or keeping only the newest) has the polls carried by the command loop instead,
//!   behind the commands. While the command connection has not answered since it opened,
//!   the poll loop writes the stops written there too, which a robot that does not read
//!   the command connection then gets at once;
//! - the **navigation** loop opens the navigation connection for each task, sends its 1003
//!   unless the task was withdrawn meanwhile, and holds that connection open until the
//!   answer, because the robot stops a task whose client disconnects (ErrorStatus 41802);
//! - the **LED** loop publishes the LED states on its own schedule, so they never freeze
//!   while a request is slow, and with them a [`Snapshot`] of the panel for the console;
//! - the **settings** loop takes in settings saved on the console
//!   ([`Shared::apply_settings`]): new speeds, presets and poll periods at once, and a new
//!   robot address by closing every connection, which reopen to the new address. The
//!   button loop takes them in too before an event, so a press after a save (`dock` after
//!   `dock here`) always acts on what was saved.
//!
//! The command loop counts its turns in [`Shared`]'s progress ([`Path::Commands`]); it turns
//! at least every [`IDLE`] while it can make progress, so that a board's watchdog can tell
//! a working application from a hung one.

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use embassy_futures::join::{join, join5};
use embassy_futures::select::{Either, Either3, select, select3};
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::{CriticalSectionRawMutex, NoopRawMutex};
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Instant, Timer, with_timeout};

use crate::client::{
    ANSWER_OVERDUE, Answer, ClientError, Connection, Health, RobotClock, SILENT_AFTER,
    STABLE_AFTER, Sent, Transport,
};
use crate::config::{Cidr, Config, PollPeriods, RobotAddress};
use crate::panel::indicators::{Faults, LinkState};
use crate::panel::monitor::Stamped;
use crate::panel::{
    Busy, ButtonEvent, ConnectionRole, ConnectionState, Indicators, NetworkState, Panel, control,
};
use crate::proto::codes::{MessageType, MotionCommandCode};
use crate::proto::message::{
    Battery, MotionCommand, MotorTemperatures, NavResult, NavTaskState, Perception, Request,
    Response, RobotStatus,
};

/// How many button events may wait for the application.
pub const BUTTON_QUEUE: usize = 16;
/// Longest sleep of a loop without an event: keeps the progress counter moving.
pub const IDLE: Duration = Duration::from_millis(500);
/// Longest wait between connection attempts while a stop waits to go out: the stop path
/// wins over the backoff's patience with a robot that keeps dropping connections.
pub const STOP_RETRY: Duration = Duration::from_millis(250);
/// How long the command connection must have been open to be reopened at once when lost
/// (the poll connection's is [`STABLE_AFTER`]). A pending stop goes first on every new
/// connection, so a robot that hangs up after each answer then gets it as often as
/// [`STOP_RETRY`] allows, the e-stop's own rate, not as fast as it can reconnect.
const COMMANDS_STABLE_AFTER: Duration = STOP_RETRY;
/// How long a cancelled task's 1003 answer may take before its connection is closed.
pub const CANCEL_GRACE: Duration = Duration::from_secs(2);
/// Longest time between two LED updates, so that a network change shows without an event.
const LED_REFRESH: Duration = Duration::from_millis(100);

/// A part of the firmware whose progress the watchdog checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Path {
    /// The board's button task: reads the buttons and hands over their events.
    Buttons,
    /// The application's command loop: writes commands to the robot.
    Commands,
}

/// What the console sees of the panel: a copy the application publishes as things change.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Snapshot {
    /// How far the connection to the robot is.
    pub link: LinkState,
    /// The robot the panel talks to.
    pub robot: RobotAddress,
    /// The latest status (1002), however old, with its arrival time.
    pub status: Option<Stamped<RobotStatus>>,
    /// The latest battery answer (2001), however old.
    pub battery: Option<Stamped<Battery>>,
    /// The latest perception answer (2002), however old.
    pub perception: Option<Stamped<Perception>>,
    /// The latest motor temperatures (1008), however old.
    pub motors: Option<Stamped<MotorTemperatures>>,
    /// The latest navigation-task status (1007), however old.
    pub nav: Option<Stamped<NavTaskState>>,
    /// The poll periods: an answer older than `STALE_AFTER_POLLS` of its period is stale.
    pub polls: PollPeriods,
    /// The faults the robot reports now.
    pub faults: Faults,
    /// What the LEDs show.
    pub leds: Indicators,
    /// Whether the last command failed.
    pub command_failed: bool,
    /// Why settings must not be saved now, if they must not.
    pub busy: Option<Busy>,
    /// The board's own address, if it has one.
    pub board_address: Option<Cidr>,
    /// When this was taken.
    pub at: Instant,
}

/// What the board and the application exchange.
pub struct Shared {
    /// Debounced button events, from the board's button task.
    pub buttons: Channel<CriticalSectionRawMutex, ButtonEvent, BUTTON_QUEUE>,
    /// The latest LED states, for the board's LED task.
    pub indicators: Signal<CriticalSectionRawMutex, Indicators>,
    /// Whether the board has a network (a link and an address), from the board.
    network: AtomicBool,
    /// Progress counters, one per [`Path`], growing (wrapping) as each path works.
    progress: [AtomicU32; 2],
    /// Settings just saved, for the application to take in.
    settings: Signal<CriticalSectionRawMutex, Config>,
    /// Whether the saved settings could not be read (the defaults are in use).
    settings_lost: AtomicBool,
    /// The latest snapshot of the panel, once the application runs.
    snapshot: Mutex<CriticalSectionRawMutex, Cell<Option<Snapshot>>>,
    /// The board's own address, once it has one.
    board_address: Mutex<CriticalSectionRawMutex, Cell<Option<Cidr>>>,
}

impl Shared {
    /// Nothing pressed, nothing shown, no network yet.
    pub const fn new() -> Self {
        Self {
            buttons: Channel::new(),
            indicators: Signal::new(),
            network: AtomicBool::new(false),
            progress: [AtomicU32::new(0), AtomicU32::new(0)],
            settings: Signal::new(),
            settings_lost: AtomicBool::new(false),
            snapshot: Mutex::new(Cell::new(None)),
            board_address: Mutex::new(Cell::new(None)),
        }
    }

    /// Puts saved settings in effect.
    pub fn apply_settings(&self, config: Config) {
        self.settings.signal(config);
    }

    /// Tells whether the saved settings could not be read, so the defaults are in use.
    pub fn set_settings_lost(&self, lost: bool) {
        self.settings_lost.store(lost, Ordering::Relaxed);
    }

    /// The latest snapshot of the panel; `None` before the application runs.
    pub fn snapshot(&self) -> Option<Snapshot> {
        self.snapshot.lock(Cell::get)
    }

    /// The board's own address, if it has one.
    pub fn board_address(&self) -> Option<Cidr> {
        self.board_address.lock(Cell::get)
    }

    /// Records the board's own address (`None`: it lost it).
    pub fn set_board_address(&self, address: Option<Cidr>) {
        self.board_address.lock(|cell| cell.set(address));
    }

    /// The board's network came up (link and address) or went down.
    pub fn set_network(&self, state: NetworkState) {
        self.network
            .store(state == NetworkState::Up, Ordering::Relaxed);
    }

    /// Whether the board has a network.
    pub fn network(&self) -> NetworkState {
        if self.network.load(Ordering::Relaxed) {
            NetworkState::Up
        } else {
            NetworkState::Down
        }
    }

    /// Shows progress of `path`.
    pub fn beat(&self, path: Path) {
        self.counter(path).fetch_add(1, Ordering::Relaxed);
    }

    /// The progress counter of `path`: a watchdog feeds only while every path's moves.
    pub fn progress(&self, path: Path) -> u32 {
        self.counter(path).load(Ordering::Relaxed)
    }

    /// The counter of `path`.
    fn counter(&self, path: Path) -> &AtomicU32 {
        match path {
            Path::Buttons => &self.progress[0],
            Path::Commands => &self.progress[1],
        }
    }
}

impl Default for Shared {
    fn default() -> Self {
        Self::new()
    }
}

/// The three connections to the robot, one per [`ConnectionRole`].
pub struct Connections<T: Transport> {
    /// Commands: written without waiting for earlier answers.
    pub commands: Connection<T>,
    /// Polls of the robot's state.
    pub polls: Connection<T>,
    /// The navigation task's 1003.
    pub navigation: Connection<T>,
}

/// Runs the panel against the robot, forever.
pub async fn run<T: Transport>(config: &Config, links: &mut Connections<T>, shared: &Shared) -> ! {
    let app = App {
        panel: RefCell::new(Panel::new(config)),
        robot: Cell::new(Target {
            robot: config.robot,
            moves: 0,
        }),
        shared,
        clock: Cell::new(RobotClock::new()),
        poll_route: Cell::new(PollRoute::Own),
        heard: [const { Cell::new(Heard::NEVER) }; 3],
        displaced: Cell::new(0),
        polls_fell_silent: Cell::new(None),
        poll_waiting: Cell::new(None),
        stops_aside: Cell::new(StopsAside::NONE),
        stop_copied: Cell::new(None),
        wake_commands: Signal::new(),
        wake_polls: Signal::new(),
        wake_tasks: Signal::new(),
        wake_leds: Signal::new(),
    };
    let Connections {
        commands,
        polls,
        navigation,
    } = links;
    // The button loop is polled first, so that an event and a due repeat that wake the task
    // together are seen in that order: a repeat never slips out after an e-stop press.
    let ((never, ..), _) = join(
        join5(
            app.button_loop(),
            app.command_loop(commands),
            app.poll_loop(polls),
            app.navigation_loop(navigation),
            app.led_loop(),
        ),
        app.settings_loop(),
    )
    .await;
    never
}

/// The robot the connections go to, and how often it changed: each connection loop
/// compares the count with the one it last followed.
#[derive(Debug, Clone, Copy)]
struct Target {
    /// The robot's address.
    robot: RobotAddress,
    /// How many times the settings moved the robot.
    moves: u32,
}

/// Which connection carries the polls.
///
/// A robot that serves one connection at a time leaves the others unread in its backlog,
/// and one that takes a limited number of clients closes the others at once. When it serves
/// the command connection, the polls would never be answered: the status never read, an
/// e-stop never confirmed and repeated for ever. So when [`UNSERVED_POLL_CONNECTIONS`] poll
/// connections in a row go silent or are lost without answering a poll, while the command
/// connection is open, the polls move to the command loop, which writes them one at a time
/// after the commands due, until the command connection closes. (When the robot serves the
/// poll connection instead, the poll connection gives way to a stop: see
/// [`Panel::stop_passed_over_by`].) A robot that keeps only its newest connection has them
/// moved too ([`App::note_lost`]).
///
/// A robot merely slow to answer polls looks the same from the poll connection, and one
/// that answers each connection's requests in order would keep a stop written after a slow
/// poll waiting behind it. So a carried poll that waits [`ANSWER_OVERDUE`] ends the carrying
/// for good, and the command connection is reopened at once, leaving the slow answer
/// behind: a stop waits at most that long, once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PollRoute {
    /// The poll connection carries them.
    Own,
    /// The command connection carries them.
    Commands,
    /// The poll connection, for good (until the robot's address changes): a poll carried
    /// on the command connection waited [`ANSWER_OVERDUE`], or the command connection
    /// closed without answering anything while it carried them (a robot silent everywhere).
    Kept,
}

/// How many of the panel's connections in a row the robot must close soon after another,
/// newer one opened, for it to be taken as keeping only its newest connection: the polls then
/// move to the command connection, which stays the only one open ([`PollRoute`]).
const DISPLACED_CONNECTIONS: u8 = 2;

/// How soon after a newer connection opened a connection's loss counts towards
/// [`DISPLACED_CONNECTIONS`]. As long as a connection must last to count as stable: the poll
/// connection, idle between polls, may notice its loss only at its next poll.
const DISPLACED_WITHIN: Duration = STABLE_AFTER;

/// How many poll connections in a row must end (silent or lost) without answering a poll
/// before the polls move to the command connection ([`PollRoute`]). Two: the second waits
/// twice as long for answers as the first, 3 s, so a robot merely slow at polls is mostly
/// found answering.
const UNSERVED_POLL_CONNECTIONS: u8 = 2;

/// The stops (e-stop, zero velocity) the command loop wrote on a command connection the
/// robot has not answered on since it opened, and an e-stop pressed while the command
/// connection is being reopened, each with when: the poll connection, if the robot has
/// answered on it, writes them too.
///
/// Such a command connection may be one the robot does not read: a robot serving one
/// connection at a time leaves it in its backlog while it serves the polls', one that takes
/// a limited number of clients closes it once another client took the place it had, one
/// whose command handler hung no longer reads it. The rules that move a stop to another
/// connection need half a second or more to tell; a copy on the poll connection reaches such
/// a robot at once. A robot that reads both gets the stop twice, which stops nothing more.
/// Only stops that cannot act late are copied: a copy is written within
/// [`control::STALE_PRESS`] of its original or not at all, a zero velocity only while no
/// motion button is held (it would stop motion pressed since), and a cancel never (it could
/// cancel a task ordered since; the task's own connection is its backstop, see
/// [`CANCEL_GRACE`]).
#[derive(Debug, Clone, Copy)]
struct StopsAside {
    /// When an e-stop was set aside, if one waits.
    estop: Option<Instant>,
    /// When a zero velocity was set aside, if one waits.
    zero_velocity: Option<Instant>,
}

/// The copies' requests, in statics: the poll loop's future then keeps a reference to the
/// one it writes, not a [`Request`] (the largest message type, 720 bytes).
static ESTOP: Request = Request::Motion(MotionCommand::SoftEmergencyStop);
/// See [`ESTOP`].
static ZERO_VELOCITY: Request = Request::Motion(MotionCommand::ZeroVelocity);

impl StopsAside {
    /// Nothing set aside.
    const NONE: Self = StopsAside {
        estop: None,
        zero_velocity: None,
    };

    /// Whether nothing is set aside.
    fn is_empty(&self) -> bool {
        self.estop.is_none() && self.zero_velocity.is_none()
    }

    /// Sets `request` aside at `at` if it is a stop that is copied; whether it is.
    fn set_aside(&mut self, request: &Request, at: Instant) -> bool {
        let slot = match request {
            Request::Motion(MotionCommand::SoftEmergencyStop) => &mut self.estop,
            Request::Motion(MotionCommand::ZeroVelocity) => &mut self.zero_velocity,
            _ => return false,
        };
        *slot = Some(at);
        true
    }

    /// Takes the stops set aside that are still fresh at `now`, e-stop first; zero velocity
    /// only if `motion_held` is false. The rest are dropped.
    fn take(&mut self, now: Instant, motion_held: bool) -> impl Iterator<Item = &'static Request> {
        let fresh = |at: Option<Instant>| {
            at.is_some_and(|at| now.saturating_duration_since(at) <= control::STALE_PRESS)
        };
        let Self {
            estop,
            zero_velocity,
        } = core::mem::replace(self, Self::NONE);
        let estop = fresh(estop).then_some(&ESTOP);
        let zero_velocity = (fresh(zero_velocity) && !motion_held).then_some(&ZERO_VELOCITY);
        estop.into_iter().chain(zero_velocity)
    }
}

/// What the loops share.
struct App<'a> {
    /// The panel; borrowed only between awaits, never across one.
    panel: RefCell<Panel>,
    /// Where the connections go.
    robot: Cell<Target>,
    /// The board's side.
    shared: &'a Shared,
    /// The robot's clock as the poll connection learns it, for the others' `Time`.
    clock: Cell<RobotClock>,
    /// Which connection carries the polls.
    poll_route: Cell<PollRoute>,
    /// When each connection last opened, and was last heard from.
    heard: [Cell<Heard>; 3],
    /// Connections in a row the robot closed soon after a newer one opened.
    displaced: Cell<u8>,
    /// When the poll connection, given up as silent after it had answered, was last
    /// answered: the command loop reopens its connection if it has heard nothing since
    /// (see [`App::command_loop`]).
    polls_fell_silent: Cell<Option<Instant>>,
    /// Since when the poll on the poll connection has waited for its answer, if one does.
    poll_waiting: Cell<Option<Instant>>,
    /// The stops the command loop wrote on a connection the robot had not answered on, for
    /// the poll connection to carry too ([`StopsAside`]).
    stops_aside: Cell<StopsAside>,
    /// When the poll connection first carried such a stop since the command connection was
    /// last answered: the original still waits there, and the poll connection gives way to
    /// it as to a stop pending ([`App::stop_passed_over_by`]), once.
    stop_copied: Cell<Option<Instant>>,
    /// Something for the command loop to send.
    wake_commands: Signal<NoopRawMutex, ()>,
    /// The poll schedule changed.
    wake_polls: Signal<NoopRawMutex, ()>,
    /// A navigation task may have been ordered.
    wake_tasks: Signal<NoopRawMutex, ()>,
    /// The LEDs may have changed.
    wake_leds: Signal<NoopRawMutex, ()>,
}

impl App<'_> {
    /// Runs `f` on the panel.
    fn panel<R>(&self, f: impl FnOnce(&mut Panel) -> R) -> R {
        f(&mut self.panel.borrow_mut())
    }

    /// When to make the next connection attempt: after `delay` (the connection's backoff),
    /// or at most [`STOP_RETRY`] while a stop waits to go out. Logged here, with the wait
    /// kept, not the backoff's: whoever reads the log sees when the panel tries again.
    fn retry_at(&self, delay: Duration) -> Instant {
        let delay = if self.panel(|p| p.control().stop_pending()) {
            delay.min(STOP_RETRY)
        } else {
            delay
        };
        warn!("next connection attempt in {} ms", delay.as_millis());
        Instant::now() + delay
    }

    /// Closes `conn` if the robot moved since `followed` (the count of moves it follows),
    /// so that it reopens to the new address; whether it did.
    async fn follow_robot<T: Transport>(
        &self,
        conn: &mut Connection<T>,
        role: ConnectionRole,
        followed: &mut u32,
    ) -> bool {
        let target = self.robot.get();
        if target.moves == *followed {
            return false;
        }
        *followed = target.moves;
        conn.retarget(target.robot).await;
        self.connection(role, ConnectionState::Connecting);
        if role == ConnectionRole::Polls {
            self.panel(Panel::robot_moved);
        }
        true
    }

    /// Reports a connection's state to the panel, and wakes the LEDs if it changed.
    fn connection(&self, role: ConnectionRole, state: ConnectionState) {
        if self.panel(|p| p.connection(role, state, Instant::now())) {
            self.wake_leds.signal(());
        }
    }

    /// Hands each button event to the panel as it arrives.
    async fn button_loop(&self) -> ! {
        loop {
            let event = self.shared.buttons.receive().await;
            // Settings saved before the press are in effect for it (a dock point saved, then
            // `dock` pressed), even when the press and the save wake this task together and
            // the settings loop, polled after this one, has not taken them in yet.
            if let Some(config) = self.shared.settings.try_take() {
                self.take_in_settings(&config);
            }
            debug!(
                "button {} {}",
                event.button.name(),
                if event.pressed { "pressed" } else { "released" }
            );
            self.panel(|p| p.button(event));
            // An e-stop the command connection cannot carry now (it is being reopened) goes
            // on the poll connection at once, not at the next connection attempt.
            if self.panel(|p| !p.commands_connected() && p.control().estop_unconfirmed()) {
                self.set_aside(&ESTOP);
            }
            // At once: the console's save asks whether a button is held.
            self.publish_snapshot(Instant::now());
            self.wake_commands.signal(());
            self.wake_tasks.signal(());
            self.wake_polls.signal(());
            self.wake_leds.signal(());
        }
    }

    /// The command connection: connect, write what is due, match answers, watch for
    /// silence; and carry the polls when the poll connection is not served ([`PollRoute`]).
    async fn command_loop<T: Transport>(&self, conn: &mut Connection<T>) -> ! {
        let mut retry_at = Instant::now();
        let mut followed = 0;
        let mut polls = CarriedPolls::default();
        // Since when the open connection's oldest request has waited, and since when one
        // waited on connections closed before any answer: a robot that closes every new
        // command connection unanswered (one that takes a limited number of clients, serving
        // the polls') would otherwise look as if each new one had just begun to wait.
        let mut waiting = None;
        let mut lost_waiting = None;
        // A stop moved to a new connection since the robot last answered on this one.
        let mut moved_unanswered = false;
        loop {
            self.shared.beat(Path::Commands);
            if self
                .follow_robot(conn, ConnectionRole::Commands, &mut followed)
                .await
            {
                retry_at = Instant::now();
                self.hand_polls_back(&mut polls);
                // Another robot: what this one served or left waiting says nothing about it.
                self.poll_route.set(PollRoute::Own);
                self.displaced.set(0);
                self.stop_copied.set(None);
                lost_waiting = None;
                waiting = None;
                moved_unanswered = false;
            }
            if !conn.is_connected() {
                self.hand_polls_back(&mut polls);
                lost_waiting = earliest(lost_waiting, waiting.take());
                self.panel(|p| p.commands_waiting(lost_waiting));
            }
            if !self
                .ensure_connected(
                    conn,
                    ConnectionRole::Commands,
                    &mut retry_at,
                    &self.wake_commands,
                )
                .await
            {
                continue;
            }
            let now = Instant::now();
            if let Some(late) = polls.overdue(now) {
                self.keep_polls_apart(late, now);
                // The robot may answer in order: a stop written now would wait behind the
                // poll. A new connection leaves it behind (and its wait: no command's).
                waiting = None;
                retry_at = self.reopen_commands(conn).await;
                continue;
            }
            while let Some((id, sent)) = conn.expire(now, conn.request_timeout()) {
                warn!(
                    "no answer to Type {} Command {} (message {})",
                    sent.message_type.raw(),
                    sent.command,
                    id
                );
                self.panel(|p| {
                    p.command_answered(sent.message_type, Some(sent.at), Err(&ClientError::Timeout))
                });
            }
            // The robot stopped answering the poll connection, which it had answered: a
            // robot whose handlers hung may no longer read this one either. Reopened now if
            // it has heard nothing since the polls' last answer, so that a stop goes on a
            // connection the robot reads, not into this one until it is given up as silent
            // (1.75 s): a latched e-stop or an unanswered zero velocity is the first thing on
            // the new one. What else waited here is given up on; the robot answered nothing
            // for seconds.
            if let Some(since) = self.polls_fell_silent.take()
                && self.heard(ConnectionRole::Commands).get().heard <= Some(since)
            {
                warn!("the robot stopped answering polls: the command connection reopens");
                retry_at = self.reopen_commands(conn).await;
                continue;
            }
            // A stop the robot has not read for 500 ms (`stop_unread_until`) goes on a new
            // connection at once, first thing there (a latched e-stop, a zero velocity
            // unanswered: `Control`), not after the seconds of silence that give a
            // connection up.
            if self
                .stop_unread_until(conn, moved_unanswered)
                .is_some_and(|from| from <= now)
            {
                warn!("the robot has not read a stop for 500 ms: it goes on a new connection");
                moved_unanswered = true;
                retry_at = self.reopen_commands(conn).await;
                continue;
            }
            let health = conn.health(now);
            if health == Health::Silent {
                warn!("the robot stopped answering commands: reconnecting");
                // A robot that reads but does not answer may still act on a stop: write
                // what is due before giving the connection up (motion is held back).
                self.send_due(conn, health).await;
                retry_at = self.retry_at(conn.give_up().await);
                self.connection(ConnectionRole::Commands, ConnectionState::Connecting);
                continue;
            }
            self.connection(ConnectionRole::Commands, state_of(health));
            let carrying = self.poll_route.get() == PollRoute::Commands;
            if carrying {
                self.connection(ConnectionRole::Polls, state_of(health));
            }
            if !self.send_due(conn, health).await || !self.send_poll(conn, &mut polls).await {
                self.note_lost(ConnectionRole::Commands);
                retry_at = self.retry_at(conn.reconnect_delay(COMMANDS_STABLE_AFTER));
                self.connection(ConnectionRole::Commands, ConnectionState::Connecting);
                continue;
            }
            waiting = conn.waiting_since();
            self.panel(|p| p.commands_waiting(earliest(lost_waiting, waiting)));
            let next_poll = match polls.in_flight {
                Some(carried) => Some(carried.sent.saturating_add(ANSWER_OVERDUE)),
                None if carrying => self.panel(|p| p.poll_deadline()),
                None => None,
            };
            let deadline = [
                self.panel(|p| p.command_deadline()),
                next_poll,
                conn.expiry(conn.request_timeout()),
                conn.health_deadline(now),
                self.stop_unread_until(conn, moved_unanswered),
            ]
            .into_iter()
            .flatten()
            .fold(now + IDLE, Instant::min);
            match select3(
                conn.receive(),
                self.wake_commands.wait(),
                Timer::at(deadline),
            )
            .await
            {
                Either3::First(Ok(answer)) => {
                    self.note_heard(ConnectionRole::Commands);
                    lost_waiting = None;
                    moved_unanswered = false;
                    polls.answered |= self.poll_route.get() == PollRoute::Commands;
                    match (polls.take(answer.message_id), answer.result) {
                        (Some(_), Ok(response)) => self.polled(conn, &response),
                        (Some(poll), Err(e)) => {
                            warn!("poll failed: {:?}", e);
                            self.panel(|p| p.poll_failed(poll, Instant::now()));
                        }
                        (None, result) => {
                            self.panel(|p| {
                                p.command_answered(
                                    answer.request.message_type,
                                    Some(answer.request.at),
                                    result.as_ref(),
                                )
                            });
                            self.wake_leds.signal(());
                        }
                    }
                }
                Either3::First(Err(e)) => {
                    warn!("command connection lost: {:?}", e);
                    self.note_lost(ConnectionRole::Commands);
                    retry_at = self.retry_at(conn.reconnect_delay(COMMANDS_STABLE_AFTER));
                    self.connection(ConnectionRole::Commands, ConnectionState::Connecting);
                }
                Either3::Second(()) | Either3::Third(()) => {}
            }
        }
    }

    /// Writes the poll due now on the command connection, if it carries the polls and
    /// none is in flight there; false if the connection was lost doing so.
    async fn send_poll<T: Transport>(
        &self,
        conn: &mut Connection<T>,
        polls: &mut CarriedPolls,
    ) -> bool {
        if self.poll_route.get() != PollRoute::Commands || polls.in_flight.is_some() {
            return true;
        }
        let Some(poll) = self.panel(|p| p.next_poll(Instant::now())) else {
            return true;
        };
        match conn.send(&poll).await {
            Ok(id) => {
                polls.in_flight = Some(CarriedPoll {
                    id,
                    poll: poll.message_type(),
                    sent: Instant::now(),
                });
                true
            }
            Err(_) => {
                self.panel(|p| p.poll_lost(poll.message_type(), Instant::now()));
                false
            }
        }
    }

    /// The command connection closed: a poll in flight on it is lost, and the polls it
    /// carried go back to the poll connection; for good if it answered nothing meanwhile
    /// ([`PollRoute`]).
    fn hand_polls_back(&self, polls: &mut CarriedPolls) {
        if let Some(carried) = polls.in_flight.take() {
            self.panel(|p| p.poll_lost(carried.poll, Instant::now()));
        }
        if self.poll_route.get() != PollRoute::Commands {
            return;
        }
        warn!("the command connection closed: the polls go back to their own connection");
        self.return_polls(if core::mem::take(&mut polls.answered) {
            PollRoute::Own
        } else {
            PollRoute::Kept
        });
    }

    /// A poll carried on the command connection, of Type `late`, waited [`ANSWER_OVERDUE`]
    /// at `now`: the polls go back to their own connection for good ([`PollRoute`]).
    fn keep_polls_apart(&self, late: MessageType, now: Instant) {
        warn!(
            "a poll waits on the command connection: the polls go back to their own connection for good"
        );
        self.panel(|p| p.poll_failed(late, now));
        self.return_polls(PollRoute::Kept);
    }

    /// Hands the polls back to the poll loop, which is to carry them from now on.
    fn return_polls(&self, route: PollRoute) {
        self.poll_route.set(route);
        self.connection(ConnectionRole::Polls, ConnectionState::Connecting);
        self.wake_polls.signal(());
    }

    /// Writes every command due now; false if the connection was lost doing so.
    async fn send_due<T: Transport>(&self, conn: &mut Connection<T>, health: Health) -> bool {
        while let Some(request) = self.panel(|p| p.next_command(Instant::now(), health)) {
            info!(
                "command: Type {} Command {}",
                request.message_type().raw(),
                request.command()
            );
            self.wake_leds.signal(());
            if let Err(e) = conn.send(&request).await {
                self.panel(|p| p.command_answered(request.message_type(), None, Err(&e)));
                return false;
            }
            if !conn.answered() {
                self.set_aside(&request);
            }
        }
        true
    }

    /// Closes the command connection `conn`, to be reopened at once: returns when to. What
    /// it holds was written long ago, or never will be: nothing is flushed.
    async fn reopen_commands<T: Transport>(&self, conn: &mut Connection<T>) -> Instant {
        conn.disconnect().await;
        self.connection(ConnectionRole::Commands, ConnectionState::Connecting);
        Instant::now()
    }

    /// When a stop outstanding on the command connection `conn` will have gone unread long
    /// enough to be moved to a new connection, if it is to be: [`ANSWER_OVERDUE`] after it
    /// was written with nothing received since, on a connection the robot answered on (it
    /// no longer reads it: a handler that hung). On one never answered on, only while a
    /// poll written after it opened waits unanswered as long: a robot serving one connection
    /// at a time leaves the command connection unread in its backlog while it serves the
    /// polls' promptly, and the poll connection gives way instead; a robot that reads
    /// neither has hung. Either way once until the robot answers on the command connection
    /// (`moved_unanswered`: a stop moved since it last did): a robot that reads nothing
    /// anywhere, or reads slowly, is not sent a new connection every half second.
    fn stop_unread_until<T: Transport>(
        &self,
        conn: &Connection<T>,
        moved_unanswered: bool,
    ) -> Option<Instant> {
        let written = conn.unread_since(is_stop)?;
        if conn.answered() {
            return Some(written.saturating_add(ANSWER_OVERDUE));
        }
        if moved_unanswered {
            return None;
        }
        let poll = self.poll_waiting.get()?;
        let opened = self.heard(ConnectionRole::Commands).get().opened?;
        (opened < poll).then(|| written.max(poll).saturating_add(ANSWER_OVERDUE))
    }

    /// Opens `conn` if it is closed and its retry is due; whether it is open. While it
    /// stays closed this waits (for the retry, at most [`IDLE`], or for `wake`, which a
    /// button signals) before returning.
    async fn ensure_connected<T: Transport>(
        &self,
        conn: &mut Connection<T>,
        role: ConnectionRole,
        retry_at: &mut Instant,
        wake: &Signal<NoopRawMutex, ()>,
    ) -> bool {
        if conn.is_connected() {
            return true;
        }
        // A stop pressed during a long backoff ends the wait once the latest attempt is
        // STOP_RETRY old: at once after a connection given up on or lost, every STOP_RETRY
        // against a robot that refuses or drops every connection.
        if self.panel(|p| p.control().stop_pending()) {
            *retry_at = (*retry_at).min(conn.last_attempt() + STOP_RETRY);
        }
        if Instant::now() >= *retry_at {
            self.connection(role, ConnectionState::Connecting);
            conn.set_clock(self.clock.get());
            match conn.connect().await {
                Ok(()) => {
                    self.note_opened(role);
                    self.connection(role, ConnectionState::Open);
                    return true;
                }
                Err(retry_in) => *retry_at = self.retry_at(retry_in),
            }
        }
        // A button may make a stop pending meanwhile: look again then.
        select(
            Timer::at((*retry_at).min(Instant::now() + IDLE)),
            wake.wait(),
        )
        .await;
        false
    }

    /// The poll connection: one poll at a time, when due; given up while the robot serves
    /// it ahead of a stop ([`Panel::stop_passed_over_by`]).
    async fn poll_loop<T: Transport>(&self, conn: &mut Connection<T>) -> ! {
        let mut retry_at = Instant::now();
        let mut followed = 0;
        // Since when the poll connection has given way to a stop, if it has.
        let mut giving_way: Option<Instant> = None;
        // Poll connections in a row that ended without answering a poll.
        let mut unserved = 0;
        loop {
            if self
                .follow_robot(conn, ConnectionRole::Polls, &mut followed)
                .await
            {
                retry_at = Instant::now();
            }
            if let Err(e) = self.write_stops_aside(conn).await {
                warn!("poll connection lost: {:?}", e);
                self.note_lost(ConnectionRole::Polls);
                retry_at = self.retry_at(conn.reconnect_delay(STABLE_AFTER));
                self.connection(ConnectionRole::Polls, ConnectionState::Connecting);
                continue;
            }
            if self.poll_route.get() == PollRoute::Commands {
                // Until the command connection closes. This connection, which the polls
                // left (from here, or moved by the command loop), closes first.
                conn.disconnect().await;
                select(self.wake_polls.wait(), Timer::after(IDLE)).await;
                unserved = 0;
                continue;
            }
            if let Some(since) = giving_way {
                // Until the command connection is answered (or the stop is no longer due):
                // a robot serving one connection at a time then takes the command one. At
                // most SILENT_AFTER at a time: a robot that answers polls and no motion at
                // all never answers there, and would otherwise have no status read again
                // (nor an e-stop confirmed); a poll between two give-ways is.
                let waits = self.panel(|p| p.stop_unanswered()) || self.stop_copied.get().is_some();
                if waits && Instant::now() < since.saturating_add(SILENT_AFTER) {
                    Timer::after(STOP_RETRY).await;
                    continue;
                }
                giving_way = None;
                // A copy makes the poll connection give way once.
                self.stop_copied.set(None);
            }
            if !self
                .ensure_connected(conn, ConnectionRole::Polls, &mut retry_at, &self.wake_polls)
                .await
            {
                continue;
            }
            let now = Instant::now();
            let Some(poll) = self.panel(|p| p.next_poll(now)) else {
                let due = self.panel(|p| p.poll_deadline()).unwrap_or(now + IDLE);
                select(self.wake_polls.wait(), Timer::at(due.min(now + IDLE))).await;
                continue;
            };
            let sent = Instant::now();
            // The command loop weighs a stop unread on a connection never answered on
            // against this wait: it looks again now.
            self.poll_waiting.set(Some(sent));
            self.wake_commands.signal(());
            let result = self.poll_exchange(conn, &poll).await;
            self.poll_waiting.set(None);
            match result {
                Ok(response) => {
                    self.note_heard(ConnectionRole::Polls);
                    unserved = 0;
                    self.polled(conn, &response);
                    if self.stop_passed_over_by(sent) {
                        warn!(
                            "the robot answers polls but not the stop: the poll connection gives way"
                        );
                        giving_way = Some(Instant::now());
                        conn.disconnect().await;
                        self.connection(ConnectionRole::Polls, ConnectionState::Connecting);
                    }
                }
                Err(e) if e.connection_usable() => {
                    warn!("poll failed: {:?}", e);
                    self.panel(|p| p.poll_failed(poll.message_type(), Instant::now()));
                    if conn.health(Instant::now()) != Health::Silent {
                        continue;
                    }
                    if self.polls_unserved(conn, &mut unserved) {
                        self.move_unserved_polls();
                    } else {
                        warn!("the robot stopped answering polls: reconnecting");
                        if conn.answered() {
                            self.polls_fell_silent
                                .set(self.heard(ConnectionRole::Polls).get().heard);
                            self.wake_commands.signal(());
                        }
                        retry_at = self.retry_at(conn.give_up().await);
                        self.connection(ConnectionRole::Polls, ConnectionState::Connecting);
                    }
                }
                Err(e) => {
                    warn!("poll connection lost: {:?}", e);
                    self.panel(|p| p.poll_lost(poll.message_type(), Instant::now()));
                    self.note_lost(ConnectionRole::Polls);
                    if self.polls_unserved(conn, &mut unserved) {
                        self.move_unserved_polls();
                    } else if self.poll_route.get() != PollRoute::Commands {
                        retry_at = self.retry_at(conn.reconnect_delay(STABLE_AFTER));
                        self.connection(ConnectionRole::Polls, ConnectionState::Connecting);
                    }
                }
            }
        }
    }

    /// Writes `poll` on the poll connection `conn` and waits for its answer as long as the
    /// connection's request timeout allows; meanwhile writes the stops set aside for it
    /// ([`App::write_stops_aside`]) and hands their answers to the panel.
    async fn poll_exchange<T: Transport>(
        &self,
        conn: &mut Connection<T>,
        poll: &Request,
    ) -> Result<Response, ClientError> {
        let id = conn.send(poll).await?;
        let until = Instant::now() + conn.request_timeout();
        loop {
            match select3(conn.receive(), self.wake_polls.wait(), Timer::at(until)).await {
                Either3::First(Ok(answer)) if answer.message_id == id => return answer.result,
                Either3::First(Ok(answer)) => self.copy_answered(&answer),
                Either3::First(Err(e)) => return Err(e),
                Either3::Second(()) => self.write_stops_aside(conn).await?,
                Either3::Third(()) => {
                    conn.give_up_on(id);
                    return Err(ClientError::Timeout);
                }
            }
        }
    }

    /// Sets `request` aside for the poll connection to write too, if it is a stop it copies
    /// ([`StopsAside`]) and the polls have a connection of their own.
    fn set_aside(&self, request: &Request) {
        if self.poll_route.get() == PollRoute::Commands {
            return;
        }
        let mut aside = self.stops_aside.get();
        if aside.set_aside(request, Instant::now()) {
            self.stops_aside.set(aside);
            self.wake_polls.signal(());
        }
    }

    /// Writes the stops set aside for the poll connection `conn` ([`StopsAside`]) if the
    /// robot has answered on it, else drops them; an error if the connection was lost.
    async fn write_stops_aside<T: Transport>(
        &self,
        conn: &mut Connection<T>,
    ) -> Result<(), ClientError> {
        let mut aside = self.stops_aside.replace(StopsAside::NONE);
        if aside.is_empty() || !(conn.is_connected() && conn.answered()) {
            return Ok(());
        }
        let motion_held = self.panel(|p| p.control().active_motion().is_some());
        for stop in aside.take(Instant::now(), motion_held) {
            info!(
                "the command connection is not answered yet: Type 2 Command {} on the poll connection too",
                stop.command()
            );
            conn.send(stop).await?;
            if self.stop_copied.get().is_none() {
                self.stop_copied.set(Some(Instant::now()));
            }
        }
        Ok(())
    }

    /// An answer on the poll connection other than its poll's: to a stop it carried too,
    /// handed to the panel as the command connection's answers are. (A poll's answer that
    /// came after its wait ended is dropped.)
    fn copy_answered(&self, answer: &Answer) {
        if answer.request.message_type == MessageType::Motion {
            self.note_heard(ConnectionRole::Polls);
            self.panel(|p| {
                p.command_answered(
                    answer.request.message_type,
                    Some(answer.request.at),
                    answer.result.as_ref(),
                )
            });
            self.wake_commands.signal(());
            self.wake_leds.signal(());
        }
    }

    /// Whether the robot served the poll written at `sent` ahead of a stop on the command
    /// connection ([`Panel::stop_passed_over_by`]), or of a stop there that the poll
    /// connection carried too ([`App::stop_copied`]), by [`ANSWER_OVERDUE`] or more: the
    /// poll connection then gives way. The copy may have had the e-stop confirmed, which
    /// ends the stop's being pending, while a robot serving one connection at a time still
    /// leaves the command connection in its backlog.
    fn stop_passed_over_by(&self, sent: Instant) -> bool {
        self.panel(|p| p.stop_passed_over_by(sent))
            || self
                .stop_copied
                .get()
                .is_some_and(|copied| copied.saturating_add(ANSWER_OVERDUE) <= sent)
    }

    /// Counts the poll connection `conn`, silent or lost, in `unserved` if it never
    /// answered, and tells whether the polls should now move to the command connection
    /// ([`PollRoute`]): [`UNSERVED_POLL_CONNECTIONS`] in a row, the command connection open.
    fn polls_unserved<T: Transport>(&self, conn: &Connection<T>, unserved: &mut u8) -> bool {
        *unserved = if conn.answered() {
            0
        } else {
            unserved.saturating_add(1)
        };
        *unserved >= UNSERVED_POLL_CONNECTIONS
            && self.poll_route.get() == PollRoute::Own
            && self.panel(|p| p.commands_connected())
    }

    /// Moves the polls to the command connection, the poll connection being unserved
    /// ([`App::polls_unserved`]).
    fn move_unserved_polls(&self) {
        warn!(
            "the robot does not serve the poll connection: the command connection carries the polls"
        );
        self.move_polls();
    }

    /// Moves the polls to the command connection; the poll loop closes its own.
    fn move_polls(&self) {
        self.poll_route.set(PollRoute::Commands);
        self.wake_commands.signal(());
        self.wake_polls.signal(());
    }

    /// When `role`'s connection last opened, and was last heard from.
    fn heard(&self, role: ConnectionRole) -> &Cell<Heard> {
        let [commands, polls, navigation] = &self.heard;
        match role {
            ConnectionRole::Commands => commands,
            ConnectionRole::Polls => polls,
            ConnectionRole::Navigation => navigation,
        }
    }

    /// Notes that `role`'s connection opened now.
    fn note_opened(&self, role: ConnectionRole) {
        let now = Some(Instant::now());
        self.heard(role).set(Heard {
            opened: now,
            heard: now,
        });
    }

    /// Notes that `role`'s connection was answered now. An answer on the command
    /// connection ends the wait of the stops the poll connection carried too.
    fn note_heard(&self, role: ConnectionRole) {
        if role == ConnectionRole::Commands {
            self.stop_copied.set(None);
        }
        let cell = self.heard(role);
        cell.set(Heard {
            heard: Some(Instant::now()),
            ..cell.get()
        });
    }

    /// Notes that `role`'s connection was lost. A robot that keeps only its newest
    /// connection closes one of the panel's each time another opens, so that none lasts and
    /// motion never gets through: after [`DISPLACED_CONNECTIONS`] in a row lost within
    /// [`DISPLACED_WITHIN`] of another's opening, with nothing answered on the lost one
    /// since, the polls move to the command connection ([`PollRoute`]), which then stays the
    /// only one open but for a navigation task's. (A robot that hangs up after each answer
    /// closes a connection right after answering on it: that does not count.)
    fn note_lost(&self, role: ConnectionRole) {
        let now = Instant::now();
        let mine = self.heard(role).get().heard;
        let displaced = self.heard.iter().map(|h| h.get().opened).any(|other| {
            other > mine
                && other.is_some_and(|at| now.saturating_duration_since(at) <= DISPLACED_WITHIN)
        });
        let in_a_row = if displaced {
            self.displaced.get().saturating_add(1)
        } else {
            0
        };
        self.displaced.set(in_a_row);
        if in_a_row >= DISPLACED_CONNECTIONS && self.poll_route.get() == PollRoute::Own {
            warn!(
                "the robot keeps only its newest connection: the command connection carries the polls"
            );
            self.move_polls();
        }
    }

    /// A poll's answer: into the panel, and the clock learned from it for the others.
    fn polled<T: Transport>(&self, conn: &Connection<T>, response: &Response) {
        self.clock.set(conn.clock());
        self.panel(|p| p.poll_answered(response, Instant::now()));
        // A confirmed e-stop stops the repeats; the LEDs follow the status.
        self.wake_commands.signal(());
        self.wake_leds.signal(());
    }

    /// The navigation connection: one task at a time, its connection held until the answer.
    async fn navigation_loop<T: Transport>(&self, conn: &mut Connection<T>) -> ! {
        let mut followed = 0;
        loop {
            // A task already running stays on its robot until it ends; the next goes to
            // the new one.
            self.follow_robot(conn, ConnectionRole::Navigation, &mut followed)
                .await;
            let Some(order) = self.panel(|p| p.take_task(Instant::now())) else {
                self.wake_tasks.wait().await;
                // A stale order was dropped and shown.
                self.wake_leds.signal(());
                continue;
            };
            conn.set_clock(self.clock.get());
            // A fresh connection per task: one left idle may have died unnoticed.
            if conn.connect().await.is_err() {
                self.task_ended(order.id, Err(&ClientError::NotConnected));
                continue;
            }
            self.note_opened(ConnectionRole::Navigation);
            // The connection may have taken a while: the task may be cancelled or stale.
            if !self.panel(|p| p.task_wanted(order.id, Instant::now())) {
                info!("navigation task withdrawn before its 1003 went out");
                conn.disconnect().await;
                self.wake_leds.signal(());
                continue;
            }
            let end = match conn.send(&Request::NavTask(order.task)).await {
                Ok(message_id) => {
                    self.panel(|p| p.task_started(order.id, Instant::now()));
                    self.wake_polls.signal(());
                    self.wake_leds.signal(());
                    self.task_answer(conn, order.id, message_id).await
                }
                Err(e) => Err(e),
            };
            match end {
                Ok(Response::NavResult(result)) => self.task_ended(order.id, Ok(&result)),
                Ok(other) => self.task_ended(
                    order.id,
                    Err(&ClientError::UnexpectedAnswer {
                        expected: MessageType::NavTask,
                        got: other.message_type(),
                    }),
                ),
                Err(e) => self.task_ended(order.id, Err(&e)),
            }
            // The task is over (or lost track of, which closing stops too: 41802).
            conn.disconnect().await;
        }
    }

    /// Waits for the answer to task `id`'s 1003 (message `message_id`). Once the panel has
    /// cancelled the task, the robot answers it at once; one that does not within
    /// [`CANCEL_GRACE`] loses the connection, which stops the task too (ErrorStatus 41802),
    /// so a robot that never answers cannot keep the next task from starting.
    async fn task_answer<T: Transport>(
        &self,
        conn: &mut Connection<T>,
        id: u32,
        message_id: u16,
    ) -> Result<Response, ClientError> {
        loop {
            if !self.panel(|p| p.control().task_running(id)) {
                return match with_timeout(CANCEL_GRACE, conn.answer(message_id)).await {
                    Ok(end) => end,
                    Err(_) => {
                        warn!("no answer to the cancelled task: closing its connection");
                        conn.disconnect().await;
                        Err(ClientError::Timeout)
                    }
                };
            }
            if let Either::First(end) =
                select(conn.answer(message_id), self.wake_tasks.wait()).await
            {
                return end;
            }
        }
    }

    /// Reports the end of task `id`.
    fn task_ended(&self, id: u32, end: Result<&NavResult, &ClientError>) {
        self.panel(|p| p.task_ended(id, end, Instant::now()));
        self.wake_polls.signal(());
        self.wake_leds.signal(());
    }

    /// Publishes the LED states whenever they change, on their own schedule.
    async fn led_loop(&self) -> ! {
        let mut shown = None;
        loop {
            let now = Instant::now();
            let (indicators, next) = self.panel(|p| {
                p.network(self.shared.network());
                p.settings_lost(self.shared.settings_lost.load(Ordering::Relaxed));
                (p.indicators(now), p.indicators_deadline(now))
            });
            self.publish_snapshot(now);
            if shown != Some(indicators) {
                shown = Some(indicators);
                self.shared.indicators.signal(indicators);
            }
            let deadline = next.map_or(now + LED_REFRESH, |at| at.min(now + LED_REFRESH));
            select(self.wake_leds.wait(), Timer::at(deadline)).await;
        }
    }

    /// Publishes what the console sees of the panel at `now`.
    fn publish_snapshot(&self, now: Instant) {
        let snapshot = self.panel(|p| Snapshot {
            link: p.link_state(),
            robot: self.robot.get().robot,
            status: p.view().last_status().copied(),
            battery: p.view().last_battery().copied(),
            perception: p.view().last_perception().copied(),
            motors: p.view().last_motor_temperatures().copied(),
            nav: p.view().last_nav_state().copied(),
            polls: p.view().polls(),
            faults: Faults::of(p.view(), now),
            leds: p.indicators(now),
            command_failed: p.control().last_failed(),
            busy: p.busy(),
            board_address: self.shared.board_address(),
            at: now,
        });
        self.shared.snapshot.lock(|cell| cell.set(Some(snapshot)));
    }

    /// Takes in settings saved on the console.
    async fn settings_loop(&self) -> ! {
        loop {
            let config = self.shared.settings.wait().await;
            self.take_in_settings(&config);
        }
    }

    /// Puts saved settings in effect: the panel's, a new robot address (every connection
    /// follows it), and the loops woken to act on them.
    fn take_in_settings(&self, config: &Config) {
        self.panel(|p| p.reconfigure(config));
        let target = self.robot.get();
        if config.robot != target.robot {
            let [a, b, c, d] = config.robot.ip;
            info!(
                "settings: the robot is now {}.{}.{}.{}:{}; reconnecting",
                a, b, c, d, config.robot.port
            );
            self.robot.set(Target {
                robot: config.robot,
                moves: target.moves.wrapping_add(1),
            });
        }
        self.wake_commands.signal(());
        self.wake_polls.signal(());
        self.wake_tasks.signal(());
        self.wake_leds.signal(());
    }
}

/// When a connection last opened, and when it last opened or was answered.
#[derive(Clone, Copy)]
struct Heard {
    /// When it last opened.
    opened: Option<Instant>,
    /// When it last opened or was answered.
    heard: Option<Instant>,
}

impl Heard {
    /// Never opened.
    const NEVER: Self = Self {
        opened: None,
        heard: None,
    };
}

/// Whether `sent` is a soft e-stop or a zero velocity (Type 2, Command 13 or 6).
fn is_stop(sent: &Sent) -> bool {
    use MotionCommandCode::{SoftEmergencyStop, ZeroVelocity};
    sent.message_type == MessageType::Motion
        && (sent.command == SoftEmergencyStop.raw() || sent.command == ZeroVelocity.raw())
}

/// The earlier of two moments, either of which may be missing.
fn earliest(a: Option<Instant>, b: Option<Instant>) -> Option<Instant> {
    a.into_iter().chain(b).min()
}

/// The polls the command connection carries ([`PollRoute::Commands`]).
#[derive(Default)]
struct CarriedPolls {
    /// The poll written and not answered yet: one at a time.
    in_flight: Option<CarriedPoll>,
    /// Whether the robot answered anything on the command connection since the polls
    /// moved there.
    answered: bool,
}

/// A poll written on the command connection.
#[derive(Clone, Copy)]
struct CarriedPoll {
    /// Its message ID.
    id: u16,
    /// Its Type.
    poll: MessageType,
    /// When it was written.
    sent: Instant,
}

impl CarriedPolls {
    /// The Type of the poll in flight, if message `id` is it.
    fn take(&mut self, id: u16) -> Option<MessageType> {
        self.in_flight
            .take_if(|carried| carried.id == id)
            .map(|carried| carried.poll)
    }

    /// The Type of the poll in flight if it has waited [`ANSWER_OVERDUE`] at `now`; it is
    /// then no longer in flight.
    fn overdue(&mut self, now: Instant) -> Option<MessageType> {
        self.in_flight
            .take_if(|carried| now.saturating_duration_since(carried.sent) >= ANSWER_OVERDUE)
            .map(|carried| carried.poll)
    }
}

/// The connection state for the robot's health on it.
fn state_of(health: Health) -> ConnectionState {
    match health {
        Health::Answering => ConnectionState::Open,
        Health::Overdue | Health::Silent => ConnectionState::NotAnswering,
    }
}
