//! The settings: the key table, each value's syntax, defaults and overrides, editing, and
//! the blob they are saved as.

use embassy_time::Duration;
use x30_panel::config::*;
use x30_panel::proto::codes::{LightEffect, PointInfo};
use x30_panel::proto::message::{Direction, Speed};
use x30_panel::settings::route::{MAX_ROUTE, ROUTE_ID, RoutePoint};
use x30_panel::settings::store::BLOB_MAX;
use x30_panel::settings::text::*;
use x30_panel::settings::{Conflict, Invalid, Key, Keys, LoadProblem, MAGIC, Settings, VERSION};

/// The value of `key` in `config`, as `show` and the store write it.
fn text(key: Key, config: &Config) -> String {
    let mut out = String::new();
    key.write(config, &mut out).unwrap();
    out
}

/// The defaults with `key` set to `value`.
fn with(key: Key, value: &str) -> Result<Config, Invalid> {
    let mut config = Config::default();
    key.apply(&mut config, value).map(|()| config)
}

#[test]
fn defaults_match_the_design() {
    let c = Config::default();
    assert_eq!(
        c.robot,
        RobotAddress {
            ip: [192, 168, 1, 106],
            port: 30000
        }
    );
    assert_eq!(c.network(), Network::Dhcp);
    assert_eq!(c.speeds.get(Direction::Forward), Speed::Default);
    assert_eq!(c.lights.as_slice(), &DEFAULT_LIGHTS);
    // No default charging point is safe to walk to.
    assert_eq!(c.dock, None);
    assert_eq!(c.polls.status, Duration::from_millis(500));
    assert_eq!(c.polls.battery, Duration::from_secs(5));
    assert_eq!(c.polls.motor_temperatures, Duration::from_secs(10));
    assert_eq!(c.polls.nav_status, Duration::from_secs(1));
    assert_eq!(c.motion_repeat, Duration::from_millis(250));
    assert_eq!(c.debounce, Duration::from_millis(15));
    assert_eq!(c.estop_input, EstopWiring::NormallyOpen);
    assert_eq!(c.web_pin, None);
}

#[test]
fn key_names_follow_their_variables() {
    let mut ids = Vec::new();
    for &key in Key::ALL {
        let derived = key
            .variable()
            .strip_prefix("X30_")
            .unwrap()
            .to_lowercase()
            .replace('_', "-");
        assert_eq!(key.name(), derived, "{key:?}");
        assert_eq!(Key::from_name(key.name()), Some(key));
        assert_eq!(Key::from_name(&key.name().to_uppercase()), Some(key));
        assert_eq!(Key::from_id(key.id()), Some(key));
        assert!(!ids.contains(&key.id()), "{key:?}: id {} twice", key.id());
        ids.push(key.id());
        assert!(!key.allowed().is_empty());
    }
    assert_eq!(Key::from_name("speed"), None);
    assert_eq!(Key::from_id(0), None);
    for (key, name) in [
        (Key::SpeedForward, "speed-forward"),
        (Key::Robot, "robot"),
        (Key::Dock, "dock"),
        (Key::EstopInput, "estop-input"),
        (Key::WebPin, "web-pin"),
    ] {
        assert_eq!(key.name(), name);
    }
}

#[test]
fn speed_keys_allow_what_the_protocol_allows() {
    for direction in Direction::ALL {
        let key = Key::speed(direction);
        assert_eq!(key.direction(), Some(direction));
        assert_eq!(
            key.syntax(),
            Syntax::Speed {
                max: direction.speed_limit()
            },
            "{key:?}"
        );
        let max = direction.speed_limit();
        assert_eq!(
            with(key, &max.to_string()).unwrap().speeds.get(direction),
            Speed::Value(max)
        );
        let above = f32::from_bits(max.to_bits() + 1);
        assert_eq!(with(key, &above.to_string()), Err(Invalid(key)));
    }
    let c = with(Key::SpeedForward, " 0.8 ").unwrap();
    assert_eq!(c.speeds.get(Direction::Forward), Speed::Value(0.8));
    // -0 is 0, shown as `0` (and so written to the robot), not as a negative `-0`.
    let c = with(Key::SpeedForward, "-0").unwrap();
    assert_eq!(text(Key::SpeedForward, &c), "0");
    let Speed::Value(zero) = c.speeds.get(Direction::Forward) else {
        panic!("-0 is a speed");
    };
    assert!(zero.is_sign_positive());
    for default in ["-1", "default", "DEFAULT"] {
        let c = with(Key::SpeedTurnLeft, default).unwrap();
        assert_eq!(c.speeds.get(Direction::TurnLeft), Speed::Default);
    }
    for bad in ["1.4", "-0.5", "fast", "", "0.8m"] {
        assert_eq!(
            with(Key::SpeedBackward, bad),
            Err(Invalid(Key::SpeedBackward)),
            "{bad:?}"
        );
    }
}

