//! The problem data of one OCP instance (paper eq. 3): road sampled at the nodes, bounds,
//! options and the vehicle. Built from config + track; consumed by a transcription.

use crate::model::{ParamError, VehicleParams, NX};

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
    /// Horizon length [m]; s_N = length.
    pub length: f64,
    /// Reference curvature k_ref(s_k) at every node [1/m] (R8: evaluated at the grid).
    pub kappa: Vec<f64>,
    /// Right lateral bound e_min(s_k) at every node [m] (obstacles already applied).
    pub e_min: Vec<f64>,
    /// Left lateral bound e_max(s_k) at every node [m] (obstacles already applied).
    pub e_max: Vec<f64>,
    /// Speed lower bound [m/s].
    pub v_min: f64,
    /// Speed upper bound [m/s].
    pub v_max: f64,
    /// Add the tire saturation constraints (R5) when true.
    pub enforce_tire_saturation: bool,
    /// Initial state treatment.
    pub initial: InitialState,
    /// Vehicle parameters.
    pub vehicle: VehicleParams,
}

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
    /// Node spacing ds = length / N [m].
    pub fn ds(&self) -> f64 {
        self.length / self.n_intervals as f64
    }

    /// Checks what the transcription and the guess rely on: N >= 1, a finite positive
    /// length, finite per-node vectors of N + 1 entries with e_min < e_max at every node,
    /// 0 < v_min < v_max, a finite fixed initial state, and the vehicle's own domain
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
        for (name, v) in [
            ("kappa", &self.kappa),
            ("e_min", &self.e_min),
            ("e_max", &self.e_max),
        ] {
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
        if let Some(k) = (0..=n).find(|&k| self.e_min[k] >= self.e_max[k]) {
            return Err(bad(
                format!("e_min[{k}]"),
                format!(
                    "{} is not below e_max[{k}] = {}",
                    self.e_min[k], self.e_max[k]
                ),
            ));
        }
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
        if let InitialState::Fixed(x0) = &self.initial {
            if let Some(i) = x0.iter().position(|x| !x.is_finite()) {
                return Err(bad(format!("x0[{i}]"), format!("{} is not finite", x0[i])));
            }
        }
        self.vehicle.check()?;
        Ok(())
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
        assert!(refused(|s| s.e_min[3] = 2.0).contains("e_min[3]"));
        assert!(refused(|s| s.v_min = 0.0).contains("v_min"));
        assert!(refused(|s| s.v_max = 0.5).contains("v_max"));
        assert!(refused(|s| s.initial = InitialState::Fixed([f64::NAN; NX])).contains("x0[0]"));
        assert!(refused(|s| s.vehicle.c_f = -1.0).contains("tire.C_f"));
    }
}
