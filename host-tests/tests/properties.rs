//! Property tests of the protocol core (`x30_panel::proto`; docs/protocol.md, from "Frame
//! header" to "Beyond the document"), run on the host.
//!
//! - Every request and response, with arbitrary field values, survives encode → decode,
//!   bare and inside a frame fed to the decoder in arbitrary pieces.
//! - The frame decoder never panics or stalls, never hands out a frame longer than its
//!   buffer allows, and never loses a valid frame that follows garbage, an oversized frame
//!   or a header with non-zero reserved bytes.
//! - `Request::decode` and `Response::decode` never panic, on arbitrary bytes or on mutated
//!   valid documents; whatever they accept re-encodes to a document that decodes the same.
//! - The decoders tolerate the layouts real traffic uses: either declaration or none, any
//!   indentation, comments inside `<Items>`, elements in any order.
//! - `Response::encode` writes exactly what `Response::encode_general` writes, into buffers
//!   of every size.
//! - On all of those documents, the reader's shortcuts for the usual layout change nothing:
//!   `decode` returns exactly what `decode_general` returns, and `read_document` hands out
//!   exactly what `read_document_general` hands out.
//!
//! Case counts are set per property so the file runs in well under a minute with the
//! test profile (opt-level 2); `PROPTEST_CASES` overrides them all for a longer run.

use std::fmt::Debug;

use proptest::array::{uniform4, uniform6, uniform8, uniform12};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::{Index, select};
use proptest::test_runner::TestCaseError;

use x30_panel::proto::codes::*;
use x30_panel::proto::frame::{self, FrameDecoder, FrameError, HEADER_LEN, Reserved, SYNC};
use x30_panel::proto::message::*;
use x30_panel::proto::time::Timestamp;
use x30_panel::proto::xml::number::NumberError;
use x30_panel::proto::xml::writer::{ItemName, WriteError};

#[path = "common/reader_trace.rs"]
mod reader_trace;
use reader_trace::reader_trace;

/// The buffer the round-trip properties encode into: 4 KiB, which holds every message but
/// the longest 1003 requests (see `encode_to_vec`).
const BODY_BUF: usize = 4096;

/// Cases for a property, unless `PROPTEST_CASES` asks for a different number.
fn cases(default: u32) -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default);
    ProptestConfig {
        cases,
        ..ProptestConfig::default()
    }
}

// ---------------------------------------------------------------------------------------
// Strategies: field values
// ---------------------------------------------------------------------------------------

/// Any finite `f32`: every bit pattern (NaN and infinity patterns have their exponent
/// lowered by one, so nothing is rejected), plus zeros, subnormals, extremes and
/// decimal-looking values, which the shortest-form writer treats specially.
fn finite_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => any::<u32>().prop_map(|bits| {
            let f = f32::from_bits(bits);
            if f.is_finite() { f } else { f32::from_bits(bits & !0x0080_0000) }
        }),
        1 => (any::<bool>(), 0u32..0x0080_0000)
            .prop_map(|(neg, mantissa)| f32::from_bits(u32::from(neg) << 31 | mantissa)),
        1 => select(vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            0.1,
            -0.000_233_936_21,
            1e-7,
            123_456.79,
            16_777_216.0,
            16_777_218.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::MAX,
            f32::MIN,
            f32::EPSILON,
        ]),
        2 => (-1_000_000i32..1_000_000, 0i32..8).prop_map(|(n, e)| n as f32 / 10f32.powi(e)),
    ]
}

/// A float an answer reports: mostly a number, sometimes a NaN or an infinity (a reading the
/// robot does not have), which answers carry as C's `nan` and `inf`.
fn reading_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        16 => finite_f32(),
        1 => select(vec![f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY]),
    ]
}

/// Any `i32`, with small values and the extremes more often than uniform sampling gives.
fn any_i32() -> impl Strategy<Value = i32> {
    prop_oneof![
        3 => any::<i32>(),
        2 => -1000i32..1000,
        1 => select(vec![i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX - 1, i32::MAX]),
    ]
}

/// Raw values for coded items: the protocol's known codes (small numbers, the 1003 error
/// statuses) and anything else, which must survive as `Unknown(raw)`.
fn raw_code() -> impl Strategy<Value = i32> {
    prop_oneof![
        4 => -2i32..=25,
        1 => 8955i32..=8965,
        1 => 41725i32..=41990,
        3 => any_i32(),
    ]
}

/// A timestamp with a 4-digit year and 2-digit fields, range-checked no further (Type 0
/// answers carry all zeros).
fn timestamp() -> impl Strategy<Value = Timestamp> {
    (0u16..=9999, uniform4(0u8..=99), 0u8..=99).prop_map(
        |(year, [month, day, hour, minute], second)| Timestamp {
            year,
            month,
            day,
            hour,
            minute,
            second,
        },
    )
}

// ---------------------------------------------------------------------------------------
// Strategies: message bodies
// ---------------------------------------------------------------------------------------

prop_compose! {
    /// Any status a robot may send: floats may be `nan`, and every item but `MotionState`
    /// may be left out (an absent float reads as NaN, which is also what `nan` reads as).
    fn robot_status()(
        f in uniform12(reading_f32()),
        h in proptest::option::of(any_i32()),
        electricity in proptest::option::of(any_i32()),
        motion_state in raw_code(),
        c in uniform6(proptest::option::of(raw_code())),
    ) -> RobotStatus {
        RobotStatus {
            motion_state: MotionState::from_raw(motion_state),
            pos_x: f[0],
            pos_y: f[1],
            pos_z: f[2],
            roll: f[3],
            pitch: f[4],
            yaw: f[5],
            speed: f[6],
            cur_odom: f[7],
            sum_odom: f[8],
            res: f[9],
            x0: f[10],
            y0: f[11],
            h,
            electricity,
            location: c[0].map(Location::from_raw),
            gait_state: c[1].map(GaitState::from_raw),
            motor_state: c[2].map(MotorState::from_raw),
            charge_state: c[3].map(ChargeState::from_raw),
            control_mode: c[4].map(ControlMode::from_raw),
            on_dock_state: c[5].map(OnDockState::from_raw),
        }
    }
}

prop_compose! {
    fn nav_point()(
        value in any_i32(),
        map_id in any_i32(),
        f in uniform4(finite_f32()),
        c in uniform8(raw_code()),
    ) -> NavPoint {
        NavPoint {
            value,
            map_id,
            pos_x: f[0],
            pos_y: f[1],
            pos_z: f[2],
            angle_yaw: f[3],
            point_info: PointInfo::from_raw(c[0]),
            gait: NavGait::from_raw(c[1]),
            speed: NavSpeed::from_raw(c[2]),
            manner: Manner::from_raw(c[3]),
            obs_mode: ObsMode::from_raw(c[4]),
            nav_mode: NavMode::from_raw(c[5]),
            terrain: Terrain::from_raw(c[6]),
            posture: Posture::from_raw(c[7]),
        }
    }
}

