//! How typed fields become `<Items>` children and back.
//!
//! Every item is an integer or a float on the wire, so a message's items are described by
//! a [`Table`] (their names one after another, and two bytes an item) and carried through
//! one array of wire values ([`Values`]) with a mask of those present ([`Present`]): one
//! reader and one writer serve every message, and each message adds only its table and the
//! conversion between its fields and that array. The `item_set!` macro writes both from a
//! struct definition that names each field's element, so the list of items is written down
//! once. Keeping per-message code and data this small is what lets the whole codec fit a
//! few KiB of flash.

use super::DecodeError;
use crate::proto::codes::Code;
use crate::proto::xml::Items;
use crate::proto::xml::number;
use crate::proto::xml::reader::Tokenizer;
#[cfg(not(feature = "compact"))]
use crate::proto::xml::reader::{plain_element, plain_item, plain_text};
#[cfg(not(feature = "compact"))]
use crate::proto::xml::writer::PaddedName;
use crate::proto::xml::writer::{DocumentWriter, ItemName, NAME_MAX, Number, WriteError};

/// What an item holds on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Kind {
    /// A float.
    Float,
    /// An integer that fits `i32`.
    Int,
    /// An integer in `0..=255` (the indicator light's colour and brightness).
    Byte,
}

/// Who wrote a document, which decides the float texts it may carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Sender {
    /// A client's request: every float is a number, since the robot acts on it.
    Client,
    /// The robot's answer: a float may also be C's `nan` or `inf`, which a robot prints for
    /// a reading it does not have (an unknown pose); refusing the whole answer for it would
    /// leave the panel without the robot's state and its e-stop unconfirmed.
    Robot,
}

/// One item of a message, as [`Table::item`] gives it: its element name, what it holds,
/// and whether it may be absent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ItemSpec {
    /// The element name as the document spells it. Reading matches it without regard to
    /// ASCII case, which also accepts the vendor client's `MapId` for `MapID`.
    pub name: ItemName,
    /// Integer or float.
    pub kind: Kind,
    /// Whether a document without the item is an error.
    pub required: bool,
}

/// One item's value as a field holds it: the bits of an `i32` or an `f32`, or `None` for an
/// optional item that is absent.
pub type Raw = Option<u32>;

/// Which items of a table are present: bit `i` for the table's item `i`. Tables hold at most
/// [`MAX_ITEMS`] (checked where each is defined), so one word, set and tested in one
/// instruction, replaces a presence flag beside every value.
pub type Present = u32;

/// Most items a table may hold: one bit each in [`Present`].
pub const MAX_ITEMS: usize = Present::BITS as usize;

/// One block's wire values in table order, with room for the largest table, so that one
/// copy of the code reading or writing them serves every message.
pub type Values = [u32; MAX_ITEMS];

/// A field type that can be an item.
pub trait ItemValue: Sized {
    /// What the item holds on the wire.
    const KIND: Kind;
    /// The field as the bits of its wire value; `None` to leave the item out.
    fn to_raw(&self) -> Raw;
    /// The field from the bits of a wire value of its own kind.
    fn from_raw_bits(bits: u32) -> Self;

    /// The field from its item's wire value, `present` or not: an absent item's value is
    /// its kind's absent value ([`ABSENT_FLOAT`] or 0), which the field reads as it reads
    /// any value (a missing float is NaN, a missing code is code 0); an `Option` reads it as
    /// `None`.
    fn from_wire(bits: u32, present: bool) -> Self {
        let _ = present;
        Self::from_raw_bits(bits)
    }
}

/// The wire value of an absent float item: NaN, as a robot writes a reading it does not
/// have.
const ABSENT_FLOAT: u32 = 0x7fc0_0000;

impl ItemValue for f32 {
    const KIND: Kind = Kind::Float;

    fn to_raw(&self) -> Raw {
        Some(self.to_bits())
    }

    fn from_raw_bits(bits: u32) -> Self {
        f32::from_bits(bits)
    }
}

impl ItemValue for i32 {
    const KIND: Kind = Kind::Int;

    fn to_raw(&self) -> Raw {
        Some(*self as u32)
    }

