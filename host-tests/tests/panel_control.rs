//! The control state machine, rule by rule (the rules are listed in the docs of
//! `x30_panel::panel::control`), driven with simulated time.

mod panel_support;

use embassy_time::{Duration, Instant};
use panel_support::*;
use x30_panel::client::Health;
use x30_panel::config::{Config, DEFAULT_LIGHTS};
use x30_panel::panel::ConnectionState;
use x30_panel::panel::Outcome;
use x30_panel::panel::control::{ESTOP_LIGHT, ESTOP_REPEAT, ONE_SHOT_QUEUE};
use x30_panel::panel::{Button, Control, STALE_PRESS, TaskEnd, TaskOrder, succeeded};
use x30_panel::proto::codes::*;
use x30_panel::proto::message::*;
use x30_panel::settings::Key;
use x30_panel::settings::route::RoutePoint;

const FORWARD: Request = Request::Motion(MotionCommand::Move(Direction::Forward, Speed::Default));
const BACKWARD: Request = Request::Motion(MotionCommand::Move(Direction::Backward, Speed::Default));
const TURN_LEFT: Request =
    Request::Motion(MotionCommand::Move(Direction::TurnLeft, Speed::Default));
const ZERO: Request = Request::Motion(MotionCommand::ZeroVelocity);
const ESTOP: Request = Request::Motion(MotionCommand::SoftEmergencyStop);
const LIE_DOWN: Request = Request::Motion(MotionCommand::LieDown);
const STOP_STEPPING: Request = Request::Motion(MotionCommand::StopStepping);
const CANCEL: Request = Request::CancelNav;

/// The Command 20 request that switches to `gait`.
fn switch_gait(gait: MotionGait) -> Request {
    Request::Motion(MotionCommand::SwitchGait(gait))
}

/// The 1101 request of the light preset `index`.
fn light(index: usize) -> Request {
    Request::Light(DEFAULT_LIGHTS[index])
}

/// `gait` pressed at `ms` while the robot reports `robot` (`None`: no fresh status).
fn press_gait(c: &mut Control, ms: u64, robot: Option<GaitState>) {
    c.button(event(Button::Gait, true, ms), robot);
}

#[test]
fn timing_constants() {
    assert_eq!(STALE_PRESS, Duration::from_millis(300));
    assert_eq!(ESTOP_REPEAT, Duration::from_millis(250));
    assert_eq!(Config::default().motion_repeat, Duration::from_millis(250));
}

// Stops first.

#[test]
fn stops_first_zero_velocity_then_cancel_then_motion_then_one_shots() {
    let mut c = connected();
    // The one-shots were pressed first: a plain queue would send them first.
    c.press(Button::LieDown, 0);
    c.press(Button::Light, 0);
    c.press(Button::Forward, 0);
    c.release(Button::Forward, 0);
    c.press(Button::Cancel, 0);
    c.press(Button::Backward, 0);
    assert_eq!(
        drain(&mut c, at(0)),
        [ZERO, CANCEL, BACKWARD, LIE_DOWN, light(1)]
    );
}

#[test]
fn stops_first_estop_goes_before_every_other_stop_and_one_shot() {
    let mut c = connected();
    c.press(Button::Estop, 0);
    c.press(Button::Stop, 0);
    c.press(Button::Cancel, 0);
    c.press(Button::LieDown, 0);
    assert_eq!(drain(&mut c, at(0)), [ESTOP, ZERO, CANCEL, LIE_DOWN]);
    // A repeat of the e-stop goes first too.
    c.press(Button::StopStepping, 240);
    c.press(Button::Stop, 240);
    assert_eq!(drain(&mut c, at(250)), [ESTOP, ZERO, STOP_STEPPING]);
}

// The e-stop latch.

/// A control whose e-stop was pressed, and sent, at 0; the button is still down.
fn latched() -> Control {
    let mut c = connected();
    c.press(Button::Estop, 0);
    assert_eq!(drain(&mut c, at(0)), [ESTOP]);
    c
}

/// Whether a forward press at `ms` goes out (the button is released again after).
fn forward_goes_out(c: &mut Control, ms: u64) -> bool {
    c.press(Button::Forward, ms);
    let out = drain(c, at(ms));
    c.release(Button::Forward, ms);
    drain(c, at(ms));
    out.contains(&FORWARD)
}

#[test]
fn estop_latch_sends_at_once_and_every_250_ms_until_the_robot_confirms() {
    let mut c = connected();
    c.press(Button::Estop, 1000);
    assert!(c.estop_unconfirmed());
    assert!(c.next_deadline().unwrap() <= at(1000));
    let mut sent = run(&mut c, at(1000), at(1400));
    // A state other than soft e-stop (an answer to an older poll, say) confirms nothing.
    c.robot_motion_state(MotionState::Stepping);
    sent.extend(run(&mut c, at(1400), at(2000)));
    assert_eq!(times_of(&sent, &ESTOP), [1000, 1250, 1500, 1750, 2000]);
    assert_eq!(sent.len(), 5, "only e-stops: {sent:?}");
    assert_eq!(c.next_deadline(), Some(at(2250)));
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    assert!(!c.estop_unconfirmed());
    assert!(c.motion_locked(), "confirmed is not unlocked");
    assert_eq!(c.next_deadline(), None);
    assert!(run(&mut c, at(2000), at(5000)).is_empty());
}

#[test]
fn estop_latch_a_press_while_disconnected_goes_out_first_when_the_connection_opens() {
    let mut c = Control::new(&Config::default());
    c.press(Button::Estop, 0);
    c.release(Button::Estop, 100);
    assert!(c.motion_locked());
    assert_eq!(c.next_command(at(100), Health::Answering), None);
    assert_eq!(c.next_deadline(), None, "nothing to do while disconnected");
    // Presses of the outage that are still fresh wait behind it.
    c.press(Button::Stop, 4900);
    c.press(Button::LieDown, 4900);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(5000)), [ESTOP, ZERO, LIE_DOWN]);
    assert_eq!(c.next_deadline(), Some(at(5250)));
    assert!(!forward_goes_out(&mut c, 5010), "motion is locked out");
}

#[test]
fn estop_latch_repeats_continue_across_command_failures_and_answers() {
    let mut c = latched();
    // Timed out or refused.
    c.command_answered(Outcome::Failed);
    assert!(c.last_failed());
    assert_eq!(drain(&mut c, at(250)), [ESTOP]);
    c.command_answered(Outcome::Failed);
    assert_eq!(drain(&mut c, at(500)), [ESTOP]);
    // The robot accepting Command 13 is no confirmation: only its status is.
    c.command_answered(Outcome::Succeeded);
    assert_eq!(drain(&mut c, at(750)), [ESTOP]);
    assert!(c.estop_unconfirmed());
}

