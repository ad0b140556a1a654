//! Factorization of the KKT matrix with inertia correction (IPOPT's Algorithm IC) and the
//! convexified fallback when the correction runs out of attempts.

use super::clock::{Clock, Deadline, Phase};
use super::{LoopState, Next, Solver};
use crate::elementary::pow;
use crate::ip::info::{SolveInfo, Status, StepKind};
use crate::ip::kkt::{Inertia, KktError, KktSolver, KktValues};
use crate::ip::residuals::Errors;
use crate::ip::vector;

/// Outcome of factorizing with inertia correction.
pub(super) struct Factorization {
    /// Scalar primal shift in the factorized matrix (for the slack elimination).
    pub(super) delta_w: f64,
    /// Factorizations spent (at most `Settings::max_refactorizations`).
    pub(super) count: usize,
    /// The convexified fallback matrix was factorized (see [`Solver::factorize_with`]).
    pub(super) fallback: bool,
}

/// Why the inertia-corrected factorization returned no factorization.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Unfactorized {
    /// The backend failed (non-finite or unsupported matrix); factorizations spent.
    Failed(usize),
    /// The time budget ran out before the next factorization; factorizations spent.
    OutOfTime(usize),
}

impl Unfactorized {
    /// Factorizations spent before the failure.
    pub(super) fn count(self) -> usize {
        match self {
            Unfactorized::Failed(count) | Unfactorized::OutOfTime(count) => count,
        }
    }
}

impl Factorization {
    /// The kind of an accepted step on this factorization: a fallback step, else a
    /// second-order correction when `soc`, else the direction's `kind`.
    pub(super) fn step_kind(&self, soc: bool, kind: StepKind) -> StepKind {
        if self.fallback {
            StepKind::Fallback
        } else if soc {
            StepKind::SecondOrder
        } else {
            kind
        }
    }
}

impl<K: KktSolver> Solver<K> {
    /// The iteration's factorization, counted in `info`. When the backend fails, a
    /// significant violation hands over to restoration (the rejected iteration is
    /// logged); otherwise the solve stops. When the time budget runs out between
    /// factorizations, the solve stops with `time_limit`.
    pub(super) fn factorize_iteration(
        &mut self,
        st: &mut LoopState,
        err: &Errors,
        f_iter: f64,
        info: &mut SolveInfo,
        clock: &mut Clock,
    ) -> Result<Factorization, Next> {
        let (mu, force_reg, deadline) = (st.mu, st.force_reg, clock.deadline);
        let fact = clock.time(Phase::Factorization, || {
            self.factorize(mu, force_reg, deadline)
        });
        let count = match &fact {
            Ok(fact) => fact.count,
            Err(u) => u.count(),
        };
        info.factorizations += count;
        info.max_factorizations_per_iter = info.max_factorizations_per_iter.max(count);
        match fact {
            Ok(fact) => {
                if fact.fallback {
                    info.fallback_steps += 1;
                }
                Ok(fact)
            }
            Err(Unfactorized::OutOfTime(_)) => Err(Next::Stop(Status::TimeLimit)),
            Err(Unfactorized::Failed(count)) => {
                if st.may_restore(err.inf_pr, self.settings.max_restoration_steps) {
                    st.enter_restoration(super::norm2(&self.ws.c));
                    self.push_log(
                        st.iter,
                        f_iter,
                        err,
                        st.mu,
                        0.0,
                        f64::INFINITY,
                        count,
                        0,
                        StepKind::Rejected,
                    );
                    return Err(Next::Continue);
                }
                Err(Next::Stop(Status::NumericalFailure))
            }
        }
    }

    /// Factorizes the KKT matrix, raising delta_w until the inertia is (n, m, 0); checks
    /// `deadline` before each factorization.
    pub(super) fn factorize(
        &mut self,
        mu: f64,
        force_reg: bool,
        deadline: Deadline,
    ) -> Result<Factorization, Unfactorized> {
        let delta_c = if self.kkt.wants_dual_regularization() {
            self.settings.delta_c_min
        } else {
            0.0
        };
        self.factorize_with(mu, force_reg, delta_c, deadline)
    }

