//! The robot driven step by step with explicit times: no threads, no sockets.

use super::*;
use x30_panel::proto::codes::{LightEffect, MotionCommandCode, NavSpeed};
use x30_panel::proto::message::{Direction, NavPoint, Speed};

const A: Requester = Requester {
    conn: 1,
    message_id: 10,
};
const B: Requester = Requester {
    conn: 2,
    message_id: 20,
};

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn answer(reply: Reply) -> Response {
    match reply {
        Reply::Now(response) => response,
        other => panic!("expected an answer now, got {other:?}"),
    }
}

fn motion(robot: &mut Robot, command: MotionCommand, now: Duration) -> CommandResult {
    match answer(robot.handle(&Request::Motion(command), A, now)) {
        Response::Motion(code, ack) => {
            assert_eq!(code, command.code());
            ack.result
        }
        other => panic!("{other:?}"),
    }
}

fn point(value: i32, x: f32, y: f32, info: PointInfo) -> NavPoint {
    NavPoint::new(value, 1, x, y, 0.0, 0.0, info)
}

fn task(points: &[NavPoint]) -> Request {
    let mut task = NavTask::to_point(points[0]);
    for p in &points[1..] {
        task.points.push(*p).unwrap();
    }
    Request::NavTask(task)
}

fn refused(reply: Reply) -> (NavOutcome, ErrorStatus) {
    match answer(reply) {
        Response::NavResult(r) => (r.outcome, r.status),
        other => panic!("{other:?}"),
    }
}

#[test]
fn starts_standing_localised_at_the_origin() {
    let robot = Robot::new(1.0);
    let s = robot.status();
    assert_eq!(s.motion_state, MotionState::ForceControlStand);
    assert_eq!((s.pos_x, s.pos_y, s.yaw), (0.0, 0.0, 0.0));
    assert_eq!(s.electricity, Some(90));
    assert_eq!(s.location, Some(Location::Localized));
    assert_eq!(s.map_image(), Some(MAP));
    assert_eq!(s.gait_state, Some(GaitState::Walk));
    assert!(!s.is_unavailable());
    assert_eq!(robot.nav_status().value, 0);
    assert_eq!(robot.nav_status().status, NavTaskStatus::Finished);
}

#[test]
fn forward_moves_until_the_watchdog_expires() {
    let mut robot = Robot::new(2.0);
    let forward = MotionCommand::Move(Direction::Forward, Speed::Default);
    assert_eq!(motion(&mut robot, forward, ms(0)), CommandResult::Success);
    assert_eq!(robot.motion_state(), MotionState::Stepping);
    assert_eq!(robot.status().speed, 0.5);
    // Repeated at 4 Hz for one second of real time: 2 s simulated at 0.5 m/s.
    for t in [250, 500, 750, 1000] {
        motion(&mut robot, forward, ms(t));
    }
    robot.advance(ms(1000));
    assert!((robot.pose().x - 1.0).abs() < 1e-9, "{:?}", robot.pose());
    // No command after t = 1 s: it keeps going until 1.4 s, then stops, still stepping.
    robot.advance(ms(3000));
    assert!((robot.pose().x - 1.4).abs() < 1e-9, "{:?}", robot.pose());
    assert_eq!(robot.status().speed, 0.0);
    assert_eq!(robot.motion_state(), MotionState::Stepping);
    assert!(robot.snapshot().manual.is_none());
    assert!(robot.snapshot().odometry > 1.39);
}

#[test]
fn the_watchdog_allows_3hz_and_stops_after_a_longer_gap() {
    let mut robot = Robot::new(1.0);
    let forward = MotionCommand::Move(Direction::Forward, Speed::Default);
    // Every 333 ms (3 Hz) the robot keeps walking.
    for t in [0, 333, 666, 999] {
        motion(&mut robot, forward, ms(t));
        assert!(robot.snapshot().manual.is_some(), "walking at {t} ms");
    }
    // A gap just over MOTION_TIMEOUT stops it, as Command 6 would.
    robot.advance(ms(999) + MOTION_TIMEOUT + ms(1));
    assert!(robot.snapshot().manual.is_none());
    assert_eq!(robot.status().speed, 0.0);
    assert_eq!(robot.motion_state(), MotionState::Stepping);
}

