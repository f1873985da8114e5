//! The request log: one entry per frame a client sent, kept in memory and optionally written
//! to a file as JSON lines. Navigation tasks add their progress to it (entries with an
//! `event` field, kept apart in memory): each waypoint the robot sets out for and how the
//! task ended, under the connection and message ID of the 1003 request.
//!
//! ```json
//! {"t":1.204,"conn":1,"id":3,"type":2,"command":1,"items":{"Value":-1.0}}
//! {"t":1.733,"conn":2,"id":0,"type":1003,"command":1,"items":{"Value":7,"MapID":1,...}}
//! {"t":1.733,"conn":2,"id":0,"event":"waypoint","index":1,"of":1,"value":7}
//! {"t":2.010,"conn":2,"id":9,"type":1234,"command":1,"error":"decode: UnknownType(1234)"}
//! {"t":9.751,"conn":2,"id":0,"event":"ended","reached":1,"of":1,"value":7,"error_code":0,"error_status":8960}
//! ```

use std::collections::VecDeque;
use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::Path;
use std::sync::Mutex;

use serde::Serialize;
use serde_json::{Map, Number, Value, json};
use x30_panel::proto::message::{MotionValue, NavPoint, Request};

use crate::robot::{ConnId, TaskEvent, TaskProgress};
use crate::server::lock;

/// Most entries kept in memory; older ones are dropped first, so a simulator left running
/// for days does not grow without bound. The file keeps every entry.
pub const MEMORY_LIMIT: usize = 100_000;

/// One frame a client sent.
///
/// Serialised (one JSON object per line) with the field names `t`, `conn`, `id`, `type`,
/// `command`, and either `items` or `error`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LogEntry {
    /// Real seconds since the simulator started.
    pub t: f64,
    /// The connection it arrived on (counted from 1).
    pub conn: ConnId,
    /// Its message ID; `None` (null) for bytes without a frame header.
    pub id: Option<u16>,
    /// Its Type, when the XML got that far.
    #[serde(rename = "type")]
    pub message_type: Option<i32>,
    /// Its Command, when the XML got that far.
    pub command: Option<i32>,
    /// The decoded items by their element names: an object, or for a 1003 request with
    /// several `<Items>` blocks an array of objects, one per waypoint. Absent for frames
    /// that failed to decode.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub items: Option<Value>,
    /// Why the frame could not be decoded, for frames that could not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The decoded request, for tests that would rather match on it (not serialised).
    #[serde(skip)]
    pub request: Option<Request>,
}

impl LogEntry {
    /// The entry for a request that decoded.
    pub fn request(t: f64, conn: ConnId, id: u16, request: &Request) -> Self {
        Self {
            t,
            conn,
            id: Some(id),
            message_type: Some(request.message_type().raw()),
            command: Some(request.command()),
            items: Some(items(request)),
            error: None,
            request: Some(request.clone()),
        }
    }

    /// The entry for a frame (or bytes) that did not decode.
    pub fn failure(
        t: f64,
        conn: ConnId,
        id: Option<u16>,
        envelope: Option<(i32, i32)>,
        error: String,
    ) -> Self {
        Self {
            t,
            conn,
            id,
            message_type: envelope.map(|(t, _)| t),
            command: envelope.map(|(_, c)| c),
            items: None,
            error: Some(error),
            request: None,
        }
    }

    /// The entry as one line of JSON, without the line break.
    pub fn to_json(&self) -> String {
        // Serialising plain numbers, strings and JSON values cannot fail.
        serde_json::to_string(self).unwrap_or_default()
    }
}

/// A navigation task's progress, as the log records it.
///
/// Serialised with the field names `t`, `conn`, `id` (those of the 1003 request), `event`
/// (`waypoint` or `ended`) and the event's own fields ([`TaskEvent`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TaskEntry {
    /// Real seconds since the simulator started.
    pub t: f64,
    /// The connection the 1003 request came on.
    pub conn: ConnId,
    /// The 1003 request's message ID.
    pub id: u16,
    /// What happened.
    #[serde(flatten)]
    pub event: TaskEvent,
}

