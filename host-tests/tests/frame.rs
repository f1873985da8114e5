//! The 16-byte header and the streaming frame decoder: split at every byte offset, merged
//! frames, garbage between frames, oversize, frames cut short, zero length, bad reserved
//! bytes.

use x30_panel::proto::frame::*;

fn frame(id: u16, body: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; HEADER_LEN + body.len()];
    let n = encode(&mut out, id, body).unwrap();
    assert_eq!(n, out.len());
    out
}

/// What the decoder reports for frame `message_id`, declared `asdu_len` bytes long, cut short
/// after `received` bytes of its body.
fn cut_short(message_id: u16, asdu_len: u16, received: u16) -> Result<(u16, Vec<u8>), FrameError> {
    Err(FrameError::CutShort {
        message_id,
        asdu_len,
        received,
    })
}

/// Feeds `bytes` in chunks of `chunk` and collects everything the decoder reports.
fn run<const N: usize>(
    decoder: &mut FrameDecoder<N>,
    bytes: &[u8],
    chunk: usize,
) -> Vec<Result<(u16, Vec<u8>), FrameError>> {
    let mut out = Vec::new();
    for piece in bytes.chunks(chunk.max(1)) {
        let mut rest = piece;
        while !rest.is_empty() {
            let n = decoder.feed(rest);
            rest = &rest[n..];
            while let Some(item) = decoder.decode() {
                out.push(item.map(|f| (f.message_id, f.asdu.to_vec())));
            }
        }
    }
    out
}

#[test]
fn header_layout() {
    let h = Header {
        asdu_len: 0x1234,
        message_id: 0xBEEF,
    };
    let bytes = h.encode();
    assert_eq!(
        bytes,
        [
            0xEB, 0x90, 0xEB, 0x90, 0x34, 0x12, 0xEF, 0xBE, 0, 0, 0, 0, 0, 0, 0, 0
        ]
    );
    assert_eq!(Header::decode(&bytes), Ok(h));
    let mut bad = bytes;
    bad[1] = 0x91;
    assert_eq!(Header::decode(&bad), Err(HeaderError::BadSync));
    let mut bad = bytes;
    bad[15] = 1;
    assert_eq!(Header::decode(&bad), Err(HeaderError::BadReserved));
}

#[test]
fn message_ids_count_from_zero_and_wrap() {
    let mut ids = MessageIds::new();
    assert_eq!(ids.next_id(), 0);
    assert_eq!(ids.next_id(), 1);
    for _ in 2..65535 {
        ids.next_id();
    }
    assert_eq!(ids.next_id(), 65535);
    assert_eq!(ids.next_id(), 0);
}

#[test]
fn encode_refuses_small_buffers_and_long_bodies() {
    let mut small = [0u8; 20];
    assert_eq!(
        encode(&mut small, 1, b"12345"),
        Err(EncodeError::BufferTooSmall)
    );
    assert_eq!(
        encode(&mut small[..10], 1, b""),
        Err(EncodeError::BufferTooSmall)
    );
    let body = vec![b'x'; 65536];
    let mut big = vec![0u8; 70000];
    assert_eq!(encode(&mut big, 1, &body), Err(EncodeError::AsduTooLong));
    assert_eq!(encode(&mut big, 1, &body[..65535]), Ok(65535 + 16));
}

#[test]
fn split_at_every_byte_offset() {
    let bytes = [frame(7, b"<a>first</a>"), frame(8, b"<b>second</b>")].concat();
    for split in 0..=bytes.len() {
        let mut d = FrameDecoder::<256>::new();
        let mut got = run(&mut d, &bytes[..split], 1000);
        got.extend(run(&mut d, &bytes[split..], 1000));
        assert_eq!(
            got,
            vec![
                Ok((7, b"<a>first</a>".to_vec())),
                Ok((8, b"<b>second</b>".to_vec()))
            ],
            "split at {split}"
        );
    }
}

