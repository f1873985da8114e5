//! Navigation tasks (1003), cancelling them (1004) and their status (1007) over loopback TCP.

mod common;

use std::thread::sleep;
use std::time::{Duration, Instant};

use common::*;
use x30_panel::proto::codes::{
    ChargeState, CommandResult, ErrorStatus, MotionState, NavGait, NavOutcome, NavSpeed,
    NavTaskStatus, OnDockState, PointInfo, Terrain,
};
use x30_panel::proto::message::{Direction, MotionCommand, NavPoint, Request, Response, Speed};
use x30_sim::TaskEvent;

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A point far enough away that the task is still running when the test is done with it.
fn far(value: i32) -> NavPoint {
    point(value, 1000.0, 0.0, PointInfo::Task)
}

/// The answer comes when the walk ends: distance / speed / time scale, not before, with
/// ErrorCode 0 and 8960; the pose moves along the way.
#[test]
fn task_answer_arrives_after_distance_over_speed() {
    let sim = start(10.0);
    let mut client = Client::connect(sim.addr());
    let sent = Instant::now();
    // 5 m at the normal 0.5 m/s: 10 s simulated, 1 s real.
    let id = client.start_task(&[point(42, 4.0, 3.0, PointInfo::Task)]);
    sleep(ms(500));
    let halfway = sim.snapshot();
    assert_eq!(halfway.motion_state, MotionState::Stepping);
    assert!(
        halfway.pose.x > 0.5 && halfway.pose.x < 3.8,
        "{:?}",
        halfway.pose
    );
    assert!(
        (halfway.pose.y / halfway.pose.x - 0.75).abs() < 1e-6,
        "along the line"
    );
    assert!((halfway.speed - 0.5).abs() < 1e-9);
    let result = client.task_result(id, ms(10_000));
    let elapsed = sent.elapsed();
    assert!(
        elapsed >= ms(1000),
        "answered before the walk could end: {elapsed:?}"
    );
    assert!(elapsed < ms(6000), "far too late: {elapsed:?}");
    assert_eq!(result.value, 42);
    assert_nav(&result, NavOutcome::Succeeded, 8960);
    let status = client.status();
    assert_eq!((status.pos_x, status.pos_y), (4.0, 3.0));
    // A task point ends standing.
    assert_eq!(status.motion_state, MotionState::ForceControlStand);
}

#[test]
fn task_speed_codes() {
    let sim = start(10.0);
    let mut client = Client::connect(sim.addr());
    // 2 m at high (1 m/s) and at low (0.25 m/s): 0.2 s and 0.8 s real.
    for (speed, x, expected) in [
        (NavSpeed::High, 2.0, ms(200)),
        (NavSpeed::Low, 0.0, ms(800)),
    ] {
        let p = NavPoint {
            speed,
            ..point(1, x, 0.0, PointInfo::Standing)
        };
        let sent = Instant::now();
        let id = client.start_task(&[p]);
        let result = client.task_result(id, ms(10_000));
        assert_nav(&result, NavOutcome::Succeeded, 8960);
        let elapsed = sent.elapsed();
        assert!(elapsed >= expected, "{speed:?}: {elapsed:?} < {expected:?}");
        assert!(elapsed < expected + ms(5000), "{speed:?}: {elapsed:?}");
    }
}

#[test]
fn waypoints_are_walked_in_order() {
    let sim = start(10.0);
    let mut client = Client::connect(sim.addr());
    let fast = |value, x, y| NavPoint {
        speed: NavSpeed::High,
        ..point(value, x, y, PointInfo::Transition)
    };
    // 3 m then 4 m at 1 m/s: 7 s simulated, 0.7 s real.
    let sent = Instant::now();
    let id = client.start_task(&[fast(1, 3.0, 0.0), fast(2, 3.0, 4.0)]);
    let mut monitor = Client::connect(sim.addr());
    assert!(wait_until(ms(5000), || monitor.nav_status().value == 2));
    assert!(
        sim.snapshot().pose.x > 2.99,
        "the first point was reached first"
    );
    let result = client.task_result(id, ms(10_000));
    assert!(sent.elapsed() >= ms(700), "{:?}", sent.elapsed());
    assert_eq!(result.value, 2);
    assert_nav(&result, NavOutcome::Succeeded, 8960);
    let pose = sim.snapshot().pose;
    assert_eq!((pose.x, pose.y), (3.0, 4.0));
    // A transition point keeps the robot stepping.
    assert_eq!(client.status().motion_state, MotionState::Stepping);
}

