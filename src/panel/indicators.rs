//! The three LEDs, derived from what the panel knows (docs/design.md, "Indicators").
//!
//! Every LED state is a pure function of the link state, the [`RobotView`], the last command
//! and the time, so the application recomputes them whenever anything changed and sets the
//! LEDs that differ; nothing here remembers a previous state.
//!
//! - **link** (green): off without a network, blinking while connecting to the robot,
//!   blinking fast while connected but the robot does not answer (answers overdue, or no
//!   fresh status), on when connected and answering.
//! - **activity** (blue): on for [`FLASH`] after each command, steady while a navigation task
//!   runs, blinking while a patrol runs.
//! - **fault** (red): on while the robot reports a [`Fault`]; otherwise blinking when the
//!   status cannot be read although connected, when the last command failed, or while the
//!   saved settings could not be read (the defaults are in use).

use embassy_time::{Duration, Instant};

use super::monitor::RobotView;
use crate::proto::codes::{Location, MotionState, MotorState, ProtectedState};
use crate::proto::message::RobotStatus;

/// How long the activity LED lights for one command: long enough to see.
pub const FLASH: Duration = Duration::from_millis(50);

/// Battery charge (`Electricity`, %) at or below which the fault LED lights.
pub const LOW_BATTERY_PERCENT: i32 = 20;

/// Half the period of a blinking LED: on this long, then off this long (2 Hz).
pub const BLINK_HALF_PERIOD: Duration = Duration::from_millis(250);

/// Half the period of a fast-blinking LED (8 Hz): clearly not the 2 Hz blink.
pub const FAST_BLINK_HALF_PERIOD: Duration = Duration::from_millis(62);

/// What one LED shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Led {
    /// Dark.
    Off,
    /// Lit.
    On,
    /// Blinking at 2 Hz.
    Blink,
    /// Blinking at 8 Hz.
    BlinkFast,
}

impl Led {
    /// Every state an LED can show.
    pub const ALL: [Led; 4] = [Self::Off, Self::On, Self::Blink, Self::BlinkFast];

    /// `off`, `on`, `blink` or `blink-fast`, as the virtual panel logs it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::On => "on",
            Self::Blink => "blink",
            Self::BlinkFast => "blink-fast",
        }
    }

    /// Whether the LED is lit at `now`; a blinking LED is lit in the first half of each period.
    pub fn is_lit(self, now: Instant) -> bool {
        match self {
            Self::Off => false,
            Self::On => true,
            Self::Blink => lit_half(BLINK_HALF_PERIOD, now),
            Self::BlinkFast => lit_half(FAST_BLINK_HALF_PERIOD, now),
        }
    }
}

/// Whether `now` falls in the lit half of a blink whose halves last `half`.
fn lit_half(half: Duration, now: Instant) -> bool {
    (now.as_ticks() / half.as_ticks().max(1)).is_multiple_of(2)
}

/// How far the connection to the robot is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkState {
    /// The board has no network (no link, or no address yet).
    NoNetwork,
    /// The board has a network and is connecting to the robot.
    Connecting,
    /// Connected, but the robot's answers are overdue: it may have gone silent.
    NotAnswering,
    /// Connected to the robot.
    Connected,
}

/// Something wrong with the robot that lights the fault LED.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Fault {
    /// MotionState 7: the robot has fallen.
    Fallen,
    /// MotionState 6: soft emergency stop.
    SoftEmergencyStop,
    /// MotorState 1: motor over-temperature.
    MotorOverTemperature,
    /// Location 1: localisation lost.
    LocalisationLost,
    /// Electricity at or below [`LOW_BATTERY_PERCENT`].
    BatteryLow,
    /// ProtectedState 1 in the battery answer: the battery's protection has triggered.
    BatteryProtection,
}

impl Fault {
    /// Every fault, most severe first.
    pub const ALL: [Fault; 6] = [
        Self::Fallen,
        Self::SoftEmergencyStop,
        Self::MotorOverTemperature,
        Self::LocalisationLost,
        Self::BatteryLow,
        Self::BatteryProtection,
    ];

    /// Short English description, for the log.
    pub const fn description(self) -> &'static str {
        match self {
            Self::Fallen => "fallen",
            Self::SoftEmergencyStop => "soft emergency stop",
            Self::MotorOverTemperature => "motor over-temperature",
            Self::LocalisationLost => "localisation lost",
            Self::BatteryLow => "battery low",
            Self::BatteryProtection => "battery protection triggered",
        }
    }
}

/// A set of faults.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Faults(u8);

impl Faults {
    /// The faults the robot reports in fresh answers at `now`.
    pub fn of(view: &RobotView, now: Instant) -> Self {
        Self(faults(view, now).fold(0, |set, fault| set | 1 << fault as u8))
    }

