//! The settings store over a simulated STM32F7 flash: round trips, wear, foreign and damaged
//! data, refused inputs, and a power cut at every step of a save.

#[path = "common/sim_flash.rs"]
mod sim_flash;

use std::ops::Range;

use sim_flash::{Cut, EraseCut, PAGE, Rng, SimFlash, Step, WriteCut};
use std::cell::Cell;

use x30_panel::settings::store::{BLOB_MAX, BUF_LEN, Store, StoreError};

/// The simulated chip's pages: the store gets the middle two, the outer ones must stay blank.
const FLASH_PAGES: usize = 4;
/// The store's range: pages 1 and 2.
const RANGE: Range<u32> = PAGE as u32..3 * PAGE as u32;
/// A typical settings blob's length.
const SMALL: usize = 100;

/// A blob that differs from every other id's: the id, then bytes drawn from it.
fn blob(id: u32, len: usize) -> Vec<u8> {
    let mut rng = Rng(u64::from(id) << 20 | len as u64);
    let mut b: Vec<u8> = id
        .to_le_bytes()
        .into_iter()
        .chain(std::iter::repeat_with(|| rng.byte()))
        .take(len)
        .collect();
    b.truncate(len);
    b
}

fn store(flash: &SimFlash) -> Store<SimFlash> {
    Store::new(flash.clone(), RANGE)
}

async fn load(store: &mut Store<SimFlash>) -> Result<Option<Vec<u8>>, StoreError> {
    let mut buf = vec![0; BUF_LEN];
    store.load(&mut buf).await.map(|b| b.map(<[u8]>::to_vec))
}

async fn save(store: &mut Store<SimFlash>, blob: &[u8]) -> Result<(), StoreError> {
    let mut scratch = vec![0; BUF_LEN];
    store.save(blob, &mut scratch).await
}

/// Whether the pages outside the store's range are still blank.
fn outside_range_blank(flash: &SimFlash) -> bool {
    let mem = flash.snapshot();
    let (start, end) = (RANGE.start as usize, RANGE.end as usize);
    mem[..start].iter().chain(&mem[end..]).all(|&b| b == 0xFF)
}

/// Where `needle` starts in `mem`, if it occurs once.
fn find(mem: &[u8], needle: &[u8]) -> Option<usize> {
    let mut hits = mem
        .windows(needle.len())
        .enumerate()
        .filter(|(_, w)| *w == needle)
        .map(|(i, _)| i);
    let first = hits.next()?;
    hits.next().is_none().then_some(first)
}

/// A load after a cut, with `Corrupted` read as "nothing saved" when nothing was: a first
/// save cut short leaves the pages neither blank nor holding an item, which the store
/// reports (the settings are the defaults, as before the save).
fn first_save_cut_as_nothing(
    got: Result<Option<Vec<u8>>, StoreError>,
    old: &Option<Vec<u8>>,
) -> Result<Option<Vec<u8>>, StoreError> {
    match got {
        Err(StoreError::Corrupted) if old.is_none() => Ok(None),
        other => other,
    }
}

#[tokio::test]
async fn blank_flash_loads_nothing() {
    let flash = SimFlash::new(FLASH_PAGES);
    assert_eq!(load(&mut store(&flash)).await, Ok(None));
    assert_eq!(
        flash.snapshot(),
        SimFlash::new(FLASH_PAGES).snapshot(),
        "a load of blank flash writes nothing"
    );
}

#[tokio::test]
async fn save_then_load_round_trips() {
    // Empty, shorter than a flash word, word-sized, just over, typical, and the largest.
    for (id, len) in [0, 1, 15, 16, 17, SMALL, BLOB_MAX].into_iter().enumerate() {
        let flash = SimFlash::new(FLASH_PAGES);
        let b = blob(id as u32, len);
        let mut s = store(&flash);
        assert_eq!(save(&mut s, &b).await, Ok(()));
        assert_eq!(s.last_save_erases(), 0);
        assert_eq!(
            load(&mut s).await,
            Ok(Some(b.clone())),
            "same store, length {len}"
        );
        assert_eq!(
            load(&mut store(&flash)).await,
            Ok(Some(b)),
            "after a reboot, length {len}"
        );
        assert!(outside_range_blank(&flash));
        assert_eq!(flash.violations(), 0);
    }
}

