//! Fault injection: answers made to look like a difficult robot or a difficult network.
//!
//! [`Faults`] is the configuration; the functions here alter the bytes the protocol core's
//! encoder produced (never writing a document of their own), so every answer starts out
//! exactly as a correct robot would send it.

use std::collections::BTreeSet;
use std::fmt;
use std::str::FromStr;
use std::time::{Duration, Instant};

use x30_panel::proto::frame::HEADER_LEN;

use crate::Robot;
use crate::outbox::encode_frame;

/// The Type every answer carries under [`Faults::unknown_type`]: RTK position, added by
/// vendor software after V1.0.12 (docs/protocol.md, "Unknown Types"), so a client built for
/// V1.0.12 does not know it.
pub const UNKNOWN_TYPE: i32 = 2102;

/// Added to an answer's message ID to get the ID of the extra frame [`Faults::merge`]
/// sends with it (wrapping at 65535).
pub const MERGED_ID_OFFSET: u16 = 0x8000;

/// The bytes [`Faults::garbage`] puts before each answer frame. They contain no sync
/// sequence, but do contain a lone `EB` and `EB 90`, so a receiver that resynchronises
/// byte by byte is exercised.
pub const GARBAGE: &[u8] = &[0x55, 0xAA, 0x00, 0xEB, 0x90, 0x00, 0x7F, 0x0A];

/// How many bytes each write of [`Faults::flood`] takes: [`GARBAGE`] over and over, about
/// one Ethernet frame's payload.
pub const FLOOD_WRITE: usize = 1456;

/// What [`Faults::reserved_bytes`] puts in the 8 reserved bytes of each answer's header,
/// which the document fills with zeros "for now".
pub const RESERVED_BYTES: [u8; 8] = [0x01, 0x00, 0x5A, 0xEB, 0x90, 0xFF, 0x00, 0x80];

/// Items a real robot sends that the document does not list (docs/protocol.md, "Extra
/// items"), one line each, in
/// the encoder's layout. [`Faults::unknown_items`] spreads them between the documented
/// ones.
pub const UNKNOWN_ITEMS: [&[u8]; 5] = [
    b"    <AngleYaw>-0.00023393621</AngleYaw>\n",
    b"    <CurRuntime>5321</CurRuntime>\n",
    b"    <SumRuntime>2147483</SumRuntime>\n",
    b"    <RTKState>0</RTKState>\n",
    b"    <MapUpdateState>0</MapUpdateState>\n",
];

