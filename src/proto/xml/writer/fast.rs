//! The default build's item lines and header, written in place: where the buffer has room
//! for the longest line, the line goes into a fixed-size window of it, in order (the opening
//! tag, the number formatted in place, the closing tag), so it takes stores at offsets
//! bounded by the window and no copy of the number. Bytes past the line's end may be
//! overwritten. A `compact` build appends every piece instead, with the same result.

use super::{
    DocumentWriter, HEADER, ITEM_OPEN, ItemName, NAME_MAX, NUMBER_MAX, Number, WriteError, concat,
    prefix,
};
use crate::proto::time::TIME_TEXT_LEN;
use crate::proto::xml::number::I32_TEXT_MAX;

impl DocumentWriter<'_> {
    /// Writes the header, its numbers' texts and lengths and its time given, in one go if
    /// it fits; returns whether it did. The header is the same text around three values:
    /// its length is checked once, then constant pieces copied (which compile to plain
    /// stores).
    #[inline(always)]
    pub(super) fn header(
        &mut self,
        (type_text, type_len): (&[u8; I32_TEXT_MAX], usize),
        (command_text, command_len): (&[u8; I32_TEXT_MAX], usize),
        time: &[u8; TIME_TEXT_LEN],
    ) -> bool {
        let total =
            HEADER.iter().map(|p| p.len()).sum::<usize>() + type_len + command_len + TIME_TEXT_LEN;
        let Some(out) = self.buf.get_mut(..total) else {
            return false;
        };
        let mut out = Cursor(out);
        let [declaration, after_type, after_command, after_time] = HEADER;
        out.put(declaration);
        out.put_number(type_text, type_len);
        out.put(after_type);
        out.put_number(command_text, command_len);
        out.put(after_command);
        out.put(time);
        out.put(after_time);
        self.len = total;
        true
    }

    /// Writes the line of item `name` whose tags `tags` write in fixed-size pieces: tags
    /// known where the code is compiled ([`ItemTags`], one constant copy each), a table's
    /// padded name ([`PaddedName`], one copy of its window), or any name. Where the buffer
    /// has room for the longest line, the line goes in place ([`DocumentWriter::item_in_place`]);
    /// else it is appended piece by piece.
    #[inline(always)]
    pub(crate) fn tagged_item(
        &mut self,
        tags: impl Tags,
        name: ItemName,
        value: Number,
    ) -> Result<(), WriteError> {
        if self.item_in_place(tags, name, value)? {
            return Ok(());
        }
        self.formatted_line(name, value)
    }

    /// Writes the line of item `name` into a window of the buffer checked once, the number
    /// formatted in place between the tags, if the buffer has room for the longest line;
    /// returns whether it had. Without room only the `<Items>` block is opened, and the
    /// caller writes the line (and any after it) piece by piece instead: an answer's own
    /// code for each item leaves that to one call for the rest of its block, so that each
    /// item costs one copy of the line, not two.
    #[inline(always)]
    pub(crate) fn item_in_place(
        &mut self,
        tags: impl Tags,
        name: ItemName,
        value: Number,
    ) -> Result<bool, WriteError> {
        self.open_items()?;
        let Some(window) = self
            .buf
            .get_mut(self.len..)
            .and_then(|out| out.first_chunk_mut())
        else {
            return Ok(false);
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
        Ok(true)
    }
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
}

/// The window an item line is written in: room for the line's start, the tags' other five
/// bytes (`>`, `</`, `>` and the newline), the longest number and the longest name twice.
const LINE_WINDOW: usize = ITEM_OPEN.len() + 5 + NUMBER_MAX + 2 * NAME_MAX;

/// Stores `bytes` at `at` in `window`; the caller's offsets keep it inside, so the check
/// folds away.
fn store<const N: usize>(window: &mut [u8; LINE_WINDOW], at: usize, bytes: &[u8; N]) {
    if let Some(to) = window.get_mut(at..).and_then(|w| w.first_chunk_mut::<N>()) {
        *to = *bytes;
    }
}

