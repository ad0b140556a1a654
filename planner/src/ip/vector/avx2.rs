//! AVX2 copies of the reduction kernels of [`super`], written with intrinsics: the
//! compiler keeps their per-entry selects scalar (or packs them into half-width vectors
//! with shuffles) however the lanes are staged. Lane l of every vector holds the entries
//! j = l (mod 4) in index order, the lanes of the baseline copies, and every lane takes the
//! baseline's operations in its order (`min(a, b)` is `_mm256_min_pd(b, a)`, `max(a, b)`
//! is `_mm256_max_pd(b, a)`), so both copies give the same bits (a NaN's sign and payload
//! aside, which Rust does not specify and which only ever meet a finiteness check).

use super::{Entries, L};

/// The lane groups of [`super::max_steps`] in the AVX2 copy when `simd`; `None` otherwise.
#[inline(always)]
pub(super) fn dispatch_max_steps(
    simd: bool,
    es: &Entries<'_>,
    tau: f64,
) -> Option<([f64; L], [f64; L])> {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: `simd` is only true when the CPU reports AVX2.
        return Some(unsafe { x86::max_steps(es, tau) });
    }
    let _ = (simd, es, tau);
    None
}

/// The lane groups of [`super::bound_errors`] (accumulators inf_du, compl, compl_mu,
/// z_sum, compl_sum; `r` completed in place) in the AVX2 copy when `simd`; `None`
/// otherwise (then `r` is untouched).
#[inline(always)]
pub(super) fn dispatch_bound_errors(
    simd: bool,
    es: &Entries<'_>,
    r: &mut [f64],
    mu: f64,
) -> Option<[[f64; L]; 5]> {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: `simd` is only true when the CPU reports AVX2.
        return Some(unsafe { x86::bound_errors(es, r, mu) });
    }
    let _ = (simd, es, r, mu);
    None
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Entries, L};
    use std::arch::x86_64::*;

    /// The four lanes of `v`.
    #[inline(always)]
    fn lanes(v: __m256d) -> [f64; L] {
        let mut out = [0.0; L];
        // SAFETY: `out` holds 4 f64; unaligned store.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
        out
    }

    /// |v| (sign bit cleared, as `f64::abs`).
    #[inline(always)]
    fn abs(v: __m256d) -> __m256d {
        // SAFETY: AVX is enabled in every caller (all are AVX2 target-feature functions
        // that inline this).
        unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), v) }
    }

    /// # Safety
    /// The CPU has AVX2.
    #[target_feature(enable = "avx,avx2")]
    pub(super) unsafe fn max_steps(es: &Entries<'_>, tau: f64) -> ([f64; L], [f64; L]) {
        let (one, zero) = (_mm256_set1_pd(1.0), _mm256_setzero_pd());
        let (ptau, ntau) = (_mm256_set1_pd(tau), _mm256_set1_pd(-tau));
        let (mut ap, mut ad) = (one, one);
        for c in 0..es.groups() {
            let j = c * L;
            // SAFETY: j + L <= groups() * L <= the common length of the slices.
            let ld = |s: &[f64]| unsafe { _mm256_loadu_pd(s.as_ptr().add(j)) };
            let (w, lo, hi, d) = (ld(es.w), ld(es.lo), ld(es.hi), ld(es.dw));
            let (zl, zu, dzl, dzu) = (ld(es.zl), ld(es.zu), ld(es.dzl), ld(es.dzu));
            let hl = _mm256_cmp_pd::<_CMP_GT_OQ>(ld(es.hl), zero);
            let hh = _mm256_cmp_pd::<_CMP_GT_OQ>(ld(es.hh), zero);
            let cl = _mm256_div_pd(_mm256_mul_pd(ntau, _mm256_sub_pd(w, lo)), d);
            let cu = _mm256_div_pd(_mm256_mul_pd(ptau, _mm256_sub_pd(hi, w)), d);
            let dl = _mm256_div_pd(_mm256_mul_pd(ntau, zl), dzl);
            let du = _mm256_div_pd(_mm256_mul_pd(ntau, zu), dzu);
            let pick = |m: __m256d, v: __m256d| _mm256_blendv_pd(one, v, m);
            let cl = pick(_mm256_and_pd(hl, _mm256_cmp_pd::<_CMP_LT_OQ>(d, zero)), cl);
            let cu = pick(_mm256_and_pd(hh, _mm256_cmp_pd::<_CMP_GT_OQ>(d, zero)), cu);
            let dl = pick(
                _mm256_and_pd(hl, _mm256_cmp_pd::<_CMP_LT_OQ>(dzl, zero)),
                dl,
            );
            let du = pick(
                _mm256_and_pd(hh, _mm256_cmp_pd::<_CMP_LT_OQ>(dzu, zero)),
                du,
            );
            ap = _mm256_min_pd(_mm256_min_pd(cu, cl), ap);
            ad = _mm256_min_pd(_mm256_min_pd(du, dl), ad);
        }
        (lanes(ap), lanes(ad))
    }

    /// # Safety
    /// The CPU has AVX2; `r` is as long as the slices of `es`.
    #[target_feature(enable = "avx,avx2")]
    pub(super) unsafe fn bound_errors(es: &Entries<'_>, r: &mut [f64], mu: f64) -> [[f64; L]; 5] {
        assert_eq!(r.len(), es.w.len(), "dual residual length");
        let zero = _mm256_setzero_pd();
        let vmu = _mm256_set1_pd(mu);
        let (mut inf_du, mut compl, mut compl_mu) = (zero, zero, zero);
        let (mut z_sum, mut compl_sum) = (zero, zero);
        for c in 0..es.groups() {
            let j = c * L;
            // SAFETY: j + L <= groups() * L <= the common length of the slices and `r`.
            let ld = |s: &[f64]| unsafe { _mm256_loadu_pd(s.as_ptr().add(j)) };
            let (w, lo, hi, zl, zu) = (ld(es.w), ld(es.lo), ld(es.hi), ld(es.zl), ld(es.zu));
            let hl = _mm256_cmp_pd::<_CMP_GT_OQ>(ld(es.hl), zero);
            let hh = _mm256_cmp_pd::<_CMP_GT_OQ>(ld(es.hh), zero);
            let rj = _mm256_add_pd(_mm256_sub_pd(ld(r), zl), zu);
            // SAFETY: as the loads.
            unsafe { _mm256_storeu_pd(r.as_mut_ptr().add(j), rj) };
            let pl = _mm256_mul_pd(_mm256_sub_pd(w, lo), zl);
            let pu = _mm256_mul_pd(_mm256_sub_pd(hi, w), zu);
            // Absent bound: product and deviation 0 (blend with the +0 vector).
            let ql = _mm256_blendv_pd(zero, abs(_mm256_sub_pd(pl, vmu)), hl);
            let qu = _mm256_blendv_pd(zero, abs(_mm256_sub_pd(pu, vmu)), hh);
            let pl = _mm256_blendv_pd(zero, pl, hl);
            let pu = _mm256_blendv_pd(zero, pu, hh);
            inf_du = _mm256_max_pd(abs(rj), inf_du);
            compl = _mm256_max_pd(abs(pu), _mm256_max_pd(abs(pl), compl));
            compl_mu = _mm256_max_pd(qu, _mm256_max_pd(ql, compl_mu));
            z_sum = _mm256_add_pd(z_sum, _mm256_add_pd(abs(zl), abs(zu)));
            compl_sum = _mm256_add_pd(compl_sum, _mm256_add_pd(pl, pu));
        }
        [
            lanes(inf_du),
            lanes(compl),
            lanes(compl_mu),
            lanes(z_sum),
            lanes(compl_sum),
        ]
    }
}
