//! One-step defect formulas of the integrators, generic over the scalar (f64 or num-dual
//! duals) and over an abstract ODE `x' = f(x, c)`, where `c` in `[0, 1]` is the fraction of
//! the step at which f is evaluated (the vehicle schemes interpolate k_ref with it; the
//! tests use it for non-autonomous test ODEs).
//!
//! Every function returns the defect `x_1 - x_0 - h Phi` of one step of length `h`, which
//! vanishes exactly when (x_0, x_1) is a step of the scheme. The same code runs inside the
//! NLP ([`super::CrankNicolson`], [`super::ExplicitRk2`], [`super::ExplicitRk4`],
//! [`super::GaussLegendre2`]) and in the order / stability tests on y' = lambda y.

use num_dual::DualNum;

/// Implicit (backward) Euler: `x1 - x0 - h f(x1, 1)` (same formula as
/// [`super::ImplicitEuler`], whose fast path is hand-written).
pub fn implicit_euler<D, const M: usize>(
    h: f64,
    x0: &[D; M],
    x1: &[D; M],
    f: impl Fn(&[D; M], f64) -> [D; M],
) -> [D; M]
where
    D: DualNum<Primitive = f64> + Copy,
{
    let f1 = f(x1, 1.0);
    std::array::from_fn(|i| x1[i] - x0[i] - f1[i] * h)
}

/// Crank-Nicolson (trapezoid): `x1 - x0 - h/2 (f(x0, 0) + f(x1, 1))`.
pub fn crank_nicolson<D, const M: usize>(
    h: f64,
    x0: &[D; M],
    x1: &[D; M],
    f: impl Fn(&[D; M], f64) -> [D; M],
) -> [D; M]
where
    D: DualNum<Primitive = f64> + Copy,
{
    let f0 = f(x0, 0.0);
    let f1 = f(x1, 1.0);
    std::array::from_fn(|i| x1[i] - x0[i] - (f0[i] + f1[i]) * (0.5 * h))
}

/// `x + a k` element-wise.
#[inline]
fn axpy<D: DualNum<Primitive = f64> + Copy, const M: usize>(
    x: &[D; M],
    a: f64,
    k: &[D; M],
) -> [D; M] {
    std::array::from_fn(|i| x[i] + k[i] * a)
}

/// Explicit midpoint RK2: `x1 - x0 - h f(x0 + h/2 f(x0, 0), 1/2)`.
pub fn rk2_midpoint<D, const M: usize>(
    h: f64,
    x0: &[D; M],
    x1: &[D; M],
    f: impl Fn(&[D; M], f64) -> [D; M],
) -> [D; M]
where
    D: DualNum<Primitive = f64> + Copy,
{
    let k1 = f(x0, 0.0);
    let k2 = f(&axpy(x0, 0.5 * h, &k1), 0.5);
    std::array::from_fn(|i| x1[i] - x0[i] - k2[i] * h)
}

