//! Scaling of the NLP (reference README finding (a)): every decision variable is
//! `physical / nominal`, every constraint row is divided by a fixed scale (the tire
//! saturation rows by one that depends on the initial state). Scaling does not
//! change the solution, only the solver's view of it; without it the oval does not converge.

use super::spec::InitialState;
use crate::model::{NU, NX};

/// Nominal value of each state [r, V, beta, V_wr, dFz, e, dpsi, s, t] (SI units).
pub const X_NOMINAL: [f64; NX] = [1.0, 10.0, 0.1, 10.0, 1000.0, 1.0, 0.1, 100.0, 10.0];
/// Nominal value of each control [delta, T_comb, T_bf] (SI units).
pub const U_NOMINAL: [f64; NU] = [0.1, 1000.0, 1000.0];
/// Scale of the objective: f = t_N / OBJECTIVE_SCALE. With 0.1 (f = 10 t_N \[s\]) the
/// objective outweighs the initial barrier terms of the ~1000 bounds; a smaller objective
/// (the reference's t_N / 10) keeps the barrier method near the analytic centre for many
/// iterations.
pub const OBJECTIVE_SCALE: f64 = 0.1;
/// Scale of the front friction rows (R9) \[N\].
pub const FRICTION_SCALE: f64 = 1000.0;
/// Scale of the tire saturation rows (R5) [-] with a fixed (measured) initial state, the
/// planner's case: the row is (sigma - sigma_sl) / 0.1. Larger scales break fixed starts
/// near the tire limits: the saturation multipliers grow, and the first plans of the oval
/// replanning drive (`replay/tests/replanning_drive.rs`) hit the iteration cap or fail
/// numerically.
pub const SATURATION_SCALE_FIXED: f64 = 0.1;
/// Scale of the tire saturation rows with a free initial state (the paper's oval and
/// segment problems): (sigma - sigma_sl) / 3. On free starts it takes fewer iterations
/// than 0.1, and so does every scale from 1.5 to 5.
pub const SATURATION_SCALE_FREE: f64 = 3.0;

/// Scale of the tire saturation rows for a problem with this initial-state treatment.
pub fn saturation_scale(initial: &InitialState) -> f64 {
    match initial {
        InitialState::Fixed(_) => SATURATION_SCALE_FIXED,
        InitialState::Free => SATURATION_SCALE_FREE,
    }
}

/// Scaled value of a physical state vector.
pub fn scale_state(x: &[f64; NX]) -> [f64; NX] {
    std::array::from_fn(|i| x[i] / X_NOMINAL[i])
}

/// Scaled value of a physical control vector.
pub fn scale_control(u: &[f64; NU]) -> [f64; NU] {
    std::array::from_fn(|i| u[i] / U_NOMINAL[i])
}

/// Physical value of a scaled state vector.
pub fn unscale_state(z: &[f64]) -> [f64; NX] {
    std::array::from_fn(|i| z[i] * X_NOMINAL[i])
}

/// Physical value of a scaled control vector.
pub fn unscale_control(z: &[f64]) -> [f64; NU] {
    std::array::from_fn(|i| z[i] * U_NOMINAL[i])
}
