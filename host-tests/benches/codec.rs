//! Codec benchmark: our no_std XML codec against quick-xml + serde, and our tokenizer
//! against `xmlparser`, on the two messages that matter most on the wire: a real robot's
//! 1002 status answer (with the undocumented extra items of docs/protocol.md, "Extra
//! items") and a full 1003
//! navigation request.
//!
//! Run it with
//!
//! ```text
//! cd tools && cargo bench -p x30-host-tests --bench codec -- --quick
//! ```
//!
//! Before any timing the binary checks, and panics if not:
//! - both decoders read the same values from both documents, and each side reads back what
//!   the other side wrote (so both do the same work);
//! - our decode and encode of each message perform no heap allocation (a counting
//!   `#[global_allocator]` wraps `System`).
//!
//! Then the binary times each operation itself (warm-up, then the best of many short
//! samples, every operation sampled in turn, round after round, so that load from other
//! processes falls on ours and the reference alike and spreads over each one's samples)
//! and prints a summary table with the speedups against the project's targets (decode and
//! encode ≥ 10×, zero allocations), the tokenizer comparison, and a breakdown of where our
//! 1002 decode and encode spend their time; criterion then measures every operation.
//! Timing is reported, never asserted.
//!
//! Knobs: `--quick` (criterion's quick mode; also shortens the summary timing),
//! `X30_BENCH_MEASURE_MS` (criterion measurement time per benchmark, default 1500 ms;
//! warm-up is a third of it), `X30_BENCH_NO_CRITERION=1` (only the checks and the summary).
//! Under `cargo test --benches` (no `--bench` argument) it runs the checks and each
//! benchmark once, and skips the summary timing.

use std::alloc::{GlobalAlloc, Layout, System};
use std::hint::black_box;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use criterion::Criterion;
use serde::{Deserialize, Serialize};
use x30_panel::proto::codes::{
    ChargeState, ControlMode, GaitState, Location, MotorState, OnDockState,
};
use x30_panel::proto::message::{NavPoint, NavTask, Request, Response, RobotStatus};
use x30_panel::proto::time::Timestamp;
use x30_panel::proto::xml::number;
use x30_panel::proto::xml::reader::Tokenizer;
use x30_panel::proto::xml::writer::{DocumentWriter, ItemName};
use x30_panel::proto::xml::{StructureError, read_document};

// ---------------------------------------------------------------------------------------
// Allocation counting
// ---------------------------------------------------------------------------------------

/// Counts every allocation and reallocation made by this binary.
struct CountingAlloc;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every method forwards to `System` with the caller's arguments unchanged; the
// counter has no effect on the memory handed out.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded from our caller, who upholds `GlobalAlloc::alloc`'s contract.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: as for `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: `ptr` was allocated by this allocator, i.e. by `System`, with `layout`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by this allocator, i.e. by `System`, with `layout`.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

fn allocations() -> usize {
    ALLOCATIONS.load(Ordering::Relaxed)
}

/// Average allocations (alloc + alloc_zeroed + realloc) per call of `f` over `runs` calls.
fn allocations_per_op<R>(runs: usize, mut f: impl FnMut() -> R) -> f64 {
    black_box(f()); // first call may initialise lazily; not counted
    let before = allocations();
    for _ in 0..runs {
        black_box(f());
    }
    (allocations() - before) as f64 / runs as f64
}

// ---------------------------------------------------------------------------------------
// Inputs
// ---------------------------------------------------------------------------------------

/// A 1002 answer as a real robot sends it: 4-space indentation, floats with 8–9
/// significant digits, and the undocumented items `AngleYaw`, `CurRuntime`, `SumRuntime`,
/// `RTKState` and `MapUpdateState` between the documented ones (docs/protocol.md, "Extra
/// items").
const STATUS_1002: &str = include_str!("../data/status-1002.xml");

/// The names of the 1002 answer's items, for the "layout with integer items only" row.
static SKELETON_NAMES: [ItemName; 21] = [
    ItemName::new("MotionState"),
    ItemName::new("PosX"),
    ItemName::new("PosY"),
    ItemName::new("PosZ"),
    ItemName::new("Roll"),
    ItemName::new("Pitch"),
    ItemName::new("Yaw"),
    ItemName::new("Speed"),
    ItemName::new("CurOdom"),
    ItemName::new("SumOdom"),
    ItemName::new("Res"),
    ItemName::new("X0"),
    ItemName::new("Y0"),
    ItemName::new("H"),
    ItemName::new("Electricity"),
    ItemName::new("Location"),
    ItemName::new("GaitState"),
    ItemName::new("MotorState"),
    ItemName::new("ChargeState"),
    ItemName::new("ControlMode"),
    ItemName::new("OnDockState"),
];

