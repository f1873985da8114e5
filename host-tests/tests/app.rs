//! The whole panel application against x30-sim over loopback: hold-to-move rate, release,
//! e-stop, outages, reconnection, navigation cancel, LEDs, and the simulator's faults.

mod common;

use common::TokioTransport;
use embassy_time::Duration;
use std::sync::atomic::Ordering;
use std::time::Duration as StdDuration;
use x30_panel::app::{self, Shared};
use x30_panel::client::{Backoff, Link};
use x30_panel::config::Config;
use x30_panel::panel::{Button, ButtonEvent, Indicators, Led};
use x30_panel::proto::codes::MotionState;
use x30_sim::{Config as SimConfig, Faults, LogEntry, Simulator};

fn simulator(time_scale: f64) -> Simulator {
    Simulator::start(SimConfig {
        listen: "127.0.0.1:0".parse().unwrap(),
        time_scale,
        ..Default::default()
    })
    .expect("the simulator starts")
}

/// Runs the application against `sim` while `script` runs; returns what the script returns.
async fn with_app<R>(sim: &Simulator, script: impl AsyncFnOnce(&Shared) -> R) -> R {
    let config = Config::default();
    let shared = Shared::new();
    let backoff = Backoff::new(Duration::from_millis(50), Duration::from_millis(400));
    let mut control = Link::new(TokioTransport::new(sim.addr()), backoff);
    let mut navigation = Link::new(TokioTransport::new(sim.addr()), backoff);
    tokio::select! {
        _ = app::run(&config, &mut control, &mut navigation, &shared) => unreachable!(),
        result = script(&shared) => result,
    }
}

async fn press(shared: &Shared, button: Button, pressed: bool) {
    shared.buttons.send(ButtonEvent { button, pressed }).await;
}

async fn sleep(ms: u64) {
    tokio::time::sleep(StdDuration::from_millis(ms)).await;
}

/// Waits until `condition` holds on the simulator's request log, for at most `limit_ms`.
async fn wait_for_log(
    sim: &Simulator,
    limit_ms: u64,
    condition: impl Fn(&[LogEntry]) -> bool,
) -> bool {
    for _ in 0..limit_ms / 20 {
        if condition(&sim.requests()) {
            return true;
        }
        sleep(20).await;
    }
    false
}

fn motion(entries: &[LogEntry]) -> Vec<(f64, i32)> {
    entries
        .iter()
        .filter(|e| e.message_type == Some(2))
        .filter_map(|e| Some((e.t, e.command?)))
        .collect()
}

fn polls(entries: &[LogEntry], message_type: i32) -> usize {
    entries
        .iter()
        .filter(|e| e.message_type == Some(message_type))
        .count()
}

/// The latest LED states the application published, waiting for one if none came yet.
struct Leds(Option<Indicators>);

impl Leds {
    async fn latest(&mut self, shared: &Shared) -> Indicators {
        if let Some(new) = shared.indicators.try_take() {
            self.0 = Some(new);
        }
        if self.0.is_none() {
            self.0 = Some(shared.indicators.wait().await);
        }
        self.0.unwrap()
    }

    /// Waits up to `limit_ms` for the LEDs to satisfy `condition`.
    async fn until(
        &mut self,
        shared: &Shared,
        limit_ms: u64,
        condition: impl Fn(&Indicators) -> bool,
    ) -> Indicators {
        let mut last = self.latest(shared).await;
        for _ in 0..limit_ms / 20 {
            if condition(&last) {
                break;
            }
            sleep(20).await;
            last = self.latest(shared).await;
        }
        last
    }
}

/// The heartbeat's count after `ms` milliseconds minus the count before.
async fn beats_during(shared: &Shared, ms: u64) -> u32 {
    let before = shared.heartbeat.load(Ordering::Relaxed);
    sleep(ms).await;
    shared
        .heartbeat
        .load(Ordering::Relaxed)
        .wrapping_sub(before)
}

