//! `/api/status`: the panel's [`Snapshot`] as JSON.
//!
//! ```text
//! {"connection":{"state":"connected","robot":"192.168.1.106:30000","board":"10.0.2.15"},
//!  "status":{"MotionState":1,"PosX":1.5,…,"age_ms":120,"stale":false,"unavailable":false,
//!            "text":{"MotionState":"standing up",…}},
//!  "battery":{…},"motors":{…},"obstacle":{…},"nav":null,
//!  "leds":{"link":"on","activity":"off","fault":"blink"},
//!  "faults":["battery low"],"busy":null}
//! ```
//!
//! `status`, `battery`, `motors`, `obstacle` and `nav` hold the latest 1002, 2001, 1008, 2002
//! and 1007 answers, however old, each item under its protocol name with its value as
//! received (codes as their numbers, an absent optional item as `null`), or are `null`
//! before the first answer. With them: `age_ms`, how long ago the answer came; `stale`,
//! whether it is as old as the panel's own rule allows no more ([`STALE_AFTER_POLLS`] of its
//! poll period: the LEDs no longer count it either); and `text`, the coded items in words.
//! Floats are written in their shortest exact form; one that is not finite, which JSON
//! cannot hold, as `null`.
//!
//! [`STALE_AFTER_POLLS`]: crate::panel::monitor::STALE_AFTER_POLLS

use core::fmt::{self, Write};

use embassy_time::{Duration, Instant};

use crate::app::Snapshot;
use crate::panel::indicators::LinkState;
use crate::panel::monitor::{Stamped, stale_limit};
use crate::proto::codes::reported_description;
use crate::proto::message::items::{ItemSet, Kind, MAX_ITEMS, Present, Table};
use crate::proto::message::{Battery, MotorTemperatures, NavTaskState, Perception, RobotStatus};
use crate::proto::xml::number::F32_TEXT_MAX;
use crate::settings::write_f32;

/// Longest JSON [`write_status`] writes, bytes: every item at its longest text, plus
/// an allowance for the rest. A buffer this long never cuts the answer short.
pub const STATUS_MAX: usize = items_max(RobotStatus::TABLE)
    + items_max(Battery::TABLE)
    + items_max(MotorTemperatures::TABLE)
    + items_max(Perception::TABLE)
    + items_max(NavTaskState::TABLE)
    + words_max(RobotStatus::WORDS.len())
    + words_max(Battery::WORDS.len())
    + words_max(MotorTemperatures::WORDS.len())
    + words_max(Perception::WORDS.len())
    + words_max(NavTaskState::WORDS.len())
    + FRAME_MAX;

/// Longest description of a code the page shows in words (`text`), bytes.
pub const WORD_MAX: usize = 64;

/// Everything [`STATUS_MAX`] does not count item by item: the keys of the top level and of
/// the connection, the addresses, five answers' `age_ms`, `stale`, `unavailable` and
/// `text` braces, the LEDs, every fault at once, and why the panel is busy.
const FRAME_MAX: usize = 1024;

/// Longest text of one item: its quoted name, a colon, the value, a comma.
const fn items_max(table: &Table) -> usize {
    let mut total = 0;
    let mut index = 0;
    while let Some(item) = table.item(index) {
        let value = match item.kind {
            Kind::Float => F32_TEXT_MAX,
            // "-2147483648"
            Kind::Int | Kind::Byte => 11,
        };
        total += item.name.as_bytes().len() + 4 + value;
        index += 1;
    }
    total
}

/// Longest text of `count` words: each a quoted item name (none longer than 20 bytes), a
/// colon, a quoted description, a comma.
const fn words_max(count: usize) -> usize {
    count * (20 + WORD_MAX + 6)
}

/// Writes the JSON of `/api/status` for `snapshot` (`None`: the panel is starting) at `now`.
pub fn write_status(
    snapshot: Option<&Snapshot>,
    now: Instant,
    out: &mut impl fmt::Write,
) -> fmt::Result {
    status(snapshot, now, out)
}

