//! The board's status and settings page, without the HTTP server: what each resource's body
//! is, written into fixed buffers, and what a settings form does. The board's server routes
//! requests here.
//!
//! - `/`: [`INDEX_HTML`], one page that refreshes itself from `/api/status` every 500 ms,
//!   greys out what is stale, and says so when the panel stops answering.
//! - `/api/status`: [`write_status`], JSON of the panel's [`Snapshot`](crate::app::Snapshot)
//!   (the layout is in [`json`]).
//! - `/settings`: [`write_settings_page`]; a POST of its form goes through [`post_settings`]
//!   (the rules are in [`form`]).
//!
//! Nothing here allocates: pages are written through `fmt::Write` into the caller's buffer,
//! forms are decoded into fixed buffers.

pub mod form;
pub mod json;
mod page;

use core::fmt;

pub use form::{FORM_MAX, Posted, post_settings};
pub use json::{STATUS_MAX, write_status};
pub use page::{SETTINGS_PAGE_MAX, write_settings_page};

/// The start of every page: the document's head with the style they share, untitled.
macro_rules! head {
    () => {
        concat!(
            "<!doctype html><html lang=en><meta charset=utf-8>",
            "<meta name=viewport content=\"width=device-width,initial-scale=1\"><style>",
            include_str!("style.css"),
            "</style>"
        )
    };
}

/// The page at `/`: HTML, CSS and JS in one, no external resources.
pub const INDEX_HTML: &str = concat!(
    head!(),
    "<title>X30 panel</title>",
    include_str!("index.html")
);

/// How long the head every page starts with is.
const HEAD_LEN: usize = head!().len();

/// The head every page starts with, taken from [`INDEX_HTML`] so that it is in flash once.
fn head() -> &'static str {
    INDEX_HTML.get(..HEAD_LEN).unwrap_or_default()
}

/// Writes `text` with `&`, `<`, `>`, `"` and `'` as character references: text that people
/// wrote (settings, form fields) shows as text, never as markup.
fn escape(out: &mut dyn fmt::Write, text: &str) -> fmt::Result {
    for c in text.chars() {
        match u8::try_from(c).ok().and_then(entity) {
            Some(entity) => out.write_str(entity)?,
            None => out.write_char(c)?,
        }
    }
    Ok(())
}

/// The length of `text` once escaped.
const fn escaped_len(text: &str) -> usize {
    let mut bytes = text.as_bytes();
    let mut len = 0;
    while let [byte, rest @ ..] = bytes {
        len += match entity(*byte) {
            Some(entity) => entity.len(),
            None => 1,
        };
        bytes = rest;
    }
    len
}

/// The character reference that stands for `byte` in a page, if it needs one.
const fn entity(byte: u8) -> Option<&'static str> {
    match byte {
        b'&' => Some("&amp;"),
        b'<' => Some("&lt;"),
        b'>' => Some("&gt;"),
        b'"' => Some("&quot;"),
        b'\'' => Some("&#39;"),
        _ => None,
    }
}
