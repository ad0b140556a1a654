//! Coupled-slip Fiala brush tire model (paper Sec. II-A, tire equations) with the
//! resolutions R1, R4, R6 and R7 of `lc500.toml`, generic over the scalar type.
//!
//! Smoothing and what it does to the physics:
//! * `eps_sigma` (R6): sigma = sqrt(tan^2 alpha + kappa^2 + eps_sigma^2) is never zero, so
//!   F_y = -F_total tan(alpha)/sigma is smooth at zero slip. Near zero slip the effective
//!   cornering stiffness is C sigma_0/sigma, i.e. reduced by about C eps/(3 F_max) (~0.5 %)
//!   through the Fiala cubic and by the factor |tan a|/sigma < 1 within ~10 eps of zero slip;
//!   for larger slips the effect is negligible. sigma_f >= eps_sigma even at zero slip, which
//!   also shifts the saturation constraint by at most eps_sigma.
//! * `fmax_floor_frac` (R7): the front friction-circle radicand d = (mu F_zf)^2 - F_xf^2 is
//!   replaced by a smooth floor q(d) >= q_min, so the de-rated front capacity never drops below
//!   about fmax_floor_frac * mu F_zf,nom (~100 N). For d >> q_min, q = d up to a relative error
//!   (q_min/d)^2/4; the R9 constraint keeps d >= 0 at feasible points.
//! * Fiala saturation (R4): F_total = F_max (1 - (1 - min(x, 1))^3), x = C sigma/(3 F_max), is
//!   C2 at x = 1 (value, slope and curvature continuous), so exact Hessians exist; the branch is
//!   chosen on the real part of x.
//! * `eps_sat` (R5, used by the OCP, not by the force law): the saturation constraint
//!   sigma - sigma_sl <= eps_sat lets each tire go up to 0.01 (tan-slip units, ~0.6 deg)
//!   past the onset of full sliding, so brief saturation does not make the OCP infeasible.

use super::{iu, ix, VehicleParams, NU, NX};
use crate::elementary as trig;
use num_dual::DualNum;

/// Tire forces, loads and slips of both axles at one (x, u), generic over the scalar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TireForces<D> {
    /// Front longitudinal force F_xf = T_bf / R_w \[N\] (R1).
    pub fxf: D,
    /// Front lateral force F_yf \[N\].
    pub fyf: D,
    /// Rear longitudinal force F_xr \[N\].
    pub fxr: D,
    /// Rear lateral force F_yr \[N\].
    pub fyr: D,
    /// Front axle load F_zf = m g b / L - dFz \[N\].
    pub fzf: D,
    /// Rear axle load F_zr = m g a / L + dFz \[N\].
    pub fzr: D,
    /// Front slip tan(alpha_f) [-].
    pub tan_alpha_f: D,
    /// Rear slip tan(alpha_r) [-].
    pub tan_alpha_r: D,
    /// Rear slip ratio kappa_r [-] (kappa_f = 0, R1).
    pub kappa_r: D,
    /// Smoothed total front slip sigma_f [-] (R6).
    pub sigma_f: D,
    /// Smoothed total rear slip sigma_r [-] (R6).
    pub sigma_r: D,
    /// De-rated, floored front capacity F_max,f \[N\] (R1, R7).
    pub fmax_f: D,
    /// Rear capacity F_max,r = mu F_zr \[N\].
    pub fmax_r: D,
    /// Front full-sliding slip sigma_sl,f = 3 F_max,f / C_f [-] (R4).
    pub sigma_sl_f: D,
    /// Rear full-sliding slip sigma_sl,r = 3 F_max,r / C_r [-] (R4).
    pub sigma_sl_r: D,
    /// Front total force magnitude F_total,f \[N\].
    pub ftotal_f: D,
    /// Rear total force magnitude F_total,r \[N\].
    pub ftotal_r: D,
}

/// Fiala total force (R4): F_max (1 - (1 - min(x,1))^3), x = C sigma / (3 F_max).
///
/// Equals the paper's cubic C s - C^2 s^2/(3 F_max) + C^3 s^3/(27 F_max^2) below sliding
/// and F_max above; C2 at x = 1. The branch is taken on the real part.
#[inline]
pub fn fiala_total<D: DualNum<Primitive = f64> + Copy>(c: f64, sigma: D, fmax: D) -> D {
    let x = sigma * c / (fmax * 3.0);
    if x.re() < 1.0 {
        let one_m = -x + 1.0;
        fmax * (-(one_m * one_m * one_m) + 1.0)
    } else {
        fmax
    }
}

/// Smooth floor of R7: q = q_min + 0.5 ((d - q_min) + sqrt((d - q_min)^2 + q_min^2)).
#[inline]
pub fn smooth_floor<D: DualNum<Primitive = f64> + Copy>(d: D, q_min: f64) -> D {
    let dd = d - q_min;
    (dd + (dd * dd + q_min * q_min).sqrt()) * 0.5 + q_min
}

/// Slips, loads and capacities (everything except the force magnitudes).
#[derive(Clone, Copy)]
struct Slips<D> {
    fxf: D,
    fzf: D,
    fzr: D,
    tan_alpha_f: D,
    tan_alpha_r: D,
    kappa_r: D,
    sigma_f: D,
    sigma_r: D,
    fmax_f: D,
    fmax_r: D,
}

