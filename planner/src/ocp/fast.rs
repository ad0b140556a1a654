//! Fast exact derivatives of the model terms the OCP needs (defect rows of implicit Euler and
//! tire saturation rows), written as small structured pieces over the lean jets of
//! [`super::jet`]. The generic model of [`crate::model`] stays the single source of truth
//! and the oracle: every function here is checked against it (value, gradient, Hessian) in
//! `planner/tests/fast_derivatives.rs`.
//!
//! Structure exploited for the Hessian of `phi = sum_i w_i f_i(x_{k+1}, u_k)`:
//! * f_i = xdot_i / sdot with sdot = V cos(dpsi) / (1 - kappa e), so
//!   `phi = B / sdot + w_e tan(dpsi) (1 - kappa e) - w_dpsi kappa` where B (the weighted sum
//!   of the force-dependent rows) does not depend on e or dpsi. B is built over the 7 tire
//!   inputs (r, V, beta, V_wr, dFz, delta, T_bf) plus T_comb (linear), and the division by
//!   sdot is one exact chain rule over the 4 intermediates (B, V, e, dpsi).
//! * B is linear in the four forces with coefficients depending only on (V, beta, delta):
//!   B = sum_j F_j c_j(V, beta, delta) + linear terms; the coefficients are 3-input jets.
//! * The slips depend on 5 inputs (r, V, beta, V_wr, delta), the front force on
//!   (tan alpha_f, dFz, T_bf), the rear forces on (tan alpha_r, kappa_r, dFz): each piece is
//!   a jet over at most 5 variables, substituted by the exact chain rule
//!   [`super::jet::compose_tail`] (intermediates that are plain inputs cost one row each).
//!
//! All inputs and outputs are physical (SI) here; scaling is applied by the callers.

use super::jet::{compose_tail, Arith, D1, D2};
use crate::model::{iu, ix, VehicleParams, NU, NX};

/// Number of tire inputs: [r, V, beta, V_wr, dFz, delta, T_bf] (also the saturation inputs).
pub const NT: usize = 7;
/// Position of each coefficient input [V, beta, delta] among the tire inputs.
const COEF_TO_TIRE: [usize; 3] = [1, 2, 5];
/// Number of defect inputs: [r, V, beta, V_wr, dFz, e, dpsi, delta, T_comb, T_bf].
pub const NF: usize = 10;
/// Position of each tire input among the defect inputs.
pub const TIRE_TO_FULL: [usize; NT] = [0, 1, 2, 3, 4, 7, 9];
/// Position of each slip input [r, V, beta, V_wr, delta] among the tire inputs.
const SLIP_TO_TIRE: [usize; 5] = [0, 1, 2, 3, 5];

// Tire-input indices.
const T_DFZ: usize = 4;
const T_TBF: usize = 6;
// Defect-input indices.
const F_V: usize = 1;
const F_E: usize = 5;
const F_DPSI: usize = 6;
const F_TCOMB: usize = 8;

/// Slips (tan alpha_f, tan alpha_r, kappa_r) from r, V, beta, V_wr, delta (paper Sec. II-A,
/// same operations as [`crate::model::tire_forces`]).
#[inline(always)]
pub fn slips<T: Arith>(p: &VehicleParams, r: T, v: T, beta: T, v_wr: T, delta: T) -> [T; 3] {
    let (sb, cb) = beta.sin_cos();
    let vx = v * cb;
    let inv_vx = vx.recip();
    let vy = v * sb;
    let tan_af_plus = (vy + r * p.a) * inv_vx;
    let td = delta.tan();
    let tan_alpha_f = (tan_af_plus - td) / (tan_af_plus * td + 1.0);
    let tan_alpha_r = (vy - r * p.b) * inv_vx;
    let kappa_r = (v_wr - vx) * inv_vx;
    [tan_alpha_f, tan_alpha_r, kappa_r]
}

