//! Build-time configuration: every setting a field engineer may change, in one place.
//!
//! Each setting has a default, and an environment variable that overrides it when the
//! firmware is built, for example
//!
//! ```text
//! X30_ROBOT=10.0.0.2:30000 X30_SPEED_FORWARD=0.8 X30_DHCP=0 X30_IP=10.0.0.50/24 cargo build --release
//! ```
//!
//! The variables are captured with `option_env!` (Cargo rebuilds when one changes) and parsed
//! once at start-up by [`Config::from_build_env`]. Parsing never fails the build or panics: a
//! variable whose text is not valid leaves its default in place and is listed by
//! [`Config::problems`], so the firmware can log it. Whitespace around a value is ignored.
//!
//! | variable | default | meaning |
//! |---|---|---|
//! | `X30_ROBOT` | `192.168.1.106:30000` | the robot's `robot_server`: `a.b.c.d` or `a.b.c.d:port` |
//! | `X30_DHCP` | `1` | `1` (also `true`, `yes`, `on`): the board's address by DHCP; `0` (`false`, `no`, `off`): the static `X30_IP` |
//! | `X30_IP` | — | static address and prefix length, `a.b.c.d/len`; read only with `X30_DHCP=0`, which falls back to DHCP without it |
//! | `X30_GATEWAY` | none | static default gateway `a.b.c.d`; read only with `X30_DHCP=0` |
//! | `X30_SPEED_FORWARD` | `-1` | speed of the `forward` button, m/s, 0..=1.5; `-1` or `default`: the robot's default (0.5) |
//! | `X30_SPEED_BACKWARD` | `-1` | `backward`, m/s, 0..=1.3 (robot default 0.5) |
//! | `X30_SPEED_TURN_LEFT` | `-1` | `turn-left`, rad/s, 0..=0.45 (robot default 0.35) |
//! | `X30_SPEED_TURN_RIGHT` | `-1` | `turn-right`, rad/s, 0..=0.45 (robot default 0.35) |
//! | `X30_SPEED_STRAFE_LEFT` | `-1` | `strafe-left`, m/s, 0..=0.15 (robot default 0.1) |
//! | `X30_SPEED_STRAFE_RIGHT` | `-1` | `strafe-right`, m/s, 0..=0.15 (robot default 0.1) |
//! | `X30_LIGHTS` | `000000:0,00FF00:100,FFBF00:100,FF0000:100:breathing` | presets the `light` button cycles through, comma-separated, at most [`MAX_LIGHT_PRESETS`]: `RRGGBB:brightness%`, optionally `:breathing` or `:steady` (the default) |
//! | `X30_DOCK` | none | the charging point `dock` navigates to: `point,map,x,y,z,yaw` (point number, map number, metres, radians); without it `dock` only blinks the fault LED, since no default point is safe to walk to |
//! | `X30_POLL_STATUS_MS` | `500` | period of the status (1002) and perception (2002) polls, 100..=60000 ms |
//! | `X30_POLL_BATTERY_MS` | `5000` | period of the battery (2001) poll, 100..=600000 ms |
//! | `X30_POLL_MOTORS_MS` | `10000` | period of the motor-temperature (1008) poll, 100..=600000 ms |
//! | `X30_POLL_NAV_MS` | `1000` | period of the navigation-status (1007) poll while a task runs, 100..=60000 ms |
//! | `X30_REPEAT_MS` | `250` | repeat period of a held motion button, 200..=333 ms (the robot needs 3–5 Hz) |
//! | `X30_DEBOUNCE_MS` | `15` | how long a button's level must be stable to count, 1..=100 ms |
//! | `X30_ESTOP_WIRING` | `no` | how the `estop` switch is wired: `no` normally open (closes to GND when pressed), `nc` normally closed (opens when pressed, so a broken wire reads as pressed) |
//!
//! The parsing functions are public so that host tests (and host programs that take these
//! settings at run time) use exactly the code the firmware uses.