#[test]
fn ipv4_addresses_and_robots() {
    assert_eq!(parse_ipv4("10.0.2.2"), Some([10, 0, 2, 2]));
    for bad in [
        "",
        "10.0.2",
        "10.0.2.2.1",
        "10.0.2.256",
        "10.0.-2.2",
        "10..2.2",
        "a.b.c.d",
        "10.0.2.2 ",
    ] {
        assert_eq!(parse_ipv4(bad), None, "{bad:?}");
    }
    assert_eq!(
        parse_robot("10.0.2.2:4000"),
        Some(RobotAddress {
            ip: [10, 0, 2, 2],
            port: 4000
        })
    );
    assert_eq!(parse_robot("10.0.2.2").map(|a| a.port), Some(DEFAULT_PORT));
    for bad in [
        "10.0.2.2:",
        "10.0.2.2:0",
        "10.0.2.2:65536",
        "10.0.2.2:x",
        "robot:30000",
    ] {
        assert_eq!(parse_robot(bad), None, "{bad:?}");
    }
}

#[test]
fn network_keys() {
    assert_eq!(
        parse_cidr("192.168.1.50/24"),
        Some(Cidr {
            address: [192, 168, 1, 50],
            prefix_len: 24
        })
    );
    for bad in ["192.168.1.50", "192.168.1.50/33", "192.168.1.50/", "/24"] {
        assert_eq!(parse_cidr(bad), None, "{bad:?}");
    }
    for yes in ["1", "true", "TRUE", "yes", "on"] {
        assert_eq!(parse_switch(yes), Some(true), "{yes}");
    }
    for no in ["0", "false", "No", "off"] {
        assert_eq!(parse_switch(no), Some(false), "{no}");
    }
    assert_eq!(parse_switch("2"), None);
    let mut c = Config::default();
    Key::Dhcp.apply(&mut c, "0").unwrap();
    // Without an address the board keeps DHCP: it must stay reachable.
    assert_eq!(c.network(), Network::Dhcp);
    Key::Ip.apply(&mut c, "10.0.0.50/24").unwrap();
    Key::Gateway.apply(&mut c, "10.0.0.1").unwrap();
    assert_eq!(
        c.network(),
        Network::Static(StaticNetwork {
            address: [10, 0, 0, 50],
            prefix_len: 24,
            gateway: Some([10, 0, 0, 1])
        })
    );
    Key::Gateway.apply(&mut c, "none").unwrap();
    assert_eq!(c.gateway, None);
    Key::Dhcp.apply(&mut c, "on").unwrap();
    assert_eq!(c.network(), Network::Dhcp);
}

#[test]
fn robot_light_is_a_switch_of_its_own_and_off_by_default() {
    assert!(!Config::default().robot_light);
    let c = with(Key::RobotLight, "yes").unwrap();
    assert!(c.robot_light && c.dhcp, "{c:?}");
    let c = with(Key::Dhcp, "off").unwrap();
    assert!(!c.robot_light && !c.dhcp, "{c:?}");
    assert_eq!(with(Key::RobotLight, "red"), Err(Invalid(Key::RobotLight)));
}

#[test]
fn periods_within_their_ranges() {
    let c = with(Key::Repeat, "333").unwrap();
    assert_eq!(c.motion_repeat, Duration::from_millis(333));
    for bad in ["199", "334", "-250", "+250", "250ms", "2.5", ""] {
        assert_eq!(with(Key::Repeat, bad), Err(Invalid(Key::Repeat)), "{bad:?}");
    }
    assert_eq!(
        with(Key::PollBattery, "600000").unwrap().polls.battery,
        Duration::from_secs(600)
    );
    assert_eq!(with(Key::PollNav, "60001"), Err(Invalid(Key::PollNav)));
    assert_eq!(
        with(Key::Debounce, "1").unwrap().debounce,
        Duration::from_millis(1)
    );
    assert_eq!(with(Key::Debounce, "0"), Err(Invalid(Key::Debounce)));
}

