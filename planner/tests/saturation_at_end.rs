//! The tire saturation rows at the last node (`OcpSpec::saturation_at_end`) in whole solves
//! on the oval: without them implicit Euler drives the last interval with tire forces from
//! (x_N, u_{N-1}) that no row checks, and the plan takes slip past the tire's limit there;
//! with them every point the dynamics read stays within the limit.

use std::path::Path;

use planner::config::{load_scenario, load_solver, load_vehicle, shipped_solver_file};
use planner::guess::GuessKind;
use planner::ip::Status;
use planner::model::{ix, saturation};
use planner::plan::Planner;

/// The oval, the paper's free-start problem, with or without the last node's rows.
fn oval(end: bool) -> Planner<100> {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let mut spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let settings = load_solver(&root.join(shipped_solver_file(spec.steering_slew_weight))).unwrap();
    spec.saturation_at_end = end;
    Planner::<100>::new(spec, settings).unwrap()
}

/// sigma - sigma_sl (front, rear) at the last node with the last interval's controls.
fn end_excess(p: &Planner<100>) -> [f64; 2] {
    let (xs, us) = (p.states(), p.controls());
    saturation(&p.spec().vehicle, &xs[100], &us[99])
}

#[test]
fn the_last_nodes_rows_hold_the_last_interval_within_the_tires_limit_slip() {
    let mut without = oval(false);
    let a = without.solve(GuessKind::Equilibrium);
    assert_eq!(a.status, Status::Optimal, "{a:?}");
    let mut with = oval(true);
    let b = with.solve(GuessKind::Equilibrium);
    assert_eq!(b.status, Status::Optimal, "{b:?}");
    let eps = with.spec().vehicle.eps_sat;
    let (ea, eb) = (end_excess(&without), end_excess(&with));
    println!("sigma - sigma_sl at (x_N, u_N-1): without {ea:?}, with {eb:?}; eps {eps}");
    // Without the rows the last interval's tires go past the limit (the test can fail).
    assert!(ea.iter().any(|&e| e > eps + 1e-2), "{ea:?}");
    // With them both tires are within it.
    assert!(eb.iter().all(|&e| e <= eps + 1e-6), "{eb:?}");
    // Every other node is held by R5 in both.
    for p in [&without, &with] {
        for k in 0..100 {
            let e = saturation(&p.spec().vehicle, &p.states()[k], &p.controls()[k]);
            assert!(e.iter().all(|&v| v <= eps + 1e-6), "node {k}: {e:?}");
        }
    }
    // The last interval's extra grip is worth little time: within 0.5 % of the horizon's.
    let (ta, tb) = (without.states()[100][ix::T], with.states()[100][ix::T]);
    println!("t_N without {ta:.4} s, with {tb:.4} s");
    assert!((tb - ta).abs() < 5e-3 * ta, "{tb} vs {ta}");
}
