//! The virtual panel's text protocol (the QEMU board's buttons): one line per change,
//! `+NAME` for a press and `-NAME` for a release, NAME a [`Button::name`] such as `turn-left`.
//!
//! Lines end with `\n` or `\r` (a terminal in raw mode sends `\r` for Enter), so `\r\n` is a
//! line end and a blank line, and blank lines are ignored. Spaces around a line are ignored.
//! Anything else is an error the board reports, never a panic; a line longer than
//! [`MAX_LINE`] is skipped to its end.

use embassy_time::Instant;
use heapless::{String, Vec};

use super::buttons::{Button, ButtonEvent};

/// Longest line the panel reads; the longest valid one, `-stop-stepping`, has 14 bytes.
pub const MAX_LINE: usize = 32;

/// A line of the virtual panel that is not a button change.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LineError {
    /// The line was longer than [`MAX_LINE`] bytes.
    TooLong,
    /// The line was not UTF-8 text.
    NotText,
    /// The line did not start with `+` or `-`.
    NoSign(String<MAX_LINE>),
    /// No button has this name.
    UnknownButton(String<MAX_LINE>),
}

impl core::fmt::Display for LineError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooLong => write!(f, "line longer than {MAX_LINE} bytes"),
            Self::NotText => f.write_str("line is not UTF-8 text"),
            Self::NoSign(line) => write!(f, "`{line}` does not start with + or -"),
            Self::UnknownButton(name) => write!(f, "no button is named `{name}`"),
        }
    }
}

impl core::error::Error for LineError {}

/// What one line, received at `at`, says: a button change, nothing (a blank line), or why
/// it is not valid.
pub fn parse_line(line: &str, at: Instant) -> Result<Option<ButtonEvent>, LineError> {
    let line = line.trim();
    let pressed = match line.as_bytes().first() {
        None => return Ok(None),
        Some(b'+') => true,
        Some(b'-') => false,
        Some(_) => return Err(LineError::NoSign(truncated(line))),
    };
    let name = line.get(1..).unwrap_or_default().trim();
    match Button::from_name(name) {
        Some(button) => Ok(Some(ButtonEvent {
            button,
            pressed,
            at,
        })),
        None => Err(LineError::UnknownButton(truncated(name))),
    }
}

/// `text`, cut to fit an error (it always does: lines are at most [`MAX_LINE`] bytes).
fn truncated(text: &str) -> String<MAX_LINE> {
    let mut out = String::new();
    for c in text.chars() {
        if out.push(c).is_err() {
            break;
        }
    }
    out
}

/// Assembles the panel's lines from the bytes of a serial port.
#[derive(Debug, Clone, Default)]
pub struct LineReader {
    /// The line so far.
    line: Vec<u8, MAX_LINE>,
    /// Whether the line outgrew [`MAX_LINE`]; the rest of it is skipped.
    too_long: bool,
}

impl LineReader {
    /// A reader at the start of a line.
    pub const fn new() -> Self {
        Self {
            line: Vec::new(),
            too_long: false,
        }
    }

    /// Takes one byte, received at `now`; at the end of a line, returns what the line said.
    pub fn push(
        &mut self,
        byte: u8,
        now: Instant,
    ) -> Option<Result<Option<ButtonEvent>, LineError>> {
        if byte != b'\n' && byte != b'\r' {
            if self.line.push(byte).is_err() {
                self.too_long = true;
            }
            return None;
        }
        let result = if core::mem::take(&mut self.too_long) {
            Err(LineError::TooLong)
        } else {
            match core::str::from_utf8(&self.line) {
                Ok(text) => parse_line(text, now),
                Err(_) => Err(LineError::NotText),
            }
        };
        self.line.clear();
        Some(result)
    }
}
