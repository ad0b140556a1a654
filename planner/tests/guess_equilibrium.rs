//! The equilibrium guess (paper Sec. V, eq. 8) is an equilibrium of the model: at the
//! returned (x, u) the five dynamic rates vanish on a straight road, V_wr = V, the
//! controls lie in their box, and by the left-right symmetry of the car the steady state
//! is straight-line cruise (r = beta = delta = 0) with drive torque against the drag.

use std::path::Path;

use planner::config::load_vehicle;
use planner::guess::equilibrium;
use planner::model::{iu, ix, time_derivatives};
use planner::ocp::path_constraints::control_box;

#[test]
fn the_equilibrium_guess_is_a_steady_state_of_the_model() {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let p = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let (lo, hi) = control_box(&p);
    for v_start in [10.0, 15.37, 30.0, 55.0] {
        let eq = equilibrium(&p, 5.0, 70.0, v_start).unwrap();
        assert_eq!(eq.status, "optimal");
        let (x, u) = (eq.x, eq.u);
        let d = time_derivatives(&p, &x, &u, 0.0);
        // Rates against their natural scales: r' [rad/s^2], V' [m/s^2], beta' [rad/s],
        // V_wr' [m/s^2], dFz' [N/s].
        for (i, scale) in [
            (ix::R, 1.0),
            (ix::V, 1.0),
            (ix::BETA, 1.0),
            (ix::VWR, 1.0),
            (ix::DFZ, 1e3),
        ] {
            assert!(
                d.dxdt[i].abs() <= 1e-6 * scale,
                "V0 {v_start}: rate of state {i} is {} at the equilibrium",
                d.dxdt[i]
            );
        }
        assert!(
            (x[ix::VWR] - x[ix::V]).abs() <= 1e-6 * x[ix::V],
            "V_wr {} vs V {}",
            x[ix::VWR],
            x[ix::V]
        );
        assert!((5.0..=70.0).contains(&x[ix::V]));
        for j in 0..3 {
            assert!(
                u[j] >= lo[j] && u[j] <= hi[j],
                "control {j} = {} outside [{}, {}]",
                u[j],
                lo[j],
                hi[j]
            );
        }
        // Symmetry: no reason to turn on a straight road.
        for (what, v) in [
            ("r", x[ix::R]),
            ("beta", x[ix::BETA]),
            ("delta", u[iu::DELTA]),
        ] {
            assert!(v.abs() <= 1e-9, "V0 {v_start}: {what} = {v}");
        }
        // Drive torque holds the speed against drag and rolling resistance.
        assert!(
            u[iu::TCOMB] > 0.0,
            "V0 {v_start}: T_comb = {}",
            u[iu::TCOMB]
        );
    }
}

/// A model that evaluates to NaN has no equilibrium: the guess reports it instead of
/// returning a NaN cost as converged.
#[test]
fn a_nan_model_gives_no_equilibrium() {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let mut p = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    p.mu = f64::NAN;
    let r = equilibrium(&p, 5.0, 70.0, 15.0);
    assert!(r.is_err(), "{r:?}");
}
