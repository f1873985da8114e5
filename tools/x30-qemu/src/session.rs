//! One run of the virtual panel: script lines in, firmware lines out, until the input ends,
//! the firmware fails, time runs out or the user interrupts.
//!
//! Everything that can happen arrives as an [`Event`] on one channel (reader threads for
//! x30-qemu's standard input, QEMU's two output streams and the serial console, the Ctrl-C
//! handler), and one loop on the main thread decides. QEMU's exit is polled rather than
//! waited for in a thread, because the same `Child` must also be killable from the loop.

use std::collections::{HashMap, VecDeque};
use std::io::{BufRead, BufReader, Read, Write};
use std::process::{Child, ExitStatus};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::thread;
use std::time::{Duration, Instant};

use crate::script::{self, Led, Pattern, Step};

/// How often QEMU's exit is checked when nothing else happens.
const POLL: Duration = Duration::from_millis(20);

/// How long a panicking firmware gets to finish its message and exit through semihosting
/// before x30-qemu stops QEMU itself.
const PANIC_EXIT_WAIT: Duration = Duration::from_secs(2);

/// How long to keep reading QEMU's output once it has exited: what it wrote last is still
/// in the pipes.
const DRAIN_WAIT: Duration = Duration::from_secs(1);

/// Something that happened, as the session loop learns it.
#[derive(Debug)]
pub enum Event {
    /// A line of x30-qemu's standard input.
    Input(String),
    /// x30-qemu's standard input ended.
    InputEnd,
    /// A line QEMU printed (the firmware's logs, UART0 output, QEMU's own messages).
    Output(String),
    /// QEMU connected the serial console: one more output stream to see to its end.
    ConsoleOpen,
    /// A line the serial console printed.
    Console(String),
    /// One of QEMU's output streams (or the console) ended.
    OutputEnd,
    /// Ctrl-C.
    Interrupt,
}

/// Limits of a session.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// How long the firmware keeps running after the input is done.
    pub grace: Duration,
    /// Longest the whole session may last, if limited.
    pub timeout: Option<Duration>,
    /// Longest a `wait` line waits.
    pub wait_timeout: Duration,
}

/// How a session ended.
#[derive(Debug)]
pub enum Outcome {
    /// The input ended, the grace period passed, and x30-qemu stopped QEMU.
    Finished,
    /// QEMU exited by itself (the firmware ended through semihosting, or QEMU failed).
    Exited(ExitStatus),
    /// The firmware printed this `panic:` line.
    Panicked(String),
    /// A `wait` line waited in vain.
    WaitTimedOut(Pattern),
    /// The session's time limit passed.
    TimedOut,
    /// Ctrl-C.
    Interrupted,
}

/// How a session ended, and whether its script was sound.
#[derive(Debug)]
pub struct Report {
    /// Why it ended.
    pub outcome: Outcome,
    /// Input lines that meant nothing and were skipped.
    pub script_errors: usize,
}

impl Report {
    /// The process exit code: 0 for a clean run, 1 for a firmware or script failure, 124
    /// for the time limit (as timeout(1) does), 130 for Ctrl-C (as shells report SIGINT).
    pub fn exit_code(&self) -> u8 {
        let failed = self.script_errors > 0;
        match &self.outcome {
            Outcome::Finished => u8::from(failed),
            Outcome::Exited(status) => u8::from(failed || !status.success()),
            Outcome::Panicked(_) | Outcome::WaitTimedOut(_) => 1,
            Outcome::TimedOut => 124,
            Outcome::Interrupted => 130,
        }
    }
}

/// Where the script is.
#[derive(Debug)]
enum Blocked {
    /// Sleeping until then.
    Sleep(Instant),
    /// Waiting for a line, until the deadline.
    Wait(Pattern, Instant),
}

/// The running session.
pub struct Session {
    child: Child,
    events: Receiver<Event>,
    to_uart: Option<Sender<String>>,
    to_console: Option<Sender<String>>,
    options: Options,
    start: Instant,
    steps: VecDeque<Step>,
    blocked: Option<Blocked>,
    input_done: bool,
    grace_end: Option<Instant>,
    open_outputs: usize,
    leds: HashMap<String, String>,
    panic: Option<(String, Instant)>,
    script_errors: usize,
}

