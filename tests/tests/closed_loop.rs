//! End-to-end: `trajopt closed-loop` starts `planner_proc` and `tracker_proc` (ipc crate),
//! runs the oval closed loop over iceoryx2 and shuts both down.
//!
//! The binaries are found next to the test's target profile folder; `cargo test --workspace`
//! builds them (`cargo test -p e2e` alone does not: run `cargo build -p ipc -p planner --bins` first).

use std::path::PathBuf;
use std::process::Command;
use std::sync::{Mutex, MutexGuard};

/// Serialises the tests of this file so two closed loops never compete for the cores.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    SERIAL
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A cycle budget no solve reaches: the tests of tracking and of determinism run in the
/// dev profile on shared cores, where a solve can take longer than the 80 ms default
/// (a time budget that stops a solve is not deterministic); the budget has its own test.
const ROOMY_BUDGET: [&str; 2] = ["--budget-ms", "1000"];

/// A solver iteration cap just above the first (cold) plan's 25 iterations at 15 m/s on the
/// oval: that plan converges, and a cold fall-back that starts a few iterations late
/// does not.
const CAPPED_MAX_ITER: usize = 26;

fn bin_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/closed_loop-<hash> -> target/<profile>
    exe.parent()
        .and_then(|d| d.parent())
        .expect("target profile folder")
        .to_path_buf()
}

fn run_closed_loop(distance_m: f64, extra: &[&str]) -> serde_json::Value {
    let dir = bin_dir();
    for b in ["trajopt", "planner_proc", "tracker_proc"] {
        assert!(
            dir.join(b).is_file(),
            "{} missing: build with `cargo build -p ipc -p planner --bins` (same profile)",
            dir.join(b).display()
        );
    }
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let prefix = format!("e2e-{}-{}", std::process::id(), line!());
    let out = Command::new(dir.join("trajopt"))
        .current_dir(&repo)
        .args(["closed-loop", "--json", "--service-prefix", &prefix])
        .args([
            "--distance-m",
            &distance_m.to_string(),
            "--duration-s",
            "60",
        ])
        .args(extra)
        .output()
        .expect("run trajopt closed-loop");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "closed-loop failed:\n{stderr}");
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("bad JSON ({e}):\n{stderr}"))
}

/// `replay run FILE --json`: its report, whether it exited 0, and its stderr.
fn replay_run_json(replay: &std::path::Path, file: &str) -> (serde_json::Value, bool, String) {
    let out = Command::new(replay)
        .args(["run", file, "--json"])
        .output()
        .expect("run replay");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let r = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("bad replay JSON ({e}):\n{stderr}"));
    (r, out.status.success(), stderr)
}

/// The closed loop's acceptance criterion: one lap of the oval over iceoryx2, the car stays in the
/// lane and within 0.5 m of the plan, and both processes shut down (the command returns
/// only after both exited).
#[test]
fn closed_loop_oval_lap_keeps_lane_and_tracks_plan() {
    let _serial = serial();
    let v = run_closed_loop(0.0, &ROOMY_BUDGET);
    for k in [
        "laps_or_distance_m",
        "plans_received",
        "max_lateral_error_m",
        "rms_lateral_error_m",
        "max_sideslip_error_rad",
        "plan_latency_ms_p50",
        "plan_latency_ms_p99",
        "ipc_latency_us_p50",
        "ipc_latency_us_p99",
    ] {
        assert!(v.get(k).is_some_and(|x| !x.is_null()), "{k} missing in {v}");
    }
    assert!(v["plans_received"].as_u64().unwrap_or(0) >= 10, "{v}");
    assert!(
        v["laps_or_distance_m"].as_f64().unwrap_or(0.0) > 250.0,
        "{v}"
    );
    assert_eq!(v["lane_kept"], serde_json::json!(true), "{v}");
    let max_e = v["max_lateral_error_m"].as_f64().unwrap_or(f64::INFINITY);
    assert!(max_e < 0.5, "max lateral error {max_e} m\n{v}");
}

