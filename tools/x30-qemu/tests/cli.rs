//! x30-qemu's own behaviour, with a shell script standing in for QEMU (tests/fake-qemu.sh):
//! the input language, the output, how each kind of ending maps to an exit status, and
//! that QEMU never outlives x30-qemu.

mod common;

use std::path::Path;
use std::time::Duration;

use common::*;
use nix::sys::signal::{self, Signal};
use nix::unistd::Pid;

/// The stand-in for QEMU.
const FAKE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fake-qemu.sh");

/// An ELF header with `entry` as its entry point, the start of an Arm firmware image: what
/// x30-qemu checks of `--firmware` (the fake QEMU reads nothing of it).
fn elf_header(entry: u32) -> Vec<u8> {
    let mut bytes = vec![0u8; 52];
    bytes[..6].copy_from_slice(b"\x7fELF\x01\x01");
    bytes[18..20].copy_from_slice(&40u16.to_le_bytes());
    bytes[24..28].copy_from_slice(&entry.to_le_bytes());
    bytes
}

/// A stand-in firmware for the QEMU board, made once for every test of this file.
fn firmware() -> &'static str {
    static FILE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    FILE.get_or_init(|| {
        let dir = folder().keep();
        let file = dir.join("x30-panel");
        std::fs::write(&file, elf_header(0x0000_0401)).expect("write the stand-in firmware");
        file.to_str().expect("a UTF-8 path").to_owned()
    })
}

/// Longest any one run may take before the test fails.
const LIMIT: Duration = Duration::from_secs(20);

/// x30-qemu on the fake QEMU with these extra arguments.
fn start(extra: &[&str]) -> Running {
    let mut args = vec![
        "--robot",
        "127.0.0.1:30123",
        "--qemu",
        FAKE,
        "--firmware",
        firmware(),
    ];
    args.extend_from_slice(extra);
    Running::start(&args)
}

/// x30-qemu on the fake QEMU, given `script` as its whole input.
fn run(script: &str, extra: &[&str]) -> Finished {
    let mut running = start(extra);
    for line in script.lines() {
        running.send(line);
    }
    running.finish(LIMIT)
}

/// The fake's process ID, from its first line.
fn fake_pid(stdout: &str) -> u32 {
    stdout
        .lines()
        .find_map(|l| l.strip_prefix("fake-qemu pid "))
        .and_then(|pid| pid.trim().parse().ok())
        .unwrap_or_else(|| panic!("no pid line in\n{stdout}"))
}

/// The times (ms) at which the fake received each UART line, in order.
fn uart(stdout: &str) -> Vec<(u64, String)> {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix("uart "))
        .map(|l| {
            let (ms, line) = l.split_once(' ').expect("uart MS LINE");
            (ms.parse().expect("milliseconds"), line.to_owned())
        })
        .collect()
}

/// The arguments the fake was started with, from its second line.
fn fake_args(stdout: &str) -> &str {
    stdout
        .lines()
        .find_map(|l| l.strip_prefix("fake-qemu args "))
        .unwrap_or_else(|| panic!("no args line in\n{stdout}"))
}

/// A fresh folder for one test's files.
fn folder() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("x30-qemu-cli-")
        .tempdir()
        .expect("temporary folder")
}

#[test]
fn boots_qemu_with_the_board_the_robot_the_console_the_settings_and_the_firmware() {
    let dir = folder();
    let settings = dir.path().join("saved.bin");
    let settings_arg = settings.to_str().expect("UTF-8 path");
    let run = run(
        "wait led link on",
        &["--grace-ms", "0", "--settings", settings_arg],
    );
    run.expect_code(0);
    let args = fake_args(&run.stdout);
    let (before, after) = args
        .split_once(" -chardev socket,id=console,path=")
        .unwrap_or_else(|| panic!("no console chardev\n{run}"));
    assert_eq!(before, "-M mps2-an386 -nographic -monitor none", "{run}");
    let (socket, rest) = after.split_once(' ').expect("more arguments");
    assert!(socket.ends_with("/console.sock"), "{run}");
    assert_eq!(
        rest,
        format!(
            "-serial stdio -serial chardev:console -semihosting-config \
             enable=on,target=native,arg=x30-panel,arg=10.0.2.2:30123,arg=settings={settings_arg} \
             -nic user,model=lan9118 -kernel {}",
            firmware()
        ),
        "{run}"
    );
    // A named settings file is created, empty (a blank flash), and outlives the run.
    assert_eq!(std::fs::metadata(&settings).map(|m| m.len()).ok(), Some(0));
    // The run's private folder, with the console's socket, does not.
    let socket = Path::new(socket);
    assert!(!socket.exists(), "{run}");
    assert!(!socket.parent().expect("folder").exists(), "{run}");
    assert!(process_gone(fake_pid(&run.stdout)), "QEMU left running");
}

