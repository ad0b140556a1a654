//! Trajectory tracking: the planned controls, looked up by arc length, as feed-forward,
//! plus feedback on lateral error, heading and yaw rate (steering) and speed (torque).

use planner::model::{iu, ix, VehicleParams, NU, NX};

use crate::msg::{Trajectory, HORIZON_N};
use crate::road::ClosedRoad;

/// Feedback gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// Steering per metre of lateral error [rad/m].
    pub k_e: f64,
    /// Steering per radian of heading error [rad/rad].
    pub k_dpsi: f64,
    /// Steering per rad/s of yaw-rate error [rad s/rad].
    pub k_r: f64,
    /// Longitudinal acceleration per m/s of speed error [1/s].
    pub k_v: f64,
    /// Rear torque per m/s of rear wheel-speed error (slip control) [N m s/m].
    pub k_w: f64,
    /// Deceleration used to brake to a stop when the plan is stale [m/s^2].
    pub stop_decel: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Self {
            k_e: 0.10,
            k_dpsi: 0.8,
            k_r: 0.05,
            k_v: 1.0,
            k_w: 1000.0,
            stop_decel: 4.0,
        }
    }
}

/// Reference of the plan at one arc length, and the tracking errors against it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    /// Interpolated planned state.
    pub x: [f64; NX],
    /// Planned control (held on the interval).
    pub u: [f64; NU],
}

/// Planned state (linear in s) and control (piecewise constant) at local arc length
/// `s_local` [m] from node 0; `None` outside [0, N ds].
pub fn reference(plan: &Trajectory, s_local: f64) -> Option<Reference> {
    let len = plan.length();
    if !(s_local >= 0.0 && s_local <= len) {
        return None;
    }
    let q = s_local / plan.ds;
    let k = (q.floor() as usize).min(HORIZON_N - 1);
    let w = (q - k as f64).clamp(0.0, 1.0);
    let (a, b) = (&plan.x[k], &plan.x[k + 1]);
    let mut x = [0.0; NX];
    for i in 0..NX {
        x[i] = a[i] + w * (b[i] - a[i]);
    }
    Some(Reference { x, u: plan.u[k] })
}

/// Wraps an angle difference into (-pi, pi].
fn wrap(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let r = a.rem_euclid(two_pi);
    if r > std::f64::consts::PI {
        r - two_pi
    } else {
        r
    }
}

/// Tracking errors (actual minus planned).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Errors {
    /// Lateral error e - e_ref [m].
    pub e: f64,
    /// Heading error dpsi - dpsi_ref [rad].
    pub dpsi: f64,
    /// Speed error V - V_ref [m/s].
    pub v: f64,
    /// Sideslip error beta - beta_ref [rad].
    pub beta: f64,
}

/// Control for the plant state x following `r`: feed-forward + feedback. Allocates nothing.
pub fn track(p: &VehicleParams, g: &Gains, x: &[f64; NX], r: &Reference) -> ([f64; NU], Errors) {
    let err = Errors {
        e: x[ix::E] - r.x[ix::E],
        dpsi: wrap(x[ix::DPSI] - r.x[ix::DPSI]),
        v: x[ix::V] - r.x[ix::V],
        beta: x[ix::BETA] - r.x[ix::BETA],
    };
    let mut u = r.u;
    u[iu::DELTA] -= g.k_e * err.e + g.k_dpsi * err.dpsi + g.k_r * (x[ix::R] - r.x[ix::R]);
    // Speed feedback as a force at the rear wheel (drive or rear brake).
    u[iu::TCOMB] -= g.k_v * err.v * p.m * p.r_w;
    // Wheel-slip control: the wheel mode is fast and unstable past the tire peak.
    u[iu::TCOMB] -= g.k_w * (x[ix::VWR] - r.x[ix::VWR]);
    (u, err)
}

/// Braking to a stop along the road when there is no usable plan: kinematic steering for
/// the road curvature, feedback to `e_hold` and zero heading error, and `stop_decel`
/// split over both axles. Allocates nothing.
pub fn brake_to_stop(
    p: &VehicleParams,
    g: &Gains,
    x: &[f64; NX],
    road: &ClosedRoad,
    e_hold: f64,
) -> [f64; NU] {
    let kappa = road.kappa(x[ix::S]);
    let delta = p.l * kappa
        - g.k_e * (x[ix::E] - e_hold)
        - g.k_dpsi * x[ix::DPSI]
        - g.k_r * (x[ix::R] - kappa * x[ix::V]);
    let torque = g.stop_decel * p.m * p.r_w;
    // Front axle carries b / L of the static load.
    let front = (p.b / p.l).clamp(0.0, 1.0);
    [delta, -(1.0 - front) * torque, -front * torque]
}
