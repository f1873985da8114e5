//! The battery: charge that drains with activity and refills on the dock or a charger.
//!
//! Rates are far faster than a real X30's so that a test sees them change within seconds
//! (or tens of seconds at time scale 1). The reported current is a plausible value for
//! the activity, not the one the accelerated drain would imply.
//!
//! Sign convention of the 2001 `Current` item: **positive while the battery discharges,
//! negative while it charges** (the document's sample, 653 = 6.53 A at 97 %, reads as a
//! working robot's discharge).

use x30_panel::proto::codes::ProtectedState;
use x30_panel::proto::message::Battery;

/// Nominal capacity in units of 10 mAh (the document's sample: 20.04 Ah).
pub const NOMINAL_CAPACITY: i32 = 2004;
/// Drain while lying down or stopped (soft e-stop, fallen), % per simulated second.
pub const LYING_DRAIN: f64 = 0.02;
/// Drain while standing or stepping in place, % per simulated second.
pub const IDLE_DRAIN: f64 = 0.05;
/// Drain while walking or turning, % per simulated second.
pub const MOVING_DRAIN: f64 = 0.2;
/// Gain while charging (on the dock or a charger), % per simulated second.
pub const CHARGE_RATE: f64 = 0.25;
/// Voltage of an empty and a full battery, V (a 14-cell lithium pack).
const VOLTAGE_RANGE: (f64, f64) = (48.0, 58.8);
/// Charge cycles the simulated battery has been through.
const CYCLES: i32 = 12;

/// What the robot is doing, as far as the battery and motors are concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Load {
    /// Lying down, or in soft emergency stop or fallen.
    Lying,
    /// Standing or stepping in place.
    Standing,
    /// Walking or turning.
    Moving,
}

impl Load {
    /// Current drawn, in units of 10 mA.
    fn current(self) -> i32 {
        match self {
            Self::Lying => 200,
            Self::Standing => 800,
            Self::Moving => 2500,
        }
    }
}

/// The battery's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Power {
    level: f64,
    load: Load,
    charging: bool,
    temperature: f64,
}

impl Power {
    /// A battery at `level` %, idle.
    pub fn new(level: f64) -> Self {
        Self {
            level: clamp_level(level).unwrap_or(0.0),
            load: Load::Standing,
            charging: false,
            temperature: 28.0,
        }
    }

    /// Charge, 0.0..=100.0 %.
    pub fn level(&self) -> f64 {
        self.level
    }

    /// Sets the charge; values outside 0..=100 are clamped, NaN is ignored.
    pub fn set_level(&mut self, level: f64) {
        if let Some(level) = clamp_level(level) {
            self.level = level;
        }
    }

    /// Charge as the robot reports it (1002 `Electricity`, 2001 `BatteryLevel`), %.
    pub fn percent(&self) -> i32 {
        self.level.round() as i32
    }

    /// Lets `dt` simulated seconds pass under `load`, charging or not.
    pub fn advance(&mut self, dt: f64, load: Load, charging: bool) {
        self.load = load;
        self.charging = charging;
        let rate = if charging {
            CHARGE_RATE
        } else {
            -match load {
                Load::Lying => LYING_DRAIN,
                Load::Standing => IDLE_DRAIN,
                Load::Moving => MOVING_DRAIN,
            }
        };
        self.set_level(self.level + rate * dt);
        // The pack warms under load and while charging, with a time constant of minutes.
        let target = match (charging, load) {
            (true, _) => 31.0,
            (false, Load::Moving) => 34.0,
            (false, _) => 28.0,
        };
        self.temperature += (target - self.temperature) * (1.0 - (-dt / 120.0).exp());
    }

    /// The 2001 answer: voltage follows the charge, remaining capacity is the charge's
    /// share of the nominal capacity, current is signed as the module docs say.
    pub fn message(&self) -> Battery {
        let fraction = self.level / 100.0;
        let (empty, full) = VOLTAGE_RANGE;
        Battery {
            voltage: Some((empty + (full - empty) * fraction).round() as i32),
            current: Some(if self.charging {
                -1000
            } else {
                self.load.current()
            }),
            remaining_capacity: Some((f64::from(NOMINAL_CAPACITY) * fraction).round() as i32),
            nominal_capacity: Some(NOMINAL_CAPACITY),
            cycles: Some(CYCLES),
            protected_state: Some(if self.level <= 0.0 {
                ProtectedState::Triggered
            } else {
                ProtectedState::Normal
            }),
            battery_level: Some(self.percent()),
            battery_temperature: Some(self.temperature as f32),
        }
    }
}

fn clamp_level(level: f64) -> Option<f64> {
    (!level.is_nan()).then(|| level.clamp(0.0, 100.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drains_faster_when_moving_and_charges() {
        let mut power = Power::new(90.0);
        power.advance(10.0, Load::Standing, false);
        assert!((power.level() - 89.5).abs() < 1e-9);
        power.advance(10.0, Load::Moving, false);
        assert!((power.level() - 87.5).abs() < 1e-9);
        assert!(power.message().current > Some(0));
        power.advance(10.0, Load::Lying, true);
        assert!((power.level() - 90.0).abs() < 1e-9);
        assert!(power.message().current.is_some_and(|current| current < 0));
        power.advance(1000.0, Load::Lying, true);
        assert_eq!(power.percent(), 100);
    }

    #[test]
    fn the_answer_is_consistent() {
        let mut power = Power::new(50.0);
        power.set_level(f64::NAN);
        let battery = power.message();
        assert_eq!(battery.battery_level, Some(50));
        assert_eq!(battery.remaining_capacity, Some(1002));
        assert_eq!(battery.voltage, Some(53));
        assert_eq!(battery.protected_state, Some(ProtectedState::Normal));
        power.set_level(-3.0);
        assert_eq!(
            power.message().protected_state,
            Some(ProtectedState::Triggered)
        );
    }
}