#[test]
fn estop_latch_repeats_continue_across_a_reconnect_and_go_out_at_once() {
    let mut c = latched();
    c.connection(ConnectionState::Connecting);
    assert_eq!(c.next_command(at(250), Health::Answering), None);
    // Back before the next repeat was due: the e-stop goes out at once all the same.
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(100)), [ESTOP]);
    assert_eq!(c.next_deadline(), Some(at(350)));
    // Back after a long outage.
    c.connection(ConnectionState::Connecting);
    assert!(run(&mut c, at(100), at(5000)).is_empty());
    c.connection(ConnectionState::Open);
    let sent = run(&mut c, at(5000), at(5500));
    assert_eq!(times_of(&sent, &ESTOP), [5000, 5250, 5500]);
}

#[test]
fn estop_latch_refuses_motion_and_dock_but_not_other_one_shots() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Estop, 0);
    assert_eq!(drain(&mut c, at(0)), [ESTOP]);
    assert!(!c.last_failed());
    c.press(Button::Dock, 10);
    assert!(c.last_failed(), "a refused dock is shown");
    assert!(!c.navigating());
    assert_eq!(c.take_task(at(10)), None);
    c.press(Button::Forward, 20);
    assert_eq!(drain(&mut c, at(20)), []);
    assert_eq!(c.active_motion(), None);
    c.press(Button::LieDown, 30);
    assert_eq!(drain(&mut c, at(30)), [LIE_DOWN]);
    // Confirmed and released, the robot still in soft e-stop: still refused.
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    c.release(Button::Estop, 40);
    c.release(Button::Forward, 40);
    assert!(!forward_goes_out(&mut c, 50));
    c.press(Button::Dock, 60);
    assert_eq!(c.take_task(at(60)), None);
}

#[test]
fn estop_latch_stays_while_the_button_is_held() {
    let mut c = latched();
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    c.robot_motion_state(MotionState::LyingDown);
    assert!(
        c.motion_locked(),
        "confirmed and left, but the button is down"
    );
    assert!(!forward_goes_out(&mut c, 100));
    c.release(Button::Estop, 200);
    assert!(!c.motion_locked());
    assert!(forward_goes_out(&mut c, 300));
}

#[test]
fn estop_latch_stays_without_the_robots_confirmation() {
    let mut c = latched();
    c.release(Button::Estop, 100);
    // The robot never reported soft e-stop.
    c.robot_motion_state(MotionState::LyingDown);
    c.robot_motion_state(MotionState::Stepping);
    assert!(c.motion_locked());
    assert!(c.estop_unconfirmed());
    assert!(!forward_goes_out(&mut c, 200));
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    assert!(c.motion_locked());
    c.robot_motion_state(MotionState::LyingDown);
    assert!(!c.motion_locked());
    assert!(forward_goes_out(&mut c, 300));
}

#[test]
fn estop_latch_stays_until_a_later_state_other_than_soft_estop() {
    let mut c = latched();
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    c.release(Button::Estop, 100);
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    assert!(
        c.motion_locked(),
        "released and confirmed, still in soft e-stop"
    );
    assert!(!forward_goes_out(&mut c, 200));
    c.robot_motion_state(MotionState::LyingDown);
    assert!(!c.motion_locked());
    assert!(forward_goes_out(&mut c, 300));
}

#[test]
fn estop_latch_a_new_press_needs_a_new_confirmation() {
    let mut c = latched();
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    c.robot_motion_state(MotionState::LyingDown);
    c.release(Button::Estop, 100);
    assert!(!c.motion_locked());
    c.press(Button::Estop, 1000);
    assert!(c.motion_locked());
    assert!(
        c.estop_unconfirmed(),
        "the last confirmation does not count"
    );
    c.robot_motion_state(MotionState::LyingDown);
    let sent = run(&mut c, at(1000), at(1500));
    assert_eq!(times_of(&sent, &ESTOP), [1000, 1250, 1500]);
}

#[test]
fn estop_latch_drops_queued_one_shots_and_an_ordered_dock() {
    let mut c = connected_with(&with_dock());
    c.press(Button::LieDown, 0);
    c.press(Button::Light, 0);
    c.press(Button::Dock, 0);
    c.press(Button::Estop, 10);
    assert_eq!(drain(&mut c, at(10)), [ESTOP]);
    assert_eq!(c.take_task(at(10)), None);
    assert!(!c.navigating());
}

#[test]
fn estop_latch_ends_held_motion_which_needs_a_new_press_after() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.press(Button::Estop, 100);
    assert_eq!(drain(&mut c, at(100)), [ESTOP]);
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    assert!(run(&mut c, at(100), at(3000)).is_empty());
    c.release(Button::Estop, 3000);
    c.robot_motion_state(MotionState::LyingDown);
    assert!(!c.motion_locked());
    // The forward button was held all along, but it drives only after a new press.
    assert!(run(&mut c, at(3000), at(4000)).is_empty());
    c.release(Button::Forward, 4000);
    assert_eq!(drain(&mut c, at(4000)), []);
    assert!(forward_goes_out(&mut c, 4100));
}

// Zero velocity.

#[test]
fn zero_velocity_on_release_goes_before_queued_one_shots() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.press(Button::LieDown, 100);
    c.press(Button::StopStepping, 100);
    c.release(Button::Forward, 100);
    assert_eq!(drain(&mut c, at(100)), [ZERO, LIE_DOWN, STOP_STEPPING]);
    // Once, not repeated.
    assert_eq!(c.next_deadline(), None);
    assert!(run(&mut c, at(100), at(5000)).is_empty());
}

#[test]
fn zero_velocity_is_not_dropped_when_the_one_shot_queue_is_full() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    for _ in 0..ONE_SHOT_QUEUE {
        c.press(Button::LieDown, 100);
    }
    c.release(Button::Forward, 100);
    assert!(!c.last_failed(), "nothing was dropped");
    // A press beyond the full queue is dropped, but not the stop.
    c.press(Button::StopStepping, 100);
    assert!(c.last_failed());
    let sent = drain(&mut c, at(100));
    assert_eq!(sent.first(), Some(&ZERO), "{sent:?}");
    assert_eq!(sent.len(), ONE_SHOT_QUEUE + 1, "{sent:?}");
    // `stop` with a full queue, too.
    for _ in 0..ONE_SHOT_QUEUE {
        c.press(Button::LieDown, 200);
    }
    c.press(Button::Stop, 200);
    assert_eq!(drain(&mut c, at(200)).first(), Some(&ZERO));
}