/// How answers and connections misbehave. The default is a well-behaved robot.
///
/// Every field can be changed while the simulator runs ([`crate::Simulator::set_faults`]).
/// Each answer uses the faults in force when it is written; `drop_after`, `hang_up_on`,
/// `mute` and `refuse_estops` also count as each request arrives,
/// `refuse_connections_until` as each connection arrives, and `hang_at` as each connection
/// reads.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Faults {
    /// Wait this long before writing each answer, counted from when its request arrived
    /// (for a 1003 answer, from when the task ended).
    pub delay: Duration,
    /// Extra delay for the answers of some Types, added to `delay`: (Type, delay) pairs,
    /// the last pair for a Type counting. A delayed answer holds up no other answer on its
    /// connection: each is written when its own delay expires, so answers may leave in
    /// another order than their requests came (clients match them by message ID). A write
    /// carrying several answers (a cancel's) waits for the longest of their delays.
    pub type_delays: Vec<(i32, Duration)>,
    /// A half-open robot: requests are still read and logged, but neither acted on nor
    /// answered (not even with Type 0), and connections stay open. Not acting means a
    /// Command 13 stops nothing, a 1003 starts no task, and motion repeats keep nothing
    /// going (the watchdog stops the robot). Answers that fall due while muted, a running
    /// task's included, are discarded rather than kept, so unmuting answers new requests
    /// only.
    pub mute: bool,
    /// Until this moment, new connections are accepted and closed at once without reading;
    /// setting it to a moment still ahead also closes every open connection.
    /// [`crate::Simulator::refuse_connections`] sets it from a duration.
    pub refuse_connections_until: Option<Instant>,
    /// From this moment, connections opened before it are no longer read, nor answered,
    /// and stay open, as by a `robot_server` whose client handlers hung all at once;
    /// connections opened later are served. [`crate::Simulator::hang_open_connections`]
    /// sets it to now.
    pub hang_at: Option<Instant>,
    /// Serve one connection at a time, as a single-threaded `robot_server` does: while one
    /// is open, new connections wait in the listener's backlog, connected but unread, and
    /// are taken in the order they came once it closes. Connections already open when this
    /// is set stay open.
    pub one_at_a_time: bool,
    /// Keep at most this many connections open: one made while that many are open is
    /// closed at once, without a byte read, as by a `robot_server` that takes a limited
    /// number of clients. `None`: no limit.
    pub max_connections: Option<usize>,
    /// Keep only the newest connection: each new one closes every other, as by a
    /// `robot_server` that serves one client and lets a new one replace it.
    pub newest_only: bool,
    /// Answer nothing on a connection until this long after it opened: answers due sooner
    /// wait until then. A `robot_server` slow to set up each new client.
    pub warm_up: Duration,
    /// Refuse this many of the next soft emergency stops (Type 2 Command 13): each is
    /// answered with ErrorCode 1, leaves the motion state as it was, and counts this down.
    pub refuse_estops: u32,
    /// Close each connection when it has received this many frames (malformed ones
    /// included), without answering the last one.
    pub drop_after: Option<u64>,
    /// Close each connection as soon as it has written an answer, leaving any other request
    /// on it unanswered: a `robot_server` that serves one request a connection.
    pub hang_up_after_answer: bool,
    /// Close a connection, without answering, when it receives a request of one of these
    /// Types: a `robot_server` that drops a client asking for a Type it does not know.
    pub hang_up_on: Vec<i32>,
    /// Put [`GARBAGE`] before each answer frame, in the same write.
    pub garbage: bool,
    /// Between answers, write [`GARBAGE`] over and over, [`FLOOD_WRITE`] bytes a write, as
    /// fast as the client reads it: a `robot_server` (or another device on its port) that
    /// streams bytes no frame holds. Answers still go out whole, between two writes.
    pub flood: bool,
    /// Put a frame with an empty body before each answer frame, in the same write, with
    /// the answer's message ID: a keep-alive that happens to share it.
    pub empty_frames: bool,
    /// Fill the reserved bytes of each answer's header with [`RESERVED_BYTES`]: a
    /// `robot_server` whose software uses them.
    pub reserved_bytes: bool,
    /// Write each answer in chunks of this many bytes, about 1 ms apart, each its own write.
    /// `None` (or 0) writes each answer whole.
    pub split: Option<usize>,
    /// Write each answer together with an unsolicited 1002 status answer whose message ID
    /// is the answer's plus [`MERGED_ID_OFFSET`], in one write, the answer first.
    pub merge: bool,
    /// Put, before each answer frame, in the same write, a copy of it cut short: its header
    /// declares the whole body, of which only the first half follows. A `robot_server`
    /// whose write went out only in part and that wrote the frame again: a client that reads
    /// by the declared length alone takes the answer for the rest of the broken frame, and
    /// loses it; one that takes the broken frame, which carries the answer's message ID, for
    /// the answer fails the request.
    pub cut_frames: bool,
    /// Answer with Type [`UNKNOWN_TYPE`] instead of the real Type, keeping the message ID,
    /// Command and items.
    pub unknown_type: bool,
    /// Name this Command in every motion answer (Type 2) instead of the request's: a
    /// `robot_server` that fills its answers in from one template. The message ID, which
    /// pairs an answer with its request, is kept.
    pub motion_answer_command: Option<i32>,
    /// Insert [`UNKNOWN_ITEMS`] between the documented items of every answer.
    pub unknown_items: bool,
    /// Report the pose as unknown: status answers carry `nan` for each of
    /// [`UNKNOWN_POSE_ITEMS`], as a robot's C library prints a float it has no value for.
    pub unknown_pose: bool,
    /// Leave every item but [`SPARSE_STATUS_ITEM`] out of status answers: a robot that
    /// reports less than the document lists.
    pub sparse_status: bool,
    /// Leave the items of these names out of every answer: a robot that lacks a reading.
    pub leave_out: Vec<String>,
    /// Write every decimal point in answers' items as a comma (`12,345678`), as the C
    /// library of a robot_server that runs under a locale such as `de_DE` prints floats.
    pub decimal_comma: bool,
    /// The XML declaration of answers.
    pub declaration: Declaration,
}

