//! QEMU `mps2-an386` (Cortex-M4F at 25 MHz): the virtual panel.
//!
//! - **Network**: the LAN9118 ([`lan9118`]) under embassy-net, DHCP (QEMU's user networking
//!   gives 10.0.2.15), three TCP connections to the robot ([`super::net`]).
//! - **Time**: two CMSDK timers ([`time`]).
//! - **Buttons**: text lines on UART0 ([`uart`], `-serial stdio`): `+NAME` press, `-NAME`
//!   release (`x30_panel::panel::virtual_panel`).
//! - **LEDs and logs**: semihosting ([`semihosting`]): each LED change as `led NAME on|off|blink`.
//! - **Robot address**: the first argument of the semihosting command line that is an
//!   address (`-semihosting-config enable=on,target=native,arg=x30-panel,arg=10.0.2.2:PORT`;
//!   QEMU forwards 10.0.2.2:PORT to the host's 127.0.0.1:PORT), else the build-time one.

mod interrupts;
pub mod lan9118;
mod mmio;
pub mod semihosting;
pub mod time;
pub mod uart;

use embassy_executor::Spawner;
use embassy_net::{Runner, StackResources};
use embassy_time::Instant;
use log::{LevelFilter, error, info, warn};
use static_cell::StaticCell;
use x30_panel::app::Shared;
use x30_panel::config::{Config, RobotAddress, parse_robot};
use x30_panel::panel::virtual_panel::LineReader;
use x30_panel::panel::{Indicators, Led};

use self::lan9118::Lan9118;
use self::uart::Uart0Rx;
use super::glue;
use super::net::{self, SOCKETS};

/// The board's Ethernet address: locally administered (0x02), "X30" and a 1.
pub const MAC: [u8; 6] = [0x02, 0x00, b'X', b'3', b'0', 0x01];

/// The network stack's memory.
static RESOURCES: StaticCell<StackResources<SOCKETS>> = StaticCell::new();

/// Brings the board up and runs the panel, forever.
pub async fn run(spawner: Spawner) -> ! {
    semihosting::init_logging(log_level());
    info!("x30-panel {} on QEMU mps2-an386", env!("CARGO_PKG_VERSION"));
    let config = config();

    let driver = match Lan9118::new(MAC) {
        Ok(driver) => driver,
        Err(e) => {
            error!(
                "no Ethernet ({:?}); is QEMU run with -nic user,model=lan9118?",
                e
            );
            semihosting::exit(false);
        }
    };
    // No entropy source on this machine; the seed only varies TCP ports and sequence numbers.
    let seed = Instant::now().as_ticks() ^ 0x5833_3070_616E_656C;
    let (stack, runner) = embassy_net::new(
        driver,
        net::stack_config(&config.network),
        RESOURCES.init(StackResources::new()),
        seed,
    );
    // Each task is spawned once: a failure is a bug, and the panic stops the firmware.
    spawner.spawn(network_task(runner).expect("network task"));
    spawner.spawn(glue::network_watch_task(stack).expect("network watch task"));
    spawner.spawn(led_task(&glue::SHARED).expect("LED task"));
    let uart = Uart0Rx::take().expect("UART0 is free");
    spawner.spawn(panel_task(uart, &glue::SHARED).expect("virtual panel task"));

    glue::run_app(stack, &config).await
}

/// The log level: `X30_LOG` at build time (`error`, `warn`, `info`, `debug`, `trace`), else
/// `info`, which shows LED changes, commands and connection changes.
fn log_level() -> LevelFilter {
    option_env!("X30_LOG")
        .and_then(|level| level.trim().parse().ok())
        .unwrap_or(LevelFilter::Info)
}

/// The build-time configuration, with the robot's address from the command line if it has
/// one.
fn config() -> Config {
    let mut config = Config::from_build_env();
    let mut buf = [0u8; 256];
    let from_command_line = semihosting::command_line(&mut buf).and_then(robot_argument);
    match from_command_line {
        Some(robot) => config.robot = robot,
        None => info!("no robot address on the command line; using the build-time one"),
    }
    glue::log_config(&config);
    config
}

/// The first argument after the program's name that is a robot address (`a.b.c.d[:port]`).
pub fn robot_argument(command_line: &str) -> Option<RobotAddress> {
    let mut arguments = command_line.split_ascii_whitespace().skip(1);
    arguments.find_map(|argument| {
        let robot = parse_robot(argument);
        if robot.is_none() {
            warn!(
                "ignoring command-line argument `{}`: not a.b.c.d[:port]",
                argument
            );
        }
        robot
    })
}

/// Runs the network stack.
#[embassy_executor::task]
async fn network_task(mut runner: Runner<'static, Lan9118>) -> ! {
    runner.run().await
}

/// Shows the LEDs: logs each change as `led NAME on|off|blink`.
#[embassy_executor::task]
async fn led_task(shared: &'static Shared) -> ! {
    let mut shown = Indicators {
        link: Led::Off,
        activity: Led::Off,
        fault: Led::Off,
    };
    loop {
        let now = shared.indicators.wait().await;
        for (name, old, new) in [
            ("link", shown.link, now.link),
            ("activity", shown.activity, now.activity),
            ("fault", shown.fault, now.fault),
        ] {
            if old != new {
                info!("led {} {}", name, new.name());
            }
        }
        shown = now;
    }
}

/// Reads the virtual panel's lines from UART0 and hands the button changes to the app.
#[embassy_executor::task]
async fn panel_task(mut uart: Uart0Rx, shared: &'static Shared) -> ! {
    let mut lines = LineReader::new();
    loop {
        let byte = uart.read().await;
        match lines.push(byte, Instant::now()) {
            None | Some(Ok(None)) => {}
            Some(Ok(Some(event))) => {
                info!(
                    "button {} {}",
                    event.button.name(),
                    if event.pressed { "pressed" } else { "released" }
                );
                shared.buttons.send(event).await;
            }
            Some(Err(e)) => warn!("virtual panel: {}", e),
        }
    }
}