/// How an item line's tags are written into its window.
pub(crate) trait Tags {
    /// Writes the indentation and `<Name>` at the window's start; returns their length.
    fn open(&self, window: &mut [u8; LINE_WINDOW]) -> usize;
    /// Writes `</Name>` and the line's end at `at`; returns their length.
    fn close(&self, window: &mut [u8; LINE_WINDOW], at: usize) -> usize;
}

/// Tags from a name, as the item tables keep it.
impl Tags for ItemName {
    #[inline(always)]
    fn open(&self, window: &mut [u8; LINE_WINDOW]) -> usize {
        let start = ITEM_OPEN.len() + self.len() + 1;
        store(window, 0, ITEM_OPEN);
        self.put(window, ITEM_OPEN.len());
        store(window, start - 1, b">");
        start
    }

    #[inline(always)]
    fn close(&self, window: &mut [u8; LINE_WINDOW], at: usize) -> usize {
        store(window, at, b"</");
        self.put(window, at + 2);
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

    /// Copies the name to `at` in `window`, in fixed-size pieces that overlap where the name
    /// is not a multiple of them: a copy of a length known only at run time would be a call
    /// to `memcpy`, a third of a request's line. Nothing is written where it does not fit,
    /// which the callers' offsets rule out.
    fn put(&self, window: &mut [u8; LINE_WINDOW], at: usize) {
        let name = self.0;
        let n = name.len();
        match n {
            8.. => {
                piece::<8>(window, at, name, 0);
                if n > 16 {
                    piece::<8>(window, at, name, 8);
                }
                piece::<8>(window, at, name, n - 8);
            }
            4.. => {
                piece::<4>(window, at, name, 0);
                piece::<4>(window, at, name, n - 4);
            }
            2.. => {
                piece::<2>(window, at, name, 0);
                piece::<2>(window, at, name, n - 2);
            }
            _ => piece::<1>(window, at, name, 0),
        }
    }
}

/// A table's item name with what follows it among the table's names, [`NAME_MAX`] bytes
/// and one more (the default build pads every table's names that far): its tags copy it in
/// one piece, then write over what follows it.
#[derive(Clone, Copy)]
pub(crate) struct PaddedName<'n> {
    text: &'n [u8; NAME_MAX + 1],
    len: usize,
}

impl<'n> PaddedName<'n> {
    /// The name of `len` bytes at the start of `text`; `None` if `text` is shorter than
    /// [`NAME_MAX`] and one more byte.
    #[inline(always)]
    pub(crate) fn new(text: &'n [u8], len: usize) -> Option<Self> {
        Some(Self {
            text: text.first_chunk()?,
            len: len.min(NAME_MAX),
        })
    }
}

impl PaddedName<'static> {
    /// The name alone.
    #[inline(always)]
    pub(crate) fn name(&self) -> ItemName {
        ItemName::from_table(self.text.get(..self.len).unwrap_or_default())
    }
}

impl Tags for PaddedName<'_> {
    #[inline(always)]
    fn open(&self, window: &mut [u8; LINE_WINDOW]) -> usize {
        let start = ITEM_OPEN.len() + self.len + 1;
        store(window, 0, ITEM_OPEN);
        store(window, ITEM_OPEN.len(), self.text);
        store(window, start - 1, b">");
        start
    }

    #[inline(always)]
    fn close(&self, window: &mut [u8; LINE_WINDOW], at: usize) -> usize {
        store(window, at, b"</");
        store(window, at + 2, self.text);
        store(window, at + 2 + self.len, b">\n");
        self.len + 4
    }
}

/// Copies `name[from..from + N]` to `at + from` in `window`.
fn piece<const N: usize>(window: &mut [u8; LINE_WINDOW], at: usize, name: &[u8], from: usize) {
    if let Some(from_name) = name.get(from..).and_then(|rest| rest.first_chunk::<N>()) {
        store(window, at + from, from_name);
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
            open: concat(&[ITEM_OPEN, name, b">"]),
            close: concat(&[b"</", name, b">\n"]),
        }
    }
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