#[tokio::test(flavor = "current_thread")]
async fn heartbeat_moves_while_connected_and_while_the_robot_is_away() {
    // Connected and idle: the control loop turns at least every 500 ms (polls come sooner).
    let sim = simulator(1.0);
    let connected = with_app(&sim, async |shared| {
        assert!(
            wait_for_log(&sim, 3000, |l| polls(l, 1002) > 0).await,
            "the panel polls the robot"
        );
        beats_during(shared, 1500).await
    })
    .await;
    assert!(connected >= 3, "{connected} beats in 1.5 s while connected");

    // No robot at all: every connection is refused, and the loop still turns while it backs off.
    let closed = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|listener| listener.local_addr())
        .expect("a free port");
    let config = Config::default();
    let shared = Shared::new();
    let backoff = Backoff::new(Duration::from_millis(50), Duration::from_millis(400));
    let mut control = Link::new(TokioTransport::new(closed), backoff);
    let mut navigation = Link::new(TokioTransport::new(closed), backoff);
    let away = tokio::select! {
        _ = app::run(&config, &mut control, &mut navigation, &shared) => unreachable!(),
        beats = beats_during(&shared, 1500) => beats,
    };
    assert!(away >= 3, "{away} beats in 1.5 s without a robot");
}

#[tokio::test(flavor = "current_thread")]
async fn held_motion_repeats_at_4_hz_and_release_sends_zero_velocity_at_once() {
    let sim = simulator(1.0);
    let (pressed_at, released_at) = with_app(&sim, async |shared| {
        assert!(
            wait_for_log(&sim, 3000, |l| polls(l, 1002) > 0).await,
            "the panel polls the robot"
        );
        let pressed_at = sim.elapsed().as_secs_f64();
        press(shared, Button::Forward, true).await;
        sleep(10_000).await;
        let released_at = sim.elapsed().as_secs_f64();
        press(shared, Button::Forward, false).await;
        sleep(600).await;
        (pressed_at, released_at)
    })
    .await;
    let motion = motion(&sim.requests());
    let forward: Vec<f64> = motion
        .iter()
        .filter(|(_, c)| *c == 1)
        .map(|(t, _)| *t)
        .collect();
    let first = forward.first().copied().expect("forward was sent");
    assert!(
        first - pressed_at < 0.1,
        "first command {:.3} s after the press",
        first - pressed_at
    );
    let rate = (forward.len() - 1) as f64 / (forward.last().unwrap() - first);
    assert!(
        (3.5..=4.5).contains(&rate),
        "held forward repeated at {rate:.2} Hz ({} commands)",
        forward.len()
    );
    // A repeat already on the wire when the button came up may land just after the release.
    let in_flight = 0.05;
    let zero_at = motion
        .iter()
        .find(|(t, c)| *t >= released_at && *c == 6)
        .map(|(t, _)| *t)
        .expect("zero velocity after the release");
    assert!(
        zero_at - released_at < 0.25,
        "zero velocity {:.3} s after the release",
        zero_at - released_at
    );
    let late: Vec<_> = motion
        .iter()
        .filter(|(t, c)| *c != 6 && *t > released_at + in_flight)
        .collect();
    assert!(
        late.is_empty(),
        "no other motion after the release: {late:?}"
    );
    let before_zero: Vec<_> = motion
        .iter()
        .filter(|(t, c)| *t >= released_at && *t < zero_at && *c != 6)
        .collect();
    assert!(
        before_zero.len() <= 1,
        "at most the one command in flight precedes zero velocity: {before_zero:?}"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn estop_during_motion_goes_out_before_any_further_motion() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        assert!(wait_for_log(&sim, 3000, |l| polls(l, 1002) > 0).await);
        press(shared, Button::Forward, true).await;
        sleep(1000).await;
        press(shared, Button::Estop, true).await;
        sleep(1000).await;
    })
    .await;
    let motion = motion(&sim.requests());
    let estop = motion
        .iter()
        .position(|(_, c)| *c == 13)
        .expect("Command 13 was sent");
    assert!(
        motion[..estop].iter().any(|(_, c)| *c == 1),
        "forward before the e-stop"
    );
    assert!(
        motion[estop + 1..].iter().all(|(_, c)| *c != 1),
        "no forward after the e-stop: {motion:?}"
    );
    assert_eq!(sim.snapshot().motion_state, MotionState::SoftEmergencyStop);
}

