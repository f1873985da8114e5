//! x30ctl against a difficult robot: every fault the simulator can inject, Type 0 answers,
//! refused connections, and `decode` of a messy capture.

mod common;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::mpsc;
use std::thread;
use std::time::Duration;

use common::*;
use x30_panel::proto::codes::{
    CommandResult, ErrorStatus, MotionCommandCode, MotionState, NavOutcome, RequestErrorCode,
};
use x30_panel::proto::frame::{self, HEADER_LEN};
use x30_panel::proto::message::{
    MotionAck, MotionCommand, NavResult, Request, RequestError, Response,
};
use x30_panel::proto::time::Timestamp;
use x30_sim::{Declaration, Faults};

#[test]
fn delay_shorter_than_the_timeout_succeeds_longer_times_out() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        delay: Duration::from_millis(400),
        ..Faults::default()
    });
    x30ctl(&sim, &["--timeout-ms", "150", "status"])
        .expect_code(3)
        .stderr_has("timed out after 150 ms waiting for the answer to Type 1002");
    x30ctl(&sim, &["battery", "--timeout-ms", "150"])
        .expect_code(3)
        .stderr_has("timed out after 150 ms waiting for the answer to Type 2001");
    x30ctl(&sim, &["--timeout-ms", "3000", "status"])
        .expect_code(0)
        .stdout_has("motion state");
}

#[test]
fn drop_after_is_a_clear_connection_closed_error() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        drop_after: Some(1),
        ..Faults::default()
    });
    x30ctl(&sim, &["status"])
        .expect_code(3)
        .stderr_has("connection closed by the robot before answering Type 1002");
    // The task connection dropping is reported the same way for a navigation task.
    x30ctl(&sim, &["nav", "--map-id", "1", "--x", "5", "--y", "0"])
        .expect_code(3)
        .stderr_has("connection closed by the robot before answering Type 1003");
    // A zero-velocity request after a dropped move goes on a new connection.
    sim.set_faults(Faults {
        drop_after: Some(2),
        ..Faults::default()
    });
    x30ctl(&sim, &["move", "forward", "--duration", "2"])
        .expect_code(3)
        .stderr_has("connection closed by the robot before answering Type 2");
    let log = requests_of(&sim, 2, None);
    let stop = log.last().expect("requests");
    assert_eq!(stop.command, Some(6), "{log:?}");
    assert_ne!(
        stop.conn, log[0].conn,
        "zero velocity on a fresh connection"
    );
}

/// A robot that hangs up after an answer (here: it closes each connection at its second
/// request, unanswered) is watched all the same: a request its connection was closed on is
/// asked again at once on a new one. Without, every refresh failed.
#[test]
fn watch_asks_again_on_a_new_connection_what_a_robot_hung_up_on() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        drop_after: Some(2),
        ..Faults::default()
    });
    let run = x30ctl(
        &sim,
        &["watch", "--count", "2", "--interval-ms", "10", "--json"],
    );
    let lines: Vec<&str> = run.stdout.lines().collect();
    assert_eq!(lines.len(), 2, "{}", run.stdout);
    for line in lines {
        assert!(
            ["\"status\"", "\"battery\"", "\"perception\""]
                .iter()
                .all(|item| line.contains(item))
                && !line.contains("\"error\""),
            "{line}"
        );
    }
    run.expect_code(0);
}

/// A robot that serves one request a connection: each command goes on a connection of its
/// own, the robot's close found before it is written. Without, the second command went on
/// the closed connection and the move failed (exit 3).
#[test]
fn move_drives_a_robot_that_hangs_up_after_each_answer() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        hang_up_after_answer: true,
        ..Faults::default()
    });
    x30ctl(&sim, &["move", "forward", "--duration", "1"])
        .expect_code(0)
        .stdout_has("4 command(s) acknowledged; zero velocity (Command 6) acknowledged");
    let log = requests_of(&sim, 2, None);
    let commands: Vec<_> = log.iter().map(|e| e.command).collect();
    assert_eq!(
        commands,
        [Some(1), Some(1), Some(1), Some(1), Some(6)],
        "{log:?}"
    );
    let mut conns: Vec<_> = log.iter().map(|e| e.conn).collect();
    conns.dedup();
    assert_eq!(conns.len(), log.len(), "one connection each: {log:?}");
}

