//! Answers that describe the robot: status (1002), battery (2001), perception (2002) and
//! motor temperatures (1008).

use super::items::item_set;
use crate::proto::codes::{
    ChargeState, ControlMode, GaitState, Location, MotionState, MotorState, ObsState, OnDockState,
    ProtectedState,
};

item_set! {
    answer
    /// Type 1002 answer: the robot's real-time basic status.
    ///
    /// Only `MotionState` is required: the panel cannot confirm an e-stop without it. A
    /// robot that leaves out any other item (a robot_server of another version, or one that
    /// lacks the reading) still has the rest read: an absent float is NaN, the value a robot
    /// writes (`nan`) for a reading it does not have, and an absent integer or code is
    /// `None`. So one missing map item never costs the panel its e-stop confirmation.
    pub struct RobotStatus {
        /// Motion state.
        pub motion_state: MotionState = "MotionState";
        /// Position in the map frame, m.
        pub pos_x: f32 = "PosX", optional;
        /// Position in the map frame, m.
        pub pos_y: f32 = "PosY", optional;
        /// Position in the map frame, m.
        pub pos_z: f32 = "PosZ", optional;
        /// Attitude in the map frame, rad.
        pub roll: f32 = "Roll", optional;
        /// Attitude in the map frame, rad.
        pub pitch: f32 = "Pitch", optional;
        /// Attitude in the map frame, rad.
        pub yaw: f32 = "Yaw", optional;
        /// Forward speed, m/s.
        pub speed: f32 = "Speed", optional;
        /// Odometry since power-on, km.
        pub cur_odom: f32 = "CurOdom", optional;
        /// Total odometry, km.
        pub sum_odom: f32 = "SumOdom", optional;
        /// Metres per map-image pixel.
        pub res: f32 = "Res", optional;
        /// Map-frame x of the map image's bottom-left corner, m.
        pub x0: f32 = "X0", optional;
        /// Map-frame y of the map image's bottom-left corner, m.
        pub y0: f32 = "Y0", optional;
        /// Map image height, px.
        pub h: Option<i32> = "H", optional;
        /// Battery charge, %.
        pub electricity: Option<i32> = "Electricity", optional;
        /// Localisation state.
        pub location: Option<Location> = "Location", optional;
        /// Gait (the 1002 numbering).
        pub gait_state: Option<GaitState> = "GaitState", optional;
        /// Motor state.
        pub motor_state: Option<MotorState> = "MotorState", optional;
        /// Charging state.
        pub charge_state: Option<ChargeState> = "ChargeState", optional;
        /// Manual or automatic control.
        pub control_mode: Option<ControlMode> = "ControlMode", optional;
        /// Whether the robot lies on its dock.
        pub on_dock_state: Option<OnDockState> = "OnDockState", optional;
    }
}

impl RobotStatus {
    /// The answer with every item 0, which the robot sends when it cannot read its status
    /// or the navigation program is not running.
    pub const UNAVAILABLE: Self = Self {
        motion_state: MotionState::LyingDown,
        pos_x: 0.0,
        pos_y: 0.0,
        pos_z: 0.0,
        roll: 0.0,
        pitch: 0.0,
        yaw: 0.0,
        speed: 0.0,
        cur_odom: 0.0,
        sum_odom: 0.0,
        res: 0.0,
        x0: 0.0,
        y0: 0.0,
        h: Some(0),
        electricity: Some(0),
        location: Some(Location::Localized),
        gait_state: Some(GaitState::Walk),
        motor_state: Some(MotorState::Normal),
        charge_state: Some(ChargeState::NotCharging),
        control_mode: Some(ControlMode::Manual),
        on_dock_state: Some(OnDockState::OffDock),
    };

    /// Whether every item is 0, which the robot sends when it cannot read its status or
    /// the navigation program is not running: not a robot lying at the origin. Absent items
    /// (and floats the robot wrote as `nan`) say nothing either way; a status that reports
    /// nothing beside `MotionState` does not show the pattern, so its `MotionState` counts.
    pub fn is_unavailable(&self) -> bool {
        let floats = [
            self.pos_x,
            self.pos_y,
            self.pos_z,
            self.roll,
            self.pitch,
            self.yaw,
            self.speed,
            self.cur_odom,
            self.sum_odom,
            self.res,
            self.x0,
            self.y0,
        ];
        let integers = [
            self.h,
            self.electricity,
            self.location.map(Location::raw),
            self.gait_state.map(GaitState::raw),
            self.motor_state.map(MotorState::raw),
            self.charge_state.map(ChargeState::raw),
            self.control_mode.map(ControlMode::raw),
            self.on_dock_state.map(OnDockState::raw),
        ];
        let floats = floats.into_iter().filter(|f| !f.is_nan()).map(|f| f == 0.0);
        let mut zero = floats
            .chain(integers.into_iter().flatten().map(|i| i == 0))
            .peekable();
        self.motion_state.raw() == 0 && zero.peek().is_some() && zero.all(|z| z)
    }

    /// The map image geometry this status reports; `None` without the image height.
    pub fn map_image(&self) -> Option<MapImage> {
        Some(MapImage {
            res: self.res,
            x0: self.x0,
            y0: self.y0,
            h: self.h?,
        })
    }
}

