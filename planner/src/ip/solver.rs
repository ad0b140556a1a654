//! The interior-point iteration loop (paper Sec. III): barrier subproblems solved by
//! Newton steps on the primal-dual system (eq. 6), globalized by a line search on the
//! l2 merit function (eq. 5), with inertia correction and a barrier-update rule.

use crate::elementary::{ln, pow};
use std::time::Instant;

use super::barrier;
use super::info::{IterLog, PhaseTimes, SolveInfo, Status, StepKind};
use super::kkt::backend::{BackendError, Pattern};
use super::kkt::{Inertia, KktBackend, KktError, KktSolver, KktValues};
use super::nlp::Nlp;
use super::residuals::{self, compute_errors, Errors};
use super::settings::{BarrierRule, Globalization, Settings};
use super::vector;
use super::workspace::Workspace;

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

/// Outcome of factorizing with inertia correction.
struct Factorization {
    /// Scalar primal shift in the factorized matrix (for the slack elimination).
    delta_w: f64,
    /// Factorizations spent (at most `Settings::max_refactorizations`).
    count: usize,
    /// The convexified fallback matrix was factorized (see [`Solver::factorize_with`]).
    fallback: bool,
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
        let t0 = Instant::now();
        let mut times = PhaseTimes::default();
        let mut info = SolveInfo {
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
            times,
        };
        self.ws.log.clear();
        self.delta_w_last = 0.0;
        self.phi_current = None;
        let s = self.settings;

        if !self.initialize(nlp, &mut info, &mut times) {
            info.times.total = t0.elapsed().as_secs_f64();
            return info;
        }
        {
            let te = Instant::now();
            let ws = &mut self.ws;
            nlp.eval_grad_f(&ws.w[..ws.n], &mut ws.grad);
            nlp.eval_jac_g(&ws.w[..ws.n], &mut ws.jac);
            times.evaluation += te.elapsed().as_secs_f64();
            let tf = Instant::now();
            self.least_squares_multipliers();
            info.factorizations += 1;
            times.factorization += tf.elapsed().as_secs_f64();
        }
        // The best iterate starts as this solve's own start: a solve that stops before its
        // first scored iterate (non-finite derivatives) must not restore an older point.
        self.save_best();

        let mut mu = match s.barrier {
            BarrierRule::Monotone => s.mu_init,
            // The quality-function rule starts where the monotone rule does and never
            // raises mu (see `direction`).
            BarrierRule::Adaptive => s.mu_init,
            _ => {
                let e = compute_errors(&mut self.ws, 0.0);
                e.mu_avg.max(s.mu_min)
            }
        };
        // IPOPT-style cap on adaptive mu: 1e3 times the initial average complementarity.
        let mu_max = 1e3 * mu.max(s.mu_init);
        let mut nu = s.penalty_init;
        // Adaptive rules run in "free mode" and fall back to the monotone rule when an
        // iterate is not acceptable to the (objective, violation) progress filter
        // (IPOPT's obj-constr-filter safeguard, Nocedal-Waechter-Waltz 2009).
        let mut free_mode = s.barrier != BarrierRule::Monotone;
        self.ws.progress.clear();
        self.ws.filter.clear();
        let theta0 = vector::norm1(&self.ws.c);
        let theta_max = 1e4 * theta0.max(1.0);
        let theta_min = 1e-4 * theta0.max(1.0);
        let mut mu_prev = f64::NAN;
        let mut ls_failures = 0usize;
        let mut force_reg = false;
        let mut best_score = (f64::INFINITY, f64::INFINITY);
        let mut resto: Option<Restoration> = None;
        let mut resto_steps = 0usize;
        let mut tiny_steps = 0usize;
        // Progress watch on ||c||: no 1 % decrease in `STALL_ITERS` iterations while
        // infeasible also hands over to restoration.
        const STALL_ITERS: usize = 30;
        let mut theta_ref = f64::INFINITY;
        let mut f_ref = f64::INFINITY;
        let mut stalled = 0usize;
        // Restoration is for significant violations only; small ones are left to the
        // regularized Newton steps (restoration ignores the objective and would undo it).
        const RESTO_MIN_VIOLATION: f64 = 1e-3;
        let mut iter = 0usize;
        let status;

