//! Every shipped racing segment and collision-avoidance run against the independent
//! reference (`config/reference/`): status, t_N within 0.5 %, sideslip where it matters.

use std::path::Path;

use planner::config::{load_scenario, load_solver, load_vehicle, shipped_solver_file};
use planner::guess::GuessKind;
use planner::ip::{SolveInfo, Status};
use planner::model::ix;
use planner::plan::Planner;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"))
}

fn solve(file: &str, select: &str, saturation: Option<bool>) -> (SolveInfo, Planner<100>) {
    let vehicle = load_vehicle(&root().join("vehicles/lc500.toml")).unwrap();
    let mut spec =
        load_scenario(&root().join("scenarios").join(file), Some(select), vehicle).unwrap();
    if let Some(s) = saturation {
        spec.enforce_tire_saturation = s;
    }
    // The reference solves the paper's pure minimum time (eq. 3): no steering-slew term.
    spec.steering_slew_weight = 0.0;
    solve_spec(spec)
}

fn solve_spec(spec: planner::ocp::OcpSpec) -> (SolveInfo, Planner<100>) {
    let settings =
        load_solver(&root().join(shipped_solver_file(spec.steering_slew_weight))).unwrap();
    let mut p = Planner::<100>::new(spec, settings).unwrap();
    let info = p.solve(GuessKind::Equilibrium);
    (info, p)
}

/// (name, t_N) rows of a reference CSV whose first column is the name and `col` holds t_N.
fn reference(file: &str, col: usize) -> Vec<(String, String, f64)> {
    let text = std::fs::read_to_string(root().join("reference").join(file)).unwrap();
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[0].to_string(),
                f[1].to_string(),
                f[col].parse().unwrap_or(f64::NAN),
            )
        })
        .collect()
}

#[test]
fn ten_segments_optimal_and_match_reference() {
    let rows = reference("segments_ie_ipopt.csv", 1);
    assert_eq!(rows.len(), 10);
    for (name, _, t_ref) in rows {
        let (info, p) = solve("segments.toml", &name, None);
        assert_eq!(info.status, Status::Optimal, "{name}: {info:?}");
        let t = p.states()[100][ix::T];
        assert!(
            ((t - t_ref) / t_ref).abs() < 3e-4,
            "{name}: t_N {t} vs {t_ref}"
        );
        assert!(info.max_violation < 1e-6, "{name}: {}", info.max_violation);
        // No iteration exceeds the refactorization cap (bounded inertia handling).
        let cap = p.solver().settings().max_refactorizations;
        assert!(info.max_factorizations_per_iter <= cap, "{name}: {info:?}");
        assert!(
            p.solver().log().iter().all(|l| l.factorizations <= cap),
            "{name}: an iteration exceeds the cap of {cap}"
        );
    }
}

fn peak_beta(p: &Planner<100>) -> f64 {
    p.states()
        .iter()
        .fold(0.0f64, |a, x| a.max(x[ix::BETA].abs()))
}

#[test]
fn forgiving_swerve_matches_reference_with_and_without_saturation() {
    let (info, p) = solve("collision_avoidance.toml", "forgiving", Some(true));
    assert_eq!(info.status, Status::Optimal, "{info:?}");
    let t = p.states()[100][ix::T];
    assert!(((t - 3.6467) / 3.6467).abs() < 3e-4, "t_N {t}");
    assert!(peak_beta(&p) < 0.15, "peak beta {}", peak_beta(&p));

    let (info, p) = solve("collision_avoidance.toml", "forgiving", Some(false));
    assert_eq!(info.status, Status::Optimal, "{info:?}");
    let t = p.states()[100][ix::T];
    assert!(((t - 3.6460) / 3.6460).abs() < 3e-4, "t_N {t}");
}

#[test]
fn critical_layout_drifts_without_saturation() {
    let (info, p) = solve("ca_critical.toml", "critical", Some(false));
    assert_eq!(info.status, Status::Optimal, "{info:?}");
    let t = p.states()[100][ix::T];
    assert!(((t - 6.1193) / 6.1193).abs() < 3e-4, "t_N {t}");
    assert!(
        peak_beta(&p) > 0.35,
        "peak beta {} (no drift)",
        peak_beta(&p)
    );
    // R10: a brake stops the rear wheel, never spins it backwards.
    assert!(p.states().iter().all(|x| x[ix::VWR] > -1e-6));
}

#[test]
fn critical_layout_with_saturation_is_certified_infeasible() {
    let (info, p) = solve("ca_critical.toml", "critical", Some(true));
    assert_eq!(info.status, Status::LocallyInfeasible, "{info:?}");
    assert!(info.iterations <= p.solver().settings().max_iter);
    assert!(info.max_violation > 1e-5);
}

/// The shipped segments objective (t_N + 1 x steering slew, `segments.toml`): every segment
/// `optimal` in at most 40 iterations, never faster than the pure optimum and within 0.5 %
/// of it (docs/modelling.md).
#[test]
fn ten_segments_with_the_shipped_objective() {
    let rows = reference("segments_ie_ipopt.csv", 1);
    for (name, _, t_ref) in rows {
        let vehicle = load_vehicle(&root().join("vehicles/lc500.toml")).unwrap();
        let spec = load_scenario(
            &root().join("scenarios/segments.toml"),
            Some(&name),
            vehicle,
        )
        .unwrap();
        assert_eq!(spec.steering_slew_weight, 1.0, "{name}");
        let (info, p) = solve_spec(spec);
        assert_eq!(info.status, Status::Optimal, "{name}: {info:?}");
        assert!(
            info.iterations <= 40,
            "{name}: {} iterations",
            info.iterations
        );
        let t = p.states()[100][ix::T];
        let rel = (t - t_ref) / t_ref;
        assert!(rel > -3e-4 && rel < 5e-3, "{name}: t_N {t} vs {t_ref}");
    }
}

/// Total steering variation sum |delta_k - delta_{k-1}| \[rad\] of a solved plan.
fn steering_variation(p: &Planner<100>) -> f64 {
    p.controls()
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).abs())
        .sum()
}

/// S07 brakes from 57 to 16 m/s with the front brake at its torque bound: the pure minimum
/// time weaves the steering at its rate limit there (scrub drag; measured 21 reversals, 3.2
/// rad of total steering variation), the steering-slew term removes the weave (0.39 rad).
#[test]
fn steering_slew_term_removes_the_braking_weave() {
    let (info0, p0) = solve("segments.toml", "S07", None);
    assert_eq!(info0.status, Status::Optimal);
    let vehicle = load_vehicle(&root().join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(
        &root().join("scenarios/segments.toml"),
        Some("S07"),
        vehicle,
    )
    .unwrap();
    let (info1, p1) = solve_spec(spec);
    assert_eq!(info1.status, Status::Optimal);
    let (v0, v1) = (steering_variation(&p0), steering_variation(&p1));
    assert!(v0 > 2.0, "pure minimum time: steering variation {v0} rad");
    assert!(v1 < 0.6, "with the slew term: steering variation {v1} rad");
    // The front brake is at its torque bound over the braking zone in both.
    let tbf_min = p0.spec().vehicle.t_bf_min;
    let at_bound = |p: &Planner<100>| {
        p.controls()[..40]
            .iter()
            .filter(|u| u[2] < 0.99 * tbf_min)
            .count()
    };
    assert!(at_bound(&p0) >= 30 && at_bound(&p1) >= 30);
}
