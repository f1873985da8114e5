//! The flash that holds the saved settings: sectors 1 and 2 of the STM32F767ZI's single-bank
//! flash, 2 × 32 KiB at 0x0800_8000..0x0801_8000, behind the async NOR-flash interface the
//! settings store takes.
//!
//! # The sectors
//!
//! The store needs at least two erase units, and the smallest the chip has are its 32 KiB
//! sectors 0–3; sector 0 must hold the vector table, where the core boots from, so the
//! settings take 1 and 2, and `memory.x` starts the code at sector 3 and asserts that the
//! vector table ends before sector 1. A flasher that erases only the sectors it writes (as
//! probe-rs does) then keeps the settings over a firmware update. Offsets here are from the
//! start of flash, as embassy-stm32's flash region takes them: [`RANGE`] is
//! 0x8000..0x1_8000. Any access outside it is refused ([`Error::OutsideSettings`]), so a
//! mistake in the store's range cannot erase the vector table or the code.
//!
//! # Erase stalls
//!
//! The flash is a single bank, so while a sector erases, every flash read waits, and the code
//! runs from flash: the whole CPU stops, interrupts included (embassy-stm32 also erases inside
//! a critical section). The datasheet (STM32F765xx/F767xx, "Flash memory programming") gives
//! `t_ERASE32KB`, the erase time of a 32 KiB sector, as 400 ms typical and 800 ms maximum at
//! the program/erase parallelism x8, and 250 ms typical and 500 ms maximum at x32.
//! embassy-stm32 0.6 erases with whatever parallelism `FLASH_CR.PSIZE` last held, which is x8
//! after reset and after each of its writes, so 800 ms is the figure to plan for. Word
//! programming (`t_prog`, 16 µs typical, 100 µs maximum) stalls too, but only briefly.
//!
//! Two things follow:
//!
//! - **The watchdog**: its real timeout may be as short as 1.0 s (`watchdog`), and the
//!   feeding task cannot run during an erase, so each erase is preceded by a feed (the stall
//!   then has the full timeout) and followed by one (the feeding task, whose timer the stall
//!   delayed, then has the full timeout again to catch up).
//! - **The time**: embassy-time's STM32 driver counts a 16-bit timer's overflows (every
//!   65.5 ms at its 1 MHz tick) in an interrupt, and no interrupt runs during the erase, so
//!   embassy's clock loses the stall's whole overflow periods: an `Instant` taken before and
//!   after would show only the remainder, and every timeout that spans an erase lasts that
//!   much longer. The stall is therefore measured with the core's cycle counter (DWT
//!   `CYCCNT`, 32 bits at the system clock: 19.9 s at 216 MHz before it wraps), which counts
//!   through it, and logged as `settings: sector erase stalled the CPU for N ms`: the real
//!   figure of each board, for field engineers to compare with the datasheet's.
//!
//! A save that needs an erase thus freezes the panel (buttons, LEDs, network) for up to
//! 0.8 s; frames that arrive meanwhile may be dropped and TCP resends them, and console
//! bytes typed meanwhile are lost (the UART holds one).
//!
//! Reads go straight to the flash: the Cortex-M7's data cache is off (nothing here turns it
//! on). Whoever turns it on must make these sectors bypass it, or reads after an erase or a
//! write would return stale data.

use core::ops::Range;

use cortex_m::peripheral::{DCB, DWT};
use defmt::{Format, info};
use embassy_embedded_hal::adapter::BlockingAsync;
use embassy_stm32::Peri;
use embassy_stm32::flash::{self, Bank1Region1, Blocking, Flash};
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::time::Hertz;
use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

use super::watchdog;

/// Offsets, from the start of flash (0x0800_0000), of sectors 1 and 2: the settings store's
/// range.
pub const RANGE: Range<u32> = 0x8000..0x1_8000;

/// Sectors 0–3 of the flash (bank 1, region 1 in embassy-stm32's terms, erased a 32 KiB
/// sector at a time), as an async NOR flash.
type Region = BlockingAsync<Bank1Region1<'static, Blocking>>;

/// The size of sectors 0–3.
const SECTOR_SIZE: u32 = 32 * 1024;

// The range is sectors 1 and 2, and the region erases exactly one of them at a time.
const _: () = assert!(
    <Region as NorFlash>::ERASE_SIZE == SECTOR_SIZE as usize
        && RANGE.start == SECTOR_SIZE
        && RANGE.end == 3 * SECTOR_SIZE
);

