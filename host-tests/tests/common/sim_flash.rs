//! A simulated NOR flash like the STM32F767's 32 KiB sectors, whose power can be cut.
//!
//! Geometry as embassy-stm32 gives it for the F7: reads of any length, writes of 16-byte
//! units (programmed as four 32-bit words), erases of whole 32 KiB pages. Erased is 0xFF and
//! programming only clears bits, as on the F7 (which has no flash ECC): a write over
//! programmed bits is done only if it clears bits and sets none, such as zeros over a
//! half-written marker. A write that would need a bit back at 1 is refused and counted as a
//! violation, since the chip would store a mix of old and new bits.
//!
//! A power cut is set up to hit the Nth step (a write, or the erase of one page): that step is
//! done partly, as [`WriteCut`] or [`EraseCut`] says, and every later operation fails until
//! [`SimFlash::power_on`] (the reboot).

use std::cell::RefCell;
use std::rc::Rc;

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// Erase page size, bytes (the F767's small sectors, single-bank).
pub const PAGE: usize = 32 * 1024;
/// Write unit, bytes (embassy-stm32's `WRITE_SIZE` for the F7).
pub const WRITE_SIZE: usize = 16;
/// The chip's programming word, bytes (32-bit parallelism): a cut write stops at one.
const PROGRAM_WORD: usize = 4;

/// Why a simulated flash operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimError {
    /// The power is off: the cut happened, no reboot yet.
    PowerOff,
    /// Offset or length not a multiple of the write or erase size.
    NotAligned,
    /// Outside the flash.
    OutOfBounds,
    /// A write that would set a programmed bit back to 1.
    NotErased,
}

impl NorFlashError for SimError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::NotAligned => NorFlashErrorKind::NotAligned,
            Self::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            Self::PowerOff | Self::NotErased => NorFlashErrorKind::Other,
        }
    }
}

/// What a cut write leaves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteCut {
    /// Share of the write's program words done in full, per mille (rounded down; at least
    /// one word is left undone).
    pub done_permille: u32,
    /// Whether the first undone word is half-programmed (only some of its zero bits cleared)
    /// rather than untouched.
    pub torn: bool,
}

/// What a cut page erase leaves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EraseCut {
    /// Nothing: the power went before the erase started.
    Untouched,
    /// Random bytes all over the page.
    Garbage,
    /// The first half erased, the rest as it was.
    FirstHalfErased,
    /// The second half erased, the rest as it was.
    SecondHalfErased,
    /// Each programmed bit erased with this probability, per mille.
    BitsErased(u32),
    /// The first half programmed to zero, the rest as it was (chips that zero a page before
    /// erasing it, so that no cell is over-erased).
    FirstHalfZeroed,
}

/// The kind of one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// A write call.
    Write,
    /// The erase of one page.
    Erase,
}

/// A planned power cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cut {
    /// Steps done in full before the cut one (counted from when the cut is armed).
    pub after: usize,
    /// How a cut write is left.
    pub write: WriteCut,
    /// How a cut erase is left.
    pub erase: EraseCut,
    /// Seed of the random bits the cut step leaves.
    pub seed: u64,
}

/// The chip's state, shared by every handle.
struct Chip {
    mem: Vec<u8>,
    powered: bool,
    cut: Option<Cut>,
    /// Steps since the cut was armed (or since the last reboot).
    steps: usize,
    /// Every step since the log was last cleared.
    log: Vec<Step>,
    /// The kind of the step the last cut hit.
    cut_hit: Option<Step>,
    /// Writes refused for needing a programmed bit back at 1.
    violations: usize,
    /// Every page erase, whole or cut, since creation.
    page_erases: usize,
    /// Every read, since creation.
    reads: usize,
}

/// A handle to the simulated chip (clones share it, as a board's flash outlives a store).
#[derive(Clone)]
pub struct SimFlash(Rc<RefCell<Chip>>);

impl SimFlash {
    /// A blank (erased) flash of `pages` pages.
    pub fn new(pages: usize) -> Self {
        Self(Rc::new(RefCell::new(Chip {
            mem: vec![0xFF; pages * PAGE],
            powered: true,
            cut: None,
            steps: 0,
            log: Vec::new(),
            cut_hit: None,
            violations: 0,
            page_erases: 0,
            reads: 0,
        })))
    }

    /// A copy of the whole flash.
    pub fn snapshot(&self) -> Vec<u8> {
        self.0.borrow().mem.clone()
    }

    /// Puts `mem` (a snapshot) back, powered, with no cut armed and the step log cleared.
    pub fn restore(&self, mem: &[u8]) {
        let mut chip = self.0.borrow_mut();
        chip.mem.copy_from_slice(mem);
        chip.powered = true;
        chip.cut = None;
        chip.steps = 0;
        chip.log.clear();
        chip.cut_hit = None;
    }

    /// Direct access to the bytes (to plant foreign data or flip bits).
    pub fn with_mem<R>(&self, f: impl FnOnce(&mut [u8]) -> R) -> R {
        f(&mut self.0.borrow_mut().mem)
    }

    /// Arms a power cut, counting steps from now.
    pub fn arm(&self, cut: Cut) {
        let mut chip = self.0.borrow_mut();
        chip.cut = Some(cut);
        chip.steps = 0;
        chip.cut_hit = None;
    }

    /// Powers the chip on again with no cut armed and none recorded: the reboot.
    pub fn power_on(&self) {
        let mut chip = self.0.borrow_mut();
        chip.powered = true;
        chip.cut = None;
        chip.steps = 0;
        chip.cut_hit = None;
    }

