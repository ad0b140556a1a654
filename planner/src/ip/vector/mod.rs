//! Vector kernels of the interior-point iteration over w = (x, s): barrier diagonal, the
//! bound terms of the right-hand side, bound-multiplier steps, step limits, trial points and
//! the multiplier update. Written branch-free (an absent bound has multiplier and target 0
//! and a bound at +-inf, so its terms vanish or are masked) so that they vectorize, and
//! compiled twice like the Riccati and derivative kernels ([`crate::cpu`]): the AVX2 copy
//! and the baseline copy give the same bits, because every loop keeps its order of
//! operations per entry and reductions are exact (min, max), sequential or summed in L = 4
//! fixed lanes.

use super::workspace::Workspace;

mod avx2;

/// Generates a kernel from a body: an `#[inline(always)]` body, an AVX2 copy of it and a
/// dispatcher on `Workspace::simd` (set at setup from [`crate::cpu::avx2_available`]).
macro_rules! kernel {
    ($(#[$m:meta])* pub fn $name:ident($ws:ident : $wt:ty $(, $a:ident : $t:ty)*) $(-> $r:ty)? $body:block) => {
        $(#[$m])*
        pub fn $name($ws: $wt $(, $a: $t)*) $(-> $r)? {
            #[inline(always)]
            fn body($ws: $wt $(, $a: $t)*) $(-> $r)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx,avx2")]
                unsafe fn avx2($ws: $wt $(, $a: $t)*) $(-> $r)? {
                    body($ws $(, $a)*)
                }
                if $ws.simd {
                    // SAFETY: `simd` is only true when the CPU reports AVX2.
                    return unsafe { avx2($ws $(, $a)*) };
                }
            }
            body($ws $(, $a)*)
        }
    };
}

kernel! {
    /// Barrier Hessian Sigma = z_l / (w - l) + z_u / (u - w) (an absent bound: 0 / inf).
    pub fn sigma(ws: &mut Workspace) {
        let nw = ws.n + ws.m;
        let (w, lo, hi) = (&ws.w[..nw], &ws.lo[..nw], &ws.hi[..nw]);
        let (zl, zu) = (&ws.zl[..nw], &ws.zu[..nw]);
        for (j, s) in ws.sigma[..nw].iter_mut().enumerate() {
            *s = zl[j] / (w[j] - lo[j]) + zu[j] / (hi[j] - w[j]);
        }
    }
}

kernel! {
    /// rhs_w <- -(rhs_w - tgt_l / (w - l) + tgt_u / (u - w)) (targets are 0 at absent bounds).
    pub fn rhs_bounds(ws: &mut Workspace) {
        let nw = ws.n + ws.m;
        let (w, lo, hi) = (&ws.w[..nw], &ws.lo[..nw], &ws.hi[..nw]);
        let (tl, tu) = (&ws.tgt_l[..nw], &ws.tgt_u[..nw]);
        for (j, r) in ws.rhs_w[..nw].iter_mut().enumerate() {
            *r = -((*r - tl[j] / (w[j] - lo[j])) + tu[j] / (hi[j] - w[j]));
        }
    }
}

kernel! {
    /// Bound-multiplier steps from dw: dz_l = (tgt_l - s_l z_l - z_l dw) / s_l and
    /// dz_u = (tgt_u - s_u z_u + z_u dw) / s_u; 0 at absent bounds.
    pub fn bound_duals(ws: &mut Workspace) {
        let nw = ws.n + ws.m;
        let (w, lo, hi, dw) = (&ws.w[..nw], &ws.lo[..nw], &ws.hi[..nw], &ws.dw[..nw]);
        let (zl, zu, tl, tu) = (&ws.zl[..nw], &ws.zu[..nw], &ws.tgt_l[..nw], &ws.tgt_u[..nw]);
        let (hl, hh) = (&ws.has_lo[..nw], &ws.has_hi[..nw]);
        let (dzl, dzu) = (&mut ws.dzl[..nw], &mut ws.dzu[..nw]);
        for j in 0..nw {
            let sl = w[j] - lo[j];
            let vl = (tl[j] - sl * zl[j] - zl[j] * dw[j]) / sl;
            dzl[j] = if hl[j] { vl } else { 0.0 };
            let su = hi[j] - w[j];
            let vu = (tu[j] - su * zu[j] + zu[j] * dw[j]) / su;
            dzu[j] = if hh[j] { vu } else { 0.0 };
        }
    }
}

/// The bound data of one entry (or, with `[T; L]` fields, of L consecutive entries).
#[derive(Clone, Copy)]
pub(super) struct Entry<F, B> {
    w: F,
    lo: F,
    hi: F,
    dw: F,
    zl: F,
    zu: F,
    dzl: F,
    dzu: F,
    hl: B,
    hh: B,
}

/// The slices [`Entry`] reads, cut to the n + m entries of w.
pub(super) struct Entries<'a> {
    pub(super) w: &'a [f64],
    pub(super) lo: &'a [f64],
    pub(super) hi: &'a [f64],
    pub(super) dw: &'a [f64],
    pub(super) zl: &'a [f64],
    pub(super) zu: &'a [f64],
    pub(super) dzl: &'a [f64],
    pub(super) dzu: &'a [f64],
    pub(super) hl: &'a [f64],
    pub(super) hh: &'a [f64],
}

