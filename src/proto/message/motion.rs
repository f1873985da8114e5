//! Motion control (Type 2), the indicator light (1101) and relocalisation (2101).

use super::ValidationError;
use super::items::item_set;
use crate::proto::codes::{
    CommandResult, LightEffect, LocalizationResult, MotionCommandCode, MotionGait,
};

/// The speed of a translation or rotation command.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Speed {
    /// The robot's default for the command (sent as −1).
    Default,
    /// An explicit speed, m/s or rad/s.
    Value(f32),
}

impl Speed {
    /// The wire form: −1 for the default.
    pub fn to_wire(self) -> f32 {
        match self {
            Self::Default => -1.0,
            Self::Value(v) => v,
        }
    }

    /// Reads the wire form, where −1 means the default.
    pub fn from_wire(value: f32) -> Self {
        if value == -1.0 {
            Self::Default
        } else {
            Self::Value(value)
        }
    }
}

/// The six ways a held motion button moves the robot: the Type 2 commands that must be
/// repeated at 3–5 Hz while the motion should continue.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Command 1: walk forwards, 0..=1.5 m/s (default 0.5).
    Forward,
    /// Command 2: walk backwards, 0..=1.3 m/s (default 0.5).
    Backward,
    /// Command 3: turn left, 0..=0.45 rad/s (default 0.35).
    TurnLeft,
    /// Command 4: turn right, 0..=0.45 rad/s (default 0.35).
    TurnRight,
    /// Command 11: strafe left, 0..=0.15 m/s (default 0.1).
    StrafeLeft,
    /// Command 12: strafe right, 0..=0.15 m/s (default 0.1).
    StrafeRight,
}

impl Direction {
    /// Every direction, in the order of their Command codes.
    pub const ALL: [Direction; 6] = [
        Self::Forward,
        Self::Backward,
        Self::TurnLeft,
        Self::TurnRight,
        Self::StrafeLeft,
        Self::StrafeRight,
    ];

    /// The `Command` code.
    pub const fn code(self) -> MotionCommandCode {
        match self {
            Self::Forward => MotionCommandCode::Forward,
            Self::Backward => MotionCommandCode::Backward,
            Self::TurnLeft => MotionCommandCode::TurnLeft,
            Self::TurnRight => MotionCommandCode::TurnRight,
            Self::StrafeLeft => MotionCommandCode::StrafeLeft,
            Self::StrafeRight => MotionCommandCode::StrafeRight,
        }
    }

    /// The direction a `Command` code moves in, if it is one of the six.
    pub fn from_code(code: MotionCommandCode) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.code() == code)
    }

    /// The name used for it everywhere people type it (buttons, settings, x30ctl), such as
    /// `turn-left`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Forward => "forward",
            Self::Backward => "backward",
            Self::TurnLeft => "turn-left",
            Self::TurnRight => "turn-right",
            Self::StrafeLeft => "strafe-left",
            Self::StrafeRight => "strafe-right",
        }
    }

    /// The direction named `name` (see [`Direction::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.name() == name)
    }

    /// Largest speed the document allows, m/s or rad/s.
    pub const fn speed_limit(self) -> f32 {
        match self {
            Self::Forward => 1.5,
            Self::Backward => 1.3,
            Self::TurnLeft | Self::TurnRight => 0.45,
            Self::StrafeLeft | Self::StrafeRight => 0.15,
        }
    }

    /// The robot's own speed when sent the default (−1), m/s or rad/s (an `f64`, for
    /// simulating the robot's motion exactly).
    pub const fn default_speed(self) -> f64 {
        match self {
            Self::Forward | Self::Backward => 0.5,
            Self::TurnLeft | Self::TurnRight => 0.35,
            Self::StrafeLeft | Self::StrafeRight => 0.1,
        }
    }
}

