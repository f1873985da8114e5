//! Starting and stopping: drop is prompt even with busy connections, and leaves no threads.
//!
//! One test only in this binary, so that counting the process's threads is meaningful.

mod common;

use std::time::{Duration, Instant};

use common::*;
use x30_panel::proto::codes::PointInfo;
use x30_panel::proto::message::Request;
use x30_sim::{Config, Faults, SHUTDOWN_LIMIT};

/// Threads of this process, where the platform tells (Linux).
fn threads() -> Option<usize> {
    std::fs::read_dir("/proc/self/task").ok().map(|d| d.count())
}

#[test]
fn drop_stops_everything_promptly() {
    let before = threads();
    let sim = start_with(Config {
        listen: "127.0.0.1:0".parse().unwrap(),
        faults: Faults {
            delay: Duration::from_secs(30),
            ..Faults::default()
        },
        ..Config::default()
    });
    let mut idle = Client::connect(sim.addr());
    let mut waiting = Client::connect(sim.addr());
    let mut tasked = Client::connect(sim.addr());
    waiting.send(&Request::Status);
    tasked.start_task(&[point(1, 1000.0, 0.0, PointInfo::Task)]);
    assert!(wait_until(Duration::from_secs(2), || sim.connections()
        == 3
        && sim.snapshot().task.is_some()));
    let dropping = Instant::now();
    drop(sim);
    let took = dropping.elapsed();
    assert!(took < SHUTDOWN_LIMIT, "drop took {took:?}");
    for client in [&mut idle, &mut waiting, &mut tasked] {
        assert!(client.closed_within(Duration::from_secs(2)));
    }
    if let Some(before) = before {
        assert!(
            wait_until(Duration::from_secs(2), || threads() == Some(before)),
            "threads: {before} before, {:?} after",
            threads()
        );
    }
    // The port is free again at once for a new simulator on port 0.
    let again = start(1.0);
    assert_eq!(Client::connect(again.addr()).status().electricity, Some(90));
}
