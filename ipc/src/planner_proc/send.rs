//! Sending a cycle's plan: the publish policy's decision, then the plan written in place
//! into a loaned shared-memory sample (allocates nothing). A cycle with nothing drivable
//! sends a notice that says so ([`KIND_NO_PLAN`]) instead of a plan.

use planner::model::{ix, NU, NX};

use super::{publish_policy, PlannerLoop, Ports, Solved};
use crate::clock::{monotonic_ns, thread_cpu_ns};
use crate::elog;
use crate::msg::{status_code, PlanKind, VehicleState, HORIZON_N, KIND_NO_PLAN, MSG_VERSION};
use crate::services::{ipc_err, IpcError};

/// How far past its budget a steady cycle may end before it counts as past the budget
/// \[ms\]: the solver stops within one factorization and one trial step of the budget
/// (`planner_proc` states that overshoot at start-up, well under this), so a cycle past it
/// lost time outside the solver's checks, to the operating system or to the send.
pub(super) const OVERRUN_ALLOWANCE_MS: f64 = 2.0;

impl PlannerLoop {
    /// Decides what the cycle sends ([`publish_policy`]) and publishes it: the planner's
    /// solution (kept as the previous plan) or the previous plan shifted to the car. When
    /// there is nothing drivable it sends a notice that says so ([`KIND_NO_PLAN`]).
    pub(super) fn send(
        &mut self,
        ports: &Ports,
        state: &VehicleState,
        solved: &Solved,
    ) -> Result<(), IpcError> {
        let (ds, cycle) = (self.ds, self.cycles);
        let pol = &mut self.policy;
        let kind = pol.decide(solved.info.as_ref(), solved.s_track, state.run_id, ds);
        if let Some(r) = self.cy.relaxed.as_mut() {
            let own = matches!(kind, Some(PlanKind::Converged | PlanKind::BestIterate));
            r.after_cycle(self.cy.relaxed_now, own, solved.s_track);
        }
        let Some(kind) = kind else {
            return self.notify_no_plan(ports, state, solved);
        };
        let meta = if kind == PlanKind::PreviousShifted {
            let (s_origin, to_car) = pol.previous.shift_to(solved.s_track, ds);
            let origin = (s_origin, state.x[ix::T] - to_car);
            (
                kind,
                pol.previous.age(cycle),
                pol.previous.max_violation(),
                origin,
            )
        } else {
            let viol = solved.info.as_ref().map_or(0.0, |i| i.max_violation);
            let (xs, us) = (self.cy.planner.states(), self.cy.planner.controls());
            pol.previous
                .store(xs, us, solved.s_track, state.run_id, viol, cycle);
            (kind, 0, viol, (solved.s_track, state.x[ix::T]))
        };
        self.publish(ports, state, solved, meta)
    }

    /// Sends the notice that this cycle has no drivable plan ([`KIND_NO_PLAN`]). Among
    /// obstacles the car does not wait for a first plan on it (it brakes in its lane), so
    /// the steady budget applies from the first notice; on a closed road the car waits for
    /// its first plan, which keeps the start-up budget.
    pub(super) fn notify_no_plan(
        &mut self,
        ports: &Ports,
        state: &VehicleState,
        solved: &Solved,
    ) -> Result<(), IpcError> {
        let among_obstacles = !self.sc.road.obstacles().is_empty();
        let viol = solved.info.as_ref().map_or(f64::NAN, |i| i.max_violation);
        let viol = if viol.is_finite() { viol } else { f64::MAX };
        let origin = (solved.s_track, state.x[ix::T]);
        self.write_sample(ports, state, solved, (KIND_NO_PLAN, 0, viol, origin))?;
        self.record_cycle_time(solved, among_obstacles);
        Ok(())
    }

    /// Records the cycle's time (start to send). The cycle that ends the start-up (the
    /// first plan, or among obstacles the first notice) runs under the start-up budget and
    /// is reported on its own; a notice on a closed road before the first plan is a
    /// start-up cycle too (the car is waiting), not a steady one.
    fn record_cycle_time(&mut self, solved: &Solved, ends_startup: bool) {
        let ns = solved.t0.elapsed().as_nanos() as u64;
        if self.startup_over {
            self.cycle_lat.record_ns(ns);
            self.note_overrun(solved, ns as f64 * 1e-6);
        } else if ends_startup {
            self.first_cycle_ms = ns as f64 * 1e-6;
            self.startup_over = true;
        }
    }

    /// Writes the plan the cycle sends in place into a loaned sample, sends it and notifies
    /// the tracker. `meta` is (kind, age in cycles, max violation, (s, t) of node 0): a
    /// [`PlanKind::PreviousShifted`] plan is the previous plan's shifted copy, any other the
    /// planner's solution.
    fn publish(
        &mut self,
        ports: &Ports,
        state: &VehicleState,
        solved: &Solved,
        (kind, age, viol, origin): (PlanKind, u32, f64, (f64, f64)),
    ) -> Result<(), IpcError> {
        self.write_sample(ports, state, solved, (kind.code(), age, viol, origin))?;
        self.record_cycle_time(solved, true);
        self.published += 1;
        Ok(())
    }