#[test]
fn light_presets() {
    assert_eq!(
        parse_light("FF8000:50"),
        Some(LightText {
            rgb: [255, 128, 0],
            brightness: 50,
            breathing: false
        })
    );
    assert_eq!(
        parse_light("00ff00:100:breathing").map(|l| l.breathing),
        Some(true)
    );
    assert_eq!(
        parse_light("0000FF:1:Steady").map(|l| l.breathing),
        Some(false)
    );
    for bad in [
        "FF8000",
        "FF8000:101",
        "FF800:50",
        "FF80000:50",
        "GG8000:50",
        "FF8000:50:blink",
        "FF8000:50:steady:x",
        "ÿÿÿ:50",
        "FF8000:-5",
        "+F+F+F:50",
        "-1FF00:50",
    ] {
        assert_eq!(parse_light(bad), None, "{bad:?}");
    }
    let c = with(Key::Lights, "000000:0, 00FF00:100,FF0000:100:breathing").unwrap();
    assert_eq!(c.lights.len(), 3);
    assert_eq!(c.lights[2].effect, LightEffect::Breathing);
    for bad in [
        "",
        "000000:0,,00FF00:100",
        &["000000:0"; MAX_LIGHT_PRESETS + 1].join(","),
    ] {
        assert_eq!(with(Key::Lights, bad), Err(Invalid(Key::Lights)), "{bad:?}");
    }
    let eight = ["000000:0"; MAX_LIGHT_PRESETS].join(",");
    assert_eq!(
        with(Key::Lights, &eight).unwrap().lights.len(),
        MAX_LIGHT_PRESETS
    );
}

#[test]
fn dock_point_and_none() {
    let p = with(Key::Dock, "3, 2, 1.5, -2.25, 0, 2.5")
        .unwrap()
        .dock
        .unwrap();
    assert_eq!((p.value, p.map_id), (3, 2));
    assert_eq!(
        (p.pos_x, p.pos_y, p.pos_z, p.angle_yaw),
        (1.5, -2.25, 0.0, 2.5)
    );
    assert_eq!(p.point_info, PointInfo::Charging);
    let mut c = with(Key::Dock, "3,2,1,1,0,0").unwrap();
    Key::Dock.apply(&mut c, "NONE").unwrap();
    assert_eq!(c.dock, None);
    for bad in [
        "3,2,1.5,-2.25,0",
        "3,2,1.5,-2.25,0,3.14,9",
        "3,x,1.5,-2.25,0,3.14",
        "",
        "3,2,1e39,0,0,0",
    ] {
        assert_eq!(with(Key::Dock, bad), Err(Invalid(Key::Dock)), "{bad:?}");
    }
}

#[test]
fn estop_input_and_web_pin() {
    assert_eq!(
        with(Key::EstopInput, " NC ").unwrap().estop_input,
        EstopWiring::NormallyClosed
    );
    assert_eq!(
        with(Key::EstopInput, "No").unwrap().estop_input,
        EstopWiring::NormallyOpen
    );
    assert_eq!(
        with(Key::EstopInput, "normally-closed"),
        Err(Invalid(Key::EstopInput))
    );
    assert!(EstopWiring::NormallyOpen.pressed(true));
    assert!(!EstopWiring::NormallyClosed.pressed(true));
    assert!(EstopWiring::NormallyClosed.pressed(false));

    let c = with(Key::WebPin, "0042").unwrap();
    assert_eq!(
        c.web_pin.map(|p| p.as_str().to_owned()),
        Some("0042".to_owned())
    );
    // A PIN never shows in a log.
    assert!(!format!("{:?}", c.web_pin).contains("0042"));
    assert_eq!(with(Key::WebPin, "none").unwrap().web_pin, None);
    for bad in ["123", "123456789", "12a4", "", "-1234"] {
        assert_eq!(with(Key::WebPin, bad), Err(Invalid(Key::WebPin)), "{bad:?}");
    }
}

