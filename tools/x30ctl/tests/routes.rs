//! `x30ctl route` against the simulator, over loopback TCP: the vendor SDK's example route
//! walked unchanged, resuming, looping, one request for the whole route, checking files
//! before anything is sent, stopping (a failed point, Ctrl-C, a lost connection) with the
//! command that resumes, and recording a route from a simulated walk.

mod common;

use std::collections::HashSet;
use std::time::Duration;

use common::*;
use serde_json::value::RawValue;
use x30_panel::proto::message::{NavPoint, Request};
use x30_sim::{Config, Faults, Pose, Simulator, TaskEvent};

/// The vendor SDK's example route, byte for byte (see tests/data/README.md).
const VENDOR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/default_navigation_points.json"
);

/// Fast enough that the vendor route (about 24 s of walking) takes a fraction of a second.
const FAST: f64 = 200.0;

/// The navigation tasks the simulator received, in order: each one's points.
fn tasks(sim: &Simulator) -> Vec<Vec<NavPoint>> {
    requests_of(sim, 1003, None)
        .into_iter()
        .filter_map(|e| match e.request {
            Some(Request::NavTask(task)) => Some(task.points.to_vec()),
            _ => None,
        })
        .collect()
}

/// The `Value` of every point the simulator received, in order.
fn values_sent(sim: &Simulator) -> Vec<i32> {
    tasks(sim).iter().flatten().map(|p| p.value).collect()
}

/// The vendor file's float items as written: per point, (item, text).
fn vendor_float_texts() -> Vec<Vec<(String, String)>> {
    let text = std::fs::read_to_string(VENDOR).expect("the vendor file");
    let points: Vec<std::collections::BTreeMap<String, Box<RawValue>>> =
        serde_json::from_str(&text).expect("JSON");
    points
        .into_iter()
        .map(|p| {
            p.into_iter()
                .filter(|(k, _)| matches!(k.as_str(), "PosX" | "PosY" | "PosZ" | "AngleYaw"))
                .map(|(k, v)| (k, v.get().to_owned()))
                .collect()
        })
        .collect()
}

#[test]
fn the_vendor_route_runs_unchanged_point_by_point() {
    let sim = sim(FAST);
    let run = x30ctl(&sim, &["route", "run", VENDOR]);
    run.expect_code(0);
    for value in 1..=4 {
        run.stdout_has(&format!(
            "point {value} of 4 (Value {value}): navigation to point {value}: succeeded (ErrorCode 0)"
        ));
    }
    run.stdout_has("route completed: 4 points reached in 1 loop(s)");

    // One task per point, in order, each with exactly the file's numbers.
    let tasks = tasks(&sim);
    assert_eq!(tasks.len(), 4);
    assert!(tasks.iter().all(|t| t.len() == 1), "{tasks:?}");
    for (point, texts) in tasks.iter().map(|t| t[0]).zip(vendor_float_texts()) {
        assert_eq!(texts.len(), 4);
        for (item, text) in texts {
            let sent = match item.as_str() {
                "PosX" => point.pos_x,
                "PosY" => point.pos_y,
                "PosZ" => point.pos_z,
                _ => point.angle_yaw,
            };
            let written: f32 = text.parse().expect("a number");
            assert_eq!(sent.to_bits(), written.to_bits(), "{item} {text}");
        }
    }
    let first = tasks[0][0];
    assert_eq!((first.value, first.map_id), (1, 0));
    assert_eq!(
        (
            first.point_info.raw(),
            first.speed.raw(),
            first.nav_mode.raw()
        ),
        (0, 1, 1)
    );
    assert_eq!(tasks[2][0].manner.raw(), 1);
    assert_eq!(tasks[3][0].point_info.raw(), 3);

    // Each task was sent after the previous one had ended, on a connection of its own.
    let log = requests_of(&sim, 1003, None);
    let ends: Vec<f64> = sim
        .task_log()
        .iter()
        .filter(|e| {
            matches!(
                e.event,
                TaskEvent::Ended {
                    error_status: 8960,
                    ..
                }
            )
        })
        .map(|e| e.t)
        .collect();
    assert_eq!(ends.len(), 4);
    for (sent, previous_end) in log.iter().skip(1).zip(&ends) {
        assert!(sent.t >= *previous_end, "{log:?} {ends:?}");
    }
    let conns: HashSet<_> = log.iter().map(|e| e.conn).collect();
    assert_eq!(conns.len(), 4);
    // The last point is a charging point: the robot ends on the dock, where point 4 is.
    let snapshot = sim.snapshot();
    assert!(snapshot.on_dock);
    assert_eq!(snapshot.pose.x, f64::from(tasks[3][0].pos_x));
}

