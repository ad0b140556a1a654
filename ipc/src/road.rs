//! The closed road both processes drive on: exact piecewise-constant curvature of the
//! scenario (`[track] kappa_pieces`), wrapped modulo the lap, plus the lane bounds; and
//! the scenario as a whole (OCP template, solver settings, road id).

use std::path::{Path, PathBuf};

use planner::config::{load_scenario_for_horizon, load_solver, load_vehicle, ConfigError};
use planner::ip::Settings;
use planner::ocp::OcpSpec;
use planner::track::piecewise_constant;
use serde::Deserialize;

use crate::msg::{fnv1a, RoadId, HORIZON_N};

/// Why a scenario cannot be used for the closed loop.
#[derive(Debug, thiserror::Error)]
pub enum RoadError {
    /// The planner's config loader rejected a file.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A file could not be read.
    #[error("{path}: {msg}")]
    Read {
        /// File.
        path: PathBuf,
        /// Reason.
        msg: String,
    },
    /// The scenario is not a closed road with N = 100.
    #[error("{path}: {msg}")]
    Unsupported {
        /// File.
        path: PathBuf,
        /// Reason.
        msg: String,
    },
}

#[derive(Deserialize)]
struct ClosedToml {
    geometry: Option<GeometryToml>,
    track: Option<TrackToml>,
}

#[derive(Deserialize)]
struct GeometryToml {
    lap_length_m: Option<f64>,
}

#[derive(Deserialize)]
struct TrackToml {
    kappa_pieces: Option<Vec<Vec<f64>>>,
    e_min_m: Option<f64>,
    e_max_m: Option<f64>,
}

/// A closed road: curvature k_ref(s mod lap) and constant lane bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedRoad {
    pieces: Vec<(f64, f64)>,
    lap: f64,
    e_min: f64,
    e_max: f64,
}

impl ClosedRoad {
    /// A road from pieces (s_start, kappa), a lap length and lane bounds (no checks).
    pub fn new(pieces: Vec<(f64, f64)>, lap: f64, e_min: f64, e_max: f64) -> Self {
        Self {
            pieces,
            lap,
            e_min,
            e_max,
        }
    }

    /// k_ref at track arc length s (any real s; wraps modulo the lap) [1/m].
    pub fn kappa(&self, s: f64) -> f64 {
        piecewise_constant(&self.pieces, s.rem_euclid(self.lap))
    }

    /// Lap length \[m\].
    pub fn lap(&self) -> f64 {
        self.lap
    }

    /// Right lane edge \[m\].
    pub fn e_min(&self) -> f64 {
        self.e_min
    }

    /// Left lane edge \[m\].
    pub fn e_max(&self) -> f64 {
        self.e_max
    }

    /// Road ahead of track s0 at the N + 1 nodes s0 + k ds, lane shrunk by `margin` on
    /// both sides; the margin ramps in linearly over the first `ramp` metres so a car that
    /// is already inside the margin can still be planned for. Allocates nothing.
    pub fn window(&self, s0: f64, ds: f64, margin: f64, ramp: f64, out: &mut RoadWindow) {
        let RoadWindow {
            kappa,
            e_min,
            e_max,
        } = out;
        for k in 0..=HORIZON_N {
            kappa[k] = self.kappa(s0 + k as f64 * ds);
            let s = k as f64 * ds;
            let m = if ramp > 0.0 {
                margin * (s / ramp).min(1.0)
            } else {
                margin
            };
            e_min[k] = self.e_min + m;
            e_max[k] = self.e_max - m;
        }
    }
}

/// The road at the N + 1 nodes of one planning horizon (fixed size, no heap).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadWindow {
    /// k_ref at the nodes [1/m].
    pub kappa: [f64; HORIZON_N + 1],
    /// Right bound at the nodes \[m\].
    pub e_min: [f64; HORIZON_N + 1],
    /// Left bound at the nodes \[m\].
    pub e_max: [f64; HORIZON_N + 1],
}

impl Default for RoadWindow {
    fn default() -> Self {
        Self {
            kappa: [0.0; HORIZON_N + 1],
            e_min: [0.0; HORIZON_N + 1],
            e_max: [0.0; HORIZON_N + 1],
        }
    }
}

/// Everything both processes load from the command line's files.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// OCP template (horizon, bounds, vehicle); its road and initial state are replaced per plan.
    pub spec: OcpSpec,
    /// Solver settings.
    pub settings: Settings,
    /// The closed road.
    pub road: ClosedRoad,
    /// Road id (hash of the scenario file).
    pub id: RoadId,
}

