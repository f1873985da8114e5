//! The settings' text: every key, the syntax of its value, and the parsers.
//!
//! A field engineer writes a value the same way in a build-time variable
//! (`X30_SPEED_FORWARD=0.8`) and on the console (`set speed-forward 0.8`); the store keeps
//! that text too. This module is plain `core` Rust using only its sibling `number` (the
//! codec's number parser), because the build script includes it as well: an invalid
//! build-time value fails the build with exactly the check the board applies. For the same
//! reason its types' `defmt::Format` impls live in the parent module.

use super::number::{parse_f32, parse_int};

/// The robot's default `robot_server` TCP port, when an address names none.
pub const DEFAULT_PORT: u16 = 30000;

/// Most light presets the `light` button can cycle through.
pub const MAX_LIGHT_PRESETS: usize = 8;

/// Most digits of the web page's PIN.
pub const MAX_PIN_DIGITS: usize = 8;

/// Fewest digits of the web page's PIN: fewer are guessed too soon.
pub const MIN_PIN_DIGITS: usize = 4;

/// The word that clears a setting whose value is optional (`gateway`, `dock`, …).
pub const NONE: &str = "none";

/// The syntax of a key's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Syntax {
    /// `a.b.c.d` or `a.b.c.d:port`.
    Robot,
    /// `1`/`true`/`yes`/`on` or `0`/`false`/`no`/`off`.
    Switch,
    /// `a.b.c.d/len`, or `none`.
    Cidr,
    /// `a.b.c.d`, or `none`.
    Ipv4,
    /// A speed from 0 to `max` (m/s or rad/s), or `-1`/`default` for the robot's own.
    Speed {
        /// The fastest the protocol document allows in this direction.
        max: f32,
    },
    /// Light presets, `RRGGBB:brightness[:breathing|:steady]`, comma-separated.
    Lights,
    /// `point,map,x,y,z,yaw`, or `none`.
    Dock,
    /// Whole milliseconds from `min` to `max`.
    Millis {
        /// Shortest allowed.
        min: u32,
        /// Longest allowed.
        max: u32,
    },
    /// `no` (normally open) or `nc` (normally closed).
    EstopInput,
    /// 4 to 8 digits, or `none`.
    Pin,
}

/// Declares the keys once: the enum, its list, names, variables, stored ids, syntax and
/// help stay in step.
macro_rules! keys {
    ($($(#[doc = $doc:literal])* $variant:ident = $id:literal, $name:literal, $variable:literal,
        $syntax:expr, $allowed:literal;)+) => {
        /// A setting.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
                pub enum Key {
            $($(#[doc = $doc])* $variant,)+
        }

        impl Key {
            /// Every key, in the order `show` lists them.
            pub const ALL: &'static [Key] = &[$(Self::$variant,)+];

            /// The key's name on the console, such as `speed-forward`.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $name,)+
                }
            }

            /// The build-time variable that gives the key's default, such as
            /// `X30_SPEED_FORWARD`.
            pub const fn variable(self) -> &'static str {
                match self {
                    $(Self::$variant => $variable,)+
                }
            }

            /// The key's number in the store; never reused for another key.
            pub const fn id(self) -> u8 {
                match self {
                    $(Self::$variant => $id,)+
                }
            }

            /// The syntax of the key's value.
            pub const fn syntax(self) -> Syntax {
                match self {
                    $(Self::$variant => $syntax,)+
                }
            }

            /// The key's value when the firmware was built, if its variable was set.
            pub const fn build_value(self) -> Option<&'static str> {
                match self {
                    $(Self::$variant => option_env!($variable),)+
                }
            }

            /// What the key's value may be, in words, for error messages and `help`.
            pub const fn allowed(self) -> &'static str {
                match self {
                    $(Self::$variant => $allowed,)+
                }
            }
        }
    };
}

