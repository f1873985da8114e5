//! The document's rules, checked before a request is sent, and the map/pixel conversion.

use x30_panel::proto::codes::*;
use x30_panel::proto::message::*;

#[test]
fn speed_ranges_per_motion_command() {
    let cases: [(Direction, f32); 6] = [
        (Direction::Forward, 1.5),
        (Direction::Backward, 1.3),
        (Direction::TurnLeft, 0.45),
        (Direction::TurnRight, 0.45),
        (Direction::StrafeLeft, 0.15),
        (Direction::StrafeRight, 0.15),
    ];
    assert_eq!(cases.map(|(d, _)| d), Direction::ALL);
    for (direction, max) in cases {
        assert_eq!(direction.speed_limit(), max);
        let command = |speed| MotionCommand::Move(direction, speed);
        assert_eq!(command(Speed::Default).validate(), Ok(()));
        assert_eq!(command(Speed::Value(0.0)).validate(), Ok(()));
        assert_eq!(command(Speed::Value(max)).validate(), Ok(()));
        let over = f32::from_bits(max.to_bits() + 1);
        assert_eq!(
            command(Speed::Value(over)).validate(),
            Err(ValidationError::SpeedOutOfRange { max }),
            "{max}"
        );
        assert_eq!(
            command(Speed::Value(-0.5)).validate(),
            Err(ValidationError::SpeedOutOfRange { max })
        );
        assert!(command(Speed::Value(f32::NAN)).validate().is_err());
        assert!(command(Speed::Default).is_continuous());
    }
    assert!(!MotionCommand::ZeroVelocity.is_continuous());
    assert_eq!(MotionCommand::SoftEmergencyStop.validate(), Ok(()));
}

#[test]
fn gait_switch_accepts_only_known_gaits() {
    for gait in [
        MotionGait::Walk,
        MotionGait::NormalStairs,
        MotionGait::Slope,
        MotionGait::PerceptionStairs,
    ] {
        assert_eq!(MotionCommand::SwitchGait(gait).validate(), Ok(()));
    }
    assert_eq!(
        MotionCommand::SwitchGait(MotionGait::Unknown(3)).validate(),
        Err(ValidationError::UnknownCode { item: "Value" })
    );
}

#[test]
fn light_ranges() {
    let light = Light {
        red: 255,
        green: 0,
        blue: 128,
        effect: LightEffect::Steady,
        brightness: 100,
    };
    assert_eq!(light.validate(), Ok(()));
    assert_eq!(
        Light {
            brightness: 101,
            ..light
        }
        .validate(),
        Err(ValidationError::BrightnessOutOfRange)
    );
    assert_eq!(
        Light {
            effect: LightEffect::Unknown(2),
            ..light
        }
        .validate(),
        Err(ValidationError::UnknownCode { item: "PER" })
    );
    assert_eq!(
        Request::Light(Light {
            brightness: 101,
            ..light
        })
        .validate(),
        Err(ValidationError::BrightnessOutOfRange)
    );
}

fn point() -> NavPoint {
    NavPoint::new(1, 1, 0.0, 0.0, 0.0, 0.0, PointInfo::Task)
}

#[test]
fn accumulated_frame_terrain_allows_only_frame_stair_gaits() {
    for gait in [
        NavGait::AccumulatedFrameStairs,
        NavGait::AccumulatedFrameStairs45,
    ] {
        let p = NavPoint {
            terrain: Terrain::AccumulatedFrame,
            gait,
            ..point()
        };
        assert_eq!(p.validate(), Ok(()));
    }
    for gait in [
        NavGait::Walk,
        NavGait::ObstacleCrossing,
        NavGait::Slope,
        NavGait::PerceptionStairs,
    ] {
        let p = NavPoint {
            terrain: Terrain::AccumulatedFrame,
            gait,
            ..point()
        };
        assert_eq!(
            p.validate(),
            Err(ValidationError::GaitNotAllowedOnTerrain),
            "{gait:?}"
        );
    }
}

#[test]
fn crouched_posture_allows_only_walk_and_slope() {
    for gait in [NavGait::Walk, NavGait::Slope] {
        let p = NavPoint {
            posture: Posture::Crouched,
            gait,
            ..point()
        };
        assert_eq!(p.validate(), Ok(()));
    }
    for gait in [
        NavGait::ObstacleCrossing,
        NavGait::PerceptionStairs,
        NavGait::AccumulatedFrameStairs,
    ] {
        let p = NavPoint {
            posture: Posture::Crouched,
            gait,
            ..point()
        };
        assert_eq!(
            p.validate(),
            Err(ValidationError::GaitNotAllowedWhenCrouched),
            "{gait:?}"
        );
    }
}

#[test]
fn nav_point_codes_and_coordinates() {
    assert_eq!(
        NavPoint {
            speed: NavSpeed::Unknown(9),
            ..point()
        }
        .validate(),
        Err(ValidationError::UnknownCode { item: "Speed" })
    );
    assert_eq!(
        NavPoint {
            angle_yaw: f32::INFINITY,
            ..point()
        }
        .validate(),
        Err(ValidationError::NotFinite { item: "AngleYaw" })
    );
    let task = NavTask {
        points: heapless::Vec::new(),
    };
    assert_eq!(task.validate(), Err(ValidationError::NoPoints));
    assert_eq!(NavTask::to_point(point()).validate(), Ok(()));
}

#[test]
fn map_to_pixel_and_back() {
    let map = MapImage {
        res: 0.05,
        x0: -10.0,
        y0: -20.0,
        h: 800,
    };
    // x_p = (PosX − X0) / Res, y_p = H − (PosY − Y0) / Res
    assert_eq!(map.to_pixel(-10.0, -20.0), Some((0, 800)));
    assert_eq!(map.to_pixel(0.0, 0.0), Some((200, 400)));
    assert_eq!(
        map.to_pixel(0.026, -19.974),
        Some((201, 799)),
        "rounds to nearest"
    );
    assert_eq!(
        map.to_pixel(-10.026, 0.0),
        Some((-1, 400)),
        "rounds half away from zero"
    );
    let (x, y) = map.to_map(200, 400);
    assert!((x - 0.0).abs() < 1e-5 && (y - 0.0).abs() < 1e-5, "{x} {y}");
    assert_eq!(MapImage { res: 0.0, ..map }.to_pixel(1.0, 1.0), None);
    assert_eq!(map.to_pixel(f32::NAN, 0.0), None);
    assert_eq!(map.to_pixel(1e30, 0.0), None);
}
