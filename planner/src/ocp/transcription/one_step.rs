//! Shared plumbing of the single-step schemes without stage variables (Crank-Nicolson,
//! explicit RK2 / RK4): the 21 local variables (x_k, u_k, x_{k+1}), the model as the ODE
//! right-hand side with u_k held over the interval and k_ref linearly interpolated between
//! the nodes, and the [`DefectScheme`](super::DefectScheme) implementation: values and
//! patterns from [`super::dense`], derivatives from a [`PointForm`] where the scheme has one
//! (Crank-Nicolson) and from jets through the RK formula otherwise (`rk_jets`: explicit RK
//! nests f inside f, so its rows are not linear in f at fixed points); the num-dual oracle
//! on request.

use super::dense::{self, LocalResidual};
use super::point_form::PointForm;
use super::rk_jets::{self, Stages};
use super::{steps, SchemeContext};
use crate::model::{spatial_derivatives, NU, NX};
use crate::ocp::layout::Layout;
use crate::ocp::scaling::{U_NOMINAL, X_NOMINAL};
use num_dual::DualNum;

/// Local variables of an interval: x_k (9), u_k (3), x_{k+1} (9).
pub(crate) const M: usize = 2 * NX + NU;

/// Which one-step formula of [`steps`] a scheme uses.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Rule {
    /// Trapezoid.
    CrankNicolson,
    /// Explicit midpoint.
    Rk2,
    /// Classical RK4.
    Rk4,
}

/// Global columns of (x_k, u_k, x_{k+1}).
pub(crate) fn cols(lay: &Layout, k: usize) -> [usize; M] {
    std::array::from_fn(|l| {
        if l < NX {
            lay.x(k, l)
        } else if l < NX + NU {
            lay.u(k, l - NX)
        } else {
            lay.x(k + 1, l - NX - NU)
        }
    })
}

/// k_ref at fraction `c` of interval k: linear interpolation of the node values (the road
/// is only known at the nodes; linear interpolation is the lowest-order consistent choice
/// and reproduces the node values exactly at c = 0 and c = 1).
#[inline]
pub(crate) fn kappa_at(kappa: &[f64], k: usize, c: f64) -> f64 {
    kappa[k] + c * (kappa[k + 1] - kappa[k])
}

/// Scaled defect rows (physical defect / state nominal) of interval k under `rule`.
pub(crate) fn residual<D: DualNum<Primitive = f64> + Copy>(
    rule: Rule,
    cx: &SchemeContext,
    k: usize,
    v: &[D; M],
    out: &mut [D],
) {
    let x0: [D; NX] = std::array::from_fn(|i| v[i] * X_NOMINAL[i]);
    let u: [D; NU] = std::array::from_fn(|j| v[NX + j] * U_NOMINAL[j]);
    let x1: [D; NX] = std::array::from_fn(|i| v[NX + NU + i] * X_NOMINAL[i]);
    let f = |x: &[D; NX], c: f64| spatial_derivatives(cx.vehicle, x, &u, kappa_at(cx.kappa, k, c));
    let d = match rule {
        Rule::CrankNicolson => steps::crank_nicolson(cx.ds, &x0, &x1, f),
        Rule::Rk2 => steps::rk2_midpoint(cx.ds, &x0, &x1, f),
        Rule::Rk4 => steps::rk4(cx.ds, &x0, &x1, f),
    };
    for i in 0..NX {
        out[i] = d[i] / X_NOMINAL[i];
    }
}

