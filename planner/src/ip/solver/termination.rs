//! Termination: the convergence test, the iteration and time caps, and the final report,
//! which falls back to the best iterate when the solve did not converge.

use super::clock::{Clock, Phase};
use super::{LoopState, Solver};
use crate::ip::info::{SolveInfo, Status};
use crate::ip::kkt::KktSolver;
use crate::ip::nlp::Nlp;
use crate::ip::residuals::{compute_errors, Errors};
use crate::ip::workspace::Workspace;

impl<K: KktSolver> Solver<K> {
    /// The status the solve stops with at an iterate with errors `err`, if any: converged,
    /// or out of iterations or time.
    pub(super) fn termination(&self, err: &Errors, iter: usize, clock: &Clock) -> Option<Status> {
        if self.converged(err) {
            return Some(Status::Optimal);
        }
        if iter >= self.settings.max_iter {
            return Some(Status::IterationLimit);
        }
        if clock.out_of_time() {
            return Some(Status::TimeLimit);
        }
        None
    }

    pub(super) fn converged(&self, e: &Errors) -> bool {
        let s = &self.settings;
        e.overall() <= s.tol
            && e.inf_du <= s.dual_inf_tol
            && e.inf_pr <= s.constr_viol_tol
            && e.compl <= s.compl_inf_tol
            && self.multipliers_finite()
    }

    /// Whether y, z_l and z_u are finite: the error measures' max reductions skip NaN, so
    /// a NaN multiplier must not pass for a small error.
    pub(super) fn multipliers_finite(&self) -> bool {
        let ws = &self.ws;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        finite(&ws.y) && finite(&ws.zl) && finite(&ws.zu)
    }

    /// The final report. A solve that did not converge (a cap, the time budget, a
    /// numerical failure) returns its best iterate (see `best`; a certificate of
    /// infeasibility is the current point, not the best one), reported as acceptable when
    /// it meets the acceptable tolerances; the report's errors and violation are that
    /// iterate's, and `best_iterate`/`best_iteration` say which iterate it is.
    pub(super) fn finish<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        status: Status,
        st: &LoopState,
        mut info: SolveInfo,
        mut clock: Clock,
    ) -> SolveInfo {
        let s = self.settings;
        let mut final_status = status;
        let best = !matches!(status, Status::Optimal | Status::LocallyInfeasible);
        if best {
            self.restore_best();
            let evals = &mut info.evaluations;
            clock.time(Phase::Evaluation, || self.reevaluate(nlp, evals));
            let err = compute_errors(&mut self.ws, 0.0);
            if matches!(
                status,
                Status::IterationLimit | Status::TimeLimit | Status::NumericalFailure
            ) && err.overall() <= s.acceptable_tol
                && err.inf_pr <= s.acceptable_constr_viol_tol
                && self.multipliers_finite()
            {
                final_status = Status::Acceptable;
            }
        }
        let err = compute_errors(&mut self.ws, 0.0);
        info.status = final_status;
        info.iterations = st.iter;
        info.objective = self.ws.f;
        info.max_violation = max_violation(&self.ws);
        info.dual_inf = err.inf_du / err.s_d;
        info.compl = err.compl / err.s_c;
        info.mu = st.mu;
        info.best_iterate = best;
        info.best_iteration = if best { st.best.iteration } else { st.iter };
        clock.times.total = clock.elapsed();
        info.times = clock.times;
        info
    }
}

/// Max violation of the original variable bounds and constraint bounds at w, with the
/// constraint values in `g` (NaN entries are skipped by `max`, infinities kept).
pub(super) fn max_violation(ws: &Workspace) -> f64 {
    let mut v: f64 = 0.0;
    for j in 0..ws.n {
        v = v.max(ws.lo_orig[j] - ws.w[j]).max(ws.w[j] - ws.hi_orig[j]);
    }
    for i in 0..ws.m {
        v = v.max(ws.g_l[i] - ws.g[i]).max(ws.g[i] - ws.g_u[i]);
    }
    v
}
