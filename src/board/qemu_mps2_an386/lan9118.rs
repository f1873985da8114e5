//! An embassy-net driver for the SMSC LAN9118 Ethernet controller (QEMU `-nic model=lan9118`).
//!
//! The LAN9118 is a MAC and PHY behind a block of 32-bit registers (here at 0x4020_0000,
//! IRQ 13). Frames move through FIFOs, one 32-bit word at a time, little-endian:
//!
//! - **Receive**: the controller stores each accepted frame in the RX data FIFO and one word
//!   in the RX status FIFO (length including the 4-byte CRC, error flags). The driver pops a
//!   status, then reads exactly the frame's words from the RX data port, so the next read
//!   starts at the next frame; frames with errors or of impossible sizes are read and dropped.
//! - **Transmit**: the driver writes TX command A (first and last segment, buffer length),
//!   TX command B (tag and frame length) and the frame's words to the TX data port; the
//!   controller sends when the last word arrives and pushes a word onto the TX status FIFO,
//!   which the driver pops (logging errors) so that it never fills.
//! - **MAC and PHY registers** are reached indirectly: MAC registers through MAC_CSR_CMD/DATA,
//!   the PHY's through the MAC's MII_ACC/MII_DATA.
//!
//! **Waking the stack.** The controller's interrupt (active high, push-pull) is enabled for
//! "RX status FIFO above level 0" and "PHY interrupt" (link down, auto-negotiation complete).
//! The handler masks the controller's interrupts (INT_EN = 0) and wakes the network runner;
//! the driver re-enables them each time it has nothing left to do, after clearing the status
//! bits and checking the FIFO once more, so a frame arriving in between is never missed and
//! no interrupt storm is possible.
//!
//! No path of the driver panics: a frame it cannot handle is dropped and logged.

use core::task::Context;

use embassy_net_driver::{Capabilities, Driver, HardwareAddress, LinkState, RxToken, TxToken};
use embassy_sync::waitqueue::AtomicWaker;

use log::{info, warn};

use super::interrupts::{self, Interrupt};
use super::mmio::Registers;

/// Largest Ethernet frame without CRC: 1500 bytes of payload and the 14-byte header.
pub const MAX_FRAME: usize = 1514;
/// Largest frame the RX FIFO hands over: a maximal frame and its CRC, in whole words.
const RX_BUFFER: usize = (MAX_FRAME + 4).next_multiple_of(4);
/// Smallest frame worth reading: an Ethernet header and the CRC.
const MIN_RX_FRAME: usize = 14 + 4;

// System control and status registers (LAN9118 datasheet, 5.3).
/// RX data FIFO port (0x00..0x1C all alias it).
const RX_DATA_FIFO: usize = 0x00;
/// TX data FIFO port (0x20..0x3C all alias it).
const TX_DATA_FIFO: usize = 0x20;
/// RX status FIFO port: reading pops one status word.
const RX_STATUS_FIFO: usize = 0x40;
/// TX status FIFO port: reading pops one status word.
const TX_STATUS_FIFO: usize = 0x48;
/// Chip ID and revision.
const ID_REV: usize = 0x50;
/// Interrupt pin configuration.
const IRQ_CFG: usize = 0x54;
/// Interrupt status; write 1 to clear.
const INT_STS: usize = 0x58;
/// Interrupt enable.
const INT_EN: usize = 0x5C;
/// Reads 0x8765_4321 whatever the bus's byte order.
const BYTE_TEST: usize = 0x64;
/// Receive configuration.
const RX_CFG: usize = 0x6C;
/// Transmit configuration.
const TX_CFG: usize = 0x70;
/// Hardware configuration, including the soft reset.
const HW_CFG: usize = 0x74;
/// RX FIFO information: used status words (23:16), used data bytes (15:0).
const RX_FIFO_INF: usize = 0x7C;
/// TX FIFO information: used status words (23:16), free data bytes (15:0).
const TX_FIFO_INF: usize = 0x80;
/// Power management control; bit 0 says the chip is ready after reset.
const PMT_CTRL: usize = 0x84;
/// MAC CSR command: busy, read, MAC register index.
const MAC_CSR_CMD: usize = 0xA4;
/// MAC CSR data.
const MAC_CSR_DATA: usize = 0xA8;
/// Size of the register block.
const BLOCK: usize = 0x100;

