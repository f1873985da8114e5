//! The panel's settings: one table of keys, two sources.
//!
//! Every key ([`Key`]) has a default, given at build time by its `X30_*` variable (or the
//! built-in one when the variable is unset), and may be overridden by a value saved on the
//! board. A key's name is its variable's without `X30_`, lower-case, `_` → `-`; its value is
//! written the same way in both places ([`text`]).
//!
//! | key | variable | default | value |
//! |---|---|---|---|
//! | `robot` | `X30_ROBOT` | `192.168.1.106:30000` | `a.b.c.d` or `a.b.c.d:port` |
//! | `dhcp` | `X30_DHCP` | `1` | `1`/`true`/`yes`/`on`: address by DHCP; `0`/`false`/`no`/`off`: the static `ip` |
//! | `ip` | `X30_IP` | `none` | `a.b.c.d/len`, used with `dhcp` 0 (which needs it) |
//! | `gateway` | `X30_GATEWAY` | `none` | `a.b.c.d`, used with `dhcp` 0 |
//! | `speed-forward` | `X30_SPEED_FORWARD` | `default` | m/s, 0..=1.5, or `default`/`-1` (the robot's 0.5) |
//! | `speed-backward` | `X30_SPEED_BACKWARD` | `default` | m/s, 0..=1.3 (robot default 0.5) |
//! | `speed-turn-left`, `speed-turn-right` | `X30_SPEED_TURN_…` | `default` | rad/s, 0..=0.45 (robot default 0.35) |
//! | `speed-strafe-left`, `speed-strafe-right` | `X30_SPEED_STRAFE_…` | `default` | m/s, 0..=0.15 (robot default 0.1) |
//! | `lights` | `X30_LIGHTS` | `000000:0,00FF00:100,FFBF00:100,FF0000:100:breathing` | 1–8 presets `RRGGBB:brightness%[:breathing\|:steady]`, comma-separated, cycled by `light` |
//! | `dock` | `X30_DOCK` | `none` | `point,map,x,y,z,yaw` (numbers, m, rad): where `dock` goes; none is safe by default |
//! | `poll-status-ms` | `X30_POLL_STATUS_MS` | `500` | status (1002) and perception (2002) period, 100..=60000 |
//! | `poll-battery-ms` | `X30_POLL_BATTERY_MS` | `5000` | battery (2001) period, 100..=600000 |
//! | `poll-motors-ms` | `X30_POLL_MOTORS_MS` | `10000` | motor temperatures (1008) period, 100..=600000 |
//! | `poll-nav-ms` | `X30_POLL_NAV_MS` | `1000` | navigation status (1007) period while a task runs, 100..=60000 |
//! | `repeat-ms` | `X30_REPEAT_MS` | `250` | repeat of a held motion button, 200..=333 (the robot needs 3–5 Hz) |
//! | `debounce-ms` | `X30_DEBOUNCE_MS` | `15` | how long a button's level must be stable, 1..=100 |
//! | `estop-input` | `X30_ESTOP_INPUT` | `no` | `no`: normally open; `nc`: normally closed (a broken wire reads as pressed) |
//! | `web-pin` | `X30_WEB_PIN` | `none` | 4–8 digits that allow changing settings from the web page |
//! | `robot-light` | `X30_ROBOT_LIGHT` | `0` | `1`: the robot's indicator light turns steady red while the panel's e-stop is latched and confirmed, and back to the `light` button's preset when it unlocks (a robot that refuses it is sent no more until the next save); `0`: only the `light` button sets it |
//!
//! A saved `robot`, speed, preset, dock point, period or `robot-light` takes effect at once; `dhcp`, `ip`,
//! `gateway`, `debounce-ms` and `estop-input` at the next start, since the board sets its
//! network and buttons up once.
//!
//! [`Settings`] keeps three things: the defaults, what is saved (the configuration in
//! effect) and what is being edited on the console (`set`, `unset`), which becomes saved on
//! `save`. The saved overrides travel to and from flash as a small blob ([`Settings::emit`],
//! [`Settings::parse`]) held by the [`store`]:
//!
//! ```text
//! "X30S" version(1)  { key-id(1) length(1) value-text(length) }*
//! ```
//!
//! The text of each value, not a binary image of [`Config`], so that a blob written by one
//! firmware reads the same in the next even where types change, and an unknown key (from a
//! newer firmware) is skipped rather than misread.

