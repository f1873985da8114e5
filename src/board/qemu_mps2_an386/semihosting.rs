//! Semihosting: the board's log, command line, exit status and host files, served by QEMU
//! (`-semihosting-config enable=on,target=native`).
//!
//! Logs go to QEMU's standard output, one semihosting write per line. Info lines are the
//! message alone, so the virtual panel's `led link on` lines read exactly so; other levels
//! start with the level (`warning: …`). A panic prints `panic: <message>` and ends QEMU with
//! a failure status, as does a hard fault.

use core::cell::Cell;
use core::ffi::CStr;
use core::fmt::{self, Write as _};
use core::panic::PanicInfo;

use cortex_m_rt::{ExceptionFrame, exception};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
use cortex_m_semihosting::hio::{self, HostStream};
use cortex_m_semihosting::{nr, syscall};
use critical_section::{CriticalSection, Mutex};
use log::{Level, LevelFilter, Log, Metadata, Record};

/// The host's standard output, once opened.
static STDOUT: Mutex<Cell<Option<HostStream>>> = Mutex::new(Cell::new(None));

/// Longest piece of a line written in one semihosting call; longer lines take several.
const LINE: usize = 192;

/// One line of output, collected so that it reaches the host in one write and is not
/// interleaved with another (it is written inside a critical section).
struct Line<'cs> {
    /// The critical section the line is written in.
    cs: CriticalSection<'cs>,
    /// Text not yet written.
    buf: [u8; LINE],
    /// How much of `buf` is used.
    len: usize,
}

impl<'cs> Line<'cs> {
    /// An empty line.
    fn new(cs: CriticalSection<'cs>) -> Self {
        Self {
            cs,
            buf: [0; LINE],
            len: 0,
        }
    }

    /// Writes what is collected to the host's standard output, opened on first use. Output
    /// is lost, silently, if the host refuses it: there is nowhere to report that.
    fn flush(&mut self) {
        let stdout = STDOUT.borrow(self.cs);
        let stream = stdout.get().or_else(|| hio::hstdout().ok());
        stdout.set(stream);
        if let (Some(mut stream), Some(text)) = (stream, self.buf.get(..self.len)) {
            let _ = stream.write_all(text);
        }
        self.len = 0;
    }

    /// Ends the line and writes it.
    fn finish(mut self) {
        let _ = self.write_str("\n");
        self.flush();
    }
}

impl fmt::Write for Line<'_> {
    fn write_str(&mut self, text: &str) -> fmt::Result {
        for &byte in text.as_bytes() {
            if self.len == LINE {
                self.flush();
            }
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = byte;
                self.len += 1;
            }
        }
        Ok(())
    }
}

/// Prints one line on the host's standard output.
pub fn print_line(args: fmt::Arguments<'_>) {
    critical_section::with(|cs| {
        let mut line = Line::new(cs);
        let _ = line.write_fmt(args);
        line.finish();
    });
}

/// The `log` back end of the QEMU board.
struct Logger;

impl Log for Logger {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        metadata.level() <= log::max_level()
    }

    fn log(&self, record: &Record<'_>) {
        if !self.enabled(record.metadata()) {
            return;
        }
        let prefix = match record.level() {
            Level::Info => "",
            Level::Error => "error: ",
            Level::Warn => "warning: ",
            Level::Debug => "debug: ",
            Level::Trace => "trace: ",
        };
        print_line(format_args!("{prefix}{}", record.args()));
    }

    fn flush(&self) {}
}

/// The logger, for `log::set_logger`.
static LOGGER: Logger = Logger;

/// Sends the `log` crate's records at `level` and above to the host.
pub fn init_logging(level: LevelFilter) {
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(level);
    }
}

/// The command line QEMU was given for the program (`-semihosting-config …,arg=…`), its
/// arguments separated by spaces, read into `buf`; `None` if the host has none or it does not
/// fit.
pub fn command_line(buf: &mut [u8]) -> Option<&str> {
    // SYS_GET_CMDLINE takes a block of two words, the buffer's address and size, and
    // replaces the size with the length of the text it wrote (without its NUL).
    let mut block = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: the block and the buffer it names are valid for writes for the duration of
    // the call, and the host writes at most `buf.len()` bytes into the buffer.
    let status =
        unsafe { cortex_m_semihosting::syscall1(nr::GET_CMDLINE, block.as_mut_ptr() as usize) };
    if status != 0 {
        return None;
    }
    let text = buf.get(..block[1].min(buf.len()))?;
    core::str::from_utf8(text).ok()
}

/// A host file operation failed (the host's reason is not kept: nothing here could act on it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HostError;

