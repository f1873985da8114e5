//! What the application logs: the wait it keeps before it reconnects, which a pending stop
//! shortens to `STOP_RETRY`, not the connection's backoff; and where its polls go. In a
//! test binary of its own, because the logger it reads is process-wide, and one test at a
//! time ([`SERIAL`]), so that each reads only its own lines.

mod common;
#[path = "common/steady.rs"]
mod steady;
#[path = "common/warnings.rs"]
mod warnings;

use common::TokioTransport;
use embassy_time::{Duration, Instant};
use std::net::TcpListener;
use std::time::Duration as StdDuration;
use steady::steady;
use warnings::{record_warnings, warnings_with};
use x30_panel::app::{self, Connections, STOP_RETRY, Shared};
use x30_panel::client::{Backoff, Connection};
use x30_panel::config::Config;
use x30_panel::panel::{Button, ButtonEvent, NetworkState};
use x30_sim::{Config as SimConfig, Faults, Simulator};

/// Held by each test for its whole run.
static SERIAL: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// The waits before a connection attempt logged so far, in milliseconds.
fn logged_waits() -> Vec<u64> {
    warnings_with("next connection attempt in")
        .iter()
        .filter_map(|w| {
            w.strip_prefix("next connection attempt in ")?
                .strip_suffix(" ms")?
                .parse()
                .ok()
        })
        .collect()
}

/// Waits until `condition` holds on the logged waits, for at most `limit_ms`.
async fn wait_for_waits(limit_ms: u64, condition: impl Fn(&[u64]) -> bool) -> bool {
    for _ in 0..limit_ms / 20 {
        if condition(&logged_waits()) {
            return true;
        }
        tokio::time::sleep(StdDuration::from_millis(20)).await;
    }
    false
}

#[tokio::test]
async fn the_wait_logged_before_reconnecting_is_the_wait_kept_while_a_stop_is_pending() {
    let _serial = SERIAL.lock().await;
    record_warnings();
    // A port nothing listens on: every connection is refused at once.
    let addr = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    // A backoff whose waits soon pass STOP_RETRY.
    let backoff = Backoff::new(Duration::from_millis(100), Duration::from_millis(3200));
    let mut links = Connections {
        commands: Connection::new(TokioTransport::new(addr), backoff),
        polls: Connection::new(TokioTransport::new(addr), backoff),
        navigation: Connection::new(TokioTransport::new(addr), backoff),
    };
    let config = Config::default();
    let shared = Shared::new();
    shared.set_network(NetworkState::Up);
    let stop_retry = STOP_RETRY.as_millis();
    let script = async {
        // Without a stop, the log follows the backoff: 100, 200, 400 ms and on.
        assert!(
            wait_for_waits(3000, |waits| waits.iter().any(|&w| w > stop_retry)).await,
            "the backoff's waits: {:?}",
            logged_waits()
        );
        shared
            .buttons
            .send(ButtonEvent {
                button: Button::Estop,
                pressed: true,
                at: Instant::now(),
            })
            .await;
        // The e-stop cannot be confirmed: no robot answers. Once the application has taken
        // the press, every wait it logs is one it keeps, at most STOP_RETRY.
        tokio::time::sleep(StdDuration::from_millis(500)).await;
        let since = logged_waits().len();
        tokio::time::sleep(StdDuration::from_millis(2000)).await;
        let waits = logged_waits().split_off(since);
        // Two connections (commands and polls) retry about every STOP_RETRY for 2 s.
        assert!(waits.len() >= 4, "{waits:?}");
        assert!(waits.iter().all(|&w| w <= stop_retry), "{waits:?}");
    };
    steady(async {
        tokio::select! {
            _ = app::run(&config, &mut links, &shared) => unreachable!(),
            () = script => {}
        }
    })
    .await;
}

/// A robot silent on every connection has its polls moved to the command connection when
/// two poll connections in a row go silent never answered; the first poll there waits
/// too, and the polls go back to their own connection for good.
#[tokio::test]
async fn a_robot_silent_everywhere_has_its_polls_moved_to_the_command_connection_once() {
    let _serial = SERIAL.lock().await;
    record_warnings();
    let moved = "the command connection carries the polls";
    let before = warnings_with(moved).len();
    let sim = Simulator::start(SimConfig {
        listen: "127.0.0.1:0".parse().unwrap(),
        ..Default::default()
    })
    .expect("the simulator starts");
    sim.set_faults(Faults {
        mute: true,
        ..Default::default()
    });
    let backoff = Backoff::new(Duration::from_millis(50), Duration::from_millis(400));
    let mut links = Connections {
        commands: Connection::new(TokioTransport::new(sim.addr()), backoff),
        polls: Connection::new(TokioTransport::new(sim.addr()), backoff),
        navigation: Connection::new(TokioTransport::new(sim.addr()), backoff),
    };
    let config = Config::default();
    let shared = Shared::new();
    shared.set_network(NetworkState::Up);
    let kept = "the polls go back to their own connection for good";
    let kept_before = warnings_with(kept).len();
    // Moved after about 9.5 s (two poll connections given up on, after 3 s and 6 s), back
    // 0.5 s later.
    steady(async {
        tokio::select! {
            _ = app::run(&config, &mut links, &shared) => unreachable!(),
            () = tokio::time::sleep(StdDuration::from_secs(12)) => {}
        }
    })
    .await;
    assert_eq!(
        warnings_with(moved).len() - before,
        1,
        "{:?}",
        warnings_with("poll")
    );
    assert_eq!(warnings_with(kept).len() - kept_before, 1);
}
