//! Board support: the only code that knows which pins and peripherals the panel runs on.
//!
//! Exactly one `board-*` feature selects the module; each provides `run(spawner)`, which
//! brings the board up and runs the panel, and the `Executor` it runs on, so `main` stays
//! board-agnostic.

/// Logs through the board's logger: defmt on the Nucleo-F767ZI, the `log` crate on QEMU.
/// `board_log!(info, "…", args)`; the format string must suit both (`{}` and `{:?}`).
macro_rules! board_log {
    ($level:ident, $($arg:tt)*) => {{
        #[cfg(feature = "board-nucleo-f767zi")]
        defmt::$level!($($arg)*);
        #[cfg(feature = "board-qemu-mps2-an386")]
        log::$level!($($arg)*);
    }};
}

#[cfg(any(feature = "board-nucleo-f767zi", feature = "board-qemu-mps2-an386"))]
mod glue;
#[cfg(feature = "board-nucleo-f767zi")]
mod nucleo_f767zi;
#[cfg(feature = "board-nucleo-f767zi")]
pub use {embassy_executor::Executor, nucleo_f767zi::run};

#[cfg(feature = "board-qemu-mps2-an386")]
pub mod qemu_mps2_an386;
#[cfg(feature = "board-qemu-mps2-an386")]
pub use qemu_mps2_an386::{executor::Executor, run};

// The client's TCP transport, for the boards with an embassy-net stack.
#[cfg(any(feature = "board-nucleo-f767zi", feature = "board-qemu-mps2-an386"))]
pub mod net;

// The status and settings page's server, on the same stack.
#[cfg(any(feature = "board-nucleo-f767zi", feature = "board-qemu-mps2-an386"))]
mod web;

/// Runs the board's executor with the tasks `init` spawns, forever.
#[cfg(any(feature = "board-nucleo-f767zi", feature = "board-qemu-mps2-an386"))]
pub fn start(init: impl FnOnce(embassy_executor::Spawner)) -> ! {
    static EXECUTOR: static_cell::StaticCell<Executor> = static_cell::StaticCell::new();
    EXECUTOR.init(Executor::new()).run(init)
}

// Without this, naming `_firmware` alone would fail later with unresolved `board::run`.
#[cfg(not(any(feature = "board-nucleo-f767zi", feature = "board-qemu-mps2-an386")))]
compile_error!(
    "enable one board feature: `board-nucleo-f767zi` (`cargo nucleo`, `cargo build-nucleo`) \
     or `board-qemu-mps2-an386` (`cargo build-qemu`)"
);
