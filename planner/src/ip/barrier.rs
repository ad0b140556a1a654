//! Barrier parameter rules (paper Sec. VI-C): the pieces shared by the solver loop.

use super::workspace::Workspace;

/// Monotone (Fiacco-McCormick) decrease: mu <- max(tol/10, min(kappa mu, mu^theta))
/// (Waechter & Biegler 2006, eq. 7; IPOPT uses kappa = 0.2, theta = 1.5).
pub fn monotone_next(mu: f64, kappa: f64, theta: f64, tol: f64, mu_min: f64) -> f64 {
    (kappa * mu).min(mu.powf(theta)).max(tol / 10.0).max(mu_min)
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
