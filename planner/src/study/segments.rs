//! The segment study (paper Sec. VI-B, Table II, Fig. 5): every segment of a
//! multi-segment scenario file solved from the equilibrium guess (eq. 8) and from the zero
//! guess, with status, iterations, median solve time, t_N next to the shipped reference
//! (`<data root>/reference/segments_ie_ipopt.csv`, CasADi + IPOPT) and the largest number
//! of KKT factorizations in one iteration (bounded by `Settings::max_refactorizations`).

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::{optimality_error, StudyError};
use crate::config::{data_root_of, list_selections, load_scenario_for_horizon};
use crate::guess::GuessKind;
use crate::ip::{Settings, StepKind};
use crate::model::VehicleParams;
use crate::plan::Planner;
use crate::stats::median;
use crate::trajectory::Trajectory;
use crate::HORIZON;

/// Reference table, relative to the data root (shipped with the product).
pub const REFERENCE_CSV: &str = "reference/segments_ie_ipopt.csv";

/// One segment solved from one guess.
#[derive(Debug, Clone, Serialize)]
pub struct SegmentRun {
    /// Segment name (S01...).
    pub segment: String,
    /// `equilibrium` or `zero`.
    pub guess: &'static str,
    /// Final solver status.
    pub status: &'static str,
    /// Iterations of the (deterministic) solve.
    pub iterations: usize,
    /// Median wall-clock solve time over the repeats \[ms\].
    pub median_ms: f64,
    /// Final time t_N of the returned iterate \[s\].
    pub t_final: f64,
    /// t_N of the reference solution \[s\], when the reference table lists the segment.
    pub reference_t_final: Option<f64>,
    /// (t_final - reference) / reference, when known.
    pub rel_error: Option<f64>,
    /// Iterations the reference (IPOPT) needed, when known.
    pub reference_iterations: Option<usize>,
    /// Max constraint violation of the returned iterate.
    pub max_violation: f64,
    /// Max constraint violation of the starting point.
    pub initial_violation: f64,
    /// Largest number of factorizations in one iteration.
    pub max_factorizations_per_iter: usize,
    /// Iterations that took the convexified fallback step.
    pub fallback_steps: usize,
    /// Iterations spent in feasibility restoration.
    pub restoration_steps: usize,
    /// Optimality error per iteration (Fig. 5).
    pub history: Vec<f64>,
    /// The returned trajectory (for the path figure; not serialized).
    #[serde(skip)]
    pub trajectory: Option<Trajectory>,
}

/// All runs of the study.
#[derive(Debug, Clone, Serialize)]
pub struct SegmentsStudy {
    /// The cap on factorizations per iteration the runs used.
    pub max_refactorizations: usize,
    /// Repeats per run (median taken).
    pub repeat: usize,
    /// Barrier rule.
    pub barrier: &'static str,
    /// Weight of the objective's steering-slew term [1/s] (0: the paper's pure minimum time).
    pub steering_slew_weight: f64,
    /// Runs, segment by segment: equilibrium then zero.
    pub runs: Vec<SegmentRun>,
}

/// Reference rows `segment -> (t_N, iterations)` of `segments_ie_ipopt.csv`
/// (columns `segment,t_N,iterations,status`).
pub fn load_reference(path: &Path) -> Result<Vec<(String, f64, usize)>, StudyError> {
    let text = std::fs::read_to_string(path).map_err(|e| StudyError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let cols: Vec<&str> = line.split(',').collect();
        let bad = |what: &str| StudyError::File {
            path: path.display().to_string(),
            message: format!("line {}: {what}", i + 1),
        };
        if cols.len() < 3 {
            return Err(bad("expected segment,t_N,iterations,..."));
        }
        let t: f64 = cols[1]
            .trim()
            .parse()
            .map_err(|_| bad("t_N is not a number"))?;
        let it: usize = cols[2]
            .trim()
            .parse()
            .map_err(|_| bad("iterations is not an integer"))?;
        out.push((cols[0].trim().to_string(), t, it));
    }
    Ok(out)
}