keys! {
    /// The robot's `robot_server`.
    Robot = 1, "robot", "X30_ROBOT", Syntax::Robot,
        "a.b.c.d or a.b.c.d:port (port 30000 if none)";
    /// Whether the board takes its address by DHCP.
    Dhcp = 2, "dhcp", "X30_DHCP", Syntax::Switch,
        "1 (the board's address by DHCP) or 0 (the static `ip`)";
    /// The board's static address, used with `dhcp` 0.
    Ip = 3, "ip", "X30_IP", Syntax::Cidr,
        "a.b.c.d/len, or none";
    /// The default gateway, with `dhcp` 0.
    Gateway = 4, "gateway", "X30_GATEWAY", Syntax::Ipv4,
        "a.b.c.d, or none";
    /// Speed of the `forward` button.
    SpeedForward = 5, "speed-forward", "X30_SPEED_FORWARD", Syntax::Speed { max: 1.5 },
        "m/s from 0 to 1.5, or default (the robot's 0.5)";
    /// Speed of the `backward` button.
    SpeedBackward = 6, "speed-backward", "X30_SPEED_BACKWARD", Syntax::Speed { max: 1.3 },
        "m/s from 0 to 1.3, or default (the robot's 0.5)";
    /// Speed of the `turn-left` button.
    SpeedTurnLeft = 7, "speed-turn-left", "X30_SPEED_TURN_LEFT", Syntax::Speed { max: 0.45 },
        "rad/s from 0 to 0.45, or default (the robot's 0.35)";
    /// Speed of the `turn-right` button.
    SpeedTurnRight = 8, "speed-turn-right", "X30_SPEED_TURN_RIGHT", Syntax::Speed { max: 0.45 },
        "rad/s from 0 to 0.45, or default (the robot's 0.35)";
    /// Speed of the `strafe-left` button.
    SpeedStrafeLeft = 9, "speed-strafe-left", "X30_SPEED_STRAFE_LEFT", Syntax::Speed { max: 0.15 },
        "m/s from 0 to 0.15, or default (the robot's 0.1)";
    /// Speed of the `strafe-right` button.
    SpeedStrafeRight = 10, "speed-strafe-right", "X30_SPEED_STRAFE_RIGHT", Syntax::Speed { max: 0.15 },
        "m/s from 0 to 0.15, or default (the robot's 0.1)";
    /// Presets of the `light` button.
    Lights = 11, "lights", "X30_LIGHTS", Syntax::Lights,
        "1 to 8 presets RRGGBB:brightness (0-100), each optionally :breathing, comma-separated";
    /// The charging point of the `dock` button.
    Dock = 12, "dock", "X30_DOCK", Syntax::Dock,
        "point,map,x,y,z,yaw (numbers, metres, radians), or none";
    /// Period of the status and perception polls.
    PollStatus = 13, "poll-status-ms", "X30_POLL_STATUS_MS", Syntax::Millis { min: 100, max: 60_000 },
        "milliseconds from 100 to 60000";
    /// Period of the battery poll.
    PollBattery = 14, "poll-battery-ms", "X30_POLL_BATTERY_MS", Syntax::Millis { min: 100, max: 600_000 },
        "milliseconds from 100 to 600000";
    /// Period of the motor-temperature poll.
    PollMotors = 15, "poll-motors-ms", "X30_POLL_MOTORS_MS", Syntax::Millis { min: 100, max: 600_000 },
        "milliseconds from 100 to 600000";
    /// Period of the navigation-status poll while a task runs.
    PollNav = 16, "poll-nav-ms", "X30_POLL_NAV_MS", Syntax::Millis { min: 100, max: 60_000 },
        "milliseconds from 100 to 60000";
    /// Repeat period of a held motion button; 200–333 ms is the robot's 3–5 Hz.
    Repeat = 17, "repeat-ms", "X30_REPEAT_MS", Syntax::Millis { min: 200, max: 333 },
        "milliseconds from 200 to 333 (the robot needs 3-5 Hz)";
    /// How long a button's level must be stable to count.
    Debounce = 18, "debounce-ms", "X30_DEBOUNCE_MS", Syntax::Millis { min: 1, max: 100 },
        "milliseconds from 1 to 100";
    /// How the e-stop switch is wired.
    EstopInput = 19, "estop-input", "X30_ESTOP_INPUT", Syntax::EstopInput,
        "no (normally open) or nc (normally closed: a broken wire reads as pressed)";
    /// The web page's PIN for changing settings.
    WebPin = 20, "web-pin", "X30_WEB_PIN", Syntax::Pin,
        "4 to 8 digits, or none (the web page is read-only)";
    /// Whether the robot's indicator light shows a confirmed e-stop.
    RobotLight = 21, "robot-light", "X30_ROBOT_LIGHT", Syntax::Switch,
        "1 (the robot's light turns red while its e-stop is confirmed) or 0 (only the light button sets it)";
}

