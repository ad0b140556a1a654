//! The closed road both processes drive on: exact piecewise-constant curvature of the
//! scenario (`[track] kappa_pieces`), wrapped modulo the lap, plus the lane bounds; and
//! the scenario as a whole (OCP template, solver settings, road id).

use std::path::{Path, PathBuf};

use planner::config::{load_scenario, load_solver, load_vehicle, ConfigError};
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

    /// Lap length [m].
    pub fn lap(&self) -> f64 {
        self.lap
    }

    /// Right lane edge [m].
    pub fn e_min(&self) -> f64 {
        self.e_min
    }

    /// Left lane edge [m].
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
    /// Right bound at the nodes [m].
    pub e_min: [f64; HORIZON_N + 1],
    /// Left bound at the nodes [m].
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
        let spec = load_scenario(scenario, None, vehicle)?;
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
        if !(lap.is_finite() && lap > 0.0 && e_min < e_max && !pieces.is_empty()) {
            return Err(unsupported(
                "need lap_length_m > 0, e_min_m < e_max_m and some kappa_pieces",
            ));
        }
        Ok(Self {
            spec,
            settings,
            road: ClosedRoad::new(pieces, lap, e_min, e_max),
            id: fnv1a(&bytes),
        })
    }

    /// Node spacing of the planning horizon [m].
    pub fn ds(&self) -> f64 {
        self.spec.ds()
    }
}
