//! The button panel: one GPIO input per button, pulled up inside the MCU, pressed = low.
//!
//! Every pin is sampled every [`POLL_PERIOD`] and fed to the library's debouncers; a debounced
//! change goes to the application's button channel. Polling rather than edge interrupts
//! because it cannot miss an edge that falls between two waits, and because the 14 pins need
//! not sit on 14 different EXTI lines (PE13 and PF13 share one).

use defmt::debug;
use embassy_stm32::Peri;
use embassy_stm32::gpio::{AnyPin, Input, Pull};
use embassy_time::{Duration, Instant, Ticker};
use x30_panel::app::{Path, Shared};
use x30_panel::config::EstopWiring;
use x30_panel::panel::buttons::BUTTON_COUNT;
use x30_panel::panel::{Button, ButtonDebouncers};

/// How often every button is sampled: well under the shortest debounce time (1 ms is the
/// least `X30_DEBOUNCE_MS` allows, 15 ms the default), at about 1 µs of CPU time per pass.
pub const POLL_PERIOD: Duration = Duration::from_millis(2);

/// The button inputs, indexed like [`Button::ALL`].
pub struct Buttons {
    /// One input per button.
    pins: [Input<'static>; BUTTON_COUNT],
}

impl Buttons {
    /// Configures the pins, given in the order of [`Button::ALL`], as inputs with pull-ups.
    pub fn new(pins: [Peri<'static, AnyPin>; BUTTON_COUNT]) -> Self {
        Self {
            pins: pins.map(|pin| Input::new(pin, Pull::Up)),
        }
    }
}

/// Samples the buttons forever and hands each debounced change to the application.
///
/// A full channel makes this task wait rather than drop the event: a lost release would
/// leave the robot walking. While it waits, nothing is sampled; the levels are read again
/// afterwards, so only the timing of a change in that moment is lost, never the change.
#[embassy_executor::task]
pub async fn button_task(
    buttons: Buttons,
    debounce: Duration,
    estop_wiring: EstopWiring,
    shared: &'static Shared,
) -> ! {
    let pressed = |button: Button, pin: &Input<'static>| {
        let low = pin.is_low();
        if button == Button::Estop {
            estop_wiring.pressed(low)
        } else {
            low
        }
    };
    let mut at_power_up = [false; BUTTON_COUNT];
    for ((button, pin), level) in Button::ALL
        .into_iter()
        .zip(&buttons.pins)
        .zip(&mut at_power_up)
    {
        *level = pressed(button, pin);
    }
    let mut debouncers = ButtonDebouncers::at_power_up(debounce, at_power_up);
    let mut ticker = Ticker::every(POLL_PERIOD);
    loop {
        shared.beat(Path::Buttons);
        let now = Instant::now();
        for (button, pin) in Button::ALL.into_iter().zip(&buttons.pins) {
            if let Some(event) = debouncers.sample(button, pressed(button, pin), now) {
                debug!(
                    "button {} {}",
                    button.name(),
                    if event.pressed { "pressed" } else { "released" }
                );
                shared.buttons.send(event).await;
            }
        }
        ticker.next().await;
    }
}