impl Key {
    /// The key named `name` (any case).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|key| key.name().eq_ignore_ascii_case(name))
    }

    /// The key stored under `id`.
    pub fn from_id(id: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|key| key.id() == id)
    }

    /// Whether `text` (already trimmed) is a valid value of this key.
    pub fn accepts(self, text: &str) -> bool {
        match self.syntax() {
            Syntax::Robot => parse_robot(text).is_some(),
            Syntax::Switch => parse_switch(text).is_some(),
            Syntax::Cidr => optional(text, parse_cidr).is_some(),
            Syntax::Ipv4 => optional(text, parse_ipv4).is_some(),
            Syntax::Speed { max } => parse_speed(text, max).is_some(),
            Syntax::Lights => lights(text).all(|light| light.is_some()) && count_ok(text),
            Syntax::Dock => optional(text, parse_dock).is_some(),
            Syntax::Millis { min, max } => parse_millis(text, min, max).is_some(),
            Syntax::EstopInput => EstopWiring::parse(text).is_some(),
            Syntax::Pin => optional(text, WebPin::parse).is_some(),
        }
    }
}

/// Where the robot's `robot_server` listens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RobotAddress {
    /// IPv4 address.
    pub ip: [u8; 4],
    /// TCP port.
    pub port: u16,
}

/// An address with its network's prefix length, such as `10.0.0.50/24`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cidr {
    /// The address.
    pub address: [u8; 4],
    /// Network prefix length, 0..=32.
    pub prefix_len: u8,
}

/// How the `estop` switch is wired to its input, which has a pull-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EstopWiring {
    /// Normally open (`no`): pressing connects the input to GND. A broken wire reads as
    /// released.
    NormallyOpen,
    /// Normally closed (`nc`): the switch holds the input at GND and pressing opens it. A
    /// broken wire reads as pressed, which is why safety wiring uses it.
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

    /// The word [`EstopWiring::parse`] reads.
    pub const fn name(self) -> &'static str {
        match self {
            Self::NormallyOpen => "no",
            Self::NormallyClosed => "nc",
        }
    }
}

/// The web page's PIN: 4 to 8 digits.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct WebPin {
    /// The digits, ASCII; only the first `len` count.
    digits: [u8; MAX_PIN_DIGITS],
    /// How many digits.
    len: u8,
}

impl WebPin {
    /// Parses 4 to 8 ASCII digits.
    pub fn parse(text: &str) -> Option<Self> {
        let len = text.len();
        if !(MIN_PIN_DIGITS..=MAX_PIN_DIGITS).contains(&len)
            || !text.bytes().all(|b| b.is_ascii_digit())
        {
            return None;
        }
        let mut digits = [0; MAX_PIN_DIGITS];
        digits
            .iter_mut()
            .zip(text.bytes())
            .for_each(|(d, b)| *d = b);
        Some(Self {
            digits,
            len: len as u8,
        })
    }

    /// The digits.
    pub fn as_str(&self) -> &str {
        let digits = self.digits.get(..usize::from(self.len)).unwrap_or_default();
        core::str::from_utf8(digits).unwrap_or_default()
    }
}

/// Never shows the digits: a PIN printed in a log is a PIN given away.
impl core::fmt::Debug for WebPin {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("WebPin(****)")
    }
}

/// One light preset as written: colour, brightness, effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LightText {
    /// Red, green, blue.
    pub rgb: [u8; 3],
    /// Brightness, 0..=100 %.
    pub brightness: u8,
    /// Breathing rather than steady.
    pub breathing: bool,
}

/// The dock point as written: point and map numbers, position (m) and heading (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DockText {
    /// The point's number (`Value`).
    pub point: i32,
    /// The map's number.
    pub map: i32,
    /// x, y, z (m) and yaw (rad) in the map frame.
    pub pose: [f32; 4],
}