pub mod desk;
pub mod route;
pub mod store;
pub mod text;

use core::fmt;

use embassy_time::Duration;
use embedded_storage_async::nor_flash::NorFlash;

use crate::config::{Config, LightPresets};
use crate::proto::codes::{LightEffect, PointInfo};
use crate::proto::message::{Direction, Light, NavPoint, Speed};
// `text` parses numbers with the codec's parser, through this name (the build script
// includes both files side by side).
use crate::proto::xml::number;

use route::{ROUTE_ID, RoutePoint};
use store::{BUF_LEN, Store};
use text::{
    DockText, EstopWiring, LightText, WebPin, lights, optional, parse_cidr, parse_dock, parse_ipv4,
    parse_millis, parse_robot, parse_speed, parse_switch,
};
pub use text::{Key, Syntax};

/// The blob's first bytes: a store written by something else is not read as settings.
pub const MAGIC: &[u8; 4] = b"X30S";
/// The blob's layout version.
pub const VERSION: u8 = 1;
/// Longest value text a blob entry holds.
pub const MAX_VALUE: usize = 255;

/// A value that is not valid for its key; nothing was changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Invalid(pub Key);

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: expected {}", self.0.name(), self.0.allowed())
    }
}

/// A set of keys.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Keys(u32);

// One bit per key must fit.
const _: () = assert!(Key::ALL.len() <= 32);

impl Keys {
    /// No key.
    pub const EMPTY: Self = Self(0);

    /// Adds `key`.
    pub fn insert(&mut self, key: Key) {
        self.0 |= bit(key);
    }

    /// Removes `key`.
    pub fn remove(&mut self, key: Key) {
        self.0 &= !bit(key);
    }

    /// Whether `key` is in the set.
    pub fn contains(self, key: Key) -> bool {
        self.0 & bit(key) != 0
    }

    /// Whether the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The keys of the set, in table order.
    pub fn iter(self) -> impl Iterator<Item = Key> {
        Key::ALL.iter().copied().filter(move |&k| self.contains(k))
    }
}

/// The names, comma-separated: `speed-forward, dock`.
impl fmt::Display for Keys {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, key) in self.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            f.write_str(key.name())?;
        }
        Ok(())
    }
}

/// What differs between the edited settings and the saved ones: keys, and the route.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unsaved {
    /// The keys whose edited value differs from the saved one.
    pub keys: Keys,
    /// Whether the edited route differs from the saved one.
    pub route: bool,
}

impl Unsaved {
    /// Nothing differs.
    pub const NONE: Self = Self {
        keys: Keys::EMPTY,
        route: false,
    };

    /// Whether nothing differs.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty() && !self.route
    }
}

impl fmt::Display for Unsaved {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.keys)?;
        match (self.route, self.keys.is_empty()) {
            (false, _) => Ok(()),
            (true, true) => f.write_str("route"),
            (true, false) => f.write_str(", route"),
        }
    }
}

/// The bit of `key` in [`Keys`].
fn bit(key: Key) -> u32 {
    1 << (key.id() % 32)
}

/// Why saved settings could not be taken as they are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum LoadProblem {
    /// The store could not be read: damaged, or written by something else. Every key has
    /// its default; the next save rewrites the store.
    Unreadable,
    /// The blob is not settings of this firmware (another magic or version) or is cut
    /// short: every key has its default.
    NotSettings,
    /// Some saved values are not valid (any more); those keys have their defaults, the
    /// others are as saved.
    InvalidValues(Keys),
    /// The blob names keys this firmware does not know (written by a newer one); they are
    /// ignored.
    UnknownKeys(u8),
    /// A saved route point is not valid (any more): the route is empty.
    InvalidRoute,
}

