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

/// A Type 2 motion command with its `Value`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MotionCommand {
    /// Command 1: walk forwards, 0..=1.5 m/s (default 0.5). Repeat at 3–5 Hz.
    Forward(Speed),
    /// Command 2: walk backwards, 0..=1.3 m/s (default 0.5). Repeat at 3–5 Hz.
    Backward(Speed),
    /// Command 3: turn left, 0..=0.45 rad/s (default 0.35). Repeat at 3–5 Hz.
    TurnLeft(Speed),
    /// Command 4: turn right, 0..=0.45 rad/s (default 0.35). Repeat at 3–5 Hz.
    TurnRight(Speed),
    /// Command 6: zero velocity.
    ZeroVelocity,
    /// Command 11: strafe left, 0..=0.15 m/s (default 0.1). Repeat at 3–5 Hz.
    StrafeLeft(Speed),
    /// Command 12: strafe right, 0..=0.15 m/s (default 0.1). Repeat at 3–5 Hz.
    StrafeRight(Speed),
    /// Command 13: soft emergency stop.
    SoftEmergencyStop,
    /// Command 14: stop stepping.
    StopStepping,
    /// Command 15: lie down.
    LieDown,
    /// Command 20: switch gait.
    SwitchGait(MotionGait),
    /// Command 16: stand up (beyond V1.0.12).
    #[cfg(feature = "vendor-extensions")]
    StandUp,
    /// Command 17: force-control mode (beyond V1.0.12).
    #[cfg(feature = "vendor-extensions")]
    ForceControl,
    /// Command 18: start stepping (beyond V1.0.12).
    #[cfg(feature = "vendor-extensions")]
    StartStepping,
    /// Command 19: body height, value as the vendor software sends it (beyond V1.0.12).
    #[cfg(feature = "vendor-extensions")]
    BodyHeight(f32),
    /// Command 21: go charging (beyond V1.0.12).
    #[cfg(feature = "vendor-extensions")]
    GoCharging,
    /// Command 22: leave the charger (beyond V1.0.12).
    #[cfg(feature = "vendor-extensions")]
    LeaveCharger,
}

/// `Value` of commands that take none.
const PLACEHOLDER: f32 = -1.0;

impl MotionCommand {
    /// The `Command` code.
    pub fn code(&self) -> MotionCommandCode {
        use MotionCommandCode as C;
        match self {
            Self::Forward(_) => C::Forward,
            Self::Backward(_) => C::Backward,
            Self::TurnLeft(_) => C::TurnLeft,
            Self::TurnRight(_) => C::TurnRight,
            Self::ZeroVelocity => C::ZeroVelocity,
            Self::StrafeLeft(_) => C::StrafeLeft,
            Self::StrafeRight(_) => C::StrafeRight,
            Self::SoftEmergencyStop => C::SoftEmergencyStop,
            Self::StopStepping => C::StopStepping,
            Self::LieDown => C::LieDown,
            Self::SwitchGait(_) => C::SwitchGait,
            #[cfg(feature = "vendor-extensions")]
            Self::StandUp => C::StandUp,
            #[cfg(feature = "vendor-extensions")]
            Self::ForceControl => C::ForceControl,
            #[cfg(feature = "vendor-extensions")]
            Self::StartStepping => C::StartStepping,
            #[cfg(feature = "vendor-extensions")]
            Self::BodyHeight(_) => C::BodyHeight,
            #[cfg(feature = "vendor-extensions")]
            Self::GoCharging => C::GoCharging,
            #[cfg(feature = "vendor-extensions")]
            Self::LeaveCharger => C::LeaveCharger,
        }
    }

    /// The `Value` item as sent: a speed, a gait number, or the −1 placeholder.
    pub fn value(&self) -> MotionValue {
        match *self {
            Self::Forward(s)
            | Self::Backward(s)
            | Self::TurnLeft(s)
            | Self::TurnRight(s)
            | Self::StrafeLeft(s)
            | Self::StrafeRight(s) => MotionValue::Float(s.to_wire()),
            Self::SwitchGait(gait) => MotionValue::Int(gait.raw()),
            #[cfg(feature = "vendor-extensions")]
            Self::BodyHeight(v) => MotionValue::Float(v),
            _ => MotionValue::Float(PLACEHOLDER),
        }
    }

    /// Builds a command from its code and `Value`; `None` for a code this build does not
    /// know or a gait value that is not an integer.
    pub fn from_parts(code: MotionCommandCode, value: f32) -> Option<Self> {
        use MotionCommandCode as C;
        let speed = Speed::from_wire(value);
        Some(match code {
            C::Forward => Self::Forward(speed),
            C::Backward => Self::Backward(speed),
            C::TurnLeft => Self::TurnLeft(speed),
            C::TurnRight => Self::TurnRight(speed),
            C::ZeroVelocity => Self::ZeroVelocity,
            C::StrafeLeft => Self::StrafeLeft(speed),
            C::StrafeRight => Self::StrafeRight(speed),
            C::SoftEmergencyStop => Self::SoftEmergencyStop,
            C::StopStepping => Self::StopStepping,
            C::LieDown => Self::LieDown,
            C::SwitchGait => Self::SwitchGait(MotionGait::from_raw(integral(value)?)),
            #[cfg(feature = "vendor-extensions")]
            C::StandUp => Self::StandUp,
            #[cfg(feature = "vendor-extensions")]
            C::ForceControl => Self::ForceControl,
            #[cfg(feature = "vendor-extensions")]
            C::StartStepping => Self::StartStepping,
            #[cfg(feature = "vendor-extensions")]
            C::BodyHeight => Self::BodyHeight(value),
            #[cfg(feature = "vendor-extensions")]
            C::GoCharging => Self::GoCharging,
            #[cfg(feature = "vendor-extensions")]
            C::LeaveCharger => Self::LeaveCharger,
            C::Unknown(_) => return None,
        })
    }

    /// Whether the robot expects this command repeated at 3–5 Hz while motion continues.
    pub fn is_continuous(&self) -> bool {
        self.speed_limit().is_some()
    }

    /// Largest speed the document allows, for the translation and rotation commands.
    pub fn speed_limit(&self) -> Option<f32> {
        match self {
            Self::Forward(_) => Some(1.5),
            Self::Backward(_) => Some(1.3),
            Self::TurnLeft(_) | Self::TurnRight(_) => Some(0.45),
            Self::StrafeLeft(_) | Self::StrafeRight(_) => Some(0.15),
            _ => None,
        }
    }

    /// Checks the command against the document before it is sent: speeds −1 or within
    /// 0..=limit, gaits known.
    pub fn validate(&self) -> Result<(), ValidationError> {
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
            #[cfg(feature = "vendor-extensions")]
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
    /// Type 2 answer: the command's value echoed and whether it was carried out.
    pub struct MotionAck {
        /// `Value` as requested (a gait number arrives as an integral float).
        pub value: f32 = "Value";
        /// Success, or failure (a navigation task running, a bad speed).
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
    /// Type 2101 answer: whether the robot is localised after the request.
    pub struct RelocalizeAck {
        /// Localised or abnormal.
        pub result: LocalizationResult = "ErrorCode";
    }
}