/// The same robot answers Command 13 and hangs up on the status asked with it: the status
/// is asked again at once on a new connection, and the next Command 13 goes on a new one
/// too. Without, the status was never answered and the e-stop never confirmed (exit 3).
#[test]
fn estop_is_confirmed_by_a_robot_that_hangs_up_after_each_answer() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        hang_up_after_answer: true,
        refuse_estops: 1,
        ..Faults::default()
    });
    x30ctl(&sim, &["estop"])
        .expect_code(0)
        .stdout_has("failure (ErrorCode 1)")
        .stdout_has(
            "confirmed: the robot reports soft emergency stop (MotionState 6) after 2 command(s)",
        );
    let estops = requests_of(&sim, 2, Some(13));
    assert_eq!(estops.len(), 2, "{estops:?}");
    assert_ne!(estops[0].conn, estops[1].conn);
    let sent = motion_times(&sim, 13);
    let gap = sent[1] - sent[0];
    assert!((0.15..=0.40).contains(&gap), "gap {gap} s in {sent:?}");
    let statuses = requests_of(&sim, 1002, None);
    let asked_again = statuses
        .iter()
        .filter(|s| estops.iter().all(|e| e.conn != s.conn));
    assert_eq!(
        asked_again.count(),
        2,
        "each e-stop's status asked again on a connection of its own: {statuses:?}"
    );
}

#[test]
fn garbage_before_each_frame_is_skipped() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        garbage: true,
        ..Faults::default()
    });
    x30ctl(&sim, &["status"])
        .expect_code(0)
        .stdout_has("motion state   force-control stand (3)")
        .stderr_has("skipped 8 bytes of garbage before a sync sequence");
    x30ctl(&sim, &["watch", "--count", "2", "--interval-ms", "10"]).expect_code(0);
}

/// A copy of each answer cut short before it (a robot whose write went out in part): the
/// broken frame is skipped with a warning, and the answer after it is read, byte by byte too.
#[test]
fn a_frame_cut_short_before_each_answer_is_skipped() {
    let sim = sim(1.0);
    for split in [None, Some(1)] {
        sim.set_faults(Faults {
            cut_frames: true,
            split,
            ..Faults::default()
        });
        x30ctl(&sim, &["status"])
            .expect_code(0)
            .stdout_has("motion state   force-control stand (3)")
            .stderr_has("skipped a frame cut short (message ID");
    }
}

#[test]
fn answers_whose_reserved_header_bytes_are_set_are_read_byte_by_byte() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        reserved_bytes: true,
        garbage: true,
        split: Some(1),
        ..Faults::default()
    });
    x30ctl(&sim, &["status"])
        .expect_code(0)
        .stdout_has("motion state   force-control stand (3)");
}

#[test]
fn split_answers_are_reassembled() {
    let sim = sim(1.0);
    for chunk in [1, 3, 17] {
        sim.set_faults(Faults {
            split: Some(chunk),
            ..Faults::default()
        });
        let run = x30ctl(&sim, &["battery", "--json"]);
        assert_eq!(run.expect_code(0).json_lines()[0]["kind"], "battery");
    }
}

#[test]
fn merged_unsolicited_frames_do_not_confuse_answers() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        merge: true,
        ..Faults::default()
    });
    // Each answer arrives with an extra 1002 frame whose ID no request has; on one
    // connection the next request then finds it first.
    let run = x30ctl(
        &sim,
        &["watch", "--count", "2", "--interval-ms", "10", "--json"],
    );
    let lines = run.expect_code(0).json_lines();
    assert_eq!(lines.len(), 2);
    for line in &lines {
        assert_eq!(line["status"]["kind"], "status");
        assert_eq!(line["battery"]["kind"], "battery");
        assert_eq!(line["perception"]["kind"], "perception");
    }
    run_stderr_names_unsolicited(&run.stderr);
    x30ctl(&sim, &["move", "forward", "--duration", "0.6"]).expect_code(0);
}

fn run_stderr_names_unsolicited(stderr: &str) {
    assert!(
        stderr.contains("ignored an unsolicited Type 1002 frame with message ID 32768"),
        "{stderr}"
    );
}

#[test]
fn unknown_type_is_a_clear_error() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        unknown_type: true,
        ..Faults::default()
    });
    x30ctl(&sim, &["status"])
        .expect_code(3)
        .stderr_has("bad answer to Type 1002 (message ID 0): unknown Type 2102");
    x30ctl(&sim, &["light", "--red", "1"])
        .expect_code(3)
        .stderr_has("unknown Type 2102");
}