/// Classical explicit RK4: `x1 - x0 - h/6 (k1 + 2 k2 + 2 k3 + k4)` with stages at
/// c = 0, 1/2, 1/2, 1.
pub fn rk4<D, const M: usize>(
    h: f64,
    x0: &[D; M],
    x1: &[D; M],
    f: impl Fn(&[D; M], f64) -> [D; M],
) -> [D; M]
where
    D: DualNum<Primitive = f64> + Copy,
{
    let k1 = f(x0, 0.0);
    let k2 = f(&axpy(x0, 0.5 * h, &k1), 0.5);
    let k3 = f(&axpy(x0, 0.5 * h, &k2), 0.5);
    let k4 = f(&axpy(x0, h, &k3), 1.0);
    std::array::from_fn(|i| x1[i] - x0[i] - (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (h / 6.0))
}

/// sqrt(3) / 6, the half distance between the two Gauss-Legendre nodes.
const GL2_R: f64 = 0.288_675_134_594_812_9;
/// Nodes c of the 2-stage Gauss-Legendre method (order 4).
pub const GL2_C: [f64; 2] = [0.5 - GL2_R, 0.5 + GL2_R];
/// Butcher matrix A of the 2-stage Gauss-Legendre method.
pub const GL2_A: [[f64; 2]; 2] = [[0.25, 0.25 - GL2_R], [0.25 + GL2_R, 0.25]];
/// Weights b of the 2-stage Gauss-Legendre method.
pub const GL2_B: [f64; 2] = [0.5, 0.5];

/// 2-stage Gauss-Legendre collocation with the stage states `xs1`, `xs2` as unknowns.
///
/// Writes `3 M` rows into `out`: the two collocation rows
/// `X_j - x0 - h sum_l A_jl f(X_l, c_l)` (j = 1, 2) and the continuity row
/// `x1 - x0 - h sum_l b_l f(X_l, c_l)`.
pub fn gauss_legendre2<D, const M: usize>(
    h: f64,
    x0: &[D; M],
    x1: &[D; M],
    xs1: &[D; M],
    xs2: &[D; M],
    f: impl Fn(&[D; M], f64) -> [D; M],
    out: &mut [D],
) where
    D: DualNum<Primitive = f64> + Copy,
{
    let f1 = f(xs1, GL2_C[0]);
    let f2 = f(xs2, GL2_C[1]);
    for i in 0..M {
        out[i] = xs1[i] - x0[i] - (f1[i] * GL2_A[0][0] + f2[i] * GL2_A[0][1]) * h;
        out[M + i] = xs2[i] - x0[i] - (f1[i] * GL2_A[1][0] + f2[i] * GL2_A[1][1]) * h;
        out[2 * M + i] = x1[i] - x0[i] - (f1[i] * GL2_B[0] + f2[i] * GL2_B[1]) * h;
    }
}

/// sqrt(15) / 10, the distance of the outer 3-stage Gauss-Legendre nodes from the midpoint.
const GL3_R: f64 = 0.387_298_334_620_741_7;
/// sqrt(15) / 15, entering the 3-stage Butcher matrix.
const GL3_S15: f64 = 0.258_198_889_747_161_1;
/// sqrt(15) / 24.
const GL3_S24: f64 = 0.161_374_306_091_975_7;
/// sqrt(15) / 30.
const GL3_S30: f64 = 0.129_099_444_873_580_56;
/// Nodes c of the 3-stage Gauss-Legendre method (order 6, A-stable; the paper's ground
/// truth, Sec. IV).
pub const GL3_C: [f64; 3] = [0.5 - GL3_R, 0.5, 0.5 + GL3_R];
/// Butcher matrix A of the 3-stage Gauss-Legendre method.
pub const GL3_A: [[f64; 3]; 3] = [
    [5.0 / 36.0, 2.0 / 9.0 - GL3_S15, 5.0 / 36.0 - GL3_S30],
    [5.0 / 36.0 + GL3_S24, 2.0 / 9.0, 5.0 / 36.0 - GL3_S24],
    [5.0 / 36.0 + GL3_S30, 2.0 / 9.0 + GL3_S15, 5.0 / 36.0],
];
/// Weights b of the 3-stage Gauss-Legendre method.
pub const GL3_B: [f64; 3] = [5.0 / 18.0, 4.0 / 9.0, 5.0 / 18.0];

/// 3-stage Gauss-Legendre collocation with the stage states `xs[0..3]` as unknowns.
///
/// Writes `4 M` rows into `out`: the three collocation rows
/// `X_j - x0 - h sum_l A_jl f(X_l, c_l)` (j = 1, 2, 3) and the continuity row
/// `x1 - x0 - h sum_l b_l f(X_l, c_l)`.
pub fn gauss_legendre3<D, const M: usize>(
    h: f64,
    x0: &[D; M],
    x1: &[D; M],
    xs: &[[D; M]; 3],
    f: impl Fn(&[D; M], f64) -> [D; M],
    out: &mut [D],
) where
    D: DualNum<Primitive = f64> + Copy,
{
    let fs: [[D; M]; 3] = std::array::from_fn(|l| f(&xs[l], GL3_C[l]));
    for i in 0..M {
        for j in 0..3 {
            let mut acc = fs[0][i] * GL3_A[j][0];
            acc += fs[1][i] * GL3_A[j][1];
            acc += fs[2][i] * GL3_A[j][2];
            out[j * M + i] = xs[j][i] - x0[i] - acc * h;
        }
        let mut acc = fs[0][i] * GL3_B[0];
        acc += fs[1][i] * GL3_B[1];
        acc += fs[2][i] * GL3_B[2];
        out[3 * M + i] = x1[i] - x0[i] - acc * h;
    }
}

/// Coefficients of one linear multistep formula (paper Sec. IV)
/// `sum_{j=0}^{q} a_j x_{n+1-j} - h sum_{j=0}^{q} b_j f(x_{n+1-j}) = 0`, with `a_0 = 1`;
/// entry j of both arrays belongs to node n + 1 - j (j = 0 is the new node).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultistepFormula {
    /// Steps q (the formula reads q + 1 nodes).
    pub steps: usize,
    /// Order of consistency.
    pub order: usize,
    /// State coefficients a_0..a_q.
    pub a: &'static [f64],
    /// Right-hand-side coefficients b_0..b_q.
    pub b: &'static [f64],
}

