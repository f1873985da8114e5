//! The serial console: line editing, each command's answer, and saving through the store.

#[path = "common/connected.rs"]
mod connected;
// The store's tests use the whole simulated chip; these only a blank one.
#[allow(dead_code)]
#[path = "common/sim_flash.rs"]
mod sim_flash;
#[path = "common/steady.rs"]
mod steady;
#[path = "common/terminal.rs"]
mod terminal;

use connected::connected;
use embassy_time::{Duration, Instant};
use sim_flash::{PAGE, SimFlash};
use steady::steady;
use terminal::{Keyboard, Screen};
use x30_panel::app::{Shared, Snapshot};
use x30_panel::config::Config;
use x30_panel::console::commands::{Action, execute};
use x30_panel::console::line::{Input, LINE_MAX, LineEditor};
use x30_panel::console::{self, ANSWER_MAX, Answer, PROMPT, Reboot};
use x30_panel::panel::indicators::LinkState;
use x30_panel::panel::monitor::Stamped;
use x30_panel::panel::{Busy, Button, ButtonEvent};
use x30_panel::proto::codes::MotionState;
use x30_panel::proto::message::{Battery, RobotStatus};
use x30_panel::settings::desk::{self, Desk, Refused};
use x30_panel::settings::route::MAX_ROUTE;
use x30_panel::settings::store::{BUF_LEN, Store};
use x30_panel::settings::{self, Key, LoadProblem, Settings};

/// What the editor answers to each byte of `typed`.
fn edit(editor: &mut LineEditor, typed: &[u8]) -> Vec<Input> {
    typed.iter().map(|&b| editor.push(b)).collect()
}

#[test]
fn typing_echoes_and_enter_ends_the_line() {
    let mut e = LineEditor::new();
    assert_eq!(edit(&mut e, b"ab"), [Input::Echo(b'a'), Input::Echo(b'b')]);
    assert_eq!(e.push(b'\r'), Input::Line);
    assert_eq!(e.line(), "ab");
    // The LF of CR LF ends no second line; the next byte starts a new one.
    assert_eq!(e.push(b'\n'), Input::Nothing);
    assert_eq!(edit(&mut e, b"c\n"), [Input::Echo(b'c'), Input::Line]);
    assert_eq!(e.line(), "c");
    assert_eq!(e.push(b'\n'), Input::Line);
    assert_eq!(e.line(), "");
}

#[test]
fn backspace_erases_and_ctrl_c_drops_the_line() {
    let mut e = LineEditor::new();
    edit(&mut e, b"shox");
    assert_eq!(e.push(0x7F), Input::Erase);
    assert_eq!(e.push(b'w'), Input::Echo(b'w'));
    assert_eq!(e.line(), "show");
    assert_eq!(
        edit(&mut e, &[0x08; 5]),
        [
            Input::Erase,
            Input::Erase,
            Input::Erase,
            Input::Erase,
            Input::Nothing
        ]
    );
    edit(&mut e, b"reboot");
    assert_eq!(e.push(0x03), Input::Dropped);
    assert_eq!(e.line(), "");
    edit(&mut e, b"x");
    assert_eq!(e.push(0x15), Input::Dropped);
    assert_eq!(e.push(b'\r'), Input::Line);
    assert_eq!(e.line(), "");
}

#[test]
fn arrow_keys_and_binary_noise_are_not_typed() {
    let mut e = LineEditor::new();
    // Up arrow, F5, a lone ESC followed by a letter, UTF-8, a NUL.
    let noise = b"\x1b[A\x1b[15~\x1bOP\x1bx\xc3\xa9\x00";
    assert!(edit(&mut e, noise).iter().all(|i| *i == Input::Nothing));
    assert_eq!(edit(&mut e, b"ok\r").last(), Some(&Input::Line));
    assert_eq!(e.line(), "ok");
}

#[test]
fn a_full_line_rings_the_bell_and_is_not_run() {
    let mut e = LineEditor::new();
    let typed = vec![b'a'; LINE_MAX];
    assert!(edit(&mut e, &typed).iter().all(|i| *i == Input::Echo(b'a')));
    assert_eq!(e.push(b'b'), Input::Bell);
    assert_eq!(e.line().len(), LINE_MAX);
    // What was kept is not what was typed: the line is dropped, and the next one runs.
    assert_eq!(e.push(b'\r'), Input::TooLong);
    assert_eq!(e.line(), "");
    assert_eq!(edit(&mut e, b"ok\r").last(), Some(&Input::Line));
    assert_eq!(e.line(), "ok");
    // Ctrl-C forgets the overflow with the line.
    edit(&mut e, &typed);
    assert_eq!(edit(&mut e, b"b\x03ok\r").last(), Some(&Input::Line));
    assert_eq!(e.line(), "ok");
}

/// Eight breathing light presets, the longest setting, fit a line.
#[test]
fn the_longest_setting_fits_a_line() {
    let presets = ["00FF00:100:breathing"; 8].join(",");
    let line = format!("set lights {presets}");
    assert!(line.len() <= LINE_MAX, "{} characters", line.len());
    let mut settings = Settings::new(Config::default());
    let (_, answer) = run_line(&line, &mut settings, None);
    assert!(answer.contains("not saved"), "{answer:?}");
    assert_eq!(settings.edited().lights.len(), 8);
}

