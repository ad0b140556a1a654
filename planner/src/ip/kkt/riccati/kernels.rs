//! Small fixed-size kernels of the stage elimination: matrix-vector and matrix-matrix
//! products over nalgebra's column storage or plain column arrays (`[[f64; R]; C]`, one
//! array per column), reductions, symmetrization and an LDL^T without pivoting.
//!
//! All are `#[inline(always)]`, so each is compiled into its caller's copy: the baseline
//! one or the one built with AVX2 enabled. Every kernel fixes its summation order, and
//! Rust never contracts a * b + c into an FMA, so both copies give the same bits. Where a
//! kernel stands in for an nalgebra product (`mv`, `mtv`, `nadot`) it follows nalgebra's
//! order, and the structured variants (`j_mul`, `jt_mul`, `mv_rows_t`) skip only terms that
//! add exact zeros; the tests below check both bit for bit.

use crate::ip::kkt::KktError;
use nalgebra::{SMatrix, SVector};

/// An R x C column-major block of the arena, viewed in place as a matrix (no copy).
#[inline(always)]
pub(super) fn block_ref<const R: usize, const C: usize>(s: &[f64]) -> &SMatrix<f64, R, C> {
    assert_eq!(s.len(), R * C);
    // SAFETY: `SMatrix<f64, R, C>` is `#[repr(C)]` over `ArrayStorage`, itself
    // `#[repr(transparent)]` over `[[f64; R]; C]` (plus zero-sized markers): R * C
    // contiguous f64 in column order with f64 alignment, which `s` provides.
    unsafe { &*(s.as_ptr() as *const SMatrix<f64, R, C>) }
}

/// a x for a small column-major matrix (C >= 1): column axpys in column order, inlined
/// into the caller's (baseline or AVX2) copy, where nalgebra's generic gemv is an
/// out-of-line call compiled for the baseline instruction set.
#[inline(always)]
pub(super) fn mv<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    x: &SVector<f64, C>,
) -> SVector<f64, R> {
    // The first column initializes (as nalgebra's gemv does: same bits, signed zeros too).
    let cols = &a.data.0;
    let mut out: [f64; R] = std::array::from_fn(|r| cols[0][r] * x[0]);
    for (col, &xc) in cols.iter().zip(x.as_slice()).skip(1) {
        for (o, &v) in out.iter_mut().zip(col) {
            *o += v * xc;
        }
    }
    SVector::from(out)
}

/// A x given A^T (`at`, C x R), for an A whose rows outside `live` are zero: those entries
/// of the result are +0 (the full product gives +-0 there), the others have [`mv`]'s bits
/// (each a serial sum in column order, read from a contiguous column of A^T).
#[inline(always)]
pub(super) fn mv_rows_t<const R: usize, const C: usize>(
    at: &SMatrix<f64, C, R>,
    x: &SVector<f64, C>,
    live: &[bool; R],
) -> SVector<f64, R> {
    let cols = &at.data.0;
    let mut out = [0.0; R];
    for (r, o) in out.iter_mut().enumerate().filter(|(r, _)| live[*r]) {
        let row = &cols[r];
        let mut acc = row[0] * x[0];
        for (&a, &xc) in row.iter().zip(x.as_slice()).skip(1) {
            acc += a * xc;
        }
        *o = acc;
    }
    SVector::from(out)
}

/// A^T x given A^T (`at`, C x R) with [`mtv`]'s bits: each entry is [`nadot`] of a column
/// of A, gathered from a row of A^T.
#[inline(always)]
pub(super) fn mtv_t<const R: usize, const C: usize>(
    at: &SMatrix<f64, C, R>,
    x: &SVector<f64, R>,
) -> SVector<f64, C> {
    let cols = &at.data.0;
    let mut out = [0.0; C];
    for (c, o) in out.iter_mut().enumerate() {
        let col: [f64; R] = std::array::from_fn(|i| cols[i][c]);
        *o = nadot(&col, &x.data.0[0]);
    }
    SVector::from(out)
}

/// J_k = [-I, G] (the implicit-Euler dynamics Jacobian with respect to z_k).
#[inline(always)]
pub(super) fn minus_identity_head<const NX: usize, const NZ: usize>(
    j: &SMatrix<f64, NX, NZ>,
) -> bool {
    let cols = &j.data.0;
    let mut ok = true;
    for (c, col) in cols.iter().take(NX).enumerate() {
        for (r, &v) in col.iter().enumerate() {
            ok &= v == if r == c { -1.0 } else { 0.0 };
        }
    }
    ok
}

