//! Gauss-Legendre collocation: the 2-stage scheme (order 4, A-stable) and the 3-stage ground
//! truth [`GaussLegendre3`] (order 6). The 2-stage scheme has the two stage states of
//! every interval as decision variables of the NLP (STAGE_VARS = 2 NX, stored in the
//! layout's w_k slots as [X_1, X_2], scaled like the states; no inner Newton loop).
//!
//! Rows of interval k (each divided by the nominal of its state), see
//! [`steps::gauss_legendre2`]: the collocation rows X_j - x_k - ds sum_l A_jl f(X_l) for
//! j = 1, 2, then the continuity row x_{k+1} - x_k - ds sum_l b_l f(X_l). u_k is held and
//! k_ref is linearly interpolated to the stage positions s_k + c_j ds.
//! Exact derivatives from the per-point jets of f at the stage states
//! (`point_form`); the num-dual oracle stays for checks.

use super::dense::{self, LocalResidual};
use super::one_step::kappa_at;
use super::point_form::{hessian_positions, PointForm};
use super::{steps, DefectScheme, SchemeContext};
use crate::model::{spatial_derivatives, NU, NX};
use crate::ocp::layout::Layout;
use crate::ocp::scaling::{U_NOMINAL, X_NOMINAL};
use num_dual::DualNum;

/// Local variables: x_k (9), u_k (3), x_{k+1} (9), X_1 (9), X_2 (9).
const M: usize = 4 * NX + NU;
/// Offset of x_{k+1} among the local variables.
const X1: usize = NX + NU;
/// Offset of the stage states among the local variables.
const W: usize = 2 * NX + NU;
/// Local indices entering nonlinearly: u_k and r..dpsi of both stage states.
const NL: [usize; 17] = [
    9, 10, 11, 21, 22, 23, 24, 25, 26, 27, 30, 31, 32, 33, 34, 35, 36,
];

/// The 2-stage rows as a point form: f at the two stage states.
const FORM2: PointForm<2> = PointForm {
    point_off: [W, W + NX],
    c: steps::GL2_C,
    lin: &[
        [(W, 1.0), (0, -1.0)],
        [(W + NX, 1.0), (0, -1.0)],
        [(X1, 1.0), (0, -1.0)],
    ],
    w: &[steps::GL2_A[0], steps::GL2_A[1], steps::GL2_B],
    nl: &NL,
    pos: hessian_positions([W, W + NX], &NL),
};

/// The 3-stage rows as a point form: f at the three stage states.
const FORM3: PointForm<3> = PointForm {
    point_off: [W, W + NX, W + 2 * NX],
    c: steps::GL3_C,
    lin: &[
        [(W, 1.0), (0, -1.0)],
        [(W + NX, 1.0), (0, -1.0)],
        [(W + 2 * NX, 1.0), (0, -1.0)],
        [(X1, 1.0), (0, -1.0)],
    ],
    w: &[
        steps::GL3_A[0],
        steps::GL3_A[1],
        steps::GL3_A[2],
        steps::GL3_B,
    ],
    nl: &NL3,
    pos: hessian_positions([W, W + NX, W + 2 * NX], &NL3),
};

/// Names of the 27 defect rows.
const ROW_NAMES: [&str; 3 * NX] = [
    "stage1.r",
    "stage1.V",
    "stage1.beta",
    "stage1.V_wr",
    "stage1.dFz",
    "stage1.e",
    "stage1.dpsi",
    "stage1.s",
    "stage1.t",
    "stage2.r",
    "stage2.V",
    "stage2.beta",
    "stage2.V_wr",
    "stage2.dFz",
    "stage2.e",
    "stage2.dpsi",
    "stage2.s",
    "stage2.t",
    "r",
    "V",
    "beta",
    "V_wr",
    "dFz",
    "e",
    "dpsi",
    "s",
    "t",
];

/// 2-stage Gauss-Legendre collocation scheme (2 NX stage variables, 3 NX rows per interval).
#[derive(Debug, Clone, Copy, Default)]
pub struct GaussLegendre2;

impl LocalResidual<M> for GaussLegendre2 {
    const ROWS: usize = 3 * NX;

