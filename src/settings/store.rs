//! The settings blob in flash: one item, replaced whole, safe against power cuts.
//!
//! From the flash upward:
//!
//! - **Pages.** The store owns a range of whole erase pages and nothing else; it is made for
//!   two (more only spread the wear). The sequential-storage crate's map writes there: each
//!   page begins and ends with a state word (blank: free; first word written: in use; both:
//!   full), and between them lie items, each a header (length, a CRC of the length, a CRC-32
//!   of the data) and the data.
//! - **One item per save.** The map has a single key, the empty key `()`, and each save
//!   appends one item holding the whole settings blob behind a generation number (4 bytes,
//!   one more than the newest item's). A single item for all settings is what makes a save
//!   atomic: no mix of old and new settings can ever be read. Old items stay until their page
//!   is recycled: when the new item does not fit in what is left of the current page, that
//!   page is closed, its newest item copied to the other (blank) page, the old page erased,
//!   and the new item written after the copy. Most saves only write; one in a page's worth
//!   erases a page, a stall the board logs ([`Store::last_save_erases`]).
//! - **Loading** reads each page on its own and takes, of all the items whose CRC checks,
//!   the one with the highest generation.
//! - **Power cuts.** An item counts only once its data is written and its CRC matches, so a
//!   save cut short leaves the previous item the newest valid one: after a reboot the load
//!   gives the old blob or the new one, never a mix. A page change cut short leaves two
//!   pages in use, or one of them half-erased, whose state words may then say anything; the
//!   map alone could take such a page for blank, or the wrong page for the current one, and
//!   lose the blob. So before its first load or save, and after any failure, the store
//!   checks the pages itself: the page with the newest item is kept and the other erased.
//!   The map then finds the state it left after a completed save.
//! - **Checked writes.** Every write is checked to need no programmed bit back at 1 (a page
//!   left nearly erased reads as blank but is not) and read back. A write that fails either
//!   check makes the save erase the whole range and write afresh.
//! - **Foreign or damaged data.** Pages that hold no valid item and are not blank (another
//!   program's data, worn-out flash, or a very first save cut short) make a load fail with
//!   [`StoreError::Corrupted`]; only blank pages load as nothing saved. The next save erases
//!   the whole range and starts afresh. A load erases a page only if
//!   another page holds a valid item. What the blob says is the caller's business: an item of
//!   this layout written by something else reads as a blob here, which is why the settings
//!   blob starts with its own magic.
//!
//! The map caches one thing: where the newest item is. Without it, recycling a page looks
//! each of its items up by reading the whole page (a thousand small items made that a
//! million reads); with it, each look-up is one read. The store forgets that cache whenever
//! it reads or erases pages behind the map's back (settling, loading one page on its own,
//! wiping), so the map never trusts an address it did not see written. The caller lends the
//! buffers.

use core::ops::Range;

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use sequential_storage::cache::key_pointers::ArrayKeyPointers;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage, SerializationError, Value};

/// Largest settings blob the store holds, bytes.
pub const BLOB_MAX: usize = 3584;

/// Asked right before each page erase, after the other tasks have had their turn: `false`
/// holds the erase back, and the operation fails with [`StoreError::Held`]. An erase stalls
/// the whole chip on some boards, so the firmware holds it back while a stop or anything
/// else a person did must not wait ([`Store::with_erase_gate`]).
pub type EraseGate = fn() -> bool;

/// Smallest buffer [`Store::load`] and [`Store::save`] accept, bytes: the largest item's data
/// rounded up to a flash word, with room for any word size up to 32 bytes.
pub const BUF_LEN: usize = BLOB_MAX + 64;

/// Largest flash word (the larger of read and write size) the store works with, bytes.
const MAX_WORD: usize = 32;

/// An item header's size in flash before its padding to a word: data CRC, length, length CRC.
const ITEM_HEADER: usize = 8;

/// The generation number's size in an item, bytes.
const GENERATION: usize = 4;

/// Bytes read at a time when checking that a page is blank (a multiple of any read size the
/// store accepts, and no longer than [`BUF_LEN`]).
const BLANK_CHUNK: usize = 1024;

/// The map's one key: the store is a single value, so the key takes no bytes.
const KEY: () = ();

/// The map over the guarded flash, caching where its one key's newest item is.
type Map<F> = MapStorage<(), Guarded<F>, KeyCache>;