/// Runs `line` on `settings` with `snapshot`; the action and the answer.
fn run_line(line: &str, settings: &mut Settings, snapshot: Option<&Snapshot>) -> (Action, String) {
    run_line_at(Instant::now(), line, settings, snapshot)
}

/// [`run_line`] at `now`.
fn run_line_at(
    now: Instant,
    line: &str,
    settings: &mut Settings,
    snapshot: Option<&Snapshot>,
) -> (Action, String) {
    let mut answer = Answer::new();
    let action = execute(line, settings, snapshot, now, &mut answer);
    (action, answer.as_str().to_owned())
}

/// A snapshot of a connected, idle panel whose robot stands at (1.5, -2, 0.1), yaw 0.5.
fn snapshot() -> Snapshot {
    let status = RobotStatus {
        motion_state: MotionState::StandingUp,
        pos_x: 1.5,
        pos_y: -2.0,
        pos_z: 0.1,
        yaw: 0.5,
        electricity: Some(87),
        ..RobotStatus::UNAVAILABLE
    };
    connected(status, Instant::now())
}

#[test]
fn help_lists_every_command_and_key() {
    let mut s = Settings::new(Config::default());
    let (action, help) = run_line("help", &mut s, None);
    assert_eq!(action, Action::Answered);
    for command in [
        "help",
        "show",
        "set KEY VALUE",
        "unset KEY",
        "save",
        "status",
        "dock here",
        "reboot",
    ] {
        assert!(help.contains(command), "{command} missing from:\n{help}");
    }
    for key in Key::ALL {
        assert!(help.contains(key.name()), "{key:?}");
    }
    let (_, one) = run_line("help speed-forward", &mut s, None);
    assert!(
        one.contains("m/s from 0 to 1.5") && one.contains("X30_SPEED_FORWARD"),
        "{one}"
    );
}

#[test]
fn show_tells_values_and_where_they_come_from() {
    let mut s = Settings::new(Config::default());
    s.set(Key::Repeat, "300").unwrap();
    s.commit();
    s.set(Key::SpeedForward, "0.8").unwrap();
    s.set(Key::WebPin, "9753").unwrap();
    let (_, shown) = run_line("show", &mut s, None);
    let lines: Vec<&str> = shown.lines().collect();
    assert_eq!(lines.len(), Key::ALL.len(), "{shown}");
    let line = |name: &str| {
        *lines
            .iter()
            .find(|l| l.starts_with(&format!("{name} ")))
            .unwrap()
    };
    assert!(
        line("robot").contains("= 192.168.1.106:30000") && line("robot").ends_with("[default]")
    );
    assert!(line("repeat-ms").contains("= 300") && line("repeat-ms").ends_with("[set]"));
    assert!(
        line("speed-forward").contains("= 0.8")
            && line("speed-forward").ends_with("[set, not saved]")
    );
    // The PIN is never printed.
    assert!(
        line("web-pin").contains("****") && !shown.contains("9753"),
        "{shown}"
    );
    let (_, one) = run_line("show dock", &mut s, None);
    assert_eq!(one.trim_end(), format!("{:<18} = none  [default]", "dock"));
}

/// Nor is it when it is set or unset: `unset` puts the build's PIN back, which whoever
/// reads the console did not type.
#[test]
fn set_and_unset_never_print_the_pin() {
    let mut defaults = Config::default();
    Key::WebPin.apply(&mut defaults, "8642").unwrap();
    let mut s = Settings::new(defaults);
    let (_, set) = run_line("set web-pin 9753", &mut s, None);
    assert_eq!(
        set.trim_end(),
        "web-pin = **** (not saved: `save` keeps it)"
    );
    let (_, unset) = run_line("unset web-pin", &mut s, None);
    assert_eq!(unset.trim_end(), "web-pin = **** (as saved)");
    assert!(!unset.contains("8642"), "{unset}");
}

#[test]
fn set_checks_the_value_and_names_what_is_allowed() {
    let mut s = Settings::new(Config::default());
    let (_, ok) = run_line("set speed-forward 0.80", &mut s, None);
    assert_eq!(
        ok.trim_end(),
        "speed-forward = 0.8 (not saved: `save` keeps it)"
    );
    let before = s.clone();
    let (_, bad) = run_line("set speed-forward 2", &mut s, None);
    assert_eq!(
        bad.trim_end(),
        "speed-forward: `2` is not valid: expected m/s from 0 to 1.5, or default (the robot's 0.5); nothing changed"
    );
    let (_, unknown) = run_line("set speed 1", &mut s, None);
    assert!(unknown.contains("no setting `speed`"), "{unknown}");
    let (_, empty) = run_line("set robot", &mut s, None);
    assert!(empty.contains("a.b.c.d"), "{empty}");
    assert_eq!(s, before, "refused commands change nothing");
    // A value with spaces (lights, dock) is the rest of the line.
    let (_, lights) = run_line("set lights 00FF00:50, FF0000:100:breathing", &mut s, None);
    assert!(
        lights.starts_with("lights = 00FF00:50,FF0000:100:breathing"),
        "{lights}"
    );
    let (_, unset) = run_line("unset speed-forward", &mut s, None);
    assert_eq!(unset.trim_end(), "speed-forward = default (as saved)");
    let (_, nonsense) = run_line("frobnicate now", &mut s, None);
    assert!(
        nonsense.contains("unknown command `frobnicate now`"),
        "{nonsense}"
    );
}

