//! E_k^-1, the inverse of a stage's dynamics Jacobian with respect to x_{k+1}, which the
//! pair step of the sweep needs (P^ = E^-T P E^-1).
//!
//! For implicit Euler E = I - ds df/dx. States on which no state depends (the vehicle's s
//! and t) give E unit trailing columns, E = [[A, 0], [B, I]], whose inverse is
//! [[A^-1, 0], [-B A^-1, I]]: only A is eliminated. Elimination is Gauss-Jordan with
//! partial pivoting on rows padded to whole 4-wide vectors; a pivot at most 1e-13 of the
//! largest entry makes E numerically singular (the backend then answers `Unsupported`).

use super::kernels::amax;
use nalgebra::SMatrix;

/// Inverse of a small matrix ([`gauss_jordan`]); `None` when a pivot is below 1e-13 of the
/// largest entry (numerically singular) or the matrix is not finite.
#[inline(always)]
pub(super) fn invert<const D: usize>(a: &SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
    let scale = amax(a.as_slice());
    if !scale.is_finite() {
        return None;
    }
    let mut rows: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| a[(r, c)]));
    let mut inv: [[f64; D]; D] =
        std::array::from_fn(|r| std::array::from_fn(|c| f64::from(u8::from(r == c))));
    gauss_jordan(&mut rows, &mut inv, 1e-13 * scale)?;
    Some(SMatrix::from_fn(|r, c| inv[r][c]))
}

/// Inverse of E = [[A, 0], [B, I]] whose trailing columns are unit vectors, as
/// [[A^-1, 0], [-B A^-1, I]]: the implicit-Euler dynamics Jacobian E = I - ds df/dx has
/// them for s and t (no state depends on either), so only the leading k x k block is
/// inverted: embedded as diag(A, I) in a fixed 8 x 8 [`gauss_jordan`] (the identity rows
/// never pivot into A's, so A^-1 comes out with the same bits as from a k x k elimination).
/// Without unit columns, or with a leading block larger than 8, it is [`invert`]. Returns
/// the transpose F^T (see [`super::stage::StageInverse::ft`]), written straight from the
/// elimination's rows.
#[inline(always)]
pub(super) fn invert_unit_tail_t<const D: usize>(
    e: &SMatrix<f64, D, D>,
) -> Option<SMatrix<f64, D, D>> {
    const W: usize = 8;
    let mut k = D;
    while k > 1 && (0..D).all(|r| e[(r, k - 1)] == if r == k - 1 { 1.0 } else { 0.0 }) {
        k -= 1;
    }
    if k == D || k > W {
        return invert(e).map(|f| f.transpose());
    }
    let scale = amax(e.as_slice());
    if !scale.is_finite() {
        return None;
    }
    // The implicit-Euler case (k = 7: s and t are unit) eliminates its 7 rows alone; the
    // identity row of the 8 x 8 embedding only ever subtracts +0 from them (same bits).
    let tiny = 1e-13 * scale;
    Some(if k == 7 {
        unit_tail_inverse_t(e, &leading_inverse::<D, 7, W>(e, k, tiny)?)
    } else {
        unit_tail_inverse_t(e, &leading_inverse::<D, W, W>(e, k, tiny)?[..k])
    })
}

/// The transpose of [[A^-1, 0], [-B A^-1, I]] from the k rows of A^-1 (`ai`, padded rows)
/// and E's B: column r is row r of the inverse, each row of -B A^-1 a serial sum over j
/// (whole padded rows at a time; the padding columns are dropped).
#[inline(always)]
fn unit_tail_inverse_t<const D: usize, const W: usize>(
    e: &SMatrix<f64, D, D>,
    ai: &[[f64; W]],
) -> SMatrix<f64, D, D> {
    let k = ai.len();
    let mut out = SMatrix::<f64, D, D>::zeros();
    let cols = &mut out.data.0;
    for (col, row) in cols.iter_mut().zip(ai) {
        col[..k].copy_from_slice(&row[..k]);
    }
    for (r, col) in cols.iter_mut().enumerate().skip(k) {
        let mut acc = [0.0; W];
        for (j, row) in ai.iter().enumerate() {
            let s = e[(r, j)];
            for (a, &x) in acc.iter_mut().zip(row) {
                *a += s * x;
            }
        }
        for (o, &a) in col[..k].iter_mut().zip(&acc) {
            *o = -a;
        }
        col[r] = 1.0;
    }
    out
}

/// The first K (>= k) rows of diag(A, I)^-1 for E's leading k x k block A, each padded to
/// W entries (whole 4-wide vectors per row operation); `None` as [`gauss_jordan`].
#[inline(always)]
fn leading_inverse<const D: usize, const K: usize, const W: usize>(
    e: &SMatrix<f64, D, D>,
    k: usize,
    tiny: f64,
) -> Option<[[f64; W]; K]> {
    let mut a = [[0.0; W]; K];
    let mut ai = [[0.0; W]; K];
    for (r, (row, irow)) in a.iter_mut().zip(ai.iter_mut()).enumerate() {
        if r < k {
            for (c, v) in row.iter_mut().take(k).enumerate() {
                *v = e[(r, c)];
            }
        } else {
            row[r] = 1.0;
        }
        irow[r] = 1.0;
    }
    gauss_jordan(&mut a, &mut ai, tiny)?;
    Some(ai)
}

