//! A fixed-buffer XML writer that produces the layout of the protocol document.
//!
//! ```xml
//! <?xml version="1.0" encoding="UTF-8"?>
//! <PatrolDevice>
//!   <Type>2</Type>
//!   <Command>1</Command>
//!   <Time>2023-01-01 00:00:00</Time>
//!   <Items>
//!     <Value>-1</Value>
//!   </Items>
//! </PatrolDevice>
//! ```
//!
//! Every write either fits or fails with [`WriteError::BufferFull`]; nothing is ever
//! truncated silently.

#[cfg(not(feature = "compact"))]
mod fast;

use super::number::{self, F32_TEXT_MAX, I32_TEXT_MAX};
use crate::proto::time::{TIME_TEXT_LEN, Timestamp};
#[cfg(not(feature = "compact"))]
pub(crate) use fast::{ItemTags, PaddedName};

/// Why a document could not be written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum WriteError {
    /// The caller's buffer is too small for the document.
    BufferFull,
    /// A float item is NaN or infinite, which has no text form.
    NotFinite {
        /// The item's element name.
        item: ItemName,
    },
}

/// Longest item name, bytes: 18 (`BatteryTemperature`) and room to spare. Checked where
/// each name is made, so that an item line with its tags and the longest number always
/// fits the line's window.
pub(crate) const NAME_MAX: usize = 19;

/// An item's element name: ASCII, at most 19 bytes.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct ItemName(&'static [u8]);

impl ItemName {
    /// The name `name`. Meant for constants, as every item name is: there a name that is
    /// too long or not ASCII fails to compile (at run time it would panic).
    pub const fn new(name: &'static str) -> Self {
        let name = name.as_bytes();
        assert!(
            name.len() <= NAME_MAX && name.is_ascii(),
            "an item name is at most 19 ASCII bytes"
        );
        Self(name)
    }

    /// The name whose bytes are `name`, an item table's, which the table checked as
    /// [`ItemName::new`] checks its name.
    pub(crate) const fn from_table(name: &'static [u8]) -> Self {
        Self(name)
    }

    /// The name's bytes.
    pub const fn as_bytes(&self) -> &'static [u8] {
        self.0
    }
}

/// The name as text: its bytes are ASCII, so each is a character (no UTF-8 check, whose code
/// the codec would otherwise link only for this).
impl core::fmt::Display for ItemName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        self.as_bytes()
            .iter()
            .try_for_each(|&c| core::fmt::Write::write_char(f, char::from(c)))
    }
}

/// The name quoted, as a string's `Debug` shows it.
impl core::fmt::Debug for ItemName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "\"{self}\"")
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ItemName {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "{=[u8]:a}", self.as_bytes());
    }
}

/// The value of a number item.
#[derive(Clone, Copy)]
pub(crate) enum Number {
    /// An integer.
    Int(i32),
    /// A float of a request, written in its shortest exact form; NaN and infinities are
    /// refused, since the robot would act on them.
    Float(f32),
    /// A float of an answer: as [`Number::Float`], but NaN and infinities are written as C's
    /// `printf` writes them (`nan`, `-nan`, `inf`, `-inf`), for a reading the robot does
    /// not have (an unknown pose). Only answers make these, so a program that writes no
    /// answer (the panel) does not link that writer.
    Reading(f32),
}

impl Number {
    /// Writes the number's text at the start of `out` and returns its length; the bytes
    /// after it may be overwritten. A float that cannot be written is refused naming `item`.
    #[inline(always)]
    fn format(self, item: ItemName, out: &mut [u8; NUMBER_MAX]) -> Result<usize, WriteError> {
        match self {
            Self::Int(value) => Ok(out
                .first_chunk_mut::<I32_TEXT_MAX>()
                .map_or(0, |out| number::write_i32(value, out))),
            Self::Float(value) if value.is_finite() => Ok(number::write_finite(value, out)),
            Self::Float(_) => Err(WriteError::NotFinite { item }),
            Self::Reading(value) => Ok(number::write_reading(value, out)),
        }
    }
}

/// Longest number text written in a window.
const NUMBER_MAX: usize = F32_TEXT_MAX;

/// The first `n` bytes of a formatted number.
fn prefix(text: &[u8], n: usize) -> &[u8] {
    text.get(..n).unwrap_or_default()
}

/// An item line's start: its indentation and the opening tag's `<`.
const ITEM_OPEN: &[u8; 5] = b"    <";