/// J_k z for the stage's dynamics Jacobian; with J = [-I, G] it is -x + G u, which has the
/// bits of the full product [`mv`] (its zero terms only add +-0) up to the sign of a zero.
#[inline(always)]
pub(super) fn j_mul<const NX: usize, const NZ: usize>(
    j: &SMatrix<f64, NX, NZ>,
    minus_identity: bool,
    z: &SVector<f64, NZ>,
) -> SVector<f64, NX> {
    if !minus_identity {
        return mv(j, z);
    }
    let cols = &j.data.0;
    let mut out: [f64; NX] = std::array::from_fn(|r| -z[r]);
    for (col, &u) in cols[NX..].iter().zip(&z.as_slice()[NX..]) {
        for (o, &g) in out.iter_mut().zip(col) {
            *o += g * u;
        }
    }
    SVector::from(out)
}

/// J_k^T lambda; with J = [-I, G] it is (-lambda, G^T lambda), the bits of [`mtv`] up to
/// the sign of a zero.
#[inline(always)]
pub(super) fn jt_mul<const NX: usize, const NZ: usize>(
    j: &SMatrix<f64, NX, NZ>,
    minus_identity: bool,
    lambda: &SVector<f64, NX>,
) -> SVector<f64, NZ> {
    if !minus_identity {
        return mtv(j, lambda);
    }
    let cols = &j.data.0;
    let mut out = [0.0; NZ];
    for (o, &l) in out.iter_mut().zip(lambda.as_slice()) {
        *o = -l;
    }
    for (o, col) in out[NX..].iter_mut().zip(&cols[NX..]) {
        *o = nadot(col, &lambda.data.0[0]);
    }
    SVector::from(out)
}

/// a^T x for a small column-major matrix: one dot product per column ([`nadot`]).
#[inline(always)]
pub(super) fn mtv<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    x: &SVector<f64, R>,
) -> SVector<f64, C> {
    let mut out = [0.0; C];
    for (o, col) in out.iter_mut().zip(&a.data.0) {
        *o = nadot(col, &x.data.0[0]);
    }
    SVector::from(out)
}

/// The dot product in nalgebra's summation order (0.35, `dotx`: closed forms for 2, 3 and 4
/// entries; otherwise eight lanes per block of eight, combined pairwise, then a serial tail),
/// so these kernels have the bits of the corresponding nalgebra products: the iterates,
/// and hence the iteration counts, are sensitive to the last bit.
#[inline(always)]
pub(super) fn nadot<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    match D {
        2 => return a[0] * b[0] + a[1] * b[1],
        3 => return a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
        4 => {
            let (x, y) = (a[0] * b[0] + a[2] * b[2], a[1] * b[1] + a[3] * b[3]);
            return x + y;
        }
        _ => {}
    }
    let mut res = 0.0;
    let mut i = 0;
    let mut acc = [0.0; 8];
    while D - i >= 8 {
        for (l, v) in acc.iter_mut().enumerate() {
            *v += a[i + l] * b[i + l];
        }
        i += 8;
    }
    res += acc[0] + acc[4];
    res += acc[1] + acc[5];
    res += acc[2] + acc[6];
    res += acc[3] + acc[7];
    for k in i..D {
        res += a[k] * b[k];
    }
    res
}

/// out += sign a b for column arrays (out R x C, a R x K, b K x C): each term is an axpy of a
/// contiguous column of a, accumulated in registers. `sign` is +-1, so exact.
#[inline(always)]
pub(super) fn mm_acc<const R: usize, const K: usize, const C: usize>(
    out: &mut [[f64; R]; C],
    a: &[[f64; R]; K],
    b: &[[f64; K]; C],
    sign: f64,
) {
    for (oc, bc) in out.iter_mut().zip(b) {
        let mut acc = *oc;
        for (ak, &bkc) in a.iter().zip(bc) {
            let s = sign * bkc;
            for (o, &x) in acc.iter_mut().zip(ak) {
                *o += x * s;
            }
        }
        *oc = acc;
    }
}

/// out += a b given b^T (`bt`): [`mm_acc`] with sign 1 and its bits, b's entries read
/// (broadcast) from b^T's columns.
#[inline(always)]
pub(super) fn mm_acc_bt<const R: usize, const K: usize, const C: usize>(
    out: &mut [[f64; R]; C],
    a: &[[f64; R]; K],
    bt: &[[f64; C]; K],
) {
    for (c, oc) in out.iter_mut().enumerate() {
        let mut acc = *oc;
        for (ak, btk) in a.iter().zip(bt) {
            let s = 1.0 * btk[c];
            for (o, &x) in acc.iter_mut().zip(ak) {
                *o += x * s;
            }
        }
        *oc = acc;
    }
}

/// Whether two slices of equal length hold the same bits (NaN never matches a number).
#[inline(always)]
pub(super) fn same_bits(a: &[f64], b: &[f64]) -> bool {
    let mut diff = 0u64;
    for (x, y) in a.iter().zip(b) {
        diff |= x.to_bits() ^ y.to_bits();
    }
    diff == 0 && a.len() == b.len()
}

