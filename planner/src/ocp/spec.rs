//! The problem data of one OCP instance (paper eq. 3): road sampled at the nodes, bounds,
//! options and the vehicle. Built from config + track; consumed by a transcription.

use super::soft_lane::SoftLane;
use crate::model::{ix, ParamError, VehicleParams, NX, STATE_NAMES};
use crate::track::beyond_curvature_centre;

/// How the initial state x_0 is treated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InitialState {
    /// Paper convention: s_0 = t_0 = dpsi_0 = 0 fixed, e_min <= e_0 <= e_max, rest free.
    Free,
    /// Every state of x_0 given (collision avoidance); s_0 and t_0 should be 0.
    Fixed([f64; NX]),
}

/// One minimum-time OCP instance on an s grid of `n_intervals` equal steps.
///
/// Node k sits at s_k = k * ds; every per-node vector has `n_intervals + 1` entries.
#[derive(Debug, Clone, PartialEq)]
pub struct OcpSpec {
    /// Human-readable name (scenario or segment).
    pub name: String,
    /// Number of intervals N (states x_0..x_N, controls u_0..u_{N-1}).
    pub n_intervals: usize,
    /// Horizon length \[m\]; s_N = length.
    pub length: f64,
    /// Reference curvature k_ref(s_k) at every node [1/m] (R8: evaluated at the grid).
    pub kappa: Vec<f64>,
    /// Right lateral bound e_min(s_k) at every node \[m\] (obstacles already applied).
    pub e_min: Vec<f64>,
    /// Left lateral bound e_max(s_k) at every node \[m\] (obstacles already applied).
    pub e_max: Vec<f64>,
    /// Speed lower bound [m/s].
    pub v_min: f64,
    /// Speed upper bound [m/s].
    pub v_max: f64,
    /// Speed upper bound at the last node [m/s], below `v_max` where the road past the
    /// horizon needs it (`f64::INFINITY`: `v_max` alone). A replanning loop sets it from
    /// the speed the car can still brake from for the curves beyond the window
    /// (docs/closed-loop.md, "The end speed").
    pub v_end_max: f64,
    /// Add the tire saturation constraints (R5) when true.
    pub enforce_tire_saturation: bool,
    /// With `enforce_tire_saturation`, also hold the tires within their slip limits at the
    /// last node, (x_N, u_{N-1}). R5 (the paper's rows) stops at (x_{N-1}, u_{N-1}), but
    /// implicit Euler drives the last interval with f(x_N, u_{N-1}), so without these rows
    /// the last interval takes tire force beyond the limit (a rear wheel spun to 0.7-0.9
    /// slip). A receding-horizon loop, whose later plans start from this tail, sets it.
    pub saturation_at_end: bool,
    /// Weight w [1/s] of the steering-slew term added to t_N in the objective:
    /// J = t_N + w sum_{k=1}^{N-1} ((delta_k - delta_{k-1}) / delta_rate_max)^2, each term the
    /// squared time the interval's steering change takes at the rate limit. 0 is the paper's
    /// pure minimum time (eq. 3), whose optimum weaves the steering at its rate limit
    /// wherever the front brake is torque-limited (scrub drag; README, Modelling choices).
    pub steering_slew_weight: f64,
    /// Soft lane bounds inside `e_min`, `e_max` with the weight of leaving them in the
    /// objective ([`SoftLane`]; [`SoftLane::OFF`]: the paper's objective).
    pub soft_lane: SoftLane,
    /// Initial state treatment.
    pub initial: InitialState,
    /// Vehicle parameters.
    pub vehicle: VehicleParams,
}

/// Largest accepted [`OcpSpec::steering_slew_weight`] [1/s]: at 1e3 the term outweighs
/// the time by orders of magnitude on any steering change, no longer a regularization.
pub const MAX_STEERING_SLEW_WEIGHT: f64 = 1e3;

/// OCP data outside its domain.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpecError {
    /// A field of the spec.
    #[error("OCP field {field}: {problem}")]
    Field {
        /// The field (with the node for per-node vectors).
        field: String,
        /// What is wrong.
        problem: String,
    },
    /// A vehicle parameter.
    #[error("vehicle: {0}")]
    Vehicle(#[from] ParamError),
}

impl OcpSpec {
    /// Node spacing ds = length / N \[m\].
    pub fn ds(&self) -> f64 {
        self.length / self.n_intervals as f64
    }