    fn cols(&self, lay: &Layout, k: usize) -> [usize; M] {
        std::array::from_fn(|l| {
            if l < NX {
                lay.x(k, l)
            } else if l < X1 {
                lay.u(k, l - NX)
            } else if l < W {
                lay.x(k + 1, l - X1)
            } else {
                lay.w(k, l - W)
            }
        })
    }

    fn residual<D: DualNum<Primitive = f64> + Copy>(
        &self,
        cx: &SchemeContext,
        k: usize,
        v: &[D; M],
        out: &mut [D],
    ) {
        let state = |off: usize| -> [D; NX] { std::array::from_fn(|i| v[off + i] * X_NOMINAL[i]) };
        let u: [D; NU] = std::array::from_fn(|j| v[NX + j] * U_NOMINAL[j]);
        let f =
            |x: &[D; NX], c: f64| spatial_derivatives(cx.vehicle, x, &u, kappa_at(cx.kappa, k, c));
        let (x0, x1, s1, s2) = (state(0), state(X1), state(W), state(W + NX));
        steps::gauss_legendre2(cx.ds, &x0, &x1, &s1, &s2, f, out);
        for (r, o) in out.iter_mut().enumerate().take(3 * NX) {
            *o /= X_NOMINAL[r % NX];
        }
    }
}

impl DefectScheme for GaussLegendre2 {
    const STAGE_VARS: usize = 2 * NX;
    const ROWS: usize = 3 * NX;

    fn name(&self) -> &'static str {
        "gauss_legendre2"
    }

    fn row_name(&self, row: usize) -> &'static str {
        ROW_NAMES[row]
    }

    fn jac_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize)) {
        dense::jac_pattern(self, lay, k, push)
    }

    fn eval(&self, cx: &SchemeContext, k: usize, z: &[f64], out: &mut [f64]) {
        dense::eval(self, cx, k, z, out)
    }

    fn jac(&self, cx: &SchemeContext, k: usize, z: &[f64], vals: &mut [f64]) {
        if cx.oracle {
            return dense::jac(self, cx, k, z, vals);
        }
        FORM2.jac(cx, k, z, &self.cols(&cx.layout, k), vals)
    }

    fn hess_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize)) {
        dense::hess_pattern(self, lay, k, &NL, push)
    }

    fn hess(&self, cx: &SchemeContext, k: usize, z: &[f64], lambda: &[f64], vals: &mut [f64]) {
        if cx.oracle {
            return dense::hess(self, cx, k, z, &NL, lambda, vals);
        }
        FORM2.hess(cx, (k, z), &self.cols(&cx.layout, k), lambda, vals)
    }

    /// Stage states on the straight line between the nodes: X_j = x_k + c_j (x_{k+1} - x_k).
    fn guess_stage_vars(&self, cx: &SchemeContext, k: usize, z: &mut [f64]) {
        let lay = &cx.layout;
        for (j, c) in steps::GL2_C.iter().enumerate() {
            for i in 0..NX {
                let (a, b) = (z[lay.x(k, i)], z[lay.x(k + 1, i)]);
                z[lay.w(k, j * NX + i)] = a + c * (b - a);
            }
        }
    }
}

/// Local variables of the 3-stage scheme: x_k (9), u_k (3), x_{k+1} (9), X_1..X_3 (27).
const M3: usize = 5 * NX + NU;
/// Local indices entering the 3-stage rows nonlinearly: u_k and r..dpsi of the three
/// stage states.
const NL3: [usize; 24] = [
    9, 10, 11, 21, 22, 23, 24, 25, 26, 27, 30, 31, 32, 33, 34, 35, 36, 39, 40, 41, 42, 43, 44, 45,
];

/// Names of the 36 defect rows of the 3-stage scheme.
const ROW_NAMES3: [&str; 4 * NX] = [
    "stage1.r",
    "stage1.V",
    "stage1.beta",
    "stage1.V_wr",
    "stage1.dFz",
    "stage1.e",
    "stage1.dpsi",
    "stage1.s",
    "stage1.t",
    "stage2.r",
    "stage2.V",
    "stage2.beta",
    "stage2.V_wr",
    "stage2.dFz",
    "stage2.e",
    "stage2.dpsi",
    "stage2.s",
    "stage2.t",
    "stage3.r",
    "stage3.V",
    "stage3.beta",
    "stage3.V_wr",
    "stage3.dFz",
    "stage3.e",
    "stage3.dpsi",
    "stage3.s",
    "stage3.t",
    "r",
    "V",
    "beta",
    "V_wr",
    "dFz",
    "e",
    "dpsi",
    "s",
    "t",
];

