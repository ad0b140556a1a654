//! The elementary functions of the model, the solver and the track: from the `libm` crate
//! (musl's algorithms in Rust, within 1 ulp), so a plan has the same bits on every x86-64
//! machine (the C library picks an FMA or a plain variant of `sincos`, `tan`, `log` and
//! `pow` at run time, and a replay on another machine must reproduce a plan's bits). Its
//! sincos and tan are also about twice as fast here (5 ns against 10-16 ns; the C library
//! saves and restores the rounding mode on every call). Dual numbers (the AD oracle) keep
//! num-dual's own rules.

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

/// (sin x, cos x): [`sin_cos_f64`] for a plain float (no derivatives), else num-dual's.
#[inline(always)]
pub fn sin_cos<D: DualNum<Primitive = f64> + Copy>(x: D) -> (D, D) {
    if D::NDERIV == 0 {
        let (s, c) = sin_cos_f64(x.re());
        (D::from(s), D::from(c))
    } else {
        x.sin_cos()
    }
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

/// tan x: [`tan_f64`] for a plain float, else num-dual's.
#[inline(always)]
pub fn tan<D: DualNum<Primitive = f64> + Copy>(x: D) -> D {
    if D::NDERIV == 0 {
        D::from(tan_f64(x.re()))
    } else {
        x.tan()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    /// Plain floats take libm's values; duals keep their derivative rules; both agree with
    /// the C library to 1 ulp over the model's angle range.
    #[test]
    fn plain_floats_use_libm_and_duals_keep_their_derivatives() {
        for i in 0..=2000 {
            let x = (i as f64 / 1000.0 - 1.0) * 1.5;
            let (s, c) = sin_cos(x);
            assert_eq!((s.to_bits(), c.to_bits()), {
                let (a, b) = libm::sincos(x);
                (a.to_bits(), b.to_bits())
            });
            assert_eq!(tan(x).to_bits(), libm::tan(x).to_bits());
            let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
            assert!(ulps(s, x.sin()) <= 1 && ulps(c, x.cos()) <= 1 && ulps(tan(x), x.tan()) <= 1);
            let d = Dual64::from(x).derivative();
            let (sd, cd) = sin_cos(d);
            assert!((sd.eps - x.cos()).abs() < 1e-15 && (cd.eps + x.sin()).abs() < 1e-15);
            assert!(
                (tan(d).eps - 1.0 / (x.cos() * x.cos())).abs() < 1e-12 * (1.0 + x.tan().powi(2))
            );
        }
    }
}
