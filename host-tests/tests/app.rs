//! The whole panel application against x30-sim over loopback: hold-to-move rate, release,
//! e-stop, outages, reconnection, navigation cancel, LEDs, and the simulator's faults.

mod common;
// The store's tests use the whole simulated chip; these only a blank one.
#[path = "common/peer.rs"]
mod peer;
#[allow(dead_code)]
#[path = "common/sim_flash.rs"]
mod sim_flash;
#[path = "common/steady.rs"]
mod steady;
#[path = "common/terminal.rs"]
mod terminal;

use common::TokioTransport;
use embassy_time::{Duration, Instant};
use peer::{answer, read_request, read_request_within};
use std::io::Write as _;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration as StdDuration;
use x30_panel::app::{self, Connections, Path, STOP_RETRY, Shared};
use x30_panel::client::{Backoff, Connection};
use x30_panel::config::{Config, DEFAULT_LIGHTS};
use x30_panel::panel::NetworkState;
use x30_panel::panel::control::ESTOP_LIGHT;
use x30_panel::panel::{Button, ButtonEvent, Indicators, Led};
use x30_panel::proto::codes::{
    CommandResult, GaitState, MotionGait, MotionState, ObsState, PointInfo, RequestErrorCode,
};
use x30_panel::proto::frame::FrameDecoder;
use x30_panel::proto::message::{
    Direction, MotionAck, MotionCommand, NavPoint, Perception, Request, RequestError, Response,
    RobotStatus, Speed,
};
use x30_sim::{Config as SimConfig, Faults, LogEntry, Simulator};

use sim_flash::{PAGE, SimFlash};
use steady::steady;
use terminal::{Keyboard, Screen};
use x30_panel::config::RobotAddress;
use x30_panel::console;
use x30_panel::settings::Settings;
use x30_panel::settings::desk::Desk;
use x30_panel::settings::store::Store;

fn simulator(time_scale: f64) -> Simulator {
    Simulator::start(SimConfig {
        listen: "127.0.0.1:0".parse().unwrap(),
        time_scale,
        ..Default::default()
    })
    .expect("the simulator starts")
}

/// Reconnection delays of the tests: short, so that outages heal quickly.
fn backoff() -> Backoff {
    Backoff::new(Duration::from_millis(50), Duration::from_millis(400))
}

/// The three connections to `addr`, each reconnecting with `backoff`.
fn links(addr: std::net::SocketAddr, backoff: Backoff) -> Connections<TokioTransport> {
    Connections {
        commands: Connection::new(TokioTransport::new(addr), backoff),
        polls: Connection::new(TokioTransport::new(addr), backoff),
        navigation: Connection::new(TokioTransport::new(addr), backoff),
    }
}

/// The test configuration: the defaults, with a charging point 1 m from the map origin.
fn config() -> Config {
    Config {
        dock: Some(NavPoint::new(1, 1, 1.0, 0.0, 0.0, 0.0, PointInfo::Charging)),
        ..Config::default()
    }
}

/// Puts the simulated robot 19 m from the test's charging point: a task to it runs for
/// half a minute.
fn far_from_dock(sim: &Simulator) {
    sim.robot(|r| {
        r.set_pose(x30_sim::Pose {
            x: 20.0,
            ..Default::default()
        })
    });
}

/// Runs the application against `sim` while `script` runs; returns what the script returns.
async fn with_app<R>(sim: &Simulator, script: impl AsyncFnOnce(&Shared) -> R) -> R {
    with_app_config(sim, &config(), script).await
}

/// [`with_app`] with another configuration.
async fn with_app_config<R>(
    sim: &Simulator,
    config: &Config,
    script: impl AsyncFnOnce(&Shared) -> R,
) -> R {
    with_app_links(&mut links(sim.addr(), backoff()), config, script).await
}

/// [`with_app_config`] on connections of the caller's.
async fn with_app_links<R>(
    links: &mut Connections<TokioTransport>,
    config: &Config,
    script: impl AsyncFnOnce(&Shared) -> R,
) -> R {
    let shared = Shared::new();
    shared.set_network(NetworkState::Up);
    steady(async {
        tokio::select! {
            _ = app::run(config, links, &shared) => unreachable!(),
            result = script(&shared) => result,
        }
    })
    .await
}

async fn press(shared: &Shared, button: Button, pressed: bool) {
    shared
        .buttons
        .send(ButtonEvent {
            button,
            pressed,
            at: Instant::now(),
        })
        .await;
}

/// Presses and releases `button`.
async fn click(shared: &Shared, button: Button) {
    press(shared, button, true).await;
    press(shared, button, false).await;
}

async fn sleep(ms: u64) {
    tokio::time::sleep(StdDuration::from_millis(ms)).await;
}

/// Sleeps until `ms` after `start` (not at all if that has passed).
async fn sleep_until(start: std::time::Instant, ms: u64) {
    tokio::time::sleep(StdDuration::from_millis(ms).saturating_sub(start.elapsed())).await;
}

/// Waits until `condition` holds, looking every 20 ms, for at most `limit_ms`; whether it
/// did.
async fn wait_until(limit_ms: u64, condition: impl Fn() -> bool) -> bool {
    for _ in 0..limit_ms / 20 {
        if condition() {
            return true;
        }
        sleep(20).await;
    }
    false
}

/// Waits until `condition` holds on the simulator's request log, for at most `limit_ms`.
async fn wait_for_log(
    sim: &Simulator,
    limit_ms: u64,
    condition: impl Fn(&[LogEntry]) -> bool,
) -> bool {
    wait_until(limit_ms, || condition(&sim.requests())).await
}

/// Waits until a scripted robot has taken up `wanted` (its log `log`), for at most
/// `limit_ms`.
async fn wait_taken_up(log: &Received, limit_ms: u64, wanted: &Request) -> bool {
    wait_until(limit_ms, || {
        log.lock().unwrap().iter().any(|(_, r)| r == wanted)
    })
    .await
}

/// Waits for the first Type 2 request with `command` logged at or after `since`
/// (simulator seconds); its time.
async fn wait_for_command(sim: &Simulator, limit_ms: u64, since: f64, command: i32) -> Option<f64> {
    let found = |l: &[LogEntry]| {
        motion(l)
            .into_iter()
            .find(|(t, c)| *t >= since && *c == command)
            .map(|(t, _)| t)
    };
    wait_for_log(sim, limit_ms, |l| found(l).is_some()).await;
    found(&sim.requests())
}

/// Clicks the e-stop and waits up to `limit_ms` for its Command 13 to reach the robot,
/// which must be within [`STOP_BOUND`] of the click; the click's and the arrival's times
/// (simulator seconds). `what` names the case in the failures.
async fn estop_reaches_the_robot(
    sim: &Simulator,
    shared: &Shared,
    limit_ms: u64,
    what: &str,
) -> (f64, f64) {
    let pressed = sim.elapsed().as_secs_f64();
    click(shared, Button::Estop).await;
    let estop = wait_for_command(sim, limit_ms, pressed, 13)
        .await
        .unwrap_or_else(|| panic!("{what}: the e-stop never reached the robot"));
    assert!(
        estop - pressed < STOP_BOUND,
        "{what}: the e-stop reached the robot {:.3} s after the button",
        estop - pressed
    );
    (pressed, estop)
}

/// Waits for the first request of `message_type` logged at or after `since`; its time.
async fn wait_for_type(
    sim: &Simulator,
    limit_ms: u64,
    since: f64,
    message_type: i32,
) -> Option<f64> {
    let found = |l: &[LogEntry]| {
        l.iter()
            .find(|e| e.t >= since && e.message_type == Some(message_type))
            .map(|e| e.t)
    };
    wait_for_log(sim, limit_ms, |l| found(l).is_some()).await;
    found(&sim.requests())
}

