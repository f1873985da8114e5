//! The virtual panel's settings flash: NOR flash emulated in a file on the host, reached
//! through semihosting, so that saved settings survive QEMU restarts.
//!
//! The geometry is the Nucleo's settings sectors': two 32 KiB pages, written in 4-byte words
//! and erased a page at a time. It behaves like NOR flash so that the settings store meets on
//! QEMU what it meets on the chip: erasing sets every byte of a page to 0xFF, and writing can
//! only clear bits (the file gets the AND of its old and the new bytes). A file shorter than
//! the flash is blank beyond its end: an empty file is an erased flash.

use core::ffi::CStr;

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

use super::semihosting::HostFile;

/// Size of the flash: two pages.
pub const CAPACITY: u32 = 2 * PAGE;

/// Size of a page, the unit of erasing (a settings sector of the Nucleo's STM32F767ZI).
pub const PAGE: u32 = 32 * 1024;

/// The value of every byte of an erased page.
const ERASED: u8 = 0xFF;

/// The longest settings file path, in bytes.
pub const MAX_PATH: usize = 255;

/// How much of the file one host call reads or writes while writing or erasing.
const CHUNK: usize = 256;

/// Why an access to the settings flash failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlashError {
    /// The flash has no file to write: none was named, or it could not be opened.
    NoFile,
    /// The file's path is longer than [`MAX_PATH`] or contains a NUL byte.
    BadPath,
    /// An offset or length is not a multiple of the read, write or erase size.
    NotAligned,
    /// The access goes beyond the flash's end, or an erase ends before it starts.
    OutOfBounds,
    /// The host could not open, read or write the file.
    Io,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::NotAligned => NorFlashErrorKind::NotAligned,
            Self::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            Self::NoFile | Self::BadPath | Self::Io => NorFlashErrorKind::Other,
        }
    }
}

/// The settings flash, over a host file.
#[derive(Debug)]
pub struct SettingsFlash {
    /// The file; `None` for a flash without one, blank and unwritable.
    file: Option<HostFile>,
}

impl SettingsFlash {
    /// The flash kept in the host file at `path`, which is created if it does not exist and
    /// filled with 0xFF up to the flash's size if it is shorter (its contents are kept).
    pub fn open(path: &str) -> Result<Self, FlashError> {
        // The host wants the path NUL-terminated; it is needed only while the file is opened.
        let mut name = [0u8; MAX_PATH + 1];
        name.get_mut(..path.len())
            .filter(|_| path.len() <= MAX_PATH)
            .ok_or(FlashError::BadPath)?
            .copy_from_slice(path.as_bytes());
        let name = name.get(..=path.len()).ok_or(FlashError::BadPath)?;
        let name = CStr::from_bytes_with_nul(name).map_err(|_| FlashError::BadPath)?;
        let mut file = HostFile::open(name).map_err(|_| FlashError::Io)?;
        // Blank to the end now, so that later writes never leave a hole, which the host would
        // fill with zeros rather than with erased bytes.
        let size = file.size().map_err(|_| FlashError::Io)?;
        fill(&mut file, size, CAPACITY as usize)?;
        Ok(Self { file: Some(file) })
    }

    /// A flash without a file: blank, and every write or erase fails with
    /// [`FlashError::NoFile`]. The settings are the defaults and cannot be saved, and that
    /// is all: nothing was lost, so nothing reads as damaged.
    pub fn absent() -> Self {
        Self { file: None }
    }

    /// The open file, to write.
    fn file(&mut self) -> Result<&mut HostFile, FlashError> {
        self.file.as_mut().ok_or(FlashError::NoFile)
    }
}

/// Writes erased bytes over `from..to` of `file`.
fn fill(file: &mut HostFile, from: usize, to: usize) -> Result<(), FlashError> {
    let blank = [ERASED; CHUNK];
    let mut at = from;
    while at < to {
        let len = (to - at).min(CHUNK);
        let chunk = blank.get(..len).ok_or(FlashError::Io)?;
        file.write_at(at, chunk).map_err(|_| FlashError::Io)?;
        at += len;
    }
    Ok(())
}

/// The start of an access of `len` bytes at `offset`, after checking that both are multiples
/// of `unit` and that the access stays inside the flash.
fn checked(offset: u32, len: usize, unit: usize) -> Result<usize, FlashError> {
    let start = offset as usize;
    if !start.is_multiple_of(unit) || !len.is_multiple_of(unit) {
        return Err(FlashError::NotAligned);
    }
    match start.checked_add(len) {
        Some(end) if end <= CAPACITY as usize => Ok(start),
        _ => Err(FlashError::OutOfBounds),
    }
}

impl ErrorType for SettingsFlash {
    type Error = FlashError;
}

impl ReadNorFlash for SettingsFlash {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        let start = checked(offset, bytes.len(), Self::READ_SIZE)?;
        let read = match &mut self.file {
            Some(file) => file.read_at(start, bytes).map_err(|_| FlashError::Io)?,
            None => 0,
        };
        // Beyond the file's end (the file shrank behind the flash's back) it is blank.
        if let Some(rest) = bytes.get_mut(read..) {
            rest.fill(ERASED);
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        CAPACITY as usize
    }
}

impl NorFlash for SettingsFlash {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE as usize;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let len = to.checked_sub(from).ok_or(FlashError::OutOfBounds)? as usize;
        let start = checked(from, len, Self::ERASE_SIZE)?;
        fill(self.file()?, start, start + len)
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let start = checked(offset, bytes.len(), Self::WRITE_SIZE)?;
        let file = self.file()?;
        let mut old = [ERASED; CHUNK];
        let mut at = start;
        for new in bytes.chunks(CHUNK) {
            let old = old.get_mut(..new.len()).ok_or(FlashError::Io)?;
            let read = file.read_at(at, old).map_err(|_| FlashError::Io)?;
            if let Some(rest) = old.get_mut(read..) {
                rest.fill(ERASED);
            }
            // NOR flash: a write clears bits, it never sets them.
            for (old, new) in old.iter_mut().zip(new) {
                *old &= new;
            }
            file.write_at(at, old).map_err(|_| FlashError::Io)?;
            at += new.len();
        }
        Ok(())
    }
}
