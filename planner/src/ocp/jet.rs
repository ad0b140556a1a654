//! Lean fixed-size forward-mode jets for the hot derivative path (allocation-free, no
//! `Option` inside): first order [`D1`] (value, gradient) and second order [`D2`] (value,
//! gradient, lower-triangle Hessian). [`Arith`] is the small arithmetic interface the
//! structured model pieces of [`super::fast`] are generic over (also implemented for f64),
//! and [`compose`] is the exact second-order chain rule that substitutes jets over a few
//! intermediate variables into jets over more inputs.
//!
//! The Hessian of a [`D2`] is stored and updated as a full symmetric square (fixed-trip
//! inner loops the compiler unrolls and vectorizes, unlike triangle loops).

// Jet arithmetic implements each operator by its derivative rules, which mix operators.
#![allow(clippy::suspicious_arithmetic_impl)]

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::elementary::{sin_cos_f64, tan_f64};

/// Arithmetic needed by the fast model pieces: field operations, scalar operations and the
/// few elementary functions of the model.
pub trait Arith:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A constant.
    fn cst(v: f64) -> Self;
    /// The value (real part).
    fn re(&self) -> f64;
    /// 1 / self.
    fn recip(self) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// (sin, cos).
    fn sin_cos(self) -> (Self, Self);
    /// Tangent.
    fn tan(self) -> Self;
}

impl Arith for f64 {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn re(&self) -> f64 {
        *self
    }
    #[inline(always)]
    fn recip(self) -> Self {
        1.0 / self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        sin_cos_f64(self)
    }
    #[inline(always)]
    fn tan(self) -> Self {
        tan_f64(self)
    }
}

/// First-order jet over M inputs: value and gradient.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct D1<const M: usize> {
    /// Value.
    pub re: f64,
    /// Gradient.
    pub g: [f64; M],
}

/// Second-order jet over M inputs: value, gradient and symmetric Hessian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct D2<const M: usize> {
    /// Value.
    pub re: f64,
    /// Gradient.
    pub g: [f64; M],
    /// Hessian (symmetric, both triangles maintained).
    pub h: [[f64; M]; M],
}

impl<const M: usize> D1<M> {
    /// Input `i` with value `v` (unit gradient in direction i).
    #[inline(always)]
    pub fn var(v: f64, i: usize) -> Self {
        let mut g = [0.0; M];
        g[i] = 1.0;
        Self { re: v, g }
    }
    /// Unary chain rule with f(re) = f0, f'(re) = f1.
    #[inline(always)]
    pub fn chain(self, f0: f64, f1: f64) -> Self {
        Self {
            re: f0,
            g: std::array::from_fn(|i| f1 * self.g[i]),
        }
    }
    /// The same jet over K >= M inputs: input i becomes input `map[i]`.
    #[inline(always)]
    pub fn embed<const K: usize>(&self, map: &[usize; M]) -> D1<K> {
        let mut g = [0.0; K];
        for (i, &mi) in map.iter().enumerate() {
            g[mi] += self.g[i];
        }
        D1 { re: self.re, g }
    }
}

impl<const M: usize> D2<M> {
    /// Input `i` with value `v` (unit gradient in direction i, zero Hessian).
    #[inline(always)]
    pub fn var(v: f64, i: usize) -> Self {
        let mut g = [0.0; M];
        g[i] = 1.0;
        Self {
            re: v,
            g,
            h: [[0.0; M]; M],
        }
    }
    /// Unary chain rule with f(re) = f0, f'(re) = f1, f''(re) = f2.
    #[inline(always)]
    pub fn chain(self, f0: f64, f1: f64, f2: f64) -> Self {
        let mut out = Self {
            re: f0,
            g: std::array::from_fn(|i| f1 * self.g[i]),
            h: [[0.0; M]; M],
        };
        for i in 0..M {
            let gi = f2 * self.g[i];
            for j in 0..M {
                out.h[i][j] = f1 * self.h[i][j] + gi * self.g[j];
            }
        }
        out
    }
    /// The same jet over K >= M inputs: input i becomes input `map[i]` (distinct indices).
    #[inline(always)]
    pub fn embed<const K: usize>(&self, map: &[usize; M]) -> D2<K> {
        let mut out = D2::<K> {
            re: self.re,
            g: [0.0; K],
            h: [[0.0; K]; K],
        };
        for i in 0..M {
            out.g[map[i]] = self.g[i];
            for j in 0..M {
                out.h[map[i]][map[j]] = self.h[i][j];
                out.h[map[j]][map[i]] = self.h[i][j];
            }
        }
        out
    }
    /// Adds `o`, a jet over L of this jet's inputs (input i of `o` is input `map[i]` here,
    /// distinct indices): the embedding and the sum in one pass.
    #[inline(always)]
    pub fn add_at<const L: usize>(&mut self, o: &D2<L>, map: &[usize; L]) {
        self.re += o.re;
        for i in 0..L {
            self.g[map[i]] += o.g[i];
            for j in 0..L {
                self.h[map[i]][map[j]] += o.h[i][j];
            }
        }
    }
    /// Writes the lower triangle row-major (i >= j), entry (i, j) multiplied by
    /// `scale[i] * scale[j]`, into `out` (length M (M + 1) / 2).
    #[inline(always)]
    pub fn write_lower(&self, scale: &[f64; M], out: &mut [f64]) {
        let mut p = 0;
        for i in 0..M {
            for j in 0..=i {
                out[p] = self.h[i][j] * scale[i] * scale[j];
                p += 1;
            }
        }
    }
    /// The first-order part.
    #[inline(always)]
    pub fn d1(&self) -> D1<M> {
        D1 {
            re: self.re,
            g: self.g,
        }
    }
}