    fn from_raw_bits(bits: u32) -> Self {
        bits as i32
    }
}

impl ItemValue for u8 {
    const KIND: Kind = Kind::Byte;

    fn to_raw(&self) -> Raw {
        Some(u32::from(*self))
    }

    fn from_raw_bits(bits: u32) -> Self {
        bits as u8
    }
}

/// An optional item: absent from older robots, written only when present.
impl<T: ItemValue> ItemValue for Option<T> {
    const KIND: Kind = T::KIND;

    fn to_raw(&self) -> Raw {
        self.as_ref().and_then(T::to_raw)
    }

    fn from_raw_bits(bits: u32) -> Self {
        Some(T::from_raw_bits(bits))
    }

    fn from_wire(bits: u32, present: bool) -> Self {
        present.then(|| T::from_raw_bits(bits))
    }
}

/// One item as its [`Table`] keeps it, in two bytes: where its name starts among the
/// table's names, and the name's length with what the item holds in the top bits. So an
/// item is found from its own entry alone.
#[derive(Clone, Copy)]
pub struct Entry {
    start: u8,
    len_kind: u8,
}

impl Entry {
    /// The entry of a name at `start` of `len` bytes (below 32) for an item of `kind`.
    const fn new(start: usize, len: usize, kind: Kind) -> Self {
        Self {
            start: start as u8,
            len_kind: len as u8 | (kind as u8) << 5,
        }
    }

    /// Where the name starts among the table's names.
    const fn start(self) -> usize {
        self.start as usize
    }

    /// Where the name ends among the table's names.
    const fn end(self) -> usize {
        self.start() + (self.len_kind & 31) as usize
    }

    /// What the item holds: looked up, where a `match` would branch on every item read.
    const fn kind(self) -> Kind {
        const KINDS: [Kind; 8] = [
            Kind::Float,
            Kind::Int,
            Kind::Byte,
            Kind::Byte,
            Kind::Byte,
            Kind::Byte,
            Kind::Byte,
            Kind::Byte,
        ];
        let [first, ..] = KINDS;
        match KINDS.split_at_checked((self.len_kind >> 5) as usize) {
            Some((_, [kind, ..])) => *kind,
            _ => first,
        }
    }
}

/// A message's items, in the order the document lists them: their names one after another,
/// two bytes an item ([`Entry`]), and what the reader derives from them once, at build time, so that
/// reading a block takes one pointer to all of it. Made by `table!`.
pub struct Table {
    /// The items' names, one after another.
    names: &'static [u8],
    /// The items.
    entries: &'static [Entry],
    /// Which items a document must hold.
    required: Present,
    /// Which names can be in the table. The filter only saves time: a `compact` build
    /// searches the table for every name, and keeps none.
    #[cfg(not(feature = "compact"))]
    filter: NameFilter,
}

impl Table {
    /// The table without items.
    pub const EMPTY: &'static Self = &Self::new("", &[], 0);

    /// The table of the items whose names, one after another, are `names`, described by
    /// `entries` (made by [`entries`]), with the `required` ones (made by [`required`]).
    pub const fn new(names: &'static str, entries: &'static [Entry], required: Present) -> Self {
        let names = names.as_bytes();
        if let [.., last] = entries {
            assert!(
                cfg!(feature = "compact") || names.len() > last.end() + NAME_MAX,
                "the default build pads a table's names past the last by NAME_MAX and one"
            );
        }
        Self {
            names,
            entries,
            required,
            #[cfg(not(feature = "compact"))]
            filter: NameFilter::of(names, entries),
        }
    }

    /// The number of items.
    pub const fn len(&self) -> usize {
        self.entries.len()
    }

    /// The item at `index`, if there is one.
    pub const fn item(&self, index: usize) -> Option<ItemSpec> {
        let Some((_, [entry, ..])) = self.entries.split_at_checked(index) else {
            return None;
        };
        let Some(name) = self.name(*entry) else {
            return None;
        };
        Some(ItemSpec {
            name: ItemName::from_table(name),
            kind: entry.kind(),
            required: self.required >> index & 1 != 0,
        })
    }