#[test]
fn zero_velocity_goes_first_after_a_reconnect_that_cut_motion_and_the_button_needs_a_new_press() {
    let mut c = connected();
    c.press(Button::TurnLeft, 0);
    assert_eq!(drain(&mut c, at(0)), [TURN_LEFT]);
    c.connection(ConnectionState::Connecting);
    assert_eq!(c.next_deadline(), None);
    assert!(run(&mut c, at(0), at(2000)).is_empty());
    c.press(Button::LieDown, 2000);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(2000)), [ZERO, LIE_DOWN]);
    // The button stayed down, but it no longer drives.
    assert_eq!(c.active_motion(), None);
    assert!(run(&mut c, at(2000), at(5000)).is_empty());
    // Its release sends nothing: it was not driving.
    c.release(Button::TurnLeft, 5000);
    assert_eq!(drain(&mut c, at(5000)), []);
    c.press(Button::TurnLeft, 6000);
    assert_eq!(drain(&mut c, at(6000)), [TURN_LEFT]);
}

#[test]
fn zero_velocity_after_an_outage_whose_release_was_lost() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.connection(ConnectionState::Connecting);
    c.release(Button::Forward, 100);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(500)), [ZERO]);
}

#[test]
fn an_outage_while_idle_sends_nothing() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    c.release(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [ZERO]);
    c.command_answered(Outcome::Succeeded);
    c.zero_velocity_answered(at(0));
    c.connection(ConnectionState::Connecting);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(600)), []);
    assert_eq!(c.next_deadline(), None);
}

/// Two zero velocities, the robot answering the first only: the second, after a press of
/// forward in between, is what says the robot stopped, and it goes again after an outage.
#[test]
fn the_answer_to_an_earlier_zero_velocity_does_not_settle_a_later_one() {
    let mut c = connected();
    // Forward and back to rest twice: two zero velocities, written at 100 and 300 ms.
    let drive = |c: &mut Control, ms: u64| {
        c.press(Button::Forward, ms);
        assert_eq!(drain(c, at(ms)), [FORWARD]);
        c.release(Button::Forward, ms + 100);
        assert_eq!(drain(c, at(ms + 100)), [ZERO]);
    };
    drive(&mut c, 0);
    drive(&mut c, 200);
    c.zero_velocity_answered(at(100));
    c.connection(ConnectionState::Connecting);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(900)), [ZERO], "the second is unanswered");
    // Its own answer settles it.
    drive(&mut c, 1000);
    c.zero_velocity_answered(at(1100));
    c.connection(ConnectionState::Connecting);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(1700)), []);
}

#[test]
fn a_zero_velocity_unanswered_when_the_connection_drops_goes_out_again_when_it_is_back() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.release(Button::Forward, 100);
    assert_eq!(drain(&mut c, at(100)), [ZERO]);
    // A robot that stopped reading never got it; its answer never comes.
    c.command_answered(Outcome::Failed);
    c.connection(ConnectionState::Connecting);
    assert!(run(&mut c, at(600), at(1000)).is_empty());
    c.connection(ConnectionState::Open);
    assert_eq!(c.next_deadline(), Some(Instant::MIN));
    assert_eq!(drain(&mut c, at(1000)), [ZERO]);
    // Once: a robot that never answers is not sent one on every connection.
    c.connection(ConnectionState::Connecting);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(2000)), []);
}

#[test]
fn an_unanswered_zero_velocity_is_not_sent_again_once_a_navigation_task_started() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.release(Button::Forward, 50);
    assert_eq!(drain(&mut c, at(50)), [ZERO]);
    c.press(Button::Dock, 100);
    let order = c.take_task(at(100)).expect("the dock task");
    c.task_started(order.id, at(100));
    // Zero velocity would take the robot out of its task.
    c.connection(ConnectionState::Connecting);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(600)), []);
    assert!(c.task_running(order.id));
}

/// Driving when the command connection dropped: a zero velocity is due when it is back.
/// But a dock pressed meanwhile, whose task the navigation connection started first, drives
/// the robot now: that zero velocity would take the robot out of it, and does not go.
#[test]
fn a_zero_velocity_due_after_an_outage_does_not_go_once_a_navigation_task_started() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.connection(ConnectionState::Connecting);
    c.press(Button::Dock, 100);
    let order = c.take_task(at(100)).expect("the dock task");
    c.task_started(order.id, at(100));
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(600)), []);
    assert!(c.task_running(order.id));
    // Without the task, it goes.
    let mut c = connected_with(&with_dock());
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.connection(ConnectionState::Connecting);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(600)), [ZERO]);
}

#[test]
fn stop_sends_zero_velocity_and_ends_held_motion() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.press(Button::Stop, 100);
    assert_eq!(drain(&mut c, at(100)), [ZERO]);
    // The forward button is still down (stuck, say), but it no longer drives.
    assert!(run(&mut c, at(100), at(2000)).is_empty());
    c.release(Button::Forward, 2000);
    assert_eq!(drain(&mut c, at(2000)), []);
}

// Motion.

#[test]
fn motion_repeats_at_the_configured_period_while_held_first_at_once() {
    let mut c = connected();
    c.press(Button::Forward, 1000);
    // Held for 10 s.
    let sent = run(&mut c, at(1000), at(11_000));
    let times = times_of(&sent, &FORWARD);
    assert_eq!(times.len(), 41, "{times:?}");
    assert_eq!(times[0], 1000);
    assert!(times.windows(2).all(|w| w[1] - w[0] == 250), "{times:?}");
    assert_eq!(sent.len(), times.len(), "only forward commands: {sent:?}");
    c.release(Button::Forward, 11_000);
    assert_eq!(drain(&mut c, at(11_000)), [ZERO]);
}

#[test]
fn motion_repeat_period_follows_the_configuration() {
    let config = Config {
        motion_repeat: Duration::from_millis(200),
        ..Config::default()
    };
    let mut c = connected_with(&config);
    c.press(Button::Forward, 0);
    let sent = run(&mut c, at(0), at(999));
    assert_eq!(times_of(&sent, &FORWARD), [0, 200, 400, 600, 800]);
}

#[test]
fn motion_first_command_goes_out_at_the_press() {
    let mut c = connected();
    assert_eq!(c.next_deadline(), None);
    c.press(Button::TurnLeft, 1234);
    assert!(c.next_deadline().unwrap() <= at(1234));
    assert_eq!(c.next_command(at(1234), Health::Answering), Some(TURN_LEFT));
    assert_eq!(c.next_command(at(1234), Health::Answering), None);
    assert_eq!(c.next_deadline(), Some(at(1484)));
    assert_eq!(c.next_command(at(1483), Health::Answering), None);
    assert_eq!(c.next_command(at(1484), Health::Answering), Some(TURN_LEFT));
}

#[test]
fn motion_a_late_wake_up_sends_one_repeat_not_a_burst() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    // The application was busy for a second.
    assert_eq!(drain(&mut c, at(1000)), [FORWARD]);
    assert_eq!(c.next_deadline(), Some(at(1250)));
}