fn nav_task() -> impl Strategy<Value = NavTask> {
    vec(nav_point(), 1..=MAX_NAV_POINTS).prop_map(|points| NavTask {
        points: heapless::Vec::from_slice(&points).expect("at most MAX_NAV_POINTS points"),
    })
}

prop_compose! {
    fn light()(
        [red, green, blue, brightness] in uniform4(any::<u8>()),
        effect in raw_code(),
    ) -> Light {
        Light { red, green, blue, effect: LightEffect::from_raw(effect), brightness }
    }
}

prop_compose! {
    fn relocalize()([pos_x, pos_y, pos_z, yaw] in uniform4(finite_f32())) -> Relocalize {
        Relocalize { pos_x, pos_y, pos_z, yaw }
    }
}

/// A speed: the default, or any finite value (−1 is the wire form of the default, so it
/// is normalised to `Speed::Default` as decoding does).
fn speed() -> impl Strategy<Value = Speed> {
    prop_oneof![
        1 => Just(Speed::Default),
        4 => finite_f32().prop_map(Speed::from_wire),
    ]
}

/// Every motion command. A gait travels in `Value`, which is read as an `f32`, so only
/// gait numbers an `f32` holds exactly (|n| ≤ 2^24) can round-trip; larger unknown gait
/// numbers are rounded to the nearest `f32` on decoding (see the report).
fn motion_command() -> impl Strategy<Value = MotionCommand> {
    use MotionCommand as M;
    prop_oneof![
        (prop::sample::select(Direction::ALL.to_vec()), speed())
            .prop_map(|(direction, speed)| M::Move(direction, speed)),
        Just(M::ZeroVelocity),
        Just(M::SoftEmergencyStop),
        Just(M::StopStepping),
        Just(M::LieDown),
        prop_oneof![raw_code(), -(1i32 << 24)..=(1 << 24)]
            .prop_filter("an f32 holds the gait exactly", |g| g.unsigned_abs()
                <= 1 << 24)
            .prop_map(|g| M::SwitchGait(MotionGait::from_raw(g))),
        Just(M::StandUp),
        Just(M::ForceControl),
        Just(M::StartStepping),
        finite_f32().prop_map(M::BodyHeight),
        Just(M::GoCharging),
        Just(M::LeaveCharger),
    ]
}

fn request() -> impl Strategy<Value = Request> {
    prop_oneof![
        1 => Just(Request::Status),
        4 => nav_task().prop_map(Request::NavTask),
        1 => Just(Request::CancelNav),
        1 => Just(Request::NavStatus),
        1 => Just(Request::MotorTemperatures),
        2 => light().prop_map(Request::Light),
        4 => motion_command().prop_map(Request::Motion),
        1 => Just(Request::Battery),
        1 => Just(Request::Perception),
        2 => relocalize().prop_map(Request::Relocalize),
    ]
}

fn response() -> impl Strategy<Value = Response> {
    let ack = || {
        raw_code().prop_map(|r| CommandAck {
            result: CommandResult::from_raw(r),
        })
    };
    prop_oneof![
        3 => robot_status().prop_map(Response::Status),
        2 => (any_i32(), raw_code(), raw_code()).prop_map(|(value, outcome, status)| {
            Response::NavResult(NavResult {
                value,
                outcome: NavOutcome::from_raw(outcome),
                status: ErrorStatus::from_raw(status),
            })
        }),
        1 => ack().prop_map(Response::CancelNav),
        1 => (any_i32(), raw_code(), raw_code()).prop_map(|(value, status, error_code)| {
            Response::NavStatus(NavTaskState {
                value,
                status: NavTaskStatus::from_raw(status),
                error_code: NavTaskStatus::from_raw(error_code),
            })
        }),
        2 => uniform12(reading_f32()).prop_map(|t| {
            Response::MotorTemperatures(MotorTemperatures {
                left_front_sway: t[0],
                left_front_hip: t[1],
                left_front_knee: t[2],
                right_front_sway: t[3],
                right_front_hip: t[4],
                right_front_knee: t[5],
                left_back_sway: t[6],
                left_back_hip: t[7],
                left_back_knee: t[8],
                right_back_sway: t[9],
                right_back_hip: t[10],
                right_back_knee: t[11],
            })
        }),
        1 => ack().prop_map(Response::Light),
        2 => (raw_code(), proptest::option::of(reading_f32()), raw_code()).prop_map(|(command, value, result)| {
            Response::Motion(
                MotionCommandCode::from_raw(command),
                MotionAck { value, result: CommandResult::from_raw(result) },
            )
        }),
        2 => (
            uniform4(proptest::option::of(any_i32())),
            proptest::option::of(any_i32()),
            proptest::option::of(raw_code()),
            proptest::option::of(any_i32()),
            proptest::option::of(reading_f32()),
        )
            .prop_map(|([voltage, current, remaining_capacity, nominal_capacity], cycles, protected, battery_level, battery_temperature)| {
                Response::Battery(Battery {
                    voltage,
                    current,
                    remaining_capacity,
                    nominal_capacity,
                    cycles,
                    protected_state: protected.map(ProtectedState::from_raw),
                    battery_level,
                    battery_temperature,
                })
            }),
        1 => raw_code().prop_map(|r| Response::Perception(Perception { obs_state: ObsState::from_raw(r) })),
        1 => raw_code().prop_map(|r| Response::Relocalize(RelocalizeAck { result: LocalizationResult::from_raw(r) })),
        1 => raw_code().prop_map(|r| Response::RequestError(RequestError { code: RequestErrorCode::from_raw(r) })),
    ]
}

/// A request or a response: the two directions are decoded by different functions.
#[derive(Debug, Clone, PartialEq)]
// Test data, built once per case; the size difference does not matter.
#[allow(clippy::large_enum_variant)]
enum Message {
    Request(Request),
    Response(Response),
}

impl Message {
    fn encode(&self, time: &Timestamp, out: &mut [u8]) -> Result<usize, WriteError> {
        match self {
            Self::Request(m) => m.encode(time, out),
            Self::Response(m) => m.encode(time, out),
        }
    }

    /// Decodes `body` in the same direction as `self`.
    fn decode_like(&self, body: &[u8]) -> Result<Decoded<Message>, DecodeError> {
        match self {
            Self::Request(_) => Request::decode(body).map(|d| Decoded {
                time: d.time,
                message: Self::Request(d.message),
                unreadable: d.unreadable,
            }),
            Self::Response(_) => Response::decode(body).map(|d| Decoded {
                time: d.time,
                message: Self::Response(d.message),
                unreadable: d.unreadable,
            }),
        }
    }