/// The fast derivatives of a single-step scheme.
#[derive(Debug, Clone, Copy)]
pub(crate) enum FastPath {
    /// Linear in f at fixed points (Crank-Nicolson): per-point jets.
    Points(&'static PointForm<2>),
    /// Explicit RK: jets carried through the stages (Hessian over [`NL_EXPLICIT`]).
    Stages(Stages),
}

/// Jacobian values of interval k: from the scheme's fast path unless the oracle is asked
/// for.
pub(crate) fn jac<R: LocalResidual<M>>(
    r: &R,
    fast: FastPath,
    cx: &SchemeContext,
    (k, z): (usize, &[f64]),
    vals: &mut [f64],
) {
    match fast {
        _ if cx.oracle => dense::jac(r, cx, k, z, vals),
        FastPath::Points(f) => f.jac(cx, k, z, &cols(&cx.layout, k), vals),
        FastPath::Stages(st) => rk_jets::jac(st, cx, k, z, vals),
    }
}

/// Hessian values of `lambda^T defect_k` over the nonlinear local variables `nl` (those of
/// the fast path's pattern): from the fast path unless the oracle is asked for.
pub(crate) fn hess<R: LocalResidual<M>, const L: usize>(
    r: &R,
    fast: FastPath,
    cx: &SchemeContext,
    (k, z, nl): (usize, &[f64], &[usize; L]),
    lambda: &[f64],
    vals: &mut [f64],
) {
    match fast {
        _ if cx.oracle => dense::hess(r, cx, k, z, nl, lambda, vals),
        FastPath::Points(f) => f.hess(cx, (k, z), &cols(&cx.layout, k), lambda, vals),
        FastPath::Stages(st) => rk_jets::hess(st, cx, k, z, lambda, vals),
    }
}

/// Local indices of r..dpsi of x_k (the states f reads) and of u_k.
pub(crate) const NL_EXPLICIT: [usize; 10] = [0, 1, 2, 3, 4, 5, 6, 9, 10, 11];
/// [`NL_EXPLICIT`] plus r..dpsi of x_{k+1} (implicit schemes evaluate f there too).
pub(crate) const NL_IMPLICIT: [usize; 17] =
    [0, 1, 2, 3, 4, 5, 6, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18];

/// Implements [`DefectScheme`](super::DefectScheme) and the oracle residual for a unit
/// struct of a single-step scheme; `$fast` is its [`FastPath`].
macro_rules! one_step_scheme {
    ($ty:ty, $rule:expr, $name:expr, $nl:expr, $fast:expr) => {
        impl
            $crate::ocp::transcription::dense::LocalResidual<
                { $crate::ocp::transcription::one_step::M },
            > for $ty
        {
            const ROWS: usize = $crate::model::NX;
            fn cols(
                &self,
                lay: &$crate::ocp::layout::Layout,
                k: usize,
            ) -> [usize; $crate::ocp::transcription::one_step::M] {
                $crate::ocp::transcription::one_step::cols(lay, k)
            }
            fn residual<D: num_dual::DualNum<Primitive = f64> + Copy>(
                &self,
                cx: &$crate::ocp::transcription::SchemeContext,
                k: usize,
                v: &[D; $crate::ocp::transcription::one_step::M],
                out: &mut [D],
            ) {
                $crate::ocp::transcription::one_step::residual($rule, cx, k, v, out)
            }
        }

        impl $crate::ocp::transcription::DefectScheme for $ty {
            const STAGE_VARS: usize = 0;
            const ROWS: usize = $crate::model::NX;
            fn name(&self) -> &'static str {
                $name
            }
            fn row_name(&self, row: usize) -> &'static str {
                $crate::model::STATE_NAMES[row]
            }
            fn jac_pattern(
                &self,
                lay: &$crate::ocp::layout::Layout,
                k: usize,
                push: &mut dyn FnMut(usize, usize),
            ) {
                $crate::ocp::transcription::dense::jac_pattern(self, lay, k, push)
            }
            fn eval(
                &self,
                cx: &$crate::ocp::transcription::SchemeContext,
                k: usize,
                z: &[f64],
                out: &mut [f64],
            ) {
                $crate::ocp::transcription::dense::eval(self, cx, k, z, out)
            }
            fn jac(
                &self,
                cx: &$crate::ocp::transcription::SchemeContext,
                k: usize,
                z: &[f64],
                vals: &mut [f64],
            ) {
                $crate::ocp::transcription::one_step::jac(self, $fast, cx, (k, z), vals)
            }
            fn hess_pattern(
                &self,
                lay: &$crate::ocp::layout::Layout,
                k: usize,
                push: &mut dyn FnMut(usize, usize),
            ) {
                $crate::ocp::transcription::dense::hess_pattern(self, lay, k, &$nl, push)
            }
            fn hess(
                &self,
                cx: &$crate::ocp::transcription::SchemeContext,
                k: usize,
                z: &[f64],
                lambda: &[f64],
                vals: &mut [f64],
            ) {
                $crate::ocp::transcription::one_step::hess(
                    self,
                    $fast,
                    cx,
                    (k, z, &$nl),
                    lambda,
                    vals,
                )
            }
        }
    };
}
pub(crate) use one_step_scheme;
