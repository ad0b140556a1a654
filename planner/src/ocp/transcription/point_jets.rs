//! f = dx/ds at one point (a node or a collocation stage state, with the interval's
//! control) and its exact derivatives in scaled units, from the hand-written jets of
//! [`crate::ocp::fast`].
//!
//! Every scheme whose defect is a linear combination of states and of f at points,
//! `sum_p a_p y_p - ds sum_p b_p f(y_p, u_k; k_ref(p))` (implicit Euler, Crank-Nicolson,
//! the linear multistep formulas, Gauss-Legendre collocation), takes its Jacobian from the
//! gradient of f at each point and the Hessian of `lambda^T defect` from one weighted
//! Hessian per point ([`fast::defect_hessian`]), `sum_i w_i f_i` with
//! `w_i = -ds sum_rows lambda b_p / nominal_i`.
//! f depends on the 10 inputs r..dpsi of the point's state and u_k only (not on s or t).

use super::SchemeContext;
use crate::model::{NU, NX};
use crate::ocp::fast;
use crate::ocp::jet::D2;
use crate::ocp::scaling::{U_NOMINAL, X_NOMINAL};

/// Inputs of f at one point: r..dpsi of the point's state, then the controls.
pub(crate) const NIN: usize = 10;
/// States among the inputs.
pub(crate) const NXIN: usize = 7;

/// Nominal of each input of f (scaled z = physical / nominal).
pub(crate) const IN_NOMINAL: [f64; NIN] = [
    X_NOMINAL[0],
    X_NOMINAL[1],
    X_NOMINAL[2],
    X_NOMINAL[3],
    X_NOMINAL[4],
    X_NOMINAL[5],
    X_NOMINAL[6],
    U_NOMINAL[0],
    U_NOMINAL[1],
    U_NOMINAL[2],
];

/// The physical state of the point whose scaled state i sits at `z[state_col(i)]`, and the
/// physical control of interval k.
#[inline(always)]
pub(crate) fn physical(
    cx: &SchemeContext,
    k: usize,
    z: &[f64],
    state_col: impl Fn(usize) -> usize,
) -> ([f64; NX], [f64; NU]) {
    let lay = &cx.layout;
    let x = std::array::from_fn(|i| z[state_col(i)] * X_NOMINAL[i]);
    let u = std::array::from_fn(|j| z[lay.u(k, j)] * U_NOMINAL[j]);
    (x, u)
}

/// Gradient of the scaled f_i / nominal_i over the scaled inputs, for every row i.
#[inline(always)]
pub(crate) fn scaled_gradient(
    cx: &SchemeContext,
    x: &[f64; NX],
    u: &[f64; NU],
    kappa: f64,
) -> [[f64; NIN]; NX] {
    let f = fast::defect_jacobian(cx.vehicle, x, u, kappa);
    std::array::from_fn(|i| std::array::from_fn(|l| f[i].g[l] * IN_NOMINAL[l] / X_NOMINAL[i]))
}

/// Index of the lower-triangle entry (a, b) (either order) in row-major order over a >= b.
#[inline(always)]
pub(crate) fn tri(a: usize, b: usize) -> usize {
    let (hi, lo) = if a >= b { (a, b) } else { (b, a) };
    hi * (hi + 1) / 2 + lo
}

/// Adds the Hessian `h` of one point (the jet of [`fast::defect_hessian`], physical inputs)
/// scaled to the scaled inputs into a dense lower triangle whose variable order places
/// input l of the point at position `pos[l]`.
#[inline(always)]
pub(crate) fn add_lower(h: &D2<NIN>, pos: &[usize; NIN], out: &mut [f64]) {
    for a in 0..NIN {
        for b in 0..=a {
            out[tri(pos[a], pos[b])] += h.h[a][b] * IN_NOMINAL[a] * IN_NOMINAL[b];
        }
    }
}