    /// Encodes into a [`BODY_BUF`] buffer. Every message fits, except a 1003 request with
    /// many waypoints and long numbers (ten-digit unknown codes, or floats as small as
    /// 1e-45, which the writer prints as 48 characters); that one may use a larger buffer
    /// here, and `largest_valid_message_fits_a_4k_frame` says whether a valid one fits.
    fn encode_to_vec(&self, time: &Timestamp) -> Result<Vec<u8>, TestCaseError> {
        let mut buf = vec![0u8; BODY_BUF];
        let result = match self.encode(time, &mut buf) {
            Err(WriteError::BufferFull) if self.is_nav_task() => {
                buf = vec![0u8; 4 * BODY_BUF];
                self.encode(time, &mut buf)
            }
            other => other,
        };
        let n =
            result.map_err(|e| TestCaseError::fail(format!("encoding {self:?} failed: {e:?}")))?;
        buf.truncate(n);
        Ok(buf)
    }

    fn is_nav_task(&self) -> bool {
        matches!(self, Self::Request(Request::NavTask(_)))
    }

    /// Checks that `body` decodes to `self` and `time`, every item read. Compared as Debug
    /// text, so that a NaN reading in an answer equals itself.
    fn check_decodes(&self, time: Timestamp, body: &[u8]) -> Result<(), TestCaseError> {
        let expected: Result<_, DecodeError> = Ok(Decoded {
            time,
            message: self.clone(),
            unreadable: Unreadable::default(),
        });
        prop_assert_eq!(
            format!("{:?}", self.decode_like(body)),
            format!("{expected:?}"),
            "{}",
            text(body)
        );
        Ok(())
    }
}

fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        request().prop_map(Message::Request),
        response().prop_map(Message::Response),
    ]
}

fn text(body: &[u8]) -> String {
    String::from_utf8_lossy(body).into_owned()
}

/// Checks the invariant the fuzz target also checks: whatever a decoder accepts, it
/// re-encodes (into a buffer large enough for any message) to a document that decodes to
/// the same message, and encoding that again gives the same bytes.
fn check_reencode(body: &[u8]) -> Result<(), TestCaseError> {
    let decoded = [
        Request::decode(body)
            .ok()
            .map(|d| (d.time, Message::Request(d.message))),
        Response::decode(body)
            .ok()
            .map(|d| (d.time, Message::Response(d.message))),
    ];
    for (time, message) in decoded.into_iter().flatten() {
        let mut first = vec![0u8; 16 * 1024];
        let n = message.encode(&time, &mut first).map_err(|e| {
            TestCaseError::fail(format!(
                "{message:?} was decoded from {:?} but does not encode: {e:?}",
                text(body)
            ))
        })?;
        let first = &first[..n];
        message.check_decodes(time, first)?;
        let mut second = vec![0u8; 16 * 1024];
        let m = message
            .encode(&time, &mut second)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        prop_assert_eq!(first, &second[..m]);
    }
    Ok(())
}

