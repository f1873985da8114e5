//! Every message of docs/protocol.md ("Message types" and the Type sections after it) in
//! both directions: the vendor document's sample decoded with
//! each value asserted, then encoded and decoded again, equal.

// Expected floats are written exactly as a robot sends them (9 significant digits), not
// as the shortest f32 literal or a named constant, so the test shows what is on the wire.
#![allow(clippy::excessive_precision, clippy::approx_constant)]

use x30_panel::proto::codes::*;
use x30_panel::proto::message::*;
use x30_panel::proto::time::Timestamp;
use x30_panel::proto::xml::number::NumberError;
use x30_panel::proto::xml::writer::ItemName;

const T0: Timestamp = Timestamp::DOCUMENT_EPOCH;
const T1: Timestamp = Timestamp {
    second: 1,
    ..Timestamp::DOCUMENT_EPOCH
};

fn request(xml: &str) -> Decoded<Request> {
    Request::decode(xml.as_bytes()).unwrap_or_else(|e| panic!("{e:?} decoding\n{xml}"))
}

fn response(xml: &str) -> Decoded<Response> {
    Response::decode(xml.as_bytes()).unwrap_or_else(|e| panic!("{e:?} decoding\n{xml}"))
}

/// A document of `message_type` with `items` in its block, without a declaration.
fn document(message_type: u16, items: &str) -> String {
    format!(
        "<PatrolDevice><Type>{message_type}</Type><Command>1</Command>\
         <Time>2023-01-01 00:00:00</Time><Items>{items}</Items></PatrolDevice>"
    )
}

/// Encodes the decoded message and decodes it again: it must come back equal.
fn assert_request_round_trip(decoded: &Decoded<Request>) {
    let mut buf = [0u8; 4096];
    let n = decoded.message.encode(&decoded.time, &mut buf).unwrap();
    let again = Request::decode(&buf[..n]).unwrap();
    assert_eq!(&again, decoded, "{}", String::from_utf8_lossy(&buf[..n]));
}

fn assert_response_round_trip(decoded: &Decoded<Response>) {
    let mut buf = [0u8; 4096];
    let n = decoded.message.encode(&decoded.time, &mut buf).unwrap();
    let again = Response::decode(&buf[..n]).unwrap();
    assert_eq!(&again, decoded, "{}", String::from_utf8_lossy(&buf[..n]));
}

/// The requests with `<Items/>`, as the document writes them (both declaration styles).
#[test]
fn empty_requests() {
    let cases = [
        ("1002", "\"1.0\" encoding=\"UTF-8\"", Request::Status),
        ("1004", "\"1.0\" encoding=\"UTF-8\"", Request::CancelNav),
        ("1007", "\"1.0\" encoding=\"UTF-8\"", Request::NavStatus),
        ("1008", "'1.0' encoding='utf-8'", Request::MotorTemperatures),
        ("2001", "'1.0' encoding='utf-8'", Request::Battery),
        ("2002", "'1.0' encoding='utf-8'", Request::Perception),
    ];
    for (ty, decl, expected) in cases {
        let xml = format!(
            "<?xml version={decl}?>\n<PatrolDevice>\n  <Type>{ty}</Type>\n  <Command>1</Command>\n  <Time>2023-01-01 00:00:00</Time>\n  <Items/>\n</PatrolDevice>\n"
        );
        let decoded = request(&xml);
        assert_eq!(decoded.message, expected);
        assert_eq!(decoded.time, T0);
        assert_request_round_trip(&decoded);
    }
}

/// Our encoder writes the document's own layout for an empty request, byte for byte.
#[test]
fn encoder_writes_the_document_layout() {
    let mut buf = [0u8; 512];
    let n = Request::Status.encode(&T0, &mut buf).unwrap();
    assert_eq!(
        std::str::from_utf8(&buf[..n]).unwrap(),
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>\n  <Type>1002</Type>\n  <Command>1</Command>\n  <Time>2023-01-01 00:00:00</Time>\n  <Items/>\n</PatrolDevice>\n"
    );
    let n = Request::Motion(MotionCommand::Move(Direction::Forward, Speed::Default))
        .encode(&T0, &mut buf)
        .unwrap();
    assert_eq!(
        std::str::from_utf8(&buf[..n]).unwrap(),
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>\n  <Type>2</Type>\n  <Command>1</Command>\n  <Time>2023-01-01 00:00:00</Time>\n  <Items>\n    <Value>-1</Value>\n  </Items>\n</PatrolDevice>\n"
    );
}

#[test]
fn status_1002_response() {
    let decoded = response(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<PatrolDevice>
  <Type>1002</Type>
  <Command>1</Command>
  <Time>2023-01-01 00:00:01</Time>
  <Items>
    <MotionState>0</MotionState>
    <PosX>0.0</PosX>
    <PosY>0.0</PosY>
    <PosZ>0.0</PosZ>
    <Roll>0.0</Roll>
    <Pitch>0.0</Pitch>
    <Yaw>0.0</Yaw>
    <Speed>0.0</Speed>
    <CurOdom>0.0</CurOdom>
    <SumOdom>0.0</SumOdom>
    <Res>0.0</Res>
    <X0>0.0</X0>
    <Y0>0.0</Y0>
    <H>1000</H>
    <Electricity>50</Electricity>
    <Location>0</Location>
    <GaitState>0</GaitState>
    <MotorState>0</MotorState>
    <ChargeState>0</ChargeState>
    <ControlMode>0</ControlMode>
    <OnDockState>0</OnDockState>
</Items>
</PatrolDevice>"#,
    );
    assert_eq!(decoded.time, T1);
    let Response::Status(s) = decoded.message else {
        panic!("{decoded:?}")
    };
    assert_eq!(s.motion_state, MotionState::LyingDown);
    for v in [s.pos_x, s.pos_y, s.pos_z, s.roll, s.pitch, s.yaw, s.speed] {
        assert_eq!(v, 0.0);
    }
    assert_eq!(
        (s.cur_odom, s.sum_odom, s.res, s.x0, s.y0),
        (0.0, 0.0, 0.0, 0.0, 0.0)
    );
    assert_eq!(s.h, Some(1000));
    assert_eq!(s.electricity, Some(50));
    assert_eq!(s.location, Some(Location::Localized));
    assert_eq!(s.gait_state, Some(GaitState::Walk));
    assert_eq!(s.motor_state, Some(MotorState::Normal));
    assert_eq!(s.charge_state, Some(ChargeState::NotCharging));
    assert_eq!(s.control_mode, Some(ControlMode::Manual));
    assert_eq!(s.on_dock_state, Some(OnDockState::OffDock));
    assert!(!s.is_unavailable(), "H and Electricity are not 0");
    assert_response_round_trip(&decoded);
}