#[test]
fn from_starts_at_the_given_point_and_must_be_in_the_route() {
    let sim = sim(FAST);
    x30ctl(&sim, &["route", "run", VENDOR, "--from", "3"])
        .expect_code(0)
        .stdout_has("from point 3")
        .stdout_has("point 4 of 4 (Value 4)");
    assert_eq!(values_sent(&sim), [3, 4]);
    sim.clear_requests();
    x30ctl(&sim, &["route", "run", VENDOR, "--from", "5"])
        .expect_code(2)
        .stderr_has("--from 5 is out of range")
        .stderr_has("has points 1 to 4; nothing sent");
    x30ctl(&sim, &["route", "run", VENDOR, "--from", "0"]).expect_code(2);
    assert!(sim.requests().is_empty());
}

#[test]
fn loop_2_walks_the_route_twice() {
    let sim = sim(FAST);
    x30ctl(&sim, &["route", "run", VENDOR, "--loop", "2"])
        .expect_code(0)
        .stdout_has("loop 1 of 2, point 1 of 4 (Value 1)")
        .stdout_has("loop 2 of 2, point 4 of 4 (Value 4)")
        .stdout_has("route completed: 8 points reached in 2 loop(s)");
    assert_eq!(values_sent(&sim), [1, 2, 3, 4, 1, 2, 3, 4]);
    // --from applies to the first loop only.
    sim.clear_requests();
    x30ctl(
        &sim,
        &["route", "run", VENDOR, "--loop", "2", "--from", "4"],
    )
    .expect_code(0);
    assert_eq!(values_sent(&sim), [4, 1, 2, 3, 4]);
}

#[test]
fn single_request_sends_every_point_in_one_task() {
    let sim = sim(FAST);
    let run = x30ctl(&sim, &["route", "run", VENDOR, "--single-request"]);
    run.expect_code(0)
        .stdout_has("one request per loop")
        .stdout_has("point 4 of 4 (Value 4): navigation to point 4: succeeded")
        .stdout_has("route completed: 4 points reached in 1 loop(s)");
    // The points before the last have no answer of their own: they were passed.
    for value in 1..=3 {
        run.stdout_has(&format!("point {value} of 4 (Value {value}): passed; "));
    }
    let log = requests_of(&sim, 1003, None);
    assert_eq!(log.len(), 1);
    // One <Items> block per point: the log shows them as an array.
    let items = log[0]
        .items
        .as_ref()
        .and_then(|i| i.as_array())
        .expect("blocks");
    assert_eq!(items.len(), 4);
    assert_eq!(values_sent(&sim), [1, 2, 3, 4]);
    // Progress is asked for on another connection than the task's.
    assert!(
        requests_of(&sim, 1007, None)
            .iter()
            .all(|e| e.conn != log[0].conn)
    );
    let events: Vec<_> = sim.task_log().iter().map(|e| e.event).collect();
    assert_eq!(events.len(), 5, "{events:?}");

    sim.clear_requests();
    let run = x30ctl(
        &sim,
        &[
            "route",
            "run",
            VENDOR,
            "--single-request",
            "--from",
            "2",
            "--json",
        ],
    );
    assert_eq!(tasks(&sim).len(), 1);
    assert_eq!(values_sent(&sim), [2, 3, 4]);
    // A start and an end for every point, only the last with the answer.
    let lines = run.expect_code(0).json_lines();
    let events: Vec<(String, i64, bool)> = lines[1..lines.len() - 1]
        .iter()
        .map(|l| {
            let kind = l["kind"].as_str().unwrap().to_owned();
            (
                kind,
                l["value"].as_i64().unwrap(),
                l.get("answer").is_some(),
            )
        })
        .collect();
    let expected: Vec<(String, i64, bool)> = [2, 3, 4]
        .into_iter()
        .flat_map(|v| {
            [
                ("point_start".to_owned(), v, false),
                ("point_end".to_owned(), v, v == 4),
            ]
        })
        .collect();
    assert_eq!(events, expected);
}

