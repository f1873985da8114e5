//! Shared pieces of the client tests: a tokio transport for the client.

use embedded_io_adapters::tokio_1::FromTokio;
use embedded_io_async::{Error, ErrorKind, ErrorType, Read, Write};
use std::net::SocketAddr;
use tokio::net::TcpStream;
use x30_panel::client::Transport;
use x30_panel::config::RobotAddress;

/// A client transport over a tokio `TcpStream`, reconnectable like the board's socket.
pub struct TokioTransport {
    addr: SocketAddr,
    stream: Option<FromTokio<TcpStream>>,
}

impl TokioTransport {
    /// A transport that connects to `addr`.
    pub fn new(addr: SocketAddr) -> Self {
        Self { addr, stream: None }
    }
}

impl ErrorType for TokioTransport {
    type Error = ErrorKind;
}

impl Read for TokioTransport {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        match &mut self.stream {
            Some(s) => s.read(buf).await.map_err(|e| Error::kind(&e)),
            None => Err(ErrorKind::NotConnected),
        }
    }
}

impl Write for TokioTransport {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        match &mut self.stream {
            Some(s) => s.write(buf).await.map_err(|e| Error::kind(&e)),
            None => Err(ErrorKind::NotConnected),
        }
    }

    async fn flush(&mut self) -> Result<(), ErrorKind> {
        match &mut self.stream {
            Some(s) => s.flush().await.map_err(|e| Error::kind(&e)),
            None => Err(ErrorKind::NotConnected),
        }
    }
}

impl Transport for TokioTransport {
    async fn connect(&mut self) -> Result<(), ErrorKind> {
        self.stream = None;
        let stream = TcpStream::connect(self.addr)
            .await
            .map_err(|e| Error::kind(&e))?;
        stream.set_nodelay(true).ok();
        self.stream = Some(FromTokio::new(stream));
        Ok(())
    }

    async fn close(&mut self) {
        self.stream = None;
    }

    fn set_robot(&mut self, robot: RobotAddress) {
        self.addr = SocketAddr::from((robot.ip, robot.port));
    }
}
