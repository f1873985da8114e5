//! Each fault injection option, observed on the wire.

mod common;

use std::time::{Duration, Instant};

use common::*;
use x30_panel::proto::codes::MotionState;
use x30_panel::proto::frame::{FrameDecoder, FrameError, HEADER_LEN, SYNC};
use x30_panel::proto::message::{Direction, MotionCommand, Request, Response};
use x30_sim::faults::{FLOOD_WRITE, GARBAGE, MERGED_ID_OFFSET, UNKNOWN_TYPE};
use x30_sim::{Config, Declaration, Faults};

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn start_faulty(faults: Faults) -> x30_sim::Simulator {
    start_with(Config {
        listen: "127.0.0.1:0".parse().unwrap(),
        faults,
        ..Config::default()
    })
}

/// The body of the next answer frame, as text.
fn next_body(client: &mut Client) -> (u16, String) {
    let (id, body) = client.recv_frame_within(TIMEOUT).expect("an answer");
    (id, String::from_utf8(body).unwrap())
}

#[test]
fn delay() {
    let sim = start_faulty(Faults {
        delay: ms(300),
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    let sent = Instant::now();
    client.status();
    assert!(sent.elapsed() >= ms(300), "{:?}", sent.elapsed());
    // Changed at run time.
    sim.update_faults(|f| f.delay = Duration::ZERO);
    let sent = Instant::now();
    client.status();
    assert!(sent.elapsed() < ms(300), "{:?}", sent.elapsed());
}

#[test]
fn drop_after() {
    let sim = start_faulty(Faults {
        drop_after: Some(2),
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.status();
    client.send(&Request::Status);
    assert!(client.closed_within(ms(5000)), "closed on the 2nd request");
    assert!(
        client.recv_within(ms(100)).is_none(),
        "the 2nd was not answered"
    );
    assert_eq!(sim.requests().len(), 2, "both were received");
    assert!(wait_until(ms(2000), || sim.connections() == 0));
}

#[test]
fn hang_up_after_answer() {
    let sim = start_faulty(Faults {
        hang_up_after_answer: true,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.send(&Request::Status);
    client.send(&Request::Battery);
    let first = client.recv_within(ms(5000)).expect("the 1st was answered");
    assert!(matches!(first.response, Response::Status(_)), "{first:?}");
    assert!(
        client.recv_within(ms(1000)).is_none(),
        "the 2nd was not answered"
    );
    assert!(client.closed_within(ms(100)), "closed after the answer");
    // A new connection is served the same way.
    let mut client = Client::connect(sim.addr());
    client.status();
    assert!(client.closed_within(ms(5000)), "closed after the answer");
}

#[test]
fn hang_up_on_a_type() {
    let sim = start_faulty(Faults {
        hang_up_on: vec![1008],
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.status();
    client.send(&Request::MotorTemperatures);
    assert!(client.closed_within(ms(5000)), "closed on the 1008 request");
    assert!(
        client.recv_within(ms(100)).is_none(),
        "the 1008 was not answered"
    );
    assert_eq!(sim.requests().len(), 2, "both were received");
    // Another connection is answered as before.
    let mut client = Client::connect(sim.addr());
    client.status();
}

#[test]
fn garbage_precedes_each_answer_frame() {
    let sim = start_faulty(Faults {
        garbage: true,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.send(&Request::Status);
    let bytes = read_frames(&mut client, 1);
    assert!(bytes.starts_with(GARBAGE), "{:02x?}", &bytes[..16]);
    assert_eq!(bytes[GARBAGE.len()..GARBAGE.len() + 4], SYNC);
    // A resynchronising decoder reports the garbage and still finds the answer.
    client.send(&Request::Status);
    let answer = client.recv();
    assert!(matches!(answer.response, Response::Status(_)));
    assert!(matches!(
        client.stream_errors.as_slice(),
        [FrameError::Garbage { skipped }] if *skipped == GARBAGE.len()
    ));
}

#[test]
fn flood_streams_garbage_between_whole_answers() {
    let sim = start_faulty(Faults {
        flood: true,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    // Unasked, garbage arrives, and keeps arriving as fast as it is read.
    let mut idle = Vec::new();
    while idle.len() < 4 * FLOOD_WRITE {
        let read = client.read_once(ms(2000));
        assert!(!read.is_empty(), "no flood after {} bytes", idle.len());
        idle.extend(read);
    }
    let pattern: Vec<u8> = GARBAGE.iter().copied().cycle().take(idle.len()).collect();
    assert_eq!(idle, pattern, "the flood is GARBAGE over and over");
    // Each answer still arrives whole among it, and a resynchronising decoder finds it.
    for _ in 0..3 {
        let status = client.status();
        assert_eq!(status.motion_state, MotionState::ForceControlStand);
    }
    assert!(
        client
            .stream_errors
            .iter()
            .all(|e| matches!(e, FrameError::Garbage { .. })),
        "only garbage was skipped, no answer broken: {:?}",
        client
            .stream_errors
            .iter()
            .find(|e| !matches!(e, FrameError::Garbage { .. }))
    );
}

/// Reads until `frames` whole frames have arrived; returns every byte read.
fn read_frames(client: &mut Client, frames: usize) -> Vec<u8> {
    let mut bytes = Vec::new();
    let deadline = Instant::now() + TIMEOUT;
    while count_frames(&bytes) < frames && Instant::now() < deadline {
        bytes.extend(client.read_once(ms(2000)));
    }
    bytes
}

fn count_frames(bytes: &[u8]) -> usize {
    let mut decoder = FrameDecoder::<8192>::new();
    decoder.feed(bytes);
    let mut frames = 0;
    while let Some(event) = decoder.decode() {
        frames += usize::from(event.is_ok());
    }
    frames
}

#[test]
fn split_writes_arrive_in_several_reads() {
    let sim = start_faulty(Faults {
        split: Some(16),
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.send(&Request::Battery);
    let mut reads = Vec::new();
    let deadline = Instant::now() + TIMEOUT;
    while count_frames(&reads.concat::<u8>()) < 1 && Instant::now() < deadline {
        let chunk = client.read_once(ms(2000));
        assert!(!chunk.is_empty(), "the answer stalled");
        reads.push(chunk);
    }
    assert!(reads.len() >= 3, "{} reads", reads.len());
    assert!(
        reads[0].len() <= 16 * 2,
        "first read {} bytes",
        reads[0].len()
    );
    let bytes = reads.concat::<u8>();
    let mut decoder = FrameDecoder::<8192>::new();
    decoder.feed(&bytes);
    let frame = decoder.decode().unwrap().unwrap();
    assert!(matches!(
        Response::decode(frame.asdu).unwrap().message,
        Response::Battery(_)
    ));
}

#[test]
fn merge_puts_two_frames_in_one_read() {
    let sim = start_faulty(Faults {
        merge: true,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.send_with_id(0x9000, &Request::Perception);
    std::thread::sleep(ms(200));
    let bytes = client.read_once(ms(5000));
    let mut decoder = FrameDecoder::<8192>::new();
    assert_eq!(decoder.feed(&bytes), bytes.len());
    let first = decoder.decode().expect("the answer").unwrap();
    assert_eq!(first.message_id, 0x9000);
    assert!(matches!(
        Response::decode(first.asdu).unwrap().message,
        Response::Perception(_)
    ));
    let second = decoder
        .decode()
        .expect("the extra frame in the same read")
        .unwrap();
    assert_eq!(second.message_id, 0x9000u16.wrapping_add(MERGED_ID_OFFSET));
    assert_eq!(second.message_id, 0x1000);
    assert!(matches!(
        Response::decode(second.asdu).unwrap().message,
        Response::Status(s) if s.electricity == Some(90)
    ));
    assert!(decoder.decode().is_none());
}

#[test]
fn unknown_type_keeps_id_and_items() {
    let sim = start_faulty(Faults {
        unknown_type: true,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    let id = client.send(&Request::Perception);
    let (answer_id, body) = next_body(&mut client);
    assert_eq!(answer_id, id);
    assert!(
        body.contains(&format!("<Type>{UNKNOWN_TYPE}</Type>")),
        "{body}"
    );
    assert!(body.contains("<ObsState>0</ObsState>"), "{body}");
    assert!(matches!(
        Response::decode(body.as_bytes()),
        Err(x30_panel::proto::message::DecodeError::UnknownType(2102))
    ));
}

#[test]
fn motion_answers_name_another_command_and_keep_the_id() {
    let sim = start_faulty(Faults {
        motion_answer_command: Some(1),
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    let id = client.send(&Request::Motion(MotionCommand::ZeroVelocity));
    let (answer_id, body) = next_body(&mut client);
    assert_eq!(answer_id, id);
    assert!(body.contains("<Type>2</Type>"), "{body}");
    assert!(body.contains("<Command>1</Command>"), "{body}");
    assert!(body.contains("<ErrorCode>0</ErrorCode>"), "{body}");
    // Other Types keep their Command.
    client.send(&Request::Perception);
    let (_, body) = next_body(&mut client);
    assert!(body.contains("<Command>1</Command>"), "{body}");
    sim.update_faults(|f| f.motion_answer_command = Some(7));
    client.send(&Request::Perception);
    let (_, body) = next_body(&mut client);
    assert!(body.contains("<Command>1</Command>"), "{body}");
    client.send(&Request::Motion(MotionCommand::SoftEmergencyStop));
    let (_, body) = next_body(&mut client);
    assert!(body.contains("<Command>7</Command>"), "{body}");
}

#[test]
fn unknown_items_between_the_documented_ones() {
    let sim = start_faulty(Faults {
        unknown_items: true,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.send(&Request::Status);
    let (_, body) = next_body(&mut client);
    for item in [
        "<AngleYaw>",
        "<CurRuntime>",
        "<RTKState>0</RTKState>",
        "<MapUpdateState>0</MapUpdateState>",
    ] {
        assert!(body.contains(item), "{item} missing in {body}");
    }
    let at = |s: &str| body.find(s).unwrap();
    assert!(at("<MotionState>") < at("<CurRuntime>") && at("<CurRuntime>") < at("<OnDockState>"));
    // A tolerant decoder still reads the documented items.
    match Response::decode(body.as_bytes()).unwrap().message {
        Response::Status(s) => assert_eq!(s.electricity, Some(90)),
        other => panic!("{other:?}"),
    }
}

#[test]
fn declarations() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    for (declaration, start) in [
        (
            Declaration::Double,
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>",
        ),
        (
            Declaration::Single,
            "<?xml version='1.0' encoding='utf-8'?>\n<PatrolDevice>",
        ),
        (Declaration::None, "<PatrolDevice>"),
    ] {
        sim.update_faults(|f| f.declaration = declaration);
        client.send(&Request::Battery);
        let (_, body) = next_body(&mut client);
        assert!(body.starts_with(start), "{declaration}: {body}");
        assert!(Response::decode(body.as_bytes()).is_ok());
    }
}

#[test]
fn faults_apply_to_type_0_answers_too() {
    let sim = start_faulty(Faults {
        declaration: Declaration::None,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.send_raw(&raw_frame(5, b"nonsense"));
    let (id, body) = next_body(&mut client);
    assert_eq!(id, 5);
    assert!(
        body.starts_with("<PatrolDevice>\n  <Type>0</Type>"),
        "{body}"
    );
    assert!(body.contains("<Time>0000-00-00 00:00:00</Time>"), "{body}");
    assert!(body.contains("<ErrorCode>4</ErrorCode>"), "{body}");
}

#[test]
fn every_answer_frame_is_its_own_write() {
    // Without faults an answer leaves in one write: it arrives whole and alone.
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    client.send(&Request::Status);
    let bytes = read_frames(&mut client, 1);
    let len = u16::from_le_bytes([bytes[4], bytes[5]]) as usize;
    assert_eq!(
        bytes.len(),
        HEADER_LEN + len,
        "one frame, whole, in its read"
    );
}

/// A delayed Type holds up no other answer on the same connection: the 2001 answer sent
/// second leaves first, the 1002 answer after its own delay, each matched by message ID.
#[test]
fn a_type_delay_holds_up_only_its_own_type() {
    let sim = start_faulty(Faults {
        delay: ms(100),
        type_delays: vec![(1002, ms(600))],
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    let sent = Instant::now();
    let status = client.send(&Request::Status);
    let battery = client.send(&Request::Battery);
    let first = client.recv();
    let first_at = sent.elapsed();
    let second = client.recv();
    let second_at = sent.elapsed();
    assert_eq!(first.id, battery, "the undelayed answer first");
    assert!(matches!(first.response, Response::Battery(_)));
    assert!(first_at >= ms(100), "the global delay still applies");
    assert_eq!(second.id, status);
    assert!(matches!(second.response, Response::Status(_)));
    assert!(second_at >= ms(700), "{second_at:?}");
    // Changed at run time: now 2001 is the slow one.
    sim.set_faults(Faults {
        type_delays: vec![(2001, ms(400))],
        ..Faults::default()
    });
    let battery = client.send(&Request::Battery);
    let status = client.send(&Request::Status);
    assert_eq!(client.recv().id, status);
    assert_eq!(client.recv().id, battery);
}

/// A connection's first answers wait for its warm-up, counted from when it opened; later
/// ones do not, and a new connection waits again.
#[test]
fn warm_up_holds_each_new_connections_answers() {
    let sim = start_faulty(Faults {
        warm_up: ms(500),
        ..Faults::default()
    });
    for _ in 0..2 {
        let opened = Instant::now();
        let mut client = Client::connect(sim.addr());
        client.status();
        assert!(opened.elapsed() >= ms(500), "{:?}", opened.elapsed());
        let sent = Instant::now();
        client.status();
        assert!(sent.elapsed() < ms(500), "{:?}", sent.elapsed());
    }
}

/// Muted, the robot reads and logs requests but neither acts on them nor answers, and the
/// connection stays open; unmuted, it answers new requests (and never the old ones).
#[test]
fn mute_logs_requests_but_neither_acts_nor_answers() {
    let sim = start_faulty(Faults {
        mute: true,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.send(&Request::Status);
    client.send(&Request::Motion(
        x30_panel::proto::message::MotionCommand::SoftEmergencyStop,
    ));
    client.send_raw(&raw_frame(9, b"not xml"));
    assert!(wait_until(ms(2000), || sim.requests().len() == 3));
    assert!(
        client.recv_frame_within(ms(500)).is_none(),
        "no answer, not even Type 0"
    );
    assert_eq!(sim.connections(), 1, "the connection stays open");
    assert_eq!(
        sim.snapshot().motion_state.raw(),
        3,
        "the e-stop was not acted on"
    );
    sim.update_faults(|f| f.mute = false);
    let status = client.status();
    assert_eq!(status.motion_state.raw(), 3);
}

/// While connections are refused, open ones are closed and new ones accepted and closed at
/// once; afterwards connections work again.
#[test]
fn refusing_connections_for_a_while() {
    let sim = start(1.0);
    let mut open = Client::connect(sim.addr());
    open.status();
    sim.refuse_connections(ms(600));
    let refused_at = Instant::now();
    assert!(open.closed_within(ms(5000)), "an open connection is closed");
    let mut refused = Client::connect(sim.addr());
    assert!(
        refused.closed_within(ms(5000)),
        "a new one is closed at once"
    );
    assert!(wait_until(ms(2000), || sim.connections() == 0));
    assert!(sim.faults().refuse_connections_until.is_some());
    std::thread::sleep(ms(700).saturating_sub(refused_at.elapsed()));
    let mut later = Client::connect(sim.addr());
    later.status();
    assert_eq!(
        sim.requests().len(),
        2,
        "nothing was read from the refused one"
    );
}

/// The field works from the start too, without the convenience method.
#[test]
fn refusing_connections_from_the_start() {
    let sim = start_faulty(Faults {
        refuse_connections_until: Some(Instant::now() + ms(300)),
        ..Faults::default()
    });
    let mut refused = Client::connect(sim.addr());
    assert!(refused.closed_within(ms(5000)));
    std::thread::sleep(ms(400));
    Client::connect(sim.addr()).status();
}

/// The next N soft emergency stops are answered with ErrorCode 1 and leave the motion state
/// alone; the one after them works.
#[test]
fn refused_estops_fail_and_change_nothing() {
    use x30_panel::proto::codes::{CommandResult, MotionState};
    use x30_panel::proto::message::{MotionCommand, Speed};
    let sim = start_faulty(Faults {
        refuse_estops: 2,
        ..Faults::default()
    });
    let mut client = Client::connect(sim.addr());
    client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
    for left in [1, 0] {
        let ack = client.motion(MotionCommand::SoftEmergencyStop);
        assert_eq!(ack.result, CommandResult::Failure);
        assert_eq!(ack.value, Some(-1.0));
        assert_eq!(client.status().motion_state, MotionState::Stepping);
        assert_eq!(sim.faults().refuse_estops, left);
    }
    let ack = client.motion(MotionCommand::SoftEmergencyStop);
    assert_eq!(ack.result, CommandResult::Success);
    assert_eq!(client.status().motion_state, MotionState::SoftEmergencyStop);
}

/// With at most one connection, a second is closed without a byte read while the first is
/// open; the first is answered as before.
#[test]
fn max_connections_closes_the_connections_beyond_it_unread() {
    let (sim, mut first, _) = second_connection_unread(Faults {
        max_connections: Some(1),
        ..Faults::default()
    });
    first.status();
    assert_eq!(sim.connections(), 1);
}

/// Keeping only the newest connection, a new connection closes the one before, and is
/// answered.
#[test]
fn newest_only_closes_the_connection_before_a_new_one() {
    let sim = start_faulty(Faults {
        newest_only: true,
        ..Faults::default()
    });
    let mut first = Client::connect(sim.addr());
    first.status();
    let mut second = Client::connect(sim.addr());
    second.status();
    first.send(&Request::Status);
    assert!(
        first.recv_frame_within(ms(500)).is_none(),
        "the first connection is answered after the second came"
    );
    assert_eq!(sim.connections(), 1);
}

/// Hung handlers: a connection open when the robot hangs is neither read nor answered from
/// then on, and stays open; a connection made afterwards is served.
#[test]
fn a_hang_leaves_the_open_connections_unread_and_serves_new_ones() {
    let sim = start_faulty(Faults::default());
    let mut open = Client::connect(sim.addr());
    open.status();
    sim.hang_open_connections();
    open.send(&Request::Status);
    assert!(
        open.recv_frame_within(ms(500)).is_none(),
        "a connection open at the hang is answered"
    );
    assert_eq!(sim.requests().len(), 1, "a request after the hang was read");
    assert_eq!(sim.connections(), 1, "the hung connection was closed");
    let mut later = Client::connect(sim.addr());
    later.status();
    assert_eq!(sim.requests().len(), 2);
}

/// A simulator with `faults`, a first connection answered, and a second whose status
/// request, sent while the first is open, is neither read nor answered within 500 ms.
fn second_connection_unread(faults: Faults) -> (x30_sim::Simulator, Client, Client) {
    let sim = start_faulty(faults);
    let mut first = Client::connect(sim.addr());
    first.status();
    let mut second = Client::connect(sim.addr());
    second.send(&Request::Status);
    assert!(
        second.recv_frame_within(ms(500)).is_none(),
        "the second connection is answered while the first is open"
    );
    assert_eq!(sim.requests().len(), 1, "the second request was read");
    (sim, first, second)
}

/// Serving one connection at a time, a second connection is accepted by the kernel but not
/// read until the first closes; then its waiting request is answered.
#[test]
fn one_at_a_time_leaves_the_next_connection_unread_until_the_open_one_closes() {
    let (sim, first, mut second) = second_connection_unread(Faults {
        one_at_a_time: true,
        ..Faults::default()
    });
    assert_eq!(sim.connections(), 1);
    drop(first);
    let (_, body) = next_body(&mut second);
    assert!(body.contains("<Type>1002</Type>"), "{body}");
    assert_eq!(sim.requests().len(), 2);
}
