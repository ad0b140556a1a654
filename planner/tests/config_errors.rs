//! Broken configuration files give errors that name the file and the field or line.

use planner::config::{load_scenario, load_scenario_for_horizon, load_vehicle, ConfigError};
use planner::model::VehicleParams;
use planner::track::Profile;
use std::path::{Path, PathBuf};

fn shipped(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../config")
        .join(rel)
}

fn shipped_text(rel: &str) -> String {
    std::fs::read_to_string(shipped(rel)).unwrap()
}

fn vehicle() -> VehicleParams {
    load_vehicle(&shipped("vehicles/lc500.toml")).unwrap()
}

/// A fresh data root under the system temp dir (scenarios/, tracks/, vehicles/), removed on drop.
struct TempRoot(PathBuf);

impl TempRoot {
    fn new(test: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("planner-config-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for sub in ["scenarios", "tracks", "vehicles"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        TempRoot(dir)
    }

    fn write(&self, rel: &str, text: &str) -> PathBuf {
        let p = self.0.join(rel);
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for TempRoot {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The error text, after checking it names the file.
fn message(err: ConfigError, file: &Path) -> String {
    let text = err.to_string();
    assert!(
        text.starts_with(&file.display().to_string()),
        "error does not name {}: {text}",
        file.display()
    );
    text
}

fn vehicle_error(test: &str, text: &str) -> String {
    let root = TempRoot::new(test);
    let path = root.write("vehicles/car.toml", text);
    let err = load_vehicle(&path).expect_err("broken vehicle file must not load");
    message(err, &path)
}

fn lc500_with(from: &str, to: &str) -> String {
    let text = shipped_text("vehicles/lc500.toml");
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

#[test]
fn vehicle_missing_field() {
    let msg = vehicle_error("missing", &lc500_with("m = 1970.0", ""));
    assert!(msg.ends_with("chassis.m: missing (required)"), "{msg}");
    let msg = vehicle_error(
        "missing-table",
        &lc500_with("[load_transfer]\nc_L = 10.0", ""),
    );
    assert!(msg.ends_with("load_transfer: missing (required)"), "{msg}");
}

#[test]
fn vehicle_nan() {
    let msg = vehicle_error("nan", &lc500_with("mu = 1.0", "mu = nan"));
    assert!(
        msg.ends_with("tire.mu = NaN: must be a finite number"),
        "{msg}"
    );
}

#[test]
fn vehicle_negative_mass() {
    let msg = vehicle_error("negative-mass", &lc500_with("m = 1970.0", "m = -5.0"));
    assert!(
        msg.ends_with("vehicles/car.toml: chassis.m = -5: must be positive"),
        "{msg}"
    );
}

#[test]
fn vehicle_extreme_values_name_the_key_and_the_accepted_range() {
    for (m, shown) in [("1e300", "1e300"), ("1e-6", "1e-6")] {
        let msg = vehicle_error(
            "extreme-mass",
            &lc500_with("m = 1970.0", &format!("m = {m}")),
        );
        assert!(
            msg.ends_with(&format!(
                "vehicles/car.toml: chassis.m = {shown}: must lie within the accepted range [5e1, 1e5] kg"
            )),
            "{msg}"
        );
    }
    let msg = vehicle_error("extreme-mu", &lc500_with("mu = 1.0", "mu = 40.0"));
    assert!(
        msg.contains("tire.mu = 40.0: must lie within the accepted range [5e-2, 3e0] -"),
        "{msg}"
    );
}

#[test]
fn vehicle_inconsistent_values() {
    let msg = vehicle_error("ab", &lc500_with("b = 1.492", "b = 1.5"));
    assert!(
        msg.contains("chassis.a + chassis.b = 2.878: must equal chassis.L = 2.87"),
        "{msg}"
    );
    let msg = vehicle_error(
        "tcomb",
        &lc500_with("T_comb_min = -3500.0", "T_comb_min = 10.0"),
    );
    assert!(
        msg.contains("limits.T_comb_min = 10: must be negative"),
        "{msg}"
    );
    let msg = vehicle_error("tbf", &lc500_with("T_bf_max = 0.0", "T_bf_max = 5.0"));
    assert!(msg.contains("limits.T_bf_max = 5: must be <= 0"), "{msg}");
    let msg = vehicle_error(
        "floor",
        &lc500_with("fmax_floor_frac = 0.01", "fmax_floor_frac = 1.5"),
    );
    assert!(
        msg.contains("model.fmax_floor_frac = 1.5: must lie in (0, 1)"),
        "{msg}"
    );
}

#[test]
fn vehicle_unknown_key_and_wrong_type() {
    let msg = vehicle_error(
        "unknown",
        &lc500_with("h_cg = 0.47", "h_cg = 0.47\nh_cgg = 0.5"),
    );
    assert!(msg.contains("unknown field `h_cgg`"), "{msg}");
    assert!(msg.contains("line 23"), "{msg}");
    let msg = vehicle_error("type", &lc500_with("I_z = 4000.0", "I_z = \"heavy\""));
    assert!(
        msg.contains("line 23") && msg.contains("expected f64"),
        "{msg}"
    );
}

#[test]
fn vehicle_truncated_file() {
    let text = shipped_text("vehicles/lc500.toml");
    // Cut in the middle of line 34, right after "C_r = ".
    let cut = text.find("C_r = ").unwrap() + "C_r = ".len();
    let msg = vehicle_error("truncated", &text[..cut]);
    assert!(msg.contains("TOML parse error at line 34"), "{msg}");
}

#[test]
fn vehicle_file_absent() {
    let path = std::env::temp_dir().join("planner-config-no-such-dir/none.toml");
    let msg = message(load_vehicle(&path).unwrap_err(), &path);
    assert!(msg.contains("cannot read file"), "{msg}");
}

// ------------------------------------------------------------------ profile CSVs

fn profile_csv(rows: usize) -> String {
    let mut s = String::from("s_m,kappa_1pm,w_right_m,w_left_m\n");
    for i in 0..rows {
        s.push_str(&format!("{i}.0,0.001,5.0,5.0\n"));
    }
    s
}

fn profile_error(test: &str, text: &str, lap: f64) -> String {
    let root = TempRoot::new(test);
    let path = root.write("tracks/T_profile.csv", text);
    let err = Profile::load(&path, lap).expect_err("broken profile must not load");
    message(err.into(), &path)
}

#[test]
fn profile_non_monotone_s() {
    let text = profile_csv(10).replacen("5.0,0.001", "3.0,0.001", 1);
    let msg = profile_error("monotone", &text, 10.0);
    // Row s = 5 is line 7 (header is line 1).
    assert!(
        msg.contains("T_profile.csv:7: s_m = 3: must be strictly increasing"),
        "{msg}"
    );
    let text = profile_csv(10).replacen("5.0,0.001", "5.5,0.001", 1);
    let msg = profile_error("step", &text, 10.0);
    assert!(msg.contains(":7: s_m = 5.5: step 1.5 differs"), "{msg}");
}

#[test]
fn profile_lane_beyond_the_curvature_centre_names_the_line() {
    let text = profile_csv(10).replacen("2.0,0.001,5.0,5.0", "2.0,1e308,5.0,5.0", 1);
    let msg = profile_error("kappa-big", &text, 10.0);
    assert!(
        msg.contains("T_profile.csv:4: kappa_1pm = 1e308: the track edge w_left_m = 5 lies at or beyond the curvature centre"),
        "{msg}"
    );
    let text = profile_csv(10).replacen("7.0,0.001,5.0,5.0", "7.0,-0.25,5.0,3.0", 1);
    let msg = profile_error("kappa-neg", &text, 10.0);
    assert!(
        msg.contains("T_profile.csv:9: kappa_1pm = -0.25: the track edge w_right_m = 5 lies"),
        "{msg}"
    );
}

#[test]
fn profile_wrong_column_count() {
    let text = profile_csv(10).replacen("4.0,0.001,5.0,5.0", "4.0,0.001,5.0", 1);
    let msg = profile_error("columns", &text, 10.0);
    assert!(
        msg.contains(
            "T_profile.csv:6: expected 4 columns (s_m,kappa_1pm,w_right_m,w_left_m), found 3"
        ),
        "{msg}"
    );
}

#[test]
fn profile_truncated_file() {
    let text = profile_csv(10);
    let msg = profile_error("truncated", &text[..text.len() - 8], 10.0);
    assert!(
        msg.contains("T_profile.csv:11: expected 4 columns"),
        "{msg}"
    );
}

#[test]
fn profile_bad_values_and_header() {
    let text = profile_csv(10).replacen("2.0,0.001", "2.0,NaN", 1);
    assert!(profile_error("nan", &text, 10.0).contains(":4: kappa_1pm = NaN: must be finite"));
    let text = profile_csv(10).replacen("2.0,0.001,5.0", "2.0,0.001,-1", 1);
    assert!(profile_error("width", &text, 10.0).contains(":4: w_right_m = -1: must be positive"));
    let text = profile_csv(10).replacen("2.0,0.001", "2.0,x", 1);
    assert!(profile_error("text", &text, 10.0).contains(":4: kappa_1pm = `x`: not a number"));
    let text = profile_csv(10).replacen("s_m,", "s,", 1);
    let msg = profile_error("header", &text, 10.0);
    assert!(
        msg.contains(":1: header must be `s_m,kappa_1pm,w_right_m,w_left_m`, found `s,kappa_1pm"),
        "{msg}"
    );
    let msg = profile_error("lap", &profile_csv(10), 12.0);
    assert!(msg.contains("lap_length_m = 12: lap length of this profile must lie in (s_last, s_last + step] = (9, 10]"), "{msg}");
}

// ------------------------------------------------------------------ scenario files

/// A one-track segments file over a 100 m synthetic profile, with `extra` appended.
fn segments_file(root: &TempRoot, s_start: &str, extra: &str) -> PathBuf {
    root.write("tracks/T_profile.csv", &profile_csv(100));
    root.write(
        "scenarios/seg.toml",
        &format!(
            r#"[defaults]
objective = "min_time"
length_m = 50.0
n_intervals = 20
ds_m = 2.5
v_min_mps = 5.0
v_max_mps = 70.0
edge_margin_m = 1.0
enforce_tire_saturation = true
initial_state = {{ mode = "free" }}

[[tracks]]
name = "T"
profile_csv = "tracks/T_profile.csv"
lap_length_m = 100.0
direction = "ccw"

[[segments]]
name = "A"
track = "T"
s_start_m = {s_start}

[[segments]]
name = "B"
track = "T"
s_start_m = 80.0
{extra}"#
        ),
    )
}

#[test]
fn synthetic_segments_file_loads_and_wraps() {
    let root = TempRoot::new("seg-ok");
    let path = segments_file(&root, "0.0", "");
    let spec = load_scenario(&path, Some("B"), vehicle()).unwrap();
    assert_eq!(spec.kappa.len(), 21);
    assert!(spec.kappa.iter().all(|&k| (k - 0.001).abs() < 1e-15));
    assert!(spec.e_min.iter().all(|&e| e == -4.0) && spec.e_max.iter().all(|&e| e == 4.0));
}

#[test]
fn unknown_segment_name() {
    let root = TempRoot::new("seg-unknown");
    let path = segments_file(&root, "0.0", "");
    let msg = message(
        load_scenario(&path, Some("S99"), vehicle()).unwrap_err(),
        &path,
    );
    assert!(
        msg.ends_with("seg.toml: no segment named \"S99\"; available: A, B"),
        "{msg}"
    );
    let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
    assert!(
        msg.contains("the file holds 2 segments: select one by name; available: A, B"),
        "{msg}"
    );
    let shipped_path = shipped("scenarios/segments.toml");
    let msg = load_scenario(&shipped_path, Some("S11"), vehicle())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("available: S01, S02, S03, S04, S05, S06, S07, S08, S09, S10"),
        "{msg}"
    );
}

#[test]
fn segment_fields() {
    let root = TempRoot::new("seg-nan");
    let path = segments_file(&root, "nan", "");
    let msg = message(
        load_scenario(&path, Some("A"), vehicle()).unwrap_err(),
        &path,
    );
    assert!(
        msg.ends_with("segments[A].s_start_m = NaN: must be a finite number"),
        "{msg}"
    );
    // A segment with its own interval count derives its ds; a ds it states is checked.
    let root = TempRoot::new("seg-ds");
    let path = segments_file(&root, "0.0", "n_intervals = 40\n");
    let spec = load_scenario(&path, Some("B"), vehicle()).unwrap();
    assert_eq!((spec.n_intervals, spec.ds()), (40, 1.25));
    let path = segments_file(&root, "0.0", "n_intervals = 40\nds_m = 2.5\n");
    let msg = message(
        load_scenario(&path, Some("B"), vehicle()).unwrap_err(),
        &path,
    );
    assert!(
        msg.contains(
            "segments[B].ds_m = 2.5: must equal defaults.length_m / segments.n_intervals = 1.25"
        ),
        "{msg}"
    );
    // A node spacing over 5 m is refused in words.
    let path = segments_file(&root, "0.0", "length_m = 100.0\nn_intervals = 10\n");
    let msg = message(
        load_scenario(&path, Some("B"), vehicle()).unwrap_err(),
        &path,
    );
    assert!(
        msg.contains("segments[B].length_m = 100: puts the 11 nodes 10.000 m apart; over 5 m the model steps across corners"),
        "{msg}"
    );
    let root = TempRoot::new("seg-track");
    let path = segments_file(&root, "0.0", "");
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text.replace(
            "track = \"T\"\ns_start_m = 80.0",
            "track = \"U\"\ns_start_m = 80.0",
        ),
    )
    .unwrap();
    let msg = message(
        load_scenario(&path, Some("B"), vehicle()).unwrap_err(),
        &path,
    );
    assert!(
        msg.ends_with("segments[B].track = \"U\": must name a [[tracks]] entry (have: T)"),
        "{msg}"
    );
    // Only the selected entry is resolved: A still loads.
    assert!(load_scenario(&path, Some("A"), vehicle()).is_ok());
}

#[test]
fn bounds_must_leave_a_corridor_at_every_node() {
    // Segments: a 5 m margin eats the whole 5 + 5 m track.
    let root = TempRoot::new("seg-margin");
    let path = segments_file(&root, "0.0", "");
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(
        &path,
        text.replace("edge_margin_m = 1.0", "edge_margin_m = 5.0"),
    )
    .unwrap();
    let msg = message(
        load_scenario(&path, Some("A"), vehicle()).unwrap_err(),
        &path,
    );
    assert!(
        msg.ends_with(
            "A at node 0 (s = 0) = e_min 0, e_max 0: lateral bounds must satisfy e_min < e_max"
        ),
        "{msg}"
    );
    // Oval: constant lane bounds the wrong way round.
    let root = TempRoot::new("oval-lane");
    let text = shipped_text("scenarios/oval.toml").replacen("e_max_m = 4.0", "e_max_m = -4.0", 1);
    let path = root.write("scenarios/oval.toml", &text);
    let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
    assert!(msg.ends_with("oval at node 0 (s = 0) = e_min -4, e_max -4: lateral bounds must satisfy e_min < e_max"), "{msg}");
}

#[test]
fn segment_profile_errors_name_the_csv_line() {
    let root = TempRoot::new("seg-csv");
    let path = segments_file(&root, "0.0", "");
    let csv = root.write(
        "tracks/T_profile.csv",
        &profile_csv(100).replacen("50.0,", "49.0,", 1),
    );
    let msg = message(
        load_scenario(&path, Some("A"), vehicle()).unwrap_err(),
        &csv,
    );
    assert!(
        msg.contains("T_profile.csv:52: s_m = 49: must be strictly increasing"),
        "{msg}"
    );
}

fn ca_error(test: &str, from: &str, to: &str, select: Option<&str>) -> String {
    let root = TempRoot::new(test);
    let text = shipped_text("scenarios/ca_critical.toml");
    assert!(text.contains(from), "{from}");
    let path = root.write("scenarios/ca.toml", &text.replacen(from, to, 1));
    message(
        load_scenario(&path, select, vehicle()).expect_err("broken scenario must not load"),
        &path,
    )
}

#[test]
fn collision_scenario_road_and_horizon_errors_name_the_key() {
    let msg = ca_error(
        "ca-nan",
        "[12.5, 17.5, 1.0, 3.5]",
        "[12.5, 17.5, nan, 3.5]",
        None,
    );
    assert!(
        msg.contains(
            "scenarios[critical].bounds_override[0] = [12.5, 17.5, NaN, 3.5]: must be finite"
        ),
        "{msg}"
    );
    let msg = ca_error(
        "ca-len",
        "[12.5, 17.5, 1.0, 3.5]",
        "[12.5, 17.5, 1.0]",
        None,
    );
    assert!(
        msg.contains(
            "bounds_override[0] = [12.5, 17.5, 1.0]: expected [s_from_m, s_to_m, e_min_m, e_max_m]"
        ),
        "{msg}"
    );
    let msg = ca_error("ca-overlap", "[35.0, 40.0,", "[15.0, 40.0,", None);
    assert!(msg.contains("overlaps [12.5, 17.5]"), "{msg}");
    let msg = ca_error("ca-ds", "ds_m = 1.25", "ds_m = 1.3", None);
    assert!(
        msg.contains(
            "common.ds_m = 1.3: must equal common.horizon_length_m / common.n_intervals = 1.25"
        ),
        "{msg}"
    );
    let msg = ca_error("ca-n", "n_intervals = 100", "n_intervals = 0", None);
    assert!(
        msg.contains("common.n_intervals = 0: must be an integer >= 1"),
        "{msg}"
    );
    let msg = ca_error("ca-v", "v_max_mps = 40.0", "v_max_mps = 4.0", None);
    assert!(
        msg.contains("common.v_max_mps = 4: must exceed common.v_min_mps = 5"),
        "{msg}"
    );
    let msg = ca_error("ca-vmin", "v_min_mps = 5.0", "v_min_mps = 0.0", None);
    assert!(
        msg.contains("common.v_min_mps = 0: must be positive"),
        "{msg}"
    );
    let msg = ca_error(
        "ca-bounds",
        "[35.0, 40.0, -3.5, -1.25]",
        "[35.0, 40.0, -3.5, -4.0]",
        None,
    );
    assert!(
        msg.contains("needs s_from_m <= s_to_m and e_min_m < e_max_m"),
        "{msg}"
    );
    let msg = ca_error("ca-road", "road_e_max_m = 3.5", "road_e_max_m = -3.6", None);
    assert!(msg.contains("critical at node 0 (s = 0) = e_min -3.5, e_max -3.6: lateral bounds must satisfy e_min < e_max"), "{msg}");
}

#[test]
fn collision_scenario_initial_state_errors_name_the_entry() {
    let msg = ca_error("ca-mode", "mode = \"fixed\"", "mode = \"frozen\"", None);
    assert!(
        msg.contains("common.initial_state.mode = \"frozen\": must be one of \"free\", \"fixed\""),
        "{msg}"
    );
    let msg = ca_error("ca-missing", "dFz_N = 0.0", "", None);
    assert!(
        msg.ends_with("common.initial_state.dFz_N: missing (required)"),
        "{msg}"
    );
    let msg = ca_error("ca-v0", "V_mps = 25.0", "V_mps = 45.0", None);
    assert!(
        msg.contains("common.initial_state.V_mps = 45: must lie within the speed bounds [5, 40]"),
        "{msg}"
    );
    // The rest of the model's domain, each entry named.
    for (test, from, to, want) in [
        (
            "ca-dpsi",
            "dpsi_rad = 0.0",
            "dpsi_rad = 1.6",
            "common.initial_state.dpsi_rad = 1.6: is not within (-pi/2, pi/2)",
        ),
        (
            "ca-beta",
            "beta_rad = 0.0",
            "beta_rad = 3.0",
            "common.initial_state.beta_rad = 3: must lie within the sideslip envelope [-1.5, 1.5]",
        ),
        (
            "ca-r",
            "r_radps = 0.0",
            "r_radps = -50.0",
            "common.initial_state.r_radps = -50: must lie within the yaw-rate envelope [-10, 10]",
        ),
        (
            "ca-vwr",
            "V_wr_mps = 25.0",
            "V_wr_mps = -5.0",
            "common.initial_state.V_wr_mps = -5: must be at least V_wr_min = 0 (R10)",
        ),
        (
            "ca-dfz",
            "dFz_N = 0.0",
            "dFz_N = 1e6",
            "common.initial_state.dFz_N = 1000000: must lie within +-m g = [",
        ),
    ] {
        let msg = ca_error(test, from, to, None);
        assert!(msg.contains(want), "{msg}");
    }
}

#[test]
fn collision_scenario_selection_objective_and_curvature_errors_name_the_key() {
    let msg = ca_error("ca-select", "", "", Some("forgiving"));
    assert!(
        msg.ends_with("no scenario named \"forgiving\"; available: critical"),
        "{msg}"
    );
    let msg = ca_error(
        "ca-objective",
        "objective = \"min_time\"",
        "objective = \"max_fun\"",
        None,
    );
    assert!(
        msg.contains("objective = \"max_fun\": must be one of \"min_time\""),
        "{msg}"
    );
    // A road whose lane reaches the curvature centre (1 - kappa e <= 0): refused at load.
    for (kappa, bound) in [("1e308", "e_max"), ("-0.5", "e_min")] {
        let to = format!("kappa_1pm = {kappa}");
        let msg = ca_error("ca-kappa", "kappa_1pm = 0.0", &to, None);
        assert!(
            msg.contains(&format!(
                "common.kappa_1pm = {kappa}: puts the lane's {bound} at or beyond the curvature centre"
            )),
            "{msg}"
        );
    }
}

/// A scenario loaded for the planner's horizon names the file and the n_intervals key
/// when its N differs.
#[test]
fn a_horizon_other_than_the_planners_names_the_file_and_key() {
    let root = TempRoot::new("horizon");
    let text = shipped_text("scenarios/ca_critical.toml")
        .replacen("n_intervals = 100", "n_intervals = 50", 1)
        .replacen("ds_m = 1.25", "ds_m = 2.5", 1);
    let path = root.write("scenarios/ca.toml", &text);
    assert!(load_scenario(&path, None, vehicle()).is_ok());
    let err = load_scenario_for_horizon(&path, None, vehicle(), planner::HORIZON).unwrap_err();
    let msg = message(err, &path);
    assert!(
        msg.contains(
            "common.n_intervals = 50: must be 100, the horizon N the planner is built for"
        ),
        "{msg}"
    );
    let path = segments_file(&root, "0.0", "");
    let err = load_scenario_for_horizon(&path, Some("A"), vehicle(), planner::HORIZON).unwrap_err();
    let msg = message(err, &path);
    assert!(
        msg.contains("defaults.n_intervals = 20: must be 100"),
        "{msg}"
    );
    let path = segments_file(&root, "0.0", "n_intervals = 40\nds_m = 1.25\n");
    let err = load_scenario_for_horizon(&path, Some("B"), vehicle(), planner::HORIZON).unwrap_err();
    let msg = message(err, &path);
    assert!(
        msg.contains("segments[B].n_intervals = 40: must be 100"),
        "{msg}"
    );
    let spec = load_scenario_for_horizon(
        &shipped("scenarios/ca_critical.toml"),
        None,
        vehicle(),
        planner::HORIZON,
    )
    .unwrap();
    assert_eq!(spec.n_intervals, planner::HORIZON);
}

#[test]
fn oval_errors() {
    let root = TempRoot::new("oval");
    let text = shipped_text("scenarios/oval.toml");
    let bad = text.replacen("[50.0, 0.04]", "[50.0, 0.04, 1.0]", 1);
    let path = root.write("scenarios/oval.toml", &bad);
    let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
    assert!(
        msg.contains("track.kappa_pieces[1] = [50.0, 0.04, 1.0]: expected [s_start_m, kappa_1pm]"),
        "{msg}"
    );
    let bad = text.replacen("[128.5398163, 0.0]", "[28.5, 0.0]", 1);
    let path = root.write("scenarios/oval.toml", &bad);
    let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
    assert!(
        msg.contains("track.kappa_pieces[2] = [28.5, 0.0]: s_start_m must increase strictly"),
        "{msg}"
    );
    let bad = text.replacen("[50.0, 0.04]", "[50.0, 0.25]", 1);
    let path = root.write("scenarios/oval.toml", &bad);
    let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
    assert!(
        msg.contains("track.kappa_pieces[1] = 0.25: puts the lane's e_max at or beyond the curvature centre (1 - kappa e = 0.0)"),
        "{msg}"
    );
    let bad = text.replacen("lap_length_m = 257.0796327", "lap_length_m = 260.0", 1);
    let path = root.write("scenarios/oval.toml", &bad);
    let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
    assert!(
        msg.contains("geometry.lap_length_m = 260: must equal 2 straight_length_m + 2 pi radius_m"),
        "{msg}"
    );
    let bad = text.replacen("v_max_mps = 40.0", "v_max_mps = 40.0\nv_top_mps = 50.0", 1);
    let path = root.write("scenarios/oval.toml", &bad);
    let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
    assert!(
        msg.contains("unknown field `v_top_mps`, expected `v_min_mps` or `v_max_mps`"),
        "{msg}"
    );
    let path = root.write(
        "scenarios/oval.toml",
        "name = \"x\"\n[bounds]\nv_min_mps = 1.0\n",
    );
    let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
    assert!(
        msg.contains("(top level) = [bounds, name]: not a scenario file"),
        "{msg}"
    );
}

/// The objective's steering-slew weight: in each of the three scenario schemas a bad value
/// names the file and the field; absent is 0 (the paper's pure minimum time).
#[test]
fn steering_slew_weight_errors() {
    let root = TempRoot::new("slew");
    let oval = shipped_text("scenarios/oval.toml");
    assert!(oval.contains("steering_slew_weight = 1.0"));
    for (to, expect) in [
        ("-1.0", "options.steering_slew_weight = -1: must be >= 0"),
        (
            "nan",
            "options.steering_slew_weight = NaN: must be a finite number",
        ),
        (
            "2000.0",
            "options.steering_slew_weight = 2000: must be at most 1000",
        ),
        ("\"one\"", "invalid type: string \"one\", expected f64"),
    ] {
        let bad = oval.replacen(
            "steering_slew_weight = 1.0",
            &format!("steering_slew_weight = {to}"),
            1,
        );
        let path = root.write("scenarios/oval.toml", &bad);
        let msg = message(load_scenario(&path, None, vehicle()).unwrap_err(), &path);
        assert!(msg.contains(expect), "{msg}");
    }
    let absent = oval.replacen("steering_slew_weight = 1.0", "", 1);
    let path = root.write("scenarios/oval.toml", &absent);
    assert_eq!(
        load_scenario(&path, None, vehicle())
            .unwrap()
            .steering_slew_weight,
        0.0
    );
    let path = segments_file(&root, "10.0", "");
    let text = std::fs::read_to_string(&path).unwrap().replacen(
        "enforce_tire_saturation = true",
        "enforce_tire_saturation = true\nsteering_slew_weight = -0.5",
        1,
    );
    let path = root.write("scenarios/seg.toml", &text);
    let msg = message(
        load_scenario(&path, Some("A"), vehicle()).unwrap_err(),
        &path,
    );
    assert!(
        msg.contains("defaults.steering_slew_weight = -0.5: must be >= 0"),
        "{msg}"
    );
    let msg = ca_error(
        "ca-slew",
        "steering_slew_weight = 0.0",
        "steering_slew_weight = inf",
        None,
    );
    assert!(
        msg.contains("common.steering_slew_weight = inf: must be a finite number"),
        "{msg}"
    );
}
