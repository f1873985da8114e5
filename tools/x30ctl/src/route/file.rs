//! Route files: the format of the vendor SDK's `default_navigation_points.json`, a JSON
//! array of points, each an object whose keys are the fourteen items of a 1003 request.
//!
//! Reading is strict, because a route drives a robot: every key must be one of the items,
//! every item must be there once, integers must be integers, codes must be ones protocol
//! V1.0.12 defines, and each point must pass `NavPoint::validate`. Every problem in the
//! file is reported (with the point's position, its `Value` and the item), and a file with
//! any problem is refused whole, so nothing is sent.
//!
//! Floats are parsed from their own text straight to `f32` (serde_json's `RawValue` keeps
//! the text), never through `f64`: going through `f64` rounds twice and can land on the
//! neighbouring `f32`. Written files use the shortest text that reads back as the same
//! `f32`, so a file survives reading and writing unchanged in value.

use std::fmt;
use std::path::Path;

use clap::ValueEnum;
use serde::Serialize;
use serde::de::{Deserializer, MapAccess, Visitor};
use serde_json::value::RawValue;
use x30_panel::proto::codes::{
    Code, Manner, NavGait, NavMode, NavSpeed, ObsMode, PointInfo, Posture, Terrain,
};
use x30_panel::proto::message::{NavPoint, ValidationError};

use crate::cli::{
    MannerArg, NavGaitArg, NavModeArg, NavSpeedArg, ObsModeArg, PointArg, PostureArg, TerrainArg,
};
use crate::error::Error;

/// The item keys, in the order the vendor's file has them (alphabetical), which is the
/// order written.
pub const ITEMS: [&str; 14] = [
    "AngleYaw",
    "Gait",
    "Manner",
    "MapID",
    "NavMode",
    "ObsMode",
    "PointInfo",
    "PosX",
    "PosY",
    "PosZ",
    "Posture",
    "Speed",
    "Terrain",
    "Value",
];

/// Most problems listed for one file; a file that is wrong throughout says so quickly.
const MAX_PROBLEMS: usize = 20;

/// One thing wrong with a route file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    /// The point's position in the file, from 1; `None` for the file as a whole.
    pub index: Option<usize>,
    /// The point's `Value`, when it could be read.
    pub value: Option<i32>,
    /// The item (key) concerned, if one is.
    pub item: Option<String>,
    /// What is wrong.
    pub what: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(index) = self.index {
            write!(f, "point {index} ")?;
            match self.value {
                Some(value) => write!(f, "(Value {value})")?,
                None => f.write_str("(no readable Value)")?,
            }
            match &self.item {
                Some(item) => write!(f, ", {item}: ")?,
                None => f.write_str(": ")?,
            }
        }
        f.write_str(&self.what)
    }
}

/// Reads and checks a route file; any problem is a usage error naming the file and listing
/// the problems.
pub fn load(path: &Path) -> Result<Vec<NavPoint>, Error> {
    let shown = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| {
        Error::Usage(format!(
            "cannot read route file {shown}: {}; nothing sent",
            crate::error::io_text(&e)
        ))
    })?;
    parse(&text).map_err(|problems| {
        let message = match problems.as_slice() {
            [one] => format!("route file {shown}: {one}; nothing sent"),
            many => {
                let mut message =
                    format!("route file {shown}: {} problems; nothing sent", many.len());
                for problem in many {
                    message.push_str(&format!("\n  {problem}"));
                }
                if many.len() >= MAX_PROBLEMS {
                    message.push_str("\n  (and maybe more)");
                }
                message
            }
        };
        Error::Usage(message)
    })
}

