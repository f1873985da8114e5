//! Bounded exponential backoff between reconnection attempts.

use embassy_time::Duration;

/// Delays that double after each failure, from `min` up to `max`, and start again from
/// `min` after a success: quick to recover from a blip, gentle on a robot that is down.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Backoff {
    min: Duration,
    max: Duration,
    next: Duration,
}

impl Backoff {
    /// A backoff between `min` and `max` (a `max` below `min` is raised to `min`).
    pub const fn new(min: Duration, max: Duration) -> Self {
        let max = if max.as_ticks() < min.as_ticks() {
            min
        } else {
            max
        };
        Self {
            min,
            max,
            next: min,
        }
    }

    /// The delay before the next attempt; the one after it will be twice as long, up to
    /// the maximum.
    pub fn next_delay(&mut self) -> Duration {
        let delay = self.next;
        let doubled = Duration::from_ticks(self.next.as_ticks().saturating_mul(2));
        self.next = if doubled > self.max {
            self.max
        } else {
            doubled
        };
        delay
    }

    /// Starts again from the minimum, after a successful connection.
    pub fn reset(&mut self) {
        self.next = self.min;
    }
}
