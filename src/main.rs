//! x30-panel firmware entry point: brings up the board, then runs the panel.
//!
//! Board specifics live in [`board`]; this file stays the same for every board.
#![no_std]
#![no_main]

mod board;

use defmt::info;
use embassy_executor::Spawner;
use embassy_time::Timer;
// Linked for their side effects only: the defmt RTT transport and the panic handler, which
// prints the panic message over defmt and halts the probe session with an error.
use {defmt_rtt as _, panic_probe as _};

/// Firmware main task, started by the embassy executor after reset.
#[embassy_executor::main]
async fn main(_spawner: Spawner) -> ! {
    let mut board: board::Board = board::init();
    info!("x30-panel {} starting", env!("CARGO_PKG_VERSION"));

    // Lamp test: every LED on for half a second, so a dead LED is noticed at power-up rather
    // than mistaken for "no fault" later.
    board.link.set_high();
    board.activity.set_high();
    board.fault.set_high();
    Timer::after_millis(500).await;
    board.activity.set_low();
    board.fault.set_low();

    // Until the application exists, blink the link LED at 1 Hz so a human sees the firmware
    // is alive and the clock configuration (hence the timer rate) is right.
    loop {
        board.link.toggle();
        Timer::after_millis(500).await;
    }
}
