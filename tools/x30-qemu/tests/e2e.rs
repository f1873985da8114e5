//! End to end: the QEMU firmware (mps2-an386) booted by x30-qemu, connected over QEMU's user
//! network to an x30-sim running in this process, driven through the virtual panel's UART
//! and its serial console.
//!
//! The firmware is built once (`x30-qemu --build-only`, or taken from `X30_QEMU_FIRMWARE`)
//! and booted afresh for each test.
//! Tests run side by side, up to four QEMUs at once: the firmware sleeps between events, so
//! a booted QEMU takes little of the host's CPU and leaves the rate assertions theirs.
//! Without `qemu-system-arm` every test prints "SKIPPED: qemu-system-arm missing" and
//! returns; CI installs it (scripts/setup.sh).

mod common;

use std::thread::sleep;
use std::time::{Duration, Instant};

use common::*;
use x30_panel::proto::codes::{ErrorStatus, MotionState, NavOutcome, PointInfo};
use x30_panel::proto::message::Request;
use x30_sim::{LogEntry, Simulator};

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

/// Asserts that the robot reaches soft emergency stop within [`REACTION`].
fn reaches_soft_estop(sim: &Simulator) {
    assert!(
        eventually(REACTION, || sim.snapshot().motion_state
            == MotionState::SoftEmergencyStop),
        "the robot never reached soft e-stop\n{}",
        log_text(sim)
    );
}

/// Whether the e-stop's repeats since `since` (simulator seconds) end within 30 s: none for
/// 1.5 s. Unconfirmed, an e-stop goes on every 250 ms for as long as the robot misbehaves.
fn estop_repeats_end(sim: &Simulator, since: f64) -> bool {
    let quiet = || {
        let last = motions(sim, since)
            .into_iter()
            .filter(|(_, c)| *c == 13)
            .map(|(t, _)| t)
            .fold(since, f64::max);
        sim.elapsed().as_secs_f64() - last > 1.5
    };
    eventually(Duration::from_secs(30), quiet)
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

/// The CPU time process `pid` has used so far (user and system), from /proc.
fn cpu_time(pid: u32) -> Duration {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).expect("the process runs");
    // The fields after the command name, which is in parentheses and may hold spaces:
    // utime and stime are the 14th and 15th fields of the line, in clock ticks.
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .expect("a stat line")
        .1
        .split_whitespace()
        .collect();
    let ticks: u64 = fields[11..13]
        .iter()
        .map(|f| f.parse::<u64>().expect("ticks"))
        .sum();
    // SAFETY: sysconf reads a constant of the system.
    let per_second = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    Duration::from_secs_f64(ticks as f64 / per_second as f64)
}

/// The QEMU process x30-qemu (process `pid`) runs.
fn qemu_of(pid: u32) -> u32 {
    let children =
        std::fs::read_to_string(format!("/proc/{pid}/task/{pid}/children")).expect("x30-qemu runs");
    children
        .split_whitespace()
        .filter_map(|child| child.parse().ok())
        .find(|child| {
            std::fs::read_to_string(format!("/proc/{child}/comm"))
                .is_ok_and(|comm| comm.trim() == "qemu-system-arm")
        })
        .expect("x30-qemu runs QEMU")
}

#[test]
fn an_idle_panel_leaves_the_hosts_cpu_alone() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let panel = boot(&turn, &sim);
    // Connected, polling the robot, nothing pressed: the firmware sleeps between events,
    // and so does the emulated core. An executor that never sleeps keeps QEMU at a whole
    // core (about 100 %).
    let qemu = qemu_of(panel.pid());
    let (polled, before, start) = (sim.requests().len(), cpu_time(qemu), Instant::now());
    sleep(Duration::from_secs(3));
    let used = cpu_time(qemu) - before;
    let share = used.as_secs_f64() / start.elapsed().as_secs_f64();
    assert!(
        sim.requests().len() > polled,
        "the panel polled the robot meanwhile"
    );
    assert!(share < 0.5, "QEMU took {:.0} % of a core", share * 100.0);
    finish(panel);
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
    let mut panel = docking(&turn, &sim);
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

/// The virtual panel booted against `sim`, with a navigation task to the dock running.
fn docking(turn: &Turn, sim: &Simulator) -> Running {
    far_from_dock(sim);
    let mut panel = boot(turn, sim);
    panel.send("+dock");
    panel.send("-dock");
    assert!(
        eventually(REACTION, || sim.snapshot().task.is_some()),
        "no navigation task started\n{}",
        log_text(sim)
    );
    panel
}