impl<'a> Entries<'a> {
    #[inline(always)]
    fn of(ws: &'a Workspace) -> Self {
        let nw = ws.n + ws.m;
        Self {
            w: &ws.w[..nw],
            lo: &ws.lo[..nw],
            hi: &ws.hi[..nw],
            dw: &ws.dw[..nw],
            zl: &ws.zl[..nw],
            zu: &ws.zu[..nw],
            dzl: &ws.dzl[..nw],
            dzu: &ws.dzu[..nw],
            hl: &ws.on_lo[..nw],
            hh: &ws.on_hi[..nw],
        }
    }

    /// [`Self::of`] and `tmp_w` (the dual residual [`bound_errors`] completes), borrowed
    /// apart.
    #[inline(always)]
    fn with_residual(ws: &'a mut Workspace) -> (Self, &'a mut [f64]) {
        let nw = ws.n + ws.m;
        let es = Self {
            w: &ws.w[..nw],
            lo: &ws.lo[..nw],
            hi: &ws.hi[..nw],
            dw: &ws.dw[..nw],
            zl: &ws.zl[..nw],
            zu: &ws.zu[..nw],
            dzl: &ws.dzl[..nw],
            dzu: &ws.dzu[..nw],
            hl: &ws.on_lo[..nw],
            hh: &ws.on_hi[..nw],
        };
        (es, &mut ws.tmp_w[..nw])
    }

    /// Number of whole lane groups.
    #[inline(always)]
    pub(super) fn groups(&self) -> usize {
        self.w.len() / L
    }

    /// Entry j.
    #[inline(always)]
    fn one(&self, j: usize) -> Entry<f64, f64> {
        Entry {
            w: self.w[j],
            lo: self.lo[j],
            hi: self.hi[j],
            dw: self.dw[j],
            zl: self.zl[j],
            zu: self.zu[j],
            dzl: self.dzl[j],
            dzu: self.dzu[j],
            hl: self.hl[j],
            hh: self.hh[j],
        }
    }
}

/// Sum of f(x) over `v` in 16 fixed lanes, the lanes then added in order, then the tail:
/// deterministic, and 8 independent chains of 2-wide adds (baseline SSE2) instead of one
/// chain whose add latency bounds the loop.
#[inline(always)]
fn lane_sum(v: &[f64], f: impl Fn(f64) -> f64) -> f64 {
    const W: usize = 16;
    let (groups, tail) = v.as_chunks::<W>();
    let mut acc = [0.0f64; W];
    for g in groups {
        for (a, &x) in acc.iter_mut().zip(g) {
            *a += f(x);
        }
    }
    let mut s = acc.iter().sum::<f64>();
    for &x in tail {
        s += f(x);
    }
    s
}

/// Whether every entry of `v` is finite. Not short-circuiting: 0 x is +-0 for a finite x
/// and NaN otherwise, summed by `lane_sum` without a compare and branch per entry.
pub fn all_finite(v: &[f64]) -> bool {
    lane_sum(v, |x| x * 0.0) == 0.0
}