        loop {
            // Derivatives at the current point (f and g are already known).
            let te = Instant::now();
            let ws = &mut self.ws;
            nlp.eval_grad_f(&ws.w[..ws.n], &mut ws.grad);
            nlp.eval_jac_g(&ws.w[..ws.n], &mut ws.jac);
            times.evaluation += te.elapsed().as_secs_f64();
            if !vector::all_finite(&self.ws.grad) || !vector::all_finite(&self.ws.jac) {
                status = Status::NumericalFailure;
                break;
            }

            let err = compute_errors(&mut self.ws, mu);
            // The log row of this iteration describes this iterate: its errors and objective.
            let f_iter = self.ws.f;
            // Valid until the step is accepted (see `accept`).
            self.ws.grad_lag_fresh = true;
            let score = self.score(&err);
            if score < best_score {
                best_score = score;
                self.save_best();
            }
            info.iterations = iter;
            if self.converged(&err) {
                status = Status::Optimal;
                break;
            }
            if iter >= s.max_iter {
                status = Status::IterationLimit;
                break;
            }
            if t0.elapsed().as_secs_f64() > s.max_time_s {
                status = Status::TimeLimit;
                break;
            }

            // Feasibility restoration: Gauss-Newton steps on 0.5 ||c||^2 with the barrier.
            if let Some(r) = resto.as_mut() {
                let theta = norm2(&self.ws.c);
                if theta <= 0.9 * r.theta_entry || err.inf_pr <= s.constr_viol_tol {
                    resto = None;
                    self.ws.filter.clear();
                    nu = s.penalty_init;
                    ls_failures = 0;
                    force_reg = false;
                } else {
                    let stat = self.infeasibility_measure();
                    // Locally infeasible: a violation well above the acceptable level at a
                    // stationary point of 0.5 ||c||^2 (relative to the violation itself).
                    let significant = err.inf_pr > 10.0 * s.constr_viol_tol;
                    // Converged: stationary to the tolerance, or full Newton steps on the
                    // violation that no longer reduce it at a loosely stationary point
                    // (the projected measure oscillates near active bounds).
                    let stagnant = r.watch(theta) >= RESTO_STAGNATION;
                    let stationary = stat <= s.infeas_stat_tol * err.inf_pr
                        || (stagnant && stat <= 1e-2 * err.inf_pr);
                    if significant && stationary {
                        status = Status::LocallyInfeasible;
                        break;
                    }
                    if resto_steps >= s.max_restoration_steps {
                        status = if significant && stat <= 1e-3 * err.inf_pr {
                            Status::LocallyInfeasible
                        } else {
                            Status::NumericalFailure
                        };
                        break;
                    }
                    r.mu = (0.2 * r.mu).max(s.mu_min);
                    let mu_r = r.mu;
                    resto_steps += 1;
                    let mut teval = 0.0;
                    let tf = Instant::now();
                    let mut nfact = 0;
                    let step = self.restoration_step(
                        nlp,
                        mu_r,
                        &mut nfact,
                        &mut teval,
                        &mut info.evaluations,
                    );
                    times.evaluation += teval;
                    times.factorization += tf.elapsed().as_secs_f64() - teval;
                    info.factorizations += nfact;
                    info.max_factorizations_per_iter = info.max_factorizations_per_iter.max(nfact);
                    let Some((alpha, backtracks)) = step else {
                        status = if significant && stat <= 1e-3 * err.inf_pr {
                            Status::LocallyInfeasible
                        } else {
                            Status::NumericalFailure
                        };
                        break;
                    };
                    // In restoration rows the dual column holds the relative stationarity of
                    // the violation, ||P(A^T c)|| / ||c||_inf, which decides infeasibility.
                    let mut e_log = err;
                    e_log.inf_du = stat / err.inf_pr.max(1e-300);
                    e_log.s_d = 1.0;
                    self.push_log(
                        iter,
                        f_iter,
                        &e_log,
                        mu_r,
                        alpha,
                        0.0,
                        nfact,
                        backtracks,
                        StepKind::Restoration,
                    );
                    iter += 1;
                    continue;
                }
            }
            if ls_failures >= s.max_ls_failures {
                status = Status::NumericalFailure;
                break;
            }

            // Hessian of the Lagrangian at (x, y).
            let te = Instant::now();
            let ws = &mut self.ws;
            nlp.eval_hess(&ws.w[..ws.n], 1.0, &ws.y, &mut ws.hess);
            times.evaluation += te.elapsed().as_secs_f64();
            if !vector::all_finite(&self.ws.hess) {
                status = Status::NumericalFailure;
                break;
            }

            // Monotone rule: decrease mu once the barrier subproblem is solved; an adaptive
            // rule in monotone fallback returns to free mode at that point.
            if !free_mode {
                let mut e = err;
                for _ in 0..8 {
                    if e.overall_mu() > s.barrier_tol_factor * mu || mu <= s.mu_min {
                        break;
                    }
                    if s.barrier != BarrierRule::Monotone {
                        // Back to free mode once the barrier subproblem is solved (IPOPT
                        // returns when the point is acceptable to its filter instead). The
                        // progress filter keeps its entries for the whole solve, like
                        // IPOPT's obj-constr filter: cleared here, it let free mode repeat
                        // a cycle of steps that trade violation for objective (dampmpc on
                        // S02, pure minimum time: 500 iterations, 68 with it kept).
                        free_mode = true;
                        break;
                    }
                    mu = barrier::monotone_next(
                        mu,
                        s.mu_linear_decrease,
                        s.mu_superlinear_power,
                        s.tol,
                        s.mu_min,
                    );
                    // Same point: only the complementarity error depends on mu.
                    e.compl_mu = vector::compl_mu(&self.ws, mu);
                }
            }

            // Factorize with inertia correction.
            let tf = Instant::now();
            let fact = self.factorize(mu, force_reg);
            times.factorization += tf.elapsed().as_secs_f64();
            let fact = match fact {
                Ok(f) => f,
                Err(count) => {
                    info.factorizations += count;
                    info.max_factorizations_per_iter = info.max_factorizations_per_iter.max(count);
                    if err.inf_pr > RESTO_MIN_VIOLATION && resto_steps < s.max_restoration_steps {
                        resto = Some(Restoration::new(norm2(&self.ws.c), mu.min(0.1)));
                        self.push_log(
                            iter,
                            f_iter,
                            &err,
                            mu,
                            0.0,
                            f64::INFINITY,
                            count,
                            0,
                            StepKind::Rejected,
                        );
                        iter += 1;
                        continue;
                    }
                    status = Status::NumericalFailure;
                    break;
                }
            };
            info.factorizations += fact.count;
            info.max_factorizations_per_iter = info.max_factorizations_per_iter.max(fact.count);
            if fact.fallback {
                info.fallback_steps += 1;
            }

            // Direction.
            let ts = Instant::now();
            let rule = if free_mode {
                s.barrier
            } else {
                BarrierRule::Monotone
            };
            let (mu_step, kind) = self.direction(rule, mu, mu_max, fact.delta_w, &err);
            times.solve += ts.elapsed().as_secs_f64();
            mu = mu_step;
            let mu_step_prev = mu;
            if mu != mu_prev {
                // A new barrier problem: its filter starts empty.
                self.ws.filter.clear();
                mu_prev = mu;
            }
            let (theta_cur, f_cur) = (vector::norm1(&self.ws.c), self.ws.f);

            // Line search on the merit function.
            let tl = Instant::now();
            let mut teval = 0.0;
            let outcome = match s.globalization {
                Globalization::Filter => self.filter_line_search(
                    nlp,
                    mu,
                    theta_cur,
                    fact.delta_w,
                    (theta_min, theta_max),
                    &mut teval,
                    &mut info.evaluations,
                ),
                Globalization::Merit => self.line_search(
                    nlp,
                    mu,
                    &mut nu,
                    fact.delta_w,
                    &mut teval,
                    &mut info.evaluations,
                ),
            };
            times.evaluation += teval;
            times.line_search += tl.elapsed().as_secs_f64() - teval;

            let (alpha, backtracks, step_kind) = match outcome {
                Some((alpha, bt, soc)) => {
                    ls_failures = 0;
                    force_reg = false;
                    if free_mode {
                        // Progress safeguard of free mode.
                        let (theta_new, f_new) = (vector::norm1(&self.ws.c), self.ws.f);
                        let gamma = 1e-5;
                        let ok = self.ws.progress.iter().all(|&(th, f)| {
                            theta_new < (1.0 - gamma) * th || f_new < f - gamma * th
                        });
                        if ok {
                            if self.ws.progress.len() < self.ws.progress.capacity() {
                                self.ws.progress.push((theta_cur, f_cur));
                            }
                        } else {
                            free_mode = false;
                            let e = compute_errors(&mut self.ws, mu);
                            mu = (0.8 * e.mu_avg).max(s.mu_min).min(mu_max);
                            if s.barrier == BarrierRule::Adaptive {
                                // The quality-function rule never raises mu (see `direction`).
                                mu = mu.min(mu_step_prev);
                            }
                        }
                    }
                    // Stalling while infeasible: hand over to restoration.
                    tiny_steps = if alpha < 1e-4 { tiny_steps + 1 } else { 0 };
                    let theta = norm2(&self.ws.c);
                    let f_now = self.ws.f;
                    if theta < 0.99 * theta_ref || f_now < f_ref - 1e-6 * f_ref.abs().max(1.0) {
                        theta_ref = theta_ref.min(theta);
                        f_ref = f_ref.min(f_now);
                        stalled = 0;
                    } else {
                        stalled += 1;
                    }
                    let infeasible = err.inf_pr > RESTO_MIN_VIOLATION;
                    if (tiny_steps >= 5 || stalled >= STALL_ITERS)
                        && infeasible
                        && resto_steps < s.max_restoration_steps
                    {
                        tiny_steps = 0;
                        stalled = 0;
                        theta_ref = f64::INFINITY;
                        f_ref = f64::INFINITY;
                        resto = Some(Restoration::new(norm2(&self.ws.c), mu.min(0.1)));
                    }
                    let kind = if fact.fallback {
                        StepKind::Fallback
                    } else if soc {
                        StepKind::SecondOrder
                    } else {
                        kind
                    };
                    (alpha, bt, kind)
                }
                None => {
                    ls_failures += 1;
                    force_reg = true;
                    self.delta_w_last = (self.delta_w_last * 10.0)
                        .max(s.delta_w_init)
                        .min(s.delta_w_max);
                    if err.inf_pr > RESTO_MIN_VIOLATION && resto_steps < s.max_restoration_steps {
                        resto = Some(Restoration::new(norm2(&self.ws.c), mu.min(0.1)));
                    }
                    (0.0, s.max_backtracks, StepKind::Rejected)
                }
            };
            self.push_log(
                iter,
                f_iter,
                &err,
                mu,
                alpha,
                fact.delta_w,
                fact.count,
                backtracks,
                step_kind,
            );
            iter += 1;
        }

