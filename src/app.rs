//! The application: the panel's logic driving the two client links. Board-agnostic.
//!
//! The board hands over two [`Link`]s (control and navigation) and a [`Shared`] with the
//! button events it produces and the LED states it shows; [`run`] does the rest, forever:
//!
//! - the control loop connects (with backoff), feeds button events, answers and link
//!   changes into the [`Panel`], sends what the panel asks for on the control link —
//!   commands before polls — and publishes the LED states;
//! - the navigation loop waits for a task, sends its 1003 on the navigation link and holds
//!   that connection open until the answer, because the robot stops a task whose client
//!   disconnects (ErrorStatus 41802).
//!
//! Both loops run in one task (`join`), so they share state through `Cell`s and signals
//! without locks.
//!
//! The control loop counts its turns in [`Shared::heartbeat`], so that a board's watchdog can
//! tell a working application from a hung one.

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_futures::join::join;
use embassy_futures::select::{Either3, select3};
use embassy_sync::blocking_mutex::raw::{CriticalSectionRawMutex, NoopRawMutex};
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Instant, Timer};

use crate::client::{ClientError, Link, RobotClock, Transport};
use crate::config::Config;
use crate::panel::{Action, ButtonEvent, Indicators, LinkState, Panel, succeeded};
use crate::proto::message::{NavResult, NavTask, Response};

/// How many button events may wait while a request is in flight.
pub const BUTTON_QUEUE: usize = 16;
/// How long a short request may take before it counts as failed.
pub const REQUEST_TIMEOUT: Duration = Duration::from_millis(1500);
/// Longest sleep of the control loop without an event: keeps it responsive to changes
/// nothing signals.
const IDLE: Duration = Duration::from_millis(500);

/// What the board and the application exchange.
pub struct Shared {
    /// Debounced button events, from the board's button task.
    pub buttons: Channel<CriticalSectionRawMutex, ButtonEvent, BUTTON_QUEUE>,
    /// The latest LED states, for the board's LED task.
    pub indicators: Signal<CriticalSectionRawMutex, Indicators>,
    /// Grows (wrapping) at every turn of the control loop and before every request: a board
    /// may feed its watchdog only while it moves. A turn may take as long as a connection
    /// attempt or a request with its timeout.
    pub heartbeat: AtomicU32,
}

impl Shared {
    /// Nothing pressed, nothing shown yet.
    pub const fn new() -> Self {
        Self {
            buttons: Channel::new(),
            indicators: Signal::new(),
            heartbeat: AtomicU32::new(0),
        }
    }

    /// Shows progress on [`Shared::heartbeat`].
    fn beat(&self) {
        self.heartbeat.fetch_add(1, Ordering::Relaxed);
    }
}

impl Default for Shared {
    fn default() -> Self {
        Self::new()
    }
}

/// Runs the panel against the robot, forever.
pub async fn run<T: Transport>(
    config: &Config,
    control: &mut Link<T>,
    navigation: &mut Link<T>,
    shared: &Shared,
) -> ! {
    let tasks = NavSignals {
        start: Signal::new(),
        end: Signal::new(),
        clock: Cell::new(RobotClock::new()),
    };
    let (never, _) = join(
        control_loop(config, control, shared, &tasks),
        navigation_loop(navigation, &tasks),
    )
    .await;
    never
}

/// How the two loops talk about navigation tasks.
struct NavSignals {
    /// A task for the navigation loop to run.
    start: Signal<NoopRawMutex, NavTask>,
    /// The end of that task: its answer, or why there is none.
    end: Signal<NoopRawMutex, Result<NavResult, ClientError>>,
    /// The robot's clock as the control link learns it, for the navigation link's `Time`.
    clock: Cell<RobotClock>,
}