/// A real robot's answer: extra items between the documented ones, 8–9 digit floats.
#[test]
fn status_1002_from_a_real_robot_with_extra_items() {
    let decoded = response(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<PatrolDevice>\n<Type>1002</Type>\n<Command>1</Command>\n<Time>2024-06-30 23:59:59</Time>\n<Items>\n\
         <MotionState>4</MotionState><PosX>12.3456783</PosX><PosY>-0.00023393621</PosY><PosZ>0.0312</PosZ>\
         <AngleYaw>1.57079637</AngleYaw><Roll>0.0012</Roll><Pitch>-0.0034</Pitch><Yaw>3.14159274</Yaw><Speed>0.5</Speed>\
         <CurRuntime>3600</CurRuntime><CurOdom>1.25</CurOdom><SumRuntime>123456</SumRuntime><SumOdom>1234.5</SumOdom>\
         <Res>0.05</Res><X0>-10.5</X0><Y0>-20.25</Y0><H>800</H><Electricity>87</Electricity><RTKState>0</RTKState>\
         <Location>1</Location><GaitState>8</GaitState><MotorState>1</MotorState><MapUpdateState>2</MapUpdateState>\
         <ChargeState>1</ChargeState><ControlMode>1</ControlMode><OnDockState>1</OnDockState>\n</Items>\n</PatrolDevice>",
    );
    assert_eq!(
        decoded.time,
        Timestamp {
            year: 2024,
            month: 6,
            day: 30,
            hour: 23,
            minute: 59,
            second: 59
        }
    );
    let Response::Status(s) = decoded.message else {
        panic!()
    };
    assert_eq!(s.motion_state, MotionState::Stepping);
    assert_eq!(s.pos_x, 12.3456783);
    assert_eq!(s.pos_y, -0.00023393621);
    assert_eq!(s.yaw, 3.14159274);
    assert_eq!(s.sum_odom, 1234.5);
    assert_eq!(s.res, 0.05);
    assert_eq!((s.x0, s.y0, s.h), (-10.5, -20.25, Some(800)));
    assert_eq!(s.electricity, Some(87));
    assert_eq!(s.location, Some(Location::Lost));
    assert_eq!(s.gait_state, Some(GaitState::AccumulatedFrameStairs45));
    assert_eq!(s.motor_state, Some(MotorState::OverTemperature));
    assert_eq!(s.charge_state, Some(ChargeState::Charging));
    assert_eq!(s.control_mode, Some(ControlMode::Automatic));
    assert_eq!(s.on_dock_state, Some(OnDockState::OnDock));
    assert_response_round_trip(&decoded);
}

/// Items are found by name whatever their order and the ASCII case of their names: a
/// status answer with its items reversed and every name in upper or lower case decodes to
/// the same message (so the reader's quick test for unknown names never drops a known one).
#[test]
fn items_are_found_in_any_order_and_any_case() {
    let mut buf = [0u8; 4096];
    let status = response(STATUS_WITH_EVERY_ITEM);
    let n = status.message.encode(&status.time, &mut buf).unwrap();
    let text = std::str::from_utf8(&buf[..n]).unwrap();
    let (head, rest) = text.split_once("<Items>\n").unwrap();
    let (items, tail) = rest.split_once("  </Items>").unwrap();
    for fold in [str::to_uppercase, str::to_lowercase] {
        let lines: Vec<String> = items
            .lines()
            .rev()
            .map(|line| {
                let (name, value) = line.trim().trim_start_matches('<').split_once('>').unwrap();
                let (value, _) = value.split_once("</").unwrap();
                let name = fold(name);
                format!("<{name}>{value}</{name}>\n")
            })
            .collect();
        let shuffled = format!("{head}<Items>\n{}  </Items>{tail}", lines.concat());
        assert_eq!(response(&shuffled), status, "{shuffled}");
    }
}

const STATUS_WITH_EVERY_ITEM: &str = "<PatrolDevice><Type>1002</Type><Command>1</Command><Time>2024-06-30 23:59:59</Time><Items>\
    <MotionState>4</MotionState><PosX>12.3456783</PosX><PosY>-0.00023393621</PosY><PosZ>0.0312</PosZ>\
    <Roll>0.0012</Roll><Pitch>-0.0034</Pitch><Yaw>3.14159274</Yaw><Speed>0.5</Speed><CurOdom>1.25</CurOdom>\
    <SumOdom>1234.5</SumOdom><Res>0.05</Res><X0>-10.5</X0><Y0>-20.25</Y0><H>800</H><Electricity>87</Electricity>\
    <Location>1</Location><GaitState>8</GaitState><MotorState>1</MotorState><ChargeState>1</ChargeState>\
    <ControlMode>1</ControlMode><OnDockState>1</OnDockState></Items></PatrolDevice>";

#[test]
fn status_all_zero_is_unavailable() {
    let items: String = [
        "MotionState",
        "PosX",
        "PosY",
        "PosZ",
        "Roll",
        "Pitch",
        "Yaw",
        "Speed",
        "CurOdom",
        "SumOdom",
        "Res",
        "X0",
        "Y0",
        "H",
        "Electricity",
        "Location",
        "GaitState",
        "MotorState",
        "ChargeState",
        "ControlMode",
        "OnDockState",
    ]
    .iter()
    .map(|n| format!("<{n}>0</{n}>"))
    .collect();
    let xml = document(1002, &items);
    let Response::Status(s) = response(&xml).message else {
        panic!()
    };
    assert!(s.is_unavailable());
    assert_eq!(
        s,
        RobotStatus::UNAVAILABLE,
        "the all-zero answer is the named constant"
    );
    let moved = RobotStatus { pos_x: 0.1, ..s };
    assert!(!moved.is_unavailable());
    let charged = RobotStatus {
        electricity: Some(1),
        ..s
    };
    assert!(!charged.is_unavailable());
}

#[test]
fn status_with_motion_state_alone_reads_the_rest_as_not_reported() {
    let xml = "<PatrolDevice><Type>1002</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><MotionState>6</MotionState></Items></PatrolDevice>";
    let Response::Status(s) = response(xml).message else {
        panic!("not a status")
    };
    assert_eq!(s.motion_state, MotionState::SoftEmergencyStop);
    let floats = [
        s.pos_x, s.pos_y, s.pos_z, s.roll, s.pitch, s.yaw, s.speed, s.cur_odom, s.sum_odom, s.res,
        s.x0, s.y0,
    ];
    assert!(floats.iter().all(|f| f.is_nan()), "{floats:?}");
    assert_eq!((s.h, s.electricity), (None, None));
    assert_eq!(
        (s.location, s.gait_state, s.motor_state),
        (None, None, None)
    );
    assert_eq!(
        (s.charge_state, s.control_mode, s.on_dock_state),
        (None, None, None)
    );
    assert_eq!(s.map_image(), None);
    // One item is no all-zero pattern: a robot lying down is lying down.
    let lying = RobotStatus {
        motion_state: MotionState::LyingDown,
        ..s
    };
    assert!(!lying.is_unavailable());
}

#[test]
fn status_missing_items_keeps_the_others() {
    let xml = "<PatrolDevice><Type>1002</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items>\
        <MotionState>4</MotionState><PosX>1.5</PosX><PosY>2.5</PosY><X0>-10</X0><Y0>-10</Y0>\
        <H>400</H><Electricity>80</Electricity><GaitState>2</GaitState></Items></PatrolDevice>";
    let Response::Status(s) = response(xml).message else {
        panic!("not a status")
    };
    assert_eq!(
        (s.motion_state, s.pos_x, s.pos_y),
        (MotionState::Stepping, 1.5, 2.5)
    );
    assert_eq!((s.h, s.electricity), (Some(400), Some(80)));
    assert_eq!((s.gait_state, s.location), (Some(GaitState::Slope), None));
    assert!(s.res.is_nan() && s.yaw.is_nan());
    // Without Res the map image is there, but no point maps to a pixel.
    let image = s.map_image().expect("H is reported");
    assert_eq!(image.to_pixel(s.pos_x, s.pos_y), None);
    assert!(!s.is_unavailable());
}

