//! Stop-path latency report: how long each press takes to reach the robot, from the virtual
//! panel's UART in QEMU to x30-sim's request log, for a healthy robot and for each fault
//! the simulator can inject.
//!
//! `cargo bench -p x30-qemu --bench latency` (from `tools/`) prints, per robot, the
//! minimum, median and maximum over `X30_LATENCY_PRESSES` (default 10) presses of:
//!
//! - forward: press → first Type 2 Command 1;
//! - release: release → Command 6 (zero velocity);
//! - stop in task: `stop` during a navigation task → 1004;
//! - e-stop: press → Command 13.
//!
//! The healthy robot is measured twice: alone, and while 20 clients load the board's web
//! page (`GET /` and `GET /api/status` back to back, each on a new connection, as fast as
//! the board answers) through x30-qemu's `--http`: the page must not delay a stop.
//! `X30_LATENCY_ROBOTS=TEXT` measures only the robots whose name contains TEXT.
//!
//! `cargo test --all-targets` (the test command) runs it too, without `--bench`, to show the
//! report still runs: one press of each kind per robot, unless `X30_LATENCY_PRESSES` says
//! otherwise. Ten take four minutes, which the report needs and the check does not.
//!
//! Both ends are read on this machine's clock: the time the line was written to x30-qemu's
//! input and the simulator's arrival time of the request, so the figures include the
//! emulated UART, the firmware and QEMU's user network. It is a report, not a test: it
//! asserts nothing about the figures, which depend on the machine.

#[path = "../tests/common/mod.rs"]
mod common;

use std::io::{Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::thread::{self, sleep};
use std::time::{Duration, Instant};

use common::{Running, Turn, boot_with, far_from_dock, finish, simulator, turn};
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
    /// Clients loading the web page all through the measurement.
    page_clients: usize,
}

/// What is measured, in the report's column order.
const MEASURES: [&str; 4] = ["forward", "release", "stop in task", "e-stop"];

/// Nothing to do.
fn as_it_is(_: &Simulator) {}

/// The robots of the report: a healthy one and one per fault of the simulator.
const ROBOTS: [Robot; 7] = [
    Robot {
        name: "healthy",
        misbehave: as_it_is,
        before_estop: as_it_is,
        page_clients: 0,
    },
    Robot {
        name: "healthy, 20 clients loading the page",
        misbehave: as_it_is,
        before_estop: as_it_is,
        page_clients: 20,
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
        page_clients: 0,
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
        page_clients: 0,
    },
    Robot {
        name: "floods garbage between answers",
        misbehave: |sim| {
            sim.set_faults(Faults {
                flood: true,
                ..Default::default()
            })
        },
        before_estop: as_it_is,
        page_clients: 0,
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
        page_clients: 0,
    },
    Robot {
        name: "refuses connections 1 s from e-stop",
        misbehave: as_it_is,
        before_estop: |sim| sim.refuse_connections(Duration::from_secs(1)),
        page_clients: 0,
    },
];