/// A 1003 request with all 14 items: a task point on map 2, planned path, walk gait.
const NAV_1003: &str = include_str!("../data/nav-1003.xml");

// ---------------------------------------------------------------------------------------
// The reference: quick-xml + serde
// ---------------------------------------------------------------------------------------

/// The envelope; `I` is the message's items.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "PatrolDevice")]
struct PatrolDevice<I> {
    #[serde(rename = "Type")]
    message_type: i32,
    #[serde(rename = "Command")]
    command: i32,
    #[serde(rename = "Time")]
    time: String,
    #[serde(rename = "Items")]
    items: I,
}

/// The documented 1002 items; the robot's extra items are ignored by serde's default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "PascalCase")]
struct StatusItems {
    motion_state: i32,
    pos_x: f32,
    pos_y: f32,
    pos_z: f32,
    roll: f32,
    pitch: f32,
    yaw: f32,
    speed: f32,
    cur_odom: f32,
    sum_odom: f32,
    res: f32,
    #[serde(rename = "X0")]
    x0: f32,
    #[serde(rename = "Y0")]
    y0: f32,
    h: i32,
    electricity: i32,
    location: i32,
    gait_state: i32,
    motor_state: i32,
    charge_state: i32,
    control_mode: i32,
    on_dock_state: i32,
}

/// The 14 items of one 1003 target point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "PascalCase")]
struct NavItems {
    value: i32,
    #[serde(rename = "MapID", alias = "MapId")]
    map_id: i32,
    pos_x: f32,
    pos_y: f32,
    pos_z: f32,
    angle_yaw: f32,
    point_info: i32,
    gait: i32,
    speed: i32,
    manner: i32,
    obs_mode: i32,
    nav_mode: i32,
    terrain: i32,
    posture: i32,
}

const DECLARATION: &str = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";

fn serde_decode<T: for<'de> Deserialize<'de>>(xml: &str) -> T {
    quick_xml::de::from_str(xml).expect("quick-xml + serde decodes the document")
}

/// Writes the same layout as our writer: declaration, then 2-space indentation.
fn serde_encode<T: Serialize>(value: &T, out: &mut String) -> usize {
    out.clear();
    out.push_str(DECLARATION);
    let mut ser = quick_xml::se::Serializer::new(out);
    ser.indent(' ', 2);
    value
        .serialize(ser)
        .expect("quick-xml + serde encodes the document");
    out.len()
}

// ---------------------------------------------------------------------------------------
// Our side
// ---------------------------------------------------------------------------------------

/// Large enough for either document.
const BUF_LEN: usize = 2048;

fn our_decode_status(xml: &[u8]) -> (Timestamp, RobotStatus) {
    match Response::decode(xml) {
        Ok(decoded) => match decoded.message {
            Response::Status(status) => (decoded.time, status),
            other => panic!("1002 decoded as {other:?}"),
        },
        Err(e) => panic!("our decoder refused the 1002 answer: {e:?}"),
    }
}

fn our_decode_nav(xml: &[u8]) -> (Timestamp, NavTask) {
    match Request::decode(xml) {
        Ok(decoded) => match decoded.message {
            Request::NavTask(task) => (decoded.time, task),
            other => panic!("1003 decoded as {other:?}"),
        },
        Err(e) => panic!("our decoder refused the 1003 request: {e:?}"),
    }
}

fn our_encode_response(message: &Response, time: &Timestamp, out: &mut [u8]) -> usize {
    message
        .encode(time, out)
        .expect("our encoder writes the 1002 answer")
}

fn our_encode_request(message: &Request, time: &Timestamp, out: &mut [u8]) -> usize {
    message
        .encode(time, out)
        .expect("our encoder writes the 1003 request")
}

fn our_tokenize(xml: &[u8]) -> usize {
    let mut tokens = Tokenizer::document(xml);
    let mut count = 0;
    while let Some(token) = tokens
        .next_token()
        .expect("our tokenizer accepts the document")
    {
        black_box(token);
        count += 1;
    }
    count
}

fn xmlparser_tokenize(xml: &str) -> usize {
    let mut count = 0;
    for token in xmlparser::Tokenizer::from(xml) {
        black_box(token.expect("xmlparser accepts the document"));
        count += 1;
    }
    count
}

