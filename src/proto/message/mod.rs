//! Typed requests and responses for every Type, in both directions.
//!
//! The panel encodes [`Request`]s and decodes [`Response`]s; the simulator does the
//! opposite with the same code. Each body is written in the document's layout and read
//! with the tolerance real peers need (docs/protocol.md, "Beyond the document"): elements
//! in any order, unknown items skipped,
//! `MapId` for `MapID`, several `<Items>` blocks in a 1003 request.

pub(crate) mod items;
mod motion;
mod nav;
mod status;

pub use motion::{
    Direction, Light, MotionAck, MotionCommand, MotionValue, Relocalize, RelocalizeAck,
    SENDS_VENDOR_EXTENSIONS, Speed,
};
pub use nav::{CommandAck, MAX_NAV_POINTS, NavPoint, NavResult, NavTask, NavTaskState};
pub use status::{Battery, MapImage, MotorTemperatures, Perception, RobotStatus};

use crate::proto::codes::{MessageType, MotionCommandCode, MotionGait, RequestErrorCode};
use crate::proto::time::Timestamp;
use crate::proto::xml::number::NumberError;
use crate::proto::xml::reader::{Tokenizer, XmlError};
use crate::proto::xml::writer::{DocumentWriter, ItemName, WriteError};
use crate::proto::xml::{Envelope, Items, StructureError, read_tokens};
#[cfg(not(feature = "compact"))]
use items::AnswerItems;
use items::{
    ItemSet, Kind, MAX_ITEMS, Sender, Table, Writing, item_set, read_values, table, write_values,
};

/// Longest body a valid request encodes to: a 1003 request with [`MAX_NAV_POINTS`]
/// waypoints whose every number has its longest text. A receiver that accepts bodies this
/// long never drops a valid request.
pub const MAX_REQUEST_LEN: usize = 4608;

/// The `Command` of every message other than Type 2 and Type 0.
const DEFAULT_COMMAND: i32 = 1;

/// The motion command's one item, `Value`: a float (a speed or a height).
const MOTION_VALUE_FLOAT: &Table = table!("Value": Kind::Float, true;);

/// The motion command's one item, `Value`, for a gait: an integer. Read as a float, a large
/// one would be rounded.
const MOTION_VALUE_INT: &Table = table!("Value": Kind::Int, true;);

/// Why a body could not be decoded into a message. The frame was consumed whole, so the
/// connection stays usable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DecodeError {
    /// The document's structure or XML is not acceptable.
    Structure(StructureError),
    /// A `Type` this protocol version does not define.
    UnknownType(i32),
    /// A Type 2 `Command` this build does not know.
    UnknownCommand(i32),
    /// A required item is missing.
    MissingItem(ItemName),
    /// An item holds child elements where a value was expected (as for
    /// [`DecodeError::BadItem`], an optional item of an answer counts as absent instead).
    ItemNotText(ItemName),
    /// An item's value does not parse or does not fit: any item of a request, a required
    /// item of an answer (an optional one that cannot be read counts as absent).
    BadItem {
        /// The item's element name.
        item: ItemName,
        /// What was wrong with its text.
        error: NumberError,
    },
    /// A message that carries items has no `<Items>` block, or a message that takes
    /// one block has several.
    ItemsBlocks {
        /// How many blocks the message carried.
        found: usize,
    },
}

impl From<StructureError> for DecodeError {
    fn from(e: StructureError) -> Self {
        Self::Structure(e)
    }
}

impl From<XmlError> for DecodeError {
    fn from(e: XmlError) -> Self {
        Self::Structure(StructureError::Xml(e))
    }
}

