//! Best-iterate bookkeeping (a solve that does not converge returns the best point it
//! saw) and the stall watch of the regular iterations.
//!
//! The best iterate is ranked on the filter's two measures (Waechter & Biegler 2006): the
//! violation theta = ||c||_1 and the objective f. Its score is (v, f), compared
//! lexicographically, with v = theta at iterates whose max violation ||c||_inf exceeds
//! `acceptable_constr_viol_tol` and v = 0 at iterates feasible to that level. So among
//! infeasible iterates the one with the smallest theta wins, as the filter prefers a point
//! that reduces the violation; every iterate feasible to the acceptable level beats every
//! infeasible one; and among those, which the filter's switching condition judges by the
//! objective alone, the one with the smallest objective wins. The barrier objective the
//! filter compares within one barrier problem is not comparable across barrier parameters,
//! so the ranking takes f itself. A tie keeps the earlier iterate. Every iterate the loop
//! reaches is scored when its derivatives are evaluated, before the termination test, so an
//! iterate a cap stops at takes part.

use super::Solver;
use crate::ip::kkt::KktSolver;
use crate::ip::nlp::Nlp;
use crate::ip::residuals::{self, Errors};

/// Iterations without a 1 % decrease of ||c||_2 (or a decrease of the objective) after
/// which an infeasible iteration counts as stalled.
const STALL_ITERS: usize = 30;

/// Progress watch of the regular iterations: a run of tiny steps, or no 1 % decrease of
/// ||c||_2 nor any decrease of the objective in [`STALL_ITERS`] iterations.
#[derive(Debug, Clone, Copy)]
pub(super) struct StallWatch {
    /// Consecutive accepted steps shorter than 1e-4.
    tiny_steps: usize,
    /// Smallest ||c||_2 seen.
    theta_ref: f64,
    /// Smallest objective seen.
    f_ref: f64,
    /// Iterations since the last progress.
    stalled: usize,
}

impl StallWatch {
    /// A watch that has seen nothing.
    pub(super) fn new() -> Self {
        Self {
            tiny_steps: 0,
            theta_ref: f64::INFINITY,
            f_ref: f64::INFINITY,
            stalled: 0,
        }
    }

    /// Records an accepted step of length `alpha` to a point with ||c||_2 = `theta` and
    /// objective `f`; returns whether the iteration stalls.
    pub(super) fn record(&mut self, alpha: f64, theta: f64, f: f64) -> bool {
        self.tiny_steps = if alpha < 1e-4 { self.tiny_steps + 1 } else { 0 };
        if theta < 0.99 * self.theta_ref || f < self.f_ref - 1e-6 * self.f_ref.abs().max(1.0) {
            self.theta_ref = self.theta_ref.min(theta);
            self.f_ref = self.f_ref.min(f);
            self.stalled = 0;
        } else {
            self.stalled += 1;
        }
        self.tiny_steps >= 5 || self.stalled >= STALL_ITERS
    }
}

/// The best iterate seen so far: its score and iteration.
#[derive(Debug, Clone, Copy)]
pub(super) struct BestIterate {
    /// Its score (see `Solver::score`).
    pub(super) score: (f64, f64),
    /// The iteration it was reached at (the index of its log row).
    pub(super) iteration: usize,
}

impl BestIterate {
    /// No iterate scored yet: the first one beats it.
    pub(super) fn none() -> Self {
        Self {
            score: (f64::INFINITY, f64::INFINITY),
            iteration: 0,
        }
    }
}

/// `x`, with NaN mapped to +infinity so that it ranks last (a NaN score compares false
/// against everything and would never be replaced).
fn nan_last(x: f64) -> f64 {
    if x.is_nan() {
        f64::INFINITY
    } else {
        x
    }
}

impl<K: KktSolver> Solver<K> {
    /// Saves the current iterate, reached at iteration `iter`, when its score beats
    /// `best`'s.
    pub(super) fn watch_best(&mut self, err: &Errors, iter: usize, best: &mut BestIterate) {
        let score = self.score(err);
        if score < best.score {
            *best = BestIterate {
                score,
                iteration: iter,
            };
            self.save_best();
        }
    }

    /// Ranking of the current iterate, whose errors are `e`, for "best so far": the
    /// filter's violation ||c||_1 above the acceptable level first, then the objective (see
    /// the module documentation). NaN measures rank last.
    pub(super) fn score(&self, e: &Errors) -> (f64, f64) {
        let v = if e.inf_pr <= self.settings.acceptable_constr_viol_tol {
            0.0
        } else {
            e.theta
        };
        let f = self.ws.f;
        (nan_last(v), nan_last(f))
    }

    pub(super) fn save_best(&mut self) {
        let ws = &mut self.ws;
        ws.best_w.copy_from_slice(&ws.w);
        ws.best_y.copy_from_slice(&ws.y);
        ws.best_zl.copy_from_slice(&ws.zl);
        ws.best_zu.copy_from_slice(&ws.zu);
    }

    pub(super) fn restore_best(&mut self) {
        self.phi_current = None;
        let ws = &mut self.ws;
        ws.grad_lag_fresh = false;
        ws.w.copy_from_slice(&ws.best_w);
        ws.y.copy_from_slice(&ws.best_y);
        ws.zl.copy_from_slice(&ws.best_zl);
        ws.zu.copy_from_slice(&ws.best_zu);
    }

    pub(super) fn reevaluate<P: Nlp + ?Sized>(&mut self, nlp: &mut P, evals: &mut usize) {
        let ws = &mut self.ws;
        ws.grad_lag_fresh = false;
        let n = ws.n;
        ws.f = nlp.eval_f(&ws.w[..n]);
        nlp.eval_g(&ws.w[..n], &mut ws.g);
        nlp.eval_grad_f(&ws.w[..n], &mut ws.grad);
        nlp.eval_jac_g(&ws.w[..n], &mut ws.jac);
        *evals += 1;
        residuals::constraint_residual(&ws.is_eq, &ws.g_l, n, &ws.g, &ws.w, &mut ws.c);
    }
}
