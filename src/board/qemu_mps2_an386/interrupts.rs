//! The board's device interrupts: their NVIC numbers and the vector table.
//!
//! The numbers are those of QEMU's `mps2-an386` machine (its MPS2 board model, ARM AN386):
//! UART0 and UART1 have RX interrupts 0 and 2, each TX interrupt one more. Without a
//! peripheral access crate, cortex-m-rt's `device` feature takes the table from here
//! (`__INTERRUPTS`) and the handler names from this board's `device.x`, where each one not
//! defined by a driver falls back to cortex-m-rt's `DefaultHandler`.

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;

/// The device interrupts the firmware uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u16)]
pub enum Interrupt {
    /// UART0 received a character.
    Uart0Rx = 0,
    /// UART0's TX buffer emptied.
    Uart0Tx = 1,
    /// UART1 received a character.
    Uart1Rx = 2,
    /// UART1's TX buffer emptied.
    Uart1Tx = 3,
    /// CMSDK timer 0 (unused; the time driver reads it without interrupts).
    Timer0 = 8,
    /// CMSDK timer 1 counted down to zero: the time driver's alarm.
    Timer1 = 9,
    /// The LAN9118 Ethernet controller.
    Ethernet = 13,
}

// SAFETY: every value is one of the board's device interrupt numbers, all below the 32 lines
// its NVIC has.
unsafe impl InterruptNumber for Interrupt {
    fn number(self) -> u16 {
        self as u16
    }
}

/// Lets `interrupt` reach the processor. Call once its handler's state is ready.
pub fn unmask(interrupt: Interrupt) {
    // SAFETY: unmasking can break a critical section that works by masking interrupts; this
    // firmware has none (its critical sections disable interrupts globally), and every
    // handler in this board only touches state through critical sections or atomics.
    unsafe { NVIC::unmask(interrupt) }
}

/// Number of device interrupt lines of the board's NVIC.
const LINES: usize = 32;

/// One entry of the vector table: a handler, or nothing for an unused line.
#[derive(Clone, Copy)]
#[repr(C)]
pub union Vector {
    /// The interrupt's handler.
    handler: unsafe extern "C" fn(),
    /// Zero: the line is never enabled.
    reserved: usize,
}

// SAFETY: these are the handlers, each defined with this signature (`#[unsafe(no_mangle)]`)
// by the driver that owns the device, or provided as `DefaultHandler` by the linker script;
// they are only placed in the table, never called from Rust.
unsafe extern "C" {
    fn UART0_RX();
    fn UART0_TX();
    fn UART1_RX();
    fn UART1_TX();
    fn TIMER0();
    fn TIMER1();
    fn ETHERNET();
}

/// The device part of the vector table, after the processor's 16 exception vectors.
// SAFETY: the section and name are the ones cortex-m-rt's link.x places right after its
// exception vectors when its `device` feature is on; nothing else defines them here.
#[unsafe(link_section = ".vector_table.interrupts")]
#[unsafe(no_mangle)]
pub static __INTERRUPTS: [Vector; LINES] = {
    let mut table = [Vector { reserved: 0 }; LINES];
    table[Interrupt::Uart0Rx as usize] = Vector { handler: UART0_RX };
    table[Interrupt::Uart0Tx as usize] = Vector { handler: UART0_TX };
    table[Interrupt::Uart1Rx as usize] = Vector { handler: UART1_RX };
    table[Interrupt::Uart1Tx as usize] = Vector { handler: UART1_TX };
    table[Interrupt::Timer0 as usize] = Vector { handler: TIMER0 };
    table[Interrupt::Timer1 as usize] = Vector { handler: TIMER1 };
    table[Interrupt::Ethernet as usize] = Vector { handler: ETHERNET };
    table
};
