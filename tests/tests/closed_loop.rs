//! End-to-end: `trajopt closed-loop` starts `planner_proc` and `tracker_proc` (ipc crate),
//! runs the oval closed loop over iceoryx2 and shuts both down.
//!
//! The binaries are found next to the test's target profile folder; `cargo test --workspace`
//! builds them (`cargo test -p e2e` alone does not: run `cargo build -p ipc -p planner --bins` first).

use std::path::PathBuf;
use std::process::Command;

fn bin_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/closed_loop-<hash> -> target/<profile>
    exe.parent()
        .and_then(|d| d.parent())
        .expect("target profile folder")
        .to_path_buf()
}

fn run_closed_loop(distance_m: f64) -> serde_json::Value {
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
        .output()
        .expect("run trajopt closed-loop");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "closed-loop failed:\n{stderr}");
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("bad JSON ({e}):\n{stderr}"))
}

/// The acceptance criterion: one lap of the oval over iceoryx2, the car stays in the
/// lane and within 0.5 m of the plan, and both processes shut down (the command returns
/// only after both exited). One test, so two closed loops never compete for the 2 cores.
#[test]
fn closed_loop_oval_lap_keeps_lane_and_tracks_plan() {
    let v = run_closed_loop(0.0);
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
