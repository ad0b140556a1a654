//! The road both processes drive on, and the scenario as a whole (OCP template, solver
//! settings, road id).
//!
//! The road is k_ref(s) with lane edges e_min(s) < e_max(s) along the car's unwrapped arc
//! length s. A closed road (the oval's exact `[track] kappa_pieces`, or a track profile
//! sampled linearly between its rows with e_min = -w_right, e_max = w_left) is periodic:
//! every lookup takes s mod lap, so a planning window that crosses s = lap reads the start
//! of the lap on. An open road (an obstacle scenario) is straight past its scenario's
//! stretch and replaces the lane bounds at its obstacles ([`RoadArgs`]).

use std::path::{Path, PathBuf};

use planner::config::{load_scenario_for_horizon, load_solver, load_vehicle, ConfigError};
use planner::ip::Settings;
use planner::ocp::OcpSpec;
use planner::track::{piecewise_constant, BoundsOverride, Profile};
use serde::Deserialize;

use crate::msg::{fnv1a, RoadId, HORIZON_N};

pub mod envelope;
pub mod footprint;
mod source;
pub use source::{RoadArgs, TRACK_HORIZON_M, TRACK_SLEW_WEIGHT, TRACK_SPEEDS_MPS};

/// Why a scenario cannot be used for the closed loop.
#[derive(Debug, thiserror::Error)]
pub enum RoadError {
    /// The planner's config loader rejected a file.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A track profile is malformed or does not fit its lap length.
    #[error(transparent)]
    Track(#[from] planner::track::TrackFileError),
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

/// The lane geometry of a road: exact pieces with constant bounds (the oval, the
/// straight of the swerve), or a sampled track profile with its widths.
#[derive(Debug, Clone, PartialEq)]
enum Shape {
    /// Piecewise-constant curvature [(s_start, kappa)] and constant lane edges.
    Pieces {
        pieces: Vec<(f64, f64)>,
        e_min: f64,
        e_max: f64,
    },
    /// A closed track profile: e_min(s) = -w_right(s), e_max(s) = w_left(s).
    Profile(Profile),
}

/// The road both processes drive on: curvature k_ref(s) and lane edges e_min(s) < e_max(s)
/// along the unwrapped arc length s.
///
/// A closed road repeats with its lap length (s mod lap everywhere, so a window that
/// crosses s = lap continues from s = 0); an open road (the swerve) is its scenario's
/// stretch followed by a straight with the nominal lane, and carries obstacles as lateral
/// bound overrides at fixed road s.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedRoad {
    shape: Shape,
    lap: f64,
    closed: bool,
    obstacles: Vec<BoundsOverride>,
    /// How far the planner's obstacle bounds reach past each obstacle's s interval \[m\].
    reach: f64,
    /// Smallest arc-length scale 1 - kappa e the planner's lane allows (0: the edges).
    min_scale: f64,
}

impl ClosedRoad {
    /// A closed road from pieces (s_start, kappa), a lap length and lane bounds (no checks).
    pub fn new(pieces: Vec<(f64, f64)>, lap: f64, e_min: f64, e_max: f64) -> Self {
        Self {
            shape: Shape::Pieces {
                pieces,
                e_min,
                e_max,
            },
            lap,
            closed: true,
            obstacles: Vec::new(),
            reach: 0.0,
            min_scale: 0.0,
        }
    }

    /// A closed road from a track profile (periodic with the profile's lap length).
    pub fn from_profile(profile: Profile) -> Self {
        let lap = profile.lap_length();
        Self {
            shape: Shape::Profile(profile),
            lap,
            closed: true,
            obstacles: Vec::new(),
            reach: 0.0,
            min_scale: 0.0,
        }
    }

    /// An open road of `length` \[m\]: constant curvature `kappa`, lane [e_min, e_max] and
    /// the obstacles (bounds replaced on [s_from, s_to] of road s); past `length` it goes
    /// on with the same curvature and lane.
    pub fn open(
        length: f64,
        kappa: f64,
        e_min: f64,
        e_max: f64,
        obstacles: Vec<BoundsOverride>,
    ) -> Self {
        Self {
            shape: Shape::Pieces {
                pieces: vec![(0.0, kappa)],
                e_min,
                e_max,
            },
            lap: length,
            closed: false,
            obstacles,
            reach: 0.0,
            min_scale: 0.0,
        }
    }

    /// k_ref at road arc length s (any real s; a closed road wraps modulo the lap) [1/m].
    pub fn kappa(&self, s: f64) -> f64 {
        match &self.shape {
            Shape::Pieces { pieces, .. } if self.closed => {
                piecewise_constant(pieces, s.rem_euclid(self.lap))
            }
            Shape::Pieces { pieces, .. } => piecewise_constant(pieces, s),
            Shape::Profile(p) => p.sample(s).0,
        }
    }