/// Fiala total force (R4), branch on the real part (as [`crate::model::tire::fiala_total`]).
#[inline(always)]
fn fiala<T: Arith>(c: f64, sigma: T, fmax: T) -> T {
    let x = sigma * c / (fmax * 3.0);
    if x.re() < 1.0 {
        let one_m = -x + 1.0;
        fmax * (-(one_m * one_m * one_m) + 1.0)
    } else {
        fmax
    }
}

/// Smooth floor of R7 (as [`crate::model::tire::smooth_floor`]).
#[inline(always)]
fn smooth_floor<T: Arith>(d: T, q_min: f64) -> T {
    let dd = d - q_min;
    (dd + (dd * dd + q_min * q_min).sqrt()) * 0.5 + q_min
}

/// Front slip norm sigma_f (R6, with the eps guard) from tan alpha_f.
#[inline(always)]
fn front_sigma<T: Arith>(p: &VehicleParams, tan_alpha_f: T) -> T {
    (tan_alpha_f * tan_alpha_f + p.eps_sigma * p.eps_sigma).sqrt()
}

/// Front force capacity F_max,f de-rated by the brake force and floored (R7) from
/// (dFz, T_bf).
#[inline(always)]
fn front_fmax<T: Arith>(p: &VehicleParams, dfz: T, t_bf: T) -> T {
    let fxf = t_bf / p.r_w;
    let mu_fzf = (-dfz + p.fz_nom_front()) * p.mu;
    let d = mu_fzf * mu_fzf - fxf * fxf;
    let q_min = {
        let f = p.fmax_floor_frac * p.mu * p.fz_nom_front();
        f * f
    };
    smooth_floor(d, q_min).sqrt()
}

/// Front axle: [F_yf, sigma_f - sigma_sl,f] from (tan alpha_f, dFz, T_bf) (R1, R4, R6, R7).
#[inline(always)]
pub fn front<T: Arith>(p: &VehicleParams, tan_alpha_f: T, dfz: T, t_bf: T) -> [T; 2] {
    let sigma = front_sigma(p, tan_alpha_f);
    let fmax = front_fmax(p, dfz, t_bf);
    let ftotal = fiala(p.c_f, sigma, fmax);
    let fyf = -(ftotal / sigma * tan_alpha_f);
    [fyf, sigma - fmax * (3.0 / p.c_f)]
}

/// Rear slip norm sigma_r (R6, with the eps guard) from (tan alpha_r, kappa_r).
#[inline(always)]
fn rear_sigma<T: Arith>(p: &VehicleParams, tan_alpha_r: T, kappa_r: T) -> T {
    (tan_alpha_r * tan_alpha_r + kappa_r * kappa_r + p.eps_sigma * p.eps_sigma).sqrt()
}

/// Rear force capacity F_max,r = mu F_zr from dFz.
#[inline(always)]
fn rear_fmax<T: Arith>(p: &VehicleParams, dfz: T) -> T {
    (dfz + p.fz_nom_rear()) * p.mu
}

/// Rear axle: [F_xr, F_yr, sigma_r - sigma_sl,r] from (tan alpha_r, kappa_r, dFz).
#[inline(always)]
pub fn rear<T: Arith>(p: &VehicleParams, tan_alpha_r: T, kappa_r: T, dfz: T) -> [T; 3] {
    let sigma = rear_sigma(p, tan_alpha_r, kappa_r);
    let fmax = rear_fmax(p, dfz);
    let ftotal = fiala(p.c_r, sigma, fmax);
    let gr = ftotal / sigma;
    [
        gr * kappa_r,
        -(gr * tan_alpha_r),
        sigma - fmax * (3.0 / p.c_r),
    ]
}