/// The header's text around its three values (`Type`, `Command`, `Time`).
const HEADER: [&[u8]; 4] = [
    b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>\n  <Type>",
    b"</Type>\n  <Command>",
    b"</Command>\n  <Time>",
    b"</Time>\n",
];

/// The header as one text with its values' places marked by their numbers, the bytes 0, 1
/// and 2, which the document's text never holds ([`DocumentWriter::fill`]).
const HEADER_TEMPLATE: [u8; HEADER_LEN] = {
    let [declaration, after_type, after_command, after_time] = HEADER;
    concat(&[
        declaration,
        &[0],
        after_type,
        &[1],
        after_command,
        &[2],
        after_time,
    ])
};

/// The length of [`HEADER_TEMPLATE`]: the header's text and three marks.
const HEADER_LEN: usize = {
    let [declaration, after_type, after_command, after_time] = HEADER;
    declaration.len() + after_type.len() + after_command.len() + after_time.len() + 3
};

/// An item line with its name's places marked 0 and its number's 1.
const LINE_TEMPLATE: [u8; ITEM_OPEN.len() + 8] =
    concat(&[ITEM_OPEN, &[0], b">", &[1], b"</", &[0], b">\n"]);

/// Writes `template` at the start of `out`, each of its bytes that numbers one of `fields`
/// (see [`HEADER_TEMPLATE`]) replaced by that field; returns the length written.
// Out of line: one loop writes the header and every line appended, where a call for each
// of their pieces would be repeated at every caller. It takes the buffer's rest, not the
// writer, so that a caller's writer stays in registers across the call. A `compact` build
// keeps its one caller, `DocumentWriter::fill`, out of line instead, and this inside it
// (68 bytes less).
#[cfg_attr(not(feature = "compact"), inline(never))]
fn fill(out: &mut [u8], template: &[u8], fields: &[&[u8]]) -> Result<usize, WriteError> {
    let mut len = 0;
    for &byte in template {
        // A template byte is stored as it is: copied as a piece of its own, each byte would
        // cost a call to `memcpy`.
        let Some(piece) = fields.get(usize::from(byte)) else {
            *out.get_mut(len).ok_or(WriteError::BufferFull)? = byte;
            len += 1;
            continue;
        };
        let end = len + piece.len();
        out.get_mut(len..end)
            .ok_or(WriteError::BufferFull)?
            .copy_from_slice(piece);
        len = end;
    }
    Ok(len)
}

/// `parts` one after the other, in an array of exactly their total length (checked when the
/// constant is built).
const fn concat<const N: usize>(parts: &[&[u8]]) -> [u8; N] {
    let mut out = [0; N];
    let mut at = 0;
    let mut parts = parts;
    while let [part, more_parts @ ..] = parts {
        let mut bytes = *part;
        while let [byte, more_bytes @ ..] = bytes {
            assert!(at < N, "the parts are longer than the array");
            if let Some((_, [slot, ..])) = out.split_at_mut_checked(at) {
                *slot = *byte;
            }
            at += 1;
            bytes = more_bytes;
        }
        parts = more_parts;
    }
    assert!(at == N, "the parts are shorter than the array");
    out
}

/// Writes one `<PatrolDevice>` document: header elements, then items, in the document's layout.
///
/// Items open an `<Items>` block on first use; a document with no items gets `<Items/>`.
#[derive(Debug)]
pub struct DocumentWriter<'a> {
    buf: &'a mut [u8],
    /// Bytes written so far.
    len: usize,
    items_open: bool,
    blocks: usize,
}

impl<'a> DocumentWriter<'a> {
    /// Writes the declaration and the `Type`, `Command` and `Time` elements into `buf`.
    pub fn begin(
        buf: &'a mut [u8],
        message_type: i32,
        command: i32,
        time: &Timestamp,
    ) -> Result<Self, WriteError> {
        let (mut type_text, mut command_text) = ([0; I32_TEXT_MAX], [0; I32_TEXT_MAX]);
        let type_len = number::write_i32(message_type, &mut type_text);
        let command_len = number::write_i32(command, &mut command_text);
        let mut time_text = [0; TIME_TEXT_LEN];
        time.encode(&mut time_text);
        let mut doc = Self {
            buf,
            len: 0,
            items_open: false,
            blocks: 0,
        };
        // The default build writes the header in one piece where it fits (`fast`); the
        // result is the same.
        #[cfg(not(feature = "compact"))]
        if doc.header(
            (&type_text, type_len),
            (&command_text, command_len),
            &time_text,
        ) {
            return Ok(doc);
        }
        let values = [
            prefix(&type_text, type_len),
            prefix(&command_text, command_len),
            &time_text,
        ];
        doc.fill(&HEADER_TEMPLATE, &values)?;
        Ok(doc)
    }