/// Checks that the reader's shortcuts for the usual layout yield exactly what the general
/// path yields on `body`: the same decoded request and response (or the same error), and
/// the same items, envelope and errors from the document reader.
fn check_shortcuts(body: &[u8]) -> Result<(), TestCaseError> {
    // Debug text, so that a NaN would compare equal to itself.
    prop_assert_eq!(
        format!("{:?}", Request::decode(body)),
        format!("{:?}", Request::decode_general(body)),
        "Request::decode of {:?}",
        text(body)
    );
    prop_assert_eq!(
        format!("{:?}", Response::decode(body)),
        format!("{:?}", Response::decode_general(body)),
        "Response::decode of {:?}",
        text(body)
    );
    prop_assert_eq!(
        reader_trace(body, true),
        reader_trace(body, false),
        "read_document of {:?}",
        text(body)
    );
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Frame decoder harness
// ---------------------------------------------------------------------------------------

/// What the frame decoder handed out, owned so a whole run can be compared at once.
#[derive(Debug, Clone, PartialEq)]
enum Event {
    Frame { message_id: u16, asdu: Vec<u8> },
    Error(FrameError),
}

/// How the stream is cut into reads: sizes 1..=64, used in turn; the flag says whether
/// that read goes through `feed` or through `spare` + `commit`.
fn read_plan() -> impl Strategy<Value = Vec<(usize, bool)>> {
    vec((1usize..=64, any::<bool>()), 1..12)
}

/// Feeds `stream` to a fresh `FrameDecoder<N>` read by read, draining it after each read,
/// and returns everything it handed out. Fails if the decoder stalls (takes no bytes
/// while it has handed out everything), loops, or hands out a frame longer than `N - 16`.
fn run<const N: usize>(stream: &[u8], plan: &[(usize, bool)]) -> Result<Vec<Event>, TestCaseError> {
    run_as::<N>(Reserved::Refuse, stream, plan)
}

/// [`run`] with a decoder doing `reserved` with non-zero reserved bytes.
fn run_as<const N: usize>(
    reserved: Reserved,
    stream: &[u8],
    plan: &[(usize, bool)],
) -> Result<Vec<Event>, TestCaseError> {
    let mut decoder = FrameDecoder::<N>::new().reserved(reserved);
    let mut events = Vec::new();
    let mut rest = stream;
    let mut reads = plan.iter().cycle();
    // Every event consumes at least one byte, so more events than bytes means a loop.
    let mut budget = stream.len() + 1;
    while !rest.is_empty() {
        let &(size, use_spare) = reads.next().expect("plan is not empty");
        let (mut read, tail) = rest.split_at(size.min(rest.len()));
        rest = tail;
        while !read.is_empty() {
            let taken = if use_spare {
                let spare = decoder.spare();
                let n = spare.len().min(read.len());
                spare[..n].copy_from_slice(&read[..n]);
                decoder.commit(n);
                n
            } else {
                decoder.feed(read)
            };
            prop_assert!(
                taken > 0,
                "decoder stalled with {} bytes left",
                read.len() + rest.len()
            );
            read = &read[taken..];
            while let Some(result) = decoder.decode() {
                prop_assert!(budget > 0, "decoder keeps handing out events");
                budget -= 1;
                events.push(match result {
                    Ok(frame) => {
                        prop_assert!(
                            frame.asdu.len() <= N - HEADER_LEN,
                            "frame of {} bytes from a {N}-byte decoder",
                            frame.asdu.len()
                        );
                        Event::Frame {
                            message_id: frame.message_id,
                            asdu: frame.asdu.to_vec(),
                        }
                    }
                    Err(e) => Event::Error(e),
                });
            }
        }
    }
    Ok(events)
}

/// The ASDU length whose little-endian bytes are `EB 90`, the first half of a sync sequence.
const AMBIGUOUS_LEN: u16 = u16::from_le_bytes([0xEB, 0x90]);

fn frame_bytes(message_id: u16, asdu: &[u8]) -> Vec<u8> {
    let mut out = vec![0; HEADER_LEN + asdu.len()];
    let n = frame::encode(&mut out, message_id, asdu).expect("buffer fits");
    assert_eq!(n, out.len());
    out
}

fn header_bytes(message_id: u16, asdu_len: u16, reserved: [u8; 8]) -> Vec<u8> {
    let mut out = SYNC.to_vec();
    out.extend_from_slice(&asdu_len.to_le_bytes());
    out.extend_from_slice(&message_id.to_le_bytes());
    out.extend_from_slice(&reserved);
    out
}

fn find_sync(bytes: &[u8]) -> Option<usize> {
    bytes.windows(SYNC.len()).position(|w| w == SYNC)
}

/// `bytes` made to look like a body of UTF-8 text to the frame decoder: no sync sequence in
/// it, and not ending in part of one (`EB`, `EB 90`, `EB 90 EB`), which UTF-8 never does.
fn body_text(bytes: Vec<u8>) -> Vec<u8> {
    let mut bytes = without_sync(&[], bytes);
    if let Some(last) = bytes.last_mut()
        && (*last == SYNC[0] || *last == SYNC[1])
    {
        *last = 0;
    }
    bytes
}

/// Zeroes bytes of `bytes` until `fixed ++ bytes` holds no sync sequence. A sync found
/// there must end inside `bytes` (`fixed` is shorter than a sync sequence), so one of its
/// bytes can always be zeroed, and a zero byte is never part of a sync sequence.
fn without_sync(fixed: &[u8], mut bytes: Vec<u8>) -> Vec<u8> {
    assert!(fixed.len() < SYNC.len());
    loop {
        let joined = [fixed, bytes.as_slice()].concat();
        match find_sync(&joined) {
            Some(at) => bytes[at.saturating_sub(fixed.len())] = 0,
            None => return bytes,
        }
    }
}

/// Splits a run's events into the `Garbage` reports at its start (how many, and how many
/// bytes they add up to) and the rest. How garbage is reported (in one report or several,
/// when a sync sequence arrives in pieces) is the decoder's choice; that every byte is
/// accounted for is not.
fn leading_garbage(events: &[Event]) -> (usize, usize, &[Event]) {
    let reports = events
        .iter()
        .take_while(|e| matches!(e, Event::Error(FrameError::Garbage { .. })))
        .count();
    let skipped = events[..reports]
        .iter()
        .map(|e| match e {
            Event::Error(FrameError::Garbage { skipped }) => *skipped,
            _ => unreachable!(),
        })
        .sum();
    (reports, skipped, &events[reports..])
}

/// Bytes that often look like the start of a sync sequence.
fn sync_ish_byte() -> impl Strategy<Value = u8> {
    prop_oneof![3 => any::<u8>(), 1 => Just(0xEB), 1 => Just(0x90)]
}

/// Deterministic filler for the body of an oversized frame, with the first three bytes of
/// a sync sequence sprinkled in, but never a whole one ([`body_text`]): a skipped body is
/// skipped by its length.
fn filler(len: usize, seed: u64) -> Vec<u8> {
    let mut state = seed | 1;
    let mut out = Vec::with_capacity(len);
    while out.len() < len {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        if state.is_multiple_of(97) {
            out.extend_from_slice(&SYNC[..3]);
        } else {
            out.push(state as u8);
        }
    }
    out.truncate(len);
    body_text(out)
}

/// One piece of a stream made only of frames: one that fits the decoder, or one that does not.
#[derive(Debug, Clone)]
enum Piece {
    Fits {
        message_id: u16,
        asdu: Vec<u8>,
    },
    Oversized {
        message_id: u16,
        asdu_len: u16,
        seed: u64,
    },
}

impl Piece {
    fn bytes(&self) -> Vec<u8> {
        match self {
            Self::Fits { message_id, asdu } => frame_bytes(*message_id, asdu),
            Self::Oversized {
                message_id,
                asdu_len,
                seed,
            } => {
                let mut out = header_bytes(*message_id, *asdu_len, [0; 8]);
                out.extend(filler(usize::from(*asdu_len), *seed));
                out
            }
        }
    }

    fn expected(&self) -> Event {
        match self {
            Self::Fits { message_id, asdu } => Event::Frame {
                message_id: *message_id,
                asdu: asdu.clone(),
            },
            Self::Oversized {
                message_id,
                asdu_len,
                ..
            } => Event::Error(FrameError::TooLong {
                message_id: *message_id,
                asdu_len: *asdu_len,
            }),
        }
    }
}

/// A frame whose body fits a decoder with `max_asdu` bytes of body room. Its body holds no
/// sync sequence, as UTF-8 text never does, though it may hold pieces of one.
fn fitting_frame(max_asdu: usize) -> impl Strategy<Value = Piece> {
    (any::<u16>(), vec(sync_ish_byte(), 0..=max_asdu.min(300))).prop_map(|(message_id, asdu)| {
        Piece::Fits {
            message_id,
            asdu: body_text(asdu),
        }
    })
}

/// A frame whose declared body is longer than `max_asdu`: often just longer, sometimes
/// up to the 16-bit limit. Never 37099 (0x90EB), whose header reads `EB 90 EB 90 EB 90`:
/// that length has a test of its own, `frame_declaring_37099_bytes_is_skipped_by_length`.
fn oversized_frame(max_asdu: usize) -> impl Strategy<Value = Piece> {
    let min = max_asdu as u16 + 1;
    let len = prop_oneof![
        4 => min..=min.saturating_add(100),
        1 => min..=u16::MAX,
        1 => Just(u16::MAX),
    ]
    .prop_filter("0x90EB has its own test", |&len| len != AMBIGUOUS_LEN);
    (any::<u16>(), len, any::<u64>()).prop_map(|(message_id, asdu_len, seed)| Piece::Oversized {
        message_id,
        asdu_len,
        seed,
    })
}

fn piece(max_asdu: usize) -> impl Strategy<Value = Piece> {
    prop_oneof![3 => fitting_frame(max_asdu), 1 => oversized_frame(max_asdu)]
}

/// Pieces of a stream for the no-panic property: frames, garbage, lone sync sequences,
/// headers with arbitrary lengths and reserved bytes, truncated frames.
fn chaos_piece() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        vec(sync_ish_byte(), 0..64),
        Just(SYNC.to_vec()),
        Just(SYNC[..3].to_vec()),
        (any::<u16>(), any::<u16>(), any::<[u8; 8]>())
            .prop_map(|(id, len, r)| header_bytes(id, len, r)),
        (any::<u16>(), 0u16..300).prop_map(|(id, len)| header_bytes(id, len, [0; 8])),
        (any::<u16>(), vec(any::<u8>(), 0..200)).prop_map(|(id, body)| frame_bytes(id, &body)),
        (any::<u16>(), vec(any::<u8>(), 1..200), any::<Index>()).prop_map(|(id, body, cut)| {
            let mut f = frame_bytes(id, &body);
            f.truncate(cut.index(f.len()));
            f
        }),
    ]
}

// ---------------------------------------------------------------------------------------
// Document rewriting, for the mutation and layout properties
// ---------------------------------------------------------------------------------------

/// An edit of a document's bytes.
#[derive(Debug, Clone)]
enum Mutation {
    Set(Index, u8),
    FlipBit(Index, u8),
    Insert(Index, Vec<u8>),
    Delete(Index, usize),
    Truncate(Index),
    Duplicate(Index, usize),
}