#[test]
fn without_settings_each_run_gets_a_fresh_file_removed_at_exit() {
    let first = run("wait led link on", &["--grace-ms", "0"]);
    let second = run("wait led link on", &["--grace-ms", "0"]);
    let settings = |run: &Finished| {
        let args = fake_args(&run.stdout);
        let (_, after) = args
            .split_once(",arg=settings=")
            .unwrap_or_else(|| panic!("no settings argument\n{run}"));
        after.split(' ').next().expect("a path").to_owned()
    };
    let (a, b) = (
        settings(first.expect_code(0)),
        settings(second.expect_code(0)),
    );
    assert_ne!(a, b);
    for path in [a, b] {
        let path = Path::new(&path);
        assert!(
            path.is_absolute() && path.ends_with("settings.bin"),
            "{path:?}"
        );
        assert!(!path.exists(), "{path:?} left behind");
        assert!(!path.parent().expect("folder").exists(), "{path:?}");
    }
}

#[test]
fn a_settings_path_the_firmware_cannot_take_is_refused() {
    let dir = folder();
    let spaced = dir.path().join("my settings.bin");
    let run = start(&["--settings", spaced.to_str().expect("UTF-8")]).finish(LIMIT);
    run.expect_code(2).stderr_has("contains whitespace");
    assert!(!spaced.exists());
    assert!(run.stdout.is_empty(), "{run}");
    start(&["--settings", "/nonexistent/settings.bin"])
        .finish(LIMIT)
        .expect_code(2)
        .stderr_has("--settings /nonexistent/settings.bin: cannot open or create it");
}

#[test]
fn http_forwards_a_loopback_port_to_the_web_page_and_says_where_it_is() {
    let run = run(
        "wait led link on",
        &["--grace-ms", "0", "--http", "127.0.0.1:18080"],
    );
    run.expect_code(0)
        .stderr_has("web page is at http://127.0.0.1:18080/");
    assert!(
        fake_args(&run.stdout)
            .contains(" -nic user,model=lan9118,hostfwd=tcp:127.0.0.1:18080-:80 "),
        "{run}"
    );
}

#[test]
fn http_off_loopback_is_refused_before_qemu_starts() {
    for http in ["0.0.0.0:18080", "192.168.1.20:80"] {
        let run = start(&["--http", http]).finish(LIMIT);
        run.expect_code(2)
            .stderr_has(&format!("--http {http}: not 127.0.0.1"));
        assert!(run.stdout.is_empty(), "{run}");
    }
}

#[test]
fn console_lines_are_typed_in_order_with_the_script() {
    // The fake never connects the console: the line waits, and the run still ends cleanly.
    let run = run(
        "wait led link on\nconsole set robot 10.0.2.2:30001\n+stop\n-stop",
        &["--grace-ms", "300"],
    );
    run.expect_code(0)
        .stderr_has("console> set robot 10.0.2.2:30001");
    let lines: Vec<String> = uart(&run.stdout).into_iter().map(|(_, l)| l).collect();
    assert_eq!(lines, ["+stop", "-stop"], "{run}");
    let err = run_err("console\n");
    err.expect_code(1)
        .stderr_has("`console` needs the text to type")
        .stderr_has("1 invalid input line(s)");
}

/// x30-qemu on the fake QEMU with `script`, which has an invalid line.
fn run_err(script: &str) -> Finished {
    run(script, &["--grace-ms", "100"])
}