#[inline]
fn slips<D: DualNum<Primitive = f64> + Copy>(
    p: &VehicleParams,
    x: &[D; NX],
    u: &[D; NU],
) -> Slips<D> {
    let r = x[ix::R];
    let v = x[ix::V];
    let beta = x[ix::BETA];
    let v_wr = x[ix::VWR];
    let dfz = x[ix::DFZ];
    let delta = u[iu::DELTA];
    let t_bf = u[iu::TBF];

    // Loads (paper Sec. II-A): F_zf = F_nom,zf - dFz, F_zr = F_nom,zr + dFz.
    let fzf = -dfz + p.fz_nom_front();
    let fzr = dfz + p.fz_nom_rear();

    // Slips (paper Sec. II-A).
    let (sb, cb) = trig::sin_cos(beta);
    let vx = v * cb;
    let inv_vx = vx.recip();
    let vy = v * sb;
    // tan(alpha_f + delta) = (V sin beta + a r)/(V cos beta); tan(alpha_f) by the tan
    // subtraction formula tan(A - delta) = (tan A - tan delta)/(1 + tan A tan delta).
    let tan_af_plus = (vy + r * p.a) * inv_vx;
    let td = trig::tan(delta);
    let tan_alpha_f = (tan_af_plus - td) / (tan_af_plus * td + 1.0);
    // tan(alpha_r) = (V sin beta - b r)/(V cos beta).
    let tan_alpha_r = (vy - r * p.b) * inv_vx;
    // kappa_r = (V_wr - V cos beta)/(V cos beta); kappa_f = 0 (R1: no front wheel state).
    let kappa_r = (v_wr - vx) * inv_vx;

    // Total slips with the R6 smoothing.
    let eps2 = p.eps_sigma * p.eps_sigma;
    let sigma_f = (tan_alpha_f * tan_alpha_f + eps2).sqrt();
    let sigma_r = (tan_alpha_r * tan_alpha_r + kappa_r * kappa_r + eps2).sqrt();

    // Front brake force (R1) and de-rated front capacity with the R7 floor.
    let fxf = t_bf / p.r_w;
    let mu_fzf = fzf * p.mu;
    let d = mu_fzf * mu_fzf - fxf * fxf;
    let q_min = {
        let f = p.fmax_floor_frac * p.mu * p.fz_nom_front();
        f * f
    };
    let fmax_f = smooth_floor(d, q_min).sqrt();
    // Rear capacity F_max,r = mu F_zr (paper).
    let fmax_r = fzr * p.mu;
    Slips {
        fxf,
        fzf,
        fzr,
        tan_alpha_f,
        tan_alpha_r,
        kappa_r,
        sigma_f,
        sigma_r,
        fmax_f,
        fmax_r,
    }
}

/// Evaluates slips, loads and forces of both axles at state `x` and control `u`
/// (only r, V, beta, V_wr, dFz, delta, T_bf are read).
#[inline]
pub fn tire_forces<D: DualNum<Primitive = f64> + Copy>(
    p: &VehicleParams,
    x: &[D; NX],
    u: &[D; NU],
) -> TireForces<D> {
    let Slips {
        fxf,
        fzf,
        fzr,
        tan_alpha_f,
        tan_alpha_r,
        kappa_r,
        sigma_f,
        sigma_r,
        fmax_f,
        fmax_r,
    } = slips(p, x, u);

    // Fiala magnitude (R4).
    let ftotal_f = fiala_total(p.c_f, sigma_f, fmax_f);
    let ftotal_r = fiala_total(p.c_r, sigma_r, fmax_r);

    // Force directions (paper): F_y = -F_total tan(alpha)/sigma, F_xr = F_total kappa_r/sigma_r.
    let gf = ftotal_f / sigma_f;
    let gr = ftotal_r / sigma_r;
    let fyf = -(gf * tan_alpha_f);
    let fyr = -(gr * tan_alpha_r);
    let fxr = gr * kappa_r;

    TireForces {
        fxf,
        fyf,
        fxr,
        fyr,
        fzf,
        fzr,
        tan_alpha_f,
        tan_alpha_r,
        kappa_r,
        sigma_f,
        sigma_r,
        fmax_f,
        fmax_r,
        sigma_sl_f: fmax_f * (3.0 / p.c_f),
        sigma_sl_r: fmax_r * (3.0 / p.c_r),
        ftotal_f,
        ftotal_r,
    }
}

/// Tire saturation constraint values (R4, R5): [sigma_f - sigma_sl,f, sigma_r - sigma_sl,r];
/// the OCP requires each to be <= eps_sat.
#[inline]
pub fn saturation<D: DualNum<Primitive = f64> + Copy>(
    p: &VehicleParams,
    x: &[D; NX],
    u: &[D; NU],
) -> [D; 2] {
    let t = slips(p, x, u);
    [
        t.sigma_f - t.fmax_f * (3.0 / p.c_f),
        t.sigma_r - t.fmax_r * (3.0 / p.c_r),
    ]
}