/// A reading the panel cannot read is no reading: the robot's C library under a locale with
/// a decimal comma, MSVC's NaN, an empty element, an element holding elements, an integer
/// beyond 32 bits. Each such optional item is not reported, and named as unreadable, and
/// the rest of the status is read, by both readers; `MotionState` written so still refuses
/// it, and a request item written so is refused.
#[test]
fn an_unreadable_optional_item_in_an_answer_is_not_reported() {
    let status = |items: &str| document(1002, items);
    let unreadable = status(
        "<MotionState>6</MotionState><PosX>12,345678</PosX><PosY>-nan(ind)</PosY><PosZ></PosZ>\
         <Roll/><Pitch><Value>1</Value></Pitch><Yaw>1.5</Yaw><H>4294967295</H><Electricity>87</Electricity>\
         <GaitState>0x1</GaitState><Location>1e0</Location><MotorState>0</MotorState>",
    );
    for decode in [Response::decode, Response::decode_general] {
        let Ok(Decoded {
            message: Response::Status(s),
            unreadable: unread_items,
            ..
        }) = decode(unreadable.as_bytes())
        else {
            panic!("the status is refused");
        };
        let names: Vec<String> = unread_items.names().map(|n| n.to_string()).collect();
        assert_eq!(
            names,
            [
                "PosX",
                "PosY",
                "PosZ",
                "Roll",
                "Pitch",
                "H",
                "Location",
                "GaitState"
            ],
            "the items that could not be read, in the table's order"
        );
        assert_eq!(
            unread_items.to_string(),
            "PosX, PosY, PosZ, Roll, Pitch, H, Location, GaitState"
        );
        assert_eq!(s.motion_state, MotionState::SoftEmergencyStop);
        let unread = [s.pos_x, s.pos_y, s.pos_z, s.roll, s.pitch];
        assert!(unread.iter().all(|f| f.is_nan()), "{unread:?}");
        assert_eq!((s.h, s.gait_state, s.location), (None, None, None));
        assert_eq!(
            (s.yaw, s.electricity, s.motor_state),
            (1.5, Some(87), Some(MotorState::Normal)),
            "the items that could be read"
        );
    }
    let whole = Response::decode(status("<MotionState>6</MotionState><PosX>1.5</PosX>").as_bytes());
    assert!(whole.is_ok_and(|d| d.unreadable.is_empty()));
    assert_eq!(
        Response::decode(status("<MotionState>6,0</MotionState>").as_bytes()),
        Err(DecodeError::BadItem {
            item: ItemName::new("MotionState"),
            error: NumberError::Invalid,
        })
    );
    assert!(matches!(
        Request::decode(NAV_REQUEST.replace("<PosX>0.0<", "<PosX>0,5<").as_bytes()),
        Err(DecodeError::BadItem { item, .. }) if item.as_bytes() == b"PosX"
    ));
}

#[test]
fn status_without_motion_state_is_refused_naming_it() {
    let xml = "<PatrolDevice><Type>1002</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><PosX>1</PosX><Electricity>50</Electricity></Items></PatrolDevice>";
    assert_eq!(
        Response::decode(xml.as_bytes()),
        Err(DecodeError::MissingItem(ItemName::new("MotionState")))
    );
}

const NAV_REQUEST: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<PatrolDevice>
  <Type>1003</Type>
  <Command>1</Command>
  <Time>2023-01-01 00:00:00</Time>
  <Items>
      <Value>100</Value>
      <MapID>1</MapID>
      <PosX>0.0</PosX>
      <PosY>0.0</PosY>
      <PosZ>0.0</PosZ>
      <AngleYaw>0.0</AngleYaw>
      <PointInfo>0</PointInfo>
      <Gait>0</Gait>
      <Speed>0</Speed>
      <Manner>0</Manner>
      <ObsMode>0</ObsMode>
      <NavMode>0</NavMode>
      <Terrain>0</Terrain>
      <Posture>0</Posture>
  </Items>
</PatrolDevice>"#;

#[test]
fn nav_task_1003_request() {
    let decoded = request(NAV_REQUEST);
    let Request::NavTask(task) = &decoded.message else {
        panic!()
    };
    assert_eq!(task.points.len(), 1);
    let p = task.points[0];
    assert_eq!(
        p,
        NavPoint::new(100, 1, 0.0, 0.0, 0.0, 0.0, PointInfo::Transition)
    );
    assert_eq!(p.gait, NavGait::Walk);
    assert_eq!(p.speed, NavSpeed::Normal);
    assert_eq!(p.manner, Manner::Forwards);
    assert_eq!(p.obs_mode, ObsMode::Enabled);
    assert_eq!(p.nav_mode, NavMode::StraightLine);
    assert_eq!(p.terrain, Terrain::Solid);
    assert_eq!(p.posture, Posture::Normal);
    assert_request_round_trip(&decoded);
}

#[test]
fn nav_task_with_every_value_set() {
    let xml = NAV_REQUEST
        .replace("<Value>100", "<Value>7")
        .replace("<MapID>1</MapID>", "<MapID>3</MapID>")
        .replace("<PosX>0.0", "<PosX>-1.25")
        .replace("<PosY>0.0", "<PosY>2.5")
        .replace("<PosZ>0.0", "<PosZ>0.125")
        .replace("<AngleYaw>0.0", "<AngleYaw>-3.1415927")
        .replace("<PointInfo>0", "<PointInfo>3")
        .replace("<Gait>0", "<Gait>7")
        .replace("<Speed>0", "<Speed>2")
        .replace("<Manner>0", "<Manner>1")
        .replace("<ObsMode>0", "<ObsMode>1")
        .replace("<NavMode>0", "<NavMode>1")
        .replace("<Terrain>0", "<Terrain>3")
        .replace("<Posture>0", "<Posture>1");
    let decoded = request(&xml);
    let Request::NavTask(task) = &decoded.message else {
        panic!()
    };
    let p = task.points[0];
    assert_eq!((p.value, p.map_id), (7, 3));
    assert_eq!(
        (p.pos_x, p.pos_y, p.pos_z, p.angle_yaw),
        (-1.25, 2.5, 0.125, -3.1415927)
    );
    assert_eq!(p.point_info, PointInfo::Charging);
    assert_eq!(p.gait, NavGait::AccumulatedFrameStairs45);
    assert_eq!(p.speed, NavSpeed::High);
    assert_eq!(p.manner, Manner::Backwards);
    assert_eq!(p.obs_mode, ObsMode::Disabled);
    assert_eq!(p.nav_mode, NavMode::Autonomous);
    assert_eq!(p.terrain, Terrain::AccumulatedFrame);
    assert_eq!(p.posture, Posture::Crouched);
    assert_request_round_trip(&decoded);
}

/// Several `<Items>` blocks, `MapId` spelling, no declaration, tabs and comments
/// (docs/protocol.md, "Beyond the document").
#[test]
fn nav_task_with_waypoints_as_real_clients_send_it() {
    let point = |value: i32, x: f32| {
        format!(
            "\t<Items>\n\t\t<!-- waypoint {value} -->\n\t\t<Value>{value}</Value>\n\t\t<MapId>2</MapId>\n\t\t<PosX>{x}</PosX>\n\t\t<PosY>1</PosY>\n\t\t<PosZ>0</PosZ>\n\t\t<AngleYaw>0</AngleYaw>\n\t\t<PointInfo>1</PointInfo>\n\t\t<Gait>0</Gait>\n\t\t<Speed>1</Speed>\n\t\t<Manner>0</Manner>\n\t\t<ObsMode>0</ObsMode>\n\t\t<NavMode>1</NavMode>\n\t\t<Terrain>0</Terrain>\n\t</Items>\n"
        )
    };
    let xml = format!(
        "<PatrolDevice>\n\t<Time>2023-01-01 00:00:00</Time>\n{}{}\t<Command>1</Command>\n\t<Type>1003</Type>\n</PatrolDevice>",
        point(1, 0.5),
        point(2, 4.75)
    );
    let decoded = request(&xml);
    let Request::NavTask(task) = &decoded.message else {
        panic!()
    };
    assert_eq!(task.points.len(), 2);
    assert_eq!(task.points[0].value, 1);
    assert_eq!(task.points[1].value, 2);
    assert_eq!(task.points[1].pos_x, 4.75);
    assert!(task.points.iter().all(|p| p.map_id == 2));
    assert!(
        task.points.iter().all(|p| p.posture == Posture::Normal),
        "absent Posture is normal height"
    );
    assert_eq!(task.target().map(|p| p.value), Some(2));
    assert_request_round_trip(&decoded);
}

