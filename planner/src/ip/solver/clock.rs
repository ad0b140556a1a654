//! Wall-clock bookkeeping of a solve: the time budget and the time spent per phase.
//!
//! The budget is checked at every point where the solver can stop cleanly: at the start of
//! each iteration, before each factorization of the inertia-correction loop (fallback
//! included), before each line-search trial and second-order correction, and so before
//! each restoration step's factorization and trials. Between two checks lies at most one
//! factorization with its direction solves, or one trial evaluation with the next
//! iterate's derivative evaluation, or one Hessian evaluation; after the stop the best
//! iterate is evaluated once more. That bounds the overshoot of a solve past its budget.
//! A check is one clock read and changes no arithmetic, so a solve that does not run out
//! of time gives the same bits whatever its budget; one that does stops at a point that
//! depends on the machine's speed (the time budget is not deterministic, the iteration
//! cap is).

use std::time::Instant;

use crate::ip::info::PhaseTimes;

/// A phase of the iteration whose time [`PhaseTimes`] reports.
#[derive(Debug, Clone, Copy)]
pub(super) enum Phase {
    /// NLP evaluations.
    Evaluation,
    /// KKT factorizations.
    Factorization,
    /// Direction solves.
    Solve,
    /// Line search (its evaluations excluded).
    LineSearch,
}

/// The budget of a solve ran out: a check inside a phase fired, and the phase returned
/// without finishing its work (the iteration loop turns this into `time_limit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct OutOfTime;

/// The time budget of a solve: its start and the seconds it may take. `Copy`, so that a
/// phase running inside [`Clock::time`] can hold its own copy and check it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Deadline {
    start: Instant,
    max_time_s: f64,
}

impl Deadline {
    /// Seconds since the start.
    pub(super) fn elapsed(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Whether the time budget is spent.
    pub(super) fn passed(&self) -> bool {
        self.elapsed() > self.max_time_s
    }

    /// `Err(OutOfTime)` once the time budget is spent (one clock read).
    pub(super) fn check(&self) -> Result<(), OutOfTime> {
        if self.passed() {
            Err(OutOfTime)
        } else {
            Ok(())
        }
    }
}

/// The time budget of a solve and the time spent per phase so far.
#[derive(Debug)]
pub(super) struct Clock {
    /// The budget.
    pub(super) deadline: Deadline,
    /// Time per phase so far.
    pub(super) times: PhaseTimes,
}

impl Clock {
    /// Starts the clock of a solve with a budget of `max_time_s` seconds.
    pub(super) fn start(max_time_s: f64) -> Self {
        Self {
            deadline: Deadline {
                start: Instant::now(),
                max_time_s,
            },
            times: PhaseTimes::default(),
        }
    }

    /// Seconds since the start.
    pub(super) fn elapsed(&self) -> f64 {
        self.deadline.elapsed()
    }

    /// Whether the time budget is spent.
    pub(super) fn out_of_time(&self) -> bool {
        self.deadline.passed()
    }

    fn slot(&mut self, phase: Phase) -> &mut f64 {
        match phase {
            Phase::Evaluation => &mut self.times.evaluation,
            Phase::Factorization => &mut self.times.factorization,
            Phase::Solve => &mut self.times.solve,
            Phase::LineSearch => &mut self.times.line_search,
        }
    }

    /// Runs `f`, adding its time to `phase`.
    pub(super) fn time<R>(&mut self, phase: Phase, f: impl FnOnce() -> R) -> R {
        let t = Instant::now();
        let r = f();
        *self.slot(phase) += t.elapsed().as_secs_f64();
        r
    }

    /// Runs `f`, which adds the time of its NLP evaluations to its argument: that time goes
    /// to [`Phase::Evaluation`], the rest to `phase`.
    pub(super) fn time_with_evaluations<R>(
        &mut self,
        phase: Phase,
        f: impl FnOnce(&mut f64) -> R,
    ) -> R {
        let t = Instant::now();
        let mut teval = 0.0;
        let r = f(&mut teval);
        self.times.evaluation += teval;
        *self.slot(phase) += t.elapsed().as_secs_f64() - teval;
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_deadline_is_checked_against_the_wall_clock_and_copies_share_it() {
        let spent = Clock::start(1e-9).deadline;
        std::thread::sleep(std::time::Duration::from_millis(1));
        assert_eq!(spent.check(), Err(OutOfTime));
        let copy = spent;
        assert!(copy.passed());
        let far = Clock::start(3600.0);
        assert_eq!(far.deadline.check(), Ok(()));
        assert!(!far.out_of_time());
    }
}