/// Why a request breaks the document's rules; checked before sending.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ValidationError {
    /// A speed outside −1 or 0..=max for its command.
    SpeedOutOfRange {
        /// The command's largest speed.
        max: f32,
    },
    /// Light brightness above 100 %.
    BrightnessOutOfRange,
    /// A coded item holds a code this protocol version does not define.
    UnknownCode {
        /// The item's element name.
        item: &'static str,
    },
    /// A float item is NaN or infinite.
    NotFinite {
        /// The item's element name.
        item: &'static str,
    },
    /// Accumulated-frame terrain allows only the accumulated-frame stair gaits (6, 7).
    GaitNotAllowedOnTerrain,
    /// Crouched posture allows only the walk (0) and slope (2) gaits.
    GaitNotAllowedWhenCrouched,
    /// A navigation task without points.
    NoPoints,
    /// A Type 2 command beyond protocol V1.0.12 (16–19, 21, 22), which this build sends
    /// only with the `vendor-extensions` feature.
    VendorExtension,
}

item_set! {
    answer
    /// Type 0 answer: the robot could not read a request.
    pub struct RequestError {
        /// What was wrong with the request.
        #[cfg_attr(feature = "serde", serde(rename = "error_code"))]
        pub code: RequestErrorCode = "ErrorCode";
    }
}

/// A request, as the panel sends it and the robot receives it.
// A navigation task holds its waypoints inline because there is no heap; requests are
// built once per send, so the size is paid rarely.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
// Serialized as its items alone; `null` for a request without items.
#[cfg_attr(feature = "serde", derive(serde::Serialize), serde(untagged))]
pub enum Request {
    /// 1002: real-time basic status.
    Status,
    /// 1003: navigation task; answered only when the task ends.
    NavTask(NavTask),
    /// 1004: cancel the navigation task.
    CancelNav,
    /// 1007: navigation task status.
    NavStatus,
    /// 1008: motor temperatures.
    MotorTemperatures,
    /// 1101: indicator light.
    Light(Light),
    /// 2: motion control.
    Motion(MotionCommand),
    /// 2001: battery.
    Battery,
    /// 2002: perception status.
    Perception,
    /// 2101: initialise localisation.
    Relocalize(Relocalize),
}

/// A response, as the robot sends it and the panel receives it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
// Serialized as its items alone.
#[cfg_attr(feature = "serde", derive(serde::Serialize), serde(untagged))]
pub enum Response {
    /// 1002 answer.
    Status(RobotStatus),
    /// 1003 answer: the task has ended.
    NavResult(NavResult),
    /// 1004 answer.
    CancelNav(CommandAck),
    /// 1007 answer.
    NavStatus(NavTaskState),
    /// 1008 answer.
    MotorTemperatures(MotorTemperatures),
    /// 1101 answer.
    Light(CommandAck),
    /// 2 answer, with the command it answers.
    #[cfg_attr(
        feature = "serde",
        serde(serialize_with = "crate::proto::serde_support::motion_answer")
    )]
    Motion(MotionCommandCode, MotionAck),
    /// 2001 answer.
    Battery(Battery),
    /// 2002 answer.
    Perception(Perception),
    /// 2101 answer.
    Relocalize(RelocalizeAck),
    /// 0: the robot could not read the request.
    RequestError(RequestError),
}

/// A decoded message and the `Time` its sender wrote.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Decoded<T> {
    /// The sender's local time.
    pub time: Timestamp,
    /// The message.
    pub message: T,
    /// The answer's optional items that were there but could not be read, which the
    /// message has as left out; none for a request, which must be read whole.
    pub unreadable: Unreadable,
}

/// Items an answer wrote that could not be read (a float with a decimal comma, an empty
/// element, …), so that a reading shown as not reported can be told from one the robot
/// left out.
#[derive(Clone, Copy)]
pub struct Unreadable {
    /// The table the mask refers to.
    table: &'static Table,
    /// Bit `i` for the table's item `i`.
    mask: items::Present,
}

/// No item.
impl Default for Unreadable {
    fn default() -> Self {
        Self {
            table: Table::EMPTY,
            mask: 0,
        }
    }
}

