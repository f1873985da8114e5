//! Every subcommand of x30ctl against the simulator, over loopback TCP: the output, the exit
//! status, and what the simulator received and did.

mod common;

use std::time::Duration;

use common::*;
use x30_panel::proto::codes::{GaitState, LightEffect, MotionState};
use x30_panel::proto::message::{Light, MotionCommand, Request};

#[test]
fn status_human_and_json() {
    let sim = sim(1.0);
    sim.robot(|r| r.set_battery(77.0));
    x30ctl(&sim, &["status"])
        .expect_code(0)
        .stdout_has("motion state   force-control stand (3)")
        .stdout_has("battery        77 %")
        .stdout_has("localisation   localised (0)")
        .stdout_has("dock           not on the dock (0)");
    let run = x30ctl(&sim, &["status", "--json"]);
    run.expect_code(0);
    let lines = run.json_lines();
    assert_eq!(lines.len(), 1);
    let status = &lines[0];
    assert_eq!(status["kind"], "status");
    assert_eq!(status["type"], 1002);
    assert_eq!(status["unavailable"], false);
    assert_eq!(status["motion_state"]["code"], 3);
    assert_eq!(status["motion_state"]["name"], "ForceControlStand");
    assert_eq!(status["electricity"], 77);
    assert!(status["map_pixel"]["x"].is_i64());
    assert_eq!(requests_of(&sim, 1002, Some(1)).len(), 2);
}

#[test]
fn status_unavailable_is_said_plainly() {
    let sim = sim(1.0);
    sim.robot(|r| r.set_navigation_running(false));
    x30ctl(&sim, &["status"])
        .expect_code(0)
        .stdout_has("status unavailable (all items 0)");
    let run = x30ctl(&sim, &["status", "--json"]);
    assert_eq!(run.expect_code(0).json_lines()[0]["unavailable"], true);
}

#[test]
fn robot_address_from_the_environment() {
    let sim = sim(1.0);
    let run = std::process::Command::new(BIN)
        .arg("battery")
        .env("X30_ROBOT", sim.addr().to_string())
        .output()
        .expect("x30ctl runs");
    assert_eq!(run.status.code(), Some(0), "{run:?}");
    assert_eq!(requests_of(&sim, 2001, None).len(), 1);
}

#[test]
fn battery_obstacle_motors_nav_status() {
    let sim = sim(1.0);
    sim.robot(|r| {
        r.set_battery(64.0);
        r.set_obstacle(true);
        r.set_motor_temperatures(41.5);
    });
    x30ctl(&sim, &["battery"])
        .expect_code(0)
        .stdout_has("level          64 %")
        .stdout_has("protection     normal (0)");
    let battery = &x30ctl(&sim, &["battery", "--json"]).json_lines()[0];
    assert_eq!(battery["kind"], "battery");
    assert_eq!(battery["battery_level"], 64);
    assert_eq!(battery["protected_state"]["name"], "Normal");

    x30ctl(&sim, &["obstacle"])
        .expect_code(0)
        .stdout_has("obstacle: obstacle on the planned path within 2 m (ObsState 1)");
    let perception = &x30ctl(&sim, &["obstacle", "--json"]).json_lines()[0];
    assert_eq!(perception["obs_state"]["code"], 1);

    x30ctl(&sim, &["motors"])
        .expect_code(0)
        .stdout_has("left front     sway 41.")
        .stdout_has("right back     sway 41.")
        .stdout_has("hottest        41.");
    let motors = &x30ctl(&sim, &["motors", "--json"]).json_lines()[0];
    let knee = motors["right_back_knee"].as_f64().expect("a number");
    assert!((41.0..=41.5).contains(&knee), "{motors}");
    assert!(motors["max"].as_f64() >= Some(knee));

    x30ctl(&sim, &["nav-status"])
        .expect_code(0)
        .stdout_has("navigation task status: point 0, finished (Status 0)");
    sim.robot(|r| r.set_navigation_running(false));
    let nav_status = &x30ctl(&sim, &["nav-status", "--json"]).json_lines()[0];
    assert_eq!(nav_status["status"]["code"], -1);
    assert_eq!(nav_status["status"]["name"], "CannotRun");

    for (ty, count) in [(2001, 2), (2002, 2), (1008, 2), (1007, 2)] {
        assert_eq!(requests_of(&sim, ty, Some(1)).len(), count, "Type {ty}");
    }
}

