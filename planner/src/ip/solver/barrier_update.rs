//! Updates of the barrier parameter outside the direction: the first mu, the monotone
//! (Fiacco-McCormick) decrease once a barrier subproblem is solved, and the safeguard of
//! the adaptive rules' free mode, which falls back to the monotone rule when an iterate
//! makes no progress on the (violation, objective) progress filter.

use super::{LoopState, Solver};
use crate::ip::barrier;
use crate::ip::kkt::KktSolver;
use crate::ip::residuals::{compute_errors, Errors};
use crate::ip::settings::BarrierRule;
use crate::ip::vector;

impl<K: KktSolver> Solver<K> {
    /// The barrier parameter of the first iteration.
    pub(super) fn initial_mu(&mut self) -> f64 {
        let s = self.settings;
        match s.barrier {
            BarrierRule::Monotone => s.mu_init,
            // The quality-function rule starts where the monotone rule does and never
            // raises mu (see `direction`).
            BarrierRule::Quality => s.mu_init,
            _ => {
                let e = compute_errors(&mut self.ws, 0.0);
                e.mu_avg.max(s.mu_min)
            }
        }
    }

    /// Monotone rule: decrease mu once the barrier subproblem is solved; an adaptive rule
    /// in monotone fallback returns to free mode at that point.
    pub(super) fn monotone_update(&self, st: &mut LoopState, err: &Errors) {
        if st.free_mode {
            return;
        }
        let s = self.settings;
        let mut e = *err;
        for _ in 0..8 {
            if e.overall_mu() > s.barrier_tol_factor * st.mu || st.mu <= s.mu_min {
                break;
            }
            if s.barrier != BarrierRule::Monotone {
                // Back to free mode once the barrier subproblem is solved (IPOPT returns
                // when the point is acceptable to its filter instead). The progress filter
                // keeps its entries for the whole solve, like IPOPT's obj-constr filter:
                // cleared here, it would let free mode repeat a cycle of steps that trade
                // violation for objective.
                st.free_mode = true;
                break;
            }
            st.mu = barrier::monotone_next(
                st.mu,
                s.mu_linear_decrease,
                s.mu_superlinear_power,
                s.tol,
                s.mu_min,
            );
            // Same point: only the complementarity error depends on mu.
            e.compl_mu = vector::compl_mu(&self.ws, st.mu);
        }
    }

    /// Progress safeguard of free mode after an accepted step from the point with
    /// (||c||_1, f) = `start`: the new point must improve on every entry of the progress
    /// filter, which then takes `start`; otherwise the monotone rule takes over from
    /// mu = 0.8 times the average complementarity.
    pub(super) fn free_mode_safeguard(&mut self, st: &mut LoopState, start: (f64, f64)) {
        let s = self.settings;
        let (theta_cur, f_cur) = start;
        let (theta_new, f_new) = (vector::norm1(&self.ws.c), self.ws.f);
        let gamma = 1e-5;
        let ok = self
            .ws
            .progress
            .iter()
            .all(|&(th, f)| theta_new < (1.0 - gamma) * th || f_new < f - gamma * th);
        if ok {
            if self.ws.progress.len() < self.ws.progress.capacity() {
                self.ws.progress.push((theta_cur, f_cur));
            }
        } else {
            st.free_mode = false;
            let mu_step = st.mu;
            let e = compute_errors(&mut self.ws, st.mu);
            st.mu = (0.8 * e.mu_avg).max(s.mu_min).min(st.mu_max);
            if s.barrier == BarrierRule::Quality {
                // The quality-function rule never raises mu (see `direction`).
                st.mu = st.mu.min(mu_step);
            }
        }
    }
}