#[tokio::test]
async fn many_saves_wrap_both_pages_and_load_the_last() {
    let flash = SimFlash::new(FLASH_PAGES);
    let mut s = store(&flash);
    let (mut erasing_saves, mut counted) = (0, 0);
    let mut rng = Rng(7);
    let mut last = Vec::new();
    for id in 0..600 {
        // Mostly typical blobs, now and then a large one.
        let len = if rng.below(10) == 0 {
            1000 + rng.below(BLOB_MAX as u32 - 999) as usize
        } else {
            rng.below(300) as usize
        };
        last = blob(id, len);
        let before = flash.page_erases();
        assert_eq!(save(&mut s, &last).await, Ok(()), "save {id}");
        let erases = s.last_save_erases();
        assert_eq!(
            erases as usize,
            flash.page_erases() - before,
            "last_save_erases counts the pages the save erased"
        );
        assert!(erases <= 1, "one page at most per save, not {erases}");
        erasing_saves += usize::from(erases > 0);
        counted += erases;
        if id % 50 == 0 {
            assert_eq!(
                load(&mut store(&flash)).await,
                Ok(Some(last.clone())),
                "after save {id}"
            );
        }
    }
    // Each page erased at least twice: the pages wrapped round more than once.
    assert!(counted >= 4, "only {counted} page erases in 600 saves");
    assert!(
        erasing_saves * 10 < 600,
        "{erasing_saves} of 600 saves erased: erases should be rare"
    );
    assert_eq!(load(&mut s).await, Ok(Some(last.clone())));
    assert_eq!(load(&mut store(&flash)).await, Ok(Some(last)));
    assert!(outside_range_blank(&flash));
    assert_eq!(flash.violations(), 0);
}

#[tokio::test]
async fn recycling_a_page_reads_each_item_a_few_times() {
    let flash = SimFlash::new(FLASH_PAGES);
    let mut s = store(&flash);
    // Settings with one key changed: the smallest items, the most of them in a page.
    let mut saves = 0;
    let mut reads_per_save = Vec::new();
    while flash.page_erases() < 2 {
        let before = flash.reads();
        assert_eq!(save(&mut s, &blob(saves, 12)).await, Ok(()));
        reads_per_save.push((flash.reads() - before, s.last_save_erases()));
        saves += 1;
        assert!(saves < 10_000, "no page change in {saves} saves");
    }
    let items_per_page = saves as usize / 2;
    let worst = reads_per_save
        .iter()
        .map(|&(reads, _)| reads)
        .max()
        .unwrap();
    let (recycling, _) = *reads_per_save
        .iter()
        .find(|&&(_, erases)| erases > 0)
        .unwrap();
    assert!(items_per_page > 500, "{items_per_page} items per page");
    // Looking each item up by reading the whole page would take items² reads.
    assert!(
        worst < 20 * items_per_page,
        "{worst} reads for one save, {recycling} for the page change, with {items_per_page} items a page"
    );
}

thread_local! {
    /// Whether [`erase_allowed`] holds erases back (each test runs on a thread of its own).
    static HOLD_ERASES: Cell<bool> = const { Cell::new(false) };
}

/// The erase gate of the test below.
fn erase_allowed() -> bool {
    !HOLD_ERASES.get()
}

/// Saves while erases are held back: the first save that needs a page erased fails before
/// erasing anything, and once erases may go again a save completes and loads back.
#[tokio::test]
async fn a_held_erase_fails_the_save_before_erasing_and_the_next_save_completes() {
    let flash = SimFlash::new(FLASH_PAGES);
    let mut s = store(&flash).with_erase_gate(erase_allowed);
    HOLD_ERASES.set(true);
    let mut saves = 0;
    let held = loop {
        match save(&mut s, &blob(saves, SMALL)).await {
            Ok(()) => saves += 1,
            Err(e) => break e,
        }
        assert!(saves < 10_000, "no save needed an erase");
    };
    assert_eq!(held, StoreError::Held);
    assert_eq!(flash.page_erases(), 0, "nothing erased");
    assert!(saves > 10, "{saves} saves before a page change");
    HOLD_ERASES.set(false);
    assert_eq!(save(&mut s, &blob(saves, SMALL)).await, Ok(()));
    assert!(flash.page_erases() > 0);
    assert_eq!(load(&mut store(&flash)).await, Ok(Some(blob(saves, SMALL))));
    assert_eq!(flash.violations(), 0);
}

