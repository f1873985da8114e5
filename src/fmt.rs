//! The crate's one logging shim: `trace!`, `debug!`, `info!`, `warn!` and `error!`.
//!
//! Portable code cannot call defmt directly: defmt needs a global logger and linker sections
//! that host builds do not have, so host tests would fail to link. These macros forward to
//! `defmt` with the `defmt` feature (firmware), else to the `log` crate with the `log` feature
//! (host programs and tests), else to nothing (the arguments are still borrowed, so they count
//! as used). `defmt` wins when both are on, so no feature combination fails to build.
//!
//! Format strings must suit both back ends: `{}` for integers and strings, `{:?}` for
//! everything else (defmt takes both through `Format`; `log` through `Display`/`Debug`).
#![allow(unused_macros)]

/// Logs at `$level` through whichever back end is enabled.
macro_rules! log_at {
    ($level:ident, $s:literal $(, $x:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        ::defmt::$level!($s $(, $x)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        ::log::$level!($s $(, $x)*);
        #[cfg(not(any(feature = "defmt", feature = "log")))]
        {
            let _ = ($(&$x),*);
        }
    }};
}

macro_rules! trace { ($($t:tt)*) => { log_at!(trace, $($t)*) }; }
macro_rules! debug { ($($t:tt)*) => { log_at!(debug, $($t)*) }; }
macro_rules! info { ($($t:tt)*) => { log_at!(info, $($t)*) }; }
macro_rules! warn { ($($t:tt)*) => { log_at!(warn, $($t)*) }; }
macro_rules! error { ($($t:tt)*) => { log_at!(error, $($t)*) }; }