/// ||v||_1 by `lane_sum` (the filter's violation measure).
pub fn norm1(v: &[f64]) -> f64 {
    lane_sum(v, f64::abs)
}

/// One entry's fraction-to-the-boundary limits (primal, dual); 1 where none applies.
#[inline(always)]
fn step_limits(e: Entry<f64, f64>, tau: f64) -> (f64, f64) {
    let d = e.dw;
    let cl = -tau * (e.w - e.lo) / d;
    let cu = tau * (e.hi - e.w) / d;
    let dl = -tau * e.zl / e.dzl;
    let du = -tau * e.zu / e.dzu;
    let cl = if (e.hl > 0.0) & (d < 0.0) { cl } else { 1.0 };
    let cu = if (e.hh > 0.0) & (d > 0.0) { cu } else { 1.0 };
    let dl = if (e.hl > 0.0) & (e.dzl < 0.0) {
        dl
    } else {
        1.0
    };
    let du = if (e.hh > 0.0) & (e.dzu < 0.0) {
        du
    } else {
        1.0
    };
    (min(cl, cu), min(dl, du))
}

/// Lanes of the reductions: entry j goes to lane j % L (the tail to lane 0), and the lanes
/// are combined in a fixed order, so both copies reduce identically.
pub(super) const L: usize = 4;

/// Lanes combined by `f` as f(f(a0, a1), f(a2, a3)).
#[inline(always)]
fn fold(a: [f64; L], f: impl Fn(f64, f64) -> f64) -> f64 {
    f(f(a[0], a[1]), f(a[2], a[3]))
}

/// min without NaN handling (a NaN candidate is ignored, as `f64::min` does).
#[inline(always)]
fn min(a: f64, b: f64) -> f64 {
    if b < a {
        b
    } else {
        a
    }
}

/// max without NaN handling (a NaN candidate is ignored, as `f64::max` does).
#[inline(always)]
fn max(a: f64, b: f64) -> f64 {
    if b > a {
        b
    } else {
        a
    }
}

/// Largest primal and dual steps in (0, 1] keeping a fraction tau of the distance to the
/// bounds (fraction-to-the-boundary rule).
pub fn max_steps(ws: &Workspace, tau: f64) -> (f64, f64) {
    let es = Entries::of(ws);
    let (mut ap, mut ad) =
        (avx2::dispatch_max_steps(ws.simd, &es, tau)).unwrap_or_else(|| max_steps_lanes(&es, tau));
    for j in es.groups() * L..es.w.len() {
        let (p, d) = step_limits(es.one(j), tau);
        ap[0] = min(ap[0], p);
        ad[0] = min(ad[0], d);
    }
    (fold(ap, min), fold(ad, min))
}

/// The whole lane groups of [`max_steps`] (entry j in lane j % L), baseline copy.
fn max_steps_lanes(es: &Entries<'_>, tau: f64) -> ([f64; L], [f64; L]) {
    let mut ap = [1.0f64; L];
    let mut ad = [1.0f64; L];
    for j in 0..es.groups() * L {
        let (p, d) = step_limits(es.one(j), tau);
        ap[j % L] = min(ap[j % L], p);
        ad[j % L] = min(ad[j % L], d);
    }
    (ap, ad)
}

kernel! {
    /// grad(barrier objective) . dw: (grad_x, 0) - mu / (w - l) + mu / (u - w), dotted
    /// with dw in index order.
    pub fn barrier_grad_dot(ws: &Workspace, mu: f64) -> f64 {
        let (n, nw) = (ws.n, ws.n + ws.m);
        let (w, lo, hi, dw) = (&ws.w[..nw], &ws.lo[..nw], &ws.hi[..nw], &ws.dw[..nw]);
        let (hl, hh) = (&ws.has_lo[..nw], &ws.has_hi[..nw]);
        let mut gd = 0.0;
        for j in 0..nw {
            let g0 = if j < n { ws.grad[j] } else { 0.0 };
            let bl = mu / (w[j] - lo[j]);
            let bu = mu / (hi[j] - w[j]);
            let gl = if hl[j] { g0 - bl } else { g0 };
            let gj = if hh[j] { gl + bu } else { gl };
            gd += gj * dw[j];
        }
        gd
    }
}