    /// The faults of the set, most severe first.
    pub fn iter(self) -> impl Iterator<Item = Fault> {
        Fault::ALL
            .into_iter()
            .filter(move |&fault| self.0 & 1 << fault as u8 != 0)
    }
}

/// The first fault the robot reports in fresh answers at `now`, most severe first.
pub fn fault(view: &RobotView, now: Instant) -> Option<Fault> {
    faults(view, now).next()
}

/// Every fault the robot reports in fresh answers at `now`, most severe first.
pub fn faults(view: &RobotView, now: Instant) -> impl Iterator<Item = Fault> {
    let status = view.status(now);
    let from_status =
        |active: fn(&RobotStatus) -> bool, fault| status.filter(|s| active(s)).map(|_| fault);
    let protection = view
        .battery(now)
        .filter(|b| b.protected_state == Some(ProtectedState::Triggered))
        .map(|_| Fault::BatteryProtection);
    [
        from_status(|s| s.motion_state == MotionState::Fallen, Fault::Fallen),
        from_status(
            |s| s.motion_state == MotionState::SoftEmergencyStop,
            Fault::SoftEmergencyStop,
        ),
        from_status(
            |s| s.motor_state == Some(MotorState::OverTemperature),
            Fault::MotorOverTemperature,
        ),
        from_status(
            |s| s.location == Some(Location::Lost),
            Fault::LocalisationLost,
        ),
        from_status(
            |s| {
                s.electricity
                    .is_some_and(|level| level <= LOW_BATTERY_PERCENT)
            },
            Fault::BatteryLow,
        ),
        protection,
    ]
    .into_iter()
    .flatten()
}

/// The link LED.
pub fn link_led(link: LinkState, view: &RobotView, now: Instant) -> Led {
    match link {
        LinkState::NoNetwork => Led::Off,
        LinkState::Connecting => Led::Blink,
        // Connected with no fresh status is a robot that does not answer its polls.
        LinkState::Connected if view.status_fresh(now) => Led::On,
        LinkState::Connected | LinkState::NotAnswering => Led::BlinkFast,
    }
}

/// What the panel's navigation is doing, for the activity LED.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Navigation {
    /// No task.
    Idle,
    /// A task (`dock`) runs or is about to.
    Task,
    /// A patrol runs.
    Patrol,
}

/// The activity LED: blinking through a patrol, steady through a task, else a flash per
/// command.
pub fn activity_led(navigation: Navigation, last_sent: Option<Instant>, now: Instant) -> Led {
    let flashing =
        last_sent.is_some_and(|at| at <= now && now.saturating_duration_since(at) < FLASH);
    match navigation {
        Navigation::Patrol => Led::Blink,
        Navigation::Task => Led::On,
        Navigation::Idle if flashing => Led::On,
        Navigation::Idle => Led::Off,
    }
}

/// The fault LED.
pub fn fault_led(link: LinkState, view: &RobotView, panel_failure: bool, now: Instant) -> Led {
    // Without a connection the link LED already says why nothing can be read.
    let unreadable = matches!(link, LinkState::Connected | LinkState::NotAnswering)
        && !view.status_readable(now);
    if fault(view, now).is_some() {
        Led::On
    } else if unreadable || panel_failure {
        Led::Blink
    } else {
        Led::Off
    }
}

/// Everything the LEDs depend on besides the time.
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    /// How far the connection to the robot is.
    pub link: LinkState,
    /// The robot's latest answers.
    pub view: &'a RobotView,
    /// What the navigation is doing.
    pub navigation: Navigation,
    /// When the last command was sent.
    pub last_sent: Option<Instant>,
    /// Whether the panel has a failure to show: the last command failed, or the saved
    /// settings could not be read.
    pub panel_failure: bool,
}

/// The state of the three LEDs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Indicators {
    /// Green: the link to the robot.
    pub link: Led,
    /// Blue: commands and navigation.
    pub activity: Led,
    /// Red: faults.
    pub fault: Led,
}

impl Indicators {
    /// The LEDs for `inputs` at `now`.
    pub fn derive(inputs: &Inputs<'_>, now: Instant) -> Self {
        Self {
            link: link_led(inputs.link, inputs.view, now),
            activity: activity_led(inputs.navigation, inputs.last_sent, now),
            fault: fault_led(inputs.link, inputs.view, inputs.panel_failure, now),
        }
    }

    /// When the LEDs may next change without any new input: the end of an activity flash or
    /// the moment the status goes stale, whichever comes first after `now`.
    pub fn next_change(inputs: &Inputs<'_>, now: Instant) -> Option<Instant> {
        let flash_end = inputs
            .last_sent
            .map(|at| at.saturating_add(FLASH))
            .filter(|&end| end > now);
        [flash_end, inputs.view.status_stale_at(now)]
            .into_iter()
            .flatten()
            .min()
    }
}