/// Waits until the panel polls the robot.
async fn wait_connected(sim: &Simulator) {
    assert!(
        wait_for_log(sim, 3000, |l| polls(l, 1002) > 0).await,
        "the panel polls the robot"
    );
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

/// The command path's progress after `ms` milliseconds minus the count before.
async fn beats_during(shared: &Shared, ms: u64) -> u32 {
    let before = shared.progress(Path::Commands);
    sleep(ms).await;
    shared.progress(Path::Commands).wrapping_sub(before)
}

#[tokio::test(flavor = "current_thread")]
async fn command_path_progress_moves_while_connected_and_while_the_robot_is_away() {
    // Connected and idle: the command loop turns at least every 500 ms.
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
    let mut links = links(closed, backoff());
    let away = steady(async {
        tokio::select! {
            _ = app::run(&config, &mut links, &shared) => unreachable!(),
            beats = beats_during(&shared, 1500) => beats,
        }
    })
    .await;
    assert!(away >= 3, "{away} beats in 1.5 s without a robot");
}

/// Connected and idle, the application waits for its next deadline or the robot's next
/// answer: it is polled a few dozen times a second, as often as those come, and never
/// polled again at once by a wake of its own (about 200 000 times a second if it were).
#[tokio::test(flavor = "current_thread")]
async fn an_idle_panel_waits_between_its_deadlines() {
    let sim = simulator(1.0);
    let mut links = links(sim.addr(), backoff());
    let shared = Shared::new();
    shared.set_network(NetworkState::Up);
    let config = config();
    let polled = std::cell::Cell::new(0u32);
    let mut app = std::pin::pin!(app::run(&config, &mut links, &shared));
    let counted = std::future::poll_fn(|cx| {
        polled.set(polled.get() + 1);
        app.as_mut().poll(cx)
    });
    let (polls, answered) = steady(async {
        tokio::select! {
            _ = counted => unreachable!(),
            window = async {
                wait_connected(&sim).await;
                let (polls, answered) = (polled.get(), sim.requests().len());
                sleep(2000).await;
                (polled.get() - polls, sim.requests().len() - answered)
            } => window,
        }
    })
    .await;
    assert!(answered > 0, "the robot was polled");
    assert!(polls <= 200, "{polls} polls in 2 s for {answered} answers");
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
async fn a_robot_that_hangs_up_after_each_answer_is_not_flooded_and_stops_still_go_at_once() {
    let sim = simulator(1.0);
    // Every connection: the first request answered, the second closes it.
    sim.set_faults(Faults {
        drop_after: Some(2),
        ..Default::default()
    });
    let (connections, pressed, estop) = with_app(&sim, async |shared| {
        sleep(2000).await;
        let connections: std::collections::BTreeSet<_> =
            sim.requests().iter().map(|e| e.conn).collect();
        let pressed = sim.elapsed().as_secs_f64();
        press(shared, Button::Estop, true).await;
        let estop = wait_for_command(&sim, 1000, pressed, 13).await;
        sleep(1000).await;
        (connections.len(), pressed, estop)
    })
    .await;
    // Until a status confirms it, the e-stop goes out every 250 ms, and first on each new
    // command connection, which the robot also hangs up: not much more often than that.
    let estops = motion(&sim.requests())
        .iter()
        .filter(|(t, c)| *c == 13 && *t >= pressed && *t < pressed + 1.0)
        .count();
    assert!((1..=10).contains(&estops), "{estops} e-stops in 1 s");
    // The poll connection lasts a few milliseconds each time: it waits out the backoff
    // (50, 100, 200, 400, 400 ms...), about eight connections in 2 s, not hundreds.
    assert!(
        (2..=14).contains(&connections),
        "{connections} connections in 2 s"
    );
    let estop = estop.expect("Command 13 was sent");
    assert!(
        estop - pressed < 0.2,
        "the e-stop went out {} s after the press",
        estop - pressed
    );
}

/// What a scripted robot received, and when (seconds from the test's start).
type Received = Arc<Mutex<Vec<(f64, Request)>>>;

/// Where a scripted robot writes down what it receives.
#[derive(Clone)]
struct Recorder {
    start: std::time::Instant,
    log: Received,
}

impl Recorder {
    /// Writes down `request`, received now.
    fn record(&self, request: Request) {
        let at = self.start.elapsed().as_secs_f64();
        self.log.lock().unwrap().push((at, request));
    }
}

/// A robot on loopback, run by `serve` on a thread of its own with its listener and a
/// recorder that times from `start`; its address, and the recorder's log.
fn scripted_robot(
    start: std::time::Instant,
    serve: impl FnOnce(std::net::TcpListener, Recorder) + Send + 'static,
) -> (std::net::SocketAddr, Received) {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let log = Received::default();
    let recorder = Recorder {
        start,
        log: log.clone(),
    };
    std::thread::spawn(move || serve(listener, recorder));
    (addr, log)
}

/// A robot on loopback that answers every request with Type 0 and hangs up at once;
/// what it received, and when (seconds from `start`).
fn robot_hanging_up_after_each_answer(
    start: std::time::Instant,
) -> (std::net::SocketAddr, Received) {
    scripted_robot(start, |listener, recorder| {
        for stream in listener.incoming().take(1000) {
            let Ok(mut stream) = stream else { return };
            let recorder = recorder.clone();
            std::thread::spawn(move || {
                let Some((id, request)) = read_request(&mut stream, &mut FrameDecoder::new())
                else {
                    return;
                };
                recorder.record(request);
                let refused = Response::RequestError(RequestError {
                    code: RequestErrorCode::ParseFailed,
                });
                let _ = stream.write_all(&answer(id, &refused));
            });
        }
    })
}

/// A robot that serves one connection at a time, in the order they came, as a
/// single-threaded server does: the others wait in its backlog, connected but unread. It
/// closes the first connection at once, so that it serves the next, the polls', while the
/// panel's new command connection waits behind it. It answers a status with `MotionState` (6
/// once an e-stop came), a perception poll with the way clear, a Type 2 with success and
/// anything else with a Type 0; what it received, with the time, and how many connections
/// it has begun to serve.
fn robot_serving_one_connection_at_a_time(
    start: std::time::Instant,
) -> (std::net::SocketAddr, Received, Arc<AtomicUsize>) {
    let served = Arc::new(AtomicUsize::new(0));
    let counted = Arc::clone(&served);
    let (addr, log) = scripted_robot(start, move |listener, recorder| {
        let mut state = MotionState::StandingUp;
        for (made, stream) in listener.incoming().take(100).enumerate() {
            let Ok(stream) = stream else { return };
            if made == 0 {
                continue;
            }
            counted.fetch_add(1, Ordering::SeqCst);
            serve_in_order(stream, &recorder, &mut state);
        }
    });
    (addr, log, served)
}

/// Answers the requests of `stream` as they come ([`scripted_answer`]) until it closes,
/// or no request comes for 5 s; records each.
fn serve_in_order(mut stream: std::net::TcpStream, recorder: &Recorder, state: &mut MotionState) {
    let mut decoder = FrameDecoder::new();
    while let Some((id, request)) = read_request(&mut stream, &mut decoder) {
        let response = scripted_answer(&request, state);
        recorder.record(request);
        if stream.write_all(&answer(id, &response)).is_err() {
            break;
        }
    }
}

/// A robot that takes one client at a time: a connection made while it serves one is
/// closed at once, unread. It closes the first connection too, so that it serves the next,
/// the polls', and every new command connection is closed while it does. Answers as
/// [`scripted_answer`]; what it received, with the time, and how many connections were
/// made to it.
fn robot_taking_one_client_at_a_time(
    start: std::time::Instant,
) -> (std::net::SocketAddr, Received, Arc<AtomicUsize>) {
    let connections = Arc::new(AtomicUsize::new(0));
    let counted = Arc::clone(&connections);
    let (addr, log) = scripted_robot(start, move |listener, recorder| {
        let busy = Arc::new(AtomicBool::new(false));
        let state = Arc::new(Mutex::new(MotionState::StandingUp));
        for (made, stream) in listener.incoming().take(1000).enumerate() {
            let Ok(stream) = stream else { return };
            counted.fetch_add(1, Ordering::SeqCst);
            if made == 0 || busy.swap(true, Ordering::SeqCst) {
                continue;
            }
            let (busy, state, recorder) = (Arc::clone(&busy), Arc::clone(&state), recorder.clone());
            std::thread::spawn(move || {
                serve_in_order(stream, &recorder, &mut state.lock().unwrap());
                busy.store(false, Ordering::SeqCst);
            });
        }
    });
    (addr, log, connections)
}

/// When a scripted robot's handler of a connection wedges ([`robot_wedging`]).
#[derive(Clone)]
enum Wedge {
    /// Just before the first request `.0` there: on the first such connection only, or on
    /// every one (`.1`).
    Before(Box<Request>, bool),
    /// At the first request there this long after the start, on every connection accepted
    /// before then: the robot's handlers hung all at once.
    At(StdDuration),
    /// At the first request there this long after the start, on every connection: the
    /// robot reads nothing anywhere from then on.
    From(StdDuration),
    /// Just before the first request `.1` there, having answered the motion it read from
    /// `.0` after the start only once `.1` came: the answer to a repeat written just before
    /// an e-stop comes after the e-stop, and the handler hangs.
    AnsweringMotionLate(StdDuration, Box<Request>),
}

/// A robot whose handler of a connection wedges, as if it had stopped reading just before
/// a request, when `wedge` says: it neither takes that request up nor answers it, and reads
/// no more there, the connection left open. It serves the others, each on a thread of its
/// own, as [`scripted_answer`] says. What it took up, with the time, and how many
/// connections it accepted.
fn robot_wedging(
    start: std::time::Instant,
    wedge: Wedge,
) -> (std::net::SocketAddr, Received, Arc<AtomicUsize>) {
    let accepted = Arc::new(AtomicUsize::new(0));
    let counted = Arc::clone(&accepted);
    let (addr, log) = scripted_robot(start, move |listener, recorder| {
        let wedged = Arc::new(AtomicBool::new(false));
        for stream in listener.incoming().take(100) {
            let Ok(mut stream) = stream else { return };
            counted.fetch_add(1, Ordering::SeqCst);
            let accepted_at = start.elapsed();
            let (wedged, recorder, wedge) = (Arc::clone(&wedged), recorder.clone(), wedge.clone());
            std::thread::spawn(move || {
                let mut state = MotionState::StandingUp;
                let mut decoder = FrameDecoder::new();
                // Motion answers `Wedge::AnsweringMotionLate` holds back.
                let mut held = Vec::new();
                while let Some((id, request)) = read_request(&mut stream, &mut decoder) {
                    let wedges = match &wedge {
                        Wedge::Before(before, every) => {
                            request == **before && (!wedged.swap(true, Ordering::SeqCst) || *every)
                        }
                        Wedge::At(at) => accepted_at < *at && start.elapsed() >= *at,
                        Wedge::From(at) => start.elapsed() >= *at,
                        Wedge::AnsweringMotionLate(_, before) => {
                            request == **before && !wedged.swap(true, Ordering::SeqCst)
                        }
                    };
                    if wedges {
                        let _ = stream.write_all(&held);
                        // Open and unread until the test is over.
                        std::thread::sleep(StdDuration::from_secs(30));
                        return;
                    }
                    let holds = matches!(&wedge, Wedge::AnsweringMotionLate(from, _)
                        if start.elapsed() >= *from
                            && matches!(request, Request::Motion(MotionCommand::Move(..))));
                    let response = scripted_answer(&request, &mut state);
                    recorder.record(request);
                    if holds {
                        held.extend(answer(id, &response));
                    } else if stream.write_all(&answer(id, &response)).is_err() {
                        break;
                    }
                }
            });
        }
    });
    (addr, log, accepted)
}

/// A robot that reads motion commands (Type 2) and answers none, on any connection; it
/// answers everything else as [`scripted_answer`] says, each connection on a thread of its
/// own. What it received, with the time.
fn robot_answering_no_motion(start: std::time::Instant) -> (std::net::SocketAddr, Received) {
    scripted_robot(start, |listener, recorder| {
        for stream in listener.incoming().take(100) {
            let Ok(mut stream) = stream else { return };
            let recorder = recorder.clone();
            std::thread::spawn(move || {
                let mut state = MotionState::StandingUp;
                let mut decoder = FrameDecoder::new();
                while let Some((id, request)) = read_request(&mut stream, &mut decoder) {
                    recorder.record(request.clone());
                    if matches!(request, Request::Motion(_)) {
                        continue;
                    }
                    let response = scripted_answer(&request, &mut state);
                    if stream.write_all(&answer(id, &response)).is_err() {
                        break;
                    }
                }
            });
        }
    })
}

/// A scripted robot's answer to `request`: a status with `MotionState` `state` (6 once an
/// e-stop came), a perception poll with the way clear, a Type 2 with success and anything
/// else with a Type 0.
fn scripted_answer(request: &Request, state: &mut MotionState) -> Response {
    match *request {
        Request::Status => Response::Status(RobotStatus {
            motion_state: *state,
            ..RobotStatus::UNAVAILABLE
        }),
        Request::Perception => Response::Perception(Perception {
            obs_state: ObsState::Clear,
        }),
        Request::Motion(command) => {
            if command == MotionCommand::SoftEmergencyStop {
                *state = MotionState::SoftEmergencyStop;
            }
            Response::Motion(
                command.code(),
                MotionAck {
                    value: None,
                    result: CommandResult::Success,
                },
            )
        }
        _ => Response::RequestError(RequestError {
            code: RequestErrorCode::ParseFailed,
        }),
    }
}

/// What a robot took up, connection by connection: when each connection opened (seconds
/// from the start) and each request as the robot came to it, with the time.
type TakenUp = Arc<Mutex<Vec<(f64, usize, Option<Request>)>>>;

/// A robot that serves every connection, each on a thread of its own that takes one
/// request at a time, as it is read, and answers it before reading the next, as a simple
/// threaded server does; a status takes it 30 s, anything else no time. Answers as
/// [`scripted_answer`]. Its address, and what it took up.
fn robot_answering_in_order_with_a_slow_status(
    start: std::time::Instant,
) -> (std::net::SocketAddr, TakenUp) {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let log = TakenUp::default();
    let taken_up = log.clone();
    std::thread::spawn(move || {
        for (conn, stream) in listener.incoming().take(100).enumerate() {
            let Ok(mut stream) = stream else { return };
            let log = log.clone();
            let record = move |request| {
                let at = start.elapsed().as_secs_f64();
                log.lock().unwrap().push((at, conn, request));
            };
            record(None);
            std::thread::spawn(move || {
                let mut state = MotionState::ForceControlStand;
                let mut decoder = FrameDecoder::new();
                let idle = StdDuration::from_secs(60);
                while let Some((id, request)) = read_request_within(&mut stream, &mut decoder, idle)
                {
                    record(Some(request.clone()));
                    if request == Request::Status {
                        std::thread::sleep(StdDuration::from_secs(30));
                    }
                    let response = scripted_answer(&request, &mut state);
                    if stream.write_all(&answer(id, &response)).is_err() {
                        break;
                    }
                }
            });
        }
    });
    (addr, taken_up)
}

/// A robot slow to answer the status on every connection, and answering each connection's
/// requests in order, looks from the poll connection like one that does not serve it: the
/// polls move to the command connection. The first status there waits too: the polls go
/// back for good and the command connection is reopened, so an e-stop pressed afterwards is
/// not left waiting behind that status, and reaches the robot at once.
#[tokio::test(flavor = "current_thread")]
async fn a_stop_never_waits_behind_a_slow_status_carried_on_the_command_connection() {
    let start = std::time::Instant::now();
    let (addr, log) = robot_answering_in_order_with_a_slow_status(start);
    // The command connection, open from the start, comes to its first request, the status,
    // long after it opened; a poll connection comes to its status at once.
    let carried = |log: &TakenUp| {
        let log = log.lock().unwrap();
        let opened = |conn| {
            log.iter()
                .find(|e| e.1 == conn && e.2.is_none())
                .map(|e| e.0)
        };
        log.iter()
            .find(|(t, conn, request)| {
                *request == Some(Request::Status) && opened(*conn).is_some_and(|at| t - at > 5.0)
            })
            .map(|e| e.0)
    };
    let pressed = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        // Two poll connections find no answer (1.5 s, then 3 s waits): about 9.5 s.
        wait_until(15_000, || carried(&log).is_some()).await;
        // The status waits 0.5 s there: the command connection is reopened. (Without, it
        // would be given up on as silent 2 s after the status, the e-stop waiting till then.)
        sleep(700).await;
        let pressed = start.elapsed().as_secs_f64();
        click(shared, Button::Estop).await;
        sleep(1000).await;
        pressed
    })
    .await;
    assert!(
        carried(&log).is_some(),
        "the status was never written on the command connection: {:?}",
        log.lock().unwrap()
    );
    let estop = log
        .lock()
        .unwrap()
        .iter()
        .find(|e| e.0 >= pressed && e.2 == Some(Request::Motion(MotionCommand::SoftEmergencyStop)))
        .map(|e| e.0 - pressed);
    assert!(
        estop.is_some_and(|after| after < STOP_BOUND),
        "the e-stop reached the robot {estop:?} s after the press: {:?}",
        log.lock().unwrap()
    );
}

