//! The segments schema: `[[segments]]` cut from the closed tracks of `[[tracks]]`, each
//! sampled from its track's profile with the defaults' edge margin.

use super::checks::{finish, horizon, objective, slew_weight, speeds};
use super::data_root_of;
use super::schema::SegmentsFile;
use super::select::pick;
use super::Layout;
use crate::config::fields::Fields;
use crate::config::tracks::TrackInfo;
use crate::config::ConfigError;
use crate::model::VehicleParams;
use crate::ocp::OcpSpec;
use crate::track::map::TrackMap;
use crate::track::{Profile, Segment};
use crate::trajectory::TrackPlacement;

/// The spec of the selected segment of a segments file.
pub(super) fn load(
    f: Fields<'_>,
    file: SegmentsFile,
    select: Option<&str>,
    vehicle: VehicleParams,
) -> Result<(OcpSpec, Layout), ConfigError> {
    let entries = file.segments.unwrap_or_default();
    let (name, seg) = pick(
        f,
        entries,
        |s| s.name.clone(),
        "segments",
        "segment",
        select,
    )?;
    let at = |k: &str| format!("segments[{name}].{k}");

    let d = f.req(file.defaults, "defaults")?;
    objective(f, d.objective.as_deref(), "defaults.objective")?;
    // A segment with its own length or interval count derives ds from them unless it
    // states its own ds_m; the defaults' ds_m checks only the defaults' horizon.
    let own_horizon = seg.length_m.is_some() || seg.n_intervals.is_some();
    let (length, n) = horizon(
        f,
        seg.length_m.map_or((d.length_m, "defaults.length_m"), |v| {
            (Some(v), "segments.length_m")
        }),
        seg.n_intervals
            .map_or((d.n_intervals, "defaults.n_intervals"), |v| {
                (Some(v), "segments.n_intervals")
            }),
        match (seg.ds_m, own_horizon) {
            (Some(v), _) => Some((Some(v), "segments.ds_m")),
            (None, false) => Some((d.ds_m, "defaults.ds_m")),
            (None, true) => None,
        },
    )
    .map_err(|e| in_segment(e, &name))?;
    let (v_min, v_max) = speeds(
        f,
        (d.v_min_mps, "defaults.v_min_mps"),
        (d.v_max_mps, "defaults.v_max_mps"),
    )?;
    let margin = f.non_neg(d.edge_margin_m, "defaults.edge_margin_m")?;
    let sat = f.req(
        d.enforce_tire_saturation,
        "defaults.enforce_tire_saturation",
    )?;
    let slew = slew_weight(f, d.steering_slew_weight, "defaults.steering_slew_weight")?;

    let root = data_root_of(f.file);
    let mut tracks: Vec<TrackInfo> = Vec::new();
    for (i, t) in file.tracks.unwrap_or_default().into_iter().enumerate() {
        tracks.push(t.resolve(f, i, &root)?);
    }
    let track_name = f.req(seg.track, &at("track"))?;
    let track = tracks
        .iter()
        .find(|t| t.name == track_name)
        .ok_or_else(|| {
            let list: Vec<&str> = tracks.iter().map(|t| t.name.as_str()).collect();
            f.invalid(
                &at("track"),
                format!("\"{track_name}\""),
                format!("must name a [[tracks]] entry (have: {})", list.join(", ")),
            )
        })?;
    if let Some(p) = &seg.profile_csv {
        if root.join(p) != track.profile_csv {
            return Err(f.invalid(
                &at("profile_csv"),
                format!("\"{p}\""),
                format!("must match tracks[{}].profile_csv", track.name),
            ));
        }
    }
    let s_start = f.num(seg.s_start_m, &at("s_start_m"))?;
    let profile = Profile::load(&track.profile_csv, track.lap_length)?;
    let road = Segment {
        s_start,
        length,
        n_intervals: n,
    }
    .sample(&profile, margin);
    let placement = placement(track, &profile, s_start);
    let spec = finish(
        f,
        name,
        length,
        road,
        (v_min, v_max),
        (sat, slew),
        (d.initial_state, "defaults.initial_state"),
        vehicle,
    )?;
    let mut layout = Layout::of(&spec);
    layout.placement = Some(placement);
    Ok((spec, layout))
}

/// Where a horizon starting at track arc length `s_start` lies on `track`.
pub(super) fn placement(track: &TrackInfo, profile: &Profile, s_start: f64) -> TrackPlacement {
    let map = TrackMap::new(profile, track.start_pose);
    TrackPlacement {
        track: track.name.clone(),
        s_start: s_start.rem_euclid(profile.lap_length()),
        lap_length: profile.lap_length(),
        origin: map.pose_at(s_start),
    }
}

/// Rewrites a `segments.key` field to `segments[name].key`.
fn in_segment(e: ConfigError, name: &str) -> ConfigError {
    match e {
        ConfigError::Invalid {
            file,
            field,
            value,
            expected,
        } => ConfigError::Invalid {
            file,
            field: field.replacen("segments.", &format!("segments[{name}]."), 1),
            value,
            expected,
        },
        other => other,
    }
}