/// The control link's side: buttons, commands, polls, LEDs.
async fn control_loop<T: Transport>(
    config: &Config,
    link: &mut Link<T>,
    shared: &Shared,
    nav: &NavSignals,
) -> ! {
    let mut panel = Panel::new(config);
    let mut shown = None;
    // When the next connection attempt is due. Kept across wake-ups, so that button presses
    // and idle ticks during an outage do not cut the link's backoff short.
    let mut retry_at = Instant::now();
    panel.link(LinkState::Connecting, Instant::now());
    loop {
        if !link.is_connected() && Instant::now() >= retry_at {
            panel.link(LinkState::Connecting, Instant::now());
            show(&panel, &mut shown, shared);
            match link.connect().await {
                Ok(()) => panel.link(LinkState::Connected, Instant::now()),
                Err(retry_in) => retry_at = Instant::now() + retry_in,
            }
        }
        if link.is_connected() {
            perform_due(&mut panel, link, shared, nav).await;
        }
        show(&panel, &mut shown, shared);
        let now = Instant::now();
        let retry = (!link.is_connected()).then_some(retry_at);
        let deadline = retry
            .into_iter()
            .chain(panel.next_deadline(now))
            .min()
            .unwrap_or(now + IDLE)
            .min(now + IDLE);
        match select3(
            shared.buttons.receive(),
            nav.end.wait(),
            Timer::at(deadline),
        )
        .await
        {
            Either3::First(event) => panel.button(event.button, event.pressed, Instant::now()),
            Either3::Second(end) => navigation_ended(&mut panel, end),
            Either3::Third(()) => {}
        }
        shared.beat();
    }
}

/// Sends everything the panel has due, taking new button events between requests so that
/// an e-stop overtakes queued polls.
async fn perform_due<T: Transport>(
    panel: &mut Panel,
    link: &mut Link<T>,
    shared: &Shared,
    nav: &NavSignals,
) {
    loop {
        shared.beat();
        while let Ok(event) = shared.buttons.try_receive() {
            panel.button(event.button, event.pressed, Instant::now());
        }
        if let Some(end) = nav.end.try_take() {
            navigation_ended(panel, end);
        }
        let Some(action) = panel.next_action(Instant::now()) else {
            return;
        };
        if action.is_command() {
            let request = action.request();
            info!(
                "command: Type {} Command {}",
                request.message_type().raw(),
                request.command()
            );
        }
        let ok = match &action {
            Action::Navigate(task) => {
                nav.start.signal(task.clone());
                panel.navigation(true, Instant::now());
                true
            }
            Action::Send(_) | Action::CancelNavigation => {
                match link.request(&action.request(), Some(REQUEST_TIMEOUT)).await {
                    Ok(response) => {
                        nav.clock.set(link.clock());
                        panel.response(&response, Instant::now());
                        succeeded(&response)
                    }
                    Err(e) => {
                        warn!("request failed: {:?}", e);
                        false
                    }
                }
            }
        };
        panel.sent(&action, ok, Instant::now());
        if !link.is_connected() {
            // Nothing is queued through an outage: the panel drops presses until it is
            // told the link is back.
            panel.link(LinkState::Connecting, Instant::now());
            return;
        }
    }
}

/// The navigation task ended, with its answer or without one.
fn navigation_ended(panel: &mut Panel, end: Result<NavResult, ClientError>) {
    let now = Instant::now();
    match end {
        Ok(result) => panel.response(&Response::NavResult(result), now),
        Err(e) => {
            warn!("navigation task lost: {:?}", e);
            panel.navigation(false, now);
        }
    }
}

/// Publishes the LED states when they changed.
fn show(panel: &Panel, shown: &mut Option<Indicators>, shared: &Shared) {
    let indicators = panel.indicators(Instant::now());
    if *shown != Some(indicators) {
        *shown = Some(indicators);
        shared.indicators.signal(indicators);
    }
}

/// The navigation link's side: one task at a time, its connection held until the answer.
async fn navigation_loop<T: Transport>(link: &mut Link<T>, nav: &NavSignals) -> ! {
    loop {
        let task = nav.start.wait().await;
        link.set_clock(nav.clock.get());
        if !link.is_connected() && link.connect().await.is_err() {
            nav.end.signal(Err(ClientError::NotConnected));
            continue;
        }
        let end = link.navigate(&task, None).await;
        nav.end.signal(end);
    }
}