#[tokio::test]
async fn too_large_blob_changes_nothing() {
    let flash = SimFlash::new(FLASH_PAGES);
    let mut s = store(&flash);
    let a = blob(1, SMALL);
    save(&mut s, &a).await.unwrap();
    let before = flash.snapshot();
    assert_eq!(
        save(&mut s, &blob(2, BLOB_MAX + 1)).await,
        Err(StoreError::TooLarge)
    );
    assert_eq!(flash.snapshot(), before);
    assert_eq!(load(&mut store(&flash)).await, Ok(Some(a)));
    assert_eq!(
        save(&mut s, &blob(3, BLOB_MAX)).await,
        Ok(()),
        "BLOB_MAX itself fits"
    );
}

#[tokio::test]
async fn short_buffers_are_refused_before_touching_flash() {
    let flash = SimFlash::new(FLASH_PAGES);
    let mut s = store(&flash);
    let a = blob(1, SMALL);
    save(&mut s, &a).await.unwrap();
    let before = flash.snapshot();
    let mut short = vec![0; BUF_LEN - 1];
    assert_eq!(
        s.save(&blob(2, 10), &mut short).await,
        Err(StoreError::BufferTooSmall)
    );
    assert_eq!(s.load(&mut short).await, Err(StoreError::BufferTooSmall));
    assert_eq!(flash.snapshot(), before);
    assert_eq!(load(&mut s).await, Ok(Some(a)));
}

#[tokio::test]
async fn unusable_ranges_are_refused_without_touching_flash() {
    let p = PAGE as u32;
    // One page; not page-aligned at either end; empty.
    for range in [p..2 * p, p + 16..3 * p, p..3 * p - 16, p..p] {
        let flash = SimFlash::new(FLASH_PAGES);
        let mut s = Store::new(flash.clone(), range.clone());
        assert_eq!(load(&mut s).await, Err(StoreError::BadRange), "{range:?}");
        assert_eq!(
            save(&mut s, &blob(1, 8)).await,
            Err(StoreError::BadRange),
            "{range:?}"
        );
        assert_eq!(
            flash.snapshot(),
            SimFlash::new(FLASH_PAGES).snapshot(),
            "{range:?}"
        );
    }
}

/// Foreign data never loads as a blob, nor does the load change it (the range might be
/// misplaced over something else); a save erases it and works.
async fn foreign_then_repaired(flash: &SimFlash, what: &str) {
    let before = flash.snapshot();
    let got = load(&mut store(flash)).await;
    assert!(
        matches!(got, Err(StoreError::Corrupted) | Ok(None)),
        "{what}: loaded {got:?}"
    );
    assert!(
        flash.snapshot() == before,
        "{what}: the load changed the flash"
    );
    let mut s = store(flash);
    let c = blob(99, SMALL);
    assert_eq!(save(&mut s, &c).await, Ok(()), "{what}: save");
    assert_eq!(
        load(&mut store(flash)).await,
        Ok(Some(c)),
        "{what}: load after the save"
    );
    assert!(outside_range_blank(flash), "{what}");
}

