//! What a solve reports: status, the final errors, per-phase timings and an iteration log.

use serde::Serialize;

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Converged to the requested tolerances.
    Optimal,
    /// A cap was hit but the best iterate meets the acceptable tolerances.
    Acceptable,
    /// Iteration cap hit; the best iterate is returned.
    IterationLimit,
    /// Wall-clock budget (`max_time_s`) spent; the best iterate is returned.
    TimeLimit,
    /// Converged to a stationary point of the constraint violation that is infeasible.
    LocallyInfeasible,
    /// Could not make progress (factorization or line search failed repeatedly).
    NumericalFailure,
    /// The problem data or starting point is unusable (NaN, inconsistent bounds).
    InvalidInput,
}

impl Status {
    /// The snake_case name used in JSON and reports.
    pub fn name(self) -> &'static str {
        match self {
            Status::Optimal => "optimal",
            Status::Acceptable => "acceptable",
            Status::IterationLimit => "iteration_limit",
            Status::TimeLimit => "time_limit",
            Status::LocallyInfeasible => "locally_infeasible",
            Status::NumericalFailure => "numerical_failure",
            Status::InvalidInput => "invalid_input",
        }
    }

    /// True for `optimal` and `acceptable`.
    pub fn is_success(self) -> bool {
        matches!(self, Status::Optimal | Status::Acceptable)
    }
}

/// Which direction an iteration took.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StepKind {
    /// Newton step on the barrier problem with the current mu.
    Newton,
    /// Mehrotra predictor-corrector step.
    Corrected,
    /// Step with a second-order correction of the constraints.
    SecondOrder,
    /// The line search failed; the iterate was kept and regularization raised.
    Rejected,
    /// Feasibility restoration (Gauss-Newton on the constraint violation).
    Restoration,
    /// The refactorization cap was reached without the right inertia: the step of the
    /// convexified (Gershgorin-shifted, quasi-definite) KKT system was taken instead.
    Fallback,
}

impl StepKind {
    /// The snake_case name used in JSON and reports.
    pub fn name(self) -> &'static str {
        match self {
            StepKind::Newton => "newton",
            StepKind::Corrected => "corrected",
            StepKind::SecondOrder => "second_order",
            StepKind::Rejected => "rejected",
            StepKind::Restoration => "restoration",
            StepKind::Fallback => "fallback",
        }
    }
}

/// One row of the iteration log.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IterLog {
    /// Iteration number.
    pub iter: usize,
    /// Objective at this iterate (the one whose errors the row holds).
    pub objective: f64,
    /// Max constraint violation.
    pub inf_pr: f64,
    /// The filter's violation measure ||c||_1 at this iterate.
    pub theta: f64,
    /// Scaled dual infeasibility (restoration rows: relative stationarity of the violation).
    pub inf_du: f64,
    /// Scaled complementarity.
    pub compl: f64,
    /// Barrier parameter used for the step.
    pub mu: f64,
    /// Primal step length taken.
    pub alpha: f64,
    /// Primal regularization delta_w (0 when the inertia was right).
    pub delta_w: f64,
    /// Factorizations (refactorizations included) this iteration; never above
    /// `Settings::max_refactorizations`.
    pub factorizations: usize,
    /// Backtracking steps this iteration.
    pub backtracks: usize,
    /// Kind of step.
    pub step: StepKind,
}

impl IterLog {
    /// Column heads of [`Self::row`]: the error columns are the scaled ones the
    /// termination test uses; nf counts factorizations, bt backtracks.
    pub const HEADER: &'static str = "iter  objective      inf_pr    theta     inf_du    compl     mu        alpha     delta_w  nf bt step";

    /// This iteration as one line of a fixed-width table under [`Self::HEADER`].
    pub fn row(&self) -> String {
        format!(
            "{:4} {:13.6e} {:9.2e} {:9.2e} {:9.2e} {:9.2e} {:9.2e} {:9.2e} {:8.1e} {:2} {:2} {}",
            self.iter,
            self.objective,
            self.inf_pr,
            self.theta,
            self.inf_du,
            self.compl,
            self.mu,
            self.alpha,
            self.delta_w,
            self.factorizations,
            self.backtracks,
            self.step.name()
        )
    }
}

/// Wall-clock time per phase of the solve, in seconds.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct PhaseTimes {
    /// Function, gradient, Jacobian and Hessian evaluations (including line-search trials).
    pub evaluation: f64,
    /// KKT factorizations.
    pub factorization: f64,
    /// KKT solves (back-substitutions).
    pub solve: f64,
    /// Line search (excluding its function evaluations).
    pub line_search: f64,
    /// Everything.
    pub total: f64,
}

/// Summary of a solve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SolveInfo {
    /// How it ended.
    pub status: Status,
    /// Iterations taken.
    pub iterations: usize,
    /// Objective at the returned point.
    pub objective: f64,
    /// Max constraint violation (bounds and constraints) at the returned point (the best
    /// iterate's when `best_iterate`).
    pub max_violation: f64,
    /// Max constraint violation at the starting point (before the bound push); infinite
    /// where the model is singular there (V = 0 in the zero guess).
    pub initial_violation: f64,
    /// Max constraint violation where the iteration actually starts: the starting point
    /// pushed into the variable bounds (finite whenever the solve runs).
    pub start_violation: f64,
    /// Scaled dual infeasibility at the returned point.
    pub dual_inf: f64,
    /// Scaled complementarity at the returned point.
    pub compl: f64,
    /// Final barrier parameter.
    pub mu: f64,
    /// Total KKT factorizations.
    pub factorizations: usize,
    /// Largest number of factorizations in one iteration (bounded by
    /// `Settings::max_refactorizations`).
    pub max_factorizations_per_iter: usize,
    /// Iterations that took the convexified fallback step ([`StepKind::Fallback`]).
    pub fallback_steps: usize,
    /// Function evaluations (f and g).
    pub evaluations: usize,
    /// Time per phase.
    pub times: PhaseTimes,
    /// The returned point is the best iterate (the filter's violation ||c||_1 above the
    /// acceptable level first, then the objective), not the last one: the solve stopped at a cap
    /// (`iteration_limit`, `time_limit`, or `acceptable` from either) or on a numerical
    /// failure. False for `optimal`, `locally_infeasible` and an unstarted solve, which
    /// return their last iterate.
    pub best_iterate: bool,
    /// The iteration of the returned point (the index of its row in the iteration log):
    /// the best iterate's when `best_iterate`, else `iterations`. A stop inside an
    /// iteration (the time budget) returns no point of that unfinished iteration.
    pub best_iteration: usize,
}