    /// Checks what the transcription and the guess rely on: N >= 1, a finite positive
    /// length, finite per-node vectors of N + 1 entries with e_min < e_max at every node,
    /// both short of the curvature centre ([`check_road`]),
    /// 0 < v_min < v_max, v_end_max > v_min (infinite allowed), a finite fixed initial
    /// state, and the vehicle's own domain
    /// ([`VehicleParams::check`]). The config loaders ensure this for their files; data
    /// from elsewhere (a recording, a message) must pass it before it is solved.
    pub fn check(&self) -> Result<(), SpecError> {
        let bad = |field: String, problem: String| SpecError::Field { field, problem };
        let n = self.n_intervals;
        if n == 0 {
            return Err(bad("n_intervals".into(), "must be at least 1".into()));
        }
        if !(self.length.is_finite() && self.length > 0.0) {
            return Err(bad(
                "length".into(),
                format!("{} is not a finite positive length", self.length),
            ));
        }
        check_road(&self.kappa, &self.e_min, &self.e_max, n)?;
        if !(self.v_min.is_finite() && self.v_min > 0.0) {
            return Err(bad(
                "v_min".into(),
                format!("{} is not a finite positive speed", self.v_min),
            ));
        }
        if !(self.v_max.is_finite() && self.v_max > self.v_min) {
            return Err(bad(
                "v_max".into(),
                format!("{} does not exceed v_min = {}", self.v_max, self.v_min),
            ));
        }
        if self.v_end_max.is_nan() || self.v_end_max <= self.v_min {
            return Err(bad(
                "v_end_max".into(),
                format!("{} does not exceed v_min = {}", self.v_end_max, self.v_min),
            ));
        }
        if !(0.0..=MAX_STEERING_SLEW_WEIGHT).contains(&self.steering_slew_weight) {
            return Err(bad(
                "steering_slew_weight".into(),
                format!(
                    "{} is not in [0, {MAX_STEERING_SLEW_WEIGHT}] 1/s",
                    self.steering_slew_weight
                ),
            ));
        }
        if let Some(problem) = self.soft_lane.problem(n + 1) {
            return Err(bad("soft_lane".into(), problem));
        }
        self.vehicle.check()?;
        if let InitialState::Fixed(x0) = &self.initial {
            self.initial_domain(&self.kappa, &self.e_min, &self.e_max)
                .check(x0)?;
        }
        Ok(())
    }

    /// The domain of a fixed initial state on this spec's speeds and vehicle, with the
    /// node-0 road values of `kappa`, `e_min`, `e_max` (a replan brings its own road).
    pub fn initial_domain(&self, kappa: &[f64], e_min: &[f64], e_max: &[f64]) -> InitialDomain<'_> {
        InitialDomain {
            vehicle: Some(&self.vehicle),
            v: (self.v_min, self.v_max),
            e0: (
                e_min.first().copied().unwrap_or(f64::NAN),
                e_max.first().copied().unwrap_or(f64::NAN),
            ),
            kappa0: kappa.first().copied(),
        }
    }
}

/// Checks road samples: `n + 1` finite entries each, e_min < e_max at every node and both
/// bounds short of the curvature centre ([`beyond_curvature_centre`]). The error names the
/// vector and the node. Allocates only for the error.
pub fn check_road(kappa: &[f64], e_min: &[f64], e_max: &[f64], n: usize) -> Result<(), SpecError> {
    let bad = |field: String, problem: String| SpecError::Field { field, problem };
    for (name, v) in [("kappa", kappa), ("e_min", e_min), ("e_max", e_max)] {
        if v.len() != n + 1 {
            return Err(bad(
                name.into(),
                format!("{} entries, expected n_intervals + 1 = {}", v.len(), n + 1),
            ));
        }
        if let Some(k) = v.iter().position(|x| !x.is_finite()) {
            return Err(bad(
                format!("{name}[{k}]"),
                format!("{} is not finite", v[k]),
            ));
        }
    }
    if let Some(k) = (0..=n).find(|&k| e_min[k] >= e_max[k]) {
        return Err(bad(
            format!("e_min[{k}]"),
            format!("{} is not below e_max[{k}] = {}", e_min[k], e_max[k]),
        ));
    }
    for k in 0..=n {
        if let Some((name, room)) = beyond_curvature_centre(kappa[k], e_min[k], e_max[k]) {
            let e = if name == "e_min" { e_min[k] } else { e_max[k] };
            return Err(bad(
                format!("{name}[{k}]"),
                format!(
                    "{e} is at or beyond the curvature centre of kappa[{k}] = {:?} \
                     (1 - kappa e = {room:?}; the spatial dynamics need it positive)",
                    kappa[k]
                ),
            ));
        }
    }
    Ok(())
}

/// Free-mode envelope |r_0| <= 10 rad/s of the initial rows (physically never active); a
/// fixed initial state must lie within it too ([`InitialDomain`]).
pub const FREE_R0_MAX: f64 = 10.0;
/// Free-mode envelope |beta_0| <= 1.5 rad of the initial rows (physically never active); a
/// fixed initial state must lie within it too ([`InitialDomain`]).
pub const FREE_BETA0_MAX: f64 = 1.5;