#[test]
fn unknown_items_are_skipped() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        unknown_items: true,
        ..Faults::default()
    });
    x30ctl(&sim, &["status"])
        .expect_code(0)
        .stdout_has("motion state   force-control stand (3)");
    for command in [
        "battery",
        "obstacle",
        "motors",
        "nav-status",
        "cancel",
        "stop",
    ] {
        x30ctl(&sim, &[command]).expect_code(0);
    }
}

#[test]
fn an_unknown_pose_is_shown_and_the_rest_of_the_status_read() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        unknown_pose: true,
        ..Faults::default()
    });
    x30ctl(&sim, &["status"])
        .expect_code(0)
        .stdout_has("x unknown, y unknown, z unknown")
        .stdout_has("roll unknown, pitch unknown, yaw unknown")
        .stdout_has("motion state   force-control stand (3)");
    let run = x30ctl(&sim, &["status", "--json"]);
    let status = &run.expect_code(0).json_lines()[0];
    assert!(status["pos_x"].is_null(), "{status}");
    assert!(status["map_pixel"].is_null(), "{status}");
    assert_eq!(status["motion_state"]["code"], 3, "{status}");
    x30ctl(&sim, &["stop"]).expect_code(0);
}

#[test]
fn a_status_with_motion_state_alone_is_shown_with_the_rest_not_reported() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        sparse_status: true,
        ..Faults::default()
    });
    x30ctl(&sim, &["status"])
        .expect_code(0)
        .stdout_has("motion state   force-control stand (3)")
        .stdout_has("x unknown, y unknown, z unknown")
        .stdout_has("battery        not reported")
        .stdout_has("gait           not reported");
    let run = x30ctl(&sim, &["status", "--json"]);
    let status = &run.expect_code(0).json_lines()[0];
    assert!(status["electricity"].is_null(), "{status}");
    assert!(status["gait_state"].is_null(), "{status}");
    assert_eq!(status["motion_state"]["code"], 3, "{status}");
}

#[test]
fn a_battery_answer_without_some_items_is_shown_with_them_not_reported() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        leave_out: vec!["Voltage".into(), "BatteryLevel".into()],
        ..Faults::default()
    });
    x30ctl(&sim, &["battery"])
        .expect_code(0)
        .stdout_has("level          not reported")
        .stdout_has("voltage        not reported")
        .stdout_has("protection     normal (0)");
    let run = x30ctl(&sim, &["battery", "--json"]);
    let battery = &run.expect_code(0).json_lines()[0];
    assert!(battery["voltage"].is_null(), "{battery}");
    assert!(battery["battery_level"].is_null(), "{battery}");
    assert!(battery["cycles"].is_i64(), "{battery}");
}

#[test]
fn a_status_written_with_decimal_commas_is_shown_with_a_warning_naming_the_items() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        decimal_comma: true,
        ..Faults::default()
    });
    // The simulated robot stands at the origin: only its total odometry and the map's
    // resolution have a fraction, and so a comma.
    x30ctl(&sim, &["status"])
        .expect_code(0)
        .stdout_has("motion state   force-control stand (3)")
        .stdout_has("position       x 0 m, y 0 m, z 0 m")
        .stdout_has("0 km since power-on, unknown total")
        .stderr_has(
            "warning: the robot wrote SumOdom, Res in a form that cannot be read (Type 1002, \
             message ID 0); shown as not reported",
        );
}

#[test]
fn every_declaration_style_decodes() {
    let sim = sim(1.0);
    for declaration in [Declaration::Single, Declaration::None, Declaration::Double] {
        sim.set_faults(Faults {
            declaration,
            ..Faults::default()
        });
        let run = x30ctl(&sim, &["status", "--json"]);
        assert_eq!(
            run.expect_code(0).json_lines()[0]["motion_state"]["code"],
            3,
            "{declaration}"
        );
    }
}

#[test]
fn all_faults_at_once() {
    let sim = sim(20.0);
    sim.set_faults(Faults {
        delay: Duration::from_millis(20),
        garbage: true,
        split: Some(5),
        merge: true,
        unknown_items: true,
        declaration: Declaration::Single,
        ..Faults::default()
    });
    x30ctl(&sim, &["nav", "--map-id", "1", "--x", "1", "--y", "0"])
        .expect_code(0)
        .stdout_has("ErrorStatus 8960");
    x30ctl(&sim, &["watch", "--count", "2", "--interval-ms", "10"]).expect_code(0);
}