use embassy_time::Duration;

use crate::proto::codes::{LightEffect, PointInfo};
use crate::proto::message::{Direction, Light, MotionCommand, NavPoint, Speed};
use crate::proto::xml::number::{parse_f32, parse_int};

/// The robot's default `robot_server` address (docs/protocol.md, "Transport").
pub const DEFAULT_ROBOT: RobotAddress = RobotAddress {
    ip: [192, 168, 1, 106],
    port: DEFAULT_PORT,
};

/// The robot's default `robot_server` TCP port, used when `X30_ROBOT` names no port.
pub const DEFAULT_PORT: u16 = 30000;

/// Most light presets the `light` button can cycle through.
pub const MAX_LIGHT_PRESETS: usize = 8;

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

/// Where the robot's `robot_server` listens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RobotAddress {
    /// IPv4 address.
    pub ip: [u8; 4],
    /// TCP port.
    pub port: u16,
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

/// How the `estop` switch is wired to its input, which has a pull-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EstopWiring {
    /// Normally open: pressing connects the input to GND. A broken wire reads as released.
    NormallyOpen,
    /// Normally closed: the switch holds the input at GND and pressing opens it. A broken
    /// wire reads as pressed, which is why safety wiring uses it.
    NormallyClosed,
}

impl EstopWiring {
    /// Parses `no` (normally open) or `nc` (normally closed), any case.
    pub fn parse(text: &str) -> Option<Self> {
        if text.eq_ignore_ascii_case("no") {
            Some(Self::NormallyOpen)
        } else if text.eq_ignore_ascii_case("nc") {
            Some(Self::NormallyClosed)
        } else {
            None
        }
    }

    /// Whether the switch is pressed when its input reads `low` (at GND).
    pub const fn pressed(self, low: bool) -> bool {
        match self {
            Self::NormallyOpen => low,
            Self::NormallyClosed => !low,
        }
    }
}

/// Every setting of the panel.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// The robot's `robot_server`.
    pub robot: RobotAddress,
    /// The board's own address.
    pub network: Network,
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
    pub estop_wiring: EstopWiring,
    /// Variables whose text was not valid.
    problems: Problems,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            robot: DEFAULT_ROBOT,
            network: Network::Dhcp,
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
            estop_wiring: EstopWiring::NormallyOpen,
            problems: Problems(0),
        }
    }
}

impl Config {
    /// The configuration this firmware was built with: the defaults, overridden by the
    /// `X30_*` variables set at build time.
    pub fn from_build_env() -> Self {
        Self::from_vars(Variable::build_value)
    }

