//! `x30-qemu`: boots the x30-panel firmware for QEMU's mps2-an386 board against a robot on
//! this machine (normally `x30-sim`), and drives its virtual panel from standard input.
//!
//! Input lines are button presses and releases (`+forward`, `-forward`), pauses
//! (`sleep MS`), waits for the firmware (`wait led link on`), lines typed on the serial
//! console (`console show`) and comments, so a scripted session is a plain text file; see
//! [`script`]. Standard output carries exactly what the firmware and QEMU print
//! (`led link on`, …) and the console's lines (`console: LINE`); x30-qemu's own messages go
//! to standard error.
//!
//! The firmware's settings flash is a file (`--settings`, else a fresh one per run), and its
//! serial console (UART1) reaches x30-qemu over a Unix socket; both live in a private
//! temporary folder that x30-qemu removes at exit.
//!
//! Exit status: 0 after a clean run, 1 if the firmware panicked, QEMU failed, a `wait` timed
//! out or an input line was invalid, 2 for a usage or set-up problem (no QEMU, a robot
//! off loopback, a failed build), 124 when `--timeout-s` passed, 130 after Ctrl-C.

#![deny(unsafe_code)]

mod console;
mod firmware;
mod qemu;
mod script;
mod session;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::mpsc;
use std::time::Duration;

use clap::Parser;

use console::Console;
use session::{Event, Options, Outcome, Session};

/// Exit status for usage and set-up problems.
const SETUP_FAILURE: u8 = 2;

/// Boots the x30-panel QEMU firmware (mps2-an386) against a robot on loopback and drives
/// its virtual panel from standard input.
///
/// Input lines: `+NAME` presses and `-NAME` releases a button (forward backward turn-left
/// turn-right strafe-left strafe-right stop estop stop-stepping lie-down gait light dock
/// cancel); `sleep MS` pauses; `wait TEXT` pauses until the firmware prints a line
/// containing TEXT (`wait led link on` also returns at once if the link LED is already on);
/// `send TEXT` sends TEXT to the UART as it is; `console TEXT` types TEXT and Enter on the
/// firmware's serial console; `# ...` and blank lines are ignored. At the end of input the
/// firmware runs on for --grace-ms, then QEMU is stopped.
///
/// Standard output is what the firmware prints (`led NAME on|off|blink|blink-fast`, commands sent,
/// connection state, `panic: ...`) and each line of its serial console as `console: LINE`
/// (`wait console: saved` waits for one); x30-qemu's own messages go to standard error.
///
/// Exit status: 0 clean run; 1 firmware panic, QEMU failure, `wait` timed out or invalid
/// input line; 2 usage or set-up problem; 124 --timeout-s passed; 130 Ctrl-C.
#[derive(Debug, Parser)]
#[command(name = "x30-qemu", version, about, verbatim_doc_comment)]
struct Cli {
    /// The robot to connect to: 127.0.0.1:PORT or localhost:PORT (the guest dials
    /// 10.0.2.2:PORT, which QEMU's user network maps to the host's 127.0.0.1:PORT).
    #[arg(
        long,
        value_name = "127.0.0.1:PORT",
        required_unless_present = "build_only"
    )]
    robot: Option<String>,
    /// Boot this firmware ELF instead of building the QEMU board's firmware (built with the
    /// features X30_FIRMWARE_FEATURES names too, comma-separated, such as `compact`).
    #[arg(long, value_name = "ELF")]
    firmware: Option<PathBuf>,
    /// Only build the firmware and print the ELF's path.
    #[arg(long, conflicts_with_all = ["robot", "firmware", "settings", "http"])]
    build_only: bool,
    /// The file behind the firmware's settings flash (64 KiB; created if it does not exist,
    /// and an empty file is a blank flash), so that settings saved on the console survive
    /// to the next run. Default: a fresh file, removed at exit. The path may not contain
    /// whitespace.
    #[arg(long, value_name = "FILE")]
    settings: Option<PathBuf>,
    /// Forward this loopback port of the host to the firmware's web page (port 80 in the
    /// guest), so that a browser here opens it at http://127.0.0.1:PORT/.
    #[arg(long, value_name = "127.0.0.1:PORT")]
    http: Option<String>,
    /// The QEMU program.
    #[arg(long, value_name = "PROGRAM", default_value = "qemu-system-arm")]
    qemu: PathBuf,
    /// An extra argument for QEMU, after the others (repeat for several).
    #[arg(long = "qemu-arg", value_name = "ARG", allow_hyphen_values = true)]
    qemu_args: Vec<String>,
    /// How long the firmware keeps running after the end of input, in milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 1000)]
    grace_ms: u64,
    /// Stop QEMU and fail (exit 124) after this many seconds of session (the build does
    /// not count).
    #[arg(long, value_name = "S")]
    timeout_s: Option<u64>,
    /// Longest a `wait` line waits, in seconds.
    #[arg(long, value_name = "S", default_value_t = 60)]
    wait_timeout_s: u64,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(code) => ExitCode::from(code),
        Err(message) => {
            eprintln!("x30-qemu: error: {message}");
            ExitCode::from(SETUP_FAILURE)
        }
    }
}

