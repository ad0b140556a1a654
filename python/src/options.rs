//! The options of a solve, spelled and checked as `trajopt solve` spells and checks them:
//! the guess, barrier and KKT choices, the steering-slew weight, the thread count and the
//! wall-clock budget; and the settings they give with the solver file.

use std::path::{Path, PathBuf};

use planner::config::paths::resolve_path;
use planner::config::{load_solver, shipped_solver_file};
use planner::guess::GuessKind;
use planner::ip::kkt::KktBackendKind;
use planner::ip::{BarrierRule, Settings};

use crate::err;
use pyo3::PyResult;

/// The vehicle file of `trajopt solve`.
pub const VEHICLE: &str = "config/vehicles/lc500.toml";
/// The segments file whose `[defaults]` a track stretch takes.
pub const SEGMENTS: &str = "config/scenarios/segments.toml";

/// `guess`: `equilibrium`, `zero` or `road_speed`.
pub fn guess(v: &str) -> PyResult<GuessKind> {
    GuessKind::parse(v).ok_or_else(|| {
        err(format!(
            "guess: `{v}` is not one of `equilibrium`, `zero`, `road_speed`"
        ))
    })
}

/// `barrier`: one of the solver's barrier rules.
fn barrier(v: &str) -> PyResult<BarrierRule> {
    BarrierRule::parse(v).ok_or_else(|| {
        let names: Vec<String> = BarrierRule::ALL
            .iter()
            .map(|b| format!("`{}`", b.name()))
            .collect();
        err(format!("barrier: `{v}` is not one of {}", names.join(", ")))
    })
}

/// `kkt`: `sparse`, `riccati` or `auto`.
fn kkt(v: &str) -> PyResult<KktBackendKind> {
    KktBackendKind::parse(v).ok_or_else(|| {
        err(format!(
            "kkt: `{v}` is not one of `sparse`, `riccati`, `auto`"
        ))
    })
}

/// `steering_slew_weight`: a number in \[0, MAX_STEERING_SLEW_WEIGHT\] 1/s.
pub fn slew_weight(w: f64) -> PyResult<f64> {
    let max = planner::ocp::MAX_STEERING_SLEW_WEIGHT;
    if (0.0..=max).contains(&w) {
        Ok(w)
    } else {
        Err(err(format!(
            "steering_slew_weight: `{w}` is not a weight in [0, {max}] 1/s"
        )))
    }
}

/// `budget_ms`: a wall-clock budget in (0, 1000 MAX_TIME_S\] milliseconds.
fn budget_ms(ms: f64) -> PyResult<f64> {
    let max = 1e3 * planner::ip::settings::MAX_TIME_S;
    if ms > 0.0 && ms <= max {
        Ok(ms)
    } else {
        Err(err(format!(
            "budget_ms: `{ms}` is not a budget in (0, {max}] ms"
        )))
    }
}

/// The solver overrides of one solve (`None` keeps the solver file's value).
#[derive(Debug, Default)]
pub struct SolverOptions<'a> {
    /// Iteration cap (at least 1).
    pub max_iter: Option<i64>,
    /// Wall-clock budget \[ms\].
    pub budget_ms: Option<f64>,
    /// Barrier rule name.
    pub barrier: Option<&'a str>,
    /// KKT backend name.
    pub kkt: Option<&'a str>,
    /// Threads of a solve (1 or 2).
    pub threads: Option<usize>,
}

/// The solver file given, or the shipped one for the objective's steering-slew weight,
/// resolved as the command line resolves it.
pub fn solver_file(given: Option<&Path>, steering_slew_weight: f64) -> PathBuf {
    match given {
        Some(p) => resolve_path(p),
        None => resolve_path(&Path::new("config").join(shipped_solver_file(steering_slew_weight))),
    }
}

/// The settings of `path` with the overrides applied (checked when the solver is built).
pub fn settings(path: &Path, o: &SolverOptions<'_>) -> PyResult<Settings> {
    let mut s = load_solver(path).map_err(err)?;
    if let Some(k) = o.kkt {
        s.kkt = kkt(k)?;
    }
    if let Some(b) = o.barrier {
        s.barrier = barrier(b)?;
    }
    if let Some(t) = o.threads {
        if !(1..=2).contains(&t) {
            return Err(err(format!("threads: `{t}` is not 1 or 2")));
        }
        s.threads = t;
    }
    if let Some(ms) = o.budget_ms {
        s.max_time_s = 1e-3 * budget_ms(ms)?;
    }
    if let Some(n) = o.max_iter {
        s.max_iter = usize::try_from(n)
            .ok()
            .filter(|&n| n >= 1)
            .ok_or_else(|| err(format!("max_iter: `{n}` is not an iteration count >= 1")))?;
    }
    Ok(s)
}
