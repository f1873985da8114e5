//! What every board does the same way around its drivers: the state it shares with the
//! application, the configuration it logs, the network watch, and running the application
//! over the three connections. Each board keeps only its drivers and pin map.

use embassy_futures::select::{Either, select};
use embassy_net::Stack;
use static_cell::ConstStaticCell;
use x30_panel::app::{self, Shared};
use x30_panel::config::{Config, Network};
use x30_panel::panel::NetworkState;

use super::net::{self, LinkBuffers, SocketBuffers};

/// What the board and the application share.
pub static SHARED: Shared = Shared::new();

/// The socket buffers of the three connections to the robot.
static LINK_BUFFERS: ConstStaticCell<LinkBuffers> = ConstStaticCell::new([
    SocketBuffers::new(),
    SocketBuffers::new(),
    SocketBuffers::new(),
]);

/// Logs the configuration the board runs with: invalid settings, the robot, the network.
pub fn log_config(config: &Config) {
    for variable in config.problems() {
        board_log!(
            warn,
            "{} is not valid; its default is used",
            variable.name()
        );
    }
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
    match config.network {
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

/// Runs the panel on `stack` with `config`, forever; call once.
pub async fn run_app(stack: Stack<'static>, config: &Config) -> ! {
    let buffers = LINK_BUFFERS.take();
    let mut connections = net::connections(stack, net::endpoint(config.robot), buffers);
    app::run(config, &mut connections, &SHARED).await
}

/// Tells the application and the log whether the board has a network: a link and an
/// address.
#[embassy_executor::task]
pub async fn network_watch_task(stack: Stack<'static>) -> ! {
    loop {
        stack.wait_link_up().await;
        board_log!(info, "Ethernet link up");
        if let Either::First(()) = select(stack.wait_config_up(), stack.wait_link_down()).await {
            match stack.config_v4() {
                Some(v4) => board_log!(info, "network up: {}", v4.address),
                None => board_log!(info, "network up"),
            }
            SHARED.set_network(NetworkState::Up);
            // A lost lease counts as no network too.
            select(stack.wait_link_down(), stack.wait_config_down()).await;
            SHARED.set_network(NetworkState::Down);
        }
        board_log!(warn, "network down");
    }
}
