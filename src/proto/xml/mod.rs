//! The XML body (ASDU) of a frame: writer, tokenizer, and the document structure.
//!
//! Every body is one `<PatrolDevice>` element holding `Type`, `Command`, `Time` and one or
//! more `Items` blocks, in any order. [`read_document`] walks it once and hands each
//! `Items` block to the caller together with the `Type` it belongs to.
//!
//! The usual start (declaration, `<PatrolDevice>`) and lines in the usual layout
//! (`<Name>text</Name>`, `<Items>`, `</Items>`) are read by the tokenizer's shortcuts
//! ([`Tokenizer::plain_root`], [`Tokenizer::simple_element`] and their siblings) without
//! making tokens; anything else goes token by token. The shortcuts yield exactly what the tokens
//! would, which [`read_document_general`] (every shortcut off) lets tests check. A build
//! with the `compact` feature leaves the shortcuts out, for their flash.

pub mod number;
pub mod reader;
pub mod writer;

use crate::proto::time::{TIME_TEXT_LEN, Timestamp};
use number::NumberError;
use reader::{Token, Tokenizer, XmlError, element_text};

/// Most `<Items>` blocks a document may carry (a 1003 request has one per waypoint).
pub const MAX_ITEMS_BLOCKS: usize = 8;

/// Why a document's structure was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum StructureError {
    /// The XML itself is not acceptable.
    Xml(XmlError),
    /// The root element is not `<PatrolDevice>`.
    NotPatrolDevice,
    /// A required element (`Type`, `Command`) is missing.
    MissingElement(&'static str),
    /// `Type`, `Command` or `Time` holds something other than plain text.
    NotText(&'static str),
    /// `Type` or `Command` is not an integer.
    BadNumber(&'static str, NumberError),
    /// More than [`MAX_ITEMS_BLOCKS`] `<Items>` blocks.
    TooManyItemsBlocks,
    /// `Type` or `Command` is there twice with different values: which of them the items
    /// belong to cannot be told.
    Conflicting(&'static str),
}

impl From<XmlError> for StructureError {
    fn from(e: XmlError) -> Self {
        Self::Xml(e)
    }
}

/// The header elements of a document.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Envelope {
    /// The `Type` element.
    pub message_type: i32,
    /// The `Command` element.
    pub command: i32,
    /// The `Time` element; the all-zero time when absent.
    pub time: Timestamp,
}

/// Reads a `<PatrolDevice>` document in one pass, checking all of its XML, and hands each
/// `<Items>` block to `on_items` with the `Type` and `Command` the document declares.
///
/// Items can only be interpreted once `Type` is known. Real documents put it first, so
/// blocks are normally read as the pass reaches them; if a block comes before `Type` or
/// `Command`, the pass only checks it (and every block after it, to keep their order), and
/// a second pass reads them all, the envelope known. Returns the envelope and the number of
/// blocks.
pub fn read_document<'a, E>(
    input: &'a [u8],
    on_items: impl FnMut(&Envelope, &mut Items<'_, 'a>) -> Result<(), E>,
) -> Result<(Envelope, usize), E>
where
    E: From<StructureError>,
{
    read_tokens(Tokenizer::document(input), &mut { on_items })
}

/// [`read_document`] without the shortcut for the usual layout
/// ([`Tokenizer::simple_element`]): every element is read token by token. It returns
/// exactly what [`read_document`] returns; it exists as the reference the shortcut is
/// tested against.
pub fn read_document_general<'a, E>(
    input: &'a [u8],
    on_items: impl FnMut(&Envelope, &mut Items<'_, 'a>) -> Result<(), E>,
) -> Result<(Envelope, usize), E>
where
    E: From<StructureError>,
{
    read_tokens(Tokenizer::document(input).without_shortcut(), &mut {
        on_items
    })
}