/// Largest magnitude; NaN when an entry is NaN or infinite (so such a block is rejected
/// by the callers' finiteness test). Four independent lanes, so the max chain does not
/// serialize on the latency of one register.
#[inline(always)]
pub(super) fn amax(a: &[f64]) -> f64 {
    const L: usize = 4;
    let mut m = [0.0f64; L];
    // x * 0 is NaN exactly for NaN and +-inf.
    let mut bad = [0.0f64; L];
    let mut chunks = a.chunks_exact(L);
    for ch in &mut chunks {
        for l in 0..L {
            let x = ch[l].abs();
            m[l] = if x > m[l] { x } else { m[l] };
            bad[l] += ch[l] * 0.0;
        }
    }
    for &v in chunks.remainder() {
        let x = v.abs();
        m[0] = if x > m[0] { x } else { m[0] };
        bad[0] += v * 0.0;
    }
    let mx = m
        .iter()
        .fold(0.0f64, |acc, &x| if x > acc { x } else { acc });
    if bad.iter().sum::<f64>() == 0.0 {
        mx
    } else {
        f64::NAN
    }
}

/// Every entry is exactly zero.
#[inline(always)]
pub(super) fn all_zero(a: &[f64]) -> bool {
    let mut z = true;
    for &v in a {
        z &= v == 0.0;
    }
    z
}

/// Copies the lower triangle of a column array into its upper one.
#[inline(always)]
pub(super) fn sym_lower<const D: usize>(a: &mut [[f64; D]; D]) {
    for c in 0..D {
        for r in c + 1..D {
            a[r][c] = a[c][r];
        }
    }
}

/// a^T b as one serial sum in index order.
#[inline(always)]
pub(super) fn dot<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut acc = 0.0;
    for (&x, &y) in a.iter().zip(b) {
        acc += x * y;
    }
    acc
}

/// a b for small column-major matrices, as axpys over contiguous columns (zeros of b
/// skipped).
#[inline(always)]
pub(super) fn mul_nn<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, K, C>,
) -> SMatrix<f64, R, C> {
    let mut out = SMatrix::<f64, R, C>::zeros();
    for c in 0..C {
        for k in 0..K {
            let bkc = b[(k, c)];
            if bkc != 0.0 {
                for r in 0..R {
                    out[(r, c)] += a[(r, k)] * bkc;
                }
            }
        }
    }
    out
}

/// a^T b for small column-major matrices, as dots of contiguous columns.
#[inline(always)]
pub(super) fn mul_tn<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, K, R>,
    b: &SMatrix<f64, K, C>,
) -> SMatrix<f64, R, C> {
    let mut out = SMatrix::<f64, R, C>::zeros();
    for c in 0..C {
        for r in 0..R {
            let mut acc = 0.0;
            for k in 0..K {
                acc += a[(k, r)] * b[(k, c)];
            }
            out[(r, c)] = acc;
        }
    }
    out
}

/// Copies the lower triangle's average into both triangles.
#[inline(always)]
pub(super) fn symmetrize<const D: usize>(a: &mut SMatrix<f64, D, D>) {
    for c in 0..D {
        for r in c + 1..D {
            let v = 0.5 * (a[(r, c)] + a[(c, r)]);
            a[(r, c)] = v;
            a[(c, r)] = v;
        }
    }
}

/// LDL^T of a symmetric matrix without pivoting: returns (unit lower L, D, number of
/// negative pivots). A zero or non-finite pivot is a singular matrix.
#[inline(always)]
pub(super) fn ldlt_factor<const D: usize>(
    a: &SMatrix<f64, D, D>,
) -> Result<(SMatrix<f64, D, D>, SVector<f64, D>, usize), KktError> {
    let mut l = SMatrix::<f64, D, D>::identity();
    let mut d = SVector::<f64, D>::zeros();
    let mut neg = 0;
    for j in 0..D {
        let mut dj = a[(j, j)];
        for k in 0..j {
            dj -= l[(j, k)] * l[(j, k)] * d[k];
        }
        if !dj.is_finite() || dj == 0.0 {
            return Err(KktError::Singular);
        }
        if dj < 0.0 {
            neg += 1;
        }
        d[j] = dj;
        for i in j + 1..D {
            let mut v = a[(i, j)];
            for k in 0..j {
                v -= l[(i, k)] * l[(j, k)] * d[k];
            }
            l[(i, j)] = v / dj;
        }
    }
    Ok((l, d, neg))
}