#[tokio::test]
async fn foreign_random_bytes_or_zeros_load_nothing_and_a_save_repairs() {
    for seed in 0..8 {
        let flash = SimFlash::new(FLASH_PAGES);
        let mut rng = Rng(seed);
        flash.with_mem(|m| {
            m[RANGE.start as usize..RANGE.end as usize]
                .iter_mut()
                .for_each(|b| *b = rng.byte())
        });
        foreign_then_repaired(&flash, &format!("random bytes, seed {seed}")).await;
    }
    let flash = SimFlash::new(FLASH_PAGES);
    flash.with_mem(|m| m[RANGE.start as usize..RANGE.end as usize].fill(0));
    assert_eq!(
        load(&mut store(&flash)).await,
        Err(StoreError::Corrupted),
        "all zeros"
    );
    foreign_then_repaired(&flash, "all zeros").await;
    // A program image: a repeating pattern of mostly-programmed words.
    let flash = SimFlash::new(FLASH_PAGES);
    flash.with_mem(|m| {
        for (i, b) in m[RANGE.start as usize..RANGE.end as usize]
            .iter_mut()
            .enumerate()
        {
            *b = [0x00, 0x20, 0x01, 0x08, 0x4F, 0xF0, 0x00, 0x0B][i % 8];
        }
    });
    foreign_then_repaired(&flash, "code-like pattern").await;
}

#[tokio::test]
async fn a_flipped_bit_in_the_newest_item_loads_the_one_before() {
    let (a, b) = (blob(1, SMALL), blob(2, SMALL));
    let flash = SimFlash::new(FLASH_PAGES);
    let mut s = store(&flash);
    save(&mut s, &a).await.unwrap();
    save(&mut s, &b).await.unwrap();
    let clean = flash.snapshot();
    let data = find(&clean, &b).expect("B's data, once in flash");
    // The item: its header (one 16-byte write unit: 8 bytes, then padding), the generation
    // (4 bytes), the blob, padding to 16 bytes.
    let start = data - 4 - 16;
    let item = start..start + 16 + (4 + SMALL).next_multiple_of(16);
    let item_len = item.len();
    let mut flips = 0;
    for at in item {
        for bit in [0, 3, 7] {
            flash.restore(&clean);
            flash.with_mem(|m| m[at] ^= 1 << bit);
            let got = load(&mut store(&flash)).await;
            // The paddings are outside the CRCs; anywhere else the item no longer counts.
            let padding = (start + 8..start + 16).contains(&at) || at >= data + SMALL;
            assert!(
                got == Ok(Some(a.clone())) || (padding && got == Ok(Some(b.clone()))),
                "bit {bit} of byte {} of the item flipped: loaded {got:?}",
                at - start
            );
            flips += 1;
            let c = blob(3, SMALL);
            assert_eq!(save(&mut store(&flash), &c).await, Ok(()));
            assert_eq!(load(&mut store(&flash)).await, Ok(Some(c)));
        }
    }
    assert_eq!(flips, 3 * item_len);
    assert_eq!(flash.violations(), 0);
}

#[tokio::test]
async fn a_flipped_bit_in_the_only_item_loads_nothing() {
    let a = blob(1, SMALL);
    let flash = SimFlash::new(FLASH_PAGES);
    save(&mut store(&flash), &a).await.unwrap();
    let data = find(&flash.snapshot(), &a).unwrap();
    flash.with_mem(|m| m[data + SMALL / 2] ^= 0x10);
    foreign_then_repaired(&flash, "flipped bit in the only item").await;
}

#[tokio::test]
async fn stray_programmed_bits_in_blank_looking_flash_are_erased_not_written_over() {
    // Flash that reads as a blank map (state words erased) but has a few programmed bytes,
    // as a nearly complete erase may leave it: here where the first item's data goes (the
    // map skips a header slot that is not blank, but not data).
    let flash = SimFlash::new(FLASH_PAGES);
    flash.with_mem(|m| {
        for at in [100, 500, 1000, 2000] {
            m[RANGE.start as usize + 32 + at] = 0;
        }
    });
    let mut s = store(&flash);
    let a = blob(1, BLOB_MAX);
    assert_eq!(save(&mut s, &a).await, Ok(()));
    assert_eq!(s.last_save_erases(), 2, "the save wiped the range");
    assert_eq!(load(&mut store(&flash)).await, Ok(Some(a)));
    assert_eq!(flash.violations(), 0, "wrote over programmed bits");
}

// --- Power cuts ---------------------------------------------------------------------------

