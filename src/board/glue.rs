//! What every board does the same way around its drivers: the state it shares with the
//! application, loading the settings, the console, the network watch, and running the
//! application over the three connections. Each board keeps only its drivers and pin map.

use embassy_futures::select::{Either, select};
use embassy_net::Stack;
use embassy_sync::once_lock::OnceLock;
use embedded_io_async::{Read, Write};
use embedded_storage_async::nor_flash::NorFlash;
use static_cell::{ConstStaticCell, StaticCell};
use x30_panel::app::{self, Shared};
use x30_panel::config::{Cidr, Config, Network};
use x30_panel::console::{self, Reboot};
use x30_panel::panel::NetworkState;
use x30_panel::settings::desk::{self, Desk};
use x30_panel::settings::store::Store;
use x30_panel::settings::{self, LoadProblem, Settings};

use super::net::{self, LinkBuffers, SocketBuffers};

// `SHARED` and `DESK` are built on first use rather than by a `const fn` in their
// statics: a constant initializer with a single byte that is not zero (an `Option`'s
// `None` niche) puts the whole value in `.data`, whose image the startup code copies from
// flash, 10 KiB for these two; an `OnceLock` starts as zeros and costs no flash.

/// What the board and the application share.
pub fn shared() -> &'static Shared {
    static SHARED: OnceLock<Shared> = OnceLock::new();
    SHARED.get_or_init(Shared::new)
}

/// Whether a settings page erase may stall the chip now: not while the panel is busy
/// ([`desk::busy`]: a stop going out or pending, motion held, a task running). The store
/// asks right before each erase, since a save reads the pages for a while first.
pub fn erase_allowed() -> bool {
    desk::busy(shared()).is_none()
}

/// Where the console, which owns the settings, takes the web page's changes.
pub fn desk() -> &'static Desk {
    static DESK: OnceLock<Desk> = OnceLock::new();
    DESK.get_or_init(Desk::new)
}

/// The socket buffers of the three connections to the robot.
static LINK_BUFFERS: ConstStaticCell<LinkBuffers> = ConstStaticCell::new([
    SocketBuffers::new(),
    SocketBuffers::new(),
    SocketBuffers::new(),
]);

/// Loads the saved settings over `defaults` and logs the configuration they give; the
/// board's first step, before its network and buttons are set up from them; call once. A
/// store that cannot be read leaves the defaults in place and the fault LED blinking until
/// a save.
///
/// The settings (4 KiB) are kept in a static and handed on by reference: moved by value
/// into the console's task, each async function on the way would keep its own copy in its
/// future, itself a static.
pub async fn load_settings<F: NorFlash>(
    store: &mut Store<F>,
    defaults: Config,
) -> (&'static mut Settings, Option<LoadProblem>) {
    static SETTINGS: StaticCell<Settings> = StaticCell::new();
    let (settings, problem) = settings::load(store, defaults).await;
    if let Some(problem) = problem {
        board_log!(warn, "settings: {:?}", problem);
        shared().set_settings_lost(problem.is_loss());
    }
    log_config(settings.config());
    (SETTINGS.init(settings), problem)
}

/// Logs the configuration the board runs with: the robot and the network.
fn log_config(config: &Config) {
    let [a, b, c, d] = config.robot.ip;
    board_log!(
        info,
        "robot at {}.{}.{}.{}:{}",
        a,
        b,
        c,
        d,
        config.robot.port
    );
    match config.network() {
        Network::Dhcp => board_log!(info, "network: DHCP"),
        Network::Static(s) => {
            let [a, b, c, d] = s.address;
            board_log!(
                info,
                "network: static {}.{}.{}.{}/{}, gateway {:?}",
                a,
                b,
                c,
                d,
                s.prefix_len,
                s.gateway
            );
        }
    }
}

/// Runs the serial console over `rx` and `tx` forever, saving through `store`; restarts
/// the board when asked to.
pub async fn run_console<R: Read, W: Write, F: NorFlash>(
    rx: R,
    tx: W,
    mut store: Store<F>,
    settings: &mut Settings,
    problem: Option<LoadProblem>,
) -> ! {
    let _: Reboot = console::run(rx, tx, &mut store, settings, problem, shared(), desk()).await;
    board_log!(info, "rebooting, as asked on the console");
    cortex_m::peripheral::SCB::sys_reset()
}

/// Runs the panel on `stack` with `config`, forever; call once.
pub async fn run_app(stack: Stack<'static>, config: &Config) -> ! {
    let buffers = LINK_BUFFERS.take();
    let mut connections = net::connections(stack, net::endpoint(config.robot), buffers);
    app::run(config, &mut connections, shared()).await
}

/// Tells the application and the log whether the board has a network: a link and an
/// address.
#[embassy_executor::task]
pub async fn network_watch_task(stack: Stack<'static>) -> ! {
    loop {
        stack.wait_link_up().await;
        board_log!(info, "Ethernet link up");
        if let Either::First(()) = select(stack.wait_config_up(), stack.wait_link_down()).await {
            let address = stack.config_v4().map(|v4| Cidr {
                address: v4.address.address().octets(),
                prefix_len: v4.address.prefix_len(),
            });
            match address {
                Some(Cidr {
                    address: [a, b, c, d],
                    prefix_len,
                }) => {
                    board_log!(info, "network up: {}.{}.{}.{}/{}", a, b, c, d, prefix_len);
                    board_log!(info, "web page: http://{}.{}.{}.{}/", a, b, c, d);
                }
                None => board_log!(info, "network up"),
            }
            shared().set_board_address(address);
            shared().set_network(NetworkState::Up);
            // A lost lease counts as no network too.
            select(stack.wait_link_down(), stack.wait_config_down()).await;
            shared().set_network(NetworkState::Down);
            shared().set_board_address(None);
        }
        board_log!(warn, "network down");
    }
}
