//! Shared helpers of the model/OCP integration tests.
#![allow(dead_code)]

use planner::model::{NU, NX};

/// Tiny deterministic xorshift generator (no rand dependency).
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [a, b).
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

/// Random state in the operating envelope (s, t left 0).
pub fn random_state(rng: &mut Rng) -> [f64; NX] {
    let v = rng.range(8.0, 35.0);
    [
        rng.range(-1.0, 1.0),
        v,
        rng.range(-0.3, 0.3),
        v * rng.range(0.85, 1.15),
        rng.range(-3000.0, 3000.0),
        rng.range(-3.0, 3.0),
        rng.range(-0.3, 0.3),
        0.0,
        0.0,
    ]
}

/// Random control inside the LC 500 box.
pub fn random_control(rng: &mut Rng) -> [f64; NU] {
    [
        rng.range(-0.5, 0.5),
        rng.range(-3400.0, 4400.0),
        rng.range(-3400.0, -1.0),
    ]
}

/// Random trajectory: states in the envelope, s_k = k ds, t increasing by ds / V.
pub fn random_trajectory(rng: &mut Rng, n: usize, ds: f64) -> (Vec<[f64; NX]>, Vec<[f64; NU]>) {
    let mut xs = Vec::with_capacity(n + 1);
    let mut t = 0.0;
    for k in 0..=n {
        let mut x = random_state(rng);
        x[7] = k as f64 * ds;
        x[8] = t;
        t += ds / x[1];
        xs.push(x);
    }
    let us = (0..n).map(|_| random_control(rng)).collect();
    (xs, us)
}
