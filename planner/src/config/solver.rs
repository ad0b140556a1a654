//! Solver settings file (`config/solver.toml`): every key optional, unknown keys rejected,
//! values validated by [`crate::ip::Settings::validate`].

use std::path::Path;

use super::ConfigError;
use crate::ip::Settings;

/// The shipped solver file (in the data root, `config/`) for the planner's objective (minimum
/// time plus a steering-slew term).
pub const SOLVER_FILE: &str = "solver.toml";
/// The shipped solver file for the paper's pure minimum time (eq. 3, steering-slew weight 0).
/// It differs from [`SOLVER_FILE`] only in `barrier_tol_factor` (IPOPT's 10 there, 30 in the
/// planner's file): each value is the better one on its own objective (README, Solver
/// settings per objective).
pub const SOLVER_FILE_MIN_TIME: &str = "solver_min_time.toml";

/// The shipped solver file (in `config/`) tuned for an objective with this steering-slew
/// weight:
/// [`SOLVER_FILE_MIN_TIME`] for 0 (the paper's pure minimum time), else [`SOLVER_FILE`].
pub fn shipped_solver_file(steering_slew_weight: f64) -> &'static str {
    if steering_slew_weight == 0.0 {
        SOLVER_FILE_MIN_TIME
    } else {
        SOLVER_FILE
    }
}

/// Reads solver settings; missing keys keep their defaults.
pub fn load_solver(path: &Path) -> Result<Settings, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    let settings: Settings = toml::from_str(&text).map_err(|e| ConfigError::Toml {
        file: path.to_path_buf(),
        message: e.to_string(),
    })?;
    settings.validate().map_err(|e| ConfigError::Invalid {
        file: path.to_path_buf(),
        field: e.field.to_string(),
        value: e.value,
        expected: e.expected.to_string(),
    })?;
    Ok(settings)
}
