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
        item: ItemName,
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

    /// Copies a number's text, the first `len` bytes of `text`: where the rest has room, as
    /// the whole array (one fixed-size copy instead of a call to `memcpy`), whose bytes past
    /// `len` what follows overwrites.
    #[inline(always)]
    fn put_number(&mut self, text: &[u8; I32_TEXT_MAX], len: usize) {
        let rest = core::mem::take(&mut self.0);
        let len = len.min(I32_TEXT_MAX);
        if let Some(whole) = rest.first_chunk_mut::<I32_TEXT_MAX>() {
            *whole = *text;
        } else if let Some(head) = rest.get_mut(..len) {
            head.copy_from_slice(prefix(text, len));
        }
        self.0 = rest.get_mut(len..).unwrap_or_default();
    }

    /// Writes `    <name>`, the start of an item line.
    fn open_tag(&mut self, name: &[u8]) {
        self.put(ITEM_INDENT);
        self.put(b"<");
        self.put(name);
        self.put(b">");
    }

    /// Writes `</name>` and a newline, the end of an item line.
    fn close_tag(&mut self, name: &[u8]) {
        self.put(b"</");
        self.put(name);
        self.put(b">\n");
    }
}

/// Longest item name, bytes: 18 (`BatteryTemperature`) and room to spare. Checked where
/// each name is made, so that an item line with its tags and the longest number always
/// fits the line's window.
pub(crate) const NAME_MAX: usize = 19;

/// An item's element name: ASCII, at most [`NAME_MAX`] bytes.
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

/// Stores `bytes` at `at` in `window`; the caller's offsets keep it inside, so the check
/// folds away.
#[inline(always)]
fn store<const N: usize>(window: &mut [u8; LINE_WINDOW], at: usize, bytes: &[u8; N]) {
    if let Some(to) = window.get_mut(at..).and_then(|w| w.first_chunk_mut::<N>()) {
        *to = *bytes;
    }
}

/// How an item line's tags are written into its window.
trait Tags {
    /// Writes the indentation and `<Name>` at the window's start; returns their length.
    fn open(&self, window: &mut [u8; LINE_WINDOW]) -> usize;
    /// Writes `</Name>` and the line's end at `at`; returns their length.
    fn close(&self, window: &mut [u8; LINE_WINDOW], at: usize) -> usize;
}

/// Tags from a name, as the item tables keep it.
impl Tags for ItemName {
    #[inline(always)]
    fn open(&self, window: &mut [u8; LINE_WINDOW]) -> usize {
        let start = ITEM_INDENT.len() + 1 + self.len() + 1;
        store(window, 0, ITEM_INDENT);
        store(window, ITEM_INDENT.len(), b"<");
        put_name(window, ITEM_INDENT.len() + 1, self.0);
        store(window, start - 1, b">");
        start
    }

    #[inline(always)]
    fn close(&self, window: &mut [u8; LINE_WINDOW], at: usize) -> usize {
        store(window, at, b"</");
        put_name(window, at + 2, self.0);
        store(window, at + 2 + self.len(), b">\n");
        self.len() + 4
    }
}

impl ItemName {
    /// The name's length; capped, so that the compiler knows it is at most [`NAME_MAX`] and
    /// every store of an item line stays inside its window without a check.
    #[inline(always)]
    fn len(&self) -> usize {
        self.0.len().min(NAME_MAX)
    }
}

/// Copies `name` to `at` in `window` (nothing if it does not fit, which the callers' offsets
/// rule out).
#[inline(always)]
fn put_name(window: &mut [u8; LINE_WINDOW], at: usize, name: &[u8]) {
    if let Some(to) = window.get_mut(at..at + name.len()) {
        to.copy_from_slice(name);
    }
}

/// An item line's tags as constant text, `    <Name>` (`OPEN` bytes) and `</Name>` with
/// the line's end (`CLOSE` bytes), for code that writes one item known where it is
/// compiled: each tag is then one copy of a constant.
pub(crate) struct ItemTags<const OPEN: usize, const CLOSE: usize> {
    open: [u8; OPEN],
    close: [u8; CLOSE],
}

impl<const OPEN: usize, const CLOSE: usize> ItemTags<OPEN, CLOSE> {
    /// The tags of the item `name`; `OPEN` must be its length plus 6, `CLOSE` plus 4
    /// (checked when the constant is built).
    pub(crate) const fn new(name: &str) -> Self {
        assert!(
            OPEN + NUMBER_MAX + CLOSE <= LINE_WINDOW,
            "an item line with these tags does not fit the line's window"
        );
        let name = name.as_bytes();
        Self {
            open: concat(&[ITEM_INDENT, b"<", name, b">"]),
            close: concat(&[b"</", name, b">\n"]),
        }
    }
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

impl<const OPEN: usize, const CLOSE: usize> Tags for &ItemTags<OPEN, CLOSE> {
    #[inline(always)]
    fn open(&self, window: &mut [u8; LINE_WINDOW]) -> usize {
        store(window, 0, &self.open);
        OPEN
    }

    #[inline(always)]
    fn close(&self, window: &mut [u8; LINE_WINDOW], at: usize) -> usize {
        store(window, at, &self.close);
        CLOSE
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
            Self::Float(value) | Self::Reading(value) if value.is_finite() => {
                Ok(number::write_finite(value, out))
            }
            Self::Reading(value) => Ok(number::write_non_finite(value, out)),
            Self::Float(_) => Err(WriteError::NotFinite { item }),
        }
    }
}

