//! `replay run`: re-solve every recorded input on a pinned core; determinism, latency,
//! jitter, iterations, time per phase and deadline misses.

use std::collections::HashMap;
use std::time::Instant;

use crate::plan_log::{self, PlanLog};
use plan_record::{first_difference, PlanOutput, PlanWarmStart, Recording};
use planner::guess::GuessKind;
use planner::plan::choice::PlanKind;
use planner::plan::{shift_plan, Planner, WarmDuals, WarmOptions};
use planner::record::{plan_output, problem_from, warm_from, RecordedStart};
use serde::Serialize;

use crate::budget::{
    comparable, hit_cap, recorded_stopped_by_clock, stopped_by_clock, Budgets, SentCounts,
    SentPlans,
};
use crate::info::Recovered;
use crate::stats::{latency, Latency, StatsError};
use crate::validate::{orphan_line, validate};
use crate::N;
use planner::model::{NU, NX};

/// How to replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunOptions {
    /// Deadline per solve \[ms\] (10 Hz: 100 ms); the time budget when one is applied.
    pub budget_ms: f64,
    /// Budgets applied to every solve (none: the recorded settings).
    pub budgets: Budgets,
    /// Core to pin the solver thread to; None: the last core.
    pub core: Option<usize>,
    /// Initial guess of every solve (None: the recorded one). A solve from another guess
    /// is compared with nothing.
    pub guess: Option<GuessKind>,
    /// The input whose solve is logged iteration by iteration ([`RunReport::plan_log`]).
    pub log_plan: Option<u64>,
    /// Re-derive each warm start's primal guess from the recorded plan it shifts (the
    /// latest `optimal` or `acceptable` output before it), with this build's
    /// [`shift_plan`]. A guess that comes out other than the recorded one is compared with
    /// nothing.
    pub reshift: bool,
    /// Iterations each warm-started solve may take before it falls back to its cold start
    /// (None: the recorded cap). A cap other than the recorded one is compared with
    /// nothing.
    pub warm_max_iter: Option<usize>,
    /// Iterations a warm-started solve may take after a replayed solve that did not
    /// succeed (None: no such cap), as the planner's `--warm-max-iter-after-failure`. A
    /// plan it changes the cap of is compared with nothing.
    pub warm_max_iter_after_failure: Option<usize>,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            budget_ms: 100.0,
            budgets: Budgets::default(),
            core: None,
            guess: None,
            log_plan: None,
            reshift: false,
            warm_max_iter: None,
            warm_max_iter_after_failure: None,
        }
    }
}

/// Why a replay could not run.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The recording has no planner inputs.
    #[error("the recording has no planner inputs (/planner/input messages)")]
    NoInputs,
    /// An input does not describe a valid problem.
    #[error(transparent)]
    Input(#[from] planner::record::RecordError),
    /// The input's horizon is not the compiled N.
    #[error("recorded input {seq}: n_intervals = {n}, this build replays N = {N}")]
    Horizon {
        /// Input seq.
        seq: u64,
        /// Its N.
        n: usize,
    },
    /// The planner could not be built for an input.
    #[error("recorded input {seq}: {source}")]
    Plan {
        /// Input seq.
        seq: u64,
        /// Why.
        source: planner::plan::PlanError,
    },
    /// The requested core does not exist.
    #[error("core {core} does not exist (this machine has {available})")]
    Core {
        /// Requested core.
        core: usize,
        /// How many there are.
        available: usize,
    },
    /// The budget is not a positive number.
    #[error("--budget-ms must be a positive number, got {0}")]
    Budget(f64),
    /// Two recorded outputs (or inputs) share a seq: which one a replay is compared with
    /// would be arbitrary.
    #[error("the recording holds two planner {what} with seq {seq}")]
    DuplicateSeq {
        /// "inputs" or "outputs".
        what: &'static str,
        /// The seq.
        seq: u64,
    },
    /// A warm-started input has no recorded warm start.
    #[error(
        "recorded input {seq} was warm-started, but the recording holds no warm start \
         (/planner/warm_start message) with that seq"
    )]
    MissingWarmStart {
        /// Input seq.
        seq: u64,
    },
    /// `--log-plan` names no recorded input.
    #[error("--log-plan {0}: the recording holds no planner input with that seq")]
    NoSuchPlan(u64),
    /// The iteration budget is out of range.
    #[error("--max-iter must lie in 1..=100000, got {0}")]
    MaxIter(usize),
    /// A warm iteration cap is out of range.
    #[error("--warm-max-iter and --warm-max-iter-after-failure must lie in 1..=100000, got {0}")]
    WarmMaxIter(usize),
    /// The solver thread failed.
    #[error("replay thread: {0}")]
    Thread(String),
    /// Statistics failed.
    #[error(transparent)]
    Stats(#[from] StatsError),
}

