//! The embassy-time driver: two CMSDK APB timers at the 25 MHz system clock.
//!
//! - **Timer 0** (0x4000_0000) runs free, counting down from `u32::MAX` and wrapping every
//!   171.8 s. [`now`](embassy_time_driver::Driver::now) extends it to 64 bits in software:
//!   each reading that is below the previous one means a wrap. That needs a reading at least
//!   once per wrap, which the alarm guarantees by never sleeping longer than [`MAX_SLEEP`].
//!   It uses no interrupt, so there is no race between a wrap and its interrupt.
//! - **Timer 1** (0x4000_1000, IRQ 9) is the alarm: armed as a one-shot count-down to the
//!   next timer of the queue (or to [`MAX_SLEEP`]), its interrupt wakes the expired timers
//!   and arms the next one.
//!
//! embassy-time counts in ticks of [`TICK_HZ`] (1 MHz, its default); one tick is
//! [`COUNTS_PER_TICK`] counts of the 25 MHz timer. Both timers start on first use, so no
//! initialisation call has to come before the first `Instant::now()`.

use core::cell::{Cell, RefCell};
use core::task::Waker;

use critical_section::{CriticalSection, Mutex};
use embassy_time_driver::{Driver, TICK_HZ};
use embassy_time_queue_utils::Queue;

use super::interrupts::{self, Interrupt};
use super::mmio::Registers;

/// The timers' clock: QEMU's mps2 machines run their APB peripherals at 25 MHz (SYSCLK).
pub const TIMER_HZ: u64 = 25_000_000;

/// Timer counts per embassy-time tick.
pub const COUNTS_PER_TICK: u64 = TIMER_HZ / TICK_HZ;

// A tick must be a whole number of counts, or `now` would drift.
const _: () = assert!(COUNTS_PER_TICK > 0 && TIMER_HZ.is_multiple_of(TICK_HZ));

/// Longest count-down of the alarm: 2^30 counts, 43 s, well inside timer 0's 171.8 s wrap.
pub const MAX_SLEEP: u32 = 1 << 30;

// CMSDK APB timer registers (ARM DDI 0479C, 4.4).
/// Control: enable, external input select, external clock, interrupt enable.
const CTRL: usize = 0x00;
/// Current value, counting down.
const VALUE: usize = 0x04;
/// Reload value; writing it also sets the current value.
const RELOAD: usize = 0x08;
/// Interrupt status; write 1 to clear.
const INTSTATUS: usize = 0x0C;
/// CTRL: the timer runs.
const CTRL_ENABLE: u32 = 1 << 0;
/// CTRL: the timer raises its interrupt when it reaches zero.
const CTRL_IRQ_ENABLE: u32 = 1 << 3;
/// Size of a timer's register block.
const BLOCK: usize = 0x1000;

/// Timer 0: the free-running counter.
// SAFETY: 0x4000_0000 is CMSDK timer 0 of mps2-an386, used by this driver only.
const COUNTER: Registers = unsafe { Registers::new(0x4000_0000, BLOCK) };
/// Timer 1: the alarm.
// SAFETY: 0x4000_1000 is CMSDK timer 1 of mps2-an386, used by this driver only.
const ALARM: Registers = unsafe { Registers::new(0x4000_1000, BLOCK) };

/// The driver's state, all behind critical sections.
struct Mps2Time {
    /// Whether the timers were started.
    started: Mutex<Cell<bool>>,
    /// Counts elapsed at the last reading of timer 0, as (wraps, counts in this wrap).
    last: Mutex<Cell<(u32, u32)>>,
    /// The timers waiting for their time.
    queue: Mutex<RefCell<Queue>>,
}

embassy_time_driver::time_driver_impl!(static DRIVER: Mps2Time = Mps2Time {
    started: Mutex::new(Cell::new(false)),
    last: Mutex::new(Cell::new((0, 0))),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

impl Mps2Time {
    /// Starts both timers the first time it is called.
    fn start(&self, cs: CriticalSection<'_>) {
        if self.started.borrow(cs).replace(true) {
            return;
        }
        // Writing RELOAD also loads the counter; a reload of u32::MAX makes the wrap period
        // exactly 2^32 counts.
        COUNTER.write(CTRL, 0);
        COUNTER.write(RELOAD, u32::MAX);
        COUNTER.write(CTRL, CTRL_ENABLE);
        // The alarm always runs, if only to read the counter before it wraps twice.
        arm(MAX_SLEEP);
        interrupts::unmask(Interrupt::Timer1);
    }

    /// Timer counts since the start, extended to 64 bits.
    fn counts(&self, cs: CriticalSection<'_>) -> u64 {
        self.start(cs);
        let elapsed = u32::MAX - COUNTER.read(VALUE);
        let last = self.last.borrow(cs);
        let (mut wraps, previous) = last.get();
        if elapsed < previous {
            wraps = wraps.wrapping_add(1);
        }
        last.set((wraps, elapsed));
        (u64::from(wraps) << 32) | u64::from(elapsed)
    }

    /// Arms the alarm for tick `at`, or for [`MAX_SLEEP`] if that is sooner. Returns `false`
    /// without arming if `at` has already come, so that the caller runs the queue again.
    fn set_alarm(&self, cs: CriticalSection<'_>, at: u64) -> bool {
        let now = self.counts(cs);
        let target = at.saturating_mul(COUNTS_PER_TICK);
        if target <= now {
            return false;
        }
        // Bounded by MAX_SLEEP, so the conversion cannot fail.
        arm(u32::try_from((target - now).min(u64::from(MAX_SLEEP))).unwrap_or(MAX_SLEEP));
        true
    }

    /// Wakes every expired timer and arms the alarm for the next one.
    fn run_queue(&self, cs: CriticalSection<'_>) {
        let mut queue = self.queue.borrow(cs).borrow_mut();
        loop {
            let now = self.counts(cs) / COUNTS_PER_TICK;
            let next = queue.next_expiration(now);
            if self.set_alarm(cs, next) {
                return;
            }
        }
    }

    /// The alarm went off (timer 1's interrupt).
    fn on_alarm(&self) {
        ALARM.write(CTRL, 0);
        ALARM.write(INTSTATUS, 1);
        critical_section::with(|cs| self.run_queue(cs));
    }
}

impl Driver for Mps2Time {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.counts(cs) / COUNTS_PER_TICK)
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            let changed = self.queue.borrow(cs).borrow_mut().schedule_wake(at, waker);
            if changed {
                self.run_queue(cs);
            }
        });
    }
}

/// Starts the alarm's count-down of `counts` (at least one: a reload of 0 never interrupts).
fn arm(counts: u32) {
    ALARM.write(CTRL, 0);
    ALARM.write(INTSTATUS, 1);
    ALARM.write(RELOAD, counts.max(1));
    ALARM.write(CTRL, CTRL_ENABLE | CTRL_IRQ_ENABLE);
}

/// Timer 1's interrupt handler.
// SAFETY: the name is the one the vector table (interrupts.rs) and device.x expect; nothing
// else defines it.
#[unsafe(no_mangle)]
#[allow(non_snake_case)]
extern "C" fn TIMER1() {
    DRIVER.on_alarm();
}