// ---------------------------------------------------------------------------------------
// Checks: equal information on both sides, no allocation on ours
// ---------------------------------------------------------------------------------------

fn time_text(time: &Timestamp) -> String {
    let mut text = [0; x30_panel::proto::time::TIME_TEXT_LEN];
    time.encode(&mut text);
    String::from_utf8(text.to_vec()).expect("the time text is ASCII")
}

/// Fails unless our status and serde's status hold exactly the same values.
fn assert_same_status(
    context: &str,
    ours: &(Timestamp, RobotStatus),
    theirs: &PatrolDevice<StatusItems>,
) {
    let (time, s) = ours;
    let t = &theirs.items;
    assert_eq!(
        (theirs.message_type, theirs.command),
        (1002, 1),
        "{context}: header"
    );
    assert_eq!(time_text(time), theirs.time, "{context}: Time");
    let floats = [
        ("PosX", s.pos_x, t.pos_x),
        ("PosY", s.pos_y, t.pos_y),
        ("PosZ", s.pos_z, t.pos_z),
        ("Roll", s.roll, t.roll),
        ("Pitch", s.pitch, t.pitch),
        ("Yaw", s.yaw, t.yaw),
        ("Speed", s.speed, t.speed),
        ("CurOdom", s.cur_odom, t.cur_odom),
        ("SumOdom", s.sum_odom, t.sum_odom),
        ("Res", s.res, t.res),
        ("X0", s.x0, t.x0),
        ("Y0", s.y0, t.y0),
    ];
    for (name, a, b) in floats {
        assert_eq!(
            a.to_bits(),
            b.to_bits(),
            "{context}: {name}: ours {a:?}, serde {b:?}"
        );
    }
    let ints = [
        ("MotionState", Some(s.motion_state.raw()), t.motion_state),
        ("H", s.h, t.h),
        ("Electricity", s.electricity, t.electricity),
        ("Location", s.location.map(Location::raw), t.location),
        ("GaitState", s.gait_state.map(GaitState::raw), t.gait_state),
        (
            "MotorState",
            s.motor_state.map(MotorState::raw),
            t.motor_state,
        ),
        (
            "ChargeState",
            s.charge_state.map(ChargeState::raw),
            t.charge_state,
        ),
        (
            "ControlMode",
            s.control_mode.map(ControlMode::raw),
            t.control_mode,
        ),
        (
            "OnDockState",
            s.on_dock_state.map(OnDockState::raw),
            t.on_dock_state,
        ),
    ];
    for (name, a, b) in ints {
        assert_eq!(a, Some(b), "{context}: {name}");
    }
}

/// Fails unless our one-point task and serde's items hold exactly the same values.
fn assert_same_nav(context: &str, ours: &(Timestamp, NavTask), theirs: &PatrolDevice<NavItems>) {
    let (time, task) = ours;
    assert_eq!(task.points.len(), 1, "{context}: one point");
    let p: &NavPoint = &task.points[0];
    let t = &theirs.items;
    assert_eq!(
        (theirs.message_type, theirs.command),
        (1003, 1),
        "{context}: header"
    );
    assert_eq!(time_text(time), theirs.time, "{context}: Time");
    let floats = [
        ("PosX", p.pos_x, t.pos_x),
        ("PosY", p.pos_y, t.pos_y),
        ("PosZ", p.pos_z, t.pos_z),
        ("AngleYaw", p.angle_yaw, t.angle_yaw),
    ];
    for (name, a, b) in floats {
        assert_eq!(
            a.to_bits(),
            b.to_bits(),
            "{context}: {name}: ours {a:?}, serde {b:?}"
        );
    }
    let ints = [
        ("Value", p.value, t.value),
        ("MapID", p.map_id, t.map_id),
        ("PointInfo", p.point_info.raw(), t.point_info),
        ("Gait", p.gait.raw(), t.gait),
        ("Speed", p.speed.raw(), t.speed),
        ("Manner", p.manner.raw(), t.manner),
        ("ObsMode", p.obs_mode.raw(), t.obs_mode),
        ("NavMode", p.nav_mode.raw(), t.nav_mode),
        ("Terrain", p.terrain.raw(), t.terrain),
        ("Posture", p.posture.raw(), t.posture),
    ];
    for (name, a, b) in ints {
        assert_eq!(a, b, "{context}: {name}");
    }
}

