//! Relaxed plans: what the planner solves after a cycle whose plan the car could not drive.
//!
//! A plan starts from the measured state, so on a closed road near the limits it can have
//! no feasible point at all: the car arrives 0.4 m/s faster than the last plan into a
//! hairpin whose braking that plan already took to the brake-torque bound, or its rear
//! tire is already past its sliding slip. The nominal problem then ends
//! `locally_infeasible` or `numerical_failure` cycle after cycle, and the tracker drives a
//! stale plan off the road (Montreal's hairpin, docs/closed-loop.md).
//!
//! After such a cycle (one that sent no plan of its own), the next cycles solve a relaxed
//! problem:
//! - the tire saturation bound sigma - sigma_sl <= eps_sat (R5) rises from the vehicle
//!   file's eps_sat to `--relaxed-saturation`. The Fiala forces stay capped at the
//!   friction limit, so no grip is invented: the plan may only let a tire slide a little
//!   past its peak, as the car already does;
//! - the lane margin shrinks from `--lane-margin-m` to `--relaxed-margin-m`, so the plan
//!   may use the room the margin keeps for tracking errors;
//! - the grip may rise from `--friction-scale` to `--relaxed-friction-scale` (by default
//!   it stays at `--friction-scale`). The grip a nominal plan leaves over is the
//!   tracker's authority to correct errors, and it is also the margin for a road that
//!   grips less than the vehicle file says: a relaxed plan at the file's full grip asks
//!   the default mismatch's plant (5 % less friction) for grip it does not have, and on
//!   40 lockstep laps such plans sent the car off Budapest's hairpin at s = 1.14 km in
//!   5 of 8 and Silverstone's track in 4 of 8, none at the nominal grip
//!   (docs/performance.md, "Relaxed plans at the plans' grip").
//!
//! Re-solving offline the 14 plans of a Montreal recording that failed into the hairpin,
//! the relaxed problem solves 8 and the nominal one 1 (docs/performance.md). Dropping the saturation rows
//! altogether solves a few more, but in closed loop its plans drift at 50 m/s (sideslip
//! 0.3 rad) and spin the rear wheel up at the horizon's end. The nominal problem resumes
//! after `hold` relaxed cycles in a row that sent their own plan. Both problems have the
//! same rows and differ in bounds and grip only, so one planner solves both, updated in
//! place ([`planner::plan::Planner::set_limits`], the road window's margin), and a
//! relaxed solve warm-starts from the last good plan like a nominal one. Obstacle
//! scenarios never relax (their constraints are what the run tests).

use planner::model::{Limits, VehicleParams};
use planner::ocp::OcpSpec;

use super::PlannerArgs;
use crate::elog;
use crate::road::Scenario;

/// The relaxed problem's bounds and when the planner process solves it.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Relaxed {
    /// Saturation bound and grip of a nominal and of a relaxed plan.
    pub limits: [Limits; 2],
    /// Lane margin of a relaxed plan \[m\].
    pub margin: f64,
    /// Relaxed cycles in a row that sent their own plan before the nominal problem resumes.
    hold: u32,
    /// Relaxed cycles still to go (0: the nominal problem).
    left: u32,
    /// Relaxed plans sent (converged or best iterates).
    pub sent: u64,
    /// Times the planner switched to the relaxed problem.
    pub episodes: u64,
}

impl Relaxed {
    /// Relaxed plans with the limits `relaxed` (a saturation bound and a grip, each at
    /// least the `nominal` plans') and a lane margin of `margin`, `hold` cycles per
    /// episode.
    pub fn new((nominal, relaxed): (Limits, Limits), margin: f64, hold: u32) -> Self {
        // More grip is a larger mu and more negative brake torque limits.
        let relaxed = Limits {
            eps_sat: relaxed.eps_sat.max(nominal.eps_sat),
            mu: relaxed.mu.max(nominal.mu),
            t_bf_min: relaxed.t_bf_min.min(nominal.t_bf_min),
            t_comb_min: relaxed.t_comb_min.min(nominal.t_comb_min),
        };
        Self {
            limits: [nominal, relaxed],
            margin,
            hold,
            left: 0,
            sent: 0,
            episodes: 0,
        }
    }

