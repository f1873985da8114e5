//! A terminal for the console tests: keys typed through a channel, the screen collected.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

use embedded_io_async::{ErrorKind, ErrorType, Read, Write};
use tokio::sync::mpsc;

/// The console's side of a terminal: typed text comes from a channel.
pub struct Keyboard {
    /// Text typed, not yet read.
    typed: mpsc::UnboundedReceiver<Vec<u8>>,
    /// The rest of the text being read.
    pending: VecDeque<u8>,
}

impl Keyboard {
    /// A keyboard, and where to send what is typed on it.
    pub fn new() -> (Self, mpsc::UnboundedSender<Vec<u8>>) {
        let (keys, typed) = mpsc::unbounded_channel();
        let keyboard = Self {
            typed,
            pending: VecDeque::new(),
        };
        (keyboard, keys)
    }
}

impl ErrorType for Keyboard {
    type Error = ErrorKind;
}

impl Read for Keyboard {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        while self.pending.is_empty() {
            match self.typed.recv().await {
                Some(text) => self.pending.extend(text),
                // Nothing more will be typed: wait for the test to drop the console.
                None => std::future::pending::<()>().await,
            }
        }
        match (self.pending.pop_front(), buf.first_mut()) {
            (Some(byte), Some(slot)) => {
                *slot = byte;
                Ok(1)
            }
            _ => Ok(0),
        }
    }
}

/// The console's output, collected.
#[derive(Clone, Default)]
pub struct Screen(Rc<RefCell<Vec<u8>>>);

impl Screen {
    /// Everything written so far.
    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.0.borrow()).into_owned()
    }
}

impl ErrorType for Screen {
    type Error = ErrorKind;
}

impl Write for Screen {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        self.0.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }

    async fn flush(&mut self) -> Result<(), ErrorKind> {
        Ok(())
    }
}
