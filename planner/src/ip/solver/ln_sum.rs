//! Sums of logarithms for the barrier term.

use crate::elementary::ln;

/// Sum of logarithms as the logarithm of running products: one `ln` per run of factors
/// whose product stays within [1e-100, 1e100] (the barrier term has thousands of slacks).
/// A factor outside that range (or not positive and finite)
/// takes its own `ln`, so a product never overflows or underflows, and a non-positive slack
/// still gives NaN or -inf as `ln` does.
#[derive(Debug, Clone, Copy)]
pub(super) struct LnSum {
    sum: f64,
    prod: f64,
}

impl Default for LnSum {
    fn default() -> Self {
        Self {
            sum: 0.0,
            prod: 1.0,
        }
    }
}

impl LnSum {
    const LO: f64 = 1e-100;
    const HI: f64 = 1e100;

    #[inline(always)]
    pub(super) fn add(&mut self, d: f64) {
        if d > Self::LO && d < Self::HI {
            self.prod *= d;
            if !(self.prod > Self::LO && self.prod < Self::HI) {
                self.sum += ln(self.prod);
                self.prod = 1.0;
            }
        } else {
            self.sum += ln(d);
        }
    }

    pub(super) fn value(self) -> f64 {
        self.sum + ln(self.prod)
    }
}

#[cfg(test)]
mod tests {
    use super::LnSum;

    fn ln_sum(v: &[f64]) -> f64 {
        let mut b = LnSum::default();
        v.iter().for_each(|&d| b.add(d));
        b.value()
    }

    #[test]
    fn ln_sum_matches_the_sum_of_logs_over_wide_ranges() {
        // Deterministic factors spanning 1e-300 .. 1e300, runs of tiny and huge ones.
        let mut v = Vec::new();
        let mut x = 0.123_f64;
        for i in 0..5000 {
            x = (x * 3.7 + 0.31).fract();
            let e = match i % 7 {
                0 => -300.0 * x,
                1 => 300.0 * x,
                2 | 3 => -12.0 * x,
                _ => 6.0 * x - 3.0,
            };
            v.push(10f64.powf(e) * (1.0 + x));
        }
        let naive: f64 = v.iter().map(|d| d.ln()).sum();
        let abs: f64 = v.iter().map(|d| d.ln().abs()).sum();
        let got = ln_sum(&v);
        assert!((got - naive).abs() <= 1e-13 * abs, "{got} vs {naive}");
    }

    #[test]
    fn ln_sum_keeps_the_sign_of_bad_slacks() {
        assert_eq!(ln_sum(&[2.0, 0.0, 3.0]), f64::NEG_INFINITY);
        assert!(ln_sum(&[2.0, -1.0]).is_nan());
        assert!(ln_sum(&[f64::NAN, 1.0]).is_nan());
        assert_eq!(ln_sum(&[f64::INFINITY, 1.0]), f64::INFINITY);
        assert_eq!(ln_sum(&[]), 0.0);
    }
}
