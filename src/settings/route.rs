//! The patrol route: points the `patrol` button walks through, one 1003 after another,
//! saved with the settings.
//!
//! A point is written like the dock point, with its type after it:
//! `point,map,x,y,z,yaw[,type]`, the type being `transition`, `task`, `standing` or
//! `charging` (or its number, 0–3), `task` when left out: the robot arrives precisely and
//! stands, then the panel sends the next point.

use core::fmt;

use super::text::parse_dock;
use super::write_f32;
use crate::proto::codes::PointInfo;
use crate::proto::message::NavPoint;

/// Most points a route holds.
pub const MAX_ROUTE: usize = 32;

/// The store's key id for a route point (one entry per point, in order); never a key's id.
pub const ROUTE_ID: u8 = 64;

/// The point type when none is written.
pub const DEFAULT_POINT_INFO: PointInfo = PointInfo::Task;

/// One point of the route.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RoutePoint {
    /// The point's number (`Value`).
    pub point: i32,
    /// The map's number (`MapID`).
    pub map: i32,
    /// x, y, z (m) and yaw (rad) in the map frame.
    pub pose: [f32; 4],
    /// What the robot does there (`PointInfo`).
    pub info: PointInfo,
}

/// The points of the patrol, in order.
pub type Route = heapless::Vec<RoutePoint, MAX_ROUTE>;

impl RoutePoint {
    /// Parses `point,map,x,y,z,yaw[,type]`.
    pub fn parse(text: &str) -> Option<Self> {
        let text = text.trim();
        // The type, if any, follows the sixth comma.
        let (numbers, info) = match text.match_indices(',').nth(5) {
            Some((at, _)) => (text.get(..at)?, parse_point_info(text.get(at + 1..)?)?),
            None => (text, DEFAULT_POINT_INFO),
        };
        let dock = parse_dock(numbers)?;
        let point = Self {
            point: dock.point,
            map: dock.map,
            pose: dock.pose,
            info,
        };
        point.nav_point().validate().ok().map(|()| point)
    }

    /// The 1003 point the panel sends.
    pub fn nav_point(&self) -> NavPoint {
        let [x, y, z, yaw] = self.pose;
        NavPoint::new(self.point, self.map, x, y, z, yaw, self.info)
    }

    /// Writes the point as [`RoutePoint::parse`] reads it.
    pub fn write(&self, out: &mut impl fmt::Write) -> fmt::Result {
        write!(out, "{},{}", self.point, self.map)?;
        for value in self.pose {
            out.write_char(',')?;
            write_f32(out, value)?;
        }
        write!(out, ",{}", point_info_word(self.info))
    }
}

/// The word for a point type.
pub fn point_info_word(info: PointInfo) -> &'static str {
    match info {
        PointInfo::Transition => "transition",
        PointInfo::Task => "task",
        PointInfo::Standing => "standing",
        PointInfo::Charging => "charging",
        PointInfo::Unknown(_) => "unknown",
    }
}

/// Parses a point type: its word or its number (0–3), any case.
pub fn parse_point_info(text: &str) -> Option<PointInfo> {
    let text = text.trim();
    let known = [
        PointInfo::Transition,
        PointInfo::Task,
        PointInfo::Standing,
        PointInfo::Charging,
    ];
    known.into_iter().find(|&info| {
        text.eq_ignore_ascii_case(point_info_word(info))
            || text.parse::<i32>().ok() == Some(info.raw())
    })
}
