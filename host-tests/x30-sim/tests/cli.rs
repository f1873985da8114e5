//! The binary: starts on the address given, prints it, serves, and honours its flags.

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

use common::*;
use x30_panel::proto::message::{Request, Response};

/// Kills the child this test started when the test ends, however it ends.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn prints_its_address_and_serves() {
    let child = Command::new(env!("CARGO_BIN_EXE_x30-sim"))
        .args([
            "--listen",
            "127.0.0.1:0",
            "--time-scale",
            "5",
            "--declaration",
            "none",
        ])
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
    let mut client = Client::connect(addr.parse().unwrap());
    client.send(&Request::Status);
    let (_, body) = client.recv_frame_within(TIMEOUT).expect("an answer");
    assert!(
        body.starts_with(b"<PatrolDevice>"),
        "{}",
        String::from_utf8_lossy(&body)
    );
    assert!(matches!(
        Response::decode(&body).unwrap().message,
        Response::Status(s) if s.electricity == 90
    ));
}

#[test]
fn refuses_bad_arguments() {
    for args in [
        &["--time-scale", "0"][..],
        &["--declaration", "triple"],
        &["--split", "0"],
        &["--listen", "nowhere"],
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
