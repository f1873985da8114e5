//! The request log: in memory and as JSON lines in a file, written while the simulator runs.

mod common;

use std::path::PathBuf;
use std::time::Duration;

use common::*;
use serde_json::Value;
use x30_panel::proto::codes::{LightEffect, PointInfo};
use x30_panel::proto::message::{Direction, Light, MotionCommand, Request, Speed};
use x30_sim::Config;

fn temp_log(name: &str) -> PathBuf {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos();
    std::env::temp_dir().join(format!(
        "x30-sim-{name}-{}-{nanos}.jsonl",
        std::process::id()
    ))
}

fn read_lines(path: &PathBuf) -> Vec<Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

#[test]
fn json_lines_while_running() {
    let path = temp_log("lines");
    let sim = start_with(Config {
        listen: "127.0.0.1:0".parse().unwrap(),
        log_file: Some(path.clone()),
        ..Config::default()
    });
    let mut a = Client::connect(sim.addr());
    let mut b = Client::connect(sim.addr());
    a.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    a.request(&Request::Light(Light {
        red: 1,
        green: 2,
        blue: 3,
        effect: LightEffect::Steady,
        brightness: 40,
    }));
    let task_id = b.start_task(&[point(12, 0.0, 0.0, PointInfo::Task)]);
    b.task_result(task_id, Duration::from_secs(5));
    b.send_raw(&raw_frame(66, b"<PatrolDevice>"));
    b.recv();

    // Read while the simulator still runs: every line is already there. The task's progress
    // (set out for its one waypoint, ended) follows its request.
    let all = read_lines(&path);
    let (progress, lines): (Vec<Value>, Vec<Value>) =
        all.iter().cloned().partition(|l| l.get("event").is_some());
    assert_eq!(lines.len(), 4, "{all:#?}");
    assert_eq!(all[3], progress[0], "{all:#?}");
    assert_eq!(
        progress,
        [
            serde_json::json!({"t": progress[0]["t"], "conn": 2, "id": 0, "event": "waypoint",
                "index": 1, "of": 1, "value": 12}),
            serde_json::json!({"t": progress[1]["t"], "conn": 2, "id": 0, "event": "ended",
                "reached": 1, "of": 1, "value": 12, "error_code": 0, "error_status": 8960}),
        ]
    );
    let motion = &lines[0];
    assert_eq!(motion["conn"], 1);
    assert_eq!(motion["id"], 0);
    assert_eq!(motion["type"], 2);
    assert_eq!(motion["command"], 1);
    assert_eq!(motion["items"], serde_json::json!({"Value": -1.0}));
    assert!(motion["t"].as_f64().unwrap() >= 0.0);
    assert_eq!(lines[1]["items"]["LUM"], 40);
    assert_eq!(lines[1]["items"]["PER"], 0);
    let task = &lines[2];
    assert_eq!(
        (task["conn"].as_u64(), task["type"].as_i64()),
        (Some(2), Some(1003))
    );
    for field in [
        "Value",
        "MapID",
        "PosX",
        "PosY",
        "PosZ",
        "AngleYaw",
        "PointInfo",
        "Gait",
        "Speed",
        "Manner",
        "ObsMode",
        "NavMode",
        "Terrain",
        "Posture",
    ] {
        assert!(
            task["items"].get(field).is_some(),
            "{field} missing: {task}"
        );
    }
    assert_eq!(task["items"]["Value"], 12);
    assert_eq!(task["items"]["PointInfo"], 1);
    let bad = &lines[3];
    assert_eq!(bad["id"], 66);
    assert!(bad.get("items").is_none());
    assert!(
        bad["error"].as_str().unwrap().starts_with("decode:"),
        "{bad}"
    );
    let times: Vec<f64> = all.iter().map(|l| l["t"].as_f64().unwrap()).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");

    // The same entries in memory, with the decoded requests.
    let entries = sim.requests();
    assert_eq!(entries.len(), 4);
    assert_eq!(
        entries[0].request,
        Some(Request::Motion(MotionCommand::Move(
            Direction::Forward,
            Speed::Default
        )))
    );
    assert_eq!(entries[2].conn, 2);
    assert!(entries[3].error.is_some());
    let tasks = sim.task_log();
    assert_eq!(tasks.len(), 2);
    assert_eq!(serde_json::to_value(tasks[1]).unwrap(), progress[1]);
    sim.clear_requests();
    assert!(sim.requests().is_empty());
    assert!(sim.task_log().is_empty());
    drop(sim);
    let _ = std::fs::remove_file(&path);
}

#[test]
fn frame_errors_are_logged() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let mut bytes = b"xyz".to_vec();
    bytes.extend(frame_bytes(3, &Request::Status));
    client.send_raw(&bytes);
    client.recv();
    client.recv();
    let entries = sim.requests();
    assert_eq!(entries.len(), 2);
    assert_eq!(entries[0].id, None);
    assert_eq!(entries[0].message_type, None);
    assert!(entries[0].error.as_deref().unwrap().contains("Garbage"));
    assert_eq!(entries[1].message_type, Some(1002));
    let json: Value = serde_json::from_str(&entries[0].to_json()).unwrap();
    assert!(json["id"].is_null());
}
