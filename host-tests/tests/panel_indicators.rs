//! The three LEDs, rule by rule (docs/design.md, "Indicators").

mod panel_support;

use embassy_time::Instant;
use panel_support::*;
use x30_panel::config::Config;
use x30_panel::panel::indicators::*;
use x30_panel::panel::{Fault, Led, LinkState, RobotView};
use x30_panel::proto::codes::*;
use x30_panel::proto::message::*;

/// A view holding `status` and a healthy battery, both answered at 0.
fn view_with(status: RobotStatus) -> RobotView {
    let mut v = RobotView::new(&Config::default());
    v.update(&Response::Status(status), at(0));
    v.update(&Response::Battery(battery()), at(0));
    v
}

/// The fault LED while connected, with no failed command, at 100 ms.
fn fault_of(status: RobotStatus) -> Led {
    fault_led(LinkState::Connected, &view_with(status), false, at(100))
}

#[test]
fn link_led_rules() {
    let fresh = view_with(status());
    let empty = RobotView::new(&Config::default());
    assert_eq!(link_led(LinkState::NoNetwork, &fresh, at(100)), Led::Off);
    assert_eq!(link_led(LinkState::Connecting, &fresh, at(100)), Led::Blink);
    assert_eq!(link_led(LinkState::Connected, &fresh, at(100)), Led::On);
    // Connected, but a connection's answers are overdue.
    assert_eq!(
        link_led(LinkState::NotAnswering, &fresh, at(100)),
        Led::BlinkFast
    );
    // Connected, but no fresh status: the robot does not answer its polls.
    assert_eq!(
        link_led(LinkState::Connected, &empty, at(100)),
        Led::BlinkFast
    );
    assert_eq!(link_led(LinkState::Connected, &fresh, at(1999)), Led::On);
    assert_eq!(
        link_led(LinkState::Connected, &fresh, at(2000)),
        Led::BlinkFast
    );
    // An all-zero status is an answer: the robot answers, its state is not known (the
    // fault LED shows that).
    let zero = view_with(RobotStatus::UNAVAILABLE);
    assert_eq!(link_led(LinkState::Connected, &zero, at(100)), Led::On);
}

#[test]
fn activity_flashes_50_ms_per_command() {
    assert_eq!(FLASH.as_millis(), 50);
    assert_eq!(activity_led(Navigation::Idle, None, at(100)), Led::Off);
    let sent = Some(at(1000));
    assert_eq!(activity_led(Navigation::Idle, sent, at(1000)), Led::On);
    assert_eq!(activity_led(Navigation::Idle, sent, at(1049)), Led::On);
    assert_eq!(activity_led(Navigation::Idle, sent, at(1050)), Led::Off);
    assert_eq!(activity_led(Navigation::Idle, sent, at(999)), Led::Off);
}

#[test]
fn activity_is_steady_while_navigating() {
    assert_eq!(activity_led(Navigation::Task, None, at(100)), Led::On);
    assert_eq!(
        activity_led(Navigation::Task, Some(at(0)), at(10_000)),
        Led::On
    );
    // A patrol blinks, whatever was sent.
    assert_eq!(activity_led(Navigation::Patrol, None, at(100)), Led::Blink);
    assert_eq!(
        activity_led(Navigation::Patrol, Some(at(90)), at(100)),
        Led::Blink
    );
}

#[test]
fn fault_off_for_a_healthy_robot() {
    assert_eq!(fault_of(status()), Led::Off);
    assert_eq!(fault(&view_with(status()), at(100)), None);
}

#[test]
fn each_fault_lights_the_fault_led() {
    type Change = fn(&mut RobotStatus);
    let cases: [(Change, Fault); 5] = [
        (|s| s.motion_state = MotionState::Fallen, Fault::Fallen),
        (
            |s| s.motion_state = MotionState::SoftEmergencyStop,
            Fault::SoftEmergencyStop,
        ),
        (
            |s| s.motor_state = Some(MotorState::OverTemperature),
            Fault::MotorOverTemperature,
        ),
        (
            |s| s.location = Some(Location::Lost),
            Fault::LocalisationLost,
        ),
        (|s| s.electricity = Some(20), Fault::BatteryLow),
    ];
    for (change, expected) in cases {
        let mut s = status();
        change(&mut s);
        assert_eq!(fault(&view_with(s), at(100)), Some(expected));
        assert_eq!(fault_of(s), Led::On, "{expected:?}");
    }
}

#[test]
fn battery_threshold_is_20_percent() {
    let with = |electricity| RobotStatus {
        electricity: Some(electricity),
        ..status()
    };
    assert_eq!(fault_of(with(21)), Led::Off);
    assert_eq!(fault_of(with(20)), Led::On);
    assert_eq!(fault_of(with(5)), Led::On);
}

#[test]
fn battery_protection_lights_the_fault_led() {
    let mut v = view_with(status());
    v.update(
        &Response::Battery(Battery {
            protected_state: Some(ProtectedState::Triggered),
            ..battery()
        }),
        at(50),
    );
    assert_eq!(fault(&v, at(100)), Some(Fault::BatteryProtection));
    assert_eq!(fault_led(LinkState::Connected, &v, false, at(100)), Led::On);
}

