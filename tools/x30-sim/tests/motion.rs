//! Motion control (Type 2) over loopback TCP: the motion states (docs/protocol.md, "Type
//! 1002: real-time status") and the pose.

mod common;

use std::thread::sleep;
use std::time::{Duration, Instant};

use common::*;
use x30_panel::proto::codes::{CommandResult, GaitState, MotionGait, MotionState};
use x30_panel::proto::message::{Direction, MotionCommand, Speed};
use x30_sim::robot::MOTION_TIMEOUT;

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// Forward at 4 Hz moves along the heading at the default 0.5 m/s, reported as Speed; when
/// the commands stop, the robot goes on for 400 ms and then stands still, still stepping.
#[test]
fn motion_moves_the_pose_at_4hz_and_stops_400ms_after_the_last_command() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let first = Instant::now();
    let mut last = first;
    for i in 0..5 {
        let ack = client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
        last = Instant::now();
        assert_eq!(ack.result, CommandResult::Success);
        assert_eq!(ack.value, Some(-1.0));
        if i == 2 {
            let status = client.status();
            assert_eq!(status.motion_state, MotionState::Stepping);
            assert_eq!(status.speed, 0.5);
        }
        if i < 4 {
            sleep(ms(250).saturating_sub(last.elapsed()));
        }
    }
    let span = (last - first).as_secs_f64();
    sleep(ms(100));
    let moving = sim.snapshot().pose.x;
    assert!(
        wait_until(ms(3000), || sim.snapshot().manual.is_none()),
        "the watchdog stops the motion"
    );
    let stopped = sim.snapshot().pose.x;
    assert!(
        stopped > moving,
        "still moving 100 ms after the last command"
    );
    sleep(ms(300));
    assert_eq!(sim.snapshot().pose.x, stopped, "stands still");
    // 0.5 m/s from the first command until 400 ms after the last.
    let expected = 0.5 * (span + MOTION_TIMEOUT.as_secs_f64());
    assert!(
        stopped > expected - 0.15 && stopped < expected + 0.15,
        "x = {stopped}, expected about {expected}"
    );
    assert!(sim.snapshot().pose.y.abs() < 1e-9);
    let status = client.status();
    assert_eq!(status.speed, 0.0);
    assert_eq!(status.motion_state, MotionState::Stepping);
    assert!((f64::from(status.pos_x) - stopped).abs() < 1e-4);
}

/// The motion watchdog: repeats 250 ms apart (4 Hz) keep the robot walking; a gap of
/// 600 ms, slower than the protocol's 3 Hz, stops it as Command 6 would.
#[test]
fn repeats_every_250ms_keep_walking_and_a_600ms_gap_stops() {
    assert_eq!(MOTION_TIMEOUT, ms(400));
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    let mut last = Instant::now();
    for _ in 0..4 {
        sleep(ms(250).saturating_sub(last.elapsed()));
        let gap = last.elapsed();
        assert!(
            sim.snapshot().manual.is_some(),
            "stopped after a gap of {gap:?}"
        );
        client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
        last = Instant::now();
    }
    sleep(ms(600).saturating_sub(last.elapsed()));
    let stopped = sim.snapshot();
    assert!(stopped.manual.is_none(), "still walking after 600 ms");
    assert_eq!(stopped.motion_state, MotionState::Stepping);
    assert_eq!(client.status().speed, 0.0);
    sleep(ms(100));
    assert_eq!(sim.snapshot().pose.x, stopped.pose.x, "stands still");
}

#[test]
fn zero_velocity_stops_at_once() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    client.motion(MotionCommand::Move(Direction::Forward, Speed::Value(1.0)));
    sleep(ms(200));
    let ack = client.motion(MotionCommand::ZeroVelocity);
    assert_eq!(ack.result, CommandResult::Success);
    let x = sim.snapshot().pose.x;
    assert!(x > 0.1, "moved before the stop: {x}");
    sleep(ms(300));
    assert_eq!(sim.snapshot().pose.x, x);
    assert_eq!(client.status().speed, 0.0);
}

#[test]
fn turning_and_strafing_move_the_pose() {
    let sim = start(4.0);
    let mut client = Client::connect(sim.addr());
    client.motion(MotionCommand::Move(Direction::TurnLeft, Speed::Default));
    sleep(ms(200));
    client.motion(MotionCommand::ZeroVelocity);
    let yaw = client.status().yaw;
    assert!(yaw > 0.1, "turning left raises yaw: {yaw}");
    sim.robot(|r| r.set_pose(x30_sim::Pose::default()));
    client.motion(MotionCommand::Move(
        Direction::StrafeLeft,
        Speed::Value(0.15),
    ));
    sleep(ms(200));
    client.motion(MotionCommand::ZeroVelocity);
    let status = client.status();
    assert!(
        status.pos_y > 0.05,
        "strafing left at yaw 0 goes to +y: {status:?}"
    );
    assert!(status.pos_x.abs() < 1e-6);
    client.motion(MotionCommand::Move(Direction::Backward, Speed::Default));
    assert_eq!(client.status().speed, -0.5);
    client.motion(MotionCommand::Move(
        Direction::TurnRight,
        Speed::Value(0.45),
    ));
    assert_eq!(client.status().speed, 0.0, "latest command wins");
}