/// A Type 2 motion command with its `Value`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize),
    serde(into = "crate::proto::serde_support::MotionCommandItems")
)]
pub enum MotionCommand {
    /// Commands 1–4, 11, 12: move in a direction at a speed. Repeat at 3–5 Hz.
    Move(Direction, Speed),
    /// Command 6: zero velocity.
    ZeroVelocity,
    /// Command 13: soft emergency stop.
    SoftEmergencyStop,
    /// Command 14: stop stepping.
    StopStepping,
    /// Command 15: lie down.
    LieDown,
    /// Command 20: switch gait.
    SwitchGait(MotionGait),
    /// Command 16: stand up (beyond V1.0.12).
    StandUp,
    /// Command 17: force-control mode (beyond V1.0.12).
    ForceControl,
    /// Command 18: start stepping (beyond V1.0.12).
    StartStepping,
    /// Command 19: body height, value as the vendor software sends it (beyond V1.0.12).
    BodyHeight(f32),
    /// Command 21: go charging (beyond V1.0.12).
    GoCharging,
    /// Command 22: leave the charger (beyond V1.0.12).
    LeaveCharger,
}

/// Whether this build sends the Type 2 commands beyond protocol V1.0.12 (16–19, 21, 22): the
/// `vendor-extensions` feature. They are decoded either way.
pub const SENDS_VENDOR_EXTENSIONS: bool = cfg!(feature = "vendor-extensions");

/// `Value` of commands that take none.
const PLACEHOLDER: f32 = -1.0;

impl MotionCommand {
    /// The `Command` code.
    pub fn code(&self) -> MotionCommandCode {
        use MotionCommandCode as C;
        match self {
            Self::Move(direction, _) => direction.code(),
            Self::ZeroVelocity => C::ZeroVelocity,
            Self::SoftEmergencyStop => C::SoftEmergencyStop,
            Self::StopStepping => C::StopStepping,
            Self::LieDown => C::LieDown,
            Self::SwitchGait(_) => C::SwitchGait,
            Self::StandUp => C::StandUp,
            Self::ForceControl => C::ForceControl,
            Self::StartStepping => C::StartStepping,
            Self::BodyHeight(_) => C::BodyHeight,
            Self::GoCharging => C::GoCharging,
            Self::LeaveCharger => C::LeaveCharger,
        }
    }

    /// The `Value` item as sent: a speed, a gait number, or the −1 placeholder.
    pub fn value(&self) -> MotionValue {
        match *self {
            Self::Move(_, speed) => MotionValue::Float(speed.to_wire()),
            Self::SwitchGait(gait) => MotionValue::Int(gait.raw()),
            Self::BodyHeight(v) => MotionValue::Float(v),
            _ => MotionValue::Float(PLACEHOLDER),
        }
    }

    /// Builds a command from its code and `Value`; `None` for a code this build does not
    /// know or a gait value that is not an integer.
    pub fn from_parts(code: MotionCommandCode, value: f32) -> Option<Self> {
        use MotionCommandCode as C;
        Some(match code {
            C::ZeroVelocity => Self::ZeroVelocity,
            C::SoftEmergencyStop => Self::SoftEmergencyStop,
            C::StopStepping => Self::StopStepping,
            C::LieDown => Self::LieDown,
            C::SwitchGait => Self::SwitchGait(MotionGait::from_raw(integral(value)?)),
            C::StandUp => Self::StandUp,
            C::ForceControl => Self::ForceControl,
            C::StartStepping => Self::StartStepping,
            C::BodyHeight => Self::BodyHeight(value),
            C::GoCharging => Self::GoCharging,
            C::LeaveCharger => Self::LeaveCharger,
            // The six directions, and codes this protocol version does not define.
            _ => Self::Move(Direction::from_code(code)?, Speed::from_wire(value)),
        })
    }

    /// Whether the robot expects this command repeated at 3–5 Hz while motion continues.
    pub fn is_continuous(&self) -> bool {
        self.speed_limit().is_some()
    }

