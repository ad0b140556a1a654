//! Constraints shared by every transcription (paper eq. 3 minus the dynamics): initial
//! conditions, variable bounds, control rates, front friction (R9) and tire saturation
//! (R4, R5), all in the scaled units of [`super::scaling`].
//!
//! Each group provides a Jacobian pattern (local row, global column), values in pattern
//! order, and (saturation only, the others are linear) a Hessian in a fixed lower-triangle
//! pattern.

use super::ad::{grad, lower_hessian, lower_pairs, seed1, seed2};
use super::fast;
use super::layout::Layout;
use super::scaling::{FRICTION_SCALE, U_NOMINAL, X_NOMINAL};
use super::spec::{InitialState, OcpSpec, FREE_BETA0_MAX, FREE_R0_MAX};
use crate::model::{iu, ix, saturation, VehicleParams, NU, NX};
use num_dual::DualNum;

/// Front friction rows per interval (R9): at (x_k, u_k) and at (x_{k+1}, u_k).
pub const FRICTION_ROWS: usize = 2;
/// Jacobian entries of the friction rows per interval.
pub const FRICTION_NNZ: usize = 4;
/// Saturation rows per saturation point (front, rear): at (x_k, u_k) for every interval
/// k, and, with [`crate::ocp::OcpSpec::saturation_at_end`], at the last node (x_N, u_{N-1}).
pub const SATURATION_ROWS: usize = 2;
/// Model inputs the saturation rows depend on: r, V, beta, V_wr, dFz, delta, T_bf.
pub const SATURATION_INPUTS: usize = 7;
/// Jacobian entries of the saturation rows per saturation point.
pub const SATURATION_NNZ: usize = SATURATION_ROWS * SATURATION_INPUTS;
/// Lower-triangle Hessian entries of the saturation rows per saturation point.
pub const SATURATION_HESS_NNZ: usize = SATURATION_INPUTS * (SATURATION_INPUTS + 1) / 2;
/// Control-rate rows per interval k >= 1 (upper and lower for each control).
pub const RATE_ROWS: usize = 2 * NU;
/// Jacobian entries of the rate rows per interval k >= 1.
pub const RATE_NNZ: usize = 4 * RATE_ROWS;

const SAT_STATES: [usize; 5] = [ix::R, ix::V, ix::BETA, ix::VWR, ix::DFZ];
const SAT_CONTROLS: [usize; 2] = [iu::DELTA, iu::TBF];

/// States of the initial-condition rows g = x_0\[state\], in row order. All nine rows are
/// always present, so the constraint structure (and the solver's symbolic factorization) does
/// not depend on the initial-state mode and [`crate::ocp::Transcription::set_initial`] only
/// changes bounds. s_0, t_0 and dpsi_0 come first (equalities in both modes).
pub const INITIAL_ROWS: [usize; NX] = [
    ix::S,
    ix::T,
    ix::DPSI,
    ix::R,
    ix::V,
    ix::BETA,
    ix::VWR,
    ix::DFZ,
    ix::E,
];

/// Free-mode envelope of the initial rows of V, V_wr and e (already bounded as variables):
/// |x_0\[i\]| <= 100 nominals (scaled units; e.g. |e_0| <= 100 m), never active.
pub const FREE_ROW_ENVELOPE: f64 = 100.0;

/// Scaled bounds (g_l, g_u) of the initial-condition row of state `i`.
///
/// * Fixed(x0): every row is the equality x_0\[i\] = x0\[i\]; x_0 has no variable bounds (a
///   fixed value on a variable bound would leave no interior).
/// * Free (paper convention): s_0 = t_0 = dpsi_0 = 0 are equalities; x_0 has the same
///   variable bounds as every other node (e_min\[0\] <= e_0 <= e_max\[0\], V, V_wr), and the
///   other six rows are inactive inequality rows: |r_0| <= 10 rad/s, |beta_0| <= 1.5 rad,
///   |dFz_0| <= m g, and |x_0\[i\]| <= [`FREE_ROW_ENVELOPE`] nominals for V, V_wr, e. They are
///   not left at -inf..inf: the solver gives such a row a slack without any barrier term,
///   whose zero curvature makes the condensed KKT dual diagonal -1/(sigma_s + delta_w)
///   infinite when delta_w = 0.
pub fn initial_row_bounds(spec: &OcpSpec, i: usize) -> (f64, f64) {
    match spec.initial {
        InitialState::Fixed(x0) => (x0[i] / X_NOMINAL[i], x0[i] / X_NOMINAL[i]),
        InitialState::Free => match i {
            ix::S | ix::T | ix::DPSI => (0.0, 0.0),
            ix::R => (-FREE_R0_MAX / X_NOMINAL[i], FREE_R0_MAX / X_NOMINAL[i]),
            ix::BETA => (
                -FREE_BETA0_MAX / X_NOMINAL[i],
                FREE_BETA0_MAX / X_NOMINAL[i],
            ),
            ix::DFZ => {
                let w = spec.vehicle.m * spec.vehicle.g / X_NOMINAL[i];
                (-w, w)
            }
            _ => (-FREE_ROW_ENVELOPE, FREE_ROW_ENVELOPE),
        },
    }
}

