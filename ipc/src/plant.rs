//! Time-domain simulation of the full single-track model (paper eq. 1) with fixed-step RK4;
//! the curvature is the road's k_ref at the current s of every stage. [`actuator`] adds
//! the steering lag and transport delay, [`noise`] the measurement noise, [`car`] puts
//! plant, actuators and sensors together as the tracker drives them.

pub mod actuator;
pub mod car;
pub mod noise;

use planner::model::{iu, ix, time_derivatives, VehicleParams, NU, NX};

use crate::road::ClosedRoad;

/// Speed below which the plant is considered stopped and no longer integrated [m/s]
/// (the model's 1/V terms are singular at standstill).
pub const STOP_SPEED: f64 = 2.0;

/// The simulated vehicle.
#[derive(Debug, Clone)]
pub struct Plant {
    /// State [r, V, beta, V_wr, dFz, e, dpsi, s, t]; s is the unwrapped track arc length.
    pub x: [f64; NX],
    /// Vehicle parameters.
    pub params: VehicleParams,
    /// True once braked below [`STOP_SPEED`]; the state is then frozen at standstill.
    pub stopped: bool,
}

impl Plant {
    /// A plant at state x.
    pub fn new(params: VehicleParams, x: [f64; NX]) -> Self {
        Self {
            x,
            params,
            stopped: false,
        }
    }

    /// Straight-line cruise at speed v at track s = 0, t = 0, centred in the lane.
    pub fn cruise(params: VehicleParams, v: f64) -> Self {
        let mut x = [0.0; NX];
        x[ix::V] = v;
        x[ix::VWR] = v;
        Self::new(params, x)
    }

    /// Clamps a control to the actuator limits of the vehicle (NaN becomes 0).
    pub fn saturate(&self, u: [f64; NU]) -> [f64; NU] {
        let p = &self.params;
        let c = |v: f64, lo: f64, hi: f64| if v.is_nan() { 0.0 } else { v.clamp(lo, hi) };
        [
            c(u[iu::DELTA], -p.delta_max, p.delta_max),
            c(u[iu::TCOMB], p.t_comb_min, p.t_comb_max),
            c(u[iu::TBF], p.t_bf_min, p.t_bf_max),
        ]
    }

    fn f(&self, x: &[f64; NX], u: &[f64; NU], road: &ClosedRoad) -> [f64; NX] {
        time_derivatives(&self.params, x, u, road.kappa(x[ix::S])).dxdt
    }

    /// One RK4 step of length dt \[s\] with the saturated control u held constant.
    /// Allocates nothing.
    pub fn step(&mut self, u: [f64; NU], road: &ClosedRoad, dt: f64) {
        if self.stopped {
            self.x[ix::T] += dt;
            return;
        }
        let u = self.saturate(u);
        let x = self.x;
        let add = |a: &[f64; NX], k: &[f64; NX], h: f64| {
            let mut o = *a;
            for i in 0..NX {
                o[i] += h * k[i];
            }
            o
        };
        let k1 = self.f(&x, &u, road);
        let k2 = self.f(&add(&x, &k1, 0.5 * dt), &u, road);
        let k3 = self.f(&add(&x, &k2, 0.5 * dt), &u, road);
        let k4 = self.f(&add(&x, &k3, dt), &u, road);
        for i in 0..NX {
            self.x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        // A brake stops the wheel; it cannot drive it backwards (R10).
        self.x[ix::VWR] = self.x[ix::VWR].max(self.params.v_wr_min);
        if self.x[ix::V] < STOP_SPEED {
            self.stopped = true;
            for i in [ix::R, ix::V, ix::BETA, ix::VWR, ix::DFZ] {
                self.x[i] = 0.0;
            }
        }
    }
}