impl LoadProblem {
    /// Whether the panel shows it on the fault LED: settings were lost, not merely skipped.
    pub fn is_loss(self) -> bool {
        !matches!(self, Self::UnknownKeys(_))
    }
}

/// The settings saved in `store` over `defaults`, and what was wrong, if anything. Never
/// fails: whatever cannot be read has its default.
pub async fn load<F: NorFlash>(
    store: &mut Store<F>,
    defaults: Config,
) -> (Settings, Option<LoadProblem>) {
    let mut buf = [0u8; BUF_LEN];
    match store.load(&mut buf).await {
        Ok(None) => (Settings::new(defaults), None),
        Ok(Some(blob)) => Settings::parse(defaults, blob),
        Err(e) => {
            warn!("settings: the store cannot be read: {:?}", e);
            (Settings::new(defaults), Some(LoadProblem::Unreadable))
        }
    }
}

/// Why the edited settings cannot be saved as they are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Conflict {
    /// `dhcp` is off but `ip` is unset: the board would have no address.
    StaticWithoutAddress,
}

impl fmt::Display for Conflict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::StaticWithoutAddress => {
                f.write_str("dhcp is 0 but ip is none: set ip a.b.c.d/len, or dhcp 1")
            }
        }
    }
}

/// A configuration and the keys in it that differ from the defaults by choice.
#[derive(Debug, Clone, PartialEq)]
struct Layer {
    /// The defaults with the overrides applied.
    config: Config,
    /// The keys overridden.
    overridden: Keys,
}

impl Layer {
    /// Hands each override (its key's id and value text), then each route point (the
    /// route's id and the point's text), to `put`; `None` if `put` or a value's text fails.
    fn entries(&self, mut put: impl FnMut(u8, &[u8]) -> Option<()>) -> Option<()> {
        for key in self.overridden.iter() {
            let mut value = heapless::String::<MAX_VALUE>::new();
            key.write(&self.config, &mut value).ok()?;
            put(key.id(), value.as_bytes())?;
        }
        for point in &self.config.route {
            let mut value = heapless::String::<MAX_VALUE>::new();
            point.write(&mut value).ok()?;
            put(ROUTE_ID, value.as_bytes())?;
        }
        Some(())
    }
}

/// The defaults, the saved settings in effect, and the edits not yet saved.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Build-time (or board-given) defaults.
    defaults: Config,
    /// What is saved: the configuration in effect.
    saved: Layer,
    /// What `save` would save.
    edited: Layer,
}

impl Settings {
    /// Settings with nothing saved: every key has its default.
    pub fn new(defaults: Config) -> Self {
        let layer = Layer {
            config: defaults.clone(),
            overridden: Keys::EMPTY,
        };
        Self {
            defaults,
            saved: layer.clone(),
            edited: layer,
        }
    }

    /// The configuration in effect: the defaults with the saved values.
    pub fn config(&self) -> &Config {
        &self.saved.config
    }

    /// The configuration `save` would put in effect.
    pub fn edited(&self) -> &Config {
        &self.edited.config
    }

    /// The defaults.
    pub fn defaults(&self) -> &Config {
        &self.defaults
    }

    /// Whether `key` is overridden in the edited settings (not its default).
    pub fn is_overridden(&self, key: Key) -> bool {
        self.edited.overridden.contains(key)
    }

    /// Whether the edited route differs from the saved one.
    pub fn route_unsaved(&self) -> bool {
        self.edited.config.route != self.saved.config.route
    }

    /// Adds `point` to the end of the edited route; `Err` if the route is full.
    pub fn add_route_point(&mut self, point: RoutePoint) -> Result<(), RoutePoint> {
        self.edited.config.route.push(point)
    }

    /// Empties the edited route.
    pub fn clear_route(&mut self) {
        self.edited.config.route.clear();
    }