#[test]
fn connection_refused_is_exit_3() {
    let port = closed_port();
    let robot = format!("127.0.0.1:{port}");
    x30ctl_raw(&["--robot", &robot, "status"])
        .expect_code(3)
        .stderr_has(&format!("connection to {robot} failed: Connection refused"));
    x30ctl_raw(&[
        "--robot", &robot, "nav", "--map-id", "1", "--x", "1", "--y", "1",
    ])
    .expect_code(3)
    .stderr_has("Connection refused");
}

/// A one-connection fake robot: answers the first request with `answer(message_id)`.
fn fake_robot(answer: impl FnOnce(u16) -> Vec<u8> + Send + 'static) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr").to_string();
    thread::spawn(move || {
        let Ok((mut stream, _)) = listener.accept() else {
            return;
        };
        let mut header = [0u8; HEADER_LEN];
        if stream.read_exact(&mut header).is_err() {
            return;
        }
        let len = usize::from(u16::from_le_bytes([header[4], header[5]]));
        let mut body = vec![0; len];
        if stream.read_exact(&mut body).is_err() {
            return;
        }
        let id = u16::from_le_bytes([header[6], header[7]]);
        let _ = stream.write_all(&answer(id));
        // Keep the connection open until the client has read the answer and left.
        let _ = stream.read(&mut [0u8; 1]);
    });
    addr
}

fn encode_response(id: u16, response: &Response) -> Vec<u8> {
    x30_sim::encode_frame(id, response, &Faults::default()).expect("the answer encodes")
}

#[test]
fn type_0_answer_is_exit_3_naming_the_error_code() {
    let addr = fake_robot(|id| {
        encode_response(
            id,
            &Response::RequestError(RequestError {
                code: RequestErrorCode::ParseFailed,
            }),
        )
    });
    x30ctl_raw(&["--robot", &addr, "status"])
        .expect_code(3)
        .stderr_has("robot answered Type 0: ErrorCode 4 (data parse failed)");
}

/// A frame with the request's message ID but another Type (a robot's own report that reuses
/// the ID) is no answer: skipped with a warning, and the answer after it is read.
#[test]
fn a_frame_of_another_type_with_the_requests_id_is_no_answer() {
    let addr = fake_robot(|id| {
        let report = Response::NavResult(NavResult {
            value: 1,
            outcome: NavOutcome::Succeeded,
            status: ErrorStatus::TaskCompleted,
        });
        [
            encode_response(id, &report),
            encode_response(id, &Response::Battery(battery())),
        ]
        .concat()
    });
    x30ctl_raw(&["--robot", &addr, "battery"])
        .expect_code(0)
        .stdout_has("level          75 %")
        .stderr_has(
            "ignored a Type 1003 Command 1 frame with the message ID of the Type 2001 Command 1 \
             request",
        );
}

#[test]
fn unsolicited_and_garbled_frames_before_the_answer_are_skipped() {
    let addr = fake_robot(|id| {
        let mut bytes = b"\x00\xEB\x90noise".to_vec();
        // An unsolicited frame whose reserved bytes are set (read all the same), an
        // undecodable frame, a stale answer.
        let mut reserved = encode_response(id.wrapping_add(5), &Response::Battery(battery()));
        reserved[10] = 1;
        bytes.extend_from_slice(&reserved);
        let mut nonsense = vec![0; HEADER_LEN + 5];
        let n = frame::encode(&mut nonsense, 77, b"<a/>x").expect("frame");
        bytes.extend_from_slice(&nonsense[..n]);
        bytes.extend_from_slice(&encode_response(
            id.wrapping_add(1),
            &Response::Battery(battery()),
        ));
        let mut real = battery();
        real.battery_level = Some(33);
        bytes.extend_from_slice(&encode_response(id, &Response::Battery(real)));
        bytes
    });
    x30ctl_raw(&["--robot", &addr, "battery"])
        .expect_code(0)
        .stdout_has("level          33 %")
        .stderr_has("ignored an unsolicited Type 2001 frame with message ID 5")
        .stderr_has("ignored an undecodable frame with message ID 77")
        .stderr_has("ignored an unsolicited Type 2001 frame with message ID 1");
}