/// Parses a route file's text into checked points, or lists what is wrong with it (at most
/// [`MAX_PROBLEMS`]).
pub fn parse(text: &str) -> Result<Vec<NavPoint>, Vec<Problem>> {
    let whole = |what: String| {
        vec![Problem {
            index: None,
            value: None,
            item: None,
            what,
        }]
    };
    let raw: &RawValue =
        serde_json::from_str(text).map_err(|e| whole(format!("not valid JSON: {e}")))?;
    if kind(raw) != Kind::Array {
        return Err(whole(format!(
            "expected a JSON array of points, found {}",
            kind(raw).name()
        )));
    }
    let elements: Vec<&RawValue> = serde_json::from_str(raw.get())
        .map_err(|e| whole(format!("not a JSON array of points: {e}")))?;
    if elements.is_empty() {
        return Err(whole("the array holds no points".to_owned()));
    }
    let mut points = Vec::with_capacity(elements.len());
    let mut problems = Vec::new();
    for (at, element) in elements.iter().enumerate() {
        match point(element) {
            Ok(p) => points.push(p),
            Err(found) => problems.extend(found.into_iter().map(|(value, item, what)| Problem {
                index: Some(at + 1),
                value,
                item,
                what,
            })),
        }
        if problems.len() >= MAX_PROBLEMS {
            problems.truncate(MAX_PROBLEMS);
            break;
        }
    }
    if problems.is_empty() {
        Ok(points)
    } else {
        Err(problems)
    }
}

/// A problem within one point: its `Value` if readable, the item, what is wrong.
type PointProblem = (Option<i32>, Option<String>, String);

/// One point from its JSON object, or everything wrong with it.
fn point(raw: &RawValue) -> Result<NavPoint, Vec<PointProblem>> {
    let found = kind(raw);
    if found != Kind::Object {
        return Err(vec![(
            None,
            None,
            format!(
                "expected an object with the 14 items, found {}",
                found.name()
            ),
        )]);
    }
    let Ok(Fields(fields)) = serde_json::from_str::<Fields<'_>>(raw.get()) else {
        // The text was checked as JSON and as an object already.
        return Err(vec![(None, None, "not a JSON object".to_owned())]);
    };
    let text = |item: &str| fields.iter().find(|(k, _)| k == item).map(|(_, v)| *v);
    let value = text("Value").and_then(|t| int(t).ok());
    let mut problems: Vec<PointProblem> = Vec::new();
    let mut problem = |item: Option<&str>, what: String| {
        problems.push((value, item.map(str::to_owned), what));
    };

    for (at, (key, _)) in fields.iter().enumerate() {
        if fields[..at].iter().any(|(k, _)| k == key) {
            problem(Some(key), "appears more than once".to_owned());
        } else if !ITEMS.contains(&key.as_str()) {
            match ITEMS.iter().find(|item| item.eq_ignore_ascii_case(key)) {
                Some(item) => problem(
                    None,
                    format!("unknown key \"{key}\" (keys are case-sensitive: \"{item}\")"),
                ),
                None => problem(
                    None,
                    format!("unknown key \"{key}\" (the keys are {})", ITEMS.join(", ")),
                ),
            }
        }
    }
    let missing: Vec<&str> = ITEMS
        .iter()
        .copied()
        .filter(|item| text(item).is_none())
        .collect();
    if !missing.is_empty() {
        problem(
            None,
            format!(
                "missing item{} {}",
                if missing.len() == 1 { "" } else { "s" },
                missing.join(", ")
            ),
        );
    }

    // Each present item is read even when others are wrong, so that every problem shows.
    let mut read = |item: &'static str, parse: fn(&RawValue) -> Result<Item, String>| {
        let raw = text(item)?;
        parse(raw).map_err(|what| problem(Some(item), what)).ok()
    };
    let items = (
        read("Value", |t| int(t).map(Item::Int)),
        read("MapID", |t| int(t).map(Item::Int)),
        read("PosX", |t| float(t).map(Item::Float)),
        read("PosY", |t| float(t).map(Item::Float)),
        read("PosZ", |t| float(t).map(Item::Float)),
        read("AngleYaw", |t| float(t).map(Item::Float)),
        read("PointInfo", |t| {
            code::<PointArg, PointInfo>(t).map(Item::Code)
        }),
        read("Gait", |t| code::<NavGaitArg, NavGait>(t).map(Item::Code)),
        read("Speed", |t| {
            code::<NavSpeedArg, NavSpeed>(t).map(Item::Code)
        }),
        read("Manner", |t| code::<MannerArg, Manner>(t).map(Item::Code)),
        read("ObsMode", |t| {
            code::<ObsModeArg, ObsMode>(t).map(Item::Code)
        }),
        read("NavMode", |t| {
            code::<NavModeArg, NavMode>(t).map(Item::Code)
        }),
        read("Terrain", |t| {
            code::<TerrainArg, Terrain>(t).map(Item::Code)
        }),
        read("Posture", |t| {
            code::<PostureArg, Posture>(t).map(Item::Code)
        }),
    );
    let (
        Some(Item::Int(value)),
        Some(Item::Int(map_id)),
        Some(Item::Float(pos_x)),
        Some(Item::Float(pos_y)),
        Some(Item::Float(pos_z)),
        Some(Item::Float(angle_yaw)),
        Some(Item::Code(point_info)),
        Some(Item::Code(gait)),
        Some(Item::Code(speed)),
        Some(Item::Code(manner)),
        Some(Item::Code(obs_mode)),
        Some(Item::Code(nav_mode)),
        Some(Item::Code(terrain)),
        Some(Item::Code(posture)),
    ) = items
    else {
        return Err(problems);
    };
    if !problems.is_empty() {
        return Err(problems);
    }
    let point = NavPoint {
        value,
        map_id,
        pos_x,
        pos_y,
        pos_z,
        angle_yaw,
        point_info: point_info.into(),
        gait: gait.into(),
        speed: speed.into(),
        manner: manner.into(),
        obs_mode: obs_mode.into(),
        nav_mode: nav_mode.into(),
        terrain: terrain.into(),
        posture: posture.into(),
    };
    match point.validate() {
        Ok(()) => Ok(point),
        Err(e) => {
            let (item, what) = rule_text(&point, &e);
            Err(vec![(Some(value), Some(item.to_owned()), what)])
        }
    }
}