        // Final report; fall back to the best iterate when not converged.
        let mut final_status = status;
        // A certificate of infeasibility is the current point, not the best one.
        if !matches!(status, Status::Optimal | Status::LocallyInfeasible) {
            self.restore_best();
            let te = Instant::now();
            self.reevaluate(nlp, &mut info.evaluations);
            times.evaluation += te.elapsed().as_secs_f64();
            let err = compute_errors(&mut self.ws, 0.0);
            if matches!(
                status,
                Status::IterationLimit | Status::TimeLimit | Status::NumericalFailure
            ) && err.overall() <= s.acceptable_tol
                && err.inf_pr <= s.acceptable_constr_viol_tol
                && self.multipliers_finite()
            {
                final_status = Status::Acceptable;
            }
        }
        let err = compute_errors(&mut self.ws, 0.0);
        info.status = final_status;
        info.iterations = iter;
        info.objective = self.ws.f;
        info.max_violation = max_violation(&self.ws);
        info.dual_inf = err.inf_du / err.s_d;
        info.compl = err.compl / err.s_c;
        info.mu = mu;
        times.total = t0.elapsed().as_secs_f64();
        info.times = times;
        info
    }

    /// Sets bounds, the starting point and multipliers; false when the input is unusable.
    fn initialize<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        info: &mut SolveInfo,
        times: &mut PhaseTimes,
    ) -> bool {
        let s = self.settings;
        let ws = &mut self.ws;
        ws.grad_lag_fresh = false;
        let (n, m) = (ws.n, ws.m);
        // Variable bounds into lo/hi[..n]; constraint bounds into g_l/g_u.
        {
            let (lo_x, _) = ws.lo.split_at_mut(n);
            let (hi_x, _) = ws.hi.split_at_mut(n);
            nlp.bounds(lo_x, hi_x, &mut ws.g_l, &mut ws.g_u);
        }
        for i in 0..m {
            let (l, u) = (ws.g_l[i], ws.g_u[i]);
            // An infinite equality bound would make its residual infinite.
            if l.is_nan() || u.is_nan() || l > u || (l == u && !l.is_finite()) {
                info.status = Status::InvalidInput;
                return false;
            }
            ws.is_eq[i] = l == u;
            ws.lo[n + i] = if ws.is_eq[i] { f64::NEG_INFINITY } else { l };
            ws.hi[n + i] = if ws.is_eq[i] { f64::INFINITY } else { u };
        }
        ws.n_compl = 0;
        for j in 0..n + m {
            let (l, u) = (ws.lo[j], ws.hi[j]);
            if l.is_nan() || u.is_nan() || l > u || l == f64::INFINITY || u == f64::NEG_INFINITY {
                info.status = Status::InvalidInput;
                return false;
            }
            ws.lo_orig[j] = l;
            ws.hi_orig[j] = u;
            ws.set_bounds_present(j, l.is_finite(), u.is_finite());
            if ws.has_lo[j] {
                ws.lo[j] = l - s.bound_relax * l.abs().max(1.0);
                ws.n_compl += 1;
            }
            if ws.has_hi[j] {
                ws.hi[j] = u + s.bound_relax * u.abs().max(1.0);
                ws.n_compl += 1;
            }
        }

        // Starting point.
        nlp.initial_point(&mut ws.w[..n]);
        if ws.w[..n].iter().any(|v| !v.is_finite()) {
            info.status = Status::InvalidInput;
            return false;
        }
        let te = Instant::now();
        nlp.eval_g(&ws.w[..n], &mut ws.g);
        times.evaluation += te.elapsed().as_secs_f64();
        info.evaluations += 1;
        info.initial_violation = max_violation(ws);
        for i in 0..m {
            ws.w[n + i] = if ws.is_eq[i] { ws.g_l[i] } else { ws.g[i] };
        }
        // Push into the (relaxed) bounds.
        for j in 0..n + m {
            let (l, u) = (ws.lo[j], ws.hi[j]);
            let v = ws.w[j];
            let range = u - l;
            let v = if ws.has_lo[j] {
                let p = (s.bound_push * l.abs().max(1.0)).min(s.bound_frac * range);
                v.max(l + p)
            } else {
                v
            };
            let v = if ws.has_hi[j] {
                let p = (s.bound_push * u.abs().max(1.0)).min(s.bound_frac * range);
                v.min(u - p)
            } else {
                v
            };
            ws.w[j] = v;
            ws.zl[j] = if ws.has_lo[j] { 1.0 } else { 0.0 };
            ws.zu[j] = if ws.has_hi[j] { 1.0 } else { 0.0 };
        }
        ws.y.iter_mut().for_each(|v| *v = 0.0);
        let te = Instant::now();
        ws.f = nlp.eval_f(&ws.w[..n]);
        nlp.eval_g(&ws.w[..n], &mut ws.g);
        times.evaluation += te.elapsed().as_secs_f64();
        info.evaluations += 1;
        if !ws.f.is_finite() || ws.g.iter().any(|v| !v.is_finite()) {
            info.status = Status::InvalidInput;
            return false;
        }
        info.start_violation = max_violation(ws);
        residuals::constraint_residual(&ws.is_eq, &ws.g_l, n, &ws.g, &ws.w, &mut ws.c);
        true
    }

    fn converged(&self, e: &Errors) -> bool {
        let s = &self.settings;
        e.overall() <= s.tol
            && e.inf_du <= s.dual_inf_tol
            && e.inf_pr <= s.constr_viol_tol
            && e.compl <= s.compl_inf_tol
            && self.multipliers_finite()
    }

    /// Whether y, z_l and z_u are finite: the error measures' max reductions skip NaN, so
    /// a NaN multiplier must not pass for a small error.
    fn multipliers_finite(&self) -> bool {
        let ws = &self.ws;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        finite(&ws.y) && finite(&ws.zl) && finite(&ws.zu)
    }

    /// Ranking of iterates for "best so far": feasibility first, then KKT error.
    fn score(&self, e: &Errors) -> (f64, f64) {
        let feas = if e.inf_pr <= self.settings.acceptable_constr_viol_tol {
            0.0
        } else {
            e.inf_pr
        };
        (feas, e.overall())
    }

    fn save_best(&mut self) {
        let ws = &mut self.ws;
        ws.best_w.copy_from_slice(&ws.w);
        ws.best_y.copy_from_slice(&ws.y);
        ws.best_zl.copy_from_slice(&ws.zl);
        ws.best_zu.copy_from_slice(&ws.zu);
    }

    fn restore_best(&mut self) {
        self.phi_current = None;
        let ws = &mut self.ws;
        ws.grad_lag_fresh = false;
        ws.w.copy_from_slice(&ws.best_w);
        ws.y.copy_from_slice(&ws.best_y);
        ws.zl.copy_from_slice(&ws.best_zl);
        ws.zu.copy_from_slice(&ws.best_zu);
    }

    fn reevaluate<P: Nlp + ?Sized>(&mut self, nlp: &mut P, evals: &mut usize) {
        let ws = &mut self.ws;
        ws.grad_lag_fresh = false;
        let n = ws.n;
        ws.f = nlp.eval_f(&ws.w[..n]);
        nlp.eval_g(&ws.w[..n], &mut ws.g);
        nlp.eval_grad_f(&ws.w[..n], &mut ws.grad);
        nlp.eval_jac_g(&ws.w[..n], &mut ws.jac);
        *evals += 1;
        residuals::constraint_residual(&ws.is_eq, &ws.g_l, n, &ws.g, &ws.w, &mut ws.c);
    }

    /// Projected gradient of 0.5 ||c||^2 over w (inf-norm): zero at a stationary point of
    /// the constraint violation.
    fn infeasibility_measure(&mut self) -> f64 {
        let ws = &mut self.ws;
        let n = ws.n;
        let v = &mut ws.tmp_w;
        v.iter_mut().for_each(|x| *x = 0.0);
        residuals::jac_t_mul(&ws.jac_rows, &ws.jac_cols, &ws.jac, &ws.c, &mut v[..n]);
        for i in 0..ws.m {
            if !ws.is_eq[i] {
                v[n + i] = -ws.c[i];
            }
        }
        let mut r: f64 = 0.0;
        for j in 0..n + ws.m {
            // Projected gradient w - P(w - v): a bound blocks the descent direction -v. The
            // barrier keeps iterates a distance ~mu/z off their bounds, so a bound within
            // `ACTIVE` (relative) counts as reached.
            const ACTIVE: f64 = 1e-5;
            let mut g = v[j];
            if ws.has_lo[j] && g > 0.0 {
                let sl = ws.w[j] - ws.lo[j];
                g = if sl <= ACTIVE * ws.lo[j].abs().max(1.0) {
                    0.0
                } else {
                    g.min(sl)
                };
            }
            if ws.has_hi[j] && g < 0.0 {
                let su = ws.hi[j] - ws.w[j];
                g = if su <= ACTIVE * ws.hi[j].abs().max(1.0) {
                    0.0
                } else {
                    g.max(-su)
                };
            }
            r = r.max(g.abs());
        }
        r
    }

    /// Factorizes the KKT matrix, raising delta_w until the inertia is (n, m, 0).
    fn factorize(&mut self, mu: f64, force_reg: bool) -> Result<Factorization, usize> {
        let delta_c = if self.kkt.wants_dual_regularization() {
            self.settings.delta_c_min
        } else {
            0.0
        };
        self.factorize_with(mu, force_reg, delta_c)
    }

    /// Inertia-corrected factorization with dual regularization at least `delta_c_base`.
    fn factorize_with(
        &mut self,
        mu: f64,
        force_reg: bool,
        delta_c_base: f64,
    ) -> Result<Factorization, usize> {
        let s = self.settings;
        let (n, m) = (self.ws.n, self.ws.m);
        self.compute_sigma();
        let mut delta_c = delta_c_base;
        // IPOPT's Algorithm IC, with two changes that bound the work per iteration: when
        // the previous iteration needed a shift, start from a third of it instead of
        // retrying zero (saves a factorization on degenerate problems), and grow tiny shifts
        // by 100 so the cap on factorizations is not spent creeping up from 1e-12.
        const DELTA_W_FLOOR: f64 = 1e-12;
        let mut delta_w = if force_reg {
            self.delta_w_last.max(s.delta_w_init)
        } else if self.delta_w_last > 0.0 {
            (self.delta_w_last / s.delta_w_decrease).max(DELTA_W_FLOOR)
        } else {
            0.0
        };
        let expected = Inertia {
            positive: n,
            negative: m,
            zero: 0,
        };
        let mut count = 0;
        // Inertia-correcting attempts; the last factorization allowed is the fallback's.
        let attempts = s
            .max_inertia_corrections
            .min(s.max_refactorizations.saturating_sub(1));
        while count < attempts {
            self.fill_diagonals(delta_w, delta_c);
            count += 1;
            let ws = &self.ws;
            let res = self.kkt.factorize_expecting(
                &KktValues {
                    hess: &ws.hess,
                    jac: &ws.jac,
                    primal_diag: &ws.primal_diag,
                    dual_diag: &ws.dual_diag,
                },
                expected,
            );
            match res {
                Ok(inertia) if inertia == expected => {
                    // A shift at the floor is forgotten: the next iteration tries zero again.
                    self.delta_w_last = if delta_w > DELTA_W_FLOOR {
                        delta_w
                    } else {
                        0.0
                    };
                    return Ok(Factorization {
                        delta_w,
                        count,
                        fallback: false,
                    });
                }
                // Wrong inertia, found at the end or (stopped early) on the way.
                Ok(_) | Err(KktError::WrongInertia) => {}
                Err(KktError::Singular) => {
                    delta_c = delta_c.max(1e-8 * pow(mu.max(1e-12), 0.25));
                }
                Err(KktError::NonFinite | KktError::Unsupported) => return Err(count),
            }
            delta_w = if delta_w == 0.0 {
                if self.delta_w_last == 0.0 {
                    s.delta_w_init
                } else {
                    (self.delta_w_last / 3.0).max(DELTA_W_FLOOR)
                }
            } else if self.delta_w_last == 0.0 || delta_w < 1e-6 {
                delta_w * 100.0
            } else {
                delta_w * 8.0
            };
            if delta_w > s.delta_w_max {
                break;
            }
        }
        // The next iteration starts its corrections from the largest shift tried here.
        let delta_w = delta_w.min(s.delta_w_max);
        self.delta_w_last = delta_w;
        self.factorize_fallback(delta_w, delta_c, count)
    }

    /// The bounded answer to bad inertia: factorize the KKT matrix with the Hessian
    /// convexified by a per-variable Gershgorin shift,
    /// `D_j = max(0, sum_{k != j} |H_jk| - H_jj) + delta` (delta: see below),
    /// so that H + D is diagonally dominant with a positive diagonal (hence positive
    /// definite, Gershgorin's circle theorem), and with a dual shift delta_c > 0. The
    /// matrix [[H + Sigma + D, J^T], [J, -D_c]] is then quasi-definite and has inertia
    /// (n, m, 0) whatever H and J are (Vanderbei 1995), so the step needs no inertia check
    /// and no further refactorization: one factorization through the `KktSolver` trait,
    /// any backend. The direction is a descent direction of the barrier merit (positive
    /// definite model), shortened along strongly coupled/negatively curved variables
    /// only; that is what KNITRO's projected-CG trust-region fallback achieves, at the cost
    /// of one factorization instead of a CG loop. Counted as a factorization of the
    /// iteration; returns `Err` only when the backend fails on a non-finite matrix.
    fn factorize_fallback(
        &mut self,
        delta_next: f64,
        delta_c: f64,
        count: usize,
    ) -> Result<Factorization, usize> {
        let s = self.settings;
        let ws = &mut self.ws;
        let n = ws.n;
        // The shift the correction loop would have tried next is kept on top of the
        // Gershgorin shift: it acts as a trust-region radius ~ 1/delta that shrinks as the
        // loop escalated, so the fallback step is no longer than a corrected Newton step
        // would have been (an unshortened fallback step can leave the region where the
        // linearized constraints are accurate).
        let delta = delta_next.max(s.delta_w_init);
        // tmp_w[..n]: diagonal of H; primal_diag[..n]: off-diagonal absolute row sums.
        ws.tmp_w[..n].iter_mut().for_each(|v| *v = 0.0);
        ws.primal_diag.iter_mut().for_each(|v| *v = 0.0);
        for ((&r, &c), &h) in ws.hess_rows.iter().zip(&ws.hess_cols).zip(&ws.hess) {
            if r == c {
                ws.tmp_w[r] += h;
            } else {
                ws.primal_diag[r] += h.abs();
                ws.primal_diag[c] += h.abs();
            }
        }
        for j in 0..n {
            let shift = (ws.primal_diag[j] - ws.tmp_w[j]).max(0.0);
            ws.primal_diag[j] = ws.sigma[j] + shift + delta;
        }
        let delta_c = delta_c.max(s.delta_c_min).max(1e-8);
        for i in 0..ws.m {
            ws.dual_diag[i] = if ws.is_eq[i] {
                -delta_c
            } else {
                -(1.0 / (ws.sigma[n + i] + delta) + delta_c)
            };
        }
        let res = self.kkt.factorize(&KktValues {
            hess: &ws.hess,
            jac: &ws.jac,
            primal_diag: &ws.primal_diag,
            dual_diag: &ws.dual_diag,
        });
        match res {
            // Quasi-definite: the inertia is right by construction; a backend that
            // reports otherwise (rounding) still holds a usable factorization.
            Ok(_) => Ok(Factorization {
                delta_w: delta,
                count: count + 1,
                fallback: true,
            }),
            Err(_) => Err(count + 1),
        }
    }

    /// Least-squares estimate of y (IPOPT's default initialization): minimize
    /// ||grad f + A^T y - z_l + z_u|| by solving [[I, A^T], [A, 0]] [d; y] = [-(grad - z); 0].
    /// Kept only if ||y||_inf <= 1e3; otherwise y stays zero.
    fn least_squares_multipliers(&mut self) {
        const Y_MAX: f64 = 1e3;
        let (n, m) = (self.ws.n, self.ws.m);
        if m == 0 {
            return;
        }
        {
            let ws = &mut self.ws;
            ws.y.iter_mut().for_each(|v| *v = 0.0);
            ws.sigma.iter_mut().for_each(|v| *v = 1.0);
            ws.hess.iter_mut().for_each(|v| *v = 0.0);
            for j in 0..n + m {
                // Targets chosen so that tgt/slack = z: the rhs becomes -(grad - z_l + z_u).
                ws.tgt_l[j] = if ws.has_lo[j] {
                    ws.zl[j] * (ws.w[j] - ws.lo[j])
                } else {
                    0.0
                };
                ws.tgt_u[j] = if ws.has_hi[j] {
                    ws.zu[j] * (ws.hi[j] - ws.w[j])
                } else {
                    0.0
                };
            }
            ws.tmp_m.iter_mut().for_each(|v| *v = 0.0);
        }
        let delta_c = self.settings.delta_c_min.max(1e-8);
        self.fill_diagonals(0.0, delta_c);
        let ws = &self.ws;
        let res = self.kkt.factorize(&KktValues {
            hess: &ws.hess,
            jac: &ws.jac,
            primal_diag: &ws.primal_diag,
            dual_diag: &ws.dual_diag,
        });
        if res.is_err() {
            return;
        }
        self.solve_direction(0.0, true);
        let ws = &mut self.ws;
        let y_max = ws.dy.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if y_max.is_finite() && y_max <= Y_MAX {
            ws.y.copy_from_slice(&ws.dy);
        }
    }

    /// Barrier Hessian Sigma = z_l/(w - l) + z_u/(u - w).
    fn compute_sigma(&mut self) {
        vector::sigma(&mut self.ws);
    }

    #[allow(clippy::too_many_arguments)]
    fn push_log(
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

    /// One feasibility-restoration iteration: a regularized Gauss-Newton step on
    /// 0.5 ||c||^2 - mu_r sum ln(slacks), i.e. the KKT system with H = 0 and D_c = -I,
    /// globalized by an Armijo search. Multipliers y are left alone.
    fn restoration_step<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu_r: f64,
        nfact: &mut usize,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Option<(f64, usize)> {
        let s = self.settings;
        let (n, m) = (self.ws.n, self.ws.m);
        self.ws.grad_lag_fresh = false;
        // Exact Hessian of 0.5 ||c||^2 beyond J^T J: sum_i c_i grad^2 g_i.
        let te = Instant::now();
        {
            let ws = &mut self.ws;
            nlp.eval_hess(&ws.w[..n], 0.0, &ws.c, &mut ws.hess);
        }
        *teval += te.elapsed().as_secs_f64();
        if self.ws.hess.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let theta = norm2(&self.ws.c);
        let delta = match self.factorize_with(mu_r, false, 1.0) {
            Ok(f) => {
                *nfact = f.count;
                f.delta_w
            }
            Err(count) => {
                *nfact = count;
                return None;
            }
        };
        self.set_targets(mu_r, false);
        self.solve_direction_mode(delta, false, true);
        let tau = (1.0 - mu_r).max(s.tau_min);
        let (alpha_max, alpha_z) = self.max_steps(tau);
        // Directional derivative of the restoration merit.
        let (phi0, dd) = {
            let ws = &mut self.ws;
            ws.tmp_m.iter_mut().for_each(|v| *v = 0.0);
            residuals::jac_mul(
                &ws.jac_rows,
                &ws.jac_cols,
                &ws.jac,
                &ws.dw[..n],
                &mut ws.tmp_m,
            );
            let mut dd = 0.0;
            for i in 0..m {
                let ad = if ws.is_eq[i] {
                    ws.tmp_m[i]
                } else {
                    ws.tmp_m[i] - ws.dw[n + i]
                };
                dd += ws.c[i] * ad;
            }
            for j in 0..n + m {
                if ws.has_lo[j] {
                    dd -= mu_r / (ws.w[j] - ws.lo[j]) * ws.dw[j];
                }
                if ws.has_hi[j] {
                    dd += mu_r / (ws.hi[j] - ws.w[j]) * ws.dw[j];
                }
            }
            let phi0 = 0.5 * theta * theta + self.barrier_value(&self.ws.w, 0.0, mu_r);
            (phi0, dd)
        };
        let mut alpha = alpha_max;
        for bt in 0..s.max_backtracks {
            self.set_trial(alpha);
            if let Some((f_t, _, _)) = self.eval_trial(nlp, mu_r, teval, evals) {
                let th = norm2(&self.ws.c_t);
                let phi = 0.5 * th * th + self.barrier_value(&self.ws.w_t, 0.0, mu_r);
                if phi.is_finite() && phi <= phi0 + s.armijo * alpha * dd.min(0.0) {
                    self.accept(f_t, alpha, alpha_z, mu_r, false);
                    return Some((alpha, bt));
                }
            }
            alpha *= 0.5;
            if alpha < 1e-14 {
                break;
            }
        }
        None
    }

    fn fill_diagonals(&mut self, delta_w: f64, delta_c: f64) {
        let ws = &mut self.ws;
        let n = ws.n;
        for j in 0..n {
            ws.primal_diag[j] = ws.sigma[j] + delta_w;
        }
        for i in 0..ws.m {
            ws.dual_diag[i] = if ws.is_eq[i] {
                -delta_c
            } else {
                -(1.0 / (ws.sigma[n + i] + delta_w) + delta_c)
            };
        }
    }

    /// Computes the step (dw, dy, dzl, dzu) for the current rule; returns mu and its kind.
    fn direction(
        &mut self,
        rule: BarrierRule,
        mu: f64,
        mu_max: f64,
        delta_w: f64,
        err: &Errors,
    ) -> (f64, StepKind) {
        let s = self.settings;
        match rule {
            BarrierRule::Monotone => {
                self.set_targets(mu, false);
                self.solve_direction(delta_w, false);
                (mu, StepKind::Newton)
            }
            BarrierRule::Loqo => {
                let mu_new = barrier::loqo(&self.ws, err.mu_avg)
                    .max(s.mu_min)
                    .min(mu_max);
                self.set_targets(mu_new, false);
                self.solve_direction(delta_w, false);
                (mu_new, StepKind::Newton)
            }
            BarrierRule::Adaptive => {
                // Affine (mu = 0) and centred (mu = average complementarity) directions from
                // the same factorization; mu = sigma * mu_avg with sigma from the quality
                // function (Nocedal, Waechter, Waltz 2009).
                let mu_avg = err.mu_avg.max(s.mu_min);
                self.affine_predictor(delta_w, mu_avg);
                self.set_targets(mu_avg, false);
                self.solve_direction(delta_w, false);
                let (rd2, rp2) = barrier::residuals_sq(&mut self.ws);
                let tau = (1.0 - mu).max(s.tau_min);
                let lo = (s.mu_min / mu_avg).clamp(1e-9, 1e-2);
                let hi = (mu_max / mu_avg).clamp(1.0, 10.0);
                let sigma = barrier::quality_sigma(&self.ws, lo, hi, tau, rd2, rp2);
                // Curvature guard: while the Hessian needed a shift (negative curvature,
                // far from a local minimizer) mu is kept, so the barrier, not the
                // regularization, shapes the subproblem; otherwise it never rises.
                let mu_new = if delta_w >= s.delta_w_init {
                    mu
                } else {
                    (sigma * mu_avg).max(self.mu_floor(mu, err)).min(mu)
                };
                self.set_targets(mu_new, false);
                self.solve_direction(delta_w, false);
                (mu_new, StepKind::Newton)
            }
            BarrierRule::Probing => {
                let mu_avg = err.mu_avg.max(s.mu_min);
                let sigma = self.affine_predictor(delta_w, mu_avg);
                let mu_new = (sigma * mu_avg).max(self.mu_floor(mu, err)).min(mu_max);
                self.set_targets(mu_new, false);
                self.solve_direction(delta_w, false);
                (mu_new, StepKind::Newton)
            }
            BarrierRule::Fullmpc | BarrierRule::Dampmpc => {
                let mu_avg = err.mu_avg.max(s.mu_min);
                let sigma = self.affine_predictor(delta_w, mu_avg);
                let mu_new = (sigma * mu_avg).max(self.mu_floor(mu, err)).min(mu_max);
                if rule == BarrierRule::Dampmpc {
                    // Centering step first, then the corrector only if it is not shorter.
                    self.set_targets(mu_new, false);
                    self.solve_direction(delta_w, false);
                    let tau = (1.0 - mu_new).max(s.tau_min);
                    let (cp, cd) = self.max_steps(tau);
                    let center_step = cp.min(cd);
                    self.set_targets(mu_new, true);
                    self.solve_direction(delta_w, false);
                    let (kp, kd) = self.max_steps(tau);
                    if kp.min(kd) >= 0.95 * center_step {
                        (mu_new, StepKind::Corrected)
                    } else {
                        self.set_targets(mu_new, false);
                        self.solve_direction(delta_w, false);
                        (mu_new, StepKind::Newton)
                    }
                } else {
                    self.set_targets(mu_new, true);
                    self.solve_direction(delta_w, false);
                    (mu_new, StepKind::Corrected)
                }
            }
        }
    }

    /// Mehrotra's predictor: solves for the affine-scaling step (mu = 0), keeps it in the
    /// `*_aff` buffers and returns the centering parameter sigma = (mu_aff / mu_avg)^3
    /// (Mehrotra 1992; Nocedal, Waechter, Waltz 2009, eq. 3.4).
    fn affine_predictor(&mut self, delta_w: f64, mu_avg: f64) -> f64 {
        self.set_targets(0.0, false);
        self.solve_direction(delta_w, false);
        let (ap, ad) = self.max_steps(1.0);
        let mu_aff = barrier::complementarity_after(&self.ws, ap, ad);
        let ws = &mut self.ws;
        ws.dw_aff.copy_from_slice(&ws.dw);
        ws.dzl_aff.copy_from_slice(&ws.dzl);
        ws.dzu_aff.copy_from_slice(&ws.dzu);
        (mu_aff / mu_avg).clamp(0.0, 1.0).powi(3)
    }

    /// Safeguards shared by the adaptive rules: mu stays above `mu_floor_factor` times the
    /// (capped) KKT error, so it does not collapse far from feasibility, and falls by at
    /// most the factor `mu_max_decrease` per iteration (damping), so the barrier keeps
    /// regularizing the nonconvex early phase.
    fn mu_floor(&self, mu: f64, err: &Errors) -> f64 {
        let s = &self.settings;
        let kkt = err.inf_pr.max(err.inf_du / err.s_d).min(1.0);
        s.mu_min
            .max(s.mu_floor_factor * kkt)
            .max(s.mu_max_decrease * mu)
    }

    /// Complementarity targets: mu, minus the Mehrotra second-order term when `corrector`.
    fn set_targets(&mut self, mu: f64, corrector: bool) {
        let ws = &mut self.ws;
        for j in 0..ws.n + ws.m {
            ws.tgt_l[j] = if ws.has_lo[j] {
                if corrector {
                    mu - ws.dw_aff[j] * ws.dzl_aff[j]
                } else {
                    mu
                }
            } else {
                0.0
            };
            ws.tgt_u[j] = if ws.has_hi[j] {
                if corrector {
                    mu + ws.dw_aff[j] * ws.dzu_aff[j]
                } else {
                    mu
                }
            } else {
                0.0
            };
        }
    }

    /// Solves for (dw, dy, dzl, dzu) with the current targets; with `soc` the constraint
    /// residual is `tmp_m` (second-order correction) instead of c.
    fn solve_direction(&mut self, delta_w: f64, soc: bool) {
        self.solve_direction_mode(delta_w, soc, false);
    }

    /// As [`Self::solve_direction`]; `feasibility` drops the objective and multiplier terms
    /// (restoration), `soc` uses `tmp_m` as the constraint residual.
    fn solve_direction_mode(&mut self, delta_w: f64, soc: bool, feasibility: bool) {
        let ws = &mut self.ws;
        let (n, m) = (ws.n, ws.m);
        // rhs_w = -(grad + A^T y - tgt_l/sl + tgt_u/su)
        ws.rhs_w.iter_mut().for_each(|v| *v = 0.0);
        if !feasibility {
            if ws.grad_lag_fresh {
                ws.rhs_w[..n].copy_from_slice(&ws.grad_lag);
            } else {
                ws.rhs_w[..n].copy_from_slice(&ws.grad);
                ws.jac_t.t_mul(&ws.jac, &ws.y, &mut ws.rhs_w[..n]);
            }
            for i in 0..m {
                if !ws.is_eq[i] {
                    ws.rhs_w[n + i] = -ws.y[i];
                }
            }
        }
        vector::rhs_bounds(ws);
        let c = if soc { &ws.tmp_m } else { &ws.c };
        ws.sol_x.copy_from_slice(&ws.rhs_w[..n]);
        for i in 0..m {
            ws.sol_y[i] = if ws.is_eq[i] {
                -c[i]
            } else {
                -c[i] + ws.rhs_w[n + i] / (ws.sigma[n + i] + delta_w)
            };
        }
        self.kkt.solve(&mut ws.sol_x, &mut ws.sol_y);
        ws.dw[..n].copy_from_slice(&ws.sol_x);
        ws.dy.copy_from_slice(&ws.sol_y);
        for i in 0..m {
            ws.dw[n + i] = if ws.is_eq[i] {
                0.0
            } else {
                (ws.rhs_w[n + i] + ws.dy[i]) / (ws.sigma[n + i] + delta_w)
            };
        }
        vector::bound_duals(ws);
    }

    /// Largest primal and dual steps keeping a fraction tau of the distance to the bounds.
    fn max_steps(&self, tau: f64) -> (f64, f64) {
        vector::max_steps(&self.ws, tau)
    }

    /// Barrier objective f - mu sum ln(slacks) at primal point `w` with objective `f`.
    fn barrier_value(&self, w: &[f64], f: f64, mu: f64) -> f64 {
        let ws = &self.ws;
        let mut b = LnSum::default();
        for j in 0..ws.n + ws.m {
            if ws.has_lo[j] {
                b.add(w[j] - ws.lo[j]);
            }
            if ws.has_hi[j] {
                b.add(ws.hi[j] - w[j]);
            }
        }
        f - mu * b.value()
    }

    /// Filter line search on (theta = ||c||_1, given for the current point, barrier
    /// objective) with second-order corrections (Waechter & Biegler 2006, Sec. 2.3-2.4).
    /// Returns (alpha, backtracks,
    /// used a second-order correction), or None when alpha fell below alpha_min.
    #[allow(clippy::too_many_arguments)]
    fn filter_line_search<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu: f64,
        theta: f64,
        delta_w: f64,
        (theta_min, theta_max): (f64, f64),
        teval: &mut f64,
        evals: &mut usize,
    ) -> Option<(f64, usize, bool)> {
        const GAMMA_THETA: f64 = 1e-5;
        const GAMMA_PHI: f64 = 1e-8;
        const S_THETA: f64 = 1.1;
        const S_PHI: f64 = 2.3;
        const DELTA: f64 = 1.0;
        const MAX_SOC: usize = 4;
        let s = self.settings;
        let m = self.ws.m;
        let tau = (1.0 - mu).max(s.tau_min);
        let (alpha_max, alpha_z) = self.max_steps(tau);
        let grad_d = self.barrier_grad_dot_dw(mu);
        let phi = match self.phi_current.take() {
            Some((bits, phi)) if bits == mu.to_bits() => phi,
            _ => self.barrier_value(&self.ws.w, self.ws.f, mu),
        };
        let alpha_min = {
            let g = 0.05;
            if grad_d < 0.0 {
                g * GAMMA_THETA
                    .min(GAMMA_PHI * theta / -grad_d)
                    .min(DELTA * pow(theta, S_THETA) / pow(-grad_d, S_PHI))
            } else {
                g * GAMMA_THETA
            }
        };
        let acceptable = |ws: &Workspace, th: f64, ph: f64| -> bool {
            th <= theta_max && ws.filter.iter().all(|&(tf, pf)| th < tf || ph < pf)
        };
        let mut alpha = alpha_max;
        for bt in 0..s.max_backtracks {
            if alpha < alpha_min && bt > 0 {
                break;
            }
            self.set_trial(alpha);
            let Some((f_t, theta_t, phi_t)) = self.eval_trial(nlp, mu, teval, evals) else {
                alpha *= 0.5;
                continue;
            };
            let switching =
                grad_d < 0.0 && alpha * pow(-grad_d, S_PHI) > DELTA * pow(theta, S_THETA);
            let armijo = le(phi_t, phi + 1e-8 * alpha * grad_d, phi);
            let f_type = theta <= theta_min && switching;
            let ok = if f_type {
                armijo
            } else {
                le(theta_t, (1.0 - GAMMA_THETA) * theta, theta)
                    || le(phi_t, phi - GAMMA_PHI * theta, phi)
            };
            if ok && acceptable(&self.ws, theta_t, phi_t) {
                if !(switching && armijo) {
                    self.augment_filter((1.0 - GAMMA_THETA) * theta, phi - GAMMA_PHI * theta);
                }
                self.accept(f_t, alpha, alpha_z, mu, true);
                self.phi_current = Some((mu.to_bits(), phi_t));
                return Some((alpha, bt, false));
            }
            // Second-order corrections on the first trial when the violation grew.
            if bt == 0 && theta_t >= theta && s.second_order_correction {
                {
                    let ws = &mut self.ws;
                    for i in 0..m {
                        ws.tmp_m[i] = alpha * ws.c[i] + ws.c_t[i];
                    }
                }
                let mut theta_soc_prev = theta;
                let mut accepted = false;
                for _ in 0..MAX_SOC {
                    self.solve_direction(delta_w, true);
                    let (ap, az) = self.max_steps(tau);
                    self.set_trial(ap);
                    let Some((f_s, theta_s, phi_s)) = self.eval_trial(nlp, mu, teval, evals) else {
                        break;
                    };
                    let ok = if f_type {
                        le(phi_s, phi + 1e-8 * alpha * grad_d, phi)
                    } else {
                        le(theta_s, (1.0 - GAMMA_THETA) * theta, theta)
                            || le(phi_s, phi - GAMMA_PHI * theta, phi)
                    };
                    if ok && acceptable(&self.ws, theta_s, phi_s) {
                        if !f_type {
                            self.augment_filter(
                                (1.0 - GAMMA_THETA) * theta,
                                phi - GAMMA_PHI * theta,
                            );
                        }
                        self.accept(f_s, ap, az, mu, true);
                        self.phi_current = Some((mu.to_bits(), phi_s));
                        accepted = true;
                        alpha = ap;
                        break;
                    }
                    if theta_s > 0.99 * theta_soc_prev {
                        break;
                    }
                    theta_soc_prev = theta_s;
                    let ws = &mut self.ws;
                    for i in 0..m {
                        ws.tmp_m[i] = ap * ws.tmp_m[i] + ws.c_t[i];
                    }
                }
                if accepted {
                    return Some((alpha, bt, true));
                }
                self.restore_direction(delta_w);
            }
            alpha *= 0.5;
        }
        None
    }

    /// w_t = w + alpha dw.
    fn set_trial(&mut self, alpha: f64) {
        vector::set_trial(&mut self.ws, alpha);
    }

    /// Evaluates f and c at w_t; returns (f, ||c||_1, barrier objective) when finite.
    fn eval_trial<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu: f64,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Option<(f64, f64, f64)> {
        let n = self.ws.n;
        let te = Instant::now();
        let f_t = nlp.eval_f(&self.ws.w_t[..n]);
        {
            let ws = &mut self.ws;
            nlp.eval_g(&ws.w_t[..n], &mut ws.g_t);
        }
        *teval += te.elapsed().as_secs_f64();
        *evals += 1;
        if !f_t.is_finite() || !vector::all_finite(&self.ws.g_t) {
            return None;
        }
        let ws = &mut self.ws;
        residuals::constraint_residual(&ws.is_eq, &ws.g_l, n, &ws.g_t, &ws.w_t, &mut ws.c_t);
        let theta_t = vector::norm1(&self.ws.c_t);
        let phi_t = self.barrier_value(&self.ws.w_t, f_t, mu);
        phi_t.is_finite().then_some((f_t, theta_t, phi_t))
    }

    fn augment_filter(&mut self, theta: f64, phi: f64) {
        let f = &mut self.ws.filter;
        // Drop entries the new one dominates, then add it (capacity permitting).
        f.retain(|&(t, p)| !(t >= theta && p >= phi));
        if f.len() < f.capacity() {
            f.push((theta, phi));
        }
    }

    /// grad(barrier objective) . dw at the current point.
    fn barrier_grad_dot_dw(&self, mu: f64) -> f64 {
        vector::barrier_grad_dot(&self.ws, mu)
    }

    /// Backtracking line search on phi_nu = barrier objective + nu ||c||_2 (paper eq. 5).
    /// Returns (alpha, backtracks, used second-order correction), or None on failure.
    #[allow(clippy::too_many_arguments)]
    fn line_search<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu: f64,
        nu: &mut f64,
        delta_w: f64,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Option<(f64, usize, bool)> {
        let s = self.settings;
        let (n, m) = (self.ws.n, self.ws.m);
        let tau = (1.0 - mu).max(s.tau_min);
        let (alpha_max, alpha_z) = self.max_steps(tau);

        // Model quantities: barrier gradient . d, curvature, linearized residual.
        let (grad_d, curv, theta, theta_lin) = {
            let ws = &mut self.ws;
            let mut gd = 0.0;
            for j in 0..n + m {
                let mut gj = if j < n { ws.grad[j] } else { 0.0 };
                if ws.has_lo[j] {
                    gj -= mu / (ws.w[j] - ws.lo[j]);
                }
                if ws.has_hi[j] {
                    gj += mu / (ws.hi[j] - ws.w[j]);
                }
                gd += gj * ws.dw[j];
            }
            ws.tmp_w.iter_mut().for_each(|v| *v = 0.0);
            residuals::hess_mul(
                &ws.hess_rows,
                &ws.hess_cols,
                &ws.hess,
                &ws.dw[..n],
                &mut ws.tmp_w[..n],
            );
            let mut curv = 0.0;
            for j in 0..n + m {
                curv += ws.dw[j] * (ws.tmp_w[j] + ws.sigma[j] * ws.dw[j]);
            }
            ws.tmp_m.copy_from_slice(&ws.c);
            residuals::jac_mul(
                &ws.jac_rows,
                &ws.jac_cols,
                &ws.jac,
                &ws.dw[..n],
                &mut ws.tmp_m,
            );
            for i in 0..m {
                if !ws.is_eq[i] {
                    ws.tmp_m[i] -= ws.dw[n + i];
                }
            }
            let theta = norm2(&ws.c);
            let theta_lin = norm2(&ws.tmp_m);
            (gd, curv, theta, theta_lin)
        };
        // Penalty update so the step is a descent direction of the merit (Nocedal-Wright 18.36).
        let rho = 0.1;
        let reduction = theta - theta_lin;
        if reduction > 1e-12 * theta.max(1.0) {
            let nu_trial = (grad_d + 0.5 * curv.max(0.0)) / ((1.0 - rho) * reduction);
            if nu_trial > *nu {
                *nu = (nu_trial * 1.1).max(*nu * 1.5).min(1e12);
            }
        }
        let dir_deriv = grad_d - *nu * reduction;
        let phi0 = self.barrier_value(&self.ws.w, self.ws.f, mu) + *nu * theta;

        let mut alpha = alpha_max;
        let mut soc_tried = false;
        for bt in 0..s.max_backtracks {
            self.set_trial(alpha);
            if let Some((f_t, _, _)) = self.eval_trial(nlp, mu, teval, evals) {
                let theta_t = norm2(&self.ws.c_t);
                let phi_t = self.barrier_value(&self.ws.w_t, f_t, mu) + *nu * theta_t;
                if phi_t.is_finite() && phi_t <= phi0 + s.armijo * alpha * dir_deriv.min(0.0) {
                    self.accept(f_t, alpha, alpha_z, mu, true);
                    return Some((alpha, bt, false));
                }
                // Second-order correction on the first rejected full step.
                if s.second_order_correction && bt == 0 && !soc_tried && theta_t >= theta {
                    soc_tried = true;
                    if let Some(a) = self.try_soc(
                        nlp, mu, *nu, phi0, dir_deriv, alpha, delta_w, tau, teval, evals,
                    ) {
                        return Some((a, bt, true));
                    }
                }
            }
            alpha *= 0.5;
            if alpha < 1e-14 {
                break;
            }
        }
        None
    }

    /// Second-order correction: re-solve with c_soc = alpha c(w) + c(w + alpha d).
    #[allow(clippy::too_many_arguments)]
    fn try_soc<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu: f64,
        nu: f64,
        phi0: f64,
        dir_deriv: f64,
        alpha: f64,
        delta_w: f64,
        tau: f64,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Option<f64> {
        let s = self.settings;
        {
            let ws = &mut self.ws;
            for i in 0..ws.m {
                ws.tmp_m[i] = alpha * ws.c[i] + ws.c_t[i];
            }
        }
        self.solve_direction(delta_w, true);
        let (ap, az) = self.max_steps(tau);
        self.set_trial(ap);
        let Some((f_t, _, _)) = self.eval_trial(nlp, mu, teval, evals) else {
            self.restore_direction(delta_w);
            return None;
        };
        let theta_t = norm2(&self.ws.c_t);
        let phi_t = self.barrier_value(&self.ws.w_t, f_t, mu) + nu * theta_t;
        if phi_t.is_finite() && phi_t <= phi0 + s.armijo * ap * dir_deriv.min(0.0) {
            self.accept(f_t, ap, az, mu, true);
            Some(ap)
        } else {
            self.restore_direction(delta_w);
            None
        }
    }

    /// Recomputes the regular direction after a failed correction (same targets).
    fn restore_direction(&mut self, delta_w: f64) {
        self.solve_direction(delta_w, false);
    }

    /// Takes the step: w = w_t (already holding w + alpha dw), y += alpha dy, z += alpha_z dz.
    fn accept(&mut self, f_t: f64, alpha: f64, alpha_z: f64, mu: f64, update_y: bool) {
        self.phi_current = None;
        let ws = &mut self.ws;
        ws.grad_lag_fresh = false;
        let m = ws.m;
        // Swapped, not copied: every trial rewrites w_t, g_t and c_t whole before reading
        // them (`set_trial`, `eval_trial`).
        std::mem::swap(&mut ws.w, &mut ws.w_t);
        ws.f = f_t;
        std::mem::swap(&mut ws.g, &mut ws.g_t);
        std::mem::swap(&mut ws.c, &mut ws.c_t);
        if update_y {
            for i in 0..m {
                ws.y[i] += alpha * ws.dy[i];
            }
        }
        vector::step_bound_duals(ws, alpha_z, mu);
    }
}