/// Fragments that make mutations land on interesting parser states.
const FRAGMENTS: &[&str] = &[
    "<",
    ">",
    "/",
    "</",
    "/>",
    "<!--",
    "-->",
    "<?",
    "?>",
    "<!DOCTYPE x>",
    "<![CDATA[x]]>",
    "&",
    "&amp;",
    "&#60;",
    "&#x3C;",
    "&bogus;",
    "'",
    "\"",
    "=",
    " a='b'",
    "<Items>",
    "</Items>",
    "<Items/>",
    "<PatrolDevice>",
    "</PatrolDevice>",
    "<Type>",
    "</Type>",
    "<Command>",
    "</Command>",
    "<Time>",
    "</Time>",
    "<Value>",
    "</Value>",
    "<MapId>",
    "<x><y><z></z></y></x>",
    "-",
    "+",
    ".",
    "e",
    "E",
    "e-",
    "1e39",
    "-1e-46",
    "1e2147483648",
    "E-99999999999",
    "nan",
    "inf",
    "0x10",
    "99999999999",
    "2147483648",
    "-2147483649",
    "340282350000000000000000000000000000000",
    "\u{FEFF}",
    "\u{00e9}",
    "\t",
    "\r\n",
    " ",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    let fragment = select(FRAGMENTS).prop_map(|s| s.as_bytes().to_vec());
    prop_oneof![
        (any::<Index>(), any::<u8>()).prop_map(|(at, b)| Mutation::Set(at, b)),
        (any::<Index>(), 0u8..8).prop_map(|(at, bit)| Mutation::FlipBit(at, bit)),
        (
            any::<Index>(),
            prop_oneof![vec(any::<u8>(), 1..4), fragment]
        )
            .prop_map(|(at, b)| Mutation::Insert(at, b)),
        (any::<Index>(), 1usize..16).prop_map(|(at, n)| Mutation::Delete(at, n)),
        any::<Index>().prop_map(Mutation::Truncate),
        (any::<Index>(), 1usize..40).prop_map(|(at, n)| Mutation::Duplicate(at, n)),
    ]
}

fn mutate(doc: &mut Vec<u8>, mutation: &Mutation) {
    let len = doc.len();
    match mutation {
        Mutation::Set(at, b) if len > 0 => doc[at.index(len)] = *b,
        Mutation::FlipBit(at, bit) if len > 0 => doc[at.index(len)] ^= 1 << bit,
        Mutation::Insert(at, bytes) => {
            let at = at.index(len + 1);
            doc.splice(at..at, bytes.iter().copied());
        }
        Mutation::Delete(at, n) if len > 0 => {
            let at = at.index(len);
            doc.drain(at..(at + n).min(len));
        }
        Mutation::Truncate(at) => doc.truncate(at.index(len + 1)),
        Mutation::Duplicate(at, n) if len > 0 => {
            let at = at.index(len);
            let copy = doc[at..(at + n).min(len)].to_vec();
            doc.splice(at..at, copy);
        }
        _ => {}
    }
}

#[derive(Debug, Clone, Copy)]
enum Declaration {
    Double,
    DoubleSpaced,
    Single,
    WithBom,
    None,
}

impl Declaration {
    fn text(self) -> &'static str {
        match self {
            Self::Double => "<?xml version=\"1.0\" encoding=\"UTF-8\"?>",
            Self::DoubleSpaced => "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>",
            Self::Single => "<?xml version='1.0' encoding='utf-8'?>",
            Self::WithBom => "\u{FEFF}<?xml version=\"1.0\" encoding=\"UTF-8\"?>",
            Self::None => "",
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Indent {
    /// Four spaces per level, as real robots write.
    Robot,
    Tabs,
    Nothing,
    CrLfSpaces,
    /// Runs of spaces shorter and longer than eight, split by tabs, and a space before each
    /// line's end: what a word-at-a-time skip of spaces must step through byte-exactly.
    Ragged,
}

/// One line of an encoded document (declaration removed): nesting depth and trimmed text.
type Line = (usize, String);

/// Splits a document from our writer (2 spaces per level) into lines, dropping the declaration.
fn lines_of(doc: &[u8]) -> Vec<Line> {
    let doc = std::str::from_utf8(doc).expect("the writer produces UTF-8");
    let mut lines = doc.lines();
    assert!(lines.next().is_some_and(|l| l.starts_with("<?xml")));
    lines
        .map(|l| {
            let t = l.trim_start();
            ((l.len() - t.len()) / 2, t.to_owned())
        })
        .collect()
}

fn render(declaration: Declaration, indent: Indent, lines: &[Line]) -> Vec<u8> {
    let (pad, end) = match indent {
        Indent::Tabs => ("\t", "\n"),
        Indent::Nothing => ("", ""),
        Indent::CrLfSpaces => ("  ", "\r\n"),
        Indent::Robot => ("    ", "\n"),
        Indent::Ragged => ("   \t      ", " \n"),
    };
    let mut out = String::from(declaration.text());
    if !matches!(declaration, Declaration::None) {
        out.push_str(end);
    }
    for (depth, line) in lines {
        out.push_str(&pad.repeat(*depth));
        out.push_str(line);
        out.push_str(end);
    }
    out.into_bytes()
}

/// Inserts an XML comment inside an `<Items>` block: between two items at the position
/// `at` picks, or, for a document with only `<Items/>`, as the block's sole content.
fn insert_comment(lines: &mut Vec<Line>, at: Index, comment: &str) {
    let comment = format!("<!--{comment}-->");
    let slots: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].1 == "<Items>" || lines[i].0 == 2)
        .map(|i| i + 1)
        .collect();
    if slots.is_empty() {
        let empty = lines
            .iter_mut()
            .find(|l| l.1 == "<Items/>")
            .expect("every document has Items");
        empty.1 = format!("<Items>{comment}</Items>");
    } else {
        lines.insert(slots[at.index(slots.len())], (2, comment));
    }
}

/// Reorders a document: the children of `<PatrolDevice>` in any order (the `<Items>`
/// blocks keep their order among themselves, as they are a 1003's waypoints), and the
/// items inside each block in any order.
fn shuffle_elements(lines: &[Line], seed: u64) -> Vec<Line> {
    let mut rng = seed | 1;
    let mut next = |n: usize| {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng % n as u64) as usize
    };
    let (open, rest) = lines.split_first().expect("root start");
    let (close, body) = rest.split_last().expect("root end");
    // Children of the root: runs of lines starting at depth 1.
    let mut children: Vec<Vec<Line>> = Vec::new();
    for line in body {
        if line.0 == 1 && !line.1.starts_with("</") {
            children.push(Vec::new());
        }
        children
            .last_mut()
            .expect("a child starts at depth 1")
            .push(line.clone());
    }
    for child in &mut children {
        if child.len() > 2 {
            let last = child.len() - 1;
            let items = &mut child[1..last];
            for i in (1..items.len()).rev() {
                items.swap(i, next(i + 1));
            }
        }
    }
    let is_block = |c: &Vec<Line>| c[0].1.starts_with("<Items");
    let blocks: Vec<Vec<Line>> = children.iter().filter(|c| is_block(c)).cloned().collect();
    for i in (1..children.len()).rev() {
        children.swap(i, next(i + 1));
    }
    let mut blocks = blocks.into_iter();
    let mut out = vec![open.clone()];
    for child in children {
        let child = if is_block(&child) {
            blocks.next().expect("same count")
        } else {
            child
        };
        out.extend(child);
    }
    out.push(close.clone());
    out
}

