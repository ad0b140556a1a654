//! The plant mismatch: how the simulated car differs from the planner's model.
//!
//! Vehicle parameters of the plant are the vehicle file's scaled by (1 + change):
//! mu' = mu (1 + friction), m' = m (1 + mass), I_z' = I_z (1 + yaw_inertia),
//! C_f' = C_f (1 + cornering_stiffness), C_r' = C_r (1 + cornering_stiffness). The
//! actuators add a first-order steering lag tau (delta_dot = (delta_cmd - delta) / tau) and
//! a transport delay on all controls ([`crate::plant::actuator`]); the measured state is the
//! true one plus zero-mean Gaussian noise of the given standard deviations
//! ([`crate::plant::noise`]).
//!
//! `--mismatch none` is every value zero, `--mismatch default` is
//! `config/mismatch/default.toml` (compiled in), `--mismatch FILE.toml` a file with the
//! same fields, checked here: unknown keys are refused and every value must lie in its
//! range; errors name the file and the field.

use std::path::Path;

use planner::model::{ix, VehicleParams, NX};
use serde::{Deserialize, Serialize};

/// The default mismatch file's text (`config/mismatch/default.toml`).
pub const DEFAULT_TOML: &str = include_str!("../../config/mismatch/default.toml");

/// Relative changes of the plant's vehicle parameters (0: as in the vehicle file).
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleChange {
    /// Relative change of the tire-road friction coefficient mu [-].
    pub friction: f64,
    /// Relative change of the mass m [-].
    pub mass: f64,
    /// Relative change of the yaw inertia I_z [-].
    pub yaw_inertia: f64,
    /// Relative change of both axles' cornering (slip) stiffness C_f, C_r [-].
    pub cornering_stiffness: f64,
}

/// Actuator dynamics between the tracker's command and the plant.
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorSpec {
    /// Time constant of the first-order steering lag \[s\] (0: none).
    pub steering_lag_s: f64,
    /// Transport delay on all controls \[s\] (0: none); rounded to whole control periods.
    pub transport_delay_s: f64,
}

/// Standard deviations of the Gaussian noise on the measured state (0: exact).
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSpec {
    /// Yaw rate r [rad/s].
    pub r_radps: f64,
    /// Speed V [m/s].
    pub v_mps: f64,
    /// Sideslip beta \[rad\].
    pub beta_rad: f64,
    /// Rear wheel speed V_wr [m/s].
    pub v_wr_mps: f64,
    /// Load transfer dFz \[N\].
    pub dfz_n: f64,
    /// Lateral offset e \[m\].
    pub e_m: f64,
    /// Heading error dpsi \[rad\].
    pub dpsi_rad: f64,
}

impl NoiseSpec {
    /// Standard deviation per state in x order (s and t are measured exactly).
    pub fn sigma(&self) -> [f64; NX] {
        let mut s = [0.0; NX];
        s[ix::R] = self.r_radps;
        s[ix::V] = self.v_mps;
        s[ix::BETA] = self.beta_rad;
        s[ix::VWR] = self.v_wr_mps;
        s[ix::DFZ] = self.dfz_n;
        s[ix::E] = self.e_m;
        s[ix::DPSI] = self.dpsi_rad;
        s
    }
}

/// A mismatch setting: vehicle changes, actuator dynamics and measurement noise.
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Mismatch {
    /// Vehicle parameter changes.
    pub vehicle: VehicleChange,
    /// Actuator lag and delay.
    pub actuator: ActuatorSpec,
    /// Measurement noise.
    pub noise: NoiseSpec,
}

/// A mismatch file that cannot be used; the message names the file and the field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{source_name}: {msg}")]
pub struct MismatchError {
    /// The file (or `default`).
    pub source_name: String,
    /// What is wrong, naming the field.
    pub msg: String,
}