#[test]
fn single_request_refuses_a_route_longer_than_one_request_holds() {
    let sim = sim(FAST);
    let text = std::fs::read_to_string(VENDOR).unwrap();
    let points: Vec<serde_json::Value> = serde_json::from_str(&text).unwrap();
    let nine: Vec<serde_json::Value> = points.iter().cycle().take(9).cloned().collect();
    let file = TempFile::with("nine.json", &serde_json::to_string(&nine).unwrap());
    x30ctl(&sim, &["route", "run", &file.arg(), "--single-request"])
        .expect_code(2)
        .stderr_has("9 points do not fit one request, which carries at most 8");
    // From the second point on, eight are left: they fit.
    x30ctl(
        &sim,
        &[
            "route",
            "run",
            &file.arg(),
            "--single-request",
            "--from",
            "2",
            "--dry-run",
        ],
    )
    .expect_code(0)
    .stdout_has("points 2 to 9 would go in 1 navigation request(s)");
    assert!(sim.requests().is_empty());
}

#[test]
fn dry_run_and_show_send_nothing() {
    let sim = sim(FAST);
    let run = x30ctl(&sim, &["route", "run", VENDOR, "--dry-run", "--from", "2"]);
    run.expect_code(0)
        .stdout_has("#  Value  MapID  PosX")
        .stdout_has("3 (charging)")
        .stdout_has("dry run: points 2 to 4 would go in 3 navigation request(s) (Type 1003), 1 loop; nothing sent");
    assert_eq!(run.stdout.lines().count(), 6, "{}", run.stdout);
    let show = x30ctl(&sim, &["route", "show", VENDOR]);
    show.expect_code(0).stdout_has("0.056386966");
    assert_eq!(show.stdout.lines().count(), 5);
    let json = x30ctl(&sim, &["route", "show", VENDOR, "--json"]);
    let lines = json.expect_code(0).json_lines();
    assert_eq!(lines.len(), 4);
    assert_eq!(lines[3]["kind"], "route_point");
    assert_eq!(lines[3]["index"], 4);
    assert_eq!(lines[3]["point"]["value"], 4);
    assert_eq!(lines[3]["point"]["point_info"]["name"], "Charging");
    let dry = x30ctl(
        &sim,
        &[
            "route",
            "run",
            VENDOR,
            "--dry-run",
            "--json",
            "--single-request",
        ],
    );
    let lines = dry.expect_code(0).json_lines();
    assert_eq!(lines.len(), 5);
    assert_eq!(lines[4]["kind"], "dry_run");
    assert_eq!(lines[4]["requests"], 1);
    assert!(sim.requests().is_empty(), "{:?}", sim.requests());
}