/// Everything the benchmarks work on, decoded once from the inputs.
struct Fixtures {
    status_time: Timestamp,
    status: Response,
    nav_time: Timestamp,
    nav: Request,
    serde_status: PatrolDevice<StatusItems>,
    serde_nav: PatrolDevice<NavItems>,
}

/// Checks that both sides read and write the same information; returns the decoded values.
fn check_equivalence() -> Fixtures {
    let ours_status = our_decode_status(STATUS_1002.as_bytes());
    let serde_status: PatrolDevice<StatusItems> = serde_decode(STATUS_1002);
    assert_same_status("decode 1002", &ours_status, &serde_status);

    let ours_nav = our_decode_nav(NAV_1003.as_bytes());
    let serde_nav: PatrolDevice<NavItems> = serde_decode(NAV_1003);
    assert_same_nav("decode 1003", &ours_nav, &serde_nav);

    let fixtures = Fixtures {
        status_time: ours_status.0,
        status: Response::Status(ours_status.1),
        nav_time: ours_nav.0,
        nav: Request::NavTask(ours_nav.1.clone()),
        serde_status,
        serde_nav,
    };

    // Each side reads back what the other wrote, so both encoders carry the same values.
    let mut buf = [0u8; BUF_LEN];
    let mut text = String::new();

    let n = our_encode_response(&fixtures.status, &fixtures.status_time, &mut buf);
    let ours_xml = std::str::from_utf8(&buf[..n]).expect("our output is UTF-8");
    assert_same_status(
        "serde reads our 1002",
        &ours_status,
        &serde_decode(ours_xml),
    );
    serde_encode(&fixtures.serde_status, &mut text);
    assert_same_status(
        "we read serde's 1002",
        &our_decode_status(text.as_bytes()),
        &fixtures.serde_status,
    );

    let n = our_encode_request(&fixtures.nav, &fixtures.nav_time, &mut buf);
    let ours_xml = std::str::from_utf8(&buf[..n]).expect("our output is UTF-8");
    assert_same_nav("serde reads our 1003", &ours_nav, &serde_decode(ours_xml));
    serde_encode(&fixtures.serde_nav, &mut text);
    assert_same_nav(
        "we read serde's 1003",
        &our_decode_nav(text.as_bytes()),
        &fixtures.serde_nav,
    );

    fixtures
}

/// Allocations per operation, measured outside any timing.
struct AllocationReport {
    ours: [f64; 4],
    serde: [f64; 4],
    our_tokenizer: f64,
    xmlparser: f64,
}

/// Asserts that one decode and one encode of each of our messages allocates nothing, and
/// counts allocations per op on both sides.
fn check_allocations(f: &Fixtures) -> AllocationReport {
    let mut buf = [0u8; BUF_LEN];

    // Exactly one call each, as the project's rule asks.
    let before = allocations();
    black_box(our_decode_status(black_box(STATUS_1002.as_bytes())));
    assert_eq!(allocations(), before, "our 1002 decode allocated");
    black_box(our_decode_nav(black_box(NAV_1003.as_bytes())));
    assert_eq!(allocations(), before, "our 1003 decode allocated");
    black_box(our_encode_response(
        black_box(&f.status),
        &f.status_time,
        &mut buf,
    ));
    assert_eq!(allocations(), before, "our 1002 encode allocated");
    black_box(our_encode_request(black_box(&f.nav), &f.nav_time, &mut buf));
    assert_eq!(allocations(), before, "our 1003 encode allocated");

    const RUNS: usize = 100;
    let mut text = String::with_capacity(BUF_LEN);
    let report = AllocationReport {
        ours: [
            allocations_per_op(RUNS, || {
                our_decode_status(black_box(STATUS_1002.as_bytes()))
            }),
            allocations_per_op(RUNS, || our_decode_nav(black_box(NAV_1003.as_bytes()))),
            allocations_per_op(RUNS, || {
                our_encode_response(black_box(&f.status), &f.status_time, &mut buf)
            }),
            allocations_per_op(RUNS, || {
                our_encode_request(black_box(&f.nav), &f.nav_time, &mut buf)
            }),
        ],
        serde: [
            allocations_per_op(RUNS, || {
                serde_decode::<PatrolDevice<StatusItems>>(black_box(STATUS_1002))
            }),
            allocations_per_op(RUNS, || {
                serde_decode::<PatrolDevice<NavItems>>(black_box(NAV_1003))
            }),
            allocations_per_op(RUNS, || serde_encode(black_box(&f.serde_status), &mut text)),
            allocations_per_op(RUNS, || serde_encode(black_box(&f.serde_nav), &mut text)),
        ],
        our_tokenizer: allocations_per_op(RUNS, || our_tokenize(black_box(STATUS_1002.as_bytes()))),
        xmlparser: allocations_per_op(RUNS, || xmlparser_tokenize(black_box(STATUS_1002))),
    };
    assert!(
        report.ours.iter().all(|&a| a == 0.0),
        "our codec allocated: {:?}",
        report.ours
    );
    report
}