#[test]
fn save_is_refused_with_a_reason() {
    let mut s = Settings::new(Config::default());
    assert_eq!(run_line("save", &mut s, None).0, Action::Save);
    assert_eq!(desk::check(&s, None), Err(Refused::NothingChanged));
    assert_eq!(
        Refused::NothingChanged.to_string(),
        "nothing changed; nothing to save"
    );

    s.set(Key::Dhcp, "0").unwrap();
    let conflict = desk::check(&s, None).unwrap_err();
    assert!(
        conflict.to_string().contains("dhcp is 0 but ip is none"),
        "{conflict}"
    );
    s.set(Key::Ip, "10.0.0.9/24").unwrap();

    for busy in [Busy::MotionHeld, Busy::TaskRunning, Busy::StopPending] {
        let refused = desk::check(&s, Some(busy)).unwrap_err();
        assert_eq!(refused, Refused::Busy(busy));
        let text = refused.to_string();
        assert!(
            text.starts_with("not saved: ") && text.contains(busy.description()),
            "{text}"
        );
    }
    assert_eq!(desk::check(&s, None), Ok(()));
}

#[test]
fn status_tells_the_connection_battery_motion_and_fault() {
    let mut s = Settings::new(Config::default());
    let (_, status) = run_line("status", &mut s, Some(&snapshot()));
    assert!(
        status.contains("192.168.1.106:30000, connected and answering"),
        "{status}"
    );
    assert!(status.contains("board      10.0.2.15/24"), "{status}");
    assert!(status.contains("battery    87 %"), "{status}");
    assert!(status.contains("motion     standing up"), "{status}");
    assert!(status.contains("fault      none"), "{status}");
    let failed = Snapshot {
        command_failed: true,
        link: LinkState::NotAnswering,
        ..snapshot()
    };
    let (_, status) = run_line("status", &mut s, Some(&failed));
    assert!(
        status.contains("not answering") && status.contains("the last command failed"),
        "{status}"
    );
    let (_, starting) = run_line("status", &mut s, None);
    assert!(starting.contains("starting"), "{starting}");
}

#[test]
fn status_tells_the_battery_answers_level_else_the_statuss() {
    let mut s = Settings::new(Config::default());
    let battery = |battery_level| Battery {
        voltage: Some(54),
        current: Some(-150),
        remaining_capacity: None,
        nominal_capacity: None,
        cycles: None,
        protected_state: None,
        battery_level,
        battery_temperature: None,
    };
    let with = |b: Battery| Snapshot {
        battery: Some(Stamped::new(b, Instant::now())),
        ..snapshot()
    };
    let (_, status) = run_line("status", &mut s, Some(&with(battery(Some(64)))));
    assert!(status.contains("battery    64 %"), "{status}");
    // A battery answer without its level: the status's.
    let (_, status) = run_line("status", &mut s, Some(&with(battery(None))));
    assert!(status.contains("battery    87 %"), "{status}");
}

/// A robot that is not localised reports its pose as `nan`: neither the dock nor a route
/// point is taken from it, and the answer says why.
#[test]
fn an_unknown_pose_is_not_taken() {
    let mut s = Settings::new(Config::default());
    let before = s.clone();
    for unknown in [f32::NAN, f32::INFINITY] {
        let mut lost = snapshot();
        if let Some(status) = &mut lost.status {
            status.value.pos_y = unknown;
        }
        for line in ["dock here", "route add here"] {
            let (action, answer) = run_line(line, &mut s, Some(&lost));
            assert_eq!(action, Action::Answered, "{line}: {answer}");
            assert!(
                answer.contains("does not know its pose"),
                "{line}: {answer}"
            );
        }
    }
    assert_eq!(s, before);
}

/// A pose whose numbers are written long (a robot just off the origin) is a dock point
/// all the same, as it is a route point.
#[test]
fn dock_here_takes_a_pose_written_long() {
    let mut s = Settings::new(Config::default());
    let status = RobotStatus {
        motion_state: MotionState::StandingUp,
        pos_x: 1.2345678e-20,
        pos_y: -1.2345678e-20,
        pos_z: 1.2345678e-20,
        yaw: -1.2345678e-20,
        ..RobotStatus::UNAVAILABLE
    };
    let (action, answer) = run_line(
        "dock here",
        &mut s,
        Some(&connected(status, Instant::now())),
    );
    assert_eq!(action, Action::Save, "{answer}");
    let dock = s.edited().dock.expect("a dock point");
    assert_eq!(
        (dock.pos_x, dock.pos_y, dock.pos_z, dock.angle_yaw),
        (1.2345678e-20, -1.2345678e-20, 1.2345678e-20, -1.2345678e-20)
    );
}

