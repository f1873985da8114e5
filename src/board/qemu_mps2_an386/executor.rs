//! The executor: embassy's raw executor in thread mode, asleep in `WFI` while it has nothing
//! to do.
//!
//! embassy's own thread-mode executor sleeps in `WFE` and is woken by `SEV`. QEMU's Cortex-M
//! (7.2, Debian 12's) runs `WFE` as a no-op, so that executor never sleeps there: it polls
//! without end, and each QEMU running the firmware takes a whole host core. `WFI` does halt
//! the emulated core until an interrupt, as it halts a real one. A wake from a task or an
//! interrupt handler sets [`WORK`]; the executor checks it with interrupts disabled and only
//! then sleeps, so a wake between the check and the `WFI` is not lost: the pending interrupt
//! ends the `WFI` at once, and its handler runs as soon as interrupts are enabled again.

use core::marker::PhantomData;
use core::sync::atomic::{AtomicBool, Ordering};

use embassy_executor::{Spawner, raw};

/// A task was woken since the executor last polled.
static WORK: AtomicBool = AtomicBool::new(false);

/// Called by embassy whenever a task is woken, in a task or an interrupt handler.
#[unsafe(export_name = "__pender")]
fn pender(_context: *mut ()) {
    WORK.store(true, Ordering::Release);
}

/// The thread-mode executor that sleeps in `WFI` (see the module's doc).
pub struct Executor {
    inner: raw::Executor,
    /// Polled from thread mode only: not `Send`.
    not_send: PhantomData<*mut ()>,
}

impl Executor {
    /// An executor with no task yet.
    pub fn new() -> Self {
        Self {
            inner: raw::Executor::new(core::ptr::null_mut()),
            not_send: PhantomData,
        }
    }

    /// Spawns the first tasks with `init`, then runs every task, forever.
    pub fn run(&'static mut self, init: impl FnOnce(Spawner)) -> ! {
        init(self.inner.spawner());
        loop {
            // A wake from here on is for the poll below, or for the next one.
            WORK.store(false, Ordering::Release);
            // SAFETY: only this loop polls the executor, and never from the pender.
            unsafe { self.inner.poll() };
            cortex_m::interrupt::free(|_| {
                if !WORK.load(Ordering::Acquire) {
                    cortex_m::asm::wfi();
                }
            });
        }
    }
}