/// One replayed plan.
#[derive(Debug, Clone, Serialize)]
pub struct PlanResult {
    /// Input seq.
    pub seq: u64,
    /// Scenario name.
    pub scenario: String,
    /// Wall-clock latency of the replayed solve \[ms\].
    pub latency_ms: f64,
    /// Total solve time when it was recorded \[ms\] (None: no output recorded).
    pub recorded_ms: Option<f64>,
    /// Status of the replayed solve.
    pub status: String,
    /// Iterations of the replayed solve.
    pub iterations: u32,
    /// Evaluation, factorization, solve, line-search time \[ms\].
    pub phases_ms: [f64; 4],
    /// Bit-identical to the recorded output (None: no output recorded, or stopped by the
    /// clock).
    pub identical: Option<bool>,
    /// The recorded or the replayed solve was stopped by its wall-clock budget: compared
    /// with nothing (where a clock stops a solve is not reproducible).
    pub clock_limited: bool,
    /// The first difference when not identical.
    pub difference: Option<String>,
    /// Latency above the budget.
    pub missed: bool,
    /// Max constraint violation of the replayed solve's returned point.
    pub max_violation: f64,
    /// The solve ended at its iteration or time cap.
    pub hit_budget: bool,
    /// What the planner would have sent the car (None: nothing).
    pub sent: Option<PlanKind>,
}

/// Mean and max of one solver phase \[ms\].
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Phase {
    /// Phase name.
    pub name: &'static str,
    /// Mean per solve.
    pub mean_ms: f64,
    /// Max per solve.
    pub max_ms: f64,
    /// Share of the summed phase times.
    pub share: f64,
}

/// The replay report.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    /// Plans replayed.
    pub plans: usize,
    /// Core the solver thread was pinned to (None: pinning failed).
    pub pinned_core: Option<usize>,
    /// Deadline \[ms\]: the time budget when `budget_applied`.
    pub budget_ms: f64,
    /// Every solve ran with `budget_ms` as its time budget (`--budget-ms`).
    pub budget_applied: bool,
    /// Iteration budget of every solve (`--max-iter`; None: the recorded one).
    pub max_iter: Option<usize>,
    /// Solves that ended at their iteration or time cap.
    pub hit_budget: usize,
    /// What the car would have been sent, by kind (the planner's decision rule).
    #[serde(flatten)]
    pub sent: SentCounts,
    /// What the car would have been sent for each plan, in order (`null`: nothing), when
    /// a budget is applied.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sent_kinds: Option<Vec<Option<&'static str>>>,
    /// Solves over the deadline.
    pub deadline_misses: usize,
    /// Outputs bit-identical to the recorded ones.
    pub identical: usize,
    /// Outputs that differ.
    pub different: usize,
    /// Inputs without a comparable recorded output (other than those stopped by the clock).
    pub unverified: usize,
    /// Plans stopped by the wall-clock budget when recorded or replayed: not comparable
    /// bit for bit (`replay run --max-iter` replays budgets deterministically).
    pub clock_limited: usize,
    /// Seqs of recorded outputs that match no input (nothing replays them).
    pub orphan_outputs: Vec<u64>,
    /// True when every output was recorded and is bit-identical (apart from the solves a
    /// clock stopped, which no replay can reproduce), and every recorded output belongs to
    /// an input.
    pub deterministic: bool,
    /// Replayed latency.
    pub latency: Latency,
    /// Latency when recorded (solver's total time), if outputs were recorded.
    pub recorded_latency: Option<Latency>,
    /// Iterations: min, median, max.
    pub iterations: [u32; 3],
    /// Statuses and their counts.
    pub statuses: Vec<(String, usize)>,
    /// Time per phase.
    pub phases: Vec<Phase>,
    /// Every plan.
    pub per_plan: Vec<PlanResult>,
    /// What was recovered of a file that was not closed cleanly (None: closed cleanly).
    pub recovered: Option<Recovered>,
    /// The logged solve (`RunOptions::log_plan`).
    pub plan_log: Option<PlanLog>,
}

