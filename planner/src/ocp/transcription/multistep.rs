//! Linear multistep transcriptions: BDF4, BDF5, BDF6 and Adams-Moulton with three steps
//! (paper Sec. IV, Table I). The defect of interval k (computing x_{k+1}) reads the last
//! q + 1 nodes,
//!
//! `sum_{j=0}^{q} a_j x_{k+1-j} - ds sum_{j=0}^{q} b_j f(x_{k+1-j}, u_k; k_ref(s_{k+1-j})) = 0`,
//!
//! each row divided by the nominal of its state (coefficients in [`super::steps::BDF`] and
//! [`super::steps::ADAMS_MOULTON`]). The controls are piecewise constant, so on interval k the ODE
//! is x' = f(x, u_k; k_ref(s)): every f value of the formula uses u_k (an Adams-Moulton
//! formula interpolates the vector field of the interval's own ODE at the earlier states),
//! and k_ref is the grid value of the node (R8), as in [`super::ImplicitEuler`]. BDF only
//! evaluates f at x_{k+1}, so BDF-q's defect is implicit Euler's with the backward
//! difference of order q.
//!
//! **"Adams-Moulton 3-stage".** The paper does not define it; we read it as the 3-step
//! Adams-Moulton formula (order 4, b = (9, 19, -5, 1) / 24), in the usual indexing by step
//! count (Hairer-Norsett-Wanner I, Sec. III.1: 0 steps = implicit Euler, 1 = trapezoid),
//! the same way "BDF4" names the 4-step BDF. Like BDF4-6 it is not A-stable, which is the
//! property the paper contrasts.
//!
//! **Start-up.** Interval k has only k + 1 earlier nodes, so the first intervals use the
//! same family with fewer steps, q_k = min(q, k + 1): BDF1 (implicit Euler), BDF2, BDF3, ...
//! on intervals 0, 1, 2, ...; Adams-Moulton 1 (trapezoid = Crank-Nicolson), then 2 steps,
//! then 3. Reasons: (i) it uses only the decision variables that exist (no extra
//! unknowns, no separate one-step start-up scheme), (ii) every start-up formula is
//! consistent and zero-stable and the first ones are A-stable (BDF1-2, trapezoid), which
//! matters on the stiff sideslip mode right where the free initial state can be far from
//! physical (reference README, finding c), and (iii) the lower order only affects
//! q - 1 intervals out of N = 100, whose local errors stay O(ds^2) or better. Note that the
//! controls jump at every node, so the solution x(s) has a kink at each node and no
//! multistep formula reaches its nominal order on the OCP anyway (the paper's accuracy
//! observation for BDF4-6 / AM).
//!
//! Exact derivatives: the defect is a linear combination of the linear past state terms
//! and of f at each node of the window, and each f(x_n, u_k) depends on the 10 inputs
//! (r..dpsi of x_n, u_k) only, so the Jacobian and Hessian are assembled from per-node
//! jets over 10 variables: the hand-written ones of `point_jets` (the same as
//! implicit Euler's), or num-dual duals under [`super::Derivatives::Oracle`].

use super::point_jets::{physical, scaled_gradient, IN_NOMINAL, NIN, NXIN};
use super::steps::{MultistepFormula, ADAMS_MOULTON, BDF};
use super::{DefectScheme, SchemeContext};
use crate::model::{spatial_derivatives, NU, NX, STATE_NAMES};
use crate::ocp::ad::{grad, lower_hessian, lower_pairs, seed1, seed2};
use crate::ocp::fast;
use crate::ocp::layout::Layout;
use crate::ocp::scaling::{U_NOMINAL, X_NOMINAL};
use num_dual::{Dual2SVec64, DualNum};

/// Lower-triangle entries of one node's Hessian block.
const NHESS: usize = NIN * (NIN + 1) / 2;
/// Most nodes a window can hold (BDF6: 7).
const MAX_NODES: usize = 7;

/// Which family of multistep formulas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MultistepFamily {
    /// Backward differentiation formulas.
    Bdf,
    /// Adams-Moulton formulas.
    AdamsMoulton,
}

/// A linear multistep defect scheme with start-up (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinearMultistep {
    family: MultistepFamily,
    steps: usize,
    name: &'static str,
}

