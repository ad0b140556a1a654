//! Feasibility restoration: Gauss-Newton steps on 0.5 ||c||^2 with a barrier on the
//! bounds, taken while a significant violation does not decrease otherwise, and the test
//! for a locally infeasible problem (a stationary point of the violation).

use std::time::Instant;

use super::clock::{Clock, Deadline, OutOfTime, Phase};
use super::inertia::Unfactorized;
use super::{norm2, LoopState, Next, Solver};
use crate::ip::info::{SolveInfo, Status, StepKind};
use crate::ip::kkt::KktSolver;
use crate::ip::nlp::Nlp;
use crate::ip::residuals::Errors;
use crate::ip::sparse;

/// Restoration is for significant violations only; small ones are left to the
/// regularized Newton steps (restoration ignores the objective and would undo it).
const RESTO_MIN_VIOLATION: f64 = 1e-3;

impl LoopState {
    /// Whether a violation `inf_pr` hands over to restoration: it is significant and the
    /// solve has restoration steps left (at most `max_steps`).
    pub(super) fn may_restore(&self, inf_pr: f64, max_steps: usize) -> bool {
        inf_pr > RESTO_MIN_VIOLATION && self.resto_steps < max_steps
    }

    /// Starts restoration at a point with ||c||_2 = `theta`.
    pub(super) fn enter_restoration(&mut self, theta: f64) {
        self.resto = Some(Restoration::new(theta, self.mu.min(0.1)));
    }
}