/// Geometry of the robot's map image, for converting between map and pixel coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MapImage {
    /// Metres per pixel.
    pub res: f32,
    /// Map-frame x of the bottom-left corner, m.
    pub x0: f32,
    /// Map-frame y of the bottom-left corner, m.
    pub y0: f32,
    /// Image height, px.
    pub h: i32,
}

impl MapImage {
    /// Pixel of a map-frame point: `x_p = (x − X0) / Res`, `y_p = H − (y − Y0) / Res`,
    /// rounded to the nearest integer; `None` when `Res` is not positive or the result is
    /// not finite.
    pub fn to_pixel(&self, x: f32, y: f32) -> Option<(i32, i32)> {
        if self.res.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
            return None;
        }
        let xp = (x - self.x0) / self.res;
        let yp = self.h as f32 - (y - self.y0) / self.res;
        Some((round(xp)?, round(yp)?))
    }

    /// Map-frame point at the centre of a pixel: the inverse of [`MapImage::to_pixel`].
    pub fn to_map(&self, xp: i32, yp: i32) -> (f32, f32) {
        let x = xp as f32 * self.res + self.x0;
        let y = (self.h - yp) as f32 * self.res + self.y0;
        (x, y)
    }
}

/// Rounds half away from zero without `std`; `None` outside the `i32` range.
fn round(v: f32) -> Option<i32> {
    let limit = 2_147_483_520.0; // the largest f32 below 2^31
    if !(-limit..=limit).contains(&v) {
        return None;
    }
    let half = if v < 0.0 { -0.5 } else { 0.5 };
    Some((v + half) as i32)
}

item_set! {
    answer
    /// Type 2001 answer: battery state.
    ///
    /// Every item is optional, as in the status (1002): a robot that leaves one out, or
    /// writes one that cannot be read, still has the rest read, the missing integer or
    /// code `None`. So one unreadable reading never costs the panel the battery's
    /// protection state.
    pub struct Battery {
        /// Voltage, V.
        pub voltage: Option<i32> = "Voltage", optional;
        /// Current, in units of 10 mA.
        pub current: Option<i32> = "Current", optional;
        /// Remaining capacity, in units of 10 mAh.
        pub remaining_capacity: Option<i32> = "RemainingCapacity", optional;
        /// Nominal capacity, in units of 10 mAh.
        pub nominal_capacity: Option<i32> = "NominalCapacity", optional;
        /// Charge cycles.
        pub cycles: Option<i32> = "Cycles", optional;
        /// Whether the battery's protection has triggered.
        pub protected_state: Option<ProtectedState> = "ProtectedState", optional;
        /// Charge, %.
        pub battery_level: Option<i32> = "BatteryLevel", optional;
        /// Temperature, °C; absent before protocol V1.0.11.
        pub battery_temperature: Option<f32> = "BatteryTemperature", optional;
    }
}

item_set! {
    answer
    /// Type 2002 answer: perception state.
    pub struct Perception {
        /// Whether an obstacle is on the planned path within 2 m.
        pub obs_state: ObsState = "ObsState";
    }
}

item_set! {
    answer
    /// Type 1008 answer: the twelve joint motor temperatures, °C. A temperature the robot
    /// leaves out, or writes in a form that cannot be read (a decimal comma, as a C library
    /// under some locales prints it), is NaN: one unreadable motor must not cost the panel
    /// the other eleven.
    pub struct MotorTemperatures {
        /// Left front sway (hip abduction) joint.
        pub left_front_sway: f32 = "LeftFrontSway", optional;
        /// Left front hip joint.
        pub left_front_hip: f32 = "LeftFrontHip", optional;
        /// Left front knee joint.
        pub left_front_knee: f32 = "LeftFrontKnee", optional;
        /// Right front sway joint.
        pub right_front_sway: f32 = "RightFrontSway", optional;
        /// Right front hip joint.
        pub right_front_hip: f32 = "RightFrontHip", optional;
        /// Right front knee joint.
        pub right_front_knee: f32 = "RightFrontKnee", optional;
        /// Left back sway joint.
        pub left_back_sway: f32 = "LeftBackSway", optional;
        /// Left back hip joint.
        pub left_back_hip: f32 = "LeftBackHip", optional;
        /// Left back knee joint.
        pub left_back_knee: f32 = "LeftBackKnee", optional;
        /// Right back sway joint.
        pub right_back_sway: f32 = "RightBackSway", optional;
        /// Right back hip joint.
        pub right_back_hip: f32 = "RightBackHip", optional;
        /// Right back knee joint.
        pub right_back_knee: f32 = "RightBackKnee", optional;
    }
}

impl MotorTemperatures {
    /// All twelve temperatures, left front first, in the document's order.
    pub fn all(&self) -> [f32; 12] {
        [
            self.left_front_sway,
            self.left_front_hip,
            self.left_front_knee,
            self.right_front_sway,
            self.right_front_hip,
            self.right_front_knee,
            self.left_back_sway,
            self.left_back_hip,
            self.left_back_knee,
            self.right_back_sway,
            self.right_back_hip,
            self.right_back_knee,
        ]
    }

    /// The hottest motor's temperature, of those reported; NaN if none is.
    pub fn max(&self) -> f32 {
        self.all()
            .into_iter()
            .filter(|t| !t.is_nan())
            .reduce(f32::max)
            .unwrap_or(f32::NAN)
    }
}
