//! The objective of the transcribed OCP: the paper's minimum time t_N (eq. 3) plus an
//! optional steering-slew term that keeps the steering from weaving at its rate limit.
//!
//! J = t_N + w sum_{k=1}^{N-1} ((delta_k - delta_{k-1}) / delta_rate_max)^2 \[s\], each term
//! the squared time the steering change of interval k takes at the rate limit
//! ([`crate::ocp::OcpSpec::steering_slew_weight`] = w). In the scaled variables
//! z = delta / U_NOMINAL it is a constant quadratic: its Hessian never changes and is
//! added once per evaluation, after the stage terms (so the stage-parallel Hessian stays
//! as it is). The term couples neighbouring controls exactly as the rate rows do, so the
//! Riccati backend's blocks already hold its entries.

use super::layout::Layout;
use super::scaling::{OBJECTIVE_SCALE, U_NOMINAL, X_NOMINAL};
use super::soft_lane::SoftLaneTerm;
use crate::model::{iu, ix, VehicleParams};

/// The objective with steering-slew weight `w` [1/s] in words, for tables and summaries.
pub fn label(w: f64) -> String {
    if w == 0.0 {
        "objective t_N (paper eq. 3)".into()
    } else {
        format!("objective t_N + {w} x steering slew")
    }
}

/// The objective's pieces for one transcription (weight fixed at construction).
#[derive(Debug, Clone)]
pub struct Objective {
    layout: Layout,
    n: usize,
    /// Coefficient c of c (z_k - z_{k-1})^2 on the scaled steering (0: pure minimum time).
    slew: f64,
    /// Per interval k = 1..N-1: Hessian slots (u_k, u_k), (u_{k-1}, u_{k-1}), (u_k, u_{k-1})
    /// of the steering. Empty when the weight is 0.
    slots: Vec<[usize; 3]>,
    /// The soft lane band's penalty ([`super::soft_lane`]), when on.
    soft: Option<SoftLaneTerm>,
}

impl Objective {
    /// The objective for slew weight `w` [1/s] and soft-lane weight `soft` [s/m^2] on
    /// `layout` with N = `n` intervals; `slot(r, c)` returns the Hessian slot of entry (r,
    /// c), r >= c, adding it to the pattern if new.
    pub fn new(
        layout: Layout,
        n: usize,
        (w, soft): (f64, f64),
        vehicle: &VehicleParams,
        mut slot: impl FnMut(usize, usize) -> usize,
    ) -> Self {
        let soft = SoftLaneTerm::new(layout, n, soft, &mut slot);
        // Weight 0 leaves the problem exactly eq. 3 (and the pattern unchanged), whatever
        // the vehicle's rate bound (a spec that skipped `OcpSpec::check` may hold 0 or inf).
        if w == 0.0 {
            return Self {
                layout,
                n,
                slew: 0.0,
                slots: Vec::new(),
                soft,
            };
        }
        let c = U_NOMINAL[iu::DELTA] / vehicle.delta_rate_max;
        let slots = (1..n)
            .map(|k| {
                let (a, b) = (layout.u(k, iu::DELTA), layout.u(k - 1, iu::DELTA));
                [slot(a, a), slot(b, b), slot(a.max(b), a.min(b))]
            })
            .collect();
        Self {
            layout,
            n,
            slew: w * c * c / OBJECTIVE_SCALE,
            slots,
            soft,
        }
    }

    /// Whether the steering-slew term is present.
    pub fn has_slew(&self) -> bool {
        !self.slots.is_empty()
    }

    /// Scaled steering difference z_k - z_{k-1} of interval k >= 1.
    #[inline]
    fn step(&self, x: &[f64], k: usize) -> f64 {
        x[self.layout.u(k, iu::DELTA)] - x[self.layout.u(k - 1, iu::DELTA)]
    }

    /// f(x) = t_N / OBJECTIVE_SCALE + slew term + soft lane's penalty on the soft bounds
    /// `e_min`, `e_max` \[m\] (scaled units).
    pub fn value(&self, x: &[f64], (e_min, e_max): (&[f64], &[f64])) -> f64 {
        let mut f = x[self.layout.x(self.n, ix::T)] * X_NOMINAL[ix::T] / OBJECTIVE_SCALE;
        if self.has_slew() {
            for k in 1..self.n {
                let d = self.step(x, k);
                f += self.slew * d * d;
            }
        }
        if let Some(soft) = &self.soft {
            f += soft.value(x, e_min, e_max);
        }
        f
    }

    /// The gradient (overwrites `grad`).
    pub fn gradient(&self, x: &[f64], (e_min, e_max): (&[f64], &[f64]), grad: &mut [f64]) {
        grad.fill(0.0);
        grad[self.layout.x(self.n, ix::T)] = X_NOMINAL[ix::T] / OBJECTIVE_SCALE;
        if self.has_slew() {
            for k in 1..self.n {
                let g = 2.0 * self.slew * self.step(x, k);
                grad[self.layout.u(k, iu::DELTA)] += g;
                grad[self.layout.u(k - 1, iu::DELTA)] -= g;
            }
        }
        if let Some(soft) = &self.soft {
            soft.add_gradient(x, e_min, e_max, grad);
        }
    }

    /// Adds `obj_factor` times the Hessian to `vals`: the slew term's (constant) and the
    /// soft lane's (on the entries of the nodes past its bounds).
    pub fn add_hessian(
        &self,
        x: &[f64],
        (e_min, e_max): (&[f64], &[f64]),
        obj_factor: f64,
        vals: &mut [f64],
    ) {
        let h = 2.0 * obj_factor * self.slew;
        for &[kk, pp, kp] in &self.slots {
            vals[kk] += h;
            vals[pp] += h;
            vals[kp] -= h;
        }
        if let Some(soft) = &self.soft {
            soft.add_hessian(x, e_min, e_max, obj_factor, vals);
        }
    }
}
