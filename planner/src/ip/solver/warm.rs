//! Primal-dual warm start: a solve that starts from given multipliers instead of the
//! least-squares y and unit bound multipliers, with a barrier parameter matched to the
//! starting point.
//!
//! The primal point is the NLP's `initial_point`, pushed into the relaxed bounds as in a
//! cold start (`start`). The bound multipliers are the given ones, floored at
//! [`Z_FLOOR`] so that every complementarity pair stays strictly interior; y is taken as
//! given (a non-finite entry as 0). The barrier parameter of the first iteration is matched
//! to the complementarity of the pairs at that point ([`MuMatch`]), clipped to
//! \[`WarmStart::mu_floor`, `Settings::mu_init`\]: a barrier problem whose central path
//! passes near the starting point, so the first Newton steps do not have to re-centre it.
//!
//! After a shift the products s_i z_i spread over many orders of magnitude, and their mean
//! is set by the few largest: a row whose bound lies far from the shifted point keeps the
//! multiplier of the active row it was shifted from (node 0's rows under a fixed start,
//! bound 1e3, take node 1's: s z up to 30 against a typical 1e-5), and one such pair puts
//! the mean 100 times above the typical pair. The geometric mean,
//! exp((1 / n_c) sum_i ln(s_i z_i)), is the typical pair's, whatever a few outliers hold;
//! [`MuMatch::Geometric`] starts a factor above it, so that the first steps also pull the
//! pairs below it back toward the central path (docs/performance.md, "The warm start's
//! barrier parameter").

use super::Solver;
use crate::ip::kkt::KktSolver;

/// Smallest bound multiplier a warm start keeps.
const Z_FLOOR: f64 = 1e-10;

/// How the first barrier parameter of a warm start is matched to its starting point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MuMatch {
    /// The average complementarity, (1 / n_c) sum_i s_i z_i.
    Mean,
    /// `factor` times the geometric mean of the complementarity products.
    Geometric {
        /// Multiple of the geometric mean (> 0).
        factor: f64,
    },
}

impl MuMatch {
    /// The rule warm-started replans use: 30 times the geometric mean (the factor is
    /// measured in docs/performance.md).
    pub const DEFAULT: Self = Self::Geometric { factor: 30.0 };

    /// The rule's name as recordings and options spell it (`mean`, `geometric`).
    pub fn name(&self) -> &'static str {
        match self {
            Self::Mean => "mean",
            Self::Geometric { .. } => "geometric",
        }
    }

    /// The rule `name` with `factor` (ignored for `mean`); `None` for an unknown name or a
    /// factor that is not finite and positive.
    pub fn parse(name: &str, factor: f64) -> Option<Self> {
        match name {
            "mean" => Some(Self::Mean),
            "geometric" if factor.is_finite() && factor > 0.0 => Some(Self::Geometric { factor }),
            _ => None,
        }
    }

    /// The factor (1 for `mean`).
    pub fn factor(&self) -> f64 {
        match self {
            Self::Mean => 1.0,
            Self::Geometric { factor } => *factor,
        }
    }
}

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
    /// How the barrier parameter is matched to the starting point.
    pub mu_match: MuMatch,
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

    /// The barrier parameter matched to the current point by `rule`, clipped to
    /// \[`mu_floor`, `mu_init`\]. Allocates nothing.
    pub(super) fn matched_mu(&self, mu_floor: f64, rule: MuMatch) -> f64 {
        let ws = &self.ws;
        // The products are positive: slacks are interior after the start's push and bound
        // multipliers floored at Z_FLOOR; the floor below keeps ln finite regardless.
        let term = |p: f64| match rule {
            MuMatch::Mean => p,
            MuMatch::Geometric { .. } => p.max(f64::MIN_POSITIVE).ln(),
        };
        let (mut sum, mut count) = (0.0, 0usize);
        for j in 0..ws.n + ws.m {
            if ws.has_lo[j] {
                sum += term((ws.w[j] - ws.lo[j]) * ws.zl[j]);
                count += 1;
            }
            if ws.has_hi[j] {
                sum += term((ws.hi[j] - ws.w[j]) * ws.zu[j]);
                count += 1;
            }
        }
        let avg = match (count, rule) {
            (0, _) => 0.0,
            (_, MuMatch::Mean) => sum / count as f64,
            (_, MuMatch::Geometric { factor }) => factor * (sum / count as f64).exp(),
        };
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