impl Session {
    /// Takes over a freshly spawned QEMU (all three streams piped): starts the threads that
    /// read its output and write its input. `events` must be the receiving end of `sender`,
    /// whose other clones feed x30-qemu's own input, the console's lines and Ctrl-C;
    /// `console` takes the lines typed on the serial console.
    pub fn new(
        mut child: Child,
        sender: &Sender<Event>,
        events: Receiver<Event>,
        console: Sender<String>,
        options: Options,
    ) -> Self {
        let mut open_outputs = 0;
        if let Some(stdout) = child.stdout.take() {
            spawn_reader(stdout, sender.clone());
            open_outputs += 1;
        }
        if let Some(stderr) = child.stderr.take() {
            spawn_reader(stderr, sender.clone());
            open_outputs += 1;
        }
        let to_uart = child.stdin.take().map(|mut stdin| {
            let (tx, rx) = mpsc::channel::<String>();
            // A thread of its own: QEMU takes UART input only as fast as the guest reads
            // it, and a full pipe must not stall the loop that watches the clock.
            thread::spawn(move || {
                for line in rx {
                    let written = stdin
                        .write_all(line.as_bytes())
                        .and_then(|()| stdin.write_all(b"\n"))
                        .and_then(|()| stdin.flush());
                    if written.is_err() {
                        break;
                    }
                }
            });
            tx
        });
        Self {
            child,
            events,
            to_uart,
            to_console: Some(console),
            options,
            start: Instant::now(),
            steps: VecDeque::new(),
            blocked: None,
            input_done: false,
            grace_end: None,
            open_outputs,
            leds: HashMap::new(),
            panic: None,
            script_errors: 0,
        }
    }

    /// Runs until the session ends, then stops QEMU if it still runs and reaps it.
    pub fn run(mut self) -> Report {
        let outcome = self.run_until_end();
        if !matches!(outcome, Outcome::Exited(_)) {
            // Already dead is fine; killing only fails then.
            let _ = self.child.kill();
        }
        // Reaps QEMU in every case, so no zombie is left even for an instant longer.
        let _ = self.child.wait();
        self.to_uart = None;
        self.to_console = None;
        self.drain();
        let outcome = match (self.panic.take(), outcome) {
            // A panic explains QEMU's exit, a wait in vain or a timeout better than they do.
            (Some((line, _)), outcome) if !matches!(outcome, Outcome::Interrupted) => {
                Outcome::Panicked(line)
            }
            (_, outcome) => outcome,
        };
        Report {
            outcome,
            script_errors: self.script_errors,
        }
    }

    fn run_until_end(&mut self) -> Outcome {
        let deadline = self.options.timeout.map(|t| self.start + t);
        loop {
            let now = Instant::now();
            if deadline.is_some_and(|d| now >= d) {
                return Outcome::TimedOut;
            }
            if let Some(pattern) = self.advance_script(now) {
                return Outcome::WaitTimedOut(pattern);
            }
            if self.grace_end.is_some_and(|end| now >= end) {
                return Outcome::Finished;
            }
            if self.panic.as_ref().is_some_and(|(_, d)| now >= *d) {
                return Outcome::Finished; // turned into Panicked by `run`
            }
            match self.child.try_wait() {
                Ok(Some(status)) => return Outcome::Exited(status),
                Ok(None) => {}
                Err(e) => {
                    self.note(&format!("cannot check on QEMU: {e}"));
                    return Outcome::Finished;
                }
            }
            let wake = [
                deadline,
                self.grace_end,
                self.panic.as_ref().map(|(_, d)| *d),
                match self.blocked {
                    Some(Blocked::Sleep(until) | Blocked::Wait(_, until)) => Some(until),
                    None => None,
                },
            ]
            .into_iter()
            .flatten()
            .fold(now + POLL, Instant::min);
            match self
                .events
                .recv_timeout(wake.saturating_duration_since(now))
            {
                Ok(Event::Interrupt) => return Outcome::Interrupted,
                Ok(event) => self.handle(event),
                Err(RecvTimeoutError::Timeout) => {}
                // Cannot happen while `self` holds no sender but the readers do; treat as
                // nothing more to come.
                Err(RecvTimeoutError::Disconnected) => thread::sleep(POLL),
            }
        }
    }