/// A point whose items are the vendor file's first point's, with `changes` applied: an item
/// set to a raw JSON text, or removed when the text is empty.
fn point_text(changes: &[(&str, &str)]) -> String {
    let mut items = vec![
        ("AngleYaw", "-0.062743418"),
        ("Gait", "0"),
        ("Manner", "0"),
        ("MapID", "0"),
        ("NavMode", "1"),
        ("ObsMode", "0"),
        ("PointInfo", "0"),
        ("PosX", "0.056386966"),
        ("PosY", "0.035720933"),
        ("PosZ", "0.0044188141"),
        ("Posture", "0"),
        ("Speed", "1"),
        ("Terrain", "0"),
        ("Value", "2"),
    ];
    for &(key, text) in changes {
        match items.iter().position(|(k, _)| *k == key) {
            Some(at) if text.is_empty() => {
                items.remove(at);
            }
            Some(at) => items[at].1 = text,
            None => items.push((key, text)),
        }
    }
    let members: Vec<String> = items.iter().map(|(k, v)| format!("\"{k}\":{v}")).collect();
    format!("{{{}}}", members.join(","))
}

/// A route of a good first point and a second point with `changes`.
fn route_text(changes: &[(&str, &str)]) -> String {
    format!(
        "[{},{}]",
        point_text(&[("Value", "1")]),
        point_text(changes)
    )
}

#[test]
fn every_problem_in_a_file_names_the_point_its_value_and_the_item_and_nothing_is_sent() {
    let sim = sim(FAST);
    let cases: &[(String, &str)] = &[
        (
            route_text(&[("Sped", "0")]),
            "point 2 (Value 2): unknown key \"Sped\"",
        ),
        (
            route_text(&[("MapID", ""), ("MapId", "0")]),
            "point 2 (Value 2): unknown key \"MapId\" (keys are case-sensitive: \"MapID\")",
        ),
        (
            route_text(&[("Posture", "")]),
            "point 2 (Value 2): missing item Posture",
        ),
        (
            route_text(&[("PosX", "\"1.5\"")]),
            "point 2 (Value 2), PosX: expected a number, found a string (\"1.5\")",
        ),
        (
            route_text(&[("Gait", "1.0")]),
            "point 2 (Value 2), Gait: expected an integer, found 1.0",
        ),
        (
            route_text(&[("MapID", "null")]),
            "point 2 (Value 2), MapID: expected an integer, found null",
        ),
        (
            route_text(&[("Speed", "5")]),
            "point 2 (Value 2), Speed: 5 is not a code protocol V1.0.12 defines (it defines 0 normal, 1 low, 2 high)",
        ),
        (
            route_text(&[("PosY", "1e39")]),
            "point 2 (Value 2), PosY: 1e39 is beyond the range of a 32-bit float (not a finite number)",
        ),
        (
            route_text(&[("Terrain", "3")]),
            "point 2 (Value 2), Gait: 0 (walk) is not allowed on Terrain 3 (frame): only 6 (frame-stairs) and 7 (frame-stairs-45)",
        ),
        (
            route_text(&[("Posture", "1"), ("Gait", "4")]),
            "point 2 (Value 2), Gait: 4 (perception-stairs) is not allowed with Posture 1 (crouched): only 0 (walk) and 2 (slope)",
        ),
        (
            format!("[{}]", point_text(&[]).replacen('{', "{\"PosX\":1,", 1)),
            "point 1 (Value 2), PosX: appears more than once",
        ),
        (
            route_text(&[("Value", "\"two\"")]),
            "point 2 (no readable Value), Value: expected an integer, found a string (\"two\")",
        ),
        (
            "[{\"Value\":1}, 7]".to_owned(),
            "point 2 (no readable Value): expected an object with the 14 items, found a number",
        ),
        (
            "{}".to_owned(),
            "expected a JSON array of points, found an object",
        ),
        ("[]".to_owned(), "the array holds no points"),
        ("[{\"Value\":1,}]".to_owned(), "not valid JSON: "),
    ];
    for (text, expected) in cases {
        let file = TempFile::with("bad.json", text);
        for command in ["run", "show"] {
            let run = x30ctl(&sim, &["route", command, &file.arg()]);
            run.expect_code(2)
                .stderr_has(&format!("route file {}: ", file.arg()))
                .stderr_has(expected)
                .stderr_has("nothing sent");
        }
    }
    // Every problem is listed, not just the first.
    let file = TempFile::with(
        "two.json",
        &format!(
            "[{},{}]",
            point_text(&[("Value", "7"), ("Speed", "9")]),
            point_text(&[("Value", "8"), ("Manner", "")])
        ),
    );
    x30ctl(&sim, &["route", "run", &file.arg()])
        .expect_code(2)
        .stderr_has("2 problems; nothing sent")
        .stderr_has("\n  point 1 (Value 7), Speed: 9 is not a code")
        .stderr_has("\n  point 2 (Value 8): missing item Manner");
    x30ctl(&sim, &["route", "run", "/nonexistent/route.json"])
        .expect_code(2)
        .stderr_has("cannot read route file /nonexistent/route.json");
    assert!(sim.requests().is_empty(), "{:?}", sim.requests());
    assert_eq!(sim.connections(), 0);
}

