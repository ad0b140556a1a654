//! The track road both processes share: a window across the lap's end continues from the
//! start of the profile, the lane bounds follow the widths, the road id covers the profile,
//! and a bad profile or option is refused before anything runs, naming file and row.

use std::path::{Path, PathBuf};

use ipc::msg::HORIZON_N;
use ipc::road::{ClosedRoad, RoadArgs, RoadWindow, Scenario, StartRamp};
use planner::track::Profile;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn load(road: &RoadArgs) -> Result<Scenario, String> {
    Scenario::load_with(
        &root().join("config/scenarios/oval.toml"),
        road,
        &root().join("config/vehicles/lc500.toml"),
        &root().join("config/solver.toml"),
    )
    .map_err(|e| e.to_string())
}

fn austin() -> RoadArgs {
    RoadArgs {
        track: Some("Austin".into()),
        tracks_index: root().join("config/tracks/tracks.toml"),
        ..RoadArgs::default()
    }
}

/// A profile file of one's own in a fresh folder.
fn user_profile(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("track_road_{name}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{name}_profile.csv"));
    std::fs::write(&path, text).unwrap();
    path
}

fn user(path: &Path, lap: f64) -> RoadArgs {
    RoadArgs {
        track_profile: Some(path.to_path_buf()),
        lap_length_m: Some(lap),
        ..RoadArgs::default()
    }
}

#[test]
fn a_window_across_the_lap_end_equals_the_profile_from_its_start() {
    let sc = load(&austin()).expect("Austin loads");
    let lap = sc.road.lap();
    let profile = Profile::load(&root().join("config/tracks/Austin_profile.csv"), lap).unwrap();
    let ds = sc.ds();
    assert_eq!(ds, 2.5);
    // 100 m before the lap's end: nodes 40.. lie past s = lap.
    let s0 = lap - 100.0;
    let mut w = RoadWindow::default();
    sc.road.window(s0, ds, 0.0, 0.0, &mut w);
    let mut wrapped = 0;
    for k in 0..=HORIZON_N {
        let s = s0 + k as f64 * ds;
        let u = if s >= lap { s - lap } else { s };
        if s >= lap {
            wrapped += 1;
        }
        let (kappa, w_right, w_left) = profile.sample(u);
        assert!((w.kappa[k] - kappa).abs() < 1e-12, "node {k}");
        assert!((w.e_min[k] + w_right).abs() < 1e-12, "node {k}");
        assert!((w.e_max[k] - w_left).abs() < 1e-12, "node {k}");
    }
    assert_eq!(wrapped, 61);
    // Past the end the window reads the profile's own rows from s = 0: node 60 sits at
    // lap - 100 + 150 = 50 m past the start, within 1e-9 m of row 50.
    let k50 = 60;
    let s = s0 + k50 as f64 * ds - lap;
    assert!((s - 50.0).abs() < 1e-9);
    assert!((w.kappa[k50] - profile.kappa()[50]).abs() < 1e-9);
    assert!((w.e_max[k50] - profile.w_left()[50]).abs() < 1e-9);
    // A second lap reads the same road.
    let mut w2 = RoadWindow::default();
    sc.road.window(s0 + lap, ds, 0.0, 0.0, &mut w2);
    for k in 0..=HORIZON_N {
        assert!((w.kappa[k] - w2.kappa[k]).abs() < 1e-12);
    }
}

#[test]
fn the_lane_margin_shrinks_the_varying_bounds_after_its_ramp() {
    let sc = load(&austin()).expect("Austin loads");
    let mut w = RoadWindow::default();
    sc.road.window(1000.0, 2.5, 0.5, 20.0, &mut w);
    let (lo, hi) = sc.road.edges(1000.0 + 50.0);
    assert!((w.e_min[20] - (lo + 0.5)).abs() < 1e-12);
    assert!((w.e_max[20] - (hi - 0.5)).abs() < 1e-12);
    assert_eq!(w.e_min[0], sc.road.edges(1000.0).0);
}

/// The oval's margin ramp over 20 m with no floor.
fn start_ramp(margin: f64, arrest_accel: f64) -> StartRamp {
    StartRamp {
        margin,
        length_m: 20.0,
        arrest_accel,
        floor_m: 0.0,
    }
}

/// A car inside the margin and moving toward the edge gets a start ramp from where its
/// sideways motion can end (e_dot^2 / (2 a_lat) further out, never past the edge); moving
/// away, from where it is; in both cases the full margin after the ramp.
#[test]
fn the_start_ramp_leaves_room_for_a_car_drifting_toward_the_edge() {
    let oval = load(&RoadArgs::default()).unwrap();
    let (lo, _) = oval.road.edges(0.0);
    let e0 = lo + 0.425;
    let ramp = |e_dot: f64| {
        let mut w = RoadWindow::default();
        oval.road
            .window_from(0.0, (e0, e_dot), 2.5, &start_ramp(0.5, 4.0), &mut w);
        w
    };
    let still = ramp(0.0);
    assert!((still.e_min[0] - e0).abs() < 1e-12);
    let away = ramp(1.5);
    assert_eq!(away.e_min, still.e_min);
    // 1.2 m/s outward: 0.18 m of drift before the ramp.
    let out = ramp(-1.2);
    assert!(
        (out.e_min[0] - (e0 - 0.18)).abs() < 1e-12,
        "{}",
        out.e_min[0]
    );
    assert!(out.e_min[1] < still.e_min[1]);
    // 3 m/s outward would drift past the edge: the ramp starts at the edge.
    assert_eq!(ramp(-3.0).e_min[0], lo);
    for w in [still, away, out] {
        assert!((w.e_min[8] - (lo + 0.5)).abs() < 1e-12);
        assert!(w.e_min.iter().all(|&b| b >= lo));
    }
}

