//! The serial console's port: USART3 on PD8 (TX) and PD9 (RX), wired to the ST-LINK, which
//! offers it to the host as its virtual COM port; 115200 baud, 8 data bits, no parity, one
//! stop bit. Interrupt-driven, with a ring buffer each way, and run by [`console_task`].

use defmt::unwrap;
use embassy_stm32::Peri;
use embassy_stm32::gpio::Pull;
use embassy_stm32::peripherals::{PD8, PD9, USART3};
use embassy_stm32::usart::{self, BufferedUart, BufferedUartRx, BufferedUartTx};
use embedded_io_async::{ErrorType, Write};
use static_cell::ConstStaticCell;
use x30_panel::settings::store::Store;
use x30_panel::settings::{LoadProblem, Settings};

use super::Irqs;
use super::glue;
use super::settings_flash::SettingsFlash;

/// Received bytes not yet read: a few typed lines, far more than a person types while the
/// console answers.
const RX_BUFFER: usize = 256;
/// Bytes queued for sending: the longest write goes out at once, a screenful of `show`
/// output.
const TX_BUFFER: usize = 1024;

/// The receive ring buffer.
static RX: ConstStaticCell<[u8; RX_BUFFER]> = ConstStaticCell::new([0; RX_BUFFER]);
/// The send ring buffer.
static TX: ConstStaticCell<[u8; TX_BUFFER]> = ConstStaticCell::new([0; TX_BUFFER]);

/// Sets up USART3 for the console and splits it into its receiving and sending halves.
pub fn open(
    usart: Peri<'static, USART3>,
    tx: Peri<'static, PD8>,
    rx: Peri<'static, PD9>,
) -> (BufferedUartRx<'static>, ConsoleTx) {
    let mut config = usart::Config::default();
    config.baudrate = 115_200;
    config.data_bits = usart::DataBits::DataBits8;
    config.parity = usart::Parity::ParityNone;
    config.stop_bits = usart::StopBits::STOP1;
    // An idle line is high; the pull-up keeps it so (rather than reading noise as bytes)
    // while the ST-LINK's side of the line is not driven.
    config.rx_pull = Pull::Up;
    // Only a wrong configuration fails (a baud rate the clock cannot make): a bug.
    let uart = unwrap!(BufferedUart::new(
        usart,
        rx,
        tx,
        TX.take(),
        RX.take(),
        Irqs,
        config
    ));
    let (tx, rx) = uart.split();
    (rx, ConsoleTx(tx))
}

/// The console's sending half.
///
/// embassy-stm32 0.6's buffered UART refuses, rather than shortens, a write longer than its
/// buffer, and a write that does not fit in the buffer's free space waits without asking to
/// be woken, so it may never end. This one therefore waits for the buffer to drain, which
/// does ask to be woken, and then writes at most a buffer's worth, which always fits; as
/// `embedded_io_async::Write` allows, it may write less than it was given. The line is the
/// bottleneck anyway: 1 KiB takes 89 ms at 115200 baud.
pub struct ConsoleTx(BufferedUartTx<'static>);

impl ErrorType for ConsoleTx {
    type Error = usart::Error;
}

impl Write for ConsoleTx {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0.flush().await?;
        let (now, _) = buf.split_at(buf.len().min(TX_BUFFER));
        self.0.write(now).await
    }

    async fn flush(&mut self) -> Result<(), Self::Error> {
        self.0.flush().await
    }
}

/// Runs the serial console on USART3, saving to the settings flash.
#[embassy_executor::task]
pub async fn console_task(
    rx: BufferedUartRx<'static>,
    tx: ConsoleTx,
    store: Store<SettingsFlash>,
    settings: &'static mut Settings,
    problem: Option<LoadProblem>,
) -> ! {
    glue::run_console(rx, tx, store, settings, problem).await
}