#[test]
fn a_failed_point_stops_the_route_with_the_command_that_resumes_it() {
    let sim = sim(FAST);
    sim.robot(|r| r.set_unreachable_points(&[3]));
    let run = x30ctl(&sim, &["route", "run", VENDOR]);
    run.expect_code(1)
        .stdout_has("point 3 of 4 (Value 3): navigation to point 3: failed (ErrorCode 1), global path planning failed (ErrorStatus 41804)")
        .stderr_has("route stopped at point 3 of 4 (Value 3): navigation failed: ErrorStatus 41804, \"global path planning failed\"");
    let resume = format!("x30ctl --robot {} route run {VENDOR} --from 3", sim.addr());
    run.stderr_has(&format!("; to resume: {resume}\n"));
    assert_eq!(values_sent(&sim), [1, 2, 3]);

    // The command carries on from there once the way is clear.
    sim.robot(|r| r.set_unreachable_points(&[]));
    sim.clear_requests();
    let words: Vec<&str> = resume.split(' ').skip(1).collect();
    x30ctl_raw(&words).expect_code(0);
    assert_eq!(values_sent(&sim), [3, 4]);

    // In one request, the answer names the point the robot stopped at.
    sim.robot(|r| r.set_unreachable_points(&[3]));
    sim.clear_requests();
    x30ctl(
        &sim,
        &["route", "run", VENDOR, "--single-request", "--loop", "3"],
    )
    .expect_code(1)
    .stderr_has("route stopped at loop 1 of 3, point 3 of 4 (Value 3)")
    .stderr_has("--from 3 --loop 3 --single-request");
}

#[test]
fn ctrl_c_cancels_the_running_point_and_prints_the_command_that_resumes() {
    let sim = sim(1.0);
    // Point 2 is 3.8 m away at 0.5 m/s: far longer than the test waits.
    let route = spawn(
        &sim,
        &["route", "run", VENDOR, "--from", "2", "--loop", "0"],
    );
    wait_for("the task to start", Duration::from_secs(10), || {
        sim.snapshot().task.is_some_and(|t| t.value == 2)
    });
    route.interrupt();
    let run = route.finish(RUN_LIMIT);
    run.expect_code(130)
        .stdout_has("loop 1, point 2 of 4 (Value 2): navigation to point 2: cancelled (ErrorCode 2), single-point task cancelled (ErrorStatus 8962)")
        .stdout_has("cancel navigation task: success (ErrorCode 0)")
        .stderr_has("route stopped at loop 1, point 2 of 4 (Value 2): cancelled by Ctrl-C: ErrorStatus 8962")
        .stderr_has(&format!(
            "; to resume: x30ctl --robot {} route run {VENDOR} --from 2 --loop 0\n",
            sim.addr()
        ));
    let task = &requests_of(&sim, 1003, None)[0];
    let cancels = requests_of(&sim, 1004, None);
    assert_eq!(cancels.len(), 1);
    assert_ne!(task.conn, cancels[0].conn);
    assert_eq!(values_sent(&sim), [2]);
    assert_eq!(sim.snapshot().last_task.map(|t| t.status.raw()), Some(8962));
}

