//! QEMU `mps2-an386` (Cortex-M4F at 25 MHz): the virtual panel.
//!
//! - **Settings**: loaded at start-up, before anything runs on them, from the settings flash
//!   ([`flash`]): two 32 KiB NOR pages emulated in a host file through semihosting, so that
//!   saved settings survive QEMU restarts.
//! - **Serial console**: UART1 ([`uart`], QEMU's second `-serial`): shows, changes and saves
//!   the settings.
//! - **Network**: the LAN9118 ([`lan9118`]) under embassy-net, DHCP (QEMU's user networking
//!   gives 10.0.2.15) or the static address the settings give, three TCP connections to the
//!   robot ([`super::net`]).
//! - **Web page**: the status and settings page on port 80 ([`super::web`]); `x30-qemu
//!   --http 127.0.0.1:PORT` forwards a port of the host to it.
//! - **Time**: two CMSDK timers ([`time`]).
//! - **Executor**: embassy's, asleep in `WFI` when idle ([`executor`]).
//! - **Buttons**: text lines on UART0 ([`uart`], `-serial stdio`): `+NAME` press, `-NAME`
//!   release (`x30_panel::panel::virtual_panel`).
//! - **LEDs and logs**: semihosting ([`semihosting`]): each LED change as `led NAME on|off|blink`.
//! - **Command line** (semihosting, `-semihosting-config
//!   enable=on,target=native,arg=x30-panel,arg=10.0.2.2:PORT,arg=settings=/abs/path`; see
//!   [`arguments`]): the robot's address stands in for the build-time default (QEMU forwards
//!   10.0.2.2:PORT to the host's 127.0.0.1:PORT; a robot saved in the settings wins), and
//!   `settings=PATH` names the settings flash's file. Without a file the flash is blank and
//!   cannot be written: the settings are the defaults and cannot be saved.

pub mod executor;
pub mod flash;
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
use x30_panel::config::{Config, RobotAddress};
use x30_panel::panel::virtual_panel::LineReader;
use x30_panel::panel::{Indicators, Led};
use x30_panel::settings::store::Store;
use x30_panel::settings::text::parse_robot;
use x30_panel::settings::{LoadProblem, Settings};

use self::flash::SettingsFlash;
use self::lan9118::Lan9118;
use self::uart::{UART0, UART1, UartRx, UartTx};
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

    // The settings first: the network and the application run on them.
    let (defaults, flash) = from_command_line();
    let mut store = Store::new(flash, 0..flash::CAPACITY).with_erase_gate(glue::erase_allowed);
    let (settings, problem) = glue::load_settings(&mut store, defaults).await;
    // The console keeps the settings; the rest of the board runs on this copy.
    let config = settings.config().clone();

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
        net::stack_config(config.network()),
        RESOURCES.init(StackResources::new()),
        seed,
    );
    // Each task is spawned once, and each UART taken once: a failure is a bug, and the panic
    // stops the firmware.
    spawner.spawn(network_task(runner).expect("network task"));
    spawner.spawn(glue::network_watch_task(stack).expect("network watch task"));
    spawner.spawn(led_task(glue::shared()).expect("LED task"));
    // UART0 only brings button lines; nothing is sent on it.
    let (panel_rx, _) = UART0.take().expect("UART0 is free");
    spawner.spawn(panel_task(panel_rx, glue::shared()).expect("virtual panel task"));
    let (console_rx, console_tx) = UART1.take().expect("UART1 is free");
    spawner.spawn(
        console_task(console_rx, console_tx, store, settings, problem).expect("console task"),
    );
    super::web::spawn(spawner, stack).expect("web server tasks");

    glue::run_app(stack, &config).await
}

/// The log level: `X30_LOG` at build time (`error`, `warn`, `info`, `debug`, `trace`), else
/// `info`, which shows LED changes, commands and connection changes.
fn log_level() -> LevelFilter {
    option_env!("X30_LOG")
        .and_then(|level| level.trim().parse().ok())
        .unwrap_or(LevelFilter::Info)
}

/// What the semihosting command line gives: the default settings (the build-time ones, with
/// its robot if it names one) and the settings flash.
fn from_command_line() -> (Config, SettingsFlash) {
    let mut line = [0u8; COMMAND_LINE];
    let arguments = semihosting::command_line(&mut line)
        .map(arguments)
        .unwrap_or_default();
    let mut defaults = Config::from_build_env();
    match arguments.robot {
        Some(robot) => defaults.robot = robot,
        None => info!("no robot address on the command line; using the build-time one"),
    }
    (defaults, settings_flash(arguments.settings))
}

/// The settings flash in the file at `path`; without one, or if it cannot be opened, a
/// blank flash that cannot be written.
fn settings_flash(path: Option<&str>) -> SettingsFlash {
    let Some(path) = path else {
        warn!(
            "no {}PATH on the command line: the settings cannot be saved",
            SETTINGS
        );
        return SettingsFlash::absent();
    };
    match SettingsFlash::open(path) {
        Ok(flash) => {
            info!("settings file {}", path);
            flash
        }
        Err(e) => {
            error!(
                "settings file {} cannot be used ({:?}): the settings cannot be saved",
                path, e
            );
            SettingsFlash::absent()
        }
    }
}

/// Longest semihosting command line read, in bytes.
const COMMAND_LINE: usize = 512;

/// The prefix of the settings file argument: `settings=PATH`.
const SETTINGS: &str = "settings=";

/// What the semihosting command line says, after the program's name.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Arguments<'a> {
    /// The first argument that is a robot address (`a.b.c.d[:port]`).
    pub robot: Option<RobotAddress>,
    /// The path of the settings flash's host file: the first `settings=PATH` argument.
    pub settings: Option<&'a str>,
}

/// Parses the command line `x30-panel [a.b.c.d[:port]] [settings=PATH]` (in any order),
/// warning about each argument it does not use.
pub fn arguments(command_line: &str) -> Arguments<'_> {
    let mut found = Arguments::default();
    for argument in command_line.split_ascii_whitespace().skip(1) {
        if let Some(path) = argument.strip_prefix(SETTINGS) {
            match found.settings {
                None if !path.is_empty() => found.settings = Some(path),
                None => warn!("ignoring `{}`: no path after `{}`", argument, SETTINGS),
                Some(_) => warn!(
                    "ignoring `{}`: the settings file is named already",
                    argument
                ),
            }
        } else if let Some(robot) = parse_robot(argument) {
            match found.robot {
                None => found.robot = Some(robot),
                Some(_) => warn!("ignoring `{}`: the robot is named already", argument),
            }
        } else {
            warn!(
                "ignoring command-line argument `{}`: neither a.b.c.d[:port] nor {}PATH",
                argument, SETTINGS
            );
        }
    }
    found
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

/// Runs the serial console on UART1, saving to the settings flash.
#[embassy_executor::task]
async fn console_task(
    rx: UartRx,
    tx: UartTx,
    store: Store<SettingsFlash>,
    settings: &'static mut Settings,
    problem: Option<LoadProblem>,
) -> ! {
    glue::run_console(rx, tx, store, settings, problem).await
}

/// Reads the virtual panel's lines from UART0 and hands the button changes to the app.
#[embassy_executor::task]
async fn panel_task(mut uart: UartRx, shared: &'static Shared) -> ! {
    let mut lines = LineReader::new();
    loop {
        let byte = uart.read_byte().await;
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
