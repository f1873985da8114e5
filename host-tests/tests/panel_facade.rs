//! The `Panel` facade: control, monitor, view and indicators kept in step, on the command,
//! poll and navigation connections.

mod panel_support;

use embassy_time::Instant;
use panel_support::*;
use x30_panel::client::ClientError;
use x30_panel::client::Health;
use x30_panel::config::Config;
use x30_panel::panel::NetworkState;
use x30_panel::panel::indicators::FLASH;
use x30_panel::panel::{Busy, Button, ConnectionRole, ConnectionState, Led, LinkState, Panel};
use x30_panel::proto::codes::*;
use x30_panel::proto::message::*;

const FORWARD: Request = Request::Motion(MotionCommand::Move(Direction::Forward, Speed::Default));
const ESTOP: Request = Request::Motion(MotionCommand::SoftEmergencyStop);
const LIE_DOWN: Request = Request::Motion(MotionCommand::LieDown);
const ZERO: Request = Request::Motion(MotionCommand::ZeroVelocity);

/// A panel with `config`, its network up and its command and poll connections open at 0.
fn online_with(config: &Config) -> Panel {
    let mut p = Panel::new(config);
    p.network(NetworkState::Up);
    p.connection(ConnectionRole::Commands, ConnectionState::Open, at(0));
    p.connection(ConnectionRole::Polls, ConnectionState::Open, at(0));
    p
}

/// [`online_with`] the default configuration.
fn online() -> Panel {
    online_with(&Config::default())
}

/// Every command due at `now`, with motion allowed.
fn commands(p: &mut Panel, now: Instant) -> Vec<Request> {
    std::iter::from_fn(|| p.next_command(now, Health::Answering)).collect()
}

/// Every poll due at `now`.
fn polls(p: &mut Panel, now: Instant) -> Vec<Request> {
    std::iter::from_fn(|| p.next_poll(now)).collect()
}

/// `status` answered to a poll at `ms`.
fn answer(p: &mut Panel, status: RobotStatus, ms: u64) {
    p.poll_answered(&Response::Status(status), at(ms));
}

/// A 1003 answer with `outcome`.
fn nav_result(outcome: NavOutcome) -> NavResult {
    NavResult {
        value: 5,
        outcome,
        status: ErrorStatus::TaskCompleted,
    }
}

#[test]
fn commands_and_polls_go_out_on_their_own_connections() {
    let mut p = online();
    p.press(Button::Forward, 0);
    assert_eq!(commands(&mut p, at(0)), [FORWARD]);
    assert_eq!(
        polls(&mut p, at(0)),
        [
            Request::Status,
            Request::Perception,
            Request::Battery,
            Request::MotorTemperatures
        ]
    );
}

#[test]
fn each_connection_waits_until_it_is_open() {
    let mut p = Panel::new(&Config::default());
    p.network(NetworkState::Up);
    p.connection(ConnectionRole::Polls, ConnectionState::Open, at(0));
    p.press(Button::LieDown, 0);
    assert_eq!(p.command_deadline(), None);
    assert_eq!(commands(&mut p, at(0)), []);
    assert!(!polls(&mut p, at(0)).is_empty());
    p.connection(ConnectionRole::Commands, ConnectionState::Open, at(100));
    assert_eq!(commands(&mut p, at(100)), [LIE_DOWN]);
    // Polls stop with their connection, and those that fell due meanwhile go at once when
    // it is back (the motor temperatures, asked at 0, keep their time: 10 s).
    p.connection(ConnectionRole::Polls, ConnectionState::Connecting, at(200));
    assert_eq!(p.poll_deadline(), None);
    assert_eq!(polls(&mut p, at(5000)), []);
    p.connection(ConnectionRole::Polls, ConnectionState::Open, at(6000));
    assert!(p.poll_deadline().is_some_and(|due| due <= at(6000)));
    assert_eq!(
        polls(&mut p, at(6000)),
        [Request::Status, Request::Perception, Request::Battery]
    );
}