#[test]
fn motion_not_allowed_skips_the_due_repeat_and_sends_no_burst_after() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(c.next_command(at(0), Health::Answering), Some(FORWARD));
    // The robot's answers are overdue: the repeat due at 250 is skipped...
    assert_eq!(c.next_command(at(250), Health::Overdue), None);
    assert_eq!(c.next_deadline(), Some(at(500)));
    // ...and not sent late once motion is allowed again.
    assert_eq!(c.next_command(at(300), Health::Answering), None);
    assert_eq!(c.next_command(at(500), Health::Answering), Some(FORWARD));
    // Overdue for a second: one repeat at the following period, not one per skipped one.
    for ms in [750, 1000, 1250] {
        assert_eq!(c.next_command(at(ms), Health::Overdue), None, "{ms}");
    }
    assert_eq!(c.next_command(at(1300), Health::Answering), None);
    assert_eq!(drain(&mut c, at(1500)), [FORWARD]);
}

#[test]
fn motion_not_allowed_still_lets_stops_and_one_shots_out() {
    let mut c = connected();
    c.press(Button::Forward, 0);
    assert_eq!(c.next_command(at(0), Health::Answering), Some(FORWARD));
    c.press(Button::LieDown, 100);
    c.release(Button::Forward, 100);
    assert_eq!(c.next_command(at(100), Health::Overdue), Some(ZERO));
    assert_eq!(c.next_command(at(100), Health::Overdue), Some(LIE_DOWN));
    c.press(Button::Estop, 200);
    assert_eq!(c.next_command(at(200), Health::Overdue), Some(ESTOP));
}

#[test]
fn motion_configured_speed_is_sent() {
    let mut config = Config::default();
    config.speeds.set(Direction::Forward, Speed::Value(0.8));
    config.speeds.set(Direction::StrafeLeft, Speed::Value(0.12));
    let mut c = connected_with(&config);
    c.press(Button::Forward, 0);
    assert_eq!(
        drain(&mut c, at(0)),
        [Request::Motion(MotionCommand::Move(
            Direction::Forward,
            Speed::Value(0.8)
        ))]
    );
    c.press(Button::StrafeLeft, 10);
    assert_eq!(
        drain(&mut c, at(10)),
        [Request::Motion(MotionCommand::Move(
            Direction::StrafeLeft,
            Speed::Value(0.12)
        ))]
    );
}

#[test]
fn motion_every_motion_button_sends_its_command() {
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
        c.press(button, 0);
        let Some(Request::Motion(command)) = c.next_command(at(0), Health::Answering) else {
            panic!("{button:?} sent no motion command");
        };
        assert_eq!(command.code().raw(), code, "{button:?}");
        assert_eq!(command.value(), MotionValue::Float(-1.0));
    }
}

#[test]
fn motion_latest_press_drives_and_release_falls_back() {
    let mut c = connected();
    let mut sent = Vec::new();
    c.press(Button::Forward, 0);
    sent.extend(run(&mut c, at(0), at(99)));
    c.press(Button::TurnLeft, 100);
    sent.extend(run(&mut c, at(100), at(199)));
    c.press(Button::Backward, 200);
    sent.extend(run(&mut c, at(200), at(600)));
    assert_eq!(
        sent.iter()
            .map(|(t, r)| (t.as_millis(), r.clone()))
            .collect::<Vec<_>>(),
        [
            (0, FORWARD),
            (100, TURN_LEFT),
            (200, BACKWARD),
            (450, BACKWARD)
        ]
    );
    // Releasing a button that does not drive changes nothing.
    c.release(Button::TurnLeft, 600);
    assert_eq!(drain(&mut c, at(600)), []);
    assert_eq!(c.active_motion(), Some(Button::Backward));
    // Releasing the driving one falls back to the latest still held, at once.
    c.release(Button::Backward, 650);
    assert_eq!(drain(&mut c, at(650)), [FORWARD]);
    assert_eq!(c.next_deadline(), Some(at(900)));
    assert_eq!(drain(&mut c, at(900)), [FORWARD]);
    c.release(Button::Forward, 1000);
    assert_eq!(drain(&mut c, at(1000)), [ZERO]);
    assert_eq!(c.active_motion(), None);
}

#[test]
fn motion_a_release_not_yet_followed_by_zero_velocity_still_sends_it_first() {
    // The application was busy: the release's stop is not lost behind the next press.
    let mut c = connected();
    c.press(Button::Forward, 0);
    c.release(Button::Forward, 50);
    c.press(Button::Backward, 80);
    assert_eq!(drain(&mut c, at(100)), [ZERO, BACKWARD]);
}

#[test]
fn motion_presses_while_disconnected_are_dropped() {
    let mut c = Control::new(&Config::default());
    c.press(Button::Backward, 0);
    assert_eq!(c.active_motion(), None);
    c.connection(ConnectionState::Open);
    assert!(run(&mut c, at(0), at(2000)).is_empty());
    c.release(Button::Backward, 2000);
    assert_eq!(drain(&mut c, at(2000)), []);
}

// Nothing stale.

/// The one-shot presses and what each sends first, with the robot walking.
fn one_shots() -> [(Button, Request); 5] {
    [
        (Button::StopStepping, STOP_STEPPING),
        (Button::LieDown, LIE_DOWN),
        (Button::Gait, switch_gait(MotionGait::NormalStairs)),
        (Button::Light, light(1)),
        (Button::Cancel, CANCEL),
    ]
}

#[test]
fn nothing_stale_a_press_pulled_within_300_ms_goes_out() {
    for (button, request) in one_shots() {
        let mut c = connected();
        c.button(event(button, true, 1000), Some(GaitState::Walk));
        assert!(c.next_deadline().unwrap() <= at(1000));
        assert_eq!(drain(&mut c, at(1300)), [request], "{button:?}");
        assert!(!c.last_failed(), "{button:?}");
    }
}

#[test]
fn nothing_stale_a_press_not_pulled_within_300_ms_is_dropped_and_shown() {
    for (button, _) in one_shots() {
        let mut c = connected();
        c.button(event(button, true, 1000), Some(GaitState::Walk));
        assert_eq!(drain(&mut c, at(1301)), [], "{button:?}");
        assert!(c.last_failed(), "{button:?}");
        // Never sent later either.
        assert_eq!(c.next_deadline(), None, "{button:?}");
        assert_eq!(drain(&mut c, at(1302)), [], "{button:?}");
    }
}

#[test]
fn nothing_stale_a_stale_press_does_not_hold_back_a_fresh_one() {
    let mut c = connected();
    c.press(Button::LieDown, 1000);
    c.press(Button::Light, 1200);
    assert_eq!(drain(&mut c, at(1350)), [light(1)]);
    assert!(c.last_failed());
}

#[test]
fn nothing_stale_presses_during_an_outage_go_stale() {
    let mut c = Control::new(&Config::default());
    c.press(Button::LieDown, 0);
    c.press(Button::Cancel, 0);
    assert_eq!(c.next_command(at(0), Health::Answering), None);
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(1000)), []);
    assert!(c.last_failed());
}

