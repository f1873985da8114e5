//! The binary frame (APDU) around every message: a 16-byte header, then the XML body (ASDU).
//!
//! ```text
//! offset  size  field
//!      0     4  sync       EB 90 EB 90
//!      4     2  length     ASDU length in bytes, little-endian
//!      6     2  message ID chosen by the requester, echoed in the answer, little-endian
//!      8     8  reserved   all zero
//! ```
//!
//! TCP is a byte stream, so a read may hold half a frame or several frames.
//! [`FrameDecoder`] accepts arbitrary chunks into a fixed buffer, hands out whole frames,
//! finds the sync sequence again after garbage, and skips frames too long for its buffer
//! without losing the frame that follows.
//!
//! The body is UTF-8 text, and no UTF-8 text contains the sync sequence: `EB` starts a
//! three-byte character, so `EB 90` must be followed by a continuation byte, never by
//! another `EB`; nor does it end in `EB`, `EB 90` or `EB 90 EB`. A sync sequence inside a
//! declared body, or part of one at its end, therefore means that frame was cut short (a
//! sender that wrote only part of it), and the next frame starts there: the decoder hands
//! that one out rather than swallowing it as the rest of the broken body. A sync sequence
//! inside a header, after its own, means the header was cut short: its bytes are reported as
//! garbage. (A whole header holds one only if its length and message ID are both 37099, or
//! if its reserved bytes, which the document fills with zeros, hold one.)
//!
//! The document reserves the last eight header bytes and fills them with zeros "for now",
//! without saying what a receiver does with other bytes there. A decoder refuses such a
//! header by default ([`Reserved::Refuse`], the robot's side as the simulator reads it); a
//! client reads answers with [`Reserved::Ignore`], so that a robot whose software puts
//! something there is still understood.

/// The four bytes that start every frame.
pub const SYNC: [u8; 4] = [0xEB, 0x90, 0xEB, 0x90];
/// Length of the frame header in bytes.
pub const HEADER_LEN: usize = 16;
/// Largest ASDU the 16-bit length field can describe.
pub const MAX_ASDU_LEN: usize = u16::MAX as usize;

/// A decoded frame header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// Length of the ASDU that follows, in bytes.
    pub asdu_len: u16,
    /// Message ID: the requester's choice, echoed unchanged in the answer.
    pub message_id: u16,
}

/// Why a header was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum HeaderError {
    /// The first four bytes are not the sync sequence (the robot's ErrorCode 1, header missing).
    BadSync,
    /// The reserved bytes are not all zero (the robot's ErrorCode 2, header wrong).
    BadReserved,
}

impl Header {
    /// Encodes the header into its 16 wire bytes.
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut out = [0; HEADER_LEN];
        let [s0, s1, s2, s3, l0, l1, m0, m1, ..] = &mut out;
        [*s0, *s1, *s2, *s3] = SYNC;
        [*l0, *l1] = self.asdu_len.to_le_bytes();
        [*m0, *m1] = self.message_id.to_le_bytes();
        out
    }

    /// Decodes 16 header bytes, checking the sync sequence and the reserved bytes.
    pub fn decode(bytes: &[u8; HEADER_LEN]) -> Result<Self, HeaderError> {
        Self::decode_as(bytes, Reserved::Refuse)
    }

    /// Decodes 16 header bytes, checking the sync sequence, and the reserved bytes if
    /// `reserved` says so.
    fn decode_as(bytes: &[u8; HEADER_LEN], reserved: Reserved) -> Result<Self, HeaderError> {
        let [s0, s1, s2, s3, l0, l1, m0, m1, rest @ ..] = *bytes;
        if [s0, s1, s2, s3] != SYNC {
            return Err(HeaderError::BadSync);
        }
        if reserved == Reserved::Refuse && rest != [0; 8] {
            return Err(HeaderError::BadReserved);
        }
        Ok(Self {
            asdu_len: u16::from_le_bytes([l0, l1]),
            message_id: u16::from_le_bytes([m0, m1]),
        })
    }
}

/// Source of message IDs for one requester: counts up from 0 and wraps 65535 → 0.
#[derive(Debug, Clone, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MessageIds {
    next: u16,
}

impl MessageIds {
    /// A counter whose first ID is 0.
    pub const fn new() -> Self {
        Self { next: 0 }
    }

    /// Returns the next message ID.
    pub fn next_id(&mut self) -> u16 {
        let id = self.next;
        self.next = self.next.wrapping_add(1);
        id
    }
}

/// Why a frame could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer cannot hold the header and body.
    BufferTooSmall,
    /// The body is longer than the 16-bit length field allows.
    AsduTooLong,
}