    /// Counts a steady cycle of `cycle_ms` that ended past the budget plus
    /// [`OVERRUN_ALLOWANCE_MS`] and logs it (the first ten, then every hundredth) with where
    /// its time went: the solve (how it started, its status and iterations) or the send,
    /// and the planner thread's CPU time in the cycle. A cycle whose CPU time stayed within
    /// the allowance is also counted as off the CPU: the thread waited, it did not compute.
    /// Lockstep counts none (its budget is in iterations).
    fn note_overrun(&mut self, solved: &Solved, cycle_ms: f64) {
        let limit_ms = self.budget_ms + OVERRUN_ALLOWANCE_MS;
        // In lockstep the budget is the iteration cap; the wall clock binds no cycle.
        if cycle_ms <= limit_ms || self.lockstep.is_some() {
            return;
        }
        let cpu_ms = thread_cpu_ns().saturating_sub(solved.cpu_t0_ns) as f64 * 1e-6;
        self.past_budget += 1;
        self.past_budget_off_cpu += u64::from(cpu_ms <= limit_ms);
        let n = self.past_budget;
        if n > 10 && !n.is_multiple_of(100) {
            return;
        }
        let solve_ms = solved.solve_time_s * 1e3;
        let start = match solved.start {
            super::Start::Cold => "cold",
            super::Start::Warm {
                fell_back: true, ..
            } => "warm, fell back to cold",
            super::Start::Warm { .. } => "warm",
        };
        let (status, iterations, t) = solved
            .info
            .as_ref()
            .map_or(("no solve", 0, Default::default()), |i| {
                (i.status.name(), i.iterations, i.times)
            });
        elog!(
            "planner: cycle at s = {:.1} m took {cycle_ms:.1} ms, past the budget {:.1} ms + {OVERRUN_ALLOWANCE_MS} ms ({n} so far): solve {solve_ms:.1} ms ({start}, {status} after {iterations} iterations; in the solver {:.1} ms: evaluations {:.1}, factorizations {:.1}), send {:.1} ms; on the CPU {cpu_ms:.1} ms",
            solved.s_track,
            self.budget_ms,
            t.total * 1e3,
            t.evaluation * 1e3,
            t.factorization * 1e3,
            cycle_ms - solve_ms,
        );
    }

    /// Loans a sample, writes the message of kind code `kind` into it in place and sends
    /// it: the previous plan shifted, the planner's solution, or for a notice
    /// ([`KIND_NO_PLAN`]) the measured state held at every node.
    fn write_sample(
        &mut self,
        ports: &Ports,
        state: &VehicleState,
        solved: &Solved,
        (kind, age, viol, (s_origin, t_origin)): (u32, u32, f64, (f64, f64)),
    ) -> Result<(), IpcError> {
        let mut sample = ports
            .publisher
            .loan_uninit()
            .map_err(ipc_err("loan trajectory"))?;
        let p = sample.payload_mut().as_mut_ptr();
        let notice = kind == KIND_NO_PLAN;
        let (xs, us) = if kind == PlanKind::PreviousShifted.code() {
            self.policy.previous.shifted_plan()
        } else {
            (self.cy.planner.states(), self.cy.planner.controls())
        };
        let held = |k: usize| {
            let mut x = state.x;
            let s = k as f64 * self.ds;
            x[ix::S] = s;
            x[ix::T] = s / state.x[ix::V].max(1.0);
            x
        };
        let (status, iterations) = match &solved.info {
            Some(info) => (info.status, info.iterations),
            None => (publish_policy::failed_status(), 0),
        };
        // SAFETY: `p` points to a properly aligned, writable `Trajectory` in the loaned
        // shared-memory chunk; every field is written exactly once below (all are plain
        // `Copy` data), so the sample is fully initialised before `assume_init`.
        let sample = unsafe {
            use core::ptr::addr_of_mut;
            addr_of_mut!((*p).version).write(MSG_VERSION);
            addr_of_mut!((*p).status).write(status_code(status));
            addr_of_mut!((*p).seq).write(self.published);
            addr_of_mut!((*p).road_id).write(self.sc.id);
            addr_of_mut!((*p).from_run_id).write(state.run_id);
            addr_of_mut!((*p).from_state_seq).write(state.seq);
            addr_of_mut!((*p).from_state_stamp_ns).write(state.stamp_ns);
            addr_of_mut!((*p).iterations).write(iterations.min(u32::MAX as usize) as u32);
            addr_of_mut!((*p).warm_started).write(u32::from(solved.start.warm_started()));
            addr_of_mut!((*p).kind).write(kind);
            addr_of_mut!((*p).age_cycles).write(age);
            addr_of_mut!((*p).max_violation).write(viol);
            addr_of_mut!((*p).solve_time_s).write(solved.solve_time_s);
            addr_of_mut!((*p).s_origin).write(s_origin);
            addr_of_mut!((*p).t_origin).write(t_origin);
            addr_of_mut!((*p).ds).write(self.ds);
            addr_of_mut!((*p).x_from).write(state.x);
            let px = addr_of_mut!((*p).x) as *mut [f64; NX];
            for k in 0..=HORIZON_N {
                px.add(k).write(if notice { held(k) } else { xs[k] });
            }
            let pu = addr_of_mut!((*p).u) as *mut [f64; NU];
            for k in 0..HORIZON_N {
                pu.add(k).write(if notice { [0.0; NU] } else { us[k] });
            }
            addr_of_mut!((*p).stamp_ns).write(monotonic_ns());
            sample.assume_init()
        };
        sample.send().map_err(ipc_err("send trajectory"))?;
        ports
            .notifier
            .notify()
            .map_err(ipc_err("notify trajectory"))?;
        Ok(())
    }
}
