//! The serial console's connection. QEMU connects the firmware's UART1 to a Unix socket that
//! x30-qemu listens on, in the run's private folder, so the console never touches the
//! terminal: each line the console prints arrives as an [`Event::Console`], and each line
//! typed (`console TEXT`) is sent with a terminal's Enter, `\r`.

use std::io::Write;
use std::os::unix::net::UnixListener;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, Sender};
use std::thread;

use crate::session::{self, Event};

/// The console's socket, listening before QEMU starts (QEMU fails if it cannot connect).
#[derive(Debug)]
pub struct Console {
    /// The listening socket.
    listener: UnixListener,
    /// Where it is.
    path: PathBuf,
}

impl Console {
    /// Listens on a new Unix socket at `path`.
    pub fn listen(path: &Path) -> Result<Self, String> {
        let listener = UnixListener::bind(path)
            .map_err(|e| format!("cannot listen on {}: {e}", path.display()))?;
        Ok(Self {
            listener,
            path: path.to_owned(),
        })
    }

    /// The socket's path, for QEMU.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Waits, in a thread of its own, for QEMU's connection; then forwards the console's
    /// lines to `events` (after an [`Event::ConsoleOpen`]) and writes the lines sent to the
    /// returned sender, each followed by `\r`. Lines sent before QEMU connects wait.
    pub fn start(self, events: Sender<Event>) -> Sender<String> {
        let (typed, to_type) = mpsc::channel();
        thread::spawn(move || {
            // Only QEMU is told the path, in a folder only this user can enter.
            let Ok((stream, _)) = self.listener.accept() else {
                return;
            };
            if events.send(Event::ConsoleOpen).is_err() {
                return;
            }
            if let Ok(writer) = stream.try_clone() {
                thread::spawn(move || type_lines(writer, &to_type));
            }
            // Lines end in \r\n on a serial console; any other \r (a redrawn line) goes too.
            session::forward_lines(stream, &events, |line| {
                Event::Console(line.replace('\r', ""))
            });
        });
        typed
    }
}

/// Writes each line from `lines` to `to` with a terminal's Enter, until either end closes.
fn type_lines(mut to: impl Write, lines: &Receiver<String>) {
    for line in lines {
        let written = to
            .write_all(line.as_bytes())
            .and_then(|()| to.write_all(b"\r"))
            .and_then(|()| to.flush());
        if written.is_err() {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{BufRead, BufReader};
    use std::os::unix::net::UnixStream;
    use std::time::Duration;

    /// Longest a test waits for an event or a byte.
    const LIMIT: Duration = Duration::from_secs(10);

    /// A console listening in a fresh folder, started; the folder, the sender of typed
    /// lines, the events, and a connection playing QEMU.
    fn connected() -> (
        tempfile::TempDir,
        Sender<String>,
        Receiver<Event>,
        UnixStream,
    ) {
        let dir = tempfile::Builder::new()
            .prefix("x30-qemu-test-")
            .tempdir()
            .unwrap();
        let console = Console::listen(&dir.path().join("console.sock")).unwrap();
        let qemu = UnixStream::connect(console.path()).unwrap();
        qemu.set_read_timeout(Some(LIMIT)).unwrap();
        let (sender, events) = mpsc::channel();
        let typed = console.start(sender);
        (dir, typed, events, qemu)
    }

    fn next(events: &Receiver<Event>) -> Event {
        events.recv_timeout(LIMIT).expect("an event")
    }

    #[test]
    fn console_lines_become_events_without_their_carriage_returns() {
        let (_dir, _typed, events, mut qemu) = connected();
        assert!(matches!(next(&events), Event::ConsoleOpen));
        qemu.write_all(b"x30> show\r\nrobot 10.0.2.2:30000\r\n\r\nx30> ")
            .unwrap();
        for expected in ["x30> show", "robot 10.0.2.2:30000", ""] {
            match next(&events) {
                Event::Console(line) => assert_eq!(line, expected),
                other => panic!("{other:?}"),
            }
        }
        // The prompt waits for its line to end, or for the console to close.
        assert!(events.recv_timeout(Duration::from_millis(200)).is_err());
        drop(qemu);
        match next(&events) {
            Event::Console(line) => assert_eq!(line, "x30> "),
            other => panic!("{other:?}"),
        }
        assert!(matches!(next(&events), Event::OutputEnd));
    }

    #[test]
    fn typed_lines_end_with_a_carriage_return_even_if_sent_before_the_connection() {
        let dir = tempfile::Builder::new()
            .prefix("x30-qemu-test-")
            .tempdir()
            .unwrap();
        let console = Console::listen(&dir.path().join("console.sock")).unwrap();
        let path = console.path().to_owned();
        let (sender, _events) = mpsc::channel();
        let typed = console.start(sender);
        typed.send("help".into()).unwrap();
        typed.send("set robot 10.0.2.2:30001".into()).unwrap();
        let qemu = UnixStream::connect(path).unwrap();
        qemu.set_read_timeout(Some(LIMIT)).unwrap();
        let mut got = Vec::new();
        let mut reader = BufReader::new(qemu);
        for _ in 0..2 {
            reader.read_until(b'\r', &mut got).unwrap();
        }
        assert_eq!(got, b"help\rset robot 10.0.2.2:30001\r");
    }

    #[test]
    fn a_socket_that_cannot_be_made_is_an_error_naming_it() {
        let err = Console::listen(Path::new("/nonexistent/console.sock")).unwrap_err();
        assert!(
            err.starts_with("cannot listen on /nonexistent/console.sock"),
            "{err}"
        );
    }
}