/// BYTE_TEST's fixed value.
const BYTE_TEST_VALUE: u32 = 0x8765_4321;
/// IRQ_CFG: the interrupt pin is enabled.
const IRQ_EN: u32 = 1 << 8;
/// IRQ_CFG: the interrupt is active high.
const IRQ_POL: u32 = 1 << 4;
/// IRQ_CFG: the pin is push-pull (rather than open drain).
const IRQ_TYPE: u32 = 1 << 0;
/// INT_STS/INT_EN: the RX status FIFO holds more words than its level (0): a frame arrived.
const RSFL_INT: u32 = 1 << 3;
/// INT_STS/INT_EN: the PHY raised its interrupt.
const PHY_INT: u32 = 1 << 18;
/// TX_CFG: transmitter on.
const TX_ON: u32 = 1 << 1;
/// TX_CFG: the TX status FIFO may overrun (sending never stalls on it).
const TXSAO: u32 = 1 << 2;
/// HW_CFG: soft reset, cleared by the chip when done.
const SRST: u32 = 1 << 0;
/// PMT_CTRL: the chip is ready.
const PMT_READY: u32 = 1 << 0;
/// MAC_CSR_CMD: the access is in progress.
const CSR_BUSY: u32 = 1 << 31;
/// MAC_CSR_CMD: the access is a read.
const CSR_READ: u32 = 1 << 30;
/// RX status: error summary (CRC, length, collision, runt, too long).
const RX_ERROR: u32 = 1 << 15;
/// TX status: error summary.
const TX_ERROR: u32 = 1 << 15;
/// TX command A: first segment of the frame.
const TX_FIRST_SEGMENT: u32 = 1 << 13;
/// TX command A: last segment of the frame.
const TX_LAST_SEGMENT: u32 = 1 << 12;

// MAC registers, reached through MAC_CSR_CMD (datasheet 5.4).
/// MAC control.
const MAC_CR: u8 = 1;
/// MAC address, bytes 4 and 5.
const MAC_ADDRH: u8 = 2;
/// MAC address, bytes 0 to 3.
const MAC_ADDRL: u8 = 3;
/// MII access: PHY address, register, write, busy.
const MII_ACC: u8 = 6;
/// MII data.
const MII_DATA: u8 = 7;
/// MAC_CR: receiver on.
const MAC_RXEN: u32 = 1 << 2;
/// MAC_CR: transmitter on.
const MAC_TXEN: u32 = 1 << 3;
/// MAC_CR: full duplex.
const MAC_FDPX: u32 = 1 << 20;
/// MII_ACC: the access is in progress.
const MII_BUSY: u32 = 1 << 0;
/// MII_ACC: the access is a write.
const MII_WRITE: u32 = 1 << 1;

// Registers of the internal PHY, at MII address 1 (datasheet 5.5).
/// MII address of the internal PHY.
const PHY_ADDRESS: u32 = 1;
/// Basic status.
const PHY_BSR: u32 = 1;
/// Interrupt source; reading clears it.
const PHY_ISR: u32 = 29;
/// Interrupt mask.
const PHY_IMR: u32 = 30;
/// BSR: the link is up.
const BSR_LINK_UP: u16 = 1 << 2;
/// ISR/IMR: auto-negotiation complete.
const PHY_INT_AUTONEG_COMPLETE: u16 = 1 << 6;
/// ISR/IMR: link down.
const PHY_INT_LINK_DOWN: u16 = 1 << 4;

/// How many register reads a busy flag may take before the driver gives up on the chip.
const BUSY_POLLS: u32 = 100_000;

/// The controller's registers on mps2-an386.
// SAFETY: 0x4020_0000 is the LAN9118's register block on mps2-an386 (0x100 bytes), used by
// this driver only.
const REGS: Registers = unsafe { Registers::new(0x4020_0000, BLOCK) };

/// The network runner's waker, woken by the controller's interrupt.
static WAKER: AtomicWaker = AtomicWaker::new();