/// State of the feasibility restoration phase.
#[derive(Debug, Clone, Copy)]
struct Restoration {
    /// ||c||_2 when restoration started; left once reduced by 10 %.
    theta_entry: f64,
    /// Barrier parameter of the restoration merit.
    mu: f64,
    /// Smallest ||c||_2 seen in this restoration phase.
    theta_best: f64,
    /// Restoration steps since ||c||_2 last fell 1 % below `theta_best`.
    stagnant: usize,
}

impl Restoration {
    fn new(theta_entry: f64, mu: f64) -> Self {
        Self {
            theta_entry,
            mu,
            theta_best: theta_entry,
            stagnant: 0,
        }
    }

    /// Records ||c||_2 of the current point; returns the steps without progress.
    fn watch(&mut self, theta: f64) -> usize {
        if theta < 0.99 * self.theta_best {
            self.theta_best = theta;
            self.stagnant = 0;
        } else {
            self.stagnant += 1;
        }
        self.stagnant
    }
}

/// Restoration steps without a 1 % decrease of the violation after which a (loosely)
/// stationary point of the violation is taken as converged.
const RESTO_STAGNATION: usize = 20;

/// `a <= b` up to rounding in quantities of magnitude `base` (IPOPT's Compare_le).
fn le(a: f64, b: f64, base: f64) -> bool {
    a - b <= 10.0 * f64::EPSILON * base.abs().max(1.0)
}