#[test]
fn connection_reports_whether_its_state_changed() {
    let mut p = Panel::new(&Config::default());
    let commands = ConnectionRole::Commands;
    assert!(!p.connection(commands, ConnectionState::Connecting, at(0)));
    assert!(p.connection(commands, ConnectionState::Open, at(0)));
    assert!(!p.connection(commands, ConnectionState::Open, at(10)));
    assert!(p.connection(commands, ConnectionState::NotAnswering, at(20)));
    assert!(p.connection(commands, ConnectionState::Connecting, at(30)));
    assert!(p.connection(ConnectionRole::Polls, ConnectionState::Open, at(40)));
    assert!(!p.connection(ConnectionRole::Polls, ConnectionState::Open, at(50)));
    // The navigation connection does not show on the LEDs.
    assert!(!p.connection(ConnectionRole::Navigation, ConnectionState::Open, at(60)));
}

#[test]
fn a_command_connection_not_answering_holds_motion_back_without_dropping_it() {
    let mut p = online();
    p.press(Button::Forward, 0);
    assert_eq!(commands(&mut p, at(0)), [FORWARD]);
    p.connection(
        ConnectionRole::Commands,
        ConnectionState::NotAnswering,
        at(100),
    );
    // The application allows no motion then.
    assert_eq!(p.next_command(at(250), Health::Overdue), None);
    p.connection(ConnectionRole::Commands, ConnectionState::Open, at(300));
    // Still open all along: no zero velocity, and the held button still drives.
    assert_eq!(commands(&mut p, at(300)), []);
    assert_eq!(commands(&mut p, at(500)), [FORWARD]);
}

#[test]
fn a_command_connection_lost_while_moving_sends_zero_velocity_first_when_back() {
    let mut p = online();
    p.press(Button::Forward, 0);
    assert_eq!(commands(&mut p, at(0)), [FORWARD]);
    p.connection(
        ConnectionRole::Commands,
        ConnectionState::Connecting,
        at(100),
    );
    assert_eq!(p.command_deadline(), None);
    p.connection(ConnectionRole::Commands, ConnectionState::Open, at(1000));
    assert_eq!(commands(&mut p, at(1000)), [ZERO]);
    assert_eq!(
        commands(&mut p, at(1250)),
        [],
        "the held button needs a new press"
    );
}

#[test]
fn only_the_robot_answering_the_zero_velocity_spares_it_a_second_one_after_an_outage() {
    let answered = |code, result| {
        Response::Motion(
            code,
            MotionAck {
                value: Some(-1.0),
                result,
            },
        )
    };
    let outage = |p: &mut Panel, ms: u64| {
        p.connection(
            ConnectionRole::Commands,
            ConnectionState::Connecting,
            at(ms),
        );
        p.connection(
            ConnectionRole::Commands,
            ConnectionState::Open,
            at(ms + 500),
        );
        commands(p, at(ms + 500))
    };
    let mut p = online();
    p.press(Button::Forward, 0);
    assert_eq!(commands(&mut p, at(0)), [FORWARD]);
    p.release(Button::Forward, 100);
    assert_eq!(commands(&mut p, at(100)), [ZERO]);
    // The answer to the motion before it says nothing about the zero velocity.
    let forward = MotionCommandCode::Forward;
    p.command_answered(
        MessageType::Motion,
        Some(at(0)),
        Ok(&answered(forward, CommandResult::Success)),
    );
    assert_eq!(outage(&mut p, 200), [ZERO]);
    // Refused or not, the robot read it.
    let code = MotionCommandCode::ZeroVelocity;
    p.command_answered(
        MessageType::Motion,
        Some(at(700)),
        Ok(&answered(code, CommandResult::Failure)),
    );
    assert_eq!(outage(&mut p, 1000), []);
}