    /// The name of `entry`, one of the table's.
    const fn name(&self, entry: Entry) -> Option<&'static [u8]> {
        let Some((name, _)) = self.names.split_at_checked(entry.end()) else {
            return None;
        };
        match name.split_at_checked(entry.start()) {
            Some((_, name)) => Some(name),
            None => None,
        }
    }

    /// Where the item called `name` (compared without regard to ASCII case) is. Names are
    /// unique in a table, so the first found is the only one.
    fn find(&self, name: &[u8]) -> Option<usize> {
        self.entries.iter().position(|&entry| {
            self.name(entry)
                .is_some_and(|candidate| candidate.eq_ignore_ascii_case(name))
        })
    }
}

/// The entries of the items called `names` (at most [`NAME_MAX`] ASCII bytes each, 255 in
/// all, checked when the constant is built) that hold `kinds`.
pub const fn entries<const N: usize>(names: [&str; N], kinds: [Kind; N]) -> [Entry; N] {
    let mut entries = [Entry::new(0, 0, Kind::Int); N];
    let mut end = 0;
    let (mut names, mut kinds, mut slots) =
        (names.as_slice(), kinds.as_slice(), entries.as_mut_slice());
    while let ([name, more_names @ ..], [kind, more_kinds @ ..], [slot, more_slots @ ..]) =
        (names, kinds, slots)
    {
        let name = name.as_bytes();
        assert!(
            name.len() <= NAME_MAX && name.is_ascii(),
            "an item name is at most 19 ASCII bytes"
        );
        *slot = Entry::new(end, name.len(), *kind);
        end += name.len();
        assert!(
            end <= u8::MAX as usize,
            "a table's names take at most 255 bytes"
        );
        (names, kinds, slots) = (more_names, more_kinds, more_slots);
    }
    entries
}

/// The mask of the items that are `required`.
pub const fn required<const N: usize>(required: [bool; N]) -> Present {
    let mut mask = 0;
    let mut rest = required.as_slice();
    while let [more @ .., last] = rest {
        mask = mask << 1 | *last as Present;
        rest = more;
    }
    mask
}

/// A [`Table`] constant: `table!("Name": kind, required; ...)`.
macro_rules! table {
    ($($name:literal: $kind:expr, $required:expr;)*) => {{
        const ENTRIES: &[$crate::proto::message::items::Entry] =
            &$crate::proto::message::items::entries([$($name),*], [$($kind),*]);
        const {
            assert!(
                ENTRIES.len() <= $crate::proto::message::items::MAX_ITEMS,
                "an item table holds at most 32 items"
            )
        };
        // The default build copies a table's name with the bytes after it in one fixed-size
        // piece (`PaddedName`), which the last name needs padding for.
        #[cfg(not(feature = "compact"))]
        const NAMES: &str = concat!($($name,)* "\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0");
        #[cfg(feature = "compact")]
        const NAMES: &str = concat!($($name),*);
        &$crate::proto::message::items::Table::new(
            NAMES,
            ENTRIES,
            $crate::proto::message::items::required([$($required),*]),
        )
    }};
}
pub(crate) use table;

/// A message's items as a whole.
pub trait ItemSet: Sized {
    /// The items, in the order the document lists them.
    const TABLE: &'static Table;

    /// Puts the fields as wire values in [`ItemSet::TABLE`] order into `values` (the rest
    /// untouched), and returns which of them are present.
    fn to_values(&self, values: &mut Values) -> Present;
    /// The fields from wire values in [`ItemSet::TABLE`] order (the rest unused), every
    /// required one present.
    fn from_values(values: &Values, present: Present) -> Self;

    /// [`ItemSet::to_values`] with the table they belong to, for writing the block of any
    /// message with one call.
    fn to_block(&self, values: &mut Values) -> (&'static Table, Present) {
        (Self::TABLE, self.to_values(values))
    }

    /// Reads the items of one request block; unknown items are skipped, a missing required
    /// one is an error naming it.
    fn read_items(items: &mut Items<'_, '_>) -> Result<Self, DecodeError> {
        let block = read_values(items, Self::TABLE, Sender::Client)?;
        Ok(Self::from_values(&block.values, block.present))
    }
}