impl Faults {
    /// How long after its request an answer of Type `message_type` is written: `delay`
    /// plus that Type's entry in `type_delays`, if any.
    pub fn delay_for(&self, message_type: i32) -> Duration {
        let extra = self
            .type_delays
            .iter()
            .rev()
            .find(|(t, _)| *t == message_type)
            .map_or(Duration::ZERO, |(_, d)| *d);
        self.delay.saturating_add(extra)
    }

    /// Whether a connection opened at `opened` is hung at `now` ([`Faults::hang_at`]).
    pub fn hangs(&self, opened: Instant, now: Instant) -> bool {
        self.hang_at.is_some_and(|at| opened < at && at <= now)
    }

    /// Whether connections arriving at `now` are refused.
    pub fn refuses_connections(&self, now: Instant) -> bool {
        self.refuse_connections_until
            .is_some_and(|until| now < until)
    }
}

/// The moment `duration` after `now`; a duration too long for the clock counts as a year.
pub fn after(now: Instant, duration: Duration) -> Instant {
    now.checked_add(duration)
        .or_else(|| now.checked_add(A_YEAR))
        .unwrap_or(now)
}

/// Stands in for a duration too long to add to the clock.
const A_YEAR: Duration = Duration::from_secs(365 * 24 * 3600);

/// The XML declaration answers start with (real traffic has all three: docs/protocol.md,
/// "Declaration and layout variants").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Declaration {
    /// `<?xml version="1.0" encoding="UTF-8"?>`, as the encoder writes it.
    #[default]
    Double,
    /// `<?xml version='1.0' encoding='utf-8'?>`, as some of the document's samples.
    Single,
    /// No declaration at all.
    None,
}

impl Declaration {
    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Double => "double",
            Self::Single => "single",
            Self::None => "none",
        }
    }
}

impl fmt::Display for Declaration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Declaration {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "double" => Ok(Self::Double),
            "single" => Ok(Self::Single),
            "none" => Ok(Self::None),
            other => Err(format!(
                "unknown declaration {other:?}: expected double, single or none"
            )),
        }
    }
}

/// The items [`Faults::unknown_pose`] writes as `nan`: the robot's position and attitude.
pub const UNKNOWN_POSE_ITEMS: [&str; 6] = ["PosX", "PosY", "PosZ", "Roll", "Pitch", "Yaw"];

/// The one item [`Faults::sparse_status`] keeps in status answers: the panel cannot
/// confirm an e-stop without it.
pub const SPARSE_STATUS_ITEM: &str = "MotionState";

const SINGLE_DECLARATION: &[u8] = b"<?xml version='1.0' encoding='utf-8'?>";

/// Alters an encoded XML body as the faults ask: fewer items, extra items, an unknown
/// pose, decimal commas, another Command, another Type, another declaration. Without those
/// faults the body comes back unchanged.
pub fn alter_body(body: &[u8], faults: &Faults) -> Vec<u8> {
    let mut body = body.to_vec();
    if faults.sparse_status && find(&body, b"<Type>1002</Type>").is_some() {
        let kept = format!("<{SPARSE_STATUS_ITEM}>");
        body = keep_items(&body, |line| find(line, kept.as_bytes()).is_some());
    }
    if !faults.leave_out.is_empty() {
        let left_out: Vec<String> = faults.leave_out.iter().map(|n| format!("<{n}>")).collect();
        body = keep_items(&body, |line| {
            left_out
                .iter()
                .all(|tag| find(line, tag.as_bytes()).is_none())
        });
    }
    if faults.unknown_items {
        body = insert_unknown_items(&body);
    }
    if faults.unknown_pose {
        for name in UNKNOWN_POSE_ITEMS {
            body = replace_text(&body, name, "nan");
        }
    }
    if faults.decimal_comma {
        body = decimal_commas(&body);
    }
    if let Some(command) = faults.motion_answer_command
        && find(&body, b"<Type>2</Type>").is_some()
    {
        body = replace_text(&body, "Command", &command.to_string());
    }
    if faults.unknown_type {
        body = replace_text(&body, "Type", &UNKNOWN_TYPE.to_string());
    }
    if faults.declaration != Declaration::Double {
        body = replace_declaration(&body, faults.declaration);
    }
    body
}