/// Frames with no body (keep-alives), one of them with the request's message ID, answer
/// nothing: the answer after them is read, and they are told once.
#[test]
fn empty_frames_before_the_answer_are_passed_over_whatever_their_message_id() {
    let addr = fake_robot(|id| {
        let mut bytes = Vec::new();
        for keep_alive_id in [0, id, 0] {
            let mut empty = vec![0; HEADER_LEN];
            frame::encode(&mut empty, keep_alive_id, &[]).expect("frame");
            bytes.extend_from_slice(&empty);
        }
        let mut real = battery();
        real.battery_level = Some(52);
        bytes.extend_from_slice(&encode_response(id, &Response::Battery(real)));
        bytes
    });
    let run = x30ctl_raw(&["--robot", &addr, "battery"]);
    run.expect_code(0)
        .stdout_has("level          52 %")
        .stderr_has("passing over frames with no body (the first had message ID 0)");
    assert_eq!(run.stderr.matches("no body").count(), 1, "{}", run.stderr);
}

#[test]
fn motion_answer_without_its_value_echo_is_read() {
    let addr = fake_robot(|id| {
        let ack = MotionAck {
            value: None,
            result: CommandResult::Success,
        };
        encode_response(id, &Response::Motion(MotionCommandCode::LieDown, ack))
    });
    x30ctl_raw(&["--robot", &addr, "lie-down"])
        .expect_code(0)
        .stdout_has("lie down (Type 2 Command 15, no Value echoed): success (ErrorCode 0)");
}

/// A robot that names Command 1 in its motion answers has still answered: the message ID
/// pairs them. The answer is shown as the request's, with the robot's ErrorCode, and a
/// warning.
#[test]
fn a_motion_answer_naming_another_command_is_read_with_a_warning() {
    let addr = fake_robot(|id| {
        let ack = MotionAck {
            value: Some(-1.0),
            result: CommandResult::Success,
        };
        encode_response(id, &Response::Motion(MotionCommandCode::Forward, ack))
    });
    x30ctl_raw(&["--robot", &addr, "lie-down"])
        .expect_code(0)
        .stdout_has("lie down (Type 2 Command 15, ")
        .stdout_has("success (ErrorCode 0)")
        .stderr_has(
            "the robot answered Type 2 Command 15 naming Command 1 (message ID 0); taken as \
             its answer",
        );
}

#[test]
fn answer_whose_reserved_header_bytes_are_set_is_read() {
    let addr = fake_robot(|id| {
        let mut real = battery();
        real.battery_level = Some(41);
        let mut bytes = encode_response(id, &Response::Battery(real));
        bytes[8..HEADER_LEN].copy_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        bytes
    });
    x30ctl_raw(&["--robot", &addr, "battery"])
        .expect_code(0)
        .stdout_has("level          41 %");
}

fn battery() -> x30_panel::proto::message::Battery {
    x30_panel::proto::message::Battery {
        voltage: Some(55),
        current: Some(120),
        remaining_capacity: Some(1500),
        nominal_capacity: Some(2004),
        cycles: Some(3),
        protected_state: Some(x30_panel::proto::codes::ProtectedState::Normal),
        battery_level: Some(75),
        battery_temperature: Some(31.5),
    }
}

fn request_frame(id: u16, request: &Request) -> Vec<u8> {
    let mut body = vec![0; 4096];
    let n = request
        .encode(&Timestamp::DOCUMENT_EPOCH, &mut body)
        .expect("encode");
    let mut out = vec![0; HEADER_LEN + n];
    let n = frame::encode(&mut out, id, &body[..n]).expect("frame");
    out.truncate(n);
    out
}

/// Garbage, a 1002 request, an oversize frame (body included), then a failed 1003 answer.
fn capture() -> Vec<u8> {
    let mut bytes = b"\x13\x37garbage".to_vec();
    bytes.extend_from_slice(&request_frame(4, &Request::Status));
    let mut oversize = vec![0; HEADER_LEN];
    let n = frame::encode(&mut oversize, 99, b"").expect("frame");
    oversize.truncate(n);
    oversize[4..6].copy_from_slice(&20_000u16.to_le_bytes());
    oversize.extend(std::iter::repeat_n(b'x', 20_000));
    bytes.extend_from_slice(&oversize);
    bytes.extend_from_slice(&encode_response(
        5,
        &Response::NavResult(NavResult {
            value: 12,
            outcome: NavOutcome::Failed,
            status: ErrorStatus::BatteryTooLow,
        }),
    ));
    bytes
}

fn as_hex(bytes: &[u8]) -> String {
    let mut text = String::from("# capture from a test\n");
    for line in bytes.chunks(16) {
        let words: Vec<String> = line.iter().map(|b| format!("0x{b:02X}")).collect();
        text.push_str(&words.join(" "));
        text.push('\n');
    }
    text
}