#[test]
fn nav_task_encoder_writes_map_id_as_the_document_spells_it() {
    let task = NavTask::to_point(NavPoint::new(5, 1, 1.0, 2.0, 0.0, 0.5, PointInfo::Charging));
    let mut buf = [0u8; 1024];
    let n = Request::NavTask(task).encode(&T0, &mut buf).unwrap();
    let text = std::str::from_utf8(&buf[..n]).unwrap();
    assert!(text.contains("<MapID>1</MapID>"), "{text}");
    assert!(!text.contains("MapId"), "{text}");
}

#[test]
fn nav_result_1003_response() {
    let decoded = response(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<PatrolDevice>
  <Type>1003</Type>
  <Command>1</Command>
  <Time>2023-01-01 00:00:01</Time>
  <Items>
    <Value>100</Value>
    <ErrorCode>0</ErrorCode>
    <ErrorStatus>0</ErrorStatus>
  </Items>
</PatrolDevice>"#,
    );
    assert_eq!(
        decoded.message,
        Response::NavResult(NavResult {
            value: 100,
            outcome: NavOutcome::Succeeded,
            status: ErrorStatus::Default
        })
    );
    assert_response_round_trip(&decoded);

    let failed = response(
        "<PatrolDevice><Type>1003</Type><Command>1</Command><Time>2023-01-01 00:00:01</Time><Items><Value>3</Value><ErrorCode>1</ErrorCode><ErrorStatus>41730</ErrorStatus></Items></PatrolDevice>",
    );
    let Response::NavResult(r) = failed.message else {
        panic!()
    };
    assert_eq!(r.outcome, NavOutcome::Failed);
    assert_eq!(r.status, ErrorStatus::BatteryTooLow);
    assert_eq!(r.status.description(), "battery too low");
}

#[test]
fn cancel_1004_response() {
    let decoded = response(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<PatrolDevice>
    <Type>1004</Type>
    <Command>1</Command>
    <Time>2023-01-01 00:00:01</Time>
    <Items>
        <ErrorCode>0</ErrorCode>
    </Items>
</PatrolDevice>"#,
    );
    assert_eq!(
        decoded.message,
        Response::CancelNav(CommandAck {
            result: CommandResult::Success
        })
    );
    assert_response_round_trip(&decoded);
}

#[test]
fn nav_status_1007_response() {
    let decoded = response(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<PatrolDevice>
  <Type>1007</Type>
  <Command>1</Command>
  <Time>2023-01-01 00:00:01</Time>
      <Items>
          <Value>0</Value>
          <Status>0</Status>
          <ErrorCode>0</ErrorCode>
     </Items>
 </PatrolDevice>"#,
    );
    assert_eq!(
        decoded.message,
        Response::NavStatus(NavTaskState {
            value: 0,
            status: NavTaskStatus::Finished,
            error_code: NavTaskStatus::Finished
        })
    );
    assert_response_round_trip(&decoded);
    let cannot = response(
        "<PatrolDevice><Type>1007</Type><Command>1</Command><Time>2023-01-01 00:00:01</Time><Items><Value>9</Value><Status>-1</Status><ErrorCode>-1</ErrorCode></Items></PatrolDevice>",
    );
    let Response::NavStatus(s) = cannot.message else {
        panic!()
    };
    assert_eq!((s.value, s.status), (9, NavTaskStatus::CannotRun));
}

#[test]
fn motion_2_request_and_response() {
    let decoded = request(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<PatrolDevice>
    <Type>2</Type>
    <Command>1</Command>
    <Time>2023-01-01 00:00:00</Time>
    <Items>
        <Value>-1</Value>
    </Items>
</PatrolDevice>"#,
    );
    assert_eq!(
        decoded.message,
        Request::Motion(MotionCommand::Move(Direction::Forward, Speed::Default))
    );
    assert_request_round_trip(&decoded);

    let ack = response(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<PatrolDevice>
    <Type>2</Type>
    <Command>1</Command>
    <Time>2023-01-01 00:00:00</Time>
    <Items>
        <Value>-1</Value>
        <ErrorCode>0</ErrorCode>
    </Items>
</PatrolDevice>"#,
    );
    assert_eq!(
        ack.message,
        Response::Motion(
            MotionCommandCode::Forward,
            MotionAck {
                value: Some(-1.0),
                result: CommandResult::Success
            }
        )
    );
    assert_response_round_trip(&ack);
}

/// A Type 2 request's `Value` is found without regard to ASCII case, as every other item
/// is, for a float and for a gait alike.
#[test]
fn motion_request_value_in_any_case() {
    let motion = |command: i32, item: &str| {
        format!(
            "<PatrolDevice><Type>2</Type><Command>{command}</Command>\
             <Time>2023-01-01 00:00:00</Time><Items>{item}</Items></PatrolDevice>"
        )
    };
    for decode in [Request::decode, Request::decode_general] {
        for name in ["VALUE", "value", "vAlUe"] {
            let walk = decode(motion(1, &format!("<{name}>0.5</{name}>")).as_bytes());
            assert_eq!(
                walk.map(|d| d.message),
                Ok(Request::Motion(MotionCommand::Move(
                    Direction::Forward,
                    Speed::Value(0.5)
                ))),
                "{name}"
            );
            let gait = decode(motion(20, &format!("<{name}>4</{name}>")).as_bytes());
            assert_eq!(
                gait.map(|d| d.message),
                Ok(Request::Motion(MotionCommand::SwitchGait(
                    MotionGait::from_raw(4)
                ))),
                "{name}"
            );
        }
    }
}

/// An answer's item that is there twice reads as its last occurrence: readable after an
/// unreadable one, it is reported and not named unreadable; unreadable after a readable
/// one, it is named unreadable and not reported. Never both.
#[test]
fn an_item_there_twice_reads_as_its_last_occurrence() {
    let status = |items: &str| {
        document(
            1002,
            &format!("<MotionState>0</MotionState>{items}<Electricity>87</Electricity>"),
        )
    };
    for decode in [Response::decode, Response::decode_general] {
        let read = |items: &str| {
            let Ok(Decoded {
                message: Response::Status(s),
                unreadable,
                ..
            }) = decode(status(items).as_bytes())
            else {
                panic!("the status is refused: {items}");
            };
            let names: Vec<String> = unreadable.names().map(|n| n.to_string()).collect();
            (s.h, s.pos_x.to_bits(), names)
        };
        let none: Vec<String> = Vec::new();
        assert_eq!(
            read("<H>abc</H><H>5</H>"),
            (Some(5), f32::NAN.to_bits(), none.clone())
        );
        assert_eq!(
            read("<H>5</H><H>abc</H>"),
            (None, f32::NAN.to_bits(), vec!["H".to_string()])
        );
        // Out of the table's order, so the second is found by the search, not in sequence.
        assert_eq!(
            read("<PosX>1,5</PosX><H>1</H><PosX>1.5</PosX>"),
            (Some(1), 1.5f32.to_bits(), none.clone())
        );
        assert_eq!(
            read("<H>x</H><PosX>2</PosX><H>7</H>"),
            (Some(7), 2f32.to_bits(), none.clone())
        );
        // A float unreadable after a readable one reads as left out: NaN, not the first.
        assert_eq!(
            read("<PosX>1.5</PosX><H>1</H><PosX>1,5</PosX>"),
            (Some(1), f32::NAN.to_bits(), vec!["PosX".to_string()])
        );
    }
}

