//! x30-panel firmware entry point: brings up the board, then runs the panel.
//!
//! Board specifics live in [`board`]; this file stays the same for every board.
#![no_std]
#![no_main]

mod board;

use embassy_executor::Spawner;

/// Starts the board's executor with the main task, after reset.
#[cortex_m_rt::entry]
fn entry() -> ! {
    board::start(|spawner| spawner.spawn(main(spawner).expect("the main task is spawned once")))
}

/// Firmware main task: the board's bring-up, then the panel.
#[embassy_executor::task]
async fn main(spawner: Spawner) -> ! {
    board::run(spawner).await
}