/// Variable bounds in scaled units: e and V at every node (V_N also below v_end_max,
/// [`end_speed_upper`]), V_wr >= v_wr_min (R10), control box; everything else free. With a
/// Fixed initial state, x_0 is left unbounded (its equality rows pin it; a value on a bound
/// would leave no interior).
pub fn variable_bounds(lay: &Layout, spec: &OcpSpec, x_l: &mut [f64], x_u: &mut [f64]) {
    let p = &spec.vehicle;
    x_l.fill(f64::NEG_INFINITY);
    x_u.fill(f64::INFINITY);
    let first = match spec.initial {
        InitialState::Free => 0,
        InitialState::Fixed(_) => 1,
    };
    for k in first..=lay.n_intervals {
        x_l[lay.x(k, ix::E)] = spec.e_min[k] / X_NOMINAL[ix::E];
        x_u[lay.x(k, ix::E)] = spec.e_max[k] / X_NOMINAL[ix::E];
        x_l[lay.x(k, ix::V)] = spec.v_min / X_NOMINAL[ix::V];
        x_u[lay.x(k, ix::V)] = spec.v_max / X_NOMINAL[ix::V];
        x_l[lay.x(k, ix::VWR)] = p.v_wr_min / X_NOMINAL[ix::VWR];
    }
    x_u[lay.x(lay.n_intervals, ix::V)] = end_speed_upper(spec);
    let (ul, uu) = control_box(p);
    for k in 0..lay.n_intervals {
        for j in 0..NU {
            x_l[lay.u(k, j)] = ul[j] / U_NOMINAL[j];
            x_u[lay.u(k, j)] = uu[j] / U_NOMINAL[j];
        }
    }
}

/// Upper bound of the last node's speed in scaled units: min(v_max, v_end_max).
pub fn end_speed_upper(spec: &OcpSpec) -> f64 {
    spec.v_max.min(spec.v_end_max) / X_NOMINAL[ix::V]
}

/// Physical control box (lower, upper).
pub fn control_box(p: &VehicleParams) -> ([f64; NU], [f64; NU]) {
    (
        [-p.delta_max, p.t_comb_min, p.t_bf_min],
        [p.delta_max, p.t_comb_max, p.t_bf_max],
    )
}

/// Rate bound of each control [unit/s].
pub fn rate_bounds(p: &VehicleParams) -> [f64; NU] {
    [p.delta_rate_max, p.t_comb_rate_max, p.t_bf_rate_max]
}

// ---------------------------------------------------------------- front friction (R9)

/// Jacobian pattern of the friction rows of interval k: (local row, column).
pub fn friction_pattern(lay: &Layout, k: usize, push: &mut impl FnMut(usize, usize)) {
    push(0, lay.x(k, ix::DFZ));
    push(0, lay.u(k, iu::TBF));
    push(1, lay.x(k + 1, ix::DFZ));
    push(1, lay.u(k, iu::TBF));
}

/// R9 row (T_bf/R_w + mu (F_zf,nom - dFz)) / 1000 N >= 0 at (x_k, u_k) and (x_{k+1}, u_k).
pub fn friction_eval(p: &VehicleParams, lay: &Layout, k: usize, z: &[f64], out: &mut [f64]) {
    let fxf = z[lay.u(k, iu::TBF)] * U_NOMINAL[iu::TBF] / p.r_w;
    for (o, node) in [k, k + 1].into_iter().enumerate() {
        let dfz = z[lay.x(node, ix::DFZ)] * X_NOMINAL[ix::DFZ];
        out[o] = (fxf + p.mu * (p.fz_nom_front() - dfz)) / FRICTION_SCALE;
    }
}

/// Friction Jacobian values in [`friction_pattern`] order (constant).
pub fn friction_jac(p: &VehicleParams, out: &mut [f64]) {
    let c_dfz = -p.mu * X_NOMINAL[ix::DFZ] / FRICTION_SCALE;
    let c_tbf = U_NOMINAL[iu::TBF] / (p.r_w * FRICTION_SCALE);
    out[..FRICTION_NNZ].copy_from_slice(&[c_dfz, c_tbf, c_dfz, c_tbf]);
}

