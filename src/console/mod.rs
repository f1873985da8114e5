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
//! running ([`Busy`](crate::panel::Busy)).

pub mod commands;
pub mod line;

use core::fmt::Write as _;

use embassy_time::Instant;
use embedded_io_async::{Read, Write};
use embedded_storage_async::nor_flash::NorFlash;

use embassy_futures::select::{Either, select};

use crate::app::Shared;
use crate::settings::desk::{self, Desk, Refused, Saved};
use crate::settings::store::Store;
use crate::settings::{Key, LoadProblem, Settings, Unsaved};
use commands::Action;
use line::{Input, LineEditor};

/// The prompt, printed when the console waits for a command.
pub const PROMPT: &str = "x30> ";

/// Most text one answer prints: `show`, or `route show` with 32 points of eight-digit
/// coordinates (2.1 KiB).
pub const ANSWER_MAX: usize = 4096;

/// An answer being written: text, cut short rather than failing if it overflows.
pub type Answer = heapless::String<ANSWER_MAX>;

/// Why [`run`] returned: the person asked for a restart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reboot;

/// Runs the console until `reboot`: greets, then reads lines from `rx` and answers on `tx`,
/// and saves the web page's changes handed over at `desk`. `problem` is what went wrong
/// loading the saved settings, told in the greeting.
pub async fn run<R: Read, W: Write, F: NorFlash>(
    mut rx: R,
    mut tx: W,
    store: &mut Store<F>,
    settings: &mut Settings,
    problem: Option<LoadProblem>,
    shared: &Shared,
    desk: &Desk,
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
        // Typing never holds the buttons up: a terminal pasting text faster than the console
        // answers would otherwise keep this task busy from one byte to the next.
        embassy_futures::yield_now().await;
        desk.publish(settings);
        answer.clear();
        let typed = match select(rx.read(&mut byte), desk.request()).await {
            // A failed read (a UART framing error, say) only loses that byte.
            Either::First(Ok(1)) => {
                let [typed] = byte;
                typed
            }
            Either::First(_) => continue,
            Either::Second(()) => {
                web_save(store, settings, desk, shared, &mut answer).await;
                let _ = answer.push_str(PROMPT);
                let _ = answer.push_str(editor.unfinished());
                send(&mut tx, &answer).await;
                continue;
            }
        };
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
            Input::TooLong => {
                let _ = writeln!(
                    answer,
                    "\r\nline too long (over {} characters): not run",
                    line::LINE_MAX
                );
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
                    Action::Save => {
                        let result = desk::save(store, settings, shared).await;
                        tell_saved(&result, settings, &mut answer);
                    }
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

/// Saves settings edited on the web page, as if `save` were typed here, and answers the
/// desk. Changes typed here and not saved give way to the page's (which start from the
/// saved settings), and the console says so.
async fn web_save<F: NorFlash>(
    store: &mut Store<F>,
    settings: &mut Settings,
    desk: &Desk,
    shared: &Shared,
    answer: &mut Answer,
) {
    if !desk.take_edits(settings) {
        return;
    }
    let result = if desk.edits_stale(settings) {
        Err(Refused::Stale)
    } else {
        desk::save(store, settings, shared).await
    };
    let _ = write!(answer, "\r\nweb page: ");
    tell_saved(&result, settings, answer);
    let dropped = desk.answer(settings, result);
    if !dropped.is_empty() {
        let _ = write!(answer, "changes typed here and not saved were dropped: ");
        let _ = write!(answer, "{dropped}");
        let _ = writeln!(answer);
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

/// Tells how a save went.
pub fn tell_saved(result: &Result<Saved, Refused>, settings: &Settings, answer: &mut Answer) {
    let saved = match result {
        Ok(saved) => saved,
        Err(refused) => {
            let _ = writeln!(answer, "{refused}");
            return;
        }
    };
    let changes = Unsaved {
        keys: saved.keys,
        route: saved.route,
    };
    let _ = write!(answer, "saved {changes}");
    let _ = write!(answer, " in {} ms", saved.took.as_millis());
    // A field engineer sees what an erase costs on this board (it stalls some chips).
    match saved.erases {
        0 => {}
        1 => {
            let _ = write!(answer, " (1 page erased)");
        }
        n => {
            let _ = write!(answer, " ({n} pages erased)");
        }
    }
    if saved.moved {
        let _ = write!(answer, "; the panel reconnects to ");
        let _ = Key::Robot.write(settings.config(), answer);
        let _ = write!(answer, " now");
    }
    let _ = writeln!(answer);
    let mut later = saved
        .keys
        .iter()
        .filter(|key| key.needs_reboot())
        .peekable();
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