    /// Inertia-corrected factorization with dual regularization at least `delta_c_base`.
    /// Before each factorization (the fallback's included) it checks `deadline`, and
    /// returns [`Unfactorized::OutOfTime`] once the budget is spent.
    pub(super) fn factorize_with(
        &mut self,
        mu: f64,
        force_reg: bool,
        delta_c_base: f64,
        deadline: Deadline,
    ) -> Result<Factorization, Unfactorized> {
        let s = self.settings;
        let (n, m) = (self.ws.n, self.ws.m);
        self.compute_sigma();
        let mut delta_c = delta_c_base;
        // IPOPT's Algorithm IC, with two changes that bound the work per iteration: when
        // the previous iteration needed a shift, start from a third of it instead of
        // retrying zero (saves a factorization on degenerate problems), and grow tiny shifts
        // by 100 so the cap on factorizations is not spent creeping up from 1e-12.
        const DELTA_W_FLOOR: f64 = 1e-12;
        let mut delta_w = if force_reg {
            self.delta_w_last.max(s.delta_w_init)
        } else if self.delta_w_last > 0.0 {
            (self.delta_w_last / s.delta_w_decrease).max(DELTA_W_FLOOR)
        } else {
            0.0
        };
        let expected = Inertia {
            positive: n,
            negative: m,
            zero: 0,
        };
        let mut count = 0;
        // Inertia-correcting attempts; the last factorization allowed is the fallback's.
        let attempts = s
            .max_inertia_corrections
            .min(s.max_refactorizations.saturating_sub(1));
        while count < attempts {
            if deadline.passed() {
                return Err(Unfactorized::OutOfTime(count));
            }
            self.fill_diagonals(delta_w, delta_c);
            count += 1;
            let ws = &self.ws;
            let res = self.kkt.factorize_expecting(
                &KktValues {
                    hess: &ws.hess,
                    jac: &ws.jac,
                    primal_diag: &ws.primal_diag,
                    dual_diag: &ws.dual_diag,
                },
                expected,
            );
            match res {
                Ok(inertia) if inertia == expected => {
                    // A shift at the floor is forgotten: the next iteration tries zero again.
                    self.delta_w_last = if delta_w > DELTA_W_FLOOR {
                        delta_w
                    } else {
                        0.0
                    };
                    return Ok(Factorization {
                        delta_w,
                        count,
                        fallback: false,
                    });
                }
                // Wrong inertia, found at the end or (stopped early) on the way.
                Ok(_) | Err(KktError::WrongInertia) => {}
                Err(KktError::Singular) => {
                    delta_c = delta_c.max(1e-8 * pow(mu.max(1e-12), 0.25));
                }
                Err(KktError::NonFinite | KktError::Unsupported) => {
                    return Err(Unfactorized::Failed(count))
                }
            }
            delta_w = if delta_w == 0.0 {
                if self.delta_w_last == 0.0 {
                    s.delta_w_init
                } else {
                    (self.delta_w_last / 3.0).max(DELTA_W_FLOOR)
                }
            } else if self.delta_w_last == 0.0 || delta_w < 1e-6 {
                delta_w * 100.0
            } else {
                delta_w * 8.0
            };
            if delta_w > s.delta_w_max {
                break;
            }
        }
        // The next iteration starts its corrections from the largest shift tried here.
        let delta_w = delta_w.min(s.delta_w_max);
        self.delta_w_last = delta_w;
        if deadline.passed() {
            return Err(Unfactorized::OutOfTime(count));
        }
        self.factorize_fallback(delta_w, delta_c, count)
            .map_err(Unfactorized::Failed)
    }

