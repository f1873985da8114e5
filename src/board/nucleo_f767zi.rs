//! ST NUCLEO-F767ZI (MB1137): STM32F767ZI at 216 MHz, on-board LAN8742A Ethernet PHY, three
//! user LEDs, ST-LINK for flashing, defmt logs over RTT and the serial console.
//!
//! - **Settings**: loaded at start-up, before anything runs on them, from flash sectors 1
//!   and 2 (0x0800_8000..0x0801_8000) over the build-time defaults ([`settings_flash`]).
//! - **Console**: USART3 on PD8/PD9, the ST-LINK's virtual COM port, 115200 8N1
//!   ([`console`]): shows, changes and saves the settings.
//! - **Network**: the STM32's Ethernet MAC in RMII mode with the LAN8742A at PHY address 0,
//!   under embassy-net: DHCP, or the static address the settings give, a random seed from
//!   the RNG, and three TCP connections to the robot ([`super::net`]). The MAC address is
//!   locally administered and derived from the chip's unique ID, so it is stable per board
//!   (DHCP reservations work) and unique between boards.
//! - **Web page**: the status and settings page on port 80 ([`super::web`]); its address is
//!   logged when the network comes up.
//! - **Buttons**: 15 GPIO inputs with the MCU's pull-ups, pressed = low (a button connects its
//!   pin to GND), sampled every 2 ms and debounced ([`buttons`]). The `estop` switch may be
//!   wired normally closed instead (setting `estop-input nc`): then a broken wire reads as
//!   pressed.
//! - **LEDs**: LD1 green = link, LD2 blue = activity, LD3 red = fault ([`leds`]).
//! - **Watchdog**: the IWDG, 1.5 s, fed only while both the button task and the command loop
//!   show progress ([`watchdog`]), and around each erase of a settings sector, which stops
//!   the CPU for up to 0.8 s.
//!
//! # Pin map
//!
//! All 15 buttons sit on the right-hand column of the Zio connector CN10 (the even pins),
//! with a GND pin (CN10-22) among them for the common return. None of these pins is used by
//! the Ethernet RMII (PA1, PA2, PA7, PB13, PC1, PC4, PC5, PG11, PG13), the console (USART3,
//! PD8/PD9, the ST-LINK's virtual COM port), USB OTG FS (PA8–PA12, PG6, PG7), the user LEDs
//! (PB0, PB7, PB14), the user button (PC13), SWD/SWO (PA13, PA14, PB3) or the oscillators
//! (PH0, PH1, PC14, PC15).
//!
//! | button | pin | CN10 pin | Zio label |
//! |---|---|---|---|
//! | `forward` | PF13 | 2 | D7 |
//! | `backward` | PE9 | 4 | D6 |
//! | `turn-left` | PE11 | 6 | D5 |
//! | `turn-right` | PF14 | 8 | D4 |
//! | `strafe-left` | PE13 | 10 | D3 |
//! | `strafe-right` | PF15 | 12 | D2 |
//! | `stop` | PG14 | 14 | D1 |
//! | `estop` | PG9 | 16 | D0 |
//! | `stop-stepping` | PE8 | 18 | D42 |
//! | `lie-down` | PE7 | 20 | D41 |
//! | (common) | GND | 22 | GND |
//! | `gait` | PE10 | 24 | D40 |
//! | `light` | PE12 | 26 | D39 |
//! | `dock` | PE14 | 28 | D38 |
//! | `cancel` | PE15 | 30 | D37 |
//! | `patrol` | PB10 | 32 | D36 |
//!
//! | LED | pin | shows |
//! |---|---|---|
//! | LD1 green | PB0 | link: off — no network; blinking — connecting to the robot; on — connected |
//! | LD2 blue | PB7 | activity: a flash per command; steady while a navigation task runs |
//! | LD3 red | PB14 | fault: on — the robot reports a fault; blinking — status unreadable or the last command failed |
//!
//! | console | pin | connected to |
//! |---|---|---|
//! | USART3 TX | PD8 | the ST-LINK's virtual COM port (the board's default solder bridges) |
//! | USART3 RX | PD9 | the ST-LINK's virtual COM port (the board's default solder bridges) |
//!
//! D0/D1 (PG9/PG14) are USART6 on Arduino shields, not the console, which is USART3 on
//! PD8/PD9; a shield must not drive them.

mod buttons;
mod console;
mod leds;
mod settings_flash;
mod watchdog;