/// BDF formulas of order 1..=6 (index q - 1): `sum_j a_j x_{n+1-j} = h beta f(x_{n+1})`,
/// normalised to a_0 = 1 (Hairer-Wanner II, Sec. III.1). BDF1 is implicit Euler; BDF1-2 are
/// A-stable, BDF3-6 only A(alpha)-stable (alpha = 86, 73, 52, 18 degrees), BDF >= 7 is not
/// zero-stable.
pub const BDF: [MultistepFormula; 6] = [
    MultistepFormula {
        steps: 1,
        order: 1,
        a: &[1.0, -1.0],
        b: &[1.0, 0.0],
    },
    MultistepFormula {
        steps: 2,
        order: 2,
        a: &[1.0, -4.0 / 3.0, 1.0 / 3.0],
        b: &[2.0 / 3.0, 0.0, 0.0],
    },
    MultistepFormula {
        steps: 3,
        order: 3,
        a: &[1.0, -18.0 / 11.0, 9.0 / 11.0, -2.0 / 11.0],
        b: &[6.0 / 11.0, 0.0, 0.0, 0.0],
    },
    MultistepFormula {
        steps: 4,
        order: 4,
        a: &[1.0, -48.0 / 25.0, 36.0 / 25.0, -16.0 / 25.0, 3.0 / 25.0],
        b: &[12.0 / 25.0, 0.0, 0.0, 0.0, 0.0],
    },
    MultistepFormula {
        steps: 5,
        order: 5,
        a: &[
            1.0,
            -300.0 / 137.0,
            300.0 / 137.0,
            -200.0 / 137.0,
            75.0 / 137.0,
            -12.0 / 137.0,
        ],
        b: &[60.0 / 137.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    },
    MultistepFormula {
        steps: 6,
        order: 6,
        a: &[
            1.0,
            -360.0 / 147.0,
            450.0 / 147.0,
            -400.0 / 147.0,
            225.0 / 147.0,
            -72.0 / 147.0,
            10.0 / 147.0,
        ],
        b: &[60.0 / 147.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    },
];

/// Adams-Moulton formulas with q = 1..=3 steps (index q - 1):
/// `x_{n+1} - x_n = h sum_{j=0}^{q} b_j f(x_{n+1-j})`, order q + 1 (Hairer-Norsett-Wanner I,
/// Sec. III.1). q = 1 is the trapezoid rule (Crank-Nicolson, A-stable); q = 2 (order 3)
/// and q = 3 (order 4) are not A-stable. The paper's "Adams-Moulton 3-stage" is q = 3
/// (see [`super::multistep`]).
pub const ADAMS_MOULTON: [MultistepFormula; 3] = [
    MultistepFormula {
        steps: 1,
        order: 2,
        a: &[1.0, -1.0],
        b: &[0.5, 0.5],
    },
    MultistepFormula {
        steps: 2,
        order: 3,
        a: &[1.0, -1.0, 0.0],
        b: &[5.0 / 12.0, 8.0 / 12.0, -1.0 / 12.0],
    },
    MultistepFormula {
        steps: 3,
        order: 4,
        a: &[1.0, -1.0, 0.0, 0.0],
        b: &[9.0 / 24.0, 19.0 / 24.0, -5.0 / 24.0, 1.0 / 24.0],
    },
];

/// Defect of one step of the multistep formula `m` with step `h`:
/// `sum_j a_j x[q - j] - h sum_j b_j f(x[q - j], 1 - j)`, where `x` holds the q + 1 states
/// oldest first (`x[q]` is the new state x_{n+1}) and f's second argument is the node's
/// position in steps relative to x_n (1 for x_{n+1}, 0 for x_n, -1 for x_{n-1}, ...).
pub fn multistep<D, const M: usize>(
    m: &MultistepFormula,
    h: f64,
    x: &[[D; M]],
    f: impl Fn(&[D; M], f64) -> [D; M],
) -> [D; M]
where
    D: DualNum<Primitive = f64> + Copy,
{
    let q = m.steps;
    let mut out = [D::from(0.0); M];
    for j in 0..=q {
        let xn = &x[q - j];
        for i in 0..M {
            out[i] += xn[i] * m.a[j];
        }
        if m.b[j] != 0.0 {
            let fj = f(xn, 1.0 - j as f64);
            for i in 0..M {
                out[i] -= fj[i] * (h * m.b[j]);
            }
        }
    }
    out
}