// ---------------------------------------------------------------- tire saturation (R4, R5)

/// The interval whose controls saturation point `k` uses: k itself, or N - 1 at the last
/// node k = N (the controls of the interval whose dynamics end there).
#[inline]
fn sat_interval(lay: &Layout, k: usize) -> usize {
    k.min(lay.n_intervals - 1)
}

/// Column of saturation input `l` of saturation point k (evaluated at (x_k, u_k), or at
/// (x_N, u_{N-1}) for k = N).
#[inline]
fn sat_col(lay: &Layout, k: usize, l: usize) -> usize {
    if l < SAT_STATES.len() {
        lay.x(k, SAT_STATES[l])
    } else {
        lay.u(sat_interval(lay, k), SAT_CONTROLS[l - SAT_STATES.len()])
    }
}

/// Builds physical (x, u) at saturation point k (x_k with the controls of
/// [`sat_interval`]) where saturation input `l` is `seed(z, l) * nominal` and every other
/// entry is a constant.
#[inline(always)]
fn sat_point<D: DualNum<Primitive = f64> + Copy>(
    lay: &Layout,
    k: usize,
    z: &[f64],
    seed: impl Fn(f64, usize) -> D,
) -> ([D; NX], [D; NU]) {
    let ku = sat_interval(lay, k);
    let mut x: [D; NX] = std::array::from_fn(|i| D::from(z[lay.x(k, i)] * X_NOMINAL[i]));
    let mut u: [D; NU] = std::array::from_fn(|j| D::from(z[lay.u(ku, j)] * U_NOMINAL[j]));
    for (l, &i) in SAT_STATES.iter().enumerate() {
        x[i] = seed(z[lay.x(k, i)], l) * X_NOMINAL[i];
    }
    for (l, &j) in SAT_CONTROLS.iter().enumerate() {
        u[j] = seed(z[lay.u(ku, j)], SAT_STATES.len() + l) * U_NOMINAL[j];
    }
    (x, u)
}

/// Jacobian pattern of the saturation rows of saturation point k: (local row, column).
pub fn saturation_pattern(lay: &Layout, k: usize, push: &mut impl FnMut(usize, usize)) {
    for row in 0..SATURATION_ROWS {
        for l in 0..SATURATION_INPUTS {
            push(row, sat_col(lay, k, l));
        }
    }
}

/// The tire saturation rows (sigma - sigma_sl) / scale (front, rear) of a problem: the
/// vehicle, the layout and the row scale ([`super::scaling::saturation_scale`]; the upper
/// bound is eps_sat / scale).
#[derive(Debug, Clone, Copy)]
pub struct SaturationRows<'a> {
    /// Vehicle parameters.
    pub p: &'a VehicleParams,
    /// Variable layout.
    pub lay: &'a Layout,
    /// Row scale.
    pub scale: f64,
}

impl SaturationRows<'_> {
    /// Row values at saturation point k: (x_k, u_k), or (x_N, u_{N-1}) for k = N.
    pub fn eval(&self, k: usize, z: &[f64], out: &mut [f64]) {
        let (x, u) = sat_point::<f64>(self.lay, k, z, |v, _| v);
        let s = saturation(self.p, &x, &u);
        out[0] = s[0] / self.scale;
        out[1] = s[1] / self.scale;
    }

    /// Jacobian values in [`saturation_pattern`] order (num-dual oracle).
    #[inline(never)]
    pub fn jac(&self, k: usize, z: &[f64], out: &mut [f64]) {
        let (x, u) = sat_point(self.lay, k, z, seed1::<SATURATION_INPUTS>);
        let s = saturation(self.p, &x, &u);
        for row in 0..SATURATION_ROWS {
            let g = grad(&s[row]);
            for l in 0..SATURATION_INPUTS {
                out[row * SATURATION_INPUTS + l] = g[l] / self.scale;
            }
        }
    }

    /// Jacobian values in [`saturation_pattern`] order, by the fast structured path of
    /// [`crate::ocp::fast`].
    #[inline(always)]
    pub fn jac_fast(&self, k: usize, z: &[f64], out: &mut [f64]) {
        let (x, u) = sat_point::<f64>(self.lay, k, z, |v, _| v);
        let s = fast::saturation_jacobian(self.p, &x, &u);
        for row in 0..SATURATION_ROWS {
            for l in 0..SATURATION_INPUTS {
                out[row * SATURATION_INPUTS + l] = s[row].g[l] * SAT_NOMINAL[l] / self.scale;
            }
        }
    }

    /// Hessian of lambda_f g_f + lambda_r g_r in [`saturation_hess_pattern`] order by the
    /// fast structured path of [`crate::ocp::fast`] (overwrites `out`).
    #[inline(always)]
    pub fn hess_fast(&self, k: usize, z: &[f64], lambda: &[f64], out: &mut [f64]) {
        let (x, u) = sat_point::<f64>(self.lay, k, z, |v, _| v);
        let w = [lambda[0] / self.scale, lambda[1] / self.scale];
        fast::saturation_hessian(self.p, &x, &u, w).write_lower(&SAT_NOMINAL, out);
    }

    /// Hessian of lambda_f g_f + lambda_r g_r (the two rows of saturation point k), in
    /// [`saturation_hess_pattern`] order (num-dual oracle; overwrites `out`).
    #[inline(never)]
    pub fn hess(&self, k: usize, z: &[f64], lambda: &[f64], out: &mut [f64]) {
        let (x, u) = sat_point(self.lay, k, z, seed2::<SATURATION_INPUTS>);
        let s = saturation(self.p, &x, &u);
        let phi = (s[0] * lambda[0] + s[1] * lambda[1]) / self.scale;
        lower_hessian(&phi, out);
    }
}