use defmt::{info, unwrap};
use embassy_executor::Spawner;
use embassy_net::{Runner, StackResources};
use embassy_stm32::eth::{self, Ethernet, GenericPhy, PacketQueue, Sma};
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::peripherals::{ETH, ETH_SMA, RNG, USART3};
use embassy_stm32::rcc::{
    self, AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllQDiv,
    PllSource, Sysclk, mux,
};
use embassy_stm32::rng::{self, Rng};
use embassy_stm32::time::Hertz;
use embassy_stm32::usart::BufferedInterruptHandler;
use embassy_stm32::{Config as HalConfig, bind_interrupts, uid};
use static_cell::ConstStaticCell;
use x30_panel::config::Config;
use x30_panel::settings::store::Store;
// Linked for their side effects only: the defmt RTT transport and the panic handler, which
// prints the panic message over defmt and halts the probe session with an error. Without a
// probe the halted core stops feeding the watchdog, which resets the board.
use {defmt_rtt as _, panic_probe as _};

use self::buttons::{Buttons, button_task};
use self::console::console_task;
use self::leds::{Leds, led_task};
use self::settings_flash::SettingsFlash;
use self::watchdog::watchdog_task;
use super::glue;
use super::net::{self, SOCKETS};
use super::web;

// Log lines carry the uptime in microseconds. Defined here rather than by embassy-time's
// `defmt-timestamp-uptime` feature, which would put defmt into every board's image.
defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_micros());

bind_interrupts!(struct Irqs {
    ETH => eth::InterruptHandler;
    RNG => rng::InterruptHandler<RNG>;
    USART3 => BufferedInterruptHandler<USART3>;
});

/// The LAN8742A's SMI (MDIO) address on the Nucleo-144 boards, as ST's own examples use it.
const PHY_ADDRESS: u8 = 0;

/// Ethernet DMA descriptors (and frame buffers) for sending: four 1.5 KiB frames.
const TX_FRAMES: usize = 4;
/// Ethernet DMA descriptors (and frame buffers) for receiving: four 1.5 KiB frames, enough
/// for the robot's largest answer (about 1.2 KiB) plus ARP and DHCP traffic meanwhile.
const RX_FRAMES: usize = 4;

/// The Ethernet driver with the LAN8742A driven through the MAC's management interface.
type Device = Ethernet<'static, ETH, GenericPhy<Sma<'static, ETH_SMA>>>;

/// The Ethernet DMA's descriptors and frame buffers (zeroed, so in `.bss`).
static PACKETS: ConstStaticCell<PacketQueue<TX_FRAMES, RX_FRAMES>> =
    ConstStaticCell::new(PacketQueue::new());

/// The network stack's memory.
static RESOURCES: ConstStaticCell<StackResources<SOCKETS>> =
    ConstStaticCell::new(StackResources::new());

