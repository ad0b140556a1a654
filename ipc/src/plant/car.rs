//! The car the tracker drives: the plant (its own vehicle parameters, mismatched against
//! the planner's), its actuators (transport delay, steering lag) and its sensors
//! (Gaussian noise). A command enters once per control period; the plant integrates it
//! over `substeps` plant steps with the control the actuators apply; the measured state is
//! the true one plus noise. Nothing here allocates after construction.

use planner::model::{ix, VehicleParams, NU, NX};

use super::actuator::Actuator;
use super::noise::StateNoise;
use super::Plant;
use crate::mismatch::Mismatch;
use crate::road::ClosedRoad;

/// Plant, actuators and sensors.
#[derive(Debug, Clone)]
pub struct Car {
    /// The true vehicle.
    pub plant: Plant,
    actuator: Actuator,
    noise: StateNoise,
    /// The controls acting when the state was last measured.
    measured_u: Option<[f64; NU]>,
}

impl Car {
    /// A car with vehicle parameters `params` (the mismatch applied to them here), cruising
    /// straight at `v0` \[m/s\]; the transport delay is rounded to whole control periods
    /// `control_dt` \[s\]; the noise stream starts from `seed`.
    pub fn new(
        params: &VehicleParams,
        mismatch: &Mismatch,
        x0: [f64; NX],
        control_dt: f64,
        seed: u64,
    ) -> Self {
        let act = &mismatch.actuator;
        let delay_steps = (act.transport_delay_s / control_dt).round().max(0.0) as usize;
        Self {
            plant: Plant::new(mismatch.apply(params), x0),
            actuator: Actuator::new(delay_steps, act.steering_lag_s),
            noise: StateNoise::new(mismatch.noise.sigma(), seed),
            measured_u: None,
        }
    }

    /// Transport delay in control periods.
    pub fn delay_steps(&self) -> usize {
        self.actuator.delay_steps()
    }

    /// The measured state: the true state plus one noise draw (a stopped car reads
    /// standstill exactly). The measured speeds stay non-negative.
    pub fn measure(&mut self) -> [f64; NX] {
        self.measured_u = self.actuator.acting();
        if self.plant.stopped {
            return self.plant.x;
        }
        let mut y = self.noise.measure(&self.plant.x);
        y[ix::V] = y[ix::V].max(0.0);
        y
    }

    /// The controls acting at the wheels when the state was last measured
    /// ([`crate::plant::actuator::Actuator::acting`]; a steering angle sensor reads the
    /// road-wheel angle to a fraction of the state noise, so it is passed without noise).
    /// `None` before the first command.
    pub fn measured_controls(&self) -> Option<[f64; NU]> {
        self.measured_u
    }

    /// Sends command `u` (saturated to the plant's limits) to the actuators and integrates
    /// the plant over `substeps` steps of `dt` \[s\].
    pub fn drive(&mut self, u: [f64; NU], road: &ClosedRoad, substeps: usize, dt: f64) {
        self.actuator.command(self.plant.saturate(u));
        for _ in 0..substeps {
            let applied = self.actuator.apply(dt);
            self.plant.step(applied, road, dt);
        }
    }
}