/// Against a plant that is not the planner's model (`--mismatch default`: friction -5 %,
/// mass +5 %, yaw inertia +10 %, cornering stiffness -10 %, 50 ms steering lag, 20 ms
/// delay, noisy measured state) the oval lap keeps the lane and stays within 0.6 m of the
/// plan (0.1 m more than without mismatch: a noisy start near the edge can cost the
/// planner a slow solve), the summary names the mismatch and the plant's own minimum lap,
/// and the tracker reports the values it used.
#[test]
fn closed_loop_oval_lap_with_the_default_mismatch_keeps_lane() {
    let _serial = serial();
    let v = run_closed_loop(0.0, &["--mismatch", "default"]);
    assert_eq!(v["mismatch"], serde_json::json!("default"), "{v}");
    let used = &v["tracker"]["mismatch_values"];
    assert_eq!(used["vehicle"]["friction"].as_f64(), Some(-0.05), "{v}");
    assert_eq!(
        used["actuator"]["transport_delay_s"].as_f64(),
        Some(0.02),
        "{v}"
    );
    assert_eq!(used["noise"]["e_m"].as_f64(), Some(0.05), "{v}");
    // The lap is judged against the car it drives: the plant's car, with less grip and
    // more mass, laps slower than the planner's.
    let (plant, own) = (
        v["plant_reference_lap_time_s"].as_f64().unwrap(),
        v["reference_lap_time_s"].as_f64().unwrap(),
    );
    assert!(plant > own && plant < 1.1 * own, "{v}");
    assert!(
        v["laps_or_distance_m"].as_f64().unwrap_or(0.0) > 250.0,
        "{v}"
    );
    assert_eq!(v["lane_kept"], serde_json::json!(true), "{v}");
    let max_e = v["max_lateral_error_m"].as_f64().unwrap_or(f64::INFINITY);
    assert!(max_e < 0.6, "max lateral error {max_e} m\n{v}");
}

/// `trajopt closed-loop --record` records every plan of the closed loop, and
/// `replay run` re-solves each input bit-identically (exit 0, "deterministic": true).
#[test]
fn closed_loop_recording_replays_bit_identically() {
    let _serial = serial();
    let replay = bin_dir().join("replay");
    assert!(
        replay.is_file(),
        "{} missing: build with `cargo build -p replay --bins` (same profile)",
        replay.display()
    );
    let file = std::env::temp_dir().join(format!("e2e-closed-loop-{}.mcap", std::process::id()));
    let _ = std::fs::remove_file(&file);
    let path = file.to_string_lossy().into_owned();
    let v = run_closed_loop(
        30.0,
        &[
            "--record",
            &path,
            ROOMY_BUDGET[0],
            ROOMY_BUDGET[1],
            "--initial-speed-mps",
            "15",
        ],
    );
    let rec = &v["planner"]["recording"];
    let inputs = rec["inputs"].as_u64().unwrap_or(0);
    assert!(inputs >= 5, "{rec}");
    assert_eq!(rec["outputs"].as_u64(), Some(inputs), "{rec}");
    assert_eq!(rec["dropped"], 0, "{rec}");
    assert_eq!(
        v["planner"]["plans_published"].as_u64(),
        Some(inputs),
        "every (equilibrium-started) plan recorded: {v}"
    );

    let (r, succeeded, stderr) = replay_run_json(&replay, &path);
    let _ = std::fs::remove_file(&file);
    assert!(succeeded, "replay run failed:\n{stderr}");
    assert_eq!(r["deterministic"], true, "{stderr}");
    assert_eq!(r["identical"].as_u64(), Some(inputs), "{stderr}");
    assert_eq!(r["different"], 0, "{stderr}");
}