/// `none` as `Some(None)`, otherwise `parse`'s result as `Some(Some(value))`; `None` if
/// the text is neither.
pub fn optional<T>(text: &str, parse: impl FnOnce(&str) -> Option<T>) -> Option<Option<T>> {
    if text.eq_ignore_ascii_case(NONE) {
        Some(None)
    } else {
        parse(text).map(Some)
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
pub fn parse_cidr(text: &str) -> Option<Cidr> {
    let (ip, prefix) = text.split_once('/')?;
    Some(Cidr {
        address: parse_ipv4(ip)?,
        prefix_len: unsigned(prefix).filter(|&p| p <= 32)?,
    })
}

/// Parses a switch: `1`, `true`, `yes`, `on` or `0`, `false`, `no`, `off`, any case.
pub fn parse_switch(text: &str) -> Option<bool> {
    let is = |words: [&str; 4]| words.iter().any(|w| w.eq_ignore_ascii_case(text));
    if is(["1", "true", "yes", "on"]) {
        Some(true)
    } else if is(["0", "false", "no", "off"]) {
        Some(false)
    } else {
        None
    }
}

/// Parses a speed: `-1` or `default` (the robot's default, as -1), otherwise a decimal
/// from 0 to `max`; `-0` reads as 0.
pub fn parse_speed(text: &str, max: f32) -> Option<f32> {
    if text.eq_ignore_ascii_case("default") {
        return Some(-1.0);
    }
    let speed = parse_f32(text.as_bytes()).ok()?;
    // -0 is within 0..=max, but would be shown, saved and sent to the robot as `-0`, a
    // negative-looking speed: adding 0 makes it 0.
    (speed == -1.0 || (0.0..=max).contains(&speed)).then_some(speed + 0.0)
}

/// Parses a whole number of milliseconds within `min..=max`.
pub fn parse_millis(text: &str, min: u32, max: u32) -> Option<u32> {
    unsigned(text).filter(|ms| (min..=max).contains(ms))
}

/// Parses one light preset, `RRGGBB:brightness` with an optional `:breathing` or `:steady`.
pub fn parse_light(text: &str) -> Option<LightText> {
    let mut parts = text.split(':').map(str::trim);
    let rgb = parts.next()?;
    let brightness = unsigned(parts.next()?).filter(|&b| b <= 100)?;
    let breathing = match parts.next() {
        None => false,
        Some(e) if e.eq_ignore_ascii_case("steady") => false,
        Some(e) if e.eq_ignore_ascii_case("breathing") => true,
        Some(_) => return None,
    };
    // Six hex digits, no sign: `from_str_radix` alone would take `+F+F+F`.
    if parts.next().is_some() || rgb.len() != 6 || !rgb.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    // `get` rather than slicing: a non-ASCII character must not panic on a char boundary.
    let byte = |i: usize| u8::from_str_radix(rgb.get(i..i + 2)?, 16).ok();
    Some(LightText {
        rgb: [byte(0)?, byte(2)?, byte(4)?],
        brightness,
        breathing,
    })
}

/// Each preset of a comma-separated list, parsed (`None` for an invalid one).
pub fn lights(text: &str) -> impl Iterator<Item = Option<LightText>> + '_ {
    text.split(',').map(|preset| parse_light(preset.trim()))
}

/// Whether a list of light presets has 1 to [`MAX_LIGHT_PRESETS`] entries.
fn count_ok(text: &str) -> bool {
    text.split(',').count() <= MAX_LIGHT_PRESETS
}

/// Parses the dock point, `point,map,x,y,z,yaw`: point and map numbers, then the charging
/// point's position (m) and heading (rad) in the map frame.
pub fn parse_dock(text: &str) -> Option<DockText> {
    let mut fields = text.split(',').map(str::trim);
    let mut int = || parse_int::<i32>(fields.next()?.as_bytes()).ok();
    let (point, map) = (int()?, int()?);
    let mut pose = [0.0; 4];
    for value in &mut pose {
        *value = parse_f32(fields.next()?.as_bytes()).ok()?;
    }
    fields
        .next()
        .is_none()
        .then_some(DockText { point, map, pose })
}