    /// Whether the armed cut happened, and on which kind of step.
    pub fn cut_hit(&self) -> Option<Step> {
        self.0.borrow().cut_hit
    }

    /// The steps since the log was last cleared.
    pub fn log(&self) -> Vec<Step> {
        self.0.borrow().log.clone()
    }

    /// Clears the step log.
    pub fn clear_log(&self) {
        self.0.borrow_mut().log.clear();
    }

    /// Writes refused for needing a programmed bit back at 1, since creation.
    pub fn violations(&self) -> usize {
        self.0.borrow().violations
    }

    /// Page erases (whole or cut) since creation.
    pub fn page_erases(&self) -> usize {
        self.0.borrow().page_erases
    }

    /// Reads since creation.
    pub fn reads(&self) -> usize {
        self.0.borrow().reads
    }
}

impl Chip {
    /// Counts a step; returns the cut to apply if this step is the one to cut.
    fn step(&mut self, kind: Step) -> Option<Cut> {
        self.log.push(kind);
        let now = self.steps;
        self.steps += 1;
        match self.cut {
            Some(cut) if cut.after == now => {
                self.powered = false;
                self.cut = None;
                self.cut_hit = Some(kind);
                Some(cut)
            }
            _ => None,
        }
    }

    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), SimError> {
        // Programming only clears bits: a write that needs a programmed bit back at 1 would
        // leave a mix of old and new bits. Refuse it before changing anything.
        let target = &self.mem[offset..offset + bytes.len()];
        if target
            .iter()
            .zip(bytes)
            .any(|(&old, &new)| old & new != new)
        {
            self.violations += 1;
            return Err(SimError::NotErased);
        }
        if bytes.is_empty() {
            return Ok(());
        }
        let words = bytes.len() / PROGRAM_WORD;
        let (done, torn_seed) = match self.step(Step::Write) {
            None => (words, None),
            Some(cut) => {
                let done = (words * cut.write.done_permille as usize / 1000).min(words - 1);
                (done, cut.write.torn.then_some(cut.seed))
            }
        };
        let end = offset + done * PROGRAM_WORD;
        for (m, &b) in self.mem[offset..end].iter_mut().zip(bytes) {
            *m &= b;
        }
        if done < words {
            if let Some(seed) = torn_seed {
                // Some of the word's zero bits cleared, the others still erased.
                let mut rng = Rng(seed);
                for (m, &b) in self.mem[end..end + PROGRAM_WORD]
                    .iter_mut()
                    .zip(&bytes[done * PROGRAM_WORD..])
                {
                    *m &= b | rng.byte();
                }
            }
            return Err(SimError::PowerOff);
        }
        Ok(())
    }

    fn erase_page(&mut self, start: usize) -> Result<(), SimError> {
        self.page_erases += 1;
        let cut = self.step(Step::Erase);
        let page = &mut self.mem[start..start + PAGE];
        let Some(cut) = cut else {
            page.fill(0xFF);
            return Ok(());
        };
        let mut rng = Rng(cut.seed);
        match cut.erase {
            EraseCut::Untouched => {}
            EraseCut::Garbage => page.iter_mut().for_each(|b| *b = rng.byte()),
            EraseCut::FirstHalfErased => page[..PAGE / 2].fill(0xFF),
            EraseCut::SecondHalfErased => page[PAGE / 2..].fill(0xFF),
            EraseCut::BitsErased(permille) => {
                for b in page.iter_mut() {
                    for bit in 0..8 {
                        if rng.below(1000) < permille {
                            *b |= 1 << bit;
                        }
                    }
                }
            }
            EraseCut::FirstHalfZeroed => page[..PAGE / 2].fill(0),
        }
        Err(SimError::PowerOff)
    }
}

impl ErrorType for SimFlash {
    type Error = SimError;
}

impl ReadNorFlash for SimFlash {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), SimError> {
        self.0.borrow_mut().reads += 1;
        let chip = self.0.borrow();
        if !chip.powered {
            return Err(SimError::PowerOff);
        }
        let start = offset as usize;
        let src = chip
            .mem
            .get(start..start + bytes.len())
            .ok_or(SimError::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.0.borrow().mem.len()
    }
}

impl NorFlash for SimFlash {
    const WRITE_SIZE: usize = WRITE_SIZE;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), SimError> {
        let mut chip = self.0.borrow_mut();
        if !chip.powered {
            return Err(SimError::PowerOff);
        }
        let (from, to) = (from as usize, to as usize);
        if !from.is_multiple_of(PAGE) || !to.is_multiple_of(PAGE) || from > to {
            return Err(SimError::NotAligned);
        }
        if to > chip.mem.len() {
            return Err(SimError::OutOfBounds);
        }
        for start in (from..to).step_by(PAGE) {
            chip.erase_page(start)?;
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), SimError> {
        let mut chip = self.0.borrow_mut();
        if !chip.powered {
            return Err(SimError::PowerOff);
        }
        let offset = offset as usize;
        if !offset.is_multiple_of(WRITE_SIZE) || !bytes.len().is_multiple_of(WRITE_SIZE) {
            return Err(SimError::NotAligned);
        }
        if offset + bytes.len() > chip.mem.len() {
            return Err(SimError::OutOfBounds);
        }
        chip.write(offset, bytes)
    }
}

/// A small deterministic generator (splitmix64), for test data and cut damage.
#[derive(Clone)]
pub struct Rng(pub u64);

impl Rng {
    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A random byte.
    pub fn byte(&mut self) -> u8 {
        self.next() as u8
    }

    /// A random number below `n` (n > 0).
    pub fn below(&mut self, n: u32) -> u32 {
        (self.next() % u64::from(n)) as u32
    }
}