kernel! {
    /// Trial point w_t = w + alpha dw.
    pub fn set_trial(ws: &mut Workspace, alpha: f64) {
        let nw = ws.n + ws.m;
        let (w, dw) = (&ws.w[..nw], &ws.dw[..nw]);
        for (j, t) in ws.w_t[..nw].iter_mut().enumerate() {
            *t = w[j] + alpha * dw[j];
        }
    }
}

kernel! {
    /// Bound multipliers after a step: z += alpha_z dz, then kept within
    /// [mu / (kappa_sigma s), kappa_sigma mu / s] (IPOPT's safeguard, kappa_sigma = 1e10).
    pub fn step_bound_duals(ws: &mut Workspace, alpha_z: f64, mu: f64) {
        const KAPPA_SIGMA: f64 = 1e10;
        let nw = ws.n + ws.m;
        let (w, lo, hi) = (&ws.w[..nw], &ws.lo[..nw], &ws.hi[..nw]);
        let (dzl, dzu) = (&ws.dzl[..nw], &ws.dzu[..nw]);
        let (hl, hh) = (&ws.has_lo[..nw], &ws.has_hi[..nw]);
        let (zl, zu) = (&mut ws.zl[..nw], &mut ws.zu[..nw]);
        for j in 0..nw {
            let sl = w[j] - lo[j];
            let z = zl[j] + alpha_z * dzl[j];
            let (a, b) = (mu / (KAPPA_SIGMA * sl), KAPPA_SIGMA * mu / sl);
            let z = if z < a { a } else if z > b { b } else { z };
            zl[j] = if hl[j] { z } else { zl[j] };
            let su = hi[j] - w[j];
            let z = zu[j] + alpha_z * dzu[j];
            let (a, b) = (mu / (KAPPA_SIGMA * su), KAPPA_SIGMA * mu / su);
            let z = if z < a { a } else if z > b { b } else { z };
            zu[j] = if hh[j] { z } else { zu[j] };
        }
    }
}

kernel! {
    /// Slack rows of the dual residual (tmp_w[n + i] = -y_i for inequality rows; equality
    /// rows keep 0), and (max |c_i|, sum |y_i|).
    pub fn slack_terms(ws: &mut Workspace) -> (f64, f64) {
        let (n, m) = (ws.n, ws.m);
        let (y, c, eq) = (&ws.y[..m], &ws.c[..m], &ws.is_eq[..m]);
        let r = &mut ws.tmp_w[n..n + m];
        for i in 0..m {
            r[i] = if eq[i] { r[i] } else { -y[i] };
        }
        let mut pr = [0.0f64; L];
        let mut ys = [0.0f64; L];
        let full = m / L * L;
        for base in (0..full).step_by(L) {
            for l in 0..L {
                pr[l] = max(pr[l], c[base + l].abs());
                ys[l] += y[base + l].abs();
            }
        }
        for i in full..m {
            pr[0] = max(pr[0], c[i].abs());
            ys[0] += y[i].abs();
        }
        (fold(pr, max), fold(ys, |a, b| a + b))
    }
}

/// Bound terms of the KKT errors, from [`bound_errors`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundErrors {
    /// max |grad_w L| after the bound multipliers are subtracted.
    pub inf_du: f64,
    /// max s z over the complementarity pairs.
    pub compl: f64,
    /// max |s z - mu|.
    pub compl_mu: f64,
    /// sum |z|.
    pub z_sum: f64,
    /// sum s z.
    pub compl_sum: f64,
}