/// A Type 2 answer that leaves out the `Value` echo is read: its `ErrorCode` alone says
/// what the robot did. It encodes back without `Value`.
#[test]
fn motion_answer_without_value() {
    let ack = response(
        "<PatrolDevice><Type>2</Type><Command>13</Command><Time>2023-01-01 00:00:00</Time>\
         <Items><ErrorCode>0</ErrorCode></Items></PatrolDevice>",
    );
    assert_eq!(
        ack.message,
        Response::Motion(
            MotionCommandCode::SoftEmergencyStop,
            MotionAck {
                value: None,
                result: CommandResult::Success
            }
        )
    );
    let mut out = [0u8; 512];
    let n = ack.message.encode(&ack.time, &mut out).unwrap();
    let text = std::str::from_utf8(&out[..n]).unwrap();
    assert!(!text.contains("<Value>"), "{text}");
    assert_response_round_trip(&ack);
    // Without ErrorCode it is still refused, naming the item.
    let no_result = Response::decode(
        b"<PatrolDevice><Type>2</Type><Command>13</Command><Time>2023-01-01 00:00:00</Time>\
          <Items><Value>-1</Value></Items></PatrolDevice>",
    );
    assert!(
        matches!(no_result, Err(DecodeError::MissingItem(name)) if name.as_bytes() == b"ErrorCode"),
        "{no_result:?}"
    );
}

/// All eleven V1.0.12 commands and the vendor extensions, with their Command and Value.
#[test]
fn motion_every_command() {
    let cases: Vec<(MotionCommand, i32, &str)> = vec![
        (
            MotionCommand::Move(Direction::Forward, Speed::Value(1.5)),
            1,
            "1.5",
        ),
        (
            MotionCommand::Move(Direction::Backward, Speed::Value(1.3)),
            2,
            "1.3",
        ),
        (
            MotionCommand::Move(Direction::TurnLeft, Speed::Value(0.45)),
            3,
            "0.45",
        ),
        (
            MotionCommand::Move(Direction::TurnRight, Speed::Default),
            4,
            "-1",
        ),
        (MotionCommand::ZeroVelocity, 6, "-1"),
        (
            MotionCommand::Move(Direction::StrafeLeft, Speed::Value(0.1)),
            11,
            "0.1",
        ),
        (
            MotionCommand::Move(Direction::StrafeRight, Speed::Value(0.15)),
            12,
            "0.15",
        ),
        (MotionCommand::SoftEmergencyStop, 13, "-1"),
        (MotionCommand::StopStepping, 14, "-1"),
        (MotionCommand::LieDown, 15, "-1"),
        (
            MotionCommand::SwitchGait(MotionGait::PerceptionStairs),
            20,
            "4",
        ),
        (MotionCommand::StandUp, 16, "-1"),
        (MotionCommand::ForceControl, 17, "-1"),
        (MotionCommand::StartStepping, 18, "-1"),
        (MotionCommand::BodyHeight(0.25), 19, "0.25"),
        (MotionCommand::GoCharging, 21, "-1"),
        (MotionCommand::LeaveCharger, 22, "-1"),
    ];
    for (command, code, value) in cases {
        let request = Request::Motion(command);
        assert_eq!(request.command(), code);
        let mut buf = [0u8; 512];
        let n = request.encode(&T0, &mut buf).unwrap();
        let text = std::str::from_utf8(&buf[..n]).unwrap();
        assert!(
            text.contains(&format!("<Command>{code}</Command>")),
            "{text}"
        );
        assert!(text.contains(&format!("<Value>{value}</Value>")), "{text}");
        assert_eq!(Request::decode(&buf[..n]).unwrap().message, request);
    }
}

#[test]
fn motion_unknown_command_is_reported() {
    let xml = "<PatrolDevice><Type>2</Type><Command>99</Command><Time>2023-01-01 00:00:00</Time><Items><Value>-1</Value></Items></PatrolDevice>";
    assert_eq!(
        Request::decode(xml.as_bytes()),
        Err(DecodeError::UnknownCommand(99))
    );
    // The answer to an unknown command still decodes: its code is kept as received.
    let xml = "<PatrolDevice><Type>2</Type><Command>99</Command><Time>2023-01-01 00:00:00</Time><Items><Value>-1</Value><ErrorCode>1</ErrorCode></Items></PatrolDevice>";
    let Response::Motion(code, ack) = Response::decode(xml.as_bytes()).unwrap().message else {
        panic!()
    };
    assert_eq!(code, MotionCommandCode::Unknown(99));
    assert_eq!(ack.result, CommandResult::Failure);
}

#[test]
fn battery_2001_response() {
    let decoded = response(
        r#"<?xml version='1.0' encoding='utf-8'?>
<PatrolDevice>
  <Type>2001</Type>
  <Command>1</Command>
  <Time>2023-01-01 00:00:00</Time>
  <Items>
    <Voltage>82</Voltage>
    <Current>653</Current>
    <RemainingCapacity>1947</RemainingCapacity>
    <NominalCapacity>2004</NominalCapacity>
    <Cycles>12</Cycles>
    <ProtectedState>0</ProtectedState>
    <BatteryLevel>97</BatteryLevel>
    <BatteryTemperature>0</BatteryTemperature>
  </Items>
</PatrolDevice>"#,
    );
    assert_eq!(
        decoded.message,
        Response::Battery(Battery {
            voltage: Some(82),
            current: Some(653),
            remaining_capacity: Some(1947),
            nominal_capacity: Some(2004),
            cycles: Some(12),
            protected_state: Some(ProtectedState::Normal),
            battery_level: Some(97),
            battery_temperature: Some(0.0),
        })
    );
    assert_response_round_trip(&decoded);
}

/// Robots before V1.0.11 send no BatteryTemperature; that must not fail the answer.
#[test]
fn battery_without_temperature() {
    let xml = "<PatrolDevice><Type>2001</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><Voltage>50</Voltage><Current>-120</Current><RemainingCapacity>100</RemainingCapacity><NominalCapacity>2004</NominalCapacity><Cycles>1</Cycles><ProtectedState>1</ProtectedState><BatteryLevel>5</BatteryLevel></Items></PatrolDevice>";
    let decoded = response(xml);
    let Response::Battery(b) = decoded.message else {
        panic!()
    };
    assert_eq!(b.battery_temperature, None);
    assert_eq!(b.current, Some(-120));
    assert_eq!(b.protected_state, Some(ProtectedState::Triggered));
    assert_response_round_trip(&decoded);
}

/// A battery answer that leaves items out, or writes one that cannot be read, still has the
/// rest read: the protection state must not be lost with the voltage.
#[test]
fn battery_2001_response_with_items_left_out_or_unreadable() {
    let decoded = response(&document(
        2001,
        "<Voltage>5,3</Voltage><Cycles>7</Cycles><ProtectedState>1</ProtectedState>",
    ));
    assert_eq!(
        decoded.message,
        Response::Battery(Battery {
            voltage: None,
            current: None,
            remaining_capacity: None,
            nominal_capacity: None,
            cycles: Some(7),
            protected_state: Some(ProtectedState::Triggered),
            battery_level: None,
            battery_temperature: None,
        })
    );
    assert_eq!(decoded.unreadable.to_string(), "Voltage");
    // What was read is written back, and what was not is left out.
    let mut buf = [0u8; 1024];
    let n = decoded.message.encode(&decoded.time, &mut buf).unwrap();
    let written = std::str::from_utf8(&buf[..n]).unwrap();
    assert!(
        !written.contains("Voltage") && !written.contains("Current"),
        "{written}"
    );
    assert_eq!(response(written).message, decoded.message);

    let decoded = response(&document(2001, "<BatteryLevel>64</BatteryLevel>"));
    let Response::Battery(b) = decoded.message else {
        panic!("{decoded:?}")
    };
    assert_eq!((b.battery_level, b.protected_state), (Some(64), None));
    assert!(decoded.unreadable.is_empty());
}