impl Unreadable {
    /// Whether every item there was read.
    pub fn is_empty(&self) -> bool {
        self.mask == 0
    }

    /// The names of the items that could not be read, in the table's order.
    pub fn names(&self) -> impl Iterator<Item = ItemName> {
        let (table, mask) = (self.table, self.mask);
        (0..table.len())
            .filter(move |i| mask >> i & 1 != 0)
            .filter_map(|i| Some(table.item(i)?.name))
    }
}

/// Equal when they name the same items.
impl PartialEq for Unreadable {
    fn eq(&self, other: &Self) -> bool {
        self.names().eq(other.names())
    }
}

impl Eq for Unreadable {}

/// The names, as a list.
impl core::fmt::Debug for Unreadable {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_list().entries(self.names()).finish()
    }
}

/// The names, separated by commas.
impl core::fmt::Display for Unreadable {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        for (i, name) in self.names().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{name}")?;
        }
        Ok(())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Unreadable {
    fn format(&self, f: defmt::Formatter<'_>) {
        for (i, name) in self.names().enumerate() {
            if i > 0 {
                defmt::write!(f, ", ");
            }
            defmt::write!(f, "{}", name);
        }
    }
}

impl Request {
    /// The message Type.
    pub fn message_type(&self) -> MessageType {
        match self {
            Self::Status => MessageType::Status,
            Self::NavTask(_) => MessageType::NavTask,
            Self::CancelNav => MessageType::CancelNav,
            Self::NavStatus => MessageType::NavStatus,
            Self::MotorTemperatures => MessageType::MotorTemperatures,
            Self::Light(_) => MessageType::Light,
            Self::Motion(_) => MessageType::Motion,
            Self::Battery => MessageType::Battery,
            Self::Perception => MessageType::Perception,
            Self::Relocalize(_) => MessageType::Relocalize,
        }
    }

    /// The `Command`: the motion command's code for Type 2, 1 otherwise.
    pub fn command(&self) -> i32 {
        match self {
            Self::Motion(motion) => motion.code().raw(),
            _ => DEFAULT_COMMAND,
        }
    }

    /// Checks the request against the document's rules; call before sending.
    pub fn validate(&self) -> Result<(), ValidationError> {
        match self {
            Self::NavTask(task) => task.validate(),
            Self::Light(light) => light.validate(),
            Self::Motion(motion) => motion.validate(),
            Self::Relocalize(pose) => {
                let values = [
                    ("PosX", pose.pos_x),
                    ("PosY", pose.pos_y),
                    ("PosZ", pose.pos_z),
                    ("Yaw", pose.yaw),
                ];
                match values.iter().find(|(_, v)| !v.is_finite()) {
                    Some(&(item, _)) => Err(ValidationError::NotFinite { item }),
                    None => Ok(()),
                }
            }
            _ => Ok(()),
        }
    }

    /// Writes the XML body into `out`; returns its length.
    pub fn encode(&self, time: &Timestamp, out: &mut [u8]) -> Result<usize, WriteError> {
        let mut doc = DocumentWriter::begin(out, self.message_type().raw(), self.command(), time)?;
        // Every block is written by one call, from its table and values.
        let mut values = [0; MAX_ITEMS];
        let (table, present) = match self {
            Self::NavTask(task) => {
                for point in &task.points {
                    let (table, present) = point.to_block(&mut values);
                    write_values(&mut doc, table, &values, present, Sender::Client)?;
                    doc.end_items_block()?;
                }
                (Table::EMPTY, 0)
            }
            Self::Light(light) => light.to_block(&mut values),
            Self::Motion(motion) => {
                let [value, ..] = &mut values;
                let table = match motion.value() {
                    MotionValue::Float(v) => {
                        *value = v.to_bits();
                        MOTION_VALUE_FLOAT
                    }
                    MotionValue::Int(v) => {
                        *value = v as u32;
                        MOTION_VALUE_INT
                    }
                };
                (table, 1)
            }
            Self::Relocalize(pose) => pose.to_block(&mut values),
            Self::Status
            | Self::CancelNav
            | Self::NavStatus
            | Self::MotorTemperatures
            | Self::Battery
            | Self::Perception => (Table::EMPTY, 0),
        };
        // Nothing present writes nothing; the call is skipped (a 1003 request, whose blocks
        // are written above, measured faster for it).
        if present != 0 {
            write_values(&mut doc, table, &values, present, Sender::Client)?;
        }
        doc.finish()
    }

