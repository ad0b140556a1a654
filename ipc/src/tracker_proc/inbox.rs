//! The tracker's plan inbox: drops invalid plans, refuses plans made from another run's
//! states ([`Ownership`]) and counts both; times the run's own plans.

use crate::elog;
use crate::msg::{RoadId, RunId, Trajectory};
use crate::stats::Latency;
use crate::tracker::{ForeignPlans, Ownership};

/// Receives plans: drops invalid ones, refuses foreign ones ([`Ownership`]) and counts
/// both; times the run's own plans.
pub(super) struct Inbox {
    pub(super) own: Ownership,
    /// Own valid plans.
    pub(super) plans: u64,
    /// Invalid plans.
    pub(super) rejected: u64,
    /// Own notices that a cycle had no drivable plan (not plans: not counted in `plans`).
    pub(super) notices: u64,
    pub(super) foreign: ForeignPlans,
    pub(super) ipc_lat: Latency,
    pub(super) plan_lat: Latency,
}

impl Inbox {
    pub(super) fn new(run_id: RunId) -> Self {
        Self {
            own: Ownership::new(run_id),
            plans: 0,
            rejected: 0,
            notices: 0,
            foreign: ForeignPlans::default(),
            ipc_lat: Latency::new(),
            plan_lat: Latency::new(),
        }
    }

    /// True when `m` is a valid plan or notice of this run (received at `now_ns`); logs the
    /// first invalid and foreign ones. Allocates nothing unless it logs.
    pub(super) fn accept(&mut self, m: &Trajectory, road: RoadId, ds: f64, now_ns: u64) -> bool {
        if let Err(e) = m.validate_for(road, ds) {
            self.rejected += 1;
            if self.rejected <= 10 {
                elog!("tracker: dropped trajectory seq {}: {e}", m.seq);
            }
            return false;
        }
        // A valid plan made from another run's state is never followed.
        if let Err(f) = self.own.check(m) {
            self.foreign.count(&f);
            let n = self.foreign.total();
            if n <= 10 || n.is_multiple_of(1000) {
                elog!(
                    "tracker: ignored foreign trajectory seq {} ({n} so far): {f}",
                    m.seq
                );
            }
            return false;
        }
        if m.is_no_plan() {
            self.notices += 1;
            return true;
        }
        self.ipc_lat.record_ns(now_ns.saturating_sub(m.stamp_ns));
        self.plan_lat
            .record_ns(now_ns.saturating_sub(m.from_state_stamp_ns));
        self.plans += 1;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{status_code, MSG_VERSION};
    use planner::ip::Status;

    /// A valid plan on road 7 (grid 2.5 m) made from state `seq` of run `run_id`.
    fn plan(run_id: RunId, seq: u64) -> Box<Trajectory> {
        let x = [0.0, 15.0, 0.0, 15.0, 0.0, 0.0, 0.0, 3.0, 1.0];
        let mut p = Box::new(Trajectory::zeroed());
        p.version = MSG_VERSION;
        p.status = status_code(Status::Optimal);
        p.road_id = 7;
        p.ds = 2.5;
        p.x_from = x;
        p.x = [x; crate::msg::HORIZON_N + 1];
        p.from_run_id = run_id;
        p.from_state_seq = seq;
        p
    }

    #[test]
    fn the_inbox_takes_own_plans_and_counts_foreign_and_invalid_ones() {
        let mut inbox = Inbox::new(0xabc);
        inbox.own.next_seq();
        inbox.own.next_seq();
        // Own plans from states 1 and 2.
        assert!(inbox.accept(&plan(0xabc, 1), 7, 2.5, 10));
        assert!(inbox.accept(&plan(0xabc, 2), 7, 2.5, 10));
        // A predecessor's plan, and an own-run plan from a state not yet published.
        assert!(!inbox.accept(&plan(0xdef, 2), 7, 2.5, 10));
        assert!(!inbox.accept(&plan(0xabc, 3), 7, 2.5, 10));
        // An invalid plan is rejected, not foreign.
        assert!(!inbox.accept(&plan(0xabc, 1), 8, 2.5, 10));
        assert_eq!(inbox.plans, 2);
        assert_eq!(inbox.rejected, 1);
        assert_eq!(
            inbox.foreign,
            ForeignPlans {
                run_id: 1,
                state_seq: 1
            }
        );
        assert_eq!(inbox.ipc_lat.count(), 2);
    }
}
