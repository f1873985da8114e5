//! Helpers for running the built `x30ctl` against an `x30-sim` over loopback TCP.

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use x30_sim::{Config, LogEntry, Simulator};

/// The binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_x30ctl");

/// Longest any single x30ctl run may take before the test fails (and the child is killed).
pub const RUN_LIMIT: Duration = Duration::from_secs(20);

/// What a finished x30ctl run left behind.
#[derive(Debug)]
pub struct Run {
    /// Exit code; `None` if killed by a signal.
    pub code: Option<i32>,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
}

impl Run {
    /// Asserts the exit code, showing both streams if it differs.
    #[track_caller]
    pub fn expect_code(&self, code: i32) -> &Self {
        assert_eq!(
            self.code,
            Some(code),
            "unexpected exit status\n--- stdout\n{}\n--- stderr\n{}",
            self.stdout,
            self.stderr
        );
        self
    }

    /// Asserts that stdout contains `needle`.
    #[track_caller]
    pub fn stdout_has(&self, needle: &str) -> &Self {
        assert!(
            self.stdout.contains(needle),
            "stdout lacks {needle:?}\n--- stdout\n{}\n--- stderr\n{}",
            self.stdout,
            self.stderr
        );
        self
    }

    /// Asserts that stderr contains `needle`.
    #[track_caller]
    pub fn stderr_has(&self, needle: &str) -> &Self {
        assert!(
            self.stderr.contains(needle),
            "stderr lacks {needle:?}\n--- stdout\n{}\n--- stderr\n{}",
            self.stdout,
            self.stderr
        );
        self
    }

    /// Stdout lines parsed as JSON.
    pub fn json_lines(&self) -> Vec<serde_json::Value> {
        self.stdout
            .lines()
            .map(|line| {
                serde_json::from_str(line)
                    .unwrap_or_else(|e| panic!("not JSON: {line:?}: {e}\n{}", self.stderr))
            })
            .collect()
    }
}

/// A simulator on an ephemeral loopback port.
pub fn sim(time_scale: f64) -> Simulator {
    Simulator::start(Config {
        listen: "127.0.0.1:0".parse().expect("address"),
        time_scale,
        ..Default::default()
    })
    .expect("simulator starts")
}

/// A running x30ctl whose output is being collected.
pub struct Running {
    child: Child,
    stdout: JoinHandle<String>,
    stderr: JoinHandle<String>,
}

impl Running {
    /// The child's process ID.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Sends SIGINT (what Ctrl-C does).
    pub fn interrupt(&self) {
        let status = Command::new("kill")
            .args(["-INT", &self.pid().to_string()])
            .status()
            .expect("kill runs");
        assert!(status.success(), "kill -INT failed");
    }

    /// Waits for the child to exit (killing it after `limit`) and collects its output.
    pub fn finish(mut self, limit: Duration) -> Run {
        let Some(status) = wait_exit(&mut self.child, limit) else {
            let stdout = self.stdout.join().unwrap_or_default();
            let stderr = self.stderr.join().unwrap_or_default();
            panic!(
                "x30ctl did not finish within {limit:?}\n--- stdout\n{stdout}\n--- stderr\n{stderr}"
            );
        };
        Run {
            code: status.code(),
            stdout: self.stdout.join().unwrap_or_default(),
            stderr: self.stderr.join().unwrap_or_default(),
        }
    }
}

/// Waits for a child to exit; `None` if it has not after `limit`, when it is killed.
fn wait_exit(child: &mut Child, limit: Duration) -> Option<ExitStatus> {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(status) = child.try_wait().expect("try_wait") {
            return Some(status);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        thread::sleep(Duration::from_millis(5));
    }
}

/// A running x30ctl fed its standard input line by line, whose stdout is read line by line
/// as it comes (for commands that answer each input line).
pub struct Interactive {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    /// Stdout lines received so far.
    seen: Vec<String>,
    stderr: JoinHandle<String>,
}

impl Interactive {
    /// Writes one line to the child's standard input.
    pub fn send(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().expect("stdin still open");
        writeln!(stdin, "{line}").expect("the child reads its input");
        stdin.flush().expect("flush");
    }

    /// Waits for a stdout line containing `needle` (at most `limit`) and returns it.
    #[track_caller]
    pub fn expect_line(&mut self, needle: &str, limit: Duration) -> String {
        let deadline = Instant::now() + limit;
        let mut searched = 0;
        loop {
            if let Some(line) = self.seen[searched..].iter().find(|l| l.contains(needle)) {
                return line.clone();
            }
            searched = self.seen.len();
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left.max(Duration::from_millis(1))) {
                Ok(line) => self.seen.push(line),
                Err(_) => panic!(
                    "no stdout line with {needle:?} within {limit:?}; stdout so far:\n{}",
                    self.seen.join("\n")
                ),
            }
        }
    }

    /// Closes standard input, waits for the child to exit (killing it after `limit`) and
    /// collects its output.
    pub fn finish(mut self, limit: Duration) -> Run {
        drop(self.stdin.take());
        let Some(status) = wait_exit(&mut self.child, limit) else {
            panic!(
                "x30ctl did not finish within {limit:?}; stdout so far:\n{}",
                self.seen.join("\n")
            );
        };
        // The reader thread ends with the child's stdout.
        while let Ok(line) = self.lines.recv_timeout(limit) {
            self.seen.push(line);
        }
        Run {
            code: status.code(),
            stdout: self.seen.iter().map(|l| format!("{l}\n")).collect(),
            stderr: self.stderr.join().unwrap_or_default(),
        }
    }
}