/// Whether connection `conn` carried a status poll (1002) before `until` (simulator
/// seconds) in `log`.
fn polled_on(log: &[LogEntry], conn: u64, until: f64) -> bool {
    log.iter()
        .any(|e| e.t < until && e.conn == conn && e.message_type == Some(1002))
}

/// The simulator seconds of the first Type 2 request with `command` at or after `since`.
fn first_command(sim: &Simulator, since: f64, command: i32) -> Option<f64> {
    motions(sim, since)
        .into_iter()
        .find(|(_, c)| *c == command)
        .map(|(t, _)| t)
}

#[test]
fn estop_pressed_during_an_outage_is_sent_first_when_the_robot_is_back() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);
    sim.refuse_connections(Duration::from_secs(2));
    sleep(Duration::from_millis(300));
    panel.send("+estop");
    sleep(Duration::from_millis(1700));
    let back = sim.elapsed().as_secs_f64();
    assert!(
        eventually(REACTION, || first_command(&sim, back, 13).is_some()),
        "no Command 13 after the robot came back\n{}",
        log_text(&sim)
    );
    let first = sim
        .first_on_connection_of(|e| e.t >= back && e.message_type == Some(2))
        .expect("a command connection after the outage");
    assert_eq!(
        (first.message_type, first.command),
        (Some(2), Some(13)),
        "the e-stop is the first request on the new command connection\n{}",
        log_text(&sim)
    );
    assert!(eventually(REACTION, || sim.snapshot().motion_state
        == MotionState::SoftEmergencyStop));
    panel.send("-estop");
    finish(panel);
}

/// A robot whose client handlers all hang while the panel is idle reads neither the
/// command connection (never answered on) nor the poll connection: an e-stop pressed then
/// reaches it on a new connection once a poll has waited half a second with it, not after
/// the 1.75 s of silence that give the old connection up, and the robot stops.
#[test]
fn an_estop_pressed_as_the_robots_handlers_hang_goes_on_a_new_connection() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);
    sim.hang_open_connections();
    sleep(Duration::from_millis(300));
    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+estop");
    assert!(
        eventually(REACTION, || first_command(&sim, pressed, 13).is_some()),
        "the e-stop never reached the robot\n{}",
        log_text(&sim)
    );
    let after = first_command(&sim, pressed, 13).map(|t| t - pressed);
    assert!(
        after.is_some_and(|after| after < 1.4),
        "the e-stop reached the robot {after:?} s after the press\n{}",
        log_text(&sim)
    );
    reaches_soft_estop(&sim);
    panel.send("-estop");
    finish(panel);
}

#[test]
fn a_refused_estop_is_repeated_until_the_robot_confirms_it() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);
    sim.set_faults(x30_sim::Faults {
        refuse_estops: 2,
        ..Default::default()
    });
    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+estop");
    panel.send("-estop");
    reaches_soft_estop(&sim);
    sleep(Duration::from_millis(1000));
    let estops = motions(&sim, pressed)
        .into_iter()
        .filter(|(_, c)| *c == 13)
        .count();
    assert!(
        (3..=5).contains(&estops),
        "{estops} e-stops: two refused, one taken, none after the confirmation\n{}",
        log_text(&sim)
    );
    finish(panel);
}

/// A robot that takes 2.5 s to answer anything, past the 1.5 s the firmware waits at first:
/// the e-stop reaches it at once, and once the firmware has given a silent connection up, the
/// next waits longer, so a status is read and confirms the e-stop, whose repeats end.
#[test]
fn a_robot_that_answers_every_request_late_confirms_the_estop() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);
    sim.set_faults(x30_sim::Faults {
        delay: Duration::from_millis(2500),
        ..Default::default()
    });
    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+estop");
    panel.send("-estop");
    assert!(
        eventually(REACTION, || first_command(&sim, pressed, 13).is_some()),
        "the e-stop reaches the late robot\n{}",
        log_text(&sim)
    );
    let estop = first_command(&sim, pressed, 13).unwrap() - pressed;
    assert!(estop < 0.5, "e-stop after {estop:.3} s\n{}", log_text(&sim));
    reaches_soft_estop(&sim);
    assert!(
        estop_repeats_end(&sim, pressed),
        "the e-stop is still repeated: no status confirmed it\n{}",
        log_text(&sim)
    );
    finish(panel);
}