#[test]
fn estop_latch_a_status_of_soft_estop_stops_the_repeats() {
    let mut p = online();
    p.press(Button::Estop, 10);
    assert_eq!(commands(&mut p, at(10)), [ESTOP]);
    assert_eq!(p.command_deadline(), Some(at(260)));
    // Other answers are no confirmation.
    p.poll_answered(&Response::Battery(battery()), at(100));
    answer(&mut p, status(), 150);
    assert_eq!(commands(&mut p, at(260)), [ESTOP]);
    answer(&mut p, status_in(MotionState::SoftEmergencyStop), 300);
    assert!(!p.control().estop_unconfirmed());
    assert_eq!(p.command_deadline(), None);
    assert_eq!(commands(&mut p, at(510)), []);
}

#[test]
fn estop_latch_unlocks_with_release_then_a_readable_status_out_of_soft_estop() {
    let mut p = online();
    p.press(Button::Estop, 10);
    assert_eq!(commands(&mut p, at(10)), [ESTOP]);
    p.release(Button::Estop, 20);
    answer(&mut p, status_in(MotionState::SoftEmergencyStop), 30);
    assert!(p.control().motion_locked());
    assert_eq!(p.indicators(at(30)).fault, Led::On);
    // An all-zero status says "lying down" but means nothing.
    answer(&mut p, RobotStatus::UNAVAILABLE, 40);
    assert!(p.control().motion_locked());
    answer(&mut p, status(), 50);
    assert!(!p.control().motion_locked());
    p.press(Button::Forward, 60);
    assert_eq!(commands(&mut p, at(60)), [FORWARD]);
}

#[test]
fn gait_steps_on_from_the_fresh_status() {
    let mut p = online();
    answer(
        &mut p,
        RobotStatus {
            gait_state: Some(GaitState::Slope),
            ..status()
        },
        0,
    );
    p.press(Button::Gait, 100);
    assert_eq!(
        commands(&mut p, at(100)),
        [Request::Motion(MotionCommand::SwitchGait(
            MotionGait::PerceptionStairs
        ))]
    );
    assert!(!p.control().last_failed());
    // The status of 0 is stale at 2000: the robot's gait is not known.
    p.press(Button::Gait, 2000);
    assert_eq!(commands(&mut p, at(2000)), []);
    assert!(p.control().last_failed());
}

#[test]
fn gait_without_a_readable_status_is_refused() {
    let mut p = online();
    p.press(Button::Gait, 0);
    assert_eq!(commands(&mut p, at(0)), []);
    assert!(p.control().last_failed());
    let mut p = online();
    answer(&mut p, RobotStatus::UNAVAILABLE, 0);
    p.press(Button::Gait, 10);
    assert_eq!(commands(&mut p, at(10)), []);
    assert!(p.control().last_failed());
}

#[test]
fn dock_runs_the_task_polls_its_state_and_ends_with_its_answer() {
    let mut p = online_with(&with_dock());
    polls(&mut p, at(0));
    answer(&mut p, status(), 0);
    p.press(Button::Dock, 100);
    let order = p.take_task(at(100)).expect("an order");
    assert_eq!(
        order.task.target().map(|t| t.point_info),
        Some(PointInfo::Charging)
    );
    assert!(p.task_wanted(order.id, at(100)));
    p.task_started(order.id, at(100));
    assert!(p.control().navigating());
    assert_eq!(p.indicators(at(1000)).activity, Led::On);
    // 1007 is polled a second after the press.
    assert!(polls(&mut p, at(1100)).contains(&Request::NavStatus));
    p.task_ended(order.id, Ok(&nav_result(NavOutcome::Succeeded)), at(1200));
    assert!(!p.control().navigating());
    assert!(!p.control().last_failed());
    assert_eq!(
        p.view().nav_result().map(|r| (r.value.outcome, r.at)),
        Some((NavOutcome::Succeeded, at(1200)))
    );
    assert_eq!(p.indicators(at(1300)).activity, Led::Off);
    assert!(!polls(&mut p, at(2100)).contains(&Request::NavStatus));
}