/// A request with several `<Items>` blocks is one task: answered once, when the last
/// waypoint is reached, with its `Value`; 1007 and the log follow it point by point.
#[test]
fn a_multi_point_task_is_answered_once_and_logged_point_by_point() {
    let sim = start(20.0);
    let mut client = Client::connect(sim.addr());
    let mut monitor = Client::connect(sim.addr());
    // 2 m, 2 m and 2 m at 0.5 m/s: 12 s simulated, 0.6 s real.
    let points = [
        point(101, 2.0, 0.0, PointInfo::Transition),
        point(102, 2.0, 2.0, PointInfo::Transition),
        point(103, 0.0, 2.0, PointInfo::Standing),
    ];
    let id = client.start_task(&points);
    let mut seen = Vec::new();
    assert!(wait_until(ms(5000), || {
        let state = monitor.nav_status();
        if state.status == NavTaskStatus::Running && seen.last() != Some(&state.value) {
            seen.push(state.value);
        }
        seen.last() == Some(&103)
    }));
    assert!(seen.windows(2).all(|w| w[0] < w[1]), "in order: {seen:?}");
    let result = client.task_result(id, ms(10_000));
    assert_eq!(result.value, 103);
    assert_nav(&result, NavOutcome::Succeeded, 8960);
    assert!(
        client.recv_within(ms(200)).is_none(),
        "one answer for the task"
    );
    let log: Vec<_> = sim.task_log().iter().map(|e| (e.conn, e.event)).collect();
    // The task's connection: the monitor's first 1007 may have come before the 1003.
    let conn = sim
        .requests()
        .iter()
        .find(|e| e.message_type == Some(1003))
        .expect("the 1003 is logged")
        .conn;
    let waypoint = |index, value| {
        (
            conn,
            TaskEvent::Waypoint {
                index,
                of: 3,
                value,
            },
        )
    };
    assert_eq!(
        log,
        [
            waypoint(1, 101),
            waypoint(2, 102),
            waypoint(3, 103),
            (
                conn,
                TaskEvent::Ended {
                    reached: 3,
                    of: 3,
                    value: 103,
                    error_code: 0,
                    error_status: 8960
                }
            ),
        ]
    );
    assert_eq!(client.status().motion_state, MotionState::ForceControlStand);
}

/// A waypoint made unreachable fails the task when the robot sets out for it; the answer
/// and 1007 name that waypoint, and the robot stands at the one before.
#[test]
fn an_unreachable_waypoint_fails_the_task_there() {
    let sim = start(20.0);
    sim.robot(|r| r.set_unreachable_points(&[202]));
    let mut client = Client::connect(sim.addr());
    let id = client.start_task(&[
        point(201, 1.0, 0.0, PointInfo::Transition),
        point(202, 2.0, 0.0, PointInfo::Transition),
        point(203, 3.0, 0.0, PointInfo::Task),
    ]);
    let result = client.task_result(id, ms(10_000));
    assert_eq!(result.value, 202);
    assert_nav(&result, NavOutcome::Failed, 41804);
    assert_eq!(result.status.description(), "global path planning failed");
    assert_eq!(sim.snapshot().pose.x, 1.0);
    assert_eq!(client.nav_status().value, 202);
    let last = sim.task_log().last().copied().expect("logged");
    assert!(
        matches!(
            last.event,
            TaskEvent::Ended {
                reached: 1,
                value: 202,
                error_status: 41804,
                ..
            }
        ),
        "{last:?}"
    );
}

