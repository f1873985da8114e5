//! The control state machine, rule by rule (DESIGN.md "Panel behaviour"), driven with
//! simulated time.

mod panel_support;

use embassy_time::Duration;
use panel_support::*;
use x30_panel::config::{Config, DEFAULT_LIGHTS, parse_dock};
use x30_panel::panel::control::QUEUE_CAPACITY;
use x30_panel::panel::{Action, Button, Control, succeeded};
use x30_panel::proto::codes::*;
use x30_panel::proto::message::*;

const FORWARD: MotionCommand = MotionCommand::Forward(Speed::Default);
const BACKWARD: MotionCommand = MotionCommand::Backward(Speed::Default);
const TURN_LEFT: MotionCommand = MotionCommand::TurnLeft(Speed::Default);
const ZERO: MotionCommand = MotionCommand::ZeroVelocity;
const ESTOP: MotionCommand = MotionCommand::SoftEmergencyStop;

fn send(command: MotionCommand) -> Action {
    Action::Send(Request::Motion(command))
}

/// The motion commands among `actions`.
fn motions(actions: &[(embassy_time::Instant, Action)]) -> Vec<MotionCommand> {
    actions.iter().filter_map(|(_, a)| motion(a)).collect()
}

#[test]
fn held_motion_button_repeats_at_4_hz() {
    let mut c = connected();
    c.button(Button::Forward, true, at(1000));
    // Held for 10 s.
    let sent = run(&mut c, at(1000), at(11_000));
    let times: Vec<u64> = sent
        .iter()
        .filter(|(_, a)| motion(a) == Some(FORWARD))
        .map(|(t, _)| t.as_millis())
        .collect();
    assert!((40..=41).contains(&times.len()), "{} commands", times.len());
    assert_eq!(times[0], 1000);
    assert!(times.windows(2).all(|w| w[1] - w[0] == 250), "{times:?}");
    assert_eq!(sent.len(), times.len(), "only forward commands: {sent:?}");
    c.button(Button::Forward, false, at(11_000));
    assert_eq!(drain(&mut c, at(11_000)), [send(ZERO)]);
}

#[test]
fn first_command_goes_out_at_the_press() {
    let mut c = connected();
    assert_eq!(c.next_deadline(), None);
    c.button(Button::TurnLeft, true, at(1234));
    assert!(c.next_deadline().unwrap() <= at(1234));
    assert_eq!(c.next_action(at(1234)), Some(send(TURN_LEFT)));
    assert_eq!(c.next_action(at(1234)), None);
    assert_eq!(c.next_deadline(), Some(at(1484)));
    assert_eq!(c.next_action(at(1483)), None);
    assert_eq!(c.next_action(at(1484)), Some(send(TURN_LEFT)));
}

#[test]
fn a_late_wake_up_sends_one_repeat_not_a_burst() {
    let mut c = connected();
    c.button(Button::Forward, true, at(0));
    assert_eq!(drain(&mut c, at(0)), [send(FORWARD)]);
    // The application was busy for a second.
    assert_eq!(drain(&mut c, at(1000)), [send(FORWARD)]);
    assert_eq!(c.next_deadline(), Some(at(1250)));
}

#[test]
fn release_sends_zero_velocity_and_repeats_stop() {
    let mut c = connected();
    c.button(Button::Forward, true, at(0));
    assert_eq!(drain(&mut c, at(0)), [send(FORWARD)]);
    c.button(Button::Forward, false, at(100));
    assert_eq!(c.next_action(at(100)), Some(send(ZERO)));
    assert_eq!(c.next_deadline(), None);
    assert!(run(&mut c, at(100), at(5000)).is_empty());
}