/// Spatial derivatives f = dx/ds of paper eq. (1) (as [`crate::model::spatial_derivatives`])
/// from x = [r, V, beta, V_wr, dFz, e, dpsi] (V_wr unused), delta, T_comb and the tire
/// forces [F_xf, F_yf, F_xr, F_yr]. Row s is the constant 1.
#[inline(always)]
pub fn spatial_rows<T: Arith>(
    p: &VehicleParams,
    x: &[T; 7],
    delta: T,
    t_comb: T,
    forces: &[T; 4],
    kappa: f64,
) -> [T; NX] {
    let [r, v, beta, _, dfz, e, dpsi] = *x;
    let [fxf, fyf, fxr, fyr] = *forces;
    let (sd, cd) = delta.sin_cos();
    let (sb, cb) = beta.sin_cos();
    let (sdb, cdb) = (delta - beta).sin_cos();
    let r_dot = ((fxf * sd + fyf * cd) * p.a - fyr * p.b) / p.i_z;
    let v_dot = (fxf * cdb - fyf * sdb + fxr * cb + fyr * sb) / p.m;
    let beta_dot = (fxf * sdb + fyf * cdb - fxr * sb + fyr * cb) / (v * p.m) - r;
    let vwr_dot = (t_comb - fxr * p.r_w) * (p.r_w / p.i_w);
    let fx_net = fxr + fxf * cd - fyf * sd;
    let dfz_dot = -(dfz - fx_net * (p.h_cg / p.l)) * p.c_l;
    let (sp, cp) = dpsi.sin_cos();
    let sdot = v * cp / (-(e * kappa) + 1.0);
    let e_dot = v * sp;
    let dpsi_dot = beta_dot + r - sdot * kappa;
    let inv = sdot.recip();
    [
        r_dot * inv,
        v_dot * inv,
        beta_dot * inv,
        vwr_dot * inv,
        dfz_dot * inv,
        e_dot * inv,
        dpsi_dot * inv,
        T::cst(1.0),
        inv,
    ]
}

/// Spatial derivatives f = dx/ds (physical) over any [`Arith`] scalar from r..dpsi of the
/// state and the controls: the same operations as [`defect_jacobian`], so a jet of it
/// equals the oracle's (explicit RK differentiates through nested calls of it).
#[inline(always)]
pub fn spatial<T: Arith>(p: &VehicleParams, x: &[T; 7], u: &[T; NU], kappa: f64) -> [T; NX] {
    let [r, v, beta, v_wr, dfz, _, _] = *x;
    let [taf, tar, kr] = slips(p, r, v, beta, v_wr, u[iu::DELTA]);
    let [fyf, _] = front(p, taf, dfz, u[iu::TBF]);
    let [fxr, fyr, _] = rear(p, tar, kr, dfz);
    let fxf = u[iu::TBF] / p.r_w;
    spatial_rows(
        p,
        x,
        u[iu::DELTA],
        u[iu::TCOMB],
        &[fxf, fyf, fxr, fyr],
        kappa,
    )
}

/// Tire inputs [r, V, beta, V_wr, dFz, delta, T_bf] of a physical (x, u).
#[inline(always)]
fn tire_inputs(x: &[f64; NX], u: &[f64; NU]) -> [f64; NT] {
    [
        x[ix::R],
        x[ix::V],
        x[ix::BETA],
        x[ix::VWR],
        x[ix::DFZ],
        u[iu::DELTA],
        u[iu::TBF],
    ]
}

/// First-order jets of the tire forces [F_xf, F_yf, F_xr, F_yr] and the saturation values
/// [front, rear] over the tire inputs.
#[inline(always)]
fn tire_d1(p: &VehicleParams, ti: &[f64; NT]) -> ([D1<NT>; 4], [D1<NT>; 2]) {
    let s: [D1<NT>; NT] = std::array::from_fn(|i| D1::var(ti[i], i));
    let [taf, tar, kr] = slips(p, s[0], s[1], s[2], s[3], s[5]);
    let [fyf, sat_f] = front(p, taf, s[4], s[6]);
    let [fxr, fyr, sat_r] = rear(p, tar, kr, s[4]);
    let fxf = s[6] / p.r_w;
    ([fxf, fyf, fxr, fyr], [sat_f, sat_r])
}