#[test]
fn one_byte_at_a_time_and_merged() {
    let bytes = [frame(1, b"one"), frame(2, b"two"), frame(3, b"three")].concat();
    for chunk in [1, 2, 3, 5, 16, 17, bytes.len()] {
        let mut d = FrameDecoder::<64>::new();
        let got = run(&mut d, &bytes, chunk);
        assert_eq!(got.len(), 3, "chunk {chunk}");
        assert_eq!(got[2], Ok((3, b"three".to_vec())));
    }
}

#[test]
fn zero_length_frame() {
    let bytes = [frame(5, b""), frame(6, b"x")].concat();
    let mut d = FrameDecoder::<64>::new();
    assert_eq!(
        run(&mut d, &bytes, 3),
        vec![Ok((5, vec![])), Ok((6, b"x".to_vec()))]
    );
}

#[test]
fn garbage_between_frames_is_reported_and_skipped() {
    let bytes = [
        b"junk".to_vec(),
        frame(1, b"a"),
        vec![0xEB, 0x90, 0x00, 0xEB],
        frame(2, b"b"),
        b"tail".to_vec(),
    ]
    .concat();
    for chunk in [1, 4, 7, 100] {
        let mut d = FrameDecoder::<64>::new();
        let got = run(&mut d, &bytes, chunk);
        assert_eq!(
            got,
            vec![
                Err(FrameError::Garbage { skipped: 4 }),
                Ok((1, b"a".to_vec())),
                Err(FrameError::Garbage { skipped: 4 }),
                Ok((2, b"b".to_vec())),
            ],
            "chunk {chunk}"
        );
    }
}

/// A sync sequence whose first bytes repeat must not hide the real one (EB 90 EB 90 EB 90 ...).
#[test]
fn overlapping_sync_prefix() {
    let bytes = [vec![0xEB, 0x90], frame(9, b"z")].concat();
    let mut d = FrameDecoder::<64>::new();
    assert_eq!(
        run(&mut d, &bytes, 1),
        vec![
            Err(FrameError::Garbage { skipped: 2 }),
            Ok((9, b"z".to_vec()))
        ]
    );
}

#[test]
fn oversize_frame_is_skipped_without_losing_the_next() {
    let big = vec![b'B'; 300];
    let bytes = [
        frame(1, &big),
        frame(2, b"next"),
        frame(3, &[b'C'; 48]),
        frame(4, b"after"),
    ]
    .concat();
    for chunk in [1, 13, 64, 1000] {
        let mut d = FrameDecoder::<64>::new();
        let got = run(&mut d, &bytes, chunk);
        assert_eq!(
            got,
            vec![
                Err(FrameError::TooLong {
                    message_id: 1,
                    asdu_len: 300
                }),
                Ok((2, b"next".to_vec())),
                Ok((3, vec![b'C'; 48])),
                Ok((4, b"after".to_vec())),
            ],
            "chunk {chunk}"
        );
    }
    assert_eq!(FrameDecoder::<64>::MAX_ASDU, 48);
}

/// A robot that wrote only part of a frame, then the next: the sync sequence inside the
/// declared body shows where the broken frame ends, so the next one is not swallowed as its
/// body, however the bytes are split into reads.
#[test]
fn frame_cut_short_does_not_swallow_the_next() {
    let mut cut = frame(1, &[b'A'; 40]);
    cut.truncate(HEADER_LEN + 10);
    let bytes = [cut, frame(2, b"next"), frame(3, b"after")].concat();
    for chunk in [1, 3, 7, 64, 1000] {
        let mut d = FrameDecoder::<64>::new();
        assert_eq!(
            run(&mut d, &bytes, chunk),
            vec![
                cut_short(1, 40, 10),
                Ok((2, b"next".to_vec())),
                Ok((3, b"after".to_vec())),
            ],
            "chunk {chunk}"
        );
    }
}

