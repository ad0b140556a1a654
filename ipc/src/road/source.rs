//! Where the road comes from: the options both processes share (`--track`,
//! `--track-profile` with `--lap-length-m`, `--segment` of an obstacle scenario) and the
//! loading of a track profile or an obstacle scenario into a [`Scenario`].
//!
//! A track's planning problem is the race-segment OCP (`config/scenarios/segments.toml`
//! defaults: N = 100 over 250 m, tire saturation on, steering-slew weight 1 1/s) whose
//! road is the profile's window ahead of the car, with the speed capped at
//! `--track-v-max-mps` (default 55 m/s). The OCP's end state is free, so a plan only
//! brakes for the corners inside its 250 m window; the planner process bounds the last
//! node's speed by the road's speed envelope (`--end-speed-envelope`, [`super::envelope`])
//! so that a plan never ends closer to a curve than its braking distance. The cap keeps
//! that bound within reach: from 55 m/s the car can brake to rest inside the window at
//! 6 m/s^2, from 70 m/s only at 9.8 m/s^2, and at 70 m/s the flying laps left the track
//! (docs/performance.md). The road id hashes
//! the profile's bytes and the lap length, so processes given different tracks refuse
//! each other's messages.

use std::path::{Path, PathBuf};

use planner::config::{load_scenario_for_horizon, load_solver, load_track_index, load_vehicle};
use planner::model::VehicleParams;
use planner::ocp::{InitialState, OcpSpec};
use planner::track::{BoundsOverride, Profile};
use serde::Deserialize;

use super::{ClosedRoad, RoadError, RoadWindow, Scenario};
use crate::msg::{fnv1a, HORIZON_N};

/// Planning horizon on a track \[m\] (N = 100 intervals of 2.5 m).
pub const TRACK_HORIZON_M: f64 = 250.0;
/// Speed bounds of the planner on a track [m/s] (the upper one is the default of
/// `--track-v-max-mps`).
pub const TRACK_SPEEDS_MPS: (f64, f64) = (5.0, 55.0);
/// Steering-slew weight of the planner on a track [1/s].
pub const TRACK_SLEW_WEIGHT: f64 = 1.0;

/// The road options both processes take (they must be given the same ones).
// clap prints these doc comments as the --help text: unit brackets stay unescaped.
#[allow(rustdoc::broken_intra_doc_links)]
#[derive(clap::Args, Debug, Clone)]
pub struct RoadArgs {
    /// Drive this closed track (a name in the track index, e.g. Austin) instead of --scenario.
    #[arg(long, conflicts_with_all = ["track_profile", "segment"])]
    pub track: Option<String>,
    /// Track index --track looks the name up in.
    #[arg(long, default_value = "config/tracks/tracks.toml")]
    pub tracks_index: PathBuf,
    /// Drive a closed track profile of one's own (CSV columns s_m,kappa_1pm,w_right_m,w_left_m
    /// on a uniform grid from s = 0), periodic with --lap-length-m.
    #[arg(long, requires = "lap_length_m", conflicts_with = "segment")]
    pub track_profile: Option<PathBuf>,
    /// Lap length of --track-profile [m] (in (s_last, s_last + step]).
    #[arg(long, requires = "track_profile")]
    pub lap_length_m: Option<f64>,
    /// Scenario of an obstacle file (--scenario config/scenarios/collision_avoidance.toml:
    /// forgiving or critical) driven on its open road with the obstacles fixed.
    #[arg(long)]
    pub segment: Option<String>,
    /// Tire-saturation constraints of the planner (default: the scenario's; on for tracks).
    #[arg(long, value_parser = ["on", "off"])]
    pub tire_saturation: Option<String>,
    /// How far the planner's obstacle bounds reach past each obstacle's s interval [m]
    /// (default: half the car's body length, so the CG bound holds while any part of the
    /// body is alongside; 0: the scenario's bound at the CG only).
    #[arg(long, default_value_t = 0.5 * crate::road::footprint::CAR_LENGTH_M)]
    pub obstacle_reach_m: f64,
    /// Speed cap of the planner on a track [m/s] (the braking from it to the slowest
    /// corner must fit the 250 m window).
    #[arg(long, default_value_t = TRACK_SPEEDS_MPS.1)]
    pub track_v_max_mps: f64,
}

impl Default for RoadArgs {
    /// The command line's defaults: the scenario's road.
    fn default() -> Self {
        Self {
            track: None,
            tracks_index: PathBuf::from("config/tracks/tracks.toml"),
            track_profile: None,
            lap_length_m: None,
            segment: None,
            tire_saturation: None,
            obstacle_reach_m: 0.5 * crate::road::footprint::CAR_LENGTH_M,
            track_v_max_mps: TRACK_SPEEDS_MPS.1,
        }
    }
}