/// The map's cache: the location of the newest item of the one key, nothing else.
type KeyCache = Cache<Uncached, Uncached, ArrayKeyPointers<(), 1>, ()>;

/// An empty cache.
fn key_cache() -> KeyCache {
    Cache::new(Uncached, Uncached, ArrayKeyPointers::new())
}

/// A settings blob in flash.
pub struct Store<F: NorFlash> {
    /// The map, or `None` if the range given to [`Store::new`] cannot hold one.
    map: Option<Map<F>>,
    /// The generation the next save writes; `None` until the pages have been checked (after
    /// `new`, and again after a failure).
    next_generation: Option<u32>,
    /// Pages erased by the last save.
    last_erases: u32,
    /// The range, to make the map again with an empty cache.
    range: Range<u32>,
}

impl<F: NorFlash> Store<F> {
    /// A store over `range` (byte offsets within `flash`, whole erase pages, at least two pages).
    ///
    /// A range that is not whole pages, has fewer than two, or whose pages cannot hold two
    /// blobs of [`BLOB_MAX`] bytes makes every load and save return [`StoreError::BadRange`]
    /// without touching the flash.
    pub fn new(flash: F, range: Range<u32>) -> Self {
        let word = F::WRITE_SIZE.max(F::READ_SIZE);
        // The write checks read whole words in chunks of MAX_WORD.
        let usable = pages_hold_two_blobs::<F>()
            && word <= MAX_WORD
            && MAX_WORD.checked_rem(word) == Some(0);
        let page_size = u32::try_from(F::ERASE_SIZE).ok().filter(|&size| size > 0);
        // An empty or reversed range is refused here: the map's check would underflow on it.
        let len = range.end.checked_sub(range.start).filter(|&len| len > 0);
        let map = match (len, page_size) {
            (Some(len), Some(page_size)) if usable => match MapConfig::try_new(range.clone()) {
                Ok(config) => {
                    let flash = Guarded {
                        flash,
                        gate: || true,
                        start: range.start,
                        page_size,
                        pages: len / page_size,
                        view: None,
                        erases: 0,
                        reads: 0,
                    };
                    Some(MapStorage::new(flash, config, key_cache()))
                }
                Err(_) => None,
            },
            _ => None,
        };
        Self {
            map,
            next_generation: None,
            last_erases: 0,
            range,
        }
    }

    /// The store with `gate` asked before each page erase (by default every erase may go).
    pub fn with_erase_gate(mut self, gate: EraseGate) -> Self {
        if let Some(map) = self.map.as_mut() {
            map.flash().gate = gate;
        }
        self
    }

    /// Makes the map again with an empty cache, after the store read or erased pages behind
    /// its back.
    fn forget_cache(&mut self) {
        if let Some(map) = self.map.take() {
            let (flash, _) = map.destroy();
            self.map = MapConfig::try_new(self.range.clone())
                .ok()
                .map(|config| MapStorage::new(flash, config, key_cache()));
        }
    }