#[test]
fn dock_a_failed_or_lost_task_is_shown() {
    for end in [Ok(nav_result(NavOutcome::Failed)), Err(ClientError::Closed)] {
        let mut p = online_with(&with_dock());
        answer(&mut p, status(), 0);
        p.press(Button::Dock, 0);
        let order = p.take_task(at(0)).unwrap();
        assert!(p.task_wanted(order.id, at(0)));
        p.task_started(order.id, at(0));
        p.task_ended(order.id, end.as_ref(), at(100));
        assert!(!p.control().navigating(), "{end:?}");
        assert_eq!(p.indicators(at(100)).fault, Led::Blink, "{end:?}");
    }
}

#[test]
fn dock_a_stale_order_ends_its_navigation_polls() {
    let mut p = online_with(&with_dock());
    polls(&mut p, at(0));
    p.press(Button::Dock, 100);
    assert_eq!(p.take_task(at(500)), None, "not taken within 300 ms");
    assert!(!polls(&mut p, at(1100)).contains(&Request::NavStatus));
    // Taken in time, but not sent within 300 ms of the press.
    let mut p = online_with(&with_dock());
    polls(&mut p, at(0));
    p.press(Button::Dock, 100);
    let order = p.take_task(at(100)).unwrap();
    assert!(!p.task_wanted(order.id, at(500)));
    assert!(!polls(&mut p, at(1100)).contains(&Request::NavStatus));
}

#[test]
fn dock_without_a_configured_point_blinks_the_fault_led() {
    let mut p = online();
    answer(&mut p, status(), 0);
    assert_eq!(p.indicators(at(10)).fault, Led::Off);
    p.press(Button::Dock, 10);
    assert_eq!(p.take_task(at(10)), None);
    assert_eq!(p.indicators(at(10)).fault, Led::Blink);
}

#[test]
fn command_answers_show_on_the_fault_led() {
    let mut p = online();
    answer(&mut p, status(), 0);
    let fault = |p: &Panel| p.indicators(at(10)).fault;
    p.command_answered(MessageType::Motion, Some(at(0)), Err(&ClientError::Timeout));
    assert_eq!(fault(&p), Led::Blink, "no answer");
    let ack = |result| {
        Response::Motion(
            MotionCommandCode::LieDown,
            MotionAck {
                value: Some(0.0),
                result,
            },
        )
    };
    p.command_answered(
        MessageType::Motion,
        Some(at(0)),
        Ok(&ack(CommandResult::Success)),
    );
    assert_eq!(fault(&p), Led::Off);
    p.command_answered(
        MessageType::Motion,
        Some(at(0)),
        Ok(&ack(CommandResult::Failure)),
    );
    assert_eq!(fault(&p), Led::Blink, "refused");
    p.command_answered(
        MessageType::CancelNav,
        Some(at(0)),
        Ok(&Response::CancelNav(CommandAck {
            result: CommandResult::Success,
        })),
    );
    assert_eq!(fault(&p), Led::Off);
    p.command_answered(
        MessageType::Motion,
        Some(at(0)),
        Ok(&Response::RequestError(RequestError {
            code: RequestErrorCode::ParseFailed,
        })),
    );
    assert_eq!(fault(&p), Led::Blink, "Type 0");
}

#[test]
fn link_led_follows_the_network_and_the_connections() {
    let mut p = Panel::new(&Config::default());
    let link = |p: &Panel, ms| (p.link_state(), p.indicators(at(ms)).link);
    assert_eq!(link(&p, 0), (LinkState::NoNetwork, Led::Off));
    p.network(NetworkState::Up);
    assert_eq!(link(&p, 0), (LinkState::Connecting, Led::Blink));
    p.connection(ConnectionRole::Commands, ConnectionState::Open, at(0));
    assert_eq!(
        link(&p, 0),
        (LinkState::Connecting, Led::Blink),
        "polls not open"
    );
    p.connection(ConnectionRole::Polls, ConnectionState::Open, at(0));
    // Connected, but no status yet.
    assert_eq!(link(&p, 0), (LinkState::Connected, Led::BlinkFast));
    answer(&mut p, status(), 10);
    assert_eq!(link(&p, 10), (LinkState::Connected, Led::On));
    // An all-zero status is an answer: the robot answers, its state is not known.
    answer(&mut p, RobotStatus::UNAVAILABLE, 20);
    assert_eq!(link(&p, 20), (LinkState::Connected, Led::On));
    for connection in [ConnectionRole::Commands, ConnectionRole::Polls] {
        p.connection(connection, ConnectionState::NotAnswering, at(30));
        assert_eq!(link(&p, 30), (LinkState::NotAnswering, Led::BlinkFast));
        p.connection(connection, ConnectionState::Open, at(40));
        assert_eq!(link(&p, 40), (LinkState::Connected, Led::On));
    }
    // The last status goes stale 2 s after it came.
    assert_eq!(link(&p, 2020), (LinkState::Connected, Led::BlinkFast));
    p.network(NetworkState::Down);
    assert_eq!(link(&p, 100), (LinkState::NoNetwork, Led::Off));
}