/// Brings the board up and runs the panel, forever.
pub async fn run(spawner: Spawner) -> ! {
    let p = embassy_stm32::init(clock_config());
    info!("x30-panel {} on NUCLEO-F767ZI", env!("CARGO_PKG_VERSION"));
    watchdog::log_reset_cause();
    let dog = watchdog::start(p.IWDG);

    // The settings first: the network, the buttons and the application run on them. The
    // core's cycle counter times the flash erases, which stop embassy's clock.
    let mut core = unwrap!(cortex_m::Peripherals::take());
    let sysclk = unwrap!(rcc::clocks(&p.RCC).sys.to_hertz());
    let flash = SettingsFlash::new(p.FLASH, &mut core.DCB, core.DWT, sysclk);
    let mut store = Store::new(flash, settings_flash::RANGE).with_erase_gate(glue::erase_allowed);
    let (settings, problem) = glue::load_settings(&mut store, Config::from_build_env()).await;
    // The console keeps the settings; the rest of the board runs on this copy.
    let config = settings.config().clone();
    let (console_rx, console_tx) = console::open(p.USART3, p.PD8, p.PD9);

    // The LEDs are active high; all start off so that a lit LED always means something.
    let leds = Leds {
        link: Output::new(p.PB0, Level::Low, Speed::Low),
        activity: Output::new(p.PB7, Level::Low, Speed::Low),
        fault: Output::new(p.PB14, Level::Low, Speed::Low),
    };
    // In the order of `Button::ALL`; the pin map in the module docs lists the same.
    let buttons = Buttons::new([
        p.PF13.into(), // forward
        p.PE9.into(),  // backward
        p.PE11.into(), // turn-left
        p.PF14.into(), // turn-right
        p.PE13.into(), // strafe-left
        p.PF15.into(), // strafe-right
        p.PG14.into(), // stop
        p.PG9.into(),  // estop
        p.PE8.into(),  // stop-stepping
        p.PE7.into(),  // lie-down
        p.PE10.into(), // gait
        p.PE12.into(), // light
        p.PE14.into(), // dock
        p.PE15.into(), // cancel
        p.PB10.into(), // patrol
    ]);

    // The seed picks TCP ports and initial sequence numbers: after a reset, the robot must not
    // mistake a new connection for the old one.
    let seed = Rng::new(p.RNG, Irqs).next_u64();
    let mac = mac_address();
    info!(
        "MAC {=u8:02x}:{=u8:02x}:{=u8:02x}:{=u8:02x}:{=u8:02x}:{=u8:02x}",
        mac[0], mac[1], mac[2], mac[3], mac[4], mac[5]
    );
    let phy = GenericPhy::new(Sma::new(p.ETH_SMA, p.PA2, p.PC1), PHY_ADDRESS);
    let device: Device = Ethernet::new_with_phy(
        PACKETS.take(),
        p.ETH,
        Irqs,
        p.PA1,  // REF_CLK
        p.PA7,  // CRS_DV
        p.PC4,  // RXD0
        p.PC5,  // RXD1
        p.PG13, // TXD0
        p.PB13, // TXD1
        p.PG11, // TX_EN
        mac,
        phy,
    );
    let (stack, runner) = embassy_net::new(
        device,
        net::stack_config(config.network()),
        RESOURCES.take(),
        seed,
    );

    // Each task is spawned once: a failure is a bug, and the panic stops the firmware (and
    // the halted core stops feeding the watchdog, which resets the board).
    spawner.spawn(unwrap!(watchdog_task(dog, glue::shared())));
    spawner.spawn(unwrap!(network_task(runner)));
    spawner.spawn(unwrap!(glue::network_watch_task(stack)));
    spawner.spawn(unwrap!(led_task(leds, glue::shared())));
    spawner.spawn(unwrap!(button_task(
        buttons,
        config.debounce,
        config.estop_input,
        glue::shared()
    )));
    spawner.spawn(unwrap!(console_task(
        console_rx, console_tx, store, settings, problem
    )));
    unwrap!(web::spawn(spawner, stack));

    glue::run_app(stack, &config).await
}

/// A locally administered, unicast MAC address derived from the chip's 96-bit unique ID:
/// the same on every start of one board, different between boards (with the odds of a
/// 40-bit hash).
fn mac_address() -> [u8; 6] {
    // FNV-1a: spreads the ID's few varying bits (wafer position, lot) over all bytes.
    let hash = uid::uid().iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    });
    let [h0, h1, h2, h3, h4, ..] = hash.to_le_bytes();
    // 0x02: locally administered (bit 1), unicast (bit 0 clear).
    [0x02, h0, h1, h2, h3, h4]
}

/// Runs the network stack: the Ethernet driver, ARP, DHCP and TCP.
#[embassy_executor::task]
async fn network_task(mut runner: Runner<'static, Device>) -> ! {
    runner.run().await
}

/// Clock tree: 216 MHz system clock (the F767's maximum) from the ST-LINK's 8 MHz MCO.
fn clock_config() -> HalConfig {
    let mut config = HalConfig::default();
    let rcc = &mut config.rcc;
    // The Nucleo has no HSE crystal fitted (X3); the ST-LINK drives 8 MHz into OSC_IN, so the
    // oscillator must be bypassed.
    rcc.hse = Some(Hse {
        freq: Hertz(8_000_000),
        mode: HseMode::Bypass,
    });
    rcc.pll_src = PllSource::HSE;
    rcc.pll = Some(Pll {
        // 2 MHz PLL input is what RM0410 recommends to limit PLL jitter.
        prediv: PllPreDiv::DIV4,
        // VCO 432 MHz.
        mul: PllMul::MUL216,
        // 432 / 2 = 216 MHz system clock.
        divp: Some(PllPDiv::DIV2),
        // 432 / 9 = 48 MHz for the RNG (network stack seed) and USB, which require exactly it.
        divq: Some(PllQDiv::DIV9),
        divr: None,
    });
    rcc.sys = Sysclk::PLL1_P;
    rcc.ahb_pre = AHBPrescaler::DIV1;
    // APB1 may run at most 54 MHz and APB2 at most 108 MHz.
    rcc.apb1_pre = APBPrescaler::DIV4;
    rcc.apb2_pre = APBPrescaler::DIV2;
    rcc.mux.clk48sel = mux::Clk48sel::PLL1_Q;
    config
}