/// A robot that stops reading the command connection just before a release's zero
/// velocity never gets it there. Half a second later the panel leaves that connection and
/// writes the zero velocity again, first thing on the next one, though the release was long
/// taken; without, the robot never gets it (and not before the seconds of silence that give
/// a connection up, 1.75 s, without the move).
#[tokio::test(flavor = "current_thread")]
async fn a_zero_velocity_a_wedged_robot_never_read_goes_out_again_on_the_next_connection() {
    let start = std::time::Instant::now();
    let zero = Request::Motion(MotionCommand::ZeroVelocity);
    let (addr, log, _) = robot_wedging(start, Wedge::Before(Box::new(zero.clone()), false));
    let released = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        wait_taken_up(&log, 3000, &Request::Status).await;
        press(shared, Button::Forward, true).await;
        sleep(600).await;
        let released = start.elapsed().as_secs_f64();
        press(shared, Button::Forward, false).await;
        wait_taken_up(&log, 3000, &zero).await;
        released
    })
    .await;
    let log = log.lock().unwrap();
    let forward = Request::Motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    assert!(
        log.iter().any(|(t, r)| *r == forward && *t < released),
        "the robot drove: {log:?}"
    );
    let after = log
        .iter()
        .find(|(_, r)| *r == zero)
        .map(|(t, _)| t - released);
    assert!(
        after.is_some_and(|after| after < 1.2),
        "the zero velocity reached the robot {after:?} s after the release: {log:?}"
    );
}

/// Waits for the scripted robot whose log is `log` to take up a status, then clicks forward
/// and waits for it to take up the zero velocity: the command connection has been answered
/// on.
async fn drive_briefly(shared: &Shared, log: &Received) {
    wait_taken_up(log, 3000, &Request::Status).await;
    click(shared, Button::Forward).await;
    wait_taken_up(log, 3000, &Request::Motion(MotionCommand::ZeroVelocity)).await;
    sleep(100).await;
}

/// A robot that answered on the command connection, then stops reading it just before an
/// e-stop (a handler that hung), gets the e-stop on a new connection half a second later,
/// not after the seconds of silence that give a connection up (1.75 s without).
#[tokio::test(flavor = "current_thread")]
async fn an_estop_a_wedged_robot_never_read_goes_on_a_new_connection_at_once() {
    let start = std::time::Instant::now();
    let estop = Request::Motion(MotionCommand::SoftEmergencyStop);
    let (addr, log, _) = robot_wedging(start, Wedge::Before(Box::new(estop), false));
    let after = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        drive_briefly(shared, &log).await;
        estop_taken_up_after(shared, &log, start).await
    })
    .await;
    assert!(
        after.is_some_and(|after| after < 1.2),
        "the e-stop reached the robot {after:?} s after the press: {log:?}"
    );
}

/// A robot that answers the motion repeat written just before an e-stop only after the
/// e-stop reached it, then hangs, gets the e-stop's repeat on a new connection half a second
/// after that repeat was written: the answer that came after the first e-stop says nothing
/// of the repeat, which it never read. (The first e-stop hid it until it was given up on,
/// 1.5 s after the press.)
#[tokio::test(flavor = "current_thread")]
async fn an_estop_behind_a_repeats_late_answer_goes_on_a_new_connection_at_once() {
    let start = std::time::Instant::now();
    let estop = Request::Motion(MotionCommand::SoftEmergencyStop);
    let wedge = Wedge::AnsweringMotionLate(StdDuration::from_secs(2), Box::new(estop));
    let (addr, log, _) = robot_wedging(start, wedge);
    let forward = Request::Motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    let after = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        drive_briefly(shared, &log).await;
        sleep_until(start, 2000).await;
        let since = log.lock().unwrap().len();
        press(shared, Button::Forward, true).await;
        assert!(
            wait_until(3000, || log.lock().unwrap()[since..]
                .iter()
                .any(|(_, r)| *r == forward))
            .await,
            "the robot read the forward"
        );
        estop_taken_up_after(shared, &log, start).await
    })
    .await;
    assert!(
        after.is_some_and(|after| after < 1.2),
        "the e-stop reached the robot {after:?} s after the press: {log:?}"
    );
}

/// A robot whose command handler hangs while the panel is idle (the command connection,
/// never answered on, no longer read; the polls' still served) gets an e-stop at once: the
/// poll connection carries it too. Without, it waited for the poll connection to give way
/// and the command connection to be given up as silent: 1.75 s.
#[tokio::test(flavor = "current_thread")]
async fn an_estop_reaches_at_once_a_robot_that_hung_only_the_idle_command_connection() {
    let start = std::time::Instant::now();
    let estop = Request::Motion(MotionCommand::SoftEmergencyStop);
    let (addr, log, _) = robot_wedging(start, Wedge::Before(Box::new(estop), false));
    let after = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        wait_taken_up(&log, 3000, &Request::Status).await;
        estop_taken_up_after(shared, &log, start).await
    })
    .await;
    assert!(
        after.is_some_and(|after| after < STOP_BOUND),
        "the e-stop reached the robot {after:?} s after the press: {log:?}"
    );
}

/// A stop written on a command connection the robot has not answered on yet goes on the
/// poll connection too; once the command connection has answered, on it alone.
#[tokio::test(flavor = "current_thread")]
async fn a_stop_goes_on_the_poll_connection_too_until_the_command_connection_answers() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        let connections_of = |since: f64, command: i32| {
            connections(&sim.requests(), |e| {
                e.t >= since && e.command == Some(command)
            })
        };
        let (pressed, _) = estop_reaches_the_robot(&sim, shared, 2000, "idle panel").await;
        sleep(300).await;
        let polled_on = sim
            .requests()
            .iter()
            .rev()
            .find(|e| e.message_type == Some(1002))
            .map(|e| e.conn);
        let estops = connections_of(pressed, 13);
        assert!(
            estops.len() == 2 && estops.contains(&polled_on.unwrap_or(0)),
            "the first e-stop on the command connection and the poll connection: {estops:?}"
        );
        // Confirmed by a status (2 Hz); released once the robot has left soft e-stop.
        sleep(1000).await;
        sim.robot(|r| r.set_motion_state(MotionState::StandingUp));
        sleep(1000).await;
        let pressed = sim.elapsed().as_secs_f64();
        click(shared, Button::Forward).await;
        assert!(
            wait_for_command(&sim, 2000, pressed, 6).await.is_some(),
            "the release's zero velocity"
        );
        sleep(300).await;
        assert_eq!(
            connections_of(pressed, 6).len(),
            1,
            "the zero velocity on the command connection alone, which answered the forward"
        );
    })
    .await;
}

/// A robot that answers polls and no motion at all never answers the command connection:
/// the poll connection, having carried a release's zero velocity too, gives way to it once,
/// for at most 2 s. Without that limit, the status was never read again after the release.
#[tokio::test(flavor = "current_thread")]
async fn a_robot_answering_no_motion_keeps_its_status_polled_after_a_release() {
    status_polled_long_after(Button::Forward).await;
}

/// As [`a_robot_answering_no_motion_keeps_its_status_polled_after_a_release`], with an
/// e-stop, which such a robot never confirms: the poll connection gives way to it 2 s at a
/// time, and polls in between. Without that limit, it stayed away for good.
#[tokio::test(flavor = "current_thread")]
async fn a_robot_answering_no_motion_keeps_its_status_polled_after_an_estop() {
    status_polled_long_after(Button::Estop).await;
}

/// Clicks `button` on a panel driving a robot that answers polls and no motion
/// ([`robot_answering_no_motion`]), and checks that its status is still polled 6 to 8 s
/// later.
async fn status_polled_long_after(button: Button) {
    let start = std::time::Instant::now();
    let (addr, log) = robot_answering_no_motion(start);
    let clicked = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        wait_taken_up(&log, 3000, &Request::Status).await;
        click(shared, button).await;
        let clicked = start.elapsed().as_secs_f64();
        // A zero velocity goes out once more on the next command connection, after the
        // first is given up on (about 2 s); an e-stop repeats until the end.
        sleep(8000).await;
        clicked
    })
    .await;
    let log = log.lock().unwrap();
    let last_status = log
        .iter()
        .filter(|(_, r)| *r == Request::Status)
        .map(|(t, _)| t - clicked)
        .fold(f64::MIN, f64::max);
    assert!(
        last_status > 6.0,
        "the last status was polled {last_status:.3} s after the click: {log:?}"
    );
}