/// Spatial derivatives f(x, u) (physical) with their gradients over the defect inputs
/// [r, V, beta, V_wr, dFz, e, dpsi, delta, T_comb, T_bf] (row s: constant 1).
#[inline(always)]
pub fn defect_jacobian(
    p: &VehicleParams,
    x: &[f64; NX],
    u: &[f64; NU],
    kappa: f64,
) -> [D1<NF>; NX] {
    let ti = tire_inputs(x, u);
    let (forces, _) = tire_d1(p, &ti);
    let forces: [D1<NF>; 4] = std::array::from_fn(|j| forces[j].embed(&TIRE_TO_FULL));
    let xs: [D1<NF>; 7] = std::array::from_fn(|i| D1::var(x[i], i));
    spatial_rows(
        p,
        &xs,
        D1::var(u[iu::DELTA], 7),
        D1::var(u[iu::TCOMB], F_TCOMB),
        &forces,
        kappa,
    )
}

/// Saturation values [front, rear] (physical, before the row scaling) with their gradients
/// over the tire inputs [r, V, beta, V_wr, dFz, delta, T_bf].
#[inline(always)]
pub fn saturation_jacobian(p: &VehicleParams, x: &[f64; NX], u: &[f64; NU]) -> [D1<NT>; 2] {
    tire_d1(p, &tire_inputs(x, u)).1
}

/// Slip jets (tan alpha_f, tan alpha_r, kappa_r) over the 5 slip inputs
/// [r, V, beta, V_wr, delta] (tire inputs `SLIP_TO_TIRE`).
#[inline(always)]
fn slips_d2(p: &VehicleParams, ti: &[f64; NT]) -> [D2<5>; 3] {
    let s: [D2<5>; 5] = std::array::from_fn(|i| D2::var(ti[SLIP_TO_TIRE[i]], i));
    slips(p, s[0], s[1], s[2], s[3], s[4])
}

/// Second-order jet of `w[0] sat_f + w[1] sat_r` (physical saturation values) over the tire
/// inputs [r, V, beta, V_wr, dFz, delta, T_bf].
///
/// Each row is a slip norm minus a multiple of a force capacity (R5-R7): the norms depend
/// on the 5 slip inputs alone, the capacities on (dFz, T_bf) alone, so the Hessian is two
/// diagonal blocks, built directly over 5 and 2 inputs.
#[inline(always)]
pub fn saturation_hessian(p: &VehicleParams, x: &[f64; NX], u: &[f64; NU], w: [f64; 2]) -> D2<NT> {
    let ti = tire_inputs(x, u);
    let [taf, tar, kr] = slips_d2(p, &ti);
    let norms = front_sigma(p, taf) * w[0] + rear_sigma(p, tar, kr) * w[1];
    let dfz = D2::<2>::var(ti[T_DFZ], 0);
    let caps = front_fmax(p, dfz, D2::var(ti[T_TBF], 1)) * (-(3.0 / p.c_f) * w[0])
        + rear_fmax(p, dfz) * (-(3.0 / p.c_r) * w[1]);
    let mut out = D2::<NT>::cst(0.0);
    out.add_at(&norms, &SLIP_TO_TIRE);
    out.add_at(&caps, &[T_DFZ, T_TBF]);
    out
}

