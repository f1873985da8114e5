//! The three user LEDs, showing what the application publishes in `Shared::indicators`.

use embassy_futures::select::{Either, select};
use embassy_stm32::gpio::Output;
use embassy_time::{Instant, Timer};
use x30_panel::app::Shared;
use x30_panel::panel::indicators::FAST_BLINK_HALF_PERIOD;
use x30_panel::panel::{Indicators, Led};

/// How long every LED lights at power-up.
const LAMP_TEST_MS: u64 = 500;

/// The user LEDs, all active high.
pub struct Leds {
    /// Green LD1 (PB0): the link to the robot.
    pub link: Output<'static>,
    /// Blue LD2 (PB7): commands sent, navigation task running.
    pub activity: Output<'static>,
    /// Red LD3 (PB14): robot or panel fault.
    pub fault: Output<'static>,
}

impl Leds {
    /// Lights or darkens each LED as `shown` says at `now`.
    fn show(&mut self, shown: &Indicators, now: Instant) {
        for (led, output) in [
            (shown.link, &mut self.link),
            (shown.activity, &mut self.activity),
            (shown.fault, &mut self.fault),
        ] {
            output.set_level(led.is_lit(now).into());
        }
    }
}

/// Runs a lamp test, then shows the latest indicators forever, blinking included.
#[embassy_executor::task]
pub async fn led_task(mut leds: Leds, shared: &'static Shared) -> ! {
    // A dead LED is noticed at power-up rather than mistaken for "no fault" later.
    let all = Indicators {
        link: Led::On,
        activity: Led::On,
        fault: Led::On,
    };
    leds.show(&all, Instant::now());
    Timer::after_millis(LAMP_TEST_MS).await;

    let mut latest = Indicators {
        link: Led::Off,
        activity: Led::Off,
        fault: Led::Off,
    };
    loop {
        let now = Instant::now();
        leds.show(&latest, now);
        // Blinking LEDs change at every half period of the fastest blink (the slower one's
        // edges fall on those too).
        let half = FAST_BLINK_HALF_PERIOD.as_ticks().max(1);
        let next_edge = Instant::from_ticks((now.as_ticks() / half + 1) * half);
        if let Either::First(new) = select(shared.indicators.wait(), Timer::at(next_edge)).await {
            latest = new;
        }
    }
}