impl<K: KktSolver> Solver<K> {
    /// One iteration of the restoration phase at an iterate with errors `err`. Returns
    /// None when restoration ends here (the violation fell enough: the iteration goes on
    /// as a regular one), `Next::Continue` after a restoration step, and `Next::Stop` at a
    /// point taken as locally infeasible, when restoration fails, or (`time_limit`) when
    /// the time budget runs out inside the step.
    pub(super) fn restoration_iteration<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        st: &mut LoopState,
        err: &Errors,
        f_iter: f64,
        info: &mut SolveInfo,
        clock: &mut Clock,
    ) -> Option<Next> {
        let s = self.settings;
        let r = st.resto.as_mut()?;
        let theta = norm2(&self.ws.c);
        if theta <= 0.9 * r.theta_entry || err.inf_pr <= s.constr_viol_tol {
            st.resto = None;
            self.ws.filter.clear();
            st.nu = s.penalty_init;
            st.ls_failures = 0;
            st.force_reg = false;
            return None;
        }
        let stat = self.infeasibility_measure();
        // Locally infeasible: a violation well above the acceptable level at a stationary
        // point of 0.5 ||c||^2 (relative to the violation itself).
        let significant = err.inf_pr > 10.0 * s.constr_viol_tol;
        // Converged: stationary to the tolerance, or full Newton steps on the violation
        // that no longer reduce it at a loosely stationary point (the projected measure
        // oscillates near active bounds).
        let stagnant = r.watch(theta) >= RESTO_STAGNATION;
        let stationary =
            stat <= s.infeas_stat_tol * err.inf_pr || (stagnant && stat <= 1e-2 * err.inf_pr);
        if significant && stationary {
            return Some(Next::Stop(Status::LocallyInfeasible));
        }
        // The status when restoration gives up.
        let failed = if significant && stat <= 1e-3 * err.inf_pr {
            Status::LocallyInfeasible
        } else {
            Status::NumericalFailure
        };
        if st.resto_steps >= s.max_restoration_steps {
            return Some(Next::Stop(failed));
        }
        r.mu = (0.2 * r.mu).max(s.mu_min);
        let mu_r = r.mu;
        st.resto_steps += 1;
        let mut nfact = 0;
        let evals = &mut info.evaluations;
        let deadline = clock.deadline;
        let step = clock.time_with_evaluations(Phase::Factorization, |teval| {
            self.restoration_step(nlp, mu_r, &mut nfact, deadline, teval, evals)
        });
        info.factorizations += nfact;
        info.max_factorizations_per_iter = info.max_factorizations_per_iter.max(nfact);
        let Ok(step) = step else {
            return Some(Next::Stop(Status::TimeLimit));
        };
        let Some((alpha, backtracks)) = step else {
            return Some(Next::Stop(failed));
        };
        // In restoration rows the dual column holds the relative stationarity of the
        // violation, ||P(A^T c)|| / ||c||_inf, which decides infeasibility.
        let mut e_log = *err;
        e_log.inf_du = stat / err.inf_pr.max(1e-300);
        e_log.s_d = 1.0;
        self.push_log(
            st.iter,
            f_iter,
            &e_log,
            mu_r,
            alpha,
            0.0,
            nfact,
            backtracks,
            StepKind::Restoration,
        );
        Some(Next::Continue)
    }

    /// Projected gradient of 0.5 ||c||^2 over w (inf-norm): zero at a stationary point of
    /// the constraint violation.
    pub(super) fn infeasibility_measure(&mut self) -> f64 {
        let ws = &mut self.ws;
        let n = ws.n;
        let v = &mut ws.tmp_w;
        v.iter_mut().for_each(|x| *x = 0.0);
        sparse::jac_t_mul(&ws.jac_rows, &ws.jac_cols, &ws.jac, &ws.c, &mut v[..n]);
        for i in 0..ws.m {
            if !ws.is_eq[i] {
                v[n + i] = -ws.c[i];
            }
        }
        let mut r: f64 = 0.0;
        for j in 0..n + ws.m {
            // Projected gradient w - P(w - v): a bound blocks the descent direction -v. The
            // barrier keeps iterates a distance ~mu/z off their bounds, so a bound within
            // `ACTIVE` (relative) counts as reached.
            const ACTIVE: f64 = 1e-5;
            let mut g = v[j];
            if ws.has_lo[j] && g > 0.0 {
                let sl = ws.w[j] - ws.lo[j];
                g = if sl <= ACTIVE * ws.lo[j].abs().max(1.0) {
                    0.0
                } else {
                    g.min(sl)
                };
            }
            if ws.has_hi[j] && g < 0.0 {
                let su = ws.hi[j] - ws.w[j];
                g = if su <= ACTIVE * ws.hi[j].abs().max(1.0) {
                    0.0
                } else {
                    g.max(-su)
                };
            }
            r = r.max(g.abs());
        }
        r
    }

    /// One feasibility-restoration iteration: a regularized Gauss-Newton step on
    /// 0.5 ||c||^2 - mu_r sum ln(slacks), i.e. the KKT system with H = 0 and D_c = -I,
    /// globalized by an Armijo search. Multipliers y are left alone. Returns (alpha,
    /// backtracks), or None when the step failed; `Err(OutOfTime)` when `deadline`,
    /// checked before each factorization and each trial, has passed.
    pub(super) fn restoration_step<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu_r: f64,
        nfact: &mut usize,
        deadline: Deadline,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Result<Option<(f64, usize)>, OutOfTime> {
        let s = self.settings;
        let (n, m) = (self.ws.n, self.ws.m);
        self.ws.grad_lag_fresh = false;
        // Exact Hessian of 0.5 ||c||^2 beyond J^T J: sum_i c_i grad^2 g_i.
        let te = Instant::now();
        {
            let ws = &mut self.ws;
            nlp.eval_hess(&ws.w[..n], 0.0, &ws.c, &mut ws.hess);
        }
        *teval += te.elapsed().as_secs_f64();
        if self.ws.hess.iter().any(|v| !v.is_finite()) {
            return Ok(None);
        }
        let theta = norm2(&self.ws.c);
        let delta = match self.factorize_with(mu_r, false, 1.0, deadline) {
            Ok(f) => {
                *nfact = f.count;
                f.delta_w
            }
            Err(Unfactorized::Failed(count)) => {
                *nfact = count;
                return Ok(None);
            }
            Err(Unfactorized::OutOfTime(count)) => {
                *nfact = count;
                return Err(OutOfTime);
            }
        };
        self.set_targets(mu_r, false);
        self.solve_direction_mode(delta, false, true);
        let tau = (1.0 - mu_r).max(s.tau_min);
        let (alpha_max, alpha_z) = self.max_steps(tau);
        // Directional derivative of the restoration merit.
        let (phi0, dd) = {
            let ws = &mut self.ws;
            ws.tmp_m.iter_mut().for_each(|v| *v = 0.0);
            sparse::jac_mul(
                &ws.jac_rows,
                &ws.jac_cols,
                &ws.jac,
                &ws.dw[..n],
                &mut ws.tmp_m,
            );
            let mut dd = 0.0;
            for i in 0..m {
                let ad = if ws.is_eq[i] {
                    ws.tmp_m[i]
                } else {
                    ws.tmp_m[i] - ws.dw[n + i]
                };
                dd += ws.c[i] * ad;
            }
            for j in 0..n + m {
                if ws.has_lo[j] {
                    dd -= mu_r / (ws.w[j] - ws.lo[j]) * ws.dw[j];
                }
                if ws.has_hi[j] {
                    dd += mu_r / (ws.hi[j] - ws.w[j]) * ws.dw[j];
                }
            }
            let phi0 = 0.5 * theta * theta + self.barrier_value(&self.ws.w, 0.0, mu_r);
            (phi0, dd)
        };
        let mut alpha = alpha_max;
        for bt in 0..s.max_backtracks {
            deadline.check()?;
            self.set_trial(alpha);
            if let Some((f_t, _, _)) = self.eval_trial(nlp, mu_r, teval, evals) {
                let th = norm2(&self.ws.c_t);
                let phi = 0.5 * th * th + self.barrier_value(&self.ws.w_t, 0.0, mu_r);
                if phi.is_finite() && phi <= phi0 + s.armijo * alpha * dd.min(0.0) {
                    self.accept(f_t, alpha, alpha_z, mu_r, false);
                    return Ok(Some((alpha, bt)));
                }
            }
            alpha *= 0.5;
            if alpha < 1e-14 {
                break;
            }
        }
        Ok(None)
    }
}

/// State of the feasibility restoration phase.
#[derive(Debug, Clone, Copy)]
pub(super) struct Restoration {
    /// ||c||_2 when restoration started; left once reduced by 10 %.
    theta_entry: f64,
    /// Barrier parameter of the restoration merit.
    mu: f64,
    /// Smallest ||c||_2 seen in this restoration phase.
    theta_best: f64,
    /// Restoration steps since ||c||_2 last fell 1 % below `theta_best`.
    stagnant: usize,
}

impl Restoration {
    pub(super) fn new(theta_entry: f64, mu: f64) -> Self {
        Self {
            theta_entry,
            mu,
            theta_best: theta_entry,
            stagnant: 0,
        }
    }

    /// Records ||c||_2 of the current point; returns the steps without progress.
    pub(super) fn watch(&mut self, theta: f64) -> usize {
        if theta < 0.99 * self.theta_best {
            self.theta_best = theta;
            self.stagnant = 0;
        } else {
            self.stagnant += 1;
        }
        self.stagnant
    }
}

/// Restoration steps without a 1 % decrease of the violation after which a (loosely)
/// stationary point of the violation is taken as converged.
pub(super) const RESTO_STAGNATION: usize = 20;
