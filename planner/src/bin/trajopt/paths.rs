//! Paths of the input files: command-line paths resolved against the working directory or
//! the repository, and the solver file that fits an objective.

use std::path::{Path, PathBuf};

pub use planner::config::paths::resolve_path as resolve;

/// The solver file given, or the shipped one tuned for the objective's steering-slew weight
/// ([`planner::config::shipped_solver_file`]), resolved.
pub fn solver_file(given: &Option<PathBuf>, steering_slew_weight: f64) -> PathBuf {
    match given {
        Some(p) => resolve(p),
        None => resolve(
            &Path::new("config").join(planner::config::shipped_solver_file(steering_slew_weight)),
        ),
    }
}