    /// The saved blob, copied into `buf`; `Ok(None)` if nothing was ever saved (blank flash).
    ///
    /// `buf` must be at least [`BUF_LEN`] bytes. A load may erase a page: one that a power cut
    /// left in the middle of a page change.
    pub async fn load<'b>(&mut self, buf: &'b mut [u8]) -> Result<Option<&'b [u8]>, StoreError> {
        if buf.len() < BUF_LEN {
            return Err(StoreError::BufferTooSmall);
        }
        self.next_generation = None;
        let newest = self.settle(buf).await?;
        let map = self.map.as_mut().ok_or(StoreError::BadRange)?;
        let Some((page, generation)) = newest else {
            // No valid item anywhere: blank flash holds nothing; anything else is foreign
            // data, damage, or a first save cut short, which the caller is told about.
            if scan(map, buf).await?.is_some() {
                return Err(StoreError::Internal);
            }
            for page in 0..map.flash().pages {
                if !page_blank(map, page, buf).await? {
                    return Err(StoreError::Corrupted);
                }
            }
            return Ok(None);
        };
        // Read the newest item again, into `buf`, and find where its blob lies there.
        let base = buf.as_ptr().addr();
        map.flash().view = Some(page);
        let found = find_generation(map, generation, buf).await;
        map.flash().view = None;
        self.forget_cache();
        let (start, len) = found?.ok_or(StoreError::Internal)?;
        let start = start.wrapping_sub(base);
        let blob = buf
            .get(start..start.saturating_add(len))
            .ok_or(StoreError::Internal)?;
        Ok(Some(blob))
    }

    /// Saves `blob` in place of the previous one.
    ///
    /// `scratch` is a work buffer of at least [`BUF_LEN`] bytes (it holds the items read while a
    /// page is recycled, and the new one). A store found corrupted or foreign is erased first,
    /// so saving repairs it: that erases every page of the range, and the blob saved before is
    /// lost (it was unreadable anyway). Returns once the item is written and read back: a
    /// power cut after that loads `blob`.
    pub async fn save(&mut self, blob: &[u8], scratch: &mut [u8]) -> Result<(), StoreError> {
        if blob.len() > BLOB_MAX {
            return Err(StoreError::TooLarge);
        }
        if scratch.len() < BUF_LEN {
            return Err(StoreError::BufferTooSmall);
        }
        self.map
            .as_mut()
            .ok_or(StoreError::BadRange)?
            .flash()
            .erases = 0;
        let result = self.save_item(blob, scratch).await;
        if result.is_err() {
            // The pages may be as a power cut would leave them: check them before the next save.
            self.next_generation = None;
        }
        if let Some(map) = self.map.as_mut() {
            self.last_erases = map.flash().erases;
        }
        result
    }

    /// How many page erases the last save did: 0 most of the time, as a page is erased only
    /// when the pages fill up (or when a corrupted store is wiped).
    pub fn last_save_erases(&self) -> u32 {
        self.last_erases
    }

    /// Writes `blob` as the newest item, numbered from the pages (checked first if that is
    /// unknown), erasing the range first if the map cannot take it.
    async fn save_item(&mut self, blob: &[u8], scratch: &mut [u8]) -> Result<(), StoreError> {
        let generation = match self.next_generation {
            Some(generation) => generation,
            None => self
                .settle(scratch)
                .await?
                .map_or(0, |(_, newest)| newest.saturating_add(1)),
        };
        // Even if this save fails, the item may be in flash: its number is never reused.
        self.next_generation = Some(generation.saturating_add(1));
        let item = Item { generation, blob };
        let map = self.map.as_mut().ok_or(StoreError::BadRange)?;
        match map.store_item(scratch, &KEY, &item).await {
            Err(e) if from_map(&e) == StoreError::Corrupted => {
                // The map has already tried its own repair; only a fresh start helps.
                warn!("settings store: flash holds no valid store; erasing it");
                map.erase_all().await.map_err(|e| from_map(&e))?;
                self.forget_cache();
                let map = self.map.as_mut().ok_or(StoreError::BadRange)?;
                let stored = map.store_item(scratch, &KEY, &item).await;
                stored.map_err(|e| from_map(&e))
            }
            other => other.map_err(|e| from_map(&e)),
        }
    }

    /// [`settle`]s the pages, then forgets the map's cache, which the pages read on their own
    /// and the erases have misled.
    async fn settle(&mut self, buf: &mut [u8]) -> Result<Option<(u32, u32)>, StoreError> {
        let map = self.map.as_mut().ok_or(StoreError::BadRange)?;
        let newest = settle(map, buf).await;
        self.forget_cache();
        let newest = newest?;
        self.next_generation = Some(newest.map_or(0, |(_, n)| n.saturating_add(1)));
        Ok(newest)
    }
}

/// Checks the pages after a possible power cut: finds the page holding the newest valid item
/// and erases the pages the map must not see (see the module's documentation). Returns that
/// page and the item's generation, `None` if no page holds a valid item (then nothing is
/// erased: the range may not be this store's at all).
async fn settle<F: NorFlash>(
    map: &mut Map<F>,
    buf: &mut [u8],
) -> Result<Option<(u32, u32)>, StoreError> {
    let pages = map.flash().pages;
    let mut newest: Option<(u32, u32)> = None;
    for page in 0..pages {
        if let Some(generation) = newest_in_page(map, page, buf).await? {
            // The first page wins a tie: both hold the same item.
            if newest.is_none_or(|(_, n)| generation > n) {
                newest = Some((page, generation));
            }
        }
    }
    let Some((keep, _)) = newest else {
        return Ok(None);
    };
    for page in (0..pages).filter(|&page| page != keep) {
        // With two pages, a completed save leaves one of them blank: whatever the other holds
        // is a page change cut short. With more, only pages without a valid item go (the
        // others may be full pages the map still counts on).
        let stale = pages == 2 || newest_in_page(map, page, buf).await?.is_none();
        if stale && !page_blank(map, page, buf).await? {
            warn!("settings store: erasing a page left by a power cut");
            map.flash()
                .erase_page(page)
                .await
                .map_err(|e| from_guard(&e))?;
        }
    }
    Ok(newest)
}