/// When the steps of [`forward_then_estop`] were taken (simulator seconds).
struct Drive {
    /// Forward pressed.
    pressed: f64,
    /// Forward released.
    released: f64,
    /// E-stop pressed.
    estop: f64,
}

/// Boots the panel against `sim`, whose faults are set, holds forward for 1.2 s, and 300 ms
/// after its release presses the e-stop; returns once the robot is in soft e-stop.
fn forward_then_estop(turn: &Turn, sim: &Simulator) -> (Running, Drive) {
    let mut panel = boot(turn, sim);
    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+forward");
    sleep(Duration::from_millis(1200));
    let released = sim.elapsed().as_secs_f64();
    panel.send("-forward");
    sleep(Duration::from_millis(300));
    let estop = sim.elapsed().as_secs_f64();
    panel.send("+estop");
    panel.send("-estop");
    reaches_soft_estop(sim);
    let drive = Drive {
        pressed,
        released,
        estop,
    };
    (panel, drive)
}

/// A robot whose writes go out only in part: a copy of each answer, cut short, comes before
/// it. The firmware still reads every answer (a decoder going by the declared length alone
/// would take each answer for the rest of the broken frame): its link comes up, held forward
/// moves the robot, and the status confirms the e-stop, whose repeats then end.
#[test]
fn answers_behind_frames_cut_short_are_read_and_the_estop_is_confirmed() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    sim.set_faults(x30_sim::Faults {
        cut_frames: true,
        ..Default::default()
    });
    let (panel, Drive { pressed, estop, .. }) = forward_then_estop(&turn, &sim);
    sleep(Duration::from_millis(1500));
    finish(panel);
    let log = log_text(&sim);
    let before = motions(&sim, pressed);
    assert!(
        before.iter().filter(|m| m.1 == 1).count() >= 3,
        "held forward did not move the robot\n{log}"
    );
    let estops = motions(&sim, estop).iter().filter(|m| m.1 == 13).count();
    // Unconfirmed, the e-stop would repeat every 250 ms: 7 or more in these 1.5 s.
    assert!(
        (1..=4).contains(&estops),
        "{estops} e-stops: the status should have confirmed the first\n{log}"
    );
}

/// A robot that streams garbage between its answers, as fast as the panel reads it, so that
/// the firmware spends its time skipping bytes and each answer comes out of the stream late
/// (behind what the host's socket buffers hold): the stops still go out at once, ahead of
/// that work, and the firmware still reads the answers (its link comes up, held forward
/// drives the robot, and a status confirms the e-stop, whose repeats then end).
#[test]
fn a_robot_flooding_its_connections_with_garbage_gets_stops_at_once() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    sim.set_faults(x30_sim::Faults {
        flood: true,
        ..Default::default()
    });
    let (
        panel,
        Drive {
            pressed,
            released,
            estop,
        },
    ) = forward_then_estop(&turn, &sim);
    let confirmed = estop_repeats_end(&sim, estop);
    finish(panel);
    let log = log_text(&sim);
    assert!(
        confirmed,
        "the e-stop is still repeated: no status confirmed it\n{log}"
    );
    let forwards = motions(&sim, pressed)
        .iter()
        .filter(|(t, c)| *c == 1 && *t < released)
        .count();
    assert!(forwards >= 3, "held forward did not drive the robot\n{log}");
    let zero = first_command(&sim, released, 6).map(|t| t - released);
    assert!(
        zero.is_some_and(|z| z < 0.5),
        "zero velocity after {zero:?} s\n{log}"
    );
    let first = first_command(&sim, estop, 13).map(|t| t - estop);
    assert!(
        first.is_some_and(|t| t < 0.5),
        "e-stop after {first:?} s\n{log}"
    );
}