/// Fills the reserved bytes of an encoded frame's header with [`RESERVED_BYTES`] if
/// [`Faults::reserved_bytes`] asks.
pub fn alter_header(frame: &mut [u8], faults: &Faults) {
    if let (true, Some(reserved)) = (faults.reserved_bytes, frame.get_mut(8..HEADER_LEN)) {
        reserved.copy_from_slice(&RESERVED_BYTES);
    }
}

/// The bytes of one write of [`Faults::flood`].
pub fn flood_bytes() -> Vec<u8> {
    GARBAGE.iter().copied().cycle().take(FLOOD_WRITE).collect()
}

/// The bytes of one write: the frames in order (answers, and the extra frames of
/// [`Faults::merge`]), each preceded by [`GARBAGE`], by a copy of it cut short
/// ([`Faults::cut_frames`]) and by an empty frame with its message ID
/// ([`Faults::empty_frames`]) if asked.
pub fn wire_bytes(frames: &[Vec<u8>], faults: &Faults) -> Vec<u8> {
    let garbage = if faults.garbage { GARBAGE.len() } else { 0 };
    let empty = if faults.empty_frames { HEADER_LEN } else { 0 };
    let mut out = Vec::with_capacity(frames.iter().map(|f| garbage + empty + 2 * f.len()).sum());
    for frame in frames {
        if faults.garbage {
            out.extend_from_slice(GARBAGE);
        }
        if let (true, Some((header, body))) = (faults.cut_frames, frame.split_first_chunk()) {
            out.extend_from_slice(&cut_copy(header, body));
        }
        if let (true, Some(header)) = (faults.empty_frames, frame.get(..HEADER_LEN)) {
            // The same header with a zero length: sync, length, message ID, reserved bytes.
            out.extend_from_slice(header.get(..4).unwrap_or_default());
            out.extend_from_slice(&[0, 0]);
            out.extend_from_slice(header.get(6..).unwrap_or_default());
        }
        out.extend_from_slice(frame);
    }
    out
}

/// The frame with `header` and `body`, cut short after half its body: its header still
/// declares the whole body.
fn cut_copy(header: &[u8; HEADER_LEN], body: &[u8]) -> Vec<u8> {
    let mut out = header.to_vec();
    out.extend_from_slice(body.get(..body.len() / 2).unwrap_or_default());
    out
}

/// Replaces the leading `<?xml …?>` declaration (and the line break after it).
fn replace_declaration(body: &[u8], declaration: Declaration) -> Vec<u8> {
    let rest = match body.strip_prefix(b"<?xml") {
        Some(_) => find(body, b"?>").map_or(body, |end| {
            let after = body.get(end + 2..).unwrap_or_default();
            after.strip_prefix(b"\n").unwrap_or(after)
        }),
        None => body,
    };
    let mut out = Vec::with_capacity(body.len());
    match declaration {
        Declaration::Double => return body.to_vec(),
        Declaration::Single => {
            out.extend_from_slice(SINGLE_DECLARATION);
            out.push(b'\n');
        }
        Declaration::None => {}
    }
    out.extend_from_slice(rest);
    out
}

/// Replaces the text of the first `<name>` element, if there is one.
fn replace_text(body: &[u8], name: &str, text: &str) -> Vec<u8> {
    let (open, close) = (format!("<{name}>"), format!("</{name}>"));
    let (Some(at), Some(end)) = (find(body, open.as_bytes()), find(body, close.as_bytes())) else {
        return body.to_vec();
    };
    let start = at + open.len();
    if end < start {
        return body.to_vec();
    }
    let mut out = body.get(..start).unwrap_or_default().to_vec();
    out.extend_from_slice(text.as_bytes());
    out.extend_from_slice(body.get(end..).unwrap_or_default());
    out
}

/// Spreads [`UNKNOWN_ITEMS`] through the first `<Items>` block: one before each documented
/// item while they last, the rest after the last one.
fn insert_unknown_items(body: &[u8]) -> Vec<u8> {
    if let Some(at) = find(body, b"<Items/>") {
        let mut out = body.get(..at).unwrap_or_default().to_vec();
        out.extend_from_slice(b"<Items>\n");
        UNKNOWN_ITEMS.iter().for_each(|i| out.extend_from_slice(i));
        out.extend_from_slice(b"  </Items>");
        out.extend_from_slice(body.get(at + b"<Items/>".len()..).unwrap_or_default());
        return out;
    }
    let Some(ItemsBlock { head, lines, tail }) = items_block(body) else {
        return body.to_vec();
    };
    let is_item = |piece: &&[u8]| piece.contains(&b'<');
    let last_item = lines.iter().rposition(is_item);
    let mut extras = UNKNOWN_ITEMS.iter();
    let mut out = head.to_vec();
    for (i, piece) in lines.iter().enumerate() {
        if is_item(piece)
            && let Some(extra) = extras.next()
        {
            out.extend_from_slice(extra);
        }
        out.extend_from_slice(piece);
        if Some(i) == last_item {
            extras.by_ref().for_each(|e| out.extend_from_slice(e));
        }
    }
    out.extend_from_slice(tail);
    out
}