#[test]
fn dock_here_takes_the_robots_pose() {
    let mut s = Settings::new(Config::default());
    let (action, answer) = run_line("dock here", &mut s, Some(&snapshot()));
    assert_eq!(action, Action::Save, "{answer}");
    let dock = s.edited().dock.unwrap();
    assert_eq!((dock.value, dock.map_id), (1, 1));
    assert_eq!(
        (dock.pos_x, dock.pos_y, dock.pos_z, dock.angle_yaw),
        (1.5, -2.0, 0.1, 0.5)
    );
    assert!(answer.starts_with("dock = 1,1,1.5,-2,0.1,0.5"), "{answer}");

    // MAP and POINT, then the previous dock's numbers as defaults.
    run_line("dock here 4 7", &mut s, Some(&snapshot()));
    assert_eq!(s.edited().dock.map(|d| (d.map_id, d.value)), Some((4, 7)));
    run_line("dock here", &mut s, Some(&snapshot()));
    assert_eq!(s.edited().dock.map(|d| (d.map_id, d.value)), Some((4, 7)));

    let before = s.clone();
    let later = Instant::now() + Duration::from_millis(2100);
    let (action, stale) = run_line_at(later, "dock here", &mut s, Some(&snapshot()));
    assert_eq!(action, Action::Answered);
    assert!(stale.contains("no fresh status"), "{stale}");
    for (line, snapshot) in [
        ("dock here", None),
        ("dock here x", Some(&snapshot())),
        ("dock here 1 2 3", Some(&snapshot())),
        ("dock there", Some(&snapshot())),
    ] {
        let (action, answer) = run_line(line, &mut s, snapshot);
        assert_eq!(action, Action::Answered, "{line}: {answer}");
    }
    assert_eq!(s, before);
}

#[test]
fn reboot_warns_of_unsaved_changes() {
    let mut s = Settings::new(Config::default());
    assert_eq!(
        run_line("reboot", &mut s, None),
        (Action::Reboot, "rebooting\n".to_owned())
    );
    s.set(Key::Repeat, "300").unwrap();
    let (_, answer) = run_line("reboot", &mut s, None);
    assert!(answer.contains("changes not saved are dropped"));
}

/// Settings flash for the tests: two 32 KiB pages.
fn flash() -> SimFlash {
    SimFlash::new(2)
}

/// Types `input` on a console over `flash` until it goes quiet or reboots; the screen, and
/// whether it asked to reboot.
async fn session(
    flash: &SimFlash,
    shared: &Shared,
    problem: Option<LoadProblem>,
    input: &str,
) -> (String, bool) {
    let mut store = Store::new(flash.clone(), 0..2 * PAGE as u32);
    let (mut settings, _) = settings::load(&mut store, Config::default()).await;
    let (keyboard, keys) = Keyboard::new();
    keys.send(input.as_bytes().to_vec()).unwrap();
    let screen = Screen::default();
    let desk = Desk::new();
    let console = console::run(
        keyboard,
        screen.clone(),
        &mut store,
        &mut settings,
        problem,
        shared,
        &desk,
    );
    let rebooted = steady(tokio::time::timeout(
        std::time::Duration::from_millis(300),
        console,
    ))
    .await;
    (screen.text(), rebooted == Ok(Reboot))
}

/// The settings saved on `flash`.
async fn saved(flash: &SimFlash) -> Settings {
    let mut store = Store::new(flash.clone(), 0..2 * PAGE as u32);
    let mut buf = [0u8; BUF_LEN];
    let blob = store
        .load(&mut buf)
        .await
        .unwrap()
        .expect("something saved");
    let (settings, problem) = Settings::parse(Config::default(), blob);
    assert_eq!(problem, None);
    settings
}

#[tokio::test(flavor = "current_thread")]
async fn a_session_sets_and_saves_and_the_next_start_reads_it() {
    let flash = flash();
    let shared = Shared::new();
    let (screen, rebooted) = session(
        &flash,
        &shared,
        None,
        "set speed-turn-left 0.2\r\nsave\rreboot\r",
    )
    .await;
    assert!(rebooted, "{screen}");
    assert!(screen.starts_with("\r\nx30-panel "), "{screen:?}");
    assert!(
        screen.contains("x30> set speed-turn-left 0.2\r\nspeed-turn-left = 0.2 (not saved"),
        "{screen:?}"
    );
    assert!(
        screen.contains("\r\nsaved speed-turn-left in "),
        "{screen:?}"
    );
    assert!(
        screen.contains("x30> reboot\r\nrebooting\r\n"),
        "{screen:?}"
    );
    // Every line ends with CR LF, as a terminal needs.
    assert!(!screen.replace("\r\n", "").contains('\n'), "{screen:?}");
    let again = saved(&flash).await;
    assert_eq!(again.config().speeds, {
        let mut c = Config::default();
        Key::SpeedTurnLeft.apply(&mut c, "0.2").unwrap();
        c.speeds
    });
    let (screen, _) = session(&flash, &shared, None, "show speed-turn-left\r").await;
    assert!(
        screen.contains("speed-turn-left    = 0.2  [set]"),
        "{screen:?}"
    );
}