/// One entry of [`bound_errors`] (`r` its dual residual so far): the completed dual
/// residual and the entry's (|s_l z_l|, |s_u z_u|, |s_l z_l - mu|, |s_u z_u - mu|,
/// |z_l| + |z_u|, s_l z_l + s_u z_u).
#[inline(always)]
fn bound_error_entry(e: Entry<f64, f64>, r: f64, mu: f64) -> (f64, [f64; 6]) {
    let (zl, zu) = (e.zl, e.zu);
    // Absent bounds have z = 0.
    let rj = (r - zl) + zu;
    let pl = (e.w - e.lo) * zl;
    let pu = (e.hi - e.w) * zu;
    let (pl, ql) = if e.hl > 0.0 {
        (pl, (pl - mu).abs())
    } else {
        (0.0, 0.0)
    };
    let (pu, qu) = if e.hh > 0.0 {
        (pu, (pu - mu).abs())
    } else {
        (0.0, 0.0)
    };
    (
        rj,
        [pl.abs(), pu.abs(), ql, qu, zl.abs() + zu.abs(), pl + pu],
    )
}

/// Adds one entry of [`bound_errors`] to lane `l` of the accumulators.
#[inline(always)]
fn accumulate(acc: &mut [[f64; L]; 5], l: usize, rj: f64, e: &[f64; 6]) {
    acc[0][l] = max(acc[0][l], rj.abs());
    acc[1][l] = max(max(acc[1][l], e[0]), e[1]);
    acc[2][l] = max(max(acc[2][l], e[2]), e[3]);
    acc[3][l] += e[4];
    acc[4][l] += e[5];
}

/// Completes the dual residual in `tmp_w` (it holds grad f + J^T y and -y on the slacks):
/// tmp_w -= z_l - z_u; returns its max norm and the complementarity measures.
pub fn bound_errors(ws: &mut Workspace, mu: f64) -> BoundErrors {
    let nw = ws.n + ws.m;
    let simd = ws.simd;
    let (es, r) = Entries::with_residual(ws);
    // Lanes: inf_du, compl, compl_mu, z_sum, compl_sum.
    let mut acc = avx2::dispatch_bound_errors(simd, &es, r, mu).unwrap_or_else(|| {
        let mut acc = [[0.0f64; L]; 5];
        for j in 0..es.groups() * L {
            let (rj, e) = bound_error_entry(es.one(j), r[j], mu);
            r[j] = rj;
            accumulate(&mut acc, j % L, rj, &e);
        }
        acc
    });
    for j in es.groups() * L..nw {
        let (rj, e) = bound_error_entry(es.one(j), r[j], mu);
        r[j] = rj;
        accumulate(&mut acc, 0, rj, &e);
    }
    let [inf_du, compl, compl_mu, z_sum, compl_sum] = acc;
    BoundErrors {
        inf_du: fold(inf_du, max),
        compl: fold(compl, max),
        compl_mu: fold(compl_mu, max),
        z_sum: fold(z_sum, |a, b| a + b),
        compl_sum: fold(compl_sum, |a, b| a + b),
    }
}

