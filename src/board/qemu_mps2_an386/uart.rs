//! The board's CMSDK APB UARTs: [`UART0`] (0x4000_4000), the virtual panel's input, and
//! [`UART1`] (0x4000_5000), the serial console. QEMU connects UART N to its N-th `-serial`
//! option (x30-qemu: UART0 to the terminal, UART1 to a socket of its own).
//!
//! One driver serves both: a [`Port`] names a UART's registers, interrupts and wakers, and
//! [`Port::take`] hands out its receiver and transmitter once.
//!
//! The UART holds one received character; QEMU offers the next only after it is read, so no
//! input is lost however slowly the firmware reads. The RX interrupt only wakes the reading
//! task; the character stays in the UART until the task reads it. The transmitter holds one
//! character too: QEMU passes it on at once unless the other end is slow, and then it raises
//! the TX interrupt when the buffer empties, which wakes the writing task.

use core::convert::Infallible;
use core::future::poll_fn;
use core::sync::atomic::{AtomicBool, Ordering};
use core::task::Poll;

use embassy_sync::waitqueue::AtomicWaker;
use embedded_io_async::{ErrorType, Read, Write};

use super::interrupts::{self, Interrupt};
use super::mmio::Registers;

// CMSDK APB UART registers (ARM DDI 0479C, 4.3).
/// Received (read) or to-send (write) character.
const DATA: usize = 0x00;
/// Status: TX buffer full (bit 0), RX buffer full (bit 1), overruns.
const STATE: usize = 0x04;
/// Control: TX/RX enable and their interrupt enables.
const CTRL: usize = 0x08;
/// Interrupt status; write 1 to clear.
const INTSTATUS: usize = 0x0C;
/// Baud-rate divider: PCLK / baud rate, at least 16.
const BAUDDIV: usize = 0x10;
/// Size of the register block.
const BLOCK: usize = 0x1000;
/// STATE: a character waits in the TX buffer.
const STATE_TX_FULL: u32 = 1 << 0;
/// STATE: a received character waits in DATA.
const STATE_RX_FULL: u32 = 1 << 1;
/// CTRL: transmitter on.
const CTRL_TX_ENABLE: u32 = 1 << 0;
/// CTRL: receiver on.
const CTRL_RX_ENABLE: u32 = 1 << 1;
/// CTRL: interrupt when the TX buffer empties.
const CTRL_TX_IRQ_ENABLE: u32 = 1 << 2;
/// CTRL: interrupt when a character arrives.
const CTRL_RX_IRQ_ENABLE: u32 = 1 << 3;
/// INTSTATUS: the TX interrupt.
const INT_TX: u32 = 1 << 0;
/// INTSTATUS: the RX interrupt.
const INT_RX: u32 = 1 << 1;
/// 115200 baud from the 25 MHz APB clock (QEMU ignores the rate, a chip would not).
const BAUD_DIVIDER: u32 = 25_000_000 / 115_200;

/// One UART: its registers, its interrupts, and the tasks they wake.
pub struct Port {
    /// The UART's registers.
    regs: Registers,
    /// Its RX interrupt.
    rx_interrupt: Interrupt,
    /// Its TX interrupt.
    tx_interrupt: Interrupt,
    /// The reading task's waker, woken by the RX interrupt.
    rx_waker: AtomicWaker,
    /// The writing task's waker, woken by the TX interrupt.
    tx_waker: AtomicWaker,
    /// Whether the receiver and transmitter were taken.
    taken: AtomicBool,
}

/// UART0: the virtual panel's button lines (QEMU's first `-serial`).
// SAFETY: 0x4000_4000 is UART0 of mps2-an386, used through this value only.
pub static UART0: Port = Port::new(
    unsafe { Registers::new(0x4000_4000, BLOCK) },
    Interrupt::Uart0Rx,
    Interrupt::Uart0Tx,
);

/// UART1: the serial console (QEMU's second `-serial`).
// SAFETY: 0x4000_5000 is UART1 of mps2-an386, used through this value only.
pub static UART1: Port = Port::new(
    unsafe { Registers::new(0x4000_5000, BLOCK) },
    Interrupt::Uart1Rx,
    Interrupt::Uart1Tx,
);

impl Port {
    /// The UART at `regs` with these interrupts.
    const fn new(regs: Registers, rx_interrupt: Interrupt, tx_interrupt: Interrupt) -> Self {
        Self {
            regs,
            rx_interrupt,
            tx_interrupt,
            rx_waker: AtomicWaker::new(),
            tx_waker: AtomicWaker::new(),
            taken: AtomicBool::new(false),
        }
    }

