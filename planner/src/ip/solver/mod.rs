//! The interior-point iteration loop (paper Sec. III): barrier subproblems solved by
//! Newton steps on the primal-dual system (eq. 6), globalized by a line search on the
//! l2 merit function (eq. 5), with inertia correction and a barrier-update rule.
//!
//! One iteration evaluates the derivatives at the current point, checks termination, and
//! then either takes a feasibility-restoration step (`restoration`) or updates the
//! barrier parameter (`barrier_update`), factorizes the KKT matrix with inertia
//! correction (`inertia`), computes the search direction (`direction`), searches along
//! it (`line_search`, `merit`) and applies the safeguards of free mode and of the
//! stall watch (`barrier_update`, `best`).

mod barrier_update;
mod best;
mod clock;
mod direction;
mod inertia;
mod line_search;
mod ln_sum;
mod merit;
mod restoration;
mod start;
mod termination;
mod warm;

use super::info::{IterLog, SolveInfo, Status, StepKind};
use super::kkt::backend::{BackendError, Pattern};
use super::kkt::{KktBackend, KktSolver};
use super::nlp::Nlp;
use super::residuals::{compute_errors, Errors};
use super::settings::Settings;
use super::workspace::Workspace;
use best::{BestIterate, StallWatch};
use clock::{Clock, OutOfTime, Phase};
use restoration::Restoration;
pub use warm::{MuMatch, WarmStart};