#[test]
fn a_half_open_robot_gets_stops_at_once_and_the_panel_reconnects() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);
    let old = sim.requests().iter().map(|e| e.conn).max().unwrap_or(0);
    panel.send("+forward");
    sleep(Duration::from_millis(500));
    sim.set_faults(x30_sim::Faults {
        mute: true,
        ..Default::default()
    });
    let muted = sim.elapsed().as_secs_f64();
    sleep(Duration::from_millis(300));
    let released = sim.elapsed().as_secs_f64();
    panel.send("-forward");
    panel.send("+estop");
    assert!(
        eventually(REACTION, || first_command(&sim, released, 6).is_some()
            && first_command(&sim, released, 13).is_some()),
        "zero velocity and e-stop reach a robot that does not answer\n{}",
        log_text(&sim)
    );
    let zero = first_command(&sim, released, 6).unwrap() - released;
    let estop = first_command(&sim, released, 13).unwrap() - released;
    assert!(
        zero < 0.5 && estop < 0.5,
        "zero velocity after {zero:.3} s, e-stop after {estop:.3} s\n{}",
        log_text(&sim)
    );
    let from = panel.stdout.len();
    panel.expect_stdout(from, REACTION, "`led link blink-fast`", |l| {
        l == "led link blink-fast" || l == "led link blink"
    });
    assert!(
        eventually(REACTION, || sim
            .requests()
            .iter()
            .any(|e| e.t > muted && e.conn > old)),
        "no new connection to the silent robot\n{}",
        log_text(&sim)
    );
    // The panel gives the robot up and reconnects, after about 2 s, then 3 s, then 6 s (each
    // give-up doubles the next connection's waits), writing the stops due (the e-stop
    // repeats every 250 ms) just before each give-up. Every request
    // written on the command connections reached the robot, those included: their message
    // IDs, which count on across connections, run without a gap. (The poll connection,
    // which carries the stops too while a new command connection has not answered, counts
    // its own.)
    let command_conns = || {
        let log = sim.requests();
        let mut conns: Vec<_> = log
            .iter()
            .filter(|e| e.message_type == Some(2) && !polled_on(&log, e.conn, f64::INFINITY))
            .map(|e| e.conn)
            .collect();
        conns.sort_unstable();
        conns.dedup();
        let mut ids: Vec<u16> = log
            .iter()
            .filter(|e| conns.contains(&e.conn))
            .filter_map(|e| e.id)
            .collect();
        ids.sort_unstable();
        (conns.len(), ids)
    };
    assert!(
        eventually(Duration::from_secs(20), || command_conns().0 >= 4),
        "three give-ups of the silent robot\n{}",
        log_text(&sim)
    );
    let (_, ids) = command_conns();
    assert!(
        ids.windows(2).all(|pair| pair[1] == pair[0] + 1),
        "message IDs on the command connections: {ids:?}\n{}",
        log_text(&sim)
    );
    panel.send("-estop");
    finish(panel);
}

/// A robot that serves one connection at a time (a single-threaded robot_server), serving
/// the polls' while the panel's command connection waits in its backlog: the e-stop reaches
/// the robot at once on the poll connection, which carries it too, and the poll connection
/// gives way to the one waiting on the command connection, not when it happens to close. The
/// robot then serves the command connection, which carries the polls from then on: the
/// status is read there.
#[test]
fn an_estop_gets_the_connection_of_a_robot_that_serves_one_at_a_time() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);
    sim.update_faults(|f| f.one_at_a_time = true);
    // Drop what is open until the robot serves a new poll connection: the panel reconnects
    // both, and whichever came first is served, the other left waiting. (Were it the command
    // connection, the polls would move there, but not before two of them wait 1.5 s each.)
    let mut polls_served = false;
    for _ in 0..3 {
        let old = sim.requests().iter().map(|e| e.conn).max().unwrap_or(0);
        sim.drop_connections();
        polls_served = eventually(Duration::from_millis(2500), || {
            sim.requests()
                .iter()
                .any(|e| e.conn > old && e.message_type == Some(1002))
        });
        if polls_served {
            break;
        }
    }
    assert!(
        polls_served,
        "the robot never served a new poll connection\n{}",
        log_text(&sim)
    );
    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+estop");
    assert!(
        eventually(REACTION, || first_command(&sim, pressed, 13).is_some()),
        "no e-stop reached the robot\n{}",
        log_text(&sim)
    );
    let estop = first_command(&sim, pressed, 13).unwrap() - pressed;
    assert!(
        estop < 0.5,
        "the e-stop reached the robot {estop:.3} s after the press\n{}",
        log_text(&sim)
    );
    // The one written on the command connection, which had polled nothing before.
    let estop_conn = || {
        let log = sim.requests();
        log.iter()
            .find(|e| e.t >= pressed && e.command == Some(13) && !polled_on(&log, e.conn, pressed))
            .map(|e| e.conn)
    };
    assert!(
        eventually(Duration::from_secs(5), || estop_conn().is_some()),
        "the robot never read the command connection\n{}",
        log_text(&sim)
    );
    let estop_conn = estop_conn();
    let status_there = || {
        sim.requests()
            .iter()
            .find(|e| e.t > pressed && Some(e.conn) == estop_conn && e.message_type == Some(1002))
            .map(|e| e.t)
    };
    assert!(
        eventually(Duration::from_secs(20), || status_there().is_some()),
        "the status is never polled on the e-stop's connection\n{}",
        log_text(&sim)
    );
    let status = status_there().unwrap();
    sleep(Duration::from_secs(2));
    let last_estop = motions(&sim, pressed)
        .into_iter()
        .filter(|(_, c)| *c == 13)
        .map(|(t, _)| t)
        .fold(0.0, f64::max);
    assert!(
        last_estop < status + 1.5,
        "the e-stop repeated until {last_estop:.3} s, the status was polled at {status:.3} s\n{}",
        log_text(&sim)
    );
    panel.send("-estop");
    finish(panel);
}