#[test]
fn nav_waits_for_the_task_and_succeeds() {
    let sim = sim(10.0);
    // 2 m at the normal 0.5 m/s: 4 simulated seconds, 0.4 s of real time.
    let run = x30ctl(
        &sim,
        &[
            "nav", "--value", "7", "--map-id", "1", "--x", "2", "--y", "0", "--yaw", "0.5",
            "--point", "standing", "--gait", "slope", "--speed", "normal",
        ],
    );
    run.expect_code(0)
        .stdout_has("navigation to point 7: succeeded (ErrorCode 0), single-point task completed (ErrorStatus 8960)");
    let tasks = requests_of(&sim, 1003, Some(1));
    assert_eq!(tasks.len(), 1);
    let items = tasks[0].items.as_ref().expect("items");
    assert_eq!(items["Value"], 7);
    assert_eq!(items["MapID"], 1);
    assert_eq!(items["PosX"], 2.0);
    assert_eq!(items["AngleYaw"], 0.5);
    assert_eq!(items["PointInfo"], 2);
    assert_eq!(items["Gait"], 2);
    assert_eq!(items["ObsMode"], 0);
    let pose = sim.snapshot().pose;
    assert!((pose.x - 2.0).abs() < 0.01, "{pose:?}");

    let run = x30ctl(
        &sim,
        &["nav", "--json", "--map-id", "1", "--x", "2", "--y", "1"],
    );
    let answer = &run.expect_code(0).json_lines()[0];
    assert_eq!(answer["kind"], "nav_result");
    assert_eq!(answer["error_status"]["code"], 8960);
    assert_eq!(answer["error_status"]["name"], "TaskCompleted");
}

#[test]
fn nav_maps_every_named_value() {
    let sim = sim(50.0);
    x30ctl(
        &sim,
        &[
            "nav",
            "--map-id",
            "3",
            "--x",
            "0.5",
            "--y",
            "-0.5",
            "--z",
            "0.25",
            "--point",
            "transition",
            "--gait",
            "frame-stairs-45",
            "--terrain",
            "frame",
            "--speed",
            "high",
            "--manner",
            "backwards",
            "--obstacle-avoidance",
            "off",
            "--nav-mode",
            "autonomous",
        ],
    )
    .expect_code(0);
    x30ctl(
        &sim,
        &[
            "nav",
            "--map-id",
            "3",
            "--x",
            "0",
            "--y",
            "0",
            "--gait",
            "walk",
            "--posture",
            "crouched",
            "--terrain",
            "grating",
            "--speed",
            "low",
            "--point",
            "charging",
        ],
    )
    .expect_code(0);
    let tasks = requests_of(&sim, 1003, None);
    assert_eq!(tasks.len(), 2);
    let first = tasks[0].items.as_ref().expect("items");
    let expected = [
        ("MapID", 3.0),
        ("PosY", -0.5),
        ("PosZ", 0.25),
        ("PointInfo", 0.0),
        ("Gait", 7.0),
        ("Speed", 2.0),
        ("Manner", 1.0),
        ("ObsMode", 1.0),
        ("NavMode", 1.0),
        ("Terrain", 3.0),
        ("Posture", 0.0),
    ];
    for (item, value) in expected {
        assert_eq!(first[item].as_f64(), Some(value), "{item}");
    }
    let second = tasks[1].items.as_ref().expect("items");
    for (item, value) in [
        ("Posture", 1),
        ("Terrain", 1),
        ("Speed", 1),
        ("PointInfo", 3),
    ] {
        assert_eq!(second[item], value, "{item}");
    }
}

/// A valid `nav` to point (1, 1) of map 1, which the tests add options to.
const NAV: [&str; 7] = ["nav", "--map-id", "1", "--x", "1", "--y", "1"];

