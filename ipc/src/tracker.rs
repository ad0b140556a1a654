//! Trajectory tracking: the planned controls, looked up by arc length, as feed-forward,
//! plus feedback on lateral error, heading and yaw rate (steering) and speed (torque);
//! and which plans a tracker may follow at all ([`Ownership`]); braking to a stop without a
//! plan is [`stop`].

use planner::model::{iu, ix, VehicleParams, NU, NX};

use crate::msg::{RunId, Trajectory, HORIZON_N};

pub mod stop;
pub use stop::brake_to_stop;

/// Why a valid plan is not the tracker's own (it is counted and not followed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Foreign {
    /// Planned from another run's state (a predecessor's plan, or another publisher's).
    #[error("planned for run {got:#018x}, not this run {own:#018x}")]
    RunId {
        /// `from_run_id` of the plan.
        got: RunId,
        /// This tracker's run id.
        own: RunId,
    },
    /// Planned from a state seq this run has not published (0, or ahead of the last one).
    #[error("planned from state seq {got}, not one of this run's states 1..={last}")]
    StateSeq {
        /// `from_state_seq` of the plan.
        got: u64,
        /// Seq of this run's last published state (0: none yet).
        last: u64,
    },
}

/// Plans belong to their requester: a tracker run follows a plan only when it was planned
/// from one of the run's own published states, i.e. the plan's `from_run_id` is the run's
/// id and its `from_state_seq` lies in 1..=the last seq the run published (seqs count up
/// from 1). Anything else (a predecessor's last plan handed over by the service history, a
/// plan for another publisher, a plan claiming a state not yet sent) is [`Foreign`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ownership {
    run_id: RunId,
    last_seq: u64,
}

impl Ownership {
    /// A run with id `run_id` (non-zero) that has published no state yet.
    pub fn new(run_id: RunId) -> Self {
        Self {
            run_id,
            last_seq: 0,
        }
    }

    /// This run's id.
    pub fn run_id(&self) -> RunId {
        self.run_id
    }

    /// Seq of the last published state (0: none yet).
    pub fn last_seq(&self) -> u64 {
        self.last_seq
    }

    /// The seq of the next state to publish, recorded as published.
    pub fn next_seq(&mut self) -> u64 {
        self.last_seq += 1;
        self.last_seq
    }

    /// `Ok` when `plan` was planned from one of this run's published states.
    pub fn check(&self, plan: &Trajectory) -> Result<(), Foreign> {
        if plan.from_run_id != self.run_id || self.run_id == 0 {
            return Err(Foreign::RunId {
                got: plan.from_run_id,
                own: self.run_id,
            });
        }
        if plan.from_state_seq == 0 || plan.from_state_seq > self.last_seq {
            return Err(Foreign::StateSeq {
                got: plan.from_state_seq,
                last: self.last_seq,
            });
        }
        Ok(())
    }
}

/// Counters of plans that were valid but not the tracker's own, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ForeignPlans {
    /// Planned for another run.
    pub run_id: u64,
    /// Planned from a state seq this run has not published.
    pub state_seq: u64,
}

impl ForeignPlans {
    /// Counts one foreign plan.
    pub fn count(&mut self, f: &Foreign) {
        match f {
            Foreign::RunId { .. } => self.run_id += 1,
            Foreign::StateSeq { .. } => self.state_seq += 1,
        }
    }

    /// Total counted.
    pub fn total(&self) -> u64 {
        self.run_id + self.state_seq
    }
}

/// Feedback gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// Steering per metre of lateral error [rad/m].
    pub k_e: f64,
    /// Steering per radian of heading error [rad/rad].
    pub k_dpsi: f64,
    /// Steering per rad/s of yaw-rate error [rad s/rad].
    pub k_r: f64,
    /// Longitudinal acceleration per m/s of speed error [1/s].
    pub k_v: f64,
    /// Rear torque per m/s of rear wheel-speed error (slip control) [N m s/m].
    pub k_w: f64,
    /// Deceleration used to brake to a stop when the plan is stale [m/s^2].
    pub stop_decel: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Self {
            k_e: 0.10,
            k_dpsi: 0.8,
            k_r: 0.05,
            k_v: 1.0,
            k_w: 1000.0,
            stop_decel: 4.0,
        }
    }
}