/// A file on the host, open for reading and writing; closed when dropped.
#[derive(Debug)]
pub struct HostFile {
    /// The host's handle.
    handle: usize,
}

impl HostFile {
    /// Opens the file at `path` for reading and writing at any offset, creating it empty if
    /// it does not exist; an existing file keeps its contents.
    pub fn open(path: &CStr) -> Result<Self, HostError> {
        if let Ok(file) = Self::open_as(path, nr::open::RW_BINARY) {
            return Ok(file);
        }
        // Mode "r+b" does not create; "ab" creates without truncating, but would write at the
        // end only. So create (or leave alone) with "ab", close, and open with "r+b" again.
        drop(Self::open_as(path, nr::open::W_APPEND_BINARY)?);
        Self::open_as(path, nr::open::RW_BINARY)
    }

    /// SYS_OPEN: `path` in `mode` (an fopen mode number).
    fn open_as(path: &CStr, mode: usize) -> Result<Self, HostError> {
        let name = path.to_bytes();
        // SAFETY: SYS_OPEN reads the NUL-terminated name (its length given without the NUL),
        // which lives for the duration of the call.
        let handle = unsafe { syscall!(OPEN, name.as_ptr(), mode, name.len()) };
        // -1 (as an unsigned word) is the host's error.
        match isize::try_from(handle) {
            Ok(_) => Ok(Self { handle }),
            Err(_) => Err(HostError),
        }
    }

    /// The file's size in bytes.
    pub fn size(&self) -> Result<usize, HostError> {
        // SAFETY: SYS_FLEN reads only the handle.
        let size = unsafe { syscall!(FLEN, self.handle) };
        // -1 (as an unsigned word) is the host's error.
        match isize::try_from(size) {
            Ok(_) => Ok(size),
            Err(_) => Err(HostError),
        }
    }

    /// Moves the file position to `offset` bytes from the start.
    fn seek(&mut self, offset: usize) -> Result<(), HostError> {
        // SAFETY: SYS_SEEK reads only the handle and the position.
        let status = unsafe { syscall!(SEEK, self.handle, offset) };
        if status == 0 { Ok(()) } else { Err(HostError) }
    }

    /// Reads into `buf` from `offset`; the number of bytes read, less than `buf.len()` only at
    /// the end of the file.
    pub fn read_at(&mut self, offset: usize, buf: &mut [u8]) -> Result<usize, HostError> {
        self.seek(offset)?;
        // SAFETY: SYS_READ writes at most `buf.len()` bytes into `buf`, which is valid for
        // writes for the duration of the call.
        let missing = unsafe { syscall!(READ, self.handle, buf.as_mut_ptr(), buf.len()) };
        // The host answers with the number of bytes it did *not* read.
        buf.len().checked_sub(missing).ok_or(HostError)
    }

    /// Writes all of `data` at `offset`.
    pub fn write_at(&mut self, offset: usize, data: &[u8]) -> Result<(), HostError> {
        self.seek(offset)?;
        // SAFETY: SYS_WRITE reads `data.len()` bytes from `data`, valid for the duration of
        // the call.
        let missing = unsafe { syscall!(WRITE, self.handle, data.as_ptr(), data.len()) };
        // The host answers with the number of bytes it did *not* write; a short write is a
        // full disk or an I/O error, not worth retrying.
        if missing == 0 { Ok(()) } else { Err(HostError) }
    }
}

impl Drop for HostFile {
    fn drop(&mut self) {
        // SAFETY: SYS_CLOSE reads only the handle, which is not used again. Nothing can be
        // done about a failed close.
        let _ = unsafe { syscall!(CLOSE, self.handle) };
    }
}

/// Ends the QEMU run with status 0 (`success`) or 1.
pub fn exit(success: bool) -> ! {
    debug::exit(if success { EXIT_SUCCESS } else { EXIT_FAILURE });
    // Only reached if the host lets the program go on: stay here.
    loop {
        cortex_m::asm::wfi();
    }
}

/// Prints `panic: <message>` and where, then ends QEMU with a failure status.
#[panic_handler]
fn panic(info: &PanicInfo<'_>) -> ! {
    cortex_m::interrupt::disable();
    print_line(format_args!("panic: {}", info.message()));
    if let Some(location) = info.location() {
        print_line(format_args!("  at {}:{}", location.file(), location.line()));
    }
    exit(false)
}

/// A hard fault (bad memory access, undefined instruction, …) ends QEMU with a failure
/// status rather than hanging.
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    print_line(format_args!("hard fault at pc {:#010x}", frame.pc()));
    exit(false)
}
