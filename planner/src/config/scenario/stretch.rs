//! A stretch of an indexed track, with no scenario file of its own: the road of
//! [`Segment::sample`] on track s in \[start, start + length\] (wrapping around the lap),
//! e_min = -w_right + margin, e_max = w_left - margin, solved with the `[defaults]` of a
//! segments file (speed bounds, tire saturation, objective, initial state) and the
//! planner's horizon N (ds = length / N). The track comes from the index
//! `tracks/tracks.toml` under the segments file's data root.

use std::path::Path;

use super::checks::{finish, objective, slew_weight, speeds};
use super::data_root_of;
use super::schema::SegmentsFile;
use crate::config::fields::{parse_toml, read_text, Fields};
use crate::config::tracks::load_track_index;
use crate::config::ConfigError;
use crate::model::VehicleParams;
use crate::ocp::OcpSpec;
use crate::track::{Profile, Segment};

/// Where a stretch lies on which track.
#[derive(Debug, Clone, PartialEq)]
pub struct Stretch {
    /// Track name in the index (e.g. `Austin`).
    pub track: String,
    /// Track s of the first node \[m\], in \[0, lap length).
    pub start_s: f64,
    /// Horizon length \[m\].
    pub length_m: f64,
    /// Distance kept from both track edges \[m\]; `None` takes the segments file's
    /// `defaults.edge_margin_m`.
    pub edge_margin_m: Option<f64>,
}

impl Stretch {
    /// The scenario name of the stretch: `<track>_s<start>` (e.g. `Austin_s480`), a
    /// file-name-safe label for its outputs.
    pub fn name(&self) -> String {
        format!("{}_s{}", self.track, self.start_s)
    }
}

/// The OCP of `stretch` with the defaults of `segments_file` and `n_intervals` intervals.
///
/// Errors name the segments file and its `defaults.*` key, or the track index and the
/// stretch's field (`stretch.track`, `stretch.start_s`, `stretch.length_m`,
/// `stretch.edge_margin_m`).
pub fn load_stretch(
    segments_file: &Path,
    stretch: &Stretch,
    vehicle: VehicleParams,
    n_intervals: usize,
) -> Result<OcpSpec, ConfigError> {
    let f = Fields::new(segments_file);
    let file: SegmentsFile = parse_toml(segments_file, &read_text(segments_file)?)?;
    let d = f.req(file.defaults, "defaults")?;
    objective(f, d.objective.as_deref(), "defaults.objective")?;
    let (v_min, v_max) = speeds(
        f,
        (d.v_min_mps, "defaults.v_min_mps"),
        (d.v_max_mps, "defaults.v_max_mps"),
    )?;
    let default_margin = f.non_neg(d.edge_margin_m, "defaults.edge_margin_m")?;
    let sat = f.req(
        d.enforce_tire_saturation,
        "defaults.enforce_tire_saturation",
    )?;
    let slew = slew_weight(f, d.steering_slew_weight, "defaults.steering_slew_weight")?;

    let index = data_root_of(segments_file)
        .join("tracks")
        .join("tracks.toml");
    let tracks = load_track_index(&index)?;
    let g = Fields::new(&index);
    let track = tracks
        .iter()
        .find(|t| t.name == stretch.track)
        .ok_or_else(|| {
            let list: Vec<&str> = tracks.iter().map(|t| t.name.as_str()).collect();
            g.invalid(
                "stretch.track",
                format!("\"{}\"", stretch.track),
                format!("must name a track of the index (have: {})", list.join(", ")),
            )
        })?;
    let start = g.non_neg(Some(stretch.start_s), "stretch.start_s")?;
    if start >= track.lap_length {
        return Err(g.invalid(
            "stretch.start_s",
            start,
            format!(
                "must lie in [0, {}), the lap of track {}",
                track.lap_length, track.name
            ),
        ));
    }
    let length = g.pos(Some(stretch.length_m), "stretch.length_m")?;
    if length > track.lap_length {
        return Err(g.invalid(
            "stretch.length_m",
            length,
            format!(
                "must be at most the lap length {} of track {}",
                track.lap_length, track.name
            ),
        ));
    }
    let margin = match stretch.edge_margin_m {
        Some(m) => g.non_neg(Some(m), "stretch.edge_margin_m")?,
        None => default_margin,
    };
    let profile = Profile::load(&track.profile_csv, track.lap_length)?;
    let road = Segment {
        s_start: start,
        length,
        n_intervals,
    }
    .sample(&profile, margin);
    finish(
        f,
        stretch.name(),
        length,
        road,
        (v_min, v_max),
        (sat, slew),
        (d.initial_state, "defaults.initial_state"),
        vehicle,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{load_scenario, load_vehicle};
    use std::path::PathBuf;

    /// `defaults.edge_margin_m` of config/scenarios/segments.toml.
    const SEGMENTS_EDGE_MARGIN_M: f64 = 1.0;

    fn config(rel: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../config")
            .join(rel)
    }

    fn stretch(track: &str, start_s: f64, length_m: f64) -> Stretch {
        Stretch {
            track: track.into(),
            start_s,
            length_m,
            edge_margin_m: None,
        }
    }

    fn load(s: &Stretch) -> Result<OcpSpec, ConfigError> {
        let vehicle = load_vehicle(&config("vehicles/lc500.toml")).unwrap();
        load_stretch(&config("scenarios/segments.toml"), s, vehicle, 100)
    }

    #[test]
    fn a_stretch_at_a_segments_start_is_that_segment_under_another_name() {
        let vehicle = load_vehicle(&config("vehicles/lc500.toml")).unwrap();
        let seg = load_scenario(&config("scenarios/segments.toml"), Some("S01"), vehicle).unwrap();
        let mut got = load(&stretch("Austin", 480.0, 250.0)).unwrap();
        assert_eq!(got.name, "Austin_s480");
        got.name = seg.name.clone();
        assert_eq!(got, seg);
    }

    #[test]
    fn an_explicit_edge_margin_moves_both_bounds() {
        let base = load(&stretch("Spa", 100.0, 200.0)).unwrap();
        let mut s = stretch("Spa", 100.0, 200.0);
        s.edge_margin_m = Some(0.0);
        let wide = load(&s).unwrap();
        let d = SEGMENTS_EDGE_MARGIN_M;
        for k in 0..=100 {
            assert!((wide.e_max[k] - base.e_max[k] - d).abs() < 1e-12);
            assert!((base.e_min[k] - wide.e_min[k] - d).abs() < 1e-12);
        }
        assert!((base.length - 200.0).abs() < 1e-12);
    }

    #[test]
    fn an_unknown_track_is_refused_with_the_tracks_it_knows() {
        let e = load(&stretch("Monza", 0.0, 250.0)).unwrap_err().to_string();
        assert!(e.contains("tracks.toml"), "{e}");
        assert!(e.contains("stretch.track = \"Monza\""), "{e}");
        assert!(e.contains("Austin"), "{e}");
    }

    #[test]
    fn a_start_outside_the_lap_or_a_bad_length_is_refused_by_name() {
        let e = load(&stretch("Austin", 6000.0, 250.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("stretch.start_s = 6000"), "{e}");
        let e = load(&stretch("Austin", -1.0, 250.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("stretch.start_s = -1"), "{e}");
        let e = load(&stretch("Austin", 0.0, 0.0)).unwrap_err().to_string();
        assert!(e.contains("stretch.length_m = 0"), "{e}");
        let e = load(&stretch("Austin", 0.0, f64::NAN))
            .unwrap_err()
            .to_string();
        assert!(e.contains("stretch.length_m = NaN"), "{e}");
    }
}