/// How a cut write is left, tried at every write step.
const WRITE_CUTS: [WriteCut; 5] = [
    WriteCut {
        done_permille: 0,
        torn: false,
    },
    WriteCut {
        done_permille: 0,
        torn: true,
    },
    WriteCut {
        done_permille: 500,
        torn: true,
    },
    WriteCut {
        done_permille: 999,
        torn: true,
    },
    WriteCut {
        done_permille: 999,
        torn: false,
    },
];

/// How a cut erase is left, tried at every erase step.
const ERASE_CUTS: [EraseCut; 7] = [
    EraseCut::Untouched,
    EraseCut::Garbage,
    EraseCut::FirstHalfErased,
    EraseCut::SecondHalfErased,
    EraseCut::BitsErased(500),
    EraseCut::BitsErased(990),
    EraseCut::FirstHalfZeroed,
];

/// One save to cut short: the flash before it, the blob that flash holds, the blob saved.
struct Case {
    name: &'static str,
    before: Vec<u8>,
    old: Option<Vec<u8>>,
    new: Vec<u8>,
    /// Whether the save must erase a page (a page change).
    erases: bool,
}

/// What the cut loop went through.
#[derive(Default, Debug)]
struct Tally {
    cuts: usize,
    write_cuts: usize,
    erase_cuts: usize,
    /// Saves under test that erase a page.
    erasing_saves: usize,
}

/// Saves blobs of `len` bytes (ids from `*id`) until the next save would erase a page, and
/// returns the case of that save.
async fn before_page_change(
    flash: &SimFlash,
    name: &'static str,
    id: &mut u32,
    len: usize,
    old: &mut Option<Vec<u8>>,
) -> Case {
    for _ in 0..1000 {
        let before = flash.snapshot();
        let new = blob(*id, len);
        *id += 1;
        let mut s = store(flash);
        save(&mut s, &new).await.unwrap();
        if s.last_save_erases() > 0 {
            let case = Case {
                name,
                before,
                old: old.clone(),
                new: new.clone(),
                erases: true,
            };
            *old = Some(new);
            return case;
        }
        *old = Some(new);
    }
    panic!("{name}: no page change in 1000 saves");
}

/// Cuts the power at every step of the case's save, in every way a step can be cut; after each
/// cut, reboots and checks that the load gives the old blob or the new one, and that a further
/// save works.
async fn cut_every_step(case: &Case, tally: &mut Tally) {
    let flash = SimFlash::new(FLASH_PAGES);
    // Full power first: the steps the save takes.
    flash.restore(&case.before);
    let mut s = store(&flash);
    assert_eq!(save(&mut s, &case.new).await, Ok(()), "{}", case.name);
    let steps = flash.log();
    let page_erases = steps.iter().filter(|&&k| k == Step::Erase).count();
    assert_eq!(s.last_save_erases() as usize, page_erases, "{}", case.name);
    assert_eq!(
        page_erases > 0,
        case.erases,
        "{}: page change expected: {}",
        case.name,
        case.erases
    );
    tally.erasing_saves += usize::from(case.erases);

    let mut seed = 0;
    for (n, &kind) in steps.iter().enumerate() {
        let variants: Vec<(WriteCut, EraseCut)> = match kind {
            Step::Write => WRITE_CUTS
                .iter()
                .map(|&w| (w, EraseCut::Untouched))
                .collect(),
            Step::Erase => ERASE_CUTS.iter().map(|&e| (WRITE_CUTS[0], e)).collect(),
        };
        for (write, erase) in variants {
            seed += 1;
            let what = format!(
                "{}: cut at step {n} ({kind:?}), {write:?} / {erase:?}",
                case.name
            );
            flash.restore(&case.before);
            flash.arm(Cut {
                after: n,
                write,
                erase,
                seed,
            });
            let result = save(&mut store(&flash), &case.new).await;
            assert_eq!(flash.cut_hit(), Some(kind), "{what}");
            assert_eq!(result, Err(StoreError::Flash), "{what}");
            tally.cuts += 1;
            match kind {
                Step::Write => tally.write_cuts += 1,
                Step::Erase => tally.erase_cuts += 1,
            }

            // Reboot.
            flash.power_on();
            let got = first_save_cut_as_nothing(load(&mut store(&flash)).await, &case.old);
            assert!(
                got == Ok(case.old.clone()) || got == Ok(Some(case.new.clone())),
                "{what}: loaded {got:?}"
            );
            let c = blob(0xC0FFEE, SMALL);
            let mut s = store(&flash);
            assert_eq!(
                save(&mut s, &c).await,
                Ok(()),
                "{what}: save after the reboot"
            );
            assert_eq!(
                load(&mut s).await,
                Ok(Some(c.clone())),
                "{what}: load after that save"
            );
            assert_eq!(
                load(&mut store(&flash)).await,
                Ok(Some(c)),
                "{what}: and after another reboot"
            );
            // And through the next two page changes: a page the cut left nearly erased would
            // show only when written again.
            let (mut changes, mut last) = (0, Vec::new());
            for id in 0..100 {
                if changes == 2 {
                    break;
                }
                last = blob(0xD000 + id, BLOB_MAX);
                assert_eq!(
                    save(&mut s, &last).await,
                    Ok(()),
                    "{what}: save {id} after the reboot"
                );
                changes += usize::from(s.last_save_erases() > 0);
            }
            assert_eq!(changes, 2, "{what}");
            assert_eq!(
                load(&mut store(&flash)).await,
                Ok(Some(last)),
                "{what}: after two page changes"
            );
            assert!(outside_range_blank(&flash), "{what}");
            assert_eq!(flash.violations(), 0, "{what}: wrote over programmed flash");
        }
    }
    // One step more than the save takes: the cut never comes.
    flash.restore(&case.before);
    flash.arm(Cut {
        after: steps.len(),
        write: WRITE_CUTS[0],
        erase: EraseCut::Garbage,
        seed,
    });
    assert_eq!(
        save(&mut store(&flash), &case.new).await,
        Ok(()),
        "{}",
        case.name
    );
    assert_eq!(flash.cut_hit(), None, "{}", case.name);
}

