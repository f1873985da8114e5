//! The robot_server protocol (V1.0.12), from the wire upward.
//!
//! - [`frame`]: the 16-byte binary header and a streaming frame decoder.
//! - [`xml`]: a fixed-buffer XML writer, a minimal tokenizer, and number text.
//! - [`codes`]: every coded value of the protocol, each with an `Unknown(raw)` case.
//! - [`message`]: typed requests and responses for every Type, in both directions.
//! - [`outstanding`]: which request an answer answers (by message ID; Type 0 to the oldest).
//!
//! Nothing here does I/O, allocates, or panics: every fallible function returns its own
//! error enum and writes into buffers the caller owns.

pub mod codes;
mod display;
pub mod frame;
pub mod message;
pub mod outstanding;
#[cfg(feature = "serde")]
mod serde_support;
pub mod time;
pub mod xml;