/// A read item: the three kinds of value a point holds.
#[derive(Debug, Clone, Copy)]
enum Item {
    Int(i32),
    Float(f32),
    /// A code's raw number, known to be one the protocol defines.
    Code(i32),
}

/// The item and the words for a point that breaks one of the document's rules.
fn rule_text(p: &NavPoint, e: &ValidationError) -> (&'static str, String) {
    match e {
        ValidationError::GaitNotAllowedOnTerrain => (
            "Gait",
            format!(
                "{} is not allowed on Terrain {}: only {} and {}",
                code_label::<NavGaitArg, _>(p.gait),
                code_label::<TerrainArg, _>(p.terrain),
                code_label::<NavGaitArg, _>(NavGait::AccumulatedFrameStairs),
                code_label::<NavGaitArg, _>(NavGait::AccumulatedFrameStairs45),
            ),
        ),
        ValidationError::GaitNotAllowedWhenCrouched => (
            "Gait",
            format!(
                "{} is not allowed with Posture {}: only {} and {}",
                code_label::<NavGaitArg, _>(p.gait),
                code_label::<PostureArg, _>(p.posture),
                code_label::<NavGaitArg, _>(NavGait::Walk),
                code_label::<NavGaitArg, _>(NavGait::Slope),
            ),
        ),
        ValidationError::UnknownCode { item } | ValidationError::NotFinite { item } => {
            (*item, crate::render::validation_error_text(e))
        }
        other => ("Value", crate::render::validation_error_text(other)),
    }
}

/// What a JSON value is, from its first character.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Object,
    Array,
    String,
    Number,
    Boolean,
    Null,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Self::Object => "an object",
            Self::Array => "an array",
            Self::String => "a string",
            Self::Number => "a number",
            Self::Boolean => "true or false",
            Self::Null => "null",
        }
    }
}

/// The kind of a raw value; serde_json has checked its syntax, so the first character
/// decides.
fn kind(raw: &RawValue) -> Kind {
    match raw.get().trim_start().as_bytes().first() {
        Some(b'{') => Kind::Object,
        Some(b'[') => Kind::Array,
        Some(b'"') => Kind::String,
        Some(b't' | b'f') => Kind::Boolean,
        Some(b'n') => Kind::Null,
        _ => Kind::Number,
    }
}

/// A number's text, or what the value is instead.
fn number<'a>(raw: &'a RawValue, expected: &str) -> Result<&'a str, String> {
    match kind(raw) {
        Kind::Number => Ok(raw.get().trim()),
        other => Err(format!(
            "expected {expected}, found {} ({})",
            other.name(),
            raw.get()
        )),
    }
}

