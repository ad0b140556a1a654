//! Barrier parameter rules (paper Sec. VI-C): the pieces shared by the solver loop.

use super::workspace::Workspace;
use crate::elementary::{exp, ln, pow};

/// The monotone rule's last barrier parameter, as a fraction of the tolerance `tol`.
/// IPOPT stops at tol / 11 so that its barrier-subproblem test implies convergence; here
/// convergence is tested on the unperturbed KKT error at every iteration, and the last
/// subproblem's solution has s z = mu < tol already, so half the tolerance suffices. A
/// smaller floor adds a subproblem whose first step overshoots.
pub const MU_FLOOR_TOL_FRACTION: f64 = 0.5;

/// Centring fraction of the complementarity-gap rule (`adaptive`): mu = GAP_SIGMA s^T z / m,
/// the usual fixed sigma of primal-dual methods (Nocedal & Wright 2006, Sec. 14.2;
/// Nocedal, Waechter, Waltz 2009, Sec. 2).
pub const GAP_SIGMA: f64 = 0.1;

/// Monotone (Fiacco-McCormick) decrease: mu <- max(tol/2, min(kappa mu, mu^theta))
/// (Waechter & Biegler 2006, eq. 7; IPOPT uses kappa = 0.2, theta = 1.5; the floor is
/// [`MU_FLOOR_TOL_FRACTION`]).
pub fn monotone_next(mu: f64, kappa: f64, theta: f64, tol: f64, mu_min: f64) -> f64 {
    (kappa * mu)
        .min(pow(mu, theta))
        .max(tol * MU_FLOOR_TOL_FRACTION)
        .max(mu_min)
}

/// Average complementarity after steps (alpha_p, alpha_d) along the current direction
/// (the Mehrotra predictor's mu_aff).
pub fn complementarity_after(ws: &Workspace, alpha_p: f64, alpha_d: f64) -> f64 {
    let mut sum = 0.0;
    for j in 0..ws.n + ws.m {
        if ws.has_lo[j] {
            sum += (ws.w[j] - ws.lo[j] + alpha_p * ws.dw[j]) * (ws.zl[j] + alpha_d * ws.dzl[j]);
        }
        if ws.has_hi[j] {
            sum += (ws.hi[j] - ws.w[j] - alpha_p * ws.dw[j]) * (ws.zu[j] + alpha_d * ws.dzu[j]);
        }
    }
    (sum / ws.n_compl.max(1) as f64).max(0.0)
}

/// LOQO rule: mu = 0.1 min(0.05 (1 - xi)/xi, 2)^3 * avg, xi = min product / avg
/// (Vanderbei & Shanno 1999).
pub fn loqo(ws: &Workspace, mu_avg: f64) -> f64 {
    let mut min_p = f64::INFINITY;
    for j in 0..ws.n + ws.m {
        if ws.has_lo[j] {
            min_p = min_p.min((ws.w[j] - ws.lo[j]) * ws.zl[j]);
        }
        if ws.has_hi[j] {
            min_p = min_p.min((ws.hi[j] - ws.w[j]) * ws.zu[j]);
        }
    }
    if mu_avg <= 0.0 || !min_p.is_finite() {
        return mu_avg;
    }
    let xi = (min_p / mu_avg).clamp(1e-12, 1.0);
    0.1 * (0.05 * (1.0 - xi) / xi).min(2.0).powi(3) * mu_avg
}

/// Golden-section evaluations of the quality function per iteration (a fixed cap).
pub const QUALITY_EVALS: usize = 12;

/// Mean squared dual residual (grad f + J^T y - z_l + z_u over x and slacks) and mean
/// squared primal residual c: the two residual terms of the quality function. Uses
/// `tmp_w` as scratch.
pub fn residuals_sq(ws: &mut Workspace) -> (f64, f64) {
    let (n, m) = (ws.n, ws.m);
    ws.tmp_w.iter_mut().for_each(|v| *v = 0.0);
    ws.tmp_w[..n].copy_from_slice(&ws.grad);
    super::sparse::jac_t_mul(
        &ws.jac_rows,
        &ws.jac_cols,
        &ws.jac,
        &ws.y,
        &mut ws.tmp_w[..n],
    );
    for i in 0..m {
        if !ws.is_eq[i] {
            ws.tmp_w[n + i] = -ws.y[i];
        }
    }
    let mut rd = 0.0;
    for j in 0..n + m {
        let r = ws.tmp_w[j] - if ws.has_lo[j] { ws.zl[j] } else { 0.0 }
            + if ws.has_hi[j] { ws.zu[j] } else { 0.0 };
        rd += r * r;
    }
    let rp: f64 = ws.c.iter().map(|c| c * c).sum();
    (rd / (n + m).max(1) as f64, rp / m.max(1) as f64)
}

