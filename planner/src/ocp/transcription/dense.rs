//! Exact derivatives of a scheme's defect rows by num-dual through the generic model, for
//! schemes written once as a function of the M local variables of an interval (the
//! oracle path; correct for any scheme, not tuned for speed).
//!
//! The Jacobian block of an interval is stored dense (all rows x all M local columns,
//! structural zeros included); the Hessian block is the dense lower triangle over the L
//! local variables that enter nonlinearly (the others only enter linearly, so their
//! second derivatives vanish).

use super::SchemeContext;
use crate::ocp::ad::{grad, lower_hessian, lower_pairs, seed1, seed2};
use crate::ocp::layout::Layout;
use num_dual::{Dual2SVec64, DualNum, DualSVec64};

/// Largest number of defect rows of one interval supported here.
pub(crate) const MAX_ROWS: usize = 36;

/// Defect rows of one interval as a function of its M local (scaled) variables.
pub(crate) trait LocalResidual<const M: usize> {
    /// Defect rows per interval (at most [`MAX_ROWS`]).
    const ROWS: usize;
    /// Global columns of the M local variables of interval k (distinct).
    fn cols(&self, lay: &Layout, k: usize) -> [usize; M];
    /// Writes the `ROWS` scaled defect rows of interval k at local variables `v`.
    fn residual<D: DualNum<Primitive = f64> + Copy>(
        &self,
        cx: &SchemeContext,
        k: usize,
        v: &[D; M],
        out: &mut [D],
    );
}

/// Values of the defect rows.
pub(crate) fn eval<R: LocalResidual<M>, const M: usize>(
    r: &R,
    cx: &SchemeContext,
    k: usize,
    z: &[f64],
    out: &mut [f64],
) {
    let cols = r.cols(&cx.layout, k);
    let v: [f64; M] = std::array::from_fn(|i| z[cols[i]]);
    r.residual(cx, k, &v, &mut out[..R::ROWS]);
}

/// Dense Jacobian pattern: every row against every local column.
pub(crate) fn jac_pattern<R: LocalResidual<M>, const M: usize>(
    r: &R,
    lay: &Layout,
    k: usize,
    push: &mut dyn FnMut(usize, usize),
) {
    let cols = r.cols(lay, k);
    for row in 0..R::ROWS {
        for &c in &cols {
            push(row, c);
        }
    }
}

/// Dense Jacobian values (row-major, [`jac_pattern`] order) by first-order duals.
pub(crate) fn jac<R: LocalResidual<M>, const M: usize>(
    r: &R,
    cx: &SchemeContext,
    k: usize,
    z: &[f64],
    vals: &mut [f64],
) {
    let cols = r.cols(&cx.layout, k);
    let v: [DualSVec64<M>; M] = std::array::from_fn(|i| seed1::<M>(z[cols[i]], i));
    let mut out: [DualSVec64<M>; MAX_ROWS] = [DualSVec64::<M>::from_re(0.0); MAX_ROWS];
    r.residual(cx, k, &v, &mut out[..R::ROWS]);
    for (row, o) in out[..R::ROWS].iter().enumerate() {
        vals[row * M..(row + 1) * M].copy_from_slice(&grad(o));
    }
}

/// Hessian pattern: lower triangle over the nonlinear local variables `nl` (indices into
/// the M local variables), as global (row >= col) pairs.
pub(crate) fn hess_pattern<R: LocalResidual<M>, const M: usize, const L: usize>(
    r: &R,
    lay: &Layout,
    k: usize,
    nl: &[usize; L],
    push: &mut dyn FnMut(usize, usize),
) {
    let cols = r.cols(lay, k);
    for (i, j) in lower_pairs(L) {
        let (a, b) = (cols[nl[i]], cols[nl[j]]);
        push(a.max(b), a.min(b));
    }
}

/// Hessian of `lambda^T defect` in [`hess_pattern`] order by second-order duals seeded on
/// the nonlinear variables only.
pub(crate) fn hess<R: LocalResidual<M>, const M: usize, const L: usize>(
    r: &R,
    cx: &SchemeContext,
    k: usize,
    z: &[f64],
    nl: &[usize; L],
    lambda: &[f64],
    vals: &mut [f64],
) {
    let cols = r.cols(&cx.layout, k);
    let mut v: [Dual2SVec64<L>; M] = std::array::from_fn(|i| Dual2SVec64::<L>::from_re(z[cols[i]]));
    for (p, &i) in nl.iter().enumerate() {
        v[i] = seed2::<L>(z[cols[i]], p);
    }
    let mut out: [Dual2SVec64<L>; MAX_ROWS] = [Dual2SVec64::<L>::from_re(0.0); MAX_ROWS];
    r.residual(cx, k, &v, &mut out[..R::ROWS]);
    let mut acc = Dual2SVec64::<L>::from_re(0.0);
    for (o, &l) in out[..R::ROWS].iter().zip(lambda) {
        acc += *o * l;
    }
    lower_hessian(&acc, vals);
}