    /// Reads a request body.
    pub fn decode(asdu: &[u8]) -> Result<Decoded<Self>, DecodeError> {
        Self::decode_from(Tokenizer::document(asdu))
    }

    /// [`Request::decode`] without the shortcuts for the usual layout: the reference they
    /// are tested against, with exactly the same results.
    pub fn decode_general(asdu: &[u8]) -> Result<Decoded<Self>, DecodeError> {
        Self::decode_from(Tokenizer::document(asdu).without_shortcut())
    }

    fn decode_from(tokens: Tokenizer<'_>) -> Result<Decoded<Self>, DecodeError> {
        let mut message = None;
        let (envelope, blocks) = read_tokens(tokens, &mut |envelope, items| {
            match MessageType::from_raw(envelope.message_type) {
                // Each block is one waypoint, added to the task in place (the task is large,
                // and every move of it is a copy); read_document allows no more blocks than
                // fit.
                MessageType::NavTask => {
                    let point = NavPoint::read_items(items)?;
                    let task = message.get_or_insert(Self::NavTask(NavTask {
                        points: heapless::Vec::new(),
                    }));
                    let Self::NavTask(task) = task else {
                        return Ok(());
                    };
                    task.points
                        .push(point)
                        .map_err(|_| DecodeError::ItemsBlocks {
                            found: MAX_NAV_POINTS + 1,
                        })
                }
                MessageType::Light if message.is_none() => {
                    message = Some(Self::Light(Light::read_items(items)?));
                    Ok(())
                }
                MessageType::Relocalize if message.is_none() => {
                    message = Some(Self::Relocalize(Relocalize::read_items(items)?));
                    Ok(())
                }
                MessageType::Motion if message.is_none() => {
                    message = Some(Self::Motion(read_motion(envelope.command, items)?));
                    Ok(())
                }
                _ => Ok(()),
            }
        })?;
        let message = match MessageType::from_raw(envelope.message_type) {
            MessageType::Status => Self::Status,
            MessageType::CancelNav => Self::CancelNav,
            MessageType::NavStatus => Self::NavStatus,
            MessageType::MotorTemperatures => Self::MotorTemperatures,
            MessageType::Battery => Self::Battery,
            MessageType::Perception => Self::Perception,
            MessageType::NavTask => match message {
                Some(task) => task,
                None => return Err(DecodeError::ItemsBlocks { found: 0 }),
            },
            MessageType::Light | MessageType::Relocalize | MessageType::Motion => {
                match (message, blocks) {
                    (Some(message), 1) => message,
                    _ => return Err(DecodeError::ItemsBlocks { found: blocks }),
                }
            }
            MessageType::RequestError | MessageType::Unknown(_) => {
                return Err(DecodeError::UnknownType(envelope.message_type));
            }
        };
        Ok(Decoded {
            time: envelope.time,
            message,
            unreadable: Unreadable::default(),
        })
    }
}

impl Response {
    /// The message Type.
    pub fn message_type(&self) -> MessageType {
        match self {
            Self::Status(_) => MessageType::Status,
            Self::NavResult(_) => MessageType::NavTask,
            Self::CancelNav(_) => MessageType::CancelNav,
            Self::NavStatus(_) => MessageType::NavStatus,
            Self::MotorTemperatures(_) => MessageType::MotorTemperatures,
            Self::Light(_) => MessageType::Light,
            Self::Motion(..) => MessageType::Motion,
            Self::Battery(_) => MessageType::Battery,
            Self::Perception(_) => MessageType::Perception,
            Self::Relocalize(_) => MessageType::Relocalize,
            Self::RequestError(_) => MessageType::RequestError,
        }
    }

