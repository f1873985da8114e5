//! How typed fields become `<Items>` children and back.
//!
//! Every item is an integer or a float on the wire, so a message's items are described by
//! a table of [`ItemSpec`]s and carried through one array of [`Raw`] values: one reader
//! and one writer serve every message, and each message adds only its table and the conversion
//! between its fields and that array. The `item_set!` macro writes both from a struct
//! definition that names each field's element, so the list of items is written down once.
//! Keeping per-message code this small is what lets the whole codec fit a few KiB of flash.

use super::DecodeError;
use crate::proto::codes::Code;
use crate::proto::xml::Items;
use crate::proto::xml::number;
use crate::proto::xml::writer::{DocumentWriter, Number, WriteError};

/// What an item holds on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A float.
    Float,
    /// An integer that fits `i32`.
    Int,
    /// An integer in `0..=255` (the indicator light's colour and brightness).
    Byte,
}

/// One item of a message: its element name, what it holds, and whether it may be absent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ItemSpec {
    /// The element name as the document spells it. Reading matches it without regard to
    /// ASCII case, which also accepts the vendor client's `MapId` for `MapID`.
    pub name: &'static str,
    /// Integer or float.
    pub kind: Kind,
    /// Whether a document without the item is an error.
    pub required: bool,
}

/// One item's value as received: the bits of an `i32` or an `f32`, or `None` if absent.
pub type Raw = Option<u32>;

/// A field type that can be an item.
pub trait ItemValue: Sized {
    /// What the item holds on the wire.
    const KIND: Kind;
    /// The field as the bits of its wire value; `None` to leave the item out.
    fn to_raw(&self) -> Raw;
    /// The field from the bits of a wire value of its own kind.
    fn from_raw_bits(bits: u32) -> Self;
}

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
}

/// A field from its item as received, or `default` when the item was absent.
pub fn field<T: ItemValue>(raw: Raw, default: impl FnOnce() -> T) -> T {
    raw.map_or_else(default, T::from_raw_bits)
}

/// A message's items as a whole.
pub trait ItemSet: Sized {
    /// The items, in the order the document lists them.
    const SPEC: &'static [ItemSpec];
    /// One wire value per item, in [`ItemSet::SPEC`] order.
    type Values: AsRef<[Raw]> + AsMut<[Raw]> + Default;

    /// The fields as wire values.
    fn to_values(&self) -> Self::Values;
    /// The fields from wire values, every required one present.
    fn from_values(values: Self::Values) -> Self;

    /// Writes every item.
    fn write_items(&self, doc: &mut DocumentWriter<'_>) -> Result<(), WriteError> {
        write_values(doc, Self::SPEC, self.to_values().as_ref())
    }

    /// Which names can be in [`ItemSet::SPEC`], for passing over unknown items quickly.
    const NAMES: NameFilter = NameFilter::of(Self::SPEC);

    /// Reads the items of one block; unknown items are skipped, a missing required one is
    /// an error naming it.
    fn read_items(items: &mut Items<'_>) -> Result<Self, DecodeError> {
        let mut values = Self::Values::default();
        read_values(items, Self::SPEC, Self::NAMES, values.as_mut())?;
        Ok(Self::from_values(values))
    }
}

/// A quick test that a name is none of a table's: a Bloom filter over the names' length,
/// first and last letter, two bits of 128 per name. An unknown item (a real robot sends
/// several in each status answer) mostly misses one of its bits, and then needs no search
/// through the table. The bits are kept in 32-bit words, which the microcontroller shifts
/// in one instruction.
#[derive(Clone, Copy)]
pub struct NameFilter([u32; 4]);