// ---------------------------------------------------------------------------------------
// Criterion
// ---------------------------------------------------------------------------------------

fn criterion_benches(c: &mut Criterion, f: &Fixtures) {
    let mut buf = [0u8; BUF_LEN];
    let mut text = String::with_capacity(BUF_LEN);

    let mut group = c.benchmark_group("decode");
    group.bench_function("1002/ours", |b| {
        b.iter(|| our_decode_status(black_box(STATUS_1002.as_bytes())))
    });
    group.bench_function("1002/quick-xml+serde", |b| {
        b.iter(|| serde_decode::<PatrolDevice<StatusItems>>(black_box(STATUS_1002)))
    });
    group.bench_function("1003/ours", |b| {
        b.iter(|| our_decode_nav(black_box(NAV_1003.as_bytes())))
    });
    group.bench_function("1003/quick-xml+serde", |b| {
        b.iter(|| serde_decode::<PatrolDevice<NavItems>>(black_box(NAV_1003)))
    });
    group.finish();

    let mut group = c.benchmark_group("encode");
    group.bench_function("1002/ours", |b| {
        b.iter(|| our_encode_response(black_box(&f.status), &f.status_time, &mut buf))
    });
    group.bench_function("1002/quick-xml+serde", |b| {
        b.iter(|| serde_encode(black_box(&f.serde_status), &mut text))
    });
    group.bench_function("1003/ours", |b| {
        b.iter(|| our_encode_request(black_box(&f.nav), &f.nav_time, &mut buf))
    });
    group.bench_function("1003/quick-xml+serde", |b| {
        b.iter(|| serde_encode(black_box(&f.serde_nav), &mut text))
    });
    group.finish();

    let mut group = c.benchmark_group("tokenize");
    group.bench_function("1002/ours", |b| {
        b.iter(|| our_tokenize(black_box(STATUS_1002.as_bytes())))
    });
    group.bench_function("1002/xmlparser", |b| {
        b.iter(|| xmlparser_tokenize(black_box(STATUS_1002)))
    });
    group.finish();
}

// ---------------------------------------------------------------------------------------
// Summary timing
// ---------------------------------------------------------------------------------------

/// How long the summary spends on each operation.
#[derive(Clone, Copy)]
struct Budget {
    warm_up: Duration,
    sample: Duration,
    samples: usize,
}

/// One operation as the summary times it: called with a batch size, it makes that many
/// calls and returns the time per call in ns. Boxed so that operations with different
/// results take turns in one loop; the call through the box is made once a batch.
type Operation<'a> = Box<dyn FnMut(u64) -> f64 + 'a>;

/// `f` as an [`Operation`].
fn operation<'a, R>(mut f: impl FnMut() -> R + 'a) -> Operation<'a> {
    Box::new(move |batch| {
        let start = Instant::now();
        for _ in 0..batch {
            black_box(f());
        }
        start.elapsed().as_secs_f64() * 1e9 / batch as f64
    })
}

/// Warms `op` up for `budget.warm_up`; returns how many calls make one sample.
fn calibrate(budget: Budget, op: &mut Operation) -> u64 {
    // Batches of a few calls, so that reading the clock adds little to the estimate.
    const WARM_UP_BATCH: u64 = 16;
    let start = Instant::now();
    let mut calls = 0u64;
    while start.elapsed() < budget.warm_up {
        op(WARM_UP_BATCH);
        calls += WARM_UP_BATCH;
    }
    let per_call = start.elapsed().as_secs_f64() / calls.max(1) as f64;
    ((budget.sample.as_secs_f64() / per_call.max(1e-9)) as u64).max(1)
}

/// Time per call of each operation, in ns: each is warmed up, then sampled
/// `budget.samples` times in batches sized to last about `budget.sample`, and its fastest
/// sample kept (on a shared machine other processes only ever add time). The operations
/// take turns, one batch each a round, so that a busy spell of the machine falls on all of
/// them alike, ours and the reference's, and no operation has every sample in one spell.
fn time_in_turn<const N: usize>(budget: Budget, mut ops: [Operation; N]) -> [f64; N] {
    let batches = ops.each_mut().map(|op| calibrate(budget, op));
    let mut fastest = [f64::INFINITY; N];
    for _ in 0..budget.samples {
        for ((op, &batch), fastest) in ops.iter_mut().zip(&batches).zip(&mut fastest) {
            *fastest = fastest.min(op(batch));
        }
    }
    fastest
}

