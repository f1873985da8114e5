//! The wall-clock `Time` every request carries, learned from the robot.
//!
//! The panel has no battery-backed clock. Every answer carries the robot's local time, so
//! the panel remembers the latest one with the instant it arrived and counts on from
//! there; before the first answer it counts from a fixed epoch plus uptime.

use embassy_time::Instant;

use crate::proto::time::Timestamp;

/// The robot's wall clock as far as the panel knows it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RobotClock {
    /// The robot's time at an instant of our own clock.
    learned: Option<(Timestamp, Instant)>,
}

impl RobotClock {
    /// A clock that has heard nothing from the robot yet.
    pub const fn new() -> Self {
        Self { learned: None }
    }

    /// Remembers the `Time` of an answer received at `at`. The all-zero time of Type 0
    /// answers says nothing about the clock and is ignored.
    pub fn learn(&mut self, time: Timestamp, at: Instant) {
        if time.month != 0 && time.day != 0 {
            self.learned = Some((time, at));
        }
    }

    /// Whether the robot's time has been learned.
    pub fn is_learned(&self) -> bool {
        self.learned.is_some()
    }

    /// The robot's time at `now`: the last learned time plus what has passed since, or the
    /// protocol document's epoch plus uptime.
    pub fn at(&self, now: Instant) -> Timestamp {
        match self.learned {
            Some((time, at)) => time.plus_seconds(now.saturating_duration_since(at).as_secs()),
            None => Timestamp::DOCUMENT_EPOCH.plus_seconds(now.as_secs()),
        }
    }
}