    /// Lane edges (e_min, e_max) at road arc length s, obstacles not included \[m\].
    pub fn edges(&self, s: f64) -> (f64, f64) {
        match &self.shape {
            Shape::Pieces { e_min, e_max, .. } => (*e_min, *e_max),
            Shape::Profile(p) => {
                let (_, w_right, w_left) = p.sample(s);
                (-w_right, w_left)
            }
        }
    }

    /// Lap length \[m\] (an open road: the length of its scenario's stretch).
    pub fn lap(&self) -> f64 {
        self.lap
    }

    /// True for a closed road (s wraps with the lap).
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// The road with the planner's obstacle bounds reaching `reach` \[m\] past both ends
    /// of each obstacle (half the car's length keeps the CG bound on while any part of the
    /// body is alongside the obstacle; 0 is the scenario's bound at the CG only).
    pub fn with_obstacle_reach(mut self, reach: f64) -> Self {
        self.reach = reach;
        self
    }

    /// The road with the planner's lane kept where the road frame's arc-length scale
    /// 1 - kappa e is at least `min_scale` (0: the lane edges only).
    ///
    /// Past the centre of curvature the curvilinear model is singular (s_dot = V cos dpsi
    /// / (1 - kappa e)); near it, a node's 2.5 m of centre line is a fraction of a metre
    /// of the inside edge while the heading turns kappa ds, so the dynamics are stiff and a
    /// car cutting the apex runs a heading of a radian to the centre line, where a small
    /// error along the path is a large error in e. The bound e <= (1 - min_scale) / kappa
    /// on the inside of a curve (e >= on the right of a right-hander) keeps the plans out
    /// of that region. It ramps in over the start ramp like the lane margin, so a car
    /// already inside it can still be planned for.
    pub fn with_min_path_scale(mut self, min_scale: f64) -> Self {
        self.min_scale = min_scale;
        self
    }

    /// The obstacles: lateral bounds replaced on closed intervals of road s.
    pub fn obstacles(&self) -> &[BoundsOverride] {
        &self.obstacles
    }

    /// The track profile of a road made from one.
    pub fn profile(&self) -> Option<&Profile> {
        match &self.shape {
            Shape::Profile(p) => Some(p),
            Shape::Pieces { .. } => None,
        }
    }

    /// Narrowest lane width anywhere on the road \[m\] (at the profile rows of a track).
    pub fn min_width(&self) -> f64 {
        match &self.shape {
            Shape::Pieces { e_min, e_max, .. } => e_max - e_min,
            Shape::Profile(p) => p
                .w_right()
                .iter()
                .zip(p.w_left())
                .map(|(r, l)| r + l)
                .fold(f64::INFINITY, f64::min),
        }
    }

    /// Right lane edge of the narrowest lane \[m\] (the largest e_min).
    pub fn e_min(&self) -> f64 {
        match &self.shape {
            Shape::Pieces { e_min, .. } => *e_min,
            Shape::Profile(p) => -p.w_right().iter().copied().fold(f64::INFINITY, f64::min),
        }
    }

    /// Left lane edge of the narrowest lane \[m\] (the smallest e_max).
    pub fn e_max(&self) -> f64 {
        match &self.shape {
            Shape::Pieces { e_max, .. } => *e_max,
            Shape::Profile(p) => p.w_left().iter().copied().fold(f64::INFINITY, f64::min),
        }
    }

    /// Road ahead of road s0 at the N + 1 nodes s0 + k ds, lane shrunk by `margin` on
    /// both sides; the margin ramps in linearly over the first `ramp` metres so a car that
    /// is already inside the margin can still be planned for. An obstacle whose interval
    /// holds a node's road s replaces (intersects) that node's bounds, shrunk by the same
    /// margin, over the interval widened by the obstacle reach. Allocates nothing.
    pub fn window(&self, s0: f64, ds: f64, margin: f64, ramp: f64, out: &mut RoadWindow) {
        self.window_with(s0, (ds, ramp), out, |s| {
            let m = margin * ramp_weight(s, ramp);
            (m, m)
        });
    }