    /// Runs script steps until one blocks; returns the pattern of a wait that timed out.
    fn advance_script(&mut self, now: Instant) -> Option<Pattern> {
        match self.blocked.take() {
            Some(Blocked::Sleep(until)) if now < until => {
                self.blocked = Some(Blocked::Sleep(until));
                return None;
            }
            Some(Blocked::Wait(pattern, until)) => {
                if now >= until {
                    return Some(pattern);
                }
                self.blocked = Some(Blocked::Wait(pattern, until));
                return None;
            }
            Some(Blocked::Sleep(_)) | None => {}
        }
        while let Some(step) = self.steps.pop_front() {
            match step {
                Step::Send(line) => {
                    self.note(&format!("> {line}"));
                    if let Some(tx) = &self.to_uart {
                        // The writer is gone only when QEMU is; its exit is noticed anyway.
                        let _ = tx.send(line);
                    }
                }
                Step::Console(text) => {
                    self.note(&format!("console> {text}"));
                    if let Some(tx) = &self.to_console {
                        // Typed lines wait for QEMU to connect; gone only when QEMU is.
                        let _ = tx.send(text);
                    }
                }
                Step::Sleep(time) => {
                    self.blocked = Some(Blocked::Sleep(now + time));
                    return None;
                }
                Step::Wait(Pattern::Led(led)) if self.led_is(&led) => {
                    self.note(&format!("{led} already"));
                }
                Step::Wait(pattern) => {
                    self.note(&format!("waiting for \"{pattern}\""));
                    self.blocked = Some(Blocked::Wait(pattern, now + self.options.wait_timeout));
                    return None;
                }
            }
        }
        if self.input_done && self.grace_end.is_none() {
            self.grace_end = Some(now + self.options.grace);
        }
        None
    }

    fn handle(&mut self, event: Event) {
        match event {
            Event::Input(line) => match script::parse(&line) {
                // Steps queue up while earlier ones sleep or wait; they run in order.
                Ok(Some(step)) => self.steps.push_back(step),
                Ok(None) => {}
                Err(e) => {
                    self.script_errors += 1;
                    self.error(&format!("input line skipped: {e}"));
                }
            },
            Event::InputEnd => self.input_done = true,
            Event::ConsoleOpen => self.open_outputs += 1,
            Event::Output(line) => self.output(line),
            Event::Console(line) => self.show(&format!("console: {line}")),
            Event::OutputEnd => self.open_outputs = self.open_outputs.saturating_sub(1),
            Event::Interrupt => {}
        }
    }

    /// A line of QEMU's output: the firmware's log, which reports LEDs and panics.
    fn output(&mut self, line: String) {
        if let Some(led) = script::led_in(&line) {
            self.leds.insert(led.name, led.state);
        }
        if self.panic.is_none() && script::is_panic(&line) {
            self.panic = Some((line.clone(), Instant::now() + PANIC_EXIT_WAIT));
        }
        self.show(&line);
    }

    /// Prints a line on standard output and ends a wait for it.
    fn show(&mut self, line: &str) {
        {
            let mut stdout = std::io::stdout().lock();
            // A closed stdout (a pager quit) must not end the session; QEMU keeps running.
            let _ = writeln!(stdout, "{line}");
            let _ = stdout.flush();
        }
        let matched = match &self.blocked {
            Some(Blocked::Wait(Pattern::Led(led), _)) => self.led_is(led),
            Some(Blocked::Wait(Pattern::Text(text), _)) => line.contains(text.as_str()),
            _ => false,
        };
        if matched && let Some(Blocked::Wait(pattern, _)) = self.blocked.take() {
            self.note(&format!("saw \"{pattern}\""));
        }
    }