    /// Writes an integer item.
    pub fn int_item(&mut self, name: ItemName, value: i32) -> Result<(), WriteError> {
        self.number_item(name, Number::Int(value))
    }

    /// Writes a float item.
    pub fn float_item(&mut self, name: ItemName, value: f32) -> Result<(), WriteError> {
        self.number_item(name, Number::Float(value))
    }

    /// Writes one item line whose value is a number: the number is formatted aside, then the
    /// line is appended piece by piece. The default build writes the line in place where
    /// the buffer has room for the longest one (`fast`), with the same result. Always
    /// inlined: the codec writes every item from one loop (over a message's item table),
    /// where a call per item (saving and restoring the registers the formatting needs)
    /// would cost the default build a fifth of the line.
    #[inline(always)]
    pub(crate) fn number_item(&mut self, name: ItemName, value: Number) -> Result<(), WriteError> {
        #[cfg(not(feature = "compact"))]
        return self.tagged_item(name, name, value);
        #[cfg(feature = "compact")]
        {
            self.open_items()?;
            self.formatted_line(name, value)
        }
    }

    /// [`DocumentWriter::number_item`]'s line, the number formatted aside.
    #[inline(always)]
    fn formatted_line(&mut self, name: ItemName, value: Number) -> Result<(), WriteError> {
        let mut text = [0; NUMBER_MAX];
        let n = value.format(name, &mut text)?;
        self.text_line(name, prefix(&text, n))
    }

    /// [`DocumentWriter::number_item`]'s line with the number's `text`, appended piece by
    /// piece.
    #[inline(always)]
    fn text_line(&mut self, name: ItemName, text: &[u8]) -> Result<(), WriteError> {
        self.fill(&LINE_TEMPLATE, &[name.as_bytes(), text])
    }

    /// Appends `template`, each of its bytes that numbers one of `fields` (see
    /// [`HEADER_TEMPLATE`]) replaced by that field. A `compact` build appends every line and
    /// its header this way, and the compiler keeps it out of line there on the
    /// microcontroller by itself (forced out of line, it cost 719 instructions more a 1002
    /// encode on the host, for no flash).
    #[cfg_attr(not(feature = "compact"), inline(always))]
    fn fill(&mut self, template: &[u8], fields: &[&[u8]]) -> Result<(), WriteError> {
        let rest = self.buf.get_mut(self.len..).unwrap_or_default();
        self.len += fill(rest, template, fields)?;
        Ok(())
    }

    /// Appends `bytes`. Out of line in a `compact` build, where every piece of markup goes
    /// through it; in the default build a constant piece then compiles to plain stores.
    #[cfg_attr(feature = "compact", inline(never))]
    fn raw(&mut self, bytes: &[u8]) -> Result<(), WriteError> {
        let end = self.len + bytes.len();
        self.buf
            .get_mut(self.len..end)
            .ok_or(WriteError::BufferFull)?
            .copy_from_slice(bytes);
        self.len = end;
        Ok(())
    }

    /// Opens the `<Items>` block if no block is open.
    fn open_items(&mut self) -> Result<(), WriteError> {
        if !self.items_open {
            self.raw(b"  <Items>\n")?;
            self.items_open = true;
        }
        Ok(())
    }

    /// Closes the current `<Items>` block, so the next item starts another one (a 1003
    /// request carries one block per waypoint).
    pub fn end_items_block(&mut self) -> Result<(), WriteError> {
        if self.items_open {
            self.raw(b"  </Items>\n")?;
            self.items_open = false;
            self.blocks += 1;
        }
        Ok(())
    }

    /// Closes the document and returns its length in bytes.
    pub fn finish(mut self) -> Result<usize, WriteError> {
        self.end_items_block()?;
        if self.blocks == 0 {
            self.raw(b"  <Items/>\n")?;
        }
        self.raw(b"</PatrolDevice>\n")?;
        Ok(self.len)
    }
}