/// Which road the options name.
enum Source<'a> {
    /// A closed-road scenario file (the oval).
    Closed,
    /// A track profile with its lap length and name.
    Track(PathBuf, f64, String),
    /// Scenario `name` of an obstacle file.
    Swerve(&'a str),
}

fn read_err(path: &Path, msg: impl std::fmt::Display) -> RoadError {
    RoadError::Read {
        path: path.to_path_buf(),
        msg: msg.to_string(),
    }
}

fn unsupported(path: &Path, msg: impl Into<String>) -> RoadError {
    RoadError::Unsupported {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

impl RoadArgs {
    /// Resolves the options to a road source (looks a track name up in the index).
    fn source(&self) -> Result<Source<'_>, RoadError> {
        if let Some(name) = &self.track {
            let index = load_track_index(&self.tracks_index)?;
            let Some(t) = index.iter().find(|t| &t.name == name) else {
                let names: Vec<&str> = index.iter().map(|t| t.name.as_str()).collect();
                return Err(unsupported(
                    &self.tracks_index,
                    format!("--track {name}: no such track (have: {})", names.join(", ")),
                ));
            };
            return Ok(Source::Track(
                t.profile_csv.clone(),
                t.lap_length,
                t.name.clone(),
            ));
        }
        if let (Some(p), Some(lap)) = (&self.track_profile, self.lap_length_m) {
            let name = p
                .file_stem()
                .map_or("track".into(), |s| s.to_string_lossy().into_owned());
            let name = name.strip_suffix("_profile").unwrap_or(&name).to_string();
            return Ok(Source::Track(p.clone(), lap, name));
        }
        if self.track_profile.is_some() || self.lap_length_m.is_some() {
            return Err(unsupported(
                Path::new("--track-profile"),
                "--track-profile and --lap-length-m go together",
            ));
        }
        Ok(match &self.segment {
            Some(s) => Source::Swerve(s),
            None => Source::Closed,
        })
    }

    /// The file the road comes from: the track profile, else the scenario file.
    pub fn road_file(&self, scenario: &Path) -> PathBuf {
        match self.source() {
            Ok(Source::Track(p, _, _)) => p,
            _ => scenario.to_path_buf(),
        }
    }

    /// The road's display name: the track's, the scenario segment's, or the scenario file's stem.
    pub fn road_name(&self, scenario: &Path) -> String {
        match self.source() {
            Ok(Source::Track(_, _, name)) => name,
            Ok(Source::Swerve(seg)) => format!("swerve_{seg}"),
            _ => scenario
                .file_stem()
                .map_or("road".into(), |s| s.to_string_lossy().into_owned()),
        }
    }
}

impl Scenario {
    /// Loads the road the options name (a track, an obstacle scenario, or else the closed
    /// road of `scenario`), the vehicle and the solver settings. Every bad file or option
    /// is an error naming the file and the row or field, before anything runs.
    pub fn load_with(
        scenario: &Path,
        road: &RoadArgs,
        vehicle: &Path,
        solver: &Path,
    ) -> Result<Self, RoadError> {
        let mut sc = match road.source()? {
            Source::Closed => Self::load(scenario, vehicle, solver)?,
            Source::Track(profile, lap, name) => {
                let params = load_vehicle(vehicle)?;
                let settings = load_solver(solver)?;
                let v_max = road.track_v_max_mps;
                if !(v_max.is_finite() && v_max > TRACK_SPEEDS_MPS.0) {
                    return Err(unsupported(
                        Path::new("--track-v-max-mps"),
                        format!(
                            "{v_max}: must be finite and above {} m/s",
                            TRACK_SPEEDS_MPS.0
                        ),
                    ));
                }
                let mut sc = load_track(&profile, lap, &name, params, settings)?;
                sc.spec.v_max = v_max;
                sc
            }
            Source::Swerve(seg) => {
                if !(road.obstacle_reach_m.is_finite() && road.obstacle_reach_m >= 0.0) {
                    return Err(unsupported(
                        Path::new("--obstacle-reach-m"),
                        format!("{}: must be finite and >= 0", road.obstacle_reach_m),
                    ));
                }
                let mut sc = load_swerve(scenario, seg, vehicle, solver)?;
                sc.road = sc.road.with_obstacle_reach(road.obstacle_reach_m);
                sc
            }
        };
        if let Some(sat) = &road.tire_saturation {
            sc.spec.enforce_tire_saturation = sat == "on";
        }
        Ok(sc)
    }
}

/// A track profile as a closed road with the race-segment OCP around it.
fn load_track(
    path: &Path,
    lap: f64,
    name: &str,
    vehicle: VehicleParams,
    settings: planner::ip::Settings,
) -> Result<Scenario, RoadError> {
    let profile = Profile::load(path, lap)?;
    let bytes = std::fs::read(path).map_err(|e| read_err(path, e))?;
    let road = ClosedRoad::from_profile(profile);
    let mut w = RoadWindow::default();
    let ds = TRACK_HORIZON_M / HORIZON_N as f64;
    road.window(0.0, ds, 0.0, 0.0, &mut w);
    let spec = OcpSpec {
        name: name.to_string(),
        n_intervals: HORIZON_N,
        length: TRACK_HORIZON_M,
        kappa: w.kappa.to_vec(),
        e_min: w.e_min.to_vec(),
        e_max: w.e_max.to_vec(),
        v_min: TRACK_SPEEDS_MPS.0,
        v_max: TRACK_SPEEDS_MPS.1,
        enforce_tire_saturation: true,
        saturation_at_end: false,
        steering_slew_weight: TRACK_SLEW_WEIGHT,
        v_end_max: f64::INFINITY,
        soft_lane: planner::ocp::SoftLane::OFF,
        initial: InitialState::Free,
        vehicle,
    };
    spec.check().map_err(|e| unsupported(path, e.to_string()))?;
    let mut tagged = b"track\0".to_vec();
    tagged.extend_from_slice(&bytes);
    tagged.extend_from_slice(&lap.to_bits().to_le_bytes());
    Ok(Scenario {
        spec,
        settings,
        road,
        id: fnv1a(&tagged),
    })
}

#[derive(Deserialize)]
struct ObstacleToml {
    common: Option<CommonToml>,
    scenarios: Option<Vec<EntryToml>>,
}

#[derive(Deserialize)]
struct CommonToml {
    horizon_length_m: Option<f64>,
    kappa_1pm: Option<f64>,
    road_e_min_m: Option<f64>,
    road_e_max_m: Option<f64>,
}

#[derive(Deserialize)]
struct EntryToml {
    name: Option<String>,
    bounds_override: Option<Vec<Vec<f64>>>,
}

/// Scenario `seg` of an obstacle file as an open road with its obstacles fixed at road s.
fn load_swerve(
    path: &Path,
    seg: &str,
    vehicle: &Path,
    solver: &Path,
) -> Result<Scenario, RoadError> {
    let params = load_vehicle(vehicle)?;
    // The planner's loader validates the file, the horizon and the selection.
    let spec = load_scenario_for_horizon(path, Some(seg), params, planner::HORIZON)?;
    let settings = load_solver(solver)?;
    let bytes = std::fs::read(path).map_err(|e| read_err(path, e))?;
    let file: ObstacleToml =
        toml::from_str(&String::from_utf8_lossy(&bytes)).map_err(|e| read_err(path, e))?;
    let need = "--segment needs an obstacle scenario file ([common] and [[scenarios]])";
    let common = file.common.ok_or_else(|| unsupported(path, need))?;
    let (Some(length), Some(kappa), Some(e_min), Some(e_max)) = (
        common.horizon_length_m,
        common.kappa_1pm,
        common.road_e_min_m,
        common.road_e_max_m,
    ) else {
        return Err(unsupported(path, need));
    };
    let entry = file
        .scenarios
        .unwrap_or_default()
        .into_iter()
        .find(|e| e.name.as_deref() == Some(seg))
        .ok_or_else(|| unsupported(path, format!("no scenario named {seg}")))?;
    let mut obstacles = Vec::new();
    for (i, o) in entry.bounds_override.unwrap_or_default().iter().enumerate() {
        let [s_from, s_to, lo, hi] = o.as_slice() else {
            return Err(unsupported(
                path,
                format!(
                    "scenarios[{seg}].bounds_override[{i}]: must be [s_from, s_to, e_min, e_max]"
                ),
            ));
        };
        obstacles.push(BoundsOverride {
            s_from: *s_from,
            s_to: *s_to,
            e_min: *lo,
            e_max: *hi,
        });
    }
    let mut tagged = b"swerve\0".to_vec();
    tagged.extend_from_slice(&bytes);
    tagged.extend_from_slice(seg.as_bytes());
    Ok(Scenario {
        spec,
        settings,
        road: ClosedRoad::open(length, kappa, e_min, e_max, obstacles),
        id: fnv1a(&tagged),
    })
}