/// Writes every `.` of the first `<Items>` block as `,`: only numbers have one there.
fn decimal_commas(body: &[u8]) -> Vec<u8> {
    let Some(ItemsBlock { head, lines, tail }) = items_block(body) else {
        return body.to_vec();
    };
    let mut out = head.to_vec();
    for line in lines {
        out.extend(line.iter().map(|&c| if c == b'.' { b',' } else { c }));
    }
    out.extend_from_slice(tail);
    out
}

/// Keeps, of the item lines of the first `<Items>` block, those `keep` takes.
fn keep_items(body: &[u8], keep: impl Fn(&[u8]) -> bool) -> Vec<u8> {
    let Some(ItemsBlock { head, lines, tail }) = items_block(body) else {
        return body.to_vec();
    };
    let mut out = head.to_vec();
    for piece in lines {
        if !piece.contains(&b'<') || keep(piece) {
            out.extend_from_slice(piece);
        }
    }
    out.extend_from_slice(tail);
    out
}

/// The first `<Items>` block of an encoded body, split for rewriting.
struct ItemsBlock<'a> {
    /// Everything up to and including `<Items>`.
    head: &'a [u8],
    /// The block's lines: the encoder writes one item per line; the last piece is the
    /// indentation of `</Items>`.
    lines: Vec<&'a [u8]>,
    /// Everything from `</Items>` on.
    tail: &'a [u8],
}

/// The first `<Items>` block of `body`, if it has one.
fn items_block(body: &[u8]) -> Option<ItemsBlock<'_>> {
    let start = find(body, b"<Items>")? + b"<Items>".len();
    let close = find(body, b"</Items>")?;
    Some(ItemsBlock {
        head: body.get(..start)?,
        lines: body
            .get(start..close)?
            .split_inclusive(|&b| b == b'\n')
            .collect(),
        tail: body.get(close..)?,
    })
}

/// The item names of the simulator's answers ([`Robot::sample_answers`] of a fresh robot):
/// the names [`Faults::leave_out`] can take out.
pub fn answer_item_names() -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    for answer in Robot::new(1.0).sample_answers() {
        let Some(frame) = encode_frame(0, &answer, &Faults::default()) else {
            continue;
        };
        let Some(block) = items_block(&frame) else {
            continue;
        };
        for line in block.lines {
            let name = line
                .split(|&b| b == b'<')
                .nth(1)
                .and_then(|tag| tag.split(|&b| b == b'>').next());
            if let Some(name) = name.filter(|name| !name.is_empty()) {
                names.insert(String::from_utf8_lossy(name).into_owned());
            }
        }
    }
    names
}

/// Position of the first occurrence of `needle` in `haystack`.
fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

#[cfg(test)]
mod tests {
    use super::*;
    use x30_panel::proto::codes::{CommandResult, MotionState};
    use x30_panel::proto::message::{Battery, CommandAck, Response, RobotStatus};
    use x30_panel::proto::time::Timestamp;

    #[test]
    fn answer_item_names_are_every_answers_and_only_answers() {
        let names = answer_item_names();
        // One of each answer: 1002, 2001, 2002, 1008, 1007, 1003, Type 2.
        for name in [
            "MotionState",
            "OnDockState",
            "BatteryLevel",
            "BatteryTemperature",
            "ObsState",
            "RightBackKnee",
            "Status",
            "ErrorStatus",
            "Value",
            "ErrorCode",
        ] {
            assert!(names.contains(name), "{name} missing from {names:?}");
        }
        // A request's item, an undocumented one the robot may add, and a misspelling.
        for name in ["LUM", "AngleYaw", "Batterylevel"] {
            assert!(!names.contains(name), "{name} in {names:?}");
        }
    }

