//! `serde` support (feature `serde`): the parts the derives cannot express with attributes
//! alone. No allocator is needed: nothing here buffers, flattens or tags by content.
//!
//! The serialized forms, which x30ctl's `--json` prints:
//!
//! - A code (every enum of [`codes`](super::codes)) is an object with its number, the
//!   core's variant name and the document's meaning:
//!   `{"code":41730,"name":"BatteryTooLow","description":"battery too low"}`, `"Unknown"` and
//!   `"unknown code"` for a number this protocol version does not define. It deserializes
//!   from such an object, reading only `code`.
//! - A [`Timestamp`] is its text, `"YYYY-MM-DD HH:MM:SS"`, both ways.
//! - A message's items are an object with one field per item in snake_case; requests and
//!   responses serialize as their items alone (the Type and Command are what
//!   `message_type()` and `command()` return), a request without items as `null`.
//! - A Type 2 request's items are `motion_command` (the code) and `value`: the speed or
//!   placeholder as a float, or for Command 20 the gait as a code. A Type 2 answer's are
//!   `motion_command`, `value` and `error_code`.

use core::fmt;

use serde::de::{self, Deserializer, Visitor};
use serde::ser::{Error as _, SerializeStruct, Serializer};
use serde::{Deserialize, Serialize};

use super::codes::{Code, MotionCommandCode, MotionGait};
use super::message::{MotionAck, MotionCommand, MotionValue};
use super::time::{TIME_TEXT_LEN, Timestamp};

/// The serialized form of a code.
#[derive(Serialize)]
pub(crate) struct CodeOut {
    code: i32,
    name: &'static str,
    description: &'static str,
}

impl<T: Code> From<T> for CodeOut {
    fn from(value: T) -> Self {
        Self {
            code: value.raw(),
            name: value.name(),
            description: value.description(),
        }
    }
}

/// What a code is read from: its number; `name` and `description` are ignored.
#[derive(Deserialize)]
struct CodeIn {
    code: i32,
}

/// Reads a code from its serialized object.
pub(crate) fn deserialize_code<'de, T: Code, D: Deserializer<'de>>(
    deserializer: D,
) -> Result<T, D::Error> {
    CodeIn::deserialize(deserializer).map(|c| T::from_raw(c.code))
}

impl Serialize for Timestamp {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut text = [0u8; TIME_TEXT_LEN];
        self.encode(&mut text);
        // `encode` writes only ASCII digits and separators.
        serializer.serialize_str(core::str::from_utf8(&text).map_err(S::Error::custom)?)
    }
}

impl<'de> Deserialize<'de> for Timestamp {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct TimeText;

        impl Visitor<'_> for TimeText {
            type Value = Timestamp;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a time as YYYY-MM-DD HH:MM:SS")
            }

            fn visit_str<E: de::Error>(self, text: &str) -> Result<Timestamp, E> {
                Timestamp::decode(text.as_bytes())
                    .map_err(|_| E::invalid_value(de::Unexpected::Str(text), &self))
            }
        }

        deserializer.deserialize_str(TimeText)
    }
}

/// The serialized form of a Type 2 request's items.
#[derive(Serialize)]
pub(crate) struct MotionCommandItems {
    motion_command: MotionCommandCode,
    value: MotionValueItem,
}

/// A Type 2 `Value`: a float, or a gait for Command 20.
#[derive(Serialize)]
#[serde(untagged)]
enum MotionValueItem {
    Float(f32),
    Gait(MotionGait),
}

impl From<MotionCommand> for MotionCommandItems {
    fn from(command: MotionCommand) -> Self {
        Self {
            motion_command: command.code(),
            value: match command.value() {
                MotionValue::Float(v) => MotionValueItem::Float(v),
                MotionValue::Int(v) => MotionValueItem::Gait(MotionGait::from_raw(v)),
            },
        }
    }
}

/// A Type 2 answer's items: the command it answers, then the [`MotionAck`]'s items.
pub(crate) fn motion_answer<S: Serializer>(
    code: &MotionCommandCode,
    ack: &MotionAck,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    let mut items = serializer.serialize_struct("MotionAnswer", 3)?;
    items.serialize_field("motion_command", code)?;
    items.serialize_field("value", &ack.value)?;
    items.serialize_field("error_code", &ack.result)?;
    items.end()
}
