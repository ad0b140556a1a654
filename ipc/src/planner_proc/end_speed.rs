//! The speed bound of each plan's last node on a closed road (`--end-speed-envelope`;
//! [`crate::road::envelope`]): the envelope is computed once from the road and the plans'
//! grip, and each cycle reads it at the window's end.
//!
//! The bound never asks the car to brake harder than [`REACH_BRAKE_FRACTION`] of the
//! plans' grip over the window from its measured speed: a car faster than the envelope
//! (a plan on a line tighter than the centre line's, or a start placed by hand) gets the
//! end speed that braking gives it instead of an infeasible plan.

use planner::model::ix;

use super::{Cycle, PlannerArgs};
use crate::elog;
use crate::msg::{VehicleState, HORIZON_N};
use crate::road::envelope::{SpeedEnvelope, ENVELOPE_GRIP_FRACTIONS};
use crate::road::Scenario;

/// Braking the end bound may ask of the car over the window, as a fraction of the plans'
/// grip mu g (module docs).
pub const REACH_BRAKE_FRACTION: f64 = 0.8;

/// The envelope and the braking the bound may ask for.
pub(super) struct EndSpeed {
    env: SpeedEnvelope,
    /// [`REACH_BRAKE_FRACTION`] times the plans' grip \[m/s^2\].
    reach_brake: f64,
}

/// The envelope of `--end-speed-envelope on` on a closed road, at the grip the plans use
/// (the vehicle file's friction times --friction-scale, already in the spec) and capped
/// at the plans' speed bound; `None` when off or on an open road.
pub(super) fn setup(sc: &Scenario, args: &PlannerArgs) -> Option<EndSpeed> {
    if args.end_speed_envelope != "on" {
        return None;
    }
    let p = &sc.spec.vehicle;
    let grip = p.mu * p.g;
    let (lat, brake) = ENVELOPE_GRIP_FRACTIONS;
    let env = SpeedEnvelope::new(&sc.road, lat * grip, brake * grip, sc.spec.v_max)?;
    Some(EndSpeed {
        env,
        reach_brake: REACH_BRAKE_FRACTION * grip,
    })
}

/// Writes the end-speed bound of the window starting at the car (`ds`: node spacing
/// \[m\]) into the cycle's road window and its planner. Allocates nothing.
pub(super) fn update(cy: &mut Cycle, end: &EndSpeed, state: &VehicleState, ds: f64) {
    let length = HORIZON_N as f64 * ds;
    let v0 = state.x[ix::V];
    let reach = (v0 * v0 - 2.0 * end.reach_brake * length).max(0.0).sqrt();
    let v_min = cy.planner.spec().v_min;
    let v = end
        .env
        .at(state.x[ix::S] + length)
        .max(reach)
        .max(v_min + 1.0);
    cy.road.v_end_max = v;
    if let Err(e) = cy.planner.set_end_speed_cap(v) {
        elog!("planner: end speed of vehicle state seq {}: {e}", state.seq);
    }
}
