//! Budget replays: re-solve every recorded input under a time budget (`--budget-ms`) or an
//! iteration budget (`--max-iter`) and say what the planner process would have sent the
//! car for each, with the planner's own decision rule
//! ([`planner::plan::choice::choose`]).
//!
//! The rule needs to know whether a previous plan is usable: one was sent (converged or
//! best iterate) and the car is still within the first eighth of its horizon. A recording
//! holds the road ahead of the car but not the car's arc length, so the replay takes the
//! car where the previous sent plan puts it at the time elapsed between the two inputs'
//! stamps (the arc length of that plan at t = elapsed, linear between nodes; past its
//! last node, beyond the horizon). On a drive that follows its plans this is where the
//! car is; the planner process uses the measured arc length.

use planner::ip::{Settings, SolveInfo, Status};
use planner::model::{ix, NX};
use planner::plan::choice::{choose, previous_usable, Outcome, PlanKind};
use serde::Serialize;

/// The budgets a replay applies to every solve.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Budgets {
    /// Wall-clock budget of each solve \[ms\] (`max_time_s`).
    pub budget_ms: Option<f64>,
    /// Iteration budget of each solve (`max_iter`).
    pub max_iter: Option<usize>,
}

impl Budgets {
    /// True when a budget is applied.
    pub fn any(&self) -> bool {
        self.budget_ms.is_some() || self.max_iter.is_some()
    }

    /// `recorded` with the budgets applied.
    pub fn apply(&self, recorded: Settings) -> Settings {
        let mut s = recorded;
        if let Some(ms) = self.budget_ms {
            s.max_time_s = ms * 1e-3;
        }
        if let Some(k) = self.max_iter {
            s.max_iter = k;
        }
        s
    }
}

/// True when the solve ended at its iteration or time cap: `iteration_limit`,
/// `time_limit`, or `acceptable` reached there.
pub fn hit_cap(info: &SolveInfo, settings: &Settings) -> bool {
    match info.status {
        Status::IterationLimit | Status::TimeLimit => true,
        Status::Acceptable => {
            info.iterations >= settings.max_iter || info.times.total >= settings.max_time_s
        }
        _ => false,
    }
}

/// [`hit_cap`] for a recorded output solved with `settings`.
pub fn recorded_hit_cap(out: &plan_record::PlanOutput, settings: &Settings) -> bool {
    match out.status.as_str() {
        "iteration_limit" | "time_limit" => true,
        "acceptable" => {
            out.iterations as usize >= settings.max_iter || out.time_total_s >= settings.max_time_s
        }
        _ => false,
    }
}

/// Whether a solve was stopped by its wall-clock budget: where it stops depends on the
/// machine's speed at that moment, so no replay can reproduce its bits.
pub fn stopped_by_clock(info: &SolveInfo, settings: &Settings) -> bool {
    match info.status {
        Status::TimeLimit => true,
        Status::Acceptable => info.times.total >= settings.max_time_s,
        _ => false,
    }
}

/// [`stopped_by_clock`] for a recorded output solved with `settings`.
pub fn recorded_stopped_by_clock(out: &plan_record::PlanOutput, settings: &Settings) -> bool {
    match out.status.as_str() {
        "time_limit" => true,
        "acceptable" => out.time_total_s >= settings.max_time_s,
        _ => false,
    }
}

/// Whether a replayed solve is compared with its recorded output: it ran under the
/// recorded caps, or neither it nor the recording stopped at a cap (a cap that does not
/// bind changes no bits).
pub fn comparable(
    replayed: (&SolveInfo, &Settings),
    recorded: (&plan_record::PlanOutput, &Settings),
) -> bool {
    replayed.1 == recorded.1
        || (!hit_cap(replayed.0, replayed.1) && !recorded_hit_cap(recorded.0, recorded.1))
}

/// What the car would have been sent for each replayed plan, in order.
#[derive(Debug, Clone, Default)]
pub struct SentPlans {
    /// States of the last plan sent as converged or best iterate, and its input's stamp.
    previous: Option<(Vec<[f64; NX]>, u64)>,
}

impl SentPlans {
    /// The decision for the plan solved from the input stamped `stamp_ns` that ended
    /// `info` with states `xs`; remembers it when it is sent as converged or best iterate.
    pub fn decide(
        &mut self,
        info: &SolveInfo,
        stamp_ns: u64,
        xs: &[[f64; NX]],
    ) -> Option<PlanKind> {
        let usable = self.previous.as_ref().is_some_and(|(prev, stamp)| {
            let elapsed = stamp_ns.saturating_sub(*stamp) as f64 * 1e-9;
            let horizon = prev.last().map_or(0.0, |x| x[ix::S]);
            previous_usable(arc_length_at(prev, elapsed), horizon)
        });
        let kind = choose(Some(Outcome::of(info)), usable);
        if matches!(kind, Some(PlanKind::Converged | PlanKind::BestIterate)) {
            self.previous = Some((xs.to_vec(), stamp_ns));
        }
        kind
    }
}