#[test]
fn a_lost_connection_stops_the_route_at_that_point() {
    let sim = sim(1.0);
    let route = spawn(&sim, &["route", "run", VENDOR, "--from", "2", "--json"]);
    wait_for("the task to start", Duration::from_secs(10), || {
        sim.snapshot().task.is_some()
    });
    sim.drop_connections();
    let run = route.finish(RUN_LIMIT);
    run.expect_code(1)
        .stderr_has("route stopped at point 2 of 4 (Value 2): connection closed by the robot before answering Type 1003")
        .stderr_has("the answer is lost with the connection, and the robot stops a task whose connection drops (ErrorStatus 41802)")
        .stderr_has("--from 2 --json\n");
    let lines = run.json_lines();
    let last = lines.last().expect("a stop event");
    assert_eq!(last["kind"], "route_stopped");
    assert_eq!(
        (last["index"].as_u64(), last["loop"].as_u64()),
        (Some(2), Some(1))
    );
    let resume = last["resume"].as_str().expect("a resume command");
    assert!(
        resume.ends_with(&format!("route run {VENDOR} --from 2 --json")),
        "{resume}"
    );
    assert_eq!(values_sent(&sim), [2]);
    assert_eq!(
        sim.snapshot().last_task.map(|t| t.status.raw()),
        Some(41802)
    );
}

#[test]
fn connecting_is_retried_with_backoff_until_the_robot_listens() {
    let port = closed_port();
    let addr = format!("127.0.0.1:{port}");
    let route = spawn_raw(
        &["--robot", &addr, "route", "run", VENDOR, "--from", "4"],
        None,
    );
    std::thread::sleep(Duration::from_millis(400));
    let sim = Simulator::start(Config {
        listen: addr.parse().unwrap(),
        time_scale: FAST,
        ..Default::default()
    })
    .expect("the simulator starts on the port the route tries");
    route
        .finish(RUN_LIMIT)
        .expect_code(0)
        .stderr_has("x30ctl: warning: connection to 127.0.0.1:")
        .stderr_has("; trying again in 0.25 s");
    assert_eq!(values_sent(&sim), [4]);
}

#[test]
fn json_events_parse_and_follow_the_route() {
    let sim = sim(FAST);
    let run = x30ctl(&sim, &["route", "run", VENDOR, "--json", "--from", "3"]);
    let lines = run.expect_code(0).json_lines();
    let kinds: Vec<&str> = lines.iter().map(|l| l["kind"].as_str().unwrap()).collect();
    assert_eq!(
        kinds,
        [
            "route_start",
            "point_start",
            "point_end",
            "point_start",
            "point_end",
            "route_end"
        ]
    );
    assert_eq!(lines[0]["points"], 4);
    assert_eq!(lines[0]["from"], 3);
    assert_eq!(lines[1]["value"], 3);
    let end = &lines[4];
    assert_eq!(
        (
            end["loop"].as_u64(),
            end["index"].as_u64(),
            end["of"].as_u64()
        ),
        (Some(1), Some(4), Some(4))
    );
    assert!(end["leg_s"].as_f64().unwrap() <= end["total_s"].as_f64().unwrap());
    assert_eq!(end["answer"]["kind"], "nav_result");
    assert_eq!(end["answer"]["error_status"]["code"], 8960);
    assert_eq!(lines[5]["points"], 2);
}

