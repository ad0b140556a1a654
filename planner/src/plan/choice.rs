//! What a planning cycle sends the car: the decision rule shared by the planner process
//! and `replay run`.
//!
//! A cycle's solve ends converged (`optimal`) or past convergence: at a cap (`acceptable`,
//! `iteration_limit`, `time_limit`) or on a failure (`numerical_failure`,
//! `locally_infeasible`, `invalid_input`, or no solve at all). Past convergence the solver
//! returns its best iterate w* with its max constraint violation v = max_i viol_i(w*) in
//! the scaled NLP's units ([`crate::ip::SolveInfo::max_violation`]). The cycle sends
//!
//! - [`PlanKind::Converged`] for `optimal`;
//! - [`PlanKind::BestIterate`] when the solve stopped at a cap or on a numerical failure
//!   and v <= [`DRIVABLE_VIOLATION`] (finite);
//! - otherwise [`PlanKind::PreviousShifted`], the last plan it sent as converged or best
//!   iterate, shifted to the car's s, when one exists and the car is still within the
//!   first [`PREVIOUS_MAX_SHIFT_FRACTION`] (an eighth) of its horizon;
//! - otherwise nothing (the tracker holds its plan, and brakes once it is stale).
//!
//! # The threshold
//!
//! Every row of the NLP is scaled (`crate::ocp::scaling`): the implicit-Euler defect row
//! of state i is (x_{k+1,i} - x_{k,i} - ds f_i) / X_NOMINAL_i, the front friction rows are
//! divided by 1000 N, the saturation rows (fixed start) by 0.1, the control-rate rows by
//! the rate limit (so they read in seconds); the lane, speed and control limits are
//! variable bounds, which an interior-point iterate never leaves. So v <= 1e-2 means, per
//! interval of ds = 2.6 m: lateral-offset defect <= 1 cm, heading and sideslip defects
//! <= 1 mrad, yaw-rate defect <= 10 mrad/s, speed and wheel-speed defects <= 10 cm/s,
//! load-transfer defect <= 10 N, front friction exceeded by <= 10 N, tire slip past
//! saturation by <= 1e-3, a control changing faster than its rate limit allows by 10 ms
//! worth of change (10 % over an interval of about 0.1 s). Integrated open loop, the
//! defects move the car off the plan by at most K v (1 m) + v (0.1 rad) ds K^2 / 2 after K
//! intervals (all defects of one sign, the heading defects turned into offset over the
//! remaining distance): 4 cm + 2 cm over the 4 intervals of one 10 Hz period. The
//! tracker's feedback closes the loop on each reference point, so the error it sees stays
//! at the scale of one interval's defect, and the next cycle plans from the measured state
//! again. The alternative, the previous plan shifted, started from a state one or more
//! periods old, and under a plant mismatch the car leaves it faster than that (docs/ipc.md).
//! The solver's own acceptable level (`acceptable_constr_viol_tol`, 1e-4) is a hundred
//! times tighter; a best iterate between the two is what a short budget leaves.

use crate::ip::Status;

/// Largest max constraint violation (scaled NLP units) of a best iterate that is still
/// sent (see the module documentation for what it bounds).
pub const DRIVABLE_VIOLATION: f64 = 1e-2;

/// A previous plan is republished, shifted, while the car's s lies within this fraction of
/// its horizon from its origin (32.5 m on the oval's 260 m horizon, about 2 s of
/// driving). A plan driven that long without a new start at the measured state drifts
/// from the car (its discretization against the plant, the start state it was planned
/// from); past the cap the cycle sends no plan (the planner process sends the notice that it
/// has none) and the tracker brakes once its plan is stale.
pub const PREVIOUS_MAX_SHIFT_FRACTION: f64 = 0.125;

/// What kind of plan a cycle sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PlanKind {
    /// The solve converged (`optimal`).
    Converged,
    /// The solve stopped past convergence; its best iterate is within
    /// [`DRIVABLE_VIOLATION`].
    BestIterate,
    /// The previous plan sent, shifted to the car's s.
    PreviousShifted,
}

impl PlanKind {
    /// All kinds, in the order of their codes.
    pub const ALL: [PlanKind; 3] = [
        PlanKind::Converged,
        PlanKind::BestIterate,
        PlanKind::PreviousShifted,
    ];

    /// The wire code (0, 1, 2).
    pub fn code(self) -> u32 {
        match self {
            PlanKind::Converged => 0,
            PlanKind::BestIterate => 1,
            PlanKind::PreviousShifted => 2,
        }
    }

    /// The kind of a wire code (`None` for an unknown code).
    pub fn from_code(code: u32) -> Option<Self> {
        Self::ALL.get(code as usize).copied()
    }

    /// The snake_case name used in JSON and logs.
    pub fn name(self) -> &'static str {
        match self {
            PlanKind::Converged => "converged",
            PlanKind::BestIterate => "best_iterate",
            PlanKind::PreviousShifted => "previous_shifted",
        }
    }
}

