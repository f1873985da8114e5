//! A minimal XML tokenizer for the protocol's documents.
//!
//! It accepts what real robots and clients send (docs/protocol.md, "XML body" and "Beyond
//! the document"): a declaration in either
//! quote style or none, any whitespace, comments anywhere, attributes (ignored), and
//! elements in any order. It refuses what the protocol never needs and what could be used
//! against a small device: DTDs and entity declarations, CDATA, unknown entity references,
//! mismatched tags, content after the root element, and nesting deeper than
//! [`MAX_DEPTH`]. It works on the caller's bytes and never copies or allocates.

/// Deepest element nesting accepted: `PatrolDevice` › `Items` › item › one more level, so
/// an unknown structured item can still be skipped.
pub const MAX_DEPTH: usize = 4;

/// What was wrong with a document, and where.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct XmlError {
    /// What was wrong.
    pub kind: XmlErrorKind,
    /// Byte offset in the input where it was found.
    pub offset: usize,
}

/// The kinds of [`XmlError`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum XmlErrorKind {
    /// The input ended inside markup or with elements still open.
    UnexpectedEnd,
    /// The input holds no root element.
    NoRoot,
    /// A `<!DOCTYPE` or `<!ENTITY` declaration; refused so no entity can expand.
    Dtd,
    /// A CDATA section; the protocol never uses one.
    Cdata,
    /// An `&` reference other than the five predefined entities or a character reference.
    UnknownEntity,
    /// An end tag that does not match the open element.
    MismatchedTag,
    /// Elements nested deeper than [`MAX_DEPTH`].
    TooDeep,
    /// Something other than whitespace, comments or processing instructions after the root
    /// element.
    TrailingContent,
    /// Text outside the root element.
    TextOutsideRoot,
    /// A tag, attribute or name that is not well formed.
    MalformedTag,
}

