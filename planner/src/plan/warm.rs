//! Warm-started replanning: the previous plan shifted in s, primal and dual, as the
//! starting point of the next solve, with a fall-back to the equilibrium start inside the
//! same budget.
//!
//! A replanning cycle moves the window by `shift` metres. The primal guess is the previous
//! plan's states interpolated at s + shift (t rebased to the new origin, the part past the
//! old horizon extended at the last node's pace, x_0 the measured state), its controls
//! taken from the interval s + shift falls in. The multipliers move by shift / ds = j + f
//! nodes: the multiplier of a row of kind K at node k (and the bound multipliers of
//! variable o of node k) is (1 - f) times the previous one of kind K at node min(k + j,
//! last) plus f times the one at min(k + j + 1, last), the weights of the primal guess's
//! interpolation; the initial-condition rows keep theirs. The solve then starts from
//! these multipliers with a barrier parameter matched to the shifted point's
//! complementarity (`ip::solver::warm`).
//!
//! A warm solve that does not succeed within `WarmOptions::max_iter` iterations stalls:
//! the cycle then solves from the equilibrium guess with what is left of the iteration
//! cap and of the time budget, so the two solves together keep the caps of one. A warm
//! solve stopped by the time budget returns its best iterate instead: nothing is left
//! for a second solve.

use super::{PlanError, Planner, ReplanGuess};
use crate::guess::GuessKind;
use crate::ip::{MuMatch, SolveInfo, WarmStart};
use crate::model::{ix, NU, NX};
use crate::ocp::layout::VarKind;
use crate::ocp::transcription::RowKind;

/// How a warm-started replan runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarmOptions {
    /// Iterations the warm solve may take before it counts as stalled (capped by the
    /// solver's `max_iter`; the default leaves the solver's cap, so only a warm solve that
    /// fails falls back).
    pub max_iter: usize,
    /// Lower clip of the matched barrier parameter.
    pub mu_floor: f64,
    /// How the warm solve's first barrier parameter is matched to its start.
    pub mu_match: MuMatch,
    /// The cold start the replan falls back to (equilibrium or road speed; the zero
    /// guess falls back to the equilibrium).
    pub cold: GuessKind,
}

impl Default for WarmOptions {
    fn default() -> Self {
        Self {
            max_iter: usize::MAX,
            mu_floor: 1e-6,
            mu_match: MuMatch::DEFAULT,
            cold: GuessKind::Equilibrium,
        }
    }
}

impl WarmOptions {
    /// These options with the warm cap lowered to `cap`, for a cycle after one whose solve
    /// did not succeed (its warm start shifts a plan a cycle older); `None` when `cap`
    /// lowers nothing.
    pub fn capped_after_failure(self, cap: usize) -> Option<Self> {
        (cap < self.max_iter).then_some(Self {
            max_iter: cap,
            ..self
        })
    }
}

/// What a warm-started replan did.
#[derive(Debug, Clone, PartialEq)]
pub struct WarmReplan {
    /// The solve whose plan is returned (the fall-back's when there was one).
    pub info: SolveInfo,
    /// Iterations of the warm solve.
    pub warm_iterations: usize,
    /// The warm solve stalled and the plan comes from the equilibrium start.
    pub fell_back: bool,
}

impl WarmReplan {
    /// Iterations of both solves together.
    pub fn total_iterations(&self) -> usize {
        if self.fell_back {
            self.warm_iterations + self.info.iterations
        } else {
            self.info.iterations
        }
    }
}

/// A plan as slices: N + 1 states and N controls.
pub type PlanSlices<'a> = (&'a [[f64; NX]], &'a [[f64; NU]]);

/// Multipliers a warm-started solve starts from: equality rows `y` (m), lower and upper
/// bound multipliers `zl`, `zu` (n + m: variables, then rows), as the solver's
/// [`WarmStart`] takes them.
#[derive(Debug, Clone, Copy)]
pub struct WarmDuals<'a> {
    /// Row multipliers.
    pub y: &'a [f64],
    /// Lower-bound multipliers.
    pub zl: &'a [f64],
    /// Upper-bound multipliers.
    pub zu: &'a [f64],
}