    /// Turns the UART and its interrupts on and returns its two directions. Only the first
    /// call gets them: a second reader would steal characters from the first.
    pub fn take(&'static self) -> Option<(UartRx, UartTx)> {
        if self.taken.swap(true, Ordering::AcqRel) {
            return None;
        }
        self.regs.write(BAUDDIV, BAUD_DIVIDER);
        self.regs.write(INTSTATUS, INT_RX | INT_TX);
        self.regs.write(
            CTRL,
            CTRL_TX_ENABLE | CTRL_RX_ENABLE | CTRL_TX_IRQ_ENABLE | CTRL_RX_IRQ_ENABLE,
        );
        interrupts::unmask(self.rx_interrupt);
        interrupts::unmask(self.tx_interrupt);
        Some((UartRx { port: self }, UartTx { port: self }))
    }

    /// The waiting character, if any; reading it lets the next one in.
    fn received(&self) -> Option<u8> {
        (self.regs.read(STATE) & STATE_RX_FULL != 0).then(|| (self.regs.read(DATA) & 0xFF) as u8)
    }

    /// Whether the TX buffer has room for a character.
    fn can_send(&self) -> bool {
        self.regs.read(STATE) & STATE_TX_FULL == 0
    }

    /// Waits until `ready` gives a value, woken by `waker`'s interrupt.
    async fn wait_for<T>(&self, waker: &AtomicWaker, mut ready: impl FnMut() -> Option<T>) -> T {
        poll_fn(|cx| {
            if let Some(value) = ready() {
                return Poll::Ready(value);
            }
            waker.register(cx.waker());
            // An interrupt between the first look and the registration woke no one.
            match ready() {
                Some(value) => Poll::Ready(value),
                None => Poll::Pending,
            }
        })
        .await
    }

    /// The RX interrupt: acknowledges it and wakes the reader.
    fn on_rx_interrupt(&self) {
        self.regs.write(INTSTATUS, INT_RX);
        self.rx_waker.wake();
    }

    /// The TX interrupt: acknowledges it and wakes the writer.
    fn on_tx_interrupt(&self) {
        self.regs.write(INTSTATUS, INT_TX);
        self.tx_waker.wake();
    }
}

/// A UART's receiver (see [`Port::take`]).
pub struct UartRx {
    /// The UART.
    port: &'static Port,
}

impl UartRx {
    /// The next received character.
    pub async fn read_byte(&mut self) -> u8 {
        let port = self.port;
        port.wait_for(&port.rx_waker, || port.received()).await
    }
}

impl ErrorType for UartRx {
    type Error = Infallible;
}

impl Read for UartRx {
    /// Waits for one character, then takes those that are already there, up to `buf`'s size.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let Some((first, rest)) = buf.split_first_mut() else {
            return Ok(0);
        };
        *first = self.read_byte().await;
        let mut len = 1;
        for slot in rest {
            match self.port.received() {
                Some(byte) => *slot = byte,
                None => break,
            }
            len += 1;
        }
        Ok(len)
    }
}

/// A UART's transmitter (see [`Port::take`]).
pub struct UartTx {
    /// The UART.
    port: &'static Port,
}

impl ErrorType for UartTx {
    type Error = Infallible;
}

impl Write for UartTx {
    /// Waits for room for one character, then sends as many as fit without waiting again.
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let Some((&first, rest)) = buf.split_first() else {
            return Ok(0);
        };
        self.flush().await?;
        self.port.regs.write(DATA, u32::from(first));
        let mut len = 1;
        for &byte in rest {
            if !self.port.can_send() {
                break;
            }
            self.port.regs.write(DATA, u32::from(byte));
            len += 1;
        }
        Ok(len)
    }

    /// Waits until the UART has passed the last character on.
    async fn flush(&mut self) -> Result<(), Infallible> {
        let port = self.port;
        port.wait_for(&port.tx_waker, || port.can_send().then_some(()))
            .await;
        Ok(())
    }
}

// The interrupt handlers. SAFETY (each): the name is the one the vector table
// (interrupts.rs) and device.x expect; nothing else defines it.

/// UART0's RX interrupt.
#[unsafe(no_mangle)]
#[allow(non_snake_case)]
extern "C" fn UART0_RX() {
    UART0.on_rx_interrupt();
}

/// UART0's TX interrupt.
#[unsafe(no_mangle)]
#[allow(non_snake_case)]
extern "C" fn UART0_TX() {
    UART0.on_tx_interrupt();
}

/// UART1's RX interrupt.
#[unsafe(no_mangle)]
#[allow(non_snake_case)]
extern "C" fn UART1_RX() {
    UART1.on_rx_interrupt();
}

/// UART1's TX interrupt.
#[unsafe(no_mangle)]
#[allow(non_snake_case)]
extern "C" fn UART1_TX() {
    UART1.on_tx_interrupt();
}