#[test]
fn configured_speed_is_sent() {
    let mut config = Config::default();
    config.speeds.forward = Speed::Value(0.8);
    config.speeds.strafe_left = Speed::Value(0.12);
    let mut c = connected_with(&config);
    c.button(Button::Forward, true, at(0));
    assert_eq!(
        drain(&mut c, at(0)),
        [send(MotionCommand::Forward(Speed::Value(0.8)))]
    );
    c.button(Button::StrafeLeft, true, at(10));
    assert_eq!(
        drain(&mut c, at(10)),
        [send(MotionCommand::StrafeLeft(Speed::Value(0.12)))]
    );
}

#[test]
fn every_motion_button_sends_its_command() {
    let cases = [
        (Button::Forward, 1),
        (Button::Backward, 2),
        (Button::TurnLeft, 3),
        (Button::TurnRight, 4),
        (Button::StrafeLeft, 11),
        (Button::StrafeRight, 12),
    ];
    for (button, code) in cases {
        let mut c = connected();
        c.button(button, true, at(0));
        let command = motion(&c.next_action(at(0)).unwrap()).unwrap();
        assert_eq!(command.code().raw(), code, "{button:?}");
        assert_eq!(command.value(), MotionValue::Float(-1.0));
    }
}

#[test]
fn latest_press_wins_and_release_falls_back() {
    let mut c = connected();
    let mut sent = Vec::new();
    c.button(Button::Forward, true, at(0));
    sent.extend(run(&mut c, at(0), at(99)));
    c.button(Button::TurnLeft, true, at(100));
    sent.extend(run(&mut c, at(100), at(199)));
    c.button(Button::Backward, true, at(200));
    sent.extend(run(&mut c, at(200), at(600)));
    assert_eq!(
        sent.iter()
            .map(|(t, a)| (t.as_millis(), motion(a).unwrap()))
            .collect::<Vec<_>>(),
        [
            (0, FORWARD),
            (100, TURN_LEFT),
            (200, BACKWARD),
            (450, BACKWARD)
        ]
    );
    // Releasing a button that does not drive changes nothing.
    c.button(Button::TurnLeft, false, at(600));
    assert_eq!(drain(&mut c, at(600)), []);
    assert_eq!(c.active_motion(), Some(Button::Backward));
    // Releasing the driving one falls back to the latest still held, at once.
    c.button(Button::Backward, false, at(650));
    assert_eq!(drain(&mut c, at(650)), [send(FORWARD)]);
    assert_eq!(c.next_deadline(), Some(at(900)));
    assert_eq!(drain(&mut c, at(900)), [send(FORWARD)]);
    c.button(Button::Forward, false, at(1000));
    assert_eq!(drain(&mut c, at(1000)), [send(ZERO)]);
    assert_eq!(c.active_motion(), None);
}

#[test]
fn pending_motion_is_replaced_by_the_latest() {
    // The application was busy: only the latest motion matters when it comes back.
    let mut c = connected();
    c.button(Button::Forward, true, at(0));
    c.button(Button::Forward, false, at(50));
    c.button(Button::Backward, true, at(80));
    assert_eq!(drain(&mut c, at(100)), [send(BACKWARD)]);
}

#[test]
fn stop_sends_zero_velocity_and_ends_held_motion() {
    let mut c = connected();
    c.button(Button::Forward, true, at(0));
    assert_eq!(drain(&mut c, at(0)), [send(FORWARD)]);
    c.button(Button::Stop, true, at(100));
    assert_eq!(drain(&mut c, at(100)), [send(ZERO)]);
    // The forward button is still down (stuck, say), but it no longer drives.
    assert!(run(&mut c, at(100), at(2000)).is_empty());
    c.button(Button::Forward, false, at(2000));
    assert_eq!(drain(&mut c, at(2000)), []);
}

#[test]
fn one_off_commands() {
    let mut c = connected();
    c.button(Button::StopStepping, true, at(0));
    c.button(Button::StopStepping, false, at(50));
    c.button(Button::LieDown, true, at(100));
    c.button(Button::Cancel, true, at(200));
    assert_eq!(
        drain(&mut c, at(200)),
        [
            send(MotionCommand::StopStepping),
            send(MotionCommand::LieDown),
            Action::CancelNavigation
        ]
    );
    assert_eq!(c.next_deadline(), None);
}