/// Presses the e-stop and waits for the scripted robot whose log is `log` (its times from
/// `start`) to take it up: how long after the press it did, if it did within 3 s.
async fn estop_taken_up_after(
    shared: &Shared,
    log: &Received,
    start: std::time::Instant,
) -> Option<f64> {
    let estop = Request::Motion(MotionCommand::SoftEmergencyStop);
    let pressed = start.elapsed().as_secs_f64();
    press(shared, Button::Estop, true).await;
    wait_taken_up(log, 3000, &estop).await;
    let log = log.lock().unwrap();
    log.iter()
        .find(|(_, r)| *r == estop)
        .map(|(t, _)| t - pressed)
}

/// A robot that stops reading every connection at its first e-stop gets one new connection
/// for it half a second after the press, not one every half second: the new one, never
/// answered on, waits for the seconds of silence, as any connection does.
#[tokio::test(flavor = "current_thread")]
async fn an_estop_goes_on_a_new_connection_once_until_the_robot_answers_again() {
    let start = std::time::Instant::now();
    let estop = Request::Motion(MotionCommand::SoftEmergencyStop);
    let (addr, log, accepted) = robot_wedging(start, Wedge::Before(Box::new(estop), true));
    let opened = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        drive_briefly(shared, &log).await;
        let before = accepted.load(Ordering::SeqCst);
        press(shared, Button::Estop, true).await;
        // One move at 0.5 s; without the limit, more at 1 s and 1.5 s. The moved e-stop's
        // connection falls silent at about 2.25 s.
        sleep(1900).await;
        accepted.load(Ordering::SeqCst) - before
    })
    .await;
    assert_eq!(opened, 1, "connections opened after the press");
}

/// A robot whose handlers all hang while the panel is idle stops answering the poll
/// connection first: the idle command connection, which it no longer reads either, is
/// reopened then, so that an e-stop pressed afterwards reaches the robot at once (without,
/// after the seconds of silence that give the old connection up: 1.75 s).
#[tokio::test(flavor = "current_thread")]
async fn an_estop_after_the_robot_stopped_answering_polls_goes_on_a_fresh_connection() {
    let start = std::time::Instant::now();
    let (addr, log, accepted) = robot_wedging(start, Wedge::At(StdDuration::from_secs(1)));
    let after = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        wait_taken_up(&log, 3000, &Request::Status).await;
        let before = accepted.load(Ordering::SeqCst);
        // The polls go unanswered from 1 s, and their connection is given up about 3.5 s
        // later: a new poll connection, and with the fix a new command connection.
        wait_until(6000, || accepted.load(Ordering::SeqCst) > before).await;
        sleep(200).await;
        estop_taken_up_after(shared, &log, start).await
    })
    .await;
    assert!(
        after.is_some_and(|after| after < 1.0),
        "the e-stop reached the robot {after:?} s after the press: {log:?}"
    );
}

/// A robot whose handlers all hang just before an e-stop, the panel idle, reads neither
/// the command connection (never answered on) nor the poll connection: the e-stop goes on
/// a new connection once a poll has waited half a second too, not after the seconds of
/// silence that give the old one up (1.75 s without).
#[tokio::test(flavor = "current_thread")]
async fn an_estop_pressed_as_the_robot_hangs_goes_on_a_new_connection_soon() {
    let start = std::time::Instant::now();
    let (addr, log, _) = robot_wedging(start, Wedge::At(StdDuration::from_secs(1)));
    let after = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        wait_taken_up(&log, 3000, &Request::Status).await;
        // Just after the hang, seconds before the poll connection is given up as silent:
        // a poll written within half a second of it waits with the e-stop.
        sleep_until(start, 1300).await;
        estop_taken_up_after(shared, &log, start).await
    })
    .await;
    assert!(
        after.is_some_and(|after| after < 1.2),
        "the e-stop reached the robot {after:?} s after the press: {log:?}"
    );
}

/// A robot that reads nothing anywhere from just before an e-stop gets one new command
/// connection for it, not one each time a new poll has waited half a second too: the
/// e-stop moves once until the robot answers on the command connection.
#[tokio::test(flavor = "current_thread")]
async fn an_estop_moves_once_to_a_robot_reading_nothing() {
    let start = std::time::Instant::now();
    let (addr, log, accepted) = robot_wedging(start, Wedge::From(StdDuration::from_secs(1)));
    let opened = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        wait_taken_up(&log, 3000, &Request::Status).await;
        sleep_until(start, 1300).await;
        let before = accepted.load(Ordering::SeqCst);
        press(shared, Button::Estop, true).await;
        // The move comes at about 1.8 s. The first poll left unread (written at 1 s) times
        // out 1.5 s later, and the next has waited half a second at about 3 s: without the
        // limit, a second move then. The moved e-stop's connection is given up as silent
        // 1.75 s after it opened (about 3.6 s), the poll connection at 4 s.
        sleep_until(start, 3300).await;
        accepted.load(Ordering::SeqCst) - before
    })
    .await;
    assert_eq!(opened, 1, "connections opened after the press");
}

/// The stop path wins the robot's connection: a robot that serves one connection at a time
/// and is serving the polls' gets an e-stop at once, on the poll connection, which carries it
/// too (without, not until the poll connection gave way, or closed).
#[tokio::test(flavor = "current_thread")]
async fn an_estop_gets_the_connection_of_a_robot_that_serves_one_at_a_time() {
    estop_gets_the_connection_of(robot_serving_one_connection_at_a_time).await;
}

/// A robot that serves one connection at a time, serving the polls', gets an e-stop at once
/// on the poll connection, which confirms it; the e-stop written on the command connection
/// still waits there, and the poll connection gives way to it, so that the robot takes the
/// command connection up and motion can reach it later. Without, the confirmed e-stop left
/// the poll connection in place, and the command connection unread for good.
#[tokio::test(flavor = "current_thread")]
async fn a_robot_serving_one_at_a_time_takes_the_command_connection_up_after_an_estop() {
    let start = std::time::Instant::now();
    let (addr, log, served) = robot_serving_one_connection_at_a_time(start);
    let (after, taken_up) =
        with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
            wait_taken_up(&log, 3000, &Request::Status).await;
            let before = served.load(Ordering::SeqCst);
            let after = estop_taken_up_after(shared, &log, start).await;
            let taken_up = wait_until(3000, || served.load(Ordering::SeqCst) > before).await;
            (after, taken_up)
        })
        .await;
    assert!(
        after.is_some_and(|after| after < STOP_BOUND),
        "the e-stop reached the robot {after:?} s after the press"
    );
    assert!(taken_up, "the robot took another connection up: {log:?}");
}

/// A robot that serves one connection at a time, serving the command connection (which the
/// panel opens first), never reads the poll connection: the command connection then carries
/// the polls, so the status is read and an e-stop is confirmed (and stops repeating), and
/// the e-stop still goes out at once. Without, no status is ever read and the e-stop
/// repeats for ever.
#[tokio::test(flavor = "current_thread")]
async fn the_command_connection_carries_the_polls_of_a_robot_serving_only_it() {
    polls_carried_for(|f| f.one_at_a_time = true).await;
}

/// As [`the_command_connection_carries_the_polls_of_a_robot_serving_only_it`], with a robot
/// that closes every connection made while it serves one.
#[tokio::test(flavor = "current_thread")]
async fn the_command_connection_carries_the_polls_of_a_robot_taking_one_client() {
    polls_carried_for(|f| f.max_connections = Some(1)).await;
}

/// Checks that a simulated robot with the faults `faults` has its status read on the
/// command connection, and an e-stop confirmed there.
async fn polls_carried_for(faults: impl FnOnce(&mut Faults)) {
    let sim = simulator(1.0);
    sim.update_faults(faults);
    with_app(&sim, async |shared| {
        let mut leds = Leds(None);
        // Two poll connections go silent (the first in about 3 s, two polls given up on;
        // the second, waiting twice as long, about 6 s later), or are closed at once.
        assert!(
            wait_for_log(&sim, 15_000, |l| polls(l, 1002) >= 2).await,
            "the status is polled"
        );
        assert_eq!(
            leds.until(shared, 3000, |i| i.link == Led::On).await.link,
            Led::On,
            "the link LED shows the robot answering"
        );
        let (pressed, estop) =
            estop_reaches_the_robot(&sim, shared, 2000, "commands carrying the polls").await;
        sleep(3000).await;
        let log = sim.requests();
        let estops: Vec<&LogEntry> = log
            .iter()
            .filter(|e| e.t >= pressed && e.command == Some(13))
            .collect();
        let status_on = |conn| {
            log.iter()
                .any(|e| e.t > estop && e.conn == conn && e.message_type == Some(1002))
        };
        assert!(
            status_on(estops[0].conn),
            "the status is polled on the e-stop's connection"
        );
        // Confirmed by the next status (2 Hz): one e-stop, or a repeat or two meanwhile.
        assert!(
            estops.len() <= 3,
            "{} e-stops in 3 s: confirmed, not repeated for ever",
            estops.len()
        );
    })
    .await;
}

/// A robot that keeps only its newest connection closes one of the panel's each time
/// another opens. After two such losses in a row the command connection carries the polls
/// and stays the only one: held motion then goes out at its rate, the release stops it,
/// and the status is read. Without, the connections take turns closing each other and the
/// held forward never reaches the robot.
#[tokio::test(flavor = "current_thread")]
async fn a_robot_keeping_only_its_newest_connection_is_driven_on_one() {
    let sim = simulator(1.0);
    sim.update_faults(|f| f.newest_only = true);
    with_app(&sim, async |shared| {
        assert!(
            wait_for_log(&sim, 5000, |l| polls(l, 1002) >= 2).await,
            "the status is polled"
        );
        sleep(1000).await;
        let connections = sim.requests().iter().map(|e| e.conn).max();
        let pressed = sim.elapsed().as_secs_f64();
        press(shared, Button::Forward, true).await;
        sleep(2000).await;
        let released = sim.elapsed().as_secs_f64();
        press(shared, Button::Forward, false).await;
        let zero = wait_for_command(&sim, 1000, released, 6).await;
        sleep(1000).await;
        let log = sim.requests();
        let forward = motion(&log)
            .into_iter()
            .filter(|&(t, c)| c == 1 && (pressed..released).contains(&t))
            .count();
        assert!((6..=10).contains(&forward), "{forward} forwards in 2 s");
        assert!(
            zero.is_some_and(|t| t - released < STOP_BOUND),
            "zero velocity {zero:?} after the release at {released:.3}"
        );
        assert_eq!(
            log.iter().map(|e| e.conn).max(),
            connections,
            "no connection opened while driving"
        );
        assert!(
            log.iter()
                .any(|e| e.t > released && e.message_type == Some(1002)),
            "the status is still polled"
        );
    })
    .await;
}

