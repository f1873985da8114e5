//! The robot's wall clock, for the `Time` element of its answers.

use std::time::{SystemTime, UNIX_EPOCH};

use x30_panel::proto::time::Timestamp;

const UNIX_EPOCH_TIME: Timestamp = Timestamp {
    year: 1970,
    month: 1,
    day: 1,
    hour: 0,
    minute: 0,
    second: 0,
};

/// The current time as the robot writes it in answers.
///
/// The robot writes its local time; std has no time zones, so the simulator writes UTC.
/// Clients must not act on it (the robot does not act on theirs either).
pub fn wall_time() -> Timestamp {
    let seconds = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    UNIX_EPOCH_TIME.plus_seconds(seconds)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn is_a_plausible_date() {
        let now = wall_time();
        assert!(now.year >= 2024, "{now:?}");
        assert!((1..=12).contains(&now.month) && (1..=31).contains(&now.day));
    }
}
