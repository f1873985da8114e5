//! The client's transport over embassy-net TCP, for every board with a network stack.
//!
//! A [`TcpTransport`] is one [`TcpSocket`] to the robot that [`Connection`](x30_panel::client::Connection)
//! opens and closes again as it needs: `connect` waits (boundedly) for the board's address,
//! aborts the previous connection and connects; `close` aborts. embassy-net's errors map to
//! `embedded_io_async::ErrorKind`, the client's error currency.

use embassy_net::tcp::{State, TcpSocket};
use embassy_net::{IpAddress, IpEndpoint, Ipv4Address, Ipv4Cidr, Stack, StaticConfigV4};
use embassy_time::{Duration, with_timeout};
use embedded_io_async::{Error as _, ErrorKind, ErrorType, Read, Write};
use x30_panel::app::Connections;
use x30_panel::client::{Backoff, Connection, RX_BUF, TX_BUF, Transport};
use x30_panel::config::{Network, RobotAddress};

/// How long `connect` waits for the board's address (DHCP) before it fails, so that the
/// connection's backoff and logging go on while the network is down.
pub const NETWORK_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a TCP connection attempt may take.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);
/// How long closing waits for the reset to go out.
pub const CLOSE_TIMEOUT: Duration = Duration::from_millis(500);
/// Keep-alive interval: an idle connection to a robot that vanished is noticed.
pub const KEEP_ALIVE: Duration = Duration::from_secs(2);
/// A connection that hears nothing (not even keep-alive answers) this long is reset.
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(10);

/// Reconnection delays: quick after a blip, at most every 5 s while the robot is away.
pub const BACKOFF: Backoff = Backoff::new(Duration::from_millis(250), Duration::from_secs(5));

/// Sockets of the stack: the three connections to the robot, DHCP and the web page's
/// server tasks.
pub const SOCKETS: usize = 4 + super::web::TASKS;

/// One TCP socket's buffers: room for a whole answer and a whole request.
pub struct SocketBuffers {
    /// Received bytes not yet read.
    rx: [u8; RX_BUF],
    /// Written bytes not yet acknowledged.
    tx: [u8; TX_BUF],
}

impl SocketBuffers {
    /// Zeroed buffers, for a `static`.
    pub const fn new() -> Self {
        Self {
            rx: [0; RX_BUF],
            tx: [0; TX_BUF],
        }
    }
}

/// The buffers of the three connections' sockets.
pub type LinkBuffers = [SocketBuffers; 3];

/// The three connections to `robot` on `stack`, over `buffers`.
pub fn connections<'d>(
    stack: Stack<'d>,
    robot: IpEndpoint,
    buffers: &'d mut LinkBuffers,
) -> Connections<TcpTransport<'d>> {
    let [commands, polls, navigation] = buffers;
    let connection = |buffers: &'d mut SocketBuffers| {
        Connection::new(
            TcpTransport::new(stack, robot, &mut buffers.rx, &mut buffers.tx),
            BACKOFF,
        )
    };
    Connections {
        commands: connection(commands),
        polls: connection(polls),
        navigation: connection(navigation),
    }
}

/// The stack configuration for the board's network settings.
pub fn stack_config(network: Network) -> embassy_net::Config {
    match network {
        Network::Dhcp => embassy_net::Config::dhcpv4(Default::default()),
        Network::Static(settings) => {
            let [a, b, c, d] = settings.address;
            embassy_net::Config::ipv4_static(StaticConfigV4 {
                address: Ipv4Cidr::new(Ipv4Address::new(a, b, c, d), settings.prefix_len),
                gateway: settings
                    .gateway
                    .map(|[a, b, c, d]| Ipv4Address::new(a, b, c, d)),
                dns_servers: Default::default(),
            })
        }
    }
}

/// The robot's address as an embassy-net endpoint.
pub fn endpoint(robot: RobotAddress) -> IpEndpoint {
    let [a, b, c, d] = robot.ip;
    IpEndpoint::new(IpAddress::v4(a, b, c, d), robot.port)
}

/// A reconnectable TCP connection to the robot.
pub struct TcpTransport<'d> {
    /// The socket, reused for every connection.
    socket: TcpSocket<'d>,
    /// The stack, to wait for the board's address.
    stack: Stack<'d>,
    /// The robot's `robot_server`.
    remote: IpEndpoint,
}

impl<'d> TcpTransport<'d> {
    /// A transport to `remote` on `stack`, with the socket's receive and send buffers.
    pub fn new(
        stack: Stack<'d>,
        remote: IpEndpoint,
        rx_buffer: &'d mut [u8],
        tx_buffer: &'d mut [u8],
    ) -> Self {
        let mut socket = TcpSocket::new(stack, rx_buffer, tx_buffer);
        // Each request goes out at once, in its own segment. With Nagle's algorithm (on by
        // default in smoltcp) a stop written while an earlier request is still
        // unacknowledged would wait for that acknowledgement, which a robot's TCP may delay
        // by tens of milliseconds (Linux's delayed ACK) while it prepares its answer.
        socket.set_nagle_enabled(false);
        socket.set_keep_alive(Some(KEEP_ALIVE));
        socket.set_timeout(Some(IDLE_TIMEOUT));
        Self {
            socket,
            stack,
            remote,
        }
    }

    /// Resets the connection, if there is one, and lets the reset go out.
    async fn abort(&mut self) {
        if self.socket.state() != State::Closed {
            self.socket.abort();
            // Only the reset is waited for; a stack that cannot send it is no reason to hang.
            let _ = with_timeout(CLOSE_TIMEOUT, self.socket.flush()).await;
        }
    }
}

impl ErrorType for TcpTransport<'_> {
    type Error = ErrorKind;
}

impl Read for TcpTransport<'_> {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        self.socket.read(buf).await.map_err(|e| e.kind())
    }
}

impl Write for TcpTransport<'_> {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        self.socket.write(buf).await.map_err(|e| e.kind())
    }

    async fn flush(&mut self) -> Result<(), ErrorKind> {
        self.socket.flush().await.map_err(|e| e.kind())
    }
}

impl Transport for TcpTransport<'_> {
    async fn connect(&mut self) -> Result<(), ErrorKind> {
        if !self.stack.is_config_up() {
            with_timeout(NETWORK_TIMEOUT, self.stack.wait_config_up())
                .await
                .map_err(|_| ErrorKind::NotConnected)?;
        }
        self.abort().await;
        match with_timeout(CONNECT_TIMEOUT, self.socket.connect(self.remote)).await {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => {
                self.socket.abort();
                Err(e.kind())
            }
            Err(_) => {
                self.socket.abort();
                Err(ErrorKind::TimedOut)
            }
        }
    }

    async fn close(&mut self) {
        self.abort().await;
    }

    fn set_robot(&mut self, robot: RobotAddress) {
        self.remote = endpoint(robot);
    }
}