/// Runs the study on every segment of `scenario` with the given vehicle and settings;
/// `repeat` solves per run (median time); every segment is solved with
/// `steering_slew_weight` in place of the scenario's (0: the paper's pure minimum time).
/// The reference table is optional: without it the reference columns are empty.
pub fn run(
    scenario: &Path,
    vehicle: &VehicleParams,
    settings: Settings,
    repeat: usize,
    steering_slew_weight: f64,
) -> Result<SegmentsStudy, StudyError> {
    if repeat == 0 {
        return Err(StudyError::Repeat);
    }
    let names = list_selections(scenario)?;
    let reference = load_reference(&data_root_of(scenario).join(REFERENCE_CSV)).ok();
    let mut runs = Vec::with_capacity(2 * names.len());
    crate::progress::begin(2 * names.len() as u64, "study segments");
    for name in &names {
        let mut spec = load_scenario_for_horizon(scenario, Some(name), *vehicle, crate::HORIZON)?;
        spec.steering_slew_weight = steering_slew_weight;
        let mut planner = Planner::<HORIZON>::new(spec, settings)?;
        let refrow = reference
            .as_ref()
            .and_then(|r| r.iter().find(|(n, _, _)| n == name));
        for (kind, label) in [
            (GuessKind::Equilibrium, "equilibrium"),
            (GuessKind::Zero, "zero"),
        ] {
            let mut ms = Vec::with_capacity(repeat);
            let mut last = None;
            for _ in 0..repeat {
                let info = planner.solve(kind);
                ms.push(info.times.total * 1e3);
                last = Some(info);
            }
            let Some(info) = last else {
                return Err(StudyError::Repeat);
            };
            crate::progress::advance(&format!("{name} {label}"));
            let traj = planner.trajectory();
            let t_final = traj.t_final();
            let log = planner.solver().log();
            runs.push(SegmentRun {
                segment: name.clone(),
                guess: label,
                status: info.status.name(),
                iterations: info.iterations,
                median_ms: median(&mut ms),
                t_final,
                reference_t_final: refrow.map(|r| r.1),
                rel_error: refrow.map(|r| (t_final - r.1) / r.1),
                reference_iterations: refrow.map(|r| r.2),
                max_violation: info.max_violation,
                initial_violation: info.initial_violation,
                max_factorizations_per_iter: info.max_factorizations_per_iter,
                fallback_steps: info.fallback_steps,
                restoration_steps: log
                    .iter()
                    .filter(|l| l.step == StepKind::Restoration)
                    .count(),
                history: log.iter().map(optimality_error).collect(),
                trajectory: Some(traj),
            });
        }
    }
    crate::progress::end();
    Ok(SegmentsStudy {
        max_refactorizations: settings.max_refactorizations,
        steering_slew_weight,
        repeat,
        barrier: settings.barrier.name(),
        runs,
    })
}

/// The table of one guess, one row per segment: the two halves of the paper's Table II
/// (robust = equilibrium guess, zero guess).
pub fn table(study: &SegmentsStudy, guess: &str) -> String {
    let mut s = String::new();
    let title = if guess == "equilibrium" {
        "Table II, robust half"
    } else {
        "Table II, zero-guess half"
    };
    let _ = writeln!(
        s,
        "{title}: segments from the {guess} guess (barrier {}, median of {}, cap {} factorizations/iteration, {})",
        study.barrier,
        study.repeat,
        study.max_refactorizations,
        crate::ocp::objective::label(study.steering_slew_weight)
    );
    let _ = writeln!(
        s,
        "{:<4} {:<18} {:>5} {:>9} {:>9} {:>9} {:>8} {:>7} {:>6} {:>6} {:>6}",
        "seg",
        "status",
        "iter",
        "ms",
        "t_N [s]",
        "ref [s]",
        "err %",
        "ref it",
        "max nf",
        "fallbk",
        "resto"
    );
    for r in study.runs.iter().filter(|r| r.guess == guess) {
        let opt = |v: Option<f64>, scale: f64, prec: usize| {
            v.map_or("-".to_string(), |x| format!("{:.prec$}", x * scale))
        };
        let _ = writeln!(
            s,
            "{:<4} {:<18} {:>5} {:>9.2} {:>9.4} {:>9} {:>8} {:>7} {:>6} {:>6} {:>6}",
            r.segment,
            r.status,
            r.iterations,
            r.median_ms,
            r.t_final,
            opt(r.reference_t_final, 1.0, 4),
            opt(r.rel_error, 100.0, 3),
            r.reference_iterations
                .map_or("-".to_string(), |i| i.to_string()),
            r.max_factorizations_per_iter,
            r.fallback_steps,
            r.restoration_steps,
        );
    }
    s
}