/// Why the controller could not be brought up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InitError {
    /// BYTE_TEST did not read 0x8765_4321: no LAN9118 at the address.
    NotFound(u32),
    /// The soft reset or the chip's ready flag did not complete.
    ResetTimeout,
    /// A MAC or PHY register access stayed busy.
    RegisterTimeout,
}

/// A MAC or PHY register access that stayed busy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Busy;

/// The LAN9118, initialised and receiving, as an embassy-net [`Driver`].
pub struct Lan9118 {
    /// The station address, also programmed into the MAC's filter.
    mac: [u8; 6],
    /// Whether the PHY reported its link up when last asked.
    link_up: bool,
    /// Whether the PHY must be asked again (at start, and after a PHY interrupt).
    link_unknown: bool,
    /// The frame handed to the stack by the last [`RxToken`].
    rx: [u8; RX_BUFFER],
    /// The frame the stack is building in a [`TxToken`].
    tx: [u8; MAX_FRAME],
}

impl Lan9118 {
    /// Resets the controller and starts it with station address `mac`: receiver and
    /// transmitter on, unicast to `mac` and broadcast accepted, interrupt enabled.
    pub fn new(mac: [u8; 6]) -> Result<Self, InitError> {
        let byte_test = REGS.read(BYTE_TEST);
        if byte_test != BYTE_TEST_VALUE {
            return Err(InitError::NotFound(byte_test));
        }
        REGS.write(HW_CFG, SRST);
        if !poll_until(|| REGS.read(HW_CFG) & SRST == 0)
            || !poll_until(|| REGS.read(PMT_CTRL) & PMT_READY != 0)
        {
            return Err(InitError::ResetTimeout);
        }
        info!("LAN9118 found: ID_REV {:x}", REGS.read(ID_REV));

        // Interrupts off until the driver asks for them; the pin active high, as the NVIC
        // expects (QEMU models the reset default, active low, as a line held high).
        REGS.write(INT_EN, 0);
        REGS.write(INT_STS, u32::MAX);
        REGS.write(IRQ_CFG, IRQ_EN | IRQ_POL | IRQ_TYPE);

        let configured = (|| -> Result<(), Busy> {
            mac_write(
                MAC_ADDRL,
                u32::from_le_bytes([mac[0], mac[1], mac[2], mac[3]]),
            )?;
            mac_write(MAC_ADDRH, u32::from_le_bytes([mac[4], mac[5], 0, 0]))?;
            phy_write(PHY_IMR, PHY_INT_LINK_DOWN | PHY_INT_AUTONEG_COMPLETE)?;
            // Reading the interrupt source clears what the reset left there.
            phy_read(PHY_ISR)?;
            // No promiscuous mode (the reset default): unicast to us and broadcast only.
            mac_write(MAC_CR, MAC_TXEN | MAC_RXEN | MAC_FDPX)
        })();
        if configured.is_err() {
            return Err(InitError::RegisterTimeout);
        }
        // Frames start at the first byte of a word and end without padding.
        REGS.write(RX_CFG, 0);
        REGS.write(TX_CFG, TX_ON | TXSAO);

        interrupts::unmask(Interrupt::Ethernet);
        Ok(Self {
            mac,
            link_up: false,
            link_unknown: true,
            rx: [0; RX_BUFFER],
            tx: [0; MAX_FRAME],
        })
    }

    /// Reads the next good frame into the RX buffer; returns its length without the CRC.
    /// Frames with errors or impossible lengths are drained from the FIFO and dropped.
    fn read_frame(&mut self) -> Option<usize> {
        while rx_frames_waiting() {
            let status = REGS.read(RX_STATUS_FIFO);
            // The length includes the 4-byte CRC.
            let length = ((status >> 16) & 0x3FFF) as usize;
            let words = length.div_ceil(4);
            if status & RX_ERROR != 0 || !(MIN_RX_FRAME..=RX_BUFFER).contains(&length) {
                warn!(
                    "LAN9118: dropped a received frame (status {:x}, {} bytes)",
                    status, length
                );
                for _ in 0..words {
                    REGS.read(RX_DATA_FIFO);
                }
                continue;
            }
            // `length` is at most RX_BUFFER, a whole number of words: every word has a place.
            for word in self.rx.as_chunks_mut::<4>().0.iter_mut().take(words) {
                *word = REGS.read(RX_DATA_FIFO).to_le_bytes();
            }
            return Some(length - 4);
        }
        None
    }