/// A value pasted too long for a line is not set cut short: the line is refused, and said
/// so, and nothing changes.
#[tokio::test(flavor = "current_thread")]
async fn a_line_pasted_too_long_is_refused_not_run_cut_short() {
    let flash = flash();
    let shared = Shared::new();
    let presets = ["00FF00:100:breathing"; 10].join(",");
    let typed = format!("set lights {presets}\rshow lights\r");
    let (screen, _) = session(&flash, &shared, None, &typed).await;
    assert!(
        screen.contains(&format!(
            "line too long (over {LINE_MAX} characters): not run"
        )),
        "{screen:?}"
    );
    assert!(!screen.contains("lights = 00FF00"), "{screen:?}");
    assert!(
        screen.contains("x30> show lights"),
        "the next line runs: {screen:?}"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn saving_reports_what_needs_a_reboot() {
    let flash = flash();
    let shared = Shared::new();
    let (screen, _) = session(
        &flash,
        &shared,
        None,
        "set dhcp 0\rset ip 10.0.0.9/24\rset debounce-ms 20\rsave\r",
    )
    .await;
    assert!(
        screen.contains("after `reboot`: dhcp ip debounce-ms"),
        "{screen:?}"
    );
    assert!(!saved(&flash).await.config().dhcp);
}

/// The e-stop pressed, as the board's button task hands it to the panel.
fn press_estop(shared: &Shared) {
    shared
        .buttons
        .try_send(ButtonEvent {
            button: Button::Estop,
            pressed: true,
            at: Instant::now(),
        })
        .unwrap();
}

#[tokio::test(flavor = "current_thread")]
async fn a_button_event_not_yet_taken_in_keeps_the_flash_untouched() {
    let flash = flash();
    let shared = Shared::new();
    press_estop(&shared);
    let (screen, _) = session(&flash, &shared, None, "set repeat-ms 300\rsave\r").await;
    assert!(
        screen.contains("not saved: a stop is going out"),
        "{screen:?}"
    );
    assert_eq!(flash.log(), [], "no write, no erase");
    assert!(
        flash.snapshot().iter().all(|&b| b == 0xFF),
        "nothing written"
    );
}

thread_local! {
    /// What the panel of the test below shares, for its store's erase gate (a plain `fn`,
    /// as the board's is): each test runs on a thread of its own.
    static GATED_PANEL: &'static Shared = Box::leak(Box::new(Shared::new()));
}

/// The board's erase gate, over [`GATED_PANEL`].
fn erase_allowed() -> bool {
    desk::busy(GATED_PANEL.with(|shared| *shared)).is_none()
}

/// An e-stop pressed while a save reads the pages, after the check that let the save start:
/// the page erase the save then needs is held back (it would stall the chip while the stop
/// waits), and the save is refused as if the press had come first.
#[tokio::test(flavor = "current_thread")]
async fn an_estop_pressed_while_a_save_reads_the_pages_holds_its_erase_back() {
    let shared = GATED_PANEL.with(|shared| *shared);
    let flash = flash();
    let mut store = Store::new(flash.clone(), 0..2 * PAGE as u32).with_erase_gate(erase_allowed);
    let (mut settings, _) = settings::load(&mut store, Config::default()).await;
    // After one turn of its own: the save has started, and passed its check, by then.
    let press = || async {
        tokio::task::yield_now().await;
        press_estop(shared);
    };
    // Saves, each with the press coming at its first turn to the other tasks, until one
    // needs a page erased: the saves before it wrote without erasing.
    let mut held = None;
    for save in 0..5000 {
        let value = if save % 2 == 0 { "300" } else { "250" };
        settings.set(Key::Repeat, value).unwrap();
        let (result, ()) = tokio::join!(desk::save(&mut store, &mut settings, shared), press());
        // The panel takes the event in.
        shared.buttons.try_receive().unwrap();
        if let Err(refused) = result {
            held = Some((save, refused));
            break;
        }
        assert_eq!(flash.page_erases(), 0);
    }
    let (save, refused) = held.expect("a save needed an erase");
    assert!(save > 10, "{save} saves before the pages filled");
    assert_eq!(refused, Refused::Busy(Busy::StopPending));
    assert_eq!(flash.page_erases(), 0, "no erase while the stop waited");
    assert!(!settings.unsaved().is_empty(), "the edit is still to save");
    // Once the panel has taken the stop in, the save goes through, erase and all.
    assert!(desk::save(&mut store, &mut settings, shared).await.is_ok());
    assert!(flash.page_erases() > 0);
}

#[tokio::test(flavor = "current_thread")]
async fn a_lost_store_is_told_in_the_greeting() {
    let shared = Shared::new();
    for (problem, words) in [
        (LoadProblem::Unreadable, "damaged or not this panel's"),
        (LoadProblem::NotSettings, "not this firmware's"),
        (LoadProblem::UnknownKeys(2), "2 saved settings are unknown"),
    ] {
        let (screen, _) = session(&flash(), &shared, Some(problem), "").await;
        assert!(screen.contains(words), "{problem:?}: {screen:?}");
    }
}

/// Runs a console over `flash` while `script` runs with the desk; the screen and what the
/// script returned. `typed` is typed first.
async fn with_console<R>(
    flash: &SimFlash,
    shared: &Shared,
    typed: &str,
    script: impl AsyncFnOnce(&Desk) -> R,
) -> (String, R) {
    let mut store = Store::new(flash.clone(), 0..2 * PAGE as u32);
    let mut settings = Settings::new(Config::default());
    let desk = Desk::new();
    let (keyboard, keys) = Keyboard::new();
    keys.send(typed.as_bytes().to_vec()).unwrap();
    let screen = Screen::default();
    let console = console::run(
        keyboard,
        screen.clone(),
        &mut store,
        &mut settings,
        None,
        shared,
        &desk,
    );
    let script = async {
        // Let the console take the typed text in and publish its settings.
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
        script(&desk).await
    };
    steady(async {
        tokio::select! {
            _ = console => panic!("the console asked for a reboot"),
            result = script => (screen.text(), result),
        }
    })
    .await
}

#[tokio::test(flavor = "current_thread")]
async fn after_a_web_save_the_prompt_shows_the_line_being_typed_and_no_finished_one() {
    for (typed, shown_again) in [("show\r", ""), ("show\rsho", "sho")] {
        let flash = flash();
        let shared = Shared::new();
        let (screen, result) = with_console(&flash, &shared, typed, async |desk| {
            desk.save_with(|edited| {
                edited.set(Key::SpeedForward, "0.3").unwrap();
                Ok::<_, Refused>(())
            })
            .await
        })
        .await;
        result.expect("saved");
        let (_, after_save) = screen
            .split_once("web page: saved speed-forward in ")
            .expect("the save is told");
        assert!(
            after_save.ends_with(&format!("\n{PROMPT}{shown_again}")),
            "typed {typed:?}: {screen:?}"
        );
    }
}

#[tokio::test(flavor = "current_thread")]
async fn the_web_pages_changes_are_saved_by_the_console_with_the_same_checks() {
    let flash = flash();
    let shared = Shared::new();
    let (screen, result) = with_console(&flash, &shared, "set repeat-ms 300\r", async |desk| {
        let published = desk.settings().expect("published");
        assert!(
            published.unsaved().contains(Key::Repeat),
            "the typed change is published"
        );
        desk.save_with(|edited| {
            assert_eq!(
                edited, &published,
                "edits start from the published settings"
            );
            // The page starts from what is saved.
            edited.revert();
            edited.set(Key::SpeedForward, "0.3").unwrap();
            Ok::<_, Refused>(())
        })
        .await
    })
    .await;
    let saved_keys = result.expect("saved").keys;
    assert_eq!(saved_keys.iter().collect::<Vec<_>>(), [Key::SpeedForward]);
    assert!(
        screen.contains("web page: saved speed-forward in "),
        "{screen:?}"
    );
    assert!(
        screen.contains("changes typed here and not saved were dropped: repeat-ms"),
        "{screen:?}"
    );
    let again = saved(&flash).await;
    assert!(again.is_overridden(Key::SpeedForward));
    assert!(!again.is_overridden(Key::Repeat));

    // The same rule as the console's: not while a button event waits.
    shared
        .buttons
        .try_send(ButtonEvent {
            button: Button::Forward,
            pressed: true,
            at: Instant::now(),
        })
        .unwrap();
    let before = flash.snapshot();
    let (screen, (result, after)) =
        with_console(&flash, &shared, "set repeat-ms 300\r", async |desk| {
            let result = desk
                .save_with(|edited| {
                    edited.set(Key::SpeedForward, "0.4").unwrap();
                    Ok::<_, Refused>(())
                })
                .await;
            // Let the console publish its settings again.
            tokio::time::sleep(std::time::Duration::from_millis(50)).await;
            (result, desk.settings().expect("published"))
        })
        .await;
    assert_eq!(result, Err(Refused::Busy(Busy::StopPending)));
    assert!(screen.contains("web page: not saved: "), "{screen:?}");
    assert!(!screen.contains("were dropped"), "{screen:?}");
    assert_eq!(flash.snapshot(), before, "nothing written");
    // The console's own edits are back, the page's are gone.
    assert_eq!(
        after.unsaved().iter().collect::<Vec<_>>(),
        [Key::Repeat],
        "after a refused save the console keeps what was typed there"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn a_save_whose_caller_gave_up_keeps_the_owners_settings_from_the_next_one() {
    let desk = Desk::new();
    let edit = |speed: &'static str| {
        move |edited: &mut Settings| {
            edited.set(Key::SpeedForward, speed).unwrap();
            Ok::<_, Refused>(())
        }
    };
    // Typed on the console, not saved.
    let mut settings = Settings::new(Config::default());
    settings.set(Key::Repeat, "300").unwrap();
    desk.publish(&settings);
    let mut expected = settings.clone();
    expected.set(Key::SpeedForward, "0.4").unwrap();
    // A caller hands its edits over and gives up before the answer.
    let gave_up = tokio::time::timeout(
        std::time::Duration::from_millis(20),
        desk.save_with(edit("0.3")),
    )
    .await;
    assert!(gave_up.is_err(), "answered without an owner: {gave_up:?}");
    // The owner takes them and starts saving; meanwhile another caller asks.
    desk.request().await;
    assert!(desk.take_edits(&mut settings));
    let saved = desk::Saved {
        keys: settings.unsaved(),
        took: Duration::from_millis(5),
        erases: 0,
        moved: false,
        route: false,
    };
    let owner = async {
        // Let the next caller run up to its wait.
        tokio::task::yield_now().await;
        // The first save is refused: the owner gets its own settings back.
        let lost = desk.answer(&mut settings, Err(Refused::Busy(Busy::StopPending)));
        assert!(lost.is_empty());
        assert_eq!(
            settings.unsaved().iter().collect::<Vec<_>>(),
            [Key::Repeat],
            "the owner's own settings, not the next caller's edits"
        );
        // Then the next caller's edits, which start from what the owner published.
        desk.request().await;
        assert!(desk.take_edits(&mut settings));
        assert_eq!(settings, expected);
        desk.answer(&mut settings, Ok(saved))
    };
    let (result, lost) = steady(async { tokio::join!(desk.save_with(edit("0.4")), owner) }).await;
    assert_eq!(result, Ok(saved));
    assert_eq!(lost.keys.iter().collect::<Vec<_>>(), [Key::Repeat]);
    assert!(!lost.route);
}

/// Edits copied from the published settings while the owner was saving its own: once
/// that save is in, the edits would undo it, and the owner refuses them.
#[tokio::test(flavor = "current_thread")]
async fn edits_copied_before_a_save_of_the_owners_are_refused_as_stale() {
    let desk = Desk::new();
    let mut settings = Settings::new(Config::default());
    settings.set(Key::SpeedForward, "0.8").unwrap();
    // Published before `save` went through: the copy does not have the new speed saved.
    desk.publish(&settings);
    let owner = async {
        desk.request().await;
        // The owner's save lands, then it takes the edits.
        settings.commit();
        desk.publish(&settings);
        assert!(desk.take_edits(&mut settings));
        assert!(desk.edits_stale(&settings));
        let lost = desk.answer(&mut settings, Err(Refused::Stale));
        assert!(lost.is_empty());
        settings
    };
    let edit = desk.save_with(|edited| {
        edited.set(Key::Repeat, "300").unwrap();
        Ok::<_, Refused>(())
    });
    let (result, settings) = steady(async { tokio::join!(edit, owner) }).await;
    assert_eq!(result, Err(Refused::Stale));
    assert!(
        settings.unsaved().is_empty(),
        "the owner's own settings back"
    );
    assert_eq!(
        settings.config().speeds,
        {
            let mut config = Config::default();
            Key::SpeedForward.apply(&mut config, "0.8").unwrap();
            config.speeds
        },
        "its save stands"
    );
    // Edits copied from what is saved now are not stale.
    let mut now = settings.clone();
    now.set(Key::Repeat, "300").unwrap();
    assert!(now.same_saved(&settings));
}

#[tokio::test(flavor = "current_thread")]
async fn a_desk_without_an_owner_refuses_at_once() {
    let desk = Desk::new();
    let saved = desk.save_with(|_| Ok::<_, Refused>(())).await;
    assert_eq!(saved, Err(Refused::NoOwner));
    assert_eq!(desk.settings(), None);
}

#[tokio::test(flavor = "current_thread")]
async fn a_damaged_store_loads_the_defaults_and_counts_as_lost() {
    let flash = flash();
    // Not a store: bytes no save writes.
    flash.with_mem(|mem| {
        for (i, byte) in mem.iter_mut().enumerate() {
            *byte = (i * 7 + 3) as u8;
        }
    });
    let mut store = Store::new(flash.clone(), 0..2 * PAGE as u32);
    let (settings, problem) = settings::load(&mut store, Config::default()).await;
    assert_eq!(settings, Settings::new(Config::default()));
    let problem = problem.expect("a problem is reported");
    assert!(problem.is_loss(), "{problem:?}");
    let shared = Shared::new();
    let (screen, _) = session(&flash, &shared, Some(problem), "").await;
    assert!(
        screen.contains("every setting has its default"),
        "{screen:?}"
    );
}

#[test]
fn route_points_are_added_shown_and_cleared() {
    let mut s = Settings::new(Config::default());
    let (_, empty) = run_line("route show", &mut s, None);
    assert!(empty.contains("no route"), "{empty}");
    let (_, added) = run_line("route add here", &mut s, Some(&snapshot()));
    assert_eq!(
        added.trim_end(),
        "point 1: 1,1,1.5,-2,0.1,0.5,task (not saved: `save` keeps it)"
    );
    let (_, added) = run_line("route add 3 4.5 0 -1.5 transition", &mut s, None);
    assert!(
        added.starts_with("point 2: 2,1,3,4.5,0,-1.5,transition"),
        "{added}"
    );
    let (_, shown) = run_line("route show", &mut s, None);
    assert_eq!(
        shown,
        " 1. 1,1,1.5,-2,0.1,0.5,task\n 2. 2,1,3,4.5,0,-1.5,transition\n(not saved: `save` keeps it)\n"
    );
    let before = s.clone();
    for bad in [
        "route add 1 2 3",
        "route add 1 2 3 x",
        "route add 1 2 3 4 flying",
        "route add 1 2 3 4 task extra",
        "route fly",
        "route",
    ] {
        let (_, answer) = run_line(bad, &mut s, None);
        assert!(answer.starts_with("usage: "), "{bad}: {answer}");
    }
    let (_, stale) = run_line("route add here", &mut s, None);
    assert!(stale.contains("no fresh status"), "{stale}");
    assert_eq!(s, before, "refused commands change nothing");
    for _ in 2..MAX_ROUTE {
        run_line("route add 0 0 0 0", &mut s, None);
    }
    let (_, full) = run_line("route add 0 0 0 0", &mut s, None);
    assert!(full.contains("the route is full (32 points)"), "{full}");
    run_line("route clear", &mut s, None);
    assert!(s.edited().route.is_empty());
}

/// A full route of realistic coordinates is shown whole, with room for the prompt; one of
/// numbers too long for the answer shows as many points as fit and says how many more.
/// Route points added and not saved count as changes not saved, wherever those are told:
/// `status`, `reboot`, and a save from the web page, which drops them.
#[tokio::test(flavor = "current_thread")]
async fn an_unsaved_route_is_told_as_a_change_not_saved() {
    let mut s = Settings::new(Config::default());
    run_line("route add 1 2 0 0", &mut s, None);
    let (_, status) = run_line("status", &mut s, Some(&snapshot()));
    assert!(status.contains("unsaved    route\n"), "{status}");
    let (_, reboot) = run_line("reboot", &mut s, None);
    assert!(reboot.contains("changes not saved are dropped"), "{reboot}");
    // The web page's edits, saved, replace them: the owner is told they were lost.
    let desk = Desk::new();
    desk.publish(&s);
    let owner = async {
        desk.request().await;
        assert!(desk.take_edits(&mut s));
        let saved = desk::Saved {
            keys: s.unsaved(),
            took: Duration::from_millis(5),
            erases: 0,
            moved: false,
            route: false,
        };
        desk.answer(&mut s, Ok(saved))
    };
    let edit = desk.save_with(|edited| {
        edited.revert();
        edited.set(Key::Repeat, "300").unwrap();
        Ok::<_, Refused>(())
    });
    let (result, lost) = steady(async { tokio::join!(edit, owner) }).await;
    assert!(result.is_ok(), "{result:?}");
    assert!(lost.route, "the route typed on the console is lost");
    assert_eq!(lost.to_string(), "route");
}

#[test]
fn route_show_shows_a_full_route_or_says_what_it_left_out() {
    let mut s = Settings::new(Config::default());
    for _ in 0..MAX_ROUTE {
        let (_, added) = run_line(
            "route add -12.345678 -23.456789 -0.012345678 -1.2345678 transition",
            &mut s,
            None,
        );
        assert!(added.starts_with("point "), "{added}");
    }
    let (_, shown) = run_line("route show", &mut s, None);
    let lines: Vec<&str> = shown.lines().collect();
    assert_eq!(lines.len(), MAX_ROUTE + 1, "{shown}");
    assert_eq!(
        lines[MAX_ROUTE - 1],
        "32. 32,1,-12.345678,-23.456789,-0.012345678,-1.2345678,transition"
    );
    assert_eq!(lines[MAX_ROUTE], "(not saved: `save` keeps it)");
    assert!(
        shown.len() + PROMPT.len() <= ANSWER_MAX,
        "{} bytes",
        shown.len()
    );

    let mut s = Settings::new(Config::default());
    let tiny = "0.0000000000000000000000000000000000000011754944";
    let line = format!("route add -{tiny} -{tiny} -{tiny} -{tiny} transition");
    for _ in 0..MAX_ROUTE {
        run_line(&line, &mut s, None);
    }
    assert_eq!(s.edited().route.len(), MAX_ROUTE);
    let (_, shown) = run_line("route show", &mut s, None);
    let more = shown
        .lines()
        .find(|line| line.starts_with("... and "))
        .expect("says what it left out");
    let listed = shown
        .lines()
        .filter(|line| {
            line.trim_start()
                .split_once(". ")
                .is_some_and(|(n, _)| n.parse::<u8>().is_ok())
        })
        .count();
    assert!(listed > 0 && listed < MAX_ROUTE, "{listed} listed");
    assert_eq!(
        more,
        format!(
            "... and {} more points, too long to show here",
            MAX_ROUTE - listed
        )
    );
    assert!(shown.ends_with("(not saved: `save` keeps it)\n"), "{shown}");
    assert!(
        shown.len() + PROMPT.len() <= ANSWER_MAX,
        "{} bytes",
        shown.len()
    );
}

#[tokio::test(flavor = "current_thread")]
async fn a_saved_route_is_there_at_the_next_start() {
    let flash = flash();
    let shared = Shared::new();
    let (screen, _) = session(
        &flash,
        &shared,
        None,
        "route add 1 0 0 0\rroute add 2 0 0 1.5 transition\rsave\r",
    )
    .await;
    assert!(screen.contains("saved route in "), "{screen:?}");
    let route = saved(&flash).await.config().route.clone();
    assert_eq!(route.len(), 2);
    assert_eq!(route[1].pose, [2.0, 0.0, 0.0, 1.5]);
    let (screen, _) = session(&flash, &shared, None, "route show\r").await;
    assert!(
        screen.contains(" 2. 2,1,2,0,0,1.5,transition"),
        "{screen:?}"
    );
}