/// The stop path wins the connection of a robot that takes one client at a time, serving
/// the polls' and closing every new command connection at once: the e-stop, written on each
/// and read on none, goes on the poll connection too (and the poll connection gives way to
/// the command connection's, which has waited since the first).
#[tokio::test(flavor = "current_thread")]
async fn an_estop_gets_the_connection_of_a_robot_that_takes_one_client_at_a_time() {
    estop_gets_the_connection_of(robot_taking_one_client_at_a_time).await;
}

/// An e-stop pressed while the command connection is being reopened goes on the poll
/// connection at once, not at the next attempt, a quarter of a second later: here a robot
/// that takes one client at a time, serving the polls', has just closed a command connection.
#[tokio::test(flavor = "current_thread")]
async fn an_estop_pressed_while_the_command_connection_reopens_goes_on_the_poll_connection() {
    let start = std::time::Instant::now();
    let (addr, log, made) = robot_taking_one_client_at_a_time(start);
    // Attempts a second apart once the robot has closed a few.
    let backoff = Backoff::new(Duration::from_millis(50), Duration::from_secs(1));
    let after = with_app_links(&mut links(addr, backoff), &config(), async |shared| {
        wait_taken_up(&log, 3000, &Request::Status).await;
        sleep(2000).await;
        let before = made.load(Ordering::SeqCst);
        wait_until(3000, || made.load(Ordering::SeqCst) > before).await;
        // The panel has seen the connection closed, and waits to try again: a stop pressed
        // now ends the wait a quarter of a second after this attempt.
        sleep(20).await;
        estop_taken_up_after(shared, &log, start).await
    })
    .await;
    assert!(
        after.is_some_and(|after| after < 0.15),
        "the e-stop reached the robot {after:?} s after the press: {log:?}"
    );
}

/// Checks that an e-stop pressed while the scripted `robot` serves the poll connection
/// reaches it within [`STOP_BOUND`].
async fn estop_gets_the_connection_of(
    robot: fn(std::time::Instant) -> (std::net::SocketAddr, Received, Arc<AtomicUsize>),
) {
    let start = std::time::Instant::now();
    let (addr, log, _) = robot(start);
    let status_read = |log: &[(f64, Request)]| log.iter().any(|(_, r)| *r == Request::Status);
    let served_polls = async || {
        wait_taken_up(&log, 3000, &Request::Status).await;
    };
    let estops = estops_after_press(addr, start, &log, served_polls, 3000).await;
    assert!(
        status_read(&log.lock().unwrap()),
        "the robot served the poll connection"
    );
    let estop = estops.first().copied();
    assert!(
        estop.is_some_and(|after| after < STOP_BOUND),
        "the e-stop reached the robot {estop:?} s after the press"
    );
}

/// Runs the application against the scripted robot at `addr`, whose log `log` times from
/// `start`; presses e-stop once `before` is done, and runs on for `after_ms`. When the robot
/// received each e-stop, in seconds after the press.
async fn estops_after_press(
    addr: std::net::SocketAddr,
    start: std::time::Instant,
    log: &Received,
    before: impl AsyncFnOnce(),
    after_ms: u64,
) -> Vec<f64> {
    let pressed = with_app_links(&mut links(addr, backoff()), &config(), async |shared| {
        before().await;
        let pressed = start.elapsed().as_secs_f64();
        press(shared, Button::Estop, true).await;
        sleep(after_ms).await;
        pressed
    })
    .await;
    log.lock()
        .unwrap()
        .iter()
        .filter(|(_, r)| *r == Request::Motion(MotionCommand::SoftEmergencyStop))
        .map(|(t, _)| t - pressed)
        .collect()
}

