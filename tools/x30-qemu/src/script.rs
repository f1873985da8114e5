//! The input language: what each line of x30-qemu's standard input means, and what the
//! firmware's output lines say.
//!
//! ```text
//! # a comment; blank lines are ignored too
//! wait led link on      wait until the link LED is on (or a line containing other text)
//! +forward              press a button (sent to the virtual panel's UART)
//! sleep 2000            pause the script for 2000 ms (x30-qemu itself; nothing is sent)
//! -forward              release it
//! send TEXT             send TEXT to the UART as it is (for testing the firmware's parser)
//! console TEXT          type TEXT and Enter on the serial console (UART1)
//! wait console: saved   wait until the console prints a line containing "saved"
//! ```
//!
//! The serial console's output comes on standard output one line at a time, each as
//! `console: LINE`, so `wait` finds it like any other line. The console echoes what is
//! typed after its prompt, so a command shows as one line: `console: x30> show`.

use std::fmt;
use std::time::Duration;

use x30_panel::panel::{self, buttons::Button};

/// The LEDs of the panel, by the names the firmware logs.
pub const LED_NAMES: [&str; 3] = ["link", "activity", "fault"];

/// Whether `state` is a state an LED can be logged in (`on`, `off`, `blink`, …).
fn is_led_state(state: &str) -> bool {
    panel::Led::ALL.iter().any(|led| led.name() == state)
}

/// One thing a script line asks for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Step {
    /// Write this line to the virtual panel's UART.
    Send(String),
    /// Type this line and Enter on the serial console.
    Console(String),
    /// Pause the script (output keeps flowing).
    Sleep(Duration),
    /// Pause the script until the firmware prints a matching line.
    Wait(Pattern),
}

/// What a `wait` line waits for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Pattern {
    /// An LED in a state; already true if the LED's last logged state is that one, so that a
    /// script does not hang when the LED changed before the script got there.
    Led(Led),
    /// A line containing this text, printed after the wait began.
    Text(String),
}

impl fmt::Display for Pattern {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Led(led) => write!(f, "{led}"),
            Self::Text(text) => f.write_str(text),
        }
    }
}

/// An LED state change as the firmware logs it: `led NAME on|off|blink|blink-fast`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Led {
    /// `link`, `activity` or `fault`.
    pub name: String,
    /// `on`, `off`, `blink` or `blink-fast`.
    pub state: String,
}

impl fmt::Display for Led {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "led {} {}", self.name, self.state)
    }
}

/// Parses one input line: `Ok(None)` for blank lines and comments, an error message for a
/// line that means nothing (so a typo in a script is reported, not sent).
pub fn parse(line: &str) -> Result<Option<Step>, String> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    if let Some(rest) = line.strip_prefix(['+', '-']) {
        return match Button::from_name(rest) {
            Some(_) => Ok(Some(Step::Send(line.to_owned()))),
            None => Err(format!(
                "unknown button {rest:?}; the buttons are: {}",
                Button::ALL.map(Button::name).join(" ")
            )),
        };
    }
    let (word, rest) = line
        .split_once(char::is_whitespace)
        .map_or((line, ""), |(w, r)| (w, r.trim()));
    match word {
        "sleep" => rest
            .parse::<u64>()
            .map(|ms| Some(Step::Sleep(Duration::from_millis(ms))))
            .map_err(|_| format!("`sleep` needs a whole number of milliseconds, not {rest:?}")),
        "wait" if rest.is_empty() => Err("`wait` needs the text to wait for".into()),
        "wait" => Ok(Some(Step::Wait(match led_in(rest) {
            Some(led) if rest.split_whitespace().count() == 3 => Pattern::Led(led),
            _ => Pattern::Text(rest.to_owned()),
        }))),
        "send" if rest.is_empty() => Err("`send` needs the text to send".into()),
        "send" => Ok(Some(Step::Send(rest.to_owned()))),
        "console" if rest.is_empty() => Err("`console` needs the text to type".into()),
        "console" => Ok(Some(Step::Console(rest.to_owned()))),
        _ => Err(format!(
            "cannot read {line:?}: expected +BUTTON, -BUTTON, sleep MS, wait TEXT, send TEXT, \
             console TEXT or # comment"
        )),
    }
}