#[test]
fn decode_hex_capture_with_garbage_and_an_oversize_frame() {
    let bytes = capture();
    let path = std::env::temp_dir().join(format!("x30ctl-capture-{}.hex", std::process::id()));
    std::fs::write(&path, as_hex(&bytes)).expect("write capture");
    let run = x30ctl_raw(&["decode", path.to_str().expect("utf-8 path")]);
    let _ = std::fs::remove_file(&path);
    run.expect_code(0)
        .stdout_has("garbage at byte 0: 9 bytes without a sync sequence, skipped")
        .stdout_has("frame 1 at byte 9: message ID 4")
        .stdout_has("Type 1002 (real-time basic status), Command 1")
        .stdout_has("real-time basic status request (no items)")
        .stdout_has("oversize frame at byte")
        .stdout_has("message ID 99, 20000-byte body")
        .stdout_has("frame 2 at byte")
        .stdout_has(
            "navigation to point 12: failed (ErrorCode 1), battery too low (ErrorStatus 41730)",
        )
        .stdout_has(
            "2 frame(s), 1 garbage run(s) (9 bytes), 0 header(s) with reserved bytes set, 1 oversize frame(s)",
        );
}

#[test]
fn decode_raw_bytes_from_stdin_as_json() {
    let mut bytes = capture();
    // A truncated frame at the end.
    let cut = request_frame(6, &Request::Battery);
    bytes.extend_from_slice(&cut[..30]);
    let run = spawn_raw(&["decode", "--json", "--xml"], Some(bytes)).finish(RUN_LIMIT);
    let lines = run.expect_code(0).json_lines();
    let events: Vec<&str> = lines.iter().filter_map(|l| l["event"].as_str()).collect();
    assert_eq!(
        events,
        ["garbage", "frame", "oversize", "frame", "truncated"],
        "{}",
        run.stdout
    );
    assert_eq!(lines[1]["request"]["kind"], "status");
    assert!(
        lines[1]["xml"]
            .as_str()
            .is_some_and(|x| x.contains("<Type>1002</Type>"))
    );
    assert_eq!(lines[2]["asdu_len"], 20_000);
    assert_eq!(lines[3]["response"]["error_status"]["code"], 41730);
    assert_eq!(
        lines[3]["response"]["error_status"]["name"],
        "BatteryTooLow"
    );
    assert_eq!(lines[4]["present"], 30);
}

#[test]
fn decode_rejects_bad_hex() {
    let run =
        spawn_raw(&["decode", "--format", "hex"], Some(b"eb 90 e".to_vec())).finish(RUN_LIMIT);
    run.expect_code(2).stderr_has("odd number of hex digits");
    x30ctl_raw(&["decode", "/nonexistent/capture.hex"])
        .expect_code(2)
        .stderr_has("cannot read /nonexistent/capture.hex");
}

#[test]
fn move_ctrl_c_does_not_wait_for_a_slow_answer() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        delay: Duration::from_millis(1500),
        ..Faults::default()
    });
    let moving = spawn(
        &sim,
        &[
            "move",
            "forward",
            "--duration",
            "10",
            "--timeout-ms",
            "5000",
        ],
    );
    wait_for("the first forward command", Duration::from_secs(10), || {
        !requests_of(&sim, 2, Some(1)).is_empty()
    });
    let interrupted = std::time::Instant::now();
    moving.interrupt();
    // Zero velocity is requested at once; only its own (delayed) answer is awaited.
    wait_for("zero velocity", Duration::from_millis(700), || {
        !requests_of(&sim, 2, Some(6)).is_empty()
    });
    let run = moving.finish(RUN_LIMIT);
    // The forward command's answer comes before zero velocity's, and counts.
    run.expect_code(130)
        .stderr_has("move interrupted by Ctrl-C after 1 command(s); zero velocity sent");
    assert!(interrupted.elapsed() < Duration::from_secs(4));
    assert!(!run.stderr.contains("unsolicited"), "{}", run.stderr);
}

