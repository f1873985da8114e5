//! ST NUCLEO-F767ZI: STM32F767ZI at 216 MHz, on-board LAN8742A Ethernet PHY, three user LEDs.

use defmt::info;
use embassy_executor::Spawner;
use embassy_stm32::Config;
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::rcc::{
    AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllQDiv, PllSource,
    Sysclk, mux,
};
use embassy_stm32::time::Hertz;
use embassy_time::Timer;
// Linked for their side effects only: the defmt RTT transport and the panic handler, which
// prints the panic message over defmt and halts the probe session with an error.
use {defmt_rtt as _, panic_probe as _};

// Log lines carry the uptime in microseconds. Defined here rather than by embassy-time's
// `defmt-timestamp-uptime` feature, which would put defmt into every board's image.
defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_micros());

/// The peripherals the application uses, configured and ready.
pub struct Board {
    /// Green user LED LD1 (PB0): state of the link to the robot.
    pub link: Output<'static>,
    /// Blue user LED LD2 (PB7): commands sent, navigation task running.
    pub activity: Output<'static>,
    /// Red user LED LD3 (PB14): robot or panel fault.
    pub fault: Output<'static>,
}

/// Brings the board up and runs until reset.
///
/// Until the board's Ethernet exists, this is the firmware skeleton: a lamp test, then the
/// link LED blinking at 1 Hz.
pub async fn run(_spawner: Spawner) -> ! {
    let mut board = init();
    info!("x30-panel {} starting", env!("CARGO_PKG_VERSION"));

    // Lamp test: every LED on for half a second, so a dead LED is noticed at power-up rather
    // than mistaken for "no fault" later.
    board.link.set_high();
    board.activity.set_high();
    board.fault.set_high();
    Timer::after_millis(500).await;
    board.activity.set_low();
    board.fault.set_low();

    // Blink the link LED at 1 Hz so a human sees the firmware is alive and the clock
    // configuration (hence the timer rate) is right.
    loop {
        board.link.toggle();
        Timer::after_millis(500).await;
    }
}

/// Configures clocks and pins; call once, first thing in `run`.
pub fn init() -> Board {
    let p = embassy_stm32::init(clock_config());

    // The LEDs are active high; all start off so that a lit LED always means something.
    Board {
        link: Output::new(p.PB0, Level::Low, Speed::Low),
        activity: Output::new(p.PB7, Level::Low, Speed::Low),
        fault: Output::new(p.PB14, Level::Low, Speed::Low),
    }
}

/// Clock tree: 216 MHz system clock (the F767's maximum) from the ST-LINK's 8 MHz MCO.
fn clock_config() -> Config {
    let mut config = Config::default();
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