#[test]
fn nav_validation_refuses_before_sending() {
    let sim = sim(1.0);
    x30ctl(&sim, &[&NAV[..], &["--terrain", "frame"]].concat())
        .expect_code(2)
        .stderr_has("allows only the gaits frame-stairs and frame-stairs-45");
    let crouched = ["--posture", "crouched", "--gait", "perception-stairs"];
    x30ctl(&sim, &[&NAV[..], &crouched].concat())
        .expect_code(2)
        .stderr_has("crouched allows only the gaits walk and slope");
    x30ctl(&sim, &["nav", "--map-id", "1", "--x", "inf", "--y", "1"])
        .expect_code(2)
        .stderr_has("PosX is not a finite number");
    x30ctl(&sim, &["nav", "--x", "1", "--y", "1"]).expect_code(2);
    assert!(sim.requests().is_empty(), "{:?}", sim.requests());
}

#[test]
fn nav_with_low_battery_fails_naming_the_reason() {
    let sim = sim(1.0);
    sim.robot(|r| r.set_battery(5.0));
    x30ctl(&sim, &["nav", "--map-id", "1", "--x", "1", "--y", "0"])
        .expect_code(1)
        .stdout_has("failed (ErrorCode 1), battery too low (ErrorStatus 41730)")
        .stderr_has("nav failed: ErrorStatus 41730, \"battery too low\"");
    let answer = &x30ctl(
        &sim,
        &["nav", "--json", "--map-id", "1", "--x", "1", "--y", "0"],
    )
    .expect_code(1)
    .json_lines()[0];
    assert_eq!(answer["error_status"]["code"], 41730);
    assert_eq!(answer["error_status"]["name"], "BatteryTooLow");
    assert_eq!(answer["error_status"]["description"], "battery too low");
}

#[test]
fn nav_ctrl_c_cancels_and_reports_both_answers() {
    let sim = sim(1.0);
    // 20 m at 0.5 m/s: far longer than the test.
    let nav = spawn(
        &sim,
        &[
            "nav", "--value", "9", "--map-id", "1", "--x", "20", "--y", "0",
        ],
    );
    wait_for("the task to start", Duration::from_secs(10), || {
        sim.snapshot().task.is_some()
    });
    // Another connection may ask how the task goes while it runs.
    x30ctl(&sim, &["nav-status"])
        .expect_code(0)
        .stdout_has("point 9, running (Status 1)");
    nav.interrupt();
    let run = nav.finish(RUN_LIMIT);
    run.expect_code(130)
        .stdout_has("navigation to point 9: cancelled (ErrorCode 2), single-point task cancelled (ErrorStatus 8962)")
        .stdout_has("cancel navigation task: success (ErrorCode 0)")
        .stderr_has("navigation task cancelled by Ctrl-C: ErrorStatus 8962");
    // The cancel went on its own connection, not the task's.
    let task = &requests_of(&sim, 1003, None)[0];
    let cancel = &requests_of(&sim, 1004, None)[0];
    assert_ne!(task.conn, cancel.conn);
    let last = sim.snapshot().last_task.expect("a task ended");
    assert_eq!(last.status.raw(), 8962);
}

#[test]
fn nav_ctrl_c_in_json_gives_one_object_per_answer() {
    let sim = sim(1.0);
    let nav = spawn(
        &sim,
        &["nav", "--json", "--map-id", "1", "--x", "-20", "--y", "0"],
    );
    wait_for("the task to start", Duration::from_secs(10), || {
        sim.snapshot().task.is_some()
    });
    nav.interrupt();
    let run = nav.finish(RUN_LIMIT);
    let lines = run.expect_code(130).json_lines();
    assert_eq!(lines.len(), 2, "{}", run.stdout);
    assert_eq!(lines[0]["kind"], "nav_result");
    assert_eq!(lines[0]["error_code"]["name"], "Cancelled");
    assert_eq!(lines[0]["error_status"]["code"], 8962);
    assert_eq!(lines[1]["kind"], "cancel_nav");
    assert_eq!(lines[1]["error_code"]["code"], 0);
}

