//! The panel's logic, board-agnostic: plain state machines fed with events and time.
//!
//! From the buttons upward:
//!
//! - [`buttons`]: the fourteen [`Button`]s and a [`Debouncer`] that turns raw pin levels into
//!   one press and one release per push.
//! - [`control`]: [`Control`] turns presses and releases into [`Action`]s (commands to send),
//!   with motion repeats, e-stop priority and lock-out, and navigation cancelling.
//! - [`monitor`]: [`Monitor`] schedules the polls of the robot's state, and [`RobotView`]
//!   keeps the latest answers with their age.
//!
//! Nothing here does I/O, reads a clock or allocates: every input carries its time (`now`),
//! and every output is pulled, so host tests drive the panel with simulated time and no
//! network.

pub mod buttons;
pub mod control;
pub mod monitor;

pub use buttons::{Button, ButtonDebouncers, ButtonEvent, Debouncer};
pub use control::{Action, Control, succeeded};
pub use monitor::{Monitor, RobotView, Stamped};

use embassy_time::{Duration, Instant};

/// The next deadline of a periodic job that ran at `now` for the deadline `due`: one period
/// after `due`, so late wake-ups do not slow the rate down, but never at or before `now`, so
/// a loop that stalled does not send a burst to catch up.
pub(crate) fn next_after(due: Instant, period: Duration, now: Instant) -> Instant {
    let next = due.saturating_add(period);
    if next > now {
        next
    } else {
        now.saturating_add(period)
    }
}