/// Writes a whole frame: `write_asdu` fills the body after the header, returning its length.
///
/// Writing the body in place avoids a second buffer and a copy; the header is filled in
/// once the body's length is known. Returns the frame's total length.
pub fn encode_with<E>(
    out: &mut [u8],
    message_id: u16,
    write_asdu: impl FnOnce(&mut [u8]) -> Result<usize, E>,
) -> Result<usize, E>
where
    E: From<EncodeError>,
{
    let (header, body) = out
        .split_first_chunk_mut::<HEADER_LEN>()
        .ok_or(EncodeError::BufferTooSmall)?;
    let asdu_len = write_asdu(body)?;
    let asdu_len = u16::try_from(asdu_len).map_err(|_| EncodeError::AsduTooLong)?;
    *header = Header {
        asdu_len,
        message_id,
    }
    .encode();
    Ok(HEADER_LEN + usize::from(asdu_len))
}

/// Writes a whole frame around an already encoded body; returns the frame's total length.
pub fn encode(out: &mut [u8], message_id: u16, asdu: &[u8]) -> Result<usize, EncodeError> {
    encode_with(out, message_id, |body| {
        body.get_mut(..asdu.len())
            .ok_or(EncodeError::BufferTooSmall)?
            .copy_from_slice(asdu);
        Ok(asdu.len())
    })
}

/// One complete frame handed out by [`FrameDecoder`], borrowing its buffer.
#[derive(Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Frame<'a> {
    /// The frame's message ID.
    pub message_id: u16,
    /// The XML body.
    pub asdu: &'a [u8],
}

/// Something in the byte stream that is not a usable frame.
///
/// None of these ends the stream: after reporting one, the decoder carries on with the
/// bytes that follow, so the connection stays usable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FrameError {
    /// Bytes without a sync sequence were discarded (the robot's ErrorCode 1).
    Garbage {
        /// How many bytes were discarded.
        skipped: usize,
    },
    /// A header had non-zero reserved bytes and the decoder refuses them
    /// ([`Reserved::Refuse`]); it searches for the next sync sequence after its first byte
    /// (the robot's ErrorCode 2).
    BadReserved {
        /// The message ID the bad header carried.
        message_id: u16,
    },
    /// A frame longer than the decoder's buffer; its bytes are skipped as they arrive, up
    /// to its declared length or the next sync sequence (the robot's ErrorCode 3).
    TooLong {
        /// The message ID of the skipped frame.
        message_id: u16,
        /// Its declared ASDU length.
        asdu_len: u16,
    },
    /// A sync sequence came before the end of a frame's declared body, or its body ended in
    /// part of one, which UTF-8 text never does: the frame was cut short, and decoding
    /// resumes at that sync sequence (the robot's ErrorCode 3). A frame longer than the
    /// buffer, reported as [`FrameError::TooLong`] already, is reported again if it is cut
    /// short.
    CutShort {
        /// The message ID of the broken frame.
        message_id: u16,
        /// Its declared ASDU length.
        asdu_len: u16,
        /// How many bytes of its body came before the next frame's sync sequence.
        received: u16,
    },
}

/// What a [`FrameDecoder`] does with a header whose reserved bytes are not all zero.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reserved {
    /// Refuse the header ([`FrameError::BadReserved`]) and look for the next sync sequence,
    /// as the robot does with a request (its ErrorCode 2).
    Refuse,
    /// Read the frame as if they were zero: what a client does with the robot's answers,
    /// since the document only fills them with zeros "for now".
    Ignore,
}

/// The length field of a header that starts `EB 90 EB 90 EB 90` (the sync sequence's first
/// half, little-endian): 37099 bytes.
const OVERLAP_ASDU_LEN: usize = u16::from_le_bytes([SYNC[0], SYNC[1]]) as usize;

/// A streaming frame decoder over a fixed buffer of `N` bytes.
///
/// Frames whose header and body fit in `N` bytes are handed out whole. Feed it bytes with
/// [`FrameDecoder::feed`] (or read straight into [`FrameDecoder::spare`] and call
/// [`FrameDecoder::commit`]), then call [`FrameDecoder::decode`] until it returns `None`.
#[derive(Debug)]
pub struct FrameDecoder<const N: usize> {
    buf: [u8; N],
    /// Whether headers with non-zero reserved bytes are refused.
    reserved: Reserved,
    /// First byte not yet examined.
    start: usize,
    /// One past the last byte received.
    end: usize,
    /// Bytes of an oversized frame still to be thrown away as they arrive.
    skip: usize,
    /// The oversized frame being skipped: its header, to report it if it is cut short.
    skipping: Header,
    /// Bytes after `start` already searched for a sync sequence that would cut the frame
    /// there short, so that a body arriving a few bytes at a time is searched once.
    searched: usize,
    /// Garbage counted before a sync sequence was found, reported once per run.
    garbage: usize,
}