#[test]
fn ctrl_c_ends_the_wait_for_zero_velocitys_answer() {
    // A half-open robot: it reads every request and answers none.
    let sim = sim(1.0);
    sim.set_faults(Faults {
        mute: true,
        ..Faults::default()
    });
    let moving = spawn(
        &sim,
        &[
            "--timeout-ms",
            "10000",
            "move",
            "forward",
            "--duration",
            "1",
        ],
    );
    wait_for("zero velocity", Duration::from_secs(10), || {
        !requests_of(&sim, 2, Some(6)).is_empty()
    });
    let interrupted = std::time::Instant::now();
    moving.interrupt();
    let run = moving.finish(RUN_LIMIT);
    // Without the Ctrl-C, the wait would last the 10 s timeout, then as long again on a
    // new connection.
    run.expect_code(130).stderr_has(
        "move interrupted by Ctrl-C after 0 command(s); zero velocity sent, its answer not \
         awaited",
    );
    assert!(interrupted.elapsed() < Duration::from_secs(4));
    assert_eq!(
        requests_of(&sim, 2, Some(6)).len(),
        1,
        "no second zero velocity on a new connection"
    );
}

#[test]
fn move_stops_on_time_and_drives_no_further_while_the_robot_answers_late() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        delay: Duration::from_millis(3000),
        ..Faults::default()
    });
    let run = x30ctl(
        &sim,
        &[
            "--timeout-ms",
            "6000",
            "move",
            "forward",
            "--duration",
            "1.5",
        ],
    );
    // Every answer comes, late: all is acknowledged in the end.
    run.expect_code(0)
        .stderr_has("the robot has not answered for 500 ms: no motion until it does")
        .stdout_has("zero velocity (Command 6) acknowledged");
    let log = requests_of(&sim, 2, None);
    let forward = motion_times(&sim, 1);
    let stop = log.last().expect("requests");
    assert_eq!(stop.command, Some(6), "{log:?}");
    // Zero velocity when the duration ends, not when the pending answers come (3 s).
    let at = stop.t - forward[0];
    assert!(
        (1.3..2.5).contains(&at),
        "zero velocity after {at} s: {log:?}"
    );
    // Commands went out until the first answer was 500 ms overdue, then none.
    assert!(
        (2..=3).contains(&forward.len()) && forward.iter().all(|t| t - forward[0] < 0.8),
        "{log:?}"
    );
    run.stdout_has(&format!("{} command(s) acknowledged", forward.len()));
}

fn type_0_frame(id: u16) -> Vec<u8> {
    encode_response(
        id,
        &Response::RequestError(RequestError {
            code: RequestErrorCode::ParseFailed,
        }),
    )
}

#[test]
fn type_0_with_an_id_no_request_has_answers_the_pending_request() {
    // The robot could not read the header, so the ID is not the request's: the Type 0
    // answer still answers the one request outstanding, and is not waited past.
    let addr = fake_robot(|id| type_0_frame(id.wrapping_add(100)));
    x30ctl_raw(&["--robot", &addr, "--timeout-ms", "5000", "status"])
        .expect_code(3)
        .stderr_has("robot answered Type 0: ErrorCode 4 (data parse failed)")
        .stderr_has("the Type 0 answer carries message ID 100, not the request's 0");
}

/// Reads one request frame: its message ID and decoded request.
fn read_request(stream: &mut TcpStream) -> Option<(u16, Request)> {
    let mut header = [0u8; HEADER_LEN];
    stream.read_exact(&mut header).ok()?;
    let len = usize::from(u16::from_le_bytes([header[4], header[5]]));
    let mut body = vec![0; len];
    stream.read_exact(&mut body).ok()?;
    let id = u16::from_le_bytes([header[6], header[7]]);
    Some((id, Request::decode(&body).ok()?.message))
}

#[test]
fn late_type_0_to_an_abandoned_move_command_is_skipped() {
    // A robot that answers the forward command only after Ctrl-C has given it up, and
    // then with a Type 0 carrying its ID, before answering zero velocity.
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr").to_string();
    let (first_in, first_seen) = mpsc::channel();
    let robot = thread::spawn(move || {
        let (mut stream, _) = listener.accept().ok()?;
        stream.set_read_timeout(Some(RUN_LIMIT)).ok()?;
        let forward = read_request(&mut stream)?;
        first_in.send(()).ok()?;
        let stop = read_request(&mut stream)?;
        let ack = Response::Motion(
            MotionCommandCode::ZeroVelocity,
            MotionAck {
                value: Some(0.0),
                result: CommandResult::Success,
            },
        );
        let mut bytes = type_0_frame(forward.0);
        bytes.extend_from_slice(&encode_response(stop.0, &ack));
        stream.write_all(&bytes).ok()?;
        let _ = stream.read(&mut [0u8; 1]);
        Some((forward, stop))
    });
    let moving = spawn_raw(
        &[
            "--robot",
            &addr,
            "--timeout-ms",
            "5000",
            "move",
            "forward",
            "--duration",
            "10",
        ],
        None,
    );
    first_seen
        .recv_timeout(Duration::from_secs(10))
        .expect("the forward command reaches the robot");
    moving.interrupt();
    let run = moving.finish(RUN_LIMIT);
    run.expect_code(130)
        .stderr_has("move interrupted by Ctrl-C after 0 command(s); zero velocity sent");
    assert!(!run.stderr.contains("Type 0"), "{}", run.stderr);
    assert!(!run.stderr.contains("unsolicited"), "{}", run.stderr);
    let ((forward_id, forward), (stop_id, stop)) =
        robot.join().expect("robot thread").expect("two requests");
    assert!(
        matches!(forward, Request::Motion(m) if m.code() == MotionCommandCode::Forward),
        "{forward:?}"
    );
    assert_eq!(stop, Request::Motion(MotionCommand::ZeroVelocity));
    assert_ne!(forward_id, stop_id);
}