#[test]
fn estop_goes_ahead_of_everything_and_clears_the_queue() {
    let mut c = connected();
    c.button(Button::Gait, true, at(0));
    c.button(Button::Light, true, at(10));
    c.button(Button::Forward, true, at(20));
    c.button(Button::Estop, true, at(30));
    assert_eq!(drain(&mut c, at(30)), [send(ESTOP)]);
    // No repeat of the forward button held before the e-stop.
    assert!(run(&mut c, at(30), at(2000)).is_empty());
}

#[test]
fn estop_jumps_the_queue_of_a_busy_application() {
    let mut c = connected();
    c.button(Button::LieDown, true, at(0));
    c.button(Button::Estop, true, at(10));
    assert_eq!(c.next_action(at(10)), Some(send(ESTOP)));
    assert_eq!(c.next_action(at(10)), None);
}

/// A control that has sent an e-stop whose button is still down.
fn after_estop() -> Control {
    let mut c = connected();
    c.button(Button::Estop, true, at(0));
    assert_eq!(drain(&mut c, at(0)), [send(ESTOP)]);
    c
}

/// Whether a forward press at `t` goes out.
fn forward_goes_out(c: &mut Control, t: u64) -> bool {
    c.button(Button::Forward, true, at(t));
    let out = drain(c, at(t));
    c.button(Button::Forward, false, at(t));
    drain(c, at(t));
    out.contains(&send(FORWARD))
}

#[test]
fn estop_lock_out_needs_release_then_robot_out_of_soft_estop() {
    let mut c = after_estop();
    assert!(c.motion_locked());
    assert!(!forward_goes_out(&mut c, 10));
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    c.button(Button::Estop, false, at(100));
    assert!(
        c.motion_locked(),
        "released, but the robot is still in soft e-stop"
    );
    assert!(!forward_goes_out(&mut c, 110));
    c.robot_motion_state(MotionState::LyingDown);
    assert!(!c.motion_locked());
    assert!(forward_goes_out(&mut c, 200));
}

#[test]
fn estop_lock_out_needs_the_button_released_too() {
    let mut c = after_estop();
    c.robot_motion_state(MotionState::LyingDown);
    assert!(
        c.motion_locked(),
        "robot out of soft e-stop, but the button is down"
    );
    assert!(!forward_goes_out(&mut c, 10));
    c.button(Button::Estop, false, at(100));
    assert!(!c.motion_locked());
    assert!(forward_goes_out(&mut c, 110));
}

#[test]
fn only_states_reported_after_the_estop_went_out_release_the_lock() {
    let mut c = connected();
    c.robot_motion_state(MotionState::Stepping);
    c.button(Button::Estop, true, at(0));
    // An answer to a poll sent before the e-stop arrives while it waits to be sent.
    c.robot_motion_state(MotionState::Stepping);
    assert_eq!(drain(&mut c, at(5)), [send(ESTOP)]);
    c.button(Button::Estop, false, at(100));
    assert!(c.motion_locked(), "no state seen since the e-stop went out");
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    assert!(c.motion_locked());
    c.robot_motion_state(MotionState::LyingDown);
    assert!(!c.motion_locked());
}

#[test]
fn estop_lock_out_blocks_dock_but_not_lie_down() {
    let mut c = after_estop();
    c.button(Button::Dock, true, at(10));
    c.button(Button::LieDown, true, at(20));
    assert_eq!(drain(&mut c, at(20)), [send(MotionCommand::LieDown)]);
}

#[test]
fn estop_while_motion_held_stops_the_repeats() {
    let mut c = connected();
    c.button(Button::Forward, true, at(0));
    assert_eq!(drain(&mut c, at(0)), [send(FORWARD)]);
    c.button(Button::Estop, true, at(100));
    assert_eq!(drain(&mut c, at(100)), [send(ESTOP)]);
    assert!(run(&mut c, at(100), at(3000)).is_empty());
    // After the lock-out ends, the still-held button needs a new press.
    c.button(Button::Estop, false, at(3000));
    c.robot_motion_state(MotionState::LyingDown);
    assert!(run(&mut c, at(3000), at(4000)).is_empty());
    c.button(Button::Forward, false, at(4000));
    assert_eq!(drain(&mut c, at(4000)), []);
}

