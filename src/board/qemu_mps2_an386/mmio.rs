//! Register access for the board's memory-mapped peripherals.

/// A block of 32-bit device registers at a fixed address.
///
/// Construction is the one `unsafe` step: it asserts that the address range is a device's
/// register block. The accesses after that are volatile, aligned 32-bit loads and stores
/// inside the block, and so safe; an offset outside it (a bug; the drivers use constants)
/// reads as 0 and writes nothing rather than touching memory the program owns.
#[derive(Debug, Clone, Copy)]
pub struct Registers {
    /// Address of the first register.
    base: usize,
    /// Size of the block in bytes.
    size: usize,
}

impl Registers {
    /// The register block of `size` bytes at `base`.
    ///
    /// # Safety
    ///
    /// `base..base + size` must be a device register block mapped for the whole program, in
    /// which every aligned 32-bit access affects that device only (never memory the program
    /// uses), and which only the one driver given this value accesses.
    pub const unsafe fn new(base: usize, size: usize) -> Self {
        Self { base, size }
    }

    /// Whether `offset` names an aligned register inside the block.
    #[inline]
    fn valid(self, offset: usize) -> bool {
        offset.is_multiple_of(4) && offset < self.size
    }

    /// Reads the register at `offset`.
    #[inline]
    pub fn read(self, offset: usize) -> u32 {
        if !self.valid(offset) {
            return 0;
        }
        // SAFETY: `new`'s contract, and `offset` is aligned and inside the block.
        unsafe { core::ptr::read_volatile((self.base + offset) as *const u32) }
    }

    /// Writes `value` to the register at `offset`.
    #[inline]
    pub fn write(self, offset: usize, value: u32) {
        if !self.valid(offset) {
            return;
        }
        // SAFETY: `new`'s contract, and `offset` is aligned and inside the block; the write
        // affects the device only.
        unsafe { core::ptr::write_volatile((self.base + offset) as *mut u32, value) }
    }
}