/// The texts of every item of the 1002 answer we keep, floats and integers apart.
fn status_item_texts() -> (Vec<&'static [u8]>, Vec<&'static [u8]>) {
    const FLOATS: [&str; 12] = [
        "PosX", "PosY", "PosZ", "Roll", "Pitch", "Yaw", "Speed", "CurOdom", "SumOdom", "Res", "X0",
        "Y0",
    ];
    let mut floats = Vec::new();
    let mut ints = Vec::new();
    read_document(STATUS_1002.as_bytes(), |_, items| {
        for item in items {
            let item = item.expect("the item reads");
            let text = item.text.expect("the item is text");
            let name = std::str::from_utf8(item.name).expect("names are ASCII");
            if FLOATS.contains(&name) {
                floats.push(text);
            } else if !matches!(
                name,
                "AngleYaw" | "CurRuntime" | "SumRuntime" | "RTKState" | "MapUpdateState"
            ) {
                ints.push(text);
            }
        }
        Ok::<_, StructureError>(())
    })
    .expect("the document reads");
    (floats, ints)
}

fn summary(f: &Fixtures, allocs: &AllocationReport, quick: bool) {
    let budget = if quick {
        Budget {
            warm_up: Duration::from_millis(30),
            sample: Duration::from_millis(3),
            samples: 15,
        }
    } else {
        Budget {
            warm_up: Duration::from_millis(150),
            sample: Duration::from_millis(5),
            samples: 41,
        }
    };
    // Where our 1002 decode and encode spend their time: the inputs of the breakdown.
    let (float_texts, int_texts) = status_item_texts();
    let Response::Status(status) = &f.status else {
        unreachable!("the 1002 fixture is a status")
    };
    let float_values = [
        status.pos_x,
        status.pos_y,
        status.pos_z,
        status.roll,
        status.pitch,
        status.yaw,
        status.speed,
        status.cur_odom,
        status.sum_odom,
        status.res,
        status.x0,
        status.y0,
    ];
    // Every operation writes to a buffer of its own: all of them are alive at once.
    let mut status_buf = [0u8; BUF_LEN];
    let mut nav_buf = [0u8; BUF_LEN];
    let mut skeleton_buf = [0u8; BUF_LEN];
    let mut status_text = String::with_capacity(BUF_LEN);
    let mut nav_text = String::with_capacity(BUF_LEN);

    let [
        decode_status,
        decode_status_serde,
        decode_nav,
        decode_nav_serde,
        encode_status,
        encode_status_serde,
        encode_nav,
        encode_nav_serde,
        our_tok,
        xmlparser_tok,
        items_walk,
        general_decode,
        parse_ours,
        parse_core,
        write_floats_ours,
        write_floats_core,
        skeleton,
    ] = time_in_turn(
        budget,
        [
            operation(|| our_decode_status(black_box(STATUS_1002.as_bytes()))),
            operation(|| serde_decode::<PatrolDevice<StatusItems>>(black_box(STATUS_1002))),
            operation(|| our_decode_nav(black_box(NAV_1003.as_bytes()))),
            operation(|| serde_decode::<PatrolDevice<NavItems>>(black_box(NAV_1003))),
            operation(|| {
                our_encode_response(black_box(&f.status), &f.status_time, &mut status_buf)
            }),
            operation(|| serde_encode(black_box(&f.serde_status), &mut status_text)),
            operation(|| our_encode_request(black_box(&f.nav), &f.nav_time, &mut nav_buf)),
            operation(|| serde_encode(black_box(&f.serde_nav), &mut nav_text)),
            operation(|| our_tokenize(black_box(STATUS_1002.as_bytes()))),
            operation(|| xmlparser_tokenize(black_box(STATUS_1002))),
            operation(|| {
                let mut n = 0usize;
                read_document(black_box(STATUS_1002.as_bytes()), |_, items| {
                    for item in items {
                        n += item.map_or(0, |i| i.name.len());
                    }
                    Ok::<_, StructureError>(())
                })
                .expect("the document reads");
                n
            }),
            operation(|| {
                Response::decode_general(black_box(STATUS_1002.as_bytes())).map(|d| d.time.second)
            }),
            operation(|| {
                let mut sum = 0.0f32;
                for t in &float_texts {
                    sum += number::parse_f32(black_box(t)).unwrap_or(0.0);
                }
                for t in &int_texts {
                    sum += number::parse_int::<i32>(black_box(t)).unwrap_or(0) as f32;
                }
                sum
            }),
            operation(|| {
                let mut sum = 0.0f32;
                for t in &float_texts {
                    let s = std::str::from_utf8(black_box(t)).unwrap_or("0");
                    sum += s.parse::<f32>().unwrap_or(0.0);
                }
                for t in &int_texts {
                    let s = std::str::from_utf8(black_box(t)).unwrap_or("0");
                    sum += s.parse::<i32>().unwrap_or(0) as f32;
                }
                sum
            }),
            operation(|| {
                let mut n = 0;
                let mut out = [0u8; number::F32_TEXT_MAX];
                for v in black_box(&float_values) {
                    n += number::write_f32(*v, &mut out).unwrap_or(0);
                    black_box(&out);
                }
                n
            }),
            operation(|| {
                use std::io::Write;
                let mut n = 0;
                let mut out = [0u8; 32];
                for v in black_box(&float_values) {
                    let mut cursor = std::io::Cursor::new(&mut out[..]);
                    let _ = write!(cursor, "{v}");
                    n += cursor.position() as usize;
                    black_box(&out);
                }
                n
            }),
            operation(|| {
                // The 1002 layout with every value already as text: markup cost alone.
                let mut doc =
                    DocumentWriter::begin(&mut skeleton_buf, 1002, 1, black_box(&f.status_time))
                        .expect("the header fits");
                for name in &SKELETON_NAMES {
                    doc.int_item(*name, 0).expect("the item fits");
                }
                doc.finish().expect("the document fits")
            }),
        ],
    );
    let ours = [decode_status, decode_nav, encode_status, encode_nav];
    let serde = [
        decode_status_serde,
        decode_nav_serde,
        encode_status_serde,
        encode_nav_serde,
    ];

    let names = [
        "decode 1002 status",
        "decode 1003 nav task",
        "encode 1002 status",
        "encode 1003 nav task",
    ];
    // Issue 13's targets: at least 10x quick-xml + serde in each direction on each message
    // (15x is the stretch goal for decoding).
    let targets = [10.0, 10.0, 10.0, 10.0];
    println!();
    println!("==================== x30-panel codec vs quick-xml 0.42 + serde ====================");
    println!(
        "{:<22} {:>10} {:>12} {:>9} {:>7} {:>5}  {:>11} {:>11}",
        "operation", "ours ns", "serde ns", "speedup", "target", "met", "ours alloc", "serde alloc"
    );
    let mut all_met = true;
    for i in 0..4 {
        let speedup = serde[i] / ours[i];
        let met = speedup >= targets[i];
        all_met &= met;
        println!(
            "{:<22} {:>10.0} {:>12.0} {:>8.2}x {:>6.0}x {:>5}  {:>11.1} {:>11.1}",
            names[i],
            ours[i],
            serde[i],
            speedup,
            targets[i],
            if met { "yes" } else { "NO" },
            allocs.ours[i],
            allocs.serde[i],
        );
    }
    let decode_speedup = (serde[0] + serde[1]) / (ours[0] + ours[1]);
    let encode_speedup = (serde[2] + serde[3]) / (ours[2] + ours[3]);
    let zero_allocs = allocs.ours.iter().all(|&a| a == 0.0);
    println!(
        "------------------------------------------------------------------------------------"
    );
    println!(
        "decode speedup = serde_ns / ours_ns (both messages): {decode_speedup:.2}x  target >= 10x: {}  stretch >= 15x: {}",
        if decode_speedup >= 10.0 {
            "met"
        } else {
            "NOT met"
        },
        if decode_speedup >= 15.0 {
            "met"
        } else {
            "NOT met"
        }
    );
    println!(
        "encode speedup = serde_ns / ours_ns (both messages): {encode_speedup:.2}x  target >= 10x: {}",
        if encode_speedup >= 10.0 {
            "met"
        } else {
            "NOT met"
        }
    );
    println!(
        "allocations per op, ours: {:?}  target 0: {}",
        allocs.ours,
        if zero_allocs { "met" } else { "NOT met" }
    );
    println!(
        "all per-message targets met: {}",
        if all_met && zero_allocs { "yes" } else { "no" }
    );
    println!();
    println!("tokenizer, 1002 answer ({} bytes):", STATUS_1002.len());
    println!(
        "  ours      {:>8.0} ns  ({} tokens, {:.1} alloc/op)",
        our_tok,
        our_tokenize(STATUS_1002.as_bytes()),
        allocs.our_tokenizer
    );
    println!(
        "  xmlparser {:>8.0} ns  ({} tokens, {:.1} alloc/op)",
        xmlparser_tok,
        xmlparser_tokenize(STATUS_1002),
        allocs.xmlparser
    );
    println!(
        "  xmlparser_ns / ours_ns = {:.2} -> {} is faster",
        xmlparser_tok / our_tok,
        if our_tok <= xmlparser_tok {
            "ours"
        } else {
            "xmlparser"
        }
    );
    println!();
    println!("where our 1002 time goes (ns per whole document):");
    println!("  read_document: full XML check, every item    {items_walk:>8.0}");
    println!(
        "  parse {} floats + {} ints, ours             {parse_ours:>8.0}   (core str::parse: {parse_core:.0})",
        float_texts.len(),
        int_texts.len()
    );
    println!(
        "  full decode                                 {:>8.0}",
        ours[0]
    );
    println!("  full decode, general path (no shortcuts)    {general_decode:>8.0}");
    println!(
        "  write {} floats, ours                       {write_floats_ours:>8.0}   (core Display: {write_floats_core:.0})",
        float_values.len()
    );
    println!("  write the layout with integer items only    {skeleton:>8.0}");
    println!(
        "  full encode                                 {:>8.0}",
        ours[2]
    );
    println!(
        "===================================================================================="
    );
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "(ns/op = best of {} samples of ~{} ms after warm-up, every operation sampled in turn, \
         round after round; load average {}; timings are not asserted)",
        budget.samples,
        budget.sample.as_millis(),
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!("(machine: {})", machine());
    println!(
        "(codec build: {})",
        if cfg!(feature = "compact") {
            "compact, its fast paths left out"
        } else {
            "default, with its fast paths"
        }
    );
}

