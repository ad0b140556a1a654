//! The infeasible swerve (collision avoidance, critical segment, tire saturation on) within
//! a planning cycle's budget: the solve cannot certify infeasibility that early (the
//! violation still falls, through restoration, long after the budget), so it ends
//! `time_limit` (or `iteration_limit` under an iteration budget) with a best iterate whose
//! violation says that no feasible plan was found; the feasible scenarios keep converging
//! (the golden test holds their statuses and iterations).

use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::ip::{Settings, Status};
use planner::plan::Planner;
use std::path::Path;

const N: usize = planner::HORIZON;

fn swerve(settings: impl FnOnce(&mut Settings)) -> (Planner<N>, Settings) {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let mut spec = load_scenario(
        &root.join("scenarios/collision_avoidance.toml"),
        Some("critical"),
        vehicle,
    )
    .unwrap();
    spec.enforce_tire_saturation = true;
    spec.steering_slew_weight = 0.0;
    let mut s = load_solver(&root.join("solver_min_time.toml")).unwrap();
    settings(&mut s);
    (Planner::<N>::new(spec, s).unwrap(), s)
}

#[test]
fn the_infeasible_swerve_under_an_iteration_budget_reports_no_feasible_plan() {
    let (mut p, s) = swerve(|s| s.max_iter = 40);
    let info = p.solve(GuessKind::Equilibrium);
    assert_eq!(info.status, Status::IterationLimit, "{info:?}");
    assert!(info.best_iterate);
    // The best iterate ranks feasibility first: its violation above the acceptable level
    // means no iterate of the solve was feasible to that level.
    assert!(
        info.max_violation > 100.0 * s.acceptable_constr_viol_tol,
        "{}",
        info.max_violation
    );
    assert!(p.states().iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn the_infeasible_swerve_under_a_cycle_time_budget_ends_time_limit_without_a_feasible_plan() {
    // 80 ms: the budget of a 10 Hz cycle; the uncapped solve takes hundreds of iterations.
    let (mut p, s) = swerve(|s| s.max_time_s = 0.08);
    let info = p.solve(GuessKind::Equilibrium);
    assert_eq!(info.status, Status::TimeLimit, "{info:?}");
    assert!(
        info.max_violation > s.acceptable_constr_viol_tol,
        "{info:?}"
    );
}