/// [`read_document`] from a tokenizer made by [`Tokenizer::document`], with or without its
/// shortcut. `on_items` is called through a pointer (once per block), so that one copy of
/// the document reader serves requests and responses alike.
pub(crate) fn read_tokens<'a, E>(
    document: Tokenizer<'a>,
    on_items: &mut dyn FnMut(&Envelope, &mut Items<'_, 'a>) -> Result<(), E>,
) -> Result<(Envelope, usize), E>
where
    E: From<StructureError>,
{
    let xml = |e: XmlError| E::from(StructureError::Xml(e));
    // Blocks are handed over with this envelope in a second pass, or, in the first, with the
    // header read so far if it is complete and no block was passed over (only checked) for
    // want of one.
    let mut known = None;
    loop {
        let mut tokens = document.clone();
        if !tokens.plain_root(b"PatrolDevice") {
            match tokens.next_token().map_err(xml)? {
                Some(Token::Start(b"PatrolDevice")) => {}
                _ => return Err(StructureError::NotPatrolDevice.into()),
            }
        }
        let mut header = Header::default();
        let mut passed_over = false;
        let mut blocks = 0;
        // The header element real documents write next.
        let mut next_header = HeaderElement::ORDER.iter();
        let mut expected = next_header.next();
        loop {
            // The usual layout without tokens: the header line expected next, the start of a
            // block, other header lines and unknown plain elements, and the end of the document.
            if let Some(&element) = expected
                && header.take_plain(&mut tokens, element)
            {
                expected = next_header.next();
                continue;
            }
            let token = if tokens.plain_start(b"Items") {
                Token::Start(b"Items")
            } else if let Some(element) = tokens.simple_element().filter(|e| e.name != b"Items") {
                tokens.take(&element);
                if let Some(header_element) = HeaderElement::named(element.name) {
                    header.set(header_element, element.text)?;
                }
                continue;
            } else if tokens.plain_end(b"PatrolDevice") {
                continue;
            } else {
                match tokens.next_token().map_err(xml)? {
                    Some(token) => token,
                    None => break,
                }
            };
            let (tag, empty) = match token {
                Token::Start(tag) => (tag, false),
                Token::Empty(tag) => (tag, true),
                Token::End(_) | Token::Text(_) => continue,
            };
            if tag != b"Items" {
                if !empty {
                    // Any other element is read whole too, which checks it, and passed over.
                    let text = element_text(&mut tokens).map_err(xml)?;
                    if let Some(element) = HeaderElement::named(tag) {
                        header.set(
                            element,
                            text.ok_or(StructureError::NotText(element.name()))?,
                        )?;
                    }
                }
                continue;
            }
            blocks += 1;
            if blocks > MAX_ITEMS_BLOCKS {
                return Err(StructureError::TooManyItemsBlocks.into());
            }
            let envelope = match (known, header.message_type, header.command) {
                (Some(envelope), ..) => Some(envelope),
                (None, Some(message_type), Some(command)) if !passed_over => Some(Envelope {
                    message_type,
                    command,
                    time: header.time,
                }),
                _ => None,
            };
            match envelope {
                Some(envelope) => {
                    let mut items = Items::new(&mut tokens, empty);
                    on_items(&envelope, &mut items)?;
                    items.finish().map_err(xml)?;
                }
                None => {
                    passed_over = true;
                    if !empty {
                        element_text(&mut tokens).map_err(xml)?;
                    }
                }
            }
        }
        let envelope = Envelope {
            message_type: header
                .message_type
                .ok_or(StructureError::MissingElement("Type"))?,
            command: header
                .command
                .ok_or(StructureError::MissingElement("Command"))?,
            time: header.time,
        };
        if !passed_over {
            return Ok((envelope, blocks));
        }
        // The first pass read no block (the first came before the header was complete), and
        // checked the whole document: the second reads every block, in order.
        known = Some(envelope);
    }
}

/// The header elements read so far.
#[derive(Default)]
struct Header {
    message_type: Option<i32>,
    command: Option<i32>,
    time: Timestamp,
}

impl Header {
    /// Takes the text of the header element `element`.
    fn set(&mut self, element: HeaderElement, text: &[u8]) -> Result<(), StructureError> {
        match self.number_slot(element) {
            Some(slot) => {
                let value = number::parse_int(text)
                    .map_err(|e| StructureError::BadNumber(element.name(), e))?;
                // A block may already have been read as the first value declared.
                if slot.is_some_and(|first| first != value) {
                    return Err(StructureError::Conflicting(element.name()));
                }
                *slot = Some(value);
            }
            // The robot does not act on the time, so a sender's other format (a `T` between
            // date and time, fractions of a second) costs only the time, read as the
            // all-zero one a body without `Time` has, not the message.
            None => self.time = Timestamp::decode(text).unwrap_or_default(),
        }
        Ok(())
    }

    /// Takes the header element `element` if it is what follows, written plainly: its name
    /// is compared rather than scanned, and its value is read in the pass that finds its
    /// end ([`Tokenizer::simple_value`]). Returns whether it did; if not, nothing is
    /// consumed and the general path reads (or refuses) what is there. What it takes, it
    /// takes exactly as [`Header::set`] would from the element's text.
    // Out of line: inlined into the document reader, its two value readers cost about 300
    // bytes more, and it runs only three times a document.
    #[inline(never)]
    fn take_plain(&mut self, tokens: &mut Tokenizer<'_>, element: HeaderElement) -> bool {
        let name = element.name().as_bytes();
        if let Some(slot) = self.number_slot(element) {
            // A second one is left to `set`, which refuses it if it differs.
            if slot.is_some() {
                return false;
            }
            let value = tokens.simple_value(name, number::parse_int_prefix::<i32>);
            if value.is_some() {
                *slot = value;
            }
            return value.is_some();
        }
        // The time has a fixed length; whatever it accepts is digits and separators.
        let time = tokens.simple_value(name, |text| {
            let text = text.get(..TIME_TEXT_LEN)?;
            Some((Timestamp::decode(text).ok()?, TIME_TEXT_LEN))
        });
        if let Some(time) = time {
            self.time = time;
        }
        time.is_some()
    }

