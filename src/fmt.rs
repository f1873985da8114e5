//! The one logging shim: `defmt` on the target, `log` on the host, nothing when neither
//! feature is on. Portable code logs through these macros only, because defmt's macros fail
//! to link in host tests.
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