#[test]
fn nothing_stale_one_shot_queue_is_bounded_and_a_press_beyond_is_shown() {
    let mut c = connected();
    for _ in 0..ONE_SHOT_QUEUE {
        c.press(Button::LieDown, 0);
    }
    assert!(!c.last_failed());
    c.press(Button::StopStepping, 0);
    assert!(
        c.last_failed(),
        "the press beyond the queue is dropped and shown"
    );
    assert_eq!(drain(&mut c, at(0)), vec![LIE_DOWN; ONE_SHOT_QUEUE]);
    // An e-stop still gets in with the queue full.
    for _ in 0..ONE_SHOT_QUEUE * 2 {
        c.press(Button::LieDown, 10);
    }
    c.press(Button::Estop, 10);
    assert_eq!(drain(&mut c, at(10)), [ESTOP]);
}

#[test]
fn nothing_stale_a_dock_not_taken_within_300_ms_is_dropped() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Dock, 1000);
    assert!(c.navigating());
    assert_eq!(c.take_task(at(1301)), None);
    assert!(c.last_failed());
    assert!(!c.navigating());
    assert_eq!(c.take_task(at(1302)), None, "not taken later either");
    // Taken in time, it goes out.
    let mut c = connected_with(&with_dock());
    c.press(Button::Dock, 1000);
    let order = c.take_task(at(1300)).expect("a fresh order");
    assert!(c.task_wanted(order.id, at(1300)));
    assert!(!c.last_failed());
}

#[test]
fn nothing_stale_a_task_not_sent_within_300_ms_of_its_press_is_not_wanted() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Dock, 1000);
    let order = c.take_task(at(1000)).unwrap();
    // Connecting took a while.
    assert!(!c.task_wanted(order.id, at(1301)));
    assert!(c.last_failed());
    assert!(!c.navigating());
}

#[test]
fn nothing_stale_a_task_withdrawn_after_take_task_is_not_wanted() {
    for button in [Button::Cancel, Button::Stop, Button::Forward, Button::Estop] {
        let mut c = connected_with(&with_dock());
        c.press(Button::Dock, 0);
        let order = c.take_task(at(10)).unwrap();
        c.press(button, 20);
        assert!(!c.task_wanted(order.id, at(30)), "{button:?}");
        assert!(!c.navigating(), "{button:?}");
    }
}

#[test]
fn a_task_withdrawn_while_its_1003_went_out_is_cancelled_once_it_is_out() {
    for button in [Button::Cancel, Button::Stop, Button::Forward, Button::Estop] {
        let mut c = connected_with(&with_dock());
        c.press(Button::Dock, 0);
        let order = c.take_task(at(10)).unwrap();
        assert!(c.task_wanted(order.id, at(10)));
        // The press comes while the 1003 is being written.
        c.press(button, 20);
        drain(&mut c, at(20));
        c.task_started(order.id, at(30));
        assert!(!c.navigating(), "{button:?}");
        assert!(
            drain(&mut c, at(30)).contains(&CANCEL),
            "{button:?}: the task that went out all the same is cancelled"
        );
    }
}

#[test]
fn nothing_stale_an_older_order_is_not_wanted() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Dock, 0);
    let first = c.take_task(at(0)).unwrap();
    c.press(Button::Cancel, 10);
    c.press(Button::Dock, 20);
    let second = c.take_task(at(20)).unwrap();
    assert_ne!(first.id, second.id);
    assert!(!c.task_wanted(first.id, at(30)));
    assert!(c.task_wanted(second.id, at(30)));
}

// Navigation.

/// A control whose dock task, ordered at 0, runs; and its order.
fn running_task() -> (Control, TaskOrder) {
    let mut c = connected_with(&with_dock());
    c.press(Button::Dock, 0);
    let order = c.take_task(at(0)).unwrap();
    assert!(c.task_wanted(order.id, at(0)));
    c.task_started(order.id, at(0));
    assert!(c.navigating());
    (c, order)
}

#[test]
fn navigation_stop_during_a_running_task_sends_zero_velocity_and_cancel() {
    let (mut c, _) = running_task();
    c.press(Button::Stop, 1000);
    assert_eq!(drain(&mut c, at(1000)), [ZERO, CANCEL]);
    assert!(!c.navigating());
}

#[test]
fn navigation_stop_withdraws_an_ordered_task_without_cancel() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Dock, 0);
    let order = c.take_task(at(0)).unwrap();
    c.press(Button::Stop, 10);
    assert_eq!(drain(&mut c, at(10)), [ZERO]);
    assert!(!c.task_wanted(order.id, at(10)));
    assert!(!c.navigating());
}

#[test]
fn navigation_motion_press_during_a_running_task_cancels_it_first() {
    let (mut c, _) = running_task();
    c.press(Button::Forward, 1000);
    assert_eq!(drain(&mut c, at(1000)), [CANCEL, FORWARD]);
    assert!(!c.navigating());
    // A second press does not cancel again.
    c.press(Button::TurnLeft, 1100);
    assert_eq!(drain(&mut c, at(1100)), [TURN_LEFT]);
}

#[test]
fn navigation_motion_press_withdraws_an_ordered_task_without_cancel() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Dock, 0);
    c.press(Button::Forward, 10);
    assert_eq!(drain(&mut c, at(10)), [FORWARD]);
    assert_eq!(c.take_task(at(10)), None);
}

#[test]
fn navigation_cancel_withdraws_an_ordered_task_and_sends_1004() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Dock, 0);
    c.press(Button::Cancel, 10);
    assert_eq!(drain(&mut c, at(10)), [CANCEL]);
    assert!(!c.navigating());
    assert_eq!(c.take_task(at(10)), None);
}

#[test]
fn navigation_a_task_ends_with_its_answer() {
    let (mut c, order) = running_task();
    c.task_ended(order.id, TaskEnd::Reached, at(500));
    assert!(!c.navigating());
    assert!(!c.last_failed());
    let (mut c, order) = running_task();
    c.task_ended(order.id, TaskEnd::Cancelled, at(500));
    assert!(!c.last_failed(), "a cancelled task is not a failure");
    let (mut c, order) = running_task();
    c.task_ended(order.id, TaskEnd::Failed, at(500));
    assert!(!c.navigating());
    assert!(c.last_failed(), "a failed or lost task is shown");
}

#[test]
fn navigation_the_end_of_an_older_task_does_not_end_the_current_one() {
    let (mut c, first) = running_task();
    c.press(Button::Cancel, 1000);
    assert_eq!(drain(&mut c, at(1000)), [CANCEL]);
    c.press(Button::Dock, 1100);
    let second = c.take_task(at(1100)).unwrap();
    // The cancelled task's 1003 is answered now.
    c.task_ended(first.id, TaskEnd::Cancelled, at(1100));
    assert!(c.navigating());
    assert!(c.task_wanted(second.id, at(1100)));
}