#[test]
fn perception_2002_response() {
    let decoded = response(
        r#"<?xml version='1.0' encoding='utf-8'?>
<PatrolDevice>
  <Type>2002</Type>
  <Command>1</Command>
  <Time>2023-01-01 00:00:00</Time>
  <Items>
    <ObsState>0</ObsState>
  </Items>
</PatrolDevice>"#,
    );
    assert_eq!(
        decoded.message,
        Response::Perception(Perception {
            obs_state: ObsState::Clear
        })
    );
    assert_response_round_trip(&decoded);
}

#[test]
fn light_1101_request_and_response() {
    let decoded = request(
        r#"<?xml version='1.0' encoding='utf-8'?>
<PatrolDevice>
    <Type>1101</Type>
    <Command>1</Command>
    <Time>2023-01-01 00:00:00</Time>
    <Items>
        <Red>0</Red>
        <Green>255</Green>
        <Blue>16</Blue>
        <PER>1</PER>
        <LUM>80</LUM>
    </Items>
</PatrolDevice>"#,
    );
    assert_eq!(
        decoded.message,
        Request::Light(Light {
            red: 0,
            green: 255,
            blue: 16,
            effect: LightEffect::Breathing,
            brightness: 80
        })
    );
    assert_request_round_trip(&decoded);

    let ack = response(
        "<?xml version='1.0' encoding='utf-8'?>\n<PatrolDevice>\n    <Type>1101</Type>\n    <Command>1</Command>\n    <Time>2023-01-01 00:00:00</Time>\n    <Items>\n       <ErrorCode>0</ErrorCode>\n     </Items>\n</PatrolDevice>",
    );
    assert_eq!(
        ack.message,
        Response::Light(CommandAck {
            result: CommandResult::Success
        })
    );
    assert_response_round_trip(&ack);
}

/// A robot that keeps an integer in a float prints it with a point (`87.0`, C's `87.000000`):
/// the answer is read, the integer exactly. Nothing is rounded: another text is no integer,
/// so an optional item holding it is not reported and a required one refuses the answer;
/// any such text in a request is refused.
#[test]
fn answers_may_write_an_integer_item_as_a_whole_float() {
    let status = |electricity: &str, motion: &str| {
        document(
            1002,
            &format!("<MotionState>{motion}</MotionState><Electricity>{electricity}</Electricity>"),
        )
    };
    for (electricity, motion, expected) in [
        ("87.0", "6", (87, MotionState::SoftEmergencyStop)),
        (
            "87.000000",
            "6.000000",
            (87, MotionState::SoftEmergencyStop),
        ),
        ("-1.", "+4.0", (-1, MotionState::Stepping)),
    ] {
        let Response::Status(s) = response(&status(electricity, motion)).message else {
            panic!("not a status")
        };
        assert_eq!(
            (s.electricity, s.motion_state),
            (Some(expected.0), expected.1)
        );
    }
    for (text, error) in [
        ("86.5", NumberError::Invalid),
        (".0", NumberError::Invalid),
        ("87.0.0", NumberError::Invalid),
        ("1e2", NumberError::Invalid),
        ("3000000000.0", NumberError::OutOfRange),
    ] {
        let Response::Status(s) = response(&status(text, "4")).message else {
            panic!("not a status")
        };
        assert_eq!(s.electricity, None, "Electricity {text}");
        assert_eq!(
            Response::decode(status("87", text).as_bytes()),
            Err(DecodeError::BadItem {
                item: ItemName::new("MotionState"),
                error,
            }),
            "MotionState {text}"
        );
    }
    let light = "<PatrolDevice><Type>1101</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><Red>0</Red><Green>255.0</Green><Blue>0</Blue><PER>0</PER><LUM>50</LUM></Items></PatrolDevice>";
    assert!(matches!(
        Request::decode(light.as_bytes()),
        Err(DecodeError::BadItem { item, .. }) if item.as_bytes() == b"Green"
    ));
}

/// The document's own 1101 sample has non-integer and negative values (docs/protocol.md,
/// "Type 1101: indicator light"): they
/// are not valid and must be rejected with the item named.
#[test]
fn light_document_sample_values_are_rejected() {
    let xml = "<?xml version='1.0' encoding='utf-8'?><PatrolDevice><Type>1101</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><Red>0</Red><Green>3.847</Green><Blue>-6.127</Blue><PER>0.082</PER><LUM>3.109</LUM></Items></PatrolDevice>";
    let err = Request::decode(xml.as_bytes()).unwrap_err();
    assert!(
        matches!(err, DecodeError::BadItem { item, .. } if item.as_bytes() == b"Green"),
        "{err:?}"
    );
    let xml = xml.replace("3.847", "256");
    assert!(matches!(
        Request::decode(xml.as_bytes()),
        Err(DecodeError::BadItem { item, .. }) if item.as_bytes() == b"Green"
    ));
}

#[test]
fn relocalize_2101_request_and_response() {
    let decoded = request(
        r#"<?xml version='1.0' encoding='utf-8'?>
<PatrolDevice>
  <Type>2101</Type>
  <Command>1</Command>
  <Time>2023-01-01 00:00:00</Time>
  <Items>
    <PosX>1.5</PosX>
    <PosY>-2.25</PosY>
    <PosZ>0.0</PosZ>
    <Yaw>0.785398185</Yaw>
  </Items>
</PatrolDevice>"#,
    );
    assert_eq!(
        decoded.message,
        Request::Relocalize(Relocalize {
            pos_x: 1.5,
            pos_y: -2.25,
            pos_z: 0.0,
            yaw: 0.785398185
        })
    );
    assert_request_round_trip(&decoded);
    let ack = response(
        "<?xml version='1.0' encoding='utf-8'?>\n<PatrolDevice>\n  <Type>2101</Type>\n  <Command>1</Command>\n  <Time>2023-01-01 00:00:00</Time>\n  <Items>\n    <ErrorCode>1</ErrorCode>\n  </Items>\n</PatrolDevice>",
    );
    assert_eq!(
        ack.message,
        Response::Relocalize(RelocalizeAck {
            result: LocalizationResult::Abnormal
        })
    );
    assert_response_round_trip(&ack);
}

#[test]
fn motor_temperatures_1008_response() {
    let names = [
        "LeftFrontSway",
        "LeftFrontHip",
        "LeftFrontKnee",
        "RightFrontSway",
        "RightFrontHip",
        "RightFrontKnee",
        "LeftBackSway",
        "LeftBackHip",
        "LeftBackKnee",
        "RightBackSway",
        "RightBackHip",
        "RightBackKnee",
    ];
    // The document's sample is all 0; give each motor its own value to catch swapped fields.
    let items: String = names
        .iter()
        .enumerate()
        .map(|(i, n)| format!("<{n}>{}.5</{n}>", 30 + i))
        .collect();
    let decoded = response(&format!(
        "<?xml version='1.0' encoding='utf-8'?>{}",
        document(1008, &items)
    ));
    let Response::MotorTemperatures(t) = decoded.message else {
        panic!()
    };
    let expected: Vec<f32> = (0..12).map(|i| 30.5 + i as f32).collect();
    assert_eq!(t.all().to_vec(), expected);
    assert_eq!(t.left_front_sway, 30.5);
    assert_eq!(t.right_back_knee, 41.5);
    assert_eq!(t.max(), 41.5);
    assert_response_round_trip(&decoded);
}