/// Second-order jet of `phi = sum_{i != s} w[i] f_i(x, u)` (f = physical spatial
/// derivatives, `w[ix::S]` ignored) over the defect inputs
/// [r, V, beta, V_wr, dFz, e, dpsi, delta, T_comb, T_bf].
#[inline(always)]
pub fn defect_hessian(
    p: &VehicleParams,
    x: &[f64; NX],
    u: &[f64; NU],
    kappa: f64,
    w: &[f64; NX],
) -> D2<NF> {
    let ti = tire_inputs(x, u);
    // Forces over the tire inputs.
    let [taf, tar, kr] = slips_d2(p, &ti).map(|j| j.embed::<NT>(&SLIP_TO_TIRE));
    let tbf = D2::<NT>::var(ti[T_TBF], T_TBF);
    let fyf3 = front(
        p,
        D2::<3>::var(taf.re, 0),
        D2::var(ti[T_DFZ], 1),
        D2::var(ti[T_TBF], 2),
    )[0];
    let fyf = compose_tail(&fyf3, &[taf], &[T_DFZ, T_TBF]);
    let [fxr3, fyr3, _] = rear(
        p,
        D2::<3>::var(tar.re, 0),
        D2::var(kr.re, 1),
        D2::var(ti[T_DFZ], 2),
    );
    let rear_in = [tar, kr];
    let fxr = compose_tail(&fxr3, &rear_in, &[T_DFZ]);
    let fyr = compose_tail(&fyr3, &rear_in, &[T_DFZ]);
    let fxf = tbf / p.r_w;

    // Coefficients of the forces in B over (V, beta, delta):
    // B = w_r r_dot + w_V V_dot + (w_beta + w_dpsi) beta_dot_F - w_beta r + w_Vwr V_wr_dot
    //     + w_dFz dFz_dot + w_t, with beta_dot = beta_dot_F - r (dpsi_dot = beta_dot + r -
    // kappa sdot; the kappa sdot / sdot part is the constant -w_dpsi kappa).
    let v3 = D2::<3>::var(x[ix::V], 0);
    let b3 = D2::<3>::var(x[ix::BETA], 1);
    let d3 = D2::<3>::var(u[iu::DELTA], 2);
    let (sd, cd) = d3.sin_cos();
    let (sb, cb) = b3.sin_cos();
    let (sdb, cdb) = (d3 - b3).sin_cos();
    let k_a = w[ix::R] * p.a / p.i_z;
    let k_b = w[ix::R] * p.b / p.i_z;
    let k_v = w[ix::V] / p.m;
    let k_w = w[ix::VWR] * p.r_w * p.r_w / p.i_w;
    let k_z = w[ix::DFZ] * p.c_l * p.h_cg / p.l;
    let bw = (v3 * p.m).recip() * (w[ix::BETA] + w[ix::DPSI]);
    let c_fxf = sd * k_a + cdb * k_v + sdb * bw + cd * k_z;
    let c_fyf = cd * k_a - sdb * k_v + cdb * bw - sd * k_z;
    let c_fxr = cb * k_v - sb * bw + (k_z - k_w);
    let c_fyr = sb * k_v + cb * bw - k_b;
    let e = |c: D2<3>| c.embed::<NT>(&COEF_TO_TIRE);
    let mut b7 = fxf * e(c_fxf) + fyf * e(c_fyf) + fxr * e(c_fxr) + fyr * e(c_fyr);
    // Linear terms in r and dFz, and the constant w_t.
    b7.re += -w[ix::BETA] * x[ix::R] - w[ix::DFZ] * p.c_l * x[ix::DFZ] + w[ix::T];
    b7.g[0] -= w[ix::BETA];
    b7.g[T_DFZ] -= w[ix::DFZ] * p.c_l;
    let mut b = b7.embed::<NF>(&TIRE_TO_FULL);
    // T_comb enters only V_wr_dot, linearly.
    let k_t = w[ix::VWR] * p.r_w / p.i_w;
    b.re += k_t * u[iu::TCOMB];
    b.g[F_TCOMB] += k_t;

    // phi = B (1 - kappa e) / (V cos dpsi) + w_e tan(dpsi) (1 - kappa e) - w_dpsi kappa.
    let b4 = D2::<4>::var(b.re, 0);
    let v4 = D2::<4>::var(x[ix::V], 1);
    let e4 = D2::<4>::var(x[ix::E], 2);
    let p4 = D2::<4>::var(x[ix::DPSI], 3);
    let one_m = -(e4 * kappa) + 1.0;
    let (sp, cp) = p4.sin_cos();
    let phi4 = (b4 + sp * v4 * w[ix::E]) * one_m / (v4 * cp) - w[ix::DPSI] * kappa;
    compose_tail(&phi4, &[b], &[F_V, F_E, F_DPSI])
}