    fn encode(response: &Response) -> Vec<u8> {
        let mut buf = [0u8; 2048];
        let n = response
            .encode(&Timestamp::DOCUMENT_EPOCH, &mut buf)
            .unwrap();
        buf[..n].to_vec()
    }

    fn ack() -> Response {
        Response::CancelNav(CommandAck {
            result: CommandResult::Success,
        })
    }

    fn text(bytes: &[u8]) -> &str {
        std::str::from_utf8(bytes).unwrap()
    }

    #[test]
    fn no_faults_change_nothing() {
        let body = encode(&ack());
        assert_eq!(alter_body(&body, &Faults::default()), body);
        assert_eq!(
            wire_bytes(&[b"frame".to_vec()], &Faults::default()),
            b"frame"
        );
    }

    #[test]
    fn declarations() {
        let body = encode(&ack());
        let single = Faults {
            declaration: Declaration::Single,
            ..Faults::default()
        };
        let none = Faults {
            declaration: Declaration::None,
            ..Faults::default()
        };
        let single = alter_body(&body, &single);
        assert!(
            text(&single).starts_with("<?xml version='1.0' encoding='utf-8'?>\n<PatrolDevice>")
        );
        let none = alter_body(&body, &none);
        assert!(text(&none).starts_with("<PatrolDevice>"));
        for altered in [single, none] {
            assert_eq!(Response::decode(&altered).unwrap().message, ack());
        }
        assert_eq!("none".parse(), Ok(Declaration::None));
        assert!("triple".parse::<Declaration>().is_err());
    }

    /// A battery answer with every item.
    fn battery() -> Battery {
        Battery {
            voltage: Some(55),
            current: Some(800),
            remaining_capacity: Some(1800),
            nominal_capacity: Some(2004),
            cycles: Some(12),
            protected_state: Some(x30_panel::proto::codes::ProtectedState::Normal),
            battery_level: Some(90),
            battery_temperature: Some(28.5),
        }
    }

    #[test]
    fn unknown_items_sit_between_the_documented_ones_and_are_skipped() {
        let battery = Response::Battery(battery());
        let faults = Faults {
            unknown_items: true,
            ..Faults::default()
        };
        let altered = alter_body(&encode(&battery), &faults);
        let xml = text(&altered);
        let at = |s: &str| xml.find(s).unwrap();
        assert!(at("<AngleYaw>") < at("<Voltage>"));
        assert!(at("<Voltage>") < at("<CurRuntime>") && at("<CurRuntime>") < at("<Current>"));
        assert!(at("<MapUpdateState>") < at("<BatteryLevel>"));
        assert_eq!(Response::decode(&altered).unwrap().message, battery);
        // One documented item: the extras go round it.
        let altered = alter_body(&encode(&ack()), &faults);
        let xml = text(&altered);
        assert!(xml.find("<AngleYaw>").unwrap() < xml.find("<ErrorCode>").unwrap());
        assert!(xml.find("<RTKState>").unwrap() > xml.find("<ErrorCode>").unwrap());
        assert_eq!(Response::decode(&altered).unwrap().message, ack());
    }

    #[test]
    fn unknown_type_keeps_everything_else() {
        let faults = Faults {
            unknown_type: true,
            ..Faults::default()
        };
        let body = encode(&ack());
        let altered = alter_body(&body, &faults);
        assert_eq!(
            text(&altered),
            text(&body).replace("<Type>1004</Type>", "<Type>2102</Type>")
        );
    }

    #[test]
    fn unknown_pose_writes_nan_and_the_panel_reads_the_rest() {
        let status = RobotStatus {
            pos_x: 1.5,
            roll: 0.25,
            electricity: Some(87),
            ..RobotStatus::UNAVAILABLE
        };
        let faults = Faults {
            unknown_pose: true,
            ..Faults::default()
        };
        let altered = alter_body(&encode(&Response::Status(status)), &faults);
        let xml = text(&altered);
        for name in UNKNOWN_POSE_ITEMS {
            assert!(
                xml.contains(&format!("<{name}>nan</{name}>")),
                "{name} in\n{xml}"
            );
        }
        let Response::Status(read) = Response::decode(&altered).unwrap().message else {
            panic!("{xml}");
        };
        assert!(read.pos_x.is_nan() && read.roll.is_nan() && read.yaw.is_nan());
        assert_eq!(read.electricity, Some(87));
        // Answers without a pose are left as they are.
        assert_eq!(alter_body(&encode(&ack()), &faults), encode(&ack()));
    }