#[test]
fn zero_velocity_stops_at_once() {
    let mut robot = Robot::new(1.0);
    motion(
        &mut robot,
        MotionCommand::Move(Direction::Backward, Speed::Value(1.0)),
        ms(0),
    );
    assert_eq!(robot.status().speed, -1.0);
    motion(&mut robot, MotionCommand::ZeroVelocity, ms(200));
    robot.advance(ms(400));
    assert!((robot.pose().x + 0.2).abs() < 1e-9, "{:?}", robot.pose());
    assert_eq!(robot.status().speed, 0.0);
}

#[test]
fn turning_and_strafing_move_the_pose() {
    let mut robot = Robot::new(1.0);
    motion(
        &mut robot,
        MotionCommand::Move(Direction::TurnLeft, Speed::Default),
        ms(0),
    );
    robot.advance(ms(400));
    assert!((robot.pose().yaw - 0.14).abs() < 1e-9);
    motion(
        &mut robot,
        MotionCommand::Move(Direction::StrafeRight, Speed::Value(0.15)),
        ms(400),
    );
    robot.advance(ms(800));
    let pose = robot.pose();
    assert!(pose.y < 0.0 && pose.x > 0.0, "{pose:?}");
    assert_eq!(robot.status().speed, 0.0);
}

#[test]
fn refused_motion() {
    let mut robot = Robot::new(1.0);
    for bad in [
        MotionCommand::Move(Direction::Forward, Speed::Value(1.6)),
        MotionCommand::Move(Direction::Backward, Speed::Value(-0.5)),
        MotionCommand::Move(Direction::TurnLeft, Speed::Value(0.5)),
        MotionCommand::Move(Direction::StrafeLeft, Speed::Value(f32::NAN)),
        MotionCommand::SwitchGait(MotionGait::Unknown(3)),
    ] {
        assert_eq!(
            motion(&mut robot, bad, ms(0)),
            CommandResult::Failure,
            "{bad:?}"
        );
    }
    assert_eq!(robot.motion_state(), MotionState::ForceControlStand);
    for state in [
        MotionState::LyingDown,
        MotionState::SoftEmergencyStop,
        MotionState::Fallen,
    ] {
        robot.set_motion_state(state);
        let forward = MotionCommand::Move(Direction::Forward, Speed::Default);
        assert_eq!(motion(&mut robot, forward, ms(0)), CommandResult::Failure);
    }
}

#[test]
fn lie_down_takes_a_second_and_e_stop_needs_it_to_recover() {
    let mut robot = Robot::new(4.0);
    motion(&mut robot, MotionCommand::LieDown, ms(0));
    assert_eq!(robot.motion_state(), MotionState::LyingDownInProgress);
    robot.advance(ms(200));
    assert_eq!(robot.motion_state(), MotionState::LyingDownInProgress);
    robot.advance(ms(260));
    assert_eq!(robot.motion_state(), MotionState::LyingDown);

    motion(&mut robot, MotionCommand::StandUp, ms(300));
    assert_eq!(robot.motion_state(), MotionState::StandingUp);
    robot.advance(ms(560));
    assert_eq!(robot.motion_state(), MotionState::InitialStand);
    robot.advance(ms(700));
    assert_eq!(robot.motion_state(), MotionState::ForceControlStand);

    motion(&mut robot, MotionCommand::SoftEmergencyStop, ms(700));
    assert_eq!(robot.motion_state(), MotionState::SoftEmergencyStop);
    assert_eq!(
        motion(&mut robot, MotionCommand::StopStepping, ms(700)),
        CommandResult::Failure
    );
    motion(&mut robot, MotionCommand::LieDown, ms(700));
    assert_eq!(robot.motion_state(), MotionState::LyingDown);
}

#[test]
fn stepping_commands() {
    let mut robot = Robot::new(1.0);
    motion(&mut robot, MotionCommand::StartStepping, ms(0));
    assert_eq!(robot.motion_state(), MotionState::Stepping);
    motion(&mut robot, MotionCommand::StopStepping, ms(0));
    assert_eq!(robot.motion_state(), MotionState::ForceControlStand);
    motion(&mut robot, MotionCommand::BodyHeight(0.3), ms(0));
    assert_eq!(robot.snapshot().body_height, Some(0.3));
}

