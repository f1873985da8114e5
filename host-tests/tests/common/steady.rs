//! A waker that stays itself when cloned, for futures built on embassy's primitives.
//!
//! embassy-sync and embassy-time keep one waker per waiter and, when polled with a waker
//! that `will_wake` says is another, wake the one they kept. tokio's wakers fail that test
//! against their own clones, so on tokio every such poll wakes the task again: the future
//! is polled without end (about 200 000 times a second for the whole panel) and a wake the
//! code forgot would go unnoticed. [`steady`] polls a future with one waker, made once,
//! whose clones compare equal to it, and which passes each wake on to tokio's.

use std::future::Future;
use std::pin::pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, RawWaker, RawWakerVTable, Waker};

/// The task's waker of the last poll, which every wake of the steady waker is passed to.
#[derive(Default)]
struct Relay(Mutex<Option<Waker>>);

impl Relay {
    fn wake(&self) {
        if let Some(waker) = self.0.lock().unwrap().as_ref() {
            waker.wake_by_ref();
        }
    }
}

/// One table for every steady waker: `will_wake` compares its address.
static VTABLE: RawWakerVTable = RawWakerVTable::new(clone, wake, wake_by_ref, drop);

unsafe fn clone(relay: *const ()) -> RawWaker {
    // SAFETY: `relay` came from `Arc::into_raw` and the waker being cloned holds a count.
    unsafe { Arc::increment_strong_count(relay.cast::<Relay>()) };
    RawWaker::new(relay, &VTABLE)
}

unsafe fn wake(relay: *const ()) {
    // SAFETY: the waker being consumed owns one count, taken back here.
    let relay = unsafe { Arc::from_raw(relay.cast::<Relay>()) };
    relay.wake();
}

unsafe fn wake_by_ref(relay: *const ()) {
    // SAFETY: the waker this is called through holds a count.
    unsafe { &*relay.cast::<Relay>() }.wake();
}

unsafe fn drop(relay: *const ()) {
    // SAFETY: the waker being dropped owns one count, given back here.
    std::mem::drop(unsafe { Arc::from_raw(relay.cast::<Relay>()) });
}

/// Runs `future` to completion with a steady waker (see the module's doc).
pub async fn steady<F: Future>(future: F) -> F::Output {
    let relay = Arc::new(Relay::default());
    // SAFETY: the table's functions keep the count `Arc::into_raw` hands over.
    let waker =
        unsafe { Waker::from_raw(RawWaker::new(Arc::into_raw(relay.clone()).cast(), &VTABLE)) };
    let mut future = pin!(future);
    std::future::poll_fn(|cx| {
        *relay.0.lock().unwrap() = Some(cx.waker().clone());
        future.as_mut().poll(&mut Context::from_waker(&waker))
    })
    .await
}
