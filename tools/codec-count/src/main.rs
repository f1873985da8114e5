//! Counts the Cortex-M instructions the protocol codec takes for what the panel does most:
//! read a status answer, and write a navigation task, a zero velocity and a soft emergency
//! stop. Built with feature `robot-side`, it counts the benchmark's other two operations
//! instead, the robot's side: read the navigation task, write the status answer. Each build
//! links only what it counts, as the firmware links only the panel's side, because a
//! function with more callers may be compiled differently.
//!
//! Runs in QEMU's mps2-an386 machine (a Cortex-M4, the firmware's instruction set) under
//! `-icount shift=0`, where the virtual clock advances one nanosecond an instruction, so the
//! 25 MHz CMSDK timer 0 counts one tick every 40 instructions. Each operation runs [`RUNS`]
//! times between two readings; the cost of an empty run is taken off. The result
//! goes to the host's standard output through semihosting, one line an operation, after a
//! calibration line: a hundred `nop`s, which must count 100, or the program fails.
//!
//! These are instructions, not cycles: a Cortex-M7 such as the Nucleo's issues up to two
//! a cycle and waits on its flash, so its time is not simply the count over the clock.
//!
//! The documents are the codec benchmark's, so that the counts and the host's figures
//! describe the same work.
#![no_std]
#![no_main]

use core::hint::black_box;
use core::ptr;

use cortex_m as _;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
#[cfg(not(feature = "robot-side"))]
use x30_panel::proto::message::MotionCommand;
use x30_panel::proto::message::{Request, Response};
use x30_panel::proto::time::Timestamp;

/// A 1002 answer as a real robot sends it (the benchmark's).
const STATUS_1002: &[u8] = include_bytes!("../../../host-tests/data/status-1002.xml");
/// A 1003 request with all its items (the benchmark's).
const NAV_1003: &[u8] = include_bytes!("../../../host-tests/data/nav-1003.xml");

/// Runs of each operation between the two timer readings.
const RUNS: u32 = 1000;

/// CMSDK APB timer 0's control register (bit 0 starts it).
const TIMER0_CTRL: *mut u32 = 0x4000_0000 as *mut u32;
/// Timer 0's current value, counting down.
const TIMER0_VALUE: *const u32 = 0x4000_0004 as *const u32;
/// Timer 0's reload value; writing it also sets the current value.
const TIMER0_RELOAD: *mut u32 = 0x4000_0008 as *mut u32;

/// Instructions a tick of the 25 MHz timer stands for, at one nanosecond an instruction.
const INSTRUCTIONS_PER_TICK: u64 = 40;

/// Starts timer 0 running free from `u32::MAX` (171 s of virtual time, far more than the
/// whole program takes).
fn start_timer() {
    // SAFETY: the timer's registers, on a machine with no other user of timer 0.
    unsafe {
        ptr::write_volatile(TIMER0_RELOAD, u32::MAX);
        ptr::write_volatile(TIMER0_CTRL, 1);
    }
}

/// Timer 0's current value.
fn ticks() -> u32 {
    // SAFETY: a read of the running timer's value register.
    unsafe { ptr::read_volatile(TIMER0_VALUE) }
}

/// Instructions `RUNS` runs of `op` take, over `RUNS`, after one run to warm up.
fn instructions(mut op: impl FnMut()) -> u64 {
    op();
    let start = ticks();
    for _ in 0..RUNS {
        op();
    }
    // The timer counts down.
    u64::from(start.wrapping_sub(ticks())) * INSTRUCTIONS_PER_TICK / u64::from(RUNS)
}

/// What a run of an empty operation takes (the loop's own instructions), so that it can be
/// taken off each count.
struct Baseline(u64);

impl Baseline {
    /// Measures the empty run.
    fn measure() -> Self {
        Self(instructions(|| black_box(())))
    }

    /// Instructions a run of `op` takes, the loop's own taken off.
    fn count(&self, op: impl FnMut()) -> u64 {
        instructions(op).saturating_sub(self.0)
    }
}

#[entry]
fn main() -> ! {
    start_timer();
    let build = if cfg!(feature = "compact") {
        "compact"
    } else {
        "default"
    };
    let report = |name: &str, count: u64| hprintln!("{build:8} {name:24} {count:6}");
    let baseline = Baseline::measure();
    let calibration = baseline.count(|| {
        // SAFETY: instructions that do nothing.
        unsafe { core::arch::asm!(".rept 100", "nop", ".endr", options(nomem, nostack)) }
    });
    report("calibration: 100 nop", calibration);
    if calibration != 100 {
        fail("QEMU does not count one nanosecond an instruction: run it with -icount shift=0");
    }
    count(&baseline, report);
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Counts and reports the panel's operations.
#[cfg(not(feature = "robot-side"))]
fn count(baseline: &Baseline, report: impl Fn(&str, u64)) {
    let Ok(nav) = Request::decode(NAV_1003) else {
        fail("the 1003 request does not decode")
    };
    let time = Timestamp::ZERO;
    let mut out = [0; 2048];
    let mut encode = |request: Request| {
        baseline.count(|| {
            black_box(black_box(&request).encode(&time, &mut out).ok());
        })
    };
    let nav_count = encode(nav.message);
    let stop_count = encode(Request::Motion(MotionCommand::ZeroVelocity));
    let estop_count = encode(Request::Motion(MotionCommand::SoftEmergencyStop));
    let decode_count = baseline.count(|| {
        black_box(Response::decode(black_box(STATUS_1002)).ok());
    });
    report("decode 1002 answer", decode_count);
    report("encode 1003 request", nav_count);
    report("encode zero velocity", stop_count);
    report("encode soft e-stop", estop_count);
}

/// Counts and reports the robot's side of the benchmark's operations.
#[cfg(feature = "robot-side")]
fn count(baseline: &Baseline, report: impl Fn(&str, u64)) {
    let Ok(status) = Response::decode(STATUS_1002) else {
        fail("the 1002 answer does not decode")
    };
    let time = Timestamp::ZERO;
    let mut out = [0; 2048];
    let decode_count = baseline.count(|| {
        black_box(Request::decode(black_box(NAV_1003)).ok());
    });
    let encode_count = baseline.count(|| {
        black_box(black_box(&status.message).encode(&time, &mut out).ok());
    });
    report("robot: decode 1003", decode_count);
    report("robot: encode 1002", encode_count);
}

/// Reports `why` and ends QEMU with a failure status.
fn fail(why: &str) -> ! {
    hprintln!("codec-count: {why}");
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    fail("panicked")
}