/// The LED change a firmware line reports, if it reports one. The three words may follow a
/// prefix (a timestamp or log level), so the line is searched rather than matched whole.
pub fn led_in(line: &str) -> Option<Led> {
    let words: Vec<&str> = line.split_whitespace().collect();
    words.windows(3).find_map(|w| match w {
        ["led", name, state] if LED_NAMES.contains(name) && is_led_state(state) => Some(Led {
            name: (*name).to_owned(),
            state: (*state).to_owned(),
        }),
        _ => None,
    })
}

/// Whether a firmware line reports a panic (`panic: ...`, possibly after a log prefix).
pub fn is_panic(line: &str) -> bool {
    line.split_whitespace().any(|word| word == "panic:") || line.trim_start().starts_with("panic:")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buttons() {
        assert_eq!(parse("+forward"), Ok(Some(Step::Send("+forward".into()))));
        assert_eq!(
            parse("  -turn-left \r"),
            Ok(Some(Step::Send("-turn-left".into())))
        );
        for button in Button::ALL {
            assert!(parse(&format!("+{}", button.name())).is_ok());
        }
        let err = parse("+forwards").unwrap_err();
        assert!(err.contains("unknown button \"forwards\""), "{err}");
        assert!(err.contains("strafe-left"), "{err}");
        assert!(parse("+").is_err());
    }

    #[test]
    fn comments_and_blanks() {
        assert_eq!(parse(""), Ok(None));
        assert_eq!(parse("   "), Ok(None));
        assert_eq!(parse("# hold forward"), Ok(None));
        assert_eq!(parse("  #"), Ok(None));
    }

    #[test]
    fn sleep() {
        assert_eq!(
            parse("sleep 250"),
            Ok(Some(Step::Sleep(Duration::from_millis(250))))
        );
        assert!(parse("sleep").is_err());
        assert!(parse("sleep 1.5").is_err());
        assert!(parse("sleep -3").is_err());
    }

    #[test]
    fn wait() {
        assert_eq!(
            parse("wait led link on"),
            Ok(Some(Step::Wait(Pattern::Led(Led {
                name: "link".into(),
                state: "on".into()
            }))))
        );
        assert_eq!(
            parse("wait connected to"),
            Ok(Some(Step::Wait(Pattern::Text("connected to".into()))))
        );
        // Not exactly an LED change: plain text.
        assert_eq!(
            parse("wait led link on twice"),
            Ok(Some(Step::Wait(Pattern::Text("led link on twice".into()))))
        );
        assert!(parse("wait").is_err());
        assert!(parse("wait   ").is_err());
    }

    #[test]
    fn send_and_garbage() {
        assert_eq!(parse("send +jump"), Ok(Some(Step::Send("+jump".into()))));
        assert!(parse("send").is_err());
        assert!(parse("forward").is_err());
        assert!(parse("sleeps 3").is_err());
    }

    #[test]
    fn console() {
        assert_eq!(
            parse("console set robot 10.0.2.2:30001"),
            Ok(Some(Step::Console("set robot 10.0.2.2:30001".into())))
        );
        assert_eq!(
            parse("  console   help \r"),
            Ok(Some(Step::Console("help".into())))
        );
        let err = parse("console").unwrap_err();
        assert!(err.contains("`console` needs the text to type"), "{err}");
        assert!(parse("console   ").is_err());
        assert!(parse("consoles help").is_err());
        // Waiting for the console's output is an ordinary text wait.
        assert_eq!(
            parse("wait console: saved"),
            Ok(Some(Step::Wait(Pattern::Text("console: saved".into()))))
        );
    }

    #[test]
    fn led_lines() {
        let led = |name: &str, state: &str| {
            Some(Led {
                name: name.into(),
                state: state.into(),
            })
        };
        assert_eq!(led_in("led link on"), led("link", "on"));
        assert_eq!(led_in("0.512 INFO led fault blink"), led("fault", "blink"));
        assert_eq!(led_in("led link blink-fast"), led("link", "blink-fast"));
        assert_eq!(led_in("led activity off\r"), led("activity", "off"));
        assert_eq!(led_in("led power on"), None);
        assert_eq!(led_in("led link dim"), None);
        assert_eq!(led_in("sled link on"), None);
        assert_eq!(led_in("led link"), None);
    }

    #[test]
    fn panics() {
        assert!(is_panic("panic: panicked at src/app.rs:10:5"));
        assert!(is_panic("  panic:oops"));
        assert!(is_panic("ERROR panic: out of memory"));
        assert!(!is_panic("no panic here"));
        assert!(!is_panic("led fault on"));
    }
}