/// Replays every input of a recording on a pinned solver thread.
pub fn run(rec: &Recording, opts: RunOptions) -> Result<RunReport, ReplayError> {
    if !(opts.budget_ms > 0.0 && opts.budget_ms.is_finite()) {
        return Err(ReplayError::Budget(opts.budget_ms));
    }
    if let Some(ms) = opts
        .budgets
        .budget_ms
        .filter(|ms| !(*ms > 0.0 && *ms <= 3.6e6))
    {
        return Err(ReplayError::Budget(ms));
    }
    if let Some(k) = opts.budgets.max_iter.filter(|k| !(1..=100_000).contains(k)) {
        return Err(ReplayError::MaxIter(k));
    }
    for k in [opts.warm_max_iter, opts.warm_max_iter_after_failure] {
        if let Some(k) = k.filter(|k| !(1..=100_000).contains(k)) {
            return Err(ReplayError::WarmMaxIter(k));
        }
    }
    if rec.inputs.is_empty() {
        return Err(ReplayError::NoInputs);
    }
    if let Some(seq) = opts
        .log_plan
        .filter(|seq| !rec.inputs.iter().any(|i| i.seq == *seq))
    {
        return Err(ReplayError::NoSuchPlan(seq));
    }
    let cores = core_affinity::get_core_ids().unwrap_or_default();
    let core = match opts.core {
        Some(c) if c >= cores.len() => {
            return Err(ReplayError::Core {
                core: c,
                available: cores.len(),
            })
        }
        Some(c) => cores.get(c).copied(),
        None => cores.last().copied(),
    };
    // Every input is checked before the first solve: a bad file is refused as a whole.
    let validated = validate(rec)?;
    let outputs: HashMap<u64, &PlanOutput> = rec.outputs.iter().map(|o| (o.seq, o)).collect();
    let per_plan = std::thread::scope(|s| {
        s.spawn(|| {
            let pinned = core
                .filter(|c| core_affinity::set_for_current(*c))
                .map(|c| c.id);
            replay_all(rec, &outputs, opts).map(|r| (pinned, r))
        })
        .join()
        .map_err(|_| ReplayError::Thread("solver thread panicked".into()))
    })??;
    let (pinned_core, (per_plan, plan_log)) = per_plan;
    let mut report = report(per_plan, pinned_core, opts.budget_ms)?;
    report.plan_log = plan_log;
    report.budget_applied = opts.budgets.budget_ms.is_some();
    report.max_iter = opts.budgets.max_iter;
    report.sent_kinds = opts.budgets.any().then(|| {
        report
            .per_plan
            .iter()
            .map(|p| p.sent.map(PlanKind::name))
            .collect()
    });
    report.recovered = rec.recovery.as_ref().map(Recovered::from);
    report.deterministic &= validated.orphan_outputs.is_empty();
    report.orphan_outputs = validated.orphan_outputs;
    Ok(report)
}