#[test]
fn estop_button_held_through_an_outage_still_locks_motion() {
    let mut c = Control::new(&Config::default());
    c.button(Button::Estop, true, at(0));
    c.link(true);
    assert!(c.motion_locked());
    assert!(!forward_goes_out(&mut c, 10));
    c.button(Button::Estop, false, at(20));
    // Nothing was sent, so nothing latched.
    assert!(!c.motion_locked());
    assert!(forward_goes_out(&mut c, 30));
}

#[test]
fn presses_while_disconnected_are_dropped_not_replayed() {
    let mut c = Control::new(&Config::default());
    for (i, button) in Button::ALL.into_iter().enumerate() {
        c.button(button, true, at(i as u64 * 10));
        c.button(button, false, at(i as u64 * 10 + 5));
    }
    assert_eq!(c.next_deadline(), None);
    c.link(true);
    assert_eq!(c.next_deadline(), None);
    assert!(run(&mut c, at(200), at(2000)).is_empty());
    // The dropped gait press did not advance the cycle either.
    c.button(Button::Gait, true, at(2000));
    assert_eq!(
        drain(&mut c, at(2000)),
        [send(MotionCommand::SwitchGait(MotionGait::NormalStairs))]
    );
}

#[test]
fn an_outage_drops_what_was_queued() {
    let mut c = connected();
    c.button(Button::LieDown, true, at(0));
    c.button(Button::Light, true, at(0));
    c.link(false);
    c.link(true);
    assert_eq!(drain(&mut c, at(10)), []);
}

#[test]
fn held_motion_does_not_resume_after_reconnect() {
    let mut c = connected();
    c.button(Button::Forward, true, at(0));
    assert_eq!(drain(&mut c, at(0)), [send(FORWARD)]);
    c.link(false);
    assert_eq!(c.next_deadline(), None);
    assert!(run(&mut c, at(0), at(2000)).is_empty());
    c.link(true);
    // The robot hears zero velocity once, in case the release is lost with the link, and
    // nothing more while the button stays down.
    assert_eq!(run(&mut c, at(2000), at(5000)), [(at(2000), send(ZERO))]);
    // Its release sends nothing either: it was not driving.
    c.button(Button::Forward, false, at(5000));
    assert_eq!(drain(&mut c, at(5000)), []);
    c.button(Button::Forward, true, at(6000));
    assert_eq!(drain(&mut c, at(6000)), [send(FORWARD)]);
}

#[test]
fn zero_velocity_goes_out_first_after_an_outage_that_cut_motion() {
    let mut c = connected();
    c.button(Button::TurnLeft, true, at(0));
    assert_eq!(
        drain(&mut c, at(0)),
        [send(MotionCommand::TurnLeft(Speed::Default))]
    );
    c.link(false);
    c.button(Button::TurnLeft, false, at(100));
    c.link(true);
    assert_eq!(drain(&mut c, at(500)), [send(ZERO)]);
    // An outage while idle sends nothing.
    c.link(false);
    c.link(true);
    assert_eq!(drain(&mut c, at(600)), []);
}

#[test]
fn button_held_during_outage_needs_a_new_press() {
    let mut c = Control::new(&Config::default());
    c.button(Button::Backward, true, at(0));
    c.link(true);
    assert!(run(&mut c, at(0), at(2000)).is_empty());
}

#[test]
fn motion_press_during_navigation_cancels_the_task_first() {
    let mut c = connected();
    c.navigation(true);
    c.button(Button::Forward, true, at(0));
    assert_eq!(
        drain(&mut c, at(0)),
        [Action::CancelNavigation, send(FORWARD)]
    );
    assert!(!c.navigating());
    // A second press does not cancel again.
    c.button(Button::TurnLeft, true, at(100));
    assert_eq!(drain(&mut c, at(100)), [send(TURN_LEFT)]);
}

