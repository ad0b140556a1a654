//! `Planner::replan` refuses bad input before touching the planner: road samples that are
//! not finite or leave no corridor, and an initial state outside the model's domain, each
//! with the entry named. A refused call leaves the next good replan's result unchanged.

use planner::config::{load_scenario, load_solver, load_vehicle, shipped_solver_file};
use planner::model::{ix, NX};
use planner::plan::{Planner, ReplanGuess};
use std::path::Path;

#[test]
fn replan_names_bad_road_samples_and_states_and_changes_nothing() {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/ca_critical.toml"), None, vehicle).unwrap();
    let settings = load_solver(&root.join(shipped_solver_file(spec.steering_slew_weight))).unwrap();
    let (kappa, e_min, e_max) = (spec.kappa.clone(), spec.e_min.clone(), spec.e_max.clone());
    let mut x0 = [0.0; NX];
    x0[ix::V] = 25.0;
    x0[ix::VWR] = 25.0;
    let mut p = Planner::<100>::new(spec, settings).unwrap();
    let first = p
        .replan(&kappa, &e_min, &e_max, x0, ReplanGuess::Equilibrium)
        .unwrap();
    let states = p.states().to_vec();
    let spec = p.spec().clone();
    // After a refused call: the same problem data and the same last result, bit for bit.
    let unchanged = |p: &Planner<100>, what: &str| {
        assert!(
            *p.spec() == spec,
            "{what}: the refused replan changed the problem"
        );
        let same = p
            .states()
            .iter()
            .zip(&states)
            .all(|(a, b)| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert!(same, "{what}: the refused replan changed the last result");
    };

    let mut bad_kappa = kappa.clone();
    bad_kappa[3] = f64::NAN;
    let err = p
        .replan(&bad_kappa, &e_min, &e_max, x0, ReplanGuess::Equilibrium)
        .expect_err("NaN curvature");
    assert!(err.to_string().contains("kappa[3]"), "{err}");
    unchanged(&p, "NaN curvature");

    let mut crossed = e_min.clone();
    crossed[7] = e_max[7] + 1.0;
    let err = p
        .replan(&kappa, &crossed, &e_max, x0, ReplanGuess::Equilibrium)
        .expect_err("no corridor");
    assert!(err.to_string().contains("e_min[7]"), "{err}");
    unchanged(&p, "no corridor");

    for (i, v, field) in [
        (ix::DPSI, 2.0, "x0.dpsi"),
        (ix::V, f64::NAN, "x0.V"),
        (ix::BETA, 1.6, "x0.beta"),
        (ix::VWR, -1.0, "x0.V_wr"),
    ] {
        let mut x = x0;
        x[i] = v;
        let err = p
            .replan(&kappa, &e_min, &e_max, x, ReplanGuess::Equilibrium)
            .expect_err(field);
        assert!(err.to_string().contains(field), "{err}");
        unchanged(&p, field);
    }

    // And the same replan again gives the same bits.
    let again = p
        .replan(&kappa, &e_min, &e_max, x0, ReplanGuess::Equilibrium)
        .unwrap();
    assert_eq!(again.iterations, first.iterations);
    assert_eq!(again.status, first.status);
    unchanged(&p, "the good replan after them");
}
