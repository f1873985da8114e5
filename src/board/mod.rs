//! Board support: the only code that knows which pins and peripherals the panel runs on.
//!
//! Exactly one `board-*` feature selects the module; each provides `init()` returning a
//! `Board` with the same field names, so `main` stays board-agnostic.

#[cfg(feature = "board-nucleo-f767zi")]
mod nucleo_f767zi;
#[cfg(feature = "board-nucleo-f767zi")]
pub use nucleo_f767zi::{Board, init};

// Without this, naming `_firmware` alone would fail later with unresolved `board::init`.
#[cfg(not(any(feature = "board-nucleo-f767zi")))]
compile_error!("enable one board feature, such as `board-nucleo-f767zi`");
