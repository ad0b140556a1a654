//! A stretch of a closed track named on the command line (track, start s, length, edge
//! margin), with the other settings of `config/scenarios/segments.toml`'s `[defaults]`: no
//! scenario file needed.
//!
//! The stretch covers track s in [start_s, start_s + length] (wrapping past the lap end),
//! sampled at N + 1 nodes s_k = start_s + k length / N. Its lane is the track's, shrunk by
//! the edge margin on both sides: e_min = -w_right + margin, e_max = w_left - margin.

use super::checks::{finish, horizon};
use super::segments::placement;
use super::Layout;
use crate::config::fields::Fields;
use crate::config::tracks::load_track_index;
use crate::config::ConfigError;
use crate::model::VehicleParams;
use crate::ocp::OcpSpec;
use crate::track::{Profile, Segment};
use std::path::Path;

/// The settings of a stretch that are not named on the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StretchDefaults {
    /// Interval count N.
    pub n_intervals: usize,
    /// Lowest speed \[m/s\].
    pub v_min: f64,
    /// Highest speed \[m/s\].
    pub v_max: f64,
    /// Tire saturation constraints on.
    pub enforce_tire_saturation: bool,
    /// Weight of the objective's steering-slew term \[1/s\].
    pub steering_slew_weight: f64,
}

/// The `[defaults]` of `config/scenarios/segments.toml` (a test keeps them equal). The
/// initial state is free, as there.
pub const STRETCH_DEFAULTS: StretchDefaults = StretchDefaults {
    n_intervals: crate::HORIZON,
    v_min: 5.0,
    v_max: 70.0,
    enforce_tire_saturation: true,
    steering_slew_weight: 1.0,
};

/// The OCP of the stretch of track `track_name` (an entry of `data_root/tracks/tracks.toml`)
/// from track arc length `start_s` \[m\] over `length_m` \[m\], with the lane shrunk by
/// `edge_margin_m` \[m\] on both sides and [`STRETCH_DEFAULTS`] otherwise. Named
/// `<track>_s<start_s>`. Errors name the index file and the option (`start_s`, `length_m`,
/// `edge_margin_m`, `track`); a node spacing over [`super::MAX_NODE_SPACING_M`] is refused.
pub fn stretch_spec(
    data_root: &Path,
    track_name: &str,
    start_s: f64,
    length_m: f64,
    edge_margin_m: f64,
    vehicle: VehicleParams,
) -> Result<OcpSpec, ConfigError> {
    stretch_layout(
        data_root,
        track_name,
        start_s,
        length_m,
        edge_margin_m,
        vehicle,
    )
    .map(|(spec, _)| spec)
}

/// [`stretch_spec`] with the stretch's [`Layout`] (its placement on the track).
pub fn stretch_layout(
    data_root: &Path,
    track_name: &str,
    start_s: f64,
    length_m: f64,
    edge_margin_m: f64,
    vehicle: VehicleParams,
) -> Result<(OcpSpec, Layout), ConfigError> {
    let index = data_root.join("tracks").join("tracks.toml");
    let f = Fields::new(&index);
    let tracks = load_track_index(&index)?;
    let track = tracks
        .iter()
        .find(|t| t.name == track_name)
        .ok_or_else(|| {
            let list: Vec<&str> = tracks.iter().map(|t| t.name.as_str()).collect();
            f.invalid(
                "track",
                format!("\"{track_name}\""),
                format!(
                    "no such track (have: {}; `trajopt track import FILE.csv` adds one)",
                    list.join(", ")
                ),
            )
        })?;
    let start_s = f.num(Some(start_s), "start_s")?;
    let margin = f.non_neg(Some(edge_margin_m), "edge_margin_m")?;
    let d = STRETCH_DEFAULTS;
    let (length, n) = horizon(
        f,
        (Some(length_m), "length_m"),
        (Some(d.n_intervals as i64), "n_intervals"),
        None,
    )?;
    let profile = Profile::load(&track.profile_csv, track.lap_length)?;
    let road = Segment {
        s_start: start_s,
        length,
        n_intervals: n,
    }
    .sample(&profile, margin);
    let name = format!("{}_s{}", track.name, start_s);
    let spec = finish(
        f,
        name,
        length,
        road,
        (d.v_min, d.v_max),
        (d.enforce_tire_saturation, d.steering_slew_weight),
        (
            Some(super::schema::InitialStateToml::free()),
            "initial_state",
        ),
        vehicle,
    )?;
    let mut layout = Layout::of(&spec);
    layout.placement = Some(placement(track, &profile, start_s));
    layout.track = Some(track.clone());
    Ok((spec, layout))
}
