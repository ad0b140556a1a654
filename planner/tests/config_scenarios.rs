//! The shipped vehicle and scenario files load into sane OcpSpecs.

use planner::config::{data_root_of, list_selections, load_scenario, load_vehicle};
use planner::model::{ix, VehicleParams};
use planner::ocp::{InitialState, OcpSpec};
use std::path::{Path, PathBuf};

fn data_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config")
}

fn vehicle() -> VehicleParams {
    load_vehicle(&data_root().join("vehicles/lc500.toml")).expect("lc500 loads")
}

fn scenario(file: &str, select: Option<&str>) -> OcpSpec {
    let path = data_root().join("scenarios").join(file);
    load_scenario(&path, select, vehicle()).unwrap_or_else(|e| panic!("{e}"))
}

fn assert_sane(spec: &OcpSpec) {
    let n = spec.n_intervals;
    assert!(n >= 1);
    for v in [&spec.kappa, &spec.e_min, &spec.e_max] {
        assert_eq!(v.len(), n + 1, "{}", spec.name);
        assert!(v.iter().all(|x| x.is_finite()), "{}", spec.name);
    }
    assert!(
        spec.e_min.iter().zip(&spec.e_max).all(|(lo, hi)| lo < hi),
        "{}",
        spec.name
    );
    assert!(0.0 < spec.v_min && spec.v_min < spec.v_max, "{}", spec.name);
}

#[test]
fn lc500_values() {
    let v = vehicle();
    assert_eq!((v.m, v.l, v.a, v.b), (1970.0, 2.87, 1.378, 1.492));
    assert_eq!((v.c_f, v.c_r, v.mu, v.c_l), (160000.0, 190000.0, 1.0, 10.0));
    assert_eq!(
        (v.t_comb_min, v.t_comb_max, v.t_bf_min, v.t_bf_max),
        (-3500.0, 4500.0, -3500.0, 0.0)
    );
    assert_eq!(
        (v.eps_sigma, v.eps_sat, v.fmax_floor_frac),
        (1e-3, 0.01, 0.01)
    );
    assert_eq!(
        (v.r_w, v.i_w, v.i_z, v.h_cg, v.g),
        (0.35, 3.6, 4000.0, 0.47, 9.81)
    );
    assert_eq!((v.delta_max, v.v_wr_min), (0.55, 0.0));
    assert_eq!(
        (v.delta_rate_max, v.t_comb_rate_max, v.t_bf_rate_max),
        (1.0, 20000.0, 30000.0)
    );
}

#[test]
fn oval_uses_the_exact_pieces() {
    let spec = scenario("oval.toml", None);
    assert_sane(&spec);
    assert_eq!(spec.name, "oval");
    assert_eq!(
        (spec.n_intervals, spec.length, spec.ds()),
        (100, 260.0, 2.6)
    );
    assert_eq!(spec.kappa[19], 0.0); // s = 49.4: still on the straight
    assert_eq!(spec.kappa[20], 0.04); // s = 52.0: in the turn
    assert_eq!(spec.kappa[49], 0.04); // s = 127.4
    assert_eq!(spec.kappa[50], 0.0); // s = 130.0 > 128.54
    assert_eq!(spec.kappa[68], 0.0); // s = 176.8 < 178.54
    assert_eq!(spec.kappa[69], 0.04); // s = 179.4
    assert_eq!(spec.kappa[98], 0.04); // s = 254.8
    assert_eq!(spec.kappa[100], 0.0); // s = 260 > 257.08: the starting straight again
    let turn_nodes = spec.kappa.iter().filter(|&&k| k == 0.04).count();
    // Turns cover [50, 128.54) and [178.54, 257.08): nodes 20..=49 and 69..=98.
    assert_eq!(turn_nodes, 60);
    assert!(spec.e_min.iter().all(|&e| e == -4.0) && spec.e_max.iter().all(|&e| e == 4.0));
    assert_eq!((spec.v_min, spec.v_max), (5.0, 40.0));
    assert!(spec.enforce_tire_saturation);
    assert_eq!(spec.initial, InitialState::Free);
    assert_eq!(spec.vehicle, vehicle());
    assert!(list_selections(&data_root().join("scenarios/oval.toml"))
        .unwrap()
        .is_empty());
}