#[test]
fn every_value_reads_back_as_written() {
    let values = [
        (Key::Robot, "10.0.2.2:4000"),
        (Key::Dhcp, "0"),
        (Key::Ip, "10.0.0.50/24"),
        (Key::Gateway, "10.0.0.1"),
        (Key::SpeedForward, "0.8"),
        (Key::SpeedBackward, "1.3"),
        (Key::SpeedTurnLeft, "0.45"),
        (Key::SpeedTurnRight, "0.1"),
        (Key::SpeedStrafeLeft, "0.15"),
        (Key::SpeedStrafeRight, "0"),
        (Key::Lights, "0000FF:20,FF0000:100:breathing"),
        (Key::Dock, "7,3,1.5,-2.25,0,3.1415927"),
        (Key::PollStatus, "1000"),
        (Key::PollBattery, "20000"),
        (Key::PollMotors, "100"),
        (Key::PollNav, "60000"),
        (Key::Repeat, "200"),
        (Key::Debounce, "30"),
        (Key::EstopInput, "nc"),
        (Key::WebPin, "2468"),
        (Key::RobotLight, "1"),
    ];
    assert_eq!(values.len(), Key::ALL.len(), "every key is covered");
    for (key, value) in values {
        let config = with(key, value).unwrap();
        assert_eq!(text(key, &config), value, "{key:?}");
        assert_ne!(
            config,
            Config::default(),
            "{key:?}: the value changes something"
        );
        let again = with(key, &text(key, &config)).unwrap();
        assert_eq!(again, config, "{key:?}");
    }
}

#[test]
fn an_invalid_value_changes_nothing() {
    let mut settings = Settings::new(Config::default());
    settings.set(Key::SpeedForward, "0.5").unwrap();
    let before = settings.clone();
    assert_eq!(
        settings.set(Key::SpeedForward, "9"),
        Err(Invalid(Key::SpeedForward))
    );
    assert_eq!(
        settings.set(Key::Lights, "FF0000:100,oops"),
        Err(Invalid(Key::Lights))
    );
    assert_eq!(settings, before);
    assert_eq!(
        Invalid(Key::Repeat).to_string(),
        "repeat-ms: expected milliseconds from 200 to 333 (the robot needs 3-5 Hz)"
    );
}

#[test]
fn edits_take_effect_only_when_committed() {
    let defaults = Config {
        robot: RobotAddress {
            ip: [10, 0, 2, 2],
            port: 30001,
        },
        ..Config::default()
    };
    let mut settings = Settings::new(defaults.clone());
    assert!(settings.unsaved().is_empty());
    settings.set(Key::Robot, "10.0.2.2:30002").unwrap();
    assert_eq!(
        settings.config().robot.port,
        30001,
        "not in effect before save"
    );
    assert_eq!(settings.edited().robot.port, 30002);
    assert!(settings.is_overridden(Key::Robot));
    assert_eq!(settings.unsaved().iter().collect::<Vec<_>>(), [Key::Robot]);
    settings.commit();
    assert_eq!(settings.config().robot.port, 30002);
    assert!(settings.unsaved().is_empty());

    // Back to the default: overridden no more, and unsaved until committed.
    settings.unset(Key::Robot);
    assert!(!settings.is_overridden(Key::Robot));
    assert_eq!(settings.edited().robot, defaults.robot);
    assert_eq!(settings.config().robot.port, 30002);
    assert!(settings.unsaved().contains(Key::Robot));
    settings.revert();
    assert_eq!(settings.edited().robot.port, 30002);

    // Setting a key to its default's value still overrides it (a later build's default
    // will not change it).
    let mut settings = Settings::new(defaults.clone());
    settings.set(Key::Robot, "10.0.2.2:30001").unwrap();
    assert!(settings.unsaved().contains(Key::Robot));
}

#[test]
fn static_network_without_an_address_is_not_saved() {
    let mut settings = Settings::new(Config::default());
    settings.set(Key::Dhcp, "0").unwrap();
    assert_eq!(settings.check(), Err(Conflict::StaticWithoutAddress));
    settings.set(Key::Ip, "10.0.0.50/24").unwrap();
    assert_eq!(settings.check(), Ok(()));
}

/// The blob of `settings`' edits.
fn blob(settings: &Settings) -> Vec<u8> {
    let mut out = [0u8; 2048];
    let len = settings.emit(&mut out).unwrap();
    out[..len].to_vec()
}