impl<const N: usize> Default for FrameDecoder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameDecoder<N> {
    /// Largest ASDU this decoder hands out; longer frames are skipped.
    pub const MAX_ASDU: usize = N.saturating_sub(HEADER_LEN);

    /// An empty decoder that refuses headers with non-zero reserved bytes
    /// ([`Reserved::Refuse`]).
    pub const fn new() -> Self {
        // Telling overlapping sync sequences apart needs a header plus two bytes.
        const {
            assert!(
                N >= HEADER_LEN + 2,
                "a FrameDecoder needs at least 18 bytes"
            )
        };
        Self {
            buf: [0; N],
            reserved: Reserved::Refuse,
            start: 0,
            end: 0,
            skip: 0,
            skipping: Header {
                asdu_len: 0,
                message_id: 0,
            },
            searched: 0,
            garbage: 0,
        }
    }

    /// The decoder, doing `policy` with headers whose reserved bytes are not zero.
    pub const fn reserved(mut self, policy: Reserved) -> Self {
        self.reserved = policy;
        self
    }

    /// Forgets every byte received, for example after the connection was re-opened.
    pub fn clear(&mut self) {
        *self = Self {
            buf: self.buf,
            ..Self::new().reserved(self.reserved)
        };
    }

    /// Free space to read into, after moving unread bytes to the front of the buffer.
    ///
    /// Never empty while a frame is incomplete, because a frame that would not fit is
    /// skipped instead of buffered.
    pub fn spare(&mut self) -> &mut [u8] {
        if self.start > 0 {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
        self.buf.get_mut(self.end..).unwrap_or_default()
    }

    /// Marks `n` bytes written into [`FrameDecoder::spare`] as received.
    pub fn commit(&mut self, n: usize) {
        self.end = self.end.saturating_add(n).min(N);
    }

    /// Copies as much of `data` as fits; returns how many bytes were taken.
    ///
    /// Call [`FrameDecoder::decode`] until it returns `None` before feeding the rest.
    pub fn feed(&mut self, data: &[u8]) -> usize {
        let spare = self.spare();
        let n = spare.len().min(data.len());
        if let (Some(dst), Some(src)) = (spare.get_mut(..n), data.get(..n)) {
            dst.copy_from_slice(src);
        }
        self.commit(n);
        n
    }

    /// The next frame or stream error, or `None` when more bytes are needed.
    pub fn decode(&mut self) -> Option<Result<Frame<'_>, FrameError>> {
        loop {
            if self.skip > 0 {
                let declared_end = self.start + self.skip;
                match self.body_end(self.start, declared_end) {
                    Ok(at) => {
                        let received = usize::from(self.skipping.asdu_len) - self.skip + at;
                        self.skip = 0;
                        self.advance(at);
                        return Some(Err(cut_short(self.skipping, received)));
                    }
                    // Drop what came, but for a tail that could start a sync sequence split
                    // across reads.
                    Err(at) => {
                        self.advance(at);
                        self.skip -= at;
                    }
                }
                if self.skip > 0 {
                    return None;
                }
            }
            let pending = self.buf.get(self.start..self.end).unwrap_or_default();
            let at = sync_start(pending);
            if pending.len() - at < SYNC.len() {
                // Keep a tail that could be the start of a sync sequence split across reads.
                self.advance(at);
                self.garbage += at;
                return None;
            }
            let skip = match self.overlapping_sync(pending.get(at..).unwrap_or_default()) {
                Overlap::No => at,
                Overlap::Later(later) => at + later,
                Overlap::Undecided => {
                    self.advance(at);
                    self.garbage += at;
                    return None;
                }
            };
            if skip > 0 {
                self.advance(skip);
                self.garbage += skip;
            }
            if skip > at {
                continue;
            }
            if self.garbage > 0 {
                let skipped = core::mem::take(&mut self.garbage);
                return Some(Err(FrameError::Garbage { skipped }));
            }
            let header = self
                .buf
                .get(self.start..self.end)
                .and_then(|b| b.first_chunk::<HEADER_LEN>())?;
            let header = match Header::decode_as(header, self.reserved) {
                Ok(header) => header,
                Err(HeaderError::BadReserved) => {
                    let message_id = u16::from_le_bytes([header[6], header[7]]);
                    // Drop one byte only: a real sync sequence may start inside this header.
                    self.advance(1);
                    return Some(Err(FrameError::BadReserved { message_id }));
                }
                // sync_start put a sync sequence at `start`; keep looking if that ever changes.
                Err(HeaderError::BadSync) => {
                    self.advance(1);
                    continue;
                }
            };
            let asdu_len = usize::from(header.asdu_len);
            if asdu_len > Self::MAX_ASDU {
                self.advance(HEADER_LEN);
                self.skip = asdu_len;
                self.skipping = header;
                return Some(Err(FrameError::TooLong {
                    message_id: header.message_id,
                    asdu_len: header.asdu_len,
                }));
            }
            let body = self.start + HEADER_LEN;
            let declared_end = body + asdu_len;
            match self.body_end(body.max(self.start + self.searched), declared_end) {
                Ok(at) => {
                    self.advance(at);
                    return Some(Err(cut_short(header, at - HEADER_LEN)));
                }
                // The bytes before `at` hold no sync sequence: they need no second search.
                Err(at) if self.end < declared_end => {
                    self.searched = at;
                    return None;
                }
                Err(_) => {}
            }
            let asdu = self.buf.get(body..declared_end)?;
            self.start = declared_end;
            self.searched = 0;
            return Some(Ok(Frame {
                message_id: header.message_id,
                asdu,
            }));
        }
    }