/// Error constructing a solver.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// Invalid settings.
    #[error(transparent)]
    Settings(#[from] super::settings::SettingsError),
    /// The KKT backend could not analyse the structure.
    #[error(transparent)]
    Kkt(#[from] BackendError),
}

/// Interior-point solver for one problem structure; all memory is allocated in `new`.
#[derive(Debug)]
pub struct Solver<K: KktSolver = KktBackend> {
    settings: Settings,
    ws: Workspace,
    kkt: K,
    /// Regularization of the last iteration that needed one (IPOPT's delta_w^last).
    delta_w_last: f64,
    /// Barrier objective of the current point and the mu (bits) it was taken at, when the
    /// filter line search accepted the point and nothing has moved it since (the next
    /// search starts from it instead of recomputing it; same bits).
    phi_current: Option<(u64, f64)>,
}

/// What the loop does after a phase of an iteration.
enum Next {
    /// The iteration is complete (its log row is written): start the next one.
    Continue,
    /// The solve ends with this status.
    Stop(Status),
}

/// The state the iteration loop carries from one iteration to the next.
struct LoopState {
    /// Iteration counter (the index of the current iterate's log row).
    iter: usize,
    /// Barrier parameter.
    mu: f64,
    /// Cap on adaptive mu: 1e3 times the initial average complementarity (IPOPT).
    mu_max: f64,
    /// The mu of the last direction; a new mu starts a new barrier problem.
    mu_prev: f64,
    /// Penalty parameter of the merit line search.
    nu: f64,
    /// Adaptive rules run in "free mode" and fall back to the monotone rule when an
    /// iterate is not acceptable to the (objective, violation) progress filter (IPOPT's
    /// obj-constr-filter safeguard, Nocedal-Waechter-Waltz 2009).
    free_mode: bool,
    /// Filter line search: the switching threshold and the cap on ||c||_1.
    theta_min: f64,
    /// See `theta_min`.
    theta_max: f64,
    /// Consecutive failed line searches.
    ls_failures: usize,
    /// The next factorization starts with a shift (the last line search failed).
    force_reg: bool,
    /// The best iterate so far (see [`Solver::score`]).
    best: BestIterate,
    /// The feasibility restoration phase, while it runs.
    resto: Option<Restoration>,
    /// Restoration steps taken in this solve.
    resto_steps: usize,
    /// Progress watch of the regular iterations.
    stall: StallWatch,
}

impl Solver<KktBackend> {
    /// Builds a solver with the KKT backend `settings.kkt` selects (default: Riccati when
    /// the NLP publishes a stage structure it fits, the general sparse LDL^T otherwise).
    pub fn new<P: Nlp + ?Sized>(nlp: &P, settings: Settings) -> Result<Self, SetupError> {
        settings.validate()?;
        let ws = Workspace::new(nlp, settings.max_iter + 2);
        let structure = nlp.stage_structure();
        let kkt = KktBackend::with_threads(
            settings.kkt,
            Pattern {
                n: ws.n,
                m: ws.m,
                hess_rows: &ws.hess_rows,
                hess_cols: &ws.hess_cols,
                jac_rows: &ws.jac_rows,
                jac_cols: &ws.jac_cols,
            },
            structure.as_ref(),
            settings.threads,
        )?;
        Self::with_backend(settings, ws, kkt)
    }
}

impl<K: KktSolver> Solver<K> {
    /// Builds a solver around a given backend and workspace; the settings are validated
    /// as in [`Solver::new`].
    pub fn with_backend(settings: Settings, ws: Workspace, kkt: K) -> Result<Self, SetupError> {
        settings.validate()?;
        Ok(Self {
            settings,
            ws,
            kkt,
            delta_w_last: 0.0,
            phi_current: None,
        })
    }

    /// The KKT backend.
    pub fn kkt(&self) -> &K {
        &self.kkt
    }

    /// Mutable access to the KKT backend.
    pub fn kkt_mut(&mut self) -> &mut K {
        &mut self.kkt
    }

    /// Current settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Replaces the settings (caps, barrier rule) for the next solve.
    pub fn set_settings(
        &mut self,
        settings: Settings,
    ) -> Result<(), super::settings::SettingsError> {
        settings.validate()?;
        if settings.threads != self.settings.threads {
            return Err(super::settings::SettingsError {
                field: "threads",
                value: settings.threads.to_string(),
                expected: "cannot change after setup",
            });
        }
        if settings.max_iter + 2 > self.ws.log.capacity() {
            return Err(super::settings::SettingsError {
                field: "max_iter",
                value: settings.max_iter.to_string(),
                expected: "cannot exceed the max_iter the solver was built with",
            });
        }
        self.settings = settings;
        Ok(())
    }

    /// Primal solution x of the last solve (the best iterate when it did not converge).
    pub fn x(&self) -> &[f64] {
        self.ws.x()
    }

    /// Constraint multipliers of the last solve.
    pub fn y(&self) -> &[f64] {
        &self.ws.y
    }

    /// Per-iteration log of the last solve.
    pub fn log(&self) -> &[IterLog] {
        &self.ws.log
    }

    /// The workspace (for diagnostics and tests).
    pub fn workspace(&self) -> &Workspace {
        &self.ws
    }

    /// Solves the NLP from its `initial_point`. Allocates nothing.
    pub fn solve<P: Nlp + ?Sized>(&mut self, nlp: &mut P) -> SolveInfo {
        self.solve_from(nlp, None)
    }

    /// Solves the NLP from its `initial_point` with the multipliers of `warm` and a barrier
    /// parameter matched to that point (see [`WarmStart`]). Allocates nothing.
    pub fn solve_warm<P: Nlp + ?Sized>(&mut self, nlp: &mut P, warm: &WarmStart<'_>) -> SolveInfo {
        self.solve_from(nlp, Some(warm))
    }

    fn solve_from<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        warm: Option<&WarmStart<'_>>,
    ) -> SolveInfo {
        let mut clock = Clock::start(self.settings.max_time_s);
        let mut info = unstarted_info();
        self.ws.log.clear();
        self.delta_w_last = 0.0;
        self.phi_current = None;
        if !self.initialize(nlp, &mut info, &mut clock) {
            info.times.total = clock.elapsed();
            return info;
        }
        let warmed = warm.is_some_and(|w| self.warm_multipliers(w));
        if !warmed {
            self.start_multipliers(nlp, &mut info, &mut clock);
        }
        // The best iterate starts as this solve's own start: a solve that stops before its
        // first scored iterate (non-finite derivatives) must not restore an older point.
        self.save_best();
        let mut st = self.loop_state();
        if let (true, Some(w)) = (warmed, warm) {
            st.mu = self.matched_mu(w.mu_floor, w.mu_match);
        }

        let status = loop {
            // Derivatives at the current point (f and g are already known).
            if let Err(status) = self.evaluate_derivatives(nlp, &mut clock) {
                break status;
            }
            let err = compute_errors(&mut self.ws, st.mu);
            // The log row of this iteration describes this iterate: its errors and objective.
            let f_iter = self.ws.f;
            // Valid until the step is accepted (see `accept`).
            self.ws.grad_lag_fresh = true;
            self.watch_best(&err, st.iter, &mut st.best);
            info.iterations = st.iter;
            if let Some(status) = self.termination(&err, st.iter, &clock) {
                break status;
            }
            if st.resto.is_some() {
                match self.restoration_iteration(nlp, &mut st, &err, f_iter, &mut info, &mut clock)
                {
                    Some(Next::Continue) => {
                        st.iter += 1;
                        continue;
                    }
                    Some(Next::Stop(status)) => break status,
                    None => {}
                }
            }
            if st.ls_failures >= self.settings.max_ls_failures {
                break Status::NumericalFailure;
            }
            if let Err(status) = self.evaluate_hessian(nlp, &mut clock) {
                break status;
            }
            self.monotone_update(&mut st, &err);
            let fact = match self.factorize_iteration(&mut st, &err, f_iter, &mut info, &mut clock)
            {
                Ok(fact) => fact,
                Err(Next::Continue) => {
                    st.iter += 1;
                    continue;
                }
                Err(Next::Stop(status)) => break status,
            };
            let kind = self.search_direction(&mut st, fact.delta_w, &err, &mut clock);
            let (theta_cur, f_cur) = (super::vector::norm1(&self.ws.c), self.ws.f);
            let outcome =
                match self.search(nlp, &mut st, theta_cur, fact.delta_w, &mut info, &mut clock) {
                    Ok(outcome) => outcome,
                    Err(OutOfTime) => break Status::TimeLimit,
                };
            let (alpha, backtracks, step_kind) = match outcome {
                Some((alpha, bt, soc)) => {
                    self.after_step(&mut st, &err, alpha, (theta_cur, f_cur));
                    (alpha, bt, fact.step_kind(soc, kind))
                }
                None => {
                    self.after_failed_search(&mut st, &err);
                    (0.0, self.settings.max_backtracks, StepKind::Rejected)
                }
            };
            self.push_log(
                st.iter,
                f_iter,
                &err,
                st.mu,
                alpha,
                fact.delta_w,
                fact.count,
                backtracks,
                step_kind,
            );
            st.iter += 1;
        };
        self.finish(nlp, status, &st, info, clock)
    }

    /// Evaluates grad f and the Jacobian at the current point; stops on non-finite values.
    fn evaluate_derivatives<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        clock: &mut Clock,
    ) -> Result<(), Status> {
        let ws = &mut self.ws;
        clock.time(Phase::Evaluation, || {
            nlp.eval_grad_f(&ws.w[..ws.n], &mut ws.grad);
            nlp.eval_jac_g(&ws.w[..ws.n], &mut ws.jac);
        });
        if !super::vector::all_finite(&self.ws.grad) || !super::vector::all_finite(&self.ws.jac) {
            return Err(Status::NumericalFailure);
        }
        Ok(())
    }

    /// Evaluates the Hessian of the Lagrangian at (x, y); stops on non-finite values.
    fn evaluate_hessian<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        clock: &mut Clock,
    ) -> Result<(), Status> {
        let ws = &mut self.ws;
        clock.time(Phase::Evaluation, || {
            nlp.eval_hess(&ws.w[..ws.n], 1.0, &ws.y, &mut ws.hess);
        });
        if !super::vector::all_finite(&self.ws.hess) {
            return Err(Status::NumericalFailure);
        }
        Ok(())
    }

    /// The loop state at the start point: the first barrier parameter, the filter bounds
    /// from the initial violation, empty filters and watches.
    fn loop_state(&mut self) -> LoopState {
        let s = self.settings;
        let mu = self.initial_mu();
        // IPOPT-style cap on adaptive mu: 1e3 times the initial average complementarity.
        let mu_max = 1e3 * mu.max(s.mu_init);
        self.ws.progress.clear();
        self.ws.filter.clear();
        let theta0 = super::vector::norm1(&self.ws.c);
        LoopState {
            iter: 0,
            mu,
            mu_max,
            mu_prev: f64::NAN,
            nu: s.penalty_init,
            free_mode: s.barrier != super::settings::BarrierRule::Monotone,
            theta_min: 1e-4 * theta0.max(1.0),
            theta_max: 1e4 * theta0.max(1.0),
            ls_failures: 0,
            force_reg: false,
            best: BestIterate::none(),
            resto: None,
            resto_steps: 0,
            stall: StallWatch::new(),
        }
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn push_log(
        &mut self,
        iter: usize,
        objective: f64,
        err: &Errors,
        mu: f64,
        alpha: f64,
        delta_w: f64,
        factorizations: usize,
        backtracks: usize,
        step: StepKind,
    ) {
        if self.ws.log.len() < self.ws.log.capacity() {
            self.ws.log.push(IterLog {
                iter,
                objective,
                inf_pr: err.inf_pr,
                theta: err.theta,
                inf_du: err.inf_du / err.s_d,
                compl: err.compl / err.s_c,
                mu,
                alpha,
                delta_w,
                factorizations,
                backtracks,
                step,
            });
        }
    }

    /// The safeguards after an accepted step: free mode's progress filter, then the stall
    /// watch, which hands a stalling infeasible iteration over to restoration.
    fn after_step(&mut self, st: &mut LoopState, err: &Errors, alpha: f64, start: (f64, f64)) {
        st.ls_failures = 0;
        st.force_reg = false;
        if st.free_mode {
            self.free_mode_safeguard(st, start);
        }
        let theta = norm2(&self.ws.c);
        let stalled = st.stall.record(alpha, theta, self.ws.f);
        if stalled && st.may_restore(err.inf_pr, self.settings.max_restoration_steps) {
            st.stall = StallWatch::new();
            st.enter_restoration(theta);
        }
    }

    /// After a failed line search: the next factorization is regularized with a larger
    /// shift, and a significant violation hands over to restoration.
    fn after_failed_search(&mut self, st: &mut LoopState, err: &Errors) {
        let s = self.settings;
        st.ls_failures += 1;
        st.force_reg = true;
        self.delta_w_last = (self.delta_w_last * 10.0)
            .max(s.delta_w_init)
            .min(s.delta_w_max);
        if st.may_restore(err.inf_pr, s.max_restoration_steps) {
            st.enter_restoration(norm2(&self.ws.c));
        }
    }
}

/// The report of a solve that has not started: every measure NaN, every count 0.
fn unstarted_info() -> SolveInfo {
    SolveInfo {
        status: Status::InvalidInput,
        iterations: 0,
        objective: f64::NAN,
        max_violation: f64::NAN,
        initial_violation: f64::NAN,
        start_violation: f64::NAN,
        dual_inf: f64::NAN,
        compl: f64::NAN,
        mu: f64::NAN,
        factorizations: 0,
        max_factorizations_per_iter: 0,
        fallback_steps: 0,
        evaluations: 0,
        best_iterate: false,
        best_iteration: 0,
        times: Default::default(),
    }
}

/// ||v||_2.
pub(super) fn norm2(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