#[test]
fn dock_navigates_to_the_configured_charging_point() {
    let mut config = Config::default();
    config.dock = parse_dock("5,2,1.5,2.5,0,1").unwrap();
    let mut c = connected_with(&config);
    c.button(Button::Dock, true, at(0));
    let actions = drain(&mut c, at(0));
    let [Action::Navigate(task)] = actions.as_slice() else {
        panic!("{actions:?}");
    };
    assert_eq!(task.points.as_slice(), &[config.dock]);
    let point = task.target().unwrap();
    assert_eq!(point.point_info, PointInfo::Charging);
    assert_eq!(
        (point.value, point.map_id, point.pos_x, point.pos_y),
        (5, 2, 1.5, 2.5)
    );
    assert!(Request::NavTask(task.clone()).validate().is_ok());
    assert!(c.navigating(), "the task runs once its action is taken");
}

#[test]
fn default_dock_point() {
    let mut c = connected();
    c.button(Button::Dock, true, at(0));
    let Some(Action::Navigate(task)) = c.next_action(at(0)) else {
        panic!("no navigation");
    };
    let p = task.target().unwrap();
    assert_eq!(
        (p.value, p.map_id, p.point_info),
        (1, 1, PointInfo::Charging)
    );
    assert_eq!(
        (p.pos_x, p.pos_y, p.pos_z, p.angle_yaw),
        (0.0, 0.0, 0.0, 0.0)
    );
}

#[test]
fn dock_then_motion_press_cancels_once_the_task_was_taken() {
    let mut c = connected();
    c.button(Button::Dock, true, at(0));
    assert!(matches!(c.next_action(at(0)), Some(Action::Navigate(_))));
    c.button(Button::Forward, true, at(100));
    assert_eq!(
        drain(&mut c, at(100)),
        [Action::CancelNavigation, send(FORWARD)]
    );
}

#[test]
fn motion_press_drops_a_dock_not_yet_sent() {
    let mut c = connected();
    c.button(Button::Dock, true, at(0));
    c.button(Button::Forward, true, at(10));
    assert_eq!(drain(&mut c, at(10)), [send(FORWARD)]);
}

#[test]
fn dock_while_a_task_runs_is_dropped() {
    let mut c = connected();
    c.navigation(true);
    c.button(Button::Dock, true, at(0));
    assert_eq!(drain(&mut c, at(0)), []);
    c.navigation(false);
    c.button(Button::Dock, true, at(100));
    assert!(matches!(
        drain(&mut c, at(100)).as_slice(),
        [Action::Navigate(_)]
    ));
}

#[test]
fn dock_ends_held_motion() {
    let mut c = connected();
    c.button(Button::Forward, true, at(0));
    assert_eq!(drain(&mut c, at(0)), [send(FORWARD)]);
    c.button(Button::Dock, true, at(100));
    let sent = run(&mut c, at(100), at(2000));
    assert_eq!(sent.len(), 1, "{sent:?}");
    assert!(matches!(sent[0].1, Action::Navigate(_)));
}

#[test]
fn cancel_drops_a_dock_not_yet_sent_and_sends_1004() {
    let mut c = connected();
    c.button(Button::Dock, true, at(0));
    c.button(Button::Cancel, true, at(10));
    assert_eq!(drain(&mut c, at(10)), [Action::CancelNavigation]);
    assert!(!c.navigating());
}

#[test]
fn gait_cycles_walk_stairs_slope_perception_stairs() {
    let mut c = connected();
    let gaits: Vec<_> = (0..5)
        .filter_map(|i| {
            c.button(Button::Gait, true, at(i * 100));
            c.button(Button::Gait, false, at(i * 100 + 50));
            match motion(&c.next_action(at(i * 100 + 50))?)? {
                MotionCommand::SwitchGait(g) => Some(g.raw()),
                _ => None,
            }
        })
        .collect();
    assert_eq!(gaits, [1, 2, 4, 0, 1]);
}