fn replay_all(
    rec: &Recording,
    outputs: &HashMap<u64, &PlanOutput>,
    opts: RunOptions,
) -> Result<(Vec<PlanResult>, Option<PlanLog>), ReplayError> {
    let mut results = Vec::with_capacity(rec.inputs.len());
    let mut plan_log = None;
    // Progress is reported between solves, outside the timed section.
    planner::progress::begin(rec.inputs.len() as u64, "replay");
    let mut sent = SentPlans::default();
    let mut last_failed = false;
    for input in &rec.inputs {
        let (spec, recorded_settings, recorded_start) = problem_from(input)?;
        let ds = spec.ds();
        let start = opts.guess.map_or(recorded_start, RecordedStart::Guess);
        let settings = opts.budgets.apply(recorded_settings);
        if spec.n_intervals != N {
            return Err(ReplayError::Horizon {
                seq: input.seq,
                n: spec.n_intervals,
            });
        }
        let mut planner =
            Planner::<N>::new(spec, settings).map_err(|source| ReplayError::Plan {
                seq: input.seq,
                source,
            })?;
        // The recorded warm start is looked up (and re-shifted) before the timed solve.
        let mut prepared = prepare(rec, input.seq, start)?;
        let mut same_start = start == recorded_start;
        if let (Some(k), Prepared::Warm(_, warm, _, _)) = (opts.warm_max_iter, &mut prepared) {
            same_start &= warm.max_iter == k;
            warm.max_iter = k;
        }
        if let (Some(k), Prepared::Warm(_, warm, _, _)) =
            (opts.warm_max_iter_after_failure, &mut prepared)
        {
            if let Some(capped) = warm.capped_after_failure(k).filter(|_| last_failed) {
                same_start = false;
                *warm = capped;
            }
        }
        if opts.reshift {
            if let Prepared::Warm(w, _, _, guess) = &mut prepared {
                *guess = reshifted(rec, input, w, ds);
                same_start &= guess.as_ref().is_none_or(|g| g.matches(w));
            }
        }
        // Where the logged plan starts, taken before the solve consumes its start.
        let log_from = (opts.log_plan == Some(input.seq)).then(|| prepared.log_start());
        let t0 = Instant::now();
        let info = solve(&mut planner, input.seq, &prepared)?;
        let latency_ms = t0.elapsed().as_secs_f64() * 1e3;
        last_failed = !info.status.is_success();
        let replayed = plan_output(input.seq, 0, &info, planner.states(), planner.controls());
        // A solve stopped by other caps than the recorded ones, or by a clock, is compared
        // with nothing.
        let output = outputs.get(&input.seq);
        let clock_limited = stopped_by_clock(&info, &settings)
            || output.is_some_and(|r| recorded_stopped_by_clock(r, &recorded_settings));
        let recorded = output
            .filter(|r| comparable((&info, &settings), (r, &recorded_settings)))
            .filter(|_| same_start && !clock_limited);
        let difference = recorded.and_then(|r| first_difference(r, &replayed));
        results.push(PlanResult {
            seq: input.seq,
            scenario: input.scenario.clone(),
            latency_ms,
            recorded_ms: recorded.map(|r| r.time_total_s * 1e3),
            status: replayed.status.clone(),
            iterations: replayed.iterations,
            phases_ms: [
                info.times.evaluation * 1e3,
                info.times.factorization * 1e3,
                info.times.solve * 1e3,
                info.times.line_search * 1e3,
            ],
            identical: recorded.map(|_| difference.is_none()),
            clock_limited,
            difference,
            missed: latency_ms > opts.budget_ms,
            max_violation: info.max_violation,
            hit_budget: hit_cap(&info, &settings),
            sent: sent.decide(&info, input.stamp_ns, planner.states()),
        });
        if let Some(from) = log_from {
            plan_log = Some(plan_log::capture(&mut planner, input.seq, from));
        }
        planner::progress::advance(&format!("plan {}", input.seq));
    }
    planner::progress::end();
    Ok((results, plan_log))
}

/// Where a replayed solve starts: a guess, or a recorded warm start with its options and
/// multipliers (and, re-shifted, its own primal guess).
enum Prepared<'a> {
    Guess(GuessKind),
    Warm(
        &'a PlanWarmStart,
        WarmOptions,
        WarmDuals<'a>,
        Option<ShiftedGuess>,
    ),
}

/// A primal guess re-derived by this build's shift.
struct ShiftedGuess {
    states: Vec<[f64; NX]>,
    controls: Vec<[f64; NU]>,
}

impl ShiftedGuess {
    /// Whether this guess is the recorded one, bit for bit.
    fn matches(&self, w: &PlanWarmStart) -> bool {
        let bits = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        bits(self.states.as_flattened(), w.states.as_flattened())
            && bits(self.controls.as_flattened(), w.controls.as_flattened())
    }
}

