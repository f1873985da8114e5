//! The serial console: a field engineer's way to read and change the panel's settings with
//! nothing but a terminal (115200 8N1).
//!
//! ```text
//! x30> set robot 10.0.0.2
//! robot = 10.0.0.2:30000 (not saved: `save` keeps it)
//! x30> save
//! saved in 3 ms; the panel reconnects to 10.0.0.2:30000 now
//! ```
//!
//! [`run`] reads bytes from any `embedded_io_async::Read`, echoes and answers on a `Write`,
//! and saves through the settings [`Store`]. It runs in a task of its own: typing never
//! holds the buttons or the robot's connections up. A save erases flash now and then, which
//! stalls the whole chip on some boards, so it is refused while anything a person does
//! could be delayed by it: a stop going out, a motion button held, a navigation task
//! running ([`Busy`]).

pub mod commands;
pub mod line;

use core::fmt::Write as _;

use embassy_time::Instant;
use embedded_io_async::{Read, Write};
use embedded_storage_async::nor_flash::NorFlash;

use crate::app::Shared;
use crate::panel::Busy;
use crate::settings::store::{BLOB_MAX, BUF_LEN, Store};
use crate::settings::{Key, Keys, LoadProblem, Settings};
use commands::Action;
use line::{Input, LineEditor};

/// The prompt, printed when the console waits for a command.
pub const PROMPT: &str = "x30> ";

/// Most text one answer prints; `show` is the longest.
pub const ANSWER_MAX: usize = 2048;

/// An answer being written: text, cut short rather than failing if it overflows.
pub type Answer = heapless::String<ANSWER_MAX>;

/// Why [`run`] returned: the person asked for a restart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reboot;

/// Runs the console until `reboot`: greets, then reads lines from `rx` and answers on `tx`.
/// `problem` is what went wrong loading the saved settings, told in the greeting.
pub async fn run<R: Read, W: Write, F: NorFlash>(
    mut rx: R,
    mut tx: W,
    store: &mut Store<F>,
    settings: &mut Settings,
    problem: Option<LoadProblem>,
    shared: &Shared,
) -> Reboot {
    let mut answer = Answer::new();
    let _ = writeln!(
        answer,
        "\r\nx30-panel {} console: `help` lists the commands",
        env!("CARGO_PKG_VERSION")
    );
    if let Some(problem) = problem {
        commands::tell_load_problem(problem, &mut answer);
    }
    let _ = answer.push_str(PROMPT);
    send(&mut tx, &answer).await;

    let mut editor = LineEditor::new();
    let mut byte = [0u8; 1];
    loop {
        // A failed read (a UART framing error, say) only loses that byte.
        if !matches!(rx.read(&mut byte).await, Ok(1)) {
            continue;
        }
        let [typed] = byte;
        answer.clear();
        match editor.push(typed) {
            Input::Nothing => {}
            Input::Echo(c) => {
                let _ = answer.push(char::from(c));
            }
            Input::Erase => {
                let _ = answer.push_str("\x08 \x08");
            }
            Input::Bell => {
                let _ = answer.push('\x07');
            }
            Input::Dropped => {
                let _ = answer.push_str("^C\r\n");
                let _ = answer.push_str(PROMPT);
            }
            Input::Line => {
                let _ = answer.push_str("\r\n");
                let action = commands::execute(
                    editor.line(),
                    settings,
                    shared.snapshot().as_ref(),
                    Instant::now(),
                    &mut answer,
                );
                match action {
                    Action::Answered => {}
                    Action::Save => save(store, settings, shared, &mut answer).await,
                    Action::Reboot => {
                        send(&mut tx, &answer).await;
                        return Reboot;
                    }
                }
                let _ = answer.push_str(PROMPT);
            }
        }
        send(&mut tx, &answer).await;
    }
}

/// Writes `text` to the terminal, `\n` as `\r\n`. A terminal that is gone loses it.
async fn send<W: Write>(tx: &mut W, text: &str) {
    for (i, piece) in text.split('\n').enumerate() {
        if i > 0 {
            let _ = tx.write_all(b"\r\n").await;
        }
        let _ = tx.write_all(piece.trim_end_matches('\r').as_bytes()).await;
    }
    let _ = tx.flush().await;
}

/// Why the panel must not save now: what the application reports, or a button event it has
/// not taken in yet.
pub fn busy(shared: &Shared) -> Option<Busy> {
    let panel = shared.snapshot().and_then(|s| s.busy);
    if panel.is_none() && !shared.buttons.is_empty() {
        // The event may be a motion press or a stop: let the panel see it first.
        return Some(Busy::StopPending);
    }
    panel
}

/// Saves the edited settings, unless the panel is busy, and puts them in effect.
async fn save<F: NorFlash>(
    store: &mut Store<F>,
    settings: &mut Settings,
    shared: &Shared,
    answer: &mut Answer,
) {
    // Checked again right before the flash work: a button may have been pressed since the
    // command was read.
    if let Some(busy) = busy(shared) {
        let _ = writeln!(
            answer,
            "not saved: {}; save when the panel is idle",
            busy.description()
        );
        return;
    }
    let mut blob = [0u8; BLOB_MAX];
    let Some(len) = settings.emit(&mut blob) else {
        let _ = writeln!(answer, "not saved: the settings do not fit the store");
        return;
    };
    let mut scratch = [0u8; BUF_LEN];
    let unsaved = settings.unsaved();
    let moved = settings.edited().robot != settings.config().robot;
    let started = Instant::now();
    let result = store
        .save(blob.get(..len).unwrap_or_default(), &mut scratch)
        .await;
    let took = Instant::now().saturating_duration_since(started);
    if let Err(e) = result {
        warn!("settings: save failed: {:?}", e);
        let _ = writeln!(
            answer,
            "not saved: the flash failed ({:?}); the settings in effect are unchanged",
            e
        );
        return;
    }
    settings.commit();
    shared.set_settings_lost(false);
    shared.apply_settings(settings.config().clone());
    info!("settings: saved in {} ms", took.as_millis());
    let _ = write!(answer, "saved ");
    names(unsaved, answer);
    let _ = write!(answer, " in {} ms", took.as_millis());
    // A field engineer sees what an erase costs on this board (it stalls some chips).
    match store.last_save_erases() {
        0 => {}
        1 => {
            let _ = write!(answer, " (1 page erased)");
        }
        n => {
            let _ = write!(answer, " ({n} pages erased)");
        }
    }
    if moved {
        let _ = write!(answer, "; the panel reconnects to ");
        let _ = Key::Robot.write(settings.config(), answer);
        let _ = write!(answer, " now");
    }
    let _ = writeln!(answer);
    let mut later = unsaved.iter().filter(|key| key.needs_reboot()).peekable();
    if later.peek().is_some() {
        let _ = write!(answer, "after `reboot`:");
        for key in later {
            let _ = write!(answer, " {}", key.name());
        }
        let _ = writeln!(answer);
    }
}

impl Key {
    /// Whether a saved change takes effect only at the next start: the board's network and
    /// its buttons are set up once.
    pub const fn needs_reboot(self) -> bool {
        matches!(
            self,
            Self::Dhcp | Self::Ip | Self::Gateway | Self::Debounce | Self::EstopInput
        )
    }
}

/// The keys of `keys` by name, for messages.
pub fn names(keys: Keys, answer: &mut Answer) {
    for (i, key) in keys.iter().enumerate() {
        let _ = write!(answer, "{}{}", if i > 0 { ", " } else { "" }, key.name());
    }
}
