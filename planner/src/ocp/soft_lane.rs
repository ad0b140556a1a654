//! A soft lane: a penalty in the objective on leaving soft bounds inside the hard ones.
//!
//! With soft bounds l_k < u_k at the nodes (inside the hard lane bounds e_min,k <= e_k <=
//! e_max,k, which stay constraints), node k's depth into the band between them is
//! d_k = max(0, e_k - u_k) + max(0, l_k - e_k), and the objective gains
//!
//! P = sum_{k=1}^{N} phi(d_k) \[s\], phi(d) = rho d^3 / (3 d_0) for d <= d_0,
//! rho (d^2 - d_0 d + d_0^2 / 3) beyond,
//!
//! rho = [`SoftLane::weight`] \[s/m^2\], d_0 = [`BLEND_DEPTH_M`]. A plan that keeps the band
//! pays nothing; one that enters it pays about rho d^2, so it enters only where the time
//! gained per metre of lane exceeds about 2 rho d. phi is C^2 (the cubic blends its
//! curvature from 0 at the band's edge to 2 rho at d_0), so Newton's steps see no jump in
//! the Hessian as nodes cross the band's edge. Every start the hard bounds admit is a start
//! of this problem: a car that a tracking error has put inside the band is planned back out
//! of it as fast as the time it costs is worth, instead of making the start infeasible as a
//! hard bound at the band would. Node 0 is the fixed start and carries no term.
//!
//! In the scaled variables z_e = e / X_e (X_e = `X_NOMINAL[E]`), the term is
//! phi(d) / OBJECTIVE_SCALE with dd/dz_e = +-X_e: gradient +-X_e phi'(d), Hessian
//! X_e^2 phi''(d) on the diagonal entry (e_k, e_k).

use super::layout::Layout;
use super::scaling::{OBJECTIVE_SCALE, X_NOMINAL};
use crate::model::ix;

/// Soft lane bounds and their weight ([module docs](self)); weight 0 is no soft lane.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftLane {
    /// Weight rho of the squared depth into the band \[s/m^2\] (0: no soft lane).
    pub weight: f64,
    /// Soft right bound l_k at the N + 1 nodes \[m\] (empty when off).
    pub e_min: Vec<f64>,
    /// Soft left bound u_k at the N + 1 nodes \[m\] (empty when off).
    pub e_max: Vec<f64>,
}

/// Largest accepted [`SoftLane::weight`] \[s/m^2\]: at 1e4 a centimetre into the band costs a
/// second, a hard bound in all but conditioning.
pub const MAX_SOFT_LANE_WEIGHT: f64 = 1e4;

/// Depth d_0 over which the penalty's curvature blends in from 0 to 2 rho \[m\].
pub const BLEND_DEPTH_M: f64 = 0.1;

/// phi(d), phi'(d), phi''(d) per unit weight rho (d >= 0; [module docs](self)).
#[inline]
fn phi(d: f64) -> [f64; 3] {
    const D0: f64 = BLEND_DEPTH_M;
    if d <= 0.0 {
        [0.0; 3]
    } else if d <= D0 {
        [d * d * d / (3.0 * D0), d * d / D0, 2.0 * d / D0]
    } else {
        [d * d - D0 * d + D0 * D0 / 3.0, 2.0 * d - D0, 2.0]
    }
}

impl SoftLane {
    /// No soft lane: the objective is the paper's.
    pub const OFF: Self = Self {
        weight: 0.0,
        e_min: Vec::new(),
        e_max: Vec::new(),
    };

    /// Soft bounds `e_min`, `e_max` (one per node) with weight `weight` \[s/m^2\].
    pub fn new(weight: f64, e_min: Vec<f64>, e_max: Vec<f64>) -> Self {
        Self {
            weight,
            e_min,
            e_max,
        }
    }

    /// The soft bounds (e_min, e_max).
    pub fn bounds(&self) -> (&[f64], &[f64]) {
        (&self.e_min, &self.e_max)
    }

    /// Whether the soft lane adds a term.
    pub fn is_on(&self) -> bool {
        self.weight > 0.0
    }