/// Gauss-Jordan elimination with partial pivoting on the K augmented rows [A | B]: the
/// leading K columns of `a` are the matrix (rows may be padded to WA entries, and B to WB,
/// so that row operations are whole 4-wide vectors); on success `b` holds A^-1 B. `None`
/// when a pivot is NaN or at most `tiny` in magnitude.
#[inline(always)]
fn gauss_jordan<const K: usize, const WA: usize, const WB: usize>(
    a: &mut [[f64; WA]; K],
    b: &mut [[f64; WB]; K],
    tiny: f64,
) -> Option<()> {
    for c in 0..K {
        let mut p = c;
        let mut best = a[c][c].abs();
        for (r, row) in a.iter().enumerate().skip(c + 1) {
            if row[c].abs() > best {
                best = row[c].abs();
                p = r;
            }
        }
        if best.is_nan() || best <= tiny {
            return None;
        }
        a.swap(p, c);
        b.swap(p, c);
        let piv = 1.0 / a[c][c];
        let (ac, bc) = (a[c].map(|v| v * piv), b[c].map(|v| v * piv));
        a[c] = ac;
        b[c] = bc;
        for (r, (ra, rb)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
            if r != c {
                let f = ra[c];
                for (v, &x) in ra.iter_mut().zip(&ac) {
                    *v -= f * x;
                }
                for (v, &x) in rb.iter_mut().zip(&bc) {
                    *v -= f * x;
                }
            }
        }
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::super::kernels::same_bits;
    use super::super::kernels::tests::scrambled;
    use super::*;

    /// A deterministic E = [[A, 0], [B, I]] (9 x 9, unit s and t columns) whose A needs
    /// row pivoting (zero leading diagonal entry) and is far from diagonal dominance.
    fn unit_tail_e() -> SMatrix<f64, 9, 9> {
        let mut e = SMatrix::<f64, 9, 9>::zeros();
        for c in 0..7 {
            for r in 0..9 {
                let v = ((r * 7 + c * 3) % 11) as f64 - 5.0;
                e[(r, c)] = v * 0.3 + if r == c { 2.0 } else { 0.0 };
            }
        }
        e[(0, 0)] = 0.0;
        e[(7, 7)] = 1.0;
        e[(8, 8)] = 1.0;
        e
    }

    /// Eliminating only A's 7 rows gives the bits of the 8 x 8 diag(A, I) elimination.
    #[test]
    fn seven_row_elimination_has_the_embeddings_bits() {
        let mut cases = vec![unit_tail_e()];
        for seed in [5, 17, 23] {
            let mut e: SMatrix<f64, 9, 9> = scrambled(seed);
            for c in 7..9 {
                for r in 0..9 {
                    e[(r, c)] = if r == c { 1.0 } else { 0.0 };
                }
            }
            cases.push(e);
        }
        for e in cases {
            let seven = leading_inverse::<9, 7, 8>(&e, 7, 0.0).expect("nonsingular");
            let eight = leading_inverse::<9, 8, 8>(&e, 7, 0.0).expect("nonsingular");
            for (a, b) in seven.iter().zip(&eight[..7]) {
                assert!(same_bits(a, b), "{a:?} vs {b:?}");
            }
        }
    }

    /// F from [`invert_unit_tail_t`].
    fn invert_unit_tail<const D: usize>(e: &SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
        invert_unit_tail_t(e).map(|ft| ft.transpose())
    }

    #[test]
    fn unit_tail_inverse_matches_general_inverse() {
        let e = unit_tail_e();
        let f = invert_unit_tail(&e).expect("nonsingular");
        let g = invert(&e).expect("nonsingular");
        let id = e * f;
        for r in 0..9 {
            for c in 0..9 {
                let want = if r == c { 1.0 } else { 0.0 };
                assert!(
                    (id[(r, c)] - want).abs() < 1e-12,
                    "E F at ({r}, {c}): {}",
                    id[(r, c)]
                );
                assert!((f[(r, c)] - g[(r, c)]).abs() < 1e-12 * g.amax());
            }
        }
    }

    #[test]
    fn unit_tail_inverse_rejects_singular_and_non_finite() {
        let mut e = unit_tail_e();
        // Row 1 of A := row 2 of A (columns 0..7): singular leading block.
        for c in 0..7 {
            e[(1, c)] = e[(2, c)];
        }
        assert!(invert_unit_tail(&e).is_none());
        let mut e = unit_tail_e();
        e[(3, 4)] = f64::NAN;
        assert!(invert_unit_tail(&e).is_none());
    }

    #[test]
    fn without_unit_tail_the_general_inverse_is_used() {
        let mut e = unit_tail_e();
        e[(2, 8)] = 0.5;
        let f = invert_unit_tail(&e).expect("nonsingular");
        let id = e * f;
        for r in 0..9 {
            for c in 0..9 {
                let want = if r == c { 1.0 } else { 0.0 };
                assert!((id[(r, c)] - want).abs() < 1e-12);
            }
        }
    }
}