    #[test]
    fn sparse_status_keeps_motion_state_alone_and_the_panel_reads_it() {
        let status = RobotStatus {
            motion_state: MotionState::SoftEmergencyStop,
            electricity: Some(87),
            ..RobotStatus::UNAVAILABLE
        };
        let faults = Faults {
            sparse_status: true,
            unknown_items: true,
            ..Faults::default()
        };
        let altered = alter_body(&encode(&Response::Status(status)), &faults);
        let xml = text(&altered);
        assert!(xml.contains("    <MotionState>6</MotionState>\n"), "{xml}");
        assert!(
            !xml.contains("Electricity") && !xml.contains("<PosX>"),
            "{xml}"
        );
        assert!(xml.contains("<RTKState>"), "the extra items stay: {xml}");
        let Response::Status(read) = Response::decode(&altered).unwrap().message else {
            panic!("{xml}");
        };
        assert_eq!(read.motion_state, MotionState::SoftEmergencyStop);
        assert_eq!((read.electricity, read.gait_state), (None, None));
        // Other answers are left as they are.
        let only_sparse = Faults {
            sparse_status: true,
            ..Faults::default()
        };
        assert_eq!(alter_body(&encode(&ack()), &only_sparse), encode(&ack()));
    }

    #[test]
    fn items_left_out_are_missing_from_every_answer_and_the_panel_reads_the_rest() {
        let faults = Faults {
            leave_out: vec![
                "BatteryLevel".into(),
                "Voltage".into(),
                "Electricity".into(),
            ],
            ..Faults::default()
        };
        let altered = alter_body(&encode(&Response::Battery(battery())), &faults);
        let xml = text(&altered);
        assert!(
            !xml.contains("BatteryLevel") && !xml.contains("Voltage"),
            "{xml}"
        );
        assert_eq!(
            Response::decode(&altered).unwrap().message,
            Response::Battery(Battery {
                battery_level: None,
                voltage: None,
                ..battery()
            })
        );
        let status = RobotStatus {
            electricity: Some(87),
            ..RobotStatus::UNAVAILABLE
        };
        let altered = alter_body(&encode(&Response::Status(status)), &faults);
        let Response::Status(read) = Response::decode(&altered).unwrap().message else {
            panic!("{}", text(&altered));
        };
        assert_eq!(
            read,
            RobotStatus {
                electricity: None,
                ..status
            }
        );
        // An answer without those items is left as it is.
        assert_eq!(alter_body(&encode(&ack()), &faults), encode(&ack()));
    }

    #[test]
    fn decimal_comma_writes_the_items_floats_with_commas_and_the_panel_reads_the_rest() {
        let status = RobotStatus {
            motion_state: MotionState::SoftEmergencyStop,
            pos_x: 12.5,
            electricity: Some(87),
            ..RobotStatus::UNAVAILABLE
        };
        let faults = Faults {
            decimal_comma: true,
            unknown_items: true,
            ..Faults::default()
        };
        let altered = alter_body(&encode(&Response::Status(status)), &faults);
        let xml = text(&altered);
        assert!(xml.contains("<PosX>12,5</PosX>"), "{xml}");
        assert!(xml.contains("<AngleYaw>-0,00023393621</AngleYaw>"), "{xml}");
        assert!(
            xml.contains("<?xml version=\"1.0\""),
            "the declaration keeps its point"
        );
        let Response::Status(read) = Response::decode(&altered).unwrap().message else {
            panic!("{xml}");
        };
        assert_eq!(read.motion_state, MotionState::SoftEmergencyStop);
        assert!(read.pos_x.is_nan(), "a float with a comma is not reported");
        assert_eq!(read.electricity, Some(87));
    }

    #[test]
    fn type_delays_add_to_the_delay_and_the_last_pair_counts() {
        let faults = Faults {
            delay: Duration::from_millis(10),
            type_delays: vec![
                (1002, Duration::from_millis(100)),
                (1002, Duration::from_millis(200)),
                (0, Duration::from_millis(5)),
            ],
            ..Faults::default()
        };
        assert_eq!(faults.delay_for(1002), Duration::from_millis(210));
        assert_eq!(faults.delay_for(0), Duration::from_millis(15));
        assert_eq!(faults.delay_for(2001), Duration::from_millis(10));
    }