/// 3-stage Gauss-Legendre collocation (order 6, A-stable): the paper's ground truth
/// (Sec. IV). The three stage states of every interval are decision variables of the NLP
/// (STAGE_VARS = 3 NX, stored in w_k as [X_1, X_2, X_3], scaled like the states; no inner
/// Newton loop); 4 NX rows per interval, see [`steps::gauss_legendre3`]. u_k is held and
/// k_ref is linearly interpolated to the stage positions s_k + c_j ds. Exact derivatives
/// from the per-point jets at the stage states.
#[derive(Debug, Clone, Copy, Default)]
pub struct GaussLegendre3;

impl LocalResidual<M3> for GaussLegendre3 {
    const ROWS: usize = 4 * NX;

    fn cols(&self, lay: &Layout, k: usize) -> [usize; M3] {
        std::array::from_fn(|l| {
            if l < NX {
                lay.x(k, l)
            } else if l < X1 {
                lay.u(k, l - NX)
            } else if l < W {
                lay.x(k + 1, l - X1)
            } else {
                lay.w(k, l - W)
            }
        })
    }

    fn residual<D: DualNum<Primitive = f64> + Copy>(
        &self,
        cx: &SchemeContext,
        k: usize,
        v: &[D; M3],
        out: &mut [D],
    ) {
        let state = |off: usize| -> [D; NX] { std::array::from_fn(|i| v[off + i] * X_NOMINAL[i]) };
        let u: [D; NU] = std::array::from_fn(|j| v[NX + j] * U_NOMINAL[j]);
        let f =
            |x: &[D; NX], c: f64| spatial_derivatives(cx.vehicle, x, &u, kappa_at(cx.kappa, k, c));
        let (x0, x1) = (state(0), state(X1));
        let xs = [state(W), state(W + NX), state(W + 2 * NX)];
        steps::gauss_legendre3(cx.ds, &x0, &x1, &xs, f, out);
        for (r, o) in out.iter_mut().enumerate().take(4 * NX) {
            *o /= X_NOMINAL[r % NX];
        }
    }
}

impl DefectScheme for GaussLegendre3 {
    const STAGE_VARS: usize = 3 * NX;
    const ROWS: usize = 4 * NX;

    fn name(&self) -> &'static str {
        "gauss_legendre3"
    }

    fn row_name(&self, row: usize) -> &'static str {
        ROW_NAMES3[row]
    }

    fn jac_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize)) {
        dense::jac_pattern(self, lay, k, push)
    }

    fn eval(&self, cx: &SchemeContext, k: usize, z: &[f64], out: &mut [f64]) {
        dense::eval(self, cx, k, z, out)
    }

    fn jac(&self, cx: &SchemeContext, k: usize, z: &[f64], vals: &mut [f64]) {
        if cx.oracle {
            return dense::jac(self, cx, k, z, vals);
        }
        FORM3.jac(cx, k, z, &self.cols(&cx.layout, k), vals)
    }

    fn hess_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize)) {
        dense::hess_pattern(self, lay, k, &NL3, push)
    }

    fn hess(&self, cx: &SchemeContext, k: usize, z: &[f64], lambda: &[f64], vals: &mut [f64]) {
        if cx.oracle {
            return dense::hess(self, cx, k, z, &NL3, lambda, vals);
        }
        FORM3.hess(cx, (k, z), &self.cols(&cx.layout, k), lambda, vals)
    }

    /// Stage states on the straight line between the nodes: X_j = x_k + c_j (x_{k+1} - x_k).
    fn guess_stage_vars(&self, cx: &SchemeContext, k: usize, z: &mut [f64]) {
        let lay = &cx.layout;
        for (j, c) in steps::GL3_C.iter().enumerate() {
            for i in 0..NX {
                let (a, b) = (z[lay.x(k, i)], z[lay.x(k + 1, i)]);
                z[lay.w(k, j * NX + i)] = a + c * (b - a);
            }
        }
    }
}
