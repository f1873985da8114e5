//! The buttons' names and the debouncer.

mod panel_support;

use embassy_time::Duration;
use panel_support::at;
use x30_panel::config::Config;
use x30_panel::panel::buttons::BUTTON_COUNT;
use x30_panel::panel::{Button, ButtonDebouncers, ButtonEvent, Debouncer};
use x30_panel::proto::message::{Direction, MotionCommand, Speed};

const DEBOUNCE: Duration = Duration::from_millis(15);

#[test]
fn buttons_in_design_order_with_virtual_panel_names() {
    let names: Vec<_> = Button::ALL.iter().map(|b| b.name()).collect();
    assert_eq!(
        names.join(" "),
        "forward backward turn-left turn-right strafe-left strafe-right stop estop \
         stop-stepping lie-down gait light dock cancel patrol"
    );
    assert_eq!(Button::ALL.len(), BUTTON_COUNT);
    for (i, button) in Button::ALL.into_iter().enumerate() {
        assert_eq!(Button::from_name(button.name()), Some(button));
        assert_eq!(button.index(), i);
    }
    for bad in ["", "Forward", "turn_left", "e-stop", "forward "] {
        assert_eq!(Button::from_name(bad), None, "{bad:?}");
    }
}

#[test]
fn the_first_six_are_motion_buttons() {
    let motion: Vec<_> = Button::ALL.into_iter().filter(|b| b.is_motion()).collect();
    assert_eq!(
        motion,
        [
            Button::Forward,
            Button::Backward,
            Button::TurnLeft,
            Button::TurnRight,
            Button::StrafeLeft,
            Button::StrafeRight
        ]
    );
    let speeds = Config::default().speeds;
    for button in Button::ALL {
        let command = button.motion(&speeds);
        assert_eq!(command.is_some(), button.is_motion(), "{button:?}");
        assert!(command.is_none_or(|c| c.is_continuous()), "{button:?}");
    }
    assert_eq!(
        Button::TurnRight.motion(&speeds),
        Some(MotionCommand::Move(Direction::TurnRight, Speed::Default))
    );
}

#[test]
fn stable_press_is_reported_once_after_the_debounce_time() {
    let mut d = Debouncer::new(DEBOUNCE);
    assert_eq!(d.sample(true, at(100)), None);
    assert_eq!(d.deadline(), Some(at(115)));
    assert_eq!(d.sample(true, at(114)), None);
    assert_eq!(d.sample(true, at(115)), Some(true));
    assert!(d.is_pressed());
    assert_eq!(d.deadline(), None);
    assert_eq!(d.sample(true, at(116)), None);
    assert_eq!(d.sample(true, at(500)), None);
}

#[test]
fn bounces_are_ignored() {
    let mut d = Debouncer::new(DEBOUNCE);
    // The contact chatters for 8 ms, each level shorter than the debounce time.
    for (i, level) in [true, false, true, false, true].into_iter().enumerate() {
        assert_eq!(d.sample(level, at(100 + 2 * i as u64)), None);
    }
    // The debounce time counts from the last change (108), not the first (100).
    assert_eq!(d.deadline(), Some(at(123)));
    assert_eq!(d.sample(true, at(116)), None);
    assert_eq!(d.sample(true, at(123)), Some(true));
    // Release, with bounces of its own.
    assert_eq!(d.sample(false, at(300)), None);
    assert_eq!(d.sample(true, at(302)), None);
    assert_eq!(d.sample(false, at(304)), None);
    assert_eq!(d.sample(false, at(318)), None);
    assert_eq!(d.sample(false, at(319)), Some(false));
    assert!(!d.is_pressed());
}

#[test]
fn a_glitch_shorter_than_the_debounce_time_is_no_event() {
    let mut d = Debouncer::new(DEBOUNCE);
    assert_eq!(d.sample(true, at(0)), None);
    assert_eq!(d.sample(false, at(10)), None);
    // Back at the reported level: nothing pending.
    assert_eq!(d.deadline(), None);
    assert_eq!(d.sample(false, at(100)), None);
    assert!(!d.is_pressed());
}

#[test]
fn debouncers_for_every_button() {
    let mut d = ButtonDebouncers::new(DEBOUNCE);
    assert_eq!(d.next_deadline(), None);
    assert_eq!(d.sample(Button::Estop, true, at(0)), None);
    assert_eq!(d.sample(Button::Gait, true, at(5)), None);
    assert_eq!(d.next_deadline(), Some(at(15)));
    assert_eq!(
        d.pending().collect::<Vec<_>>(),
        [Button::Estop, Button::Gait]
    );
    assert_eq!(
        d.sample(Button::Estop, true, at(15)),
        Some(ButtonEvent {
            button: Button::Estop,
            pressed: true,
            at: at(15)
        })
    );
    assert_eq!(d.next_deadline(), Some(at(20)));
    assert_eq!(d.sample(Button::Gait, false, at(12)), None);
    assert_eq!(d.next_deadline(), None);
    assert_eq!(d.pending().count(), 0);
}

#[test]
fn events_carry_when_the_level_became_stable() {
    let mut d = ButtonDebouncers::new(DEBOUNCE);
    assert_eq!(d.sample(Button::Forward, true, at(1000)), None);
    let press = d.sample(Button::Forward, true, at(1015)).unwrap();
    assert_eq!((press.pressed, press.at), (true, at(1015)));
    assert_eq!(d.sample(Button::Forward, false, at(2000)), None);
    let release = d.sample(Button::Forward, false, at(2015)).unwrap();
    assert_eq!((release.pressed, release.at), (false, at(2015)));
}

/// A button pressed at power-up (stuck, or held through a reset) is no press: it acts only
/// once released and pressed again. A stop button held at power-up is a press.
#[test]
fn at_power_up_a_held_button_acts_only_when_pressed_again_but_a_stop_at_once() {
    let held = [Button::Forward, Button::Dock, Button::Estop, Button::Stop];
    let d = &mut ButtonDebouncers::at_power_up(DEBOUNCE, Button::ALL.map(|b| held.contains(&b)));
    assert_eq!(d.pending().collect::<Vec<_>>(), [], "nothing pending yet");
    let pressed = |d: &mut ButtonDebouncers, button, level, ms| {
        d.sample(button, level, at(ms)).map(|e| e.pressed)
    };
    for button in [Button::Forward, Button::Dock] {
        assert_eq!(pressed(d, button, true, 0), None, "{button:?}");
        assert_eq!(
            pressed(d, button, true, 100),
            None,
            "{button:?} still held: no press"
        );
    }
    for button in [Button::Estop, Button::Stop] {
        assert_eq!(pressed(d, button, true, 0), None, "{button:?}");
        assert_eq!(
            pressed(d, button, true, 15),
            Some(true),
            "{button:?} held: a press"
        );
    }
    // Released (which drives nothing), forward then presses as usual.
    assert_eq!(pressed(d, Button::Forward, false, 200), None);
    assert_eq!(pressed(d, Button::Forward, false, 215), Some(false));
    assert_eq!(pressed(d, Button::Forward, true, 300), None);
    assert_eq!(pressed(d, Button::Forward, true, 315), Some(true));
    // A button released at power-up presses as usual.
    assert_eq!(pressed(d, Button::Gait, true, 400), None);
    assert_eq!(pressed(d, Button::Gait, true, 415), Some(true));
    assert!(Button::ALL.iter().filter(|b| b.is_stop()).eq(&[
        Button::Stop,
        Button::Estop,
        Button::Cancel
    ]));
}