/// An answer's items, which the default build writes each by code of its own
/// ([`Writing::Straight`]); a `compact` build has no such code. A request's are written
/// through their table in every build: the panel writes them, and there the flash counts
/// more than the time.
#[cfg(not(feature = "compact"))]
pub trait AnswerItems: ItemSet {
    /// Writes the present items, each by code of its own in which its kind and tags are
    /// constants: no table is read and nothing is converted to wire values first. Where the
    /// buffer is too nearly full for an item's line to go in place, that item and the rest
    /// are written through the table ([`write_from`]).
    fn write_items(&self, doc: &mut DocumentWriter<'_>) -> Result<(), WriteError>;
}

/// A quick test that a name is none of a table's: a Bloom filter over the names' length,
/// first and last letter, two bits of 128 per name. An unknown item (a real robot sends
/// several in each status answer) mostly misses one of its bits, and then needs no search
/// through the table. The bits are kept in 32-bit words, which the microcontroller shifts
/// in one instruction.
#[derive(Clone, Copy)]
#[cfg(not(feature = "compact"))]
pub struct NameFilter([u32; 4]);

#[cfg(not(feature = "compact"))]
impl NameFilter {
    /// The bits of every name of `entries`, whose names are `names`.
    const fn of(names: &[u8], entries: &[Entry]) -> Self {
        let mut set: u128 = 0;
        let mut rest = entries;
        while let [entry, tail @ ..] = rest {
            if let Some((name, _)) = names.split_at_checked(entry.end())
                && let Some((_, name)) = name.split_at_checked(entry.start())
            {
                let [a, b] = Self::bits(name);
                set |= 1 << a | 1 << b;
            }
            rest = tail;
        }
        Self([
            set as u32,
            (set >> 32) as u32,
            (set >> 64) as u32,
            (set >> 96) as u32,
        ])
    }

    /// The two bit numbers (below 128) of `name`; names equal but for ASCII case share them.
    const fn bits(name: &[u8]) -> [u32; 2] {
        let (first, last) = match name {
            [first, .., last] => (*first, *last),
            [only] => (*only, *only),
            [] => (0, 0),
        };
        // Fibonacci hashing: the top bits of the product mix every input bit.
        let key = (name.len() as u32) << 16 | ((first | 0x20) as u32) << 8 | (last | 0x20) as u32;
        let hash = key.wrapping_mul(0x9e37_79b9);
        [hash >> 25, (hash >> 18) & 127]
    }

    /// Whether `name` (compared without regard to ASCII case) may be one of the table's.
    fn may_hold(self, name: &[u8]) -> bool {
        Self::bits(name).iter().all(|&bit| {
            let word = self.0.get((bit / 32) as usize).copied().unwrap_or(0);
            word & 1 << (bit % 32) != 0
        })
    }
}

/// How a message's blocks of items are written. Both ways write the same bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Writing {
    /// Each item by code of its own ([`AnswerItems::write_items`]), its kind and tags
    /// constants there: the fastest, about 130 bytes of flash an item on the
    /// microcontroller. Not in a `compact` build.
    #[cfg(not(feature = "compact"))]
    Straight,
    /// Every item through its table and one loop ([`write_values`]) that serves every
    /// message: the smallest.
    Table,
}

impl Writing {
    /// This build's way: straight, or through the tables in a `compact` build.
    #[cfg(not(feature = "compact"))]
    pub(crate) const BUILD: Self = Self::Straight;
    /// This build's way: straight, or through the tables in a `compact` build.
    #[cfg(feature = "compact")]
    pub(crate) const BUILD: Self = Self::Table;
}