fn run(cli: &Cli) -> Result<u8, String> {
    if cli.build_only {
        let elf = firmware::build(&firmware::repository_root())?;
        println!("{}", elf.display());
        return Ok(0);
    }
    let robot = cli.robot.as_deref().unwrap_or_default();
    let guest_robot = qemu::guest_robot(robot)?;
    let http = cli.http.as_deref().map(qemu::http_port).transpose()?;
    // Checked before building, so a missing QEMU costs no build time.
    let program = qemu::find(&cli.qemu).ok_or_else(|| {
        format!(
            "{} not found: install QEMU's Arm system emulator (Debian: apt-get install \
             qemu-system-arm; scripts/setup.sh does it) or name it with --qemu",
            cli.qemu.display()
        )
    })?;
    let elf = match &cli.firmware {
        Some(elf) if elf.is_file() => {
            firmware::check(elf)?;
            elf.clone()
        }
        Some(elf) => return Err(format!("--firmware {}: no such file", elf.display())),
        None => {
            eprintln!(
                "x30-qemu: building the firmware (features {})",
                firmware::features()
            );
            firmware::build(&firmware::repository_root())?
        }
    };

    let (sender, events) = mpsc::channel();
    // Installed after the build, so a Ctrl-C during the build stops cargo and x30-qemu
    // together in the ordinary way.
    let on_interrupt = sender.clone();
    ctrlc::set_handler(move || {
        let _ = on_interrupt.send(Event::Interrupt);
    })
    .map_err(|e| format!("cannot install the Ctrl-C handler: {e}"))?;

    // Removed when `folder` is dropped at the end of this function (only a killed x30-qemu
    // leaves it behind).
    let folder = tempfile::Builder::new()
        .prefix("x30-qemu-")
        .tempdir()
        .map_err(|e| format!("cannot make a temporary folder: {e}"))?;
    let settings = qemu::settings_file(cli.settings.as_deref(), folder.path())?;
    let console = Console::listen(&folder.path().join("console.sock"))?;
    let args = qemu::args(
        &elf,
        guest_robot,
        &settings,
        console.path(),
        http,
        &cli.qemu_args,
    );
    eprintln!(
        "x30-qemu: booting {} with {}: robot {robot} is {guest_robot} for the guest, \
         settings in {}",
        elf.display(),
        program.display(),
        settings.display()
    );
    if let Some(port) = http {
        eprintln!("x30-qemu: the board's web page is at http://127.0.0.1:{port}/");
    }
    let child = qemu::spawn(&program, &args)
        .map_err(|e| format!("cannot start {}: {e}", program.display()))?;
    // The input is read only once QEMU runs: lines typed earlier wait in the pipe.
    session::spawn_input_reader(sender.clone());
    let typed = console.start(sender.clone());
    let options = Options {
        grace: Duration::from_millis(cli.grace_ms),
        timeout: cli.timeout_s.map(Duration::from_secs),
        wait_timeout: Duration::from_secs(cli.wait_timeout_s),
    };
    let report = Session::new(child, &sender, events, typed, options).run();
    let outcome = match &report.outcome {
        Outcome::Finished => "input done; QEMU stopped".to_owned(),
        Outcome::Exited(status) => format!("QEMU exited by itself ({status})"),
        Outcome::Panicked(line) => format!("the firmware panicked: {line}"),
        Outcome::WaitTimedOut(pattern) => format!(
            "gave up waiting for \"{pattern}\" after {} s",
            cli.wait_timeout_s
        ),
        Outcome::TimedOut => format!(
            "session time limit ({} s) passed; QEMU stopped",
            cli.timeout_s.unwrap_or_default()
        ),
        Outcome::Interrupted => "interrupted; QEMU stopped".to_owned(),
    };
    let code = report.exit_code();
    let errors = match report.script_errors {
        0 => String::new(),
        n => format!(", {n} invalid input line(s)"),
    };
    eprintln!("x30-qemu: {outcome}{errors}; exit status {code}");
    Ok(code)
}