/// An integer item: a JSON number without fraction or exponent that fits 32 bits.
fn int(raw: &RawValue) -> Result<i32, String> {
    let text = number(raw, "an integer")?;
    if text.contains(['.', 'e', 'E']) {
        return Err(format!("expected an integer, found {text}"));
    }
    text.parse::<i32>()
        .map_err(|_| format!("{text} does not fit a 32-bit integer"))
}

/// A float item, read from its own text straight to the nearest `f32`.
fn float(raw: &RawValue) -> Result<f32, String> {
    let text = number(raw, "a number")?;
    match text.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        // JSON has no infinities; only a number beyond f32's range gets here.
        _ => Err(format!(
            "{text} is beyond the range of a 32-bit float (not a finite number)"
        )),
    }
}

/// A coded item: an integer that is one of the codes the protocol defines for it, which are
/// exactly the values of its command-line enum `A`.
fn code<A, C>(raw: &RawValue) -> Result<i32, String>
where
    A: ValueEnum + Copy + Into<C>,
    C: Code,
{
    let value = int(raw)?;
    let choices = choices::<A, C>();
    if choices.iter().any(|(code, _)| *code == value) {
        return Ok(value);
    }
    let listed: Vec<String> = choices
        .iter()
        .map(|(code, name)| format!("{code} {name}"))
        .collect();
    Err(format!(
        "{value} is not a code protocol V1.0.12 defines (it defines {})",
        listed.join(", ")
    ))
}

/// A coded item's codes with the command line's names for them.
fn choices<A, C>() -> Vec<(i32, String)>
where
    A: ValueEnum + Copy + Into<C>,
    C: Code,
{
    A::value_variants()
        .iter()
        .filter_map(|&v| {
            let name = v.to_possible_value()?.get_name().to_owned();
            Some((v.into().raw(), name))
        })
        .collect()
}

/// `3 (charging)`: a code with the command line's name for it.
pub fn code_label<A, C>(value: C) -> String
where
    A: ValueEnum + Copy + Into<C>,
    C: Code,
{
    let raw = value.raw();
    match choices::<A, C>().into_iter().find(|(code, _)| *code == raw) {
        Some((_, name)) => format!("{raw} ({name})"),
        None => raw.to_string(),
    }
}

/// An object's members in file order, duplicates kept, values as their raw text.
struct Fields<'a>(Vec<(String, &'a RawValue)>);

impl<'de: 'a, 'a> serde::Deserialize<'de> for Fields<'a> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Members;

        impl<'de> Visitor<'de> for Members {
            type Value = Fields<'de>;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a JSON object")
            }

            fn visit_map<M: MapAccess<'de>>(self, mut map: M) -> Result<Fields<'de>, M::Error> {
                let mut fields = Vec::new();
                while let Some(entry) = map.next_entry::<String, &'de RawValue>()? {
                    fields.push(entry);
                }
                Ok(Fields(fields))
            }
        }

        deserializer.deserialize_map(Members)
    }
}

/// One point as written: the items by their keys, in the vendor file's order.
#[derive(Serialize)]
struct FilePoint {
    #[serde(rename = "AngleYaw")]
    angle_yaw: f32,
    #[serde(rename = "Gait")]
    gait: i32,
    #[serde(rename = "Manner")]
    manner: i32,
    #[serde(rename = "MapID")]
    map_id: i32,
    #[serde(rename = "NavMode")]
    nav_mode: i32,
    #[serde(rename = "ObsMode")]
    obs_mode: i32,
    #[serde(rename = "PointInfo")]
    point_info: i32,
    #[serde(rename = "PosX")]
    pos_x: f32,
    #[serde(rename = "PosY")]
    pos_y: f32,
    #[serde(rename = "PosZ")]
    pos_z: f32,
    #[serde(rename = "Posture")]
    posture: i32,
    #[serde(rename = "Speed")]
    speed: i32,
    #[serde(rename = "Terrain")]
    terrain: i32,
    #[serde(rename = "Value")]
    value: i32,
}