    /// The keys whose edited value differs from the saved one.
    pub fn unsaved(&self) -> Keys {
        let mut keys = Keys::EMPTY;
        for &key in Key::ALL {
            let overridden = |layer: &Layer| layer.overridden.contains(key);
            if overridden(&self.edited) != overridden(&self.saved)
                || !key.same(&self.edited.config, &self.saved.config)
            {
                keys.insert(key);
            }
        }
        keys
    }

    /// Everything not saved: [`Settings::unsaved`] and [`Settings::route_unsaved`].
    pub fn unsaved_changes(&self) -> Unsaved {
        Unsaved {
            keys: self.unsaved(),
            route: self.route_unsaved(),
        }
    }

    /// Sets `key` to `text` in the edited settings; on error nothing changes.
    pub fn set(&mut self, key: Key, text: &str) -> Result<(), Invalid> {
        key.apply(&mut self.edited.config, text)?;
        self.edited.overridden.insert(key);
        Ok(())
    }

    /// Returns `key` to its default in the edited settings.
    pub fn unset(&mut self, key: Key) {
        key.copy(&self.defaults, &mut self.edited.config);
        self.edited.overridden.remove(key);
    }

    /// Whether the edited settings can be saved.
    pub fn check(&self) -> Result<(), Conflict> {
        let config = &self.edited.config;
        if !config.dhcp && config.ip.is_none() {
            return Err(Conflict::StaticWithoutAddress);
        }
        Ok(())
    }

    /// The edited settings become the saved ones, in effect (after the store saved them).
    pub fn commit(&mut self) {
        self.saved = self.edited.clone();
    }

    /// The edited settings go back to the saved ones.
    pub fn revert(&mut self) {
        self.edited = self.saved.clone();
    }

    /// Writes the edited overrides as a blob into `out`; its length, or `None` if `out`
    /// is too small.
    pub fn emit(&self, out: &mut [u8]) -> Option<usize> {
        let mut blob = Blob { out, len: 0 };
        blob.push(MAGIC)?;
        blob.push(&[VERSION])?;
        self.edited.entries(|id, value| {
            blob.push(&[id, value.len() as u8])?;
            blob.push(value)
        })?;
        Some(blob.len)
    }

    /// A number that changes whenever what is saved does (a 32-bit FNV-1a hash of the saved
    /// overrides and route), so that a form can tell whether the settings it was shown are
    /// still those saved. The `web-pin` is left out: the number is shown on the page, which
    /// shows every other value, and would otherwise let a PIN be found by trying them all.
    pub fn saved_stamp(&self) -> u32 {
        let mut hash: u32 = 0x811c_9dc5;
        let mut mix = |bytes: &[u8]| {
            for &byte in bytes {
                hash = (hash ^ u32::from(byte)).wrapping_mul(0x0100_0193);
            }
        };
        let _ = self.saved.entries(|id, value| {
            if id != Key::WebPin.id() {
                mix(&[id, value.len() as u8]);
                mix(value);
            }
            Some(())
        });
        hash
    }

    /// Whether `other` has the same settings saved.
    pub fn same_saved(&self, other: &Settings) -> bool {
        self.saved == other.saved
    }