#[test]
fn oval_pieces_agree_with_the_sampled_profile_csv() {
    // The 1 m CSV of the oval holds the same curvature; away from the breakpoints the
    // nodes must match its rows exactly.
    let spec = scenario("oval.toml", None);
    let csv = std::fs::read_to_string(data_root().join("scenarios/oval_profile.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    for (k, kappa) in spec.kappa.iter().enumerate() {
        let s = spec.ds() * k as f64;
        let (lo, hi) = (&rows[s.floor() as usize], &rows[s.ceil() as usize]);
        if lo[1] == hi[1] {
            assert_eq!(*kappa, lo[1], "node {k}, s = {s}");
        }
    }
}

#[test]
fn segments_s01_to_s10() {
    let path = data_root().join("scenarios/segments.toml");
    let names = list_selections(&path).unwrap();
    let want: Vec<String> = (1..=10).map(|i| format!("S{i:02}")).collect();
    assert_eq!(names, want);
    // Peak |kappa| at the nodes vs. the "# computed:" comments (profile peak, 1 m grid):
    // node values can only be lower, by at most a little since ds = 2.5 m.
    let peaks = [
        0.0878, 0.0123, 0.0191, 0.0330, 0.0382, 0.0740, 0.0715, 0.0505, 0.0861, 0.0190,
    ];
    for (name, peak) in names.iter().zip(peaks) {
        let spec = scenario("segments.toml", Some(name));
        assert_sane(&spec);
        assert_eq!(&spec.name, name);
        assert_eq!(
            (spec.n_intervals, spec.length, spec.ds()),
            (100, 250.0, 2.5)
        );
        assert_eq!((spec.v_min, spec.v_max), (5.0, 70.0));
        assert!(spec.enforce_tire_saturation);
        assert_eq!(spec.initial, InitialState::Free);
        let node_peak = spec.kappa.iter().fold(0.0f64, |m, k| m.max(k.abs()));
        assert!(
            node_peak <= peak + 1e-4 && node_peak > 0.9 * peak,
            "{name}: {node_peak} vs {peak}"
        );
        // Minimum track width >= 11 m everywhere: bounds leave >= 9 m with the 1 m margins.
        let min_width = spec
            .e_min
            .iter()
            .zip(&spec.e_max)
            .map(|(lo, hi)| hi - lo)
            .fold(f64::INFINITY, f64::min);
        assert!(min_width > 9.0, "{name}: {min_width}");
        assert!(spec.e_min.iter().all(|&e| e < 0.0) && spec.e_max.iter().all(|&e| e > 0.0));
    }
}

#[test]
fn segment_s01_node_values_follow_the_profile() {
    // S01 starts at track s = 480; node 4 is track s = 490, a row of the profile.
    let spec = scenario("segments.toml", Some("S01"));
    let csv = std::fs::read_to_string(data_root().join("tracks/Austin_profile.csv")).unwrap();
    let row: Vec<f64> = csv
        .lines()
        .nth(1 + 490)
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    assert_eq!(row[0], 490.0);
    assert_eq!(spec.kappa[4], row[1]);
    assert!((spec.e_min[4] - (-row[2] + 1.0)).abs() < 1e-12);
    assert!((spec.e_max[4] - (row[3] - 1.0)).abs() < 1e-12);
    // Node 1 is track s = 482.5: the mean of rows 482 and 483.
    let r = |s: usize| -> Vec<f64> {
        csv.lines()
            .nth(1 + s)
            .unwrap()
            .split(',')
            .map(|x| x.parse().unwrap())
            .collect()
    };
    assert!((spec.kappa[1] - 0.5 * (r(482)[1] + r(483)[1])).abs() < 1e-12);
}

#[test]
fn collision_avoidance_scenarios() {
    let path = data_root().join("scenarios/collision_avoidance.toml");
    assert_eq!(list_selections(&path).unwrap(), ["forgiving", "critical"]);
    let node = |s: f64| (s / 1.25).round() as usize;

    let crit = scenario("collision_avoidance.toml", Some("critical"));
    assert_sane(&crit);
    assert_eq!((crit.n_intervals, crit.length), (100, 125.0));
    assert!(crit.kappa.iter().all(|&k| k == 0.0));
    assert!(!crit.enforce_tire_saturation);
    for k in node(12.5)..=node(17.5) {
        assert_eq!((crit.e_min[k], crit.e_max[k]), (1.0, 3.5), "node {k}");
    }
    for k in node(35.0)..=node(40.0) {
        assert_eq!((crit.e_min[k], crit.e_max[k]), (-3.5, -1.25), "node {k}");
    }
    let narrowed: Vec<usize> = (0..=100)
        .filter(|&k| crit.e_min[k] != -3.5 || crit.e_max[k] != 3.5)
        .collect();
    assert_eq!(narrowed, [10, 11, 12, 13, 14, 28, 29, 30, 31, 32]);
    let InitialState::Fixed(x0) = crit.initial else {
        panic!("fixed initial state expected")
    };
    let mut want = [0.0; 9];
    want[ix::V] = 25.0;
    want[ix::VWR] = 25.0;
    assert_eq!(x0, want);

    let forg = scenario("collision_avoidance.toml", Some("forgiving"));
    assert_sane(&forg);
    for k in node(40.0)..=node(45.0) {
        assert_eq!(forg.e_min[k], 1.0);
    }
    for k in node(75.0)..=node(80.0) {
        assert_eq!(forg.e_max[k], -1.0);
    }
    assert_eq!(forg.e_min[node(40.0) - 1], -3.5);
    assert_eq!(forg.e_max[node(80.0) + 1], 3.5);
}

#[test]
fn split_collision_files_equal_the_combined_file() {
    for name in ["forgiving", "critical"] {
        let combined = scenario("collision_avoidance.toml", Some(name));
        let split = scenario(&format!("ca_{name}.toml"), None);
        assert_eq!(split, combined, "{name}");
        assert_eq!(scenario(&format!("ca_{name}.toml"), Some(name)), combined);
    }
}

#[test]
fn data_root_is_the_parent_of_the_scenario_folder() {
    assert_eq!(
        data_root_of(Path::new("config/scenarios/oval.toml")),
        Path::new("config")
    );
    assert_eq!(
        data_root_of(Path::new("/a/b/scenarios/x.toml")),
        Path::new("/a/b")
    );
    assert_eq!(data_root_of(Path::new("scenarios/x.toml")), Path::new("."));
    assert_eq!(data_root_of(Path::new("x.toml")), Path::new("./.."));
}

/// The receding-horizon set is S01-S10 started 30 and 15 m earlier and later: the same
/// road, shifted by 12 or 6 nodes (ds = 2.5 m), and the same problem otherwise.
#[test]
fn shifted_segments_are_the_benchmark_segments_moved_along_the_track() {
    let path = data_root().join("scenarios/segments_shifted.toml");
    let names = list_selections(&path).unwrap();
    assert_eq!(names.len(), 40);
    for shift in [-30i32, -15, 15, 30] {
        for i in 1..=10 {
            let base = scenario("segments.toml", Some(&format!("S{i:02}")));
            let name = format!("S{i:02}{shift:+}");
            assert!(names.contains(&name), "{name}");
            let moved = scenario("segments_shifted.toml", Some(&name));
            assert_sane(&moved);
            assert_eq!(
                (moved.n_intervals, moved.length, moved.v_max, moved.initial),
                (base.n_intervals, base.length, base.v_max, base.initial)
            );
            let nodes = (shift.unsigned_abs() as f64 / base.ds()).round() as usize;
            let n = base.n_intervals + 1;
            for k in 0..n - nodes {
                // Node k of the later start is node k + nodes of the earlier one.
                let (early, late, kk) = if shift > 0 {
                    (&base, &moved, k)
                } else {
                    (&moved, &base, k)
                };
                for (a, b) in [
                    (&early.kappa, &late.kappa),
                    (&early.e_min, &late.e_min),
                    (&early.e_max, &late.e_max),
                ] {
                    assert!((a[kk + nodes] - b[kk]).abs() < 1e-12, "{name} node {k}");
                }
            }
        }
    }
}

/// The shipped objectives: the oval and the race segments (plain and shifted) weight the
/// steering slew by 1, the collision-avoidance scenarios keep the paper's pure minimum time.
#[test]
fn shipped_steering_slew_weights() {
    assert_eq!(scenario("oval.toml", None).steering_slew_weight, 1.0);
    assert_eq!(
        scenario("segments.toml", Some("S07")).steering_slew_weight,
        1.0
    );
    assert_eq!(
        scenario("segments_shifted.toml", Some("S07-15")).steering_slew_weight,
        1.0
    );
    for (file, sel) in [
        ("collision_avoidance.toml", Some("critical")),
        ("ca_forgiving.toml", None),
        ("ca_critical.toml", None),
    ] {
        assert_eq!(scenario(file, sel).steering_slew_weight, 0.0, "{file}");
    }
}