/// Where a fixed initial state x_0 must lie for the model and the OCP to make sense. A
/// state outside it is refused with the entry named, instead of being handed to the
/// solver, which would spend its caps and report a failure.
#[derive(Debug, Clone, Copy)]
pub struct InitialDomain<'a> {
    /// The vehicle, for V_wr >= V_wr_min (R10) and |dFz| <= m g; `None` skips those two
    /// (a scenario file is read before its vehicle).
    pub vehicle: Option<&'a VehicleParams>,
    /// Speed bounds (v_min, v_max) [m/s].
    pub v: (f64, f64),
    /// Lateral bounds at node 0 (e_min\[0\], e_max\[0\]) \[m\].
    pub e0: (f64, f64),
    /// Road curvature at node 0 [1/m], if known.
    pub kappa0: Option<f64>,
}

impl InitialDomain<'_> {
    /// The first entry of `x0` outside the domain, as (state index, what is wrong, worded
    /// to follow the value):
    /// finite values; s_0 = t_0 = 0 (the horizon starts there); V and e within the OCP's
    /// bounds; 1 - kappa_0 e_0 > 0 (e short of the road's curvature centre); |r| and
    /// |beta| within the free-mode envelopes ([`FREE_R0_MAX`], [`FREE_BETA0_MAX`]);
    /// |dpsi| < pi/2, so the vehicle moves forward along the road (s' = V cos(dpsi) /
    /// (1 - kappa e) > 0, paper eq. 1); with the vehicle, V_wr >= V_wr_min and |dFz| <= m g.
    /// Allocates only for the error.
    pub fn problem(&self, x0: &[f64; NX]) -> Option<(usize, String)> {
        if let Some(i) = x0.iter().position(|x| !x.is_finite()) {
            return Some((i, "is not finite".into()));
        }
        let out = |i: usize, why: String| Some((i, why));
        for i in [ix::S, ix::T] {
            if x0[i] != 0.0 {
                return out(i, "must be 0 (the horizon starts at s = 0, t = 0)".into());
            }
        }
        let within = |i: usize, (lo, hi): (f64, f64), what: &str| {
            if (lo..=hi).contains(&x0[i]) {
                None
            } else {
                out(i, format!("must lie within {what}[{lo}, {hi}]"))
            }
        };
        let r_max = FREE_R0_MAX;
        let beta_max = FREE_BETA0_MAX;
        let half_pi = std::f64::consts::FRAC_PI_2;
        within(ix::V, self.v, "the speed bounds ")
            .or_else(|| within(ix::E, self.e0, "the lateral bounds at s = 0: "))
            .or_else(|| {
                let k = self.kappa0?;
                let room = 1.0 - k * x0[ix::E];
                (room <= 0.0).then(|| {
                    (ix::E, format!("is beyond the road's curvature centre (1 - kappa e = {room} at kappa = {k})"))
                })
            })
            .or_else(|| within(ix::R, (-r_max, r_max), "the yaw-rate envelope "))
            .or_else(|| within(ix::BETA, (-beta_max, beta_max), "the sideslip envelope "))
            .or_else(|| {
                (x0[ix::DPSI].abs() >= half_pi).then(|| {
                    (ix::DPSI, "is not within (-pi/2, pi/2): the vehicle must move forward along the road".into())
                })
            })
            .or_else(|| {
                let p = self.vehicle?;
                if x0[ix::VWR] < p.v_wr_min {
                    return out(
                        ix::VWR,
                        format!("must be at least V_wr_min = {} (R10)", p.v_wr_min),
                    );
                }
                let w = p.m * p.g;
                within(ix::DFZ, (-w, w), "+-m g = ")
            })
    }

    /// [`Self::problem`] as a [`SpecError`] naming `x0.<state>`.
    pub fn check(&self, x0: &[f64; NX]) -> Result<(), SpecError> {
        match self.problem(x0) {
            None => Ok(()),
            Some((i, why)) => Err(SpecError::Field {
                field: format!("x0.{}", STATE_NAMES[i]),
                problem: format!("{} {why}", x0[i]),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::params::lc500;

    fn spec() -> OcpSpec {
        OcpSpec {
            name: "t".into(),
            n_intervals: 4,
            length: 10.0,
            kappa: vec![0.0; 5],
            e_min: vec![-2.0; 5],
            e_max: vec![2.0; 5],
            v_min: 1.0,
            v_max: 60.0,
            enforce_tire_saturation: true,
            saturation_at_end: false,
            steering_slew_weight: 0.0,
            v_end_max: f64::INFINITY,
            soft_lane: SoftLane::OFF,
            initial: InitialState::Free,
            vehicle: lc500(),
        }
    }

    /// The message of the check's error for a spec changed by `f`.
    fn refused(f: impl Fn(&mut OcpSpec)) -> String {
        let mut s = spec();
        f(&mut s);
        s.check().expect_err("must be refused").to_string()
    }

    #[test]
    fn a_sound_spec_passes_and_each_broken_field_is_named() {
        assert_eq!(spec().check(), Ok(()));
        assert!(refused(|s| s.n_intervals = 0).contains("n_intervals"));
        assert!(refused(|s| s.length = f64::NAN).contains("length"));
        assert!(refused(|s| s.kappa.pop().map_or((), |_| ())).contains("kappa"));
        assert!(refused(|s| s.kappa[2] = f64::INFINITY).contains("kappa[2]"));
        assert!(refused(|s| s.steering_slew_weight = -1.0).contains("steering_slew_weight"));
        assert!(refused(|s| s.steering_slew_weight = f64::NAN).contains("steering_slew_weight"));
        assert!(
            refused(|s| s.steering_slew_weight = f64::INFINITY).contains("steering_slew_weight")
        );
        assert!(refused(|s| s.steering_slew_weight = 1001.0).contains("steering_slew_weight"));
        assert!(refused(|s| s.e_min[3] = 2.0).contains("e_min[3]"));
        assert!(refused(|s| s.kappa[1] = 1e308).contains("e_max[1]"));
        assert!(refused(|s| s.kappa[4] = -0.5).contains("e_min[4]"));
        assert!(refused(|s| s.kappa[0] = 0.5).contains("curvature centre"));
        assert!(refused(|s| s.v_min = 0.0).contains("v_min"));
        assert!(refused(|s| s.v_end_max = f64::NAN).contains("v_end_max"));
        assert!(refused(|s| s.v_end_max = 1.0).contains("v_end_max"));
        assert!(refused(|s| s.v_max = 0.5).contains("v_max"));
        assert!(refused(|s| s.initial = InitialState::Fixed([f64::NAN; NX])).contains("x0.r"));
        assert!(refused(|s| s.vehicle.c_f = -1.0).contains("tire.C_f"));
    }

    /// A steady straight-line state at 20 m/s in the lane centre.
    fn cruise() -> [f64; NX] {
        let mut x = [0.0; NX];
        x[ix::V] = 20.0;
        x[ix::VWR] = 20.0;
        x
    }

    /// The message for a fixed initial state `cruise()` changed at `i` to `v`.
    fn refused_x0(i: usize, v: f64) -> String {
        let mut x = cruise();
        x[i] = v;
        refused(|s| s.initial = InitialState::Fixed(x))
    }

    #[test]
    fn a_fixed_initial_state_outside_the_models_domain_is_refused_by_name() {
        let mut s = spec();
        s.initial = InitialState::Fixed(cruise());
        assert_eq!(s.check(), Ok(()));
        for (i, v, field) in [
            (ix::S, 1.0, "x0.s"),
            (ix::T, -0.5, "x0.t"),
            (ix::V, 0.5, "x0.V"),
            (ix::V, 61.0, "x0.V"),
            (ix::E, 2.5, "x0.e"),
            (ix::R, 10.5, "x0.r"),
            (ix::BETA, -1.6, "x0.beta"),
            (ix::DPSI, 100.0, "x0.dpsi"),
            (ix::DPSI, -std::f64::consts::FRAC_PI_2, "x0.dpsi"),
            (ix::VWR, -5.0, "x0.V_wr"),
            (ix::DFZ, 1e6, "x0.dFz"),
        ] {
            let msg = refused_x0(i, v);
            assert!(msg.contains(field), "{field} = {v}: {msg}");
        }
        // Just inside every bound passes.
        for (i, v) in [
            (ix::R, -10.0),
            (ix::BETA, 1.5),
            (ix::DPSI, 1.57),
            (ix::VWR, 0.0),
        ] {
            let mut s = spec();
            let mut x = cruise();
            x[i] = v;
            s.initial = InitialState::Fixed(x);
            assert_eq!(s.check(), Ok(()), "{i} = {v}");
        }
        // On a curve of radius 1.5 m (kappa = 1/1.5), e = 1.6 is past the centre.
        let mut s = spec();
        s.kappa[0] = 1.0 / 1.5;
        let mut x = cruise();
        x[ix::E] = 1.6;
        s.initial = InitialState::Fixed(x);
        assert!(s
            .check()
            .expect_err("past the centre")
            .to_string()
            .contains("curvature centre"));
        // Without a vehicle, V_wr and dFz are not judged.
        let d = InitialDomain {
            vehicle: None,
            v: (1.0, 60.0),
            e0: (-2.0, 2.0),
            kappa0: None,
        };
        let mut x = cruise();
        x[ix::VWR] = -5.0;
        x[ix::DFZ] = 1e6;
        assert_eq!(d.problem(&x), None);
    }
}
