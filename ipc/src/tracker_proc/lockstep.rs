//! The tracker's side of lockstep ([`crate::lockstep`]): at every planning period of
//! simulated time it publishes the state flagged [`FLAG_PLAN_NOW`], waits for the
//! planner's answer to that state, and drives the plan from its modelled arrival time on.
//!
//! A cycle at t_k: publish the state (seq q), wait for the plan or notice made from q;
//! step the car to t_k + latency on the plan it has, take the new plan, step on to
//! t_k + T. Before the first plan the car waits at its start, as in real time; a notice
//! leaves the car on the plan it has, which goes stale --stale-after-s of simulated time
//! after it was taken.

use std::time::{Duration, Instant};

use planner::model::ix;

use super::{Ports, TrackerArgs, TrackerLoop, TrackerProcError};
use crate::lockstep::Lockstep;
use crate::msg::{Trajectory, VehicleState, FLAG_PLAN_NOW};
use crate::services::{publish_state, wait_events};

/// Wall-clock silence after which a flagged state is sent again.
const RESEND_AFTER: Duration = Duration::from_millis(100);

/// Lockstep's period and latency model, and the plan received but not yet arrived.
pub(super) struct Schedule {
    ls: Lockstep,
    /// The plan waiting for its arrival time (preallocated; copied in place).
    pending: Box<Trajectory>,
    /// Simulated time at which `pending` arrives \[s\] (`None`: no plan waiting).
    arrives_at: Option<f64>,
}

impl Schedule {
    /// The schedule of `args` in lockstep, `None` in real time.
    pub(super) fn from_args(args: &TrackerArgs) -> Result<Option<Self>, String> {
        if !args.lockstep {
            return Ok(None);
        }
        Ok(Some(Self {
            ls: Lockstep::new(args.rate_hz, args.lockstep_ms_per_iter)?,
            pending: Box::new(Trajectory::zeroed()),
            arrives_at: None,
        }))
    }

    /// Holds `m`, received at simulated time `t`, until its modelled solve time has
    /// passed. Allocates nothing.
    pub(super) fn stage(&mut self, m: &Trajectory, t: f64) {
        *self.pending = *m;
        self.arrives_at = Some(t + self.ls.latency_s(m.iterations));
    }

    /// The settings as JSON, for the report.
    pub(super) fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "period_s": self.ls.period_s,
            "ms_per_iter": self.ls.ms_per_iter,
        })
    }
}

impl TrackerLoop {
    /// Steps to the waiting plan's arrival and takes it (nothing when none waits).
    fn take_arrived(&mut self, args: &TrackerArgs) {
        let Some(ls) = self.lockstep.as_mut() else {
            return;
        };
        let Some(at) = ls.arrives_at.take() else {
            return;
        };
        self.step_to(args, at);
        if let Some(ls) = self.lockstep.as_mut() {
            std::mem::swap(&mut self.plan, &mut ls.pending);
        }
        self.took_plan();
    }

    /// Waits until the planner has answered `state` (a plan or a notice made from it),
    /// sending it again after every 100 ms of silence: a planner that subscribed after
    /// it was sent would otherwise never see it, and one that has it skips the copy (same
    /// run and seq). `Ok(Some(reason))` when the run is asked to stop meanwhile; an error
    /// when the planner stays silent for --first-plan-timeout-s of wall-clock time. A state
    /// the planner drops as invalid (a car spun past the physical range of beta) gets no
    /// answer, in lockstep as in real time, so the wait ends at once.
    fn await_answer(
        &mut self,
        args: &TrackerArgs,
        ports: &Ports,
        state: VehicleState,
    ) -> Result<Option<&'static str>, TrackerProcError> {
        if state.validate(self.sc.id).is_err() {
            return Ok(None);
        }
        let asked = Instant::now();
        let mut sent = asked;
        while self.answered_seq < state.seq {
            if sent.elapsed() >= RESEND_AFTER {
                publish_state(&ports.publisher, &ports.notifier, state)?;
                sent = Instant::now();
            }
            if ports.stdin.closed() || ports.svc.termination_requested() {
                return Ok(Some("stop requested"));
            }
            if asked.elapsed().as_secs_f64() > args.first_plan_timeout_s {
                return Err(TrackerProcError::NoPlan(args.first_plan_timeout_s));
            }
            if let Err(e) = wait_events(&ports.listener, RESEND_AFTER) {
                if ports.svc.termination_requested() {
                    return Ok(Some("stop requested"));
                }
                return Err(e.into());
            }
            self.receive(ports)?;
        }
        Ok(None)
    }
}

/// The lockstep loop: one planning period of simulated time per pass; returns why the
/// drive ended.
pub(super) fn run(
    tl: &mut TrackerLoop,
    args: &TrackerArgs,
    ports: &Ports,
) -> Result<&'static str, TrackerProcError> {
    let period_s = tl.lockstep.as_ref().map_or(0.1, |l| l.ls.period_s);
    loop {
        let state = tl.publish(ports, Instant::now(), FLAG_PLAN_NOW)?;
        if let Some(reason) = tl.await_answer(args, ports, state)? {
            return Ok(reason);
        }
        if tl.sim_start.is_some() {
            let t_tick = tl.car.plant.x[ix::T];
            tl.take_arrived(args);
            tl.step_to(args, t_tick + period_s);
            let age_s = tl.car.plant.x[ix::T] - tl.last_plan_t;
            tl.check_stale(args, age_s);
        }
        if let Some(reason) = tl.end_reason(args, Instant::now()) {
            return Ok(reason);
        }
    }
}
