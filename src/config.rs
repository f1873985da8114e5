//! The panel's configuration: every setting, as the application uses it.
//!
//! A [`Config`] holds typed values. Where they come from is the [`settings`](crate::settings)
//! module's business: build-time `X30_*` variables give the defaults, values saved on the
//! board override them. The keys, their syntax and their limits are listed there
//! ([`Key`](crate::settings::Key)); the firmware's build fails on an invalid variable.

use embassy_time::Duration;

use crate::proto::codes::LightEffect;
use crate::proto::message::{Direction, Light, NavPoint, Speed};
pub use crate::settings::route::Route;
pub use crate::settings::text::{
    Cidr, DEFAULT_PORT, EstopWiring, MAX_LIGHT_PRESETS, RobotAddress, WebPin,
};

/// The robot's default `robot_server` address (docs/protocol.md, "Transport").
pub const DEFAULT_ROBOT: RobotAddress = RobotAddress {
    ip: [192, 168, 1, 106],
    port: DEFAULT_PORT,
};

/// The light presets, in the order the `light` button cycles through them.
pub type LightPresets = heapless::Vec<Light, MAX_LIGHT_PRESETS>;

/// Default light presets: off, green, amber, red breathing.
pub const DEFAULT_LIGHTS: [Light; 4] = [
    light(0, 0, 0, LightEffect::Steady, 0),
    light(0, 255, 0, LightEffect::Steady, 100),
    light(255, 191, 0, LightEffect::Steady, 100),
    light(255, 0, 0, LightEffect::Breathing, 100),
];

/// `Light` in a `const`, where struct literals of another module's type read poorly.
const fn light(red: u8, green: u8, blue: u8, effect: LightEffect, brightness: u8) -> Light {
    Light {
        red,
        green,
        blue,
        effect,
        brightness,
    }
}

/// How the board gets its own network address.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Network {
    /// By DHCP.
    Dhcp,
    /// A fixed address.
    Static(StaticNetwork),
}

/// A fixed IPv4 configuration of the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StaticNetwork {
    /// The board's address.
    pub address: [u8; 4],
    /// Network prefix length, 0..=32.
    pub prefix_len: u8,
    /// Default gateway, if the robot is not on the board's own subnet.
    pub gateway: Option<[u8; 4]>,
}

/// The speed each motion button sends, per [`Direction`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotionSpeeds([Speed; Direction::ALL.len()]);

impl MotionSpeeds {
    /// The robot's default speed in every direction.
    pub const DEFAULT: Self = Self([Speed::Default; Direction::ALL.len()]);

    /// The speed of `direction`.
    pub fn get(&self, direction: Direction) -> Speed {
        self.0
            .get(direction as usize)
            .copied()
            .unwrap_or(Speed::Default)
    }

    /// Sets the speed of `direction`.
    pub fn set(&mut self, direction: Direction, speed: Speed) {
        if let Some(slot) = self.0.get_mut(direction as usize) {
            *slot = speed;
        }
    }
}

/// How often the monitor asks the robot for each kind of state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PollPeriods {
    /// Status (1002) and perception (2002).
    pub status: Duration,
    /// Battery (2001).
    pub battery: Duration,
    /// Motor temperatures (1008).
    pub motor_temperatures: Duration,
    /// Navigation-task status (1007), only while a task runs.
    pub nav_status: Duration,
}

/// Every setting of the panel.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// The robot's `robot_server`.
    pub robot: RobotAddress,
    /// Whether the board takes its address by DHCP rather than `ip`.
    pub dhcp: bool,
    /// The board's static address, used without DHCP.
    pub ip: Option<Cidr>,
    /// The default gateway, used without DHCP, if the robot is not on the board's subnet.
    pub gateway: Option<[u8; 4]>,
    /// Speed per motion button.
    pub speeds: MotionSpeeds,
    /// Presets of the `light` button; never empty.
    pub lights: LightPresets,
    /// The charging point of the `dock` button (PointInfo 3); `None`: not configured.
    pub dock: Option<NavPoint>,
    /// Poll periods of the monitor.
    pub polls: PollPeriods,
    /// Repeat period of a held motion button.
    pub motion_repeat: Duration,
    /// How long a button's level must be stable to count.
    pub debounce: Duration,
    /// How the `estop` switch is wired.
    pub estop_input: EstopWiring,
    /// The web page's PIN for changing settings; `None`: the page is read-only.
    pub web_pin: Option<WebPin>,
    /// The points the `patrol` button walks through; empty: no patrol.
    pub route: Route,
    /// Whether the robot's indicator light shows a confirmed e-stop.
    pub robot_light: bool,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            robot: DEFAULT_ROBOT,
            dhcp: true,
            ip: None,
            gateway: None,
            speeds: MotionSpeeds::DEFAULT,
            lights: LightPresets::from_array(DEFAULT_LIGHTS),
            dock: None,
            polls: PollPeriods {
                status: Duration::from_millis(500),
                battery: Duration::from_secs(5),
                motor_temperatures: Duration::from_secs(10),
                nav_status: Duration::from_secs(1),
            },
            motion_repeat: Duration::from_millis(250),
            debounce: Duration::from_millis(15),
            estop_input: EstopWiring::NormallyOpen,
            web_pin: None,
            route: Route::new(),
            robot_light: false,
        }
    }
}

impl Config {
    /// How the board gets its address: DHCP, or the static `ip` when DHCP is off. DHCP also
    /// when it is off but no address is set, which the settings refuse to save: a board
    /// without an address could never be reached to correct it.
    pub fn network(&self) -> Network {
        match (self.dhcp, self.ip) {
            (false, Some(ip)) => Network::Static(StaticNetwork {
                address: ip.address,
                prefix_len: ip.prefix_len,
                gateway: self.gateway,
            }),
            _ => Network::Dhcp,
        }
    }
}

impl EstopWiring {
    /// Whether the switch is pressed when its input reads `low` (at GND).
    pub const fn pressed(self, low: bool) -> bool {
        match self {
            Self::NormallyOpen => low,
            Self::NormallyClosed => !low,
        }
    }
}
