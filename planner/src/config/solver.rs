//! Solver settings file (`config/solver.toml`): every key optional, unknown keys rejected,
//! values validated by [`crate::ip::Settings::validate`].

use std::path::Path;

use super::ConfigError;
use crate::ip::Settings;

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
