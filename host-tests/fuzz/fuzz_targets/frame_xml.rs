//! libFuzzer target: the frame decoder and both message decoders, end to end, as the panel
//! and the simulator run them on a TCP byte stream.
//!
//! Input layout:
//!
//! - byte 0, the mode: bits 0–2 give `k`, how many read-size bytes follow (0: the whole
//!   stream in one read); bit 3 set means reads go through `spare()` + `commit()` instead of
//!   `feed()`; bit 4 set means the decoder ignores reserved header bytes, as a client's
//!   does, instead of refusing them, as the robot's does.
//! - `k` bytes, each a read size of `byte + 1` bytes, used in turn.
//! - the rest: the byte stream, fed to a `FrameDecoder<2048>`.
//!
//! Every frame's body is decoded as a `Request` and as a `Response`. Invariants (a panic is
//! a finding):
//!
//! - the decoder takes at least one byte per read while it has nothing to hand out (it never
//!   stalls), hands out at most one event per byte (it never loops), and never hands out a
//!   frame longer than `2048 - 16` bytes;
//! - every message a decoder accepts encodes again (into a buffer large enough for any
//!   message), the encoding decodes to an equal message with an equal `Time` (a NaN equal
//!   to itself), and encoding that gives the same bytes.
//!
//! Build and run with `scripts/fuzz.sh`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use x30_panel::proto::frame::{FrameDecoder, HEADER_LEN, Reserved};
use x30_panel::proto::message::{DecodeError, Decoded, Request, Response};
use x30_panel::proto::time::Timestamp;
use x30_panel::proto::xml::writer::WriteError;

/// Decoder buffer: smaller than a large 1003 request, so oversized frames are exercised too.
const N: usize = 2048;
/// Re-encoding buffer: larger than any message the codec can write.
const ENCODE_BUF: usize = 16 * 1024;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let k = usize::from(mode & 0b111);
    let use_spare = mode & 0b1000 != 0;
    let reserved = if mode & 0b1_0000 != 0 {
        Reserved::Ignore
    } else {
        Reserved::Refuse
    };
    let (sizes, stream) = rest.split_at(k.min(rest.len()));
    run(sizes, use_spare, reserved, stream);
});

fn run(sizes: &[u8], use_spare: bool, reserved: Reserved, stream: &[u8]) {
    let mut decoder = FrameDecoder::<N>::new().reserved(reserved);
    let mut reads = sizes.iter().map(|&s| usize::from(s) + 1).cycle();
    let mut rest = stream;
    let mut budget = stream.len() + 1;
    while !rest.is_empty() {
        let size = reads.next().unwrap_or(rest.len()).min(rest.len());
        let (mut read, tail) = rest.split_at(size);
        rest = tail;
        while !read.is_empty() {
            let taken = if use_spare {
                let spare = decoder.spare();
                let n = spare.len().min(read.len());
                spare[..n].copy_from_slice(&read[..n]);
                decoder.commit(n);
                n
            } else {
                decoder.feed(read)
            };
            assert!(
                taken > 0,
                "decoder stalled with {} bytes to go",
                read.len() + rest.len()
            );
            read = &read[taken..];
            while let Some(result) = decoder.decode() {
                assert!(
                    budget > 0,
                    "decoder hands out more events than bytes received"
                );
                budget -= 1;
                if let Ok(frame) = result {
                    assert!(
                        frame.asdu.len() <= N - HEADER_LEN,
                        "frame of {} bytes",
                        frame.asdu.len()
                    );
                    check_body::<Request>(frame.asdu);
                    check_body::<Response>(frame.asdu);
                }
            }
        }
    }
}

/// The two message directions, behind one interface.
trait Codec: Sized + PartialEq + core::fmt::Debug {
    fn decode(body: &[u8]) -> Result<Decoded<Self>, DecodeError>;
    fn encode(&self, time: &Timestamp, out: &mut [u8]) -> Result<usize, WriteError>;
}

impl Codec for Request {
    fn decode(body: &[u8]) -> Result<Decoded<Self>, DecodeError> {
        Request::decode(body)
    }
    fn encode(&self, time: &Timestamp, out: &mut [u8]) -> Result<usize, WriteError> {
        Request::encode(self, time, out)
    }
}

impl Codec for Response {
    fn decode(body: &[u8]) -> Result<Decoded<Self>, DecodeError> {
        Response::decode(body)
    }
    fn encode(&self, time: &Timestamp, out: &mut [u8]) -> Result<usize, WriteError> {
        Response::encode(self, time, out)
    }
}

fn check_body<T: Codec>(body: &[u8]) {
    let Ok(decoded) = T::decode(body) else {
        return;
    };
    let shown = || String::from_utf8_lossy(body).into_owned();
    let mut first = [0u8; ENCODE_BUF];
    let n = match decoded.message.encode(&decoded.time, &mut first) {
        Ok(n) => n,
        Err(e) => panic!(
            "{:?} decoded from {:?} does not encode: {e:?}",
            decoded,
            shown()
        ),
    };
    let first = &first[..n];
    let again = T::decode(first);
    // Debug text, so that a NaN an answer reports equals itself; the message and `Time`
    // only, since items that could not be read are written as left out.
    let read = |d: &Decoded<T>| format!("{:?}", (&d.time, &d.message));
    assert!(
        again.as_ref().map(read).ok() == Some(read(&decoded)),
        "decoded {:?} from {:?}, re-encoded as {:?}, which decodes as {:?}",
        decoded,
        shown(),
        String::from_utf8_lossy(first),
        again
    );
    let mut second = [0u8; ENCODE_BUF];
    let m = decoded
        .message
        .encode(&decoded.time, &mut second)
        .expect("encoded once already");
    assert_eq!(first, &second[..m], "encoding is not deterministic");
}
