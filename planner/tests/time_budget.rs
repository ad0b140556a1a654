//! The wall-clock budget of a solve (`Settings::max_time_s`): a solve that spends it stops
//! within a bounded overshoot, returns its best iterate and says so; the iteration cap
//! stays deterministic, and a budget that does not run out changes no bits.

use std::path::Path;
use std::time::Instant;

use planner::config::{load_scenario, load_solver, load_vehicle, shipped_solver_file};
use planner::guess::GuessKind;
use planner::ip::{Settings, SolveInfo, Status};
use planner::plan::Planner;
use planner::HORIZON;

/// Overshoot allowed past the budget [s]. A solve stops at most one factorization with its
/// direction solves, or one trial with the next derivative evaluation, past its budget,
/// then evaluates its best iterate once: less than one iteration's work, and an iteration
/// of the N = 100 OCP is a small fraction of this bound. The margin is for slow, shared CI
/// machines, whose scheduler may stall a solve: the test checks that the solve stops, not
/// how fast the machine is.
const OVERSHOOT_S: f64 = 0.2;

/// A planner for `file` (entry `select`) with the shipped solver file of the steering-slew
/// weight `slew`, tire saturation `saturation` (scenario's own when None) and the
/// settings changed by `settings`.
fn planner(
    file: &str,
    select: Option<&str>,
    slew: f64,
    saturation: Option<bool>,
    settings: impl FnOnce(&mut Settings),
) -> Planner<HORIZON> {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let mut spec = load_scenario(&root.join("scenarios").join(file), select, vehicle).unwrap();
    if let Some(s) = saturation {
        spec.enforce_tire_saturation = s;
    }
    spec.steering_slew_weight = slew;
    let mut s = load_solver(&root.join(shipped_solver_file(slew))).unwrap();
    settings(&mut s);
    Planner::<HORIZON>::new(spec, s).unwrap()
}

fn oval(settings: impl FnOnce(&mut Settings)) -> Planner<HORIZON> {
    planner("oval.toml", None, 1.0, None, settings)
}

/// The critical collision-avoidance layout with tire saturation, pure minimum time: an
/// infeasible problem that ends `locally_infeasible` after some hundred iterations.
fn infeasible(settings: impl FnOnce(&mut Settings)) -> Planner<HORIZON> {
    planner(
        "collision_avoidance.toml",
        Some("critical"),
        0.0,
        Some(true),
        settings,
    )
}

/// Solves from the equilibrium guess; returns the report and the wall-clock time [s].
fn timed_solve(p: &mut Planner<HORIZON>) -> (SolveInfo, f64) {
    let t = Instant::now();
    let info = p.solve(GuessKind::Equilibrium);
    (info, t.elapsed().as_secs_f64())
}

/// The bits of the solver's primal and dual vectors.
fn bits(p: &Planner<HORIZON>) -> Vec<u64> {
    let s = p.solver();
    s.x().iter().chain(s.y()).map(|v| v.to_bits()).collect()
}

#[test]
fn a_two_millisecond_budget_stops_the_oval_with_its_finite_best_iterate_in_time() {
    let budget = 0.002;
    let mut p = oval(|s| s.max_time_s = budget);
    let (info, elapsed) = timed_solve(&mut p);
    assert_eq!(info.status, Status::TimeLimit, "{info:?}");
    assert!(info.best_iterate, "{info:?}");
    assert!(info.best_iteration <= info.iterations, "{info:?}");
    assert!(info.max_violation.is_finite(), "{info:?}");
    assert!(info.objective.is_finite(), "{info:?}");
    assert!(p.states().iter().flatten().all(|v| v.is_finite()));
    assert!(
        elapsed < budget + OVERSHOOT_S,
        "stopped after {elapsed} s on a budget of {budget} s"
    );
}

#[test]
fn an_iteration_cap_gives_the_same_bits_twice() {
    let cap = 8;
    let run = || {
        let mut p = oval(|s| s.max_iter = cap);
        let info = p.solve(GuessKind::Equilibrium);
        (info, bits(&p))
    };
    let (a, bits_a) = run();
    let (b, bits_b) = run();
    assert_eq!(a.status, Status::IterationLimit);
    assert_eq!(a.iterations, cap);
    assert!(a.best_iterate);
    assert_eq!(a.best_iteration, b.best_iteration);
    assert_eq!(a.objective.to_bits(), b.objective.to_bits());
    assert_eq!(a.max_violation.to_bits(), b.max_violation.to_bits());
    assert!(bits_a == bits_b, "the capped solves differ");
}

#[test]
fn a_budget_that_does_not_run_out_changes_no_bits() {
    let mut default = oval(|_| {});
    let info_default = default.solve(GuessKind::Equilibrium);
    let mut long = oval(|s| s.max_time_s = planner::ip::settings::MAX_TIME_S);
    let info_long = long.solve(GuessKind::Equilibrium);
    assert_eq!(info_default.status, Status::Optimal);
    assert!(!info_default.best_iterate);
    assert_eq!(info_default.best_iteration, info_default.iterations);
    assert_eq!(info_default.iterations, info_long.iterations);
    assert!(bits(&default) == bits(&long), "the budget moved the bits");
}

#[test]
fn the_infeasible_case_under_an_80_ms_budget_ends_in_time_without_a_feasible_point() {
    let budget = 0.08;
    let mut p = infeasible(|s| s.max_time_s = budget);
    let (info, elapsed) = timed_solve(&mut p);
    assert_eq!(info.status, Status::TimeLimit, "{info:?}");
    assert!(info.best_iterate, "{info:?}");
    // No feasible point was found: the best iterate's violation is reported, finite and
    // above the tolerance.
    let s = *p.solver().settings();
    assert!(info.max_violation.is_finite(), "{info:?}");
    assert!(
        info.max_violation > s.acceptable_constr_viol_tol,
        "{info:?}"
    );
    assert!(
        elapsed < budget + OVERSHOOT_S,
        "stopped after {elapsed} s on a budget of {budget} s"
    );
}

/// `trajopt solve` run from the workspace root with `args`.
fn trajopt(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_trajopt"))
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn trajopt_solve_budget_ms_ends_time_limit_and_reports_the_best_iterate() {
    let out = trajopt(&["solve", "--budget-ms", "2", "--no-output", "--json"]);
    assert!(out.status.success(), "{out:?}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["status"], "time_limit", "{v}");
    assert_eq!(v["best_iterate"], true, "{v}");
    assert!(v["best_iteration"].as_u64().is_some(), "{v}");
    assert!(
        v["max_violation"].as_f64().is_some_and(f64::is_finite),
        "{v}"
    );
    for bad in ["0", "-1", "nan", "3600001"] {
        let out = trajopt(&["solve", "--budget-ms", bad, "--no-output"]);
        assert!(!out.status.success(), "--budget-ms {bad} was accepted");
    }
}