#[test]
fn script_lines_reach_the_uart_in_order_with_their_pauses() {
    let script = "\
# Comments and blank lines are x30-qemu's, not the panel's.

wait led link on
+forward
sleep 400
-forward
  +estop  
-estop
";
    let run = run(script, &["--grace-ms", "100"]);
    run.expect_code(0)
        .stderr_has("> +forward")
        .stderr_has("saw \"led link on\"");
    let uart = uart(&run.stdout);
    let lines: Vec<&str> = uart.iter().map(|(_, l)| l.as_str()).collect();
    assert_eq!(lines, ["+forward", "-forward", "+estop", "-estop"], "{run}");
    let held = uart[1].0 - uart[0].0;
    assert!((390..1000).contains(&held), "held {held} ms\n{run}");
    assert!(!run.stdout.contains("sleep"), "{run}");
}

#[test]
fn end_of_input_lets_the_firmware_run_for_the_grace_period_then_stops_qemu() {
    let run = run(
        "wait led link on\nsend stderr still running",
        &["--grace-ms", "800"],
    );
    run.expect_code(0)
        .stderr_has("input done; QEMU stopped")
        .stdout_has("still running");
    assert!(run.elapsed >= Duration::from_millis(1000), "{run}");
    assert!(run.elapsed < Duration::from_secs(5), "{run}");
    assert!(process_gone(fake_pid(&run.stdout)), "QEMU left running");
}

#[test]
fn both_of_qemus_output_streams_reach_standard_output() {
    // QEMU's own messages (a fatal CPU error, say) come on its standard error.
    let run = run("wait led link on\nsend stderr led fault blink", &[]);
    run.expect_code(0).stdout_has("\nled fault blink");
}

#[test]
fn wait_for_an_led_already_in_that_state_returns_at_once() {
    let run = run(
        "sleep 600\nwait led link on\n+gait\n-gait",
        &["--grace-ms", "300", "--wait-timeout-s", "1"],
    );
    run.expect_code(0).stderr_has("led link on already");
    assert_eq!(uart(&run.stdout).len(), 2, "{run}");
}

#[test]
fn wait_for_text_gives_up_after_its_timeout() {
    let run = run(
        "wait connected to the robot\n+forward",
        &["--wait-timeout-s", "1"],
    );
    run.expect_code(1)
        .stderr_has("gave up waiting for \"connected to the robot\" after 1 s");
    assert!(uart(&run.stdout).is_empty(), "{run}");
    assert!(run.elapsed < Duration::from_secs(5), "{run}");
    assert!(process_gone(fake_pid(&run.stdout)), "QEMU left running");
}

#[test]
fn invalid_lines_are_reported_skipped_and_fail_the_run() {
    let run = run(
        "wait led link on\n+jump\nsleep soon\n+stop",
        &["--grace-ms", "300"],
    );
    run.expect_code(1)
        .stderr_has("unknown button \"jump\"")
        .stderr_has("`sleep` needs a whole number of milliseconds")
        .stderr_has("2 invalid input line(s)");
    let uart = uart(&run.stdout);
    assert_eq!(uart.len(), 1, "{run}");
    assert_eq!(uart[0].1, "+stop");
}

#[test]
fn a_panic_fails_the_run() {
    let run = run("wait led link on\nsend boom\n+forward", &[]);
    run.expect_code(1)
        .stdout_has("panic: boom")
        .stderr_has("the firmware panicked: panic: boom");
}

#[test]
fn a_panic_fails_the_run_even_if_qemu_does_not_exit() {
    let run = run("wait led link on\nsend hang-panic\nsleep 10000", &[]);
    run.expect_code(1)
        .stderr_has("the firmware panicked: panic: stuck");
    // Stopped about two seconds after the panic, not after the sleep.
    assert!(run.elapsed < Duration::from_secs(6), "{run}");
    assert!(process_gone(fake_pid(&run.stdout)), "QEMU left running");
}

#[test]
fn qemu_exiting_by_itself_passes_its_verdict_on() {
    run("wait led link on\nsend exit 3\nsleep 5000", &[])
        .expect_code(1)
        .stderr_has("QEMU exited by itself (exit status: 3)");
    let run = run("wait led link on\nsend exit 0\nsleep 5000", &[]);
    run.expect_code(0);
    assert!(run.elapsed < Duration::from_secs(4), "{run}");
}

#[test]
fn the_time_limit_stops_qemu_with_status_124() {
    let run = run("sleep 10000", &["--timeout-s", "1"]);
    run.expect_code(124).stderr_has("time limit (1 s) passed");
    assert!(run.elapsed < Duration::from_secs(4), "{run}");
    assert!(process_gone(fake_pid(&run.stdout)), "QEMU left running");
}

