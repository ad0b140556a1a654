//! Primal-dual warm start: a solve that starts from given multipliers instead of the
//! least-squares y and unit bound multipliers, with a barrier parameter matched to the
//! starting point.
//!
//! The primal point is the NLP's `initial_point`, pushed into the relaxed bounds as in a
//! cold start (`start`). The bound multipliers are the given ones, floored at
//! [`Z_FLOOR`] so that every complementarity pair stays strictly interior; y is taken as
//! given (a non-finite entry as 0). The barrier parameter of the first iteration is the average complementarity of
//! the pairs at that point, mu = (1 / n_c) sum_i s_i z_i, clipped to
//! \[`WarmStart::mu_floor`, `Settings::mu_init`\]: a barrier problem whose central path
//! passes near the starting point, so the first Newton steps do not have to re-centre it.

use super::Solver;
use crate::ip::kkt::KktSolver;

/// Smallest bound multiplier a warm start keeps.
const Z_FLOOR: f64 = 1e-10;

/// The multipliers a warm-started solve begins with, in the solver's ordering: y over the
/// m constraint rows, z_l and z_u over the n + m entries of w = (x, s) (entries without a
/// bound are ignored).
#[derive(Debug, Clone, Copy)]
pub struct WarmStart<'a> {
    /// Constraint multipliers (m).
    pub y: &'a [f64],
    /// Lower-bound multipliers (n + m).
    pub zl: &'a [f64],
    /// Upper-bound multipliers (n + m).
    pub zu: &'a [f64],
    /// Lower clip of the matched barrier parameter.
    pub mu_floor: f64,
}

impl<K: KktSolver> Solver<K> {
    /// Copies the warm multipliers into the workspace (floored bound multipliers, zero
    /// where a bound is absent). Lengths that do not fit leave the cold start's
    /// multipliers in place and return false.
    pub(super) fn warm_multipliers(&mut self, warm: &WarmStart<'_>) -> bool {
        let ws = &mut self.ws;
        let (n, m) = (ws.n, ws.m);
        if warm.y.len() != m || warm.zl.len() != n + m || warm.zu.len() != n + m {
            return false;
        }
        for (y, &v) in ws.y.iter_mut().zip(warm.y) {
            *y = if v.is_finite() { v } else { 0.0 };
        }
        for j in 0..n + m {
            ws.zl[j] = if ws.has_lo[j] {
                nonneg(warm.zl[j]).max(Z_FLOOR)
            } else {
                0.0
            };
            ws.zu[j] = if ws.has_hi[j] {
                nonneg(warm.zu[j]).max(Z_FLOOR)
            } else {
                0.0
            };
        }
        true
    }

    /// The barrier parameter matched to the current point: its average complementarity,
    /// clipped to \[`mu_floor`, `mu_init`\].
    pub(super) fn matched_mu(&self, mu_floor: f64) -> f64 {
        let ws = &self.ws;
        let (mut sum, mut count) = (0.0, 0usize);
        for j in 0..ws.n + ws.m {
            if ws.has_lo[j] {
                sum += (ws.w[j] - ws.lo[j]) * ws.zl[j];
                count += 1;
            }
            if ws.has_hi[j] {
                sum += (ws.hi[j] - ws.w[j]) * ws.zu[j];
                count += 1;
            }
        }
        let avg = if count > 0 { sum / count as f64 } else { 0.0 };
        let s = self.settings;
        let lo = mu_floor.max(s.mu_min);
        let hi = s.mu_init.max(lo);
        if avg.is_finite() {
            avg.clamp(lo, hi)
        } else {
            hi
        }
    }
}

/// `x` when it is a finite non-negative number, else 0.
fn nonneg(x: f64) -> f64 {
    if x.is_finite() && x > 0.0 {
        x
    } else {
        0.0
    }
}
