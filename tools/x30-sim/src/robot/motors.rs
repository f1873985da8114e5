//! The twelve joint motors' temperatures: they warm while the robot walks and cool at rest.

use x30_panel::proto::message::MotorTemperatures;

/// Above this temperature a motor is over-temperature (1002 `MotorState` 1), °C.
pub const OVER_TEMPERATURE: f64 = 80.0;
/// Temperature of a resting sway motor, °C; hips and knees run warmer.
const REST: f64 = 34.0;
/// How much warmer each joint of a leg runs: sway, hip, knee, °C.
const JOINT_OFFSET: [f64; 3] = [0.0, 2.0, 4.0];
/// How much warmer motors settle while walking, °C: below the over-temperature limit, so
/// only a test that sets temperatures makes a motor overheat.
const WALKING_RISE: f64 = 28.0;
/// Time constant of warming and cooling, simulated seconds.
const TIME_CONSTANT: f64 = 60.0;

/// The motors' temperatures, in the document's order (left front sway first).
#[derive(Debug, Clone, PartialEq)]
pub struct Motors {
    temperatures: [f64; 12],
}

impl Default for Motors {
    fn default() -> Self {
        Self {
            temperatures: std::array::from_fn(|i| settle(i, false)),
        }
    }
}

/// Where motor `index` settles, walking or not.
fn settle(index: usize, walking: bool) -> f64 {
    let joint = JOINT_OFFSET.get(index % 3).copied().unwrap_or(0.0);
    REST + joint + if walking { WALKING_RISE } else { 0.0 }
}

impl Motors {
    /// Lets `dt` simulated seconds pass, walking or not.
    pub fn advance(&mut self, dt: f64, walking: bool) {
        let k = 1.0 - (-dt / TIME_CONSTANT).exp();
        for (i, t) in self.temperatures.iter_mut().enumerate() {
            *t += (settle(i, walking) - *t) * k;
        }
    }

    /// The temperatures, °C.
    pub fn temperatures(&self) -> [f64; 12] {
        self.temperatures
    }

    /// Sets one motor's temperature (index in the document's order); others unchanged.
    pub fn set(&mut self, index: usize, celsius: f64) {
        if let Some(t) = self.temperatures.get_mut(index)
            && celsius.is_finite()
        {
            *t = celsius;
        }
    }

    /// Whether any motor is above [`OVER_TEMPERATURE`].
    pub fn over_temperature(&self) -> bool {
        self.temperatures.iter().any(|&t| t > OVER_TEMPERATURE)
    }

    /// The 1008 answer.
    pub fn message(&self) -> MotorTemperatures {
        let [a, b, c, d, e, f, g, h, i, j, k, l] = self.temperatures.map(|t| t as f32);
        MotorTemperatures {
            left_front_sway: a,
            left_front_hip: b,
            left_front_knee: c,
            right_front_sway: d,
            right_front_hip: e,
            right_front_knee: f,
            left_back_sway: g,
            left_back_hip: h,
            left_back_knee: i,
            right_back_sway: j,
            right_back_hip: k,
            right_back_knee: l,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warm_when_walking_and_cool_at_rest() {
        let mut motors = Motors::default();
        let rest = motors.message().max();
        motors.advance(60.0, true);
        let warm = motors.message().max();
        assert!(warm > rest + 10.0, "{rest} → {warm}");
        assert!(!motors.over_temperature());
        motors.advance(600.0, false);
        assert!((f64::from(motors.message().max()) - (REST + 4.0)).abs() < 0.1);
    }

    #[test]
    fn over_temperature_is_any_motor_above_the_limit() {
        let mut motors = Motors::default();
        motors.set(11, 80.5);
        motors.set(12, 99.0);
        assert!(motors.over_temperature());
        assert_eq!(motors.message().right_back_knee, 80.5);
    }
}