/// A 1008 answer that leaves a motor out, or writes one with a decimal comma, still gives
/// the others: those two read NaN, the hottest is the hottest of the rest, and an answer
/// with no temperature at all has no hottest.
#[test]
fn motor_temperatures_1008_response_with_motors_left_out_or_unreadable() {
    let temperatures = |items: &str| {
        format!(
            "<?xml version='1.0' encoding='utf-8'?>{}",
            document(1008, items)
        )
    };
    let decoded = response(&temperatures(
        "<LeftFrontSway>31.5</LeftFrontSway><LeftFrontHip>45,5</LeftFrontHip>\
         <RightBackHip>40</RightBackHip><RightBackKnee>39.25</RightBackKnee>",
    ));
    let Response::MotorTemperatures(t) = decoded.message else {
        panic!("{decoded:?}")
    };
    let reported: Vec<(usize, f32)> = t
        .all()
        .into_iter()
        .enumerate()
        .filter(|(_, c)| !c.is_nan())
        .collect();
    assert_eq!(reported, [(0, 31.5), (10, 40.0), (11, 39.25)]);
    assert_eq!(t.max(), 40.0);
    assert_eq!(decoded.unreadable.to_string(), "LeftFrontHip");

    let decoded = response(&temperatures(""));
    let Response::MotorTemperatures(t) = decoded.message else {
        panic!("{decoded:?}")
    };
    assert!(t.all().iter().all(|c| c.is_nan()), "{t:?}");
    assert!(t.max().is_nan());
}

#[test]
fn request_error_type_0() {
    let decoded = response(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<PatrolDevice>
    <Type>0</Type>
    <Command>0</Command>
    <Time>0000-00-00 00:00:00</Time>
    <Items>
        <ErrorCode>4</ErrorCode>
    </Items>
</PatrolDevice>"#,
    );
    assert_eq!(decoded.time, Timestamp::ZERO);
    assert_eq!(
        decoded.message,
        Response::RequestError(RequestError {
            code: RequestErrorCode::ParseFailed
        })
    );
    assert_eq!(decoded.message.command(), 0);
    assert_response_round_trip(&decoded);
    for (raw, code) in [
        (1, RequestErrorCode::HeaderMissing),
        (2, RequestErrorCode::HeaderWrong),
        (3, RequestErrorCode::LengthAbnormal),
    ] {
        let xml = format!(
            "<PatrolDevice><Type>0</Type><Command>0</Command><Time>0000-00-00 00:00:00</Time><Items><ErrorCode>{raw}</ErrorCode></Items></PatrolDevice>"
        );
        assert_eq!(
            response(&xml).message,
            Response::RequestError(RequestError { code })
        );
    }
}

/// A code from a newer robot is kept, never fails the whole message.
#[test]
fn unknown_codes_are_kept() {
    let xml = "<PatrolDevice><Type>1003</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><Value>1</Value><ErrorCode>7</ErrorCode><ErrorStatus>49999</ErrorStatus></Items></PatrolDevice>";
    let decoded = response(xml);
    assert_eq!(
        decoded.message,
        Response::NavResult(NavResult {
            value: 1,
            outcome: NavOutcome::Unknown(7),
            status: ErrorStatus::Unknown(49999)
        })
    );
    assert_response_round_trip(&decoded);
}

#[test]
fn unknown_type_is_reported_with_its_number() {
    let xml = "<PatrolDevice><Type>2102</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items/></PatrolDevice>";
    assert_eq!(
        Response::decode(xml.as_bytes()),
        Err(DecodeError::UnknownType(2102))
    );
    assert_eq!(
        Request::decode(xml.as_bytes()),
        Err(DecodeError::UnknownType(2102))
    );
    // Type 0 is sent only by the robot; as a request it is unknown.
    let xml = xml.replace("2102", "0");
    assert_eq!(
        Request::decode(xml.as_bytes()),
        Err(DecodeError::UnknownType(0))
    );
}

#[test]
fn bad_numbers_are_named() {
    use x30_panel::proto::xml::number::NumberError;
    let base = "<PatrolDevice><Type>2002</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><ObsState>X</ObsState></Items></PatrolDevice>";
    for (text, error) in [
        ("abc", NumberError::Invalid),
        ("", NumberError::Empty),
        ("99999999999", NumberError::OutOfRange),
        ("1.5", NumberError::Invalid),
    ] {
        assert_eq!(
            Response::decode(base.replace(">X<", &format!(">{text}<")).as_bytes()),
            Err(DecodeError::BadItem {
                item: ItemName::new("ObsState"),
                error
            }),
            "{text}"
        );
    }
    let float = "<PatrolDevice><Type>2</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><Value>1e39</Value></Items></PatrolDevice>";
    assert_eq!(
        Request::decode(float.as_bytes()),
        Err(DecodeError::BadItem {
            item: ItemName::new("Value"),
            error: NumberError::OutOfRange
        })
    );
}

#[test]
fn items_block_count_is_checked() {
    let none = "<PatrolDevice><Type>2002</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time></PatrolDevice>";
    assert_eq!(
        Response::decode(none.as_bytes()),
        Err(DecodeError::ItemsBlocks { found: 0 })
    );
    let two = "<PatrolDevice><Type>2002</Type><Command>1</Command><Time>2023-01-01 00:00:00</Time><Items><ObsState>0</ObsState></Items><Items><ObsState>1</ObsState></Items></PatrolDevice>";
    assert_eq!(
        Response::decode(two.as_bytes()),
        Err(DecodeError::ItemsBlocks { found: 2 })
    );
}

#[test]
fn encoding_into_a_small_buffer_fails_rather_than_truncates() {
    use x30_panel::proto::xml::writer::WriteError;
    let mut full = [0u8; 1024];
    let n = Request::Status.encode(&T0, &mut full).unwrap();
    for len in 0..n {
        let mut buf = vec![0u8; len];
        assert_eq!(
            Request::Status.encode(&T0, &mut buf),
            Err(WriteError::BufferFull),
            "buffer of {len}"
        );
    }
    let mut exact = vec![0u8; n];
    assert_eq!(Request::Status.encode(&T0, &mut exact), Ok(n));
}

/// Items near the buffer's end: a number is formatted in place only where the buffer has
/// room for its longest text, so the last items of an exactly sized buffer take the other
/// path (formatted aside, copied if it fits). Both must give the same bytes, and every
/// shorter buffer must fail.
#[test]
fn number_items_fit_an_exactly_sized_buffer() {
    use x30_panel::proto::xml::writer::WriteError;
    let requests = [
        Request::Relocalize(Relocalize {
            pos_x: 12.345_678,
            pos_y: -0.000_233_936_21,
            pos_z: 1e-30,
            yaw: -3.141_592_7,
        }),
        Request::Motion(MotionCommand::SwitchGait(MotionGait::from_raw(i32::MIN))),
    ];
    for request in requests {
        let mut full = [0u8; 1024];
        let n = request.encode(&T0, &mut full).unwrap();
        let mut exact = vec![0u8; n];
        assert_eq!(request.encode(&T0, &mut exact), Ok(n), "{request:?}");
        assert_eq!(exact, full[..n], "{request:?}");
        for len in 0..n {
            let mut buf = vec![0u8; len];
            assert_eq!(
                request.encode(&T0, &mut buf),
                Err(WriteError::BufferFull),
                "{request:?} into {len} bytes"
            );
        }
    }
}

#[test]
fn non_finite_floats_are_refused_by_name() {
    use x30_panel::proto::xml::writer::WriteError;
    let pose = Relocalize {
        pos_x: 0.0,
        pos_y: f32::NAN,
        pos_z: 0.0,
        yaw: 0.0,
    };
    let mut buf = [0u8; 1024];
    assert_eq!(
        Request::Relocalize(pose).encode(&T0, &mut buf),
        Err(WriteError::NotFinite {
            item: ItemName::new("PosY")
        })
    );
    assert_eq!(
        Request::Relocalize(pose).validate(),
        Err(ValidationError::NotFinite { item: "PosY" })
    );
}

