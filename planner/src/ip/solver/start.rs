//! The start of a solve: bounds, the starting point pushed into the relaxed bounds, and
//! least-squares constraint multipliers.

use super::clock::{Clock, Phase};
use super::termination::max_violation;
use super::Solver;
use crate::ip::info::{SolveInfo, Status};
use crate::ip::kkt::{KktSolver, KktValues};
use crate::ip::nlp::Nlp;
use crate::ip::residuals;

impl<K: KktSolver> Solver<K> {
    /// Sets bounds, the starting point and multipliers; false when the input is unusable.
    pub(super) fn initialize<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        info: &mut SolveInfo,
        clock: &mut Clock,
    ) -> bool {
        let s = self.settings;
        let ws = &mut self.ws;
        ws.grad_lag_fresh = false;
        let (n, m) = (ws.n, ws.m);
        // Variable bounds into lo/hi[..n]; constraint bounds into g_l/g_u.
        {
            let (lo_x, _) = ws.lo.split_at_mut(n);
            let (hi_x, _) = ws.hi.split_at_mut(n);
            nlp.bounds(lo_x, hi_x, &mut ws.g_l, &mut ws.g_u);
        }
        for i in 0..m {
            let (l, u) = (ws.g_l[i], ws.g_u[i]);
            // An infinite equality bound would make its residual infinite.
            if l.is_nan() || u.is_nan() || l > u || (l == u && !l.is_finite()) {
                info.status = Status::InvalidInput;
                return false;
            }
            ws.is_eq[i] = l == u;
            ws.lo[n + i] = if ws.is_eq[i] { f64::NEG_INFINITY } else { l };
            ws.hi[n + i] = if ws.is_eq[i] { f64::INFINITY } else { u };
        }
        ws.n_compl = 0;
        for j in 0..n + m {
            let (l, u) = (ws.lo[j], ws.hi[j]);
            if l.is_nan() || u.is_nan() || l > u || l == f64::INFINITY || u == f64::NEG_INFINITY {
                info.status = Status::InvalidInput;
                return false;
            }
            ws.lo_orig[j] = l;
            ws.hi_orig[j] = u;
            ws.set_bounds_present(j, l.is_finite(), u.is_finite());
            if ws.has_lo[j] {
                ws.lo[j] = l - s.bound_relax * l.abs().max(1.0);
                ws.n_compl += 1;
            }
            if ws.has_hi[j] {
                ws.hi[j] = u + s.bound_relax * u.abs().max(1.0);
                ws.n_compl += 1;
            }
        }

        // Starting point.
        nlp.initial_point(&mut ws.w[..n]);
        if ws.w[..n].iter().any(|v| !v.is_finite()) {
            info.status = Status::InvalidInput;
            return false;
        }
        clock.time(Phase::Evaluation, || nlp.eval_g(&ws.w[..n], &mut ws.g));
        info.evaluations += 1;
        info.initial_violation = max_violation(ws);
        for i in 0..m {
            ws.w[n + i] = if ws.is_eq[i] { ws.g_l[i] } else { ws.g[i] };
        }
        // Push into the (relaxed) bounds.
        for j in 0..n + m {
            let (l, u) = (ws.lo[j], ws.hi[j]);
            let v = ws.w[j];
            let range = u - l;
            let v = if ws.has_lo[j] {
                let p = (s.bound_push * l.abs().max(1.0)).min(s.bound_frac * range);
                v.max(l + p)
            } else {
                v
            };
            let v = if ws.has_hi[j] {
                let p = (s.bound_push * u.abs().max(1.0)).min(s.bound_frac * range);
                v.min(u - p)
            } else {
                v
            };
            ws.w[j] = v;
            ws.zl[j] = if ws.has_lo[j] { 1.0 } else { 0.0 };
            ws.zu[j] = if ws.has_hi[j] { 1.0 } else { 0.0 };
        }
        ws.y.iter_mut().for_each(|v| *v = 0.0);
        clock.time(Phase::Evaluation, || {
            ws.f = nlp.eval_f(&ws.w[..n]);
            nlp.eval_g(&ws.w[..n], &mut ws.g);
        });
        info.evaluations += 1;
        if !ws.f.is_finite() || ws.g.iter().any(|v| !v.is_finite()) {
            info.status = Status::InvalidInput;
            return false;
        }
        info.start_violation = max_violation(ws);
        residuals::constraint_residual(&ws.is_eq, &ws.g_l, n, &ws.g, &ws.w, &mut ws.c);
        true
    }

    /// Derivatives at the starting point and the least-squares multipliers from them.
    pub(super) fn start_multipliers<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        info: &mut SolveInfo,
        clock: &mut Clock,
    ) {
        let ws = &mut self.ws;
        clock.time(Phase::Evaluation, || {
            nlp.eval_grad_f(&ws.w[..ws.n], &mut ws.grad);
            nlp.eval_jac_g(&ws.w[..ws.n], &mut ws.jac);
        });
        clock.time(Phase::Factorization, || self.least_squares_multipliers());
        info.factorizations += 1;
    }

    /// Least-squares estimate of y (IPOPT's default initialization): minimize
    /// ||grad f + A^T y - z_l + z_u|| by solving [[I, A^T], [A, 0]] [d; y] = [-(grad - z); 0].
    /// Kept only if ||y||_inf <= 1e3; otherwise y stays zero.
    pub(super) fn least_squares_multipliers(&mut self) {
        const Y_MAX: f64 = 1e3;
        let (n, m) = (self.ws.n, self.ws.m);
        if m == 0 {
            return;
        }
        {
            let ws = &mut self.ws;
            ws.y.iter_mut().for_each(|v| *v = 0.0);
            ws.sigma.iter_mut().for_each(|v| *v = 1.0);
            ws.hess.iter_mut().for_each(|v| *v = 0.0);
            for j in 0..n + m {
                // Targets chosen so that tgt/slack = z: the rhs becomes -(grad - z_l + z_u).
                ws.tgt_l[j] = if ws.has_lo[j] {
                    ws.zl[j] * (ws.w[j] - ws.lo[j])
                } else {
                    0.0
                };
                ws.tgt_u[j] = if ws.has_hi[j] {
                    ws.zu[j] * (ws.hi[j] - ws.w[j])
                } else {
                    0.0
                };
            }
            ws.tmp_m.iter_mut().for_each(|v| *v = 0.0);
        }
        let delta_c = self.settings.delta_c_min.max(1e-8);
        self.fill_diagonals(0.0, delta_c);
        let ws = &self.ws;
        let res = self.kkt.factorize(&KktValues {
            hess: &ws.hess,
            jac: &ws.jac,
            primal_diag: &ws.primal_diag,
            dual_diag: &ws.dual_diag,
        });
        if res.is_err() {
            return;
        }
        self.solve_direction(0.0, true);
        let ws = &mut self.ws;
        let y_max = ws.dy.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if y_max.is_finite() && y_max <= Y_MAX {
            ws.y.copy_from_slice(&ws.dy);
        }
    }
}