    /// The defaults, overridden by whatever `lookup` returns for each variable; `None` keeps
    /// the default. Host programs pass their run-time environment here.
    pub fn from_vars<'a>(lookup: impl Fn(Variable) -> Option<&'a str>) -> Self {
        let d = Self::default();
        let mut r = Reader {
            lookup,
            problems: Problems(0),
        };
        let robot = r.get(Variable::Robot, parse_robot).unwrap_or(d.robot);
        let network = if r.get(Variable::Dhcp, parse_bool).unwrap_or(true) {
            Network::Dhcp
        } else if let Some((address, prefix_len)) = r.get(Variable::Ip, parse_cidr) {
            Network::Static(StaticNetwork {
                address,
                prefix_len,
                gateway: r.get(Variable::Gateway, parse_ipv4),
            })
        } else {
            // Static without an address is unusable; DHCP at least may work.
            r.problems.add(Variable::Ip);
            Network::Dhcp
        };
        let mut speeds = d.speeds;
        for direction in Direction::ALL {
            let speed = r.speed(direction, d.speeds.get(direction));
            speeds.set(direction, speed);
        }
        let p = d.polls;
        let polls = PollPeriods {
            status: r.millis(Variable::PollStatus, 100, 60_000, p.status),
            battery: r.millis(Variable::PollBattery, 100, 600_000, p.battery),
            motor_temperatures: r.millis(Variable::PollMotors, 100, 600_000, p.motor_temperatures),
            nav_status: r.millis(Variable::PollNav, 100, 60_000, p.nav_status),
        };
        Self {
            robot,
            network,
            speeds,
            lights: r.get(Variable::Lights, parse_lights).unwrap_or(d.lights),
            dock: r.get(Variable::Dock, parse_dock).or(d.dock),
            polls,
            // 200..=333 ms is 3–5 Hz, the rate the robot requires (docs/protocol.md, "Type 2:
            // motion control").
            motion_repeat: r.millis(Variable::Repeat, 200, 333, d.motion_repeat),
            debounce: r.millis(Variable::Debounce, 1, 100, d.debounce),
            estop_wiring: r
                .get(Variable::EstopWiring, EstopWiring::parse)
                .unwrap_or(d.estop_wiring),
            problems: r.problems,
        }
    }

    /// The variables whose text was not valid and whose defaults are in use instead.
    pub fn problems(&self) -> impl Iterator<Item = Variable> + '_ {
        Variable::ALL
            .iter()
            .copied()
            .filter(|&v| self.problems.contains(v))
    }
}

/// Looks up variables and notes the ones that do not parse.
struct Reader<F> {
    /// Where variable text comes from.
    lookup: F,
    /// Variables found invalid so far.
    problems: Problems,
}

impl<'a, F: Fn(Variable) -> Option<&'a str>> Reader<F> {
    /// The parsed value of `variable`; `None` if it is unset or (noted) invalid.
    fn get<T>(
        &mut self,
        variable: Variable,
        parse: impl FnOnce(&'a str) -> Option<T>,
    ) -> Option<T> {
        let value = parse((self.lookup)(variable)?.trim());
        if value.is_none() {
            self.problems.add(variable);
        }
        value
    }

    /// A motion button's speed, checked against its direction's limits.
    fn speed(&mut self, direction: Direction, default: Speed) -> Speed {
        self.get(Variable::speed(direction), |text| {
            parse_speed(text, direction)
        })
        .unwrap_or(default)
    }

    /// A period in milliseconds within `min..=max`.
    fn millis(&mut self, variable: Variable, min: u32, max: u32, default: Duration) -> Duration {
        self.get(variable, |text| parse_millis(text, min, max))
            .unwrap_or(default)
    }
}

/// A set of [`Variable`]s, one bit each.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct Problems(u32);

// One bit per variable must fit.
const _: () = assert!(Variable::ALL.len() <= 32);

impl Problems {
    /// Adds a variable to the set.
    fn add(&mut self, variable: Variable) {
        self.0 |= 1 << variable as u32;
    }