/// The drift allowance stops at the floor: a car 1.2 m inside the edge crossing toward it
/// at 5 m/s (3.1 m of drift at 4 m/s^2) gets a ramp from 0.3 m, not from the edge; a car
/// already closer than the floor keeps its own distance; a slow drift is granted in full.
#[test]
fn the_drift_allowance_never_takes_the_ramp_closer_to_the_edge_than_its_floor() {
    let oval = load(&RoadArgs::default()).unwrap();
    let (lo, _) = oval.road.edges(0.0);
    let ramp = |inside: f64, e_dot: f64, floor_m: f64| {
        let mut w = RoadWindow::default();
        let spec = StartRamp {
            floor_m,
            ..start_ramp(1.0, 4.0)
        };
        oval.road
            .window_from(0.0, (lo + inside, e_dot), 2.5, &spec, &mut w);
        w.e_min[0] - lo
    };
    assert!(ramp(1.2, -5.0, 0.0).abs() < 1e-12);
    assert!((ramp(1.2, -5.0, 0.3) - 0.3).abs() < 1e-12);
    assert!((ramp(0.2, -5.0, 0.3) - 0.2).abs() < 1e-12);
    // 1 m/s: 0.125 m of drift, above the floor either way.
    assert!((ramp(0.6, -1.0, 0.3) - 0.475).abs() < 1e-12);
    assert_eq!(ramp(0.6, -1.0, 0.3), ramp(0.6, -1.0, 0.0));
}

#[test]
fn the_road_id_covers_the_profile_bytes() {
    let a = load(&austin()).unwrap();
    let text = std::fs::read_to_string(root().join("config/tracks/Austin_profile.csv")).unwrap();
    let lap = a.road.lap();
    let same = user_profile("same", &text);
    let b = load(&user(&same, lap)).unwrap();
    assert_eq!(a.id, b.id, "the same bytes and lap are the same road");
    // One width changed in the last digit.
    let changed = text.replacen(
        "0.0,-0.00001073,7.565,7.361",
        "0.0,-0.00001073,7.565,7.362",
        1,
    );
    assert_ne!(changed, text);
    let other = user_profile("other", &changed);
    let c = load(&user(&other, lap)).unwrap();
    assert_ne!(a.id, c.id);
    let oval = load(&RoadArgs::default()).unwrap();
    assert_ne!(a.id, oval.id);
}

fn refused(name: &str, text: &str, lap: f64) -> String {
    let path = user_profile(name, text);
    match load(&user(&path, lap)) {
        Ok(_) => panic!("{name}: accepted"),
        Err(e) => {
            assert!(e.contains(&path.display().to_string()), "{name}: {e}");
            e
        }
    }
}

#[test]
fn a_bad_profile_is_refused_naming_file_and_row() {
    let head = "s_m,kappa_1pm,w_right_m,w_left_m\n";
    let ok = |rows: &str| format!("{head}0.0,0.0,4.0,4.0\n1.0,0.0,4.0,4.0\n{rows}");
    let e = refused("nan", &ok("2.0,NaN,4.0,4.0\n3.0,0.0,4.0,4.0\n"), 4.0);
    assert!(e.contains(":4:"), "{e}");
    let e = refused("order", &ok("0.5,0.0,4.0,4.0\n3.0,0.0,4.0,4.0\n"), 4.0);
    assert!(e.contains(":4:") && e.contains("increasing"), "{e}");
    let e = refused("width", &ok("2.0,0.0,-1.0,4.0\n3.0,0.0,4.0,4.0\n"), 4.0);
    assert!(e.contains(":4:") && e.contains("w_right_m"), "{e}");
    let e = refused("lap", &ok("2.0,0.0,4.0,4.0\n3.0,0.0,4.0,4.0\n"), 7.0);
    assert!(e.contains("lap_length_m"), "{e}");
}

#[test]
fn a_lane_margin_that_leaves_no_lane_names_the_row() {
    let text =
        "s_m,kappa_1pm,w_right_m,w_left_m\n0.0,0.0,4.0,4.0\n1.0,0.0,0.4,0.4\n2.0,0.0,4.0,4.0\n";
    let path = user_profile("narrow", text);
    let sc = load(&user(&path, 3.0)).unwrap();
    let e = sc.road.check_margin(0.5).unwrap_err();
    assert!(e.contains("row 1"), "{e}");
    assert!(sc.road.check_margin(0.3).is_ok());
}

#[test]
fn the_oval_stays_its_exact_pieces() {
    let sc = load(&RoadArgs::default()).unwrap();
    let old = ClosedRoad::new(
        vec![
            (0.0, 0.0),
            (50.0, 0.04),
            (128.5398163, 0.0),
            (178.5398163, 0.04),
        ],
        257.0796327,
        -4.0,
        4.0,
    );
    assert_eq!(sc.road, old);
}