impl NameFilter {
    /// The bits of every name in `spec`.
    pub const fn of(spec: &[ItemSpec]) -> Self {
        let mut set: u128 = 0;
        let mut rest = spec;
        while let [item, tail @ ..] = rest {
            let [a, b] = Self::bits(item.name.as_bytes());
            set |= 1 << a | 1 << b;
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

/// Writes the present values as items.
// One copy serves every message; inlined into each it would cost a copy per message.
#[inline(never)]
fn write_values(
    doc: &mut DocumentWriter<'_>,
    spec: &[ItemSpec],
    values: &[Raw],
) -> Result<(), WriteError> {
    for (item, value) in spec.iter().zip(values) {
        let Some(bits) = *value else {
            continue;
        };
        let number = match item.kind {
            Kind::Float => Number::Float(f32::from_bits(bits)),
            Kind::Int | Kind::Byte => Number::Int(bits as i32),
        };
        doc.number_item(item.name, number)?;
    }
    Ok(())
}

/// Writes one item, as a table of one: the item line is written in one place only.
pub(crate) fn write_item(
    doc: &mut DocumentWriter<'_>,
    name: &'static str,
    kind: Kind,
    bits: u32,
) -> Result<(), WriteError> {
    let spec = ItemSpec {
        name,
        kind,
        required: true,
    };
    write_values(doc, &[spec], &[Some(bits)])
}

/// Reads a block's items into `values`, by position in `spec`; unknown items are skipped.
#[inline(never)]
fn read_values(
    items: &mut Items<'_>,
    spec: &[ItemSpec],
    names: NameFilter,
    values: &mut [Raw],
) -> Result<(), DecodeError> {
    // Documents list items in the table's order, so the search starts after the item found
    // last: a known item is then found at the first comparison. Names are unique in a
    // table, so where the search starts cannot change what it finds.
    let mut next = 0;
    loop {
        // The usual layout: the item the table lists next, written plainly. An integer's
        // text is short, so it is read in the pass that finds its end; a float's text is
        // found first (a word at a time) and parsed after, which keeps the work that the
        // next line has to wait for short. Another item written plainly is read by the same
        // pass, its name scanned rather than compared.
        let item = if let Some((spec, value)) = spec.get(next).zip(values.get_mut(next)) {
            let integer = match spec.kind {
                Kind::Float => None,
                Kind::Int => items.next_number(spec.name, number::parse_int_prefix::<i32>),
                Kind::Byte => items
                    .next_number(spec.name, number::parse_int_prefix::<u8>)
                    .map(i32::from),
            };
            if let Some(integer) = integer {
                *value = Some(integer as u32);
                next += 1;
                continue;
            }
            match items.next_plain(spec.name) {
                Some((item, true)) => {
                    *value = Some(parse_text(item.text, spec)?);
                    next += 1;
                    continue;
                }
                Some((other, false)) => Some(Ok(other)),
                None => items.next(),
            }
        } else {
            items.next()
        };
        let Some(item) = item else {
            break;
        };
        let item = item?;
        if !names.may_hold(item.name) {
            continue;
        }
        let matches = |s: &ItemSpec| item.name.eq_ignore_ascii_case(s.name.as_bytes());
        let (earlier, later) = spec.split_at_checked(next).unwrap_or_default();
        let index = match later.iter().position(matches) {
            Some(i) => Some(next + i),
            None => earlier.iter().position(matches),
        };
        let known = index.and_then(|i| Some((i, spec.get(i)?, values.get_mut(i)?)));
        if let Some((index, spec, value)) = known {
            *value = Some(parse_text(item.text, spec)?);
            next = index + 1;
        }
    }
    match spec
        .iter()
        .zip(values)
        .find(|(s, v)| s.required && v.is_none())
    {
        Some((missing, _)) => Err(DecodeError::MissingItem(missing.name)),
        None => Ok(()),
    }
}

/// Parses one item's text (`None`: it holds elements) as its spec says, naming the item on
/// failure.
pub(crate) fn parse_text(text: Option<&[u8]>, spec: &ItemSpec) -> Result<u32, DecodeError> {
    let bad = |error| DecodeError::BadItem {
        item: spec.name,
        error,
    };
    let text = text.ok_or(DecodeError::ItemNotText(spec.name))?;
    match spec.kind {
        Kind::Float => number::parse_f32(text).map(f32::to_bits).map_err(bad),
        Kind::Int => number::parse_int::<i32>(text)
            .map(|v| v as u32)
            .map_err(bad),
        Kind::Byte => number::parse_int::<u8>(text).map(u32::from).map_err(bad),
    }
}

/// Defines a struct whose fields are items, and its [`ItemSet`] implementation.
///
/// Each field names its element and optionally a default used when the element is absent
/// (items added in later protocol versions); fields without a default are required.
macro_rules! item_set {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[$fmeta:meta])*
                pub $field:ident: $ty:ty = $wire:literal $(, default $default:expr)?;
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
            const SPEC: &'static [$crate::proto::message::items::ItemSpec] = &[$(
                $crate::proto::message::items::ItemSpec {
                    name: $wire,
                    kind: <$ty as $crate::proto::message::items::ItemValue>::KIND,
                    required: item_set!(@required $($default)?),
                },
            )*];
            type Values = [$crate::proto::message::items::Raw; [$($wire),*].len()];

            fn to_values(&self) -> Self::Values {
                use $crate::proto::message::items::ItemValue;
                [$( self.$field.to_raw() ),*]
            }

            fn from_values(values: Self::Values) -> Self {
                let [$($field),*] = values;
                Self {
                    $( $field: item_set!(@field $field $($default)?), )*
                }
            }
        }
    };
    (@required) => { true };
    (@required $default:expr) => { false };
    // read_values has checked that required items are present: no branch for absence.
    (@field $raw:ident) => {
        $crate::proto::message::items::ItemValue::from_raw_bits($raw.unwrap_or(0))
    };
    (@field $raw:ident $default:expr) => {
        $crate::proto::message::items::field($raw, || $default)
    };
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