#[tokio::test]
async fn power_cut_at_every_step_of_a_save_loads_old_or_new() {
    let mut cases = Vec::new();
    let blank = SimFlash::new(FLASH_PAGES).snapshot();
    cases.push(Case {
        name: "first save on blank flash",
        before: blank,
        old: None,
        new: blob(1, SMALL),
        erases: false,
    });

    let flash = SimFlash::new(FLASH_PAGES);
    let a = blob(2, SMALL);
    save(&mut store(&flash), &a).await.unwrap();
    cases.push(Case {
        name: "second save",
        before: flash.snapshot(),
        old: Some(a),
        new: blob(3, SMALL),
        erases: false,
    });

    // Typical blobs until the first page change (page 1 to page 2), then the second (back).
    let flash = SimFlash::new(FLASH_PAGES);
    let (mut id, mut old) = (10, None);
    cases.push(before_page_change(&flash, "first page change", &mut id, SMALL, &mut old).await);
    cases.push(before_page_change(&flash, "second page change", &mut id, SMALL, &mut old).await);
    cases.push(before_page_change(&flash, "third page change", &mut id, SMALL, &mut old).await);
    // The largest blobs: few to a page, so each page change moves a large item.
    let flash = SimFlash::new(FLASH_PAGES);
    old = None;
    cases.push(
        before_page_change(
            &flash,
            "page change, largest blobs",
            &mut id,
            BLOB_MAX,
            &mut old,
        )
        .await,
    );
    cases.push(
        before_page_change(
            &flash,
            "second page change, largest blobs",
            &mut id,
            BLOB_MAX,
            &mut old,
        )
        .await,
    );
    // After the page change, the next save: the freshly written page.
    let before = flash.snapshot();
    cases.push(Case {
        name: "save right after a page change",
        before,
        old: old.clone(),
        new: blob(id, 7),
        erases: false,
    });

    let mut tally = Tally::default();
    for case in &cases {
        cut_every_step(case, &mut tally).await;
    }
    eprintln!("{tally:?}");
    assert_eq!(tally.erasing_saves, 5);
    assert!(tally.erase_cuts >= 5 * ERASE_CUTS.len(), "{tally:?}");
    assert!(
        tally.write_cuts >= cases.len() * 2 * WRITE_CUTS.len(),
        "{tally:?}"
    );
    assert!(tally.cuts < 5000, "{tally:?}");
}