impl Scenario {
    /// Loads scenario, vehicle and solver files; the scenario must be a closed road
    /// (`[geometry] lap_length_m`, `[track] kappa_pieces`) with N = 100.
    pub fn load(scenario: &Path, vehicle: &Path, solver: &Path) -> Result<Self, RoadError> {
        let vehicle = load_vehicle(vehicle)?;
        let spec = load_scenario_for_horizon(scenario, None, vehicle, planner::HORIZON)?;
        let settings = load_solver(solver)?;
        let bytes = std::fs::read(scenario).map_err(|e| RoadError::Read {
            path: scenario.to_path_buf(),
            msg: e.to_string(),
        })?;
        let unsupported = |msg: &str| RoadError::Unsupported {
            path: scenario.to_path_buf(),
            msg: msg.to_string(),
        };
        if spec.n_intervals != HORIZON_N {
            return Err(unsupported("the closed loop needs n_intervals = 100"));
        }
        let text = String::from_utf8_lossy(&bytes);
        let file: ClosedToml = toml::from_str(&text).map_err(|e| RoadError::Read {
            path: scenario.to_path_buf(),
            msg: e.to_string(),
        })?;
        let need = "the closed loop needs a closed road: [geometry] lap_length_m and [track] kappa_pieces, e_min_m, e_max_m";
        let lap = file
            .geometry
            .and_then(|g| g.lap_length_m)
            .ok_or_else(|| unsupported(need))?;
        let track = file.track.ok_or_else(|| unsupported(need))?;
        let (Some(raw), Some(e_min), Some(e_max)) =
            (track.kappa_pieces, track.e_min_m, track.e_max_m)
        else {
            return Err(unsupported(need));
        };
        let mut pieces = Vec::with_capacity(raw.len());
        for p in &raw {
            match p.as_slice() {
                [s, k] if s.is_finite() && k.is_finite() => pieces.push((*s, *k)),
                _ => {
                    return Err(unsupported(
                        "kappa_pieces entries must be [s_m, kappa] pairs",
                    ))
                }
            }
        }
        if !(lap.is_finite() && lap > 0.0) {
            return Err(unsupported(&format!(
                "[geometry] lap_length_m = {lap}: must be a finite positive length"
            )));
        }
        if !(e_min.is_finite() && e_max.is_finite() && e_min < e_max) {
            return Err(unsupported(&format!(
                "[track] e_min_m = {e_min} must be below e_max_m = {e_max} (both finite)"
            )));
        }
        if pieces.is_empty() {
            return Err(unsupported("[track] kappa_pieces is empty"));
        }
        // Starts must be ascending from 0: the curvature is looked up at s mod lap among
        // ascending starts. Pieces from the lap length on describe an open horizon run past
        // one lap (the oval's last piece starts exactly at the lap); the closed road wraps
        // instead, so it drops them.
        for (i, &(s0, _)) in pieces.iter().enumerate() {
            if s0 < 0.0 {
                return Err(unsupported(&format!(
                    "[track] kappa_pieces[{i}] starts at s = {s0} m, before the start of the lap"
                )));
            }
            if i > 0 && s0 <= pieces[i - 1].0 {
                return Err(unsupported(&format!(
                    "[track] kappa_pieces[{i}] starts at s = {s0} m, not after the previous piece ({} m)",
                    pieces[i - 1].0
                )));
            }
        }
        pieces.retain(|&(s0, _)| s0 < lap);
        if pieces.is_empty() {
            return Err(unsupported(&format!(
                "[track] no kappa_pieces entry starts within the lap [0, {lap})"
            )));
        }
        Ok(Self {
            spec,
            settings,
            road: ClosedRoad::new(pieces, lap, e_min, e_max),
            id: fnv1a(&bytes),
        })
    }

    /// Node spacing of the planning horizon \[m\].
    pub fn ds(&self) -> f64 {
        self.spec.ds()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    /// Loads the oval with its `kappa_pieces` block replaced by `pieces`.
    fn oval_with(name: &str, pieces: &str) -> Result<Scenario, RoadError> {
        let text = std::fs::read_to_string(root().join("config/scenarios/oval.toml")).unwrap();
        let start = text.find("kappa_pieces = [").unwrap();
        let end = start + text[start..].find("\n]\n").unwrap() + 3;
        let text = format!(
            "{}kappa_pieces = {pieces}\n{}",
            &text[..start],
            &text[end..]
        );
        // A data root of its own (scenarios/ with the profile CSV the file names).
        let dir = std::env::temp_dir().join(format!("road_test_{name}_{}", std::process::id()));
        std::fs::create_dir_all(dir.join("scenarios")).unwrap();
        std::fs::copy(
            root().join("config/scenarios/oval_profile.csv"),
            dir.join("scenarios/oval_profile.csv"),
        )
        .unwrap();
        let path = dir.join("scenarios/oval.toml");
        std::fs::write(&path, text).unwrap();
        let sc = Scenario::load(
            &path,
            &root().join("config/vehicles/lc500.toml"),
            &root().join("config/solver.toml"),
        );
        let _ = std::fs::remove_dir_all(&dir);
        sc
    }

    #[test]
    fn the_oval_closes_and_drops_the_piece_past_the_lap() {
        let sc = oval_with("ok", "[[0.0, 0.0], [50.0, 0.04], [128.5398163, 0.0], [178.5398163, 0.04], [257.0796327, 0.0]]")
            .expect("the oval loads");
        assert_eq!(sc.road.kappa(60.0), 0.04);
        assert_eq!(sc.road.kappa(257.0796327 + 10.0), 0.0);
        assert_eq!(sc.road.kappa(257.0796327 + 60.0), 0.04);
    }

    #[test]
    fn unordered_or_negative_pieces_are_refused_by_index() {
        let Err(e) = oval_with("order", "[[0.0, 0.0], [128.5, 0.0], [50.0, 0.04]]") else {
            panic!("refused")
        };
        let e = e.to_string();
        assert!(e.contains("kappa_pieces"), "{e}");
        let Err(e) = oval_with("neg", "[[-5.0, 0.0], [50.0, 0.04]]") else {
            panic!("refused")
        };
        let e = e.to_string();
        assert!(e.contains("kappa_pieces"), "{e}");
    }
}