/// Writes the `present` values as items.
// One copy serves every message; inlined into each it would cost a copy per message.
#[inline(never)]
pub(crate) fn write_values(
    doc: &mut DocumentWriter<'_>,
    table: &Table,
    values: &[u32],
    present: Present,
    sender: Sender,
) -> Result<(), WriteError> {
    for (index, (&entry, &bits)) in table.entries.iter().zip(values).enumerate() {
        if present >> index & 1 == 0 {
            continue;
        }
        let number = number(entry.kind(), bits, sender);
        // The default build copies the name from its table in one fixed-size piece.
        #[cfg(not(feature = "compact"))]
        if let Some(padded) = table
            .names
            .get(entry.start()..)
            .and_then(|text| PaddedName::new(text, entry.end() - entry.start()))
        {
            doc.tagged_item(padded, padded.name(), number)?;
            continue;
        }
        let name = ItemName::from_table(table.name(entry).unwrap_or_default());
        doc.number_item(name, number)?;
    }
    Ok(())
}

/// Writes an answer's present items from position `from` of its table on, through the
/// table: where the buffer is too nearly full for an item's line to go in place, that line
/// and the rest are appended piece by piece ([`AnswerItems::write_items`]).
#[cfg(not(feature = "compact"))]
#[inline(never)]
pub(crate) fn write_from<S: ItemSet>(
    doc: &mut DocumentWriter<'_>,
    set: &S,
    from: u32,
) -> Result<(), WriteError> {
    let mut values = [0; MAX_ITEMS];
    let (table, present) = set.to_block(&mut values);
    let from_on = Present::MAX.checked_shl(from).unwrap_or(0);
    write_values(doc, table, &values, present & from_on, Sender::Robot)
}

/// A wire value of `kind` as the writer takes it from `sender`.
#[inline(always)]
pub(crate) fn number(kind: Kind, bits: u32, sender: Sender) -> Number {
    match (kind, sender) {
        (Kind::Float, Sender::Client) => Number::Float(f32::from_bits(bits)),
        (Kind::Float, Sender::Robot) => Number::Reading(f32::from_bits(bits)),
        (Kind::Int | Kind::Byte, _) => Number::Int(bits as i32),
    }
}

/// The items of one block, as [`read_values`] found them.
pub(crate) struct Block {
    /// The wire values, in table order.
    pub values: Values,
    /// Which items were read.
    pub present: Present,
    /// Which optional items of an answer were there but could not be read.
    pub unreadable: Present,
}

/// Reads a block's items, by position in `table`, and which were found; unknown items are
/// skipped, and a missing required one is an error naming it. Floats are read as `sender`
/// may write them. One copy serves every table, so the values have room for the largest.
#[inline(never)]
pub(crate) fn read_values(
    items: &mut Items<'_, '_>,
    table: &Table,
    sender: Sender,
) -> Result<Block, DecodeError> {
    let (tokens, done) = items.parts();
    read_block(tokens, done, table, sender)
}