    /// Asks the controller to interrupt on the next frame or PHY event, with `cx`'s waker to
    /// wake. Returns whether a frame arrived meanwhile.
    fn arm(&self, cx: &mut Context) -> bool {
        WAKER.register(cx.waker());
        REGS.write(INT_STS, RSFL_INT);
        REGS.write(INT_EN, RSFL_INT | PHY_INT);
        rx_frames_waiting()
    }
}

/// Whether the RX status FIFO holds a frame's status.
fn rx_frames_waiting() -> bool {
    (REGS.read(RX_FIFO_INF) >> 16) & 0xFF != 0
}

/// Calls `done` until it returns `true`, at most [`BUSY_POLLS`] times.
fn poll_until(mut done: impl FnMut() -> bool) -> bool {
    (0..BUSY_POLLS).any(|_| done())
}

/// Waits for the MAC CSR interface to be idle.
fn mac_idle() -> Result<(), Busy> {
    if poll_until(|| REGS.read(MAC_CSR_CMD) & CSR_BUSY == 0) {
        Ok(())
    } else {
        Err(Busy)
    }
}

/// Writes MAC register `register`.
fn mac_write(register: u8, value: u32) -> Result<(), Busy> {
    mac_idle()?;
    REGS.write(MAC_CSR_DATA, value);
    REGS.write(MAC_CSR_CMD, CSR_BUSY | u32::from(register));
    mac_idle()
}

/// Reads MAC register `register`.
fn mac_read(register: u8) -> Result<u32, Busy> {
    mac_idle()?;
    REGS.write(MAC_CSR_CMD, CSR_BUSY | CSR_READ | u32::from(register));
    mac_idle()?;
    Ok(REGS.read(MAC_CSR_DATA))
}

/// Waits for the MII interface to be idle.
fn mii_idle() -> Result<(), Busy> {
    for _ in 0..BUSY_POLLS {
        if mac_read(MII_ACC)? & MII_BUSY == 0 {
            return Ok(());
        }
    }
    Err(Busy)
}

/// The MII_ACC value that accesses PHY register `register`.
fn mii_access(register: u32) -> u32 {
    (PHY_ADDRESS << 11) | ((register & 0x1F) << 6) | MII_BUSY
}

/// Reads PHY register `register`.
fn phy_read(register: u32) -> Result<u16, Busy> {
    mii_idle()?;
    mac_write(MII_ACC, mii_access(register))?;
    mii_idle()?;
    Ok((mac_read(MII_DATA)? & 0xFFFF) as u16)
}

/// Writes PHY register `register`.
fn phy_write(register: u32, value: u16) -> Result<(), Busy> {
    mii_idle()?;
    mac_write(MII_DATA, u32::from(value))?;
    mac_write(MII_ACC, mii_access(register) | MII_WRITE)?;
    mii_idle()
}

/// The controller's interrupt handler: masks the controller's interrupts and wakes the
/// network runner, which re-enables them when it has handled everything.
// SAFETY: the name is the one the vector table (interrupts.rs) and device.x expect; nothing
// else defines it.
#[unsafe(no_mangle)]
#[allow(non_snake_case)]
extern "C" fn ETHERNET() {
    REGS.write(INT_EN, 0);
    WAKER.wake();
}

impl Driver for Lan9118 {
    type RxToken<'a>
        = Lan9118Rx<'a>
    where
        Self: 'a;
    type TxToken<'a>
        = Lan9118Tx<'a>
    where
        Self: 'a;

    fn receive(&mut self, cx: &mut Context) -> Option<(Self::RxToken<'_>, Self::TxToken<'_>)> {
        let length = match self.read_frame() {
            Some(length) => length,
            None if self.arm(cx) => self.read_frame()?,
            None => return None,
        };
        let frame = self.rx.get_mut(..length)?;
        Some((
            Lan9118Rx { frame },
            Lan9118Tx {
                frame: &mut self.tx,
            },
        ))
    }