/// One piece of a document. Comments, the declaration and processing instructions are
/// consumed silently.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Token<'a> {
    /// `<name ...>`
    Start(&'a [u8]),
    /// `</name>`
    End(&'a [u8]),
    /// `<name .../>`
    Empty(&'a [u8]),
    /// Character data between tags, as written (entity references left in place).
    Text(&'a [u8]),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Place {
    Prolog,
    Root,
    Epilog,
}

/// Splits a document into [`Token`]s.
#[derive(Debug, Clone)]
pub struct Tokenizer<'a> {
    input: &'a [u8],
    pos: usize,
    open: [&'a [u8]; MAX_DEPTH],
    depth: usize,
    place: Place,
    /// Whether [`Tokenizer::simple_element`] may take its shortcut.
    shortcut: bool,
}

/// A plain `<name>text</name>` element found by [`Tokenizer::simple_element`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimpleElement<'a> {
    /// The element name.
    pub name: &'a [u8],
    /// The text, with surrounding whitespace removed.
    pub text: &'a [u8],
    /// Offset just past the end tag.
    end: usize,
}

impl<'a> Tokenizer<'a> {
    /// A tokenizer for a whole document with exactly one root element. A UTF-8 byte order
    /// mark before it and NUL bytes after it are not part of it.
    pub fn document(input: &'a [u8]) -> Self {
        let input = input.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(input);
        // A sender that counts a C string's terminator in the frame's length leaves a NUL
        // after the document. It is not XML, but the XML libraries robots and their clients
        // use read a string only up to it, so it is dropped rather than the message refused.
        let end = input
            .iter()
            .rposition(|&b| b != 0)
            .map_or(0, |last| last + 1);
        let input = input.get(..end).unwrap_or(input);
        Self {
            input,
            pos: 0,
            open: [&[]; MAX_DEPTH],
            depth: 0,
            place: Place::Prolog,
            shortcut: true,
        }
    }

    /// The same tokenizer with [`Tokenizer::simple_element`] always declining, so that every
    /// element goes through [`Tokenizer::next_token`]: the reference the shortcut is tested
    /// against.
    pub fn without_shortcut(self) -> Self {
        Self {
            shortcut: false,
            ..self
        }
    }

    /// Whether the shortcuts may be taken: never in a `compact` build, so that their code is
    /// left out of it.
    fn shortcuts_on(&self) -> bool {
        !cfg!(feature = "compact") && self.shortcut
    }

    /// Byte offset of the next token.
    pub fn offset(&self) -> usize {
        self.pos
    }

    /// Number of elements currently open.
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// The input the offsets refer to.
    pub fn input(&self) -> &'a [u8] {
        self.input
    }

    /// The shortcut for the usual layout of an item or header line: if what follows (after
    /// whitespace) is a plain `<name>text</name>` (no attributes, comments, references or
    /// child elements, the end tag written exactly), returns it without consuming it.
    ///
    /// Whenever it returns an element, [`Tokenizer::next_token`] would have read the same
    /// thing as whitespace text, `Start(name)`, `Text` and `End(name)`, with no error, so
    /// [`Tokenizer::take`] followed by the caller's use of the element is exactly what the
    /// general path does; anything else declines and leaves the general path to read (or
    /// refuse) it. Checked by the `read_paths` fuzz target and property tests.
    pub fn simple_element(&self) -> Option<SimpleElement<'a>> {
        let (at, tag) = self.simple_start()?;
        let (name, text, len) = plain_element(tag)?;
        Some(SimpleElement {
            name,
            text: text.trim_ascii(),
            end: at + len,
        })
    }

    /// [`Tokenizer::simple_element`] for the element `name` whose text is a short value
    /// (the header's numbers and time), read by [`plain_item`] in the pass that finds the
    /// text's end: consumes the element and returns the value, or consumes nothing.
    /// Always inlined: once the header reader called it too, the compiler kept one shared
    /// copy, and the item reader's loop measured slower.
    #[inline(always)]
    pub fn simple_value<T>(
        &mut self,
        name: &[u8],
        read: impl FnOnce(&[u8]) -> Option<(T, usize)>,
    ) -> Option<T> {
        // The value leaves through a capture, not through `take_element`'s result: a
        // result generic over `T` changed how the item reader's loop was compiled, 180
        // instructions more a 1002 answer (measured).
        let mut value = None;
        self.take_element(|tag| {
            let (read_value, len) = plain_item(tag, name, None, read)?;
            value = Some(read_value);
            Some(len)
        });
        value
    }

    /// The shortcut for the usual start of a document: one declaration (`<?…?>`) or none,
    /// whitespace, then the root's start tag written plainly, `<name>`, where `name` is made
    /// of name bytes. Consumes them and returns `true` exactly where
    /// [`Tokenizer::next_token`] would have skipped the same declaration and whitespace and
    /// read `Start(name)` without error; otherwise consumes nothing.
    // Left to the compiler: kept out of line, as `plain_start` is, it took 16 instructions
    // and (on the microcontroller) 56 bytes more a decode (callgrind, on 0886527).
    pub fn plain_root(&mut self, name: &'static [u8]) -> bool {
        if !self.shortcuts_on() || self.place != Place::Prolog {
            return false;
        }
        let rest = self.rest();
        let mut at = 0;
        if rest.starts_with(b"<?") {
            // What the general path skips: up to the first `?>`, whatever is inside.
            let Some(end) = find(rest, b"?>") else {
                return false;
            };
            at = end + 2;
        }
        let tail = rest.get(at..).unwrap_or_default();
        at += skip_spaces(tail);
        let Some(tag) = rest.get(at..).and_then(|t| t.strip_prefix(b"<")) else {
            return false;
        };
        match self.open.first_mut() {
            Some(slot) if self.depth == 0 && is_tag(tag, name) => *slot = name,
            _ => return false,
        }
        self.depth = 1;
        self.place = Place::Root;
        self.pos += at + name.len() + 2;
        true
    }

    /// The shortcut for a start tag written plainly, `<name>`, after whitespace, where
    /// `name` is made of name bytes: consumes it and returns `true` exactly where
    /// [`Tokenizer::next_token`] would have read whitespace text and `Start(name)` without
    /// error; otherwise consumes nothing.
    // Out of line: inlined into the document reader (one copy for requests and answers, its
    // items handler called through a pointer), it made the reader's loop slower by several
    // percent (measured).
    #[inline(never)]
    pub fn plain_start(&mut self, name: &'static [u8]) -> bool {
        let Some((at, tag)) = self.simple_start() else {
            return false;
        };
        if !is_tag(tag, name) {
            return false;
        }
        // simple_start checked that one more level is allowed.
        if let Some(slot) = self.open.get_mut(self.depth) {
            *slot = name;
            self.depth += 1;
            self.pos = at + name.len() + 2;
            return true;
        }
        false
    }

    /// The shortcut for the end tag of the open element `name`, written plainly
    /// (`</name>`), after whitespace: consumes it and returns `true` exactly where
    /// [`Tokenizer::next_token`] would have read whitespace text and `End(name)`; otherwise
    /// consumes nothing.
    pub fn plain_end(&mut self, name: &[u8]) -> bool {
        let open = self.depth.checked_sub(1).and_then(|d| self.open.get(d));
        let is_open = open.is_some_and(|open| same_name(open, name));
        if !self.shortcuts_on() || self.place != Place::Root || !is_open {
            return false;
        }
        let rest = self.rest();
        let at = skip_spaces(rest);
        let Some(tag) = rest.get(at..).and_then(|t| t.strip_prefix(b"</")) else {
            return false;
        };
        if !is_tag(tag, name) {
            return false;
        }
        self.depth -= 1;
        if self.depth == 0 {
            self.place = Place::Epilog;
        }
        self.pos += at + name.len() + 3;
        true
    }

    /// Where a simple element may start: inside an element, with room for one more level,
    /// after whitespace; the offset of its `<` and what follows it.
    fn simple_start(&self) -> Option<(usize, &'a [u8])> {
        if !self.may_take_elements() {
            return None;
        }
        let rest = self.rest();
        let at = skip_spaces(rest);
        let tag = rest.get(at..)?.strip_prefix(b"<")?;
        Some((self.pos + at, tag))
    }

    /// Whether the shortcuts may take a simple element here: text is only allowed inside an
    /// element, and an element inside another only below the deepest level, so a depth of 1
    /// to `MAX_DEPTH - 1` (an open element means the tokenizer is inside the root), tested
    /// in one comparison.
    fn may_take_elements(&self) -> bool {
        self.shortcuts_on() && self.depth.wrapping_sub(1) < MAX_DEPTH - 1
    }

    /// The shortcut for a run of elements in the usual layout, an item block's lines: after
    /// whitespace, `line` is given what follows each `<` and returns the length of the
    /// element it read from there, or `None` to end the run there, that element left
    /// unread. `line` must take only an element written plainly, as [`plain_item`] reads
    /// one, so that the run consumes exactly the whitespace and elements the general path
    /// would have read without error.
    #[cfg(not(feature = "compact"))]
    pub fn plain_run(&mut self, mut line: impl FnMut(&'a [u8]) -> Option<usize>) {
        if !self.may_take_elements() {
            return;
        }
        let input = self.input;
        let mut pos = self.pos;
        while let Some(rest) = input.get(pos..) {
            let at = skip_spaces(rest);
            let Some(tag) = rest.get(at..).and_then(|t| t.strip_prefix(b"<")) else {
                break;
            };
            let Some(len) = line(tag) else {
                break;
            };
            pos += at + len;
        }
        self.pos = pos;
    }

    /// Consumes the element at the next `<` (after whitespace) if `read` takes it: `read` is
    /// given what follows the `<` and returns the element's length if it takes it. Returns
    /// whether it did; otherwise consumes nothing. `read` must take only an element
    /// [`plain_element`] reads, one [`Tokenizer::simple_element`] would have read.
    pub fn take_element(&mut self, read: impl FnOnce(&'a [u8]) -> Option<usize>) -> bool {
        let Some((at, len)) = self
            .simple_start()
            .and_then(|(at, tag)| Some((at, read(tag)?)))
        else {
            return false;
        };
        self.pos = at + len;
        true
    }

    /// Moves past an element returned by [`Tokenizer::simple_element`].
    pub fn take(&mut self, element: &SimpleElement<'a>) {
        self.pos = element.end;
    }

    fn error(&self, kind: XmlErrorKind) -> XmlError {
        XmlError {
            kind,
            offset: self.pos,
        }
    }

    /// What follows the current position. Out of line in a `compact` build, where its
    /// callers are many and none is hot; the default build's shortcuts want it inlined.
    #[cfg_attr(feature = "compact", inline(never))]
    fn rest(&self) -> &'a [u8] {
        self.input.get(self.pos..).unwrap_or_default()
    }

    /// Advances past the first `needle` after the current position.
    fn skip_past(&mut self, needle: &[u8]) -> Result<(), XmlError> {
        let at = find(self.rest(), needle).ok_or(self.error(XmlErrorKind::UnexpectedEnd))?;
        self.pos += at + needle.len();
        Ok(())
    }

    /// The next token, or `None` at the end of a complete document.
    pub fn next_token(&mut self) -> Result<Option<Token<'a>>, XmlError> {
        loop {
            let rest = self.rest();
            let Some(&first) = rest.first() else {
                return match self.place {
                    Place::Epilog if self.depth == 0 => Ok(None),
                    Place::Prolog => Err(self.error(XmlErrorKind::NoRoot)),
                    _ => Err(self.error(XmlErrorKind::UnexpectedEnd)),
                };
            };
            if first != b'<' {
                let len = rest.iter().position(|&b| b == b'<').unwrap_or(rest.len());
                let text = rest.get(..len).unwrap_or_default();
                if self.place != Place::Root || self.depth == 0 {
                    if text.iter().all(u8::is_ascii_whitespace) {
                        self.pos += len;
                        continue;
                    }
                    return Err(self.error(match self.place {
                        Place::Epilog => XmlErrorKind::TrailingContent,
                        _ => XmlErrorKind::TextOutsideRoot,
                    }));
                }
                self.check_references(text)?;
                self.pos += len;
                return Ok(Some(Token::Text(text)));
            }
            let markup = rest.get(1..).unwrap_or_default();
            if markup.starts_with(b"?") {
                self.skip_past(b"?>")?;
            } else if markup.starts_with(b"!--") {
                self.pos += 4;
                self.skip_past(b"-->")?;
            } else if markup.starts_with(b"!") {
                // Every other `<!`: refused, and why. A list, where three `starts_with`
                // would each be inlined.
                const REFUSED: [(&[u8], XmlErrorKind); 3] = [
                    (b"![CDATA[", XmlErrorKind::Cdata),
                    (b"!DOCTYPE", XmlErrorKind::Dtd),
                    (b"!ENTITY", XmlErrorKind::Dtd),
                ];
                let kind = REFUSED
                    .iter()
                    .find(|(prefix, _)| markup.starts_with(prefix))
                    .map_or(XmlErrorKind::MalformedTag, |&(_, kind)| kind);
                return Err(self.error(kind));
            } else if let Some(tag) = markup.strip_prefix(b"/") {
                return self.end_tag(tag).map(Some);
            } else {
                return self.start_tag(markup).map(Some);
            }
        }
    }

    fn end_tag(&mut self, tag: &'a [u8]) -> Result<Token<'a>, XmlError> {
        let name_len = name_len(tag);
        let name = tag.get(..name_len).unwrap_or_default();
        let after = tag.get(name_len..).unwrap_or_default();
        let close = after
            .iter()
            .position(|&b| b == b'>')
            .ok_or(self.error(XmlErrorKind::UnexpectedEnd))?;
        let between = after.get(..close).unwrap_or_default();
        if name.is_empty() || !between.iter().all(u8::is_ascii_whitespace) {
            return Err(self.error(XmlErrorKind::MalformedTag));
        }
        let open = self
            .depth
            .checked_sub(1)
            .and_then(|d| self.open.get(d))
            .copied();
        if open != Some(name) {
            return Err(self.error(XmlErrorKind::MismatchedTag));
        }
        self.depth -= 1;
        if self.depth == 0 {
            self.place = Place::Epilog;
        }
        self.pos += 2 + name_len + close + 1;
        Ok(Token::End(name))
    }

    fn start_tag(&mut self, tag: &'a [u8]) -> Result<Token<'a>, XmlError> {
        if self.place == Place::Epilog {
            return Err(self.error(XmlErrorKind::TrailingContent));
        }
        let name_len = name_len(tag);
        let name = tag.get(..name_len).unwrap_or_default();
        if name.is_empty() {
            return Err(self.error(XmlErrorKind::MalformedTag));
        }
        let (attrs_len, empty) = self.attributes(tag.get(name_len..).unwrap_or_default())?;
        // '<' + name + attributes + '>' or '/>'
        let tag_len = 1 + name_len + attrs_len + if empty { 2 } else { 1 };
        if empty {
            if self.depth == 0 {
                self.place = Place::Epilog;
            }
            self.pos += tag_len;
            return Ok(Token::Empty(name));
        }
        let slot = self.open.get_mut(self.depth).ok_or(XmlError {
            kind: XmlErrorKind::TooDeep,
            offset: self.pos,
        })?;
        *slot = name;
        self.depth += 1;
        self.place = Place::Root;
        self.pos += tag_len;
        Ok(Token::Start(name))
    }

    /// Checks `name="value"` pairs up to the tag's end; returns their length and whether the
    /// tag closes itself.
    fn attributes(&self, attrs: &[u8]) -> Result<(usize, bool), XmlError> {
        let malformed = self.error(XmlErrorKind::MalformedTag);
        let end = self.error(XmlErrorKind::UnexpectedEnd);
        let mut at = 0;
        loop {
            let rest = attrs.get(at..).unwrap_or_default();
            let ws = rest.iter().take_while(|b| b.is_ascii_whitespace()).count();
            let rest = rest.get(ws..).unwrap_or_default();
            match rest {
                [] => return Err(end),
                [b'>', ..] => return Ok((at + ws, false)),
                [b'/', b'>', ..] => return Ok((at + ws, true)),
                [b'/'] => return Err(end),
                _ if ws == 0 && at > 0 => return Err(malformed),
                _ => {}
            }
            let name = name_len(rest);
            let quote = match rest.get(name..) {
                Some([b'=', q @ (b'"' | b'\''), ..]) if name > 0 => *q,
                Some([] | [b'=']) => return Err(end),
                _ => return Err(malformed),
            };
            let value = rest.get(name + 2..).unwrap_or_default();
            let close = value.iter().position(|&b| b == quote).ok_or(end)?;
            let value = value.get(..close).unwrap_or_default();
            #[expect(
                clippy::manual_contains,
                reason = "`contains` links a `memchr` larger than the codec needs"
            )]
            if value.iter().any(|&b| b == b'<') {
                return Err(malformed);
            }
            self.check_references(value)?;
            at += ws + name + 2 + close + 1;
        }
    }

    /// Refuses `&` references other than the predefined entities and character references.
    fn check_references(&self, text: &[u8]) -> Result<(), XmlError> {
        let mut rest = text;
        while let Some(amp) = rest.iter().position(|&b| b == b'&') {
            let after = rest.get(amp + 1..).unwrap_or_default();
            let semi = after.iter().position(|&b| b == b';');
            let entity = semi.and_then(|s| after.get(..s)).unwrap_or_default();
            // A list, not a `match`, whose five comparisons would each be inlined.
            const PREDEFINED: [&[u8]; 5] = [b"lt", b"gt", b"amp", b"quot", b"apos"];
            let known = PREDEFINED.contains(&entity) || is_char_reference(entity);
            if !known {
                let offset = self.pos + (text.len() - rest.len()) + amp;
                return Err(XmlError {
                    kind: XmlErrorKind::UnknownEntity,
                    offset,
                });
            }
            rest = after.get(entity.len() + 1..).unwrap_or_default();
        }
        Ok(())
    }
}