#[test]
fn gait_switch_uses_the_status_numbering() {
    let mut robot = Robot::new(1.0);
    for (gait, state) in [
        (MotionGait::PerceptionStairs, GaitState::PerceptionStairs),
        (MotionGait::NormalStairs, GaitState::ObstacleCrossing),
        (MotionGait::Slope, GaitState::Slope),
        (MotionGait::Walk, GaitState::Walk),
    ] {
        let command = MotionCommand::SwitchGait(gait);
        assert_eq!(motion(&mut robot, command, ms(0)), CommandResult::Success);
        assert_eq!(robot.status().gait_state, Some(state));
    }
    match answer(robot.handle(
        &Request::Motion(MotionCommand::SwitchGait(MotionGait::PerceptionStairs)),
        A,
        ms(0),
    )) {
        Response::Motion(MotionCommandCode::SwitchGait, ack) => assert_eq!(ack.value, Some(4.0)),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_task_ends_after_distance_over_speed() {
    let mut robot = Robot::new(10.0);
    let reply = robot.handle(&task(&[point(5, 3.0, 4.0, PointInfo::Task)]), A, ms(100));
    assert_eq!(reply, Reply::Later);
    assert_eq!(robot.status().control_mode, Some(ControlMode::Automatic));
    // 5 m at 0.5 m/s is 10 s simulated, 1 s real at scale 10.
    robot.advance(ms(600));
    let pose = robot.pose();
    assert!(
        (pose.x - 1.5).abs() < 1e-6 && (pose.y - 2.0).abs() < 1e-6,
        "{pose:?}"
    );
    assert_eq!(robot.status().speed, 0.5);
    assert_eq!(robot.nav_status().status, NavTaskStatus::Running);
    assert_eq!(robot.nav_status().value, 5);
    robot.advance(ms(1099));
    assert!(robot.take_ended().is_empty());
    // Reached at 1.1 s; a step past it avoids depending on float rounding at the edge.
    robot.advance(ms(1101));
    let ended = robot.take_ended();
    assert_eq!(
        ended,
        [EndedTask {
            owner: A,
            result: NavResult {
                value: 5,
                outcome: NavOutcome::Succeeded,
                status: ErrorStatus::TaskCompleted
            }
        }]
    );
    assert_eq!(robot.motion_state(), MotionState::ForceControlStand);
    assert_eq!(robot.nav_status().status, NavTaskStatus::Finished);
    assert_eq!(robot.nav_status().value, 5);
}

#[test]
fn waypoints_are_walked_in_order_and_the_answer_names_the_last() {
    let mut robot = Robot::new(1.0);
    let points = [
        point(1, 1.0, 0.0, PointInfo::Transition),
        point(2, 1.0, 1.0, PointInfo::Transition),
    ];
    robot.handle(&task(&points), A, ms(0));
    robot.advance(ms(2500));
    assert_eq!(robot.nav_status().value, 2);
    assert_eq!(robot.snapshot().task.map(|t| t.reached), Some(1));
    robot.advance(ms(4010));
    let ended = robot.take_ended();
    assert_eq!(ended.len(), 1);
    assert_eq!(ended[0].result.value, 2);
    // A transition point keeps the robot stepping.
    assert_eq!(robot.motion_state(), MotionState::Stepping);
}

#[test]
fn each_waypoint_set_out_for_and_the_end_are_noted() {
    let mut robot = Robot::new(1.0);
    let points = [
        point(11, 1.0, 0.0, PointInfo::Transition),
        point(12, 1.0, 1.0, PointInfo::Transition),
        point(13, 0.0, 1.0, PointInfo::Task),
    ];
    robot.handle(&task(&points), A, ms(100));
    // 3 m at 0.5 m/s: all three reached within one long step.
    robot.advance(ms(6200));
    let waypoint = |index, value| TaskEvent::Waypoint {
        index,
        of: 3,
        value,
    };
    let events: Vec<_> = robot
        .take_task_events()
        .into_iter()
        .map(|p| (p.owner, p.at, p.event))
        .collect();
    assert_eq!(
        events,
        [
            (A, ms(100), waypoint(1, 11)),
            (A, ms(6200), waypoint(2, 12)),
            (A, ms(6200), waypoint(3, 13)),
            (
                A,
                ms(6200),
                TaskEvent::Ended {
                    reached: 3,
                    of: 3,
                    value: 13,
                    error_code: 0,
                    error_status: 8960,
                }
            ),
        ]
    );
    assert!(robot.take_task_events().is_empty());
}

#[test]
fn an_unreachable_waypoint_fails_the_task_naming_it() {
    let mut robot = Robot::new(1.0);
    robot.set_unreachable_points(&[22]);
    let points = [
        point(21, 1.0, 0.0, PointInfo::Transition),
        point(22, 2.0, 0.0, PointInfo::Transition),
        point(23, 3.0, 0.0, PointInfo::Task),
    ];
    robot.handle(&task(&points), A, ms(0));
    robot.advance(ms(10_000));
    let ended = robot.take_ended();
    assert_eq!(ended.len(), 1);
    assert_eq!(ended[0].result.value, 22);
    assert_eq!(ended[0].result.outcome, NavOutcome::Failed);
    assert_eq!(ended[0].result.status, ErrorStatus::GlobalPlanningFailed);
    // It stopped at the waypoint before the unreachable one.
    assert_eq!(robot.pose().x, 1.0);
    assert_eq!(robot.motion_state(), MotionState::ForceControlStand);
    assert_eq!(robot.nav_status().value, 22);
    // As the first waypoint, it fails the task on the next step.
    robot.handle(&task(&[points[1]]), A, ms(10_000));
    robot.advance(ms(10_020));
    assert_eq!(
        robot.take_ended()[0].result.status,
        ErrorStatus::GlobalPlanningFailed
    );
    robot.set_unreachable_points(&[]);
    robot.handle(&task(&[points[1]]), A, ms(10_020));
    robot.advance(ms(13_000));
    assert_eq!(
        robot.take_ended()[0].result.status,
        ErrorStatus::TaskCompleted
    );
}

#[test]
fn a_cancelled_or_refused_task_names_the_waypoint_it_was_on() {
    let mut robot = Robot::new(1.0);
    let points = [
        point(31, 1.0, 0.0, PointInfo::Transition),
        point(32, 100.0, 0.0, PointInfo::Transition),
        point(33, 0.0, 0.0, PointInfo::Task),
    ];
    robot.handle(&task(&points), A, ms(0));
    robot.advance(ms(5000));
    // A refused task never left its first waypoint.
    match answer(robot.handle(&task(&points), B, ms(5000))) {
        Response::NavResult(r) => {
            assert_eq!((r.value, r.status), (31, ErrorStatus::TaskAlreadyRunning));
        }
        other => panic!("{other:?}"),
    }
    match robot.handle(&Request::CancelNav, B, ms(5000)) {
        Reply::AfterTask { task, .. } => {
            assert_eq!(task.result.value, 32);
            assert_eq!(task.result.outcome, NavOutcome::Cancelled);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(robot.snapshot().last_task.map(|t| t.value), Some(32));
}

#[test]
fn a_charging_point_ends_on_the_dock() {
    let mut robot = Robot::new(1.0);
    robot.handle(&task(&[point(3, 0.5, 0.0, PointInfo::Charging)]), A, ms(0));
    robot.advance(ms(1010));
    assert_eq!(robot.take_ended().len(), 1);
    let s = robot.status();
    assert_eq!(s.motion_state, MotionState::LyingDown);
    assert_eq!(s.charge_state, Some(ChargeState::Charging));
    assert_eq!(s.on_dock_state, Some(OnDockState::OnDock));
    let before = robot.battery_level();
    robot.advance(ms(5000));
    assert!(robot.battery_level() > before);
    assert!(robot.battery().current.is_some_and(|current| current < 0));
    // A new task takes it off the dock.
    robot.handle(
        &task(&[point(4, 0.0, 0.0, PointInfo::Standing)]),
        A,
        ms(5000),
    );
    assert_eq!(robot.status().on_dock_state, Some(OnDockState::OffDock));
}

#[test]
fn second_task_cancel_and_dropped_connection() {
    let mut robot = Robot::new(1.0);
    let far = task(&[point(7, 100.0, 0.0, PointInfo::Standing)]);
    assert_eq!(robot.handle(&far, A, ms(0)), Reply::Later);
    let other = task(&[point(8, 1.0, 0.0, PointInfo::Standing)]);
    assert_eq!(
        refused(robot.handle(&other, B, ms(10))),
        (NavOutcome::Failed, ErrorStatus::TaskAlreadyRunning)
    );
    // Motion is refused while the task runs.
    let forward = MotionCommand::Move(Direction::Forward, Speed::Default);
    assert_eq!(motion(&mut robot, forward, ms(20)), CommandResult::Failure);

    match robot.handle(&Request::CancelNav, B, ms(30)) {
        Reply::AfterTask { task, answer } => {
            assert_eq!(task.owner, A);
            assert_eq!(task.result.outcome, NavOutcome::Cancelled);
            assert_eq!(task.result.status, ErrorStatus::TaskCancelled);
            assert_eq!(task.result.value, 7);
            assert!(matches!(answer, Response::CancelNav(a) if a.result.is_success()));
        }
        other => panic!("{other:?}"),
    }
    assert!(robot.take_ended().is_empty());
    assert!(matches!(
        answer(robot.handle(&Request::CancelNav, B, ms(40))),
        Response::CancelNav(_)
    ));

    assert_eq!(robot.handle(&far, A, ms(50)), Reply::Later);
    robot.connection_closed(2, ms(60));
    assert!(robot.snapshot().task.is_some());
    robot.connection_closed(1, ms(70));
    assert!(robot.snapshot().task.is_none());
    assert!(robot.take_ended().is_empty(), "nobody to answer");
    let last = robot.snapshot().last_task.unwrap();
    assert_eq!(last.status, ErrorStatus::ClientDisconnected);
    assert_eq!(last.outcome, NavOutcome::Failed);
    assert_eq!(robot.nav_status().status, NavTaskStatus::Finished);
}

#[test]
fn tasks_refused_by_the_robots_state() {
    type Setup = fn(&mut Robot);
    let cases: [(Setup, ErrorStatus); 7] = [
        (|r| r.set_battery(10.4), ErrorStatus::BatteryTooLow),
        (
            |r| r.set_motion_state(MotionState::SoftEmergencyStop),
            ErrorStatus::MotionStateAbnormal,
        ),
        (
            |r| r.set_motion_state(MotionState::Fallen),
            ErrorStatus::MotionStateAbnormal,
        ),
        (
            |r| r.set_motor_temperature(4, 85.0),
            ErrorStatus::MotorOverTemperature,
        ),
        (
            |r| r.set_charger_connected(true),
            ErrorStatus::ChargingOnCharger,
        ),
        (
            |r| r.set_navigation_running(false),
            ErrorStatus::NavigationNotRunning,
        ),
        (
            |r| r.set_localized(false),
            ErrorStatus::LocalizationAbnormal,
        ),
    ];
    for (setup, status) in cases {
        let mut robot = Robot::new(1.0);
        setup(&mut robot);
        let reply = robot.handle(&task(&[point(1, 1.0, 0.0, PointInfo::Task)]), A, ms(0));
        assert_eq!(refused(reply), (NavOutcome::Failed, status));
        assert!(robot.snapshot().task.is_none());
    }
    // A point that breaks the document's rules: failure without a reason code.
    let mut robot = Robot::new(1.0);
    let mut bad = point(1, 1.0, 0.0, PointInfo::Task);
    bad.speed = NavSpeed::Unknown(9);
    assert_eq!(
        refused(robot.handle(&task(&[bad]), A, ms(0))),
        (NavOutcome::Failed, ErrorStatus::Default)
    );
}

#[test]
fn tasks_fail_when_the_state_changes_under_them() {
    type Change = fn(&mut Robot);
    let cases: [(Change, ErrorStatus); 4] = [
        (|r| r.set_battery(5.0), ErrorStatus::BatteryTooLow),
        (
            |r| r.set_motion_state(MotionState::Fallen),
            ErrorStatus::MotionStateAbnormal,
        ),
        (
            |r| r.set_localized(false),
            ErrorStatus::LocalizationAbnormal,
        ),
        (
            |r| r.set_navigation_running(false),
            ErrorStatus::NavigationNotRunning,
        ),
    ];
    for (change, status) in cases {
        let mut robot = Robot::new(1.0);
        robot.handle(&task(&[point(1, 10.0, 0.0, PointInfo::Task)]), A, ms(0));
        robot.advance(ms(1000));
        change(&mut robot);
        robot.advance(ms(1020));
        let ended = robot.take_ended();
        assert_eq!(ended.len(), 1, "{status:?}");
        assert_eq!(ended[0].result.outcome, NavOutcome::Failed);
        assert_eq!(ended[0].result.status, status);
        let x = robot.pose().x;
        robot.advance(ms(3000));
        assert_eq!(robot.pose().x, x, "the robot stops where the task failed");
    }
}

#[test]
fn soft_emergency_stop_fails_the_task() {
    let mut robot = Robot::new(1.0);
    robot.handle(&task(&[point(1, 10.0, 0.0, PointInfo::Task)]), A, ms(0));
    let e_stop = MotionCommand::SoftEmergencyStop;
    assert_eq!(motion(&mut robot, e_stop, ms(500)), CommandResult::Success);
    let ended = robot.take_ended();
    assert_eq!(ended[0].result.status, ErrorStatus::SoftEmergencyStopped);
    assert_eq!(robot.motion_state(), MotionState::SoftEmergencyStop);
}

#[test]
fn an_obstacle_holds_the_task_up_and_finally_fails_it() {
    let mut robot = Robot::new(1.0);
    robot.handle(&task(&[point(1, 100.0, 0.0, PointInfo::Task)]), A, ms(0));
    robot.advance(ms(1000));
    robot.set_obstacle(true);
    assert_eq!(robot.perception().obs_state, ObsState::ObstacleAhead);
    robot.advance(ms(1100));
    let x = robot.pose().x;
    robot.advance(ms(20_000));
    assert_eq!(robot.pose().x, x);
    assert_eq!(robot.status().speed, 0.0);
    robot.set_obstacle(false);
    robot.advance(ms(21_000));
    assert!(robot.pose().x > x);
    robot.set_obstacle(true);
    robot.advance(ms(21_100));
    robot.advance(ms(51_200));
    assert_eq!(
        robot.take_ended()[0].result.status,
        ErrorStatus::ObstacleStopTooLong
    );
}

#[test]
fn navigation_not_running() {
    let mut robot = Robot::new(1.0);
    robot.set_navigation_running(false);
    assert!(robot.status().is_unavailable());
    assert_eq!(robot.nav_status().status, NavTaskStatus::CannotRun);
    assert_eq!(robot.nav_status().error_code, NavTaskStatus::CannotRun);
}

#[test]
fn relocalisation() {
    let mut robot = Robot::new(1.0);
    robot.set_localized(false);
    let pose = Relocalize {
        pos_x: 1.5,
        pos_y: -2.0,
        pos_z: 0.1,
        yaw: 7.0,
    };
    match answer(robot.handle(&Request::Relocalize(pose), A, ms(0))) {
        Response::Relocalize(ack) => assert_eq!(ack.result, LocalizationResult::Localized),
        other => panic!("{other:?}"),
    }
    let s = robot.status();
    assert_eq!(
        (s.pos_x, s.pos_y, s.location),
        (1.5, -2.0, Some(Location::Localized))
    );
    assert!((f64::from(s.yaw) - (7.0 - std::f64::consts::TAU)).abs() < 1e-6);
    robot.set_localization_broken(true);
    match answer(robot.handle(&Request::Relocalize(pose), A, ms(0))) {
        Response::Relocalize(ack) => assert_eq!(ack.result, LocalizationResult::Abnormal),
        other => panic!("{other:?}"),
    }
    assert_eq!(robot.status().location, Some(Location::Lost));
}

#[test]
fn light_is_recorded_when_valid() {
    let mut robot = Robot::new(1.0);
    let light = Light {
        red: 255,
        green: 10,
        blue: 0,
        effect: LightEffect::Breathing,
        brightness: 80,
    };
    let ack = |r: Reply| match answer(r) {
        Response::Light(ack) => ack.result,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        ack(robot.handle(&Request::Light(light), A, ms(0))),
        CommandResult::Success
    );
    assert_eq!(robot.light(), Some(light));
    let too_bright = Light {
        brightness: 101,
        ..light
    };
    assert_eq!(
        ack(robot.handle(&Request::Light(too_bright), A, ms(0))),
        CommandResult::Failure
    );
    assert_eq!(robot.light(), Some(light));
}

#[test]
fn battery_drains_and_agrees_with_status() {
    let mut robot = Robot::new(1.0);
    robot.advance(Duration::from_secs(20));
    assert!((robot.battery_level() - 89.0).abs() < 1e-9);
    assert_eq!(robot.battery().battery_level, robot.status().electricity);
    robot.set_motor_temperatures(90.0);
    assert_eq!(
        robot.status().motor_state,
        Some(MotorState::OverTemperature)
    );
    assert_eq!(robot.motor_temperatures().max(), 90.0);
}

#[test]
fn time_never_runs_backwards() {
    let mut robot = Robot::new(1.0);
    robot.advance(ms(1000));
    robot.advance(ms(500));
    assert_eq!(robot.snapshot().real_time, ms(1000));
    assert_eq!(Robot::new(f64::NAN).time_scale(), 1.0);
}