    /// Settings over `defaults` with the overrides of `blob` saved, and what was wrong
    /// with it, if anything. Never fails: what cannot be read keeps its default.
    pub fn parse(defaults: Config, blob: &[u8]) -> (Self, Option<LoadProblem>) {
        let mut settings = Self::new(defaults);
        let Some(mut entries) = blob
            .strip_prefix(MAGIC.as_slice())
            .and_then(|rest| rest.strip_prefix(&[VERSION]))
        else {
            return (settings, Some(LoadProblem::NotSettings));
        };
        let (mut invalid, mut unknown, mut bad_route) = (Keys::EMPTY, 0u8, false);
        while let [id, len, rest @ ..] = entries {
            let Some((value, next)) = rest.split_at_checked(usize::from(*len)) else {
                return (Self::new(settings.defaults), Some(LoadProblem::NotSettings));
            };
            entries = next;
            if *id == ROUTE_ID {
                let text = core::str::from_utf8(value).unwrap_or_default();
                let added = RoutePoint::parse(text).map(|p| settings.add_route_point(p));
                bad_route |= !matches!(added, Some(Ok(())));
                continue;
            }
            let Some(key) = Key::from_id(*id) else {
                unknown = unknown.saturating_add(1);
                continue;
            };
            let text = core::str::from_utf8(value).unwrap_or_default();
            if settings.set(key, text).is_err() {
                invalid.insert(key);
            }
        }
        if !entries.is_empty() {
            return (Self::new(settings.defaults), Some(LoadProblem::NotSettings));
        }
        if bad_route {
            settings.clear_route();
        }
        settings.commit();
        let problem = if bad_route {
            Some(LoadProblem::InvalidRoute)
        } else if !invalid.is_empty() {
            Some(LoadProblem::InvalidValues(invalid))
        } else if unknown > 0 {
            Some(LoadProblem::UnknownKeys(unknown))
        } else {
            None
        };
        (settings, problem)
    }
}

/// A blob being written.
struct Blob<'a> {
    /// Where it goes.
    out: &'a mut [u8],
    /// Bytes written.
    len: usize,
}

impl Blob<'_> {
    /// Appends `bytes`; `None` if they do not fit.
    fn push(&mut self, bytes: &[u8]) -> Option<()> {
        let end = self.len.checked_add(bytes.len())?;
        self.out.get_mut(self.len..end)?.copy_from_slice(bytes);
        self.len = end;
        Some(())
    }
}

impl Config {
    /// The build-time configuration: the defaults, overridden by the `X30_*` variables set
    /// when the firmware was built (which the build checked).
    pub fn from_build_env() -> Self {
        let mut config = Self::default();
        for &key in Key::ALL {
            if let Some(text) = key.build_value() {
                // The build script refuses invalid values, so this cannot fail in firmware;
                // a host build without that check keeps the built-in default.
                let _ = key.apply(&mut config, text);
            }
        }
        config
    }
}

/// One value's place in a [`Config`], to read it from a shared one and to set it in a
/// mutable one: a key names it once for both.
struct Field<T: 'static> {
    /// The value in a config being read.
    value: fn(&Config) -> &T,
    /// The value in a config being set.
    place: fn(&mut Config) -> &mut T,
}

/// The [`Field`] at `config.$path`.
macro_rules! field {
    ($($path:ident).+) => {
        Field {
            value: |config| &config.$($path).+,
            place: |config| &mut config.$($path).+,
        }
    };
}

impl Key {
    /// The direction of a speed key.
    pub const fn direction(self) -> Option<Direction> {
        Some(match self {
            Self::SpeedForward => Direction::Forward,
            Self::SpeedBackward => Direction::Backward,
            Self::SpeedTurnLeft => Direction::TurnLeft,
            Self::SpeedTurnRight => Direction::TurnRight,
            Self::SpeedStrafeLeft => Direction::StrafeLeft,
            Self::SpeedStrafeRight => Direction::StrafeRight,
            _ => return None,
        })
    }

    /// The key holding the speed of `direction`.
    pub fn speed(direction: Direction) -> Self {
        Key::ALL
            .iter()
            .copied()
            .find(|key| key.direction() == Some(direction))
            .unwrap_or(Self::SpeedForward)
    }

    /// Where in a [`Config`] a milliseconds key keeps its period.
    fn period(self) -> Option<Field<Duration>> {
        Some(match self {
            Self::PollStatus => field!(polls.status),
            Self::PollBattery => field!(polls.battery),
            Self::PollMotors => field!(polls.motor_temperatures),
            Self::PollNav => field!(polls.nav_status),
            Self::Repeat => field!(motion_repeat),
            Self::Debounce => field!(debounce),
            _ => return None,
        })
    }