/// Exact second-order chain rule: `outer` is a jet of y(w) over K intermediates w, `inner[k]`
/// the jet of w_k over M inputs; returns the jet of y(w(x)) over the M inputs:
/// grad = sum_k y_k grad w_k, H = sum_k y_k H(w_k) + sum_kl y_kl grad w_k grad w_l^T.
#[inline(always)]
pub fn compose<const K: usize, const M: usize>(outer: &D2<K>, inner: &[D2<M>; K]) -> D2<M> {
    compose_tail::<K, M, K>(outer, inner, &[])
}

/// [`compose`] when the last intermediates are plain inputs: `outer` is a jet over K
/// intermediates, the first H of them the jets `head` over M inputs and intermediate
/// H + i the input `tail[i]` (unit gradient, zero Hessian; K = H + tail.len()). Their
/// Hessian terms vanish and their outer products are single rows, so only the H head
/// Hessians are swept: H M^2 instead of K M^2 multiply-adds.
#[inline(always)]
pub fn compose_tail<const K: usize, const M: usize, const H: usize>(
    outer: &D2<K>,
    head: &[D2<M>; H],
    tail: &[usize],
) -> D2<M> {
    debug_assert_eq!(H + tail.len(), K);
    let mut out = D2::<M> {
        re: outer.re,
        g: [0.0; M],
        h: [[0.0; M]; M],
    };
    // t[k] = sum_l y_kl grad w_l over all K intermediates.
    let mut t = [[0.0; M]; K];
    for (k, tk) in t.iter_mut().enumerate() {
        for (l, w) in head.iter().enumerate() {
            let ykl = outer.h[k][l];
            for n in 0..M {
                tk[n] += ykl * w.g[n];
            }
        }
        for (i, &v) in tail.iter().enumerate() {
            tk[v] += outer.h[k][H + i];
        }
    }
    for (k, w) in head.iter().enumerate() {
        let yk = outer.g[k];
        for n in 0..M {
            out.g[n] += yk * w.g[n];
        }
        for m in 0..M {
            let wm = w.g[m];
            for n in 0..M {
                out.h[m][n] += yk * w.h[m][n] + wm * t[k][n];
            }
        }
    }
    for (i, &v) in tail.iter().enumerate() {
        out.g[v] += outer.g[H + i];
        for n in 0..M {
            out.h[v][n] += t[H + i][n];
        }
    }
    out
}

/// First-order chain rule: jet of y(w(x)) from the jet of y over K intermediates and the
/// jets of the intermediates over M inputs.
#[inline(always)]
pub fn compose1<const K: usize, const M: usize>(outer: &D1<K>, inner: &[D1<M>; K]) -> D1<M> {
    let mut g = [0.0; M];
    for k in 0..K {
        for n in 0..M {
            g[n] += outer.g[k] * inner[k].g[n];
        }
    }
    D1 { re: outer.re, g }
}

// ---------------------------------------------------------------- D1 arithmetic

impl<const M: usize> Add for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            re: self.re + o.re,
            g: std::array::from_fn(|i| self.g[i] + o.g[i]),
        }
    }
}
impl<const M: usize> Sub for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            re: self.re - o.re,
            g: std::array::from_fn(|i| self.g[i] - o.g[i]),
        }
    }
}
impl<const M: usize> Mul for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self {
            re: self.re * o.re,
            g: std::array::from_fn(|i| self.g[i] * o.re + o.g[i] * self.re),
        }
    }
}
impl<const M: usize> Div for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.re;
        let q = self.re * inv;
        Self {
            re: q,
            g: std::array::from_fn(|i| (self.g[i] - q * o.g[i]) * inv),
        }
    }
}
impl<const M: usize> Neg for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self {
            re: -self.re,
            g: std::array::from_fn(|i| -self.g[i]),
        }
    }
}
impl<const M: usize> Add<f64> for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, o: f64) -> Self {
        self.re += o;
        self
    }
}
impl<const M: usize> Sub<f64> for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, o: f64) -> Self {
        self.re -= o;
        self
    }
}
impl<const M: usize> Mul<f64> for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: f64) -> Self {
        Self {
            re: self.re * o,
            g: std::array::from_fn(|i| self.g[i] * o),
        }
    }
}
impl<const M: usize> Div<f64> for D1<M> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: f64) -> Self {
        self * (1.0 / o)
    }
}