#[test]
fn navigation_dock_while_a_task_runs_is_dropped() {
    let (mut c, order) = running_task();
    c.press(Button::Dock, 100);
    assert_eq!(c.take_task(at(100)), None);
    assert!(c.navigating());
    c.task_ended(order.id, TaskEnd::Reached, at(200));
    c.press(Button::Dock, 200);
    assert!(c.take_task(at(200)).is_some());
}

#[test]
fn navigation_dock_ends_held_motion() {
    let mut c = connected_with(&with_dock());
    c.press(Button::Forward, 0);
    assert_eq!(drain(&mut c, at(0)), [FORWARD]);
    c.press(Button::Dock, 100);
    assert_eq!(c.active_motion(), None);
    assert!(run(&mut c, at(100), at(2000)).is_empty());
    assert!(c.take_task(at(100)).is_some());
}

// Dock.

#[test]
fn dock_without_a_configured_point_orders_nothing_and_is_shown() {
    assert_eq!(Config::default().dock, None);
    let mut c = connected();
    c.press(Button::Dock, 0);
    assert!(c.last_failed());
    assert!(!c.navigating());
    assert_eq!(c.take_task(at(0)), None);
    assert_eq!(drain(&mut c, at(0)), []);
}

#[test]
fn dock_navigates_to_the_configured_charging_point() {
    let config = with_dock();
    let mut c = connected_with(&config);
    c.press(Button::Dock, 0);
    assert!(!c.last_failed());
    let order = c.take_task(at(0)).expect("an order");
    let point = config.dock.unwrap();
    assert_eq!(order.task.points.as_slice(), &[point]);
    let target = order.task.target().unwrap();
    assert_eq!(target.point_info, PointInfo::Charging);
    assert_eq!(
        (target.value, target.map_id, target.pos_x, target.pos_y),
        (5, 2, 1.5, 2.5)
    );
    assert!(Request::NavTask(order.task.clone()).validate().is_ok());
    assert!(c.navigating());
    // Nothing goes out on the command connection for it.
    assert_eq!(drain(&mut c, at(0)), []);
}

// Gait.

#[test]
fn gait_steps_on_from_the_robots_reported_gait() {
    let cases = [
        (GaitState::Walk, MotionGait::NormalStairs, 1),
        (GaitState::ObstacleCrossing, MotionGait::Slope, 2),
        (GaitState::Slope, MotionGait::PerceptionStairs, 4),
        (GaitState::PerceptionStairs, MotionGait::Walk, 0),
        (GaitState::AccumulatedFrameStairs, MotionGait::Walk, 0),
        (GaitState::AccumulatedFrameStairs45, MotionGait::Walk, 0),
        (GaitState::Unknown(5), MotionGait::Walk, 0),
    ];
    for (robot, next, raw) in cases {
        let mut c = connected();
        press_gait(&mut c, 0, Some(robot));
        assert_eq!(drain(&mut c, at(0)), [switch_gait(next)], "{robot:?}");
        assert_eq!(next.raw(), raw);
    }
    assert_eq!(GaitState::PerceptionStairs.raw(), 6);
}

#[test]
fn gait_follows_the_robot_not_a_local_counter() {
    let mut c = connected();
    // The robot has not switched yet when the second press comes.
    press_gait(&mut c, 0, Some(GaitState::Walk));
    press_gait(&mut c, 100, Some(GaitState::Walk));
    let normal_stairs = switch_gait(MotionGait::NormalStairs);
    assert_eq!(
        drain(&mut c, at(100)),
        [normal_stairs.clone(), normal_stairs]
    );
}

#[test]
fn gait_without_a_fresh_status_is_refused() {
    let mut c = connected();
    press_gait(&mut c, 0, None);
    assert!(c.last_failed());
    assert_eq!(drain(&mut c, at(0)), []);
    assert_eq!(c.next_deadline(), None);
}

#[test]
fn gait_codes_status_gait_to_command_20_gait() {
    assert_eq!(GaitState::Walk.motion_gait(), Some(MotionGait::Walk));
    assert_eq!(
        GaitState::ObstacleCrossing.motion_gait(),
        Some(MotionGait::NormalStairs)
    );
    assert_eq!(GaitState::Slope.motion_gait(), Some(MotionGait::Slope));
    assert_eq!(
        GaitState::PerceptionStairs.motion_gait(),
        Some(MotionGait::PerceptionStairs)
    );
    for none in [
        GaitState::AccumulatedFrameStairs,
        GaitState::AccumulatedFrameStairs45,
        GaitState::Unknown(3),
    ] {
        assert_eq!(none.motion_gait(), None, "{none:?}");
    }
}

#[test]
fn gait_codes_command_20_gait_cycle_and_round_trip() {
    let cycle = [
        MotionGait::Walk,
        MotionGait::NormalStairs,
        MotionGait::Slope,
        MotionGait::PerceptionStairs,
    ];
    for (i, gait) in cycle.into_iter().enumerate() {
        assert_eq!(gait.next(), cycle[(i + 1) % cycle.len()], "{gait:?}");
        assert_eq!(gait.gait_state().motion_gait(), Some(gait), "{gait:?}");
    }
    assert_eq!(MotionGait::Unknown(3).next(), MotionGait::Walk);
    assert_eq!(MotionGait::Unknown(3).gait_state(), GaitState::Unknown(3));
    // The two numberings differ: perception stairs is 4 for Command 20, 6 in the status.
    assert_eq!(
        (
            MotionGait::PerceptionStairs.raw(),
            MotionGait::PerceptionStairs.gait_state().raw()
        ),
        (4, 6)
    );
    assert_eq!(
        MotionGait::NormalStairs.gait_state(),
        GaitState::ObstacleCrossing
    );
}

#[test]
fn gait_codes_navigation_gait_to_status_gait() {
    let cases = [
        (NavGait::Walk, GaitState::Walk),
        (NavGait::ObstacleCrossing, GaitState::ObstacleCrossing),
        (NavGait::Slope, GaitState::Slope),
        (NavGait::PerceptionStairs, GaitState::PerceptionStairs),
        (
            NavGait::AccumulatedFrameStairs,
            GaitState::AccumulatedFrameStairs,
        ),
        (
            NavGait::AccumulatedFrameStairs45,
            GaitState::AccumulatedFrameStairs45,
        ),
        (NavGait::Unknown(9), GaitState::Unknown(9)),
    ];
    for (nav, status) in cases {
        assert_eq!(nav.gait_state(), status, "{nav:?}");
    }
    assert_eq!(
        [4, 6, 7].map(|raw| NavGait::from_raw(raw).gait_state().raw()),
        [6, 7, 8]
    );
}

// Light, answers and bookkeeping.