#[test]
fn nav_timeout_cancels_the_task() {
    let sim = sim(1.0);
    x30ctl(
        &sim,
        &[
            "nav",
            "--map-id",
            "1",
            "--x",
            "20",
            "--y",
            "0",
            "--nav-timeout",
            "0.5",
        ],
    )
    .expect_code(3)
    .stdout_has("cancelled (ErrorCode 2)")
    .stderr_has("timed out after 500 ms waiting for the answer to Type 1003");
    assert_eq!(requests_of(&sim, 1004, None).len(), 1);
    assert!(sim.snapshot().task.is_none());
}

#[test]
fn cancel_without_a_task_succeeds() {
    let sim = sim(1.0);
    x30ctl(&sim, &["cancel"])
        .expect_code(0)
        .stdout_has("cancel navigation task: success (ErrorCode 0)");
    assert_eq!(requests_of(&sim, 1004, Some(1)).len(), 1);
}

#[test]
fn one_shot_motion_commands() {
    let sim = sim(1.0);
    x30ctl(&sim, &["stop"])
        .expect_code(0)
        .stdout_has("zero velocity (Type 2 Command 6, Value -1): success (ErrorCode 0)");
    x30ctl(&sim, &["gait", "perception-stairs"])
        .expect_code(0)
        .stdout_has("gait perception stairs (4)");
    assert_eq!(sim.snapshot().gait, GaitState::PerceptionStairs);
    x30ctl(&sim, &["stop-stepping"]).expect_code(0);
    x30ctl(&sim, &["estop"])
        .expect_code(0)
        .stdout_has("soft emergency stop (Type 2 Command 13");
    assert_eq!(sim.snapshot().motion_state, MotionState::SoftEmergencyStop);
    assert_eq!(sim.snapshot().motion_state.raw(), 6);
    // Soft emergency stop refuses a gait change: a failed ErrorCode is exit 1.
    x30ctl(&sim, &["gait", "walk"]).expect_code(1).stderr_has(
        "gait failed: the robot refused switch gait (Type 2 Command 20): ErrorCode 1, \"failure\"",
    );
    x30ctl(&sim, &["lie-down"]).expect_code(0);
    assert_eq!(sim.snapshot().motion_state, MotionState::LyingDown);
    let commands: Vec<_> = requests_of(&sim, 2, None)
        .iter()
        .filter_map(|e| e.request.clone())
        .collect();
    assert_eq!(
        commands,
        [
            MotionCommand::ZeroVelocity,
            MotionCommand::SwitchGait(x30_panel::proto::codes::MotionGait::PerceptionStairs),
            MotionCommand::StopStepping,
            MotionCommand::SoftEmergencyStop,
            MotionCommand::SwitchGait(x30_panel::proto::codes::MotionGait::Walk),
            MotionCommand::LieDown,
        ]
        .map(Request::Motion)
    );
}

#[test]
fn light_sets_the_simulated_light() {
    let sim = sim(1.0);
    x30ctl(
        &sim,
        &[
            "light",
            "--red",
            "255",
            "--green",
            "10",
            "--blue",
            "3",
            "--effect",
            "breathing",
            "--brightness",
            "60",
        ],
    )
    .expect_code(0)
    .stdout_has("indicator light: success (ErrorCode 0)");
    assert_eq!(
        sim.snapshot().light,
        Some(Light {
            red: 255,
            green: 10,
            blue: 3,
            effect: LightEffect::Breathing,
            brightness: 60,
        })
    );
    x30ctl(&sim, &["light", "--brightness", "101"])
        .expect_code(2)
        .stderr_has("brightness above 100 %");
    x30ctl(&sim, &["light", "--red", "256"]).expect_code(2);
    assert_eq!(requests_of(&sim, 1101, None).len(), 1);
}

#[test]
fn relocalize_moves_the_robot_or_reports_failure() {
    let sim = sim(1.0);
    x30ctl(
        &sim,
        &["relocalize", "--x", "1.5", "--y", "-2.25", "--yaw", "0.5"],
    )
    .expect_code(0)
    .stdout_has("initialise localisation: localised (ErrorCode 0)");
    let pose = sim.snapshot().pose;
    assert_eq!((pose.x, pose.y, pose.yaw), (1.5, -2.25, 0.5));
    sim.robot(|r| r.set_localization_broken(true));
    x30ctl(&sim, &["relocalize", "--x", "0", "--y", "0"])
        .expect_code(1)
        .stderr_has("relocalize failed: ErrorCode 1, \"localisation abnormal\"");
}

