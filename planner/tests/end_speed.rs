//! The bound on the last node's speed (`OcpSpec::v_end_max`, `Planner::set_end_speed_cap`)
//! in whole solves on the oval: the plan meets it by braking before the horizon's end, and
//! an infinite bound gives back the plan without it bit for bit.

use std::path::Path;

use planner::config::{load_scenario, load_solver, load_vehicle, shipped_solver_file};
use planner::guess::GuessKind;
use planner::ip::Status;
use planner::model::ix;
use planner::plan::Planner;

fn oval() -> Planner<100> {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let settings = load_solver(&root.join(shipped_solver_file(spec.steering_slew_weight))).unwrap();
    Planner::<100>::new(spec, settings).unwrap()
}

#[test]
fn a_plan_brakes_to_its_end_speed_bound_and_an_infinite_bound_changes_no_bit() {
    let mut p = oval();
    let free = p.solve(GuessKind::Equilibrium);
    assert_eq!(free.status, Status::Optimal, "{free:?}");
    let free_states = p.states().to_vec();
    let v_end_free = free_states[100][ix::V];

    // A bound 5 m/s below the free plan's end speed: met, at a cost in time.
    let cap = v_end_free - 5.0;
    p.set_end_speed_cap(cap).unwrap();
    let capped = p.solve(GuessKind::Equilibrium);
    assert_eq!(capped.status, Status::Optimal, "{capped:?}");
    let v_end = p.states()[100][ix::V];
    assert!(v_end <= cap + 1e-6, "V_N {v_end} above the bound {cap}");
    assert!(v_end > cap - 0.5, "V_N {v_end}: the bound should be active");
    let (t_free, t_capped) = (free_states[100][ix::T], p.states()[100][ix::T]);
    assert!(t_capped > t_free, "{t_capped} vs {t_free}");
    // Only the end changes: braking 5 m/s takes a few tens of metres, not the horizon.
    let (v0_free, v0) = (free_states[0][ix::V], p.states()[0][ix::V]);
    assert!((v0 - v0_free).abs() < 1.0, "start speed {v0} vs {v0_free}");
    println!(
        "free V_N {v_end_free:.3} m/s, t_N {t_free:.4} s; capped at {cap:.3}: V_N {v_end:.3}, t_N {t_capped:.4} s, {} iterations",
        capped.iterations
    );

    // Back to no bound: the same bits as the free solve.
    p.set_end_speed_cap(f64::INFINITY).unwrap();
    let again = p.solve(GuessKind::Equilibrium);
    assert_eq!(again.iterations, free.iterations);
    assert_eq!(p.states(), &free_states[..]);
}

#[test]
fn an_end_speed_bound_at_or_below_v_min_is_refused_and_changes_nothing() {
    let mut p = oval();
    let v_min = p.spec().v_min;
    for bad in [v_min, v_min - 1.0, f64::NAN] {
        let e = p.set_end_speed_cap(bad).expect_err("must be refused");
        assert!(e.to_string().contains("end speed"), "{e}");
    }
    assert_eq!(p.spec().v_end_max, f64::INFINITY);
}