#[test]
fn light_cycles_through_the_presets() {
    let mut c = connected();
    let lights: Vec<_> = (0..5)
        .map(|i| {
            c.press(Button::Light, i * 100);
            match c.next_command(at(i * 100), Health::Answering) {
                Some(Request::Light(light)) => light,
                other => panic!("{other:?}"),
            }
        })
        .collect();
    let [off, green, amber, red] = DEFAULT_LIGHTS;
    assert_eq!(lights, [green, amber, red, off, green]);
    assert_eq!(red.effect, LightEffect::Breathing);
}

// The robot's light (`robot-light`).

const ESTOP_LIT: Request = Request::Light(ESTOP_LIGHT);

/// A connected control with `robot-light` on, its e-stop pressed and sent at 0, the
/// button still down.
fn latched_with_robot_light() -> Control {
    let mut c = connected_with(&Config {
        robot_light: true,
        ..Config::default()
    });
    c.press(Button::Estop, 0);
    assert_eq!(drain(&mut c, at(0)), [ESTOP]);
    c
}

#[test]
fn robot_light_turns_red_once_the_estop_is_confirmed_and_back_when_it_unlocks() {
    let mut c = latched_with_robot_light();
    // Not before the robot confirms: the e-stop repeats alone until then.
    assert_eq!(run(&mut c, at(0), at(500)).len(), 2, "e-stops only");
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    assert_eq!(
        c.next_deadline(),
        Some(Instant::MIN),
        "the light is due at once"
    );
    assert_eq!(drain(&mut c, at(510)), [ESTOP_LIT]);
    // Once: its answer or not, it is not sent again while the latch holds.
    c.light_answered(Outcome::Succeeded);
    assert_eq!(run(&mut c, at(510), at(2000)), []);
    c.release(Button::Estop, 2000);
    c.robot_motion_state(MotionState::LyingDown);
    assert!(!c.motion_locked());
    assert_eq!(drain(&mut c, at(2100)), [light(0)], "back to the preset");
    c.light_answered(Outcome::Succeeded);
    assert_eq!(run(&mut c, at(2100), at(3000)), []);
}

#[test]
fn robot_light_is_off_by_default() {
    let mut c = latched();
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    c.release(Button::Estop, 100);
    c.robot_motion_state(MotionState::LyingDown);
    assert_eq!(run(&mut c, at(0), at(1000)), [], "no light written");
}

#[test]
fn robot_light_never_goes_ahead_of_a_stop_motion_or_a_press() {
    let mut c = latched_with_robot_light();
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    c.press(Button::Stop, 100);
    c.press(Button::LieDown, 100);
    assert_eq!(drain(&mut c, at(100)), [ZERO, LIE_DOWN, ESTOP_LIT]);
    c.light_answered(Outcome::Succeeded);
    // Held motion after the unlock: the preset waits for the release's zero velocity.
    c.release(Button::Estop, 200);
    c.robot_motion_state(MotionState::LyingDown);
    c.press(Button::Forward, 200);
    assert_eq!(drain(&mut c, at(200)), [FORWARD]);
    assert_eq!(drain(&mut c, at(450)), [FORWARD]);
    c.release(Button::Forward, 500);
    assert_eq!(drain(&mut c, at(500)), [ZERO, light(0)]);
}

#[test]
fn robot_light_the_light_button_picks_the_preset_shown_after_the_estop() {
    let mut c = latched_with_robot_light();
    c.robot_motion_state(MotionState::SoftEmergencyStop);
    assert_eq!(drain(&mut c, at(10)), [ESTOP_LIT]);
    c.light_answered(Outcome::Succeeded);
    // Red stays while the latch holds; the press chooses what comes after.
    c.press(Button::Light, 100);
    assert_eq!(drain(&mut c, at(100)), []);
    c.release(Button::Estop, 200);
    c.robot_motion_state(MotionState::LyingDown);
    assert_eq!(drain(&mut c, at(200)), [light(1)]);
}

#[test]
fn robot_light_refused_or_hung_up_on_is_not_sent_again_until_a_save() {
    let refused = |c: &mut Control| c.light_answered(Outcome::Failed);
    let hung_up = |c: &mut Control| {
        c.connection(ConnectionState::Connecting);
        c.connection(ConnectionState::Open);
        drain(c, at(20));
    };
    for (name, give_up) in [
        ("refused", &refused as &dyn Fn(&mut Control)),
        ("hung up", &hung_up),
    ] {
        let mut c = latched_with_robot_light();
        c.robot_motion_state(MotionState::SoftEmergencyStop);
        assert_eq!(drain(&mut c, at(10)), [ESTOP_LIT], "{name}");
        give_up(&mut c);
        c.release(Button::Estop, 100);
        c.robot_motion_state(MotionState::LyingDown);
        assert_eq!(
            run(&mut c, at(100), at(1000)),
            [],
            "{name}: no preset after"
        );
        // Saving the setting again tries once more.
        c.reconfigure(&Config {
            robot_light: true,
            ..Config::default()
        });
        assert_eq!(drain(&mut c, at(1000)), [light(0)], "{name}");
    }
}

#[test]
fn command_answers_set_and_clear_the_failure() {
    let mut c = connected();
    assert!(!c.last_failed());
    c.command_answered(Outcome::Failed);
    assert!(c.last_failed());
    c.command_answered(Outcome::Succeeded);
    assert!(!c.last_failed());
}

#[test]
fn last_sent_is_when_the_last_command_went_out() {
    let mut c = connected();
    assert_eq!(c.last_sent(), None);
    c.press(Button::LieDown, 10);
    assert_eq!(c.last_sent(), None, "pressed, not sent");
    assert_eq!(drain(&mut c, at(20)), [LIE_DOWN]);
    assert_eq!(c.last_sent(), Some(at(20)));
}

#[test]
fn connection_is_reported() {
    let mut c = Control::new(&Config::default());
    assert!(!c.connected());
    c.connection(ConnectionState::Open);
    assert!(c.connected());
    c.connection(ConnectionState::Connecting);
    assert!(!c.connected());
}

