//! The planner's side of lockstep ([`crate::lockstep`]): each solve is bounded by the
//! iterations its budget allows at the modelled iteration time, the wall clock only by
//! [`WALL_CAP_S`], and every flagged state gets an answer, a notice when it is not
//! planned from, since the tracker's simulation waits for it.

use std::time::Instant;

use planner::ip::Settings;

use super::{PlannerArgs, PlannerLoop, PlannerProcError, Ports, Solved, Start};
use crate::lockstep::{Lockstep, WALL_CAP_S};
use crate::msg::VehicleState;
use crate::services::IpcError;

/// The iteration caps of lockstep solves: steady, and until the first plan is sent (each
/// at most the solver file's cap).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Caps {
    pub(super) steady: usize,
    pub(super) first: usize,
}

impl Caps {
    /// The caps of `args` in lockstep (`None` in real time) from the budgets \[ms\] and the
    /// solver file's iteration cap.
    pub(super) fn from_args(
        args: &PlannerArgs,
        (budget_ms, first_budget_ms): (f64, f64),
        file_max_iter: usize,
    ) -> Result<Option<Self>, PlannerProcError> {
        if !args.lockstep {
            return Ok(None);
        }
        let ls = Lockstep::new(args.rate_hz, args.lockstep_ms_per_iter)
            .map_err(PlannerProcError::Setup)?;
        Ok(Some(Self {
            steady: ls.iterations(budget_ms).min(file_max_iter),
            first: ls.iterations(first_budget_ms).min(file_max_iter),
        }))
    }

    /// `settings` with the iteration cap of a steady solve (`startup`: of a solve before
    /// the first plan) and the wall-clock cap [`WALL_CAP_S`].
    pub(super) fn apply(&self, settings: Settings, startup: bool) -> Settings {
        Settings {
            max_iter: if startup { self.first } else { self.steady },
            max_time_s: WALL_CAP_S,
            ..settings
        }
    }
}

impl PlannerLoop {
    /// Answers a flagged state the cycle did not plan from (outside the planner's domain)
    /// with the notice that there is no drivable plan, so the waiting
    /// tracker goes on; it then holds the plan it has, as in real time, where such a
    /// state gets no answer.
    pub(super) fn decline(&mut self, ports: &Ports, state: &VehicleState) -> Result<(), IpcError> {
        let solved = Solved {
            info: None,
            start: Start::Cold,
            x0: state.x,
            s_track: state.x[planner::model::ix::S],
            stamp_in: plan_record::now_ns(),
            t0: Instant::now(),
            cpu_t0_ns: crate::clock::thread_cpu_ns(),
            solve_time_s: 0.0,
        };
        self.notify_no_plan(ports, state, &solved)
    }
}