impl<const M: usize> Arith for D1<M> {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        Self { re: v, g: [0.0; M] }
    }
    #[inline(always)]
    fn re(&self) -> f64 {
        self.re
    }
    #[inline(always)]
    fn recip(self) -> Self {
        let r = 1.0 / self.re;
        self.chain(r, -r * r)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let s = self.re.sqrt();
        self.chain(s, 0.5 / s)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = sin_cos_f64(self.re);
        (self.chain(s, c), self.chain(c, -s))
    }
    #[inline(always)]
    fn tan(self) -> Self {
        let t = tan_f64(self.re);
        self.chain(t, 1.0 + t * t)
    }
}

// ---------------------------------------------------------------- D2 arithmetic

impl<const M: usize> Add for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, o: Self) -> Self {
        self.re += o.re;
        for i in 0..M {
            self.g[i] += o.g[i];
            for j in 0..M {
                self.h[i][j] += o.h[i][j];
            }
        }
        self
    }
}
impl<const M: usize> Sub for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, o: Self) -> Self {
        self.re -= o.re;
        for i in 0..M {
            self.g[i] -= o.g[i];
            for j in 0..M {
                self.h[i][j] -= o.h[i][j];
            }
        }
        self
    }
}
impl<const M: usize> Mul for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let mut out = Self {
            re: self.re * o.re,
            g: std::array::from_fn(|i| self.g[i] * o.re + o.g[i] * self.re),
            h: [[0.0; M]; M],
        };
        for i in 0..M {
            let (ai, bi) = (self.g[i], o.g[i]);
            for j in 0..M {
                out.h[i][j] =
                    self.h[i][j] * o.re + o.h[i][j] * self.re + ai * o.g[j] + bi * self.g[j];
            }
        }
        out
    }
}
impl<const M: usize> Div for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self * o.recip()
    }
}
impl<const M: usize> Neg for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self * -1.0
    }
}
impl<const M: usize> Add<f64> for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, o: f64) -> Self {
        self.re += o;
        self
    }
}
impl<const M: usize> Sub<f64> for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, o: f64) -> Self {
        self.re -= o;
        self
    }
}
impl<const M: usize> Mul<f64> for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn mul(mut self, o: f64) -> Self {
        self.re *= o;
        for i in 0..M {
            self.g[i] *= o;
            for j in 0..M {
                self.h[i][j] *= o;
            }
        }
        self
    }
}
impl<const M: usize> Div<f64> for D2<M> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: f64) -> Self {
        self * (1.0 / o)
    }
}

impl<const M: usize> Arith for D2<M> {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        Self {
            re: v,
            g: [0.0; M],
            h: [[0.0; M]; M],
        }
    }
    #[inline(always)]
    fn re(&self) -> f64 {
        self.re
    }
    #[inline(always)]
    fn recip(self) -> Self {
        let r = 1.0 / self.re;
        self.chain(r, -r * r, 2.0 * r * r * r)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let s = self.re.sqrt();
        let d1 = 0.5 / s;
        self.chain(s, d1, -0.5 * d1 / self.re)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = sin_cos_f64(self.re);
        (self.chain(s, c, -s), self.chain(c, -s, -c))
    }
    #[inline(always)]
    fn tan(self) -> Self {
        let t = tan_f64(self.re);
        let d1 = 1.0 + t * t;
        self.chain(t, d1, 2.0 * t * d1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y(w) = w0 w1 + w2^2 with w0 = x0^2 x2 (a jet), w1 = x1 and w2 = x2 (plain inputs):
    /// y = x0^2 x1 x2 + x2^2, whose gradient and Hessian are known in closed form.
    #[test]
    fn compose_tail_matches_the_closed_form_and_compose() {
        let x = [0.7, -1.3, 2.1];
        let v: [D2<3>; 3] = std::array::from_fn(|i| D2::var(x[i], i));
        let w0 = v[0] * v[0] * v[2];
        let o: [D2<3>; 3] = std::array::from_fn(|i| D2::var([w0.re, x[1], x[2]][i], i));
        let outer = o[0] * o[1] + o[2] * o[2];
        let tail = compose_tail(&outer, &[w0], &[1, 2]);
        let full = compose(&outer, &[w0, v[1], v[2]]);
        let (a, b, c) = (x[0], x[1], x[2]);
        let g = [2.0 * a * b * c, a * a * c, a * a * b + 2.0 * c];
        let h = [
            [2.0 * b * c, 2.0 * a * c, 2.0 * a * b],
            [2.0 * a * c, 0.0, a * a],
            [2.0 * a * b, a * a, 2.0],
        ];
        for jet in [&tail, &full] {
            assert!((jet.re - (a * a * b * c + c * c)).abs() < 1e-12);
            for i in 0..3 {
                assert!((jet.g[i] - g[i]).abs() < 1e-12, "g[{i}]");
                for j in 0..3 {
                    assert!((jet.h[i][j] - h[i][j]).abs() < 1e-12, "h[{i}][{j}]");
                }
            }
        }
    }
}
