//! Measurement noise: the measured state is y = x + sigma .* n with n ~ N(0, I) drawn
//! from a ChaCha8 stream seeded once, so the same seed gives the same noise, bit for bit,
//! on every platform. Every draw takes one normal per state (also where sigma is 0), so
//! changing one standard deviation leaves the other states' noise as it was. Drawing
//! allocates nothing.

use planner::model::NX;
use rand_chacha::rand_core::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Seeded Gaussian noise on the measured state.
#[derive(Debug, Clone)]
pub struct StateNoise {
    rng: ChaCha8Rng,
    sigma: [f64; NX],
}

impl StateNoise {
    /// Noise of standard deviations `sigma` (x order) from the stream of `seed`.
    pub fn new(sigma: [f64; NX], seed: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
            sigma,
        }
    }

    /// The measured state: `x` plus one noise draw.
    pub fn measure(&mut self, x: &[f64; NX]) -> [f64; NX] {
        let mut y = *x;
        for i in 0..NX {
            let n: f64 = StandardNormal.sample(&mut self.rng);
            y[i] += self.sigma[i] * n;
        }
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SIGMA: [f64; NX] = [0.005, 0.1, 0.005, 0.05, 20.0, 0.05, 0.01, 0.0, 0.0];

    #[test]
    fn the_same_seed_gives_the_same_noise_and_another_seed_other_noise() {
        let x = [0.1, 20.0, 0.01, 20.0, 100.0, 0.5, 0.02, 30.0, 2.0];
        let draw = |seed| {
            let mut n = StateNoise::new(SIGMA, seed);
            (0..100).map(|_| n.measure(&x)).collect::<Vec<_>>()
        };
        let a = draw(7);
        let b = draw(7);
        assert!(a
            .iter()
            .zip(&b)
            .all(|(p, q)| p.iter().zip(q).all(|(u, v)| u.to_bits() == v.to_bits())));
        assert_ne!(a, draw(8));
        // s and t are measured exactly.
        assert!(a.iter().all(|y| y[7] == x[7] && y[8] == x[8]));
    }

    /// Over 20000 draws the sample mean is within 4 standard errors of zero and the
    /// sample standard deviation within 3 % of the stated one, for every noisy state.
    #[test]
    fn the_noise_has_zero_mean_and_the_stated_standard_deviation() {
        let n_draws = 20_000;
        let mut noise = StateNoise::new(SIGMA, 1);
        let x = [0.0; NX];
        let (mut sum, mut sum2) = ([0.0; NX], [0.0; NX]);
        for _ in 0..n_draws {
            let y = noise.measure(&x);
            for i in 0..NX {
                sum[i] += y[i];
                sum2[i] += y[i] * y[i];
            }
        }
        for i in 0..NX {
            let mean = sum[i] / n_draws as f64;
            let sd = (sum2[i] / n_draws as f64 - mean * mean).max(0.0).sqrt();
            if SIGMA[i] == 0.0 {
                assert_eq!(sd, 0.0);
                continue;
            }
            let se = SIGMA[i] / (n_draws as f64).sqrt();
            assert!(mean.abs() < 4.0 * se, "state {i}: mean {mean}");
            assert!((sd / SIGMA[i] - 1.0).abs() < 0.03, "state {i}: sd {sd}");
        }
    }
}
