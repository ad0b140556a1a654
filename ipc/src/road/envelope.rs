//! The speed a car may carry at each point of a closed road and still slow down for every
//! curve ahead of it, used to bound the speed at the last node of each plan.
//!
//! A plan's end state is otherwise free: a plan only brakes for the curves inside its
//! 250 m window, so at 70 m/s it may end closer to a hairpin than the braking distance, and
//! the next plan, from the measured state, is then infeasible. With the bound, the end of
//! every plan is a state from which the car can still brake for the road past the window,
//! so the next plan has at least that continuation (recursive feasibility, up to the
//! tracking error).
//!
//! The envelope is the quasi-steady speed profile of the centre line:
//!
//!   v_c(s) = sqrt(a_lat / |k_ref(s)|),
//!   v(s) = min over s' >= s of sqrt(v_c(s')^2 + 2 a_brake (s' - s)),
//!
//! computed once on a grid of about 1 m by a backward pass taken twice around the lap (a
//! curve's braking reaches back at most one lap). It is deliberately conservative, with
//! a_lat and a_brake below the plans' grip: it bounds one node 250 m ahead of the car,
//! which the plans reach again only after the window has seen the curve itself.

use super::ClosedRoad;

/// Grid spacing of the envelope \[m\] (at most; the lap is cut into equal steps).
const STEP_M: f64 = 1.0;

/// The lateral and braking accelerations of the envelope as fractions of the plans' grip
/// mu g: below what a plan uses (about 0.9-1.0 mu g on the racing line), so a plan can
/// always meet the bound and the next plan can always brake along it.
pub const ENVELOPE_GRIP_FRACTIONS: (f64, f64) = (0.8, 0.7);

/// A closed road's speed envelope v(s) (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedEnvelope {
    /// v at s = i step, i = 0..n (periodic) [m/s].
    v: Vec<f64>,
    step: f64,
    lap: f64,
}

impl SpeedEnvelope {
    /// The envelope of a closed road with lateral acceleration `a_lat` and braking
    /// `a_brake` [m/s^2], capped at `v_cap` [m/s]. `None` for an open road or accelerations
    /// that are not finite and positive.
    pub fn new(road: &ClosedRoad, a_lat: f64, a_brake: f64, v_cap: f64) -> Option<Self> {
        let ok = |a: f64| a.is_finite() && a > 0.0;
        if !road.is_closed() || !ok(a_lat) || !ok(a_brake) || v_cap.is_nan() || v_cap <= 0.0 {
            return None;
        }
        let lap = road.lap();
        let n = ((lap / STEP_M).ceil() as usize).max(1);
        let step = lap / n as f64;
        let mut v: Vec<f64> = (0..n)
            .map(|i| {
                let k = road.kappa(i as f64 * step).abs();
                if k > 0.0 {
                    (a_lat / k).sqrt().min(v_cap)
                } else {
                    v_cap
                }
            })
            .collect();
        let gain = 2.0 * a_brake * step;
        for j in (0..2 * n).rev() {
            let i = j % n;
            let next = v[(i + 1) % n];
            v[i] = v[i].min((next * next + gain).sqrt());
        }
        Some(Self { v, step, lap })
    }

    /// v at road arc length s (any real s, wrapped with the lap; linear between grid
    /// points) [m/s]. Allocates nothing.
    pub fn at(&self, s: f64) -> f64 {
        let n = self.v.len();
        let x = s.rem_euclid(self.lap) / self.step;
        let i = (x.floor() as usize).min(n - 1);
        let w = x - i as f64;
        self.v[i] * (1.0 - w) + self.v[(i + 1) % n] * w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1000 m lap: straight to 600 m, a curve of radius 20 m to 700 m, straight on.
    fn road() -> ClosedRoad {
        ClosedRoad::new(
            vec![(0.0, 0.0), (600.0, 0.05), (700.0, 0.0)],
            1000.0,
            -4.0,
            4.0,
        )
    }

    #[test]
    fn the_envelope_is_the_curve_speed_in_the_curve_and_the_braking_parabola_before_it() {
        let env = SpeedEnvelope::new(&road(), 8.0, 6.0, 70.0).expect("closed road");
        let v_c = (8.0f64 / 0.05).sqrt();
        assert!((env.at(650.0) - v_c).abs() < 1e-9, "{}", env.at(650.0));
        for d in [10.0, 100.0, 300.0] {
            let want = (v_c * v_c + 2.0 * 6.0 * d).sqrt().min(70.0);
            let got = env.at(600.0 - d);
            assert!((got - want).abs() < 1e-6, "{d} m before: {got} vs {want}");
        }
        // Past the curve the straight is free up to the cap.
        assert_eq!(env.at(750.0), 70.0);
    }

    #[test]
    fn the_envelope_wraps_with_the_lap() {
        // At 950 m the next curve is the one at 600 m of the next lap, 650 m ahead across
        // s = lap: with gentle braking its parabola is still below the cap there.
        let env = SpeedEnvelope::new(&road(), 8.0, 1.0, 70.0).expect("closed road");
        let v_c = (8.0f64 / 0.05).sqrt();
        let want = (v_c * v_c + 2.0 * 1.0 * 650.0).sqrt();
        assert!(want < 70.0);
        assert!((env.at(950.0) - want).abs() < 1e-6, "{}", env.at(950.0));
        assert!((env.at(-50.0) - env.at(950.0)).abs() < 1e-12);
        assert!((env.at(1950.0) - env.at(950.0)).abs() < 1e-9);
    }

    #[test]
    fn an_open_road_or_a_bad_acceleration_has_no_envelope() {
        let open = ClosedRoad::open(100.0, 0.0, -4.0, 4.0, Vec::new());
        assert!(SpeedEnvelope::new(&open, 8.0, 6.0, 70.0).is_none());
        for (a, b) in [(0.0, 6.0), (8.0, f64::NAN), (f64::INFINITY, 6.0)] {
            assert!(SpeedEnvelope::new(&road(), a, b, 70.0).is_none());
        }
    }
}
