//! The panel's buttons and their debouncing.
//!
//! A mechanical contact bounces for a few milliseconds when it closes or opens. The
//! [`Debouncer`] reports a new level only after the raw level has stayed the same for the
//! debounce time, so one press is one event however often the contact chattered.

use embassy_time::{Duration, Instant};

use crate::config::MotionSpeeds;
use crate::proto::message::{Direction, MotionCommand};

/// How many buttons the panel has.
pub const BUTTON_COUNT: usize = 15;

/// A button of the panel, in the order of docs/design.md, "Panel behaviour".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Button {
    /// Walk forwards while held (Type 2 Command 1).
    Forward,
    /// Walk backwards while held (Command 2).
    Backward,
    /// Turn left while held (Command 3).
    TurnLeft,
    /// Turn right while held (Command 4).
    TurnRight,
    /// Strafe left while held (Command 11).
    StrafeLeft,
    /// Strafe right while held (Command 12).
    StrafeRight,
    /// Zero velocity (Command 6).
    Stop,
    /// Soft emergency stop (Command 13); locks motion out.
    Estop,
    /// Stop stepping (Command 14).
    StopStepping,
    /// Lie down (Command 15).
    LieDown,
    /// Next gait (Command 20).
    Gait,
    /// Next light preset (Type 1101).
    Light,
    /// Navigate to the charging point (Type 1003).
    Dock,
    /// Cancel the navigation task (Type 1004).
    Cancel,
    /// Walk the saved route, point after point (a 1003 each).
    Patrol,
}

impl Button {
    /// Every button, in the order of docs/design.md, "Panel behaviour".
    pub const ALL: [Button; BUTTON_COUNT] = [
        Self::Forward,
        Self::Backward,
        Self::TurnLeft,
        Self::TurnRight,
        Self::StrafeLeft,
        Self::StrafeRight,
        Self::Stop,
        Self::Estop,
        Self::StopStepping,
        Self::LieDown,
        Self::Gait,
        Self::Light,
        Self::Dock,
        Self::Cancel,
        Self::Patrol,
    ];

    /// The button's name on the virtual panel, such as `turn-left`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Forward => "forward",
            Self::Backward => "backward",
            Self::TurnLeft => "turn-left",
            Self::TurnRight => "turn-right",
            Self::StrafeLeft => "strafe-left",
            Self::StrafeRight => "strafe-right",
            Self::Stop => "stop",
            Self::Estop => "estop",
            Self::StopStepping => "stop-stepping",
            Self::LieDown => "lie-down",
            Self::Gait => "gait",
            Self::Light => "light",
            Self::Dock => "dock",
            Self::Cancel => "cancel",
            Self::Patrol => "patrol",
        }
    }

    /// The button with this virtual-panel name; names are exact (lower case).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|b| b.name() == name)
    }

    /// Whether the button drives the robot while held (the first six).
    pub fn is_motion(self) -> bool {
        self.direction().is_some()
    }

    /// Whether the button only ever stops the robot: `estop`, `stop` and `cancel`.
    pub const fn is_stop(self) -> bool {
        matches!(self, Self::Estop | Self::Stop | Self::Cancel)
    }

    /// The button's position in [`Button::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The direction a motion button moves the robot in; `None` for the other buttons.
    pub fn direction(self) -> Option<Direction> {
        Direction::ALL
            .into_iter()
            .find(|direction| direction.name() == self.name())
    }

    /// The Type 2 command a motion button repeats, at its configured speed; `None` for the
    /// other buttons.
    pub fn motion(self, speeds: &MotionSpeeds) -> Option<MotionCommand> {
        self.direction()
            .map(|direction| MotionCommand::Move(direction, speeds.get(direction)))
    }
}

/// A debounced change of a button, with when it happened: a press is acted on only while
/// it is fresh, never late.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ButtonEvent {
    /// Which button.
    pub button: Button,
    /// Pressed (`true`) or released.
    pub pressed: bool,
    /// When the change was seen (for a debounced input, when its level became stable).
    pub at: Instant,
}

