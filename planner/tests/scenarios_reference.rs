//! Every shipped racing segment and collision-avoidance run against the independent
//! reference (`config/reference/`): status, t_N within 0.5 %, sideslip where it matters.

use std::path::Path;

use planner::config::{load_scenario, load_solver, load_vehicle};
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
    let settings = load_solver(&root().join("solver.toml")).unwrap();
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
        // No iteration exceeds the refactorization cap (issue 7's bounded inertia handling).
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