fn is_char_reference(entity: &[u8]) -> bool {
    match entity {
        [b'#', b'x', hex @ ..] => !hex.is_empty() && hex.iter().all(u8::is_ascii_hexdigit),
        [b'#', dec @ ..] => !dec.is_empty() && dec.iter().all(u8::is_ascii_digit),
        _ => false,
    }
}

/// A byte that may appear in an XML name (as far as this reader checks names).
const NAME_BYTE: u8 = 1 << 1;
/// ASCII whitespace, as [`u8::is_ascii_whitespace`] defines it.
const SPACE_BYTE: u8 = 1 << 2;
/// A byte that ends plain text: `<` (markup) or `&` (a reference).
const TEXT_END: u8 = 1 << 3;

/// The class of the byte `c`: 0 for none of the others, 1 for a name byte, 2 for
/// whitespace, 3 for the end of plain text.
const fn class(c: u8) -> u8 {
    if c.is_ascii_alphanumeric() || matches!(c, b'_' | b'-' | b'.' | b':') || c >= 0x80 {
        1
    } else if c.is_ascii_whitespace() {
        2
    } else if c == b'<' || c == b'&' {
        3
    } else {
        0
    }
}

/// Every byte's [`class`], so that the scanning loops cost one lookup per byte instead of a
/// chain of comparisons: in the default build a byte each, `1 << class`, which [`is`] tests
/// against a set of classes in one instruction; in a `compact` build two bits each, the
/// class itself, 64 bytes of flash, whose lookups then take a shift or two more.
#[cfg(not(feature = "compact"))]
static CLASSES: [u8; 256] = classes();