    /// The window with the (right, left) margin a function of the local s, and the
    /// path-scale bound ramped in over `ramp` metres.
    fn window_with(
        &self,
        s0: f64,
        (ds, ramp): (f64, f64),
        out: &mut RoadWindow,
        margin_at: impl Fn(f64) -> (f64, f64),
    ) {
        let RoadWindow {
            kappa,
            e_min,
            e_max,
            ..
        } = out;
        for k in 0..=HORIZON_N {
            let s_road = s0 + k as f64 * ds;
            kappa[k] = self.kappa(s_road);
            let (mr, ml) = margin_at(k as f64 * ds);
            let (lo, hi) = self.edges(s_road);
            e_min[k] = lo + mr;
            e_max[k] = hi - ml;
            for o in &self.obstacles {
                if o.s_from - self.reach <= s_road && s_road <= o.s_to + self.reach {
                    e_min[k] = e_min[k].max(o.e_min + mr);
                    e_max[k] = e_max[k].min(o.e_max - ml);
                }
            }
            if self.min_scale > 0.0 && kappa[k] != 0.0 {
                let w = ramp_weight(k as f64 * ds, ramp);
                let e_scale = (1.0 - self.min_scale) / kappa[k];
                if kappa[k] > 0.0 && e_scale < e_max[k] {
                    e_max[k] = (e_max[k] + w * (e_scale - e_max[k])).max(e_min[k]);
                } else if kappa[k] < 0.0 && e_scale > e_min[k] {
                    e_min[k] = (e_min[k] + w * (e_scale - e_min[k])).min(e_max[k]);
                }
            }
        }
    }

    /// [`Self::window`] for a car at lateral position `e0` moving sideways at `e_dot`
    /// (V sin dpsi): on each side the margin ramps in over `ramp.length_m`
    /// from the car's own distance inside that edge (at most the margin) rather than from
    /// 0, so successive plans never lead a car that keeps the margin closer to the edge
    /// than the margin, while a car already inside it can still be planned for.
    ///
    /// A car moving toward an edge cannot stop at once: that side's ramp starts from where
    /// its sideways motion can end, `e_dot^2 / (2 a)` further out (a =
    /// `ramp.arrest_accel`), so the start is plannable instead of locally infeasible. The
    /// allowance never takes the ramp's start closer to the edge than `ramp.floor_m` (or
    /// the car's own distance, when smaller): a plan cutting toward an apex would otherwise
    /// be allowed a little closer on every replan. Allocates nothing.
    pub fn window_from(
        &self,
        s0: f64,
        (e0, e_dot): (f64, f64),
        ds: f64,
        ramp: &StartRamp,
        out: &mut RoadWindow,
    ) {
        let (lo0, hi0) = self.edges(s0);
        let margin = ramp.margin;
        let start = |inside: f64, toward: f64| {
            let drift = if ramp.arrest_accel > 0.0 {
                toward.max(0.0).powi(2) / (2.0 * ramp.arrest_accel)
            } else {
                0.0
            };
            (inside - drift)
                .max(inside.min(ramp.floor_m))
                .clamp(ramp.floor_m.min(0.0), margin)
        };
        let right0 = start(e0 - lo0, -e_dot);
        let left0 = start(hi0 - e0, e_dot);
        let length = ramp.length_m;
        self.window_with(s0, (ds, length), out, |s| {
            let w = ramp_weight(s, length);
            (right0 + (margin - right0) * w, left0 + (margin - left0) * w)
        });
    }
}

/// How far a ramp of `length` metres has come in at local s: s / length, capped at 1 (1
/// at once for a ramp of no length).
fn ramp_weight(s: f64, length: f64) -> f64 {
    if length > 0.0 {
        (s / length).min(1.0)
    } else {
        1.0
    }
}

impl ClosedRoad {
    /// The soft lane of the window at road s0 ([`planner::ocp::SoftLane`]): the lane edges
    /// at the N + 1 nodes s0 + k ds shrunk by `margin` on both sides, with no ramp (the
    /// penalty, unlike a hard bound, leaves every start plannable). Obstacles are not
    /// included: their bounds stay hard. Allocates nothing.
    pub fn soft_window(&self, s0: f64, ds: f64, margin: f64, out: &mut RoadWindow) {
        for k in 0..=HORIZON_N {
            let (lo, hi) = self.edges(s0 + k as f64 * ds);
            out.soft_e_min[k] = lo + margin;
            out.soft_e_max[k] = hi - margin;
        }
        out.soft_on = true;
    }
}

/// How a plan's lane margin ramps in from a car near an edge ([`ClosedRoad::window_from`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartRamp {
    /// The lane margin after the ramp \[m\].
    pub margin: f64,
    /// Distance over which the margin ramps in \[m\] (0: the full margin at once).
    pub length_m: f64,
    /// Lateral acceleration a car is assumed to stop its sideways motion with \[m/s^2\]
    /// (0: no drift allowance).
    pub arrest_accel: f64,
    /// Closest to an edge the drift allowance takes the ramp's start \[m\] (negative: past
    /// the edge, for a plan whose soft lane pulls it back).
    pub floor_m: f64,
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
    /// Soft right bound at the nodes \[m\] ([`ClosedRoad::soft_window`]; when `soft_on`).
    pub soft_e_min: [f64; HORIZON_N + 1],
    /// Soft left bound at the nodes \[m\] (when `soft_on`).
    pub soft_e_max: [f64; HORIZON_N + 1],
    /// Whether the soft bounds are set.
    pub soft_on: bool,
    /// Speed bound of the last node [m/s] ([`envelope::SpeedEnvelope`]; infinite: none).
    pub v_end_max: f64,
}