/// The plans a trace folder's plans.csv logs, without the solve's wall-clock time (the one
/// column that is the machine's, not the run's).
fn plans_without_solve_time(dir: &std::path::Path) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("plans.csv")).expect("plans.csv");
    let header: Vec<&str> = text.lines().next().unwrap_or("").split(',').collect();
    let skip = header.iter().position(|h| *h == "solve_time_s");
    assert!(skip.is_some(), "plans.csv has no solve_time_s column");
    text.lines()
        .map(|l| {
            l.split(',')
                .enumerate()
                .filter(|(i, _)| Some(*i) != skip)
                .map(|(_, f)| f)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect()
}

/// In lockstep the tracker waits for each plan and the solves are bounded by iterations:
/// two laps of the oval against the default mismatch (seeded noise) drive the same bits,
/// plan for plan and step for step, and every plan recorded replays bit-identically.
#[test]
fn two_lockstep_laps_against_the_default_mismatch_drive_the_same_bits_and_replay() {
    let _serial = serial();
    let tmp = std::env::temp_dir().join(format!("e2e-lockstep-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temporary folder");
    let run = |name: &str, record: bool| {
        let dir = tmp.join(name);
        let mut extra = vec![
            "--lockstep".to_string(),
            "--mismatch".into(),
            "default".into(),
            "--trace-dir".into(),
            dir.to_string_lossy().into_owned(),
        ];
        if record {
            extra.push("--record".into());
            extra.push(tmp.join("lap.mcap").to_string_lossy().into_owned());
        }
        let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
        (run_closed_loop(0.0, &extra), dir)
    };
    let (a, dir_a) = run("a", true);
    let (b, dir_b) = run("b", false);
    for v in [&a, &b] {
        assert_eq!(v["clock"], "lockstep", "{v}");
        assert_eq!(v["lane_kept"], true, "{v}");
        assert!(
            v["laps_or_distance_m"].as_f64().unwrap_or(0.0) > 250.0,
            "{v}"
        );
        assert!(
            v["planner"]["lockstep"]["max_iter"].as_u64().unwrap_or(0) > 0,
            "{v}"
        );
    }
    let driven = |d: &std::path::Path| std::fs::read(d.join("driven.csv")).expect("driven.csv");
    assert!(driven(&dir_a) == driven(&dir_b), "the driven traces differ");
    assert_eq!(
        plans_without_solve_time(&dir_a),
        plans_without_solve_time(&dir_b)
    );
    for k in [
        "max_lateral_error_m",
        "min_edge_margin_m",
        "lap_times_s",
        "plans_received",
    ] {
        assert_eq!(a[k], b[k], "{k}");
    }

    let replay = bin_dir().join("replay");
    let path = tmp.join("lap.mcap").to_string_lossy().into_owned();
    let (r, succeeded, stderr) = replay_run_json(&replay, &path);
    let _ = std::fs::remove_dir_all(&tmp);
    assert!(succeeded, "replay run failed:\n{stderr}");
    let inputs = a["planner"]["recording"]["inputs"].as_u64().unwrap_or(0);
    assert!(inputs > 100, "{a}");
    assert_eq!(r["identical"].as_u64(), Some(inputs), "{stderr}");
    assert_eq!(r["different"], 0, "{stderr}");
}

/// Warm solves capped at 4 iterations fall back to a cold solve left 22 of the solver's
/// 26, which ends at the cap: the cycle fails. The cycle after each failure runs its warm
/// solve under `--warm-max-iter-after-failure 2` instead, so its fall-back gets 24; each
/// warm start is recorded with the cap it ran under, so every plan replays bit-identically
/// (a recording of the other cap would leave the replayed fall-back 2 iterations short).
#[test]
fn warm_solves_after_a_failed_cycle_run_under_their_cap_and_replay_bit_identically() {
    let _serial = serial();
    let replay = bin_dir().join("replay");
    assert!(replay.is_file(), "{} missing", replay.display());
    let dir = std::env::temp_dir().join(format!("e2e-warm-cap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let solver = dir.join("solver.toml");
    std::fs::write(&solver, format!("max_iter = {CAPPED_MAX_ITER}\n")).expect("solver file");
    let file = dir.join("capped.mcap");
    let path = file.to_string_lossy().into_owned();
    let solver = solver.to_string_lossy().into_owned();
    let v = run_closed_loop(
        40.0,
        &[
            "--record",
            &path,
            "--solver",
            &solver,
            "--warm-max-iter",
            "4",
            "--warm-max-iter-after-failure",
            "2",
            ROOMY_BUDGET[0],
            ROOMY_BUDGET[1],
            "--initial-speed-mps",
            "15",
        ],
    );
    let capped = v["planner"]["warm_capped_after_failure"]
        .as_u64()
        .unwrap_or(0);
    assert!(capped >= 1, "no warm solve ran under the cap: {v}");
    let inputs = v["planner"]["recording"]["inputs"].as_u64().unwrap_or(0);
    assert!(inputs > capped, "{v}");
    let (r, _, stderr) = replay_run_json(&replay, &path);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(r["deterministic"], true, "{stderr}");
    assert_eq!(r["identical"].as_u64(), Some(inputs), "{stderr}");
    assert_eq!(r["different"], 0, "{stderr}");
}

/// A budget far too small to converge (1 ms; the first plan gets the start-up budget):
/// the planner republishes its previous plan shifted to the car, and the tracker keeps
/// driving it, in the lane, to the end of the distance. Both processes report the kinds.
#[test]
fn closed_loop_with_a_tiny_budget_drives_on_the_previous_plan_shifted() {
    let _serial = serial();
    let v = run_closed_loop(25.0, &["--budget-ms", "1"]);
    assert_eq!(v["budget_ms"].as_f64(), Some(1.0), "{v}");
    let driven = |k: &str| v[k].as_u64().unwrap_or(0);
    assert!(driven("plans_previous_shifted") >= 3, "{v}");
    assert!(driven("plans_converged") >= 1, "the first plan: {v}");
    assert!(
        v["planner"]["plans_previous_shifted"].as_u64().unwrap_or(0)
            >= driven("plans_previous_shifted"),
        "{v}"
    );
    assert_eq!(v["tracker"]["end_reason"], "distance reached", "{v}");
    assert!(
        v["laps_or_distance_m"].as_f64().unwrap_or(0.0) >= 25.0,
        "{v}"
    );
    assert_eq!(v["lane_kept"], serde_json::json!(true), "{v}");
    assert_eq!(v["tracker"]["stale"], serde_json::json!(false), "{v}");
}

/// A closed 400 m track of one's own made of a shipped track's last 200 m and first 200 m
/// (`--track-profile`), driven one lap from a flying start: the drive crosses the shipped
/// track's lap end at s = 200 m and the profile's own at s = 401 m, completes one timed lap
/// and stays on the track.
#[test]
fn one_lap_of_a_track_across_the_lap_end_is_completed_in_the_lane() {
    let _serial = serial();
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = std::fs::read_to_string(repo.join("config/tracks/Austin_profile.csv")).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    let n = rows.len();
    let mut out = String::from("s_m,kappa_1pm,w_right_m,w_left_m\n");
    for (i, row) in rows[n - 201..].iter().chain(&rows[..200]).enumerate() {
        let rest = row.split_once(',').unwrap().1;
        out.push_str(&format!("{i}.0,{rest}\n"));
    }
    let dir = std::env::temp_dir().join(format!("e2e-wrap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let profile = dir.join("austin_wrap_profile.csv");
    std::fs::write(&profile, out).unwrap();
    let figs = dir.join("out");
    let v = run_closed_loop(
        0.0,
        &[
            "--track-profile",
            &profile.to_string_lossy(),
            "--lap-length-m",
            "401",
            "--out-dir",
            &figs.to_string_lossy(),
        ],
    );
    let png = figs.join("austin_wrap_lap.png").is_file();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(v["outcome"], "completed", "{v}");
    assert_eq!(v["laps_completed"], 1, "{v}");
    let laps = v["lap_times_s"].as_array().expect("lap times");
    assert_eq!(laps.len(), 1, "{v}");
    // 401 m at no less than 15 m/s and no more than the 70 m/s bound.
    let t = laps[0].as_f64().unwrap();
    assert!(t > 401.0 / 70.0 && t < 401.0 / 15.0, "{v}");
    // The CG stays on the track: within 0.5 m of the lane edge at worst. The planner keeps
    // a 1 m margin on a track; a debug build's solves can overrun the period on a loaded
    // machine, so the test allows that margin to be used up, not the track to be left.
    let margin = v["min_edge_margin_m"].as_f64().unwrap();
    assert!(margin > -0.5, "{v}");
    assert_eq!(v["start_state"], "free_start_solve", "{v}");
    assert_eq!(v["mismatch"], "none", "{v}");
    assert!(png, "the lap figure is written");
}

/// One emergency swerve `segment` of collision_avoidance.toml driven from 25 m/s with tire
/// saturation on, its figures in a temporary folder (removed).
fn run_swerve(segment: &str) -> serde_json::Value {
    let dir = std::env::temp_dir().join(format!("e2e-swerve-{segment}-{}", std::process::id()));
    let v = run_closed_loop(
        0.0,
        &[
            "--scenario",
            "config/scenarios/collision_avoidance.toml",
            "--segment",
            segment,
            "--tire-saturation",
            "on",
            "--out-dir",
            &dir.to_string_lossy(),
        ],
    );
    let _ = std::fs::remove_dir_all(&dir);
    v
}

/// The forgiving emergency swerve driven from 25 m/s: the planner replans around the two
/// obstacles fixed on the road and the car's footprint clears both.
#[test]
fn the_forgiving_swerve_driven_clears_both_obstacles() {
    let _serial = serial();
    let v = run_swerve("forgiving");
    assert_eq!(v["start_state"], "scenario", "{v}");
    assert_eq!(v["obstacles_cleared"], true, "{v}");
    assert!(v["min_obstacle_clearance_m"].as_f64().unwrap() > 0.0, "{v}");
    assert!(v["impact_speed_mps"].is_null(), "{v}");
    assert_eq!(v["outcome"], "cleared", "{v}");
}

/// The critical swerve with tire saturation has no feasible plan from its 25 m/s start: the
/// planner says so within its first cycle (a notice, not silence), the car brakes to a
/// stop in its lane at once, the run ends by itself, and the report says what happened:
/// no feasible plan, stopped in the lane, the first obstacle hit below the start speed.
#[test]
fn the_infeasible_swerve_brakes_in_lane_and_reports_the_contact() {
    let _serial = serial();
    let v = run_swerve("critical");
    assert_eq!(v["outcome"], "stopped_in_lane_no_feasible_plan", "{v}");
    assert_eq!(v["tracker"]["no_feasible_plan_braking"], true, "{v}");
    assert!(v["no_plan_notices"].as_u64().unwrap() >= 1, "{v}");
    assert_eq!(v["plans_converged"], 0, "no plan was driven: {v}");
    assert_eq!(v["lane_kept"], true, "{v}");
    assert_eq!(v["obstacles_cleared"], false, "{v}");
    let impact = v["impact_speed_mps"].as_f64().unwrap();
    assert!(
        impact > 0.0 && impact < 25.0,
        "braked before the contact: {v}"
    );
    // The car braked as commanded (0.8 mu g = 7.85 m/s^2, 39.8 m from 25 m/s): within
    // 10 % of that deceleration it stops within 25^2 / (2 * 0.9 * 7.85) = 44.2 m.
    assert!(v["laps_or_distance_m"].as_f64().unwrap() < 44.2, "{v}");
}

/// A profile with a NaN is refused before any process starts, naming the file and line.
#[test]
fn a_bad_track_profile_is_refused_with_its_row() {
    let dir = std::env::temp_dir().join(format!("e2e-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let profile = dir.join("bad_profile.csv");
    std::fs::write(
        &profile,
        "s_m,kappa_1pm,w_right_m,w_left_m\n0.0,0.0,4.0,4.0\n1.0,NaN,4.0,4.0\n2.0,0.0,4.0,4.0\n",
    )
    .unwrap();
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = Command::new(bin_dir().join("trajopt"))
        .current_dir(&repo)
        .args(["closed-loop", "--json", "--track-profile"])
        .arg(&profile)
        .args(["--lap-length-m", "3"])
        .output()
        .expect("run trajopt closed-loop");
    let _ = std::fs::remove_dir_all(&dir);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(out.stdout.is_empty(), "nothing on stdout");
    assert!(stderr.contains("bad_profile.csv:3:"), "{stderr}");
    assert!(
        !stderr.contains("planner: up"),
        "no process started: {stderr}"
    );
}

/// A planner that refuses its options (a recording folder that does not exist) ends the
/// run at once with its error, instead of leaving the tracker to wait out its 120 s
/// first-plan timeout.
#[test]
fn a_planner_that_fails_at_start_ends_the_run_at_once() {
    let _serial = serial();
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let started = std::time::Instant::now();
    let out = Command::new(bin_dir().join("trajopt"))
        .current_dir(&repo)
        .args([
            "closed-loop",
            "--json",
            "--record",
            "/nonexistent-folder/lap.mcap",
        ])
        .output()
        .expect("run trajopt closed-loop");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(out.stdout.is_empty(), "nothing on stdout");
    assert!(
        stderr.contains("--record /nonexistent-folder/lap.mcap"),
        "{stderr}"
    );
    assert!(stderr.contains("planner_proc failed"), "{stderr}");
    assert!(
        started.elapsed().as_secs_f64() < 60.0,
        "took {:?}: {stderr}",
        started.elapsed()
    );
}