/// The warm start of `input` re-derived from the plan it shifts: the latest recorded output
/// before it that ended `optimal` or `acceptable` (the planner's warm source), shifted by
/// the recorded `shift_m` to the input's initial state with this build's [`shift_plan`].
/// `None` when no such output was recorded (the warm start then came from a failed solve).
fn reshifted(
    rec: &Recording,
    input: &plan_record::PlanInput,
    w: &PlanWarmStart,
    ds: f64,
) -> Option<ShiftedGuess> {
    let source = rec
        .outputs
        .iter()
        .filter(|o| o.seq < input.seq && matches!(o.status.as_str(), "optimal" | "acceptable"))
        .max_by_key(|o| o.seq)?;
    if source.states.len() != N + 1 || source.controls.len() != N {
        return None;
    }
    let mut g = ShiftedGuess {
        states: vec![[0.0; NX]; N + 1],
        controls: vec![[0.0; NU]; N],
    };
    shift_plan(
        &source.states,
        &source.controls,
        ds,
        w.shift_m,
        &input.x0,
        &mut g.states,
        &mut g.controls,
    );
    Some(g)
}

impl<'a> Prepared<'a> {
    /// The start as the plan log reads it: the warm start's primal guess, or the guess.
    fn log_start(&'a self) -> plan_log::Start<'a> {
        match self {
            Prepared::Guess(kind) => plan_log::Start::Cold(*kind),
            Prepared::Warm(_, _, _, Some(g)) => plan_log::Start::Warm(&g.states, &g.controls),
            Prepared::Warm(w, ..) => plan_log::Start::Warm(&w.states, &w.controls),
        }
    }
}

/// The start of input `seq`: `start` itself, or its warm start found in the recording.
fn prepare(rec: &Recording, seq: u64, start: RecordedStart) -> Result<Prepared<'_>, ReplayError> {
    match start {
        RecordedStart::Guess(guess) => Ok(Prepared::Guess(guess)),
        RecordedStart::Warm => {
            let w = rec
                .warm_start(seq)
                .ok_or(ReplayError::MissingWarmStart { seq })?;
            let (opts, duals) = warm_from(w)?;
            Ok(Prepared::Warm(w, opts, duals, None))
        }
    }
}

/// Solves input `seq` from its prepared start.
fn solve(
    planner: &mut Planner<N>,
    seq: u64,
    start: &Prepared<'_>,
) -> Result<planner::ip::SolveInfo, ReplayError> {
    match start {
        Prepared::Guess(guess) => Ok(planner.solve(*guess)),
        Prepared::Warm(w, opts, duals, guess) => {
            let primal = guess
                .as_ref()
                .map_or((&w.states[..], &w.controls[..]), |g| {
                    (&g.states[..], &g.controls[..])
                });
            planner
                .solve_warm_from(primal, *duals, *opts)
                .map(|r| r.info)
                .map_err(|source| ReplayError::Plan { seq, source })
        }
    }
}

fn to_ns(ms: f64) -> u64 {
    (ms * 1e6).round().max(1.0) as u64
}

fn report(
    per_plan: Vec<PlanResult>,
    pinned_core: Option<usize>,
    budget_ms: f64,
) -> Result<RunReport, ReplayError> {
    let lat: Vec<u64> = per_plan.iter().map(|p| to_ns(p.latency_ms)).collect();
    let recorded: Vec<u64> = per_plan
        .iter()
        .filter_map(|p| p.recorded_ms.map(to_ns))
        .collect();
    let mut its: Vec<u32> = per_plan.iter().map(|p| p.iterations).collect();
    its.sort_unstable();
    let mut statuses: Vec<(String, usize)> = Vec::new();
    for p in &per_plan {
        match statuses.iter_mut().find(|(s, _)| *s == p.status) {
            Some((_, c)) => *c += 1,
            None => statuses.push((p.status.clone(), 1)),
        }
    }
    let n = per_plan.len().max(1) as f64;
    let names = ["evaluation", "factorization", "solve", "line_search"];
    let total: f64 = per_plan.iter().flat_map(|p| p.phases_ms).sum();
    let phases = names
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let sum: f64 = per_plan.iter().map(|p| p.phases_ms[i]).sum();
            Phase {
                name,
                mean_ms: sum / n,
                max_ms: per_plan.iter().map(|p| p.phases_ms[i]).fold(0.0, f64::max),
                share: if total > 0.0 { sum / total } else { 0.0 },
            }
        })
        .collect();
    let identical = per_plan
        .iter()
        .filter(|p| p.identical == Some(true))
        .count();
    let different = per_plan
        .iter()
        .filter(|p| p.identical == Some(false))
        .count();
    let clock_limited = per_plan.iter().filter(|p| p.clock_limited).count();
    let unverified = per_plan
        .iter()
        .filter(|p| p.identical.is_none() && !p.clock_limited)
        .count();
    Ok(RunReport {
        plans: per_plan.len(),
        pinned_core,
        budget_ms,
        budget_applied: false,
        max_iter: None,
        hit_budget: per_plan.iter().filter(|p| p.hit_budget).count(),
        sent: SentCounts::of(per_plan.iter().map(|p| &p.sent)),
        sent_kinds: None,
        deadline_misses: per_plan.iter().filter(|p| p.missed).count(),
        identical,
        different,
        unverified,
        clock_limited,
        orphan_outputs: Vec::new(),
        deterministic: different == 0 && unverified == 0,
        latency: latency(&lat)?,
        recorded_latency: if recorded.is_empty() {
            None
        } else {
            Some(latency(&recorded)?)
        },
        iterations: [
            its.first().copied().unwrap_or(0),
            its.get(its.len() / 2).copied().unwrap_or(0),
            its.last().copied().unwrap_or(0),
        ],
        statuses,
        phases,
        per_plan,
        recovered: None,
        plan_log: None,
    })
}