/// Every byte's [`class`], two bits each (see the default build's).
#[cfg(feature = "compact")]
static CLASSES: [u8; 64] = classes();

/// [`CLASSES`] as this build keeps it.
#[expect(
    clippy::indexing_slicing,
    reason = "the index is below the table's length by the loop's bound"
)]
const fn classes<const N: usize>() -> [u8; N] {
    let mut table = [0; N];
    let mut b = 0;
    while b < 256 {
        let class = class(b as u8);
        if N == 256 {
            table[b] = 1 << class;
        } else {
            table[b / 4] |= class << (b % 4 * 2);
        }
        b += 1;
    }
    table
}

/// Whether `b` is of one of the `classes` (a set of `1 << class`).
#[inline(always)]
fn is(b: u8, classes: u8) -> bool {
    #[cfg(not(feature = "compact"))]
    let set = CLASSES.get(usize::from(b)).copied().unwrap_or(1);
    #[cfg(feature = "compact")]
    let set = 1
        << CLASSES
            .get(usize::from(b / 4))
            .map_or(0, |four| four >> (b % 4 * 2) & 3);
    set & classes != 0
}

/// Length of the run of bytes of `classes` at the start of `bytes`.
fn run(bytes: &[u8], classes: u8) -> usize {
    bytes.iter().take_while(|&&b| is(b, classes)).count()
}

