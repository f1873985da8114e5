//! Line editing for a serial terminal: characters echo as typed, backspace erases, Enter ends
//! the line, Ctrl-C or Ctrl-U drops it, and the escape sequences of arrow and function keys
//! are swallowed rather than typed into the line.

/// Longest line the console reads; a longer one rings the bell instead of growing, and is
/// refused when it ends. Room for the longest setting, eight breathing light presets (178).
pub const LINE_MAX: usize = 200;

/// What the terminal should be sent after a byte was typed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input {
    /// Nothing.
    Nothing,
    /// Echo this character.
    Echo(u8),
    /// Erase the last character on the screen.
    Erase,
    /// The line is full: ring the bell.
    Bell,
    /// The line was dropped: start a new one.
    Dropped,
    /// The line is complete: [`LineEditor::line`] holds it until the next byte.
    Line,
    /// The line ended after more than [`LINE_MAX`] characters were typed into it: dropped,
    /// not run, since what was kept is not what was typed (a pasted value cut short).
    TooLong,
}

/// Where an escape sequence is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Escape {
    /// Not in one.
    None,
    /// After ESC.
    Started,
    /// After ESC and `[` (or `O`): parameters until a final byte.
    Sequence,
}

/// A line being typed.
#[derive(Debug, Clone)]
pub struct LineEditor {
    /// The characters so far (printable ASCII only).
    line: heapless::String<LINE_MAX>,
    /// Whether the line was completed by the previous byte, to be cleared by the next.
    complete: bool,
    /// Whether the previous byte was a CR, so that the LF of a CR LF ends no second line.
    after_cr: bool,
    /// Whether a character did not fit the line: then it is refused when it ends.
    overflowed: bool,
    /// Escape-sequence state.
    escape: Escape,
}

impl Default for LineEditor {
    fn default() -> Self {
        Self::new()
    }
}

impl LineEditor {
    /// An empty line.
    pub const fn new() -> Self {
        Self {
            line: heapless::String::new(),
            complete: false,
            after_cr: false,
            overflowed: false,
            escape: Escape::None,
        }
    }

    /// The line typed so far, or the complete line right after [`Input::Line`].
    pub fn line(&self) -> &str {
        &self.line
    }

    /// The line being typed, to show again after the console printed something else: empty
    /// right after [`Input::Line`], whose line was already run.
    pub fn unfinished(&self) -> &str {
        if self.complete { "" } else { &self.line }
    }

    /// Takes one typed byte.
    pub fn push(&mut self, byte: u8) -> Input {
        if core::mem::take(&mut self.complete) {
            self.line.clear();
        }
        let after_cr = core::mem::replace(&mut self.after_cr, byte == b'\r');
        match self.escape {
            Escape::Started => {
                self.escape = if matches!(byte, b'[' | b'O') {
                    Escape::Sequence
                } else {
                    Escape::None
                };
                return Input::Nothing;
            }
            Escape::Sequence => {
                // Parameters and intermediates are 0x20–0x3F; a final byte ends it.
                if !(0x20..=0x3F).contains(&byte) {
                    self.escape = Escape::None;
                }
                return Input::Nothing;
            }
            Escape::None => {}
        }
        match byte {
            b'\n' if after_cr => Input::Nothing,
            b'\r' | b'\n' if core::mem::take(&mut self.overflowed) => {
                self.line.clear();
                Input::TooLong
            }
            b'\r' | b'\n' => {
                self.complete = true;
                Input::Line
            }
            // Backspace and DEL: terminals send either for the backspace key.
            0x08 | 0x7F => match self.line.pop() {
                Some(_) => Input::Erase,
                None => Input::Nothing,
            },
            // Ctrl-C, Ctrl-U.
            0x03 | 0x15 => {
                self.line.clear();
                self.overflowed = false;
                Input::Dropped
            }
            0x1B => {
                self.escape = Escape::Started;
                Input::Nothing
            }
            0x20..=0x7E => match self.line.push(char::from(byte)) {
                Ok(()) => Input::Echo(byte),
                Err(_) => {
                    self.overflowed = true;
                    Input::Bell
                }
            },
            // Other control characters and non-ASCII bytes mean nothing here.
            _ => Input::Nothing,
        }
    }
}
