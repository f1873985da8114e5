//! The status answers (1002, 2001, 2002, 1008), the light (1101) and relocalisation (2101)
//! over loopback TCP, and many clients at once.

mod common;

use std::thread::{self, sleep};
use std::time::Duration;

use common::*;
use x30_panel::proto::codes::{
    ChargeState, CommandResult, LightEffect, LocalizationResult, Location, MotionState, MotorState,
    ObsState, OnDockState, ProtectedState,
};
use x30_panel::proto::message::{
    Battery, Direction, Light, MotionCommand, MotorTemperatures, Relocalize, Request, Response,
    Speed,
};

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn battery(client: &mut Client) -> Battery {
    match client.request(&Request::Battery) {
        Response::Battery(b) => b,
        other => panic!("{other:?}"),
    }
}

fn temperatures(client: &mut Client) -> MotorTemperatures {
    match client.request(&Request::MotorTemperatures) {
        Response::MotorTemperatures(t) => t,
        other => panic!("{other:?}"),
    }
}

#[test]
fn starting_status() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let s = client.status();
    assert_eq!(s.motion_state, MotionState::ForceControlStand);
    assert_eq!(s.electricity, Some(90));
    assert_eq!(s.location, Some(Location::Localized));
    assert_eq!((s.pos_x, s.pos_y, s.pos_z, s.yaw), (0.0, 0.0, 0.0, 0.0));
    assert_eq!((s.res, s.x0, s.y0, s.h), (0.05, -10.0, -10.0, Some(400)));
    assert_eq!(
        s.map_image().and_then(|m| m.to_pixel(0.0, 0.0)),
        Some((200, 200))
    );
}

/// At scale 20 the idle drain (0.05 %/s) is 1 % per real second; 2001 agrees with 1002 and
/// its numbers agree with each other.
#[test]
fn battery_drains_and_2001_agrees_with_1002() {
    let sim = start(20.0);
    let mut client = Client::connect(sim.addr());
    assert!(wait_until(ms(10_000), || client
        .status()
        .electricity
        .is_some_and(|e| e <= 88)));
    let mut agreed = false;
    // A reading can straddle a change of the rounded level; a few tries settle it.
    for _ in 0..5 {
        let before = client.status().electricity;
        let b = battery(&mut client);
        let after = client.status().electricity;
        if before != after {
            continue;
        }
        assert_eq!(b.battery_level, before);
        let reported = |value: Option<i32>| f64::from(value.expect("the simulator reports it"));
        let from_capacity = reported(b.remaining_capacity) * 100.0 / reported(b.nominal_capacity);
        assert!(
            // Both are rounded from the same charge, each to its own unit.
            (from_capacity - reported(b.battery_level)).abs() < 1.0,
            "{b:?}"
        );
        assert!(b.current > Some(0), "positive while discharging: {b:?}");
        assert!(b.voltage.is_some_and(|v| (48..=59).contains(&v)), "{b:?}");
        assert_eq!(b.protected_state, Some(ProtectedState::Normal));
        assert!(b.battery_temperature.is_some());
        agreed = true;
        break;
    }
    assert!(agreed, "2001 and 1002 never agreed");
}

#[test]
fn battery_charges_on_the_dock() {
    let sim = start(20.0);
    let mut client = Client::connect(sim.addr());
    sim.robot(|r| {
        r.set_battery(50.0);
        r.set_on_dock(true);
    });
    let s = client.status();
    assert_eq!(s.charge_state, Some(ChargeState::Charging));
    assert_eq!(s.on_dock_state, Some(OnDockState::OnDock));
    assert_eq!(s.motion_state, MotionState::LyingDown);
    assert!(
        battery(&mut client)
            .current
            .is_some_and(|current| current < 0),
        "negative while charging"
    );
    assert!(wait_until(ms(10_000), || client
        .status()
        .electricity
        .is_some_and(|e| e >= 53)));
}

#[test]
fn motors_warm_with_motion_and_report_over_temperature() {
    let sim = start(20.0);
    let mut client = Client::connect(sim.addr());
    let cold = temperatures(&mut client).max();
    for _ in 0..6 {
        client.motion(MotionCommand::Move(Direction::Forward, Speed::Default));
        sleep(ms(200));
    }
    client.motion(MotionCommand::ZeroVelocity);
    let warm = temperatures(&mut client).max();
    assert!(warm > cold + 3.0, "{cold} → {warm}");
    assert_eq!(client.status().motor_state, Some(MotorState::Normal));
    sim.robot(|r| r.set_motor_temperature(7, 85.0));
    assert_eq!(
        client.status().motor_state,
        Some(MotorState::OverTemperature)
    );
    assert!(temperatures(&mut client).left_back_hip > 80.0);
}

#[test]
fn obstacle_flag_is_reported() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let perception = |client: &mut Client| match client.request(&Request::Perception) {
        Response::Perception(p) => p.obs_state,
        other => panic!("{other:?}"),
    };
    assert_eq!(perception(&mut client), ObsState::Clear);
    sim.robot(|r| r.set_obstacle(true));
    assert_eq!(perception(&mut client), ObsState::ObstacleAhead);
    sim.robot(|r| r.set_obstacle(false));
    assert_eq!(perception(&mut client), ObsState::Clear);
}

#[test]
fn light_is_recorded() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    let light = Light {
        red: 0,
        green: 200,
        blue: 30,
        effect: LightEffect::Breathing,
        brightness: 60,
    };
    let ack = |client: &mut Client, light: Light| match client.request(&Request::Light(light)) {
        Response::Light(ack) => ack.result,
        other => panic!("{other:?}"),
    };
    assert_eq!(ack(&mut client, light), CommandResult::Success);
    assert_eq!(sim.robot(|r| r.light()), Some(light));
    let invalid = Light {
        brightness: 150,
        ..light
    };
    assert_eq!(ack(&mut client, invalid), CommandResult::Failure);
    assert_eq!(sim.snapshot().light, Some(light));
}

#[test]
fn relocalize_sets_the_pose() {
    let sim = start(1.0);
    let mut client = Client::connect(sim.addr());
    sim.robot(|r| r.set_localized(false));
    assert_eq!(client.status().location, Some(Location::Lost));
    let pose = Relocalize {
        pos_x: 2.5,
        pos_y: -1.25,
        pos_z: 0.0,
        yaw: 1.5,
    };
    let relocalize = |client: &mut Client| match client.request(&Request::Relocalize(pose)) {
        Response::Relocalize(ack) => ack.result,
        other => panic!("{other:?}"),
    };
    assert_eq!(relocalize(&mut client), LocalizationResult::Localized);
    let s = client.status();
    assert_eq!((s.pos_x, s.pos_y, s.yaw), (2.5, -1.25, 1.5));
    assert_eq!(s.location, Some(Location::Localized));
    sim.robot(|r| r.set_localization_broken(true));
    assert_eq!(relocalize(&mut client), LocalizationResult::Abnormal);
    assert_eq!(client.status().location, Some(Location::Lost));
}

#[test]
fn many_clients_at_once() {
    let sim = start(1.0);
    let addr = sim.addr();
    let workers: Vec<_> = (0..8)
        .map(|_| {
            thread::spawn(move || {
                let mut client = Client::connect(addr);
                for _ in 0..25 {
                    // `request` checks that each answer carries its request's ID.
                    assert_eq!(client.status().electricity, Some(90));
                    assert!(matches!(
                        client.request(&Request::NavStatus),
                        Response::NavStatus(_)
                    ));
                }
            })
        })
        .collect();
    for worker in workers {
        worker.join().unwrap();
    }
    assert_eq!(sim.requests().len(), 8 * 50);
}
