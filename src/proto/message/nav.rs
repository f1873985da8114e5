//! Navigation: tasks (1003), cancelling them (1004) and asking how they go (1007).

use super::ValidationError;
use super::items::item_set;
use crate::proto::codes::{
    CommandResult, ErrorStatus, Manner, NavGait, NavMode, NavOutcome, NavSpeed, NavTaskStatus,
    ObsMode, PointInfo, Posture, Terrain,
};

/// Most waypoints one 1003 request may carry, one `<Items>` block each.
pub const MAX_NAV_POINTS: usize = crate::proto::xml::MAX_ITEMS_BLOCKS;

item_set! {
    /// One target point of a Type 1003 navigation task: where to go and how.
    pub struct NavPoint {
        /// Target point number, echoed in the answer.
        pub value: i32 = "Value";
        /// Grid-map number, as in the robot's map.toml. `MapId` is accepted when reading.
        pub map_id: i32 = "MapID";
        /// Target in the map frame, m.
        pub pos_x: f32 = "PosX";
        /// Target in the map frame, m.
        pub pos_y: f32 = "PosY";
        /// Target in the map frame, m.
        pub pos_z: f32 = "PosZ";
        /// Heading at the target, rad.
        pub angle_yaw: f32 = "AngleYaw";
        /// What the robot does on arrival.
        pub point_info: PointInfo = "PointInfo";
        /// Gait on the way (the 1003 numbering).
        pub gait: NavGait = "Gait";
        /// Speed on the way.
        pub speed: NavSpeed = "Speed";
        /// Walking forwards or backwards.
        pub manner: Manner = "Manner";
        /// Whether navigation stops for or avoids obstacles.
        pub obs_mode: ObsMode = "ObsMode";
        /// Straight line or planned path.
        pub nav_mode: NavMode = "NavMode";
        /// Terrain-map mode on the way.
        pub terrain: Terrain = "Terrain";
        /// Body height on the way; absent before protocol V1.0.9, meaning normal height.
        pub posture: Posture = "Posture", optional;
    }
}

impl NavPoint {
    /// A point with the document's defaults: walk at normal speed, forwards, obstacle
    /// stop on, straight line, solid ground, normal height.
    pub fn new(
        value: i32,
        map_id: i32,
        x: f32,
        y: f32,
        z: f32,
        angle_yaw: f32,
        point_info: PointInfo,
    ) -> Self {
        Self {
            value,
            map_id,
            pos_x: x,
            pos_y: y,
            pos_z: z,
            angle_yaw,
            point_info,
            gait: NavGait::Walk,
            speed: NavSpeed::Normal,
            manner: Manner::Forwards,
            obs_mode: ObsMode::Enabled,
            nav_mode: NavMode::StraightLine,
            terrain: Terrain::Solid,
            posture: Posture::Normal,
        }
    }

    /// Checks the point against the document's rules before it is sent: known codes,
    /// finite coordinates, accumulated-frame terrain only with gaits 6 and 7, crouched
    /// posture only with walk and slope gaits.
    pub fn validate(&self) -> Result<(), ValidationError> {
        let coordinates = [
            ("PosX", self.pos_x),
            ("PosY", self.pos_y),
            ("PosZ", self.pos_z),
            ("AngleYaw", self.angle_yaw),
        ];
        if let Some((item, _)) = coordinates.iter().find(|(_, v)| !v.is_finite()) {
            return Err(ValidationError::NotFinite { item });
        }
        let codes = [
            ("PointInfo", self.point_info.is_known()),
            ("Gait", self.gait.is_known()),
            ("Speed", self.speed.is_known()),
            ("Manner", self.manner.is_known()),
            ("ObsMode", self.obs_mode.is_known()),
            ("NavMode", self.nav_mode.is_known()),
            ("Terrain", self.terrain.is_known()),
            ("Posture", self.posture.is_known()),
        ];
        if let Some((item, _)) = codes.iter().find(|(_, known)| !known) {
            return Err(ValidationError::UnknownCode { item });
        }
        let frame_gait = matches!(
            self.gait,
            NavGait::AccumulatedFrameStairs | NavGait::AccumulatedFrameStairs45
        );
        if self.terrain == Terrain::AccumulatedFrame && !frame_gait {
            return Err(ValidationError::GaitNotAllowedOnTerrain);
        }
        if self.posture == Posture::Crouched && !matches!(self.gait, NavGait::Walk | NavGait::Slope)
        {
            return Err(ValidationError::GaitNotAllowedWhenCrouched);
        }
        Ok(())
    }
}

/// Type 1003 request: a navigation task to one point, or (as some clients send) several
/// waypoints in order.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct NavTask {
    /// The points, in the order they are to be reached; never empty.
    pub points: heapless::Vec<NavPoint, MAX_NAV_POINTS>,
}

impl NavTask {
    /// A task to a single point, the form protocol V1.0.12 describes.
    pub fn to_point(point: NavPoint) -> Self {
        let mut points = heapless::Vec::new();
        // Capacity is at least one, so this cannot fail; ignoring the result keeps it panic-free.
        let _ = points.push(point);
        Self { points }
    }

    /// The final point, whose number the answer echoes.
    pub fn target(&self) -> Option<&NavPoint> {
        self.points.last()
    }

    /// Validates every point.
    pub fn validate(&self) -> Result<(), ValidationError> {
        if self.points.is_empty() {
            return Err(ValidationError::NoPoints);
        }
        self.points.iter().try_for_each(NavPoint::validate)
    }
}

item_set! {
    answer
    /// Type 1003 answer, sent when the task has ended.
    pub struct NavResult {
        /// Target point number, as requested.
        pub value: i32 = "Value";
        /// Succeeded, failed or cancelled.
        #[cfg_attr(feature = "serde", serde(rename = "error_code"))]
        pub outcome: NavOutcome = "ErrorCode";
        /// Why; absent before protocol V1.0.9.
        #[cfg_attr(feature = "serde", serde(rename = "error_status"))]
        pub status: ErrorStatus = "ErrorStatus", optional;
    }
}

item_set! {
    answer
    /// Answer carrying only a success/failure `ErrorCode`: Type 1004 (cancel), Type 1101
    /// (indicator light).
    pub struct CommandAck {
        /// Whether the command succeeded.
        #[cfg_attr(feature = "serde", serde(rename = "error_code"))]
        pub result: CommandResult = "ErrorCode";
    }
}

item_set! {
    answer
    /// Type 1007 answer: the state of the current or last navigation task.
    pub struct NavTaskState {
        /// Target point number of the current or last task.
        pub value: i32 = "Value";
        /// Finished, running, or cannot run.
        pub status: NavTaskStatus = "Status";
        /// The same code as `status`, as the robot sends it.
        pub error_code: NavTaskStatus = "ErrorCode";
    }
}
