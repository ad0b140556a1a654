//! Implicit (backward) Euler defect, the paper's fastest A-stable choice:
//! x_{k+1} - x_k - ds f(x_{k+1}, u_k; k_ref(s_{k+1})) = 0, each row divided by the nominal of
//! its state.

use super::point_jets::{IN_NOMINAL, NIN, NXIN};
use super::{DefectScheme, SchemeContext};
use crate::model::{ix, spatial_derivatives, time_derivatives, NU, NX, STATE_NAMES};
use crate::ocp::ad::{grad, lower_hessian, lower_pairs, seed1, seed2};
use crate::ocp::fast;
use crate::ocp::layout::Layout;
use crate::ocp::scaling::{U_NOMINAL, X_NOMINAL};
use num_dual::DualNum;

/// Implicit Euler defect scheme (no stage variables, NX rows per interval).
#[derive(Debug, Clone, Copy, Default)]
pub struct ImplicitEuler;

/// Column of input `l` (0..7 states of x_{k+1}, 7..10 controls of u_k).
#[inline]
fn in_col(lay: &Layout, k: usize, l: usize) -> usize {
    if l < NXIN {
        lay.x(k + 1, l)
    } else {
        lay.u(k, l - NXIN)
    }
}

/// Physical (x_{k+1}, u_k) with input `l` built as `seed(z, l) * nominal`.
#[inline(always)]
fn point<D: DualNum<Primitive = f64> + Copy>(
    lay: &Layout,
    k: usize,
    z: &[f64],
    seed: impl Fn(f64, usize) -> D,
) -> ([D; NX], [D; NU]) {
    let x: [D; NX] = std::array::from_fn(|i| {
        let zi = z[lay.x(k + 1, i)];
        if i < NXIN {
            seed(zi, i) * X_NOMINAL[i]
        } else {
            D::from(zi * X_NOMINAL[i])
        }
    });
    let u: [D; NU] = std::array::from_fn(|j| seed(z[lay.u(k, j)], NXIN + j) * U_NOMINAL[j]);
    (x, u)
}

impl DefectScheme for ImplicitEuler {
    const STAGE_VARS: usize = 0;
    const ROWS: usize = NX;

    fn name(&self) -> &'static str {
        "implicit_euler"
    }

    fn row_name(&self, row: usize) -> &'static str {
        STATE_NAMES[row]
    }

    fn jac_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize)) {
        for i in 0..NX {
            push(i, lay.x(k, i));
            if i != ix::S {
                for l in 0..NIN {
                    push(i, in_col(lay, k, l));
                }
            }
            if i >= NXIN {
                push(i, lay.x(k + 1, i));
            }
        }
    }

    fn eval(&self, cx: &SchemeContext, k: usize, z: &[f64], out: &mut [f64]) {
        let lay = &cx.layout;
        let (x, u) = point::<f64>(lay, k, z, |v, _| v);
        let f = spatial_derivatives(cx.vehicle, &x, &u, cx.kappa[k + 1]);
        for i in 0..NX {
            out[i] = z[lay.x(k + 1, i)] - z[lay.x(k, i)] - cx.ds * f[i] / X_NOMINAL[i];
        }
    }

    #[inline(always)]
    fn jac(&self, cx: &SchemeContext, k: usize, z: &[f64], vals: &mut [f64]) {
        if cx.oracle {
            return jac_oracle(cx, k, z, vals);
        }
        let lay = &cx.layout;
        let (x, u) = point::<f64>(lay, k, z, |v, _| v);
        let f = fast::defect_jacobian(cx.vehicle, &x, &u, cx.kappa[k + 1]);
        let mut p = 0;
        for i in 0..NX {
            vals[p] = -1.0;
            p += 1;
            if i != ix::S {
                let c = -cx.ds / X_NOMINAL[i];
                for (l, (gl, nl)) in f[i].g.iter().zip(&IN_NOMINAL).enumerate() {
                    vals[p] = c * gl * nl + if l == i && l < NXIN { 1.0 } else { 0.0 };
                    p += 1;
                }
            }
            if i >= NXIN {
                vals[p] = 1.0;
                p += 1;
            }
        }
    }

    fn hess_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize)) {
        for (i, j) in lower_pairs(NIN) {
            let (a, b) = (in_col(lay, k, i), in_col(lay, k, j));
            push(a.max(b), a.min(b));
        }
    }

    #[inline(always)]
    fn hess(&self, cx: &SchemeContext, k: usize, z: &[f64], lambda: &[f64], vals: &mut [f64]) {
        if cx.oracle {
            return hess_oracle(cx, k, z, lambda, vals);
        }
        let lay = &cx.layout;
        let (x, u) = point::<f64>(lay, k, z, |v, _| v);
        // Only the -ds f / nominal part of each defect is nonlinear (ds/ds = 1 is constant).
        let w: [f64; NX] = std::array::from_fn(|i| -cx.ds * lambda[i] / X_NOMINAL[i]);
        fast::defect_hessian(cx.vehicle, &x, &u, cx.kappa[k + 1], &w)
            .write_lower(&IN_NOMINAL, vals);
    }
}

/// Defect Jacobian of interval k by num-dual first-order duals through the generic model
/// (the oracle).
#[inline(never)]
fn jac_oracle(cx: &SchemeContext, k: usize, z: &[f64], vals: &mut [f64]) {
    let lay = &cx.layout;
    let (x, u) = point(lay, k, z, seed1::<NIN>);
    let f = spatial_derivatives(cx.vehicle, &x, &u, cx.kappa[k + 1]);
    let mut p = 0;
    for i in 0..NX {
        vals[p] = -1.0;
        p += 1;
        if i != ix::S {
            let g = grad(&f[i]);
            let c = -cx.ds / X_NOMINAL[i];
            for (l, gl) in g.iter().enumerate() {
                vals[p] = c * gl + if l == i && l < NXIN { 1.0 } else { 0.0 };
                p += 1;
            }
        }
        if i >= NXIN {
            vals[p] = 1.0;
            p += 1;
        }
    }
}

/// Hessian of `lambda^T defect_k` by num-dual second-order duals through the generic model
/// (the oracle).
#[inline(never)]
fn hess_oracle(cx: &SchemeContext, k: usize, z: &[f64], lambda: &[f64], vals: &mut [f64]) {
    let lay = &cx.layout;
    let (x, u) = point(lay, k, z, seed2::<NIN>);
    // With f_i = xdot_i / sdot (i < 7) and f_t = 1 / sdot, the weighted sum is formed
    // before the single division by sdot (fewer second-order dual operations).
    let td = time_derivatives(cx.vehicle, &x, &u, cx.kappa[k + 1]);
    let w = |i: usize| -cx.ds * lambda[i] / X_NOMINAL[i];
    let mut acc = td.dxdt[0] * w(0);
    for i in 1..NXIN {
        acc += td.dxdt[i] * w(i);
    }
    let phi = (acc + w(ix::T)) / td.sdot;
    lower_hessian(&phi, vals);
}