impl Default for RoadWindow {
    fn default() -> Self {
        Self {
            kappa: [0.0; HORIZON_N + 1],
            e_min: [0.0; HORIZON_N + 1],
            e_max: [0.0; HORIZON_N + 1],
            soft_e_min: [0.0; HORIZON_N + 1],
            soft_e_max: [0.0; HORIZON_N + 1],
            soft_on: false,
            v_end_max: f64::INFINITY,
        }
    }
}

impl RoadWindow {
    /// k_ref, e_min, e_max and the soft bounds (empty when not set), as a recording holds
    /// them.
    pub fn slices(&self) -> [&[f64]; 5] {
        let soft: [&[f64]; 2] = if self.soft_on {
            [&self.soft_e_min, &self.soft_e_max]
        } else {
            [&[], &[]]
        };
        [&self.kappa, &self.e_min, &self.e_max, soft[0], soft[1]]
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
    /// Road id (hash of the scenario file, or of the track profile and its lap length).
    pub id: RoadId,
}

impl ClosedRoad {
    /// `Err` naming the first profile row (0-based, with its s) where a lane shrunk by
    /// `margin` on both sides leaves no room.
    pub fn check_margin(&self, margin: f64) -> Result<(), String> {
        match &self.shape {
            Shape::Pieces { e_min, e_max, .. } => {
                if 2.0 * margin >= e_max - e_min {
                    return Err(format!(
                        "a lane margin of {margin} m leaves no lane between {e_min} and {e_max} m"
                    ));
                }
            }
            Shape::Profile(p) => {
                for (i, (r, l)) in p.w_right().iter().zip(p.w_left()).enumerate() {
                    if 2.0 * margin >= r + l {
                        return Err(format!(
                            "row {i} (s = {} m): a lane margin of {margin} m leaves no lane in w_right + w_left = {} m",
                            i as f64 * p.step(),
                            r + l
                        ));
                    }
                }
            }
        }
        Ok(())
    }
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

    /// On a left-hander of radius 10 m (lane +-8 m) and a right-hander after it, the
    /// path-scale bound 0.5 keeps e <= 5 m on the inside of the left one and e >= -5 m on
    /// the inside of the right one, past the 20 m ramp; it starts from the edge at node 0
    /// and leaves the outside and the straights alone. Without it the window is the lane.
    #[test]
    fn the_path_scale_bound_keeps_plans_off_the_centre_of_curvature() {
        let pieces = vec![(0.0, 0.0), (10.0, 0.1), (110.0, -0.1), (210.0, 0.0)];
        let plain = ClosedRoad::new(pieces, 1000.0, -8.0, 8.0);
        let bounded = plain.clone().with_min_path_scale(0.5);
        let (mut a, mut b) = (RoadWindow::default(), RoadWindow::default());
        plain.window(0.0, 2.5, 0.0, 20.0, &mut a);
        bounded.window(0.0, 2.5, 0.0, 20.0, &mut b);
        assert!(a.e_max.iter().all(|&e| e == 8.0) && a.e_min.iter().all(|&e| e == -8.0));
        for k in 0..=HORIZON_N {
            let s = k as f64 * 2.5;
            let (lo, hi) = (b.e_min[k], b.e_max[k]);
            if s > 20.0 && s < 110.0 {
                assert!(
                    (hi - 5.0).abs() < 1e-12 && lo == -8.0,
                    "s {s}: [{lo}, {hi}]"
                );
            } else if s > 110.0 && s < 210.0 {
                assert!((lo + 5.0).abs() < 1e-12 && hi == 8.0, "s {s}: [{lo}, {hi}]");
            } else if !(10.0..=210.0).contains(&s) {
                assert!(lo == -8.0 && hi == 8.0, "s {s}: [{lo}, {hi}]");
            }
            // Where the scale bound acts, 1 - kappa e >= 0.5 at the bound.
            assert!(1.0 - b.kappa[k] * hi >= 0.5 - 1e-12 || s <= 20.0, "s {s}");
            assert!(1.0 - b.kappa[k] * lo >= 0.5 - 1e-12 || s <= 20.0, "s {s}");
        }
        // The ramp: node 4 (10 m, half-way) is half-way between the edge and the bound.
        assert!((b.e_max[4] - 6.5).abs() < 1e-12, "{}", b.e_max[4]);
    }
}