/// [`read_values`] from the block's tokenizer and whether it has ended (see [`Items::parts`]).
#[inline(never)]
fn read_block(
    tokens: &mut Tokenizer<'_>,
    done: &mut bool,
    table: &Table,
    sender: Sender,
) -> Result<Block, DecodeError> {
    let items = &mut Items::new(tokens, *done);
    let mut values = [0; MAX_ITEMS];
    // The item after the one found last: documents list items in the table's order.
    #[cfg(not(feature = "compact"))]
    let mut next = 0;
    let mut present: Present = 0;
    let mut unreadable: Present = 0;
    // An item there twice is as its last occurrence reads: present or unreadable, not both.
    let record = |present: &mut Present, unreadable: &mut Present, index: usize, reading: u32| {
        let bit = 1 << index;
        *present = *present & !bit | (reading & PRESENT) << index;
        *unreadable = *unreadable & !bit | (reading >> 1) << index;
    };
    #[cfg_attr(
        feature = "compact",
        expect(
            clippy::while_let_loop,
            reason = "the same loop as the default build's, which reads a run of lines first"
        )
    )]
    loop {
        // The usual layout: the items the table lists next, each written plainly on a line
        // of its own with a number that reads as it is, in one loop that keeps its state in
        // registers. The first line that is anything else ends the run, and is read below.
        #[cfg(not(feature = "compact"))]
        if let (tokens, false) = items.parts() {
            tokens.plain_run(|tag| {
                let (bits, len) = plain_line(tag, table, next)?;
                *values.get_mut(next)? = bits;
                record(&mut present, &mut unreadable, next, PRESENT);
                next += 1;
                Some(len)
            });
            // An item no table has (a robot_server's extra reading), written plainly: passed
            // over as the general path below passes over it, and the run goes on after it.
            // Outside the run's loop: a call in that loop cost it registers (measured).
            if tokens.take_element(|tag| unknown_line(tag, table)) {
                continue;
            }
        }
        let Some(item) = items.next() else {
            break;
        };
        let item = item?;
        #[cfg(not(feature = "compact"))]
        if !table.filter.may_hold(item.name) {
            continue;
        }
        let index = table.find(item.name);
        let known = index.and_then(|i| Some((i, table.item(i)?, values.get_mut(i)?)));
        if let Some((index, spec, value)) = known {
            let reading = read_item(item.text, &spec, sender, value)?;
            record(&mut present, &mut unreadable, index, reading);
            #[cfg(not(feature = "compact"))]
            {
                next = index + 1;
            }
        }
    }
    // Every item not read takes its kind's absent value, as if the robot had left it out.
    let mut absent_items = !present;
    while let Some((value, entry)) = values
        .get_mut(absent_items.trailing_zeros() as usize)
        .zip(table.entries.get(absent_items.trailing_zeros() as usize))
    {
        *value = absent(entry.kind());
        absent_items &= absent_items - 1;
    }
    *done = items.is_done();
    match table.required & !present {
        0 => Ok(Block {
            values,
            present,
            unreadable,
        }),
        missing => {
            let first = table.item(missing.trailing_zeros() as usize);
            Err(DecodeError::MissingItem(
                first.map_or(ItemName::new(""), |item| item.name),
            ))
        }
    }
}

/// The length of the element at `tag` (what follows a `<`) if it is an item no name of the
/// table can be (a robot_server's extra reading), written plainly: passed over as the
/// general path passes over it.
#[cfg(not(feature = "compact"))]
fn unknown_line(tag: &[u8], table: &Table) -> Option<usize> {
    let (name, _, len) = plain_element(tag)?;
    (!table.filter.may_hold(name)).then_some(len)
}

/// The wire value of the table's item `index` and the length of its element, if `tag` (what
/// follows a `<`) is that item written plainly with a number as its text: an integer of up
/// to seven digits, or a float's usual text. `None` for anything else, which the general
/// path reads (or refuses) as it would have without this one.
#[cfg(not(feature = "compact"))]
#[inline(always)]
fn plain_line(tag: &[u8], table: &Table, index: usize) -> Option<(u32, usize)> {
    let entry = *table.entries.get(index)?;
    // The default build pads the names, so the name's window of 16 bytes is always there.
    let padded = table.names.get(entry.start()..)?;
    let name = padded.get(..entry.end() - entry.start())?;
    let head = padded.first_chunk()?;
    let kind = entry.kind();
    plain_item(tag, name, Some(head), |content| match kind {
        // A float's text is found first, a word at a time, and parsed after: the next line
        // waits only for where this one ends.
        Kind::Float => {
            let (text, len) = plain_text(content)?;
            Some((number::parse_f32(text).ok()?.to_bits(), len))
        }
        // An integer's text is short: it is read in the pass that finds its end.
        Kind::Int => number::short_int_prefix(content),
        Kind::Byte => number::short_int_prefix(content).filter(|&(value, _)| value <= 0xff),
    })
}

/// Reads one item's text into `value`; returns whether the item is present (bit 0) or was
/// there but could not be read (bit 1). An answer's optional item that cannot be read (a
/// float with a decimal comma, as a C library under some locales prints it; an empty
/// element; an integer beyond 32 bits) is not present, as if the robot had left it out: one
/// unreadable reading must not cost the panel the whole answer, and with a status the
/// e-stop's confirmation. A required item, and any item of a request (which the robot acts
/// on), must be read.
#[inline(always)]
fn read_item(
    text: Option<&[u8]>,
    spec: &ItemSpec,
    sender: Sender,
    value: &mut u32,
) -> Result<u32, DecodeError> {
    match parse_text(text, spec, sender) {
        Ok(bits) => {
            *value = bits;
            Ok(PRESENT)
        }
        Err(_) if sender == Sender::Robot && !spec.required => Ok(UNREADABLE),
        Err(error) => Err(error),
    }
}

