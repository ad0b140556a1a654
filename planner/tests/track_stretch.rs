//! A track stretch named by track, start s and length: the same OCP as the equal segment
//! of `segments.toml`, the defaults of that file, refusals in words, and the plan's place
//! on the track (the CSV's s_track, x, y, heading).

use planner::config::{
    load_scenario_layout, load_track_index, load_vehicle, stretch_layout, stretch_spec,
    STRETCH_DEFAULTS,
};
use planner::model::{ix, VehicleParams, NU, NX};
use planner::track::map::TrackMap;
use planner::track::Profile;
use planner::trajectory::Trajectory;
use std::path::PathBuf;

fn data_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config")
}

fn vehicle() -> VehicleParams {
    load_vehicle(&data_root().join("vehicles/lc500.toml")).unwrap()
}

#[test]
fn the_stretch_defaults_are_those_of_segments_toml() {
    let text = std::fs::read_to_string(data_root().join("scenarios/segments.toml")).unwrap();
    let t: toml::Table = toml::from_str(&text).unwrap();
    let d = t["defaults"].as_table().unwrap();
    let f = |k: &str| d[k].as_float().unwrap();
    assert_eq!(
        d["n_intervals"].as_integer(),
        Some(STRETCH_DEFAULTS.n_intervals as i64)
    );
    assert_eq!(f("v_min_mps"), STRETCH_DEFAULTS.v_min);
    assert_eq!(f("v_max_mps"), STRETCH_DEFAULTS.v_max);
    assert_eq!(
        f("steering_slew_weight"),
        STRETCH_DEFAULTS.steering_slew_weight
    );
    assert_eq!(f("edge_margin_m"), 1.0);
    assert_eq!(f("length_m"), 250.0);
    assert_eq!(
        d["enforce_tire_saturation"].as_bool(),
        Some(STRETCH_DEFAULTS.enforce_tire_saturation)
    );
    assert_eq!(d["initial_state"]["mode"].as_str(), Some("free"));
}

#[test]
fn a_stretch_equals_the_segment_of_segments_toml_at_the_same_place() {
    let (s01, s01_layout) = load_scenario_layout(
        &data_root().join("scenarios/segments.toml"),
        Some("S01"),
        vehicle(),
        Some(planner::HORIZON),
    )
    .unwrap();
    let (mut ours, layout) =
        stretch_layout(&data_root(), "Austin", 480.0, 250.0, 1.0, vehicle()).unwrap();
    assert_eq!(ours.name, "Austin_s480");
    ours.name = s01.name.clone();
    assert_eq!(ours, s01);
    assert_eq!(layout.placement, s01_layout.placement);
    let p = layout.placement.unwrap();
    assert_eq!((p.track.as_str(), p.s_start), ("Austin", 480.0));
}

#[test]
fn a_stretch_is_refused_in_words_when_its_nodes_are_over_5_m_apart_or_its_track_is_unknown() {
    let msg = stretch_spec(&data_root(), "Austin", 0.0, 5800.0, 1.0, vehicle())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("length_m = 5800: puts the 101 nodes 58.000 m apart; over 5 m the model steps across corners"),
        "{msg}"
    );
    assert!(stretch_spec(&data_root(), "Austin", 0.0, 500.0, 1.0, vehicle()).is_ok());
    let msg = stretch_spec(&data_root(), "Monza", 0.0, 250.0, 1.0, vehicle())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains(
            "track = \"Monza\": no such track (have: Austin, Budapest, Montreal, Silverstone, Spa"
        ),
        "{msg}"
    );
    let msg = stretch_spec(&data_root(), "Spa", f64::NAN, 250.0, 1.0, vehicle())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("start_s = NaN: must be a finite number"),
        "{msg}"
    );
    let msg = stretch_spec(&data_root(), "Spa", 0.0, 250.0, -1.0, vehicle())
        .unwrap_err()
        .to_string();
    assert!(msg.contains("edge_margin_m = -1: must be >= 0"), "{msg}");
}

/// A trajectory on the stretch's road with the car on the centerline (e = 0), states
/// otherwise zero.
fn centred(spec: &planner::ocp::OcpSpec) -> Trajectory {
    let n = spec.n_intervals;
    Trajectory {
        name: spec.name.clone(),
        ds: spec.ds(),
        x: vec![[0.0; NX]; n + 1],
        u: vec![[0.0; NU]; n],
        kappa: spec.kappa.clone(),
        e_min: spec.e_min.clone(),
        e_max: spec.e_max.clone(),
        lane_e_min: spec.e_min.clone(),
        lane_e_max: spec.e_max.clone(),
        placement: None,
    }
}

#[test]
fn the_csv_places_the_plan_on_the_track_map_across_the_lap_end() {
    let info = load_track_index(&data_root().join("tracks/tracks.toml"))
        .unwrap()
        .into_iter()
        .find(|t| t.name == "Spa")
        .unwrap();
    let profile = Profile::load(&info.profile_csv, info.lap_length).unwrap();
    let map = TrackMap::new(&profile, info.start_pose);
    let start = info.lap_length - 100.0;
    let (spec, layout) = stretch_layout(&data_root(), "Spa", start, 250.0, 1.0, vehicle()).unwrap();
    let mut traj = centred(&spec);
    layout.apply(&mut traj);
    traj.x[40][ix::E] = 2.0;
    let poses = traj.car_poses();
    for k in [0, 20, 39, 41, 60, 100] {
        let s = traj.s_track(k);
        let want_s = (start + k as f64 * spec.ds()).rem_euclid(info.lap_length);
        assert!((s - want_s).abs() < 1e-9, "node {k}: s {s} vs {want_s}");
        let m = map.pose_at(s);
        let d = (poses[k][0] - m[0]).hypot(poses[k][1] - m[1]);
        // The horizon's path is rebuilt from its node curvatures (2.5 m apart), the map
        // from the 1 m rows, and the map's lap closes within 0.6 m.
        assert!(d < 0.7, "node {k}: {d} m from the map");
    }
    // e = 2 m puts the car 2 m to the left of the centerline.
    let m = map.pose_at(traj.s_track(40));
    let left = [m[0] - 2.0 * m[2].sin(), m[1] + 2.0 * m[2].cos()];
    assert!((poses[40][0] - left[0]).hypot(poses[40][1] - left[1]) < 0.7);

    let dir = std::env::temp_dir().join(format!("planner-stretch-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("plan.csv");
    traj.write_csv(&csv).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert!(lines
        .next()
        .unwrap()
        .ends_with(",e_min,e_max,s_track,x,y,heading"));
    let row41: Vec<f64> = lines
        .nth(41)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!((row41[17] - traj.s_track(41)).abs() < 1e-6);
    assert!((row41[18] - poses[41][0]).abs() < 1e-6 && (row41[19] - poses[41][1]).abs() < 1e-6);
    let _ = std::fs::remove_dir_all(&dir);
}