    /// Where in a [`Config`] a key of [`Syntax::Switch`] keeps its switch.
    fn switch(self) -> Option<Field<bool>> {
        Some(match self {
            Self::Dhcp => field!(dhcp),
            Self::RobotLight => field!(robot_light),
            _ => return None,
        })
    }

    /// Sets this key in `config` from `text` (surrounding whitespace ignored); on error
    /// `config` is unchanged.
    pub fn apply(self, config: &mut Config, text: &str) -> Result<(), Invalid> {
        let text = text.trim();
        let invalid = Invalid(self);
        match self.syntax() {
            Syntax::Robot => config.robot = parse_robot(text).ok_or(invalid)?,
            Syntax::Switch => {
                *(self.switch().ok_or(invalid)?.place)(config) =
                    parse_switch(text).ok_or(invalid)?
            }
            Syntax::Cidr => config.ip = optional(text, parse_cidr).ok_or(invalid)?,
            Syntax::Ipv4 => config.gateway = optional(text, parse_ipv4).ok_or(invalid)?,
            Syntax::Speed { max } => {
                let direction = self.direction().ok_or(invalid)?;
                let speed = parse_speed(text, max).ok_or(invalid)?;
                config.speeds.set(direction, Speed::from_wire(speed));
            }
            Syntax::Lights => {
                let mut presets = LightPresets::new();
                for light in lights(text) {
                    presets
                        .push(light_preset(light.ok_or(invalid)?))
                        .map_err(|_| invalid)?;
                }
                config.lights = presets;
            }
            Syntax::Dock => config.dock = optional(text, parse_dock).ok_or(invalid)?.map(dock),
            Syntax::Millis { min, max } => {
                let ms = parse_millis(text, min, max).ok_or(invalid)?;
                *(self.period().ok_or(invalid)?.place)(config) = Duration::from_millis(ms.into());
            }
            Syntax::EstopInput => config.estop_input = EstopWiring::parse(text).ok_or(invalid)?,
            Syntax::Pin => config.web_pin = optional(text, WebPin::parse).ok_or(invalid)?,
        }
        Ok(())
    }

    /// Writes this key's value in `config` as text that [`Key::apply`] reads back to the
    /// same value (floats in their shortest exact form).
    pub fn write(self, config: &Config, out: &mut impl fmt::Write) -> fmt::Result {
        match self.syntax() {
            Syntax::Robot => {
                write_ipv4(out, config.robot.ip)?;
                write!(out, ":{}", config.robot.port)
            }
            Syntax::Switch => {
                let on = self.switch().map(|field| *(field.value)(config));
                out.write_str(if on.ok_or(fmt::Error)? { "1" } else { "0" })
            }
            Syntax::Cidr => write_optional(out, config.ip.as_ref(), |out, ip| {
                write_ipv4(out, ip.address)?;
                write!(out, "/{}", ip.prefix_len)
            }),
            Syntax::Ipv4 => write_optional(out, config.gateway.as_ref(), |out, gateway| {
                write_ipv4(out, *gateway)
            }),
            Syntax::Speed { .. } => {
                let direction = self.direction().ok_or(fmt::Error)?;
                match config.speeds.get(direction) {
                    Speed::Default => out.write_str("default"),
                    Speed::Value(v) => write_f32(out, v),
                }
            }
            Syntax::Lights => {
                for (i, light) in config.lights.iter().enumerate() {
                    if i > 0 {
                        out.write_char(',')?;
                    }
                    write!(
                        out,
                        "{:02X}{:02X}{:02X}:{}",
                        light.red, light.green, light.blue, light.brightness
                    )?;
                    if light.effect == LightEffect::Breathing {
                        out.write_str(":breathing")?;
                    }
                }
                Ok(())
            }
            Syntax::Dock => write_optional(out, config.dock.as_ref(), |out, point| {
                write!(out, "{},{}", point.value, point.map_id)?;
                for v in [point.pos_x, point.pos_y, point.pos_z, point.angle_yaw] {
                    out.write_char(',')?;
                    write_f32(out, v)?;
                }
                Ok(())
            }),
            Syntax::Millis { .. } => {
                let ms = self.period().map(|field| (field.value)(config).as_millis());
                write!(out, "{}", ms.ok_or(fmt::Error)?)
            }
            Syntax::EstopInput => out.write_str(config.estop_input.name()),
            Syntax::Pin => write_optional(out, config.web_pin.as_ref(), |out, pin| {
                out.write_str(pin.as_str())
            }),
        }
    }