#[test]
fn record_from_a_simulated_walk_writes_a_route_that_runs() {
    let sim = sim(1.0);
    let file = TempFile::new("recorded.json");
    let poses = [
        Pose {
            x: 1.5,
            y: -2.0,
            z: 0.0,
            yaw: 0.5,
        },
        Pose {
            x: 3.25,
            y: -2.0,
            z: 0.125,
            yaw: -1.0,
        },
        Pose {
            x: 0.1,
            y: 0.2,
            z: 0.0,
            yaw: 3.0,
        },
    ];
    let mut record = spawn_interactive(
        &sim,
        &[
            "route",
            "record",
            &file.arg(),
            "--map-id",
            "2",
            "--point-info",
            "standing",
            "--speed",
            "high",
            "--obs-mode",
            "off",
        ],
    );
    for (at, pose) in poses.iter().enumerate() {
        sim.robot(|r| r.set_pose(*pose));
        record.send("");
        let line = record.expect_line(&format!("point {} (Value {})", at + 1, at + 1), RUN_LIMIT);
        assert!(
            line.contains(&format!("x {} m, y {} m", pose.x, pose.y)),
            "{line}"
        );
        if at == 0 {
            record.send("what?");
        }
    }
    record.send("q");
    let run = record.finish(RUN_LIMIT);
    run.expect_code(0)
        .stdout_has(&format!("route {}: 3 point(s) recorded", file.arg()))
        .stderr_has("\"what?\" ignored: Enter records a point, q + Enter finishes");
    assert_eq!(requests_of(&sim, 1002, None).len(), 3);
    assert_eq!(
        std::fs::read_to_string(&file.0).unwrap(),
        r#"[
  {
    "AngleYaw": 0.5,
    "Gait": 0,
    "Manner": 0,
    "MapID": 2,
    "NavMode": 0,
    "ObsMode": 1,
    "PointInfo": 2,
    "PosX": 1.5,
    "PosY": -2.0,
    "PosZ": 0.0,
    "Posture": 0,
    "Speed": 2,
    "Terrain": 0,
    "Value": 1
  },
  {
    "AngleYaw": -1.0,
    "Gait": 0,
    "Manner": 0,
    "MapID": 2,
    "NavMode": 0,
    "ObsMode": 1,
    "PointInfo": 2,
    "PosX": 3.25,
    "PosY": -2.0,
    "PosZ": 0.125,
    "Posture": 0,
    "Speed": 2,
    "Terrain": 0,
    "Value": 2
  },
  {
    "AngleYaw": 3.0,
    "Gait": 0,
    "Manner": 0,
    "MapID": 2,
    "NavMode": 0,
    "ObsMode": 1,
    "PointInfo": 2,
    "PosX": 0.1,
    "PosY": 0.2,
    "PosZ": 0.0,
    "Posture": 0,
    "Speed": 2,
    "Terrain": 0,
    "Value": 3
  }
]
"#
    );

    // The recorded route checks out and walks back over the same poses.
    x30ctl(&sim, &["route", "show", &file.arg()]).expect_code(0);
    sim.robot(|r| r.set_pose(Pose::default()));
    let fast = common::sim(FAST);
    x30ctl(&fast, &["route", "run", &file.arg()]).expect_code(0);
    assert_eq!(values_sent(&fast), [1, 2, 3]);
    let end = fast.snapshot().pose;
    assert_eq!(
        (end.x as f32, end.y as f32, end.yaw as f32),
        (0.1, 0.2, 3.0)
    );
}

/// Each pose is read on a new connection from a robot that serves one request a
/// connection; without, every other point failed on the connection it had closed.
#[test]
fn record_reads_each_pose_from_a_robot_that_hangs_up_after_each_answer() {
    const POINTS: usize = 32;
    let sim = sim(1.0);
    sim.set_faults(Faults {
        hang_up_after_answer: true,
        ..Faults::default()
    });
    let file = TempFile::new("hung-up.json");
    let mut record = spawn_interactive(&sim, &["route", "record", &file.arg(), "--map-id", "2"]);
    // Many points, each asked for as soon as the last is in: the robot's close may come
    // just after x30ctl looked whether the connection was still open.
    for at in 1..=POINTS {
        record.send("");
        record.expect_line(&format!("point {at} (Value {at})"), RUN_LIMIT);
    }
    record.send("q");
    record
        .finish(RUN_LIMIT)
        .expect_code(0)
        .stdout_has(&format!("route {}: {POINTS} point(s) recorded", file.arg()));
}