/// A robot's C library prints a float it has no value for as `nan` or `inf`: an answer may
/// carry them (its other items are still read, and written back the same way), a request
/// may not.
#[test]
fn answers_may_report_nan_and_infinity_and_requests_may_not() {
    use x30_panel::proto::xml::number::NumberError;
    let unknown_pose = STATUS_WITH_EVERY_ITEM
        .replace(">12.3456783<", ">nan<")
        .replace(">-0.00023393621<", ">-nan<")
        .replace(">0.0312<", ">INF<")
        .replace(">0.0012<", ">-Infinity<");
    for decode in [Response::decode, Response::decode_general] {
        let decoded = decode(unknown_pose.as_bytes()).expect("an answer with nan and inf");
        let Response::Status(status) = decoded.message else {
            panic!("{decoded:?}");
        };
        assert!(status.pos_x.is_nan() && status.pos_x.is_sign_positive());
        assert!(status.pos_y.is_nan() && status.pos_y.is_sign_negative());
        assert_eq!(
            (status.pos_z, status.roll),
            (f32::INFINITY, f32::NEG_INFINITY)
        );
        assert_eq!(
            (status.pitch, status.h),
            (-0.0034, Some(800)),
            "the other items"
        );
    }
    let decoded = response(&unknown_pose);
    let mut buf = [0u8; 4096];
    let n = decoded.message.encode(&decoded.time, &mut buf).unwrap();
    let text = String::from_utf8_lossy(&buf[..n]);
    for line in [
        "<PosX>nan</PosX>",
        "<PosY>-nan</PosY>",
        "<PosZ>inf</PosZ>",
        "<Roll>-inf</Roll>",
    ] {
        assert!(text.contains(line), "{line} in\n{text}");
    }
    let again = Response::decode(&buf[..n]).unwrap();
    assert_eq!(format!("{again:?}"), format!("{decoded:?}"), "{text}");
    // Anything else that is not a number is no reading: an answer's item holding it is not
    // reported, and named as unreadable (a required one refuses the answer:
    // `an_unreadable_optional_item_in_an_answer_is_not_reported`).
    for text in ["nan1", "na", "infinit", "+-inf", "nan()"] {
        let Response::Status(status) =
            response(&STATUS_WITH_EVERY_ITEM.replace(">12.3456783<", &format!(">{text}<"))).message
        else {
            panic!("not a status");
        };
        assert!(status.pos_x.is_nan(), "{text}");
        let temperatures = response(&document(
            1008,
            &format!("<LeftFrontSway>{text}</LeftFrontSway><LeftFrontHip>30</LeftFrontHip>"),
        ));
        let Response::MotorTemperatures(t) = temperatures.message else {
            panic!("not motor temperatures");
        };
        assert!(t.left_front_sway.is_nan(), "{text}");
        assert_eq!(t.left_front_hip, 30.0, "{text}");
        assert_eq!(
            temperatures.unreadable.to_string(),
            "LeftFrontSway",
            "{text}"
        );
    }
    let requests = [
        (document(2, "<Value>nan</Value>"), ItemName::new("Value")),
        (
            document(
                2101,
                "<PosX>1</PosX><PosY>inf</PosY><PosZ>0</PosZ><Yaw>0</Yaw>",
            ),
            ItemName::new("PosY"),
        ),
        (
            NAV_REQUEST.replace("<PosX>0.0<", "<PosX>-nan<"),
            ItemName::new("PosX"),
        ),
    ];
    for (body, item) in requests {
        assert_eq!(
            Request::decode(body.as_bytes()),
            Err(DecodeError::BadItem {
                item,
                error: NumberError::Invalid
            }),
            "{body}"
        );
    }
}

#[test]
fn commands_beyond_the_protocol_are_decoded_always_and_sent_only_with_the_feature() {
    let beyond = [
        MotionCommand::StandUp,
        MotionCommand::ForceControl,
        MotionCommand::StartStepping,
        MotionCommand::BodyHeight(0.3),
        MotionCommand::GoCharging,
        MotionCommand::LeaveCharger,
    ];
    for command in beyond {
        assert!(command.code().is_vendor_extension(), "{command:?}");
        let request = Request::Motion(command);
        let mut body = [0u8; 1024];
        let n = request
            .encode(&Timestamp::DOCUMENT_EPOCH, &mut body)
            .unwrap();
        let decoded = Request::decode(&body[..n]).unwrap().message;
        assert_eq!(decoded, request, "decoded whatever the build");
        let sendable = command.validate();
        if SENDS_VENDOR_EXTENSIONS {
            assert_eq!(sendable, Ok(()), "{command:?}");
        } else {
            assert_eq!(
                sendable,
                Err(ValidationError::VendorExtension),
                "{command:?}"
            );
        }
    }
    assert!(!MotionCommand::ZeroVelocity.code().is_vendor_extension());
}

#[test]
fn byte_items_out_of_range_are_refused_by_both_paths() {
    use x30_panel::proto::xml::number::NumberError;
    let base = "<PatrolDevice>\n  <Type>1101</Type>\n  <Command>1</Command>\n  <Time>2023-01-01 00:00:00</Time>\n  <Items>\n    <Red>R</Red>\n    <Green>0</Green>\n    <Blue>0</Blue>\n    <PER>0</PER>\n    <LUM>50</LUM>\n  </Items>\n</PatrolDevice>";
    for (text, expected) in [
        ("0", Ok(0)),
        ("255", Ok(255)),
        ("+7", Ok(7)),
        ("256", Err(NumberError::OutOfRange)),
        ("-1", Err(NumberError::OutOfRange)),
        ("2147483648", Err(NumberError::OutOfRange)),
        ("99999999999", Err(NumberError::OutOfRange)),
    ] {
        let xml = base.replace(">R<", &format!(">{text}<"));
        let fast = Request::decode(xml.as_bytes());
        assert_eq!(fast, Request::decode_general(xml.as_bytes()), "{text}");
        match (fast, expected) {
            (Ok(decoded), Ok(red)) => {
                let Request::Light(light) = decoded.message else {
                    panic!("{text}: not a light request");
                };
                assert_eq!(light.red, red, "{text}");
            }
            (Err(error), Err(number)) => assert_eq!(
                error,
                DecodeError::BadItem {
                    item: ItemName::new("Red"),
                    error: number
                },
                "{text}"
            ),
            (got, want) => panic!("{text}: got {got:?}, want {want:?}"),
        }
    }
}

#[test]
fn an_answer_has_its_requests_type_whatever_command_it_names() {
    let zero_velocity = Request::Motion(MotionCommand::ZeroVelocity);
    let ack = |code| {
        Response::Motion(
            code,
            MotionAck {
                value: None,
                result: CommandResult::Success,
            },
        )
    };
    let answers = |answer: &Response, request: &Request| answer.answers(request.message_type());
    assert!(answers(
        &ack(MotionCommandCode::ZeroVelocity),
        &zero_velocity
    ));
    // The message ID pairs them: a motion answer naming another Command is still one.
    assert!(answers(&ack(MotionCommandCode::Forward), &zero_velocity));
    let status = Response::Status(RobotStatus::UNAVAILABLE);
    assert!(answers(&status, &Request::Status));
    assert!(!answers(&status, &Request::Battery));
    assert!(!answers(&status, &zero_velocity));
    assert!(!answers(
        &ack(MotionCommandCode::ZeroVelocity),
        &Request::Status
    ));
}
