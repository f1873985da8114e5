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

use super::number::{self, F32_TEXT_MAX, I32_TEXT_MAX};
use crate::proto::time::{TIME_TEXT_LEN, Timestamp};

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
        item: &'static str,
    },
}

/// Fills a slice already checked to be long enough, piece by piece.
struct Cursor<'a>(&'a mut [u8]);

impl Cursor<'_> {
    /// Copies `bytes` and moves past them. Always inlined, so that constant pieces become
    /// plain stores instead of calls to `memcpy`.
    #[inline(always)]
    fn put(&mut self, bytes: &[u8]) {
        let rest = core::mem::take(&mut self.0);
        if let Some((head, tail)) = rest.split_at_mut_checked(bytes.len()) {
            head.copy_from_slice(bytes);
            self.0 = tail;
        }
    }

    /// Writes `    <name>`, the start of an item line, the name copied by `put_name`
    /// ([`Cursor::put_name`] where the line is hot, [`Cursor::put`] where size matters more).
    #[inline(always)]
    fn open_tag(&mut self, name: &[u8], put_name: fn(&mut Self, &[u8])) {
        self.put(ITEM_INDENT);
        self.put(b"<");
        put_name(self, name);
        self.put(b">");
    }

    /// Writes `</name>` and a newline, the end of an item line, the name copied by
    /// `put_name`.
    #[inline(always)]
    fn close_tag(&mut self, name: &[u8], put_name: fn(&mut Self, &[u8])) {
        self.put(b"</");
        put_name(self, name);
        self.put(b">\n");
    }

    /// [`Cursor::put`] for an element name: 1 to 16 bytes are copied as two overlapping
    /// fixed-size pieces (a few loads and stores) rather than by a call to `memcpy`, which
    /// costs more than such a short copy.
    #[inline(always)]
    fn put_name(&mut self, name: &[u8]) {
        let rest = core::mem::take(&mut self.0);
        let Some((head, tail)) = rest.split_at_mut_checked(name.len()) else {
            return;
        };
        let n = name.len();
        if (8..=16).contains(&n) {
            copy_fixed::<8>(head, name, 0);
            copy_fixed::<8>(head, name, n - 8);
        } else if (4..8).contains(&n) {
            copy_fixed::<4>(head, name, 0);
            copy_fixed::<4>(head, name, n - 4);
        } else if (1..4).contains(&n) {
            // The first byte, then the last two (which a one-byte name does not have).
            copy_fixed::<1>(head, name, 0);
            copy_fixed::<2>(head, name, n.saturating_sub(2));
        } else {
            head.copy_from_slice(name);
        }
        self.0 = tail;
    }
}

/// The value of a number item.
#[derive(Clone, Copy)]
pub(crate) enum Number {
    /// An integer.
    Int(i32),
    /// A float, written in its shortest exact form.
    Float(f32),
}

impl Number {
    /// Writes the number's text at the start of `out` and returns its length; the bytes
    /// after it may be overwritten. A NaN or an infinity is written as C prints it if
    /// `non_finite` allows, else refused naming `item`.
    #[inline(always)]
    fn format(
        self,
        item: &'static str,
        non_finite: bool,
        out: &mut [u8; NUMBER_MAX],
    ) -> Result<usize, WriteError> {
        match self {
            Self::Int(value) => Ok(out
                .first_chunk_mut::<I32_TEXT_MAX>()
                .map_or(0, |out| number::write_i32(value, out))),
            Self::Float(value) => match number::write_f32(value, out) {
                Ok(n) => Ok(n),
                Err(_) if non_finite => Ok(number::write_non_finite(value, out)),
                Err(_) => Err(WriteError::NotFinite { item }),
            },
        }
    }
}

/// Copies the `N` bytes of `from` at `at` to the same place in `to`.
#[inline(always)]
fn copy_fixed<const N: usize>(to: &mut [u8], from: &[u8], at: usize) {
    let from = from.get(at..).and_then(|f| f.first_chunk::<N>());
    let to = to.get_mut(at..).and_then(|t| t.first_chunk_mut::<N>());
    if let (Some(to), Some(from)) = (to, from) {
        *to = *from;
    }
}

/// Longest element name of an item line written in a window ([`DocumentWriter::number_item`]);
/// the longest item name in the protocol has 14 bytes.
const NAME_MAX: usize = 16;

/// Longest number text written in a window.
const NUMBER_MAX: usize = F32_TEXT_MAX;

/// The window an item line is written in: room for the indentation, the longest name twice,
/// the longest number and the tags' six bytes.
const LINE_WINDOW: usize = 64 + NUMBER_MAX;

/// Writes the indentation and tags of an item line around a number of `n` bytes already
/// formatted in place, and returns the line's length. The name is at most [`NAME_MAX`] and
/// `n` at most [`NUMBER_MAX`] bytes, so every piece lands inside the window.
#[inline(always)]
fn item_tags(window: &mut [u8; LINE_WINDOW], name: &[u8], n: usize) -> usize {
    let name_len = name.len().min(NAME_MAX);
    let end = ITEM_INDENT.len() + name_len + 2 + n.min(NUMBER_MAX);
    Cursor(window).open_tag(name, Cursor::put_name);
    Cursor(window.get_mut(end..).unwrap_or_default()).close_tag(name, Cursor::put_name);
    end + name_len + 4
}

