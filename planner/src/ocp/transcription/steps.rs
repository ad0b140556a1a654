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