    /// Where the value of the integer element `element` goes; `None` for `Time`.
    fn number_slot(&mut self, element: HeaderElement) -> Option<&mut Option<i32>> {
        match element {
            HeaderElement::Type => Some(&mut self.message_type),
            HeaderElement::Command => Some(&mut self.command),
            HeaderElement::Time => None,
        }
    }
}

/// An element of the header.
#[derive(Clone, Copy)]
enum HeaderElement {
    Type,
    Command,
    Time,
}

impl HeaderElement {
    /// The header elements in the order real documents write them.
    const ORDER: [Self; 3] = [Self::Type, Self::Command, Self::Time];

    /// Their element names, in the same order: one list that both ways between an element
    /// and its name read, where a `match` each way would compare and copy each name apart.
    const NAMES: [&'static str; 3] = ["Type", "Command", "Time"];

    /// The header element called `tag`, or `None` for another element.
    fn named(tag: &[u8]) -> Option<Self> {
        let index = Self::NAMES.iter().position(|name| name.as_bytes() == tag)?;
        Self::ORDER.get(index).copied()
    }

    /// Its element name (only errors ask).
    fn name(self) -> &'static str {
        Self::NAMES.get(self as usize).copied().unwrap_or_default()
    }
}

/// One item: its element name and, if it holds only text, that text with surrounding
/// whitespace removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Item<'a> {
    /// The element name.
    pub name: &'a [u8],
    /// The trimmed text, or `None` if the element holds child elements.
    pub text: Option<&'a [u8]>,
}

/// The items of one `<Items>` block, in document order, read from the document's tokenizer
/// (borrowed for `'t`); unknown ones are the caller's to skip.
#[derive(Debug)]
pub struct Items<'t, 'a> {
    tokens: &'t mut Tokenizer<'a>,
    done: bool,
}

impl<'t, 'a> Items<'t, 'a> {
    /// Items read from the document's tokenizer, just after `<Items>`, or none (`done`) for
    /// an empty block (`<Items/>`).
    pub(crate) fn new(tokens: &'t mut Tokenizer<'a>, done: bool) -> Self {
        Self { tokens, done }
    }

    /// The tokenizer and whether the block has ended, to be read through [`Items::new`] by
    /// a function that takes them as arguments of its own: only a reference passed as an
    /// argument tells the compiler that no other reaches the tokenizer, which lets it keep
    /// the tokenizer's fields in registers across calls (a tenth of a 1002 decode).
    pub(crate) fn parts(&mut self) -> (&mut Tokenizer<'a>, &mut bool) {
        (self.tokens, &mut self.done)
    }

    /// Whether the block has ended.
    pub(crate) fn is_done(&self) -> bool {
        self.done
    }

    /// Reads whatever the consumer left, so the whole block is checked and the tokenizer is
    /// left after `</Items>`.
    fn finish(mut self) -> Result<(), XmlError> {
        for item in &mut self {
            item?;
        }
        Ok(())
    }
}

impl<'a> Iterator for Items<'_, 'a> {
    type Item = Result<Item<'a>, XmlError>;

    fn next(&mut self) -> Option<Self::Item> {
        while !self.done {
            if let Some(element) = self.tokens.simple_element() {
                self.tokens.take(&element);
                return Some(Ok(Item {
                    name: element.name,
                    text: Some(element.text),
                }));
            }
            if self.tokens.plain_end(b"Items") {
                break;
            }
            let token = match self.tokens.next_token() {
                Ok(Some(token)) => token,
                Ok(None) => break,
                Err(e) => {
                    self.done = true;
                    return Some(Err(e));
                }
            };
            return Some(match token {
                Token::Start(name) => element_text(self.tokens).map(|text| Item { name, text }),
                Token::Empty(name) => Ok(Item {
                    name,
                    text: Some(&[]),
                }),
                // The block's end: every item's own end tag is consumed by element_text.
                Token::End(_) => break,
                // Stray text between items is layout.
                Token::Text(_) => continue,
            });
        }
        self.done = true;
        None
    }
}