// ---------------------------------------------------------------------------------------
// Properties
// ---------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(cases(8192))]

    /// Every message encodes into 4 KiB and decodes back equal, Time included.
    #[test]
    fn message_round_trip(message in message(), time in timestamp()) {
        let body = message.encode_to_vec(&time)?;
        check_shortcuts(&body)?;
        message.check_decodes(time, &body)?;
    }

    /// `Response::encode`, which writes each answer item by code of its own in the default
    /// build, gives what `Response::encode_general` (through the item tables) gives: the
    /// same bytes, or the same error, into a buffer of any size, also one that ends in the
    /// middle of an item line.
    #[test]
    fn answers_are_written_alike_both_ways(
        response in response(),
        time in timestamp(),
        room in any::<Index>(),
    ) {
        let mut whole = vec![0u8; BODY_BUF];
        let len = response.encode_general(&time, &mut whole)
            .map_err(|e| TestCaseError::fail(format!("{response:?} does not encode: {e:?}")))?;
        // Sizes up to the text's length and a little past it, where the item lines are
        // written through a window that must fit the buffer.
        let size = room.index(len + 128);
        let (mut straight, mut general) = (vec![0u8; size], vec![0u8; size]);
        let written = response.encode(&time, &mut straight);
        prop_assert_eq!(written, response.encode_general(&time, &mut general), "size {}", size);
        if let Ok(n) = written {
            prop_assert_eq!(text(&straight[..n]), text(&general[..n]));
        }
    }
}

