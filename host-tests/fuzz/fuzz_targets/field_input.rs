//! libFuzzer target: what the field hands the panel's settings, byte for byte. A field
//! engineer types on the serial console, a browser posts the settings form, and the flash
//! gives back whatever a power cut or a different firmware left in it. None of these may
//! panic the firmware, and whatever any of them leaves in the settings must be storable.
//!
//! The input's first byte chooses the way in (its remainder modulo 3); the rest is:
//!
//! - **flash:** a settings blob, as the store would hand it to `Settings::parse`;
//! - **console:** sixteen bytes of the robot's pose (x, y, z, yaw as little-endian `f32`s,
//!   for `dock here` and `route add here`), then the bytes typed, each through the console's
//!   `LineEditor`, every completed line run by `console::commands::execute` (a `save` keeps
//!   the edits when the console would: no conflict, and they fit the store);
//! - **form:** a settings form body, posted after a correct `pin=1234&` through
//!   `web::post_settings` to a settings owner that takes the edits.
//!
//! Invariants (a panic is a finding):
//!
//! - nothing panics, whatever the bytes;
//! - the settings each way in leaves (loaded, edited on the console after each line, taken
//!   from the form) are written to a blob that fits the store, or do not fit at all; a blob
//!   written is read back by `Settings::parse` with no problem and as the same
//!   configuration: nothing a person could enter is lost or changed by a reboot;
//! - a form with the right PIN is never answered 403, 500 or 503.
//!
//! Build and run with `scripts/fuzz.sh`.
#![no_main]

use embassy_futures::block_on;
use embassy_futures::select::{Either, select};
use embassy_time::{Duration, Instant};
use libfuzzer_sys::fuzz_target;
use x30_panel::app::Snapshot;
use x30_panel::config::Config;
use x30_panel::console::Answer;
use x30_panel::console::commands::{Action, execute};
use x30_panel::console::line::{Input, LineEditor};
use x30_panel::proto::codes::MotionState;
use x30_panel::proto::message::RobotStatus;
use x30_panel::settings::desk::{Desk, Saved};
use x30_panel::settings::store::BUF_LEN;
use x30_panel::settings::{Key, Settings};
use x30_panel::web;

#[path = "../../tests/common/connected.rs"]
mod connected;
use connected::connected;

/// The PIN the form's settings have saved, and the form's first field, which gives it.
const PIN: &str = "1234";
const PIN_FIELD: &[u8] = b"pin=1234&";

fuzz_target!(|data: &[u8]| {
    let Some((&way, rest)) = data.split_first() else {
        return;
    };
    match way % 3 {
        0 => flash(rest),
        1 => console(rest),
        _ => form(rest),
    }
});

/// A blob from the flash, loaded.
fn flash(blob: &[u8]) {
    let (settings, _problem) = Settings::parse(Config::default(), blob);
    assert_storable(&settings);
}

/// Bytes typed on the console.
fn console(data: &[u8]) {
    let (pose, typed) = data.split_at(data.len().min(16));
    let snapshot = snapshot(pose);
    let mut settings = Settings::new(Config::default());
    let mut editor = LineEditor::new();
    for &byte in typed {
        if editor.push(byte) != Input::Line {
            continue;
        }
        let mut answer = Answer::new();
        let at = snapshot.at;
        if execute(
            editor.line(),
            &mut settings,
            Some(&snapshot),
            at,
            &mut answer,
        ) == Action::Save
            && settings.check().is_ok()
            && settings.emit(&mut [0; BUF_LEN]).is_some()
        {
            settings.commit();
        }
        assert_storable(&settings);
    }
}

/// A settings form body, after the right PIN.
fn form(fields: &[u8]) {
    let mut settings = Settings::new(Config::default());
    settings.set(Key::WebPin, PIN).expect("a valid PIN");
    settings.commit();
    let desk = Desk::new();
    desk.publish(&settings);
    let body = [PIN_FIELD, fields].concat();
    // The settings' owner, as the console task is: takes the form's edits and answers. It
    // never ends; the post does.
    let owner = async {
        loop {
            desk.request().await;
            if desk.take_edits(&mut settings) {
                assert_storable(&settings);
                let saved = Saved {
                    keys: settings.unsaved(),
                    took: Duration::from_ticks(0),
                    erases: 0,
                    moved: false,
                    route: false,
                };
                desk.answer(&mut settings, Ok(saved));
                settings.commit();
            }
        }
    };
    // The owner never ends: only the post can.
    let Either::First(posted) = block_on(select(web::post_settings(&desk, &body), owner));
    assert!(
        !matches!(posted.status, 403 | 500 | 503),
        "{} {} for {:?}",
        posted.status,
        posted.message,
        String::from_utf8_lossy(&body)
    );
}

/// Asserts that `settings`' edits are stored as a blob that reads back as the same
/// configuration, if they fit the store at all.
fn assert_storable(settings: &Settings) {
    let mut blob = [0u8; BUF_LEN];
    let Some(len) = settings.emit(&mut blob) else {
        return;
    };
    let (loaded, problem) = Settings::parse(Config::default(), &blob[..len]);
    assert_eq!(problem, None, "the blob {:?}", &blob[..len]);
    assert_eq!(
        loaded.config(),
        settings.edited(),
        "the blob {:?}",
        &blob[..len]
    );
}

/// What the console shows of the robot, standing at `pose` (x, y, z, yaw; zero where the
/// input ran out).
fn snapshot(pose: &[u8]) -> Snapshot {
    let mut values = [0.0f32; 4];
    for (value, bytes) in values.iter_mut().zip(pose.chunks_exact(4)) {
        *value = f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
    }
    let [pos_x, pos_y, pos_z, yaw] = values;
    let at = Instant::from_secs(100);
    let status = RobotStatus {
        motion_state: MotionState::StandingUp,
        pos_x,
        pos_y,
        pos_z,
        yaw,
        ..RobotStatus::UNAVAILABLE
    };
    connected(status, at)
}
