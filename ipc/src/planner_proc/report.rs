//! The planner process's final report: the totals logged in one line and the summary as
//! JSON (plans by kind, starts, relaxed plans, cycle times, the recording's counts).

use super::{PlannerArgs, PlannerLoop, PlannerProcError};
use crate::elog;
use crate::stats::Latency;

impl PlannerLoop {
    /// Logs the totals, closes the recording and returns the summary as JSON.
    pub(super) fn report(self, args: &PlannerArgs) -> Result<serde_json::Value, PlannerProcError> {
        let (published, warm, cold, failed, outside) = (
            self.published,
            self.warm,
            self.cold,
            self.failed,
            self.outside,
        );
        let rejected = self.rejected;
        elog!(
            "planner: stopping after {published} plans ({warm} warm, {cold} equilibrium starts, {failed} not converged, {} notices of no drivable plan), {} states dropped, {outside} outside the planner's domain",
            self.policy.not_sent,
            rejected.total()
        );
        let recording = match (self.recorder, &args.record) {
            (Some(rec), Some(path)) => {
                let stats = rec.finish().map_err(|e| {
                    PlannerProcError::Setup(format!("--record {}: {e}", path.display()))
                })?;
                serde_json::json!({
                    "file": path.display().to_string(),
                    "inputs": stats.inputs,
                    "outputs": stats.outputs,
                    "warm_starts": stats.warm_starts,
                    "dropped": stats.dropped,
                })
            }
            _ => serde_json::Value::Null,
        };
        let ms = |l: &Latency, q: f64| l.quantile_ns(q) as f64 * 1e-6;
        let mut v = serde_json::json!({
            "process": "planner",
            "budget_ms": self.budget_ms,
            "first_budget_ms": self.first_budget_ms,
            "cycles_not_published": self.policy.not_sent,
            // Every cycle that sends no plan sends the notice instead.
            "no_plan_notices": self.policy.not_sent,
            "first_cycle_ms": self.first_cycle_ms,
            "plans_published": published,
            "warm_starts": warm,
            "warm_capped_after_failure": self.capped_after_failure,
            "equilibrium_starts": cold,
            "not_converged": failed,
            "relaxed_plans": self.cy.relaxed.as_ref().map_or(0, |r| r.sent),
            "relaxed_episodes": self.cy.relaxed.as_ref().map_or(0, |r| r.episodes),
            "states_received": self.states_received,
            "states_rejected": rejected.total(),
            "states_outside_domain": outside,
            "state_run_switches": self.planned.run_switches(),
            "states_rejected_by_reason": {
                "version": rejected.version,
                "road": rejected.road,
                "non_finite": rejected.non_finite,
                "range": rejected.range,
            },
            "cycle_ms_p50": ms(&self.cycle_lat, 0.5),
            "cycle_ms_p99": ms(&self.cycle_lat, 0.99),
            "cycle_ms_max": self.cycle_lat.max_ns() as f64 * 1e-6,
            "cycles_past_budget": self.past_budget,
            "cycles_past_budget_off_cpu": self.past_budget_off_cpu,
            "state_age_at_receive_us": self.state_ipc_lat.json_us(),
            "rate_hz": args.rate_hz,
            "lockstep": match &self.lockstep {
                Some(caps) => serde_json::json!({
                    "ms_per_iter": args.lockstep_ms_per_iter,
                    "max_iter": caps.steady,
                    "first_max_iter": caps.first,
                }),
                None => serde_json::Value::Null,
            },
            "recording": recording,
        });
        self.policy.sent.add_json(&mut v);
        Ok(v)
    }
}