/// The same for a frame too long for the buffer: it is reported as too long at once, and as
/// cut short when the next frame's sync sequence turns up inside its declared body.
#[test]
fn oversize_frame_cut_short_does_not_swallow_the_next() {
    let mut cut = frame(1, &[b'B'; 300]);
    cut.truncate(HEADER_LEN + 100);
    let bytes = [cut, frame(2, b"next")].concat();
    for chunk in [1, 2, 13, 64, 1000] {
        let mut d = FrameDecoder::<64>::new();
        assert_eq!(
            run(&mut d, &bytes, chunk),
            vec![
                Err(FrameError::TooLong {
                    message_id: 1,
                    asdu_len: 300
                }),
                cut_short(1, 300, 100),
                Ok((2, b"next".to_vec())),
            ],
            "chunk {chunk}"
        );
    }
}

/// A frame cut short within its last three declared bytes: the next frame's sync sequence
/// does not fit in the body, but its first bytes end it, and no UTF-8 text ends so.
#[test]
fn frame_cut_short_near_its_end_does_not_swallow_the_next() {
    for missing in 1..=3 {
        let mut cut = frame(1, &[b'A'; 20]);
        cut.truncate(cut.len() - missing);
        let bytes = [cut, frame(2, b"next")].concat();
        for chunk in [1, 2, 5, 1000] {
            let mut d = FrameDecoder::<64>::new();
            assert_eq!(
                run(&mut d, &bytes, chunk),
                vec![
                    cut_short(1, 20, 20 - missing as u16),
                    Ok((2, b"next".to_vec())),
                ],
                "{missing} missing, chunk {chunk}"
            );
        }
        let mut cut = frame(3, &[b'B'; 100]);
        cut.truncate(cut.len() - missing);
        let bytes = [cut, frame(4, b"next")].concat();
        let mut d = FrameDecoder::<64>::new();
        assert_eq!(
            run(&mut d, &bytes, 7),
            vec![
                Err(FrameError::TooLong {
                    message_id: 3,
                    asdu_len: 100
                }),
                cut_short(3, 100, 100 - missing as u16),
                Ok((4, b"next".to_vec())),
            ],
            "oversized, {missing} missing"
        );
    }
}

/// A robot that wrote only the first bytes of a header, then the next frame: the sync
/// sequence inside the header shows where the next frame starts. The broken header's bytes
/// are garbage, for a client's decoder (which reads a header whatever its reserved bytes)
/// and for a frame too long for the buffer alike.
#[test]
fn header_cut_short_does_not_swallow_the_next() {
    for declared in [20, 300] {
        for kept in 5..HEADER_LEN {
            let mut cut = frame(1, &vec![b'A'; declared]);
            cut.truncate(kept);
            let bytes = [cut, frame(2, b"next")].concat();
            for chunk in [1, 3, 1000] {
                let mut d = FrameDecoder::<64>::new().reserved(Reserved::Ignore);
                assert_eq!(
                    run(&mut d, &bytes, chunk),
                    vec![
                        Err(FrameError::Garbage { skipped: kept }),
                        Ok((2, b"next".to_vec()))
                    ],
                    "{declared}-byte body, {kept} header bytes, chunk {chunk}"
                );
            }
        }
    }
}

/// Part of a sync sequence inside a body is a byte like any other (it is no UTF-8, but the
/// decoder does not judge the body): only a whole one cuts the frame short.
#[test]
fn part_of_a_sync_sequence_inside_a_body_is_kept() {
    let body = [b"a\xEB\x90\xEBb".as_slice(), &SYNC[..3], b"\xEB\x90c"].concat();
    let bytes = [frame(1, &body), frame(2, b"next")].concat();
    for chunk in [1, 2, 3, 1000] {
        let mut d = FrameDecoder::<64>::new();
        assert_eq!(
            run(&mut d, &bytes, chunk),
            vec![Ok((1, body.clone())), Ok((2, b"next".to_vec()))],
            "chunk {chunk}"
        );
    }
}