/// Starts x30ctl against the simulator with its standard input and stdout line by line.
pub fn spawn_interactive(sim: &Simulator, args: &[&str]) -> Interactive {
    let addr = sim.addr().to_string();
    let mut child = Command::new(BIN)
        .args(["--robot", addr.as_str()])
        .args(args)
        .env_remove("X30_ROBOT")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("x30ctl starts");
    let stdout = child.stdout.take().expect("stdout");
    let (tx, lines) = mpsc::channel();
    thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    Interactive {
        stdin: child.stdin.take(),
        stderr: collect(child.stderr.take().expect("stderr")),
        child,
        lines,
        seen: Vec::new(),
    }
}

/// A path for a file in the temporary directory that no other test uses; the test removes
/// it (a [`TempFile`] does so when dropped).
pub struct TempFile(pub PathBuf);

impl TempFile {
    /// A fresh path ending in `name`; nothing is created.
    pub fn new(name: &str) -> Self {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        Self(std::env::temp_dir().join(format!("x30ctl-{}-{nanos}-{name}", std::process::id())))
    }

    /// A fresh file holding `text`.
    pub fn with(name: &str, text: &str) -> Self {
        let file = Self::new(name);
        std::fs::write(&file.0, text).expect("write a temporary file");
        file
    }

    /// The path as text, for the command line.
    pub fn arg(&self) -> String {
        self.0.display().to_string()
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn collect(mut pipe: impl Read + Send + 'static) -> JoinHandle<String> {
    // Read on a thread, so a chatty child never blocks on a full pipe.
    thread::spawn(move || {
        let mut bytes = Vec::new();
        let _ = pipe.read_to_end(&mut bytes);
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

/// Starts x30ctl with `args` (no `--robot`), standard input from `stdin`.
pub fn spawn_raw(args: &[&str], stdin: Option<Vec<u8>>) -> Running {
    let mut command = Command::new(BIN);
    command
        .args(args)
        .env_remove("X30_ROBOT")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .stdin(if stdin.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        });
    let mut child = command.spawn().expect("x30ctl starts");
    if let (Some(input), Some(mut pipe)) = (stdin, child.stdin.take()) {
        thread::spawn(move || {
            use std::io::Write;
            let _ = pipe.write_all(&input);
        });
    }
    let stdout = collect(child.stdout.take().expect("stdout"));
    let stderr = collect(child.stderr.take().expect("stderr"));
    Running {
        child,
        stdout,
        stderr,
    }
}

/// Starts x30ctl against the simulator.
pub fn spawn(sim: &Simulator, args: &[&str]) -> Running {
    let addr = sim.addr().to_string();
    let mut all = vec!["--robot", addr.as_str()];
    all.extend_from_slice(args);
    spawn_raw(&all, None)
}

/// Runs x30ctl against the simulator to completion.
pub fn x30ctl(sim: &Simulator, args: &[&str]) -> Run {
    spawn(sim, args).finish(RUN_LIMIT)
}

/// Runs x30ctl with exactly `args` to completion.
pub fn x30ctl_raw(args: &[&str]) -> Run {
    spawn_raw(args, None).finish(RUN_LIMIT)
}

/// Requests of one Type (and Command, if given) in the simulator's log.
pub fn requests_of(sim: &Simulator, message_type: i32, command: Option<i32>) -> Vec<LogEntry> {
    sim.requests()
        .into_iter()
        .filter(|e| e.message_type == Some(message_type))
        .filter(|e| command.is_none_or(|c| e.command == Some(c)))
        .collect()
}

/// When (seconds on the simulator's clock) it received each Type 2 request with `command`.
pub fn motion_times(sim: &Simulator, command: i32) -> Vec<f64> {
    requests_of(sim, 2, Some(command))
        .iter()
        .map(|e| e.t)
        .collect()
}

/// Polls `condition` every 5 ms until it holds; panics after `limit`.
#[track_caller]
pub fn wait_for(what: &str, limit: Duration, mut condition: impl FnMut() -> bool) {
    let deadline = Instant::now() + limit;
    while !condition() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        thread::sleep(Duration::from_millis(5));
    }
}

/// A loopback port nothing listens on: bound, then closed.
pub fn closed_port() -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = listener.local_addr().expect("addr").port();
    drop(listener);
    port
}
