//! The independent watchdog (IWDG): resets the board when the firmware hangs.
//!
//! Two levels of hang are caught:
//!
//! - **The executor stops** (a task that never yields, an interrupt storm, a HardFault or a
//!   panic, which halts the core): nothing feeds the IWDG, and it resets the board after
//!   [`TIMEOUT`].
//! - **The application stops** while the executor runs (a wait that never ends, a deadlock
//!   between the loops): the feeding task sees `Shared::heartbeat` stand still for
//!   [`STALL_LIMIT`] and stops feeding, so the IWDG resets the board [`TIMEOUT`] later.
//!
//! The stall limit is far longer than the IWDG's timeout because one legitimate step of the
//! control loop may take that long: a connection attempt waits up to 5 s for an address and
//! 5 s for the robot (`board::net`), and a request may wait 10 s for TCP to give up on a write
//! and 1.5 s for the answer.
//!
//! The IWDG runs from the LSI oscillator (32 kHz nominal, 17–47 kHz over the STM32F767's
//! range), so the real timeout is 1.0–2.8 s for the nominal 1.5 s; it is fed every
//! [`FEED_PERIOD`], well inside the shortest. It is frozen while a debugger halts the core,
//! so a breakpoint does not reset the board.

use core::sync::atomic::Ordering;

use defmt::{error, info, warn};
use embassy_stm32::Peri;
use embassy_stm32::pac;
use embassy_stm32::peripherals::IWDG;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_time::{Duration, Instant, Timer};
use x30_panel::app::Shared;

/// Nominal IWDG timeout: how long the board survives without a feed.
pub const TIMEOUT: Duration = Duration::from_millis(1500);
/// How often the IWDG is fed while the application makes progress.
pub const FEED_PERIOD: Duration = Duration::from_millis(250);
/// How long the application's heartbeat may stand still before the board is reset.
pub const STALL_LIMIT: Duration = Duration::from_secs(20);

/// The running watchdog, to hand to [`watchdog_task`].
pub struct Watchdog(IndependentWatchdog<'static, IWDG>);

/// Starts the IWDG; from now on the board resets unless [`watchdog_task`] runs.
///
/// Called before the Ethernet set-up, whose register waits (DMA reset, PHY reset) would
/// otherwise hang forever without a PHY clock.
pub fn start(iwdg: Peri<'static, IWDG>) -> Watchdog {
    // Halting at a breakpoint must not reset the board under the debugger.
    pac::DBGMCU.apb1fzr().modify(|w| w.set_iwdg(true));
    let timeout_us = u32::try_from(TIMEOUT.as_micros()).unwrap_or(u32::MAX);
    let mut dog = IndependentWatchdog::new(iwdg, timeout_us);
    dog.unleash();
    dog.pet();
    Watchdog(dog)
}

/// Feeds the IWDG every [`FEED_PERIOD`] while the application's heartbeat moves.
#[embassy_executor::task]
pub async fn watchdog_task(mut dog: Watchdog, shared: &'static Shared) -> ! {
    let mut beats = shared.heartbeat.load(Ordering::Relaxed);
    // The application has not started yet; its set-up counts as progress.
    let mut last_progress = Instant::now();
    let mut stalled = false;
    loop {
        let now = Instant::now();
        let latest = shared.heartbeat.load(Ordering::Relaxed);
        if latest != beats {
            beats = latest;
            last_progress = now;
        }
        if now.saturating_duration_since(last_progress) < STALL_LIMIT {
            dog.0.pet();
        } else if !stalled {
            stalled = true;
            error!(
                "application stalled for {} s: letting the watchdog reset the board",
                STALL_LIMIT.as_secs()
            );
        }
        Timer::after(FEED_PERIOD).await;
    }
}

/// Logs why the board last reset, and clears the reset flags for next time.
pub fn log_reset_cause() {
    let csr = pac::RCC.csr().read();
    // Several flags may be set at once (a power-on also sets the pin flag); the first that
    // applies says the most.
    if csr.wdgrstf() {
        warn!("reset by the independent watchdog: the firmware had hung");
    } else if csr.wwdgrstf() {
        warn!("reset by the window watchdog");
    } else if csr.lpwrrstf() {
        warn!("reset by low-power management");
    } else if csr.sftrstf() {
        info!("reset by software (debugger or system reset request)");
    } else if csr.borrstf() || csr.porrstf() {
        info!("reset by power-on or brown-out");
    } else if csr.padrstf() {
        info!("reset by the NRST pin");
    }
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
}