impl Gains {
    /// The gains of an emergency stop among obstacles: braking at the grip `stop_decel`
    /// allows on a straight (0.8 mu g of the tracker's model), not the comfort stop of a
    /// stale plan, since every metre the car still covers carries it toward an obstacle
    /// no plan clears.
    pub fn emergency_stop(self, p: &VehicleParams) -> Self {
        Self {
            stop_decel: 0.8 * p.mu * p.g,
            ..self
        }
    }
}

/// Reference of the plan at one arc length, and the tracking errors against it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    /// Interpolated planned state.
    pub x: [f64; NX],
    /// Planned control (held on the interval).
    pub u: [f64; NU],
}

/// Planned state (linear in s) and control (piecewise constant) at local arc length
/// `s_local` \[m\] from node 0; `None` outside [0, N ds].
pub fn reference(plan: &Trajectory, s_local: f64) -> Option<Reference> {
    let len = plan.length();
    if !(s_local >= 0.0 && s_local <= len) {
        return None;
    }
    let q = s_local / plan.ds;
    let k = (q.floor() as usize).min(HORIZON_N - 1);
    let w = (q - k as f64).clamp(0.0, 1.0);
    let (a, b) = (&plan.x[k], &plan.x[k + 1]);
    let mut x = [0.0; NX];
    for i in 0..NX {
        x[i] = a[i] + w * (b[i] - a[i]);
    }
    Some(Reference { x, u: plan.u[k] })
}

/// Wraps an angle difference into (-pi, pi].
fn wrap(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let r = a.rem_euclid(two_pi);
    if r > std::f64::consts::PI {
        r - two_pi
    } else {
        r
    }
}

/// Tracking errors (actual minus planned).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Errors {
    /// Lateral error e - e_ref along the road normal \[m\].
    pub e: f64,
    /// Cross-track error: the car's distance from the planned path, across the path,
    /// (e - e_ref) cos(dpsi_ref + beta_ref) (the plan's course relative to the road) \[m\].
    /// At a heading across the road (a hairpin) the road normal and the path normal part,
    /// and e - e_ref overstates how far the car is from the path.
    pub cross: f64,
    /// Heading error dpsi - dpsi_ref \[rad\].
    pub dpsi: f64,
    /// Speed error V - V_ref [m/s].
    pub v: f64,
    /// Sideslip error beta - beta_ref \[rad\].
    pub beta: f64,
}

/// Tracking errors of state x against the reference `r`. Allocates nothing.
pub fn errors(x: &[f64; NX], r: &Reference) -> Errors {
    let e = x[ix::E] - r.x[ix::E];
    Errors {
        e,
        cross: e * (r.x[ix::DPSI] + r.x[ix::BETA]).cos(),
        dpsi: wrap(x[ix::DPSI] - r.x[ix::DPSI]),
        v: x[ix::V] - r.x[ix::V],
        beta: x[ix::BETA] - r.x[ix::BETA],
    }
}

/// Control for the plant state x following `r`: feed-forward + fixed-gain feedback.
/// Allocates nothing.
pub fn track(p: &VehicleParams, g: &Gains, x: &[f64; NX], r: &Reference) -> ([f64; NU], Errors) {
    let err = errors(x, r);
    let mut u = r.u;
    u[iu::DELTA] -= g.k_e * err.e + g.k_dpsi * err.dpsi + g.k_r * (x[ix::R] - r.x[ix::R]);
    // Speed feedback as a force at the rear wheel (drive or rear brake).
    u[iu::TCOMB] -= g.k_v * err.v * p.m * p.r_w;
    // Wheel-slip control: the wheel mode is fast and unstable past the tire peak.
    u[iu::TCOMB] -= g.k_w * (x[ix::VWR] - r.x[ix::VWR]);
    (u, err)
}

#[cfg(test)]
mod ownership_tests {
    use super::*;