/// Wire code of a notice that a cycle has no drivable plan (the decision's `None`): the
/// code after [`PlanKind::ALL`]'s, so it is never a plan's.
pub const NO_PLAN_CODE: u32 = PlanKind::ALL.len() as u32;

/// Name of a plan-kind wire code (`None` for an unknown code).
pub fn kind_name(code: u32) -> Option<&'static str> {
    PlanKind::from_code(code).map(PlanKind::name)
}

/// How a cycle's solve ended, as far as the decision needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// The solver's status.
    pub status: Status,
    /// Max constraint violation of the returned point (scaled NLP units).
    pub max_violation: f64,
}

impl Outcome {
    /// The outcome of a solve.
    pub fn of(info: &crate::ip::SolveInfo) -> Self {
        Self {
            status: info.status,
            max_violation: info.max_violation,
        }
    }

    /// True when the returned point may be sent as a best iterate: the solve stopped at a
    /// cap or on a numerical failure and its violation is at most [`DRIVABLE_VIOLATION`].
    pub fn drivable(&self) -> bool {
        matches!(
            self.status,
            Status::Acceptable
                | Status::IterationLimit
                | Status::TimeLimit
                | Status::NumericalFailure
        ) && self.max_violation.is_finite()
            && self.max_violation <= DRIVABLE_VIOLATION
    }
}

/// True when a previous plan whose origin lies `shift_m` behind the car (on a horizon of
/// `horizon_m`) may be republished: 0 <= shift <= [`PREVIOUS_MAX_SHIFT_FRACTION`] horizon.
pub fn previous_usable(shift_m: f64, horizon_m: f64) -> bool {
    shift_m >= 0.0 && shift_m <= PREVIOUS_MAX_SHIFT_FRACTION * horizon_m
}

/// The decision rule: what a cycle whose solve ended `solve` (`None`: nothing was solved)
/// sends, given whether a usable previous plan exists ([`previous_usable`]). `None`: send
/// nothing.
pub fn choose(solve: Option<Outcome>, previous_usable: bool) -> Option<PlanKind> {
    match solve {
        Some(o) if o.status == Status::Optimal => Some(PlanKind::Converged),
        Some(o) if o.drivable() => Some(PlanKind::BestIterate),
        _ if previous_usable => Some(PlanKind::PreviousShifted),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ended(status: Status, max_violation: f64) -> Option<Outcome> {
        Some(Outcome {
            status,
            max_violation,
        })
    }

    #[test]
    fn a_converged_solve_is_sent_as_converged() {
        assert_eq!(
            choose(ended(Status::Optimal, 1e-9), false),
            Some(PlanKind::Converged)
        );
    }

    #[test]
    fn a_capped_solve_within_the_threshold_sends_its_best_iterate() {
        for status in [
            Status::Acceptable,
            Status::IterationLimit,
            Status::TimeLimit,
            Status::NumericalFailure,
        ] {
            assert_eq!(
                choose(ended(status, DRIVABLE_VIOLATION), false),
                Some(PlanKind::BestIterate),
                "{status:?}"
            );
        }
    }

    #[test]
    fn a_capped_solve_past_the_threshold_sends_the_previous_plan_or_nothing() {
        let over = 1.01 * DRIVABLE_VIOLATION;
        for status in [Status::TimeLimit, Status::IterationLimit] {
            assert_eq!(
                choose(ended(status, over), true),
                Some(PlanKind::PreviousShifted)
            );
            assert_eq!(choose(ended(status, over), false), None);
            assert_eq!(
                choose(ended(status, f64::NAN), true),
                Some(PlanKind::PreviousShifted)
            );
        }
    }

    #[test]
    fn an_infeasible_or_invalid_solve_never_sends_its_point() {
        for status in [Status::LocallyInfeasible, Status::InvalidInput] {
            assert_eq!(choose(ended(status, 0.0), false), None);
            assert_eq!(
                choose(ended(status, 0.0), true),
                Some(PlanKind::PreviousShifted)
            );
        }
        assert_eq!(choose(None, true), Some(PlanKind::PreviousShifted));
        assert_eq!(choose(None, false), None);
    }

    #[test]
    fn a_previous_plan_is_usable_over_the_first_eighth_of_its_horizon() {
        assert!(previous_usable(0.0, 260.0));
        assert!(previous_usable(32.5, 260.0));
        assert!(!previous_usable(32.6, 260.0));
        assert!(!previous_usable(-0.1, 260.0));
        assert!(!previous_usable(f64::NAN, 260.0));
    }

    #[test]
    fn kind_codes_round_trip() {
        for k in PlanKind::ALL {
            assert_eq!(PlanKind::from_code(k.code()), Some(k));
            assert_eq!(kind_name(k.code()), Some(k.name()));
        }
        assert_eq!(kind_name(3), None);
    }
}
