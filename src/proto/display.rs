//! Human-readable messages for every error of the codec, and `core::error::Error`, so host
//! programs can print them and pass them on with `?`.

use core::fmt::{self, Display, Formatter};

use super::frame::{EncodeError, FrameError, HeaderError};
use super::message::{DecodeError, ValidationError};
use super::time::BadTimestamp;
use super::xml::StructureError;
use super::xml::number::NumberError;
use super::xml::reader::{XmlError, XmlErrorKind};
use super::xml::writer::WriteError;

impl Display for HeaderError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::BadSync => "frame header does not start with EB 90 EB 90",
            Self::BadReserved => "frame header's reserved bytes are not zero",
        })
    }
}

impl Display for EncodeError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "frame does not fit the output buffer",
            Self::AsduTooLong => "body longer than 65535 bytes",
        })
    }
}

impl Display for FrameError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Self::Garbage { skipped } => {
                write!(f, "{skipped} bytes without a frame header skipped")
            }
            Self::BadReserved { message_id } => {
                write!(
                    f,
                    "message {message_id}: header's reserved bytes are not zero"
                )
            }
            Self::TooLong {
                message_id,
                asdu_len,
            } => write!(
                f,
                "message {message_id}: {asdu_len}-byte body is too long, skipped"
            ),
            Self::CutShort {
                message_id,
                asdu_len,
                received,
            } => write!(
                f,
                "message {message_id}: cut short after {received} of its {asdu_len} body \
                 bytes, where the next frame starts; skipped"
            ),
        }
    }
}

impl Display for NumberError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Empty => "empty number",
            Self::Invalid => "not a decimal number",
            Self::OutOfRange => "number out of range",
            Self::NotFinite => "NaN or infinite number",
        })
    }
}

impl Display for XmlError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let what = match self.kind {
            XmlErrorKind::UnexpectedEnd => "unexpected end of document",
            XmlErrorKind::NoRoot => "no root element",
            XmlErrorKind::Dtd => "DTD or entity declaration refused",
            XmlErrorKind::Cdata => "CDATA section refused",
            XmlErrorKind::UnknownEntity => "unknown entity reference",
            XmlErrorKind::MismatchedTag => "end tag does not match the open element",
            XmlErrorKind::TooDeep => "elements nested too deep",
            XmlErrorKind::TrailingContent => "content after the root element",
            XmlErrorKind::TextOutsideRoot => "text outside the root element",
            XmlErrorKind::MalformedTag => "malformed tag",
        };
        write!(f, "XML: {what} at byte {}", self.offset)
    }
}

impl Display for StructureError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Self::Xml(e) => e.fmt(f),
            Self::NotPatrolDevice => f.write_str("root element is not <PatrolDevice>"),
            Self::MissingElement(name) => write!(f, "<{name}> is missing"),
            Self::NotText(name) => write!(f, "<{name}> holds elements, not text"),
            Self::BadNumber(name, e) => write!(f, "<{name}>: {e}"),
            Self::TooManyItemsBlocks => f.write_str("too many <Items> blocks"),
            Self::Conflicting(name) => write!(f, "<{name}> is there twice, with different values"),
        }
    }
}

impl Display for DecodeError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Self::Structure(e) => e.fmt(f),
            Self::UnknownType(t) => write!(f, "unknown Type {t}"),
            Self::UnknownCommand(c) => write!(f, "unknown motion Command {c}"),
            Self::MissingItem(name) => write!(f, "item <{name}> is missing"),
            Self::ItemNotText(name) => write!(f, "item <{name}> holds elements, not a value"),
            Self::BadItem { item, error } => write!(f, "item <{item}>: {error}"),
            Self::ItemsBlocks { found } => write!(f, "wrong number of <Items> blocks: {found}"),
        }
    }
}

impl Display for WriteError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Self::BufferFull => f.write_str("document does not fit the output buffer"),
            Self::NotFinite { item } => write!(f, "item <{item}> is NaN or infinite"),
        }
    }
}

impl Display for ValidationError {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Self::SpeedOutOfRange { max } => write!(f, "speed must be -1 or 0..={max}"),
            Self::BrightnessOutOfRange => f.write_str("brightness must be 0..=100"),
            Self::UnknownCode { item } => {
                write!(f, "<{item}> holds a code the protocol does not define")
            }
            Self::NotFinite { item } => write!(f, "<{item}> is NaN or infinite"),
            Self::GaitNotAllowedOnTerrain => {
                f.write_str("accumulated-frame terrain allows only gaits 6 and 7")
            }
            Self::GaitNotAllowedWhenCrouched => {
                f.write_str("crouched posture allows only the walk and slope gaits")
            }
            Self::NoPoints => f.write_str("navigation task without points"),
            Self::VendorExtension => {
                f.write_str("command beyond protocol V1.0.12 (needs the vendor-extensions feature)")
            }
        }
    }
}

impl Display for BadTimestamp {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str("time is not YYYY-MM-DD HH:MM:SS")
    }
}

impl core::error::Error for HeaderError {}
impl core::error::Error for EncodeError {}
impl core::error::Error for FrameError {}
impl core::error::Error for NumberError {}
impl core::error::Error for XmlError {}
impl core::error::Error for StructureError {}
impl core::error::Error for DecodeError {}
impl core::error::Error for WriteError {}
impl core::error::Error for ValidationError {}
impl core::error::Error for BadTimestamp {}

#[cfg(feature = "defmt")]
impl defmt::Format for NumberError {
    fn format(&self, f: defmt::Formatter<'_>) {
        let name = match self {
            Self::Empty => "Empty",
            Self::Invalid => "Invalid",
            Self::OutOfRange => "OutOfRange",
            Self::NotFinite => "NotFinite",
        };
        defmt::write!(f, "{=str}", name);
    }
}
