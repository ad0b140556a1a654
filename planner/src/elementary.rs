//! The elementary functions of the model, the solver and the track, from the `libm` crate
//! (musl's algorithms in Rust, within 1 ulp), so that the planner's own arithmetic gives a
//! plan the same bits on every x86-64 machine: the C library picks an FMA or a plain
//! variant of `sincos`, `tan`, `exp`, `log` and `pow` at run time, and a replay on another
//! machine must reproduce a plan's bits. Its sincos and tan are also faster here (the C
//! library saves and restores the rounding mode on every call). Dual numbers (the
//! equilibrium guess's fit and the AD oracle) take the same libm values through their
//! Taylor polynomial (see [`sin_cos`]): num-dual's own rules call the C library for the
//! real part.

use num_dual::DualNum;

/// (sin x, cos x) of a plain float.
#[inline(always)]
pub fn sin_cos_f64(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// tan x of a plain float.
#[inline(always)]
pub fn tan_f64(x: f64) -> f64 {
    libm::tan(x)
}

/// (sin x, cos x) with [`sin_cos_f64`]'s values. A dual number's derivatives come from the
/// Taylor polynomial about its real part r to the type's highest derivative n: with
/// d = x - r (no real part), d^(n+1) = 0 for every num-dual type, so
/// f(x) = sum_{j <= n} f^(j)(r) d^j / j! is exact.
#[inline(always)]
pub fn sin_cos<D: DualNum<Primitive = f64> + Copy>(x: D) -> (D, D) {
    let r = x.re();
    let (s, c) = sin_cos_f64(r);
    if D::NDERIV == 0 {
        return (D::from(s), D::from(c));
    }
    // The j-th derivatives of sin and cos at r repeat with period 4.
    let ds = [s, c, -s, -c];
    let dc = [c, -s, -c, s];
    (taylor(x, r, |j| ds[j % 4]), taylor(x, r, |j| dc[j % 4]))
}

/// tan x with [`tan_f64`]'s value; a dual's derivatives as in [`sin_cos`], from
/// tan' = 1 + t^2, tan'' = 2 t (1 + t^2) and tan''' = 2 (1 + t^2) (1 + 3 t^2) (num-dual's
/// types have at most third derivatives; beyond, num-dual's own rule).
#[inline(always)]
pub fn tan<D: DualNum<Primitive = f64> + Copy>(x: D) -> D {
    let r = x.re();
    let t = tan_f64(r);
    if D::NDERIV == 0 {
        return D::from(t);
    }
    if D::NDERIV > 3 {
        return x.tan();
    }
    let q = 1.0 + t * t;
    let d = [t, q, 2.0 * t * q, 2.0 * q * (1.0 + 3.0 * t * t)];
    taylor(x, r, |j| d[j])
}

/// sum_{j <= n} f(j) (x - r)^j / j! for a dual `x` with real part `r` and highest
/// derivative n.
#[inline(always)]
fn taylor<D: DualNum<Primitive = f64> + Copy>(x: D, r: f64, f: impl Fn(usize) -> f64) -> D {
    let d = x - r;
    let mut out = D::from(f(0));
    let mut p = D::from(1.0);
    let mut fact = 1.0;
    for j in 1..=D::NDERIV {
        p *= d;
        fact *= j as f64;
        out += p * (f(j) / fact);
    }
    out
}

/// Natural logarithm.
#[inline(always)]
pub fn ln(x: f64) -> f64 {
    libm::log(x)
}

/// e^x.
#[inline(always)]
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}

/// x^y.
#[inline(always)]
pub fn pow(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

/// sqrt(x^2 + y^2) without undue overflow.
#[inline(always)]
pub fn hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{Dual2_64, Dual3_64, Dual64, HyperDual64};

    /// Plain floats and the real parts of duals take libm's values, within 1 ulp of the C
    /// library over the model's angle range; the duals' first, second, third and mixed
    /// derivatives match the closed forms.
    #[test]
    fn libm_values_and_exact_dual_derivatives() {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        for i in 0..=2000 {
            let x = (i as f64 / 1000.0 - 1.0) * 1.5;
            let (s, c) = sin_cos(x);
            let (ls, lc) = libm::sincos(x);
            assert_eq!((s.to_bits(), c.to_bits()), (ls.to_bits(), lc.to_bits()));
            assert_eq!(tan(x).to_bits(), libm::tan(x).to_bits());
            assert!(ulps(s, x.sin()) <= 1 && ulps(c, x.cos()) <= 1 && ulps(tan(x), x.tan()) <= 1);

            let (s1, c1) = sin_cos(Dual64::from(x).derivative());
            assert_eq!(
                (s1.re.to_bits(), c1.re.to_bits()),
                (s.to_bits(), c.to_bits())
            );
            assert!((s1.eps - x.cos()).abs() < 1e-15 && (c1.eps + x.sin()).abs() < 1e-15);
            let (s3, c3) = sin_cos(Dual3_64::from(x).derivative());
            assert!((s3.v2 + x.sin()).abs() < 1e-15 && (s3.v3 + x.cos()).abs() < 1e-15);
            assert!((c3.v2 + x.cos()).abs() < 1e-15 && (c3.v3 - x.sin()).abs() < 1e-15);

            let t = x.tan();
            let q = 1.0 + t * t;
            let t1 = tan(Dual64::from(x).derivative());
            assert_eq!(t1.re.to_bits(), tan(x).to_bits());
            assert!((t1.eps - q).abs() < 1e-12 * q);
            let t2 = tan(Dual2_64::from(x).derivative());
            assert!((t2.v2 - 2.0 * t * q).abs() < 1e-12 * q * q);
            let t3 = tan(Dual3_64::from(x).derivative());
            assert!((t3.v3 - 2.0 * q * (1.0 + 3.0 * t * t)).abs() < 1e-12 * q * q * q);

            // x + eps1 + 2 eps2: the eps1 eps2 part of sin is 2 sin''(x) = -2 sin x.
            let (sh, ch) = sin_cos(HyperDual64::new(x, 1.0, 2.0, 0.0));
            assert!((sh.eps1eps2 + 2.0 * x.sin()).abs() < 1e-14);
            assert!((ch.eps1eps2 + 2.0 * x.cos()).abs() < 1e-14);
            let th = tan(HyperDual64::new(x, 1.0, 2.0, 0.0));
            assert!((th.eps1eps2 - 4.0 * t * q).abs() < 1e-12 * q * q);
        }
    }
}
