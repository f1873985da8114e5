//! Bytes without a sync sequence (ErrorCode 1) that no frame follows.
//!
//! The protocol core's decoder throws bytes without a sync sequence away as they arrive,
//! but reports them (`FrameError::Garbage`) only when the next sync sequence turns up: until
//! then it cannot know that the run has ended. A client that writes a bare XML document
//! and then waits for the answer would wait for ever. So the simulator takes a run of such
//! bytes as one chunk that has ended either when the next sync sequence arrives or when
//! [`NO_SYNC_QUIET`] passes without a byte arriving, whichever comes first, and answers
//! each chunk once. A trailing piece of a sync sequence (up to three bytes, such as a lone
//! `EB`) may be the start of a frame and is not counted until more bytes show what it is.
//!
//! The decoder does not say how many bytes it has thrown away unreported, so [`Unsynced`]
//! works it out from what it does say: the bytes read, the bytes its events account for
//! (a frame, a reported run, the first byte of a wrong header, an oversized frame, the part
//! of a frame cut short), and the bytes it still holds. Whatever is left was thrown away.

use std::time::{Duration, Instant};

use x30_panel::proto::frame::{FrameError, HEADER_LEN};

/// How long no byte must arrive before bytes without a sync sequence are answered: long
/// enough that one write split up by the network counts once, short enough that a client
/// waiting for its answer gets it well within any sensible timeout.
pub const NO_SYNC_QUIET: Duration = Duration::from_millis(100);

/// A decoder event as the reader hands it on: the frame's message ID and body, or an error.
pub(crate) type Event = Result<(u16, Vec<u8>), FrameError>;

/// One connection's count of bytes thrown away without a sync sequence.
#[derive(Debug)]
pub(crate) struct Unsynced {
    /// Bytes read from the connection.
    received: u64,
    /// Bytes the decoder's events account for.
    accounted: u64,
    /// Of the bytes thrown away since the decoder last reported a run, those answered.
    answered: u64,
    /// When the last byte arrived.
    last_byte: Instant,
    /// Whether the bytes thrown away now are the rest of a frame with a wrong header, which
    /// that frame's ErrorCode 2 covers.
    rest_of_bad_frame: bool,
    /// The longest body the decoder holds: a longer frame was accounted for whole when it
    /// was reported too long, before it was found cut short.
    max_asdu: usize,
}

impl Unsynced {
    /// A count for a connection opened at `now`, read by a decoder that holds bodies of up
    /// to `max_asdu` bytes.
    pub fn new(now: Instant, max_asdu: usize) -> Self {
        Self {
            received: 0,
            accounted: 0,
            answered: 0,
            last_byte: now,
            rest_of_bad_frame: false,
            max_asdu,
        }
    }

    /// Notes `n` bytes read at `now`.
    pub fn on_read(&mut self, n: usize, now: Instant) {
        self.received = self.received.saturating_add(n as u64);
        self.last_byte = now;
    }

    /// Notes that the decoder forgot the `n` bytes it held (it was cleared).
    pub fn on_cleared(&mut self, n: usize) {
        self.accounted = self.accounted.saturating_add(n as u64);
    }

    /// Notes a decoder event and returns what of it still needs an answer: `None` for a run
    /// answered already or the rest of a frame with a wrong header; a run partly answered
    /// comes back shortened to its unanswered bytes.
    pub fn filter(&mut self, event: Event) -> Option<Event> {
        let consumed = match &event {
            Ok((_, body)) => HEADER_LEN + body.len(),
            Err(FrameError::Garbage { skipped }) => *skipped,
            // The decoder looks for the next sync sequence after the header's first byte.
            Err(FrameError::BadReserved { .. }) => 1,
            Err(FrameError::TooLong { asdu_len, .. }) => HEADER_LEN + usize::from(*asdu_len),
            Err(FrameError::CutShort {
                asdu_len, received, ..
            }) if usize::from(*asdu_len) > self.max_asdu => {
                // Its TooLong counted the whole declared body; only `received` bytes came.
                let unused = u64::from(asdu_len - received);
                self.accounted = self.accounted.saturating_sub(unused);
                0
            }
            Err(FrameError::CutShort { received, .. }) => HEADER_LEN + usize::from(*received),
            Err(_) => 0,
        };
        self.accounted = self.accounted.saturating_add(consumed as u64);
        let rest_of_bad_frame = std::mem::replace(
            &mut self.rest_of_bad_frame,
            matches!(event, Err(FrameError::BadReserved { .. })),
        );
        let Err(FrameError::Garbage { skipped }) = event else {
            return Some(event);
        };
        let answered = std::mem::take(&mut self.answered);
        let fresh = (skipped as u64).saturating_sub(answered);
        (fresh > 0 && !rest_of_bad_frame).then(|| {
            Err(FrameError::Garbage {
                skipped: usize::try_from(fresh).unwrap_or(skipped),
            })
        })
    }

