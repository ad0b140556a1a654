//! The `trajopt` command line: the default solve, the JSON contract, bad input.

use std::process::Command;

fn trajopt() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_trajopt"));
    c.current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    c
}

/// The one JSON object on stdout of a run that succeeded (else the test fails with its
/// stderr).
fn json_of(out: &std::process::Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn solve_json_has_the_contract_fields() {
    let out_dir = std::env::temp_dir().join(format!("trajopt-cli-{}", std::process::id()));
    let out = trajopt()
        .args(["solve", "--json", "--out-dir"])
        .arg(&out_dir)
        .output()
        .unwrap();
    let v = json_of(&out);
    for key in [
        "status",
        "iterations",
        "solve_ms",
        "t_final",
        "max_violation",
        "initial_violation",
        "start_violation",
        "max_abs_beta_rad",
        "guess",
        "integrator",
        "barrier",
    ] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    assert_eq!(v["status"], "optimal");
    assert_eq!(v["guess"], "equilibrium");
    assert_eq!(v["integrator"], "implicit_euler");
    // The shipped oval weights the steering slew; t_N stays within 5e-4 of the reference's
    // pure optimum.
    assert_eq!(v["steering_slew_weight"], 1.0);
    assert!(
        v["solver_file"]
            .as_str()
            .is_some_and(|f| f.ends_with("config/solver.toml")),
        "{}",
        v["solver_file"]
    );
    let t = v["t_final"].as_f64().unwrap();
    assert!((t - 13.0699).abs() / 13.0699 < 5e-4, "t_final {t}");
    // `times_ms` is the last solve's phases, `times_ms_median` each phase's median over the
    // repeats (here one), whose total is `solve_ms`.
    for key in [
        "evaluation",
        "factorization",
        "solve",
        "line_search",
        "total",
    ] {
        let (last, med) = (&v["times_ms"][key], &v["times_ms_median"][key]);
        assert!(med.as_f64().is_some_and(|x| x > 0.0), "{key}: {med}");
        assert_eq!(last, med, "{key} with one solve");
    }
    assert_eq!(v["times_ms_median"]["total"], v["solve_ms"]);
    // CSV with one row per node and a PNG.
    let csv = std::fs::read_to_string(out_dir.join("oval.csv")).unwrap();
    assert_eq!(csv.lines().count(), 102);
    assert!(std::fs::metadata(out_dir.join("oval.png")).unwrap().len() > 1000);
    let _ = std::fs::remove_dir_all(&out_dir);
}

/// Without --solver, the pure minimum time loads the file shipped for it, whose settings
/// differ (barrier_tol_factor 10 against 30): the iterations match an explicit
/// `--solver config/solver_min_time.toml` and not `--solver config/solver.toml`.
#[test]
fn solve_picks_the_solver_file_for_its_objective() {
    let run = |extra: &[&str]| {
        let out = trajopt()
            .args([
                "solve",
                "--json",
                "--no-output",
                "--steering-slew-weight",
                "0",
            ])
            .args(extra)
            .output()
            .unwrap();
        let v = json_of(&out);
        (
            v["solver_file"].as_str().unwrap().to_string(),
            v["iterations"].as_u64().unwrap(),
        )
    };
    let (file, its) = run(&[]);
    assert!(file.ends_with("config/solver_min_time.toml"), "{file}");
    let (_, its_min_time) = run(&["--solver", "config/solver_min_time.toml"]);
    let (_, its_planner) = run(&["--solver", "config/solver.toml"]);
    assert_eq!(its, its_min_time);
    assert_ne!(its, its_planner, "the two files should differ on the oval");
}

#[test]
fn bad_input_gives_a_clear_error_and_nonzero_exit() {
    let out = trajopt()
        .args([
            "solve",
            "--scenario",
            "config/scenarios/nope.toml",
            "--no-output",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("nope.toml") && err.contains("cannot read"),
        "{err}"
    );

    let out = trajopt()
        .args([
            "solve",
            "--scenario",
            "config/scenarios/segments.toml",
            "--segment",
            "S99",
            "--no-output",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("S99") && err.contains("S01"), "{err}");

    let out = trajopt()
        .args(["solve", "--steering-slew-weight=-1", "--no-output"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--steering-slew-weight") && err.contains("not a weight in [0, 1000]"),
        "{err}"
    );
}

#[test]
fn solve_record_writes_a_replayable_mcap() {
    let dir = std::env::temp_dir().join(format!("trajopt-record-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("oval.mcap");
    let out = trajopt()
        .args([
            "solve",
            "--json",
            "--no-output",
            "--repeat",
            "2",
            "--record",
        ])
        .arg(&file)
        .output()
        .unwrap();
    let v = json_of(&out);
    assert_eq!(v["recording"]["inputs"], 2);
    assert_eq!(v["recording"]["outputs"], 2);
    assert_eq!(v["recording"]["dropped"], 0);
    let rec = plan_record::Recording::read(&file).unwrap();
    assert_eq!(rec.inputs.len(), 2);
    assert_eq!(rec.outputs[1].status, v["status"].as_str().unwrap());
    assert_eq!(
        rec.outputs[1].iterations as u64,
        v["iterations"].as_u64().unwrap()
    );
    assert_eq!(rec.inputs[0].scenario, "oval");
    assert!(!rec.inputs[0].initial_state_fixed);
    // With two solves each median is the mean of the two recorded solves' times of that
    // phase (the total's is also the mean of `solve_ms_all`).
    let all: Vec<f64> = v["solve_ms_all"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(all.len(), 2);
    // serde_json parses floats to within an ulp (no `float_roundtrip`).
    let near = |x: f64, want: f64| (x - want).abs() <= 1e-12 * want.abs();
    let total = v["times_ms_median"]["total"].as_f64().unwrap();
    assert!(near(total, 0.5 * (all[0] + all[1])), "{total} ({all:?})");
    let (a, b) = (&rec.outputs[0], &rec.outputs[1]);
    for (key, t0, t1) in [
        ("evaluation", a.time_evaluation_s, b.time_evaluation_s),
        (
            "factorization",
            a.time_factorization_s,
            b.time_factorization_s,
        ),
        ("solve", a.time_solve_s, b.time_solve_s),
        ("line_search", a.time_line_search_s, b.time_line_search_s),
        ("total", a.time_total_s, b.time_total_s),
    ] {
        let (med, last) = (
            v["times_ms_median"][key].as_f64().unwrap(),
            v["times_ms"][key].as_f64().unwrap(),
        );
        assert!(
            near(med, 0.5 * (t0 * 1e3 + t1 * 1e3)),
            "{key}: {med} ({t0}, {t1})"
        );
        assert!(
            near(last, t1 * 1e3),
            "{key}: the last solve's, {last} ({t1})"
        );
    }
    // An unwritable path is bad input: exit 2 before solving.
    let out = trajopt()
        .args([
            "solve",
            "--no-output",
            "--record",
            "/nonexistent-dir/x.mcap",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent-dir/x.mcap"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `trajopt study integrators --json` in a reduced variant (two fast integrators, implicit
/// Euler as the reference instead of the 8 s Gauss-Legendre 3 ground truth): one JSON
/// object with the table's fields, and the scatter PNG.
#[test]
fn study_integrators_json_has_the_contract_fields() {
    let out_dir = std::env::temp_dir().join(format!("trajopt-study-int-{}", std::process::id()));
    let out = trajopt()
        .args([
            "study",
            "integrators",
            "--repeat",
            "1",
            "--integrators",
            "bdf4,adams_moulton3",
            "--reference",
            "implicit_euler",
            "--json",
            "--out-dir",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    let v = json_of(&out);
    assert_eq!(v["reference"], "implicit_euler");
    assert_eq!(v["repeat"], 1);
    let runs = v["runs"].as_array().unwrap();
    let names: Vec<&str> = runs
        .iter()
        .map(|r| r["integrator"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["bdf4", "adams_moulton3", "implicit_euler"]);
    for r in runs {
        for key in [
            "status",
            "iterations",
            "median_ms",
            "max_nrmse_pct",
            "nrmse_pct",
            "t_final",
        ] {
            assert!(r.get(key).is_some(), "missing {key} in {r}");
        }
        assert!(r["median_ms"].as_f64().unwrap() > 0.0);
        assert_eq!(r["nrmse_pct"].as_array().unwrap().len(), 3);
    }
    assert_eq!(runs[2]["max_nrmse_pct"].as_f64(), Some(0.0));
    assert!(runs[0]["max_nrmse_pct"].as_f64().unwrap() > 0.0);
    // The human table went to stderr.
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("max NRMSE%") && err.contains("bdf4"), "{err}");
    let png = v["figure"].as_str().unwrap();
    assert!(std::fs::metadata(png).unwrap().len() > 1000);
    // Unknown names are bad input.
    let out = trajopt()
        .args(["study", "integrators", "--integrators", "rk45"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("rk45"));
    let _ = std::fs::remove_dir_all(&out_dir);
}

#[test]
fn study_stiffness_json_names_the_peak_and_its_state() {
    let out_dir = std::env::temp_dir().join(format!("trajopt-study-st-{}", std::process::id()));
    let out = trajopt()
        .args(["study", "stiffness", "--json", "--out-dir"])
        .arg(&out_dir)
        .output()
        .unwrap();
    let v = json_of(&out);
    assert_eq!(v["status"], "optimal");
    assert_eq!(v["jacobian"], "spatial");
    assert_eq!(v["nodes"].as_array().unwrap().len(), 101);
    // Paper Sec. IV: the dynamics are stiff along the optimum, the ratio far above the
    // threshold 10^3.
    let peak = v["peak_ratio"].as_f64().unwrap();
    assert!(peak > 1e3, "peak stiffness ratio {peak} is not stiff");
    let state = v["peak_dominant_state"].as_str().unwrap();
    assert!(planner::model::STATE_NAMES.contains(&state), "{state}");
    let k = v["peak_node"].as_u64().unwrap() as usize;
    assert!(
        k >= 1,
        "node 0 (free initial state) is excluded from the peak"
    );
    let p: f64 = v["nodes"][k]["participation"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .sum();
    assert!((p - 1.0).abs() < 1e-9);
    assert!(
        std::fs::metadata(v["figure"].as_str().unwrap())
            .unwrap()
            .len()
            > 1000
    );
    let _ = std::fs::remove_dir_all(&out_dir);
}

#[test]
fn study_barrier_json_has_every_rule() {
    let out = trajopt()
        .args(["study", "barrier", "--repeat", "1", "--json"])
        .output()
        .unwrap();
    let v = json_of(&out);
    let cap = v["max_refactorizations"].as_u64().expect("cap");
    assert_eq!(v["repeat"], 1);
    // The studies solve the paper's pure minimum time unless told otherwise.
    assert_eq!(v["steering_slew_weight"], 0.0);
    let runs = v["runs"].as_array().expect("runs");
    let mut names: Vec<&str> = runs.iter().filter_map(|r| r["barrier"].as_str()).collect();
    names.sort_unstable();
    assert_eq!(
        names,
        ["adaptive", "dampmpc", "fullmpc", "loqo", "monotone", "probing", "quality"]
    );
    for r in runs {
        for key in [
            "status",
            "iterations",
            "median_ms",
            "t_final",
            "max_violation",
            "max_factorizations_per_iter",
            "fallback_steps",
        ] {
            assert!(r.get(key).is_some(), "missing {key} in {r}");
        }
        assert!(
            r["max_factorizations_per_iter"].as_u64().unwrap() <= cap,
            "{r}"
        );
        // A run that used every iteration says so (500 = max_iter of solver.toml).
        if r["iterations"].as_u64().unwrap() >= 500 {
            let st = r["status"].as_str().unwrap();
            assert!(st == "iteration_limit" || st == "acceptable", "{r}");
        }
    }
    let monotone = runs.iter().find(|r| r["barrier"] == "monotone").unwrap();
    assert_eq!(monotone["status"], "optimal");
    // The human table went to stderr.
    assert!(String::from_utf8_lossy(&out.stderr).contains("Table IV"));
}

#[test]
fn study_rejects_zero_repeat() {
    let out = trajopt()
        .args(["study", "barrier", "--repeat", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}