    #[test]
    fn refusal_ends_at_its_moment() {
        let now = Instant::now();
        let later = now + Duration::from_secs(1);
        let faults = Faults {
            refuse_connections_until: Some(later),
            ..Faults::default()
        };
        assert!(faults.refuses_connections(now));
        assert!(!faults.refuses_connections(later));
        assert!(!Faults::default().refuses_connections(now));
    }

    #[test]
    fn reserved_bytes_fill_the_header_and_only_with_the_fault() {
        use x30_panel::proto::frame::{self, FrameDecoder, FrameError, Reserved};
        let mut bytes = vec![0; HEADER_LEN + 3];
        frame::encode(&mut bytes, 7, b"abc").expect("frame");
        let plain = bytes.clone();
        alter_header(&mut bytes, &Faults::default());
        assert_eq!(bytes, plain);
        let faults = Faults {
            reserved_bytes: true,
            ..Faults::default()
        };
        alter_header(&mut bytes, &faults);
        assert_eq!(bytes[..8], plain[..8]);
        assert_eq!(bytes[8..HEADER_LEN], RESERVED_BYTES);
        assert_eq!(bytes[HEADER_LEN..], *b"abc");
        // A client's decoder reads the frame; the robot's refuses it.
        let mut client = FrameDecoder::<64>::new().reserved(Reserved::Ignore);
        client.feed(&bytes);
        let frame = client.decode().expect("a frame").expect("read");
        assert_eq!((frame.message_id, frame.asdu), (7, &b"abc"[..]));
        let mut robot = FrameDecoder::<64>::new();
        robot.feed(&bytes);
        assert_eq!(
            robot.decode(),
            Some(Err(FrameError::BadReserved { message_id: 7 }))
        );
    }

    #[test]
    fn an_empty_frame_with_the_same_message_id_precedes_each_frame() {
        let faults = Faults {
            empty_frames: true,
            ..Faults::default()
        };
        let mut frame = vec![0; HEADER_LEN + 2];
        let n = x30_panel::proto::frame::encode(&mut frame, 0x1234, b"AB").unwrap();
        let bytes = wire_bytes(&[frame[..n].to_vec()], &faults);
        let mut empty = vec![0; HEADER_LEN];
        x30_panel::proto::frame::encode(&mut empty, 0x1234, &[]).unwrap();
        assert_eq!(bytes, [&empty[..], &frame[..n]].concat());
    }

    /// A copy cut short comes before each frame, and a client's decoder reports it as cut
    /// short and still reads the frame after it.
    #[test]
    fn a_copy_cut_short_precedes_each_frame_and_the_frame_is_still_read() {
        use x30_panel::proto::frame::{self, FrameDecoder, FrameError, Reserved};
        let faults = Faults {
            cut_frames: true,
            ..Faults::default()
        };
        let mut whole = vec![0; HEADER_LEN + 10];
        frame::encode(&mut whole, 0x1234, b"<answer/>\n").expect("frame");
        let bytes = wire_bytes(&[whole.clone(), whole.clone()], &faults);
        assert_eq!(bytes.len(), 2 * (2 * HEADER_LEN + 15));
        let mut client = FrameDecoder::<256>::new().reserved(Reserved::Ignore);
        assert_eq!(client.feed(&bytes), bytes.len());
        for _ in 0..2 {
            assert_eq!(
                client.decode(),
                Some(Err(FrameError::CutShort {
                    message_id: 0x1234,
                    asdu_len: 10,
                    received: 5
                }))
            );
            let frame = client.decode().expect("a frame").expect("read");
            assert_eq!(
                (frame.message_id, frame.asdu),
                (0x1234, &b"<answer/>\n"[..])
            );
        }
    }

    #[test]
    fn garbage_precedes_each_frame_and_holds_no_sync() {
        assert!(!GARBAGE.windows(4).any(|w| w == [0xEB, 0x90, 0xEB, 0x90]));
        let faults = Faults {
            garbage: true,
            ..Faults::default()
        };
        let bytes = wire_bytes(&[b"AB".to_vec(), b"CD".to_vec()], &faults);
        assert_eq!(bytes, [GARBAGE, b"AB", GARBAGE, b"CD"].concat());
    }
}
