//! The anatomy of one replayed solve (`replay run --log-plan SEQ`): its iteration log and
//! the constraint rows violated most where it starts and where it ends, by name. A plan
//! that takes many iterations or stops at a budget shows here where its start was
//! infeasible (a defect at the end of a shifted horizon, a tire's saturation at the
//! first node) and which steps stalled (short steps, rejected trials, restoration).

use planner::ip::IterLog;
use planner::model::{NU, NX};
use planner::plan::Planner;
use serde::Serialize;

/// Rows listed at each end of the solve.
const WORST_ROWS: usize = 10;

/// A constraint row and its violation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WorstRow {
    /// The row's name, e.g. `defect[V_wr]@44`.
    pub row: String,
    /// How far it lies outside its bounds.
    pub violation: f64,
}

/// One replayed solve, iteration by iteration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanLog {
    /// Input seq.
    pub seq: u64,
    /// The solver's log of the solve (the fall-back's after a stalled warm start).
    pub iterations: Vec<IterLog>,
    /// The rows violated most by the guess the solve started from.
    pub worst_at_start: Vec<WorstRow>,
    /// The rows violated most by the point it returned.
    pub worst_at_end: Vec<WorstRow>,
}

/// Where a solve started: the primal guess of a warm start, or a cold guess already
/// written into the planner.
pub enum Start<'a> {
    /// A warm start's states and controls.
    Warm(&'a [[f64; NX]], &'a [[f64; NU]]),
    /// A cold guess, written by [`Planner::set_guess`].
    Cold(planner::guess::GuessKind),
}

/// The log of the solve `planner` has just made for input `seq` from `start`. Call it
/// after everything else has read the solution: it writes the start's guess into the
/// planner.
pub fn capture<const N: usize>(planner: &mut Planner<N>, seq: u64, start: Start<'_>) -> PlanLog {
    let iterations = planner.solver().log().to_vec();
    let x_end = planner.solver().x().to_vec();
    let worst_at_end = named(planner.worst_rows(&x_end, WORST_ROWS));
    match start {
        Start::Warm(xs, us) => planner.nlp().set_initial_guess(xs, us),
        Start::Cold(kind) => planner.set_guess(kind),
    }
    let x_start = planner.guess_point();
    let worst_at_start = named(planner.worst_rows(&x_start, WORST_ROWS));
    PlanLog {
        seq,
        iterations,
        worst_at_start,
        worst_at_end,
    }
}

fn named(rows: Vec<(String, f64)>) -> Vec<WorstRow> {
    rows.into_iter()
        .map(|(row, violation)| WorstRow { row, violation })
        .collect()
}

impl std::fmt::Display for PlanLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "plan {}: {} iterations", self.seq, self.iterations.len())?;
        writeln!(f, "{}", IterLog::HEADER)?;
        for l in &self.iterations {
            writeln!(f, "{}", l.row())?;
        }
        for (label, rows) in [
            ("at its start", &self.worst_at_start),
            ("at its end", &self.worst_at_end),
        ] {
            if rows.is_empty() {
                writeln!(f, "no row violated {label}")?;
                continue;
            }
            writeln!(f, "rows violated most {label}:")?;
            for r in rows {
                writeln!(f, "  {:<28} {:.3e}", r.row, r.violation)?;
            }
        }
        Ok(())
    }
}