impl std::fmt::Display for RunReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let l = &self.latency;
        writeln!(
            f,
            "replayed {} plans on core {}",
            self.plans,
            self.pinned_core
                .map_or("(not pinned)".to_string(), |c| c.to_string())
        )?;
        writeln!(
            f,
            "determinism: {} bit-identical, {} different, {} without a recorded output, {} stopped by the clock -> {}",
            self.identical,
            self.different,
            self.unverified,
            self.clock_limited,
            if self.deterministic {
                "DETERMINISTIC"
            } else {
                "NOT VERIFIED"
            }
        )?;
        write!(f, "{}", orphan_line(&self.orphan_outputs))?;
        writeln!(
            f,
            "latency [ms]: p50 {:.2}  p90 {:.2}  p99 {:.2}  p99.9 {:.2}  max {:.2}  (min {:.2}, mean {:.2})",
            l.p50_ms, l.p90_ms, l.p99_ms, l.p999_ms, l.max_ms, l.min_ms, l.mean_ms
        )?;
        writeln!(
            f,
            "jitter [ms]: max - p50 {:.2}, std dev {:.2}",
            l.jitter_ms, l.stdev_ms
        )?;
        if let Some(r) = &self.recorded_latency {
            writeln!(
                f,
                "as recorded [ms]: p50 {:.2}  p99 {:.2}  max {:.2}",
                r.p50_ms, r.p99_ms, r.max_ms
            )?;
        }
        writeln!(
            f,
            "deadline misses: {} of {} over {:.1} ms",
            self.deadline_misses, self.plans, self.budget_ms
        )?;
        let budget = match (self.budget_applied, self.max_iter) {
            (true, Some(k)) => format!("budget {:.1} ms and {k} iterations", self.budget_ms),
            (true, None) => format!("budget {:.1} ms", self.budget_ms),
            (false, Some(k)) => format!("budget {k} iterations"),
            (false, None) => "recorded caps".to_string(),
        };
        let c = &self.sent;
        writeln!(
            f,
            "{budget}: {} of {} solves hit it; the car would have been sent {} converged, {} best iterates, {} previous plans shifted, nothing {} times",
            self.hit_budget,
            self.plans,
            c.sent_converged,
            c.sent_best_iterate,
            c.sent_previous_shifted,
            c.sent_nothing
        )?;
        let st: Vec<String> = self
            .statuses
            .iter()
            .map(|(s, c)| format!("{s} {c}"))
            .collect();
        writeln!(
            f,
            "iterations: min {} median {} max {}; status: {}",
            self.iterations[0],
            self.iterations[1],
            self.iterations[2],
            st.join(", ")
        )?;
        write!(f, "time per phase [ms, mean / max / share]:")?;
        for p in &self.phases {
            write!(
                f,
                " {} {:.2}/{:.2}/{:.0}%",
                p.name,
                p.mean_ms,
                p.max_ms,
                p.share * 100.0
            )?;
        }
        writeln!(f)?;
        for p in self
            .per_plan
            .iter()
            .filter(|p| p.identical == Some(false))
            .take(5)
        {
            writeln!(
                f,
                "  plan {} differs: {}",
                p.seq,
                p.difference.as_deref().unwrap_or("?")
            )?;
        }
        Ok(())
    }
}