/// The lengths of a primal guess: N + 1 states, N controls.
fn check_guess<const N: usize>(xs: &[[f64; NX]], us: &[[f64; NU]]) -> Result<(), PlanError> {
    if xs.len() != N + 1 {
        return Err(PlanError::ReplanLength {
            field: "states",
            expected: N + 1,
            got: xs.len(),
        });
    }
    if us.len() != N {
        return Err(PlanError::ReplanLength {
            field: "controls",
            expected: N,
            got: us.len(),
        });
    }
    Ok(())
}

/// The buffers of the shifted multipliers and of the warm start's source, allocated once
/// with the planner.
#[derive(Debug)]
pub(super) struct WarmBuffers {
    y: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    /// First row of each node's rows (N + 1 entries: node k's rows are
    /// `row_start[k]..row_start[k + 1]`).
    row_start: Vec<usize>,
    /// The last successful solve, source of the next warm start: its states, controls and
    /// multipliers (`kept` false until a solve succeeded). A failed solve leaves it as it
    /// is, so a cycle after a failure still starts from the last good plan.
    src_x: Vec<[f64; NX]>,
    src_u: Vec<[f64; NU]>,
    src_y: Vec<f64>,
    src_zl: Vec<f64>,
    src_zu: Vec<f64>,
    kept: bool,
}

impl WarmBuffers {
    /// Buffers for N intervals, n variables and the rows `rows` (kind and node of each).
    pub(super) fn new(n_intervals: usize, n: usize, rows: &[(RowKind, usize)]) -> Self {
        let m = rows.len();
        let mut row_start = vec![m; n_intervals + 1];
        for (i, &(_, node)) in rows.iter().enumerate().rev() {
            if node < n_intervals {
                row_start[node] = i;
            }
        }
        for k in (0..n_intervals).rev() {
            row_start[k] = row_start[k].min(row_start[k + 1]);
        }
        Self {
            y: vec![0.0; m],
            zl: vec![0.0; n + m],
            zu: vec![0.0; n + m],
            row_start,
            src_x: vec![[0.0; NX]; n_intervals + 1],
            src_u: vec![[0.0; NU]; n_intervals],
            src_y: vec![0.0; m],
            src_zl: vec![0.0; n + m],
            src_zu: vec![0.0; n + m],
            kept: false,
        }
    }
}

/// The state of a plan (`xs`, grid `ds`) at local arc length `s`, linear between nodes,
/// clamped to the horizon.
pub fn interp(xs: &[[f64; NX]], ds: f64, s: f64) -> [f64; NX] {
    let n = xs.len() - 1;
    let q = (s / ds).clamp(0.0, n as f64);
    let k = (q.floor() as usize).min(n - 1);
    let w = q - k as f64;
    let mut x = [0.0; NX];
    for i in 0..NX {
        x[i] = xs[k][i] + w * (xs[k + 1][i] - xs[k][i]);
    }
    x
}

/// The plan (`xs`, `us`, grid `ds`) shifted forward by `shift` metres into `out_x`,
/// `out_u`, with x_0 = `x0` (see the module documentation). Allocates nothing.
pub fn shift_plan(
    xs: &[[f64; NX]],
    us: &[[f64; NU]],
    ds: f64,
    shift: f64,
    x0: &[f64; NX],
    out_x: &mut [[f64; NX]],
    out_u: &mut [[f64; NU]],
) {
    let n = us.len();
    let horizon = n as f64 * ds;
    let t_shift = interp(xs, ds, shift)[ix::T];
    for (k, out) in out_x.iter_mut().enumerate() {
        let s = k as f64 * ds;
        let mut x = interp(xs, ds, s + shift);
        x[ix::S] = s;
        x[ix::T] = if s + shift <= horizon {
            x[ix::T] - t_shift
        } else {
            let last = &xs[n];
            last[ix::T] - t_shift + (s + shift - horizon) / last[ix::V].max(1.0)
        };
        *out = x;
    }
    out_x[0] = *x0;
    for (k, out) in out_u.iter_mut().enumerate() {
        let j = (((k as f64 * ds + shift) / ds).floor() as usize).min(n - 1);
        *out = us[j];
    }
}