/// [`write_status`], one copy whatever the writer.
fn status(snapshot: Option<&Snapshot>, now: Instant, out: &mut dyn Write) -> fmt::Result {
    let state = snapshot.map_or("starting", |s| match s.link {
        LinkState::NoNetwork => "no-network",
        LinkState::Connecting => "connecting",
        LinkState::NotAnswering => "not-answering",
        LinkState::Connected => "connected",
    });
    write!(out, "{{\"connection\":{{\"state\":\"{state}\",\"robot\":")?;
    match snapshot {
        Some(s) => {
            let [a, b, c, d] = s.robot.ip;
            write!(out, "\"{a}.{b}.{c}.{d}:{}\"", s.robot.port)?;
        }
        None => out.write_str("null")?,
    }
    out.write_str(",\"board\":")?;
    match snapshot.and_then(|s| s.board_address) {
        Some(cidr) => {
            let [a, b, c, d] = cidr.address;
            write!(out, "\"{a}.{b}.{c}.{d}\"")?;
        }
        None => out.write_str("null")?,
    }
    out.write_char('}')?;
    let polls = snapshot.map(|s| s.polls);
    answer(
        out,
        now,
        "status",
        snapshot.and_then(|s| s.status),
        polls.map(|p| p.status),
    )?;
    answer(
        out,
        now,
        "battery",
        snapshot.and_then(|s| s.battery),
        polls.map(|p| p.battery),
    )?;
    let period = polls.map(|p| p.motor_temperatures);
    answer(out, now, "motors", snapshot.and_then(|s| s.motors), period)?;
    let period = polls.map(|p| p.status);
    answer(
        out,
        now,
        "obstacle",
        snapshot.and_then(|s| s.perception),
        period,
    )?;
    answer(
        out,
        now,
        "nav",
        snapshot.and_then(|s| s.nav),
        polls.map(|p| p.nav_status),
    )?;
    out.write_str(",\"leds\":")?;
    match snapshot.map(|s| s.leds) {
        Some(leds) => write!(
            out,
            "{{\"link\":\"{}\",\"activity\":\"{}\",\"fault\":\"{}\"}}",
            leds.link.name(),
            leds.activity.name(),
            leds.fault.name()
        )?,
        None => out.write_str("null")?,
    }
    out.write_str(",\"faults\":[")?;
    if let Some(s) = snapshot {
        let failed = s.command_failed.then_some("the last command failed");
        let faults = s.faults.iter().map(|f| f.description()).chain(failed);
        for (i, fault) in faults.enumerate() {
            if i > 0 {
                out.write_char(',')?;
            }
            string(out, fault)?;
        }
    }
    out.write_str("],\"busy\":")?;
    match snapshot.and_then(|s| s.busy) {
        Some(busy) => string(out, busy.description())?,
        None => out.write_str("null")?,
    }
    out.write_char('}')
}

/// Writes `,"name":` and `answer` as an object, or `null` when there is none; it is stale
/// from [`STALE_AFTER_POLLS`](crate::panel::monitor::STALE_AFTER_POLLS) of its poll `period`
/// on, as the panel counts it.
fn answer<T: Shown>(
    out: &mut dyn Write,
    now: Instant,
    name: &str,
    answer: Option<Stamped<T>>,
    period: Option<Duration>,
) -> fmt::Result {
    write!(out, ",\"{name}\":")?;
    let (Some(answer), Some(period)) = (answer, period) else {
        return out.write_str("null");
    };
    let age = now.saturating_duration_since(answer.at);
    let value = &answer.value;
    let words = &mut T::WORDS.iter().map(|&(item, word)| (item, word(value)));
    let facts = Facts {
        age_ms: age.as_millis(),
        stale: age >= stale_limit(period),
        unavailable: value.unavailable(),
    };
    let mut values = [0; MAX_ITEMS];
    let present = value.to_values(&mut values);
    object(out, T::TABLE, &values, present, facts, words)
}