/// The highest generation of the valid items in `page`, read on its own; `None` if it has
/// none (or is not readable as a map page at all).
async fn newest_in_page<F: NorFlash>(
    map: &mut Map<F>,
    page: u32,
    buf: &mut [u8],
) -> Result<Option<u32>, StoreError> {
    map.flash().view = Some(page);
    let newest = scan(map, buf).await;
    map.flash().view = None;
    match newest {
        Err(StoreError::Corrupted) => Ok(None),
        other => other,
    }
}

/// Whether `page` is fully erased.
async fn page_blank<F: NorFlash>(
    map: &mut Map<F>,
    page: u32,
    buf: &mut [u8],
) -> Result<bool, StoreError> {
    let flash = map.flash();
    let chunk = buf.get_mut(..BLANK_CHUNK).ok_or(StoreError::Internal)?;
    let start = flash.page_start(page);
    for offset in (start..start.saturating_add(flash.page_size)).step_by(BLANK_CHUNK) {
        flash
            .flash
            .read(offset, chunk)
            .await
            .map_err(|_| StoreError::Flash)?;
        if chunk.iter().any(|&b| b != 0xFF) {
            return Ok(false);
        }
    }
    Ok(true)
}

/// The highest generation of all the valid items the map sees, `None` if there are none.
async fn scan<F: NorFlash>(map: &mut Map<F>, buf: &mut [u8]) -> Result<Option<u32>, StoreError> {
    let mut items = map.fetch_all_items(buf).await.map_err(|e| from_map(&e))?;
    let mut newest = None;
    while let Some(((), item)) = items.next::<Item>(buf).await.map_err(|e| from_map(&e))? {
        if item.blob.len() > BLOB_MAX {
            // Longer than any blob a save writes: not this store's item.
            return Err(StoreError::Corrupted);
        }
        newest = newest.max(Some(item.generation));
    }
    Ok(newest)
}

/// Reads the first item of generation `generation` the map sees into `buf`: the address and
/// length of its blob there, `None` if there is no such item.
async fn find_generation<F: NorFlash>(
    map: &mut Map<F>,
    generation: u32,
    buf: &mut [u8],
) -> Result<Option<(usize, usize)>, StoreError> {
    let mut items = map.fetch_all_items(buf).await.map_err(|e| from_map(&e))?;
    while let Some(((), item)) = items.next::<Item>(buf).await.map_err(|e| from_map(&e))? {
        if item.generation == generation {
            return Ok(Some((item.blob.as_ptr().addr(), item.blob.len())));
        }
    }
    Ok(None)
}

/// Whether one page of `F` holds its two state words and two items of the largest blob: the
/// item in use and the new one, which a save needs side by side after a page change.
fn pages_hold_two_blobs<F: NorFlash>() -> bool {
    let word = F::WRITE_SIZE.max(F::READ_SIZE).max(1);
    let item = ITEM_HEADER.next_multiple_of(word) + (GENERATION + BLOB_MAX).next_multiple_of(word);
    F::ERASE_SIZE >= 2 * word + 2 * item
}

/// A stored item's value: the generation, then the blob.
struct Item<'a> {
    /// One more than the newest item's when it was saved.
    generation: u32,
    /// The settings blob.
    blob: &'a [u8],
}

impl<'a> Value<'a> for Item<'a> {
    fn serialize_into(&self, buffer: &mut [u8]) -> Result<usize, SerializationError> {
        let len = GENERATION + self.blob.len();
        let out = buffer
            .get_mut(..len)
            .ok_or(SerializationError::BufferTooSmall)?;
        let (generation, blob) = out
            .split_first_chunk_mut::<GENERATION>()
            .ok_or(SerializationError::BufferTooSmall)?;
        *generation = self.generation.to_le_bytes();
        blob.copy_from_slice(self.blob);
        Ok(len)
    }

    fn deserialize_from(buffer: &'a [u8]) -> Result<(Self, usize), SerializationError> {
        let (generation, blob) = buffer
            .split_first_chunk::<GENERATION>()
            .ok_or(SerializationError::InvalidFormat)?;
        let generation = u32::from_le_bytes(*generation);
        Ok((Self { generation, blob }, buffer.len()))
    }
}

