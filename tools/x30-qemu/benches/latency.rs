//! Stop-path latency report: how long each press takes to reach the robot, from the virtual
//! panel's UART in QEMU to x30-sim's request log, for a healthy robot and for each fault
//! the simulator can inject.
//!
//! `cargo bench -p x30-qemu --bench latency` (from `host-tests/`) prints, per robot, the
//! minimum, median and maximum over `X30_LATENCY_PRESSES` (default 10) presses of:
//!
//! - forward: press → first Type 2 Command 1;
//! - release: release → Command 6 (zero velocity);
//! - stop in task: `stop` during a navigation task → 1004;
//! - e-stop: press → Command 13.
//!
//! Both ends are read on this machine's clock: the time the line was written to x30-qemu's
//! input and the simulator's arrival time of the request, so the figures include the
//! emulated UART, the firmware and QEMU's user network. It is a report, not a test: it
//! asserts nothing about the figures, which depend on the machine.

#[path = "../tests/common/mod.rs"]
mod common;

use std::thread::sleep;
use std::time::Duration;

use common::{Running, Turn, boot_for, far_from_dock, finish, simulator, turn};
use x30_panel::proto::codes::MotionState;
use x30_sim::{Faults, LogEntry, Simulator};

/// Longest a press may take to show before it counts as lost.
const LIMIT: Duration = Duration::from_secs(5);

/// One robot to measure against: a name and how to make the simulator misbehave.
struct Robot {
    /// Shown in the report.
    name: &'static str,
    /// Applied at the start of each round.
    misbehave: fn(&Simulator),
    /// Applied right before each e-stop press.
    before_estop: fn(&Simulator),
}

/// What is measured, in the report's column order.
const MEASURES: [&str; 4] = ["forward", "release", "stop in task", "e-stop"];

/// Nothing to do.
fn as_it_is(_: &Simulator) {}

/// The robots of the report: a healthy one and one per fault of the simulator.
const ROBOTS: [Robot; 5] = [
    Robot {
        name: "healthy",
        misbehave: as_it_is,
        before_estop: as_it_is,
    },
    Robot {
        name: "status answers 1.2 s late",
        misbehave: |sim| {
            sim.set_faults(Faults {
                type_delays: vec![(1002, Duration::from_millis(1200))],
                ..Default::default()
            })
        },
        before_estop: as_it_is,
    },
    Robot {
        name: "half-open (reads, never answers)",
        misbehave: |sim| {
            sim.set_faults(Faults {
                mute: true,
                ..Default::default()
            })
        },
        before_estop: as_it_is,
    },
    Robot {
        name: "refuses the first 2 e-stops",
        misbehave: |sim| {
            sim.set_faults(Faults {
                refuse_estops: 2,
                ..Default::default()
            })
        },
        before_estop: as_it_is,
    },
    Robot {
        name: "refuses connections 1 s from e-stop",
        misbehave: as_it_is,
        before_estop: |sim| sim.refuse_connections(Duration::from_secs(1)),
    },
];

fn main() {
    let presses = std::env::var("X30_LATENCY_PRESSES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(10usize);
    let Some(turn) = turn() else { return };
    println!(
        "press -> wire latency in QEMU against x30-sim, ms: min / median / max over {presses} presses"
    );
    print!("| {:38}", "robot");
    for measure in MEASURES {
        print!(" | {measure:>18}");
    }
    println!(" |");
    for robot in &ROBOTS {
        let samples = measure(&turn, robot, presses);
        print!("| {:38}", robot.name);
        for column in &samples {
            print!(" | {:>18}", summary(column));
        }
        println!(" |");
    }
}

/// Boots the panel against a simulator that misbehaves as `robot` says and measures
/// `presses` of each kind; seconds per column of [`MEASURES`], `None` for a press that never
/// showed.
fn measure(turn: &Turn, robot: &Robot, presses: usize) -> [Vec<Option<f64>>; 4] {
    let sim = simulator();
    far_from_dock(&sim);
    // Each round takes about 5 s, and up to 5 s more per press that never shows.
    let session = Duration::from_secs(60 + 25 * presses as u64);
    let mut panel = boot_for(turn, &sim, session);
    let mut columns: [Vec<Option<f64>>; 4] = Default::default();
    for _ in 0..presses {
        (robot.misbehave)(&sim);
        columns[0].push(press(&sim, &mut panel, "+forward", |e| is_motion(e, 1)));
        sleep(Duration::from_millis(600));
        columns[1].push(press(&sim, &mut panel, "-forward", |e| is_motion(e, 6)));
        sleep(Duration::from_millis(300));
        panel.send("+dock");
        panel.send("-dock");
        sleep(Duration::from_millis(800));
        columns[2].push(press(&sim, &mut panel, "+stop", |e| {
            e.message_type == Some(1004)
        }));
        panel.send("-stop");
        sleep(Duration::from_millis(300));
        (robot.before_estop)(&sim);
        columns[3].push(press(&sim, &mut panel, "+estop", |e| is_motion(e, 13)));
        panel.send("-estop");
        recover(&sim);
    }
    finish(panel);
    columns
}

/// Back to a healthy, standing robot for the next round, as an operator would after an
/// e-stop: once the panel has stopped repeating Command 13 (it saw the robot confirm the
/// stop), the robot stands up again, and the panel's e-stop latch opens.
fn recover(sim: &Simulator) {
    sim.set_faults(Faults::default());
    let quiet = Duration::from_millis(600);
    let deadline = std::time::Instant::now() + LIMIT * 2;
    while std::time::Instant::now() < deadline {
        let now = sim.elapsed().as_secs_f64();
        let repeating = sim
            .requests()
            .iter()
            .any(|e| is_motion(e, 13) && now - e.t < quiet.as_secs_f64());
        if !repeating && sim.snapshot().motion_state == MotionState::SoftEmergencyStop {
            break;
        }
        sleep(Duration::from_millis(50));
    }
    sim.robot(|r| r.set_motion_state(MotionState::ForceControlStand));
    sleep(Duration::from_millis(1000));
}

/// Whether `entry` is a Type 2 request with `command`.
fn is_motion(entry: &LogEntry, command: i32) -> bool {
    entry.message_type == Some(2) && entry.command == Some(command)
}

/// Sends `line` and waits for the first request after it that `arrived` accepts; seconds
/// from the line to the request, `None` if none came within [`LIMIT`].
fn press(
    sim: &Simulator,
    panel: &mut Running,
    line: &str,
    arrived: impl Fn(&LogEntry) -> bool,
) -> Option<f64> {
    let sent = sim.elapsed().as_secs_f64();
    panel.send(line);
    let deadline = std::time::Instant::now() + LIMIT;
    while std::time::Instant::now() < deadline {
        if let Some(at) = sim
            .requests()
            .iter()
            .find(|e| e.t >= sent && arrived(e))
            .map(|e| e.t)
        {
            return Some(at - sent);
        }
        sleep(Duration::from_millis(2));
    }
    None
}

/// `min / median / max` in milliseconds, with the number that never arrived.
fn summary(samples: &[Option<f64>]) -> String {
    let mut got: Vec<f64> = samples.iter().flatten().map(|s| s * 1000.0).collect();
    got.sort_by(f64::total_cmp);
    let missing = samples.len() - got.len();
    let (Some(min), Some(max)) = (got.first(), got.last()) else {
        return "none arrived".into();
    };
    let median = got[got.len() / 2];
    let text = format!("{min:.0} / {median:.0} / {max:.0}");
    if missing == 0 {
        text
    } else {
        format!("{text} ({missing} lost)")
    }
}