/// Cancelled on the way, a multi-point task's answer names the waypoint it was walking to.
#[test]
fn a_cancelled_multi_point_task_names_the_waypoint_it_was_on() {
    let sim = start(10.0);
    let mut a = Client::connect(sim.addr());
    let mut b = Client::connect(sim.addr());
    let task_id = a.start_task(&[
        point(301, 0.5, 0.0, PointInfo::Transition),
        far(302),
        point(303, 0.0, 0.0, PointInfo::Task),
    ]);
    assert!(wait_until(ms(5000), || {
        sim.snapshot().task.is_some_and(|t| t.target == 302)
    }));
    b.request(&Request::CancelNav);
    let answer = a.recv();
    assert_eq!(answer.id, task_id);
    match answer.response {
        Response::NavResult(r) => {
            assert_eq!(r.value, 302);
            assert_nav(&r, NavOutcome::Cancelled, 8962);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn charging_point_ends_lying_on_the_dock() {
    let sim = start(20.0);
    let mut client = Client::connect(sim.addr());
    let id = client.start_task(&[point(9, 1.0, 0.0, PointInfo::Charging)]);
    assert_nav(
        &client.task_result(id, ms(10_000)),
        NavOutcome::Succeeded,
        8960,
    );
    let status = client.status();
    assert_eq!(status.motion_state, MotionState::LyingDown);
    assert_eq!(status.charge_state, Some(ChargeState::Charging));
    assert_eq!(status.on_dock_state, Some(OnDockState::OnDock));
}

#[test]
fn a_second_task_is_refused_at_once() {
    let sim = start(1.0);
    let mut a = Client::connect(sim.addr());
    let mut b = Client::connect(sim.addr());
    let first = a.start_task(&[far(1)]);
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    let sent = Instant::now();
    let second = b.start_task(&[point(2, 1.0, 0.0, PointInfo::Task)]);
    let result = b.task_result(second, ms(3000));
    assert!(sent.elapsed() < ms(3000));
    assert_eq!(result.value, 2);
    assert_nav(&result, NavOutcome::Failed, 41793);
    let task = sim.snapshot().task.expect("the first task goes on");
    assert_eq!(task.owner.message_id, first);
    assert_eq!(task.value, 1);
    // Motion is refused while a task runs.
    let ack = b.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    assert_eq!(ack.result, CommandResult::Failure);
}

/// The cancelled task's answer (ErrorCode 2, 8962) goes out on the task's connection, and
/// the 1004 answer on the cancel's connection right after it, with no gap in between.
#[test]
fn cancel_answers_the_task_first_then_the_cancel() {
    let sim = start(1.0);
    let mut a = Client::connect(sim.addr());
    let mut b = Client::connect(sim.addr());
    let task_id = a.start_task(&[far(5)]);
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    let cancel_id = b.send(&Request::CancelNav);
    let cancel = b.recv();
    assert_eq!(cancel.id, cancel_id);
    assert!(matches!(cancel.response, Response::CancelNav(a) if a.result.is_success()));
    // Written before the 1004 answer, so it is there by now.
    let task_answer = a.recv();
    assert_eq!(task_answer.id, task_id);
    match task_answer.response {
        Response::NavResult(r) => {
            assert_eq!(r.value, 5);
            assert_nav(&r, NavOutcome::Cancelled, 8962);
        }
        other => panic!("{other:?}"),
    }
    let last = sim.snapshot().last_task.unwrap();
    assert_eq!(last.status, ErrorStatus::TaskCancelled);
}

/// The 1004 answer waits for the task's answer to be written: delaying Type 1003 answers
/// delays it too, though Type 1004 itself has no delay.
#[test]
fn the_cancel_answer_waits_for_a_delayed_task_answer() {
    let sim = start(1.0);
    sim.update_faults(|f| f.type_delays = vec![(1003, ms(400))]);
    let mut a = Client::connect(sim.addr());
    let mut b = Client::connect(sim.addr());
    let task_id = a.start_task(&[far(6)]);
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    let sent = Instant::now();
    let cancel_id = b.send(&Request::CancelNav);
    let cancel = b.recv();
    assert!(sent.elapsed() >= ms(400), "{:?}", sent.elapsed());
    assert_eq!(cancel.id, cancel_id);
    assert_eq!(a.recv().id, task_id);
}

/// Cancelled on its own connection, the two answers leave in one write, the task's first:
/// one read holds both frames.
#[test]
fn cancel_on_the_task_connection_writes_both_answers_at_once() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let task_id = client.start_task(&[far(5)]);
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    client.send_with_id(900, &Request::CancelNav);
    let bytes = client.read_once(ms(5000));
    let mut decoder = x30_panel::proto::frame::FrameDecoder::<4096>::new();
    assert_eq!(decoder.feed(&bytes), bytes.len());
    let mut next = || {
        let frame = decoder
            .decode()
            .expect("a frame in the one read")
            .expect("a good frame");
        (
            frame.message_id,
            Response::decode(frame.asdu).unwrap().message,
        )
    };
    let (id, response) = next();
    assert_eq!(id, task_id);
    assert!(matches!(response, Response::NavResult(r) if r.outcome == NavOutcome::Cancelled));
    let (id, response) = next();
    assert_eq!(id, 900);
    assert!(matches!(response, Response::CancelNav(a) if a.result.is_success()));
    assert!(decoder.decode().is_none(), "exactly two frames");
}

#[test]
fn cancel_without_a_task_succeeds() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    match client.request(&Request::CancelNav) {
        Response::CancelNav(ack) => assert_eq!(ack.result, CommandResult::Success),
        other => panic!("{other:?}"),
    }
}

#[test]
fn nav_status_before_during_and_after() {
    let sim = start(10.0);
    let mut task = Client::connect(sim.addr());
    let mut query = Client::connect(sim.addr());
    let before = query.nav_status();
    assert_eq!((before.value, before.status), (0, NavTaskStatus::Finished));
    // 5 m: 1 s real at scale 10.
    let id = task.start_task(&[point(17, 5.0, 0.0, PointInfo::Task)]);
    // The task's request travels on another connection: wait until the robot has it.
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    let during = query.nav_status();
    assert_eq!((during.value, during.status), (17, NavTaskStatus::Running));
    assert_eq!(during.error_code, NavTaskStatus::Running);
    task.task_result(id, ms(10_000));
    let after = query.nav_status();
    assert_eq!((after.value, after.status), (17, NavTaskStatus::Finished));
    sim.robot(|r| r.set_navigation_running(false));
    let off = query.nav_status();
    assert_eq!(
        (off.status, off.error_code),
        (NavTaskStatus::CannotRun, NavTaskStatus::CannotRun)
    );
}

#[test]
fn a_dropped_task_connection_stops_the_task() {
    let sim = start(1.0);
    let mut task = Client::connect(sim.addr());
    task.start_task(&[far(23)]);
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    drop(task);
    assert!(wait_until(ms(5000), || sim.snapshot().task.is_none()));
    let last = sim.snapshot().last_task.expect("a recorded end");
    assert_eq!(last.status, ErrorStatus::ClientDisconnected);
    assert_eq!(last.outcome, NavOutcome::Failed);
    let x = sim.snapshot().pose.x;
    sleep(ms(100));
    assert_eq!(sim.snapshot().pose.x, x, "the robot stopped");
    let mut query = Client::connect(sim.addr());
    let status = query.nav_status();
    assert_eq!((status.value, status.status), (23, NavTaskStatus::Finished));
}

#[test]
fn drop_connections_stops_the_task_and_closes_clients() {
    let sim = start(1.0);
    let mut task = Client::connect(sim.addr());
    task.start_task(&[far(3)]);
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    sim.drop_connections();
    assert!(task.closed_within(ms(5000)));
    assert!(wait_until(ms(5000), || sim.snapshot().task.is_none()));
    assert_eq!(
        sim.snapshot().last_task.unwrap().status,
        ErrorStatus::ClientDisconnected
    );
    // New connections are served as before.
    let mut again = Client::connect(sim.addr());
    assert_eq!(again.status().electricity, Some(90));
}

#[test]
fn low_battery_fails_tasks() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    sim.robot(|r| r.set_battery(5.0));
    let id = client.start_task(&[point(1, 1.0, 0.0, PointInfo::Task)]);
    let result = client.task_result(id, ms(3000));
    assert_nav(&result, NavOutcome::Failed, 41730);
    // While a task runs, too.
    sim.robot(|r| r.set_battery(50.0));
    let id = client.start_task(&[far(2)]);
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    sim.robot(|r| r.set_battery(9.0));
    assert_nav(&client.task_result(id, ms(3000)), NavOutcome::Failed, 41730);
}