#[tokio::test(flavor = "current_thread")]
async fn a_pending_estop_is_not_sent_faster_than_it_repeats_to_a_robot_hanging_up_each_time() {
    let start = std::time::Instant::now();
    let (addr, log) = robot_hanging_up_after_each_answer(start);
    let estops = estops_after_press(addr, start, &log, async || sleep(500).await, 1000).await;
    let log = log.lock().unwrap();
    // Never confirmed, so repeated for the whole second: every 250 ms, and first on each
    // new connection, which the robot hangs up at once; not as fast as it can reconnect.
    assert!(
        estops.first().is_some_and(|&t| (0.0..0.2).contains(&t)),
        "the first e-stop at once: {estops:?}"
    );
    assert!(
        (3..=10).contains(&estops.len()),
        "{} e-stops in 1 s",
        estops.len()
    );
    let polls = log
        .iter()
        .filter(|(_, r)| matches!(r, Request::Status))
        .count();
    assert!(polls <= 15, "{polls} status polls in 1.5 s");
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

/// `robot-light` on: the robot's light turns red once a status confirmed the e-stop,
/// written after Command 13 on the command connection, and back to the first preset once
/// the latch is released.
#[tokio::test(flavor = "current_thread")]
async fn robot_light_shows_a_confirmed_estop_after_its_command_13() {
    let sim = simulator(1.0);
    let config = Config {
        robot_light: true,
        ..config()
    };
    let lights = |log: &[LogEntry]| -> Vec<LogEntry> {
        log.iter()
            .filter(|e| e.message_type == Some(1101))
            .cloned()
            .collect()
    };
    let pressed = with_app_config(&sim, &config, async |shared| {
        wait_connected(&sim).await;
        let pressed = sim.elapsed().as_secs_f64();
        press(shared, Button::Estop, true).await;
        assert!(
            wait_for_log(&sim, 3000, |l| lights(l).len() == 1).await,
            "red once confirmed"
        );
        press(shared, Button::Estop, false).await;
        sim.robot(|r| r.set_motion_state(MotionState::LyingDown));
        assert!(
            wait_for_log(&sim, 3000, |l| lights(l).len() == 2).await,
            "the preset after the unlock"
        );
        sleep(500).await;
        pressed
    })
    .await;
    let log = sim.requests();
    // The e-stop may go on the poll connection too (the command connection has answered
    // nothing yet): the light goes on the command connection alone.
    let estops: Vec<_> = log
        .iter()
        .filter(|e| e.t >= pressed && e.message_type == Some(2) && e.command == Some(13))
        .collect();
    let first = estops.first().expect("Command 13 was sent");
    let lit = lights(&log);
    assert_eq!(lit.len(), 2, "once each: {lit:?}");
    assert_eq!(lit[0].request, Some(Request::Light(ESTOP_LIGHT)));
    assert_eq!(lit[1].request, Some(Request::Light(DEFAULT_LIGHTS[0])));
    assert!(lit[0].t > first.t, "{lit:?} {estops:?}");
    assert!(
        lit.iter().all(|l| estops.iter().any(|e| e.conn == l.conn)),
        "on a connection that carried Command 13: {lit:?} {estops:?}"
    );
    // Not before a status said so.
    assert!(
        log.iter()
            .any(|e| e.message_type == Some(1002) && e.t > first.t && e.t < lit[0].t),
        "{log:?}"
    );
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
        sim.refuse_connections(StdDuration::from_millis(1000));
        sleep(300).await;
        // While the robot refuses every connection, press lie-down and light: one-shots that
        // cannot go out within 300 ms of the press.
        click(shared, Button::LieDown).await;
        click(shared, Button::Light).await;
        sleep(700).await;
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
    assert_eq!(
        polls(&sim.requests(), 1101),
        0,
        "nor the light pressed during the outage"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn navigation_task_docks_and_is_cancelled_from_the_panel() {
    let sim = simulator(1.0);
    far_from_dock(&sim);
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
async fn a_dock_point_saved_right_before_dock_is_pressed_is_the_one_used() {
    let sim = simulator(1.0);
    far_from_dock(&sim);
    with_app(&sim, async |shared| {
        assert!(wait_for_log(&sim, 3000, |l| polls(l, 1002) > 0).await);
        // Saved and pressed with no turn for the application in between, as a console's
        // "saved" and a press that follows it can reach the application together.
        shared.apply_settings(Config {
            dock: Some(NavPoint::new(7, 2, 3.0, 0.0, 0.0, 0.0, PointInfo::Charging)),
            ..config()
        });
        click(shared, Button::Dock).await;
        assert!(wait_for_log(&sim, 2000, |l| polls(l, 1003) == 1).await);
    })
    .await;
    let sent = sim.requests().into_iter().find_map(|e| match e.request {
        Some(Request::NavTask(task)) => task.points.first().map(|p| (p.value, p.map_id)),
        _ => None,
    });
    assert_eq!(sent, Some((7, 2)), "the dock point saved before the press");
}

#[tokio::test(flavor = "current_thread")]
async fn motion_press_during_navigation_cancels_the_task_first() {
    let sim = simulator(1.0);
    far_from_dock(&sim);
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

/// Robots whose status answers carry nothing readable but `MotionState`: they leave the
/// rest out, or write their floats with a decimal comma.
fn motion_state_alone() -> [(&'static str, Faults); 2] {
    [
        (
            "status with MotionState alone",
            Faults {
                sparse_status: true,
                ..Default::default()
            },
        ),
        (
            "decimal commas",
            Faults {
                decimal_comma: true,
                ..Default::default()
            },
        ),
    ]
}

/// Runs the app against a simulator with `faults`, and `script` once the link LED says the
/// robot's status is readable (asserted, naming the robot `name`); returns the simulator,
/// whose log tells what reached it.
async fn with_faulty_robot(
    name: &str,
    faults: Faults,
    script: impl AsyncFnOnce(&Shared, &Simulator, &mut Leds),
) -> Simulator {
    let sim = simulator(1.0);
    sim.set_faults(faults);
    with_app(&sim, async |shared| {
        let mut leds = Leds(None);
        let ok = leds.until(shared, 4000, |i| i.link == Led::On).await;
        assert_eq!(ok.link, Led::On, "{name}: the status is readable");
        script(shared, &sim, &mut leds).await;
    })
    .await;
    sim
}

#[tokio::test(flavor = "current_thread")]
async fn every_fault_injection_option_is_survived() {
    let options: [(&str, Faults); 12] = [
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
            "empty frames sharing the answers' message IDs",
            Faults {
                empty_frames: true,
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
            "a copy cut short before each answer",
            Faults {
                cut_frames: true,
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
            "reserved header bytes set",
            Faults {
                reserved_bytes: true,
                ..Default::default()
            },
        ),
        (
            "unknown pose",
            Faults {
                unknown_pose: true,
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
    for (name, faults) in options.into_iter().chain(motion_state_alone()) {
        let sim = with_faulty_robot(name, faults, async |shared, _, _| {
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

    fn set_robot(&mut self, _: x30_panel::config::RobotAddress) {}
}

/// Connection attempts made in 1.2 s to a robot that refuses every connection, with a
/// backoff of `min_ms..max_ms`, while `button` is pressed and released every 20 ms (or
/// pressed once and held, for the e-stop).
async fn attempts_while_pressing(button: Button, min_ms: u64, max_ms: u64) -> u32 {
    let attempts = std::rc::Rc::new(std::cell::Cell::new(0));
    let config = Config::default();
    let shared = Shared::new();
    let backoff = Backoff::new(Duration::from_millis(min_ms), Duration::from_millis(max_ms));
    let refused = |attempts| Connection::new(Refused { attempts }, backoff);
    let mut links = Connections {
        commands: refused(attempts.clone()),
        polls: refused(std::rc::Rc::new(std::cell::Cell::new(0))),
        navigation: refused(std::rc::Rc::new(std::cell::Cell::new(0))),
    };
    steady(async {
        tokio::select! {
            _ = app::run(&config, &mut links, &shared) => unreachable!(),
            _ = async {
                for i in 0..60 {
                    if button != Button::Estop || i == 0 {
                        press(&shared, button, i % 2 == 0 || button == Button::Estop).await;
                    }
                    sleep(20).await;
                }
            } => {}
        }
    })
    .await;
    attempts.get()
}

#[tokio::test(flavor = "current_thread")]
async fn reconnection_waits_out_the_backoff_even_while_buttons_are_pressed() {
    // Attempts at 0, 100, 300 and 700 ms, then every 800 ms: 5 in 1.2 s.
    let made = attempts_while_pressing(Button::Light, 100, 800).await;
    assert!(
        (3..=6).contains(&made),
        "{made} connection attempts in 1.2 s with a 100..800 ms backoff"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn a_pending_estop_retries_the_connection_at_least_every_250_ms() {
    // The backoff alone would try at 0 and 2 s: one attempt in 1.2 s. With the e-stop
    // waiting to go out, the panel tries every 250 ms instead.
    let made = attempts_while_pressing(Button::Estop, 2000, 10_000).await;
    assert!(
        (3..=7).contains(&made),
        "{made} connection attempts in 1.2 s with an e-stop waiting"
    );
}

/// Latencies, in seconds, from each press to the first matching request in the simulator's
/// log: forward press → Command 1, forward release → Command 6, e-stop press → Command 13.
async fn stop_path_latencies(sim: &Simulator, shared: &Shared) -> [f64; 3] {
    let pressed = sim.elapsed().as_secs_f64();
    press(shared, Button::Forward, true).await;
    let forward = wait_for_command(sim, 2000, pressed, 1)
        .await
        .expect("forward sent");
    sleep(600).await;
    let released = sim.elapsed().as_secs_f64();
    press(shared, Button::Forward, false).await;
    let zero = wait_for_command(sim, 2000, released, 6)
        .await
        .expect("zero velocity sent");
    sleep(300).await;
    let estop_pressed = sim.elapsed().as_secs_f64();
    press(shared, Button::Estop, true).await;
    let estop = wait_for_command(sim, 2000, estop_pressed, 13)
        .await
        .expect("e-stop sent");
    press(shared, Button::Estop, false).await;
    [forward - pressed, zero - released, estop - estop_pressed]
}

/// Stops must reach the robot within this of the press (the bound the stop paths are held
/// to, docs/design.md "Stop paths"; generous for a
/// shared machine, while a stop behind a slow answer would take the 1.2 s the answer takes).
const STOP_BOUND: f64 = 0.3;

#[tokio::test(flavor = "current_thread")]
async fn commands_do_not_wait_behind_slow_status_answers() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        sim.set_faults(Faults {
            type_delays: vec![(1002, StdDuration::from_millis(1200))],
            ..Default::default()
        });
        sleep(500).await;
        let latencies = stop_path_latencies(&sim, shared).await;
        for (what, latency) in ["forward", "zero velocity", "e-stop"].iter().zip(latencies) {
            assert!(
                latency < STOP_BOUND,
                "{what} reached the robot {latency:.3} s after the button"
            );
        }
    })
    .await;
}

/// Lets the panel meet the robot for 6 s (the first time round every poll is due, and
/// each that fails costs its wait), then checks 6 s of polling: the status at least 6
/// times (12 at its 500 ms), `failing` at most twice. Then an e-stop is confirmed by a
/// status poll, so it stops repeating: within the status period plus at most one failing
/// poll's 1.5 s wait. Returns the log of the 6 s.
async fn check_the_status_is_not_starved(
    sim: &Simulator,
    shared: &Shared,
    failing: i32,
) -> Vec<LogEntry> {
    wait_connected(sim).await;
    sleep(6000).await;
    let start = sim.elapsed().as_secs_f64();
    sleep(6000).await;
    let log: Vec<LogEntry> = sim
        .requests()
        .into_iter()
        .filter(|e| e.t >= start)
        .collect();
    let count = |message_type: i32| {
        log.iter()
            .filter(|e| e.message_type == Some(message_type))
            .count()
    };
    assert!(count(1002) >= 6, "status polls in 6 s: {}", count(1002));
    assert!(
        count(failing) <= 2,
        "{failing} polls in 6 s: {}",
        count(failing)
    );
    click(shared, Button::Estop).await;
    assert!(
        wait_for_log(sim, 3000, |_| sim.snapshot().motion_state
            == MotionState::SoftEmergencyStop)
        .await,
        "the robot is in soft e-stop"
    );
    let stopped = sim.elapsed().as_secs_f64();
    sleep(3000).await;
    let last = motion(&sim.requests())
        .into_iter()
        .filter(|(_, c)| *c == 13)
        .map(|(t, _)| t)
        .fold(0.0, f64::max);
    assert!(
        last - stopped < 2.5,
        "e-stops repeated until {last:.2} s, the robot stopped at {stopped:.2} s"
    );
    log
}

/// An older `robot_server` ignores the Types it does not know: those polls are never
/// answered. They are asked less and less often, the status goes between them, and the
/// connection, which is answering, is kept.
#[tokio::test(flavor = "current_thread")]
async fn polls_the_robot_never_answers_back_off_and_never_starve_the_status() {
    let sim = simulator(1.0);
    let never = StdDuration::from_secs(3600);
    sim.set_faults(Faults {
        type_delays: vec![(2001, never), (2002, never), (1008, never)],
        ..Default::default()
    });
    let log = with_app(&sim, async |shared| {
        check_the_status_is_not_starved(&sim, shared, 2002).await
    })
    .await;
    let connections: std::collections::BTreeSet<_> = log.iter().map(|e| e.conn).collect();
    assert_eq!(
        connections.len(),
        1,
        "the answering robot is not reconnected to"
    );
}

/// A `robot_server` that ignores one Type of the command connection (here the light's,
/// 1101, which older ones do not know) keeps answering the motion commands around it: the
/// held button's repeats go on at their rate instead of pausing until the light's request
/// is given up on, and the answering connection is kept.
#[tokio::test(flavor = "current_thread")]
async fn a_command_the_robot_never_answers_does_not_hold_up_motion() {
    let sim = simulator(1.0);
    sim.set_faults(Faults {
        type_delays: vec![(1101, StdDuration::from_secs(3600))],
        ..Default::default()
    });
    let (start, end) = with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        press(shared, Button::Forward, true).await;
        sleep(300).await;
        let start = sim.elapsed().as_secs_f64();
        click(shared, Button::Light).await;
        sleep(2500).await;
        let end = sim.elapsed().as_secs_f64();
        press(shared, Button::Forward, false).await;
        sleep(200).await;
        (start, end)
    })
    .await;
    let log = sim.requests();
    assert!(
        log.iter().any(|e| e.message_type == Some(1101)),
        "the light's request went out"
    );
    let forward: Vec<f64> = motion(&log)
        .into_iter()
        .filter(|&(t, c)| c == 1 && (start..end).contains(&t))
        .map(|(t, _)| t)
        .collect();
    let longest_gap = forward.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
    // At 4 Hz, 2.5 s hold 10 repeats 0.25 s apart; held back until the light's request is
    // given up on (1.5 s), they would pause for about a second.
    assert!(
        forward.len() >= 8 && longest_gap < 0.6,
        "{} forward commands, longest gap {longest_gap:.2} s",
        forward.len()
    );
    assert_eq!(
        command_connections(&log),
        1,
        "the command connection is kept"
    );
}

/// How many connections carried Type 2 requests.
fn command_connections(log: &[LogEntry]) -> usize {
    connections(log, |e| e.message_type == Some(2)).len()
}

/// The connections that carried a request `which` picks.
fn connections(
    log: &[LogEntry],
    which: impl Fn(&LogEntry) -> bool,
) -> std::collections::BTreeSet<u64> {
    log.iter().filter(|e| which(e)).map(|e| e.conn).collect()
}

/// Against a robot that never answers Type `ignored` and answers the rest: clicks `first`,
/// waits `after_ms`, holds forward for `hold_ms`; the requests logged, and when the click was.
async fn forward_after_an_unanswered(
    ignored: i32,
    first: Button,
    after_ms: u64,
    hold_ms: u64,
) -> (Vec<LogEntry>, f64) {
    let sim = simulator(1.0);
    sim.set_faults(Faults {
        type_delays: vec![(ignored, StdDuration::from_secs(3600))],
        ..Default::default()
    });
    let clicked = with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        let clicked = sim.elapsed().as_secs_f64();
        click(shared, first).await;
        sleep(after_ms).await;
        press(shared, Button::Forward, true).await;
        sleep(hold_ms).await;
        press(shared, Button::Forward, false).await;
        sleep(200).await;
        clicked
    })
    .await;
    (sim.requests(), clicked)
}

/// When each Type 2 request with `command` came, in seconds after `since`.
fn commands_after(log: &[LogEntry], since: f64, command: i32) -> Vec<f64> {
    motion(log)
        .into_iter()
        .filter(|&(t, c)| t >= since && c == command)
        .map(|(t, _)| t - since)
        .collect()
}

/// The same robot, with forward pressed after the light: held back while the light's answer
/// is overdue, the forward goes out once that request is given up on (a Type the robot
/// ignores says nothing of motion), and the connection is kept.
#[tokio::test(flavor = "current_thread")]
async fn motion_pressed_after_an_ignored_light_goes_out_once_the_light_is_given_up_on() {
    let (log, light_at) = forward_after_an_unanswered(1101, Button::Light, 700, 2300).await;
    let forward = commands_after(&log, light_at, 1);
    // Given up on at 1.5 s; from then to the release at 3.0 s, about six repeats at 4 Hz.
    assert!(
        forward.iter().filter(|&&t| t > 1.4).count() >= 4,
        "forward after the light was given up on: {forward:?} s"
    );
    assert_eq!(
        command_connections(&log),
        1,
        "the command connection is kept"
    );
}

/// A stricter `robot_server` hangs up on a Type it does not know. The poll lost with the
/// connection goes first on the next one only once; lost again, it backs off like an
/// unanswered one, instead of being the only thing ever asked.
#[tokio::test(flavor = "current_thread")]
async fn a_poll_the_robot_hangs_up_on_backs_off_and_never_starves_the_status() {
    let sim = simulator(1.0);
    sim.set_faults(Faults {
        hang_up_on: vec![1008],
        ..Default::default()
    });
    with_app(&sim, async |shared| {
        check_the_status_is_not_starved(&sim, shared, 1008).await
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn stops_reach_a_half_open_robot_at_once_and_the_silence_is_detected() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        let mut leds = Leds(None);
        wait_connected(&sim).await;
        assert_eq!(
            leds.until(shared, 3000, |i| i.link == Led::On).await.link,
            Led::On
        );
        // The robot reads but never answers from now on.
        sim.set_faults(Faults {
            mute: true,
            ..Default::default()
        });
        let muted_at = sim.elapsed().as_secs_f64();
        let latencies = stop_path_latencies(&sim, shared).await;
        for (what, latency) in ["forward", "zero velocity", "e-stop"].iter().zip(latencies) {
            assert!(
                latency < STOP_BOUND,
                "{what} reached the muted robot {latency:.3} s after the button"
            );
        }
        let silent = leds
            .until(shared, 5000, |i| {
                i.link == Led::BlinkFast || i.link == Led::Blink
            })
            .await;
        assert_ne!(
            silent.link,
            Led::On,
            "the link LED shows the robot not answering"
        );
        // Silence closes the connections and opens new ones.
        let newest =
            |l: &[LogEntry], before: f64| l.iter().filter(|e| e.t < before).map(|e| e.conn).max();
        let old = newest(&sim.requests(), muted_at).expect("connections before the silence");
        assert!(
            wait_for_log(&sim, 6000, |l| l.iter().any(|e| e.conn > old)).await,
            "the panel reconnects to a silent robot"
        );
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn a_stop_pressed_while_waiting_to_reconnect_to_a_silent_robot_goes_out_at_once() {
    let sim = simulator(1.0);
    // A backoff far longer than a stop may wait: the stop must not wait it out.
    let backoff = Backoff::new(Duration::from_secs(3), Duration::from_secs(5));
    with_app_links(&mut links(sim.addr(), backoff), &config(), async |shared| {
        wait_connected(&sim).await;
        sleep(300).await;
        let open = sim.connections();
        sim.set_faults(Faults {
            mute: true,
            ..Default::default()
        });
        // A command the robot never answers: given up on after 1.5 s, the connection is
        // silent and closed, well before the polls' (2 s of silence). Not motion: the
        // zero velocity of its release would go once more at once, on a new connection.
        click(shared, Button::LieDown).await;
        let mut closed = false;
        for _ in 0..400 {
            sleep(10).await;
            if sim.connections() < open {
                closed = true;
                break;
            }
        }
        assert!(closed, "the silent command connection is closed");
        let before = sim.requests().iter().map(|e| e.conn).max();
        sleep(100).await;
        let pressed = sim.elapsed().as_secs_f64();
        press(shared, Button::Estop, true).await;
        wait_for_command(&sim, 2000, pressed, 13)
            .await
            .expect("e-stop sent");
        press(shared, Button::Estop, false).await;
        // The poll connection, still open, may carry it too: the new command connection has
        // not answered yet.
        let first = sim
            .requests()
            .into_iter()
            .find(|e| e.t >= pressed && e.command == Some(13) && Some(e.conn) > before)
            .expect("the e-stop on a new command connection");
        // Not even the pace of retries against a refusing robot: nothing refused here.
        assert!(
            first.t - pressed < STOP_RETRY.as_micros() as f64 / 1e6,
            "the e-stop reached the robot {:.3} s after the button, during a 3 s backoff",
            first.t - pressed
        );
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn motion_is_not_written_while_answers_are_overdue() {
    let sim = simulator(1.0);
    let muted_at = with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        sim.set_faults(Faults {
            mute: true,
            ..Default::default()
        });
        let muted_at = sim.elapsed().as_secs_f64();
        press(shared, Button::Forward, true).await;
        sleep(1500).await;
        press(shared, Button::Forward, false).await;
        sleep(200).await;
        muted_at
    })
    .await;
    let forward = motion(&sim.requests())
        .into_iter()
        .filter(|(t, c)| *t >= muted_at && *c == 1)
        .count();
    // At 4 Hz, 1.5 s would be 6 or 7 commands; once the first answer is 0.5 s overdue no more
    // go out, so a robot that wakes up finds no backlog.
    assert!(
        (1..=3).contains(&forward),
        "{forward} forward commands reached a robot that did not answer"
    );
}

/// A robot that names Command 1 in every motion answer (its answers filled in from one
/// template) has still answered: the message ID pairs each answer with its request. The
/// panel shows no failed command and keeps its command connection; taken for no answers,
/// the zero velocity and the e-stop would be given up on, shown as failed, and the
/// connection dropped.
#[tokio::test(flavor = "current_thread")]
async fn motion_answers_naming_another_command_still_answer() {
    let faults = Faults {
        motion_answer_command: Some(1),
        ..Default::default()
    };
    let sim = with_faulty_robot(
        "Command 1 in motion answers",
        faults,
        async |shared, _, _| {
            press(shared, Button::Forward, true).await;
            sleep(600).await;
            press(shared, Button::Forward, false).await;
            sleep(300).await;
            click(shared, Button::Estop).await;
            // Longer than a request's wait (1.5 s) and the silence that gives a connection up
            // (2 s).
            sleep(2600).await;
            let snapshot = shared.snapshot().expect("the application runs");
            assert!(!snapshot.command_failed, "no command shown as failed");
        },
    )
    .await;
    let log = sim.requests();
    let sent = motion(&log);
    assert!(sent.iter().any(|&(_, c)| c == 6), "zero velocity went out");
    assert!(sent.iter().any(|&(_, c)| c == 13), "the e-stop went out");
    assert_eq!(
        command_connections(&log),
        1,
        "the command connection is kept"
    );
}

/// A robot that answers the polls but no command: the zero velocity that went unanswered is
/// given up on after 1.5 s, which does not make the robot answer. A forward held from before
/// that until the panel gives the connection up never reaches it. It is pressed once the
/// zero velocity's answer is well overdue (ANSWER_OVERDUE, 500 ms): before that, one
/// forward may go out by the rule.
#[tokio::test(flavor = "current_thread")]
async fn motion_stays_held_back_after_an_unanswered_command_is_given_up_on() {
    let (log, stopped_at) = forward_after_an_unanswered(2, Button::Stop, 800, 2500).await;
    assert!(
        !commands_after(&log, stopped_at, 6).is_empty(),
        "the zero velocity went out"
    );
    let forward = commands_after(&log, stopped_at, 1);
    assert!(
        forward.is_empty(),
        "forward reached a robot that had answered no command, at {forward:?} s"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn estop_pressed_while_the_robot_refuses_connections_goes_out_first_when_it_is_back() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        sim.refuse_connections(StdDuration::from_millis(1500));
        sleep(200).await;
        press(shared, Button::Estop, true).await;
        sleep(1300).await;
        let back = sim.elapsed().as_secs_f64();
        let estop = wait_for_command(&sim, 5000, back, 13).await;
        assert!(
            estop.is_some(),
            "Command 13 reaches the robot once it is back"
        );
        let first = sim
            .first_on_connection_of(|e| e.t >= back && e.message_type == Some(2))
            .expect("a command connection after the outage");
        assert_eq!(
            (first.message_type, first.command),
            (Some(2), Some(13)),
            "the e-stop is the first request on the new command connection"
        );
        assert!(
            wait_for_log(&sim, 3000, |_| sim.snapshot().motion_state
                == MotionState::SoftEmergencyStop)
            .await
        );
        press(shared, Button::Estop, false).await;
    })
    .await;
}

/// A robot whose status carries nothing readable but `MotionState` (it leaves the rest out,
/// or writes its floats with a decimal comma) still confirms an e-stop, which then stops
/// repeating.
#[tokio::test(flavor = "current_thread")]
async fn an_estop_is_confirmed_by_a_status_whose_motion_state_alone_is_readable() {
    for (name, faults) in motion_state_alone() {
        with_faulty_robot(name, faults, async |shared, sim, leds| {
            let pressed = sim.elapsed().as_secs_f64();
            click(shared, Button::Estop).await;
            sleep(1500).await;
            let estops = commands_after(&sim.requests(), pressed, 13);
            let last = *estops.last().expect("the e-stop went out");
            let now = sim.elapsed().as_secs_f64() - pressed;
            assert!(
                now - last > 0.6,
                "{name}: no more e-stops once the robot confirmed: {estops:?}, now {now:.2}"
            );
            let fault = leds.until(shared, 2000, |i| i.fault == Led::On).await.fault;
            assert_eq!(
                fault,
                Led::On,
                "{name}: the soft e-stop shows on the fault LED"
            );
        })
        .await;
    }
}

#[tokio::test(flavor = "current_thread")]
async fn a_refused_estop_is_repeated_until_the_robot_confirms_it() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        sim.set_faults(Faults {
            refuse_estops: 3,
            ..Default::default()
        });
        let pressed = sim.elapsed().as_secs_f64();
        click(shared, Button::Estop).await;
        assert!(
            wait_for_log(&sim, 5000, |_| sim.snapshot().motion_state
                == MotionState::SoftEmergencyStop)
            .await,
            "the robot ends in soft e-stop"
        );
        sleep(1000).await;
        let estops = commands_after(&sim.requests(), pressed, 13);
        assert!(estops.len() >= 4, "3 refused, then one taken: {estops:?}");
        let gaps: Vec<f64> = estops.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(
            gaps.iter().take(3).all(|g| *g < 0.5),
            "repeated at least every 250 ms (with slack): {gaps:?}"
        );
        let last = *estops.last().unwrap();
        let now = sim.elapsed().as_secs_f64() - pressed;
        assert!(
            now - last > 0.6,
            "no more e-stops once the robot confirmed: last at {last:.2}, now {now:.2}"
        );
    })
    .await;
}

/// Robots that take 2.5 s to answer, past the 1.5 s a request waits at first: one every
/// request, one its status alone, and one each new connection's first requests (3 s to
/// set the client up). Once a connection was given up on as silent, the next waits
/// longer, so the status is read, and an e-stop, which goes out at once as ever, is
/// confirmed and stops repeating.
#[tokio::test(flavor = "current_thread")]
async fn a_robot_that_answers_late_is_read_and_confirms_an_estop() {
    let late = StdDuration::from_millis(2500);
    // (name, faults, whether the connections open when the status is read stay open: the
    // robot that answers the e-stop late gets its command connection given up on once).
    let robots = [
        (
            "every answer late",
            Faults {
                delay: late,
                ..Default::default()
            },
            false,
        ),
        (
            "the status late",
            Faults {
                type_delays: vec![(1002, late)],
                ..Default::default()
            },
            true,
        ),
        (
            "each connection's first answers late",
            Faults {
                warm_up: StdDuration::from_secs(3),
                ..Default::default()
            },
            true,
        ),
    ];
    for (name, faults, steady) in robots {
        let sim = simulator(1.0);
        sim.set_faults(faults);
        with_app(&sim, async |shared| {
            let read = wait_until(15_000, || {
                shared.snapshot().is_some_and(|s| s.status.is_some())
            })
            .await;
            assert!(read, "{name}: the status is read within 15 s");
            let newest = || sim.requests().iter().map(|e| e.conn).max();
            let connections = newest();
            let (pressed, _) = estop_reaches_the_robot(&sim, shared, 1000, name).await;
            // Confirmed by a status 2.5 s late: the repeats end. (Unconfirmed, they go on
            // every 250 ms for as long as the robot is slow.)
            let mut quiet = false;
            for _ in 0..100 {
                sleep(200).await;
                let now = sim.elapsed().as_secs_f64();
                let last = pressed
                    + commands_after(&sim.requests(), pressed, 13)
                        .last()
                        .copied()
                        .unwrap_or(0.0);
                if now - last > 1.0 {
                    quiet = true;
                    break;
                }
            }
            assert!(
                quiet,
                "{name}: the e-stop stops repeating within 20 s: confirmed"
            );
            assert_eq!(sim.snapshot().motion_state, MotionState::SoftEmergencyStop);
            assert!(
                polls(&sim.requests(), 2002) > 0 && polls(&sim.requests(), 2001) > 0,
                "{name}: the obstacle and battery polls are asked too, not the status alone"
            );
            if steady {
                assert_eq!(
                    newest(),
                    connections,
                    "{name}: no connection given up on once the status is read"
                );
            }
        })
        .await;
    }
}

/// Connects, orders the dock task and lets it run 300 ms; the simulator's seconds then.
async fn docking(sim: &Simulator, shared: &Shared) -> f64 {
    wait_connected(sim).await;
    click(shared, Button::Dock).await;
    assert!(
        wait_for_log(sim, 2000, |l| polls(l, 1003) == 1).await,
        "dock sends a 1003"
    );
    sleep(300).await;
    sim.elapsed().as_secs_f64()
}

#[tokio::test(flavor = "current_thread")]
async fn stop_during_a_navigation_task_sends_1004_and_zero_velocity() {
    let sim = simulator(1.0);
    far_from_dock(&sim);
    with_app(&sim, async |shared| {
        let pressed = docking(&sim, shared).await;
        click(shared, Button::Stop).await;
        let cancel = wait_for_type(&sim, 2000, pressed, 1004).await;
        let zero = wait_for_command(&sim, 2000, pressed, 6).await;
        assert!(
            cancel.is_some_and(|t| t - pressed < STOP_BOUND),
            "1004 at once: {cancel:?}"
        );
        assert!(
            zero.is_some_and(|t| t - pressed < STOP_BOUND),
            "zero velocity at once: {zero:?}"
        );
        assert!(
            wait_for_log(&sim, 3000, |_| sim.snapshot().last_task.is_some()).await,
            "the task ends"
        );
    })
    .await;
    let last = sim.snapshot().last_task.expect("the task ended");
    assert_eq!(last.status.raw(), 8962, "cancelled: {last:?}");
}

/// A robot fails a running task in soft e-stop; one that did not would walk on once the
/// e-stop is released. The e-stop ends the panel's task as `stop` does: a 1004 goes out
/// right after the e-stop.
#[tokio::test(flavor = "current_thread")]
async fn estop_during_a_navigation_task_cancels_the_task_after_the_estop() {
    let sim = simulator(1.0);
    far_from_dock(&sim);
    with_app(&sim, async |shared| {
        let pressed = docking(&sim, shared).await;
        press(shared, Button::Estop, true).await;
        let estop = wait_for_command(&sim, 2000, pressed, 13).await;
        let cancel = wait_for_type(&sim, 2000, pressed, 1004).await;
        assert!(
            matches!((estop, cancel), (Some(e), Some(c)) if e <= c && c - pressed < STOP_BOUND),
            "e-stop at {estop:?}, then the 1004 at {cancel:?}"
        );
        press(shared, Button::Estop, false).await;
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn dock_without_a_charging_point_sends_nothing_and_blinks_the_fault_led() {
    let sim = simulator(1.0);
    with_app_config(&sim, &Config::default(), async |shared| {
        let mut leds = Leds(None);
        wait_connected(&sim).await;
        assert_eq!(
            leds.until(shared, 3000, |i| i.fault == Led::Off)
                .await
                .fault,
            Led::Off
        );
        click(shared, Button::Dock).await;
        let shown = leds.until(shared, 2000, |i| i.fault == Led::Blink).await;
        assert_eq!(shown.fault, Led::Blink, "the refused dock shows");
        sleep(500).await;
    })
    .await;
    assert_eq!(
        polls(&sim.requests(), 1003),
        0,
        "no task without a charging point"
    );
}

#[tokio::test(flavor = "current_thread")]
async fn gait_steps_on_from_the_robots_reported_gait() {
    let sim = simulator(1.0);
    // The robot was switched to slope by someone else: the panel's next gait is perception
    // stairs (Command 20 value 4), not the "normal stairs" a local counter would send.
    sim.robot(|r| r.set_gait(GaitState::Slope));
    with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        sleep(600).await;
        let pressed = sim.elapsed().as_secs_f64();
        click(shared, Button::Gait).await;
        assert!(wait_for_command(&sim, 2000, pressed, 20).await.is_some());
    })
    .await;
    let gait = sim
        .requests()
        .into_iter()
        .rev()
        .find_map(|e| match e.request {
            Some(Request::Motion(MotionCommand::SwitchGait(gait))) => Some(gait),
            _ => None,
        })
        .expect("a gait command");
    assert_eq!(gait, MotionGait::PerceptionStairs);
}

/// The loopback address of `sim`, as a robot setting.
fn robot_of(sim: &Simulator) -> RobotAddress {
    RobotAddress {
        ip: [127, 0, 0, 1],
        port: sim.addr().port(),
    }
}

#[tokio::test(flavor = "current_thread")]
async fn a_saved_robot_address_moves_every_connection_at_once() {
    let first = simulator(1.0);
    let second = simulator(1.0);
    with_app(&first, async |shared| {
        wait_connected(&first).await;
        let mut moved = config();
        moved.robot = robot_of(&second);
        shared.apply_settings(moved);
        assert!(
            wait_for_log(&second, 2000, |l| polls(l, 1002) > 0).await,
            "the second robot is polled within 2 s"
        );
        assert!(
            wait_for_log(&second, 1000, |l| polls(l, 2001) > 0 && polls(l, 1008) > 0).await,
            "the second robot is asked its battery and motor temperatures at once, not when \
             the first robot's were next due"
        );
        click(shared, Button::Light).await;
        assert!(
            wait_for_type(&second, 2000, 0.0, 1101).await.is_some(),
            "commands go to the second robot"
        );
        let heard = first.requests().len();
        sleep(700).await;
        assert_eq!(
            first.requests().len(),
            heard,
            "the first robot hears nothing more"
        );
        assert!(
            shared
                .snapshot()
                .is_some_and(|s| s.robot == robot_of(&second)),
            "the console's status names the new robot"
        );
    })
    .await;
}

/// Types each of `lines` on a console next to the application, waiting `gap_ms` after
/// each; the screen.
async fn console_session(shared: &Shared, flash: &SimFlash, lines: &[&str], gap_ms: u64) -> String {
    let mut store = Store::new(flash.clone(), 0..2 * PAGE as u32);
    let mut settings = Settings::new(config());
    let (keyboard, keys) = Keyboard::new();
    let screen = Screen::default();
    let desk = Desk::new();
    let console = console::run(
        keyboard,
        screen.clone(),
        &mut store,
        &mut settings,
        None,
        shared,
        &desk,
    );
    let typing = async {
        for line in lines {
            keys.send(format!("{line}\r").into_bytes()).unwrap();
            sleep(gap_ms).await;
        }
    };
    tokio::select! {
        _ = console => panic!("the console asked for a reboot"),
        () = typing => screen.text(),
    }
}

#[tokio::test(flavor = "current_thread")]
async fn settings_are_not_saved_while_a_motion_button_is_held_and_apply_once_saved() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        let flash = SimFlash::new(2);
        press(shared, Button::Forward, true).await;
        let held = console_session(shared, &flash, &["set speed-forward 0.3", "save"], 100).await;
        assert!(
            held.contains("not saved: a motion button is held"),
            "{held}"
        );
        assert_eq!(flash.log(), [], "the flash is not touched while moving");
        press(shared, Button::Forward, false).await;
        sleep(100).await;

        let quiet = console_session(shared, &flash, &["set speed-forward 0.3", "save"], 100).await;
        assert!(quiet.contains("saved speed-forward in"), "{quiet}");
        let since = sim.elapsed().as_secs_f64();
        press(shared, Button::Forward, true).await;
        assert!(wait_for_command(&sim, 2000, since, 1).await.is_some());
        press(shared, Button::Forward, false).await;
        let speed = sim
            .requests()
            .into_iter()
            .filter(|e| e.t >= since)
            .find_map(|e| match e.request {
                Some(Request::Motion(MotionCommand::Move(_, speed))) => Some(speed),
                _ => None,
            });
        assert_eq!(speed, Some(x30_panel::proto::message::Speed::Value(0.3)));
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn an_unconfirmed_estop_keeps_settings_from_being_saved() {
    let sim = simulator(1.0);
    sim.update_faults(|f| f.refuse_estops = 100);
    with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        press(shared, Button::Estop, true).await;
        let flash = SimFlash::new(2);
        let screen = console_session(shared, &flash, &["set repeat-ms 300", "save"], 100).await;
        assert!(
            screen.contains("not saved: a stop is going out"),
            "{screen}"
        );
        assert_eq!(flash.log(), []);
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn lost_settings_blink_the_fault_led_until_a_save() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        let mut leds = Leds(None);
        let healthy = leds
            .until(shared, 3000, |i| i.link == Led::On && i.fault == Led::Off)
            .await;
        assert_eq!(healthy.fault, Led::Off);
        shared.set_settings_lost(true);
        let lost = leds.until(shared, 1000, |i| i.fault == Led::Blink).await;
        assert_eq!(lost.fault, Led::Blink, "the defaults are in use");

        let flash = SimFlash::new(2);
        let screen = console_session(shared, &flash, &["set repeat-ms 300", "save"], 100).await;
        assert!(screen.contains("saved repeat-ms in"), "{screen}");
        let saved = leds.until(shared, 1000, |i| i.fault == Led::Off).await;
        assert_eq!(saved.fault, Led::Off, "a save rewrote the store");
    })
    .await;
}

#[tokio::test(flavor = "current_thread")]
async fn an_estop_goes_out_at_once_while_the_console_is_flooded() {
    let sim = simulator(1.0);
    with_app(&sim, async |shared| {
        wait_connected(&sim).await;
        let flash = SimFlash::new(2);
        // `show` pasted 5000 times at once: megabytes of answers to write.
        let flood = "show\r".repeat(5000);
        let lines = [flood.as_str()];
        let start = sim.elapsed().as_secs_f64();
        let estop = async {
            // The press is meant for 50 ms in: whatever delays it counts.
            sleep(50).await;
            press(shared, Button::Estop, true).await;
            let sent = wait_for_command(&sim, 5000, start, 13).await;
            sent.map(|t| t - (start + 0.05))
        };
        let (latency, screen) = tokio::join!(estop, console_session(shared, &flash, &lines, 500));
        assert!(screen.len() > 1_000_000, "the console answered the flood");
        let latency = latency.expect("the e-stop went out");
        // Generous: on an idle machine it is a few milliseconds.
        assert!(latency < 0.25, "e-stop took {latency} s behind the console");
    })
    .await;
}
