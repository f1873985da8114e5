//! End to end: the QEMU firmware (mps2-an386) booted by x30-qemu, connected over QEMU's user
//! network to an x30-sim running in this process, driven through the virtual panel's UART.
//!
//! The firmware is built once (`x30-qemu --build-only`, or taken from `X30_QEMU_FIRMWARE`)
//! and booted afresh for each test.
//! One QEMU runs at a time: the rate assertions need the CPU, and a 2-core machine runs the
//! whole file in well under two minutes that way. Without `qemu-system-arm` every test
//! prints "SKIPPED: qemu-system-arm missing" and returns; CI installs it (scripts/setup.sh).

mod common;

use std::io::Write;
use std::path::PathBuf;
use std::process::Command;
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::thread::sleep;
use std::time::{Duration, Instant};

use common::*;
use x30_panel::proto::codes::{ErrorStatus, MotionState, NavOutcome};
use x30_sim::{Config, Pose, Simulator};

/// Longest the firmware may take from QEMU's start to `led link on` (DHCP, then TCP).
const BOOT_LIMIT: Duration = Duration::from_secs(45);

/// Longest one x30-qemu run may last; x30-qemu enforces it too (`--timeout-s`).
const SESSION_LIMIT: Duration = Duration::from_secs(75);

/// Longest anything asked of the panel may take to show at the robot.
const REACTION: Duration = Duration::from_secs(10);

/// The firmware ELF, built on first use; the error if it does not build. `X30_QEMU_FIRMWARE`
/// names a ready ELF instead (one built elsewhere, such as another worktree).
fn firmware() -> &'static Result<PathBuf, String> {
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
fn have_qemu() -> bool {
    std::env::var_os("PATH").is_some_and(|path| {
        std::env::split_paths(&path).any(|dir| dir.join("qemu-system-arm").is_file())
    })
}

/// What every test holds while it runs: the turn to run QEMU, and the firmware.
struct Turn {
    _guard: MutexGuard<'static, ()>,
    elf: PathBuf,
}

/// Takes this test's turn; `None` (after saying so) when QEMU is missing. A firmware that
/// does not build fails the test.
fn turn() -> Option<Turn> {
    static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());
    if !have_qemu() {
        // Straight to the file descriptor: the test harness captures `println!`, and a
        // skipped end-to-end test must show in the log, not pass unnoticed.
        let _ = writeln!(std::io::stderr(), "SKIPPED: qemu-system-arm missing");
        return None;
    }
    // A test that failed while holding the turn does not spoil the others'.
    let guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    match firmware() {
        Ok(elf) => Some(Turn {
            _guard: guard,
            elf: elf.clone(),
        }),
        Err(e) => panic!("{e}"),
    }
}

/// A simulator in real time on a free loopback port.
fn simulator() -> Simulator {
    Simulator::start(Config {
        listen: "127.0.0.1:0".parse().expect("address"),
        time_scale: 1.0,
        ..Default::default()
    })
    .expect("simulator starts")
}

/// The virtual panel booted against `sim`, once its link LED is on.
fn boot(turn: &Turn, sim: &Simulator) -> Running {
    let robot = sim.addr().to_string();
    let elf = turn.elf.to_string_lossy().into_owned();
    let limit = SESSION_LIMIT.as_secs().to_string();
    let panel = Running::start(&[
        "--robot",
        &robot,
        "--firmware",
        &elf,
        "--timeout-s",
        &limit,
        "--grace-ms",
        "300",
    ]);
    panel.expect_stdout(0, BOOT_LIMIT, "`led link on`", |l| l == "led link on");
    panel
}

/// Ends the session and checks that the firmware never panicked.
fn finish(panel: Running) {
    let run = panel.finish(SESSION_LIMIT);
    run.expect_code(0);
    assert!(!run.stdout.contains("panic:"), "{run}");
}