impl From<TaskProgress> for TaskEntry {
    fn from(p: TaskProgress) -> Self {
        Self {
            t: p.at.as_secs_f64(),
            conn: p.owner.conn,
            id: p.owner.message_id,
            event: p.event,
        }
    }
}

/// A request's items as JSON, by element name.
fn items(request: &Request) -> Value {
    match request {
        Request::NavTask(task) => {
            let points: Vec<Value> = task.points.iter().map(point).collect();
            match points.as_slice() {
                [one] => one.clone(),
                _ => Value::Array(points),
            }
        }
        Request::Light(light) => json!({
            "Red": light.red,
            "Green": light.green,
            "Blue": light.blue,
            "PER": light.effect.raw(),
            "LUM": light.brightness,
        }),
        Request::Motion(command) => json!({
            "Value": match command.value() {
                MotionValue::Float(v) => float(v),
                MotionValue::Int(v) => Value::from(v),
            }
        }),
        Request::Relocalize(pose) => json!({
            "PosX": float(pose.pos_x),
            "PosY": float(pose.pos_y),
            "PosZ": float(pose.pos_z),
            "Yaw": float(pose.yaw),
        }),
        Request::Status
        | Request::CancelNav
        | Request::NavStatus
        | Request::MotorTemperatures
        | Request::Battery
        | Request::Perception => Value::Object(Map::new()),
    }
}

fn point(p: &NavPoint) -> Value {
    json!({
        "Value": p.value,
        "MapID": p.map_id,
        "PosX": float(p.pos_x),
        "PosY": float(p.pos_y),
        "PosZ": float(p.pos_z),
        "AngleYaw": float(p.angle_yaw),
        "PointInfo": p.point_info.raw(),
        "Gait": p.gait.raw(),
        "Speed": p.speed.raw(),
        "Manner": p.manner.raw(),
        "ObsMode": p.obs_mode.raw(),
        "NavMode": p.nav_mode.raw(),
        "Terrain": p.terrain.raw(),
        "Posture": p.posture.raw(),
    })
}

