//! Build-time configuration: the parsing of each variable's text, the defaults, and the
//! report of invalid variables.

use embassy_time::Duration;
use x30_panel::config::*;
use x30_panel::proto::codes::{LightEffect, PointInfo};
use x30_panel::proto::message::{Direction, Light, Speed};

/// A configuration built from `(variable name, text)` pairs, as a build environment gives them.
fn config(vars: &[(&str, &'static str)]) -> Config {
    Config::from_vars(|v| {
        vars.iter()
            .find(|(name, _)| *name == v.name())
            .map(|&(_, text)| text)
    })
}

fn problems(config: &Config) -> Vec<&'static str> {
    config.problems().map(Variable::name).collect()
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
    assert_eq!(c.network, Network::Dhcp);
    assert_eq!(c.speeds.get(Direction::Forward), Speed::Default);
    assert_eq!(c.speeds.get(Direction::StrafeRight), Speed::Default);
    assert_eq!(c.lights.as_slice(), &DEFAULT_LIGHTS);
    assert_eq!(c.lights[3].effect, LightEffect::Breathing);
    // No default charging point is safe to walk to.
    assert_eq!(c.dock, None);
    assert_eq!(c.polls.status, Duration::from_millis(500));
    assert_eq!(c.polls.battery, Duration::from_secs(5));
    assert_eq!(c.polls.motor_temperatures, Duration::from_secs(10));
    assert_eq!(c.polls.nav_status, Duration::from_secs(1));
    assert_eq!(c.motion_repeat, Duration::from_millis(250));
    assert_eq!(c.debounce, Duration::from_millis(15));
    assert_eq!(c.estop_wiring, EstopWiring::NormallyOpen);
    assert_eq!(c.problems().count(), 0);
}

#[test]
fn no_variables_give_the_defaults() {
    assert_eq!(config(&[]), Config::default());
}

#[test]
fn every_variable_has_a_distinct_x30_name() {
    let names: Vec<_> = Variable::ALL.iter().map(|v| v.name()).collect();
    for (i, name) in names.iter().enumerate() {
        assert!(name.starts_with("X30_"), "{name}");
        assert!(!names[i + 1..].contains(name), "{name} twice");
    }
    assert_eq!(names.len(), 19);
    assert_eq!(Variable::EstopWiring.name(), "X30_ESTOP_WIRING");
}

#[test]
fn ipv4_addresses() {
    assert_eq!(parse_ipv4("10.0.2.2"), Some([10, 0, 2, 2]));
    assert_eq!(parse_ipv4("255.255.255.255"), Some([255; 4]));
    for bad in [
        "",
        "10.0.2",
        "10.0.2.2.1",
        "10.0.2.256",
        "10.0.-2.2",
        "10.0.+2.2",
        "10..2.2",
        "a.b.c.d",
        "10.0.2.2 ",
    ] {
        assert_eq!(parse_ipv4(bad), None, "{bad:?}");
    }
}

#[test]
fn robot_address_with_and_without_port() {
    assert_eq!(
        parse_robot("1.2.3.4:30000"),
        Some(RobotAddress {
            ip: [1, 2, 3, 4],
            port: 30000
        })
    );
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
fn cidr_and_switches() {
    assert_eq!(parse_cidr("192.168.1.50/24"), Some(([192, 168, 1, 50], 24)));
    assert_eq!(parse_cidr("10.0.0.1/32"), Some(([10, 0, 0, 1], 32)));
    for bad in ["192.168.1.50", "192.168.1.50/33", "192.168.1.50/", "/24"] {
        assert_eq!(parse_cidr(bad), None, "{bad:?}");
    }
    for yes in ["1", "true", "TRUE", "yes", "on"] {
        assert_eq!(parse_bool(yes), Some(true), "{yes}");
    }
    for no in ["0", "false", "No", "off"] {
        assert_eq!(parse_bool(no), Some(false), "{no}");
    }
    assert_eq!(parse_bool("2"), None);
    assert_eq!(parse_bool(""), None);
}

#[test]
fn speeds_within_each_commands_limits() {
    assert_eq!(
        parse_speed("0.8", Direction::Forward),
        Some(Speed::Value(0.8))
    );
    assert_eq!(parse_speed("-1", Direction::Forward), Some(Speed::Default));
    assert_eq!(
        parse_speed("default", Direction::TurnLeft),
        Some(Speed::Default)
    );
    assert_eq!(
        parse_speed("1.5", Direction::Forward),
        Some(Speed::Value(1.5))
    );
    // Forward allows 1.5 m/s, backward only 1.3, strafing 0.15.
    assert_eq!(parse_speed("1.4", Direction::Backward), None);
    assert_eq!(parse_speed("0.2", Direction::StrafeLeft), None);
    assert_eq!(parse_speed("0.5", Direction::TurnRight), None);
    assert_eq!(parse_speed("-0.5", Direction::Forward), None);
    assert_eq!(parse_speed("fast", Direction::Forward), None);
    assert_eq!(parse_speed("", Direction::Forward), None);
}

#[test]
fn millisecond_periods_within_range() {
    assert_eq!(
        parse_millis("250", 200, 333),
        Some(Duration::from_millis(250))
    );
    assert_eq!(
        parse_millis("200", 200, 333),
        Some(Duration::from_millis(200))
    );
    assert_eq!(
        parse_millis("333", 200, 333),
        Some(Duration::from_millis(333))
    );
    for bad in ["199", "334", "-250", "+250", "250ms", "2.5", ""] {
        assert_eq!(parse_millis(bad, 200, 333), None, "{bad:?}");
    }
}

#[test]
fn light_presets() {
    assert_eq!(
        parse_light("FF8000:50"),
        Some(Light {
            red: 255,
            green: 128,
            blue: 0,
            effect: LightEffect::Steady,
            brightness: 50
        })
    );
    assert_eq!(
        parse_light("00ff00:100:breathing").map(|l| (l.green, l.effect)),
        Some((255, LightEffect::Breathing))
    );
    assert_eq!(
        parse_light("0000FF:1:Steady").map(|l| l.effect),
        Some(LightEffect::Steady)
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
    ] {
        assert_eq!(parse_light(bad), None, "{bad:?}");
    }
    let presets = parse_lights("000000:0, 00FF00:100,FF0000:100:breathing").unwrap();
    assert_eq!(presets.len(), 3);
    assert_eq!(presets[2].effect, LightEffect::Breathing);
    assert_eq!(parse_lights(""), None);
    assert_eq!(parse_lights("000000:0,,00FF00:100"), None);
    let nine = ["000000:0"; MAX_LIGHT_PRESETS + 1].join(",");
    assert_eq!(parse_lights(&nine), None);
}

#[test]
fn dock_point() {
    let p = parse_dock("3, 2, 1.5, -2.25, 0, 2.5").unwrap();
    assert_eq!((p.value, p.map_id), (3, 2));
    assert_eq!(
        (p.pos_x, p.pos_y, p.pos_z, p.angle_yaw),
        (1.5, -2.25, 0.0, 2.5)
    );
    assert_eq!(p.point_info, PointInfo::Charging);
    for bad in [
        "3,2,1.5,-2.25,0",
        "3,2,1.5,-2.25,0,3.14,9",
        "3,x,1.5,-2.25,0,3.14",
        "",
    ] {
        assert_eq!(parse_dock(bad), None, "{bad:?}");
    }
}

#[test]
fn variables_override_defaults() {
    let c = config(&[
        ("X30_ROBOT", "1.2.3.4:30001"),
        ("X30_SPEED_FORWARD", " 0.8 "),
        ("X30_SPEED_STRAFE_RIGHT", "0.1"),
        ("X30_LIGHTS", "0000FF:20"),
        ("X30_DOCK", "7,3,1,2,0,0.5"),
        ("X30_POLL_STATUS_MS", "250"),
        ("X30_POLL_BATTERY_MS", "1000"),
        ("X30_POLL_MOTORS_MS", "20000"),
        ("X30_POLL_NAV_MS", "500"),
        ("X30_REPEAT_MS", "200"),
        ("X30_DEBOUNCE_MS", "30"),
        ("X30_ESTOP_WIRING", "nc"),
    ]);
    assert_eq!(c.robot.ip, [1, 2, 3, 4]);
    assert_eq!(c.robot.port, 30001);
    assert_eq!(c.speeds.get(Direction::Forward), Speed::Value(0.8));
    assert_eq!(c.speeds.get(Direction::Backward), Speed::Default);
    assert_eq!(c.speeds.get(Direction::StrafeRight), Speed::Value(0.1));
    assert_eq!(c.lights.len(), 1);
    let dock = c.dock.expect("the configured charging point");
    assert_eq!((dock.value, dock.map_id, dock.angle_yaw), (7, 3, 0.5));
    assert_eq!(dock.point_info, PointInfo::Charging);
    assert_eq!(c.polls.status, Duration::from_millis(250));
    assert_eq!(c.polls.battery, Duration::from_millis(1000));
    assert_eq!(c.polls.motor_temperatures, Duration::from_secs(20));
    assert_eq!(c.polls.nav_status, Duration::from_millis(500));
    assert_eq!(c.motion_repeat, Duration::from_millis(200));
    assert_eq!(c.debounce, Duration::from_millis(30));
    assert_eq!(c.estop_wiring, EstopWiring::NormallyClosed);
    assert!(problems(&c).is_empty());
}

#[test]
fn static_network() {
    let c = config(&[
        ("X30_DHCP", "0"),
        ("X30_IP", "10.0.0.50/24"),
        ("X30_GATEWAY", "10.0.0.1"),
    ]);
    assert_eq!(
        c.network,
        Network::Static(StaticNetwork {
            address: [10, 0, 0, 50],
            prefix_len: 24,
            gateway: Some([10, 0, 0, 1])
        })
    );
    let c = config(&[("X30_DHCP", "off"), ("X30_IP", "10.0.0.50/24")]);
    assert!(matches!(
        c.network,
        Network::Static(StaticNetwork { gateway: None, .. })
    ));
    // With DHCP the static settings are not read, so they cannot be wrong.
    let c = config(&[("X30_IP", "nonsense"), ("X30_GATEWAY", "nonsense")]);
    assert_eq!(c.network, Network::Dhcp);
    assert!(problems(&c).is_empty());
}

#[test]
fn static_network_without_address_falls_back_to_dhcp_and_says_so() {
    let c = config(&[("X30_DHCP", "0")]);
    assert_eq!(c.network, Network::Dhcp);
    assert_eq!(problems(&c), ["X30_IP"]);
    let c = config(&[("X30_DHCP", "0"), ("X30_IP", "10.0.0.50")]);
    assert_eq!(c.network, Network::Dhcp);
    assert_eq!(problems(&c), ["X30_IP"]);
}

#[test]
fn invalid_values_keep_the_default_and_are_reported() {
    let c = config(&[
        ("X30_ROBOT", "robot.local"),
        ("X30_DHCP", "maybe"),
        ("X30_SPEED_FORWARD", "2.0"),
        ("X30_SPEED_TURN_LEFT", "0.3"),
        ("X30_LIGHTS", "red"),
        ("X30_DOCK", "1,1"),
        ("X30_POLL_STATUS_MS", "0"),
        ("X30_REPEAT_MS", "1000"),
        ("X30_DEBOUNCE_MS", "fast"),
        ("X30_ESTOP_WIRING", "closed"),
    ]);
    let d = Config::default();
    assert_eq!(c.robot, d.robot);
    assert_eq!(c.network, Network::Dhcp);
    assert_eq!(c.speeds.get(Direction::Forward), Speed::Default);
    assert_eq!(c.speeds.get(Direction::TurnLeft), Speed::Value(0.3));
    assert_eq!(c.lights, d.lights);
    assert_eq!(c.dock, d.dock);
    assert_eq!(c.polls, d.polls);
    assert_eq!(c.motion_repeat, d.motion_repeat);
    assert_eq!(c.debounce, d.debounce);
    assert_eq!(c.dock, None);
    assert_eq!(c.estop_wiring, d.estop_wiring);
    assert_eq!(
        problems(&c),
        [
            "X30_ROBOT",
            "X30_DHCP",
            "X30_SPEED_FORWARD",
            "X30_LIGHTS",
            "X30_DOCK",
            "X30_POLL_STATUS_MS",
            "X30_REPEAT_MS",
            "X30_DEBOUNCE_MS",
            "X30_ESTOP_WIRING"
        ]
    );
}

#[test]
fn estop_wiring_normally_open_is_pressed_when_low() {
    assert!(EstopWiring::NormallyOpen.pressed(true));
    assert!(!EstopWiring::NormallyOpen.pressed(false));
}

#[test]
fn estop_wiring_normally_closed_is_pressed_when_high() {
    assert!(
        EstopWiring::NormallyClosed.pressed(false),
        "a broken wire reads as pressed"
    );
    assert!(!EstopWiring::NormallyClosed.pressed(true));
}

#[test]
fn estop_wiring_parses_no_and_nc_in_any_case() {
    for no in ["no", "NO", "No"] {
        assert_eq!(
            EstopWiring::parse(no),
            Some(EstopWiring::NormallyOpen),
            "{no}"
        );
    }
    for nc in ["nc", "NC", "nC"] {
        assert_eq!(
            EstopWiring::parse(nc),
            Some(EstopWiring::NormallyClosed),
            "{nc}"
        );
    }
    for bad in ["", "n", "open", "closed", "nc ", "1"] {
        assert_eq!(EstopWiring::parse(bad), None, "{bad:?}");
    }
    // Through the configuration: spaces around the value are ignored.
    let c = config(&[("X30_ESTOP_WIRING", " NC ")]);
    assert_eq!(c.estop_wiring, EstopWiring::NormallyClosed);
    assert!(problems(&c).is_empty());
    let c = config(&[("X30_ESTOP_WIRING", "No")]);
    assert_eq!(c.estop_wiring, EstopWiring::NormallyOpen);
    assert!(problems(&c).is_empty());
}

#[test]
fn estop_wiring_invalid_keeps_normally_open_and_is_reported() {
    let c = config(&[("X30_ESTOP_WIRING", "normally-closed")]);
    assert_eq!(c.estop_wiring, EstopWiring::NormallyOpen);
    assert_eq!(problems(&c), ["X30_ESTOP_WIRING"]);
}

#[test]
fn build_environment_is_read() {
    // The tests are built without X30_* variables, so the build-time configuration is the
    // default one; a variable set for this build would show up here.
    assert_eq!(Variable::Robot.build_value(), option_env!("X30_ROBOT"));
    if Variable::ALL.iter().all(|v| v.build_value().is_none()) {
        assert_eq!(Config::from_build_env(), Config::default());
    }
}