/// Solves (L D L^T) x = b in place for a vector.
#[inline(always)]
pub(super) fn ldlt_solve_vec<const D: usize>(
    l: &SMatrix<f64, D, D>,
    d: &SVector<f64, D>,
    b: &mut SVector<f64, D>,
) {
    for i in 0..D {
        for k in 0..i {
            b[i] -= l[(i, k)] * b[k];
        }
    }
    for i in 0..D {
        b[i] /= d[i];
    }
    for i in (0..D).rev() {
        for k in i + 1..D {
            b[i] -= l[(k, i)] * b[k];
        }
    }
}

/// Solves (L D L^T) X = B in place, column by column.
#[inline(always)]
pub(super) fn ldlt_solve_cols<const D: usize, const C: usize>(
    l: &SMatrix<f64, D, D>,
    d: &SVector<f64, D>,
    b: &mut SMatrix<f64, D, C>,
) {
    for c in 0..C {
        let mut col: SVector<f64, D> = b.column(c).into_owned();
        ldlt_solve_vec(l, d, &mut col);
        b.set_column(c, &col);
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// Pseudo-random matrix with entries of mixed sign and magnitude (and some zeros).
    pub(in crate::ip::kkt::riccati) fn scrambled<const R: usize, const C: usize>(
        seed: u64,
    ) -> SMatrix<f64, R, C> {
        let mut state = seed;
        SMatrix::from_fn(|_, _| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            if u < 0.1 {
                0.0
            } else {
                (u - 0.55) * 10f64.powi((state % 7) as i32 - 3)
            }
        })
    }

    fn same<const R: usize, const C: usize>(
        a: &SMatrix<f64, R, C>,
        b: &SMatrix<f64, R, C>,
    ) -> bool {
        a.iter()
            .zip(b.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// The inlined products keep nalgebra's bits for every block shape the solves use.
    #[test]
    fn inlined_products_have_nalgebras_bits() {
        fn check<const R: usize, const C: usize>(seed: u64) {
            let a: SMatrix<f64, R, C> = scrambled(seed);
            let x: SVector<f64, C> = scrambled(seed + 1);
            let xt: SVector<f64, R> = scrambled(seed + 2);
            assert!(same(&mv(&a, &x), &(a * x)), "a x, {R} x {C}");
            assert!(same(&mtv(&a, &xt), &a.tr_mul(&xt)), "a^T x, {R} x {C}");
        }
        for seed in [1, 7, 42] {
            check::<9, 9>(seed);
            check::<12, 9>(seed);
            check::<9, 12>(seed);
            check::<3, 9>(seed);
            check::<12, 3>(seed);
            check::<2, 5>(seed);
            check::<4, 4>(seed);
            check::<17, 1>(seed);
        }
    }

    /// The structured products of the solves (J = [-I, G], rows of Y known to be zero)
    /// give the full products' bits, up to the sign of a zero.
    #[test]
    fn structured_products_have_the_full_products_bits() {
        fn same_value<const R: usize, const C: usize>(
            a: &SMatrix<f64, R, C>,
            b: &SMatrix<f64, R, C>,
        ) -> bool {
            a.iter()
                .zip(b.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits() || (*x == 0.0 && *y == 0.0))
        }
        for seed in [3, 11, 99] {
            let mut j: SMatrix<f64, 9, 12> = scrambled(seed);
            for c in 0..9 {
                for r in 0..9 {
                    j[(r, c)] = if r == c { -1.0 } else { 0.0 };
                }
            }
            let mut minus_identity = minus_identity_head(&j);
            assert!(minus_identity);
            let z: SVector<f64, 12> = scrambled(seed + 1);
            let lambda: SVector<f64, 9> = scrambled(seed + 2);
            assert!(same_value(&j_mul(&j, minus_identity, &z), &(j * z)));
            assert!(same_value(
                &jt_mul(&j, minus_identity, &lambda),
                &j.tr_mul(&lambda)
            ));
            // Anything else goes through the general products.
            j[(4, 4)] = -0.5;
            minus_identity = minus_identity_head(&j);
            assert!(!minus_identity);
            assert!(same(&j_mul(&j, minus_identity, &z), &(j * z)));
            assert!(same(
                &jt_mul(&j, minus_identity, &lambda),
                &j.tr_mul(&lambda)
            ));

            let live = [
                false, true, false, false, false, false, false, true, false, true, true, true,
            ];
            let mut y: SMatrix<f64, 12, 9> = scrambled(seed + 3);
            for (r, &l) in live.iter().enumerate() {
                if !l {
                    y.row_mut(r).fill(0.0);
                }
            }
            let x: SVector<f64, 9> = scrambled(seed + 4);
            let w: SVector<f64, 12> = scrambled(seed + 5);
            let yt = y.transpose();
            assert!(same_value(&mv_rows_t(&yt, &x, &live), &(y * x)));
            assert!(same(&mtv_t(&yt, &w), &y.tr_mul(&w)));
        }
    }
}