    /// Moves past `n` bytes, which ends any search of a body that started before them.
    fn advance(&mut self, n: usize) {
        self.start += n;
        self.searched = 0;
    }

    /// Searches the bytes received from `from` up to `declared_end`, the declared end of the
    /// body they belong to, for the start of the next frame: a sync sequence, or, once the
    /// whole body is here, part of one that ends it. UTF-8 text holds neither, so either
    /// means the body was cut short there: `Ok(where)`. Otherwise `Err(where)`: the bytes
    /// before it are body, those after it may still start a sync sequence. Both count from
    /// `start`.
    fn body_end(&self, from: usize, declared_end: usize) -> Result<usize, usize> {
        let bytes = self
            .buf
            .get(from..self.end.min(declared_end))
            .unwrap_or_default();
        let at = sync_start(bytes);
        let rest = bytes.len() - at;
        let found = from + at - self.start;
        if rest >= SYNC.len() || (rest > 0 && self.end >= declared_end) {
            Ok(found)
        } else {
            Err(found)
        }
    }

    /// Whether the sync sequence at the start of `bytes` hides another in what would be its
    /// header, where the frame really starts.
    ///
    /// One after the header's own (or starting in it) means the sender cut the header
    /// short and the next frame starts there: a whole header holds none unless its length
    /// and message ID are both 37099 or its reserved bytes, zeros in the document, hold one.
    ///
    /// One two bytes in is the pattern `EB 90 EB 90 EB 90`: either a frame whose length
    /// field is `EB 90` (37099 bytes), or garbage ending in half a sync sequence followed by
    /// a real frame two bytes later. A decoder that cannot hold 37099 bytes and ignores
    /// reserved bytes takes the later header: the earlier frame would be skipped anyway, and
    /// no answer comes near that length. Otherwise the later header is the real one when its
    /// reserved bytes are zero: in a genuine 37099-byte frame those positions hold the start
    /// of the XML body, never zeros.
    fn overlapping_sync(&self, bytes: &[u8]) -> Overlap {
        let head = bytes.get(2..).unwrap_or_default();
        let head = head.get(..HEADER_LEN + 1).unwrap_or(head);
        let found = sync_start(head);
        let later = 2 + found;
        if head.len() - found < SYNC.len() {
            // Part of one ending what came of the header: the bytes after it will tell.
            return if found < head.len() && later < HEADER_LEN {
                Overlap::Undecided
            } else {
                Overlap::No
            };
        }
        if later > 2 || (self.reserved == Reserved::Ignore && Self::MAX_ASDU < OVERLAP_ASDU_LEN) {
            return Overlap::Later(later);
        }
        match bytes
            .get(2..2 + HEADER_LEN)
            .and_then(|b| b.first_chunk::<HEADER_LEN>())
        {
            None => Overlap::Undecided,
            Some(header) if Header::decode(header).is_ok() => Overlap::Later(2),
            Some(_) => Overlap::No,
        }
    }
}

/// Whether a sync sequence at the start of some bytes hides another in what would be its
/// header.
enum Overlap {
    /// Only one candidate header.
    No,
    /// The real frame starts this many bytes later.
    Later(usize),
    /// More bytes are needed to tell.
    Undecided,
}

/// The error for the frame with `header`, cut short after `received` bytes of its body.
fn cut_short(header: Header, received: usize) -> FrameError {
    FrameError::CutShort {
        message_id: header.message_id,
        asdu_len: header.asdu_len,
        // Less than the declared length, which is a u16.
        received: u16::try_from(received).unwrap_or(header.asdu_len),
    }
}

/// Where in `bytes` the first sync sequence starts, or part of one that ends them;
/// `bytes.len()` if neither does.
#[inline(never)]
fn sync_start(bytes: &[u8]) -> usize {
    (0..bytes.len())
        .find(|&at| {
            let rest = bytes.get(at..).unwrap_or_default();
            let n = rest.len().min(SYNC.len());
            rest.get(..n) == SYNC.get(..n)
        })
        .unwrap_or(bytes.len())
}