/// Random saves of random sizes, many cut short, some cut again during the next save or the
/// load after the reboot (when the store repairs itself): every load gives one of the blobs
/// that could be there.
#[tokio::test]
async fn random_saves_with_repeated_power_cuts_never_load_a_stranger() {
    let flash = SimFlash::new(FLASH_PAGES);
    let mut rng = Rng(2024);
    let mut current: Option<Vec<u8>> = None;
    let (mut cuts, mut nested, mut erase_cuts, mut load_cuts) = (0, 0, 0, 0);
    for round in 0..2000u32 {
        let mut allowed = vec![current.clone()];
        // Up to three saves in a row, each maybe cut, with a reboot after each cut.
        for attempt in 0..3 {
            // Mostly large blobs, so that page changes (and erases to cut) come often.
            let len = if rng.below(4) != 0 {
                1500 + rng.below(BLOB_MAX as u32 - 1499) as usize
            } else {
                rng.below(200) as usize
            };
            let b = blob(round * 4 + attempt, len);
            if rng.below(4) != 0 {
                // Cut at one of the steps this save takes (a dry run with full power tells),
                // mostly at an erase if it has any.
                let before = flash.snapshot();
                flash.clear_log();
                save(&mut store(&flash), &b).await.unwrap();
                let steps = flash.log();
                flash.restore(&before);
                let erases: Vec<usize> = (0..steps.len())
                    .filter(|&i| steps[i] == Step::Erase)
                    .collect();
                let after = if !erases.is_empty() && rng.below(4) != 0 {
                    erases[rng.below(erases.len() as u32) as usize]
                } else {
                    rng.below(steps.len() as u32) as usize
                };
                let erase = ERASE_CUTS[rng.below(ERASE_CUTS.len() as u32) as usize];
                let write = WRITE_CUTS[rng.below(WRITE_CUTS.len() as u32) as usize];
                flash.arm(Cut {
                    after,
                    write,
                    erase,
                    seed: rng.next(),
                });
            }
            let result = save(&mut store(&flash), &b).await;
            match flash.cut_hit() {
                None => {
                    flash.power_on();
                    assert_eq!(result, Ok(()), "round {round}");
                    allowed = vec![Some(b)];
                    break;
                }
                Some(kind) => {
                    assert_eq!(result, Err(StoreError::Flash), "round {round}");
                    flash.power_on();
                    cuts += 1;
                    nested += usize::from(attempt > 0);
                    erase_cuts += usize::from(kind == Step::Erase);
                    allowed.push(Some(b));
                    if rng.below(2) == 0 {
                        break;
                    }
                }
            }
        }
        if rng.below(2) == 0 {
            // A cut during the load too: it writes only when it erases a page a cut left.
            let erase = ERASE_CUTS[rng.below(ERASE_CUTS.len() as u32) as usize];
            flash.arm(Cut {
                after: 0,
                write: WRITE_CUTS[0],
                erase,
                seed: rng.next(),
            });
            let result = load(&mut store(&flash)).await;
            if flash.cut_hit().is_some() {
                assert_eq!(result, Err(StoreError::Flash), "round {round}");
                load_cuts += 1;
            }
            flash.power_on();
        }
        let got = first_save_cut_as_nothing(load(&mut store(&flash)).await, &current);
        let got = got.unwrap_or_else(|e| panic!("round {round}: load failed: {e:?}"));
        assert!(
            allowed.contains(&got),
            "round {round}: loaded {got:?}, not one of the {} candidates",
            allowed.len()
        );
        current = got;
        assert_eq!(flash.violations(), 0, "round {round}");
    }
    let counts = format!(
        "{cuts} cuts of a save ({nested} of the save after a reboot, {erase_cuts} during an erase), \
         {load_cuts} of a load"
    );
    eprintln!("{counts}");
    assert!(
        cuts > 1500 && nested > 500 && erase_cuts > 80 && load_cuts > 10,
        "{counts}"
    );
    assert!(outside_range_blank(&flash));
}