#[test]
fn the_blob_keeps_only_the_overrides_and_reads_back() {
    let mut settings = Settings::new(Config::default());
    assert_eq!(blob(&settings), [&MAGIC[..], &[VERSION]].concat());
    settings.set(Key::Robot, "10.0.0.2").unwrap();
    settings
        .set(Key::Lights, "0000FF:20,FF0000:100:breathing")
        .unwrap();
    settings.set(Key::Dock, "1,1,2.5,-1,0,1.5707964").unwrap();
    settings.set(Key::WebPin, "1234").unwrap();
    let bytes = blob(&settings);

    // Over other defaults: the saved keys win, the others follow the new defaults.
    let defaults = Config {
        motion_repeat: Duration::from_millis(300),
        robot: RobotAddress {
            ip: [10, 0, 2, 2],
            port: 30001,
        },
        ..Config::default()
    };
    let (loaded, problem) = Settings::parse(defaults, &bytes);
    assert_eq!(problem, None);
    assert_eq!(
        loaded.config().robot,
        RobotAddress {
            ip: [10, 0, 0, 2],
            port: 30000
        }
    );
    assert_eq!(loaded.config().motion_repeat, Duration::from_millis(300));
    assert_eq!(loaded.config().lights, settings.edited().lights);
    assert_eq!(loaded.config().dock, settings.edited().dock);
    assert_eq!(loaded.config().web_pin, settings.edited().web_pin);
    assert!(loaded.unsaved().is_empty());
    for key in [Key::Robot, Key::Lights, Key::Dock, Key::WebPin] {
        assert!(loaded.is_overridden(key), "{key:?}");
    }
    assert!(!loaded.is_overridden(Key::Repeat));
}

#[test]
fn every_key_survives_the_blob() {
    let mut settings = Settings::new(Config::default());
    for &key in Key::ALL {
        let value = text(key, &Config::default());
        settings.set(key, &value).unwrap();
    }
    let (loaded, problem) = Settings::parse(Config::default(), &blob(&settings));
    assert_eq!(problem, None);
    for &key in Key::ALL {
        assert!(loaded.is_overridden(key), "{key:?}");
    }
}

#[test]
fn foreign_or_damaged_blobs_give_the_defaults() {
    let mut settings = Settings::new(Config::default());
    settings.set(Key::SpeedForward, "1").unwrap();
    let good = blob(&settings);
    let mut other_version = good.clone();
    other_version[4] = VERSION + 1;
    let truncated = &good[..good.len() - 1];
    for bad in [
        &b""[..],
        b"X30",
        b"ABCD\x01",
        &other_version,
        truncated,
        &[0xFF; 64],
    ] {
        let (loaded, problem) = Settings::parse(Config::default(), bad);
        assert_eq!(problem, Some(LoadProblem::NotSettings), "{bad:?}");
        assert!(problem.unwrap().is_loss());
        assert_eq!(loaded, Settings::new(Config::default()), "{bad:?}");
    }
}

#[test]
fn invalid_and_unknown_entries_are_skipped_alone() {
    let mut bytes = [&MAGIC[..], &[VERSION]].concat();
    let mut entry = |id: u8, text: &str| {
        bytes.push(id);
        bytes.push(text.len() as u8);
        bytes.extend_from_slice(text.as_bytes());
    };
    entry(Key::SpeedForward.id(), "1.2");
    entry(Key::Repeat.id(), "5000"); // out of range
    entry(200, "from a newer firmware");
    entry(Key::Dock.id(), "\u{fffd}"); // not a dock point
    let (loaded, problem) = Settings::parse(Config::default(), &bytes);
    let mut invalid = Keys::EMPTY;
    invalid.insert(Key::Repeat);
    invalid.insert(Key::Dock);
    assert_eq!(problem, Some(LoadProblem::InvalidValues(invalid)));
    assert_eq!(
        loaded.config().speeds.get(Direction::Forward),
        Speed::Value(1.2)
    );
    assert_eq!(
        loaded.config().motion_repeat,
        Config::default().motion_repeat
    );
    assert!(!loaded.is_overridden(Key::Repeat));

    let mut bytes = [&MAGIC[..], &[VERSION]].concat();
    bytes.extend_from_slice(&[250, 1, b'x']);
    let (loaded, problem) = Settings::parse(Config::default(), &bytes);
    assert_eq!(problem, Some(LoadProblem::UnknownKeys(1)));
    assert!(!problem.unwrap().is_loss());
    assert_eq!(loaded.config(), &Config::default());
}