/// The wire value of an absent item of `kind`: [`ABSENT_FLOAT`] for a float, else 0.
fn absent(kind: Kind) -> u32 {
    match kind {
        Kind::Float => ABSENT_FLOAT,
        Kind::Int | Kind::Byte => 0,
    }
}

/// [`read_item`]'s answer for an item read.
const PRESENT: u32 = 1;
/// [`read_item`]'s answer for an item there but not read.
const UNREADABLE: u32 = 2;

/// Parses one item's text (`None`: it holds elements) as its spec says and its `sender` may
/// write it, naming the item on failure.
fn parse_text(text: Option<&[u8]>, spec: &ItemSpec, sender: Sender) -> Result<u32, DecodeError> {
    let text = text.ok_or(DecodeError::ItemNotText(spec.name))?;
    match spec.kind {
        Kind::Float => match number::parse_f32(text) {
            Ok(value) => Ok(value.to_bits()),
            Err(error) => not_a_number(text, spec, sender, error),
        },
        Kind::Int | Kind::Byte => {
            integer(text, spec.kind).or_else(|error| whole_float(text, spec, sender, error))
        }
    }
}

/// An integer item's text as the bits of its value: an `i32`, or a `u8` for [`Kind::Byte`].
#[inline(always)]
fn integer(text: &[u8], kind: Kind) -> Result<u32, number::NumberError> {
    let value = number::parse_int::<i32>(text)?;
    match kind {
        // An `i32` beyond a byte is beyond it as an `i64` too: the same error.
        Kind::Byte => u8::try_from(value)
            .map(u32::from)
            .map_err(|_| number::NumberError::OutOfRange),
        _ => Ok(value as u32),
    }
}

/// An integer item whose text is not an integer: the integer if the robot wrote it as a
/// float with nothing but zeros after the point (`87.0`, `87.000000`, as C's `%f` and
/// Python's `str` print a whole number held in a float), else `error` naming the item.
/// Nothing is rounded: `86.5` is refused. A request must write integers as integers.
/// Out of line, as [`not_a_number`] is, and cold, which keeps the default build's 1002
/// decode 22 instructions shorter.
#[cold]
#[inline(never)]
fn whole_float(
    text: &[u8],
    spec: &ItemSpec,
    sender: Sender,
    error: number::NumberError,
) -> Result<u32, DecodeError> {
    let bad = |error| DecodeError::BadItem {
        item: spec.name,
        error,
    };
    let (Sender::Robot, Some(point)) = (sender, text.iter().position(|&c| c == b'.')) else {
        return Err(bad(error));
    };
    // The point and the zeros after it.
    let (whole, fraction) = text.split_at(point);
    if whole.is_empty() || fraction.iter().skip(1).any(|&c| c != b'0') {
        return Err(bad(error));
    }
    integer(whole, spec.kind).map_err(bad)
}

/// A float item whose text is not a number: NaN or an infinity if the robot wrote C's word
/// for one, else `error` naming the item. Out of line: only such a text gets here, and the
/// number's path stays as it was (the flash is also 4 bytes smaller for the panel, 48 for
/// both directions, than with the words read inline). Not marked cold, which took 24 bytes
/// more of a `compact` build's flash and saved no instruction (measured).
#[inline(never)]
fn not_a_number(
    text: &[u8],
    spec: &ItemSpec,
    sender: Sender,
    error: number::NumberError,
) -> Result<u32, DecodeError> {
    match (sender, number::parse_non_finite(text)) {
        (Sender::Robot, Some(value)) => Ok(value.to_bits()),
        _ => Err(DecodeError::BadItem {
            item: spec.name,
            error,
        }),
    }
}