#[test]
fn estop_is_sent_again_until_a_status_confirms_it() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        refuse_estops: 2,
        ..Faults::default()
    });
    x30ctl(&sim, &["estop"])
        .expect_code(0)
        .stdout_has("soft emergency stop (Type 2 Command 13, Value -1): failure (ErrorCode 1)")
        .stdout_has(
            "confirmed: the robot reports soft emergency stop (MotionState 6) after 3 command(s)",
        );
    let sent = motion_times(&sim, 13);
    assert_eq!(sent.len(), 3, "{sent:?}");
    for pair in sent.windows(2) {
        let gap = pair[1] - pair[0];
        assert!((0.15..=0.40).contains(&gap), "gap {gap} s in {sent:?}");
    }
    assert_eq!(sim.snapshot().motion_state, MotionState::SoftEmergencyStop);
    // With --json: the answer to Command 13, then the status that confirms it.
    let run = x30ctl(&sim, &["estop", "--json"]);
    let lines = run.expect_code(0).json_lines();
    assert_eq!(lines.len(), 2, "{}", run.stdout);
    assert_eq!(lines[0]["command"], 13);
    assert_eq!(lines[1]["motion_state"]["code"], 6);
}

#[test]
fn estop_is_repeated_while_the_answers_are_late() {
    let sim = sim(1.0);
    sim.set_faults(Faults {
        delay: Duration::from_millis(1000),
        ..Faults::default()
    });
    x30ctl(&sim, &["estop"])
        .expect_code(0)
        .stdout_has("confirmed: the robot reports soft emergency stop (MotionState 6)");
    // The first status says so after a second; meanwhile Command 13 goes every 250 ms.
    let sent = motion_times(&sim, 13);
    assert!(
        (3..=6).contains(&sent.len()) && sent.iter().all(|t| t - sent[0] < 1.3),
        "{sent:?}"
    );
}

#[test]
fn estop_is_confirmed_by_a_robot_that_answers_every_request_late() {
    // Every answer 2.5 s late: later than the first connection waits before it is given up.
    let sim = sim(1.0);
    sim.set_faults(Faults {
        delay: Duration::from_millis(2500),
        ..Faults::default()
    });
    x30ctl(&sim, &["--timeout-ms", "15000", "estop"])
        .expect_code(0)
        .stderr_has("the robot has not answered for 2000 ms: reconnecting (waiting 4000 ms")
        .stdout_has("confirmed: the robot reports soft emergency stop (MotionState 6)");
    assert_eq!(sim.snapshot().motion_state, MotionState::SoftEmergencyStop);
}

#[test]
fn estop_to_a_silent_robot_is_repeated_then_reported_unconfirmed() {
    // A robot that reads every request and answers none.
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr").to_string();
    let robot = thread::spawn(move || {
        let (mut stream, _) = listener.accept().ok()?;
        stream.set_read_timeout(Some(RUN_LIMIT)).ok()?;
        let mut estops = 0;
        while let Some((_, request)) = read_request(&mut stream) {
            if matches!(request, Request::Motion(MotionCommand::SoftEmergencyStop)) {
                estops += 1;
            }
        }
        Some(estops)
    });
    x30ctl_raw(&["--robot", &addr, "--timeout-ms", "1200", "estop"])
        .expect_code(3)
        .stderr_has("no status confirmed soft emergency stop (MotionState 6) within 1200 ms");
    let estops = robot.join().expect("robot thread").expect("a connection");
    assert!((4..=6).contains(&estops), "{estops} e-stops in 1.2 s");
}