/// The first `n` bytes of a formatted number.
fn prefix(text: &[u8], n: usize) -> &[u8] {
    text.get(..n).unwrap_or_default()
}

const ITEM_INDENT: &[u8] = b"    ";

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
    /// Whether a NaN or an infinity is written as `nan` or `inf` rather than refused.
    non_finite: bool,
}

impl<'a> DocumentWriter<'a> {
    /// Writes the declaration and the `Type`, `Command` and `Time` elements into `buf`.
    pub fn begin(
        buf: &'a mut [u8],
        message_type: i32,
        command: i32,
        time: &Timestamp,
    ) -> Result<Self, WriteError> {
        // The header is the same text around three values: format those, check the length
        // once, then copy constant pieces (which compile to plain stores).
        let (mut type_text, mut command_text) = ([0; I32_TEXT_MAX], [0; I32_TEXT_MAX]);
        let type_len = number::write_i32(message_type, &mut type_text);
        let command_len = number::write_i32(command, &mut command_text);
        let type_text = prefix(&type_text, type_len);
        let command_text = prefix(&command_text, command_len);
        let mut time_text = [0; TIME_TEXT_LEN];
        time.encode(&mut time_text);
        const PIECES: [&[u8]; 4] = [
            b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>\n  <Type>",
            b"</Type>\n  <Command>",
            b"</Command>\n  <Time>",
            b"</Time>\n",
        ];
        let total = PIECES.iter().map(|p| p.len()).sum::<usize>()
            + type_text.len()
            + command_text.len()
            + TIME_TEXT_LEN;
        let mut out = Cursor(buf.get_mut(..total).ok_or(WriteError::BufferFull)?);
        let [declaration, after_type, after_command, after_time] = PIECES;
        out.put(declaration);
        out.put(type_text);
        out.put(after_type);
        out.put(command_text);
        out.put(after_command);
        out.put(&time_text);
        out.put(after_time);
        Ok(Self {
            buf,
            len: total,
            items_open: false,
            blocks: 0,
            non_finite: false,
        })
    }

    /// Writes NaN and infinities as C's `printf` does (`nan`, `-nan`, `inf`, `-inf`)
    /// instead of refusing them: an answer may report a reading the robot does not have
    /// (an unknown pose), a request must not carry one.
    pub(crate) fn with_non_finite(mut self) -> Self {
        self.non_finite = true;
        self
    }

    /// Writes an integer item.
    pub fn int_item(&mut self, name: &'static str, value: i32) -> Result<(), WriteError> {
        self.number_item(name, Number::Int(value))
    }

    /// Writes a float item.
    pub fn float_item(&mut self, name: &'static str, value: f32) -> Result<(), WriteError> {
        self.number_item(name, Number::Float(value))
    }

    /// Writes one item line whose value is a number. Where the buffer has room for the
    /// longest such line, the line is written into a fixed-size window of it: the tags are
    /// stores at offsets checked once, and the number is formatted in place, between them,
    /// never copied. Near the buffer's end (or for a name longer than any item's) it is
    /// formatted aside and copied only if it fits. Always inlined: the codec writes every
    /// item from one loop (over a message's item table), where a call per item (saving and
    /// restoring the registers the formatting needs) would cost a fifth of the line.
    #[inline(always)]
    pub(crate) fn number_item(
        &mut self,
        name: &'static str,
        value: Number,
    ) -> Result<(), WriteError> {
        self.open_items()?;
        let bytes = name.as_bytes();
        let out = self.buf.get_mut(self.len..).unwrap_or_default();
        let window = out
            .first_chunk_mut::<LINE_WINDOW>()
            .filter(|_| bytes.len() <= NAME_MAX);
        let Some(window) = window else {
            let mut text = [0; NUMBER_MAX];
            let n = value.format(name, self.non_finite, &mut text)?;
            return self.number_line(bytes, prefix(&text, n));
        };
        let start = ITEM_INDENT.len() + bytes.len() + 2;
        let text = window
            .get_mut(start..)
            .and_then(|rest| rest.first_chunk_mut::<NUMBER_MAX>());
        let n = match text {
            Some(text) => value.format(name, self.non_finite, text)?,
            None => 0,
        };
        self.len += item_tags(window, bytes, n);
        Ok(())
    }

    /// Writes an item line whose number was formatted aside, near the buffer's end, with
    /// one bounds check.
    #[inline(never)]
    fn number_line(&mut self, name: &[u8], text: &[u8]) -> Result<(), WriteError> {
        let total = ITEM_INDENT.len() + 2 * name.len() + text.len() + 6;
        let out = self
            .buf
            .get_mut(self.len..self.len + total)
            .ok_or(WriteError::BufferFull)?;
        let mut out = Cursor(out);
        out.open_tag(name, Cursor::put);
        out.put(text);
        out.close_tag(name, Cursor::put);
        self.len += total;
        Ok(())
    }

    /// Appends constant markup.
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