    fn transmit(&mut self, cx: &mut Context) -> Option<Self::TxToken<'_>> {
        if tx_space() < MAX_FRAME + 8 {
            // QEMU sends each frame as its last word arrives, so this never happens there;
            // on a chip, retry on the next poll rather than rely on FIFO level interrupts.
            cx.waker().wake_by_ref();
            return None;
        }
        Some(Lan9118Tx {
            frame: &mut self.tx,
        })
    }

    fn link_state(&mut self, cx: &mut Context) -> LinkState {
        if self.link_unknown || REGS.read(INT_STS) & PHY_INT != 0 {
            // Reading ISR clears the PHY's interrupt; then BSR has the current state.
            let state = phy_read(PHY_ISR).and_then(|_| phy_read(PHY_BSR));
            REGS.write(INT_STS, PHY_INT);
            match state {
                Ok(bsr) => {
                    let up = bsr & BSR_LINK_UP != 0;
                    if up != self.link_up || self.link_unknown {
                        info!("Ethernet link {}", if up { "up" } else { "down" });
                    }
                    self.link_up = up;
                    self.link_unknown = false;
                }
                Err(Busy) => {
                    warn!("LAN9118: PHY status unreadable; link taken as down");
                    self.link_up = false;
                }
            }
        }
        if self.arm(cx) {
            // A frame arrived meanwhile, and arming cleared its interrupt: poll again.
            cx.waker().wake_by_ref();
        }
        if self.link_up {
            LinkState::Up
        } else {
            LinkState::Down
        }
    }

    fn capabilities(&self) -> Capabilities {
        let mut capabilities = Capabilities::default();
        capabilities.max_transmission_unit = MAX_FRAME;
        capabilities
    }

    fn hardware_address(&self) -> HardwareAddress {
        HardwareAddress::Ethernet(self.mac)
    }
}

/// Free bytes in the TX data FIFO.
fn tx_space() -> usize {
    (REGS.read(TX_FIFO_INF) & 0xFFFF) as usize
}

/// A received frame, read out of the RX FIFO.
pub struct Lan9118Rx<'a> {
    /// The frame, without its CRC.
    frame: &'a mut [u8],
}

impl RxToken for Lan9118Rx<'_> {
    fn consume<R, F>(self, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> R,
    {
        f(self.frame)
    }
}

/// Room for one frame to send.
pub struct Lan9118Tx<'a> {
    /// The buffer the stack fills.
    frame: &'a mut [u8; MAX_FRAME],
}

impl TxToken for Lan9118Tx<'_> {
    fn consume<R, F>(self, len: usize, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> R,
    {
        // The stack never asks for more than the MTU; a longer request gets a short buffer
        // and its frame is dropped below, rather than a panic.
        let fits = len <= MAX_FRAME;
        let length = len.min(MAX_FRAME);
        let (frame, _) = self.frame.split_at_mut(length);
        let result = f(frame);
        if !fits {
            warn!(
                "LAN9118: dropped a {}-byte frame (longer than {})",
                len, MAX_FRAME
            );
        } else if tx_space() < length + 8 {
            warn!("LAN9118: dropped a frame: TX FIFO full");
        } else {
            send(frame);
        }
        result
    }
}

/// Writes one frame to the TX FIFO, which sends it, and pops the TX status words.
fn send(frame: &[u8]) {
    // Lengths are at most MAX_FRAME, so they fit the 11-bit fields.
    let length = (frame.len() & 0x7FF) as u32;
    REGS.write(TX_DATA_FIFO, TX_FIRST_SEGMENT | TX_LAST_SEGMENT | length);
    // The tag (upper half) comes back in the TX status; the length is the frame's.
    REGS.write(TX_DATA_FIFO, (length << 16) | length);
    let (words, rest) = frame.as_chunks::<4>();
    for word in words {
        REGS.write(TX_DATA_FIFO, u32::from_le_bytes(*word));
    }
    if !rest.is_empty() {
        let mut last = [0u8; 4];
        for (to, from) in last.iter_mut().zip(rest) {
            *to = *from;
        }
        REGS.write(TX_DATA_FIFO, u32::from_le_bytes(last));
    }
    while (REGS.read(TX_FIFO_INF) >> 16) & 0xFF != 0 {
        let status = REGS.read(TX_STATUS_FIFO);
        if status & TX_ERROR != 0 {
            warn!("LAN9118: a frame failed to send (status {:x})", status);
        }
    }
}
