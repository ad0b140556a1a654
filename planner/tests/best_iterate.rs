//! What a capped solve returns: the best iterate so far as the filter ranks iterates (the
//! violation ||c||_1 first, then among iterates feasible to the acceptable level the
//! objective), not the last one; and a wall-clock cap ends a solve with `time_limit`.

use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::ip::{IterLog, Settings, Status};
use planner::plan::Planner;
use std::path::Path;

fn oval(settings: impl FnOnce(&mut Settings)) -> Planner<100> {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let mut s = load_solver(&root.join("solver.toml")).unwrap();
    settings(&mut s);
    Planner::<100>::new(spec, s).unwrap()
}

/// The filter's ranking of a logged iterate: the violation ||c||_1 where the max violation
/// is above the acceptable level (0 below it) first, then the objective.
fn score(row: &IterLog, s: &Settings) -> (f64, f64) {
    let feas = if row.inf_pr <= s.acceptable_constr_viol_tol {
        0.0
    } else {
        row.theta
    };
    (feas, row.objective)
}

#[test]
fn an_iteration_cap_returns_the_best_iterate_not_the_last() {
    // The uncapped run's log holds the iterates every capped run passes through.
    let mut full = oval(|_| {});
    full.solve(GuessKind::Equilibrium);
    let log = full.solver().log().to_vec();
    let settings = *full.solver().settings();
    let mut differs = 0;
    for cap in 1..=12 {
        let best = (0..=cap)
            .min_by(|&a, &b| {
                score(&log[a], &settings)
                    .partial_cmp(&score(&log[b], &settings))
                    .unwrap()
            })
            .unwrap();
        if best != cap {
            differs += 1;
        }
        let mut p = oval(|s| s.max_iter = cap);
        let info = p.solve(GuessKind::Equilibrium);
        assert_eq!(info.status, Status::IterationLimit, "cap {cap}");
        assert_eq!(info.iterations, cap);
        assert_eq!(
            info.objective.to_bits(),
            log[best].objective.to_bits(),
            "cap {cap}: returned objective {} is not that of the best iterate {best} ({}), last {}",
            info.objective,
            log[best].objective,
            log[cap].objective
        );
    }
    // The check has teeth: for some caps the last iterate is not the best one.
    assert!(differs >= 2, "{differs}");
}

#[test]
fn a_wall_clock_cap_ends_with_time_limit_and_a_finite_best_iterate() {
    let mut p = oval(|s| s.max_time_s = 1e-9);
    let info = p.solve(GuessKind::Equilibrium);
    assert_eq!(info.status, Status::TimeLimit);
    // The clock is checked after the first iterate is scored: the start comes back.
    assert_eq!(info.iterations, 0);
    assert!(info.objective.is_finite() && info.max_violation.is_finite());
    assert!(p.states().iter().flatten().all(|v| v.is_finite()));
}