fn main() {
    let measured = std::env::args().any(|arg| arg == "--bench");
    let presses = std::env::var("X30_LATENCY_PRESSES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(if measured { 10usize } else { 1 });
    let only = std::env::var("X30_LATENCY_ROBOTS").unwrap_or_default();
    let Some(turn) = turn() else { return };
    let plural = if presses == 1 { "" } else { "es" };
    println!(
        "press -> wire latency in QEMU against x30-sim, ms: min / median / max over {presses} press{plural}"
    );
    print!("| {:38}", "robot");
    for measure in MEASURES {
        print!(" | {measure:>18}");
    }
    println!(" |");
    let mut loads = Vec::new();
    for robot in ROBOTS.iter().filter(|r| r.name.contains(&only)) {
        let (samples, load) = measure(&turn, robot, presses);
        print!("| {:38}", robot.name);
        for column in &samples {
            print!(" | {:>18}", summary(column));
        }
        println!(" |");
        loads.extend(load.map(|load| (robot.name, load)));
    }
    for (name, load) in loads {
        println!(
            "{name}: {} page and status loads answered, {} failed or refused, in {:.0} s",
            load.answered,
            load.failed,
            load.lasted.as_secs_f64()
        );
    }
}

/// Boots the panel against a simulator that misbehaves as `robot` says and measures
/// `presses` of each kind, under the page load it asks for; seconds per column of
/// [`MEASURES`], `None` for a press that never showed, and what the page's clients got.
fn measure(turn: &Turn, robot: &Robot, presses: usize) -> ([Vec<Option<f64>>; 4], Option<Load>) {
    let sim = simulator();
    // Each round takes about 5 s, and up to 5 s more per press that never shows.
    let session = Duration::from_secs(60 + 25 * presses as u64);
    let page = SocketAddr::from((Ipv4Addr::LOCALHOST, free_port()));
    let http = page.to_string();
    let extra: &[&str] = if robot.page_clients > 0 {
        &["--http", &http]
    } else {
        &[]
    };
    let mut panel = boot_with(turn, &sim, session, extra);
    let clients =
        (robot.page_clients > 0).then(|| Clients::start(page, robot.page_clients, session));
    let mut columns: [Vec<Option<f64>>; 4] = Default::default();
    for _ in 0..presses {
        // Every round's task starts far from the charging point: the tasks before walked
        // towards it, and one that arrives leaves no task for `stop` to cancel.
        far_from_dock(&sim);
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
    let load = clients.map(Clients::stop);
    finish(panel);
    (columns, load)
}

/// A free loopback port (free when asked; nothing else on this machine races for it).
fn free_port() -> u16 {
    TcpListener::bind((Ipv4Addr::LOCALHOST, 0))
        .and_then(|listener| listener.local_addr())
        .expect("a free loopback port")
        .port()
}

/// What the page's clients got.
struct Load {
    /// Answers read whole.
    answered: usize,
    /// Connections refused, reset or timed out.
    failed: usize,
    /// How long they ran.
    lasted: Duration,
}

/// Threads loading the board's page as fast as it answers, until stopped.
struct Clients {
    /// Set to stop them.
    stop: Arc<AtomicBool>,
    /// Answers read whole.
    answered: Arc<AtomicUsize>,
    /// Loads that failed.
    failed: Arc<AtomicUsize>,
    /// The clients.
    threads: Vec<thread::JoinHandle<()>>,
    /// When they started.
    started: Instant,
}

/// How long one page load may take before it counts as failed.
const PAGE_LIMIT: Duration = Duration::from_secs(5);

/// Pause after a failed load: a refused connection comes back at once, and retrying at
/// once would only load this machine's CPU, not the board.
const RETRY: Duration = Duration::from_millis(20);

impl Clients {
    /// `count` clients of the page at `page`, each stopping by itself after `limit`.
    fn start(page: SocketAddr, count: usize, limit: Duration) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let answered = Arc::new(AtomicUsize::new(0));
        let failed = Arc::new(AtomicUsize::new(0));
        let deadline = Instant::now() + limit;
        let threads = (0..count)
            .map(|_| {
                let (stop, answered, failed) = (stop.clone(), answered.clone(), failed.clone());
                thread::spawn(move || {
                    for path in ["/", "/api/status"].iter().cycle() {
                        if stop.load(Ordering::Relaxed) || Instant::now() >= deadline {
                            break;
                        }
                        if load(page, path) {
                            answered.fetch_add(1, Ordering::Relaxed);
                        } else {
                            failed.fetch_add(1, Ordering::Relaxed);
                            sleep(RETRY);
                        }
                    }
                })
            })
            .collect();
        Self {
            stop,
            answered,
            failed,
            threads,
            started: Instant::now(),
        }
    }

    /// Stops the clients and says what they got.
    fn stop(self) -> Load {
        self.stop.store(true, Ordering::Relaxed);
        for thread in self.threads {
            let _ = thread.join();
        }
        Load {
            answered: self.answered.load(Ordering::Relaxed),
            failed: self.failed.load(Ordering::Relaxed),
            lasted: self.started.elapsed(),
        }
    }
}

/// Loads `path` from `page` on a new connection; whether a whole `200 OK` answer came
/// within [`PAGE_LIMIT`].
fn load(page: SocketAddr, path: &str) -> bool {
    let Ok(mut stream) = TcpStream::connect_timeout(&page, PAGE_LIMIT) else {
        return false;
    };
    let _ = stream.set_read_timeout(Some(PAGE_LIMIT));
    let _ = stream.set_write_timeout(Some(PAGE_LIMIT));
    let request = format!("GET {path} HTTP/1.1\r\nHost: {page}\r\nConnection: close\r\n\r\n");
    let mut answer = Vec::new();
    stream.write_all(request.as_bytes()).is_ok()
        && stream.read_to_end(&mut answer).is_ok()
        && answer.starts_with(b"HTTP/1.1 200 ")
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