/// Range of every field: (name as in the file, value, min, max).
fn ranges(m: &Mismatch) -> [(&'static str, f64, f64, f64); 13] {
    let (v, a, n) = (&m.vehicle, &m.actuator, &m.noise);
    [
        ("vehicle.friction", v.friction, -0.5, 0.5),
        ("vehicle.mass", v.mass, -0.5, 1.0),
        ("vehicle.yaw_inertia", v.yaw_inertia, -0.5, 1.0),
        (
            "vehicle.cornering_stiffness",
            v.cornering_stiffness,
            -0.5,
            1.0,
        ),
        ("actuator.steering_lag_s", a.steering_lag_s, 0.0, 0.5),
        ("actuator.transport_delay_s", a.transport_delay_s, 0.0, 0.2),
        ("noise.r_radps", n.r_radps, 0.0, 0.5),
        ("noise.v_mps", n.v_mps, 0.0, 2.0),
        ("noise.beta_rad", n.beta_rad, 0.0, 0.1),
        ("noise.v_wr_mps", n.v_wr_mps, 0.0, 2.0),
        ("noise.dfz_n", n.dfz_n, 0.0, 2000.0),
        ("noise.e_m", n.e_m, 0.0, 1.0),
        ("noise.dpsi_rad", n.dpsi_rad, 0.0, 0.2),
    ]
}

impl Mismatch {
    /// No mismatch: the plant is the model, controls act at once, the state is exact.
    pub fn none() -> Self {
        Self::default()
    }

    /// Parses and checks a mismatch file's text; `source_name` names it in errors.
    pub fn parse(text: &str, source_name: &str) -> Result<Self, MismatchError> {
        let err = |msg: String| MismatchError {
            source_name: source_name.to_string(),
            msg,
        };
        let m: Mismatch = toml::from_str(text).map_err(|e| err(e.to_string()))?;
        for (field, value, lo, hi) in ranges(&m) {
            if !(value.is_finite() && (lo..=hi).contains(&value)) {
                return Err(err(format!(
                    "{field} = {value}: must be a finite number in [{lo}, {hi}]"
                )));
            }
        }
        Ok(m)
    }

    /// The mismatch named on the command line: `none`, `default`, or a TOML file.
    pub fn from_arg(arg: &str) -> Result<Self, MismatchError> {
        match arg {
            "none" => Ok(Self::none()),
            "default" => Self::parse(DEFAULT_TOML, "config/mismatch/default.toml"),
            path => {
                let text = std::fs::read_to_string(Path::new(path)).map_err(|e| MismatchError {
                    source_name: path.to_string(),
                    msg: e.to_string(),
                })?;
                Self::parse(&text, path)
            }
        }
    }

    /// The plant's vehicle parameters: `p` with the relative changes applied.
    pub fn apply(&self, p: &VehicleParams) -> VehicleParams {
        let v = &self.vehicle;
        let mut q = *p;
        q.mu *= 1.0 + v.friction;
        q.m *= 1.0 + v.mass;
        q.i_z *= 1.0 + v.yaw_inertia;
        q.c_f *= 1.0 + v.cornering_stiffness;
        q.c_r *= 1.0 + v.cornering_stiffness;
        q
    }

    /// The values as JSON (the tracker's report).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }
}

/// Adds the plant's settings to a tracker report: `mismatch` (the name as given: `none`,
/// `default` or the file path), `mismatch_values` (the values used), `plant_vehicle`
/// (the file, or null for the planner's), `noise_seed` and `feedforward_preview_s`.
pub fn add_to_report(
    obj: &mut serde_json::Value,
    name: &str,
    m: &Mismatch,
    plant_vehicle: Option<&Path>,
    noise_seed: u64,
    preview_s: f64,
) {
    if let Some(map) = obj.as_object_mut() {
        map.insert("mismatch".into(), name.into());
        map.insert("mismatch_values".into(), m.to_json());
        map.insert(
            "plant_vehicle".into(),
            plant_vehicle.map_or(serde_json::Value::Null, |p| p.display().to_string().into()),
        );
        map.insert("noise_seed".into(), noise_seed.into());
        map.insert("feedforward_preview_s".into(), preview_s.into());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_file_holds_the_stated_mismatch() {
        let m = Mismatch::from_arg("default").unwrap();
        assert_eq!(m.vehicle.friction, -0.05);
        assert_eq!(m.vehicle.mass, 0.05);
        assert_eq!(m.vehicle.yaw_inertia, 0.10);
        assert_eq!(m.vehicle.cornering_stiffness, -0.10);
        assert_eq!(m.actuator.steering_lag_s, 0.05);
        assert_eq!(m.actuator.transport_delay_s, 0.02);
        assert_eq!(m.noise.e_m, 0.05);
        assert_eq!(m.noise.dpsi_rad, 0.01);
        assert_eq!(m.noise.v_mps, 0.1);
        let sigma = m.noise.sigma();
        assert_eq!((sigma[ix::S], sigma[ix::T]), (0.0, 0.0));
    }

    #[test]
    fn none_is_every_value_zero_and_leaves_the_vehicle_as_it_is() {
        let m = Mismatch::from_arg("none").unwrap();
        assert_eq!(m, Mismatch::default());
        assert!(m.noise.sigma().iter().all(|&s| s == 0.0));
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let p = planner::config::load_vehicle(&root.join("config/vehicles/lc500.toml")).unwrap();
        assert_eq!(m.apply(&p), p);
    }

    #[test]
    fn the_default_mismatch_scales_friction_mass_inertia_and_stiffness() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let p = planner::config::load_vehicle(&root.join("config/vehicles/lc500.toml")).unwrap();
        let q = Mismatch::from_arg("default").unwrap().apply(&p);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        assert!(close(q.mu, 0.95 * p.mu));
        assert!(close(q.m, 1.05 * p.m));
        assert!(close(q.i_z, 1.10 * p.i_z));
        assert!(close(q.c_f, 0.90 * p.c_f) && close(q.c_r, 0.90 * p.c_r));
        assert_eq!((q.a, q.b, q.delta_max), (p.a, p.b, p.delta_max));
        assert!(q.check().is_ok());
    }

    #[test]
    fn an_unknown_key_is_refused_naming_the_file_and_the_key() {
        let text = DEFAULT_TOML.replace("mass = 0.05", "mass = 0.05\nmas = 0.1");
        let e = Mismatch::parse(&text, "my_car.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("my_car.toml: "), "{e}");
        assert!(e.contains("unknown field") && e.contains("mas"), "{e}");
        let text = DEFAULT_TOML.replace("[noise]", "[noise]\nsteering = 1.0");
        let e = Mismatch::parse(&text, "my_car.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("steering"), "{e}");
    }

    #[test]
    fn an_out_of_range_value_is_refused_naming_the_file_and_the_field() {
        for (from, to, field) in [
            ("friction = -0.05", "friction = -0.9", "vehicle.friction"),
            (
                "steering_lag_s = 0.05",
                "steering_lag_s = -0.01",
                "actuator.steering_lag_s",
            ),
            ("e_m = 0.05", "e_m = nan", "noise.e_m"),
            (
                "transport_delay_s = 0.02",
                "transport_delay_s = 3.0",
                "actuator.transport_delay_s",
            ),
        ] {
            let text = DEFAULT_TOML.replace(from, to);
            assert_ne!(text, DEFAULT_TOML);
            let e = Mismatch::parse(&text, "bad.toml").unwrap_err().to_string();
            assert!(e.starts_with("bad.toml: ") && e.contains(field), "{e}");
        }
    }

    #[test]
    fn a_missing_field_or_file_is_named() {
        let text = DEFAULT_TOML.replace("dpsi_rad = 0.01", "");
        let e = Mismatch::parse(&text, "short.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("short.toml") && e.contains("dpsi_rad"), "{e}");
        let e = Mismatch::from_arg("/nonexistent/mismatch.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("/nonexistent/mismatch.toml: "), "{e}");
    }
}
