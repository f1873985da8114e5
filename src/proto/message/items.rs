//! How typed fields become `<Items>` children and back.
//!
//! [`ItemValue`] says how one field is written and parsed; the `item_set!` macro turns a
//! struct definition that names each field's element into the struct plus its
//! [`ItemSet`] implementation, so the list of items is written down once per message.

use super::DecodeError;
use crate::proto::xml::number::{self, NumberError};
use crate::proto::xml::writer::{DocumentWriter, WriteError};
use crate::proto::xml::{Item, Items};

/// A field type that can be an item: written as text, parsed from text.
pub trait ItemValue: Sized {
    /// Parses the item's trimmed text.
    fn parse(text: &[u8]) -> Result<Self, NumberError>;
    /// Writes `<name>value</name>` as an item line.
    fn write(&self, name: &'static str, doc: &mut DocumentWriter<'_>) -> Result<(), WriteError>;
}

impl ItemValue for f32 {
    fn parse(text: &[u8]) -> Result<Self, NumberError> {
        number::parse_f32(text)
    }

    fn write(&self, name: &'static str, doc: &mut DocumentWriter<'_>) -> Result<(), WriteError> {
        doc.float_item(name, *self)
    }
}

/// Integer fields.
macro_rules! int_item_value {
    ($($ty:ty),*) => {$(
        impl ItemValue for $ty {
            fn parse(text: &[u8]) -> Result<Self, NumberError> {
                number::parse_int(text)
            }

            fn write(&self, name: &'static str, doc: &mut DocumentWriter<'_>) -> Result<(), WriteError> {
                doc.int_item(name, i64::from(*self))
            }
        }
    )*};
}
int_item_value!(i32, u8);

/// An optional item: absent from older robots, written only when present.
impl<T: ItemValue> ItemValue for Option<T> {
    fn parse(text: &[u8]) -> Result<Self, NumberError> {
        T::parse(text).map(Some)
    }

    fn write(&self, name: &'static str, doc: &mut DocumentWriter<'_>) -> Result<(), WriteError> {
        match self {
            Some(value) => value.write(name, doc),
            None => Ok(()),
        }
    }
}

/// A message's items as a whole.
pub trait ItemSet: Sized {
    /// Writes every item.
    fn write_items(&self, doc: &mut DocumentWriter<'_>) -> Result<(), WriteError>;
    /// Reads the items of one block; unknown items are skipped, missing required ones are
    /// an error naming them.
    fn read_items(items: &mut Items<'_>) -> Result<Self, DecodeError>;
}

/// Parses one item's text into `T`, naming the item on failure.
pub(crate) fn parse_item<T: ItemValue>(
    item: &Item<'_>,
    name: &'static str,
) -> Result<T, DecodeError> {
    let text = item.text.ok_or(DecodeError::ItemNotText(name))?;
    T::parse(text).map_err(|error| DecodeError::BadItem { item: name, error })
}

/// Defines a struct whose fields are items, and its [`ItemSet`] implementation.
///
/// Each field names its element, any other spellings accepted when reading, and
/// optionally a default used when the element is absent (items added in later protocol
/// versions); fields without a default are required.
macro_rules! item_set {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[$fmeta:meta])*
                pub $field:ident: $ty:ty = $wire:literal $(| $alias:literal)* $(, default $default:expr)?;
            )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct $name {
            $( $(#[$fmeta])* pub $field: $ty, )*
        }

        impl $crate::proto::message::items::ItemSet for $name {
            fn write_items(
                &self,
                doc: &mut $crate::proto::xml::writer::DocumentWriter<'_>,
            ) -> Result<(), $crate::proto::xml::writer::WriteError> {
                use $crate::proto::message::items::ItemValue;
                $( self.$field.write($wire, doc)?; )*
                Ok(())
            }

            fn read_items(
                items: &mut $crate::proto::xml::Items<'_>,
            ) -> Result<Self, $crate::proto::message::DecodeError> {
                $( let mut $field: Option<$ty> = None; )*
                for item in items {
                    let item = item?;
                    // Matching on text lets the compiler dispatch on length first instead of
                    // comparing the name with every item in turn.
                    match core::str::from_utf8(item.name).unwrap_or_default() {
                        $( $wire $(| $alias)* => {
                            $field = Some($crate::proto::message::items::parse_item(&item, $wire)?);
                        } )*
                        _ => {}
                    }
                }
                Ok(Self {
                    $( $field: match $field {
                        Some(value) => value,
                        None => item_set!(@missing $wire $(, $default)?),
                    }, )*
                })
            }
        }
    };
    (@missing $wire:literal) => {
        return Err($crate::proto::message::DecodeError::MissingItem($wire))
    };
    (@missing $wire:literal, $default:expr) => {
        $default
    };
}
pub(crate) use item_set;

/// Coded enums are items through their raw integer, so an unknown code never fails a
/// message.
macro_rules! coded_item_value {
    ($($ty:ty),* $(,)?) => {$(
        impl ItemValue for $ty {
            fn parse(text: &[u8]) -> Result<Self, NumberError> {
                number::parse_int::<i32>(text).map(<$ty>::from_raw)
            }

            fn write(&self, name: &'static str, doc: &mut DocumentWriter<'_>) -> Result<(), WriteError> {
                doc.int_item(name, i64::from(self.raw()))
            }
        }
    )*};
}

use crate::proto::codes::*;
coded_item_value!(
    MotionState,
    GaitState,
    NavGait,
    MotionGait,
    PointInfo,
    NavSpeed,
    Manner,
    ObsMode,
    NavMode,
    Terrain,
    Posture,
    Location,
    MotorState,
    ChargeState,
    ControlMode,
    OnDockState,
    NavOutcome,
    ErrorStatus,
    NavTaskStatus,
    LightEffect,
    RequestErrorCode,
    CommandResult,
    LocalizationResult,
    ObsState,
    ProtectedState,
);