/// Debounces one input: reports a level once it has been stable for the debounce time.
///
/// Feed it the raw level whenever it may have changed (on an edge interrupt, or when
/// polling) and again at [`Debouncer::deadline`], when a pending level becomes stable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Debouncer {
    /// How long the raw level must hold.
    debounce: Duration,
    /// The level last reported (pressed = `true`).
    stable: bool,
    /// The level last seen.
    raw: bool,
    /// When the raw level last changed.
    since: Instant,
}

impl Debouncer {
    /// A debouncer for an input that starts released.
    pub const fn new(debounce: Duration) -> Self {
        Self::starting(debounce, false)
    }

    /// A debouncer for an input whose level at the start is `pressed`: that level is
    /// reported already, so it makes no event.
    pub const fn starting(debounce: Duration, pressed: bool) -> Self {
        Self {
            debounce,
            stable: pressed,
            raw: pressed,
            since: Instant::MIN,
        }
    }

    /// Takes the raw level at `now`; returns the new debounced level if it just changed.
    pub fn sample(&mut self, pressed: bool, now: Instant) -> Option<bool> {
        if pressed != self.raw {
            self.raw = pressed;
            self.since = now;
        }
        // A bounce back to the reported level before the time is up cancels the change.
        if self.raw != self.stable && now.saturating_duration_since(self.since) >= self.debounce {
            self.stable = self.raw;
            return Some(self.stable);
        }
        None
    }

    /// When the pending raw level will have been stable long enough; `None` when the raw
    /// level is the reported one.
    pub fn deadline(&self) -> Option<Instant> {
        (self.raw != self.stable).then(|| self.since.saturating_add(self.debounce))
    }

    /// The debounced level: pressed or not.
    pub fn is_pressed(&self) -> bool {
        self.stable
    }
}

/// One [`Debouncer`] per button.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ButtonDebouncers {
    /// Indexed like [`Button::ALL`].
    pins: [Debouncer; BUTTON_COUNT],
}

impl ButtonDebouncers {
    /// Debouncers for every button, all released.
    pub const fn new(debounce: Duration) -> Self {
        Self {
            pins: [Debouncer::new(debounce); BUTTON_COUNT],
        }
    }

    /// Debouncers for every button at power-up, given which are pressed then (indexed like
    /// [`Button::ALL`]). A button already pressed counts as held from before, not as a
    /// press: it acts only once released and pressed again, so a button stuck or held
    /// through a reset never moves the robot at start-up. The stop buttons
    /// ([`Button::is_stop`]) are the exception: they start released, so one held at
    /// power-up is a press (an e-stop latches), as stopping is always safe.
    pub fn at_power_up(debounce: Duration, pressed: [bool; BUTTON_COUNT]) -> Self {
        let mut pins = [Debouncer::new(debounce); BUTTON_COUNT];
        for ((button, pin), pressed) in Button::ALL.into_iter().zip(&mut pins).zip(pressed) {
            *pin = Debouncer::starting(debounce, pressed && !button.is_stop());
        }
        Self { pins }
    }

    /// Takes a button's raw level at `now`; returns the debounced event if there is one.
    pub fn sample(&mut self, button: Button, pressed: bool, now: Instant) -> Option<ButtonEvent> {
        let pin = self.pins.get_mut(button.index())?;
        let pressed = pin.sample(pressed, now)?;
        Some(ButtonEvent {
            button,
            pressed,
            at: now,
        })
    }

    /// The earliest time a pending level becomes stable, when every button with one must be
    /// sampled again.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.pins.iter().filter_map(Debouncer::deadline).min()
    }

    /// Buttons with a pending level, to sample at [`ButtonDebouncers::next_deadline`].
    pub fn pending(&self) -> impl Iterator<Item = Button> + '_ {
        Button::ALL
            .into_iter()
            .zip(&self.pins)
            .filter(|(_, pin)| pin.deadline().is_some())
            .map(|(button, _)| button)
    }
}