#[test]
fn move_repeats_at_4_hz_then_sends_zero_velocity() {
    let sim = sim(1.0);
    x30ctl(
        &sim,
        &["move", "forward", "--speed", "0.4", "--duration", "1"],
    )
    .expect_code(0)
    .stdout_has("4 command(s) acknowledged; zero velocity (Command 6) acknowledged");
    let log = requests_of(&sim, 2, None);
    let forward = motion_times(&sim, 1);
    assert_eq!(forward.len(), 4, "{log:?}");
    for pair in forward.windows(2) {
        let gap = pair[1] - pair[0];
        assert!((0.15..=0.40).contains(&gap), "gap {gap} s in {forward:?}");
    }
    let stop = log.last().expect("a stop");
    assert_eq!(stop.command, Some(6), "{log:?}");
    let total = stop.t - forward[0];
    assert!((0.9..=1.4).contains(&total), "stop after {total} s");
    assert_eq!(log[0].items.as_ref().expect("items")["Value"], 0.4);
    let snapshot = sim.snapshot();
    assert!(snapshot.manual.is_none());
    assert!(snapshot.pose.x > 0.2, "{:?}", snapshot.pose);
}

#[test]
fn move_every_direction_and_json() {
    let sim = sim(1.0);
    for (direction, command) in [
        ("backward", 2),
        ("turn-left", 3),
        ("turn-right", 4),
        ("strafe-left", 11),
        ("strafe-right", 12),
    ] {
        sim.clear_requests();
        x30ctl(&sim, &["move", direction, "--duration", "0.3"]).expect_code(0);
        let commands: Vec<_> = requests_of(&sim, 2, None)
            .iter()
            .map(|e| e.command)
            .collect();
        assert_eq!(
            commands,
            [Some(command), Some(command), Some(6)],
            "{direction}"
        );
    }
    let run = x30ctl(&sim, &["move", "forward", "--duration", "0.5", "--json"]);
    let lines = run.expect_code(0).json_lines();
    assert_eq!(lines.len(), 3, "{}", run.stdout);
    assert_eq!(lines[0]["motion_command"]["code"], 1);
    assert_eq!(lines[0]["value"], -1.0);
    assert_eq!(lines[2]["motion_command"]["name"], "ZeroVelocity");
}

#[test]
fn move_speed_is_validated() {
    let sim = sim(1.0);
    x30ctl(
        &sim,
        &["move", "strafe-left", "--speed", "0.2", "--duration", "1"],
    )
    .expect_code(2)
    .stderr_has("speed 0.2 m/s out of range");
    x30ctl(
        &sim,
        &["move", "turn-right", "--speed", "-0.5", "--duration", "1"],
    )
    .expect_code(2);
    assert!(sim.requests().is_empty());
    // -0 is 0, sent as `0`.
    x30ctl(
        &sim,
        &["move", "forward", "--speed", "-0", "--duration", "0.1"],
    )
    .expect_code(0);
    let forward = requests_of(&sim, 2, Some(1));
    let value = &forward[0].items.as_ref().expect("items")["Value"];
    assert_eq!(value.to_string(), "0.0", "{value}");
}

#[test]
fn durations_out_of_range_are_refused_saying_why() {
    let sim = sim(1.0);
    let cases = [
        ("0", "--duration 0 is not a positive number of seconds"),
        ("-1", "--duration -1 is not a positive number of seconds"),
        ("NaN", "--duration NaN is not a positive number of seconds"),
        ("1e-12", "--duration 0.000000000001 is under a nanosecond"),
        ("1e300", "--duration 1e300 is too long"),
        // A Duration holds it, but not the clock's moment it ends.
        ("5e18", "--duration 5e18 is too long"),
    ];
    for (seconds, expected) in cases {
        x30ctl(&sim, &["move", "forward", "--duration", seconds])
            .expect_code(2)
            .stderr_has(&format!("move: {expected}; nothing sent"));
    }
    x30ctl(&sim, &[&NAV[..], &["--nav-timeout", "1e20"]].concat())
        .expect_code(2)
        .stderr_has("nav: --nav-timeout 1e20 is too long; nothing sent");
    x30ctl(&sim, &[&NAV[..], &["--nav-timeout", "-5"]].concat())
        .expect_code(2)
        .stderr_has("nav: --nav-timeout -5 is not a positive number of seconds");
    assert!(sim.requests().is_empty());
}