/// The Type 2 requests logged since `since` (simulator seconds): (time, Command).
fn motions(sim: &Simulator, since: f64) -> Vec<(f64, i32)> {
    sim.requests()
        .iter()
        .filter(|e| e.t >= since && e.message_type == Some(2))
        .filter_map(|e| Some((e.t, e.command?)))
        .collect()
}

/// Polls `cond` until it holds or `limit` passes; whether it held.
fn eventually(limit: Duration, mut cond: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + limit;
    loop {
        if cond() {
            return true;
        }
        if Instant::now() >= deadline {
            return false;
        }
        sleep(Duration::from_millis(50));
    }
}

/// The log of `sim`, one request a line, for failure messages.
fn log_text(sim: &Simulator) -> String {
    sim.requests()
        .iter()
        .map(|e| {
            format!(
                "{:8.3} conn {} type {:?} command {:?}",
                e.t, e.conn, e.message_type, e.command
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn holding_forward_repeats_command_1_at_3_to_5_hz_then_sends_zero_velocity() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);

    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+forward");
    sleep(Duration::from_secs(2));
    let released = sim.elapsed().as_secs_f64();
    panel.send("-forward");
    assert!(
        eventually(REACTION, || motions(&sim, released)
            .iter()
            .any(|m| m.1 == 6)),
        "no Command 6 after the release\n{}",
        log_text(&sim)
    );
    sleep(Duration::from_millis(600));
    finish(panel);

    let motions = motions(&sim, pressed);
    let forward: Vec<f64> = motions.iter().filter(|m| m.1 == 1).map(|m| m.0).collect();
    let log = log_text(&sim);
    assert!(
        forward.len() >= 6,
        "{} forwards in 2 s\n{log}",
        forward.len()
    );
    let (first, last) = (forward[0], forward[forward.len() - 1]);
    let rate = (forward.len() - 1) as f64 / (last - first);
    assert!(
        (3.0..=5.0).contains(&rate),
        "forward at {rate:.2} Hz\n{log}"
    );
    assert!(
        first - pressed < 0.5,
        "first forward {:.3} s after the press\n{log}",
        first - pressed
    );
    // Nothing between the repeats but forwards, then zero velocity, then no more forwards.
    let zero = motions
        .iter()
        .position(|m| m.1 == 6)
        .unwrap_or_else(|| panic!("no Command 6\n{log}"));
    assert!(motions[..zero].iter().all(|m| m.1 == 1), "{log}");
    assert!(motions[zero].0 >= last, "{log}");
    assert!(
        motions[zero].0 - released < 0.5,
        "zero velocity late\n{log}"
    );
    assert!(
        motions[zero..].iter().all(|m| m.1 != 1),
        "forward after the release\n{log}"
    );
}

#[test]
fn estop_during_motion_sends_command_13_and_stops_the_repeats() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);

    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+forward");
    sleep(Duration::from_millis(1200));
    panel.send("+estop");
    assert!(
        eventually(REACTION, || motions(&sim, pressed)
            .iter()
            .any(|m| m.1 == 13)),
        "no Command 13\n{}",
        log_text(&sim)
    );
    // Forward stays held through the e-stop and after its release: still no motion.
    sleep(Duration::from_millis(1500));
    panel.send("-estop");
    sleep(Duration::from_millis(1000));
    panel.send("-forward");
    sleep(Duration::from_millis(300));
    finish(panel);

    let motions = motions(&sim, pressed);
    let log = log_text(&sim);
    let estop = motions.iter().position(|m| m.1 == 13).expect("Command 13");
    assert!(
        motions[..estop].iter().filter(|m| m.1 == 1).count() >= 3,
        "the robot was not moving\n{log}"
    );
    assert!(
        motions[estop..].iter().all(|m| m.1 != 1),
        "Command 1 after the e-stop\n{log}"
    );
    assert_eq!(sim.snapshot().motion_state, MotionState::SoftEmergencyStop);
}

