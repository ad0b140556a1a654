//! Limits set in place (`Planner::set_limits`): the saturation bound and the grip of the
//! following solves change without rebuilding the planner, as the closed loop's relaxed
//! plans need, and a planner so updated solves exactly as one built with those limits.

use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::model::{ix, NX};
use planner::ocp::OcpSpec;
use planner::plan::{Planner, ReplanGuess};
use std::path::Path;

const N: usize = planner::HORIZON;

fn oval() -> (OcpSpec, planner::ip::Settings) {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let settings = load_solver(&root.join("solver.toml")).unwrap();
    (spec, settings)
}

/// A fixed start on the oval's free-start lap, `j` nodes on, with its road window.
fn start(spec: &OcpSpec, settings: planner::ip::Settings, j: usize) -> Window {
    let mut lap = Planner::<N>::new(spec.clone(), settings).unwrap();
    assert!(lap.solve(GuessKind::Equilibrium).status.is_success());
    let mut x0 = lap.states()[j];
    x0[ix::S] = 0.0;
    x0[ix::T] = 0.0;
    let road = |v: &[f64]| (0..=N).map(|k| v[(k + j) % N]).collect::<Vec<f64>>();
    Window {
        kappa: road(&spec.kappa),
        e_min: road(&spec.e_min),
        e_max: road(&spec.e_max),
        x0,
    }
}

struct Window {
    kappa: Vec<f64>,
    e_min: Vec<f64>,
    e_max: Vec<f64>,
    x0: [f64; NX],
}

/// Solves `w` cold and returns the plan's states as bits, with its final time.
fn solve(p: &mut Planner<N>, w: &Window) -> (Vec<u64>, f64) {
    let info = p
        .replan(&w.kappa, &w.e_min, &w.e_max, w.x0, ReplanGuess::Equilibrium)
        .unwrap();
    assert!(info.status.is_success(), "{info:?}");
    let bits = p.states().iter().flatten().map(|v| v.to_bits()).collect();
    (bits, p.states()[N][ix::T])
}

#[test]
fn a_planner_given_more_grip_in_place_solves_bit_for_bit_as_one_built_with_it() {
    let (full, settings) = oval();
    let mut reduced = full.clone();
    reduced.vehicle.scale_grip(0.9);
    let w = start(&reduced, settings, 30);

    let mut built_full = Planner::<N>::new(full.clone(), settings).unwrap();
    let mut updated = Planner::<N>::new(reduced.clone(), settings).unwrap();
    let (reduced_plan, reduced_t) = solve(&mut updated, &w);
    updated.set_limits(full.vehicle.limits()).unwrap();
    assert_eq!(updated.spec().vehicle, full.vehicle);
    let (updated_plan, updated_t) = solve(&mut updated, &w);
    let (full_plan, full_t) = solve(&mut built_full, &w);

    assert!(
        updated_plan == full_plan,
        "the updated planner's plan differs"
    );
    // The grip is what changed: the full-grip plan is faster.
    assert!(
        updated_t < reduced_t - 0.05,
        "{updated_t} s with full grip against {reduced_t} s at 90 %"
    );
    assert_eq!(updated_t.to_bits(), full_t.to_bits());

    // And back: the reduced limits give the reduced plan again.
    updated.set_limits(reduced.vehicle.limits()).unwrap();
    assert!(solve(&mut updated, &w).0 == reduced_plan);
}

#[test]
fn refused_limits_leave_the_planner_as_it_was() {
    let (spec, settings) = oval();
    let mut p = Planner::<N>::new(spec.clone(), settings).unwrap();
    let bad = planner::model::Limits {
        mu: f64::NAN,
        ..spec.vehicle.limits()
    };
    let err = p.set_limits(bad).unwrap_err().to_string();
    assert!(err.contains("mu"), "{err}");
    assert_eq!(p.spec().vehicle, spec.vehicle);
}
