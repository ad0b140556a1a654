//! The barrier study (paper Sec. VI-C, Table IV): one scenario (the oval) solved from the
//! equilibrium guess with each of the six barrier rules of [`BarrierRule::ALL`].

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::StudyError;
use crate::config::load_scenario_for_horizon;
use crate::guess::GuessKind;
use crate::ip::{BarrierRule, Settings};
use crate::model::VehicleParams;
use crate::plan::Planner;
use crate::stats::median;
use crate::HORIZON;

/// One rule's result.
#[derive(Debug, Clone, Serialize)]
pub struct BarrierRun {
    /// Rule name (`--barrier`).
    pub barrier: &'static str,
    /// Final status.
    pub status: &'static str,
    /// Iterations.
    pub iterations: usize,
    /// Median solve time over the repeats \[ms\].
    pub median_ms: f64,
    /// t_N of the returned iterate \[s\].
    pub t_final: f64,
    /// Max constraint violation of the returned iterate.
    pub max_violation: f64,
    /// Largest number of factorizations in one iteration.
    pub max_factorizations_per_iter: usize,
    /// Iterations that took the convexified fallback step.
    pub fallback_steps: usize,
}

/// Solves `scenario` (optionally one `select`ed entry) with every rule, `repeat` times each,
/// with `steering_slew_weight` in place of the scenario's.
pub fn run(
    scenario: &Path,
    select: Option<&str>,
    vehicle: &VehicleParams,
    settings: Settings,
    repeat: usize,
    steering_slew_weight: f64,
) -> Result<Vec<BarrierRun>, StudyError> {
    if repeat == 0 {
        return Err(StudyError::Repeat);
    }
    let mut spec = load_scenario_for_horizon(scenario, select, *vehicle, crate::HORIZON)?;
    spec.steering_slew_weight = steering_slew_weight;
    let mut planner = Planner::<HORIZON>::new(spec, settings)?;
    let mut out = Vec::with_capacity(BarrierRule::ALL.len());
    crate::progress::begin(BarrierRule::ALL.len() as u64, "study barrier");
    for rule in BarrierRule::ALL {
        let mut s = settings;
        s.barrier = rule;
        planner
            .solver_mut()
            .set_settings(s)
            .map_err(|e| StudyError::Plan(crate::plan::PlanError::Setup(e.into())))?;
        let mut ms = Vec::with_capacity(repeat);
        let mut last = None;
        for _ in 0..repeat {
            let info = planner.solve(GuessKind::Equilibrium);
            ms.push(info.times.total * 1e3);
            last = Some(info);
        }
        let Some(info) = last else {
            return Err(StudyError::Repeat);
        };
        out.push(BarrierRun {
            barrier: rule.name(),
            status: info.status.name(),
            iterations: info.iterations,
            median_ms: median(&mut ms),
            t_final: planner.trajectory().t_final(),
            max_violation: info.max_violation,
            max_factorizations_per_iter: info.max_factorizations_per_iter,
            fallback_steps: info.fallback_steps,
        });
        crate::progress::advance(rule.name());
    }
    crate::progress::end();
    Ok(out)
}

/// Table IV: one row per rule, on the objective with `steering_slew_weight`.
pub fn table(runs: &[BarrierRun], repeat: usize, cap: usize, steering_slew_weight: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Table IV: barrier rules (median of {repeat}, cap {cap} factorizations/iteration, {})",
        crate::ocp::objective::label(steering_slew_weight)
    );
    let _ = writeln!(
        s,
        "{:<9} {:<18} {:>5} {:>9} {:>9} {:>6} {:>6}",
        "rule", "status", "iter", "ms", "t_N [s]", "max nf", "fallbk"
    );
    for r in runs {
        let _ = writeln!(
            s,
            "{:<9} {:<18} {:>5} {:>9.2} {:>9.4} {:>6} {:>6}",
            r.barrier,
            r.status,
            r.iterations,
            r.median_ms,
            r.t_final,
            r.max_factorizations_per_iter,
            r.fallback_steps
        );
    }
    s
}