    /// The `Command`: echoed from the request; 0 for Type 0.
    pub fn command(&self) -> i32 {
        match self {
            Self::Motion(code, _) => code.raw(),
            Self::RequestError(_) => 0,
            _ => DEFAULT_COMMAND,
        }
    }

    /// Whether this can answer a request of `message_type`: it has that Type. A frame with
    /// a request's message ID but another Type is no answer to it. A motion answer's Command
    /// is not compared: the message ID pairs a request with its answer, and a robot that
    /// echoes another Command has still answered.
    pub fn answers(&self, message_type: MessageType) -> bool {
        self.message_type() == message_type
    }

    /// Writes the XML body into `out`; returns its length.
    pub fn encode(&self, time: &Timestamp, out: &mut [u8]) -> Result<usize, WriteError> {
        self.encode_as(time, out, Writing::BUILD)
    }

    /// [`Response::encode`] with the block written through its item table, as a `compact`
    /// build writes it: the reference the default build's faster writing is tested against,
    /// with the same bytes and errors.
    pub fn encode_general(&self, time: &Timestamp, out: &mut [u8]) -> Result<usize, WriteError> {
        self.encode_as(time, out, Writing::Table)
    }

    // Inlined into both callers, so that each writes its block one way only.
    #[inline(always)]
    fn encode_as(
        &self,
        time: &Timestamp,
        out: &mut [u8],
        writing: Writing,
    ) -> Result<usize, WriteError> {
        let mut doc = DocumentWriter::begin(out, self.message_type().raw(), self.command(), time)?;
        // `$items` for the answer's item set `$set`, whatever its Type.
        macro_rules! with_items {
            ($set:ident => $items:expr) => {
                match self {
                    Self::Status($set) => $items,
                    Self::NavResult($set) => $items,
                    Self::CancelNav($set) | Self::Light($set) => $items,
                    Self::NavStatus($set) => $items,
                    Self::MotorTemperatures($set) => $items,
                    Self::Motion(_, $set) => $items,
                    Self::Battery($set) => $items,
                    Self::Perception($set) => $items,
                    Self::Relocalize($set) => $items,
                    Self::RequestError($set) => $items,
                }
            };
        }
        match writing {
            #[cfg(not(feature = "compact"))]
            Writing::Straight => with_items!(set => set.write_items(&mut doc))?,
            Writing::Table => {
                // The block is written by one call for every Type, from its table and values.
                let mut values = [0; MAX_ITEMS];
                let (table, present) = with_items!(set => set.to_block(&mut values));
                write_values(&mut doc, table, &values, present, Sender::Robot)?;
            }
        }
        doc.finish()
    }

    /// Reads a response body.
    pub fn decode(asdu: &[u8]) -> Result<Decoded<Self>, DecodeError> {
        Self::decode_from(Tokenizer::document(asdu))
    }

    /// [`Response::decode`] without the shortcuts for the usual layout: the reference they
    /// are tested against, with exactly the same results.
    pub fn decode_general(asdu: &[u8]) -> Result<Decoded<Self>, DecodeError> {
        Self::decode_from(Tokenizer::document(asdu).without_shortcut())
    }