/// Defines a struct whose fields are items, and its [`ItemSet`] implementation.
///
/// Each field names its element, and `optional` if a document may leave it out (items added
/// in later protocol versions), which reads as [`ItemValue::from_wire`] says; other fields are
/// required.
macro_rules! item_set {
    // An answer's items: an item set that is also an `AnswerItems`.
    (
        answer
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[$fmeta:meta])*
                pub $field:ident: $ty:ty = $wire:literal $(, $optional:ident)?;
            )*
        }
    ) => {
        item_set! {
            $(#[$meta])*
            pub struct $name {
                $(
                    $(#[$fmeta])*
                    pub $field: $ty = $wire $(, $optional)?;
                )*
            }
        }

        #[cfg(not(feature = "compact"))]
        impl $crate::proto::message::items::AnswerItems for $name {
            #[inline]
            fn write_items(
                &self,
                doc: &mut $crate::proto::xml::writer::DocumentWriter<'_>,
            ) -> Result<(), $crate::proto::xml::writer::WriteError> {
                use $crate::proto::message::items::ItemValue;
                // Each field's position in the table, by name.
                #[allow(non_camel_case_types)]
                enum Position { $($field),* }
                $(
                    if let Some(bits) = self.$field.to_raw() {
                        const NAME: $crate::proto::xml::writer::ItemName =
                            $crate::proto::xml::writer::ItemName::new($wire);
                        // Four spaces, `<` and `>`; `</`, `>` and the newline.
                        const TAGS: &$crate::proto::xml::writer::ItemTags<
                            { $wire.len() + 6 },
                            { $wire.len() + 4 },
                        > = &$crate::proto::xml::writer::ItemTags::new($wire);
                        let in_place = doc.item_in_place(
                            TAGS,
                            NAME,
                            $crate::proto::message::items::number(
                                <$ty as ItemValue>::KIND,
                                bits,
                                $crate::proto::message::items::Sender::Robot,
                            ),
                        )?;
                        if !in_place {
                            return $crate::proto::message::items::write_from(
                                doc,
                                self,
                                Position::$field as u32,
                            );
                        }
                    }
                )*
                Ok(())
            }
        }
    };
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[$fmeta:meta])*
                pub $field:ident: $ty:ty = $wire:literal $(, $optional:ident)?;
            )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        #[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
        pub struct $name {
            $( $(#[$fmeta])* pub $field: $ty, )*
        }

        impl $crate::proto::message::items::ItemSet for $name {
            const TABLE: &'static $crate::proto::message::items::Table =
                $crate::proto::message::items::table!($(
                    $wire: <$ty as $crate::proto::message::items::ItemValue>::KIND,
                        item_set!(@required $($optional)?);
                )*);

            fn to_values(
                &self,
                values: &mut $crate::proto::message::items::Values,
            ) -> $crate::proto::message::items::Present {
                use $crate::proto::message::items::ItemValue;
                // Each field's position in the table, by name.
                #[allow(non_camel_case_types)]
                enum Position { $($field),* }
                let mut present = 0;
                let [$($field,)* ..] = values;
                $(
                    let raw = self.$field.to_raw();
                    present |= u32::from(raw.is_some()) << Position::$field as u32;
                    *$field = raw.unwrap_or(0);
                )*
                present
            }

            fn from_values(
                values: &$crate::proto::message::items::Values,
                present: $crate::proto::message::items::Present,
            ) -> Self {
                use $crate::proto::message::items::ItemValue;
                // Each field's position in the table, by name.
                #[allow(non_camel_case_types)]
                enum Position { $($field),* }
                let [$($field,)* ..] = *values;
                Self {
                    $( $field: ItemValue::from_wire(
                        $field,
                        present >> Position::$field as u32 & 1 != 0,
                    ), )*
                }
            }
        }
    };
    (@required) => { true };
    (@required optional) => { false };
}
pub(crate) use item_set;

/// Coded enums are items through their raw integer, so an unknown code never fails a
/// message.
impl<T: Code> ItemValue for T {
    const KIND: Kind = Kind::Int;

    fn to_raw(&self) -> Raw {
        Some(Code::raw(*self) as u32)
    }

    fn from_raw_bits(bits: u32) -> Self {
        T::from_raw(bits as i32)
    }
}