/// Max violation of the original variable bounds and constraint bounds at w, with the
/// constraint values in `g` (NaN entries are skipped by `max`, infinities kept).
fn max_violation(ws: &Workspace) -> f64 {
    let mut v: f64 = 0.0;
    for j in 0..ws.n {
        v = v.max(ws.lo_orig[j] - ws.w[j]).max(ws.w[j] - ws.hi_orig[j]);
    }
    for i in 0..ws.m {
        v = v.max(ws.g_l[i] - ws.g[i]).max(ws.g[i] - ws.g_u[i]);
    }
    v
}

/// Sum of logarithms as the logarithm of running products: one `ln` per run of factors
/// whose product stays within [1e-100, 1e100] (the barrier term has thousands of slacks,
/// and `ln` was 5 % of a solve). A factor outside that range (or not positive and finite)
/// takes its own `ln`, so a product never overflows or underflows, and a non-positive slack
/// still gives NaN or -inf as `ln` does.
#[derive(Debug, Clone, Copy)]
struct LnSum {
    sum: f64,
    prod: f64,
}

impl Default for LnSum {
    fn default() -> Self {
        Self {
            sum: 0.0,
            prod: 1.0,
        }
    }
}

impl LnSum {
    const LO: f64 = 1e-100;
    const HI: f64 = 1e100;