#[test]
fn out_of_range_speeds_are_refused() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    for bad in [
        MotionCommand::Move(Direction::Forward, Speed::Value(1.51)),
        MotionCommand::Move(Direction::Backward, Speed::Value(1.31)),
        MotionCommand::Move(Direction::TurnLeft, Speed::Value(0.46)),
        MotionCommand::Move(Direction::TurnRight, Speed::Value(-0.1)),
        MotionCommand::Move(Direction::StrafeLeft, Speed::Value(0.16)),
        MotionCommand::Move(Direction::StrafeRight, Speed::Value(-2.0)),
    ] {
        let ack = client.motion(bad);
        assert_eq!(ack.result, CommandResult::Failure, "{bad:?}");
        assert_eq!(ack.value, Some(bad.value_f32()));
    }
    assert_eq!(client.status().motion_state, MotionState::ForceControlStand);
    for good in [
        MotionCommand::Move(Direction::Forward, Speed::Value(1.5)),
        MotionCommand::Move(Direction::Backward, Speed::Value(1.3)),
        MotionCommand::Move(Direction::TurnLeft, Speed::Value(0.45)),
        MotionCommand::Move(Direction::StrafeRight, Speed::Value(0.0)),
    ] {
        assert_eq!(
            client.motion(good).result,
            CommandResult::Success,
            "{good:?}"
        );
    }
}

/// Value echo of a command as the answer carries it.
trait ValueF32 {
    fn value_f32(&self) -> f32;
}

impl ValueF32 for MotionCommand {
    fn value_f32(&self) -> f32 {
        match self.value() {
            x30_panel::proto::message::MotionValue::Float(v) => v,
            x30_panel::proto::message::MotionValue::Int(v) => v as f32,
        }
    }
}

#[test]
fn gait_switch_is_reflected_in_status() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    for (gait, state) in [
        (MotionGait::NormalStairs, GaitState::ObstacleCrossing),
        (MotionGait::Slope, GaitState::Slope),
        (MotionGait::PerceptionStairs, GaitState::PerceptionStairs),
        (MotionGait::Walk, GaitState::Walk),
    ] {
        let ack = client.motion(MotionCommand::SwitchGait(gait));
        assert_eq!(ack.result, CommandResult::Success);
        assert_eq!(ack.value, Some(gait.raw() as f32));
        assert_eq!(client.status().gait_state, Some(state), "{gait:?}");
    }
    client.motion(MotionCommand::SwitchGait(MotionGait::PerceptionStairs));
    let ack = client.motion(MotionCommand::SwitchGait(MotionGait::Unknown(3)));
    assert_eq!(ack.result, CommandResult::Failure);
    assert_eq!(
        client.status().gait_state,
        Some(GaitState::PerceptionStairs)
    );
}

#[test]
fn soft_emergency_stop_then_lie_down() {
    let sim = start(5.0);
    let mut client = Client::connect(sim.addr());
    client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    let ack = client.motion(MotionCommand::SoftEmergencyStop);
    assert_eq!(ack.result, CommandResult::Success);
    let status = client.status();
    assert_eq!(status.motion_state, MotionState::SoftEmergencyStop);
    assert_eq!(status.speed, 0.0);
    let x = sim.snapshot().pose.x;
    let refused = client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    assert_eq!(refused.result, CommandResult::Failure);
    sleep(ms(100));
    assert_eq!(sim.snapshot().pose.x, x, "no motion in soft e-stop");
    // Lying down is the way out of soft emergency stop.
    assert_eq!(
        client.motion(MotionCommand::LieDown).result,
        CommandResult::Success
    );
    assert_eq!(client.status().motion_state, MotionState::LyingDown);
    let refused = client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    assert_eq!(
        refused.result,
        CommandResult::Failure,
        "no motion lying down"
    );
}

#[test]
fn lie_down_passes_through_lying_down_in_progress_and_stand_up_back() {
    // Lying down takes 1 s simulated: 200 ms at scale 5.
    let sim = start(5.0);
    let mut client = Client::connect(sim.addr());
    let start = Instant::now();
    client.motion(MotionCommand::LieDown);
    assert_eq!(
        client.status().motion_state,
        MotionState::LyingDownInProgress
    );
    assert!(wait_until(ms(5000), || client.status().motion_state
        == MotionState::LyingDown));
    assert!(start.elapsed() >= ms(190), "{:?}", start.elapsed());

    client.motion(MotionCommand::StandUp);
    assert_eq!(client.status().motion_state, MotionState::StandingUp);
    assert!(wait_until(ms(5000), || {
        client.status().motion_state == MotionState::ForceControlStand
    }));
    client.motion(MotionCommand::StartStepping);
    assert_eq!(client.status().motion_state, MotionState::Stepping);
    client.motion(MotionCommand::StopStepping);
    assert_eq!(client.status().motion_state, MotionState::ForceControlStand);
}

#[test]
fn stop_stepping_returns_to_force_control_stand() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    assert_eq!(client.status().motion_state, MotionState::Stepping);
    assert_eq!(
        client.motion(MotionCommand::StopStepping).result,
        CommandResult::Success
    );
    let status = client.status();
    assert_eq!(status.motion_state, MotionState::ForceControlStand);
    assert_eq!(status.speed, 0.0);
}

#[test]
fn one_robot_for_every_connection() {
    let sim = start(1.0);
    let mut a = Client::connect(sim.addr());
    let mut b = Client::connect(sim.addr());
    a.motion(MotionCommand::SoftEmergencyStop);
    assert_eq!(b.status().motion_state, MotionState::SoftEmergencyStop);
    assert_eq!(sim.connections(), 2);
}