/// Why the store could not load or save.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreError {
    /// The flash driver failed (or refused an address). The operation stopped where the driver
    /// failed; the store is as a power cut there would leave it, so a later load gives the old
    /// blob or the new one. Retrying helps if the failure was passing.
    Flash,
    /// The range is not a store this firmware wrote: foreign data or damage. Loading gives
    /// nothing; the next save erases the whole range and writes afresh, so saving repairs it.
    /// From a save: even the range just erased does not hold the item (the flash is failing).
    Corrupted,
    /// The blob is longer than [`BLOB_MAX`]. Nothing was written; the saved blob is unchanged.
    TooLarge,
    /// The buffer passed to a load or save is shorter than [`BUF_LEN`]: a caller bug. Nothing
    /// was read or written; retrying with a large enough buffer works.
    BufferTooSmall,
    /// The range given to [`Store::new`] is not whole erase pages, has fewer than two, or has
    /// pages too small for two blobs of [`BLOB_MAX`] bytes: a build mistake. Nothing was read
    /// or written; no retry helps.
    BadRange,
    /// sequential-storage reported an inconsistency in its own logic, or an error this store
    /// does not know (from a newer version). The flash is as the failed operation left it;
    /// retrying may give the same error, and a save does not erase on it.
    Internal,
    /// The [`EraseGate`] held back a page erase the operation needed. The store is as a
    /// power cut before that erase would leave it: a later load gives the old blob or, if
    /// the save had written it already, the new one. Retrying once the gate allows works.
    Held,
}

impl core::fmt::Display for StoreError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Flash => "flash driver error",
            Self::Corrupted => "settings store corrupted or foreign",
            Self::TooLarge => "settings too large for the store",
            Self::BufferTooSmall => "settings buffer too small",
            Self::Held => "a page erase was held back",
            Self::BadRange => "settings flash range unusable",
            Self::Internal => "settings store internal error",
        })
    }
}

/// The store's view of a map error.
fn from_map<E>(e: &sequential_storage::Error<GuardError<E>>) -> StoreError {
    use sequential_storage::Error;
    match e {
        Error::Storage { value, .. } => from_guard(value),
        // The blob fits a page with room for its predecessor (checked in `new`), so the map is
        // full only of items something else left.
        Error::FullStorage
        | Error::Corrupted { .. }
        // The buffers hold any item a save writes: an item too large for them, or too short
        // to hold a generation, was written by something else.
        | Error::BufferTooSmall(_)
        | Error::SerializationError(_) => StoreError::Corrupted,
        Error::ItemTooBig => StoreError::TooLarge,
        // `BufferTooBig` comes from the queue only; `LogicBug` is the crate's own fault.
        Error::BufferTooBig | Error::LogicBug { .. } => StoreError::Internal,
        // `Error` is non-exhaustive: a variant of a later 8.x release.
        _ => StoreError::Internal,
    }
}

/// The store's view of a guarded flash error.
fn from_guard<E>(e: &GuardError<E>) -> StoreError {
    match e {
        GuardError::Driver(_) => StoreError::Flash,
        // A write that would not stick: the map took flash for blank that is not.
        GuardError::Dirty => StoreError::Corrupted,
        GuardError::ReadOnly => StoreError::Internal,
        GuardError::Held => StoreError::Held,
    }
}

/// Why a guarded flash operation failed.
#[derive(Debug)]
enum GuardError<E> {
    /// The driver failed.
    Driver(E),
    /// A write would need a programmed bit back at 1, or did not read back as written.
    Dirty,
    /// A write or erase while one page is being read on its own.
    ReadOnly,
    /// An erase the [`EraseGate`] held back.
    Held,
}

impl<E: NorFlashError> NorFlashError for GuardError<E> {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::Driver(e) => e.kind(),
            Self::Dirty | Self::ReadOnly | Self::Held => NorFlashErrorKind::Other,
        }
    }
}

/// The flash driver as the map sees it: erases counted, writes checked, and the range either
/// as it is or showing one page alone (as the first page of the range, the others blank).
struct Guarded<F> {
    /// The driver.
    flash: F,
    /// Asked before each erase.
    gate: EraseGate,
    /// The range's first offset.
    start: u32,
    /// The erase page size, bytes.
    page_size: u32,
    /// Pages in the range.
    pages: u32,
    /// The page shown alone, read-only, if any.
    view: Option<u32>,
    /// Pages erased since the count was last reset.
    erases: u32,
    /// Reads, counted to yield to other tasks every [`READS_PER_YIELD`].
    reads: u32,
}