/// Length of the whitespace at the start of `bytes`; a run of spaces (indentation) is
/// skipped up to eight bytes at a time, with the whitespace byte (a line end) before it.
fn skip_spaces(bytes: &[u8]) -> usize {
    const SPACES: u64 = u64::from_le_bytes([b' '; 8]);
    let mut at = 0;
    loop {
        match bytes.get(at) {
            Some(&b) if is(b, SPACE_BYTE) => {
                // The spaces after it, up to eight at a time: the first other byte is the
                // lowest nonzero byte of the word XOR eight spaces.
                let from = at + 1;
                at = match bytes.get(from..from + 8).and_then(|w| w.try_into().ok()) {
                    Some(word) => {
                        from + match u64::from_le_bytes(word) ^ SPACES {
                            0 => 8,
                            others => (others.trailing_zeros() / 8) as usize,
                        }
                    }
                    None => from,
                };
            }
            _ => return at,
        }
    }
}

/// Length of the plain text at the start of `bytes`: up to the first `<` or `&`, found a
/// word at a time; `None` if there is neither.
fn text_len(bytes: &[u8]) -> Option<usize> {
    const ONES: u64 = u64::from_le_bytes([1; 8]);
    const HIGHS: u64 = ONES << 7;
    // A byte of `x` is zero exactly where the lowest set high bit of `zero_bytes(x)` is: a
    // borrow can only mark bytes above a zero byte, never below one.
    let zero_bytes = |x: u64| x.wrapping_sub(ONES) & !x & HIGHS;
    let mut at = 0;
    while let Some(word) = bytes.get(at..at + 8).and_then(|w| w.try_into().ok()) {
        let word = u64::from_le_bytes(word);
        let ends = zero_bytes(word ^ (ONES * u64::from(b'<')))
            | zero_bytes(word ^ (ONES * u64::from(b'&')));
        if ends != 0 {
            return Some(at + (ends.trailing_zeros() / 8) as usize);
        }
        at += 8;
    }
    let tail = bytes.get(at..)?;
    tail.iter().position(|&b| is(b, TEXT_END)).map(|i| at + i)
}