#[test]
fn battery_protection_counts_from_an_answer_that_leaves_the_rest_out() {
    // A robot that reports the protection and no reading that can be read beside it.
    let answer = Response::decode(
        b"<PatrolDevice><Type>2001</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time>\
          <Items><Voltage>5,3</Voltage><ProtectedState>1</ProtectedState></Items></PatrolDevice>",
    )
    .expect("the readable items are read");
    let mut v = RobotView::new(&Config::default());
    v.update(&Response::Status(status()), at(0));
    v.update(&answer.message, at(50));
    assert_eq!(fault(&v, at(100)), Some(Fault::BatteryProtection));
}

#[test]
fn stale_or_unavailable_status_blinks() {
    let mut fallen = status();
    fallen.motion_state = MotionState::Fallen;
    let v = view_with(fallen);
    // A fall reported 2 s ago is no longer known: the status is unavailable instead.
    assert_eq!(
        fault_led(LinkState::Connected, &v, false, at(1999)),
        Led::On
    );
    assert_eq!(
        fault_led(LinkState::Connected, &v, false, at(2000)),
        Led::Blink
    );
    assert_eq!(fault_of(RobotStatus::UNAVAILABLE), Led::Blink);
    let empty = RobotView::new(&Config::default());
    assert_eq!(
        fault_led(LinkState::Connected, &empty, false, at(0)),
        Led::Blink
    );
}

#[test]
fn failed_command_blinks() {
    let v = view_with(status());
    assert_eq!(
        fault_led(LinkState::Connected, &v, true, at(100)),
        Led::Blink
    );
    // A robot fault is more than a failed command.
    let mut s = status();
    s.location = Some(Location::Lost);
    assert_eq!(
        fault_led(LinkState::Connected, &view_with(s), true, at(100)),
        Led::On
    );
}

#[test]
fn without_a_connection_only_a_failed_command_blinks_the_fault_led() {
    let empty = RobotView::new(&Config::default());
    for link in [LinkState::NoNetwork, LinkState::Connecting] {
        assert_eq!(fault_led(link, &empty, false, at(100)), Led::Off);
        assert_eq!(fault_led(link, &empty, true, at(100)), Led::Blink);
    }
}

#[test]
fn not_answering_is_connected_for_the_fault_led() {
    let empty = RobotView::new(&Config::default());
    assert_eq!(
        fault_led(LinkState::NotAnswering, &empty, false, at(100)),
        Led::Blink
    );
    let zero = view_with(RobotStatus::UNAVAILABLE);
    assert_eq!(
        fault_led(LinkState::NotAnswering, &zero, false, at(100)),
        Led::Blink
    );
    assert_eq!(
        fault_led(
            LinkState::NotAnswering,
            &view_with(status()),
            false,
            at(100)
        ),
        Led::Off
    );
}

#[test]
fn indicators_together_and_when_they_change() {
    let v = view_with(status());
    let inputs = Inputs {
        link: LinkState::Connected,
        view: &v,
        navigation: Navigation::Idle,
        last_sent: Some(at(100)),
        panel_failure: false,
    };
    assert_eq!(
        Indicators::derive(&inputs, at(120)),
        Indicators {
            link: Led::On,
            activity: Led::On,
            fault: Led::Off
        }
    );
    assert_eq!(Indicators::next_change(&inputs, at(120)), Some(at(150)));
    assert_eq!(Indicators::next_change(&inputs, at(150)), Some(at(2000)));
    assert_eq!(Indicators::next_change(&inputs, at(2000)), None);
    assert_eq!(
        Indicators::derive(&inputs, at(2000)),
        Indicators {
            link: Led::BlinkFast,
            activity: Led::Off,
            fault: Led::Blink
        }
    );
}

#[test]
fn led_names_and_blinking() {
    assert_eq!(
        [Led::Off, Led::On, Led::Blink, Led::BlinkFast].map(Led::name),
        ["off", "on", "blink", "blink-fast"]
    );
    let lit = |ms| Led::Blink.is_lit(Instant::from_millis(ms));
    assert!(lit(0) && lit(249) && !lit(250) && !lit(499) && lit(500));
    assert!(Led::On.is_lit(at(250)) && !Led::Off.is_lit(at(0)));
    assert_eq!(Fault::BatteryLow.description(), "battery low");
}

#[test]
fn fast_blink_is_8_hz() {
    assert_eq!(FAST_BLINK_HALF_PERIOD.as_millis(), 62);
    let lit = |ms| Led::BlinkFast.is_lit(Instant::from_millis(ms));
    assert!(lit(0) && lit(61) && !lit(62) && !lit(123) && lit(124));
    // Four times as many changes as the 2 Hz blink in a second.
    let changes = |led: Led| {
        (1..1000)
            .filter(|&ms| led.is_lit(at(ms)) != led.is_lit(at(ms - 1)))
            .count()
    };
    assert_eq!(changes(Led::Blink), 3);
    assert_eq!(changes(Led::BlinkFast), 16);
}
