//! The binary: starts on the address given, prints it, serves, and honours its flags.

mod common;

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::*;
use x30_panel::proto::codes::{CommandResult, MotionState, NavOutcome, PointInfo};
use x30_panel::proto::message::{MotionCommand, Request, Response};

/// Kills the child this test started when the test ends, however it ends.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts the binary on a free loopback port with `args`; returns it and its address.
fn spawn(args: &[&str]) -> (Running, SocketAddr) {
    let child = Command::new(env!("CARGO_BIN_EXE_x30-sim"))
        .args(["--listen", "127.0.0.1:0"])
        .args(args)
        .stdout(Stdio::piped())
        .spawn()
        .expect("the binary starts");
    let mut running = Running(child);
    let stdout = running.0.stdout.take().unwrap();
    let mut line = String::new();
    BufReader::new(stdout).read_line(&mut line).unwrap();
    let addr = line
        .trim()
        .strip_prefix("x30-sim listening on ")
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"));
    assert!(addr.starts_with("127.0.0.1:"), "{addr}");
    (running, addr.parse().unwrap())
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

#[test]
fn prints_its_address_and_serves() {
    let (_running, addr) = spawn(&["--time-scale", "5", "--declaration", "none"]);
    let mut client = Client::connect(addr);
    client.send(&Request::Status);
    let (_, body) = client.recv_frame_within(TIMEOUT).expect("an answer");
    assert!(
        body.starts_with(b"<PatrolDevice>"),
        "{}",
        String::from_utf8_lossy(&body)
    );
    assert!(matches!(
        Response::decode(&body).unwrap().message,
        Response::Status(s) if s.electricity == Some(90)
    ));
}

#[test]
fn leaves_out_the_items_named() {
    let (_running, addr) = spawn(&[
        "--leave-out",
        "BatteryLevel,Voltage",
        "--leave-out",
        "Cycles",
    ]);
    let mut client = Client::connect(addr);
    client.send(&Request::Battery);
    let (_, body) = client.recv_frame_within(TIMEOUT).expect("an answer");
    let Response::Battery(b) = Response::decode(&body).unwrap().message else {
        panic!("{}", String::from_utf8_lossy(&body));
    };
    assert_eq!(
        (b.battery_level, b.voltage, b.cycles),
        (None, None, None),
        "{b:?}"
    );
    assert!(b.protected_state.is_some() && b.current.is_some(), "{b:?}");
}

#[test]
fn refuses_bad_arguments() {
    for args in [
        &["--time-scale", "0"][..],
        &["--declaration", "triple"],
        &["--split", "0"],
        &["--listen", "nowhere"],
        &["--delay-type", "1002"],
        &["--delay-type", "status=5"],
        &["--delay-type", "1002=-5"],
        &["--refuse-estops", "-1"],
        &["--refuse-for-ms", "soon"],
        // A misspelt item would leave nothing out.
        &["--leave-out", "BatteryLevel,Batterylevel"],
    ] {
        let status = Command::new(env!("CARGO_BIN_EXE_x30-sim"))
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .unwrap();
        assert!(!status.success(), "{args:?}");
    }
}

/// `--delay-type` (repeatable) delays one Type without holding up the others, and
/// `--refuse-estops` refuses that many Command 13s.
#[test]
fn delay_type_and_refuse_estops() {
    let (_running, addr) = spawn(&[
        "--delay-type",
        "1002=500",
        "--delay-type",
        "1008=500",
        "--refuse-estops",
        "1",
    ]);
    let mut client = Client::connect(addr);
    let sent = Instant::now();
    let status = client.send(&Request::Status);
    let battery = client.send(&Request::Battery);
    assert_eq!(client.recv().id, battery);
    assert_eq!(client.recv().id, status);
    assert!(sent.elapsed() >= ms(500), "{:?}", sent.elapsed());
    let refused = client.motion(MotionCommand::SoftEmergencyStop);
    assert_eq!(refused.result, CommandResult::Failure);
    let stopped = client.motion(MotionCommand::SoftEmergencyStop);
    assert_eq!(stopped.result, CommandResult::Success);
    let id = client.send(&Request::Status);
    match client.recv() {
        Answer {
            id: answer_id,
            response: Response::Status(s),
            ..
        } if answer_id == id => assert_eq!(s.motion_state, MotionState::SoftEmergencyStop),
        other => panic!("{other:?}"),
    }
}

/// `--motion-answer-command N`: motion answers name Command N, with the request's ID.
#[test]
fn motion_answer_command() {
    let (_running, addr) = spawn(&["--motion-answer-command", "1"]);
    let mut client = Client::connect(addr);
    let id = client.send(&Request::Motion(MotionCommand::ZeroVelocity));
    let (answer_id, body) = client.recv_frame_within(TIMEOUT).expect("an answer");
    assert_eq!(answer_id, id);
    let body = String::from_utf8(body).unwrap();
    assert!(
        body.contains("<Type>2</Type>") && body.contains("<Command>1</Command>"),
        "{body}"
    );
}

/// `--mute`: the connection is accepted and stays open, but nothing is answered.
#[test]
fn mute() {
    let (_running, addr) = spawn(&["--mute"]);
    let mut client = Client::connect(addr);
    client.send(&Request::Status);
    client.send_raw(b"no header");
    assert!(client.recv_frame_within(ms(500)).is_none());
    // Still open: the request goes out, and nothing comes back, not even a close.
    client.send(&Request::Battery);
    assert!(!client.closed_within(ms(300)));
}

/// `--refuse-for-ms`: connections are closed at once for that long after the start.
#[test]
fn refuse_for_ms() {
    let started = Instant::now();
    let (_running, addr) = spawn(&["--refuse-for-ms", "700"]);
    let mut refused = Client::connect(addr);
    if started.elapsed() < ms(600) {
        assert!(refused.closed_within(ms(5000)), "refused at first");
    }
    std::thread::sleep(ms(900).saturating_sub(started.elapsed()));
    let mut client = Client::connect(addr);
    assert!(matches!(
        client.request(&Request::Battery),
        Response::Battery(_)
    ));
}

/// `--one-at-a-time`: a second connection is answered only once the first closes.
#[test]
fn one_at_a_time() {
    let (_running, addr) = spawn(&["--one-at-a-time"]);
    let mut first = Client::connect(addr);
    first.status();
    let mut second = Client::connect(addr);
    second.send(&Request::Battery);
    assert!(second.recv_frame_within(ms(300)).is_none());
    drop(first);
    assert!(second.recv_frame_within(ms(5000)).is_some());
}

/// `--max-connections 1`: a second connection is closed unread while the first is open,
/// and a connection made after the first closed is served.
#[test]
fn max_connections() {
    let (_running, addr) = spawn(&["--max-connections", "1"]);
    let mut first = Client::connect(addr);
    first.status();
    let mut second = Client::connect(addr);
    second.send(&Request::Battery);
    assert!(second.recv_frame_within(ms(1000)).is_none());
    first.status();
    drop(first);
    let mut third = None;
    for _ in 0..50 {
        std::thread::sleep(ms(20));
        let mut client = Client::connect(addr);
        client.send(&Request::Battery);
        if client.recv_frame_within(ms(200)).is_some() {
            third = Some(client);
            break;
        }
    }
    assert!(
        third.is_some(),
        "no connection served after the first closed"
    );
}

/// `--hang-after-ms`: a connection open at the hang goes unanswered, a new one is served.
#[test]
fn hang_after_ms() {
    let (_running, addr) = spawn(&["--hang-after-ms", "500"]);
    let mut open = Client::connect(addr);
    open.status();
    std::thread::sleep(Duration::from_millis(600));
    open.send(&Request::Battery);
    assert!(open.recv_frame_within(Duration::from_millis(500)).is_none());
    Client::connect(addr).status();
}

/// `--newest-only`: a new connection closes the one before.
#[test]
fn newest_only() {
    let (_running, addr) = spawn(&["--newest-only"]);
    let mut first = Client::connect(addr);
    first.status();
    let mut second = Client::connect(addr);
    second.status();
    first.send(&Request::Battery);
    assert!(first.recv_frame_within(ms(1000)).is_none());
}

#[test]
fn unreachable_points_fail_tasks_with_41804() {
    let (_running, addr) = spawn(&[
        "--time-scale",
        "20",
        "--unreachable",
        "7",
        "--unreachable",
        "-2",
    ]);
    let mut client = Client::connect(addr);
    for value in [7, -2] {
        let id = client.start_task(&[point(value, 1.0, 0.0, PointInfo::Task)]);
        let result = client.task_result(id, TIMEOUT);
        assert_eq!(result.value, value);
        assert_nav(&result, NavOutcome::Failed, 41804);
    }
    let id = client.start_task(&[point(8, 1.0, 0.0, PointInfo::Task)]);
    assert_nav(
        &client.task_result(id, TIMEOUT),
        NavOutcome::Succeeded,
        8960,
    );
}