/// The value of the element `name` at `tag` (what follows its `<`) and the element's length
/// from its `<`, if it is written plainly, `<name>text</name>`, with a text that `read`
/// accepts. `read` parses a value at the start of the text and returns it with the length of
/// its text; it must accept only text that holds no `<` or `&` and neither starts nor ends
/// with whitespace (digits, a float's usual text, the time), so the text is exactly what
/// [`Tokenizer::simple_element`] would have found; and it must give for it what parsing it
/// alone gives. `head`, where the caller has it, is `name`'s first 16 bytes with whatever
/// follows them, so that a name shorter than that is compared in one masked piece (the item
/// lines of `Tokenizer::plain_run`, which a `compact` build leaves out).
pub fn plain_item<T>(
    tag: &[u8],
    name: &[u8],
    head: Option<&[u8; 16]>,
    read: impl FnOnce(&[u8]) -> Option<(T, usize)>,
) -> Option<(T, usize)> {
    let n = name.len();
    let start = head.zip(tag.first_chunk::<16>()).filter(|_| n < 16);
    let opened = match start {
        Some((head, start)) => same_head(start, head, n) && start.get(n) == Some(&b'>'),
        None => is_tag(tag, name),
    };
    if !opened {
        return None;
    }
    let content = tag.get(n + 1..)?;
    let (value, used) = read(content)?;
    if used == 0 {
        return None;
    }
    let close = content.get(used..)?.strip_prefix(b"</")?;
    // The end tag's name and `>` against the start tag's.
    let closed = match (start, close.first_chunk::<16>()) {
        (Some((_, start)), Some(close)) => same_head(close, start, n + 1),
        _ => is_tag(close, name),
    };
    closed.then_some((value, element_len(n, used)))
}

