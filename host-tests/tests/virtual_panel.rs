//! The virtual panel's text lines (the QEMU board's buttons): `+NAME` press, `-NAME` release.

use embassy_time::Instant;
use x30_panel::panel::virtual_panel::{LineError, LineReader, MAX_LINE};
use x30_panel::panel::{Button, ButtonEvent};

/// When the lines of these tests arrive, unless a test says otherwise.
const T: u64 = 1000;

fn at(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

/// The change of `button`, received at [`T`].
fn event(button: Button, pressed: bool) -> Option<ButtonEvent> {
    Some(ButtonEvent {
        button,
        pressed,
        at: at(T),
    })
}

/// What `line` says, received at [`T`].
fn parse_line(line: &str) -> Result<Option<ButtonEvent>, LineError> {
    x30_panel::panel::virtual_panel::parse_line(line, at(T))
}

/// Feeds `bytes`, all received at [`T`], and collects what each completed line said.
fn lines(reader: &mut LineReader, bytes: &[u8]) -> Vec<Result<Option<ButtonEvent>, LineError>> {
    bytes
        .iter()
        .filter_map(|&b| reader.push(b, at(T)))
        .collect()
}

#[test]
fn every_button_name_presses_and_releases() {
    for button in Button::ALL {
        assert_eq!(
            parse_line(&format!("+{}", button.name())),
            Ok(event(button, true))
        );
        assert_eq!(
            parse_line(&format!("-{}", button.name())),
            Ok(event(button, false))
        );
    }
}

#[test]
fn spaces_around_a_line_and_after_the_sign_are_ignored() {
    assert_eq!(
        parse_line("  +turn-left \t"),
        Ok(event(Button::TurnLeft, true))
    );
    assert_eq!(parse_line("- stop"), Ok(event(Button::Stop, false)));
}

#[test]
fn blank_lines_say_nothing() {
    assert_eq!(parse_line(""), Ok(None));
    assert_eq!(parse_line("   "), Ok(None));
}

#[test]
fn lines_that_are_not_button_changes_are_errors() {
    assert!(matches!(parse_line("forward"), Err(LineError::NoSign(s)) if s == "forward"));
    assert!(matches!(parse_line("+jump"), Err(LineError::UnknownButton(s)) if s == "jump"));
    // Names are exact: no other case, no abbreviations.
    assert!(matches!(
        parse_line("+Forward"),
        Err(LineError::UnknownButton(_))
    ));
    assert!(matches!(
        parse_line("+for"),
        Err(LineError::UnknownButton(_))
    ));
    assert!(matches!(parse_line("+"), Err(LineError::UnknownButton(s)) if s.is_empty()));
    let message = parse_line("+jump").unwrap_err().to_string();
    assert!(message.contains("jump"), "{message}");
}

#[test]
fn reader_splits_on_newline_and_carriage_return() {
    let mut reader = LineReader::new();
    let got = lines(&mut reader, b"+forward\n-forward\r\n+estop\r");
    assert_eq!(
        got,
        vec![
            Ok(event(Button::Forward, true)),
            Ok(event(Button::Forward, false)),
            Ok(None), // the \n of \r\n ends an empty line
            Ok(event(Button::Estop, true)),
        ]
    );
}

#[test]
fn reader_waits_for_the_end_of_the_line() {
    let mut reader = LineReader::new();
    assert!(lines(&mut reader, b"+lie-do").is_empty());
    assert_eq!(
        lines(&mut reader, b"wn\n"),
        vec![Ok(event(Button::LieDown, true))]
    );
}

#[test]
fn an_overlong_line_is_skipped_to_its_end_and_reading_goes_on() {
    let mut reader = LineReader::new();
    let mut input = vec![b'+'; MAX_LINE + 10];
    input.extend_from_slice(b"\n+gait\n");
    assert_eq!(
        lines(&mut reader, &input),
        vec![Err(LineError::TooLong), Ok(event(Button::Gait, true))]
    );
}

#[test]
fn bytes_that_are_not_text_are_an_error() {
    let mut reader = LineReader::new();
    assert_eq!(
        lines(&mut reader, b"+\xff\xfe\n-dock\n"),
        vec![Err(LineError::NotText), Ok(event(Button::Dock, false))]
    );
}

#[test]
fn a_line_carries_when_it_was_received() {
    assert_eq!(
        x30_panel::panel::virtual_panel::parse_line("+dock", at(42)),
        Ok(Some(ButtonEvent {
            button: Button::Dock,
            pressed: true,
            at: at(42)
        }))
    );
    // A line typed slowly counts from its end, when it says something.
    let mut reader = LineReader::new();
    for (i, &byte) in b"-gait".iter().enumerate() {
        assert_eq!(reader.push(byte, at(100 + i as u64)), None);
    }
    let done = reader.push(b'\n', at(500)).unwrap().unwrap().unwrap();
    assert_eq!(
        (done.button, done.pressed, done.at),
        (Button::Gait, false, at(500))
    );
}
