//! The crate's one logging shim: `trace!`, `debug!`, `info!`, `warn!` and `error!`.
//!
//! Portable code cannot call defmt directly: defmt needs a global logger and linker sections
//! that host builds do not have, so host tests would fail to link. These macros forward to
//! `defmt` with the `defmt` feature (firmware), else to the `log` crate with the `log` feature
//! (host programs and tests), else to nothing. `defmt` wins when both are on, so no feature
//! combination fails to build.
//!
//! Format strings must suit both back ends: use `{}` and `{:?}` only, with arguments that
//! implement `defmt::Format` as well as `Display` or `Debug` (every type of this crate derives
//! both).

// Not every level is used yet; the shim still offers all five so that call sites never
// reach for defmt or log directly.
#![allow(unused_macros)]

/// Most detailed level: every event of a state machine.
macro_rules! trace {
    ($s:literal $(, $x:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        ::defmt::trace!($s $(, $x)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        ::log::trace!($s $(, $x)*);
        // Evaluates nothing but borrows the arguments, so they count as used.
        #[cfg(not(any(feature = "defmt", feature = "log")))]
        let _ = ($(&$x,)*);
    }};
}

/// Decisions worth seeing while debugging: a press dropped, a lock released.
macro_rules! debug {
    ($s:literal $(, $x:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        ::defmt::debug!($s $(, $x)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        ::log::debug!($s $(, $x)*);
        #[cfg(not(any(feature = "defmt", feature = "log")))]
        let _ = ($(&$x,)*);
    }};
}

/// Normal operation a field engineer wants in the log: connections, e-stops, tasks.
macro_rules! info {
    ($s:literal $(, $x:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        ::defmt::info!($s $(, $x)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        ::log::info!($s $(, $x)*);
        #[cfg(not(any(feature = "defmt", feature = "log")))]
        let _ = ($(&$x,)*);
    }};
}

/// Something went wrong but the panel carries on: a full queue, a bad setting.
macro_rules! warn {
    ($s:literal $(, $x:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        ::defmt::warn!($s $(, $x)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        ::log::warn!($s $(, $x)*);
        #[cfg(not(any(feature = "defmt", feature = "log")))]
        let _ = ($(&$x,)*);
    }};
}

/// Something the panel cannot do its job without.
macro_rules! error {
    ($s:literal $(, $x:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        ::defmt::error!($s $(, $x)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        ::log::error!($s $(, $x)*);
        #[cfg(not(any(feature = "defmt", feature = "log")))]
        let _ = ($(&$x,)*);
    }};
}