    /// Why this soft lane is outside its domain on `n_nodes` nodes (weight finite in [0,
    /// [`MAX_SOFT_LANE_WEIGHT`]]; when on, `n_nodes` finite bounds per side), or `None`.
    pub fn problem(&self, n_nodes: usize) -> Option<String> {
        if !(self.weight.is_finite() && (0.0..=MAX_SOFT_LANE_WEIGHT).contains(&self.weight)) {
            return Some(format!(
                "weight {} s/m^2 is not in [0, {MAX_SOFT_LANE_WEIGHT}]",
                self.weight
            ));
        }
        if !self.is_on() {
            return None;
        }
        for (side, v) in [("e_min", &self.e_min), ("e_max", &self.e_max)] {
            if v.len() != n_nodes {
                return Some(format!("{side} has {} values, not {n_nodes}", v.len()));
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Some(format!("{side}[{k}] = {} is not finite", v[k]));
            }
        }
        None
    }
}

/// The soft lane's term of one transcription: the Hessian slots of (e_k, e_k), k = 1..N.
#[derive(Debug, Clone)]
pub struct SoftLaneTerm {
    layout: Layout,
    /// c = rho / OBJECTIVE_SCALE (scaled objective per m^2).
    coef: f64,
    /// Hessian slot of (e_k, e_k) for k = 1..=N (index k - 1).
    slots: Vec<usize>,
}

impl SoftLaneTerm {
    /// The term of weight `weight` \[s/m^2\] on `layout` with N = `n` intervals, or `None`
    /// at weight 0 (the Hessian pattern is then unchanged); `slot(r, c)` as in
    /// [`super::objective::Objective::new`].
    pub fn new(
        layout: Layout,
        n: usize,
        weight: f64,
        mut slot: impl FnMut(usize, usize) -> usize,
    ) -> Option<Self> {
        if weight <= 0.0 {
            return None;
        }
        let slots = (1..=n)
            .map(|k| {
                let i = layout.x(k, ix::E);
                slot(i, i)
            })
            .collect();
        Some(Self {
            layout,
            coef: weight / OBJECTIVE_SCALE,
            slots,
        })
    }

    /// Node k's depth past the soft bounds `e_min`, `e_max` and the sign of dd/de: (d, +1)
    /// past the left one, (d, -1) past the right one, (0, 0) between them. Soft bounds
    /// that cross (l_k > u_k) have both sides pulling: the depths add, and their slopes
    /// cancel.
    #[inline]
    fn depth(&self, x: &[f64], k: usize, e_min: &[f64], e_max: &[f64]) -> (f64, f64) {
        let e = x[self.layout.x(k, ix::E)] * X_NOMINAL[ix::E];
        let over = (e - e_max[k]).max(0.0);
        let under = (e_min[k] - e).max(0.0);
        let slope = (over > 0.0) as u8 as f64 - (under > 0.0) as u8 as f64;
        (over + under, slope)
    }

    /// The penalty's value (scaled objective units).
    pub fn value(&self, x: &[f64], e_min: &[f64], e_max: &[f64]) -> f64 {
        (1..=self.slots.len())
            .map(|k| self.coef * phi(self.depth(x, k, e_min, e_max).0)[0])
            .sum()
    }

    /// Adds the gradient to `grad`.
    pub fn add_gradient(&self, x: &[f64], e_min: &[f64], e_max: &[f64], grad: &mut [f64]) {
        for k in 1..=self.slots.len() {
            let (d, slope) = self.depth(x, k, e_min, e_max);
            if d > 0.0 {
                grad[self.layout.x(k, ix::E)] += self.coef * X_NOMINAL[ix::E] * slope * phi(d)[1];
            }
        }
    }

    /// Adds `obj_factor` times the Hessian to `vals`.
    pub fn add_hessian(
        &self,
        x: &[f64],
        e_min: &[f64],
        e_max: &[f64],
        obj_factor: f64,
        vals: &mut [f64],
    ) {
        let h = obj_factor * self.coef * X_NOMINAL[ix::E] * X_NOMINAL[ix::E];
        for (i, &slot) in self.slots.iter().enumerate() {
            let (d, slope) = self.depth(x, i + 1, e_min, e_max);
            if d > 0.0 {
                vals[slot] += h * slope * slope * phi(d)[2];
            }
        }
    }
}