#[test]
fn light_cycles_through_the_presets() {
    let mut c = connected();
    let lights: Vec<_> = (0..5)
        .map(|i| {
            c.button(Button::Light, true, at(i * 100));
            match c.next_action(at(i * 100)) {
                Some(Action::Send(Request::Light(light))) => light,
                other => panic!("{other:?}"),
            }
        })
        .collect();
    let [off, green, amber, red] = DEFAULT_LIGHTS;
    assert_eq!(lights, [green, amber, red, off, green]);
    assert_eq!(red.effect, LightEffect::Breathing);
}

#[test]
fn queue_is_bounded_and_never_blocks() {
    let mut c = connected();
    for i in 0..100 {
        c.button(Button::LieDown, true, at(i));
        c.button(Button::LieDown, false, at(i));
    }
    assert_eq!(drain(&mut c, at(100)).len(), QUEUE_CAPACITY);
    // An e-stop still gets in when the queue is full.
    for i in 0..100 {
        c.button(Button::LieDown, true, at(200 + i));
    }
    c.button(Button::Estop, true, at(300));
    assert_eq!(drain(&mut c, at(300)), [send(ESTOP)]);
}

#[test]
fn sent_records_commands_not_polls() {
    let mut c = connected();
    assert_eq!(c.last_sent(), None);
    c.sent(&Action::Send(Request::Status), false, at(10));
    assert_eq!(c.last_sent(), None);
    assert!(!c.last_failed());
    c.sent(&send(FORWARD), false, at(20));
    assert_eq!(c.last_sent(), Some(at(20)));
    assert!(c.last_failed());
    c.sent(&Action::CancelNavigation, true, at(30));
    assert_eq!(c.last_sent(), Some(at(30)));
    assert!(!c.last_failed());
}

#[test]
fn actions_map_to_requests() {
    assert_eq!(Action::CancelNavigation.request(), Request::CancelNav);
    let task = NavTask::to_point(Config::default().dock);
    assert_eq!(
        Action::Navigate(task.clone()).request(),
        Request::NavTask(task)
    );
    assert_eq!(send(ZERO).request(), Request::Motion(ZERO));
    assert!(send(ZERO).is_command());
    assert!(!Action::Send(Request::Battery).is_command());
    assert!(Action::Send(Request::Light(DEFAULT_LIGHTS[0])).is_command());
}

#[test]
fn answers_say_whether_a_command_succeeded() {
    let ack = |result| MotionAck { value: 0.5, result };
    assert!(succeeded(&Response::Motion(
        MotionCommandCode::Forward,
        ack(CommandResult::Success)
    )));
    assert!(!succeeded(&Response::Motion(
        MotionCommandCode::Forward,
        ack(CommandResult::Failure)
    )));
    assert!(!succeeded(&Response::Light(CommandAck {
        result: CommandResult::Failure
    })));
    let nav = |outcome| {
        Response::NavResult(NavResult {
            value: 1,
            outcome,
            status: ErrorStatus::Default,
        })
    };
    assert!(succeeded(&nav(NavOutcome::Succeeded)));
    assert!(succeeded(&nav(NavOutcome::Cancelled)));
    assert!(!succeeded(&nav(NavOutcome::Failed)));
    assert!(!succeeded(&Response::RequestError(RequestError {
        code: RequestErrorCode::ParseFailed
    })));
    assert!(succeeded(&Response::Battery(battery())));
}

#[test]
fn repeat_period_follows_the_configuration() {
    let mut config = Config::default();
    config.motion_repeat = Duration::from_millis(200);
    let mut c = connected_with(&config);
    c.button(Button::Forward, true, at(0));
    let sent = run(&mut c, at(0), at(999));
    assert_eq!(motions(&sent).len(), 5);
}
