//! Horizons cut from a track and the road sampled at the OCP nodes.

use super::Profile;

/// Lateral bounds replaced on the closed interval `s_from <= s <= s_to` (local horizon s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundsOverride {
    /// Start of the interval \[m\], inclusive.
    pub s_from: f64,
    /// End of the interval \[m\], inclusive.
    pub s_to: f64,
    /// Right bound inside the interval \[m\].
    pub e_min: f64,
    /// Left bound inside the interval \[m\].
    pub e_max: f64,
}

/// Curvature and lateral bounds at the N + 1 nodes s_k = k * ds of a horizon.
#[derive(Debug, Clone, PartialEq)]
pub struct Road {
    /// Node spacing ds \[m\].
    pub ds: f64,
    /// k_ref(s_k) [1/m].
    pub kappa: Vec<f64>,
    /// e_min(s_k) \[m\].
    pub e_min: Vec<f64>,
    /// e_max(s_k) \[m\].
    pub e_max: Vec<f64>,
}

impl Road {
    /// Samples `f(s) -> (kappa, e_min, e_max)` at s_k = k * length / n_intervals, k = 0..=N.
    pub fn from_fn(length: f64, n_intervals: usize, f: impl Fn(f64) -> (f64, f64, f64)) -> Self {
        let ds = length / n_intervals as f64;
        let n = n_intervals + 1;
        let mut road = Road {
            ds,
            kappa: Vec::with_capacity(n),
            e_min: Vec::with_capacity(n),
            e_max: Vec::with_capacity(n),
        };
        for k in 0..n {
            let (kappa, e_min, e_max) = f(road.node_s(k));
            road.kappa.push(kappa);
            road.e_min.push(e_min);
            road.e_max.push(e_max);
        }
        road
    }

    /// Constant curvature and bounds (a straight road for kappa = 0).
    pub fn uniform(length: f64, n_intervals: usize, kappa: f64, e_min: f64, e_max: f64) -> Self {
        Self::from_fn(length, n_intervals, |_| (kappa, e_min, e_max))
    }

    /// Local arc length s_k = k * ds of node k \[m\].
    pub fn node_s(&self, k: usize) -> f64 {
        k as f64 * self.ds
    }

    /// Number of intervals N (nodes are 0..=N).
    pub fn n_intervals(&self) -> usize {
        self.kappa.len().saturating_sub(1)
    }

    /// Replaces the bounds at every node with `s_from <= s_k <= s_to` (closed; a tolerance
    /// of 1e-9 ds absorbs rounding of k * ds). Later overrides win where intervals overlap.
    pub fn apply_overrides(&mut self, overrides: &[BoundsOverride]) {
        let tol = 1e-9 * self.ds;
        for o in overrides {
            for k in 0..self.kappa.len() {
                let s = self.node_s(k);
                if o.s_from - tol <= s && s <= o.s_to + tol {
                    self.e_min[k] = o.e_min;
                    self.e_max[k] = o.e_max;
                }
            }
        }
    }
}

/// A horizon of `length` metres and `n_intervals` steps starting at track arc length `s_start`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Track s of node 0 \[m\] (wrapped modulo the lap when sampled).
    pub s_start: f64,
    /// Horizon length \[m\].
    pub length: f64,
    /// Number of intervals N.
    pub n_intervals: usize,
}

impl Segment {
    /// Samples the profile at track s = s_start + s_k (wrapping around the lap);
    /// e_min = -w_right + edge_margin, e_max = w_left - edge_margin.
    pub fn sample(&self, profile: &Profile, edge_margin: f64) -> Road {
        Road::from_fn(self.length, self.n_intervals, |s| {
            let (kappa, w_right, w_left) = profile.sample(self.s_start + s);
            (kappa, -w_right + edge_margin, w_left - edge_margin)
        })
    }
}

/// The first lateral bound at or beyond the road's curvature centre, as (`"e_min"` or
/// `"e_max"`, 1 - kappa e there), or `None` when 1 - kappa e > 0 at both bounds and so
/// across the lane between them. The spatial dynamics divide by 1 - kappa e (s' = V
/// cos(dpsi) / (1 - kappa e), paper eq. 1): e must stay short of 1/kappa for kappa > 0
/// and above 1/kappa for kappa < 0. NaN inputs count as beyond.
pub fn beyond_curvature_centre(kappa: f64, e_min: f64, e_max: f64) -> Option<(&'static str, f64)> {
    [("e_min", e_min), ("e_max", e_max)]
        .into_iter()
        .map(|(name, e)| (name, 1.0 - kappa * e))
        .find(|&(_, room)| room.is_nan() || room <= 0.0)
}

/// Right-continuous piecewise-constant function: the value of the last piece
/// `(s_i, v_i)` with `s_i <= s` (the first piece's value before its start).
/// A tolerance of 1e-9 (absolute, in s) puts a point on a breakpoint into the new piece.
pub fn piecewise_constant(pieces: &[(f64, f64)], s: f64) -> f64 {
    let mut v = pieces.first().map_or(0.0, |p| p.1);
    for &(s_i, v_i) in pieces {
        if s_i <= s + 1e-9 {
            v = v_i;
        } else {
            break;
        }
    }
    v
}
