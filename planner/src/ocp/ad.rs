//! Small helpers around num-dual's statically sized duals (allocation-free).

use num_dual::{Dual2SVec64, DualSVec64};

/// First-order dual with value `v` and unit derivative in direction `i`.
#[inline]
pub(crate) fn seed1<const M: usize>(v: f64, i: usize) -> DualSVec64<M> {
    DualSVec64::<M>::from_re(v).derivative(i)
}

/// Second-order dual with value `v` and unit derivative in direction `i`.
#[inline]
pub(crate) fn seed2<const M: usize>(v: f64, i: usize) -> Dual2SVec64<M> {
    Dual2SVec64::<M>::from_re(v).derivative(i)
}

/// Gradient part of a first-order dual (zeros if structurally absent).
#[inline]
pub(crate) fn grad<const M: usize>(d: &DualSVec64<M>) -> [f64; M] {
    match &d.eps.0 {
        Some(m) => std::array::from_fn(|i| m[i]),
        None => [0.0; M],
    }
}

/// Writes the lower triangle (row-major over i >= j) of the Hessian part of `d` into `out`
/// (length M (M + 1) / 2), zeros if structurally absent.
#[inline]
pub(crate) fn lower_hessian<const M: usize>(d: &Dual2SVec64<M>, out: &mut [f64]) {
    match &d.v2.0 {
        Some(h) => {
            let mut p = 0;
            for i in 0..M {
                for j in 0..=i {
                    out[p] = h[(i, j)];
                    p += 1;
                }
            }
        }
        None => out[..M * (M + 1) / 2].fill(0.0),
    }
}

/// The (i, j), i >= j, pairs of a dense lower triangle in the order of [`lower_hessian`].
pub(crate) fn lower_pairs(m: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..m).flat_map(|i| (0..=i).map(move |j| (i, j)))
}