    /// Largest speed the document allows, for the translation and rotation commands.
    pub fn speed_limit(&self) -> Option<f32> {
        match self {
            Self::Move(direction, _) => Some(direction.speed_limit()),
            _ => None,
        }
    }

    /// Checks the command against the document before it is sent: speeds −1 or within
    /// 0..=limit, gaits known, and commands beyond V1.0.12 only with the
    /// `vendor-extensions` feature.
    pub fn validate(&self) -> Result<(), ValidationError> {
        if !SENDS_VENDOR_EXTENSIONS && self.code().is_vendor_extension() {
            return Err(ValidationError::VendorExtension);
        }
        if let (Some(max), MotionValue::Float(v)) = (self.speed_limit(), self.value())
            && v != -1.0
            && !(0.0..=max).contains(&v)
        {
            return Err(ValidationError::SpeedOutOfRange { max });
        }
        match self {
            Self::SwitchGait(gait) if !gait.is_known() => {
                Err(ValidationError::UnknownCode { item: "Value" })
            }
            Self::BodyHeight(v) if !v.is_finite() => {
                Err(ValidationError::NotFinite { item: "Value" })
            }
            _ => Ok(()),
        }
    }
}

/// An `f32` that holds an integer exactly, as that integer.
fn integral(value: f32) -> Option<i32> {
    let int = value as i32;
    (int as f32 == value).then_some(int)
}

/// The `Value` item of a motion command: an integer for Command 20, a float otherwise.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MotionValue {
    /// A speed or the −1 placeholder.
    Float(f32),
    /// A gait number.
    Int(i32),
}

item_set! {
    answer
    /// Type 2 answer: the command's value echoed and whether it was carried out.
    pub struct MotionAck {
        /// `Value` as requested (a gait number arrives as an integral float); `None` if the
        /// answer leaves it out. Only `ErrorCode` says what the robot did, so an answer
        /// without the echo is still read rather than taken for a failure.
        pub value: Option<f32> = "Value", optional;
        /// Success, or failure (a navigation task running, a bad speed).
        #[cfg_attr(feature = "serde", serde(rename = "error_code"))]
        pub result: CommandResult = "ErrorCode";
    }
}

item_set! {
    /// Type 1101 request: the colour, effect and brightness of the robot's indicator light.
    pub struct Light {
        /// Red, 0..=255.
        pub red: u8 = "Red";
        /// Green, 0..=255.
        pub green: u8 = "Green";
        /// Blue, 0..=255.
        pub blue: u8 = "Blue";
        /// Steady or breathing.
        pub effect: LightEffect = "PER";
        /// Brightness, 0..=100 %.
        pub brightness: u8 = "LUM";
    }
}

impl Light {
    /// Checks the request before it is sent: brightness at most 100 %, known effect.
    pub fn validate(&self) -> Result<(), ValidationError> {
        if self.brightness > 100 {
            return Err(ValidationError::BrightnessOutOfRange);
        }
        if !self.effect.is_known() {
            return Err(ValidationError::UnknownCode { item: "PER" });
        }
        Ok(())
    }
}

item_set! {
    /// Type 2101 request: the pose to relocalise the robot at.
    pub struct Relocalize {
        /// Position in the map frame, m.
        pub pos_x: f32 = "PosX";
        /// Position in the map frame, m.
        pub pos_y: f32 = "PosY";
        /// Position in the map frame, m.
        pub pos_z: f32 = "PosZ";
        /// Rotation about the z axis, rad.
        pub yaw: f32 = "Yaw";
    }
}

item_set! {
    answer
    /// Type 2101 answer: whether the robot is localised after the request.
    pub struct RelocalizeAck {
        /// Localised or abnormal.
        #[cfg_attr(feature = "serde", serde(rename = "error_code"))]
        pub result: LocalizationResult = "ErrorCode";
    }
}
