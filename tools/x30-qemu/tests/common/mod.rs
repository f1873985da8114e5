//! Running the built `x30-qemu` as a child process: feeding its input line by line,
//! watching its output as it comes, and always reaping it.

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock};
use std::thread;
use std::time::{Duration, Instant};

use x30_sim::{Config, Pose, Simulator};

/// The binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_x30-qemu");

/// A line and when it arrived.
type Timed = (Instant, String);

/// Lines of one output stream, in arrival order, with the time each arrived.
#[derive(Debug, Clone, Default)]
pub struct Lines(Arc<(Mutex<Vec<Timed>>, Condvar)>);

impl Lines {
    fn lock(&self) -> MutexGuard<'_, Vec<Timed>> {
        // A test thread that panicked while holding the lock has failed already.
        self.0.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn collect(&self, stream: impl Read + Send + 'static) {
        let lines = self.clone();
        thread::spawn(move || {
            for line in BufReader::new(stream).lines() {
                let Ok(line) = line else { break };
                lines.lock().push((Instant::now(), line));
                lines.0.1.notify_all();
            }
        });
    }

    /// Every line so far.
    pub fn all(&self) -> Vec<String> {
        self.lock().iter().map(|(_, l)| l.clone()).collect()
    }

    /// Number of lines so far.
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// Waits until a line at index `from` or later satisfies `pred`; its index and arrival
    /// time, or `None` after `timeout`.
    pub fn wait_for(
        &self,
        from: usize,
        timeout: Duration,
        pred: impl Fn(&str) -> bool,
    ) -> Option<(usize, Instant)> {
        let deadline = Instant::now() + timeout;
        let mut lines = self.lock();
        loop {
            if let Some(i) = (from..lines.len()).find(|&i| pred(&lines[i].1)) {
                return Some((i, lines[i].0));
            }
            let left = deadline.checked_duration_since(Instant::now())?;
            lines = self
                .0
                .1
                .wait_timeout(lines, left)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }
}

/// A running x30-qemu.
#[derive(Debug)]
pub struct Running {
    child: Child,
    stdin: Option<ChildStdin>,
    /// Its standard output.
    pub stdout: Lines,
    /// Its standard error.
    pub stderr: Lines,
    /// When it was started.
    pub started: Instant,
}

/// A finished x30-qemu.
#[derive(Debug)]
pub struct Finished {
    /// Exit code; `None` if a signal ended it.
    pub code: Option<i32>,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
    /// From start to exit.
    pub elapsed: Duration,
}

impl Finished {
    /// Asserts the exit code, showing both streams if it differs.
    #[track_caller]
    pub fn expect_code(&self, code: i32) -> &Self {
        assert_eq!(self.code, Some(code), "unexpected exit status\n{self}");
        self
    }

    /// Asserts that standard output contains `needle`.
    #[track_caller]
    pub fn stdout_has(&self, needle: &str) -> &Self {
        assert!(
            self.stdout.contains(needle),
            "stdout lacks {needle:?}\n{self}"
        );
        self
    }

    /// Asserts that standard error contains `needle`.
    #[track_caller]
    pub fn stderr_has(&self, needle: &str) -> &Self {
        assert!(
            self.stderr.contains(needle),
            "stderr lacks {needle:?}\n{self}"
        );
        self
    }
}

impl std::fmt::Display for Finished {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "--- exit {:?} after {:?}\n--- stdout\n{}\n--- stderr\n{}",
            self.code, self.elapsed, self.stdout, self.stderr
        )
    }
}

impl Running {
    /// Starts x30-qemu with these arguments, its input a pipe kept open until
    /// [`Running::close_input`] or [`Running::finish`].
    pub fn start(args: &[&str]) -> Self {
        let mut child = Command::new(BIN)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("x30-qemu starts");
        let stdout = Lines::default();
        let stderr = Lines::default();
        stdout.collect(child.stdout.take().expect("piped"));
        stderr.collect(child.stderr.take().expect("piped"));
        Self {
            stdin: child.stdin.take(),
            child,
            stdout,
            stderr,
            started: Instant::now(),
        }
    }

    /// Its process ID.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Sends one input line.
    pub fn send(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().expect("input still open");
        // x30-qemu may have ended already; the test sees that in its output and status.
        let _ = writeln!(stdin, "{line}").and_then(|()| stdin.flush());
    }