impl<const N: usize> Planner<N> {
    /// Keeps the solution just computed as the warm start's source when `info` says the
    /// solve succeeded (copies into preallocated buffers).
    pub(super) fn keep_if_success(&mut self, info: &SolveInfo) {
        if !info.status.is_success() {
            return;
        }
        let ws = self.solver.workspace();
        let w = &mut self.warm;
        w.src_x.copy_from_slice(&self.xs);
        w.src_u.copy_from_slice(&self.us);
        w.src_y.copy_from_slice(&ws.y);
        w.src_zl.copy_from_slice(&ws.zl);
        w.src_zu.copy_from_slice(&ws.zu);
        w.kept = true;
    }

    /// The last successful solve's states and controls, the source of the next warm start
    /// (`None` before any solve succeeded). A failed solve leaves it as it is.
    pub fn warm_source(&self) -> Option<PlanSlices<'_>> {
        let w = &self.warm;
        w.kept.then_some((w.src_x.as_slice(), w.src_u.as_slice()))
    }

    /// Replans from the primal guess (`xs`: N + 1 states, `us`: N controls; typically the
    /// last successful solution, [`Self::warm_source`], shifted by [`shift_plan`]) with
    /// that solve's multipliers moved forward by `shift` metres (see the module
    /// documentation; before any success, the last solve's). Falls back to the equilibrium start when the warm
    /// solve stalls. The solution is then in [`Self::states`] and [`Self::controls`]; the
    /// multipliers it started from in [`Self::warm_duals`]. Allocates nothing.
    #[allow(clippy::too_many_arguments)]
    pub fn replan_warm(
        &mut self,
        kappa: &[f64],
        e_min: &[f64],
        e_max: &[f64],
        x0: [f64; NX],
        (xs, us): (&[[f64; NX]], &[[f64; NU]]),
        shift: f64,
        opts: WarmOptions,
    ) -> Result<WarmReplan, PlanError> {
        check_guess::<N>(xs, us)?;
        let t0 = std::time::Instant::now();
        let ds = self.nlp.spec().ds();
        self.set_window(kappa, e_min, e_max, x0)?;
        self.shift_duals(shift, ds);
        self.warm_solve(t0, (xs, us), opts, |p| {
            p.replan(kappa, e_min, e_max, x0, ReplanGuess::cold(opts.cold))
        })
    }

    /// The multipliers the last warm-started solve started from (after
    /// [`Self::replan_warm`]: the previous solve's, shifted).
    pub fn warm_duals(&self) -> WarmDuals<'_> {
        WarmDuals {
            y: &self.warm.y,
            zl: &self.warm.zl,
            zu: &self.warm.zu,
        }
    }

    /// Solves this planner's problem as [`Self::replan_warm`] solved it, from a recorded
    /// primal guess and recorded multipliers (what [`Self::warm_duals`] gave): same
    /// options, same bits. Falls back to the cold start of `opts` when the warm solve
    /// stalls. Allocates nothing.
    pub fn solve_warm_from(
        &mut self,
        (xs, us): (&[[f64; NX]], &[[f64; NU]]),
        duals: WarmDuals<'_>,
        opts: WarmOptions,
    ) -> Result<WarmReplan, PlanError> {
        check_guess::<N>(xs, us)?;
        let w = &mut self.warm;
        for (field, from, to) in [
            ("y", duals.y, &mut w.y),
            ("zl", duals.zl, &mut w.zl),
            ("zu", duals.zu, &mut w.zu),
        ] {
            if from.len() != to.len() {
                return Err(PlanError::ReplanLength {
                    field,
                    expected: to.len(),
                    got: from.len(),
                });
            }
            to.copy_from_slice(from);
        }
        let t0 = std::time::Instant::now();
        self.warm_solve(t0, (xs, us), opts, |p| Ok(p.solve(opts.cold.cold_start())))
    }

    /// The warm solve from `(xs, us)` and the multipliers in the warm buffers under the
    /// warm iteration cap; when it does not succeed, `cold` solves with what is left of the
    /// iteration cap and of the time budget counted from `t0`.
    fn warm_solve(
        &mut self,
        t0: std::time::Instant,
        (xs, us): (&[[f64; NX]], &[[f64; NU]]),
        opts: WarmOptions,
        cold: impl FnOnce(&mut Self) -> Result<SolveInfo, PlanError>,
    ) -> Result<WarmReplan, PlanError> {
        let base = *self.solver.settings();
        self.nlp.set_initial_guess(xs, us);
        let capped = crate::ip::Settings {
            max_iter: opts.max_iter.min(base.max_iter),
            ..base
        };
        self.solver.set_settings(capped).ok();
        let start = WarmStart {
            y: &self.warm.y,
            zl: &self.warm.zl,
            zu: &self.warm.zu,
            mu_floor: opts.mu_floor,
            mu_match: opts.mu_match,
        };
        let info = self.solver.solve_warm(&mut self.nlp, &start);
        self.solver.set_settings(base).ok();
        self.nlp
            .trajectory_into(self.solver.x(), &mut self.xs, &mut self.us);
        self.keep_if_success(&info);
        // A warm solve the clock stopped leaves no time for another: its best iterate is
        // the answer (a fall-back would return its own guess, after no iteration).
        if info.status.is_success() || info.status == crate::ip::Status::TimeLimit {
            return Ok(WarmReplan {
                warm_iterations: info.iterations,
                info,
                fell_back: false,
            });
        }
        let warm_iterations = info.iterations;
        let rest = crate::ip::Settings {
            max_iter: base.max_iter.saturating_sub(warm_iterations).max(1),
            max_time_s: (base.max_time_s - t0.elapsed().as_secs_f64()).max(1e-9),
            ..base
        };
        self.solver.set_settings(rest).ok();
        let cold = cold(self);
        self.solver.set_settings(base).ok();
        Ok(WarmReplan {
            info: cold?,
            warm_iterations,
            fell_back: true,
        })
    }

    /// The last successful solve's multipliers (before any success, the last solve's)
    /// moved forward by `shift` / `ds` nodes, blended between the whole-node shifts around
    /// it, into the warm buffers.
    fn shift_duals(&mut self, shift: f64, ds: f64) {
        let q = (shift / ds).max(0.0);
        let j = q.floor() as usize;
        // The primal guess is interpolated at the exact shift; the multipliers blend the
        // two whole-node shifts around it with the same weight.
        let f = q - j as f64;
        let ws = self.solver.workspace();
        let lay = self.nlp.layout();
        let (n, m) = (ws.n, ws.m);
        let w = &mut self.warm;
        let (y, zl, zu) = if w.kept {
            (&w.src_y[..], &w.src_zl[..], &w.src_zu[..])
        } else {
            (&ws.y[..], &ws.zl[..], &ws.zu[..])
        };
        let mix = |v: &[f64], a: usize, b: usize| (1.0 - f) * v[a] + f * v[b];
        for idx in 0..n {
            let (k, kind) = lay.describe(idx);
            let src = |j: usize| match kind {
                VarKind::State(i) => lay.x((k + j).min(N), i),
                VarKind::Control(i) => lay.u((k + j).min(N - 1), i),
                VarKind::Stage(i) => lay.w((k + j).min(N - 1), i),
            };
            let (a, b) = (src(j), src(j + 1));
            w.zl[idx] = mix(zl, a, b);
            w.zu[idx] = mix(zu, a, b);
        }
        for i in 0..m {
            let info = self.nlp.describe_row(i);
            let src = |j: usize| match info.kind {
                // The initial rows, and the last node's saturation rows (node N: the shifted
                // plan holds x_N), keep their own multipliers.
                RowKind::Initial { .. } => i,
                RowKind::Saturation { .. } if info.node == N => i,
                kind => {
                    let node = (info.node + j).min(N - 1);
                    (w.row_start[node]..w.row_start[node + 1])
                        .find(|&r| self.nlp.describe_row(r).kind == kind)
                        .unwrap_or(i)
                }
            };
            let (a, b) = (src(j), src(j + 1));
            w.y[i] = mix(y, a, b);
            w.zl[n + i] = mix(zl, n + a, n + b);
            w.zu[n + i] = mix(zu, n + a, n + b);
        }
    }
}
