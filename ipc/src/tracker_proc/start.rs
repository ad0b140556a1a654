//! Where the car starts: at road s = start_s, either in the lane centre in straight-line
//! cruise at a given speed (15 m/s when nothing else is asked for), at the scenario's
//! fixed initial state (the swerve), or, asked for on a road with a free initial state, at
//! node 0 of a free-start solve over the
//! planner's window at start_s (speed, sideslip, yaw rate, wheel speed, load transfer and
//! lateral position of the minimum-time plan; heading error 0 by the OCP's convention): a
//! flying start at the pace the planner itself would choose there (with its grip scale),
//! solved from the equilibrium guess and, when that does not converge, from the road-speed
//! guess.

use planner::guess::GuessKind;
use planner::model::{ix, NX};
use planner::ocp::InitialState;
use planner::plan::Planner;

use crate::msg::HORIZON_N;
use crate::planner_proc::MARGIN_RAMP_M;
use crate::road::{RoadWindow, Scenario};

/// Cruise speed of a start with no speed given and no free-start solve asked for [m/s].
pub const DEFAULT_V0_MPS: f64 = 15.0;

/// The start state and how it was chosen (`"cruise"`, `"scenario"`, `"free_start_solve"`).
/// The free-start solve plans with the planner's grip scale `grip`
/// ([`planner::model::VehicleParams::scale_grip`]).
pub fn initial_state(
    sc: &Scenario,
    start_s: f64,
    (v0, free_start, grip): (Option<f64>, bool, f64),
    margin: f64,
) -> Result<([f64; NX], &'static str), String> {
    let fixed = matches!(sc.spec.initial, InitialState::Fixed(_));
    if let Some(v) = v0.or((!fixed && !free_start).then_some(DEFAULT_V0_MPS)) {
        let (lo, hi) = sc.road.edges(start_s);
        let mut x = [0.0; NX];
        x[ix::V] = v;
        x[ix::VWR] = v;
        x[ix::E] = 0.5 * (lo + hi);
        x[ix::S] = start_s;
        return Ok((x, "cruise"));
    }
    if let InitialState::Fixed(mut x) = sc.spec.initial {
        x[ix::S] += start_s;
        x[ix::T] = 0.0;
        return Ok((x, "scenario"));
    }
    let mut w = RoadWindow::default();
    sc.road
        .window(start_s, sc.ds(), margin, MARGIN_RAMP_M, &mut w);
    let mut spec = sc.spec.clone();
    spec.kappa = w.kappa.to_vec();
    spec.e_min = w.e_min.to_vec();
    spec.e_max = w.e_max.to_vec();
    spec.initial = InitialState::Free;
    spec.vehicle.scale_grip(grip);
    let mut planner = Planner::<HORIZON_N>::new(spec, sc.settings)
        .map_err(|e| format!("free-start solve at s = {start_s} m: {e}"))?;
    // The equilibrium guess runs through the window's corners at one speed; when it does
    // not converge (plans well below the grip, e.g. --friction-scale 0.85 on Austin), the
    // guess capped at the speeds the curvature allows is tried before giving up.
    let mut info = planner.solve(GuessKind::Equilibrium);
    if !info.status.is_success() {
        info = planner.solve(GuessKind::RoadSpeed);
    }
    if !info.status.is_success() {
        return Err(format!(
            "free-start solve at s = {start_s} m ended {} after {} iterations from the road-speed guess (also not from the equilibrium); give the start speed (--v0 / --initial-speed-mps)",
            info.status.name(),
            info.iterations
        ));
    }
    let mut x = planner.states()[0];
    x[ix::DPSI] = 0.0;
    x[ix::S] = start_s;
    x[ix::T] = 0.0;
    Ok((x, "free_start_solve"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::road::RoadArgs;
    use std::path::Path;

    /// At 85 % of the grip the equilibrium guess does not solve Silverstone's free start
    /// within the solver's 500 iterations; the road-speed guess does, so the flying start
    /// is found (its speed within the plans' bounds) instead of refused.
    #[test]
    fn a_flying_start_the_equilibrium_guess_misses_is_found_from_the_road_speed_guess() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let road = RoadArgs {
            track: Some("Silverstone".into()),
            tracks_index: root.join("config/tracks/tracks.toml"),
            ..RoadArgs::default()
        };
        let sc = Scenario::load_with(
            &root.join("config/scenarios/oval.toml"),
            &road,
            &root.join("config/vehicles/lc500.toml"),
            &root.join("config/solver.toml"),
        )
        .unwrap();
        let (x, how) = initial_state(&sc, 0.0, (None, true, 0.85), 1.0).unwrap();
        assert_eq!(how, "free_start_solve");
        assert!(
            x[ix::V] >= sc.spec.v_min && x[ix::V] <= sc.spec.v_max + 1e-6,
            "{x:?}"
        );
        assert!(x.iter().all(|v| v.is_finite()), "{x:?}");
    }
}