proptest! {
    #![proptest_config(cases(4096))]

    /// Messages framed back to back and read in arbitrary pieces come out of a
    /// `FrameDecoder<4096>` as the same frames, and decode to the same messages.
    #[test]
    fn framed_messages_round_trip(
        messages in vec((message(), timestamp(), any::<u16>()), 1..=3),
        plan in read_plan(),
    ) {
        let mut stream = Vec::new();
        let mut expected = Vec::new();
        for (message, time, id) in &messages {
            let body = message.encode_to_vec(time)?;
            stream.extend(frame_bytes(*id, &body));
            // Only a 1003 request can outgrow the decoder (see encode_to_vec).
            expected.push(if body.len() <= FrameDecoder::<4096>::MAX_ASDU {
                Event::Frame { message_id: *id, asdu: body }
            } else {
                prop_assert!(message.is_nav_task());
                Event::Error(FrameError::TooLong { message_id: *id, asdu_len: body.len() as u16 })
            });
        }
        let events = run::<4096>(&stream, &plan)?;
        prop_assert_eq!(&events, &expected);
        for ((message, time, _), event) in messages.iter().zip(&events) {
            if let Event::Frame { asdu, .. } = event {
                message.check_decodes(*time, asdu)?;
            }
        }
    }

    /// No byte stream panics, stalls or loops the frame decoder, and no frame it hands out
    /// is longer than its buffer allows.
    #[test]
    fn frame_decoder_survives_random_bytes(stream in vec(any::<u8>(), 0..=8192), plan in read_plan()) {
        run::<64>(&stream, &plan)?;
        run::<4096>(&stream, &plan)?;
    }

    /// The same for streams built from frames, partial frames, bad headers and garbage,
    /// which reach far more of the decoder than uniform bytes.
    #[test]
    fn frame_decoder_survives_frame_soup(pieces in vec(chaos_piece(), 0..60), plan in read_plan()) {
        let stream: Vec<u8> = pieces.concat();
        prop_assume!(stream.len() <= 8192);
        run::<64>(&stream, &plan)?;
        run::<256>(&stream, &plan)?;
        run::<4096>(&stream, &plan)?;
    }

    /// A stream of whole frames, some too long for the decoder, yields each frame that fits
    /// and one `TooLong` for each that does not, in order: a frame after an oversized one
    /// (or after several) is never lost, and oversized bodies are skipped by their length.
    #[test]
    fn frames_after_oversized_frames_are_never_lost(
        small in vec(piece(FrameDecoder::<64>::MAX_ASDU), 1..8),
        medium in vec(piece(FrameDecoder::<256>::MAX_ASDU), 1..6),
        large in vec(piece(FrameDecoder::<4096>::MAX_ASDU), 1..4),
        plan in read_plan(),
    ) {
        fn check<const N: usize>(pieces: &[Piece], plan: &[(usize, bool)]) -> Result<(), TestCaseError> {
            let stream: Vec<u8> = pieces.iter().flat_map(Piece::bytes).collect();
            let expected: Vec<Event> = pieces.iter().map(Piece::expected).collect();
            prop_assert_eq!(run::<N>(&stream, plan)?, expected);
            Ok(())
        }
        check::<64>(&small, &plan)?;
        check::<256>(&medium, &plan)?;
        check::<4096>(&large, &plan)?;
    }

    /// A stream of frames, some cut short (a sender that wrote only part of one, then the
    /// next), some too long for the decoder: each frame that fits and is whole comes out,
    /// each one cut in its body is reported with how much of its body came, each one cut in
    /// its header (after more than its sync sequence) as garbage, and each oversized one as
    /// too long (and then as cut short, if it was): no frame after a broken one is lost.
    #[test]
    fn frames_after_frames_cut_short_are_never_lost(
        small in vec((piece(FrameDecoder::<64>::MAX_ASDU), any::<Option<Index>>()), 1..8),
        large in vec((piece(FrameDecoder::<4096>::MAX_ASDU), any::<Option<Index>>()), 1..4),
        last in fitting_frame(FrameDecoder::<64>::MAX_ASDU),
        plan in read_plan(),
    ) {
        fn check<const N: usize>(
            pieces: &[(Piece, Option<Index>)],
            last: &Piece,
            plan: &[(usize, bool)],
        ) -> Result<(), TestCaseError> {
            let mut stream = Vec::new();
            let mut expected = Vec::new();
            for (piece, cut) in pieces {
                let mut bytes = piece.bytes();
                let (message_id, asdu_len) = match piece {
                    Piece::Fits { message_id, asdu } => (*message_id, asdu.len() as u16),
                    Piece::Oversized { message_id, asdu_len, .. } => (*message_id, *asdu_len),
                };
                // Kept: more than the sync sequence, less than the whole frame.
                let first = SYNC.len() + 1;
                let Some(kept) = cut.map(|c| first + c.index(bytes.len() - first)) else {
                    stream.extend(bytes);
                    expected.push(piece.expected());
                    continue;
                };
                bytes.truncate(kept);
                if kept < HEADER_LEN {
                    // A message ID of `EB 90` would put a sync sequence in the header itself.
                    prop_assume!(message_id != u16::from_le_bytes([0xEB, 0x90]));
                    match expected.last_mut() {
                        Some(Event::Error(FrameError::Garbage { skipped })) => *skipped += kept,
                        _ => expected.push(Event::Error(FrameError::Garbage { skipped: kept })),
                    }
                    stream.extend(bytes);
                    continue;
                }
                // A body ending in `EB 90` would make a sync sequence with the next header's
                // first half; such a body is no UTF-8 either.
                if bytes.ends_with(&SYNC[..2]) {
                    *bytes.last_mut().unwrap() = 0;
                }
                if let Piece::Oversized { .. } = piece {
                    expected.push(piece.expected());
                }
                expected.push(Event::Error(FrameError::CutShort {
                    message_id,
                    asdu_len,
                    received: (kept - HEADER_LEN) as u16,
                }));
                stream.extend(bytes);
            }
            stream.extend(last.bytes());
            expected.push(last.expected());
            // Garbage may come in several reports (the decoder's choice): count it in runs.
            let mut got: Vec<Event> = Vec::new();
            for event in run::<N>(&stream, plan)? {
                match (got.last_mut(), event) {
                    (
                        Some(Event::Error(FrameError::Garbage { skipped })),
                        Event::Error(FrameError::Garbage { skipped: more }),
                    ) => *skipped += more,
                    (_, event) => got.push(event),
                }
            }
            prop_assert_eq!(got, expected);
            Ok(())
        }
        check::<64>(&small, &last, &plan)?;
        check::<4096>(&large, &last, &plan)?;
    }

    /// Garbage that holds no sync sequence, then a valid frame: the decoder reports every
    /// garbage byte (in one report or more) and then yields exactly that frame. The garbage
    /// may end in `EB 90`, `EB 90 EB` or `EB`, half a sync sequence in front of a real one.
    #[test]
    fn frame_after_garbage_is_never_lost(
        garbage in vec(sync_ish_byte(), 0..600),
        frame in fitting_frame(FrameDecoder::<256>::MAX_ASDU),
        plan in read_plan(),
    ) {
        let garbage = without_sync(&[], garbage);
        let stream = [garbage.as_slice(), &frame.bytes()].concat();
        for events in [run::<256>(&stream, &plan)?, run::<4096>(&stream, &plan)?] {
            let (reports, skipped, rest) = leading_garbage(&events);
            prop_assert_eq!(rest, &[frame.expected()][..], "events: {:?}", events);
            prop_assert_eq!(skipped, garbage.len(), "events: {:?}", events);
            prop_assert_eq!(reports > 0, !garbage.is_empty());
        }
    }

    /// A client's decoder, which ignores reserved bytes: garbage that holds no sync
    /// sequence (perhaps ending in half of one), then a frame whose reserved bytes are
    /// anything but a sync sequence. The decoder reports every garbage byte and then yields
    /// exactly that frame, as if its reserved bytes were zero.
    #[test]
    fn frame_with_reserved_bytes_set_is_read_when_they_are_ignored(
        garbage in vec(sync_ish_byte(), 0..600),
        frame in fitting_frame(FrameDecoder::<256>::MAX_ASDU),
        reserved in any::<[u8; 8]>(),
        plan in read_plan(),
    ) {
        let garbage = without_sync(&[], garbage);
        let mut bytes = frame.bytes();
        bytes[8..HEADER_LEN].copy_from_slice(&reserved);
        // Reserved bytes that make a sync sequence with the bytes around them, or end an
        // empty frame in part of one, read as a header cut short: this property is about
        // the others.
        prop_assume!(find_sync(&bytes[SYNC.len()..]).is_none());
        prop_assume!(bytes.len() > HEADER_LEN || ![0xEB, 0x90].contains(&bytes[HEADER_LEN - 1]));
        let stream = [garbage.as_slice(), &bytes].concat();
        for events in [
            run_as::<256>(Reserved::Ignore, &stream, &plan)?,
            run_as::<4096>(Reserved::Ignore, &stream, &plan)?,
        ] {
            let (reports, skipped, rest) = leading_garbage(&events);
            prop_assert_eq!(rest, &[frame.expected()][..], "events: {:?}", events);
            prop_assert_eq!(skipped, garbage.len(), "events: {:?}", events);
            prop_assert_eq!(reports > 0, !garbage.is_empty());
        }
    }

    /// A header with non-zero reserved bytes (and any bytes after it that hold no sync
    /// sequence, alone or with the next frame's), then a valid frame: the decoder reports the bad header, drops at least its
    /// first byte and at most its sync sequence, reports the rest as garbage, and then yields
    /// exactly that frame.
    #[test]
    fn frame_after_bad_reserved_header_is_never_lost(
        bad_id in any::<u16>(),
        bad_len in any::<u16>(),
        reserved in any::<[u8; 8]>(),
        nonzero in (1u8..=255, 0usize..8),
        junk in vec(sync_ish_byte(), 0..100),
        frame in fitting_frame(FrameDecoder::<256>::MAX_ASDU),
        plan in read_plan(),
    ) {
        let mut reserved = reserved;
        reserved[nonzero.1] = nonzero.0;
        let header = header_bytes(bad_id, bad_len, reserved);
        // After the bad header's first byte, nothing before the real frame is a sync sequence.
        let mut tail = without_sync(&SYNC[1..], [&header[SYNC.len()..], junk.as_slice()].concat());
        // Nor do its last bytes and the frame's sync sequence make one that starts before the
        // frame (a tail ending in `EB 90`): the decoder would rightly take the bad header for
        // one cut short there.
        while let Some(at) = find_sync(&[tail.as_slice(), &SYNC].concat()).filter(|&at| at < tail.len()) {
            tail[at] = 1;
        }
        if tail[4..12] == [0; 8] {
            tail[11] = 1; // zeroing may have cleared the reserved bytes; 1 is no sync byte
        }
        let bad_id = u16::from_le_bytes([tail[2], tail[3]]);
        let stream = [&SYNC[..], &tail, &frame.bytes()].concat();
        let skippable = SYNC.len() + tail.len();
        for events in [run::<256>(&stream, &plan)?, run::<4096>(&stream, &plan)?] {
            prop_assert_eq!(
                events.first(),
                Some(&Event::Error(FrameError::BadReserved { message_id: bad_id }))
            );
            let (_, skipped, rest) = leading_garbage(&events[1..]);
            prop_assert_eq!(rest, &[frame.expected()][..], "events: {:?}", events);
            prop_assert!(
                (skippable - SYNC.len()..skippable).contains(&skipped),
                "{} garbage bytes reported of {}: {:?}",
                skipped,
                skippable,
                events
            );
        }
    }
}

