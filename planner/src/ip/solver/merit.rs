//! Backtracking line search on the l2 merit function phi_nu = barrier objective +
//! nu ||c||_2 (paper eq. 5), with a penalty update and a second-order correction.

use super::clock::{Deadline, OutOfTime};
use super::{norm2, Solver};
use crate::ip::kkt::KktSolver;
use crate::ip::nlp::Nlp;
use crate::ip::sparse;

impl<K: KktSolver> Solver<K> {
    /// Backtracking line search on phi_nu = barrier objective + nu ||c||_2 (paper eq. 5).
    /// Returns (alpha, backtracks, used second-order correction), or None on failure;
    /// `Err(OutOfTime)` when `deadline`, checked before each trial, has passed.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn line_search<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu: f64,
        nu: &mut f64,
        delta_w: f64,
        deadline: Deadline,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Result<Option<(f64, usize, bool)>, OutOfTime> {
        let s = self.settings;
        let (n, m) = (self.ws.n, self.ws.m);
        let tau = (1.0 - mu).max(s.tau_min);
        let (alpha_max, alpha_z) = self.max_steps(tau);

        // Model quantities: barrier gradient . d, curvature, linearized residual.
        let (grad_d, curv, theta, theta_lin) = {
            let ws = &mut self.ws;
            let mut gd = 0.0;
            for j in 0..n + m {
                let mut gj = if j < n { ws.grad[j] } else { 0.0 };
                if ws.has_lo[j] {
                    gj -= mu / (ws.w[j] - ws.lo[j]);
                }
                if ws.has_hi[j] {
                    gj += mu / (ws.hi[j] - ws.w[j]);
                }
                gd += gj * ws.dw[j];
            }
            ws.tmp_w.iter_mut().for_each(|v| *v = 0.0);
            sparse::hess_mul(
                &ws.hess_rows,
                &ws.hess_cols,
                &ws.hess,
                &ws.dw[..n],
                &mut ws.tmp_w[..n],
            );
            let mut curv = 0.0;
            for j in 0..n + m {
                curv += ws.dw[j] * (ws.tmp_w[j] + ws.sigma[j] * ws.dw[j]);
            }
            ws.tmp_m.copy_from_slice(&ws.c);
            sparse::jac_mul(
                &ws.jac_rows,
                &ws.jac_cols,
                &ws.jac,
                &ws.dw[..n],
                &mut ws.tmp_m,
            );
            for i in 0..m {
                if !ws.is_eq[i] {
                    ws.tmp_m[i] -= ws.dw[n + i];
                }
            }
            let theta = norm2(&ws.c);
            let theta_lin = norm2(&ws.tmp_m);
            (gd, curv, theta, theta_lin)
        };
        // Penalty update so the step is a descent direction of the merit (Nocedal-Wright 18.36).
        let rho = 0.1;
        let reduction = theta - theta_lin;
        if reduction > 1e-12 * theta.max(1.0) {
            let nu_trial = (grad_d + 0.5 * curv.max(0.0)) / ((1.0 - rho) * reduction);
            if nu_trial > *nu {
                *nu = (nu_trial * 1.1).max(*nu * 1.5).min(1e12);
            }
        }
        let dir_deriv = grad_d - *nu * reduction;
        let phi0 = self.barrier_value(&self.ws.w, self.ws.f, mu) + *nu * theta;

        let mut alpha = alpha_max;
        let mut soc_tried = false;
        for bt in 0..s.max_backtracks {
            deadline.check()?;
            self.set_trial(alpha);
            if let Some((f_t, _, _)) = self.eval_trial(nlp, mu, teval, evals) {
                let theta_t = norm2(&self.ws.c_t);
                let phi_t = self.barrier_value(&self.ws.w_t, f_t, mu) + *nu * theta_t;
                if phi_t.is_finite() && phi_t <= phi0 + s.armijo * alpha * dir_deriv.min(0.0) {
                    self.accept(f_t, alpha, alpha_z, mu, true);
                    return Ok(Some((alpha, bt, false)));
                }
                // Second-order correction on the first rejected full step.
                if s.second_order_correction && bt == 0 && !soc_tried && theta_t >= theta {
                    soc_tried = true;
                    deadline.check()?;
                    if let Some(a) = self.try_soc(
                        nlp, mu, *nu, phi0, dir_deriv, alpha, delta_w, tau, teval, evals,
                    ) {
                        return Ok(Some((a, bt, true)));
                    }
                }
            }
            alpha *= 0.5;
            if alpha < 1e-14 {
                break;
            }
        }
        Ok(None)
    }

    /// Second-order correction: re-solve with c_soc = alpha c(w) + c(w + alpha d).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn try_soc<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu: f64,
        nu: f64,
        phi0: f64,
        dir_deriv: f64,
        alpha: f64,
        delta_w: f64,
        tau: f64,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Option<f64> {
        let s = self.settings;
        {
            let ws = &mut self.ws;
            for i in 0..ws.m {
                ws.tmp_m[i] = alpha * ws.c[i] + ws.c_t[i];
            }
        }
        self.solve_direction(delta_w, true);
        let (ap, az) = self.max_steps(tau);
        self.set_trial(ap);
        let Some((f_t, _, _)) = self.eval_trial(nlp, mu, teval, evals) else {
            self.restore_direction(delta_w);
            return None;
        };
        let theta_t = norm2(&self.ws.c_t);
        let phi_t = self.barrier_value(&self.ws.w_t, f_t, mu) + nu * theta_t;
        if phi_t.is_finite() && phi_t <= phi0 + s.armijo * ap * dir_deriv.min(0.0) {
            self.accept(f_t, ap, az, mu, true);
            Some(ap)
        } else {
            self.restore_direction(delta_w);
            None
        }
    }
}