#[test]
fn soft_emergency_stop_fails_tasks() {
    let sim = start(1.0);
    let mut task = Client::connect(sim.addr());
    let mut control = Client::connect(sim.addr());
    // A running task ends "soft emergency stopped".
    let id = task.start_task(&[far(1)]);
    assert!(wait_until(ms(2000), || sim.snapshot().task.is_some()));
    let ack = control.motion(MotionCommand::SoftEmergencyStop);
    assert_eq!(ack.result, CommandResult::Success);
    assert_nav(&task.task_result(id, ms(3000)), NavOutcome::Failed, 41766);
    // A task sent in soft emergency stop: motion state abnormal.
    let id = task.start_task(&[point(2, 1.0, 0.0, PointInfo::Task)]);
    assert_nav(&task.task_result(id, ms(3000)), NavOutcome::Failed, 41729);
}

#[test]
fn tasks_refused_by_the_robots_state() {
    type Setup = fn(&mut x30_sim::Robot);
    let cases: [(Setup, i32); 6] = [
        (|r| r.set_motion_state(MotionState::Fallen), 41729),
        (|r| r.set_motor_temperatures(95.0), 41731),
        (|r| r.set_charger_connected(true), 41732),
        (|r| r.set_navigation_running(false), 41745),
        (|r| r.set_localized(false), 41747),
        (|_| {}, 0),
    ];
    for (setup, status) in cases {
        let sim = start(1.0);
        let mut client = Client::connect(sim.addr());
        sim.robot(setup);
        let mut p = point(4, 1.0, 0.0, PointInfo::Task);
        if status == 0 {
            // Accumulated-frame terrain with the walk gait breaks the document's rules.
            p.terrain = Terrain::AccumulatedFrame;
            p.gait = NavGait::Walk;
        }
        let id = client.start_task(&[p]);
        let result = client.task_result(id, ms(3000));
        assert_eq!(result.value, 4);
        assert_nav(&result, NavOutcome::Failed, status);
        assert!(sim.snapshot().task.is_none());
    }
}

#[test]
fn navigation_not_running_makes_status_unavailable() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    sim.robot(|r| r.set_navigation_running(false));
    assert!(client.status().is_unavailable());
    sim.robot(|r| r.set_navigation_running(true));
    assert!(!client.status().is_unavailable());
}