/// What an answer's object tells besides its items.
struct Facts {
    /// How long ago it came.
    age_ms: u64,
    /// Whether it is too old to count.
    stale: bool,
    /// Whether it says the robot could not tell, for answers that can.
    unavailable: Option<bool>,
}

/// Writes one answer's object: `values` under the names of `table` (`null` where not
/// `present`), then `facts`, then `words` as `text`.
// One copy serves every answer.
#[inline(never)]
fn object(
    out: &mut dyn Write,
    table: &Table,
    values: &[u32],
    present: Present,
    facts: Facts,
    words: &mut dyn Iterator<Item = (&'static str, &'static str)>,
) -> fmt::Result {
    out.write_char('{')?;
    for (index, &bits) in values.iter().enumerate() {
        let Some(item) = table.item(index) else {
            break;
        };
        write!(out, "\"{}\":", item.name)?;
        match item.kind {
            _ if present >> index & 1 == 0 => out.write_str("null")?,
            Kind::Float => float(out, f32::from_bits(bits))?,
            Kind::Int | Kind::Byte => write!(out, "{}", bits as i32)?,
        }
        out.write_char(',')?;
    }
    write!(out, "\"age_ms\":{},\"stale\":{}", facts.age_ms, facts.stale)?;
    if let Some(unavailable) = facts.unavailable {
        write!(out, ",\"unavailable\":{unavailable}")?;
    }
    out.write_str(",\"text\":{")?;
    for (i, (item, word)) in words.enumerate() {
        if i > 0 {
            out.write_char(',')?;
        }
        write!(out, "\"{item}\":")?;
        string(out, word)?;
    }
    out.write_str("}}")
}

/// Writes `value` in its shortest exact form, or `null` if it is NaN or infinite.
fn float(mut out: &mut dyn Write, value: f32) -> fmt::Result {
    if value.is_finite() {
        write_f32(&mut out, value)
    } else {
        out.write_str("null")
    }
}

/// Writes `text` as a JSON string.
fn string(out: &mut dyn Write, text: &str) -> fmt::Result {
    out.write_char('"')?;
    for c in text.chars() {
        match c {
            '"' => out.write_str("\\\"")?,
            '\\' => out.write_str("\\\\")?,
            c if c.is_control() => write!(out, "\\u{:04x}", u32::from(c))?,
            c => out.write_char(c)?,
        }
    }
    out.write_char('"')
}

/// A coded item's name, and how to put its value in words.
type Word<T> = (&'static str, fn(&T) -> &'static str);

/// An answer the page shows: its items, and its coded items in words.
trait Shown: ItemSet + 'static {
    /// Each coded item's name, and its value in words.
    const WORDS: &'static [Word<Self>];

    /// Whether the answer says the robot could not tell; `None` for answers that cannot.
    fn unavailable(&self) -> Option<bool> {
        None
    }
}

impl Shown for RobotStatus {
    const WORDS: &'static [Word<Self>] = &[
        ("MotionState", |s| s.motion_state.description()),
        ("Location", |s| reported_description(s.location)),
        ("GaitState", |s| reported_description(s.gait_state)),
        ("MotorState", |s| reported_description(s.motor_state)),
        ("ChargeState", |s| reported_description(s.charge_state)),
        ("ControlMode", |s| reported_description(s.control_mode)),
        ("OnDockState", |s| reported_description(s.on_dock_state)),
    ];

    /// The all-zero status the robot sends when it cannot read its own.
    fn unavailable(&self) -> Option<bool> {
        Some(self.is_unavailable())
    }
}

impl Shown for Battery {
    const WORDS: &'static [Word<Self>] = &[("ProtectedState", |b| {
        reported_description(b.protected_state)
    })];
}

impl Shown for MotorTemperatures {
    const WORDS: &'static [Word<Self>] = &[];
}

impl Shown for Perception {
    const WORDS: &'static [Word<Self>] = &[("ObsState", |p| p.obs_state.description())];
}

impl Shown for NavTaskState {
    const WORDS: &'static [Word<Self>] = &[("Status", |n| n.status.description())];
}