#[test]
fn record_refuses_to_overwrite_and_records_nothing_without_a_pose() {
    let sim = sim(1.0);
    let file = TempFile::with("exists.json", "keep me");
    x30ctl(&sim, &["route", "record", &file.arg(), "--map-id", "0"])
        .expect_code(2)
        .stderr_has(&format!(
            "route record: {} exists; --force overwrites it",
            file.arg()
        ));
    assert_eq!(std::fs::read_to_string(&file.0).unwrap(), "keep me");
    // A folder that does not exist is found out before any pose is read.
    let nowhere = std::path::PathBuf::from(format!("{}.missing", file.arg())).join("route.json");
    x30ctl(
        &sim,
        &[
            "route",
            "record",
            nowhere.to_str().unwrap(),
            "--map-id",
            "0",
        ],
    )
    .expect_code(2)
    .stderr_has(&format!(
        "route record: no folder {}; nothing recorded",
        nowhere.parent().unwrap().display()
    ));
    x30ctl(
        &sim,
        &[
            "route",
            "record",
            &file.arg(),
            "--map-id",
            "0",
            "--posture",
            "crouched",
            "--gait",
            "perception-stairs",
        ],
    )
    .expect_code(2)
    .stderr_has("posture crouched allows only the gaits walk and slope");
    assert!(sim.requests().is_empty());

    // With --force it records, but only poses worth having: not from an unavailable status,
    // nor from one that does not say whether the robot is localised, nor an unknown pose.
    let refusals = [
        (
            false,
            Faults::default(),
            "point 1 not recorded: status unavailable",
        ),
        (
            true,
            Faults {
                sparse_status: true,
                ..Faults::default()
            },
            "point 1 not recorded: the robot does not report whether it is localised",
        ),
        // Localised, but its pose unknown (`nan`) or left out: a route of `null` points
        // that `route show` and `route run` refuse would be written.
        (
            true,
            Faults {
                unknown_pose: true,
                ..Faults::default()
            },
            "point 1 not recorded: the robot reports no pose",
        ),
        (
            true,
            Faults {
                leave_out: vec!["PosZ".to_owned()],
                ..Faults::default()
            },
            "point 1 not recorded: the robot reports no pose",
        ),
    ];
    let path = file.arg();
    let forced = [
        "route", "record", &path, "--map-id", "0", "--force", "--json",
    ];
    for (navigating, faults, refusal) in refusals {
        sim.robot(|r| r.set_navigation_running(navigating));
        sim.set_faults(faults);
        let mut record = spawn_interactive(&sim, &forced);
        record.send("");
        record.send("q");
        let run = record.finish(RUN_LIMIT);
        run.expect_code(2)
            .stderr_has(refusal)
            .stderr_has("no point recorded");
        assert_eq!(std::fs::read_to_string(&file.0).unwrap(), "keep me");
    }

    sim.set_faults(Faults::default());
    sim.robot(|r| r.set_navigation_running(true));
    let mut record = spawn_interactive(&sim, &forced);
    record.send("");
    record.expect_line("\"kind\":\"route_point\"", RUN_LIMIT);
    // The end of the input finishes like q.
    let run = record.finish(RUN_LIMIT);
    let lines = run.expect_code(0).json_lines();
    assert_eq!(lines[0]["index"], 1);
    assert_eq!(lines[1]["kind"], "route_written");
    assert_eq!(lines[1]["points"], 1);
    x30ctl(&sim, &["route", "show", &file.arg()]).expect_code(0);
}