/// Longest number text written in a window.
const NUMBER_MAX: usize = F32_TEXT_MAX;

/// The window an item line is written in: room for the indentation, the tags' six bytes,
/// the longest number and the longest name twice.
const LINE_WINDOW: usize = ITEM_INDENT.len() + 6 + NUMBER_MAX + 2 * NAME_MAX;

/// The first `n` bytes of a formatted number.
fn prefix(text: &[u8], n: usize) -> &[u8] {
    text.get(..n).unwrap_or_default()
}

const ITEM_INDENT: &[u8; 4] = b"    ";

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
        // The header is the same text around three values: format those, check the length
        // once, then copy constant pieces (which compile to plain stores).
        let (mut type_text, mut command_text) = ([0; I32_TEXT_MAX], [0; I32_TEXT_MAX]);
        let type_len = number::write_i32(message_type, &mut type_text);
        let command_len = number::write_i32(command, &mut command_text);
        let mut time_text = [0; TIME_TEXT_LEN];
        time.encode(&mut time_text);
        const PIECES: [&[u8]; 4] = [
            b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>\n  <Type>",
            b"</Type>\n  <Command>",
            b"</Command>\n  <Time>",
            b"</Time>\n",
        ];
        let total =
            PIECES.iter().map(|p| p.len()).sum::<usize>() + type_len + command_len + TIME_TEXT_LEN;
        let mut out = Cursor(buf.get_mut(..total).ok_or(WriteError::BufferFull)?);
        let [declaration, after_type, after_command, after_time] = PIECES;
        out.put(declaration);
        out.put_number(&type_text, type_len);
        out.put(after_type);
        out.put_number(&command_text, command_len);
        out.put(after_command);
        out.put(&time_text);
        out.put(after_time);
        Ok(Self {
            buf,
            len: total,
            items_open: false,
            blocks: 0,
        })
    }

    /// Writes an integer item.
    pub fn int_item(&mut self, name: ItemName, value: i32) -> Result<(), WriteError> {
        self.number_item(name, Number::Int(value))
    }

    /// Writes a float item.
    pub fn float_item(&mut self, name: ItemName, value: f32) -> Result<(), WriteError> {
        self.number_item(name, Number::Float(value))
    }

    /// Writes one item line whose value is a number. Where the buffer has room for the
    /// longest such line, the line is written into a fixed-size window of it, in order:
    /// the opening tag, the number formatted in place, the closing tag. So the line takes
    /// stores at offsets bounded by the window and no copy of the number; bytes past the
    /// line's end may be overwritten. Near the
    /// buffer's end the number is formatted aside and copied only if it fits. Always
    /// inlined: the codec writes every item from one loop (over a message's item table),
    /// where a call per item (saving and restoring the registers the formatting needs)
    /// would cost a fifth of the line.
    #[inline(always)]
    pub(crate) fn number_item(&mut self, name: ItemName, value: Number) -> Result<(), WriteError> {
        self.item_line(name, name, value)
    }

    /// Writes an item line whose tags are known where the code is compiled (`tags`, made
    /// for the item called `name`): each is one constant copy.
    #[inline(always)]
    pub(crate) fn tagged_item<const OPEN: usize, const CLOSE: usize>(
        &mut self,
        tags: &ItemTags<OPEN, CLOSE>,
        name: ItemName,
        value: Number,
    ) -> Result<(), WriteError> {
        self.item_line(name, tags, value)
    }

    /// Writes the line of item `name`, whose tags `tags` write, into a window of the
    /// buffer checked once, with the number formatted in place between them.
    #[inline(always)]
    fn item_line(
        &mut self,
        name: ItemName,
        tags: impl Tags,
        value: Number,
    ) -> Result<(), WriteError> {
        self.open_items()?;
        let window = self
            .buf
            .get_mut(self.len..)
            .and_then(|out| out.first_chunk_mut());
        let Some(window) = window else {
            let mut text = [0; NUMBER_MAX];
            let n = value.format(name, &mut text)?;
            let rest = self.buf.get_mut(self.len..).unwrap_or_default();
            self.len += text_line(rest, name, prefix(&text, n))?;
            return Ok(());
        };
        let start = tags.open(window);
        let text = window
            .get_mut(start..)
            .and_then(|rest| rest.first_chunk_mut::<NUMBER_MAX>());
        let n = match text {
            Some(text) => value.format(name, text)?,
            None => 0,
        };
        let end = start + n.min(NUMBER_MAX);
        self.len += end + tags.close(window, end);
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

/// [`DocumentWriter::number_item`]'s line at the start of `out`, near the buffer's end,
/// where the line's window does not fit: the number's `text` was formatted aside, and the
/// line is written with one bounds check. Returns its length.
// Out of line: one copy serves every item line, whichever code writes it; and apart from
// the writer, whose fields can then stay in registers. The number is formatted by the
// caller, where what kind of number it is may be known.
#[inline(never)]
fn text_line(out: &mut [u8], name: ItemName, text: &[u8]) -> Result<usize, WriteError> {
    let name = name.as_bytes();
    let total = ITEM_INDENT.len() + 2 * name.len() + text.len() + 6;
    let out = out.get_mut(..total).ok_or(WriteError::BufferFull)?;
    let mut out = Cursor(out);
    out.open_tag(name);
    out.put(text);
    out.close_tag(name);
    Ok(total)
}