    /// Whether a variable is in the set.
    fn contains(self, variable: Variable) -> bool {
        self.0 & (1 << variable as u32) != 0
    }
}

/// Declares the variables once: the enum, its list, names and build-time values stay in step.
macro_rules! variables {
    ($($(#[doc = $doc:literal])* $variant:ident = $name:literal,)+) => {
        /// An environment variable that overrides a setting at build time.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum Variable {
            $($(#[doc = $doc])* $variant,)+
        }

        impl Variable {
            /// Every variable, in the order of the table in the module docs.
            pub const ALL: &'static [Variable] = &[$(Self::$variant,)+];

            /// The variable's name, such as `X30_ROBOT`.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $name,)+
                }
            }

            /// The variable's value when the firmware was built, if it was set.
            pub fn build_value(self) -> Option<&'static str> {
                match self {
                    $(Self::$variant => option_env!($name),)+
                }
            }
        }
    };
}

variables! {
    /// `X30_ROBOT`: the robot's address.
    Robot = "X30_ROBOT",
    /// `X30_DHCP`: DHCP or a static address.
    Dhcp = "X30_DHCP",
    /// `X30_IP`: static address and prefix length.
    Ip = "X30_IP",
    /// `X30_GATEWAY`: static default gateway.
    Gateway = "X30_GATEWAY",
    /// `X30_SPEED_FORWARD`: speed of `forward`.
    SpeedForward = "X30_SPEED_FORWARD",
    /// `X30_SPEED_BACKWARD`: speed of `backward`.
    SpeedBackward = "X30_SPEED_BACKWARD",
    /// `X30_SPEED_TURN_LEFT`: speed of `turn-left`.
    SpeedTurnLeft = "X30_SPEED_TURN_LEFT",
    /// `X30_SPEED_TURN_RIGHT`: speed of `turn-right`.
    SpeedTurnRight = "X30_SPEED_TURN_RIGHT",
    /// `X30_SPEED_STRAFE_LEFT`: speed of `strafe-left`.
    SpeedStrafeLeft = "X30_SPEED_STRAFE_LEFT",
    /// `X30_SPEED_STRAFE_RIGHT`: speed of `strafe-right`.
    SpeedStrafeRight = "X30_SPEED_STRAFE_RIGHT",
    /// `X30_LIGHTS`: light presets.
    Lights = "X30_LIGHTS",
    /// `X30_DOCK`: the charging point.
    Dock = "X30_DOCK",
    /// `X30_POLL_STATUS_MS`: status and perception poll period.
    PollStatus = "X30_POLL_STATUS_MS",
    /// `X30_POLL_BATTERY_MS`: battery poll period.
    PollBattery = "X30_POLL_BATTERY_MS",
    /// `X30_POLL_MOTORS_MS`: motor-temperature poll period.
    PollMotors = "X30_POLL_MOTORS_MS",
    /// `X30_POLL_NAV_MS`: navigation-status poll period.
    PollNav = "X30_POLL_NAV_MS",
    /// `X30_REPEAT_MS`: motion repeat period.
    Repeat = "X30_REPEAT_MS",
    /// `X30_DEBOUNCE_MS`: button debounce time.
    Debounce = "X30_DEBOUNCE_MS",
    /// `X30_ESTOP_WIRING`: normally-open or normally-closed e-stop switch.
    EstopWiring = "X30_ESTOP_WIRING",
}

impl Variable {
    /// The variable holding the speed of `direction`, such as `X30_SPEED_TURN_LEFT`.
    pub const fn speed(direction: Direction) -> Self {
        match direction {
            Direction::Forward => Self::SpeedForward,
            Direction::Backward => Self::SpeedBackward,
            Direction::TurnLeft => Self::SpeedTurnLeft,
            Direction::TurnRight => Self::SpeedTurnRight,
            Direction::StrafeLeft => Self::SpeedStrafeLeft,
            Direction::StrafeRight => Self::SpeedStrafeRight,
        }
    }
}

/// An unsigned decimal of plain digits (no sign, unlike the protocol's integers).
fn unsigned<T: TryFrom<i64>>(text: &str) -> Option<T> {
    if text.is_empty() || !text.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    parse_int(text.as_bytes()).ok()
}

/// Parses a dotted-quad IPv4 address, `a.b.c.d`.
pub fn parse_ipv4(text: &str) -> Option<[u8; 4]> {
    let mut parts = text.split('.');
    let mut ip = [0u8; 4];
    for octet in &mut ip {
        *octet = unsigned(parts.next()?)?;
    }
    parts.next().is_none().then_some(ip)
}

/// Parses the robot's address, `a.b.c.d` (port 30000) or `a.b.c.d:port` (port 1..=65535).
pub fn parse_robot(text: &str) -> Option<RobotAddress> {
    let (ip, port) = match text.split_once(':') {
        Some((ip, port)) => (ip, unsigned(port).filter(|&p| p != 0)?),
        None => (text, DEFAULT_PORT),
    };
    Some(RobotAddress {
        ip: parse_ipv4(ip)?,
        port,
    })
}

/// Parses an address with its prefix length, `a.b.c.d/len` (len 0..=32).
pub fn parse_cidr(text: &str) -> Option<([u8; 4], u8)> {
    let (ip, prefix) = text.split_once('/')?;
    let prefix = unsigned(prefix).filter(|&p| p <= 32)?;
    Some((parse_ipv4(ip)?, prefix))
}

/// Parses a switch: `1`, `true`, `yes`, `on` or `0`, `false`, `no`, `off`, any case.
pub fn parse_bool(text: &str) -> Option<bool> {
    let is = |words: [&str; 4]| words.iter().any(|w| w.eq_ignore_ascii_case(text));
    if is(["1", "true", "yes", "on"]) {
        Some(true)
    } else if is(["0", "false", "no", "off"]) {
        Some(false)
    } else {
        None
    }
}

/// Parses a motion button's speed: `-1` or `default` for the robot's default, otherwise a
/// decimal the document allows for `direction` (for example 0..=1.5 for forward).
pub fn parse_speed(text: &str, direction: Direction) -> Option<Speed> {
    let speed = if text.eq_ignore_ascii_case("default") {
        Speed::Default
    } else {
        Speed::from_wire(parse_f32(text.as_bytes()).ok()?)
    };
    MotionCommand::Move(direction, speed)
        .validate()
        .ok()
        .map(|()| speed)
}

/// Parses a whole number of milliseconds within `min..=max`.
pub fn parse_millis(text: &str, min: u32, max: u32) -> Option<Duration> {
    let ms: u32 = unsigned(text).filter(|ms| (min..=max).contains(ms))?;
    Duration::try_from_millis(ms.into())
}

/// Parses one light preset, `RRGGBB:brightness` with an optional `:breathing` or `:steady`.
pub fn parse_light(text: &str) -> Option<Light> {
    let mut parts = text.split(':');
    let rgb = parts.next()?.trim();
    let brightness = unsigned(parts.next()?.trim())?;
    let effect = match parts.next().map(str::trim) {
        None => LightEffect::Steady,
        Some(e) if e.eq_ignore_ascii_case("steady") => LightEffect::Steady,
        Some(e) if e.eq_ignore_ascii_case("breathing") => LightEffect::Breathing,
        Some(_) => return None,
    };
    if parts.next().is_some() || rgb.len() != 6 {
        return None;
    }
    // `get` rather than slicing: a non-ASCII character must not panic on a char boundary.
    let byte = |i: usize| u8::from_str_radix(rgb.get(i..i + 2)?, 16).ok();
    let light = light(byte(0)?, byte(2)?, byte(4)?, effect, brightness);
    light.validate().ok().map(|()| light)
}

/// Parses the light presets: one or more [`parse_light`] presets separated by commas.
pub fn parse_lights(text: &str) -> Option<LightPresets> {
    let mut lights = LightPresets::new();
    for preset in text.split(',') {
        lights.push(parse_light(preset.trim())?).ok()?;
    }
    Some(lights)
}

/// Parses the dock point, `point,map,x,y,z,yaw`: point and map numbers, then the charging
/// point's position (m) and heading (rad) in the map frame.
pub fn parse_dock(text: &str) -> Option<NavPoint> {
    let mut fields = text.split(',').map(str::trim);
    let mut int = || parse_int::<i32>(fields.next()?.as_bytes()).ok();
    let (value, map) = (int()?, int()?);
    let mut float = || parse_f32(fields.next()?.as_bytes()).ok();
    let (x, y, z, yaw) = (float()?, float()?, float()?, float()?);
    if fields.next().is_some() {
        return None;
    }
    let point = NavPoint::new(value, map, x, y, z, yaw, PointInfo::Charging);
    point.validate().ok().map(|()| point)
}
