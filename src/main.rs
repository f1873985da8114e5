//! x30-panel firmware entry point: brings up the board, then runs the panel.
//!
//! Board specifics live in [`board`]; this file stays the same for every board.
#![no_std]
#![no_main]

mod board;

use embassy_executor::Spawner;

/// Firmware main task, started by the embassy executor after reset.
#[embassy_executor::main]
async fn main(spawner: Spawner) -> ! {
    board::run(spawner).await
}