#[test]
fn stop_during_a_navigation_task_sends_1004_and_zero_velocity() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = docking(&turn, &sim);
    sleep(Duration::from_millis(500));
    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+stop");
    panel.send("-stop");
    assert!(
        eventually(REACTION, || sim.snapshot().last_task.is_some()),
        "the task did not end\n{}",
        log_text(&sim)
    );
    let log = sim.requests();
    assert!(
        log.iter()
            .any(|e| e.t >= pressed && e.message_type == Some(1004)),
        "no 1004 after stop\n{}",
        log_text(&sim)
    );
    assert!(
        first_command(&sim, pressed, 6).is_some(),
        "no zero velocity\n{}",
        log_text(&sim)
    );
    assert_eq!(
        sim.snapshot().last_task.expect("ended").status,
        ErrorStatus::TaskCancelled
    );
    finish(panel);
}

#[test]
fn the_console_answers_on_its_own_uart() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);
    let from = panel.stdout.len();
    panel.send("console help");
    // The typed command comes back after the prompt, as one line, then the answer.
    let (echo, _) = panel.expect_stdout(from, REACTION, "the echoed command", |l| {
        l == "console: x30> help"
    });
    panel.expect_stdout(echo, REACTION, "`save` in the help", |l| {
        l.starts_with("console: save ")
    });
    // The panel's own lines stay apart from the console's.
    assert!(
        panel
            .stdout
            .all()
            .iter()
            .any(|l| l.starts_with("console: x30-panel ") && l.contains("`help`")),
        "no console greeting\n{}",
        panel.stdout.all().join("\n")
    );
    finish(panel);
}

#[test]
fn a_robot_saved_on_the_console_is_used_at_once_and_after_a_restart() {
    let Some(turn) = turn() else { return };
    let first = simulator();
    let second = simulator();
    let dir = tempfile::Builder::new()
        .prefix("x30-qemu-e2e-")
        .tempdir()
        .expect("temporary folder");
    let file = dir.path().join("settings.bin");
    let settings = ["--settings", file.to_str().expect("UTF-8 path")];

    let mut panel = boot_with(&turn, &first, SESSION_LIMIT, &settings);
    let from = panel.stdout.len();
    panel.send(&format!(
        "console set robot 10.0.2.2:{}",
        second.addr().port()
    ));
    panel.send("console save");
    panel.expect_stdout(from, REACTION, "`saved robot in`", |l| {
        l.starts_with("console: saved robot in ")
    });
    assert!(
        eventually(REACTION, || sim_polled(&second)),
        "the panel did not move to the saved robot\n{}",
        log_text(&second)
    );
    finish(panel);
    // The flash is all there, saved or erased.
    assert_eq!(std::fs::metadata(&file).map(|m| m.len()).ok(), Some(65536));

    // The same file, and the first robot again on the command line: the saved one wins.
    let restarted = second.elapsed().as_secs_f64();
    let before = first.requests().len();
    let panel = boot_with(&turn, &first, SESSION_LIMIT, &settings);
    assert!(
        eventually(REACTION, || second
            .requests()
            .iter()
            .any(|e| e.t > restarted && e.message_type == Some(1002))),
        "no polling of the saved robot after the restart\n{}",
        log_text(&second)
    );
    finish(panel);
    assert_eq!(
        first.requests().len(),
        before,
        "the command line's robot was dialled after the restart\n{}",
        log_text(&first)
    );
}