/// The processor this run measured, from `/proc/cpuinfo`: the ratios differ between
/// processors (a Zen 4 EPYC runs the reference relatively faster than an older EPYC does),
/// so a table compares only with runs on the same kind.
fn machine() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |key: &str| {
        info.lines()
            .filter_map(|line| line.split_once(':'))
            .find(|(k, _)| k.trim() == key)
            .map_or("?", |(_, v)| v.trim())
    };
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{}, family {} model {}, {cores} cores",
        field("model name"),
        field("cpu family"),
        field("model"),
    )
}

// ---------------------------------------------------------------------------------------
// Main
// ---------------------------------------------------------------------------------------

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let has = |flag: &str| args.iter().any(|a| a == flag);
    if has("--list") {
        // Listing must print only the benchmark names.
        let fixtures = check_equivalence();
        let mut c = Criterion::default().configure_from_args();
        criterion_benches(&mut c, &fixtures);
        return;
    }
    // Criterion's own rule: without `--bench` (cargo test --benches) or with `--test`, run
    // each benchmark once as a test.
    let bench_mode = has("--bench") && !has("--test") && !has("--profile-time");
    let quick = has("--quick") || std::env::var_os("X30_BENCH_QUICK").is_some();

    let fixtures = check_equivalence();
    println!(
        "check: both decoders read identical values from the 1002 and 1003 documents, and each reads the other's output"
    );
    let allocs = check_allocations(&fixtures);
    println!("check: our decode and encode of 1002 and 1003 made no heap allocation");

    // The summary first: after a minute of criterion at full load, this shared machine runs
    // slower for a while, and the summary's figures are the ones the README quotes.
    if bench_mode {
        summary(&fixtures, &allocs, quick);
    }

    if std::env::var_os("X30_BENCH_NO_CRITERION").is_none() {
        let measure_ms = std::env::var("X30_BENCH_MEASURE_MS")
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(1500);
        let mut c = Criterion::default()
            .without_plots()
            .sample_size(50)
            .warm_up_time(Duration::from_millis(measure_ms / 3))
            .measurement_time(Duration::from_millis(measure_ms))
            .configure_from_args();
        criterion_benches(&mut c, &fixtures);
        c.final_summary();
    }

    if !bench_mode {
        println!(
            "test mode: every benchmark ran once; summary timing skipped (run `cargo bench --bench codec`)"
        );
    }
}
