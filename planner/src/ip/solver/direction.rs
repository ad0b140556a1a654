//! The search direction: the Newton step on the primal-dual system for the barrier rule
//! in force, with Mehrotra's predictor and corrector for the predictor-corrector rules.

use super::clock::{Clock, Phase};
use super::{LoopState, Solver};
use crate::ip::barrier;
use crate::ip::info::StepKind;
use crate::ip::kkt::KktSolver;
use crate::ip::residuals::Errors;
use crate::ip::settings::BarrierRule;
use crate::ip::vector;

impl<K: KktSolver> Solver<K> {
    /// The iteration's direction: by the barrier rule in free mode, by the monotone rule
    /// otherwise. Takes the rule's mu; a new mu starts a new barrier problem, whose filter
    /// starts empty.
    pub(super) fn search_direction(
        &mut self,
        st: &mut LoopState,
        delta_w: f64,
        err: &Errors,
        clock: &mut Clock,
    ) -> StepKind {
        let s = self.settings;
        let rule = if st.free_mode {
            s.barrier
        } else {
            BarrierRule::Monotone
        };
        let (mu, mu_max) = (st.mu, st.mu_max);
        let (mu_step, kind) = clock.time(Phase::Solve, || {
            self.direction(rule, mu, mu_max, delta_w, err)
        });
        st.mu = mu_step;
        if st.mu != st.mu_prev {
            self.ws.filter.clear();
            st.mu_prev = st.mu;
        }
        kind
    }

    /// Computes the step (dw, dy, dzl, dzu) for the current rule; returns mu and its kind.
    pub(super) fn direction(
        &mut self,
        rule: BarrierRule,
        mu: f64,
        mu_max: f64,
        delta_w: f64,
        err: &Errors,
    ) -> (f64, StepKind) {
        let s = self.settings;
        match rule {
            BarrierRule::Monotone => {
                self.set_targets(mu, false);
                self.solve_direction(delta_w, false);
                (mu, StepKind::Newton)
            }
            BarrierRule::Loqo => {
                let mu_new = barrier::loqo(&self.ws, err.mu_avg)
                    .max(s.mu_min)
                    .min(mu_max);
                self.set_targets(mu_new, false);
                self.solve_direction(delta_w, false);
                (mu_new, StepKind::Newton)
            }
            BarrierRule::Adaptive => {
                // KNITRO's gap rule: a fixed fraction of the average complementarity.
                let mu_avg = err.mu_avg.max(s.mu_min);
                let mu_new = (barrier::GAP_SIGMA * mu_avg)
                    .max(self.mu_floor(mu, err))
                    .min(mu_max);
                self.set_targets(mu_new, false);
                self.solve_direction(delta_w, false);
                (mu_new, StepKind::Newton)
            }
            BarrierRule::Quality => {
                // Affine (mu = 0) and centred (mu = average complementarity) directions from
                // the same factorization; mu = sigma * mu_avg with sigma from the quality
                // function (Nocedal, Waechter, Waltz 2009).
                let mu_avg = err.mu_avg.max(s.mu_min);
                self.affine_predictor(delta_w, mu_avg);
                self.set_targets(mu_avg, false);
                self.solve_direction(delta_w, false);
                let (rd2, rp2) = barrier::residuals_sq(&mut self.ws);
                let tau = (1.0 - mu).max(s.tau_min);
                let lo = (s.mu_min / mu_avg).clamp(1e-9, 1e-2);
                let hi = (mu_max / mu_avg).clamp(1.0, 10.0);
                let sigma = barrier::quality_sigma(&self.ws, lo, hi, tau, rd2, rp2);
                // Curvature guard: while the Hessian needed a shift (negative curvature,
                // far from a local minimizer) mu is kept, so the barrier, not the
                // regularization, shapes the subproblem; otherwise it never rises.
                let mu_new = if delta_w >= s.delta_w_init {
                    mu
                } else {
                    (sigma * mu_avg).max(self.mu_floor(mu, err)).min(mu)
                };
                self.set_targets(mu_new, false);
                self.solve_direction(delta_w, false);
                (mu_new, StepKind::Newton)
            }
            BarrierRule::Probing => {
                let mu_avg = err.mu_avg.max(s.mu_min);
                let sigma = self.affine_predictor(delta_w, mu_avg);
                let mu_new = (sigma * mu_avg).max(self.mu_floor(mu, err)).min(mu_max);
                self.set_targets(mu_new, false);
                self.solve_direction(delta_w, false);
                (mu_new, StepKind::Newton)
            }
            BarrierRule::Fullmpc | BarrierRule::Dampmpc => {
                let mu_avg = err.mu_avg.max(s.mu_min);
                let sigma = self.affine_predictor(delta_w, mu_avg);
                let mu_new = (sigma * mu_avg).max(self.mu_floor(mu, err)).min(mu_max);
                if rule == BarrierRule::Dampmpc {
                    // Centering step first, then the corrector only if it is not shorter.
                    self.set_targets(mu_new, false);
                    self.solve_direction(delta_w, false);
                    let tau = (1.0 - mu_new).max(s.tau_min);
                    let (cp, cd) = self.max_steps(tau);
                    let center_step = cp.min(cd);
                    self.set_targets(mu_new, true);
                    self.solve_direction(delta_w, false);
                    let (kp, kd) = self.max_steps(tau);
                    if kp.min(kd) >= 0.95 * center_step {
                        (mu_new, StepKind::Corrected)
                    } else {
                        self.set_targets(mu_new, false);
                        self.solve_direction(delta_w, false);
                        (mu_new, StepKind::Newton)
                    }
                } else {
                    self.set_targets(mu_new, true);
                    self.solve_direction(delta_w, false);
                    (mu_new, StepKind::Corrected)
                }
            }
        }
    }

