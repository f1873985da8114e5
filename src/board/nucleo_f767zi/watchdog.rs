//! The independent watchdog (IWDG): resets the board when the firmware hangs.
//!
//! Two levels of hang are caught:
//!
//! - **The executor stops** (a task that never yields, an interrupt storm, a HardFault or a
//!   panic, which halts the core): nothing feeds the IWDG, and it resets the board after
//!   [`TIMEOUT`].
//! - **The button path or the command path stops** while the executor runs (a wait that
//!   never ends, a deadlock between the loops): the feeding task sees the progress counter
//!   of the button task or of the command loop (`Shared::progress`) stand still for
//!   [`STALL_LIMIT`] and stops feeding, so the IWDG resets the board [`TIMEOUT`] later.
//!
//! The stall limit is far longer than the IWDG's timeout because one legitimate step of the
//! command loop may take that long: a connection attempt waits up to 5 s for an address and
//! 5 s for the robot (`board::net`); writes are bounded to 200 ms.
//!
//! The IWDG runs from the LSI oscillator (32 kHz nominal, 17–47 kHz over the STM32F767's
//! range), so the real timeout is 1.0–2.8 s for the nominal 1.5 s; it is fed every
//! [`FEED_PERIOD`], well inside the shortest. It is frozen while a debugger halts the core,
//! so a breakpoint does not reset the board.

use defmt::{error, info, warn};
use embassy_stm32::Peri;
use embassy_stm32::pac;
use embassy_stm32::peripherals::IWDG;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_time::{Duration, Instant, Timer};
use x30_panel::app::{Path, Shared};

/// Nominal IWDG timeout: how long the board survives without a feed.
pub const TIMEOUT: Duration = Duration::from_millis(1500);
/// How often the IWDG is fed while the application makes progress.
pub const FEED_PERIOD: Duration = Duration::from_millis(250);
/// How long a path's progress may stand still before the board is reset.
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

/// Feeds the IWDG every [`FEED_PERIOD`] while both the button path and the command path
/// make progress.
#[embassy_executor::task]
pub async fn watchdog_task(mut dog: Watchdog, shared: &'static Shared) -> ! {
    let paths = [Path::Buttons, Path::Commands];
    let mut seen = paths.map(|path| shared.progress(path));
    // Nothing has started yet; the set-up counts as progress.
    let mut last_progress = [Instant::now(); 2];
    let mut stalled = false;
    loop {
        let now = Instant::now();
        for ((path, seen), last) in paths.iter().zip(&mut seen).zip(&mut last_progress) {
            let latest = shared.progress(*path);
            if latest != *seen {
                *seen = latest;
                *last = now;
            }
        }
        let stuck = paths
            .iter()
            .zip(&last_progress)
            .find(|(_, last)| now.saturating_duration_since(**last) >= STALL_LIMIT);
        match stuck {
            None => dog.0.pet(),
            Some((path, _)) if !stalled => {
                stalled = true;
                error!(
                    "{} path stalled for {} s: letting the watchdog reset the board",
                    path,
                    STALL_LIMIT.as_secs()
                );
            }
            Some(_) => {}
        }
        Timer::after(FEED_PERIOD).await;
    }
}

/// Reloads the IWDG at once, giving the firmware the IWDG's full timeout from now.
///
/// Only for right before (and after) a known stall of the whole CPU that [`watchdog_task`]
/// cannot feed through: erasing a flash sector holds every flash read, so no code runs until
/// the erase ends (`settings_flash`). It bypasses the progress check, so it is not for
/// anything that could repeat without end.
pub fn feed_now() {
    pac::IWDG
        .kr()
        .write(|w| w.set_key(pac::iwdg::vals::Key::RESET));
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