/// Why the settings flash refused or failed an operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Format)]
pub enum Error {
    /// The operation reaches outside sectors 1 and 2 (a wrong range given to the store).
    OutsideSettings,
    /// The flash controller reported an error.
    Flash(flash::Error),
}

impl NorFlashError for Error {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::OutsideSettings => NorFlashErrorKind::OutOfBounds,
            Self::Flash(error) => error.kind(),
        }
    }
}

impl From<flash::Error> for Error {
    fn from(error: flash::Error) -> Self {
        Self::Flash(error)
    }
}

/// Sectors 1 and 2 of the flash, for the settings store: feeds the watchdog around each
/// erase and logs how long the erase stalled the CPU.
pub struct SettingsFlash {
    /// Sectors 0–3, of which only 1 and 2 are touched.
    region: Region,
    /// Times the erases.
    stopwatch: Stopwatch,
}

impl SettingsFlash {
    /// Takes the flash controller, and the core's debug and trace units for the cycle counter
    /// that times the erases; `sysclk` is the core's clock.
    pub fn new(flash: Peri<'static, FLASH>, dcb: &mut DCB, dwt: DWT, sysclk: Hertz) -> Self {
        Self {
            region: BlockingAsync::new(
                Flash::new_blocking(flash)
                    .into_blocking_regions()
                    .bank1_region1,
            ),
            stopwatch: Stopwatch::new(dcb, dwt, sysclk),
        }
    }
}

/// Checks that `from..to` lies within the settings' sectors.
fn check(from: u32, to: u32) -> Result<(), Error> {
    if RANGE.start <= from && from <= to && to <= RANGE.end {
        Ok(())
    } else {
        Err(Error::OutsideSettings)
    }
}

/// The end offset of `len` bytes at `offset`, if it fits in a `u32`.
fn end(offset: u32, len: usize) -> Result<u32, Error> {
    u32::try_from(len)
        .ok()
        .and_then(|len| offset.checked_add(len))
        .ok_or(Error::OutsideSettings)
}

impl ErrorType for SettingsFlash {
    type Error = Error;
}

impl ReadNorFlash for SettingsFlash {
    const READ_SIZE: usize = <Region as ReadNorFlash>::READ_SIZE;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        check(offset, end(offset, bytes.len())?)?;
        Ok(self.region.read(offset, bytes).await?)
    }

    fn capacity(&self) -> usize {
        // Offsets count from the start of flash, so the valid ones end at the range's end.
        RANGE.end as usize
    }
}

impl NorFlash for SettingsFlash {
    const WRITE_SIZE: usize = <Region as NorFlash>::WRITE_SIZE;
    const ERASE_SIZE: usize = <Region as NorFlash>::ERASE_SIZE;

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        check(offset, end(offset, bytes.len())?)?;
        Ok(self.region.write(offset, bytes).await?)
    }

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Error> {
        check(from, to)?;
        // One sector at a time, so that each gets its own feed and its own measurement; the
        // region refuses a range that is not whole sectors.
        let mut sector = from;
        while sector < to {
            let next = sector.saturating_add(SECTOR_SIZE).min(to);
            watchdog::feed_now();
            let start = Stopwatch::start();
            let result = self.region.erase(sector, next).await;
            let stalled_ms = self.stopwatch.elapsed_ms(start);
            watchdog::feed_now();
            info!(
                "settings: sector erase stalled the CPU for {=u32} ms (sector {=u32})",
                stalled_ms,
                sector / SECTOR_SIZE
            );
            result?;
            sector = next;
        }
        Ok(())
    }
}

/// The core's cycle counter, the one clock that keeps counting through an erase.
struct Stopwatch {
    /// Owned so that nothing else reprograms the counter.
    _dwt: DWT,
    /// Counter increments per millisecond.
    cycles_per_ms: u32,
}

impl Stopwatch {
    /// Starts the cycle counter.
    fn new(dcb: &mut DCB, mut dwt: DWT, sysclk: Hertz) -> Self {
        // The DWT needs the trace enable, and the STM32F7 also locks it after a power cycle.
        dcb.enable_trace();
        DWT::unlock();
        dwt.enable_cycle_counter();
        Self {
            _dwt: dwt,
            cycles_per_ms: (sysclk.0 / 1000).max(1),
        }
    }

    /// The counter now, to pass to [`Self::elapsed_ms`].
    fn start() -> u32 {
        DWT::cycle_count()
    }

    /// Milliseconds since `start`; right for up to 2^32 cycles (19.9 s at 216 MHz).
    fn elapsed_ms(&self, start: u32) -> u32 {
        DWT::cycle_count().wrapping_sub(start) / self.cycles_per_ms
    }
}