#[test]
fn move_ctrl_c_sends_zero_velocity() {
    let sim = sim(1.0);
    let moving = spawn(&sim, &["move", "turn-left", "--duration", "30"]);
    wait_for("two turn commands", Duration::from_secs(10), || {
        requests_of(&sim, 2, Some(3)).len() >= 2
    });
    moving.interrupt();
    moving
        .finish(RUN_LIMIT)
        .expect_code(130)
        .stdout_has("zero velocity (Command 6) acknowledged")
        .stderr_has("move interrupted by Ctrl-C");
    let log = requests_of(&sim, 2, None);
    assert_eq!(log.last().and_then(|e| e.command), Some(6), "{log:?}");
    assert!(sim.snapshot().manual.is_none());
}

#[test]
fn move_refused_still_sends_zero_velocity() {
    let sim = sim(1.0);
    sim.robot(|r| r.set_motion_state(MotionState::SoftEmergencyStop));
    x30ctl(&sim, &["move", "forward", "--duration", "2"])
        .expect_code(1)
        .stderr_has("move failed: the robot refused forward (Type 2 Command 1): ErrorCode 1");
    let commands: Vec<_> = requests_of(&sim, 2, None)
        .iter()
        .map(|e| e.command)
        .collect();
    assert_eq!(commands, [Some(1), Some(6)]);
}

#[test]
fn watch_plain_lines_and_json() {
    let sim = sim(1.0);
    let run = x30ctl(&sim, &["watch", "--count", "3", "--interval-ms", "50"]);
    run.expect_code(0);
    let lines: Vec<&str> = run.stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{}", run.stdout);
    for line in &lines {
        assert!(line.contains("state=\"force-control stand\""), "{line}");
        assert!(
            line.contains(" battery=") && line.contains("% voltage="),
            "{line}"
        );
        assert!(line.contains("obstacle=\"no obstacle (0)\""), "{line}");
        assert!(
            !line.contains('\x1b'),
            "no ANSI codes into a pipe: {line:?}"
        );
    }
    for ty in [1002, 2001, 2002] {
        assert_eq!(requests_of(&sim, ty, None).len(), 3, "Type {ty}");
    }
    // One connection for the whole watch.
    let conns: std::collections::HashSet<_> = sim.requests().iter().map(|e| e.conn).collect();
    assert_eq!(conns.len(), 1);

    let run = x30ctl(
        &sim,
        &["watch", "--count", "2", "--interval-ms", "50", "--json"],
    );
    let lines = run.expect_code(0).json_lines();
    assert_eq!(lines.len(), 2);
    assert_eq!(lines[1]["refresh"], 2);
    assert_eq!(lines[1]["status"]["kind"], "status");
    assert!(lines[1]["battery"]["battery_level"].is_i64());
    assert_eq!(lines[1]["perception"]["obs_state"]["code"], 0);

    // No refresh at all is a usage error, not a silent success.
    let requests = sim.requests().len();
    x30ctl(&sim, &["watch", "--count", "0"])
        .expect_code(2)
        .stderr_has("0 is not in 1..");
    assert_eq!(sim.requests().len(), requests);
}

#[test]
fn watch_reconnects_after_the_connection_drops() {
    let sim = sim(1.0);
    let watch = spawn(&sim, &["watch", "--count", "6", "--interval-ms", "150"]);
    wait_for("the first refresh", Duration::from_secs(10), || {
        !requests_of(&sim, 2002, None).is_empty()
    });
    sim.drop_connections();
    let run = watch.finish(RUN_LIMIT);
    run.expect_code(0);
    assert!(run.stdout.lines().count() >= 4, "{}", run.stdout);
    let conns: std::collections::HashSet<_> = sim.requests().iter().map(|e| e.conn).collect();
    assert!(conns.len() >= 2, "reconnected: {conns:?}");
}