#[test]
fn ctrl_c_stops_qemu_with_status_130() {
    let mut running = start(&[]);
    running.expect_stdout(0, LIMIT, "boot", |l| l == "led link on");
    running.send("+forward");
    running.expect_stdout(0, LIMIT, "forward", |l| l.ends_with(" +forward"));
    signal::kill(Pid::from_raw(running.pid() as i32), Signal::SIGINT).expect("signal");
    let run = running.wait(LIMIT);
    run.expect_code(130).stderr_has("interrupted; QEMU stopped");
    assert!(process_gone(fake_pid(&run.stdout)), "QEMU left running");
}

#[test]
fn qemu_dies_with_x30_qemu_even_when_it_is_killed() {
    let running = start(&[]);
    running.expect_stdout(0, LIMIT, "boot", |l| l == "led link on");
    let pid = fake_pid(&running.stdout.all().join("\n"));
    signal::kill(Pid::from_raw(running.pid() as i32), Signal::SIGKILL).expect("signal");
    let run = running.wait(LIMIT);
    // A killed x30-qemu cannot remove its folder; the test does, not to litter.
    if let Some(folder) = run_folder(&run.stdout) {
        let _ = std::fs::remove_dir_all(folder);
    }
    assert_eq!(run.code, None, "{run}");
    assert!(
        wait_gone(pid, Duration::from_secs(5)),
        "QEMU outlived x30-qemu"
    );
}

/// The run's private folder, where the console's socket is, from the fake's arguments.
fn run_folder(stdout: &str) -> Option<&Path> {
    let (_, after) = fake_args(stdout).split_once("socket,id=console,path=")?;
    Path::new(after.split(' ').next()?).parent()
}

#[test]
fn robots_off_loopback_are_refused() {
    let run = Running::start(&["--robot", "192.168.1.106:30000", "--qemu", FAKE]).finish(LIMIT);
    run.expect_code(2)
        .stderr_has("--robot 192.168.1.106:30000: not 127.0.0.1")
        .stderr_has("127.0.0.1:PORT");
    assert!(run.stdout.is_empty(), "{run}");
}

#[test]
fn missing_qemu_is_named() {
    Running::start(&[
        "--robot",
        "127.0.0.1:30000",
        "--qemu",
        "x30-no-such-qemu",
        "--firmware",
        firmware(),
    ])
    .finish(LIMIT)
    .expect_code(2)
    .stderr_has("x30-no-such-qemu not found")
    .stderr_has("apt-get install qemu-system-arm");
}

#[test]
fn missing_firmware_is_named() {
    Running::start(&[
        "--robot",
        "127.0.0.1:30000",
        "--qemu",
        FAKE,
        "--firmware",
        "/nonexistent/x30-panel",
    ])
    .finish(LIMIT)
    .expect_code(2)
    .stderr_has("--firmware /nonexistent/x30-panel: no such file");
}

#[test]
fn a_file_that_cannot_be_the_qemu_boards_firmware_is_named() {
    let dir = folder();
    let nucleo = dir.path().join("x30-panel");
    // The Nucleo's code starts at 0x0800_0000.
    std::fs::write(&nucleo, elf_header(0x0801_8001)).unwrap();
    let nucleo = nucleo.to_str().unwrap();
    for (file, problem) in [
        (FAKE, "not an ELF file"),
        (
            nucleo,
            "its entry point 0x08018001 is outside the QEMU board's code memory",
        ),
    ] {
        let run = Running::start(&[
            "--robot",
            "127.0.0.1:30000",
            "--qemu",
            FAKE,
            "--firmware",
            file,
        ])
        .finish(LIMIT);
        run.expect_code(2)
            .stderr_has(&format!("--firmware {file}: {problem}"))
            .stderr_has("cargo build-qemu");
        assert!(!run.stdout.contains("fake-qemu pid"), "QEMU started\n{run}");
    }
}

#[test]
fn usage_errors_exit_with_2() {
    Running::start(&[]).finish(LIMIT).expect_code(2);
    Running::start(&["--robot", "127.0.0.1:1", "--grace-ms", "soon"])
        .finish(LIMIT)
        .expect_code(2);
}
