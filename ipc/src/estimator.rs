//! The tracker's state estimator: a predictor-corrector filter on the planner's model.
//!
//! The car's sensors give the true state plus white noise at every control step
//! ([`crate::plant::noise`]). Fed straight to the LQR feedback, the noise becomes steering
//! and torque jitter that grows with speed (the gains on the lateral and heading errors
//! act through V), and fed to the planner it starts every plan from a noisy yaw rate,
//! sideslip and heading. A real car filters its sensors; so does the tracker:
//!
//!   x^- = Phi(x_hat, u, T_c)          one control period of the nominal model (RK4 on the
//!                                     plant's sub-steps) with the controls acting,
//!   x_hat = x^- + L (y - x^-),  L = 1 - exp(-T_c / tau),
//!
//! with tau the filter's time constant. The prediction carries the dynamics, so the
//! estimate trails the car only by what the model gets wrong over about tau, while white
//! noise of standard deviation sigma leaves sqrt(L / (2 - L)) sigma in the estimate (0.16
//! sigma at T_c = 1 ms and tau = 20 ms). The arc length s and the time t are copied from
//! the measurement (their sensors are exact). Allocates nothing.

use planner::model::{ix, VehicleParams, NU, NX};

use crate::plant::{Plant, STOP_SPEED};
use crate::road::ClosedRoad;

/// Predictor-corrector filter of the measured state.
#[derive(Debug, Clone)]
pub struct Estimator {
    /// The nominal model, at the estimate.
    model: Plant,
    /// Correction gain L per control period (1: no filtering).
    gain: f64,
    /// False until the first measurement (which the estimate starts from).
    primed: bool,
}

impl Estimator {
    /// A filter on the model `p` (the planner's vehicle) with time constant `tau_s` \[s\]
    /// (0: the estimate is the measurement) at control period `control_dt` \[s\].
    pub fn new(p: VehicleParams, tau_s: f64, control_dt: f64) -> Self {
        let gain = if tau_s > 0.0 {
            1.0 - (-control_dt / tau_s).exp()
        } else {
            1.0
        };
        Self {
            model: Plant::new(p, [0.0; NX]),
            gain,
            primed: false,
        }
    }

    /// The estimate after measurement `y`, predicted from the last estimate over `substeps`
    /// steps of `dt` \[s\] with the controls `u` acting (`None`, before the first command:
    /// no prediction, the measurement is taken as it is). A measurement at standstill
    /// (below the plant's stop speed) resets the filter to it.
    pub fn update(
        &mut self,
        y: &[f64; NX],
        u: Option<[f64; NU]>,
        road: &ClosedRoad,
        (substeps, dt): (usize, f64),
    ) -> [f64; NX] {
        let Some(u) = u else {
            return self.reset(y);
        };
        if !self.primed || self.gain >= 1.0 || y[ix::V] < STOP_SPEED {
            return self.reset(y);
        }
        for _ in 0..substeps {
            self.model.step(u, road, dt);
        }
        if self.model.stopped || !self.model.x.iter().all(|v| v.is_finite()) {
            return self.reset(y);
        }
        let x = &mut self.model.x;
        for i in 0..NX {
            x[i] += self.gain * (y[i] - x[i]);
        }
        x[ix::S] = y[ix::S];
        x[ix::T] = y[ix::T];
        *x
    }

    /// Restarts the filter at `y`.
    fn reset(&mut self, y: &[f64; NX]) -> [f64; NX] {
        self.model.x = *y;
        self.model.stopped = false;
        self.primed = true;
        *y
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mismatch::Mismatch;
    use crate::plant::car::Car;
    use planner::model::iu;

    /// On a car in a steady curve with the default sensor noise, the filtered yaw rate,
    /// sideslip, lateral offset and heading error scatter at most a third as much as the
    /// measured ones, and stay centred on the true state (no lag-induced bias beyond a
    /// tenth of the measurement noise).
    #[test]
    fn the_estimate_scatters_less_than_the_measurement_and_follows_the_car() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let p = planner::config::load_vehicle(&root.join("config/vehicles/lc500.toml")).unwrap();
        let road = ClosedRoad::new(vec![(0.0, 0.0)], 10_000.0, -8.0, 8.0);
        let noise = Mismatch::from_arg("default").unwrap().noise;
        let mut mismatch = Mismatch::from_arg("none").unwrap();
        mismatch.noise = noise;
        let mut car = Car::new(&p, &mismatch, Plant::cruise(p, 30.0).x, 0.001, 7);
        let mut est = Estimator::new(p, 0.02, 0.001);
        let mut u = [0.0; NU];
        u[iu::DELTA] = 0.01;
        u[iu::TCOMB] = 400.0;
        let states = [ix::R, ix::BETA, ix::E, ix::DPSI];
        let (mut meas, mut filt) = ([0.0; 4], [0.0; 4]);
        let mut bias = [0.0; 4];
        let n = 2000;
        for k in 0..3000 {
            let y = car.measure();
            let x_hat = est.update(&y, car.measured_controls(), &road, (4, 0.00025));
            if k >= 3000 - n {
                for (j, &i) in states.iter().enumerate() {
                    let truth = car.plant.x[i];
                    meas[j] += (y[i] - truth).powi(2);
                    filt[j] += (x_hat[i] - truth).powi(2);
                    bias[j] += x_hat[i] - truth;
                }
            }
            car.drive(u, &road, 4, 0.00025);
        }
        let sigma = noise.sigma();
        for (j, &i) in states.iter().enumerate() {
            let (m, f) = ((meas[j] / n as f64).sqrt(), (filt[j] / n as f64).sqrt());
            assert!(
                f < m / 3.0,
                "state {i}: filtered rms {f} against measured {m}"
            );
            let b = bias[j] / n as f64;
            assert!(b.abs() < 0.1 * sigma[i], "state {i}: bias {b}");
        }
    }
}