    /// Copies this key's value from `from` to `to`.
    fn copy(self, from: &Config, to: &mut Config) {
        let mut text = heapless::String::<MAX_VALUE>::new();
        // Written values always read back; a failure would leave `to` as it was.
        if self.write(from, &mut text).is_ok() {
            let _ = self.apply(to, &text);
        }
    }

    /// Whether `a` and `b` hold the same value of this key.
    fn same(self, a: &Config, b: &Config) -> bool {
        let text = |config: &Config| {
            let mut text = heapless::String::<MAX_VALUE>::new();
            self.write(config, &mut text).map(|()| text)
        };
        text(a) == text(b)
    }
}

/// The light preset `text` describes.
fn light_preset(text: LightText) -> Light {
    let [red, green, blue] = text.rgb;
    Light {
        red,
        green,
        blue,
        effect: if text.breathing {
            LightEffect::Breathing
        } else {
            LightEffect::Steady
        },
        brightness: text.brightness,
    }
}

/// The charging point `text` describes.
fn dock(text: DockText) -> NavPoint {
    let [x, y, z, yaw] = text.pose;
    NavPoint::new(text.point, text.map, x, y, z, yaw, PointInfo::Charging)
}

/// Writes `a.b.c.d`.
fn write_ipv4(out: &mut impl fmt::Write, [a, b, c, d]: [u8; 4]) -> fmt::Result {
    write!(out, "{a}.{b}.{c}.{d}")
}

/// Writes `value` with `write`, or `none`.
fn write_optional<W: fmt::Write, T>(
    out: &mut W,
    value: Option<&T>,
    write: impl FnOnce(&mut W, &T) -> fmt::Result,
) -> fmt::Result {
    match value {
        Some(value) => write(out, value),
        None => out.write_str(text::NONE),
    }
}

/// Writes `value` in its shortest form that reads back exactly.
pub fn write_f32(out: &mut impl fmt::Write, value: f32) -> fmt::Result {
    let mut buf = [0; number::F32_TEXT_MAX];
    let len = number::write_f32(value, &mut buf).map_err(|_| fmt::Error)?;
    let text = buf.get(..len).ok_or(fmt::Error)?;
    out.write_str(core::str::from_utf8(text).map_err(|_| fmt::Error)?)
}

// The text module's types, which the build script compiles without defmt.
#[cfg(feature = "defmt")]
mod defmt_impls {
    use super::Key;
    use super::text::{Cidr, EstopWiring, RobotAddress, WebPin};

    impl defmt::Format for Key {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(f, "{=str}", self.name());
        }
    }

    impl defmt::Format for RobotAddress {
        fn format(&self, f: defmt::Formatter<'_>) {
            let [a, b, c, d] = self.ip;
            defmt::write!(f, "{}.{}.{}.{}:{}", a, b, c, d, self.port);
        }
    }

    impl defmt::Format for Cidr {
        fn format(&self, f: defmt::Formatter<'_>) {
            let [a, b, c, d] = self.address;
            defmt::write!(f, "{}.{}.{}.{}/{}", a, b, c, d, self.prefix_len);
        }
    }

    impl defmt::Format for EstopWiring {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(f, "{=str}", self.name());
        }
    }

    /// Never the digits, as with `Debug`.
    impl defmt::Format for WebPin {
        fn format(&self, f: defmt::Formatter<'_>) {
            defmt::write!(f, "WebPin(****)");
        }
    }
}