#[test]
fn answers_say_whether_a_command_succeeded() {
    let ack = |result| MotionAck {
        value: Some(0.5),
        result,
    };
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
    assert!(succeeded(&Response::CancelNav(CommandAck {
        result: CommandResult::Success
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

/// A configuration with a three-point route: (1,0), (2,0) and (2,1) on map 1.
fn with_route() -> Config {
    let mut config = Config::default();
    for point in [
        "1,1,1,0,0,0,transition",
        "2,1,2,0,0,0,task",
        "3,1,2,1,0,1.5,standing",
    ] {
        config
            .route
            .push(RoutePoint::parse(point).unwrap())
            .unwrap();
    }
    config
}

/// The point order `order` goes to.
fn target(order: &TaskOrder) -> (i32, [f32; 2]) {
    let point = order.task.target().expect("one point");
    (point.value, [point.pos_x, point.pos_y])
}

/// Takes, checks and starts the ordered task at `ms`.
fn start(c: &mut Control, ms: u64) -> TaskOrder {
    let order = c.take_task(at(ms)).expect("an order");
    assert!(c.task_wanted(order.id, at(ms)));
    c.task_started(order.id, at(ms));
    order
}

#[test]
fn patrol_walks_the_route_point_after_point() {
    let mut c = connected_with(&with_route());
    c.press(Button::Patrol, 0);
    assert!(c.patrolling());
    let first = start(&mut c, 0);
    assert_eq!(target(&first), (1, [1.0, 0.0]));
    assert_eq!(c.take_task(at(10)), None, "one point at a time");
    c.task_ended(first.id, TaskEnd::Reached, at(5000));
    let second = start(&mut c, 5000);
    assert_eq!(target(&second), (2, [2.0, 0.0]));
    c.task_ended(second.id, TaskEnd::Reached, at(9000));
    let third = start(&mut c, 9000);
    assert_eq!(target(&third), (3, [2.0, 1.0]));
    assert_eq!(
        third.task.target().map(|p| p.point_info),
        Some(PointInfo::Standing)
    );
    c.task_ended(third.id, TaskEnd::Reached, at(12_000));
    assert!(!c.patrolling() && !c.navigating(), "the route is done");
    assert!(!c.last_failed());
    assert_eq!(c.take_task(at(12_000)), None);
}

#[test]
fn patrol_ends_at_a_failed_cancelled_or_lost_point_and_never_resumes() {
    for end in [TaskEnd::Failed, TaskEnd::Cancelled] {
        let mut c = connected_with(&with_route());
        c.press(Button::Patrol, 0);
        let first = start(&mut c, 0);
        c.task_ended(first.id, end, at(3000));
        assert!(!c.patrolling(), "{end:?}");
        assert_eq!(c.take_task(at(3000)), None, "{end:?}: no next point");
        assert_eq!(c.last_failed(), end == TaskEnd::Failed, "{end:?}");
    }
    // An outage: the point is lost with its connection, and the patrol with it.
    let mut c = connected_with(&with_route());
    c.press(Button::Patrol, 0);
    let first = start(&mut c, 0);
    c.connection(ConnectionState::Connecting);
    c.task_ended(first.id, TaskEnd::Failed, at(100));
    c.connection(ConnectionState::Open);
    assert_eq!(c.take_task(at(5000)), None);
    assert!(!c.patrolling());
}

#[test]
fn patrol_is_ended_by_stop_cancel_a_motion_press_or_an_estop() {
    for button in [Button::Stop, Button::Cancel, Button::Forward] {
        let mut c = connected_with(&with_route());
        c.press(Button::Patrol, 0);
        let first = start(&mut c, 0);
        c.press(button, 1000);
        assert!(!c.patrolling(), "{button:?}");
        assert!(
            drain(&mut c, at(1000)).contains(&CANCEL),
            "{button:?}: 1004"
        );
        // The robot's answer to the cancelled point starts nothing.
        c.task_ended(first.id, TaskEnd::Cancelled, at(1100));
        assert_eq!(c.take_task(at(1100)), None, "{button:?}");
    }
    let mut c = connected_with(&with_route());
    c.press(Button::Patrol, 0);
    let first = start(&mut c, 0);
    c.press(Button::Estop, 1000);
    assert!(!c.patrolling());
    // The e-stop first, then the 1004: a robot that did not fail the point in soft e-stop
    // would walk on once the e-stop is released.
    assert_eq!(drain(&mut c, at(1000)), [ESTOP, CANCEL]);
    assert!(!c.task_running(first.id), "the task is over for the panel");
    c.task_ended(first.id, TaskEnd::Failed, at(1200));
    assert_eq!(c.take_task(at(1200)), None);
}

/// A task cancelled by a press whose answer comes after a new patrol was pressed: the late
/// answer is the old task's, and the new patrol goes to the route's first point, not to the
/// charging point (nobody pressed dock).
#[test]
fn a_cancelled_tasks_late_answer_leaves_a_newer_patrol_alone() {
    for first_button in [Button::Dock, Button::Patrol] {
        let mut config = with_route();
        Key::Dock
            .apply(&mut config, "5,2,1.5,2.5,0,1")
            .expect("a valid dock point");
        let mut c = connected_with(&config);
        c.press(first_button, 0);
        let first = start(&mut c, 0);
        c.press(Button::Cancel, 1000);
        assert!(drain(&mut c, at(1000)).contains(&CANCEL));
        c.press(Button::Patrol, 1150);
        c.task_ended(first.id, TaskEnd::Cancelled, at(1200));
        assert!(c.patrolling(), "{first_button:?}: the new patrol stands");
        let order = c.take_task(at(1210)).expect("the new patrol's first point");
        assert_ne!(order.id, first.id);
        assert_eq!(target(&order), (1, [1.0, 0.0]), "{first_button:?}");
    }
}

/// An e-stop while the command connection is down: no 1004 is kept to go stale (and blink
/// the fault LED for a cancel nobody pressed); the task is over for the panel, whose
/// navigation connection then closes, which stops the task.
#[test]
fn an_estop_during_an_outage_ends_the_task_without_a_cancel_going_stale() {
    let mut c = connected_with(&with_route());
    c.press(Button::Patrol, 0);
    let first = start(&mut c, 0);
    c.connection(ConnectionState::Connecting);
    c.press(Button::Estop, 1000);
    assert!(!c.task_running(first.id));
    assert!(!c.patrolling());
    c.connection(ConnectionState::Open);
    assert_eq!(drain(&mut c, at(2000)), [ESTOP]);
    assert!(!c.last_failed(), "no fault blink");
}

#[test]
fn patrol_without_a_route_or_while_locked_only_blinks() {
    let mut c = connected();
    c.press(Button::Patrol, 0);
    assert!(!c.patrolling() && !c.navigating());
    assert!(c.last_failed(), "no route saved");
    assert_eq!(c.take_task(at(0)), None);

    let mut c = connected_with(&with_route());
    c.press(Button::Estop, 0);
    c.press(Button::Patrol, 100);
    assert!(!c.patrolling());
    assert!(c.last_failed(), "locked out by the e-stop");
}

#[test]
fn a_stale_patrol_press_is_dropped() {
    let mut c = connected_with(&with_route());
    c.press(Button::Patrol, 0);
    assert_eq!(c.take_task(at(500)), None, "not taken within 300 ms");
    assert!(!c.patrolling());
    assert!(c.last_failed());
}

#[test]
fn a_patrols_next_point_does_not_go_stale() {
    let mut c = connected_with(&with_route());
    c.press(Button::Patrol, 0);
    let first = start(&mut c, 0);
    c.task_ended(first.id, TaskEnd::Reached, at(5000));
    // Closing the finished point's connection took a while.
    let second = start(&mut c, 6000);
    assert_eq!(target(&second).0, 2);
}
