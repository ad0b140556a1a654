//! The planning cycle's time budget, and the worst-case cycle time it allows on this
//! machine, measured at start-up.
//!
//! The budget B of a cycle's solve is `--budget-ms`, else `--max-solve-s` (its hidden
//! alias in seconds), else 80 % of the period 1 / rate: the remaining 20 % cover the
//! overshoot below and the cycle's own work (road window, publish). Until the first plan
//! is sent the solves get `--first-budget-ms` (at least B): the tracker does not start the
//! drive before a first plan arrives, so no deadline binds it.
//!
//! A solve stops within its budget B plus at most one step between two budget checks
//! (one factorization with its direction solves, or one trial evaluation with the next
//! point's derivatives) and the final evaluation of the best iterate
//! (`planner::ip::solver`'s clock). The overshoot is estimated from short solves of the
//! first window (the road at s = 0, a straight-line cruise): per factorization, the mean
//! factorization and direction-solve time; per evaluation, the mean time of one
//! evaluation round (constraints and objective with their derivatives, which
//! overestimates a trial). The worst case is B + t_factorization + t_solves + 2
//! t_evaluation, the median of three solves (the first pays one-time costs).

use planner::ip::Settings;
use planner::model::ix;
use planner::plan::{Planner, ReplanGuess};

use super::{PlannerArgs, PlannerProcError, MARGIN_RAMP_M};
use crate::msg::HORIZON_N;
use crate::plant::Plant;
use crate::road::{RoadWindow, Scenario};

/// Share of the period a cycle's solve may take by default.
pub const DEFAULT_BUDGET_SHARE: f64 = 0.8;

/// The budgets of a cycle's solve \[ms\]: (steady, until the first plan is sent).
pub fn budgets_ms(args: &PlannerArgs) -> Result<(f64, f64), PlannerProcError> {
    let budget = match (args.budget_ms, args.max_solve_s) {
        (Some(_), Some(_)) => {
            return Err(PlannerProcError::Setup(
                "--max-solve-s is an alias of --budget-ms: give one of them".into(),
            ))
        }
        (Some(ms), None) => ms,
        (None, Some(s)) => s * 1e3,
        (None, None) => DEFAULT_BUDGET_SHARE * 1e3 / args.rate_hz,
    };
    let ok = |ms: f64| ms > 0.0 && ms <= 3.6e6;
    if !ok(budget) {
        return Err(PlannerProcError::Setup(format!(
            "--budget-ms = {budget}: must lie in (0, 3600000]"
        )));
    }
    if !ok(args.first_budget_ms) {
        return Err(PlannerProcError::Setup(format!(
            "--first-budget-ms = {}: must lie in (0, 3600000]",
            args.first_budget_ms
        )));
    }
    Ok((budget, args.first_budget_ms.max(budget)))
}

/// Iterations of each measuring solve.
const MEASURE_ITERS: usize = 3;
/// Measuring solves (the largest overshoot counts).
const MEASURE_SOLVES: usize = 3;

/// The measured overshoot of a solve past its budget.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Overshoot {
    /// One factorization \[ms\].
    pub factorization_ms: f64,
    /// The direction solves of one factorization \[ms\].
    pub solves_ms: f64,
    /// One evaluation round \[ms\].
    pub evaluation_ms: f64,
}

impl Overshoot {
    /// The overshoot bound: one factorization with its solves and two evaluations \[ms\].
    pub fn total_ms(&self) -> f64 {
        self.factorization_ms + self.solves_ms + 2.0 * self.evaluation_ms
    }
}

/// Measures the overshoot with `settings` (capped at three iterations) on the
/// first window, the car cruising at `v0` (allocates: a planner of its own).
pub fn measure(
    sc: &Scenario,
    settings: Settings,
    margin: f64,
    v0: f64,
) -> Result<Overshoot, String> {
    let settings = Settings {
        max_iter: MEASURE_ITERS,
        max_time_s: 10.0,
        ..settings
    };
    let mut planner =
        Planner::<HORIZON_N>::new(sc.spec.clone(), settings).map_err(|e| e.to_string())?;
    let mut road = RoadWindow::default();
    sc.road
        .window(0.0, sc.ds(), margin, MARGIN_RAMP_M, &mut road);
    let v = v0.clamp(sc.spec.v_min + 1.0, sc.spec.v_max - 1.0);
    let mut x0 = Plant::cruise(sc.spec.vehicle, v).x;
    x0[ix::S] = 0.0;
    x0[ix::T] = 0.0;
    let mut measured = [Overshoot {
        factorization_ms: 0.0,
        solves_ms: 0.0,
        evaluation_ms: 0.0,
    }; MEASURE_SOLVES];
    for slot in measured.iter_mut() {
        let info = planner
            .replan(
                &road.kappa,
                &road.e_min,
                &road.e_max,
                x0,
                ReplanGuess::Equilibrium,
            )
            .map_err(|e| e.to_string())?;
        let f = info.factorizations.max(1) as f64;
        let e = info.evaluations.max(1) as f64;
        let o = Overshoot {
            factorization_ms: info.times.factorization / f * 1e3,
            solves_ms: info.times.solve / f * 1e3,
            evaluation_ms: info.times.evaluation / e * 1e3,
        };
        *slot = o;
    }
    // The median: the first solve pays one-time costs (page faults, the helper thread).
    measured.sort_by(|a, b| a.total_ms().total_cmp(&b.total_ms()));
    Ok(measured[MEASURE_SOLVES / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_overshoot_of_the_first_window_is_measured_and_positive() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let sc = Scenario::load(
            &root.join("config/scenarios/oval.toml"),
            &root.join("config/vehicles/lc500.toml"),
            &root.join("config/solver.toml"),
        )
        .expect("oval scenario");
        let o = measure(&sc, sc.settings, 0.5, 15.0).expect("measured");
        assert!(o.factorization_ms > 0.0, "{o:?}");
        assert!(o.evaluation_ms > 0.0, "{o:?}");
        assert!(o.total_ms().is_finite(), "{o:?}");
    }
}