    #[inline(always)]
    fn add(&mut self, d: f64) {
        if d > Self::LO && d < Self::HI {
            self.prod *= d;
            if !(self.prod > Self::LO && self.prod < Self::HI) {
                self.sum += ln(self.prod);
                self.prod = 1.0;
            }
        } else {
            self.sum += ln(d);
        }
    }

    fn value(self) -> f64 {
        self.sum + ln(self.prod)
    }
}

fn norm2(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::LnSum;

    fn ln_sum(v: &[f64]) -> f64 {
        let mut b = LnSum::default();
        v.iter().for_each(|&d| b.add(d));
        b.value()
    }

    #[test]
    fn ln_sum_matches_the_sum_of_logs_over_wide_ranges() {
        // Deterministic factors spanning 1e-300 .. 1e300, runs of tiny and huge ones.
        let mut v = Vec::new();
        let mut x = 0.123_f64;
        for i in 0..5000 {
            x = (x * 3.7 + 0.31).fract();
            let e = match i % 7 {
                0 => -300.0 * x,
                1 => 300.0 * x,
                2 | 3 => -12.0 * x,
                _ => 6.0 * x - 3.0,
            };
            v.push(10f64.powf(e) * (1.0 + x));
        }
        let naive: f64 = v.iter().map(|d| d.ln()).sum();
        let abs: f64 = v.iter().map(|d| d.ln().abs()).sum();
        let got = ln_sum(&v);
        assert!((got - naive).abs() <= 1e-13 * abs, "{got} vs {naive}");
    }

    #[test]
    fn ln_sum_keeps_the_sign_of_bad_slacks() {
        assert_eq!(ln_sum(&[2.0, 0.0, 3.0]), f64::NEG_INFINITY);
        assert!(ln_sum(&[2.0, -1.0]).is_nan());
        assert!(ln_sum(&[f64::NAN, 1.0]).is_nan());
        assert_eq!(ln_sum(&[f64::INFINITY, 1.0]), f64::INFINITY);
        assert_eq!(ln_sum(&[]), 0.0);
    }
}