proptest! {
    #![proptest_config(cases(8192))]

    /// The message decoders never panic on arbitrary bytes, nor on sequences of XML-ish
    /// fragments; whatever they accept re-encodes consistently.
    #[test]
    fn decoders_survive_arbitrary_bytes(
        bytes in prop_oneof![
            vec(any::<u8>(), 0..2048),
            vec(select(FRAGMENTS), 0..80).prop_map(|f| f.concat().into_bytes()),
        ],
    ) {
        check_reencode(&bytes)?;
        check_shortcuts(&bytes)?;
    }

    /// The message decoders never panic on mutations of valid documents (byte changes,
    /// insertions of bytes or markup, deletions, truncations, duplications); whatever they
    /// accept re-encodes consistently.
    #[test]
    fn decoders_survive_mutated_documents(
        message in message(),
        time in timestamp(),
        mutations in vec(mutation(), 1..6),
    ) {
        let mut body = message.encode_to_vec(&time)?;
        for m in &mutations {
            mutate(&mut body, m);
        }
        check_reencode(&body)?;
        check_shortcuts(&body)?;
    }
}

proptest! {
    #![proptest_config(cases(4096))]

    /// A document with another declaration (double or single quotes, a space before `?>`, a
    /// byte-order mark, or none), re-indented as robots do, with tabs, CR LF, ragged runs of
    /// spaces or no whitespace at all, with a comment inside `<Items>`, and followed by NUL
    /// bytes (a C string's terminator counted in the frame's length), decodes to the same
    /// message.
    #[test]
    fn decoders_tolerate_layout(
        message in message(),
        time in timestamp(),
        declaration in prop_oneof![
            Just(Declaration::Double),
            Just(Declaration::DoubleSpaced),
            Just(Declaration::Single),
            Just(Declaration::WithBom),
            Just(Declaration::None),
        ],
        indent in prop_oneof![
            Just(Indent::Robot),
            Just(Indent::Tabs),
            Just(Indent::Nothing),
            Just(Indent::CrLfSpaces),
            Just(Indent::Ragged),
        ],
        comment in proptest::option::of((any::<Index>(), "[a-zA-Z0-9 <>&;'\"=/?!.\u{6ce8}\u{91ca}]{0,24}")),
        nuls in 0usize..3,
    ) {
        let body = message.encode_to_vec(&time)?;
        let mut lines = lines_of(&body);
        if let Some((at, comment)) = &comment {
            insert_comment(&mut lines, *at, comment);
        }
        let mut relaid = render(declaration, indent, &lines);
        relaid.resize(relaid.len() + nuls, 0);
        check_shortcuts(&relaid)?;
        message.check_decodes(time, &relaid)?;
    }

    /// A document whose elements come in another order (header elements and `<Items>`
    /// blocks interleaved differently, items shuffled inside each block) decodes to the
    /// same message.
    #[test]
    fn decoders_tolerate_element_order(message in message(), time in timestamp(), seed in any::<u64>()) {
        let body = message.encode_to_vec(&time)?;
        let lines = shuffle_elements(&lines_of(&body), seed);
        let shuffled = render(Declaration::Double, Indent::Tabs, &lines);
        check_shortcuts(&shuffled)?;
        message.check_decodes(time, &shuffled)?;
    }
}

/// The largest request that passes `validate()` fits `MAX_REQUEST_LEN`, the size a robot-side
/// receiver must accept: a 1003 request with eight waypoints whose numbers and coordinates
/// all have the longest text the writer produces. (Unknown codes with ten digits each make
/// a 1003 request longer still; `validate()` refuses those.)
#[test]
fn largest_valid_request_fits_max_request_len() {
    let text_len = |v: f32| {
        let mut buf = [0u8; 512];
        Request::Motion(MotionCommand::BodyHeight(v))
            .encode(&Timestamp::ZERO, &mut buf)
            .expect("a finite float encodes")
    };
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let longest = (0..200_000)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let f = f32::from_bits(state as u32 | 0x8000_0000);
            if f.is_finite() { f } else { f32::MIN }
        })
        .chain([
            f32::MIN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            -1.175_494_4e-38,
            -f32::from_bits(1),
        ])
        .max_by_key(|&f| text_len(f))
        .unwrap();
    let point = NavPoint::new(
        i32::MIN,
        i32::MIN,
        longest,
        longest,
        longest,
        longest,
        PointInfo::from_raw(3),
    );
    let task = Request::NavTask(NavTask {
        points: heapless::Vec::from_slice(&[point; MAX_NAV_POINTS]).unwrap(),
    });
    assert_eq!(task.validate(), Ok(()));
    let time = Timestamp {
        year: 9999,
        month: 99,
        day: 99,
        hour: 99,
        minute: 99,
        second: 99,
    };
    let mut buf = vec![0u8; 4 * BODY_BUF];
    let n = task.encode(&time, &mut buf).expect("fits 16 KiB");
    assert!(
        n <= MAX_REQUEST_LEN,
        "a valid 1003 request of {n} bytes is longer than MAX_REQUEST_LEN; its coordinates are {longest:e}, written as {}",
        text(&buf[..n])
            .lines()
            .find(|l| l.contains("<PosX>"))
            .unwrap()
            .trim()
    );
}

/// The protocol allows any body length up to 65535 (docs/protocol.md, "Frame header"). A
/// frame declaring 37099 bytes has the length bytes
/// `EB 90`, so its first six bytes read `EB 90 EB 90 EB 90`, exactly what garbage ending
/// in half a sync sequence followed by a real frame looks like. The frame is too long for
/// the decoder, so it must be reported and skipped by length, and the frame after it
/// must not be lost.
#[test]
fn frame_declaring_37099_bytes_is_skipped_by_length() {
    let oversized = Piece::Oversized {
        message_id: 1,
        asdu_len: AMBIGUOUS_LEN,
        seed: 7,
    };
    let next = Piece::Fits {
        message_id: 2,
        asdu: b"<PatrolDevice/>".to_vec(),
    };
    let stream = [oversized.bytes(), next.bytes()].concat();
    for plan in [[(64, false)], [(1, true)]] {
        let events = run::<4096>(&stream, &plan).unwrap();
        assert_eq!(
            events,
            [oversized.expected(), next.expected()],
            "reads {plan:?}"
        );
    }
}

/// Regression for a crash the fuzz target found: an exponent of ten or more digits
/// overflowed `i32` inside the float parser (a panic with overflow checks on, a wrong value
/// without them). Such a value is out of range (or zero, for a negative exponent), and the
/// message decodes or fails accordingly, without panicking.
#[test]
fn float_with_huge_exponent_is_out_of_range() {
    let doc = |value: &str| {
        format!(
            "<PatrolDevice><Type>2</Type><Command>1</Command>\
             <Items><Value>{value}</Value></Items></PatrolDevice>"
        )
    };
    assert_eq!(
        Request::decode(doc("1e2147483648").as_bytes()),
        Err(DecodeError::BadItem {
            item: ItemName::new("Value"),
            error: NumberError::OutOfRange
        })
    );
    assert_eq!(
        Request::decode(doc("1e-99999999999").as_bytes()).map(|d| d.message),
        Ok(Request::Motion(MotionCommand::Move(
            Direction::Forward,
            Speed::Value(0.0)
        )))
    );
    assert!(Request::decode(doc("xE99999999999").as_bytes()).is_err());
}