/// Arc length of the plan `xs` at time `t` (linear between nodes; infinite past its end).
fn arc_length_at(xs: &[[f64; NX]], t: f64) -> f64 {
    match xs.windows(2).find(|w| w[1][ix::T] >= t) {
        Some(w) => {
            let (a, b) = (&w[0], &w[1]);
            let span = b[ix::T] - a[ix::T];
            let f = if span > 0.0 {
                ((t - a[ix::T]) / span).clamp(0.0, 1.0)
            } else {
                1.0
            };
            a[ix::S] + f * (b[ix::S] - a[ix::S])
        }
        None => f64::INFINITY,
    }
}

/// Counts of what the car would have been sent.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct SentCounts {
    /// Converged plans.
    pub sent_converged: usize,
    /// Best iterates within the drivable violation.
    pub sent_best_iterate: usize,
    /// Previous plans shifted to the car.
    pub sent_previous_shifted: usize,
    /// Cycles that sent no plan (no drivable plan, no usable previous one; the planner
    /// process sends the notice of no drivable plan there).
    pub sent_nothing: usize,
}

impl SentCounts {
    /// Counts the kinds of `sent`.
    pub fn of<'a>(sent: impl IntoIterator<Item = &'a Option<PlanKind>>) -> Self {
        let mut c = Self::default();
        for k in sent {
            match k {
                Some(PlanKind::Converged) => c.sent_converged += 1,
                Some(PlanKind::BestIterate) => c.sent_best_iterate += 1,
                Some(PlanKind::PreviousShifted) => c.sent_previous_shifted += 1,
                None => c.sent_nothing += 1,
            }
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(status: Status, max_violation: f64) -> SolveInfo {
        SolveInfo {
            status,
            iterations: 3,
            objective: 0.0,
            max_violation,
            initial_violation: 0.0,
            start_violation: 0.0,
            dual_inf: 0.0,
            compl: 0.0,
            mu: 0.0,
            factorizations: 0,
            max_factorizations_per_iter: 0,
            fallback_steps: 0,
            evaluations: 0,
            times: Default::default(),
            best_iterate: true,
            best_iteration: 2,
        }
    }

    /// A plan at 20 m/s over 100 m, nodes every 10 m.
    fn plan() -> Vec<[f64; NX]> {
        (0..=10)
            .map(|k| {
                let mut x = [0.0; NX];
                x[ix::S] = 10.0 * k as f64;
                x[ix::T] = 0.5 * k as f64;
                x
            })
            .collect()
    }

    #[test]
    fn the_replay_sends_what_the_planner_rule_sends_with_the_car_on_the_previous_plan() {
        let mut sent = SentPlans::default();
        let xs = plan();
        let bad = info(Status::TimeLimit, 1.0);
        // Nothing sent yet: a failed solve sends no plan.
        assert_eq!(sent.decide(&bad, 0, &xs), None);
        assert_eq!(
            sent.decide(&info(Status::Optimal, 0.0), 0, &xs),
            Some(PlanKind::Converged)
        );
        // 0.5 s later the car is 10 m along the previous plan (of 100 m): usable.
        assert_eq!(
            sent.decide(&bad, 500_000_000, &xs),
            Some(PlanKind::PreviousShifted)
        );
        // 1 s later it is 20 m along: past an eighth of the horizon.
        assert_eq!(sent.decide(&bad, 1_000_000_000, &xs), None);
        let c = SentCounts::of(&[
            None,
            Some(PlanKind::Converged),
            Some(PlanKind::PreviousShifted),
        ]);
        assert_eq!(c.sent_nothing, 1);
        assert_eq!(c.sent_converged, 1);
        assert_eq!(c.sent_previous_shifted, 1);
    }

    #[test]
    fn a_solve_hits_its_cap_when_it_stops_there() {
        let s = Settings {
            max_iter: 3,
            ..Settings::default()
        };
        assert!(hit_cap(&info(Status::IterationLimit, 0.0), &s));
        assert!(hit_cap(&info(Status::TimeLimit, 0.0), &s));
        assert!(hit_cap(&info(Status::Acceptable, 0.0), &s));
        assert!(!hit_cap(&info(Status::Optimal, 0.0), &s));
        let roomy = Settings {
            max_iter: 30,
            ..Settings::default()
        };
        assert!(!hit_cap(&info(Status::Acceptable, 0.0), &roomy));
    }
}
