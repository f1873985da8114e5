//! What the panel shows when it is connected and has only the robot's status: the console's
//! tests and the `field_input` fuzz target read the robot's pose from it.

use embassy_time::Instant;
use x30_panel::app::Snapshot;
use x30_panel::config::{Cidr, Config};
use x30_panel::panel::indicators::{Faults, LinkState};
use x30_panel::panel::monitor::Stamped;
use x30_panel::panel::{Indicators, Led};
use x30_panel::proto::message::RobotStatus;

/// A panel connected to the default robot, with `status` arrived and the snapshot taken at
/// `at`, nothing else answered, no fault, on the board address 10.0.2.15/24.
pub fn connected(status: RobotStatus, at: Instant) -> Snapshot {
    let config = Config::default();
    Snapshot {
        link: LinkState::Connected,
        robot: config.robot,
        status: Some(Stamped::new(status, at)),
        battery: None,
        perception: None,
        motors: None,
        nav: None,
        polls: config.polls,
        faults: Faults::default(),
        leds: Indicators {
            link: Led::On,
            activity: Led::Off,
            fault: Led::Off,
        },
        command_failed: false,
        busy: None,
        board_address: Some(Cidr {
            address: [10, 0, 2, 15],
            prefix_len: 24,
        }),
        at,
    }
}