#[test]
fn build_environment_is_read() {
    // The tests are built without X30_* variables, so the build-time configuration is the
    // default one; a variable set for this build would show up here.
    assert_eq!(Key::Robot.build_value(), option_env!("X30_ROBOT"));
    if Key::ALL.iter().all(|k| k.build_value().is_none()) {
        assert_eq!(Config::from_build_env(), Config::default());
    }
}

#[test]
fn route_points_read_as_written() {
    let p = RoutePoint::parse("3, 2, 1.5, -2.25, 0, 2.5").unwrap();
    assert_eq!((p.point, p.map, p.pose), (3, 2, [1.5, -2.25, 0.0, 2.5]));
    assert_eq!(p.info, PointInfo::Task, "task when no type is written");
    for (text, info) in [
        ("1,1,0,0,0,0,transition", PointInfo::Transition),
        ("1,1,0,0,0,0,Standing", PointInfo::Standing),
        ("1,1,0,0,0,0, 3", PointInfo::Charging),
        ("1,1,0,0,0,0,1", PointInfo::Task),
    ] {
        assert_eq!(
            RoutePoint::parse(text).map(|p| p.info),
            Some(info),
            "{text}"
        );
    }
    for bad in [
        "1,1,0,0,0",
        "1,1,0,0,0,0,walk",
        "1,1,0,0,0,0,4",
        "1,1,0,0,0,0,task,x",
        "1,1,1e39,0,0,0",
        "",
    ] {
        assert_eq!(RoutePoint::parse(bad), None, "{bad:?}");
    }
    let mut text = String::new();
    p.write(&mut text).unwrap();
    assert_eq!(text, "3,2,1.5,-2.25,0,2.5,task");
    assert_eq!(RoutePoint::parse(&text), Some(p));
    let nav = p.nav_point();
    assert_eq!(
        (nav.value, nav.map_id, nav.point_info),
        (3, 2, PointInfo::Task)
    );
}

#[test]
fn a_full_route_and_every_key_fit_the_blob_and_read_back() {
    let mut settings = Settings::new(Config::default());
    // Long values: eight presets, a dock point and a full route with numbers of eight
    // significant digits on a map as large as 10 km (write_f32 never uses an exponent, so
    // a tiny number such as 1e-30 would take 40 characters: the store refuses such a
    // blob as too large rather than cutting it).
    settings
        .set(
            Key::Lights,
            &["FFFFFF:100:breathing"; MAX_LIGHT_PRESETS].join(","),
        )
        .unwrap();
    settings
        .set(
            Key::Dock,
            "-2147483648,-2147483648,-1234.5679,-1234.5679,-0.33333334,-3.1415927",
        )
        .unwrap();
    for &key in Key::ALL {
        if !settings.is_overridden(key) {
            let value = text(key, &Config::default());
            settings.set(key, &value).unwrap();
        }
    }
    for i in 0..MAX_ROUTE {
        let text =
            format!("{i},2147483647,-1234.5679,-1234.5679,-0.33333334,-3.1415927,transition");
        settings
            .add_route_point(RoutePoint::parse(&text).unwrap())
            .unwrap();
    }
    assert!(
        settings
            .add_route_point(RoutePoint::parse("1,1,0,0,0,0").unwrap())
            .is_err(),
        "full"
    );
    let mut out = vec![0u8; BLOB_MAX];
    let len = settings.emit(&mut out).expect("fits the store");
    let (loaded, problem) = Settings::parse(Config::default(), &out[..len]);
    assert_eq!(problem, None);
    assert_eq!(loaded.config().route, settings.edited().route);
    assert_eq!(loaded.config().dock, settings.edited().dock);
    assert!(!loaded.route_unsaved());
}

#[test]
fn an_invalid_saved_route_point_empties_the_route() {
    let mut bytes = [&MAGIC[..], &[VERSION]].concat();
    for point in ["1,1,0,0,0,0,task", "2,1,0,0,0,0,flying"] {
        bytes.push(ROUTE_ID);
        bytes.push(point.len() as u8);
        bytes.extend_from_slice(point.as_bytes());
    }
    let (loaded, problem) = Settings::parse(Config::default(), &bytes);
    assert_eq!(problem, Some(LoadProblem::InvalidRoute));
    assert!(problem.unwrap().is_loss());
    assert!(loaded.config().route.is_empty());
}