#[tokio::test(flavor = "current_thread")]
async fn disconnect_during_hold_stops_motion_until_a_new_press() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        assert!(wait_for_log(&sim, 3000, |l| polls(l, 1002) > 0).await);
        press(shared, Button::Forward, true).await;
        sleep(800).await;
        let conns_before = sim.connections();
        sim.drop_connections();
        let dropped_at = sim.elapsed().as_secs_f64();
        // The panel reconnects and polls again on a new connection.
        assert!(
            wait_for_log(&sim, 5000, |l| l
                .iter()
                .any(|e| e.t > dropped_at && e.message_type == Some(1002)))
            .await,
            "polling resumes after the reconnect"
        );
        assert!(conns_before >= 1);
        sleep(1500).await;
        let still_held = motion(&sim.requests())
            .into_iter()
            .filter(|(t, c)| *t > dropped_at && *c == 1)
            .count();
        assert_eq!(
            still_held, 0,
            "a button held through the outage does not resume motion"
        );
        press(shared, Button::Forward, false).await;
        press(shared, Button::Forward, true).await;
        assert!(
            wait_for_log(&sim, 2000, |l| motion(l)
                .iter()
                .any(|(t, c)| *t > dropped_at && *c == 1))
            .await,
            "a new press moves again"
        );
        press(shared, Button::Forward, false).await;
        sleep(300).await;
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn presses_during_an_outage_are_dropped_not_replayed() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        assert!(wait_for_log(&sim, 3000, |l| polls(l, 1002) > 0).await);
        sim.set_faults(Faults {
            drop_after: Some(0),
            ..Default::default()
        });
        sim.drop_connections();
        sleep(300).await;
        // While every connection is refused service, press lie-down.
        press(shared, Button::LieDown, true).await;
        press(shared, Button::LieDown, false).await;
        sleep(500).await;
        sim.set_faults(Faults::default());
        let healed_at = sim.elapsed().as_secs_f64();
        assert!(
            wait_for_log(&sim, 5000, |l| l
                .iter()
                .any(|e| e.t > healed_at && e.message_type == Some(1002)))
            .await
        );
        sleep(500).await;
    })
    .await;
    assert!(
        motion(&sim.requests()).iter().all(|(_, c)| *c != 15),
        "the lie-down pressed during the outage was never sent"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn navigation_task_docks_and_is_cancelled_from_the_panel() {
    let sim = simulator(1.0);
    sim.robot(|r| {
        r.set_pose(x30_sim::Pose {
            x: 20.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        })
    });
    with_app(&sim, async |shared| {
        let mut leds = Leds(None);
        assert!(wait_for_log(&sim, 3000, |l| polls(l, 1002) > 0).await);
        press(shared, Button::Dock, true).await;
        press(shared, Button::Dock, false).await;
        assert!(
            wait_for_log(&sim, 2000, |l| polls(l, 1003) == 1).await,
            "dock sends a 1003"
        );
        let on = leds.until(shared, 2000, |i| i.activity == Led::On).await;
        assert_eq!(
            on.activity,
            Led::On,
            "activity is steady while the task runs"
        );
        assert!(
            wait_for_log(&sim, 2000, |l| polls(l, 1007) > 0).await,
            "1007 polls while the task runs"
        );
        press(shared, Button::Cancel, true).await;
        press(shared, Button::Cancel, false).await;
        assert!(
            wait_for_log(&sim, 2000, |l| polls(l, 1004) == 1).await,
            "cancel sends a 1004"
        );
        let off = leds.until(shared, 2000, |i| i.activity != Led::On).await;
        assert_ne!(
            off.activity,
            Led::On,
            "the task ended when its cancelled answer arrived"
        );
    })
    .await;
    let log = sim.requests();
    let nav_conn = log
        .iter()
        .find(|e| e.message_type == Some(1003))
        .unwrap()
        .conn;
    let cancel_conn = log
        .iter()
        .find(|e| e.message_type == Some(1004))
        .unwrap()
        .conn;
    assert_ne!(
        nav_conn, cancel_conn,
        "the 1003 waits on its own connection"
    );
    assert!(
        log.iter()
            .filter(|e| e.conn == nav_conn)
            .all(|e| e.message_type == Some(1003))
    );
    let last = sim.snapshot().last_task.expect("the task ended");
    assert_eq!(last.status.raw(), 8962, "cancelled: {last:?}");
}

#[tokio::test(flavor = "current_thread")]
async fn motion_press_during_navigation_cancels_the_task_first() {
    let sim = simulator(1.0);
    sim.robot(|r| {
        r.set_pose(x30_sim::Pose {
            x: 20.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        })
    });
    with_app(&sim, async |shared| {
        assert!(wait_for_log(&sim, 3000, |l| polls(l, 1002) > 0).await);
        press(shared, Button::Dock, true).await;
        press(shared, Button::Dock, false).await;
        assert!(wait_for_log(&sim, 2000, |l| polls(l, 1003) == 1).await);
        press(shared, Button::TurnLeft, true).await;
        assert!(wait_for_log(&sim, 2000, |l| motion(l).iter().any(|(_, c)| *c == 3)).await);
        press(shared, Button::TurnLeft, false).await;
        sleep(300).await;
    })
    .await;
    let log = sim.requests();
    let cancel = log
        .iter()
        .position(|e| e.message_type == Some(1004))
        .expect("1004 sent");
    let turn = log
        .iter()
        .position(|e| e.message_type == Some(2) && e.command == Some(3))
        .unwrap();
    assert!(
        cancel < turn,
        "the task is cancelled before the manual motion"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn leds_follow_the_robot() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        let mut leds = Leds(None);
        let healthy = leds
            .until(shared, 3000, |i| i.link == Led::On && i.fault == Led::Off)
            .await;
        assert_eq!(
            (healthy.link, healthy.fault),
            (Led::On, Led::Off),
            "connected, no fault"
        );
        type Setup = fn(&mut x30_sim::Robot);
        let faults: [(&str, Setup, Setup); 5] = [
            (
                "battery 15 %",
                |r| r.set_battery(15.0),
                |r| r.set_battery(90.0),
            ),
            (
                "fallen",
                |r| r.set_motion_state(MotionState::Fallen),
                |r| r.set_motion_state(MotionState::ForceControlStand),
            ),
            (
                "soft e-stop",
                |r| r.set_motion_state(MotionState::SoftEmergencyStop),
                |r| r.set_motion_state(MotionState::ForceControlStand),
            ),
            (
                "localisation lost",
                |r| r.set_localized(false),
                |r| r.set_localized(true),
            ),
            (
                "motor over-temperature",
                |r| r.set_motor_temperatures(95.0),
                |r| r.set_motor_temperatures(40.0),
            ),
        ];
        for (name, set, clear) in faults {
            sim.robot(set);
            let lit = leds.until(shared, 3000, |i| i.fault == Led::On).await;
            assert_eq!(lit.fault, Led::On, "{name} lights the fault LED");
            sim.robot(clear);
            let dark = leds.until(shared, 3000, |i| i.fault == Led::Off).await;
            assert_eq!(dark.fault, Led::Off, "{name} cleared");
        }
        sim.robot(|r| r.set_navigation_running(false));
        let unavailable = leds.until(shared, 3000, |i| i.fault == Led::Blink).await;
        assert_eq!(
            unavailable.fault,
            Led::Blink,
            "status unavailable blinks the fault LED"
        );
        sim.robot(|r| r.set_navigation_running(true));
        // The robot goes away: every connection is dropped as soon as it is made.
        sim.set_faults(Faults {
            drop_after: Some(0),
            ..Default::default()
        });
        sim.drop_connections();
        let gone = leds.until(shared, 5000, |i| i.link == Led::Blink).await;
        assert_eq!(gone.link, Led::Blink, "link blinks while reconnecting");
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn every_fault_injection_option_is_survived() {
    let options: [(&str, Faults); 8] = [
        (
            "delay",
            Faults {
                delay: StdDuration::from_millis(200),
                ..Default::default()
            },
        ),
        (
            "garbage",
            Faults {
                garbage: true,
                ..Default::default()
            },
        ),
        (
            "split",
            Faults {
                split: Some(3),
                ..Default::default()
            },
        ),
        (
            "merge",
            Faults {
                merge: true,
                ..Default::default()
            },
        ),
        (
            "unknown items",
            Faults {
                unknown_items: true,
                ..Default::default()
            },
        ),
        (
            "single-quoted declaration",
            Faults {
                declaration: x30_sim::Declaration::Single,
                ..Default::default()
            },
        ),
        (
            "no declaration",
            Faults {
                declaration: x30_sim::Declaration::None,
                ..Default::default()
            },
        ),
        (
            "drop after 5",
            Faults {
                drop_after: Some(5),
                ..Default::default()
            },
        ),
    ];
    for (name, faults) in options {
        let sim = simulator(1.0);
        sim.set_faults(faults);
        with_app(&sim, async |shared| {
            let mut leds = Leds(None);
            let ok = leds.until(shared, 4000, |i| i.link == Led::On).await;
            assert_eq!(ok.link, Led::On, "{name}: status readable");
            press(shared, Button::Forward, true).await;
            sleep(700).await;
            press(shared, Button::Forward, false).await;
            sleep(400).await;
        })
        .await;
        let motion = motion(&sim.requests());
        assert!(
            motion.iter().any(|(_, c)| *c == 1),
            "{name}: forward reached the robot"
        );
        assert_eq!(
            motion.last().map(|(_, c)| *c),
            Some(6),
            "{name}: zero velocity last"
        );
    }
    // An answer of an unknown Type is an error, not a crash: the status stays unreadable.
    let sim = simulator(1.0);
    sim.set_faults(Faults {
        unknown_type: true,
        ..Default::default()
    });
    with_app(&sim, async |shared| {
        let mut leds = Leds(None);
        sleep(1500).await;
        let state = leds.latest(shared).await;
        assert_ne!(state.link, Led::On, "no readable status from unknown Types");
        sim.set_faults(Faults::default());
        let healed = leds.until(shared, 3000, |i| i.link == Led::On).await;
        assert_eq!(
            healed.link,
            Led::On,
            "the same connection works once answers are sane"
        );
    })
    .await;
}

/// A transport to a robot that is not there: every connection attempt is refused and counted.
struct Refused {
    attempts: std::rc::Rc<std::cell::Cell<u32>>,
}

impl embedded_io_async::ErrorType for Refused {
    type Error = embedded_io_async::ErrorKind;
}

impl embedded_io_async::Read for Refused {
    async fn read(&mut self, _: &mut [u8]) -> Result<usize, Self::Error> {
        Err(embedded_io_async::ErrorKind::NotConnected)
    }
}

impl embedded_io_async::Write for Refused {
    async fn write(&mut self, _: &[u8]) -> Result<usize, Self::Error> {
        Err(embedded_io_async::ErrorKind::NotConnected)
    }

    async fn flush(&mut self) -> Result<(), Self::Error> {
        Err(embedded_io_async::ErrorKind::NotConnected)
    }
}

impl x30_panel::client::Transport for Refused {
    async fn connect(&mut self) -> Result<(), Self::Error> {
        self.attempts.set(self.attempts.get() + 1);
        Err(embedded_io_async::ErrorKind::ConnectionRefused)
    }

    async fn close(&mut self) {}
}

#[tokio::test(flavor = "current_thread")]
async fn reconnection_waits_out_the_backoff_even_while_buttons_are_pressed() {
    let attempts = std::rc::Rc::new(std::cell::Cell::new(0));
    let config = Config::default();
    let shared = Shared::new();
    // Attempts at 0, 100, 300 and 700 ms, then every 800 ms: 5 in 1.2 s.
    let backoff = Backoff::new(Duration::from_millis(100), Duration::from_millis(800));
    let mut control = Link::new(
        Refused {
            attempts: attempts.clone(),
        },
        backoff,
    );
    let mut navigation = Link::new(
        Refused {
            attempts: std::rc::Rc::new(std::cell::Cell::new(0)),
        },
        backoff,
    );
    tokio::select! {
        _ = app::run(&config, &mut control, &mut navigation, &shared) => unreachable!(),
        _ = async {
            // A press every 20 ms wakes the control loop 60 times.
            for i in 0..60 {
                press(&shared, Button::Light, i % 2 == 0).await;
                sleep(20).await;
            }
        } => {}
    }
    let made = attempts.get();
    assert!(
        (3..=6).contains(&made),
        "{made} connection attempts in 1.2 s with a 100..800 ms backoff"
    );
}