/// Whether the first `n` (at most 16) bytes of `a` and `b` are the same.
#[inline(always)]
fn same_head(a: &[u8; 16], b: &[u8; 16], n: usize) -> bool {
    // The first byte that differs, if any, is at `n` or after it.
    (u128::from_le_bytes(*a) ^ u128::from_le_bytes(*b)).trailing_zeros() >= 8 * n as u32
}

/// For a [`plain_item`] whose text is a float's: the text up to the first `<` or `&`.
#[cfg(not(feature = "compact"))]
pub fn plain_text(content: &[u8]) -> Option<(&[u8], usize)> {
    let len = text_len(content)?;
    Some((content.get(..len)?, len))
}

/// Whether `bytes` starts with `prefix`. Names of up to 16 bytes are compared as two
/// overlapping fixed-size pieces: a call to `memcmp` costs more than such a short compare.
fn has_prefix(bytes: &[u8], prefix: &[u8]) -> bool {
    fn same<const N: usize>(a: &[u8], b: &[u8], at: usize) -> bool {
        let a = a.get(at..).and_then(|a| a.first_chunk::<N>());
        let b = b.get(at..).and_then(|b| b.first_chunk::<N>());
        a.is_some() && a == b
    }
    let n = prefix.len();
    match n {
        8..=16 => same::<8>(bytes, prefix, 0) && same::<8>(bytes, prefix, n - 8),
        4..8 => same::<4>(bytes, prefix, 0) && same::<4>(bytes, prefix, n - 4),
        2..4 => same::<2>(bytes, prefix, 0) && same::<2>(bytes, prefix, n - 2),
        _ => bytes.starts_with(prefix),
    }
}

