//! A bare Cortex-M binary that runs the protocol codec, so that its size minus the size of
//! the same binary without the codec is what the codec costs in flash. Both link the
//! memory routines (`memcpy`, `memset`, `memcmp`) every firmware has.
//!
//! Feature `codec` links what the panel needs: framing, encoding every request and
//! decoding every response. Feature `robot-side` adds the other direction (decoding every
//! request, encoding every response), as the simulator uses it. Inputs come from places
//! the optimiser cannot see through, so no variant is folded away.
#![no_std]
#![no_main]

use core::hint::black_box;

#[cfg(feature = "codec")]
fn exercise(input: &[u8], out: &mut [u8]) -> usize {
    use x30_panel::proto::frame::{self, FrameDecoder, Reserved};
    use x30_panel::proto::message::{Request, Response};
    use x30_panel::proto::time::Timestamp;

    let mut total = 0;
    // As the panel reads answers.
    let mut decoder = FrameDecoder::<1024>::new().reserved(Reserved::Ignore);
    decoder.feed(input);
    while let Some(Ok(f)) = decoder.decode() {
        if let Ok(response) = Response::decode(f.asdu) {
            total += usize::from(response.time.second);
            black_box(response.message);
        }
        #[cfg(feature = "robot-side")]
        if let Ok(request) = Request::decode(f.asdu) {
            black_box(request.message);
        }
    }
    let request: Request = black_box(Request::Status);
    total += frame::encode_with(out, black_box(7), |body| {
        request
            .encode(&Timestamp::ZERO, body)
            .map_err(|_| frame::EncodeError::BufferTooSmall)
    })
    .unwrap_or(0);
    #[cfg(feature = "robot-side")]
    {
        let response: Response = black_box(Response::Perception(
            x30_panel::proto::message::Perception {
                obs_state: x30_panel::proto::codes::ObsState::Clear,
            },
        ));
        total += response.encode(&Timestamp::ZERO, out).unwrap_or(0);
    }
    total
}

/// The baseline: copies, fills and compares buffers of unknown length, as every firmware
/// does, so that the routines behind them (`memcpy`, `memset`, `memcmp`, which the
/// firmware links anyway) are not counted as the codec's.
#[cfg(not(feature = "codec"))]
fn exercise(input: &[u8], out: &mut [u8]) -> usize {
    let n = input.len().min(out.len());
    if let (Some(to), Some(from)) = (out.get_mut(..n), input.get(..n)) {
        to.copy_from_slice(from);
    }
    if let Some(rest) = out.get_mut(n..) {
        rest.fill(0);
    }
    usize::from(input == black_box(&out[..]))
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
    // Never reached on a real run; the same in the baseline, so it costs the codec nothing.
    loop {
        core::hint::spin_loop();
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