    fn decode_from(tokens: Tokenizer<'_>) -> Result<Decoded<Self>, DecodeError> {
        let mut message = None;
        let (envelope, blocks) = read_tokens(tokens, &mut |envelope, items| {
            if message.is_none() {
                message = Some(Self::read_items(envelope, items)?);
            }
            Ok::<_, DecodeError>(())
        })?;
        if let MessageType::Unknown(raw) = MessageType::from_raw(envelope.message_type) {
            return Err(DecodeError::UnknownType(raw));
        }
        match (message, blocks) {
            (Some((message, unreadable)), 1) => Ok(Decoded {
                time: envelope.time,
                message,
                unreadable,
            }),
            _ => Err(DecodeError::ItemsBlocks { found: blocks }),
        }
    }

    /// Reads the items of an answer of the envelope's Type.
    // The block is read by one call for every Type, with the Type's table, and only turned
    // into its message per Type: one call and one error path instead of eleven. Left to the
    // compiler, which inlines it into the items handler: once kept out of line because
    // that made the 1002 decode slower, it now takes 20 bytes less of the panel's flash
    // and 104 less both ways, and is no slower (measured).
    fn read_items(
        envelope: &Envelope,
        items: &mut Items<'_, '_>,
    ) -> Result<(Self, Unreadable), DecodeError> {
        let message_type = MessageType::from_raw(envelope.message_type);
        let table = match message_type {
            MessageType::Status => RobotStatus::TABLE,
            MessageType::NavTask => NavResult::TABLE,
            MessageType::CancelNav | MessageType::Light => CommandAck::TABLE,
            MessageType::NavStatus => NavTaskState::TABLE,
            MessageType::MotorTemperatures => MotorTemperatures::TABLE,
            MessageType::Motion => MotionAck::TABLE,
            MessageType::Battery => Battery::TABLE,
            MessageType::Perception => Perception::TABLE,
            MessageType::Relocalize => RelocalizeAck::TABLE,
            MessageType::RequestError => RequestError::TABLE,
            MessageType::Unknown(raw) => return Err(DecodeError::UnknownType(raw)),
        };
        let block = read_values(items, table, Sender::Robot)?;
        let (values, present) = (&block.values, block.present);
        let unreadable = Unreadable {
            table,
            mask: block.unreadable,
        };
        let message = match message_type {
            MessageType::Status => Self::Status(ItemSet::from_values(values, present)),
            MessageType::NavTask => Self::NavResult(ItemSet::from_values(values, present)),
            MessageType::CancelNav => Self::CancelNav(ItemSet::from_values(values, present)),
            MessageType::NavStatus => Self::NavStatus(ItemSet::from_values(values, present)),
            MessageType::MotorTemperatures => {
                Self::MotorTemperatures(ItemSet::from_values(values, present))
            }
            MessageType::Light => Self::Light(ItemSet::from_values(values, present)),
            MessageType::Motion => Self::Motion(
                MotionCommandCode::from_raw(envelope.command),
                ItemSet::from_values(values, present),
            ),
            MessageType::Battery => Self::Battery(ItemSet::from_values(values, present)),
            MessageType::Perception => Self::Perception(ItemSet::from_values(values, present)),
            MessageType::Relocalize => Self::Relocalize(ItemSet::from_values(values, present)),
            MessageType::RequestError => Self::RequestError(ItemSet::from_values(values, present)),
            MessageType::Unknown(raw) => return Err(DecodeError::UnknownType(raw)),
        };
        Ok((message, unreadable))
    }
}

fn read_motion(command: i32, items: &mut Items<'_, '_>) -> Result<MotionCommand, DecodeError> {
    let code = MotionCommandCode::from_raw(command);
    let table = match code {
        MotionCommandCode::SwitchGait => MOTION_VALUE_INT,
        _ => MOTION_VALUE_FLOAT,
    };
    let [bits, ..] = read_values(items, table, Sender::Client)?.values;
    match code {
        MotionCommandCode::SwitchGait => {
            Ok(MotionCommand::SwitchGait(MotionGait::from_raw(bits as i32)))
        }
        _ => MotionCommand::from_parts(code, f32::from_bits(bits))
            .ok_or(DecodeError::UnknownCommand(command)),
    }
}