    /// Mehrotra's predictor: solves for the affine-scaling step (mu = 0), keeps it in the
    /// `*_aff` buffers and returns the centering parameter sigma = (mu_aff / mu_avg)^3
    /// (Mehrotra 1992; Nocedal, Waechter, Waltz 2009, eq. 3.4).
    pub(super) fn affine_predictor(&mut self, delta_w: f64, mu_avg: f64) -> f64 {
        self.set_targets(0.0, false);
        self.solve_direction(delta_w, false);
        let (ap, ad) = self.max_steps(1.0);
        let mu_aff = barrier::complementarity_after(&self.ws, ap, ad);
        let ws = &mut self.ws;
        ws.dw_aff.copy_from_slice(&ws.dw);
        ws.dzl_aff.copy_from_slice(&ws.dzl);
        ws.dzu_aff.copy_from_slice(&ws.dzu);
        (mu_aff / mu_avg).clamp(0.0, 1.0).powi(3)
    }

    /// Safeguards shared by the adaptive rules: mu stays above `mu_floor_factor` times the
    /// (capped) KKT error, so it does not collapse far from feasibility, and falls by at
    /// most the factor `mu_max_decrease` per iteration (damping), so the barrier keeps
    /// regularizing the nonconvex early phase.
    pub(super) fn mu_floor(&self, mu: f64, err: &Errors) -> f64 {
        let s = &self.settings;
        let kkt = err.inf_pr.max(err.inf_du / err.s_d).min(1.0);
        s.mu_min
            .max(s.mu_floor_factor * kkt)
            .max(s.mu_max_decrease * mu)
    }

    /// Complementarity targets: mu, minus the Mehrotra second-order term when `corrector`.
    pub(super) fn set_targets(&mut self, mu: f64, corrector: bool) {
        let ws = &mut self.ws;
        for j in 0..ws.n + ws.m {
            ws.tgt_l[j] = if ws.has_lo[j] {
                if corrector {
                    mu - ws.dw_aff[j] * ws.dzl_aff[j]
                } else {
                    mu
                }
            } else {
                0.0
            };
            ws.tgt_u[j] = if ws.has_hi[j] {
                if corrector {
                    mu + ws.dw_aff[j] * ws.dzu_aff[j]
                } else {
                    mu
                }
            } else {
                0.0
            };
        }
    }

    /// Solves for (dw, dy, dzl, dzu) with the current targets; with `soc` the constraint
    /// residual is `tmp_m` (second-order correction) instead of c.
    pub(super) fn solve_direction(&mut self, delta_w: f64, soc: bool) {
        self.solve_direction_mode(delta_w, soc, false);
    }

    /// As [`Self::solve_direction`]; `feasibility` drops the objective and multiplier terms
    /// (restoration), `soc` uses `tmp_m` as the constraint residual.
    pub(super) fn solve_direction_mode(&mut self, delta_w: f64, soc: bool, feasibility: bool) {
        let ws = &mut self.ws;
        let (n, m) = (ws.n, ws.m);
        // rhs_w = -(grad + A^T y - tgt_l/sl + tgt_u/su)
        ws.rhs_w.iter_mut().for_each(|v| *v = 0.0);
        if !feasibility {
            if ws.grad_lag_fresh {
                ws.rhs_w[..n].copy_from_slice(&ws.grad_lag);
            } else {
                ws.rhs_w[..n].copy_from_slice(&ws.grad);
                ws.jac_t.t_mul(&ws.jac, &ws.y, &mut ws.rhs_w[..n]);
            }
            for i in 0..m {
                if !ws.is_eq[i] {
                    ws.rhs_w[n + i] = -ws.y[i];
                }
            }
        }
        vector::rhs_bounds(ws);
        let c = if soc { &ws.tmp_m } else { &ws.c };
        ws.sol_x.copy_from_slice(&ws.rhs_w[..n]);
        for i in 0..m {
            ws.sol_y[i] = if ws.is_eq[i] {
                -c[i]
            } else {
                -c[i] + ws.rhs_w[n + i] / (ws.sigma[n + i] + delta_w)
            };
        }
        self.kkt.solve(&mut ws.sol_x, &mut ws.sol_y);
        ws.dw[..n].copy_from_slice(&ws.sol_x);
        ws.dy.copy_from_slice(&ws.sol_y);
        for i in 0..m {
            ws.dw[n + i] = if ws.is_eq[i] {
                0.0
            } else {
                (ws.rhs_w[n + i] + ws.dy[i]) / (ws.sigma[n + i] + delta_w)
            };
        }
        vector::bound_duals(ws);
    }

    /// Largest primal and dual steps keeping a fraction tau of the distance to the bounds.
    pub(super) fn max_steps(&self, tau: f64) -> (f64, f64) {
        vector::max_steps(&self.ws, tau)
    }

    /// Recomputes the regular direction after a failed correction (same targets).
    pub(super) fn restore_direction(&mut self, delta_w: f64) {
        self.solve_direction(delta_w, false);
    }
}