impl LinearMultistep {
    /// BDF4 (order 4).
    pub const BDF4: Self = Self {
        family: MultistepFamily::Bdf,
        steps: 4,
        name: "bdf4",
    };
    /// BDF5 (order 5).
    pub const BDF5: Self = Self {
        family: MultistepFamily::Bdf,
        steps: 5,
        name: "bdf5",
    };
    /// BDF6 (order 6).
    pub const BDF6: Self = Self {
        family: MultistepFamily::Bdf,
        steps: 6,
        name: "bdf6",
    };
    /// The paper's "Adams-Moulton 3-stage": 3-step Adams-Moulton, order 4.
    pub const ADAMS_MOULTON3: Self = Self {
        family: MultistepFamily::AdamsMoulton,
        steps: 3,
        name: "adams_moulton3",
    };

    /// Family of the formulas.
    pub fn family(&self) -> MultistepFamily {
        self.family
    }

    /// Steps q of the full formula.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Formula of interval k: the family's formula with min(q, k + 1) steps (start-up).
    pub fn formula(&self, k: usize) -> &'static MultistepFormula {
        let q = self.steps.min(k + 1);
        match self.family {
            MultistepFamily::Bdf => &BDF[q - 1],
            MultistepFamily::AdamsMoulton => &ADAMS_MOULTON[q - 1],
        }
    }
}

/// Column of input `l` of node `n` on interval `k` (0..7 states of x_n, 7..10 controls u_k).
#[inline]
fn in_col(lay: &Layout, k: usize, n: usize, l: usize) -> usize {
    if l < NXIN {
        lay.x(n, l)
    } else {
        lay.u(k, l - NXIN)
    }
}

/// Scaled f at node n with u_k: f_i(x_n, u_k; kappa_n) / nominal_i, inputs seeded by `seed`.
#[inline]
fn scaled_f<D: DualNum<Primitive = f64> + Copy>(
    cx: &SchemeContext,
    k: usize,
    n: usize,
    z: &[f64],
    seed: impl Fn(f64, usize) -> D,
) -> [D; NX] {
    let lay = &cx.layout;
    let x: [D; NX] = std::array::from_fn(|i| {
        let zi = z[lay.x(n, i)];
        if i < NXIN {
            seed(zi, i) * X_NOMINAL[i]
        } else {
            D::from(zi * X_NOMINAL[i])
        }
    });
    let u: [D; NU] = std::array::from_fn(|j| seed(z[lay.u(k, j)], NXIN + j) * U_NOMINAL[j]);
    let f = spatial_derivatives(cx.vehicle, &x, &u, cx.kappa[n]);
    std::array::from_fn(|i| f[i] / X_NOMINAL[i])
}

/// Gradient of the scaled f_i(x_n, u_k; kappa_n) / nominal_i over the 10 scaled inputs.
fn node_gradient(cx: &SchemeContext, k: usize, n: usize, z: &[f64]) -> [[f64; NIN]; NX] {
    if cx.oracle {
        let f = scaled_f(cx, k, n, z, seed1::<NIN>);
        return std::array::from_fn(|i| grad(&f[i]));
    }
    let (x, u) = physical(cx, k, z, |i| cx.layout.x(n, i));
    scaled_gradient(cx, &x, &u, cx.kappa[n])
}

/// One Jacobian entry of row i: which term produces its value.
#[derive(Debug, Clone, Copy)]
enum Entry {
    /// d/dx_{n,l} of window node j (a_j delta_il - ds b_j df_i/dx_l).
    State { j: usize, l: usize },
    /// d/du_{k,c}.
    Control { c: usize },
}

impl LinearMultistep {
    /// Walks the Jacobian entries of interval k in pattern order: (row, column, entry).
    fn entries(&self, lay: &Layout, k: usize, mut visit: impl FnMut(usize, usize, Entry)) {
        let m = self.formula(k);
        for i in 0..NX {
            for j in 0..=m.steps {
                let n = k + 1 - j;
                if m.b[j] != 0.0 {
                    for l in 0..NXIN {
                        visit(i, lay.x(n, l), Entry::State { j, l });
                    }
                    if i >= NXIN && m.a[j] != 0.0 {
                        visit(i, lay.x(n, i), Entry::State { j, l: i });
                    }
                } else if m.a[j] != 0.0 {
                    visit(i, lay.x(n, i), Entry::State { j, l: i });
                }
            }
            for c in 0..NU {
                visit(i, lay.u(k, c), Entry::Control { c });
            }
        }
    }
}