#[test]
fn fault_led_follows_the_robot() {
    let mut p = online();
    answer(&mut p, status(), 0);
    assert_eq!(p.indicators(at(0)).fault, Led::Off);
    answer(&mut p, RobotStatus::UNAVAILABLE, 100);
    assert_eq!(p.indicators(at(100)).fault, Led::Blink);
    answer(&mut p, status_in(MotionState::Fallen), 200);
    assert_eq!(p.indicators(at(200)).fault, Led::On);
}

#[test]
fn activity_flashes_per_command_and_the_leds_say_when_they_change() {
    let mut p = online();
    answer(&mut p, status(), 0);
    p.press(Button::LieDown, 20);
    assert_eq!(commands(&mut p, at(20)), [LIE_DOWN]);
    assert_eq!(p.indicators(at(30)).activity, Led::On);
    assert_eq!(p.indicators_deadline(at(30)), Some(at(20) + FLASH));
    assert_eq!(p.indicators(at(20) + FLASH).activity, Led::Off);
    // Then the status going stale.
    assert_eq!(p.indicators_deadline(at(100)), Some(at(2000)));
}

#[test]
fn deadlines_cover_repeats_and_polls() {
    let mut p = online();
    polls(&mut p, at(0));
    assert_eq!(p.poll_deadline(), Some(at(500)));
    assert_eq!(p.command_deadline(), None);
    p.press(Button::Forward, 100);
    assert!(p.command_deadline().unwrap() <= at(100));
    commands(&mut p, at(100));
    assert_eq!(p.command_deadline(), Some(at(350)));
}

#[test]
fn the_panel_is_busy_while_a_stop_a_held_motion_or_a_task_is_under_way() {
    let mut p = online_with(&with_dock());
    polls(&mut p, at(0));
    answer(&mut p, status(), 0);
    assert_eq!(p.busy(), None, "idle");

    p.press(Button::Forward, 10);
    assert_eq!(p.busy(), Some(Busy::MotionHeld));
    p.release(Button::Forward, 20);
    assert_eq!(
        p.busy(),
        Some(Busy::StopPending),
        "zero velocity not yet out"
    );
    commands(&mut p, at(20));
    assert_eq!(p.busy(), None);

    p.press(Button::Estop, 30);
    assert_eq!(p.busy(), Some(Busy::StopPending));
    commands(&mut p, at(30));
    assert_eq!(
        p.busy(),
        Some(Busy::StopPending),
        "e-stop not yet confirmed"
    );
    answer(
        &mut p,
        RobotStatus {
            motion_state: MotionState::SoftEmergencyStop,
            ..status()
        },
        40,
    );
    p.release(Button::Estop, 50);
    assert_eq!(p.busy(), None, "the robot confirmed the e-stop");

    let mut p = online_with(&with_dock());
    polls(&mut p, at(0));
    answer(&mut p, status(), 0);
    p.press(Button::Dock, 100);
    p.release(Button::Dock, 110);
    let order = p.take_task(at(110)).expect("an order");
    p.task_started(order.id, at(110));
    assert_eq!(p.busy(), Some(Busy::TaskRunning));
    p.task_ended(order.id, Ok(&nav_result(NavOutcome::Succeeded)), at(900));
    assert_eq!(p.busy(), None);
}