/// An f32 as the JSON number with the same shortest text (0.1, not 0.10000000149011612);
/// null if not finite.
fn float(v: f32) -> Value {
    v.to_string()
        .parse::<f64>()
        .ok()
        .and_then(Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

/// The log itself: entries in memory, and the file if one was asked for.
#[derive(Debug)]
pub(crate) struct RequestLog {
    entries: Mutex<VecDeque<LogEntry>>,
    tasks: Mutex<VecDeque<TaskEntry>>,
    file: Mutex<Option<File>>,
}

impl RequestLog {
    /// A log in memory, also written to `path` (created or truncated) if given.
    pub fn open(path: Option<&Path>) -> io::Result<Self> {
        let file = path
            .map(|p| {
                OpenOptions::new()
                    .create(true)
                    .write(true)
                    .truncate(true)
                    .open(p)
            })
            .transpose()?;
        Ok(Self {
            entries: Mutex::new(VecDeque::new()),
            tasks: Mutex::new(VecDeque::new()),
            file: Mutex::new(file),
        })
    }

    /// Adds an entry; the file gets it as one line in one write, so a reader never sees half
    /// a line and sees each line as soon as it is written.
    pub fn record(&self, entry: LogEntry) {
        self.write_line(&entry.to_json());
        push_bounded(&self.entries, entry);
    }

    /// Adds a task's progress, to the file like a request.
    pub fn record_task(&self, entry: TaskEntry) {
        // Serialising plain numbers cannot fail.
        self.write_line(&serde_json::to_string(&entry).unwrap_or_default());
        push_bounded(&self.tasks, entry);
    }

    /// Writes one line to the file, if there is one.
    fn write_line(&self, json: &str) {
        if let Some(file) = lock(&self.file).as_mut() {
            let mut line = json.as_bytes().to_vec();
            line.push(b'\n');
            // A full disk must not stop the simulator answering; the memory log still has it.
            let _ = file.write_all(&line).and_then(|()| file.flush());
        }
    }

    /// Every entry kept in memory, oldest first.
    pub fn entries(&self) -> Vec<LogEntry> {
        lock(&self.entries).iter().cloned().collect()
    }

    /// Every task entry kept in memory, oldest first.
    pub fn task_entries(&self) -> Vec<TaskEntry> {
        lock(&self.tasks).iter().copied().collect()
    }

    /// Forgets the entries kept in memory, task entries included (the file keeps them).
    pub fn clear(&self) {
        lock(&self.entries).clear();
        lock(&self.tasks).clear();
    }
}

/// Appends to an in-memory log, dropping the oldest entry beyond [`MEMORY_LIMIT`].
fn push_bounded<T>(log: &Mutex<VecDeque<T>>, entry: T) {
    let mut entries = lock(log);
    if entries.len() >= MEMORY_LIMIT {
        entries.pop_front();
    }
    entries.push_back(entry);
}

#[cfg(test)]
mod tests {
    use super::*;
    use x30_panel::proto::codes::PointInfo;
    use x30_panel::proto::message::{Direction, MotionCommand, NavTask, Speed};

    #[test]
    fn motion_entry() {
        let request = Request::Motion(MotionCommand::Move(
            Direction::StrafeLeft,
            Speed::Value(0.1),
        ));
        let entry = LogEntry::request(1.5, 2, 7, &request);
        assert_eq!(
            entry.to_json(),
            r#"{"t":1.5,"conn":2,"id":7,"type":2,"command":11,"items":{"Value":0.1}}"#
        );
        let entry = LogEntry::request(0.0, 1, 0, &Request::Motion(MotionCommand::ZeroVelocity));
        assert_eq!(entry.items, Some(json!({"Value": -1.0})));
    }

    #[test]
    fn nav_task_entries() {
        let p = NavPoint::new(7, 1, 1.5, -2.0, 0.0, 0.5, PointInfo::Charging);
        let mut task = NavTask::to_point(p);
        let entry = LogEntry::request(0.0, 1, 0, &Request::NavTask(task.clone()));
        let items = entry.items.unwrap();
        assert_eq!(items["Value"], 7);
        assert_eq!(items["PointInfo"], 3);
        assert_eq!(items["PosY"], -2.0);
        assert_eq!(items.as_object().map(Map::len), Some(14));
        task.points.push(p).unwrap();
        let entry = LogEntry::request(0.0, 1, 0, &Request::NavTask(task));
        assert_eq!(entry.items.unwrap().as_array().map(Vec::len), Some(2));
    }

    #[test]
    fn task_entries() {
        use crate::robot::Requester;
        let progress = TaskProgress {
            owner: Requester {
                conn: 2,
                message_id: 5,
            },
            at: std::time::Duration::from_millis(1500),
            event: TaskEvent::Waypoint {
                index: 2,
                of: 4,
                value: 7,
            },
        };
        let json = serde_json::to_string(&TaskEntry::from(progress)).unwrap();
        assert_eq!(
            json,
            r#"{"t":1.5,"conn":2,"id":5,"event":"waypoint","index":2,"of":4,"value":7}"#
        );
        let ended = TaskEvent::Ended {
            reached: 1,
            of: 4,
            value: 7,
            error_code: 1,
            error_status: 41804,
        };
        let json = serde_json::to_string(&TaskEntry {
            event: ended,
            ..TaskEntry::from(progress)
        })
        .unwrap();
        assert!(
            json.ends_with(r#""event":"ended","reached":1,"of":4,"value":7,"error_code":1,"error_status":41804}"#),
            "{json}"
        );
    }

    #[test]
    fn failure_entry() {
        let entry = LogEntry::failure(0.25, 3, None, None, "frame: Garbage".into());
        assert_eq!(
            entry.to_json(),
            r#"{"t":0.25,"conn":3,"id":null,"type":null,"command":null,"error":"frame: Garbage"}"#
        );
    }

    #[test]
    fn memory_is_bounded() {
        let log = RequestLog::open(None).unwrap();
        for i in 0..MEMORY_LIMIT + 3 {
            log.record(LogEntry::request(i as f64, 1, 0, &Request::Status));
        }
        let entries = log.entries();
        assert_eq!(entries.len(), MEMORY_LIMIT);
        assert_eq!(entries[0].t, 3.0);
        log.clear();
        assert!(log.entries().is_empty());
        assert!(log.task_entries().is_empty());
    }
}