    /// How long a reader may wait for bytes before [`Unsynced::take_due`] may have
    /// something, given that the decoder holds `held` bytes; `None` if nothing waits.
    pub fn wait(&self, held: usize, now: Instant) -> Option<Duration> {
        (self.unreported(held) > self.answered)
            .then(|| (self.last_byte + NO_SYNC_QUIET).saturating_duration_since(now))
    }

    /// The number of unanswered bytes of a run without a sync sequence that has ended by
    /// quiet time, given that the decoder holds `held` bytes; they count as answered now.
    pub fn take_due(&mut self, held: usize, now: Instant) -> Option<usize> {
        if now.saturating_duration_since(self.last_byte) < NO_SYNC_QUIET {
            return None;
        }
        let unreported = self.unreported(held);
        let fresh = unreported.checked_sub(self.answered).filter(|&n| n > 0)?;
        self.answered = unreported;
        // The rest of a frame with a wrong header is that frame's error; more bytes after
        // a quiet time are a run of their own.
        if std::mem::take(&mut self.rest_of_bad_frame) {
            return None;
        }
        usize::try_from(fresh).ok()
    }

    /// Bytes thrown away that the decoder has not reported yet (0 while it skips the rest
    /// of an oversized frame, which its event accounted for in advance).
    fn unreported(&self, held: usize) -> u64 {
        self.received
            .saturating_sub(self.accounted)
            .saturating_sub(held as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use x30_panel::proto::frame::FrameDecoder;

    const N: usize = 256;

    /// A decoder and its count, fed as a connection's reader feeds them.
    struct Reader {
        decoder: FrameDecoder<N>,
        unsynced: Unsynced,
        start: Instant,
    }

    impl Reader {
        fn new() -> Self {
            let start = Instant::now();
            Self {
                decoder: FrameDecoder::new(),
                unsynced: Unsynced::new(start, FrameDecoder::<N>::MAX_ASDU),
                start,
            }
        }

        /// Feeds `bytes` at `at` ms, as many reads as it takes; returns the events that
        /// need an answer.
        fn feed(&mut self, mut bytes: &[u8], at: u64) -> Vec<Event> {
            let mut out = Vec::new();
            for _ in 0..100 {
                let n = self.decoder.feed(bytes);
                self.unsynced.on_read(n, self.at(at));
                bytes = &bytes[n..];
                while let Some(event) = self.decoder.decode() {
                    let event = event.map(|f| (f.message_id, f.asdu.to_vec()));
                    out.extend(self.unsynced.filter(event));
                }
                if bytes.is_empty() {
                    return out;
                }
            }
            panic!("the decoder stopped taking bytes");
        }

        fn due(&mut self, at: u64) -> Option<usize> {
            let held = N - self.decoder.spare().len();
            self.unsynced.take_due(held, self.at(at))
        }

        fn at(&self, ms: u64) -> Instant {
            self.start + Duration::from_millis(ms)
        }
    }

    fn frame(id: u16, body: &[u8]) -> Vec<u8> {
        let mut out = vec![0; HEADER_LEN + body.len()];
        let n = x30_panel::proto::frame::encode(&mut out, id, body).expect("fits");
        out.truncate(n);
        out
    }

    #[test]
    fn a_run_is_answered_once_after_a_quiet_time() {
        let mut r = Reader::new();
        assert!(r.feed(b"<PatrolDevice/>", 0).is_empty());
        assert_eq!(r.due(50), None, "not quiet yet");
        assert_eq!(r.due(100), Some(15));
        assert_eq!(r.due(300), None, "answered once");
        // The frame that follows brings the decoder's report, answered already.
        let events = r.feed(&frame(3, b"x"), 400);
        assert_eq!(events, [Ok((3, b"x".to_vec()))]);
    }

    #[test]
    fn a_run_followed_by_a_frame_is_answered_by_the_decoders_report() {
        let mut r = Reader::new();
        let mut bytes = b"junk".to_vec();
        bytes.extend(frame(4, b"y"));
        let events = r.feed(&bytes, 0);
        assert_eq!(
            events,
            [
                Err(FrameError::Garbage { skipped: 4 }),
                Ok((4, b"y".to_vec()))
            ]
        );
        assert_eq!(r.due(500), None);
    }

    #[test]
    fn more_bytes_after_an_answered_run_are_a_run_of_their_own() {
        let mut r = Reader::new();
        r.feed(b"abc", 0);
        assert_eq!(r.due(100), Some(3));
        let mut bytes = b"defgh".to_vec();
        bytes.extend(frame(5, b"z"));
        let events = r.feed(&bytes, 200);
        assert_eq!(events[0], Err(FrameError::Garbage { skipped: 5 }));
    }

    #[test]
    fn a_frame_in_pieces_and_a_trailing_sync_piece_are_not_garbage() {
        let mut r = Reader::new();
        let whole = frame(6, b"<body/>");
        r.feed(&whole[..10], 0);
        assert_eq!(r.due(500), None, "half a header");
        assert_eq!(r.feed(&whole[10..], 600).len(), 1);
        r.feed(&[0xEB, 0x90], 700);
        assert_eq!(r.due(1000), None, "maybe the start of a frame");
    }

    #[test]
    fn the_rest_of_a_frame_with_a_wrong_header_is_not_another_error() {
        let mut r = Reader::new();
        let mut bad = frame(7, b"<body/>");
        bad[9] = 1;
        let events = r.feed(&bad, 0);
        assert_eq!(events, [Err(FrameError::BadReserved { message_id: 7 })]);
        assert_eq!(r.due(200), None);
        r.feed(b"new", 300);
        assert_eq!(r.due(400), Some(3));
    }

    #[test]
    fn an_oversized_frame_being_skipped_is_not_garbage() {
        let mut r = Reader::new();
        let mut header = frame(8, &[b' '; 300]);
        header.truncate(HEADER_LEN + 40);
        let events = r.feed(&header, 0);
        assert!(matches!(
            events.as_slice(),
            [Err(FrameError::TooLong { message_id: 8, .. })]
        ));
        assert_eq!(r.due(200), None, "still skipping");
        r.feed(&[b' '; 260], 300);
        assert_eq!(r.due(500), None, "skipped to its end");
        r.feed(b"??", 600);
        assert_eq!(r.due(700), Some(2));
    }

    /// A frame cut short, small or oversized, accounts for the part of it that came: bytes
    /// without a sync sequence after the next frame are counted exactly.
    #[test]
    fn a_frame_cut_short_is_not_garbage_and_leaves_the_count_right() {
        for declared in [100, 300] {
            let mut r = Reader::new();
            let mut cut = frame(9, &vec![b' '; declared]);
            cut.truncate(HEADER_LEN + 40);
            let mut bytes = cut;
            bytes.extend(frame(10, b"<next/>"));
            let events = r.feed(&bytes, 0);
            let cut_short = Err(FrameError::CutShort {
                message_id: 9,
                asdu_len: declared as u16,
                received: 40,
            });
            assert_eq!(events.last(), Some(&Ok((10, b"<next/>".to_vec()))));
            assert!(events.contains(&cut_short), "{declared}: {events:?}");
            assert_eq!(r.due(200), None, "{declared}: nothing thrown away");
            r.feed(b"????", 300);
            assert_eq!(r.due(400), Some(4), "{declared}");
        }
    }
}