/// Nominal of each saturation input [r, V, beta, V_wr, dFz, delta, T_bf].
const SAT_NOMINAL: [f64; SATURATION_INPUTS] = [
    X_NOMINAL[ix::R],
    X_NOMINAL[ix::V],
    X_NOMINAL[ix::BETA],
    X_NOMINAL[ix::VWR],
    X_NOMINAL[ix::DFZ],
    U_NOMINAL[iu::DELTA],
    U_NOMINAL[iu::TBF],
];

/// Hessian pattern of the saturation rows of saturation point k: global (row >= col) pairs.
pub fn saturation_hess_pattern(lay: &Layout, k: usize, push: &mut impl FnMut(usize, usize)) {
    for (i, j) in lower_pairs(SATURATION_INPUTS) {
        let (a, b) = (sat_col(lay, k, i), sat_col(lay, k, j));
        push(a.max(b), a.min(b));
    }
}

// ---------------------------------------------------------------- control rates

/// Jacobian pattern of the rate rows of interval k >= 1: for each control j an upper and
/// a lower row, entries (u_k\[j\], u_{k-1}\[j\], t_k, t_{k-1}).
pub fn rate_pattern(lay: &Layout, k: usize, push: &mut impl FnMut(usize, usize)) {
    for j in 0..NU {
        for side in 0..2 {
            let row = 2 * j + side;
            push(row, lay.u(k, j));
            push(row, lay.u(k - 1, j));
            push(row, lay.x(k, ix::T));
            push(row, lay.x(k - 1, ix::T));
        }
    }
}

/// Rate rows in the multiplied form (reference finding (b)), divided by the rate bound:
/// upper (u_k - u_{k-1} - rate (t_k - t_{k-1})) / rate <= 0,
/// lower (u_k - u_{k-1} + rate (t_k - t_{k-1})) / rate >= 0.
pub fn rate_eval(p: &VehicleParams, lay: &Layout, k: usize, z: &[f64], out: &mut [f64]) {
    let rates = rate_bounds(p);
    let dt = (z[lay.x(k, ix::T)] - z[lay.x(k - 1, ix::T)]) * X_NOMINAL[ix::T];
    for j in 0..NU {
        let du = (z[lay.u(k, j)] - z[lay.u(k - 1, j)]) * U_NOMINAL[j] / rates[j];
        out[2 * j] = du - dt;
        out[2 * j + 1] = du + dt;
    }
}

/// Rate Jacobian values in [`rate_pattern`] order (constant).
pub fn rate_jac(p: &VehicleParams, out: &mut [f64]) {
    let rates = rate_bounds(p);
    let ct = X_NOMINAL[ix::T];
    for j in 0..NU {
        let cu = U_NOMINAL[j] / rates[j];
        let o = 8 * j;
        out[o..o + 4].copy_from_slice(&[cu, -cu, -ct, ct]);
        out[o + 4..o + 8].copy_from_slice(&[cu, -cu, ct, -ct]);
    }
}

/// Bounds of the 6 rate rows: upper rows (-inf, 0], lower rows [0, inf).
pub fn rate_row_bounds(g_l: &mut [f64], g_u: &mut [f64]) {
    for j in 0..NU {
        g_l[2 * j] = f64::NEG_INFINITY;
        g_u[2 * j] = 0.0;
        g_l[2 * j + 1] = 0.0;
        g_u[2 * j + 1] = f64::INFINITY;
    }
}