/// Reads between two yields to the executor. A blocking driver never yields, and a page
/// change reads the page item by item for each of its items (thousands of reads): without
/// yields the other tasks, the buttons among them, would wait for the whole save.
const READS_PER_YIELD: u32 = 16;

impl<F: NorFlash> Guarded<F> {
    /// The first offset of `page` of the range.
    fn page_start(&self, page: u32) -> u32 {
        self.start
            .saturating_add(page.saturating_mul(self.page_size))
    }

    /// Erases `page` of the range.
    async fn erase_page(&mut self, page: u32) -> Result<(), GuardError<F::Error>> {
        let start = self.page_start(page);
        self.erase(start, start.saturating_add(self.page_size))
            .await
    }

    /// Compares `bytes` with the flash at `offset`, a chunk at a time: whether every chunk
    /// passes `ok(flash, bytes)`.
    async fn check(
        &mut self,
        offset: u32,
        bytes: &[u8],
        ok: impl Fn(&[u8], &[u8]) -> bool,
    ) -> Result<bool, GuardError<F::Error>> {
        let mut chunk = [0; MAX_WORD];
        let mut at = offset;
        for expected in bytes.chunks(MAX_WORD) {
            let read = chunk.get_mut(..expected.len()).ok_or(GuardError::Dirty)?;
            self.flash
                .read(at, read)
                .await
                .map_err(GuardError::Driver)?;
            if !ok(read, expected) {
                return Ok(false);
            }
            at = at.saturating_add(MAX_WORD as u32);
        }
        Ok(true)
    }
}

impl<F: ErrorType> ErrorType for Guarded<F> {
    type Error = GuardError<F::Error>;
}

impl<F: NorFlash> ReadNorFlash for Guarded<F> {
    const READ_SIZE: usize = F::READ_SIZE;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.reads = self.reads.wrapping_add(1);
        if self.reads.is_multiple_of(READS_PER_YIELD) {
            embassy_futures::yield_now().await;
        }
        let Some(page) = self.view else {
            return self
                .flash
                .read(offset, bytes)
                .await
                .map_err(GuardError::Driver);
        };
        // The range's first page shows `page`; the rest reads as erased.
        let first_end = self.start.saturating_add(self.page_size);
        let shown = (first_end.saturating_sub(offset) as usize).min(bytes.len());
        let (from_page, blank) = bytes.split_at_mut_checked(shown).ok_or(GuardError::Dirty)?;
        if !from_page.is_empty() {
            let shift = page.saturating_mul(self.page_size);
            let at = offset.saturating_add(shift);
            self.flash
                .read(at, from_page)
                .await
                .map_err(GuardError::Driver)?;
        }
        blank.fill(0xFF);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.flash.capacity()
    }
}

impl<F: NorFlash> NorFlash for Guarded<F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if self.view.is_some() {
            return Err(GuardError::ReadOnly);
        }
        // The other tasks first: a button pressed while the pages were read reaches the
        // panel, and the gate, before the erase can stall the chip.
        embassy_futures::yield_now().await;
        if !(self.gate)() {
            return Err(GuardError::Held);
        }
        let pages = to.saturating_sub(from).checked_div(self.page_size);
        self.erases = self.erases.saturating_add(pages.unwrap_or(0));
        self.flash.erase(from, to).await.map_err(GuardError::Driver)
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        if self.view.is_some() {
            return Err(GuardError::ReadOnly);
        }
        // Programming only clears bits. Writing over programmed bits is what the map does to
        // finish a half-written state word (zeros over some zeros); anything needing a bit
        // back at 1 means the map took unerased flash for blank.
        let clears_only =
            |old: &[u8], new: &[u8]| old.iter().zip(new).all(|(&old, &new)| old & new == new);
        if !self.check(offset, bytes, clears_only).await? {
            return Err(GuardError::Dirty);
        }
        self.flash
            .write(offset, bytes)
            .await
            .map_err(GuardError::Driver)?;
        if !self
            .check(offset, bytes, |read, written| read == written)
            .await?
        {
            return Err(GuardError::Dirty);
        }
        Ok(())
    }
}