    fn led_is(&self, led: &Led) -> bool {
        self.leds.get(&led.name) == Some(&led.state)
    }

    /// Prints what QEMU still writes after it ended, for at most [`DRAIN_WAIT`].
    fn drain(&mut self) {
        let until = Instant::now() + DRAIN_WAIT;
        while self.open_outputs > 0 {
            let left = until.saturating_duration_since(Instant::now());
            match self.events.recv_timeout(left) {
                Ok(
                    event @ (Event::Output(_)
                    | Event::Console(_)
                    | Event::ConsoleOpen
                    | Event::OutputEnd),
                ) => self.handle(event),
                Ok(_) => {}
                Err(_) => break,
            }
        }
    }

    fn elapsed(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// A message of x30-qemu's own, on standard error so that standard output is only what
    /// the firmware and QEMU printed.
    fn note(&self, message: &str) {
        eprintln!("x30-qemu: [{:8.3}] {message}", self.elapsed());
    }

    fn error(&self, message: &str) {
        eprintln!("x30-qemu: [{:8.3}] error: {message}", self.elapsed());
    }
}

/// Forwards each line of `stream` as an [`Event::Output`], then [`Event::OutputEnd`], from a
/// thread of its own.
fn spawn_reader(stream: impl Read + Send + 'static, events: Sender<Event>) {
    thread::spawn(move || forward_lines(stream, &events, Event::Output));
}

/// Sends each line of `stream` as `wrap(line)`, without its line end, then
/// [`Event::OutputEnd`]; a last line without a line end is sent at the end of the stream.
/// Bytes that are not UTF-8 are replaced rather than ending the stream: a garbled log line
/// must not hide the ones after it.
pub fn forward_lines(stream: impl Read, events: &Sender<Event>, wrap: fn(String) -> Event) {
    let mut reader = BufReader::new(stream);
    let mut line = Vec::new();
    loop {
        line.clear();
        match reader.read_until(b'\n', &mut line) {
            Ok(0) | Err(_) => break,
            Ok(_) => {
                let text = String::from_utf8_lossy(&line);
                let text = text.trim_end_matches(['\n', '\r']).to_owned();
                if events.send(wrap(text)).is_err() {
                    return;
                }
            }
        }
    }
    let _ = events.send(Event::OutputEnd);
}

/// Forwards each line of x30-qemu's standard input as an [`Event::Input`], then
/// [`Event::InputEnd`].
pub fn spawn_input_reader(events: Sender<Event>) {
    thread::spawn(move || {
        let mut stdin = std::io::stdin().lock();
        let mut line = Vec::new();
        loop {
            line.clear();
            match stdin.read_until(b'\n', &mut line) {
                Ok(0) | Err(_) => break,
                Ok(_) => {
                    let text = String::from_utf8_lossy(&line).into_owned();
                    if events.send(Event::Input(text)).is_err() {
                        return;
                    }
                }
            }
        }
        let _ = events.send(Event::InputEnd);
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::process::ExitStatusExt;

    fn report(outcome: Outcome, script_errors: usize) -> u8 {
        Report {
            outcome,
            script_errors,
        }
        .exit_code()
    }

    #[test]
    fn exit_codes() {
        assert_eq!(report(Outcome::Finished, 0), 0);
        assert_eq!(report(Outcome::Finished, 2), 1);
        assert_eq!(report(Outcome::Exited(ExitStatus::from_raw(0)), 0), 0);
        assert_eq!(report(Outcome::Exited(ExitStatus::from_raw(1 << 8)), 0), 1);
        assert_eq!(report(Outcome::Panicked("panic: x".into()), 0), 1);
        assert_eq!(
            report(Outcome::WaitTimedOut(Pattern::Text("x".into())), 0),
            1
        );
        assert_eq!(report(Outcome::TimedOut, 0), 124);
        assert_eq!(report(Outcome::Interrupted, 0), 130);
    }
}