#[test]
fn bad_reserved_bytes_resynchronise() {
    let mut bad = frame(1, b"bad");
    bad[10] = 0x55;
    let bytes = [bad, frame(2, b"good")].concat();
    let mut d = FrameDecoder::<64>::new();
    let got = run(&mut d, &bytes, 5);
    assert_eq!(got[0], Err(FrameError::BadReserved { message_id: 1 }));
    assert!(matches!(got[1], Err(FrameError::Garbage { .. })));
    assert_eq!(got.last(), Some(&Ok((2, b"good".to_vec()))));
    assert_eq!(got.len(), 3);
}

/// A client reads an answer whose reserved bytes are set as if they were zero, at every
/// read size, and keeps doing so after `clear`; pieces of a sync sequence there, even one
/// that ends the header, are no sign of a header cut short.
#[test]
fn ignored_reserved_bytes_do_not_hide_the_frame() {
    let mut set = frame(1, b"answer");
    set[8..HEADER_LEN].copy_from_slice(&[0xFF, 0xEB, 0x90, 0xEB, 0x91, 1, 0xEB, 0x90]);
    let bytes = [set.clone(), frame(2, b"next")].concat();
    for chunk in 1..=bytes.len() {
        let mut d = FrameDecoder::<64>::new().reserved(Reserved::Ignore);
        assert_eq!(
            run(&mut d, &bytes, chunk),
            vec![Ok((1, b"answer".to_vec())), Ok((2, b"next".to_vec()))],
            "chunk {chunk}"
        );
        d.clear();
        assert_eq!(run(&mut d, &set, chunk), vec![Ok((1, b"answer".to_vec()))]);
    }
}

/// Half a sync sequence before a frame whose reserved bytes are set: a client's decoder,
/// which cannot hold the 37099-byte frame `EB 90 EB 90 EB 90` would declare, takes the
/// later header without looking at its reserved bytes.
#[test]
fn overlapping_sync_prefix_before_reserved_bytes_set() {
    let mut set = frame(9, b"z");
    set[HEADER_LEN - 1] = 0x42;
    let bytes = [vec![0xEB, 0x90], set].concat();
    for chunk in 1..=bytes.len() {
        let mut d = FrameDecoder::<64>::new().reserved(Reserved::Ignore);
        assert_eq!(
            run(&mut d, &bytes, chunk),
            vec![
                Err(FrameError::Garbage { skipped: 2 }),
                Ok((9, b"z".to_vec()))
            ],
            "chunk {chunk}"
        );
    }
}

/// A decoder large enough for a 37099-byte frame tells the overlap apart by the later
/// header's reserved bytes, as the robot's does, even while ignoring reserved bytes.
#[test]
fn large_decoder_ignoring_reserved_bytes_still_reads_a_37099_byte_frame() {
    let body: Vec<u8> = (0..0x90EB_u32).map(|i| b'<' + (i % 7) as u8).collect();
    let mut long = frame(3, &body);
    long[8] = 3;
    let bytes = [long, frame(4, b"after")].concat();
    let mut d = Box::new(FrameDecoder::<40000>::new().reserved(Reserved::Ignore));
    let got = run(&mut d, &bytes, 4096);
    assert_eq!(got, vec![Ok((3, body)), Ok((4, b"after".to_vec()))]);
}

#[test]
fn spare_and_commit_read_in_place() {
    let bytes = frame(42, b"in place");
    let mut d = FrameDecoder::<32>::new();
    let spare = d.spare();
    assert_eq!(spare.len(), 32);
    spare[..bytes.len()].copy_from_slice(&bytes);
    d.commit(bytes.len());
    let f = d.decode().unwrap().unwrap();
    assert_eq!((f.message_id, f.asdu), (42, &b"in place"[..]));
    assert_eq!(d.decode(), None);
    // After compaction the whole buffer is free again.
    assert_eq!(d.spare().len(), 32);
}

#[test]
fn clear_forgets_a_partial_frame() {
    let bytes = frame(1, b"abcdef");
    let mut d = FrameDecoder::<64>::new();
    d.feed(&bytes[..10]);
    assert_eq!(d.decode(), None);
    d.clear();
    let got = run(&mut d, &frame(2, b"x"), 64);
    assert_eq!(got, vec![Ok((2, b"x".to_vec()))]);
}