impl DefectScheme for LinearMultistep {
    const STAGE_VARS: usize = 0;
    const ROWS: usize = NX;

    fn name(&self) -> &'static str {
        self.name
    }

    fn row_name(&self, row: usize) -> &'static str {
        STATE_NAMES[row]
    }

    fn jac_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize)) {
        self.entries(lay, k, |r, c, _| push(r, c));
    }

    fn eval(&self, cx: &SchemeContext, k: usize, z: &[f64], out: &mut [f64]) {
        let m = self.formula(k);
        let lay = &cx.layout;
        out[..NX].fill(0.0);
        for j in 0..=m.steps {
            let n = k + 1 - j;
            for i in 0..NX {
                out[i] += m.a[j] * z[lay.x(n, i)];
            }
            if m.b[j] != 0.0 {
                let f = scaled_f(cx, k, n, z, |v, _| v);
                for i in 0..NX {
                    out[i] -= cx.ds * m.b[j] * f[i];
                }
            }
        }
    }

    fn jac(&self, cx: &SchemeContext, k: usize, z: &[f64], vals: &mut [f64]) {
        let m = self.formula(k);
        // Scaled df/d(inputs) of every window node with b_j != 0.
        let mut g = [[[0.0; NIN]; NX]; MAX_NODES];
        for j in 0..=m.steps {
            if m.b[j] != 0.0 {
                g[j] = node_gradient(cx, k, k + 1 - j, z);
            }
        }
        let mut p = 0;
        self.entries(&cx.layout, k, |i, _, e| {
            vals[p] = match e {
                Entry::State { j, l } => {
                    let lin = if l == i { m.a[j] } else { 0.0 };
                    let nl = if l < NXIN { g[j][i][l] } else { 0.0 };
                    lin - cx.ds * m.b[j] * nl
                }
                Entry::Control { c } => {
                    let mut s = 0.0;
                    for j in 0..=m.steps {
                        s += m.b[j] * g[j][i][NXIN + c];
                    }
                    -cx.ds * s
                }
            };
            p += 1;
        });
    }

    /// One dense lower-triangle block over (r..dpsi of x_n, u_k) per window node with
    /// b_j != 0 (the u_k blocks of different nodes share slots and add up).
    fn hess_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize)) {
        let m = self.formula(k);
        for j in 0..=m.steps {
            if m.b[j] != 0.0 {
                let n = k + 1 - j;
                for (a, b) in lower_pairs(NIN) {
                    let (ca, cb) = (in_col(lay, k, n, a), in_col(lay, k, n, b));
                    push(ca.max(cb), ca.min(cb));
                }
            }
        }
    }

    fn hess(&self, cx: &SchemeContext, k: usize, z: &[f64], lambda: &[f64], vals: &mut [f64]) {
        let m = self.formula(k);
        let mut off = 0;
        for j in (0..=m.steps).filter(|&j| m.b[j] != 0.0) {
            let n = k + 1 - j;
            let block = &mut vals[off..off + NHESS];
            off += NHESS;
            if cx.oracle {
                let f = scaled_f(cx, k, n, z, seed2::<NIN>);
                let mut acc = Dual2SVec64::<NIN>::from_re(0.0);
                for i in 0..NX {
                    acc += f[i] * (-cx.ds * m.b[j] * lambda[i]);
                }
                lower_hessian(&acc, block);
            } else {
                let (x, u) = physical(cx, k, z, |i| cx.layout.x(n, i));
                let w: [f64; NX] =
                    std::array::from_fn(|i| -cx.ds * m.b[j] * lambda[i] / X_NOMINAL[i]);
                fast::defect_hessian(cx.vehicle, &x, &u, cx.kappa[n], &w)
                    .write_lower(&IN_NOMINAL, block);
            }
        }
    }
}
