//! The road options of `trajopt closed-loop` (a track, a profile of one's own, or an
//! obstacle scenario's segment), passed on to both processes alike, and the road's map for
//! the figures: curvature and lane edges on a uniform grid from s = 0.

use std::path::{Path, PathBuf};
use std::process::Command;

use planner::config::{load_scenario, load_track_index, load_vehicle};
use planner::track::Profile;

use crate::paths::resolve;

#[allow(rustdoc::broken_intra_doc_links)] // clap prints these docs as --help: unit brackets stay unescaped
#[derive(clap::Args, Debug)]
pub struct RoadOpts {
    /// Drive this closed track (a name in config/tracks/tracks.toml, e.g. Austin).
    #[arg(long, conflicts_with_all = ["track_profile", "segment"])]
    pub track: Option<String>,
    /// Drive a closed track profile of one's own (CSV s_m,kappa_1pm,w_right_m,w_left_m).
    #[arg(long, requires = "lap_length_m", conflicts_with = "segment")]
    pub track_profile: Option<PathBuf>,
    /// Lap length of --track-profile [m].
    #[arg(long, requires = "track_profile")]
    pub lap_length_m: Option<f64>,
    /// Laps to drive (when --distance-m is 0).
    #[arg(long, default_value_t = 1)]
    pub laps: usize,
    /// Road s where the car starts [m].
    #[arg(long, default_value_t = 0.0)]
    pub start_s: f64,
    /// Start speed [m/s], straight-line cruise in the lane centre (default on a track:
    /// node 0 of a free-start solve at --start-s; on a scenario road: its fixed initial
    /// state, else 15 m/s).
    #[arg(long)]
    pub initial_speed_mps: Option<f64>,
    /// Lane margin the plans keep from each edge and obstacle [m] (default: 1 on a track,
    /// the reference lap's edge margin, which leaves the tracker 0.8 m before the CG comes
    /// within 0.2 m of an edge; 0.2 for an obstacle scenario, whose bounds already hold a
    /// 1 m half-width of the car; 0.5 otherwise).
    #[arg(long)]
    pub lane_margin_m: Option<f64>,
    /// Scenario of an obstacle file to drive (with --scenario config/scenarios/collision_avoidance.toml:
    /// forgiving or critical).
    #[arg(long)]
    pub segment: Option<String>,
    /// Tire-saturation constraints of the planner (default: the scenario's).
    #[arg(long, value_parser = ["on", "off"])]
    pub tire_saturation: Option<String>,
    /// How far the planner's obstacle bounds reach past each obstacle's s interval [m]
    /// (default: half the car's body length; 0: the scenario's bound at the CG only).
    #[arg(long)]
    pub obstacle_reach_m: Option<f64>,
    /// Speed cap of the plans on a track [m/s] (default 55: from it the car can always
    /// brake to the end-speed bound inside the 250 m window; at 70 the laps left the track).
    #[arg(long)]
    pub track_v_max_mps: Option<f64>,
    /// Folder for the figures ROAD_lap.png and ROAD_speed.png.
    #[arg(long, default_value = "out")]
    pub out_dir: PathBuf,
}

impl RoadOpts {
    /// The lane margin of the plans.
    pub fn margin(&self) -> f64 {
        let on_track = self.track.is_some() || self.track_profile.is_some();
        self.lane_margin_m.unwrap_or(if self.segment.is_some() {
            0.2
        } else if on_track {
            1.0
        } else {
            0.5
        })
    }

    /// Adds the road options both processes take to `c`.
    pub fn pass(&self, c: &mut Command) {
        if let Some(t) = &self.track {
            c.arg("--track").arg(t);
            c.arg("--tracks-index")
                .arg(resolve(Path::new("config/tracks/tracks.toml")));
        }
        if let (Some(p), Some(l)) = (&self.track_profile, self.lap_length_m) {
            c.arg("--track-profile")
                .arg(resolve(p))
                .arg("--lap-length-m")
                .arg(l.to_string());
        }
        if let Some(s) = &self.segment {
            c.arg("--segment").arg(s);
        }
        if let Some(r) = self.obstacle_reach_m {
            c.arg("--obstacle-reach-m").arg(r.to_string());
        }
        if let Some(s) = &self.tire_saturation {
            c.arg("--tire-saturation").arg(s);
        }
        if let Some(v) = self.track_v_max_mps {
            c.arg("--track-v-max-mps").arg(v.to_string());
        }
        c.arg("--lane-margin-m").arg(self.margin().to_string());
    }

    /// The road's name in figure files and the summary.
    pub fn name(&self, scenario: &Path) -> String {
        if let Some(t) = &self.track {
            return t.clone();
        }
        if let Some(p) = &self.track_profile {
            let stem = p
                .file_stem()
                .map_or("track".into(), |s| s.to_string_lossy().into_owned());
            return stem.strip_suffix("_profile").unwrap_or(&stem).to_string();
        }
        if let Some(s) = &self.segment {
            return format!("swerve_{s}");
        }
        scenario
            .file_stem()
            .map_or("road".into(), |s| s.to_string_lossy().into_owned())
    }
}

/// The road for the figures: curvature and lane edges at s = k step (k = 0..n), periodic
/// with `length` when closed.
pub struct RoadMap {
    pub step: f64,
    pub length: f64,
    pub closed: bool,
    pub kappa: Vec<f64>,
    pub e_min: Vec<f64>,
    pub e_max: Vec<f64>,
}

/// Loads the road map of the options (a track's profile, else the scenario's nodes).
pub fn road_map(opts: &RoadOpts, scenario: &Path, vehicle: &Path) -> Result<RoadMap, String> {
    let track = match (&opts.track, &opts.track_profile, opts.lap_length_m) {
        (Some(name), _, _) => {
            let index = load_track_index(&resolve(Path::new("config/tracks/tracks.toml")))
                .map_err(|e| e.to_string())?;
            let t = index
                .into_iter()
                .find(|t| &t.name == name)
                .ok_or_else(|| format!("--track {name}: not in config/tracks/tracks.toml"))?;
            Some((t.profile_csv, t.lap_length))
        }
        (None, Some(p), Some(l)) => Some((resolve(p), l)),
        _ => None,
    };
    if let Some((path, lap)) = track {
        let p = Profile::load(&path, lap).map_err(|e| e.to_string())?;
        return Ok(RoadMap {
            step: p.step(),
            length: lap,
            closed: true,
            kappa: p.kappa().to_vec(),
            e_min: p.w_right().iter().map(|w| -w).collect(),
            e_max: p.w_left().to_vec(),
        });
    }
    let params = load_vehicle(&resolve(vehicle)).map_err(|e| e.to_string())?;
    let spec = load_scenario(&resolve(scenario), opts.segment.as_deref(), params)
        .map_err(|e| e.to_string())?;
    let closed = opts.segment.is_none();
    // The oval's horizon runs a little past its lap: the map keeps the lap.
    let lap = if closed {
        read_lap(&resolve(scenario)).unwrap_or(spec.length)
    } else {
        spec.length
    };
    let n = ((lap / spec.ds()).floor() as usize + 1).min(spec.kappa.len());
    Ok(RoadMap {
        step: spec.ds(),
        length: lap,
        closed,
        kappa: spec.kappa[..n].to_vec(),
        e_min: spec.e_min[..n].to_vec(),
        e_max: spec.e_max[..n].to_vec(),
    })
}

/// `[geometry] lap_length_m` of a closed-road scenario file.
fn read_lap(path: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(path).ok()?;
    let t: toml::Table = toml::from_str(&text).ok()?;
    t.get("geometry")?.get("lap_length_m")?.as_float()
}