    /// The bounded answer to bad inertia: factorize the KKT matrix with the Hessian
    /// convexified by a per-variable Gershgorin shift,
    /// `D_j = max(0, sum_{k != j} |H_jk| - H_jj) + delta` (delta: see below),
    /// so that H + D is diagonally dominant with a positive diagonal (hence positive
    /// definite, Gershgorin's circle theorem), and with a dual shift delta_c > 0. The
    /// matrix [[H + Sigma + D, J^T], [J, -D_c]] is then quasi-definite and has inertia
    /// (n, m, 0) whatever H and J are (Vanderbei 1995), so the step needs no inertia check
    /// and no further refactorization: one factorization through the `KktSolver` trait,
    /// any backend. The direction is a descent direction of the barrier merit (positive
    /// definite model), shortened along strongly coupled/negatively curved variables
    /// only; that is what KNITRO's projected-CG trust-region fallback achieves, at the cost
    /// of one factorization instead of a CG loop. Counted as a factorization of the
    /// iteration; returns `Err` only when the backend fails on a non-finite matrix.
    pub(super) fn factorize_fallback(
        &mut self,
        delta_next: f64,
        delta_c: f64,
        count: usize,
    ) -> Result<Factorization, usize> {
        let s = self.settings;
        let ws = &mut self.ws;
        let n = ws.n;
        // The shift the correction loop would have tried next is kept on top of the
        // Gershgorin shift: it acts as a trust-region radius ~ 1/delta that shrinks as the
        // loop escalated, so the fallback step is no longer than a corrected Newton step
        // would have been (an unshortened fallback step can leave the region where the
        // linearized constraints are accurate).
        let delta = delta_next.max(s.delta_w_init);
        // tmp_w[..n]: diagonal of H; primal_diag[..n]: off-diagonal absolute row sums.
        ws.tmp_w[..n].iter_mut().for_each(|v| *v = 0.0);
        ws.primal_diag.iter_mut().for_each(|v| *v = 0.0);
        for ((&r, &c), &h) in ws.hess_rows.iter().zip(&ws.hess_cols).zip(&ws.hess) {
            if r == c {
                ws.tmp_w[r] += h;
            } else {
                ws.primal_diag[r] += h.abs();
                ws.primal_diag[c] += h.abs();
            }
        }
        for j in 0..n {
            let shift = (ws.primal_diag[j] - ws.tmp_w[j]).max(0.0);
            ws.primal_diag[j] = ws.sigma[j] + shift + delta;
        }
        let delta_c = delta_c.max(s.delta_c_min).max(1e-8);
        for i in 0..ws.m {
            ws.dual_diag[i] = if ws.is_eq[i] {
                -delta_c
            } else {
                -(1.0 / (ws.sigma[n + i] + delta) + delta_c)
            };
        }
        let res = self.kkt.factorize(&KktValues {
            hess: &ws.hess,
            jac: &ws.jac,
            primal_diag: &ws.primal_diag,
            dual_diag: &ws.dual_diag,
        });
        match res {
            // Quasi-definite: the inertia is right by construction; a backend that
            // reports otherwise (rounding) still holds a usable factorization.
            Ok(_) => Ok(Factorization {
                delta_w: delta,
                count: count + 1,
                fallback: true,
            }),
            Err(_) => Err(count + 1),
        }
    }

    pub(super) fn fill_diagonals(&mut self, delta_w: f64, delta_c: f64) {
        let ws = &mut self.ws;
        let n = ws.n;
        for j in 0..n {
            ws.primal_diag[j] = ws.sigma[j] + delta_w;
        }
        for i in 0..ws.m {
            ws.dual_diag[i] = if ws.is_eq[i] {
                -delta_c
            } else {
                -(1.0 / (ws.sigma[n + i] + delta_w) + delta_c)
            };
        }
    }

    /// Barrier Hessian Sigma = z_l/(w - l) + z_u/(u - w).
    pub(super) fn compute_sigma(&mut self) {
        vector::sigma(&mut self.ws);
    }
}