/// max |s z - mu| over the complementarity pairs at a new mu: the `compl_mu` of
/// [`bound_errors`] (a max of the same terms, so the same value in any order) without its
/// other measures, which do not depend on mu, and without touching the dual residual.
pub fn compl_mu(ws: &Workspace, mu: f64) -> f64 {
    let es = Entries::of(ws);
    let mut m = 0.0f64;
    for j in 0..ws.n + ws.m {
        let (_, e) = bound_error_entry(es.one(j), 0.0, mu);
        m = max(max(m, e[2]), e[3]);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ip::nlp::{Nlp, NlpDims};

    #[test]
    fn norm1_sums_every_magnitude() {
        for len in [0usize, 1, 15, 16, 17, 40, 100] {
            // Integers: exact in any order, so every entry must be counted once.
            let v: Vec<f64> = (0..len).map(|i| (i as f64 - 7.0) * 3.0).collect();
            let want: f64 = v.iter().map(|x| x.abs()).sum();
            assert_eq!(norm1(&v), want, "len {len}");
        }
        assert!(norm1(&[1.0, f64::NAN]).is_nan());
        assert_eq!(norm1(&[f64::NEG_INFINITY; 20]), f64::INFINITY);
    }

    #[test]
    fn compl_mu_is_the_bound_errors_one() {
        let ws = filled(0);
        for mu in [0.0, 1e-9, 0.1, 3.0] {
            for simd in [false, true] {
                let mut b = ws.clone();
                b.set_simd(simd);
                let want = bound_errors(&mut b, mu).compl_mu;
                assert_eq!(compl_mu(&ws, mu).to_bits(), want.to_bits(), "mu {mu}");
            }
        }
    }

    /// Only the dimensions matter: the kernels see a filled workspace.
    struct Dims;
    impl Nlp for Dims {
        fn dims(&self) -> NlpDims {
            NlpDims {
                n: 23,
                m: 14,
                nnz_jac: 0,
                nnz_hess: 0,
            }
        }
        fn bounds(&self, _: &mut [f64], _: &mut [f64], _: &mut [f64], _: &mut [f64]) {}
        fn initial_point(&self, _: &mut [f64]) {}
        fn jac_structure(&self, _: &mut [usize], _: &mut [usize]) {}
        fn hess_structure(&self, _: &mut [usize], _: &mut [usize]) {}
        fn eval_f(&mut self, _: &[f64]) -> f64 {
            0.0
        }
        fn eval_grad_f(&mut self, _: &[f64], _: &mut [f64]) {}
        fn eval_g(&mut self, _: &[f64], _: &mut [f64]) {}
        fn eval_jac_g(&mut self, _: &[f64], _: &mut [f64]) {}
        fn eval_hess(&mut self, _: &[f64], _: f64, _: &[f64], _: &mut [f64]) {}
    }

    /// A workspace with every bound pattern (none, lower, upper, both), points strictly
    /// inside, positive multipliers at present bounds and 0 at absent ones (the solver's
    /// invariants), and directions of both signs.
    fn filled(seed: u64) -> Workspace {
        let mut ws = Workspace::new(&Dims, 0);
        let mut s = seed;
        let mut rnd = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let nw = ws.n + ws.m;
        for j in 0..nw {
            let (hl, hh) = (j % 4 == 1 || j % 4 == 3, j % 4 >= 2);
            ws.set_bounds_present(j, hl, hh);
            ws.lo[j] = if hl { -1.0 - rnd() } else { f64::NEG_INFINITY };
            ws.hi[j] = if hh { 1.0 + rnd() } else { f64::INFINITY };
            ws.w[j] = rnd() * 1.8 - 0.9;
            ws.zl[j] = if hl { 0.1 + rnd() } else { 0.0 };
            ws.zu[j] = if hh { 0.1 + rnd() } else { 0.0 };
            ws.tgt_l[j] = if hl { 0.01 } else { 0.0 };
            ws.tgt_u[j] = if hh { 0.01 } else { 0.0 };
            ws.dw[j] = 4.0 * rnd() - 2.0;
            ws.dzl[j] = if hl { 4.0 * rnd() - 2.0 } else { 0.0 };
            ws.dzu[j] = if hh { 4.0 * rnd() - 2.0 } else { 0.0 };
            ws.rhs_w[j] = rnd() - 0.5;
            ws.tmp_w[j] = rnd() - 0.5;
        }
        for j in 0..ws.n {
            ws.grad[j] = rnd() - 0.5;
        }
        for i in 0..ws.m {
            ws.y[i] = rnd() - 0.5;
            ws.c[i] = rnd() - 0.5;
            ws.is_eq[i] = i % 3 == 0;
        }
        ws
    }

    /// Every kernel, run once on a copy of `ws`; returns all outputs as bits.
    fn run_all(mut ws: Workspace, simd: bool) -> Vec<u64> {
        ws.set_simd(simd);
        let mut out = Vec::new();
        let (ap, ad) = max_steps(&ws, 0.99);
        let gd = barrier_grad_dot(&ws, 0.1);
        let (pr, ys) = slack_terms(&mut ws);
        let e = bound_errors(&mut ws, 0.1);
        out.extend([
            ap,
            ad,
            gd,
            pr,
            ys,
            e.inf_du,
            e.compl,
            e.compl_mu,
            e.z_sum,
            e.compl_sum,
        ]);
        out.extend(&ws.tmp_w);
        sigma(&mut ws);
        rhs_bounds(&mut ws);
        bound_duals(&mut ws);
        set_trial(&mut ws, 0.3);
        out.extend(
            ws.sigma
                .iter()
                .chain(&ws.rhs_w)
                .chain(&ws.dzl)
                .chain(&ws.dzu),
        );
        out.extend(&ws.w_t);
        step_bound_duals(&mut ws, 0.7, 0.1);
        out.extend(ws.zl.iter().chain(&ws.zu));
        out.iter().map(|v| v.to_bits()).collect()
    }

    #[test]
    fn all_finite_finds_every_non_finite_entry() {
        for len in [0usize, 1, 7, 8, 9, 23, 64] {
            let v: Vec<f64> = (0..len).map(|i| i as f64 - 3.5).collect();
            assert!(all_finite(&v), "len {len}");
            for j in 0..len {
                for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                    let mut w = v.clone();
                    w[j] = bad;
                    assert!(!all_finite(&w), "len {len}, entry {j}: {bad}");
                }
            }
        }
        assert!(all_finite(&[-0.0; 17]) && all_finite(&[f64::MAX, f64::MIN_POSITIVE]));
    }

    #[test]
    fn simd_and_baseline_kernels_agree_bit_for_bit() {
        for seed in 1..20 {
            assert_eq!(run_all(filled(seed), true), run_all(filled(seed), false));
        }
    }

    /// The branch-free kernels against the plain per-bound formulas.
    #[test]
    fn kernels_match_the_per_bound_formulas() {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * (1.0 + b.abs());
        for seed in 1..20 {
            let mut ws = filled(seed);
            let nw = ws.n + ws.m;
            let tau = 0.99;
            let (mut ap, mut ad, mut gd) = (1.0f64, 1.0f64, 0.0);
            for j in 0..nw {
                let (d, sl, su) = (ws.dw[j], ws.w[j] - ws.lo[j], ws.hi[j] - ws.w[j]);
                let mut g = if j < ws.n { ws.grad[j] } else { 0.0 };
                if ws.has_lo[j] {
                    if d < 0.0 {
                        ap = ap.min(-tau * sl / d);
                    }
                    if ws.dzl[j] < 0.0 {
                        ad = ad.min(-tau * ws.zl[j] / ws.dzl[j]);
                    }
                    g -= 0.1 / sl;
                }
                if ws.has_hi[j] {
                    if d > 0.0 {
                        ap = ap.min(tau * su / d);
                    }
                    if ws.dzu[j] < 0.0 {
                        ad = ad.min(-tau * ws.zu[j] / ws.dzu[j]);
                    }
                    g += 0.1 / su;
                }
                gd += g * d;
            }
            assert_eq!(max_steps(&ws, tau), (ap, ad));
            assert!(ap < 1.0 && ad < 1.0, "the case must limit both steps");
            assert!(close(barrier_grad_dot(&ws, 0.1), gd));

            let before = ws.clone();
            sigma(&mut ws);
            bound_duals(&mut ws);
            let e = bound_errors(&mut ws, 0.1);
            let (mut compl, mut inf_du) = (0.0f64, 0.0f64);
            for j in 0..nw {
                let b = &before;
                let (sl, su) = (b.w[j] - b.lo[j], b.hi[j] - b.w[j]);
                let (mut sg, mut dzl, mut dzu, mut r) = (0.0, 0.0, 0.0, b.tmp_w[j]);
                if b.has_lo[j] {
                    sg += b.zl[j] / sl;
                    dzl = (b.tgt_l[j] - sl * b.zl[j] - b.zl[j] * b.dw[j]) / sl;
                    compl = compl.max(sl * b.zl[j]);
                    r -= b.zl[j];
                }
                if b.has_hi[j] {
                    sg += b.zu[j] / su;
                    dzu = (b.tgt_u[j] - su * b.zu[j] + b.zu[j] * b.dw[j]) / su;
                    compl = compl.max(su * b.zu[j]);
                    r += b.zu[j];
                }
                inf_du = inf_du.max(r.abs());
                assert!(close(ws.sigma[j], sg) && close(ws.dzl[j], dzl) && close(ws.dzu[j], dzu));
                assert!(close(ws.tmp_w[j], r));
            }
            assert!(close(e.compl, compl) && close(e.inf_du, inf_du));
        }
    }
}
