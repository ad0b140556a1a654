//! Exact derivatives of the explicit RK defects over the lean jets of
//! [`crate::ocp::jet`]. The defect of interval k is `x_{k+1} - x_k - ds Phi(x_k, u_k)`,
//! where the increment Phi nests f inside f (RK2: `f(x + ds/2 f(x))`); f reads only
//! r..dpsi of its state and u_k, so Phi depends on the 10 inputs r..dpsi of x_k and u_k
//! alone. One pass of the RK formula over first-order jets in those 10 inputs gives the
//! Jacobian, one over second-order jets the Hessian of `lambda^T defect`; the values and
//! patterns stay those of [`super::dense`] (the num-dual oracle's).

use super::one_step::{kappa_at, M};
use super::point_jets::{NIN, NXIN};
use super::SchemeContext;
use crate::model::{NU, NX};
use crate::ocp::fast::spatial;
use crate::ocp::jet::{Arith, D1, D2};
use crate::ocp::scaling::{U_NOMINAL, X_NOMINAL};

/// Which explicit RK formula.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Stages {
    /// Explicit midpoint.
    Rk2,
    /// Classical RK4.
    Rk4,
}

/// The increment Phi of `stages` from x_k's r..dpsi and u_k (physical, as jets), the
/// formulas of `steps::rk2_midpoint` and `steps::rk4`.
fn increment<T: Arith>(
    stages: Stages,
    cx: &SchemeContext,
    k: usize,
    x: [T; 7],
    u: [T; NU],
) -> [T; NX] {
    let h = cx.ds;
    let f = |y: &[T; 7], c: f64| spatial(cx.vehicle, y, &u, kappa_at(cx.kappa, k, c));
    let step = |a: f64, d: &[T; NX]| -> [T; 7] { std::array::from_fn(|i| x[i] + d[i] * a) };
    match stages {
        Stages::Rk2 => {
            let k1 = f(&x, 0.0);
            f(&step(0.5 * h, &k1), 0.5)
        }
        Stages::Rk4 => {
            let k1 = f(&x, 0.0);
            let k2 = f(&step(0.5 * h, &k1), 0.5);
            let k3 = f(&step(0.5 * h, &k2), 0.5);
            let k4 = f(&step(h, &k3), 1.0);
            std::array::from_fn(|i| (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (1.0 / 6.0))
        }
    }
}

/// The 10 inputs of interval k as jets in the physical units: input l is
/// `var(z_l) * nominal_l`, so derivatives are per scaled input.
fn inputs<T: Arith>(
    cx: &SchemeContext,
    k: usize,
    z: &[f64],
    var: impl Fn(f64, usize) -> T,
) -> ([T; 7], [T; NU]) {
    let lay = &cx.layout;
    let x = std::array::from_fn(|i| var(z[lay.x(k, i)], i) * X_NOMINAL[i]);
    let u = std::array::from_fn(|j| var(z[lay.u(k, j)], NXIN + j) * U_NOMINAL[j]);
    (x, u)
}

/// Dense Jacobian values of interval k (row-major over x_k, u_k, x_{k+1}).
pub(crate) fn jac(stages: Stages, cx: &SchemeContext, k: usize, z: &[f64], vals: &mut [f64]) {
    let (x, u) = inputs(cx, k, z, D1::<NIN>::var);
    let phi = increment(stages, cx, k, x, u);
    vals[..NX * M].fill(0.0);
    for (i, p) in phi.iter().enumerate() {
        let row = &mut vals[i * M..(i + 1) * M];
        row[i] -= 1.0;
        row[NX + NU + i] += 1.0;
        let c = -cx.ds / X_NOMINAL[i];
        for (l, g) in p.g.iter().enumerate() {
            let col = if l < NXIN { l } else { NX + l - NXIN };
            row[col] += c * g;
        }
    }
}

/// Lower-triangle Hessian of `lambda^T defect_k` over the 10 inputs, in the order of
/// `one_step::NL_EXPLICIT` (r..dpsi of x_k, then u_k).
pub(crate) fn hess(
    stages: Stages,
    cx: &SchemeContext,
    k: usize,
    z: &[f64],
    lambda: &[f64],
    vals: &mut [f64],
) {
    let (x, u) = inputs(cx, k, z, D2::<NIN>::var);
    let phi = increment(stages, cx, k, x, u);
    let mut acc = D2::<NIN>::cst(0.0);
    for (i, p) in phi.iter().enumerate() {
        acc = acc + *p * (-cx.ds * lambda[i] / X_NOMINAL[i]);
    }
    // The jets' derivatives are already per scaled input.
    acc.write_lower(&[1.0; NIN], vals);
}