    /// The next cycle solves the relaxed problem.
    pub fn active(&self) -> bool {
        self.left > 0
    }

    /// Counts a cycle that was relaxed (`relaxed`) or not and sent its own plan
    /// (`own_plan`) or not: a nominal cycle without its own plan starts an episode, a
    /// relaxed one restarts it, and each relaxed cycle with its own plan counts down.
    pub fn after_cycle(&mut self, relaxed: bool, own_plan: bool, s_car: f64) {
        match (relaxed, own_plan) {
            (false, true) => {}
            (false, false) => {
                self.left = self.hold;
                self.episodes += 1;
                if self.episodes <= 10 || self.episodes.is_multiple_of(100) {
                    elog!(
                        "planner: no plan of its own at s = {s_car:.1} m: the next {} cycles plan relaxed (saturation bound {}, friction {:.3}, lane margin {} m; {} times so far)",
                        self.hold,
                        self.limits[1].eps_sat,
                        self.limits[1].mu,
                        self.margin,
                        self.episodes
                    );
                }
            }
            (true, true) => {
                self.sent += 1;
                self.left = self.left.saturating_sub(1);
            }
            (true, false) => self.left = self.hold,
        }
    }
}

/// The relaxed-plan state and the problem a relaxed plan solves. Relaxed plans run on
/// closed roads only: an obstacle scenario's constraints are what its run tests.
pub(super) fn setup(
    args: &PlannerArgs,
    sc: &Scenario,
    relaxed_vehicle: &VehicleParams,
) -> (Option<Relaxed>, Option<OcpSpec>) {
    let relaxed = (args.relaxed_cycles > 0 && sc.road.is_closed()).then(|| {
        Relaxed::new(
            (sc.spec.vehicle.limits(), relaxed_vehicle.limits()),
            args.relaxed_margin_m.min(args.lane_margin_m),
            args.relaxed_cycles,
        )
    });
    let relaxed_spec = relaxed.as_ref().map(|r| {
        let mut spec = sc.spec.clone();
        spec.vehicle = spec.vehicle.with_limits(r.limits[1]);
        spec
    });
    (relaxed, relaxed_spec)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(eps_sat: f64, grip: f64) -> Limits {
        Limits {
            eps_sat,
            mu: 1.0 * grip,
            t_bf_min: -5000.0 * grip,
            t_comb_min: -3000.0 * grip,
        }
    }

    fn relaxed(hold: u32) -> Relaxed {
        Relaxed::new((limits(0.01, 0.9), limits(0.05, 1.0)), 0.2, hold)
    }

    #[test]
    fn a_relaxed_bound_below_the_vehicles_keeps_the_vehicles() {
        let r = Relaxed::new((limits(0.01, 0.9), limits(0.005, 1.0)), 0.2, 3);
        assert_eq!(r.limits[1].eps_sat, 0.01);
        assert_eq!(relaxed(3).limits, [limits(0.01, 0.9), limits(0.05, 1.0)]);
    }

    #[test]
    fn a_relaxed_grip_below_the_nominal_one_keeps_the_nominal_one() {
        let r = Relaxed::new((limits(0.01, 0.9), limits(0.05, 0.8)), 0.2, 3);
        assert_eq!(r.limits[1], limits(0.05, 0.9));
    }

    #[test]
    fn a_cycle_without_its_own_plan_starts_an_episode_that_ends_after_hold_good_cycles() {
        let mut r = relaxed(3);
        r.after_cycle(false, true, 0.0);
        assert!(!r.active());
        r.after_cycle(false, false, 1.0);
        assert!(r.active());
        assert_eq!(r.episodes, 1);
        r.after_cycle(true, true, 2.0);
        r.after_cycle(true, false, 3.0);
        // A relaxed cycle without its own plan restarts the count.
        for s in 4..6 {
            r.after_cycle(true, true, s as f64);
            assert!(r.active());
        }
        r.after_cycle(true, true, 6.0);
        assert!(!r.active());
        assert_eq!((r.sent, r.episodes), (4, 1));
    }
}
