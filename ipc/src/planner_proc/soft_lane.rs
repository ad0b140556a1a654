//! The soft lane of the plans on a closed road (`--soft-lane-m`, `--soft-lane-weight`;
//! [`planner::ocp::soft_lane`]): set up once in the spec, its bounds rewritten each cycle
//! from the window ahead of the car.

use planner::model::ix;

use super::{Cycle, PlannerArgs, PlannerProcError};
use crate::elog;
use crate::msg::VehicleState;
use crate::road::Scenario;

/// Checks `--soft-lane-m` and, when it is not 0, puts the soft lane of it and
/// `--soft-lane-weight` into the scenario's spec (the bounds of the window at s = 0; each
/// cycle writes its own).
pub(super) fn setup(sc: &mut Scenario, args: &PlannerArgs) -> Result<(), PlannerProcError> {
    let m = args.soft_lane_m;
    if !(0.0..=10.0).contains(&m) {
        return Err(PlannerProcError::Setup(format!(
            "--soft-lane-m {m}: must be in [0, 10]"
        )));
    }
    if m == 0.0 {
        return Ok(());
    }
    if !sc.road.is_closed() {
        return Err(PlannerProcError::Setup(
            "--soft-lane-m: a soft lane is for closed roads (an obstacle scenario's bounds are what its run tests)".into(),
        ));
    }
    let w = args.soft_lane_weight;
    if !(w > 0.0 && w <= planner::ocp::soft_lane::MAX_SOFT_LANE_WEIGHT) {
        return Err(PlannerProcError::Setup(format!(
            "--soft-lane-weight {w}: must be in (0, {}] with --soft-lane-m",
            planner::ocp::soft_lane::MAX_SOFT_LANE_WEIGHT
        )));
    }
    let spec = &mut sc.spec;
    spec.soft_lane = planner::ocp::SoftLane::new(
        w,
        spec.e_min.iter().map(|e| e + m).collect(),
        spec.e_max.iter().map(|e| e - m).collect(),
    );
    Ok(())
}

/// Writes the soft lane of the window at the car's s into the cycle's road window and its
/// planner, when the spec has one (`(ds, margin)`: node spacing and soft margin \[m\]).
/// Allocates nothing.
pub(super) fn update(
    cy: &mut Cycle,
    sc: &Scenario,
    state: &VehicleState,
    (ds, margin): (f64, f64),
) {
    if !cy.planner.spec().soft_lane.is_on() {
        return;
    }
    sc.road
        .soft_window(state.x[ix::S], ds, margin, &mut cy.road);
    if let Err(e) = cy
        .planner
        .set_soft_lane(&cy.road.soft_e_min, &cy.road.soft_e_max)
    {
        elog!("planner: soft lane of vehicle state seq {}: {e}", state.seq);
    }
}