#[test]
fn dock_then_cancel_sends_1003_then_1004_and_the_task_ends_cancelled() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    // 20 m from the dock (the default charging point is the origin): a 40 s walk.
    sim.robot(|r| {
        r.set_pose(Pose {
            x: 20.0,
            ..Default::default()
        })
    });
    let mut panel = boot(&turn, &sim);

    panel.send("+dock");
    panel.send("-dock");
    assert!(
        eventually(REACTION, || sim.snapshot().task.is_some()),
        "no navigation task started\n{}",
        log_text(&sim)
    );
    sleep(Duration::from_millis(1000));
    panel.send("+cancel");
    panel.send("-cancel");
    assert!(
        eventually(REACTION, || sim.snapshot().last_task.is_some()),
        "the task did not end\n{}",
        log_text(&sim)
    );
    sleep(Duration::from_millis(500));
    finish(panel);

    let log = sim.requests();
    let text = log_text(&sim);
    let time_of = |ty: i32| {
        log.iter()
            .find(|e| e.message_type == Some(ty))
            .map(|e| e.t)
            .unwrap_or_else(|| panic!("no {ty}\n{text}"))
    };
    assert!(time_of(1003) < time_of(1004), "{text}");
    let last = sim.snapshot().last_task.expect("a task ended");
    assert_eq!(last.status, ErrorStatus::TaskCancelled, "{text}");
    assert_eq!(last.status.raw(), 8962);
    assert_eq!(last.outcome, NavOutcome::Cancelled);
}

#[test]
fn after_the_robot_drops_the_connection_the_firmware_reconnects_and_polls_again() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let panel = boot(&turn, &sim);

    assert!(
        eventually(REACTION, || sim
            .requests()
            .iter()
            .any(|e| e.message_type == Some(1002))),
        "no polling before the drop\n{}",
        log_text(&sim)
    );
    let old = sim.requests().iter().map(|e| e.conn).max().unwrap_or(0);
    let dropped = sim.elapsed().as_secs_f64();
    sim.drop_connections();
    let polled_again = || {
        sim.requests()
            .iter()
            .any(|e| e.t > dropped && e.conn > old && e.message_type == Some(1002))
    };
    assert!(
        eventually(REACTION, polled_again),
        "no 1002 on a new connection after the drop\n{}",
        log_text(&sim)
    );
    // And it keeps polling there.
    sleep(Duration::from_millis(1500));
    let later = sim
        .requests()
        .iter()
        .filter(|e| e.t > dropped && e.conn > old && e.message_type == Some(1002))
        .count();
    assert!(
        later >= 2,
        "{later} polls after the reconnect\n{}",
        log_text(&sim)
    );
    finish(panel);
}

#[test]
fn leds_follow_the_robots_battery_and_faults() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let panel = boot(&turn, &sim);
    assert!(
        sim.requests().iter().any(|e| e.message_type == Some(1002)),
        "link on before any status was read\n{}",
        log_text(&sim)
    );

    let from = panel.stdout.len();
    sim.robot(|r| r.set_battery(15.0));
    let (at, _) = panel.expect_stdout(from, REACTION, "`led fault on` at 15 %", |l| {
        l == "led fault on"
    });
    sim.robot(|r| r.set_battery(90.0));
    let (at, _) = panel.expect_stdout(at + 1, REACTION, "`led fault off` at 90 %", |l| {
        l == "led fault off"
    });
    // A motor over 80 °C is a fault of its own (MotorState 1).
    sim.robot(|r| r.set_motor_temperatures(95.0));
    let (at, _) = panel.expect_stdout(
        at + 1,
        REACTION,
        "`led fault on` when a motor overheats",
        |l| l == "led fault on",
    );
    sim.robot(|r| r.set_motor_temperatures(40.0));
    panel.expect_stdout(
        at + 1,
        REACTION,
        "`led fault off` when the motors cool",
        |l| l == "led fault off",
    );
    finish(panel);
}