    fn plan_from(run_id: RunId, seq: u64) -> Trajectory {
        Trajectory {
            from_run_id: run_id,
            from_state_seq: seq,
            ..Trajectory::zeroed()
        }
    }

    /// A run that published states 1..=3.
    fn run_with_three_states() -> Ownership {
        let mut o = Ownership::new(0xabc);
        for want in 1..=3 {
            assert_eq!(o.next_seq(), want);
        }
        o
    }

    #[test]
    fn a_plan_from_an_own_published_state_is_accepted() {
        let o = run_with_three_states();
        for seq in 1..=3 {
            assert_eq!(o.check(&plan_from(0xabc, seq)), Ok(()));
        }
    }

    #[test]
    fn a_plan_for_another_run_is_rejected_and_counted() {
        let o = run_with_three_states();
        let mut foreign = ForeignPlans::default();
        // A predecessor's plan from a seq this run has published too.
        for plan in [plan_from(0xdef, 2), plan_from(0, 2)] {
            let e = o.check(&plan).unwrap_err();
            assert!(matches!(e, Foreign::RunId { own: 0xabc, .. }), "{e}");
            foreign.count(&e);
        }
        assert_eq!(
            foreign,
            ForeignPlans {
                run_id: 2,
                state_seq: 0
            }
        );
        assert_eq!(foreign.total(), 2);
    }

    #[test]
    fn a_plan_from_a_state_ahead_of_the_last_published_one_is_rejected() {
        let mut o = run_with_three_states();
        let ahead = plan_from(0xabc, 4);
        let e = o.check(&ahead).unwrap_err();
        assert_eq!(e, Foreign::StateSeq { got: 4, last: 3 });
        let mut foreign = ForeignPlans::default();
        foreign.count(&e);
        assert_eq!(foreign.state_seq, 1);
        assert_eq!(
            o.check(&plan_from(0xabc, 0)),
            Err(Foreign::StateSeq { got: 0, last: 3 })
        );
        // Once state 4 is published, the plan from it is the run's own.
        o.next_seq();
        assert_eq!(o.check(&ahead), Ok(()));
    }

    #[test]
    fn a_run_that_published_nothing_owns_no_plan() {
        let o = Ownership::new(0xabc);
        assert_eq!(
            o.check(&plan_from(0xabc, 1)),
            Err(Foreign::StateSeq { got: 1, last: 0 })
        );
    }

    #[test]
    fn run_id_zero_owns_no_plan() {
        let mut o = Ownership::new(0);
        o.next_seq();
        assert!(matches!(
            o.check(&plan_from(0, 1)),
            Err(Foreign::RunId { .. })
        ));
    }
}

#[cfg(test)]
mod error_tests {
    use super::*;

    /// On a straight road the planned path through (0, e_ref) at course angle
    /// chi = dpsi_ref + beta_ref is a line; a car at (0, e) is |(e - e_ref) cos chi| from
    /// it (the point-to-line distance in the plane). The cross-track error is that
    /// distance; the road-normal error is not, once chi is large.
    #[test]
    fn the_cross_track_error_is_the_distance_from_the_planned_path() {
        for (dpsi, beta) in [(0.0, 0.0), (0.3, -0.05), (-0.9, -0.1), (1.2, 0.2)] {
            let mut r = Reference {
                x: [0.0; NX],
                u: [0.0; NU],
            };
            r.x[ix::E] = 2.0;
            r.x[ix::DPSI] = dpsi;
            r.x[ix::BETA] = beta;
            let mut x = r.x;
            x[ix::E] = 3.0;
            let chi: f64 = dpsi + beta;
            // Distance from (0, 3) to the line through (0, 2) along (cos chi, sin chi).
            let (dx, dy) = (0.0, 1.0);
            let distance = (dx * chi.sin() - dy * chi.cos()).abs();
            let err = errors(&x, &r);
            assert!((err.cross.abs() - distance).abs() < 1e-12, "chi {chi}");
            assert_eq!(err.e, 1.0);
        }
    }
}
