//! The `Panel` facade: control, monitor, view and indicators kept in step.

mod panel_support;

use panel_support::*;
use x30_panel::config::Config;
use x30_panel::panel::{Action, Button, Led, LinkState, Panel};
use x30_panel::proto::codes::*;
use x30_panel::proto::message::*;

fn connected_panel() -> Panel {
    let mut p = Panel::new(&Config::default());
    p.link(LinkState::Connected, at(0));
    p
}

fn drain(p: &mut Panel, now: embassy_time::Instant) -> Vec<Action> {
    std::iter::from_fn(|| p.next_action(now)).collect()
}

#[test]
fn commands_go_before_polls() {
    let mut p = connected_panel();
    p.button(Button::Forward, true, at(0));
    let actions = drain(&mut p, at(0));
    assert_eq!(
        actions[0],
        Action::Send(Request::Motion(MotionCommand::Forward(Speed::Default)))
    );
    assert_eq!(
        actions.len(),
        5,
        "the command, then four polls: {actions:?}"
    );
    assert!(actions[1..].iter().all(|a| !a.is_command()));
}

#[test]
fn nothing_while_not_connected() {
    let mut p = Panel::new(&Config::default());
    p.link(LinkState::Connecting, at(0));
    p.button(Button::LieDown, true, at(0));
    assert_eq!(drain(&mut p, at(0)), []);
    assert_eq!(p.indicators(at(0)).link, Led::Blink);
}

#[test]
fn status_answers_release_the_estop_lock() {
    let mut p = connected_panel();
    drain(&mut p, at(0));
    p.button(Button::Estop, true, at(10));
    assert_eq!(
        drain(&mut p, at(10)),
        [Action::Send(Request::Motion(
            MotionCommand::SoftEmergencyStop
        ))]
    );
    p.button(Button::Estop, false, at(20));
    let soft_estop = RobotStatus {
        motion_state: MotionState::SoftEmergencyStop,
        ..status()
    };
    p.response(&Response::Status(soft_estop), at(30));
    assert!(p.control().motion_locked());
    assert_eq!(p.indicators(at(30)).fault, Led::On);
    // An all-zero status says "lying down" but means nothing.
    p.response(&Response::Status(RobotStatus::UNAVAILABLE), at(40));
    assert!(p.control().motion_locked());
    p.response(&Response::Status(status()), at(50));
    assert!(!p.control().motion_locked());
}

#[test]
fn dock_runs_the_task_polls_its_state_and_ends_with_its_answer() {
    let mut p = connected_panel();
    drain(&mut p, at(0));
    p.button(Button::Dock, true, at(100));
    let actions = drain(&mut p, at(100));
    assert!(matches!(actions.as_slice(), [Action::Navigate(_)]));
    p.sent(&actions[0], true, at(100));
    assert!(p.control().navigating());
    assert_eq!(p.indicators(at(1000)).activity, Led::On);
    // 1007 is polled one second after the task started.
    let polls = drain(&mut p, at(1100));
    assert!(
        polls.contains(&Action::Send(Request::NavStatus)),
        "{polls:?}"
    );
    p.response(
        &Response::NavResult(NavResult {
            value: 1,
            outcome: NavOutcome::Succeeded,
            status: ErrorStatus::TaskCompleted,
        }),
        at(1200),
    );
    assert!(!p.control().navigating());
    assert_eq!(p.indicators(at(1300)).activity, Led::Off);
    let polls = drain(&mut p, at(2100));
    assert!(
        !polls.contains(&Action::Send(Request::NavStatus)),
        "{polls:?}"
    );
}

#[test]
fn leds_follow_the_panel() {
    let mut p = Panel::new(&Config::default());
    assert_eq!(p.indicators(at(0)).link, Led::Off);
    p.link(LinkState::Connected, at(0));
    assert_eq!(p.indicators(at(0)).link, Led::Blink);
    drain(&mut p, at(0));
    p.response(&Response::Status(status()), at(10));
    let leds = p.indicators(at(10));
    assert_eq!(
        (leds.link, leds.activity, leds.fault),
        (Led::On, Led::Off, Led::Off)
    );
    let stop = Action::Send(Request::Motion(MotionCommand::ZeroVelocity));
    p.sent(&stop, false, at(20));
    let leds = p.indicators(at(30));
    assert_eq!((leds.activity, leds.fault), (Led::On, Led::Blink));
    assert_eq!(p.next_deadline(at(30)), Some(at(70)), "the flash ends");
    p.sent(&stop, true, at(100));
    assert_eq!(p.indicators(at(200)).fault, Led::Off);
}

#[test]
fn next_deadline_covers_repeats_and_polls() {
    let mut p = connected_panel();
    drain(&mut p, at(0));
    assert_eq!(p.next_deadline(at(0)), Some(at(500)));
    p.button(Button::Forward, true, at(100));
    assert!(p.next_deadline(at(100)).unwrap() <= at(100));
    drain(&mut p, at(100));
    assert_eq!(p.next_deadline(at(100)), Some(at(350)));
}
