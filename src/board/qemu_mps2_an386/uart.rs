//! UART0 (CMSDK APB UART at 0x4000_4000, RX interrupt 0), the virtual panel's input: QEMU
//! connects it to `-serial`, typically the terminal (`-serial stdio`).
//!
//! The UART holds one received character; QEMU offers the next only after it is read, so no
//! input is lost however slowly the firmware reads. The RX interrupt only wakes the reading
//! task; the character stays in the UART until the task reads it.

use core::future::poll_fn;
use core::sync::atomic::{AtomicBool, Ordering};
use core::task::Poll;

use embassy_sync::waitqueue::AtomicWaker;

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
/// STATE: a received character waits in DATA.
const STATE_RX_FULL: u32 = 1 << 1;
/// CTRL: receiver on.
const CTRL_RX_ENABLE: u32 = 1 << 1;
/// CTRL: interrupt when a character arrives.
const CTRL_RX_IRQ_ENABLE: u32 = 1 << 3;
/// INTSTATUS: the RX interrupt.
const INT_RX: u32 = 1 << 1;
/// 115200 baud from the 25 MHz APB clock (QEMU ignores the rate, a chip would not).
const BAUD_DIVIDER: u32 = 25_000_000 / 115_200;

/// UART0's registers.
// SAFETY: 0x4000_4000 is UART0 of mps2-an386, used by this driver only.
const REGS: Registers = unsafe { Registers::new(0x4000_4000, BLOCK) };

/// The reading task's waker, woken by the RX interrupt.
static WAKER: AtomicWaker = AtomicWaker::new();

/// Whether the receiver was taken.
static TAKEN: AtomicBool = AtomicBool::new(false);

/// UART0's receiver. Only one exists (see [`Uart0Rx::take`]).
pub struct Uart0Rx {
    /// Not constructible outside this module.
    _private: (),
}

impl Uart0Rx {
    /// Turns the receiver and its interrupt on. Only the first call gets the receiver: a
    /// second one would steal characters from it.
    pub fn take() -> Option<Self> {
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        REGS.write(BAUDDIV, BAUD_DIVIDER);
        REGS.write(INTSTATUS, INT_RX);
        REGS.write(CTRL, CTRL_RX_ENABLE | CTRL_RX_IRQ_ENABLE);
        interrupts::unmask(Interrupt::Uart0Rx);
        Some(Self { _private: () })
    }

    /// The next received character.
    pub async fn read(&mut self) -> u8 {
        poll_fn(|cx| {
            if let Some(byte) = received() {
                return Poll::Ready(byte);
            }
            WAKER.register(cx.waker());
            // A character that came between the first look and the registration woke no one.
            match received() {
                Some(byte) => Poll::Ready(byte),
                None => Poll::Pending,
            }
        })
        .await
    }
}

/// The waiting character, if any; reading it lets the next one in.
fn received() -> Option<u8> {
    (REGS.read(STATE) & STATE_RX_FULL != 0).then(|| (REGS.read(DATA) & 0xFF) as u8)
}

/// UART0's RX interrupt handler: acknowledges the interrupt and wakes the reader.
// SAFETY: the name is the one the vector table (interrupts.rs) and device.x expect; nothing
// else defines it.
#[unsafe(no_mangle)]
#[allow(non_snake_case)]
extern "C" fn UART0_RX() {
    REGS.write(INTSTATUS, INT_RX);
    WAKER.wake();
}