/// Whether the names `a` and `b` are the same, compared as [`has_prefix`] does.
fn same_name(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && has_prefix(a, b)
}

/// The element at `tag` (what follows its `<`) if it is written plainly, `<name>text</name>`,
/// with a text that holds no `<` or `&`: its name, its text as written (untrimmed) and its
/// length from its `<`. What [`Tokenizer::simple_element`] reads, wherever the element is.
// Out of line, one copy for `simple_element` and the block reader's pass-over: a copy
// inlined into each saved under 1 % of a 1002 decode's instructions, for 372 bytes (measured).
#[inline(never)]
pub fn plain_element(tag: &[u8]) -> Option<(&[u8], &[u8], usize)> {
    let (name, after) = tag.split_at_checked(run(tag, NAME_BYTE))?;
    let content = after.strip_prefix(b">").filter(|_| !name.is_empty())?;
    let (text, after) = content.split_at_checked(text_len(content)?)?;
    let close = after.strip_prefix(b"</")?;
    is_tag(close, name).then_some((name, text, element_len(name.len(), text.len())))
}

/// The length of `<name>text</name>` for a name and a text of these lengths.
#[inline(always)]
fn element_len(name_len: usize, text_len: usize) -> usize {
    2 * name_len + text_len + 5
}

/// Whether `bytes` starts with the tag name `name` and the `>` that closes it.
fn is_tag(bytes: &[u8], name: &[u8]) -> bool {
    has_prefix(bytes, name) && bytes.get(name.len()) == Some(&b'>')
}

/// Length of the XML name at the start of `bytes`.
// Out of line: the general path's three callers share one copy of the scan.
#[inline(never)]
fn name_len(bytes: &[u8]) -> usize {
    run(bytes, NAME_BYTE)
}

/// Position of `needle` (two or three bytes) in `haystack`: candidates are found by their
/// first byte, which is rare in a declaration or comment.
fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    let (&first, _) = needle.split_first()?;
    let mut at = 0;
    loop {
        let rest = haystack.get(at..)?;
        let candidate = at + rest.iter().position(|&b| b == first)?;
        if haystack.get(candidate..)?.starts_with(needle) {
            return Some(candidate);
        }
        at = candidate + 1;
    }
}

/// Content of a simple element after its start tag: `Some(text)`, with surrounding
/// whitespace removed, when it holds only text (or nothing); `None` when it holds child
/// elements or comments split its text.
///
/// Consumes everything up to and including the element's end tag.
pub fn element_text<'a>(tokens: &mut Tokenizer<'a>) -> Result<Option<&'a [u8]>, XmlError> {
    let depth = tokens.depth();
    // The one piece of text that is not whitespace; `None` once anything else is there.
    let mut text: Option<&'a [u8]> = Some(&[]);
    let mut seen_text = false;
    loop {
        match tokens.next_token()? {
            Some(Token::End(_)) if tokens.depth() < depth => {
                return Ok(text.map(<[u8]>::trim_ascii));
            }
            // Whitespace around a comment inside a value is layout, not part of the value.
            Some(Token::Text(t)) if t.iter().all(u8::is_ascii_whitespace) => {}
            Some(Token::Text(t)) if !seen_text => {
                seen_text = true;
                text = text.map(|_| t);
            }
            Some(_) => text = None,
            None => return Err(tokens.error(XmlErrorKind::UnexpectedEnd)),
        }
    }
}
