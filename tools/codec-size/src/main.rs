//! A bare Cortex-M binary that encodes and decodes every message, so that its size minus
//! the size of the same binary without the codec is what the codec costs in flash.
//!
//! Inputs come from addresses the optimiser cannot see through, so nothing is folded away.
#![no_std]
#![no_main]

use core::hint::black_box;

#[cfg(feature = "codec")]
fn exercise(input: &[u8], out: &mut [u8]) -> usize {
    use x30_panel::proto::frame::{self, FrameDecoder};
    use x30_panel::proto::message::{Request, Response};
    use x30_panel::proto::time::Timestamp;

    let mut total = 0;
    let mut decoder = FrameDecoder::<1024>::new();
    decoder.feed(input);
    while let Some(Ok(f)) = decoder.decode() {
        let asdu = f.asdu;
        if let Ok(request) = Request::decode(asdu) {
            total += request.message.encode(&Timestamp::ZERO, out).unwrap_or(0);
        }
        if let Ok(response) = Response::decode(asdu) {
            let time = response.time.plus_seconds(1);
            total += response.message.encode(&time, out).unwrap_or(0);
        }
    }
    total + frame::encode(out, 1, input).unwrap_or(0)
}

#[cfg(not(feature = "codec"))]
fn exercise(input: &[u8], out: &mut [u8]) -> usize {
    out.first_mut().map(|b| *b = input.len() as u8);
    input.len()
}

/// Entry point: the linker starts here, with `--gc-sections` keeping only what it reaches.
#[unsafe(no_mangle)]
pub extern "C" fn _start() -> ! {
    let mut out = [0u8; 1024];
    // SAFETY: never run; the address only hides the input's contents from the optimiser.
    let input =
        unsafe { core::slice::from_raw_parts(black_box(0x2000_0000 as *const u8), black_box(512)) };
    let n = exercise(input, &mut out);
    black_box((n, out));
    loop {}
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}