    /// Ends its input.
    pub fn close_input(&mut self) {
        self.stdin = None;
    }

    /// Waits for a standard output line satisfying `pred`, failing the test with the
    /// output so far if none comes within `timeout`.
    #[track_caller]
    pub fn expect_stdout(
        &self,
        from: usize,
        timeout: Duration,
        what: &str,
        pred: impl Fn(&str) -> bool,
    ) -> (usize, Instant) {
        self.stdout
            .wait_for(from, timeout, pred)
            .unwrap_or_else(|| {
                panic!(
                    "no {what} within {timeout:?}\n--- stdout\n{}\n--- stderr\n{}",
                    self.stdout.all().join("\n"),
                    self.stderr.all().join("\n")
                )
            })
    }

    /// Closes its input and waits for it to exit, at most `limit` (then kills it and fails).
    #[track_caller]
    pub fn finish(mut self, limit: Duration) -> Finished {
        self.close_input();
        self.wait(limit)
    }

    /// Waits for it to exit without closing its input, at most `limit`.
    #[track_caller]
    pub fn wait(mut self, limit: Duration) -> Finished {
        let deadline = Instant::now() + limit;
        let status = loop {
            if let Some(status) = self.child.try_wait().expect("try_wait") {
                break status;
            }
            if Instant::now() >= deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                panic!(
                    "x30-qemu still running after {limit:?}; killed\n--- stdout\n{}\n--- stderr\n{}",
                    self.stdout.all().join("\n"),
                    self.stderr.all().join("\n")
                );
            }
            thread::sleep(Duration::from_millis(10));
        };
        let elapsed = self.started.elapsed();
        // The reader threads end at end of file, right after the exit.
        let settle = Instant::now() + Duration::from_secs(2);
        while Instant::now() < settle && self.streams_open() {
            thread::sleep(Duration::from_millis(10));
        }
        Finished {
            code: status.code(),
            stdout: self.stdout.all().join("\n"),
            stderr: self.stderr.all().join("\n"),
            elapsed,
        }
    }

    fn streams_open(&self) -> bool {
        // Each collector holds one extra reference while its thread runs.
        Arc::strong_count(&self.stdout.0) > 1 || Arc::strong_count(&self.stderr.0) > 1
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        // A failed test must not leave x30-qemu (and with it QEMU) running.
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// Whether process `pid` is gone (or a zombie nobody has reaped yet, as happens to orphans
/// in containers whose init does not reap).
pub fn process_gone(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        // The state follows the command name in parentheses, which may contain spaces.
        Ok(stat) => stat
            .rsplit_once(')')
            .is_some_and(|(_, rest)| rest.trim_start().starts_with('Z')),
    }
}

/// Waits up to `limit` for process `pid` to be gone.
pub fn wait_gone(pid: u32, limit: Duration) -> bool {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        if process_gone(pid) {
            return true;
        }
        thread::sleep(Duration::from_millis(10));
    }
    process_gone(pid)
}

// Booting the firmware against an in-process simulator, for the end-to-end tests and the
// latency report.

/// Longest the firmware may take from QEMU's start to `led link on` (DHCP, then TCP).
pub const BOOT_LIMIT: Duration = Duration::from_secs(45);

/// Longest one x30-qemu run may last; x30-qemu enforces it too (`--timeout-s`).
pub const SESSION_LIMIT: Duration = Duration::from_secs(75);

/// Longest anything asked of the panel may take to show at the robot.
pub const REACTION: Duration = Duration::from_secs(10);

