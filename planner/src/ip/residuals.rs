//! Optimality measures of the primal-dual iterate (IPOPT's scaled KKT error).

use super::workspace::Workspace;

/// Scaled KKT errors of one iterate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Errors {
    /// Max |c| (constraint violation of g(x) - s).
    pub inf_pr: f64,
    /// ||c||_1, the filter's violation measure.
    pub theta: f64,
    /// Max |grad L| (unscaled).
    pub inf_du: f64,
    /// Max complementarity |slack * z| (unscaled, mu = 0).
    pub compl: f64,
    /// Max complementarity deviation from mu (unscaled).
    pub compl_mu: f64,
    /// Dual scaling s_d.
    pub s_d: f64,
    /// Complementarity scaling s_c.
    pub s_c: f64,
    /// Average complementarity product.
    pub mu_avg: f64,
}

impl Errors {
    /// Overall scaled error with mu = 0.
    pub fn overall(&self) -> f64 {
        (self.inf_du / self.s_d)
            .max(self.inf_pr)
            .max(self.compl / self.s_c)
    }
    /// Overall scaled error of the barrier subproblem.
    pub fn overall_mu(&self) -> f64 {
        (self.inf_du / self.s_d)
            .max(self.inf_pr)
            .max(self.compl_mu / self.s_c)
    }
}

/// Computes c = g - s (equalities: g - g_l) into `c`.
pub fn constraint_residual(
    ws_is_eq: &[bool],
    g_l: &[f64],
    n: usize,
    g: &[f64],
    w: &[f64],
    c: &mut [f64],
) {
    for i in 0..g.len() {
        c[i] = if ws_is_eq[i] {
            g[i] - g_l[i]
        } else {
            g[i] - w[n + i]
        };
    }
}

/// Dual residual grad L over w into `ws.tmp_w` (and grad f + J^T y into `ws.grad_lag`);
/// returns the KKT errors at mu.
pub fn compute_errors(ws: &mut Workspace, mu: f64) -> Errors {
    let n = ws.n;
    let m = ws.m;
    let r = &mut ws.tmp_w;
    r[..n].copy_from_slice(&ws.grad);
    r[n..].iter_mut().for_each(|v| *v = 0.0);
    ws.jac_t.t_mul(&ws.jac, &ws.y, &mut r[..n]);
    ws.grad_lag.copy_from_slice(&ws.tmp_w[..n]);
    let (inf_pr, y_sum) = super::vector::slack_terms(ws);
    let super::vector::BoundErrors {
        inf_du,
        compl,
        compl_mu,
        z_sum,
        compl_sum,
    } = super::vector::bound_errors(ws, mu);
    let s_max = 100.0;
    let nc = ws.n_compl.max(1) as f64;
    let s_d = ((y_sum + z_sum) / (m as f64 + nc)).max(s_max) / s_max;
    let s_c = (z_sum / nc).max(s_max) / s_max;
    Errors {
        inf_pr,
        theta: super::vector::norm1(&ws.c),
        inf_du,
        compl,
        compl_mu,
        s_d,
        s_c,
        mu_avg: if ws.n_compl > 0 { compl_sum / nc } else { 0.0 },
    }
}