/// Whether `sim` has been polled for status (1002) at all.
fn sim_polled(sim: &Simulator) -> bool {
    sim.requests().iter().any(|e| e.message_type == Some(1002))
}

#[test]
fn dock_here_then_dock_sends_a_1003_to_the_robots_pose() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    sim.robot(|r| {
        r.set_pose(x30_sim::Pose {
            x: 3.5,
            y: -1.25,
            z: 0.0,
            yaw: 0.75,
        })
    });
    let mut panel = boot(&turn, &sim);
    let from = panel.stdout.len();
    panel.send("console dock here 2 5");
    panel.expect_stdout(from, REACTION, "`saved dock in`", |l| {
        l.starts_with("console: saved dock in ")
    });
    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+dock");
    panel.send("-dock");
    let task = |sim: &Simulator| {
        sim.requests()
            .into_iter()
            .filter(|e| e.t >= pressed)
            .find_map(|e| match e.request {
                Some(Request::NavTask(task)) => task.points.first().copied(),
                _ => None,
            })
    };
    assert!(
        eventually(REACTION, || task(&sim).is_some()),
        "no 1003 after dock\n{}",
        log_text(&sim)
    );
    let point = task(&sim).expect("a 1003");
    assert_eq!(
        (point.value, point.map_id, point.point_info),
        (5, 2, PointInfo::Charging)
    );
    assert_eq!(
        (point.pos_x, point.pos_y, point.pos_z, point.angle_yaw),
        (3.5, -1.25, 0.0, 0.75)
    );
    finish(panel);
}

/// The 1003 points logged at or after `since`: (Value, PosX, PosY), in order.
fn nav_points(sim: &Simulator, since: f64) -> Vec<(i32, f32, f32)> {
    sim.requests()
        .into_iter()
        .filter(|e| e.t >= since)
        .filter_map(|e| match e.request {
            Some(Request::NavTask(task)) => {
                task.points.first().map(|p| (p.value, p.pos_x, p.pos_y))
            }
            _ => None,
        })
        .collect()
}

#[test]
fn patrol_walks_a_stored_route_and_stop_ends_it() {
    let Some(turn) = turn() else { return };
    let sim = simulator();
    let mut panel = boot(&turn, &sim);
    let from = panel.stdout.len();
    for line in [
        "console route add 1 0 0 0",
        "console route add 2 0 0 0",
        "console route add 2 1 0 1.5",
        "console save",
    ] {
        panel.send(line);
    }
    panel.expect_stdout(from, REACTION, "`saved route in`", |l| {
        l.starts_with("console: saved route in ")
    });

    let pressed = sim.elapsed().as_secs_f64();
    panel.send("+patrol");
    panel.send("-patrol");
    let walked = Duration::from_secs(30);
    assert!(
        eventually(walked, || nav_points(&sim, pressed).len() == 3
            && sim.snapshot().task.is_none()),
        "the route was not walked\n{}",
        log_text(&sim)
    );
    assert_eq!(
        nav_points(&sim, pressed),
        [(1, 1.0, 0.0), (2, 2.0, 0.0), (3, 2.0, 1.0)],
        "one 1003 per point, in order"
    );

    // The robot ends the last task before the panel has its answer; a press in between
    // is dropped as made during a task. So the next press waits for the panel.
    panel.expect_stdout(from, REACTION, "the end of the route", |l| {
        l.contains("patrol: the route is done")
    });

    // Again, and `stop` during the first point: 1004, zero velocity, no next point.
    sim.robot(|r| r.set_pose(x30_sim::Pose::default()));
    let again = sim.elapsed().as_secs_f64();
    panel.send("+patrol");
    panel.send("-patrol");
    assert!(
        eventually(REACTION, || sim.snapshot().task.is_some()),
        "the patrol did not start\n{}",
        log_text(&sim)
    );
    let stopped = sim.elapsed().as_secs_f64();
    panel.send("+stop");
    panel.send("-stop");
    assert!(
        eventually(REACTION, || sim
            .requests()
            .iter()
            .any(|e| e.t >= stopped && e.message_type == Some(1004))),
        "no 1004 after stop\n{}",
        log_text(&sim)
    );
    assert!(
        first_command(&sim, stopped, 6).is_some(),
        "no zero velocity"
    );
    sleep(Duration::from_secs(3));
    assert_eq!(
        nav_points(&sim, again).len(),
        1,
        "no point after the stop\n{}",
        log_text(&sim)
    );
    finish(panel);
}