/// The firmware ELF, built on first use; the error if it does not build. `X30_QEMU_FIRMWARE`
/// names a ready ELF instead (one built elsewhere, such as another worktree).
pub fn firmware() -> &'static Result<PathBuf, String> {
    static ELF: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    ELF.get_or_init(|| {
        if let Some(elf) = std::env::var_os("X30_QEMU_FIRMWARE") {
            return Ok(PathBuf::from(elf));
        }
        let started = Instant::now();
        let out = Command::new(BIN)
            .arg("--build-only")
            .output()
            .map_err(|e| format!("cannot run x30-qemu --build-only: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "x30-qemu --build-only failed ({})\n{}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let elf = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
        eprintln!(
            "firmware {} ready in {:?}",
            elf.display(),
            started.elapsed()
        );
        Ok(elf)
    })
}

/// Whether QEMU's Arm system emulator is on PATH.
pub fn have_qemu() -> bool {
    std::env::var_os("PATH").is_some_and(|path| {
        std::env::split_paths(&path).any(|dir| dir.join("qemu-system-arm").is_file())
    })
}

/// How many tests run QEMU at once. The firmware sleeps between events, so each QEMU takes
/// little of the host's CPU once booted; the bound keeps a many-core machine from booting
/// dozens together.
const AT_ONCE: usize = 4;

/// The QEMUs running now, and the condition a test waits on for a free place among them.
static RUNNING: (Mutex<usize>, Condvar) = (Mutex::new(0), Condvar::new());

/// What every test holds while it runs: its turn to run QEMU, and the firmware.
pub struct Turn {
    /// The firmware ELF to boot.
    pub elf: PathBuf,
}

impl Drop for Turn {
    fn drop(&mut self) {
        // A test that failed while holding its turn does not spoil the others'.
        let mut running = RUNNING.0.lock().unwrap_or_else(|e| e.into_inner());
        *running -= 1;
        RUNNING.1.notify_one();
    }
}

/// Takes this test's turn, once fewer than [`AT_ONCE`] tests run QEMU; `None` (after saying
/// so) when QEMU is missing. A firmware that does not build fails the test.
pub fn turn() -> Option<Turn> {
    if !have_qemu() {
        // Straight to the file descriptor: the test harness captures `println!`, and a
        // skipped end-to-end test must show in the log, not pass unnoticed.
        let _ = writeln!(std::io::stderr(), "SKIPPED: qemu-system-arm missing");
        return None;
    }
    let elf = match firmware() {
        Ok(elf) => elf.clone(),
        Err(e) => panic!("{e}"),
    };
    let (lock, freed) = &RUNNING;
    let running = lock.lock().unwrap_or_else(|e| e.into_inner());
    let mut running = freed
        .wait_while(running, |running| *running >= AT_ONCE)
        .unwrap_or_else(|e| e.into_inner());
    *running += 1;
    Some(Turn { elf })
}

/// A simulator in real time on a free loopback port.
pub fn simulator() -> Simulator {
    Simulator::start(Config {
        listen: "127.0.0.1:0".parse().expect("address"),
        time_scale: 1.0,
        ..Default::default()
    })
    .expect("simulator starts")
}

/// The virtual panel booted against `sim`, once its link LED is on.
pub fn boot(turn: &Turn, sim: &Simulator) -> Running {
    boot_for(turn, sim, SESSION_LIMIT)
}

/// [`boot`] for a session of up to `session`.
pub fn boot_for(turn: &Turn, sim: &Simulator, session: Duration) -> Running {
    boot_with(turn, sim, session, &[])
}

/// [`boot_for`] with more arguments for x30-qemu (such as `--settings FILE`); returns once
/// the link LED is on, whichever robot the panel connected to.
pub fn boot_with(turn: &Turn, sim: &Simulator, session: Duration, extra: &[&str]) -> Running {
    let robot = sim.addr().to_string();
    let elf = turn.elf.to_string_lossy().into_owned();
    let limit = session.as_secs().to_string();
    let mut args = vec![
        "--robot",
        &robot,
        "--firmware",
        &elf,
        "--timeout-s",
        &limit,
        "--grace-ms",
        "300",
    ];
    args.extend_from_slice(extra);
    let panel = Running::start(&args);
    panel.expect_stdout(0, BOOT_LIMIT, "`led link on`", |l| l == "led link on");
    panel
}

/// Ends the session and checks that the firmware never panicked.
pub fn finish(panel: Running) {
    let run = panel.finish(SESSION_LIMIT);
    run.expect_code(0);
    assert!(!run.stdout.contains("panic:"), "{run}");
}

/// Puts the simulated robot 15 m from the virtual panel's charging point, so that a
/// navigation task to it runs for half a minute.
pub fn far_from_dock(sim: &Simulator) {
    sim.robot(|r| {
        r.set_pose(Pose {
            x: 20.0,
            ..Default::default()
        })
    });
}