impl From<&NavPoint> for FilePoint {
    fn from(p: &NavPoint) -> Self {
        Self {
            angle_yaw: p.angle_yaw,
            gait: p.gait.raw(),
            manner: p.manner.raw(),
            map_id: p.map_id,
            nav_mode: p.nav_mode.raw(),
            obs_mode: p.obs_mode.raw(),
            point_info: p.point_info.raw(),
            pos_x: p.pos_x,
            pos_y: p.pos_y,
            pos_z: p.pos_z,
            posture: p.posture.raw(),
            speed: p.speed.raw(),
            terrain: p.terrain.raw(),
            value: p.value,
        }
    }
}

/// A route file's text: pretty-printed, keys in the vendor file's order, floats in their
/// shortest form that reads back as the same `f32`, a line break at the end.
pub fn to_text(points: &[NavPoint]) -> String {
    let points: Vec<FilePoint> = points.iter().map(FilePoint::from).collect();
    // Plain numbers always serialise; the empty array stands in for the impossible failure.
    let mut text = serde_json::to_string_pretty(&points).unwrap_or_else(|_| "[]".to_owned());
    text.push('\n');
    text
}

/// The points as an aligned table, one row per point, codes with their command-line names.
pub fn table(points: &[NavPoint]) -> String {
    let mut rows: Vec<Vec<String>> = vec![
        ["#", "Value", "MapID", "PosX", "PosY", "PosZ", "AngleYaw"]
            .iter()
            .chain(&[
                "PointInfo",
                "Gait",
                "Speed",
                "Manner",
                "ObsMode",
                "NavMode",
                "Terrain",
                "Posture",
            ])
            .map(|s| (*s).to_owned())
            .collect(),
    ];
    for (at, p) in points.iter().enumerate() {
        rows.push(vec![
            (at + 1).to_string(),
            p.value.to_string(),
            p.map_id.to_string(),
            p.pos_x.to_string(),
            p.pos_y.to_string(),
            p.pos_z.to_string(),
            p.angle_yaw.to_string(),
            code_label::<PointArg, _>(p.point_info),
            code_label::<NavGaitArg, _>(p.gait),
            code_label::<NavSpeedArg, _>(p.speed),
            code_label::<MannerArg, _>(p.manner),
            code_label::<ObsModeArg, _>(p.obs_mode),
            code_label::<NavModeArg, _>(p.nav_mode),
            code_label::<TerrainArg, _>(p.terrain),
            code_label::<PostureArg, _>(p.posture),
        ]);
    }
    let columns = rows[0].len();
    let widths: Vec<usize> = (0..columns)
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    rows.iter()
        .map(|row| {
            let cells: Vec<String> = row
                .iter()
                .zip(&widths)
                .map(|(cell, &width)| format!("{cell:<width$}"))
                .collect();
            cells.join("  ").trim_end().to_owned()
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vendor SDK's example route (see tests/data/README.md).
    const VENDOR: &str = include_str!("../../tests/data/default_navigation_points.json");

    /// Every float of the vendor file with its text: (point, item, text).
    fn vendor_float_texts() -> Vec<(usize, &'static str, &'static str)> {
        let points: Vec<Fields<'_>> = serde_json::from_str(VENDOR).expect("the vendor file");
        let mut texts = Vec::new();
        for (at, Fields(fields)) in points.into_iter().enumerate() {
            for (key, raw) in fields {
                let item = ITEMS.iter().find(|i| **i == key).expect("a known item");
                if matches!(*item, "PosX" | "PosY" | "PosZ" | "AngleYaw") {
                    let text: &'static str = raw.get();
                    texts.push((at, *item, text));
                }
            }
        }
        texts
    }

    fn float_of(p: &NavPoint, item: &str) -> f32 {
        match item {
            "PosX" => p.pos_x,
            "PosY" => p.pos_y,
            "PosZ" => p.pos_z,
            _ => p.angle_yaw,
        }
    }

    #[test]
    fn the_vendor_file_reads_exactly() {
        let points = parse(VENDOR).expect("the vendor file is valid");
        assert_eq!(points.len(), 4);
        let first = &points[0];
        assert_eq!((first.value, first.map_id), (1, 0));
        assert_eq!(first.point_info, PointInfo::Transition);
        assert_eq!(first.speed, NavSpeed::Low);
        assert_eq!(first.nav_mode, NavMode::Autonomous);
        assert_eq!(first.obs_mode, ObsMode::Enabled);
        assert_eq!(points[2].manner, Manner::Backwards);
        assert_eq!(points[3].point_info, PointInfo::Charging);
        assert!(points.iter().all(|p| p.gait == NavGait::Walk
            && p.terrain == Terrain::Solid
            && p.posture == Posture::Normal));
        let texts = vendor_float_texts();
        assert_eq!(texts.len(), 16);
        for (at, item, text) in texts {
            let value = float_of(&points[at], item);
            // The nearest f32 to the text, and its shortest form (which may have fewer
            // digits than the vendor's eight) reads back as itself.
            assert_eq!(
                value.to_bits(),
                text.parse::<f32>().unwrap().to_bits(),
                "{text}"
            );
            let shortest = value.to_string();
            assert!(
                shortest.len() <= text.len(),
                "point {} {item}: {shortest}",
                at + 1
            );
            assert_eq!(shortest.parse::<f32>().unwrap().to_bits(), value.to_bits());
        }
    }

    #[test]
    fn written_files_read_back_the_same() {
        let points = parse(VENDOR).unwrap();
        let text = to_text(&points);
        assert_eq!(parse(&text).unwrap(), points);
        // Same keys in the same order as the vendor's file.
        let keys: Vec<String> = serde_json::from_str::<Vec<Fields<'_>>>(&text).unwrap()[0]
            .0
            .iter()
            .map(|(k, _)| k.clone())
            .collect();
        assert_eq!(keys, ITEMS);
        assert!(
            text.starts_with("[\n  {\n    \"AngleYaw\": -0.06274342,\n"),
            "{text}"
        );
    }

    #[test]
    fn f32_from_text_not_through_f64() {
        // Halfway between two f32s as an f64 sees it, but just above it in full: going
        // through f64 rounds down to 1.0, the text itself rounds up.
        let text = "[{\"AngleYaw\":1.000000059604644775390625000001,\"Gait\":0,\"Manner\":0,\"MapID\":0,\"NavMode\":0,\"ObsMode\":0,\"PointInfo\":0,\"PosX\":0,\"PosY\":0,\"PosZ\":0,\"Posture\":0,\"Speed\":0,\"Terrain\":0,\"Value\":1}]";
        let via_f64 = "1.000000059604644775390625000001".parse::<f64>().unwrap() as f32;
        let points = parse(text).unwrap();
        assert_eq!(via_f64, 1.0);
        assert_eq!(points[0].angle_yaw, f32::from_bits(1.0f32.to_bits() + 1));
    }

    #[test]
    fn every_command_line_enum_covers_exactly_the_defined_codes() {
        fn check<A: ValueEnum + Copy + Into<C>, C: Code>(known: impl Fn(i32) -> bool) {
            let listed: Vec<i32> = choices::<A, C>().iter().map(|(c, _)| *c).collect();
            let defined: Vec<i32> = (-100..100).filter(|&raw| known(raw)).collect();
            assert_eq!(listed, defined, "{}", std::any::type_name::<C>());
        }
        check::<PointArg, PointInfo>(|r| PointInfo::from_raw(r).is_known());
        check::<NavGaitArg, NavGait>(|r| NavGait::from_raw(r).is_known());
        check::<NavSpeedArg, NavSpeed>(|r| NavSpeed::from_raw(r).is_known());
        check::<MannerArg, Manner>(|r| Manner::from_raw(r).is_known());
        check::<ObsModeArg, ObsMode>(|r| ObsMode::from_raw(r).is_known());
        check::<NavModeArg, NavMode>(|r| NavMode::from_raw(r).is_known());
        check::<TerrainArg, Terrain>(|r| Terrain::from_raw(r).is_known());
        check::<PostureArg, Posture>(|r| Posture::from_raw(r).is_known());
    }

    #[test]
    fn table_shows_every_item_with_names() {
        let table = table(&parse(VENDOR).unwrap());
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 5);
        assert!(lines[0].starts_with("#  Value  MapID  PosX"), "{table}");
        assert!(lines[1].contains("0.056386966"), "{table}");
        assert!(lines[1].contains("0 (transition)"), "{table}");
        assert!(lines[1].contains("1 (low)"), "{table}");
        assert!(lines[3].contains("1 (backwards)"), "{table}");
        assert!(lines[4].contains("3 (charging)"), "{table}");
    }
}