/// Linearized quality function q_L(sigma) of Nocedal, Waechter, Waltz (2009, eq. 4.4 with
/// mean-squared l2 norms): the direction is d(sigma) = d_aff + sigma (d_1 - d_aff), where
/// d_aff (in the `*_aff` buffers) targets mu = 0 and d_1 (in dw/dzl/dzu) targets the
/// average complementarity; with fraction-to-the-boundary steps (alpha_p, alpha_d),
/// q = (1 - alpha_d)^2 rd2 + (1 - alpha_p)^2 rp2 + mean((s + alpha_p ds)(z + alpha_d dz))^2.
pub fn quality(ws: &Workspace, sigma: f64, tau: f64, rd2: f64, rp2: f64) -> f64 {
    let mix = |aff: f64, one: f64| aff + sigma * (one - aff);
    let mut ap: f64 = 1.0;
    let mut ad: f64 = 1.0;
    for j in 0..ws.n + ws.m {
        let d = mix(ws.dw_aff[j], ws.dw[j]);
        if ws.has_lo[j] {
            if d < 0.0 {
                ap = ap.min(-tau * (ws.w[j] - ws.lo[j]) / d);
            }
            let dz = mix(ws.dzl_aff[j], ws.dzl[j]);
            if dz < 0.0 {
                ad = ad.min(-tau * ws.zl[j] / dz);
            }
        }
        if ws.has_hi[j] {
            if d > 0.0 {
                ap = ap.min(tau * (ws.hi[j] - ws.w[j]) / d);
            }
            let dz = mix(ws.dzu_aff[j], ws.dzu[j]);
            if dz < 0.0 {
                ad = ad.min(-tau * ws.zu[j] / dz);
            }
        }
    }
    let mut cs = 0.0;
    for j in 0..ws.n + ws.m {
        let d = mix(ws.dw_aff[j], ws.dw[j]);
        if ws.has_lo[j] {
            let p = (ws.w[j] - ws.lo[j] + ap * d) * (ws.zl[j] + ad * mix(ws.dzl_aff[j], ws.dzl[j]));
            cs += p * p;
        }
        if ws.has_hi[j] {
            let p = (ws.hi[j] - ws.w[j] - ap * d) * (ws.zu[j] + ad * mix(ws.dzu_aff[j], ws.dzu[j]));
            cs += p * p;
        }
    }
    (1.0 - ad).powi(2) * rd2 + (1.0 - ap).powi(2) * rp2 + cs / ws.n_compl.max(1) as f64
}

/// Minimizes [`quality`] over sigma in [lo, hi] by golden-section search on ln sigma with
/// [`QUALITY_EVALS`] evaluations (deterministic, bounded); returns the best sigma seen.
pub fn quality_sigma(ws: &Workspace, lo: f64, hi: f64, tau: f64, rd2: f64, rp2: f64) -> f64 {
    let (mut a, mut b) = (ln(lo), ln(hi));
    if a.partial_cmp(&b) != Some(std::cmp::Ordering::Less) {
        return hi;
    }
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let q = |t: f64| quality(ws, exp(t), tau, rd2, rp2);
    let mut x1 = b - g * (b - a);
    let mut x2 = a + g * (b - a);
    let (mut q1, mut q2) = (q(x1), q(x2));
    for _ in 2..QUALITY_EVALS {
        if q1 <= q2 {
            b = x2;
            x2 = x1;
            q2 = q1;
            x1 = b - g * (b - a);
            q1 = q(x1);
        } else {
            a = x1;
            x1 = x2;
            q1 = q2;
            x2 = a + g * (b - a);
            q2 = q(x2);
        }
    }
    if q1 <= q2 {
        exp(x1)
    } else {
        exp(x2)
    }
}
